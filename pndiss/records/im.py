"""I&M identification records 0xAFF0-0xAFF4 (spec/records.md §2).

The byte layout is the standard I&M one (records.md §2.2, [external], confirmed field for field by
tshark 4.0 packet-dcerpc-pn-io.c: pn_io.vendor_id_high ... pn_io.im_supported). Lika's manual
prints a 6-byte vendor ID and a 64-byte total (000_37bf2397999f1108.txt:1938-1949); that is
taken as a misprint (its vendor ID is a 16-bit value, 000_...:1962), so we decode 2 bytes.
"""
from __future__ import annotations

import struct

from ..proto.common import Malformed

LAYER = "im"

# Vendor IDs we can cite. Lika: P964/P975 sub 0 = 0x239 and GSDML "LIKA-0239"
# (000_37bf2397999f1108.txt:846, 1962, 1993). Siemens 0x002A: DCP DeviceID of an ET200SP in the
# python-profinet capture (spec/wire.md:510-511). The SCANCON, Hohner and PS/PSM manuals give none.
VENDORS = {0x0239: "Lika Electronic", 0x002A: "Siemens"}

# I&M0 profile IDs: 0x0000 = no profile / standard API (000_...:93-97); 0x3D00 = encoder profile
# (API of the encoder object, 002_d69f444daf0f8af2.txt:490-493; P965 profile number 0x3D,
# 000_...:1972).
IM_PROFILE_IDS = {0x0000: "Non-profile / standard", 0x3D00: "Encoder profile"}

# I&M block types (records.md §2.2 [external]; tshark 4.0 pn_io.block_type values I&M0..I&M4)
BLOCK_TYPES = {0x0020: "I&M0", 0x0021: "I&M1", 0x0022: "I&M2", 0x0023: "I&M3", 0x0024: "I&M4"}

# Layouts after the 6-byte block header: (field, size, kind). kind "s" = visible string,
# "H"/"B" = big-endian unsigned, "c" = one character, "x" = octets kept as hex.
IM0 = (("vendor_id_high", 1, "B"), ("vendor_id_low", 1, "B"), ("order_id", 20, "s"),
       ("serial_number", 16, "s"), ("hw_revision", 2, "H"), ("sw_revision_prefix", 1, "c"),
       ("sw_revision_functional_enhancement", 1, "B"), ("sw_revision_bug_fix", 1, "B"),
       ("sw_revision_internal_change", 1, "B"), ("revision_counter", 2, "H"), ("profile_id", 2, "H"),
       ("profile_specific_type", 2, "H"), ("im_version_major", 1, "B"), ("im_version_minor", 1, "B"),
       ("im_supported", 2, "H"))
LAYOUTS = {
    0xAFF0: (0x0020, IM0),
    0xAFF1: (0x0021, (("tag_function", 32, "s"), ("tag_location", 22, "s"))),
    0xAFF2: (0x0022, (("date", 16, "s"),)),
    0xAFF3: (0x0023, (("descriptor", 54, "s"),)),
    0xAFF4: (0x0024, (("signature", 54, "x"),)),
}


def _fields(layout, data: bytes, off: int) -> dict:
    out = {}
    for name, size, kind in layout:
        if off + size > len(data):
            raise Malformed(LAYER, f"{name} truncated (needs {size} bytes at offset {off}, record has {len(data)})")
        raw = data[off:off + size]
        if kind == "s" or kind == "c":
            out[name] = raw.decode("latin-1")
        elif kind == "x":
            out[name] = raw.hex()
        else:
            out[name] = int.from_bytes(raw, "big")
        off += size
    return out


def decode_im(index: int, data: bytes) -> dict:
    """I&M0..I&M4 record (index 0xAFF0..0xAFF4): block header plus the fields."""
    btype_expected, layout = LAYOUTS[index]
    if len(data) < 6:
        raise Malformed(LAYER, f"block header truncated ({len(data)} of 6 bytes)")
    btype, blen, vh, vl = struct.unpack_from(">HHBB", data, 0)
    out = {"block_type": btype, "block_type_name": BLOCK_TYPES.get(btype, f"0x{btype:04X}"),
           "block_length": blen, "block_version_high": vh, "block_version_low": vl, "notes": []}
    if btype != btype_expected:
        out["notes"].append(f"block type 0x{btype:04X}, expected 0x{btype_expected:04X}")
    out.update(_fields(layout, data, 6))
    if index == 0xAFF0:
        vid = (out["vendor_id_high"] << 8) | out["vendor_id_low"]
        out["vendor_id"] = vid
        out["vendor_name"] = VENDORS.get(vid, f"vendor 0x{vid:04X}")
        out["order_id"] = out["order_id"].rstrip(" \x00")
        out["serial_number"] = out["serial_number"].rstrip(" \x00")
        out["sw_revision"] = (f"{out['sw_revision_prefix']}{out['sw_revision_functional_enhancement']}."
                              f"{out['sw_revision_bug_fix']}.{out['sw_revision_internal_change']}")
        out["profile_name"] = IM_PROFILE_IDS.get(out["profile_id"], f"profile 0x{out['profile_id']:04X}")
        out["im_version"] = f"{out['im_version_major']}.{out['im_version_minor']}"
        # bits 1..4 flag I&M1..I&M4 (records.md §2.2, "verify")
        out["im_supported_records"] = [f"I&M{i}" for i in range(1, 16) if out["im_supported"] >> i & 1]
    else:
        for k, v in list(out.items()):
            if isinstance(v, str) and k not in ("block_type_name",):
                out[k] = v.rstrip(" \x00")
    if 4 + blen != len(data):
        out["notes"].append(f"block length {blen} + 4 != record length {len(data)}")
    return out
