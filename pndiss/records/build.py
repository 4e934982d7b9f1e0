"""Record builders (pure bytes) for the simulator and the tests: the inverse of the decoders in
this package, same layouts (PROFIdrive base mode: 001_9461bb7bc8c2767b.txt:1876-1900;
I&M0: spec/records.md §2.2; user parameters: records.md §5.1)."""
from __future__ import annotations

import struct

from .profidrive import FMT_ERROR, FORMATS
from .userparams import FLAG_BITS, RECORD_LEN


def _value_block(fmt: int, values) -> bytes:
    """Format byte, number of values, the values, a zero pad byte if the block is odd (001_...:1965)."""
    name, size, code = FORMATS[fmt]
    values = list(values)
    if code == "str":
        raw = values[0].encode("latin-1") if values else b""
        n = len(raw)
    elif code == "hex":
        raw = b"".join(bytes.fromhex(v) for v in values)
        n = len(values)
    elif code:
        raw = struct.pack(f">{len(values)}{code}", *values)
        n = len(values)
    else:
        raw, n = b"", 0
    blk = bytes([fmt, n]) + raw
    return blk + b"\x00" if len(raw) % 2 else blk


def build_param_request(request_ref: int, request_id: int, params: list[dict], axis: int = 0,
                        no_of_parameters: int | None = None) -> bytes:
    """params: [{"pnu", "subindex"=0, "count"=0, "attribute"=0x10, and for a change request
    "format" (e.g. 0x43) and "values" (list)}]."""
    n = len(params) if no_of_parameters is None else no_of_parameters
    out = bytearray([request_ref, request_id, axis, n])
    for p in params:
        out += struct.pack(">BBHH", p.get("attribute", 0x10), p.get("count", 0), p["pnu"], p.get("subindex", 0))
    if request_id == 0x02:
        for p in params:
            out += _value_block(p["format"], p["values"])
    return bytes(out)


def build_param_response(request_ref: int, response_id: int, blocks: list[dict] | None = None, axis: int = 0,
                         no_of_parameters: int | None = None) -> bytes:
    """blocks: [{"format", "values"}] or [{"error": code, "error_subindex": optional}] or
    [{"format": 0x40}] (zero block). A positive change response (0x02) has no blocks; give
    ``no_of_parameters`` then."""
    blocks = blocks or []
    n = len(blocks) if no_of_parameters is None else no_of_parameters
    out = bytearray([request_ref, response_id, axis, n])
    for b in blocks:
        if "error" in b:
            errs = [b["error"]] + ([b["error_subindex"]] if "error_subindex" in b else [])
            out += _value_block(FMT_ERROR, errs)
        else:
            out += _value_block(b["format"], b.get("values", []))
    return bytes(out)


def _text(s: str, n: int) -> bytes:
    return s.encode("latin-1")[:n].ljust(n, b" ")


def build_im0(vendor_id: int = 0x0239, order_id: str = "", serial: str = "", hw_revision: int = 1,
              sw_revision: tuple = ("V", 1, 0, 0), revision_counter: int = 0, profile_id: int = 0x3D00,
              profile_specific_type: int = 0, im_version: tuple = (1, 1), im_supported: int = 0) -> bytes:
    """I&M0 record (60 bytes incl. the block header, type 0x0020, length 56, version 1.0)."""
    body = (struct.pack(">BBH", 1, 0, vendor_id) + _text(order_id, 20) + _text(serial, 16)
            + struct.pack(">H", hw_revision) + sw_revision[0].encode("latin-1")[:1]
            + bytes(sw_revision[1:4]) + struct.pack(">HHHBBH", revision_counter, profile_id,
                                                   profile_specific_type, im_version[0], im_version[1],
                                                   im_supported))
    return struct.pack(">HH", 0x0020, len(body)) + body


# per-profile factory defaults (records.md §5.2): Lika 000_...:3513-3532, SCANCON 001_...:773-826,
# Hohner 004_...:713-756, PSM 002_...:985-1004; MUPR/TMR defaults are the hardware resolution,
# here a 13+12 bit multiturn.
DEFAULTS = {
    "lika": dict(code_sequence=0, class4=1, preset_control=0, scaling=0, alarm_channel_control=0, compat=1),
    "scancon": dict(code_sequence=0, class4=0, preset_control=0, scaling=1, alarm_channel_control=0, compat=1),
    "hohner": dict(code_sequence=0, class4=0, preset_control=0, scaling=0, alarm_channel_control=0, compat=1),
    "psm": dict(code_sequence=0, class4=1, preset_control=1, scaling=0, alarm_channel_control=0, compat=1),
    "generic": dict(code_sequence=0, class4=1, preset_control=0, scaling=0, alarm_channel_control=0, compat=1),
}


def build_bf00(profile: str = "generic", **values) -> bytes:
    """User parameter record (31 bytes). Keyword names as decoded: code_sequence (or direction),
    class4, preset_control, scaling, alarm_channel_control, compat, mupr, tmr,
    max_master_sol_failures, velocity_unit; PSM also encoder_type, velocity_reference;
    reserved_bits / reserved_bytes (bytes) / length to build faulty records."""
    v = dict(DEFAULTS.get(profile, DEFAULTS["generic"]))
    v.update(mupr=8192, tmr=8192 * 4096, max_master_sol_failures=1, velocity_unit=0)
    if "direction" in values:
        values["code_sequence"] = values.pop("direction")
    v.update(values)
    b0 = 0
    for name, bit in FLAG_BITS:
        b0 |= (v[name] & 1) << bit
    b0 |= (v.get("encoder_type", 0) & 1) << 6
    b0 |= (v.get("reserved_bits", 0) & 3) << 6
    out = bytearray([b0]) + v["mupr"].to_bytes(8, "big") + v["tmr"].to_bytes(8, "big")
    out += bytes([v["max_master_sol_failures"], v["velocity_unit"]])
    tail = bytearray(RECORD_LEN - 19)
    if "velocity_reference" in v:
        tail[0:4] = struct.pack(">f", v["velocity_reference"])
    if "reserved_bytes" in v:
        rb = v["reserved_bytes"]
        tail[:len(rb)] = rb
    out += tail
    n = v.get("length", RECORD_LEN)
    return bytes(out[:n]) + bytes(max(0, n - len(out)))
