"""What every protocol module shares: the Malformed exception and small formatting helpers.

Decoders are plain functions ``decode(data, ...) -> dict``. They never let an IndexError or
struct.error escape: bad input raises :class:`Malformed` with the layer and a reason, which the
analyzer turns into a ``malformed`` event (frame number, layer, reason).
"""
from __future__ import annotations

import struct


class Malformed(Exception):
    """The bytes do not form a valid PDU of ``layer``; ``reason`` says why, in words."""

    def __init__(self, layer: str, reason: str):
        super().__init__(f"{layer}: {reason}")
        self.layer = layer
        self.reason = reason


def need(data: bytes, off: int, n: int, layer: str, what: str) -> None:
    """Raise Malformed unless ``n`` bytes are available at ``off``."""
    if off < 0 or off + n > len(data):
        raise Malformed(layer, f"{what} truncated (needs {n} bytes at offset {off}, frame has {len(data)})")


_MAC_CACHE: dict[bytes, str] = {}


def mac(b: bytes) -> str:
    """'aa:bb:cc:dd:ee:ff'; cached, since a capture has few distinct MACs and many frames."""
    s = _MAC_CACHE.get(b)
    if s is None:
        s = ":".join(f"{x:02x}" for x in b)
        if len(_MAC_CACHE) < 65536:  # bounded: a flood of random MACs must not grow memory
            _MAC_CACHE[bytes(b)] = s
    return s


def ipv4(b: bytes) -> str:
    return ".".join(str(x) for x in b)


def u8(d: bytes, o: int) -> int:
    return d[o]


U16 = struct.Struct(">H")
U32 = struct.Struct(">I")


def u16(d: bytes, o: int) -> int:
    return U16.unpack_from(d, o)[0]


def u32(d: bytes, o: int) -> int:
    return U32.unpack_from(d, o)[0]


KEEP_FRAMES = 1024  # frame numbers a reassembly keeps by name; beyond, it counts them (bounded memory)


class FrameList(list):
    """The frames of one reassembly: the first KEEP_FRAMES by number, ``total`` and ``last`` of all."""

    __slots__ = ("total", "last")

    def __init__(self, first=()):
        super().__init__(first)
        self.total = len(self)
        self.last = self[-1] if self else None

    def add(self, fn: int) -> None:
        self.total += 1
        self.last = fn
        if len(self) < KEEP_FRAMES:
            self.append(fn)


class PendingBuffers:
    """Bookkeeping shared by the reassemblers (IPv4, DCE/RPC): pending entries with their frames,
    first time stamp and byte count; dropped ones come back as ``(frames, reason)`` (frames a
    FrameList) so the caller reports them as malformed. Subclasses set ``what`` (for the reasons)
    and ``timeout_ns``. Entries are dicts in arrival order, so the oldest (first to time out, first
    evicted) is the first key: ``expire`` looks at that one only, O(1) per call while nothing is due."""

    what = "reassembly"

    def __init__(self, timeout_ns: int):
        self.timeout_ns = timeout_ns
        self.pending: dict[tuple, dict] = {}
        self.bytes = 0
        self.dropped: list[tuple[list[int], str]] = []

    def _drop(self, key, reason: str) -> None:
        p = self.pending.pop(key)
        self.bytes -= p["bytes"]
        self.dropped.append((p["frames"], reason))

    def expire(self, now_ns: int | None) -> list[tuple[list[int], str]]:
        """Drop entries older than the time-out (all of them with ``now_ns=None``, end of capture)."""
        pending = self.pending
        if now_ns is None:
            for key in list(pending):
                self._drop(key, f"{self.what} incomplete at end of capture")
        else:
            # pending is in arrival order and time stamps mostly rise: stop at the first entry not due
            while pending:
                key = next(iter(pending))
                if now_ns - pending[key]["ts"] <= self.timeout_ns:
                    break
                self._drop(key, f"{self.what} timed out")
        out, self.dropped = self.dropped, []
        return out
