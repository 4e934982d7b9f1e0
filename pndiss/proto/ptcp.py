"""PN-PTCP (precision transparent clock protocol) PDUs on PN-RT FrameIDs 0x0000-0x00FF and
0xFF00-0xFF5F: header per FrameID range, then TLV blocks up to the End block.

Layouts: spec/wire.md §2.9 and tshark 4.0 plugins/epan/profinet/packet-pn-ptcp.c (field names
``pn_ptcp.*``, tests/tshark_map/ptcp.json). Padding aligns to 4 bytes counted from the first
byte after the FrameID, as tshark does.
"""
from __future__ import annotations

import struct
import uuid

from .common import mac, need

L = "ptcp"

# FrameID -> (PDU name, header layout) (packet-pn-ptcp.c dissect_PNPTCP_Data_heur)
RTSYNC, ANNOUNCE, FOLLOWUP, DELAY = "rtsync", "announce", "followup", "delay"
PDU_NAMES = {0x0020: ("RTSync FU (Clock)", RTSYNC), 0x0021: ("RTSync FU (Time)", RTSYNC),
             0x0080: ("RTSync (Clock)", RTSYNC), 0x0081: ("RTSync (Time)", RTSYNC),
             0xFF00: ("Announce (Clock)", ANNOUNCE), 0xFF01: ("Announce (Time)", ANNOUNCE),
             0xFF20: ("FollowUp (Clock)", FOLLOWUP), 0xFF21: ("FollowUp (Time)", FOLLOWUP),
             0xFF40: ("DelayReq", DELAY), 0xFF41: ("DelayRes", DELAY),
             0xFF42: ("DelayFuRes", DELAY), 0xFF43: ("DelayRes", DELAY)}
HEADER_LEN = 20  # every PTCP header is 20 bytes

# TLV block types (packet-pn-ptcp.c pn_ptcp_block_type)
BLOCK_TYPES = {0x00: "End", 0x01: "Subdomain", 0x02: "Time", 0x03: "TimeExtension", 0x04: "Master",
               0x05: "PortParameter", 0x06: "DelayParameter", 0x07: "PortTime", 0x7F: "Organizational Specific"}
OUI_PROFINET = (0x000ECF, 0x010ECF)  # PROFINET and its multicast form

# Block layouts: (key, kind); "align" pads to 4 from the PDU start (kinds: u8/u16/i16/u32/mac/uuid)
BLOCK_LAYOUTS = {
    0x01: (("master_source_address", "mac"), ("subdomain_uuid", "uuid")),
    0x02: (("epoch_number", "u16"), ("seconds", "u32"), ("nanoseconds", "u32")),
    0x03: (("flags", "u16"), ("currentutcoffset", "u16")),
    0x04: (("_prio1", "u8"), ("master_priority2", "u8"), ("clock_class", "u8"), ("clock_accuracy", "u8"),
           ("clockvariance", "i16")),
    0x05: (("align", ""), ("t2portrxdelay", "u32"), ("t3porttxdelay", "u32")),
    0x06: (("port_mac_address", "mac"),),
    0x07: (("align", ""), ("t2timestamp", "u32")),
}
SIZES = {"u8": 1, "u16": 2, "i16": 2, "u32": 4, "i32": 4, "mac": 6, "uuid": 16}
FORMATS = {"u8": ">B", "u16": ">H", "i16": ">h", "u32": ">I", "i32": ">i"}

# MasterPriority1 bit fields: (key, mask, shift) (tshark pn_ptcp.master_priority1_* masks)
PRIO1_BITS = (("master_priority1_prio", 0x07, 0), ("master_priority1_level", 0x38, 3),
              ("master_priority1_res", 0x40, 6), ("master_priority1_act", 0x80, 7))
MASTER_PRIO1 = {0: "Sync slave", 1: "Primary sync master", 2: "Secondary sync master"}
CLOCK_ACCURACY = {0x20: "25ns", 0x21: "100ns (Default)", 0x22: "250ns", 0x23: "1us", 0x24: "2.5us",
                  0x25: "10us", 0x26: "25us", 0x27: "100us", 0x28: "250us", 0x29: "1ms", 0xFE: "Unknown"}


def _read(data: bytes, o: int, kind: str, what: str):
    n = SIZES[kind]
    need(data, o, n, L, what)
    if kind == "mac":
        return mac(data[o:o + n]), o + n
    if kind == "uuid":
        return str(uuid.UUID(bytes=bytes(data[o:o + n]))), o + n
    return struct.unpack_from(FORMATS[kind], data, o)[0], o + n


def _align(o: int, base: int) -> int:
    return o + (-(o - base) % 4)


def _header(data: bytes, off: int, kind: str) -> dict:
    need(data, off, HEADER_LEN, L, "PTCP header")
    h: dict = {}
    if kind == RTSYNC:
        h["res1"], h["res2"], h["delay10ns"], h["sequence_id"], h["delay1ns_byte"] = \
            struct.unpack_from(">IIIHB", data, off)
        h["delay1ns"] = struct.unpack_from(">I", data, off + 16)[0]
        h["delay_ns"] = h["delay10ns"] * 10 + h["delay1ns_byte"] + h["delay1ns"]
    else:
        h["sequence_id"] = struct.unpack_from(">H", data, off + 12)[0]
        if kind == FOLLOWUP:
            h["delay1ns_fup"] = struct.unpack_from(">i", data, off + 16)[0]
            h["delay_ns"] = h["delay1ns_fup"]
        elif kind == DELAY:
            h["delay1ns"] = struct.unpack_from(">I", data, off + 16)[0]
            h["delay_ns"] = h["delay1ns"]
    return h


def _block_body(data: bytes, o: int, base: int, btype: int, length: int) -> dict:
    b: dict = {}
    if btype == 0x7F:
        if length < 4:
            return b
        need(data, o, 3, L, "PTCP option OUI")
        b["oui"] = (data[o] << 16) | (data[o + 1] << 8) | data[o + 2]
        if b["oui"] in OUI_PROFINET:
            b["subtype"], o = _read(data, o + 3, "u8", "PTCP option subtype")
            if b["subtype"] == 1:  # RTData
                b["irdata_uuid"], _ = _read(data, _align(o, base), "uuid", "PTCP IRDataUUID")
        return b
    for key, kind in BLOCK_LAYOUTS[btype]:
        if key == "align":
            o = _align(o, base)
            continue
        b[key], o = _read(data, o, kind, f"PTCP {BLOCK_TYPES[btype]} {key}")
    if "_prio1" in b:
        p = b.pop("_prio1")
        b.update({k: (p & m) >> s for k, m, s in PRIO1_BITS})
        b["master_priority1_name"] = MASTER_PRIO1.get(b["master_priority1_prio"], "Reserved")
        b["clock_accuracy_name"] = CLOCK_ACCURACY.get(b["clock_accuracy"], "Reserved")
    return b


def decode(data: bytes, off: int, frame_id: int) -> dict:
    """PTCP PDU after the FrameID at ``data[off]`` -> event fields (raises Malformed)."""
    name, kind = PDU_NAMES.get(frame_id, (None, None))
    if kind is None:  # reserved FrameID in a PTCP range: tshark shows the bytes undecoded
        return {"pdu": f"Reserved FrameID 0x{frame_id:04x}", "data": data[off:].hex()}
    d = {"pdu": name, **_header(data, off, kind), "blocks": []}
    o = off + HEADER_LEN
    while True:
        need(data, o, 2, L, "PTCP TLV header")
        tl = struct.unpack_from(">H", data, o)[0]
        btype, length = tl >> 9, tl & 0x1FF
        blk = {"tl_type": btype, "tl_length": length, "name": BLOCK_TYPES.get(btype, "Unknown")}
        d["blocks"].append(blk)
        o += 2
        if btype == 0:
            break
        if btype in BLOCK_LAYOUTS or btype == 0x7F:
            blk.update(_block_body(data, o, off, btype, length))
            o += length
        else:  # tshark 4.0 steps over an unknown block's length twice; follow it to stay in step
            o += 2 * length
    return d
