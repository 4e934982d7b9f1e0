"""MRP (media redundancy protocol, EtherType 0x88E3): MRP_Version, then TLVs up to End.

spec/wire.md §2.9 and tshark 4.0 plugins/epan/profinet/packet-pn-mrp.c (``pn_mrp.*``;
tests/tshark_map/mrp.json). tshark steps through a TLV by what it parses (plus 4-byte padding
counted from the first TLV), not by its Length; we do the same so both stay in step.
"""
from __future__ import annotations

import struct
import uuid

from .common import Malformed, mac, need

L = "mrp"

TLV_TYPES = {0x00: "End", 0x01: "Common", 0x02: "Test", 0x03: "TopologyChange", 0x04: "LinkDown",
             0x05: "LinkUp", 0x06: "InTest", 0x07: "InTopologyChange", 0x08: "InLinkDown",
             0x09: "InLinkUp", 0x0A: "InLinkStatusPoll", 0x7F: "Option"}
PORT_ROLES = {0: "Primary ring port", 1: "Secondary ring port", 2: "Interconnection port"}
RING_STATES = {0: "Ring open", 1: "Ring closed"}

# TLV layouts (key, kind, then "align" = pad to 4) (packet-pn-mrp.c dissect_PNMRP_*)
LAYOUTS = {
    0x01: (("sequence_id", "u16"), ("domain_uuid", "uuid"), ("align", "")),
    0x02: (("prio", "u16"), ("sa", "mac"), ("port_role", "u16"), ("ring_state", "u16"),
           ("transition", "u16"), ("time_stamp", "u32"), ("align", "")),
    0x03: (("prio", "u16"), ("sa", "mac"), ("interval", "u16")),
    0x04: (("sa", "mac"), ("port_role", "u16"), ("interval", "u16"), ("blocked", "u16"), ("align", "")),
    0x05: (("sa", "mac"), ("port_role", "u16"), ("interval", "u16"), ("blocked", "u16"), ("align", "")),
}
SIZES = {"u16": 2, "u32": 4, "mac": 6, "uuid": 16}

# Option TLV (0x7F): tshark 4.0 decodes only the Siemens OUI (MRP_Ed1Type, ManufacturerData,
# SubOption2); any other OUI, PROFINET's included, is shown undecoded. Checked with tshark -V.
OUI_SIEMENS = 0x080006
ED1_WITH_DATA = (0x00, 0x04)  # Ed1Types followed by a u16 MRP_Ed1ManufacturerData
SUB_OPTION_MGR = (0x01, 0x02)  # MRP_TestMgrNAck, MRP_AutoMgr: Prio, SA, OtherMRMPrio, OtherMRMSA
SUB_OPTION_LAYOUT = (("prio", "u16"), ("sa", "mac"), ("other_mrm_prio", "u16"), ("other_mrm_sa", "mac"))


def _field(data: bytes, o: int, kind: str):
    n = SIZES[kind]
    need(data, o, n, L, f"MRP {kind} field")
    b = data[o:o + n]
    if kind == "mac":
        return mac(b)
    if kind == "uuid":
        return str(uuid.UUID(bytes=bytes(b)))
    return int.from_bytes(b, "big")


def _fields(data: bytes, o: int, base: int, layout, out: dict) -> int:
    for key, kind in layout:
        if key == "align":
            o += -(o - base) % 4
            continue
        out[key] = _field(data, o, kind)
        o += SIZES[kind]
    return o


def _option(data: bytes, o: int, base: int, n: int, tlv: dict) -> int:
    start = o
    if n < 3:
        raise Malformed(L, f"MRP Option TLV of {n} bytes has no room for the OUI")
    need(data, o, 3, L, "MRP option OUI")
    tlv["oui"] = int.from_bytes(data[o:o + 3], "big")
    o += 3
    if tlv["oui"] == OUI_SIEMENS:
        need(data, o, 1, L, "MRP_Ed1Type")
        tlv["ed1type"] = data[o]
        o += 1
        if tlv["ed1type"] in ED1_WITH_DATA:
            tlv["ed1manufacturerdata"] = _field(data, o, "u16")
            o += 2
        if o - start != n:  # more bytes announced: one SubOption2
            need(data, o, 2, L, "MRP SubOption2 header")
            sub = {"sub_type": data[o], "sub_length": data[o + 1]}
            tlv["sub_option2"] = sub
            o += 2
            if sub["sub_type"] in SUB_OPTION_MGR:
                o = _fields(data, o, base, SUB_OPTION_LAYOUT + (("align", ""),), sub)
            elif sub["sub_type"] >= 0xF1:  # vendor specific data
                o += sub["sub_length"]
    else:
        o += n - 3
    return o + (-(o - base) % 4)


def decode(data: bytes, off: int) -> dict:
    """MRP PDU at ``data[off]`` (MRP_Version) -> event fields (raises Malformed)."""
    need(data, off, 2, L, "MRP_Version")
    d = {"version": struct.unpack_from(">H", data, off)[0], "tlvs": []}
    base = o = off + 2
    while True:
        need(data, o, 2, L, "MRP TLV header")
        t, n = data[o], data[o + 1]
        tlv = {"type": t, "length": n, "name": TLV_TYPES.get(t, f"Unknown TLVType 0x{t:x}")}
        d["tlvs"].append(tlv)
        o += 2
        if t == 0:
            break
        layout = LAYOUTS.get(t)
        if t == 0x7F:
            o = _option(data, o, base, n, tlv)
            continue
        if layout is None:  # In* and unknown TLVs: tshark skips Length bytes undecoded
            o += n
            continue
        o = _fields(data, o, base, layout, tlv)
        if "port_role" in tlv:
            tlv["port_role_name"] = PORT_ROLES.get(tlv["port_role"], "Reserved")
        if "ring_state" in tlv:
            tlv["ring_state_name"] = RING_STATES.get(tlv["ring_state"], "Reserved")
    return d
