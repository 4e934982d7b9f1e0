"""PROFIdrive encoder telegrams: bytes <-> named signals and bits.

Everything comes from the one table pndiss/data/telegrams.json (layouts, bit maps, error codes,
velocity units, vendor defaults; each entry cites spec/cyclic.md). This module only compiles it:
one precompiled ``struct.Struct`` per (telegram, direction, byte order), and per (signal,
profile) a tuple of (name, shift, mask) for the bits. Bad input raises ``Malformed``.
"""
from __future__ import annotations

import json
import os
import struct
from functools import lru_cache

from .proto.common import Malformed

_PATH = os.path.join(os.path.dirname(__file__), "data", "telegrams.json")
with open(_PATH, encoding="utf-8") as _f:
    TABLE: dict = json.load(_f)

SIGNALS: dict[str, dict] = TABLE["signals"]
TELEGRAMS: dict[int, dict] = {int(k): v for k, v in TABLE["telegrams"].items()}
BITMAPS: dict[str, list] = TABLE["bitmaps"]
PROFILES: tuple[str, ...] = tuple(TABLE["profiles"])
PROFILE_DEFAULTS: dict[str, dict] = {k: v for k, v in TABLE["profile_defaults"].items() if not k.startswith("_")}
XIST2_ERRORS: dict[int, dict] = {e["code"]: e for e in TABLE["xist2_errors"]}
VELOCITY_UNITS: dict[int, dict] = {u["value"]: u for u in TABLE["velocity_units"]}
DIRECTIONS = ("setpoint", "actual")
STANDARD = frozenset(t for t, d in TELEGRAMS.items() if d["standard"])  # 81-84: STW2/G1_STW words
# STD of behaviour.md §9: telegrams carrying STW2_ENC and ZSW2_ENC (81-84 and PS/PSM 89), from the layouts
CONTROL_WORDS = frozenset(t for t, d in TELEGRAMS.items() if "stw2_enc" in {r[0] for r in d["setpoint"]}
                          and "zsw2_enc" in {r[0] for r in d["actual"]})
# telegrams whose preset rides in the setpoint word itself: (signal, trigger bit) of that word (cyclic.md §10)
PRESET_WORD: dict[int, tuple[str, int]] = {
    t: next((name, b["bit"]) for name, _ in d["setpoint"] for b in BITMAPS.get(name, ()) if b["name"] == "trigger")
    for t, d in TELEGRAMS.items()
    if any(b["name"] == "trigger" for name, _ in d["setpoint"] for b in BITMAPS.get(name, ()))}
# a preset by a control/status bit pair (telegram 89): {telegram: {"trigger", "ack", "value"}}
PRESET_HANDSHAKE: dict[int, dict] = {t: d["preset_handshake"] for t, d in TELEGRAMS.items() if "preset_handshake" in d}
# the length guess tries telegrams in this order (cyclic.md §2: standard, then 860, then OEM)
GUESS_ORDER: tuple[int, ...] = tuple(sorted(TELEGRAMS, key=lambda t: (TELEGRAMS[t]["guess_rank"], t)))

_FMT = {(1, False): "B", (2, False): "H", (4, False): "I", (8, False): "Q",
        (1, True): "b", (2, True): "h", (4, True): "i", (8, True): "q"}


class Layout:
    """One direction of one telegram, compiled: ``names`` in offset order, ``struct``, ``length``."""

    __slots__ = ("telegram", "direction", "names", "struct", "length", "byte_order")

    def __init__(self, telegram: int, direction: str, byte_order: str):
        rows = sorted(TELEGRAMS[telegram][direction], key=lambda r: r[1])
        fmt = "<" if byte_order == "little" else ">"
        pos = 0
        for name, off in rows:
            if off != pos:  # the table has no gaps; a gap would be a table error
                raise ValueError(f"telegram {telegram} {direction}: gap before {name}")
            sig = SIGNALS[name]
            fmt += _FMT[(sig["size"], sig["signed"])]
            pos += sig["size"]
        self.telegram = telegram
        self.direction = direction
        self.names = tuple(r[0] for r in rows)
        self.struct = struct.Struct(fmt)
        self.length = pos
        self.byte_order = byte_order

    def decode(self, data: bytes, off: int = 0) -> dict:
        if off < 0 or len(data) - off < self.length:
            raise Malformed("telegram", f"telegram {self.telegram} {self.direction} needs {self.length} bytes, "
                                        f"got {max(0, len(data) - off)}")
        return dict(zip(self.names, self.struct.unpack_from(data, off)))

    def encode(self, signals: dict) -> bytes:
        vals = []
        for n in self.names:
            v = int(signals.get(n, 0))
            sig = SIGNALS[n]
            bits = 8 * sig["size"]
            if sig["signed"]:  # accept both two's complement views
                v = ((v + (1 << (bits - 1))) % (1 << bits)) - (1 << (bits - 1))
            else:
                v &= (1 << bits) - 1
            vals.append(v)
        return self.struct.pack(*vals)


@lru_cache(maxsize=None)
def layout(telegram: int, direction: str, byte_order: str = "big") -> Layout:
    """Compiled layout; KeyError for an unknown telegram, ValueError for a bad direction."""
    if direction not in DIRECTIONS:
        raise ValueError(direction)
    return Layout(telegram, direction, byte_order)


def length(telegram: int, direction: str) -> int:
    return layout(telegram, direction).length


def decode(telegram: int, direction: str, data: bytes, byte_order: str = "big", off: int = 0) -> dict:
    """Signals of one data object; Malformed when too short or the telegram is unknown."""
    if telegram not in TELEGRAMS:
        raise Malformed("telegram", f"unknown telegram {telegram}")
    return layout(telegram, direction, byte_order).decode(data, off)


def encode(telegram: int, direction: str, signals: dict, byte_order: str = "big") -> bytes:
    return layout(telegram, direction, byte_order).encode(signals)


@lru_cache(maxsize=None)
def bit_fields(signal: str, profile: str = "generic") -> tuple:
    """(name, shift, mask) of the named bits of ``signal`` for ``profile`` (vendor variants, §12)."""
    out = []
    for b in BITMAPS.get(signal, ()):
        if "profiles" in b and profile not in b["profiles"]:
            continue
        out.append((b["name"], b["bit"], (1 << b["width"]) - 1))
    return tuple(out)


COUNTERS = ("sign_of_life",)   # bit fields that change every cycle by design: no change for on_change thinning


def _change_masks() -> dict[str, int]:
    out = {}
    for sig, rows in BITMAPS.items():
        counters = 0
        for b in rows:
            if b["name"] in COUNTERS:
                counters |= ((1 << b["width"]) - 1) << b["bit"]
        if counters:
            out[sig] = ((1 << (8 * SIGNALS[sig]["size"])) - 1) & ~counters
    return out


# signal -> the bits of it whose change is a change (MCAP --on-change, the dataset's on_change cycles): the
# sign-of-life counters step every cycle, so with them every sample of a standing shaft would differ
CHANGE_MASKS: dict[str, int] = _change_masks()


@lru_cache(maxsize=None)
def reserved_mask(signal: str, profile: str = "generic") -> int:
    """Bits of a control/status word with no meaning for ``profile`` (behaviour.md §9.8 #60-63)."""
    used = 0
    for _, shift, mask in bit_fields(signal, profile):
        used |= mask << shift
    return ((1 << (8 * SIGNALS[signal]["size"])) - 1) & ~used


@lru_cache(maxsize=None)
def bit_position(signal: str, name: str, profile: str = "generic") -> int:
    """Bit number of a named 1-bit field for ``profile`` (e.g. control_requested: 9, PS/PSM 10)."""
    for n, shift, _ in bit_fields(signal, profile):
        if n == name:
            return shift
    raise KeyError(f"{signal}.{name} not defined for {profile}")


def bits(signals: dict, profile: str = "generic") -> dict:
    """Every named bit of the signals that have a bit map: {"g1_zsw.sensor_error": 0/1, ...}."""
    out = {}
    for sig, v in signals.items():
        if sig in BITMAPS:
            for name, shift, mask in bit_fields(sig, profile):
                out[f"{sig}.{name}"] = (v >> shift) & mask
    return out


def error_text(code: int) -> str:
    """Words for a G1_XIST2 error code (cyclic.md §9); unknown codes are device-specific."""
    e = XIST2_ERRORS.get(code)
    return e["text"] if e else f"device-specific error code 0x{code:04X}"


def velocity_unit_name(value: int | None) -> str | None:
    if value is None:
        return None
    u = VELOCITY_UNITS.get(value)
    return u["text"] if u else f"unknown unit {value}"


def telegrams_for_length(actual_len: int | None, setpoint_len: int | None = None) -> list[int]:
    """Telegrams whose lengths fit (cyclic.md §14: length alone is ambiguous)."""
    out = []
    for t in sorted(TELEGRAMS):
        if actual_len is not None and layout(t, "actual").length != actual_len:
            continue
        if setpoint_len is not None and layout(t, "setpoint").length != setpoint_len:
            continue
        out.append(t)
    return out


def field_names() -> list[str]:
    """Every display-filter field the table defines (pndiss.<signal>, pndiss.<signal>.<bit>)."""
    names = [f"pndiss.{s}" for s in SIGNALS]
    for sig, rows in BITMAPS.items():
        for b in rows:
            n = f"pndiss.{sig}.{b['name']}"
            if n not in names:
                names.append(n)
    return names
