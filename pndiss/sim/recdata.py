"""Record payloads the simulator writes/reads: 0xBF00 user parameters, I&M0, 0xB02E/0xB02F base-mode
parameter requests and responses.

The bytes come from ``pndiss.records.build`` (the records helper's builders: records.md §3.3-3.5
request/response, §5.1 0xBF00, §2.2 I&M0); this module adapts them to the simulator's tuples and
holds the values the reference device answers with.
"""
from __future__ import annotations

from ..records import build as B

# What the reference device answers per PNU (records.md §4.2-4.8): pnu -> values function(dev)
PNU_VALUES = {
    922: lambda d: [d["telegram"]],                                               # telegram selection
    964: lambda d: [d["vendor_id"], 1, 0x0100, 2026, 0x0101, 1],                 # device identification
    965: lambda d: [0x3D, 41 if d["compat"] else 31],                             # profile number, version
    971: lambda d: [d.get("p971", 0)],
    980: lambda d: [922, 964, 965, 971, 975, 979, 980, 65000, 65001],          # list of defined parameters
    979: lambda d: [0x00005011, 0x80000000, d["mupr"], 0, 0, d["tmr"] // max(d["mupr"], 1)],
    65000: lambda d: [d["preset_value"]],
    65001: lambda d: [0x000C0101, 0, 0, 0x30, 0, 0, 0x401, 0xFFFFFFFF,
                      d["offset"] & 0xFFFFFFFF, d["mupr"], d["tmr"] & 0xFFFFFFFF, d["velocity_unit"]],
}


def read_block(pnu: int, dev: dict, profile: str) -> tuple[int, list]:
    """(format, values) of a positive read response, in the parameter's own data type."""
    from ..records.profidrive import param_info
    info = param_info(pnu, profile) or {}
    fmt = info.get("type_code") or 0x07     # the format byte of the declared type (records.md §3.6)
    vals = PNU_VALUES[pnu](dev)
    if fmt == 0x1F:   # OctetString2 (P965): one 2-octet value. tshark 4.0 does not decode format 0x1F
        return fmt, ["".join(f"{v:02x}" for v in vals)]   # (expert warning), the exact type wins
    if pnu == 965:    # PS/PSM declares P965 a single UINT16 (records.md §4.3)
        return fmt, [vals[0] << 8 | vals[1]]
    if fmt == 0x04:
        vals = [v - (1 << 32) if v >= 1 << 31 else v for v in vals]
    return fmt, vals


def bf00(profile: str, **values) -> bytes:
    """31-byte user parameter block (records.md §5.1), via the records helper's builder."""
    return B.build_bf00(profile, **values)


def im0(vendor_id: int, order_id: str, serial: str, profile_id: int = 0x3D00) -> bytes:
    """I&M0 block (block type 0x0020, records.md §2.2)."""
    return B.build_im0(vendor_id=vendor_id, order_id=order_id, serial=serial, profile_id=profile_id)


def param_request(ref: int, request_id: int, params: list[tuple], axis: int = 1, n: int | None = None) -> bytes:
    """params: [(pnu, subindex, count, values|None, fmt)]; values only for a change request."""
    return B.build_param_request(ref, request_id, [
        {"pnu": pnu, "subindex": sub, "count": count, "format": fmt, "values": vals or []}
        for pnu, sub, count, vals, fmt in params], axis=axis, no_of_parameters=n)


def param_response(ref: int, response_id: int, blocks: list[tuple], axis: int = 1) -> bytes:
    """blocks: [(fmt, values)] per parameter; fmt 0x44 = error (values = [error number]).
    A positive change response (0x02) is the header only (records.md §3.9)."""
    if response_id == 0x02:
        return B.build_param_response(ref, response_id, [], axis=axis, no_of_parameters=len(blocks))
    return B.build_param_response(ref, response_id, [
        {"error": vals[0], **({"error_subindex": vals[1]} if len(vals) > 1 else {})} if fmt == 0x44
        else {"format": fmt, "values": vals} for fmt, vals in blocks], axis=axis)
