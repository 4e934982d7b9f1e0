"""Record payloads the simulator writes/reads: 0xBF00 user parameters, I&M0, 0xB02E/0xB02F base-mode
parameter requests and responses.

Uses ``pndiss.records.build`` (records helper) when it is importable; otherwise these minimal
builders, which follow spec/records.md §3.3-3.5 (request/response), §5.1 (0xBF00) and §2.2 (I&M0).
"""
from __future__ import annotations

import struct

try:  # the records helper's builders, when they have landed
    from ..records import build as _build  # type: ignore
except Exception:  # pragma: no cover - depends on the other helper's progress
    _build = None

# Format bytes (records.md §3.5): 0x41 byte, 0x42 word, 0x43 double word, 0x44 error, 0x40 zero
FMT_SIZE = {0x41: 1, 0x42: 2, 0x43: 4, 0x06: 2, 0x07: 4, 0x04: 4, 0x0A: 1}

# PNUs the simulator reads and how the reference device answers (records.md §4.2-4.8):
# pnu -> (format, values function(dev) -> list)
PNU_VALUES = {
    922: (0x42, lambda d: [d["telegram"]]),                                       # telegram selection
    964: (0x42, lambda d: [d["vendor_id"], 1, 0x0100, 2026, 0x0101, 1]),         # device identification
    965: (0x0A, lambda d: [0x3D, 41 if d["compat"] else 31]),                     # profile number, version
    979: (0x43, lambda d: [0x00005011, 0x80000000, d["mupr"], 0, 0, d["tmr"] // max(d["mupr"], 1)]),
    65000: (0x43, lambda d: [d["preset_value"] & 0xFFFFFFFF]),
    65001: (0x43, lambda d: [0x000C0101, 0, 0, 0x30, 0, 0, 0x401, 0xFFFFFFFF,
                             d["offset"] & 0xFFFFFFFF, d["mupr"], d["tmr"] & 0xFFFFFFFF, d["velocity_unit"]]),
}


def bf00(profile: str, *, direction=0, class4=1, preset_control=0, scaling=1, alarm_channel_control=0,
         compat=1, mupr=8192, tmr=8192 * 4096, max_master_sol_failures=1, velocity_unit=0) -> bytes:
    """31-byte user parameter block (records.md §5.1); PSM adds nothing we set (velocity reference 0)."""
    if _build is not None and hasattr(_build, "build_bf00"):
        return _build.build_bf00(profile, direction=direction, class4=class4, preset_control=preset_control,
                                 scaling=scaling, alarm_channel_control=alarm_channel_control, compat=compat,
                                 mupr=mupr, tmr=tmr, max_master_sol_failures=max_master_sol_failures,
                                 velocity_unit=velocity_unit)
    b0 = (direction & 1) | (class4 & 1) << 1 | (preset_control & 1) << 2 | (scaling & 1) << 3 \
        | (alarm_channel_control & 1) << 4 | (compat & 1) << 5
    return struct.pack(">BQQBB", b0, mupr, tmr, max_master_sol_failures, velocity_unit) + bytes(12)


def im0(vendor_id: int, order_id: str, serial: str, profile_id: int = 0x3D00) -> bytes:
    """I&M0 block (block type 0x0020, records.md §2.2): vendor, order ID, serial, revisions, profile."""
    if _build is not None and hasattr(_build, "build_im0"):
        return _build.build_im0(vendor_id=vendor_id, order_id=order_id, serial=serial, profile_id=profile_id)
    body = struct.pack(">BBH", 1, 0, vendor_id) + order_id.encode().ljust(20)[:20] \
        + serial.encode().ljust(16)[:16] + struct.pack(">H", 1) + b"V" + bytes([1, 0, 0]) \
        + struct.pack(">HHHBBH", 0, profile_id, 0x0004, 1, 1, 0)
    return struct.pack(">HH", 0x0020, len(body)) + body


def param_request(ref: int, request_id: int, params: list[tuple], axis: int = 1) -> bytes:
    """params: [(pnu, subindex, count, values|None, fmt)]; values only for a change request."""
    if _build is not None and hasattr(_build, "build_param_request"):
        return _build.build_param_request(ref, request_id, params, axis=axis)
    out = bytearray(struct.pack(">BBBB", ref, request_id, axis, len(params)))
    for pnu, sub, count, _vals, _fmt in params:
        out += struct.pack(">BBHH", 0x10, count, pnu, sub)
    if request_id == 2:
        for _pnu, _sub, _count, vals, fmt in params:
            out += _value_block(fmt, vals)
    return bytes(out)


def _value_block(fmt: int, vals: list[int]) -> bytes:
    size = FMT_SIZE[fmt]
    b = bytes([fmt, len(vals)]) + b"".join(v.to_bytes(size, "big") for v in vals)
    return b + b"\0" * (len(b) & 1)  # value blocks are padded to even length (records.md §3.3)


def param_response(ref: int, response_id: int, blocks: list[tuple], axis: int = 1) -> bytes:
    """blocks: [(fmt, values)] per parameter; fmt 0x44 = error (values = [error number])."""
    if _build is not None and hasattr(_build, "build_param_response"):
        return _build.build_param_response(ref, response_id, blocks, axis=axis)
    out = bytearray(struct.pack(">BBBB", ref, response_id, axis, len(blocks)))
    if response_id != 2:  # a positive change response is the header only (records.md §3.9)
        for fmt, vals in blocks:
            if fmt == 0x44:
                out += bytes([0x44, len(vals)]) + b"".join(struct.pack(">H", v) for v in vals)
            else:
                out += _value_block(fmt, vals)
    return bytes(out)
