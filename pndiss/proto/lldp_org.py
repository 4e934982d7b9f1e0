"""LLDP organisation-specific TLVs (type 127): PROFINET (OUI 00-0E-CF), IEEE 802.3 and IEEE 802.1,
with the field helpers the basic TLVs (lldp.py) share. Layouts: spec/wire.md §4.3-4.4 and tshark
4.0 packet-lldp.c (dissect_profinet_tlv, dissect_ieee_802_3_tlv, dissect_ieee_802_1_tlv); keys
mirror the tshark field names (tests/tshark_map/lldp.json).
"""
from __future__ import annotations

import uuid

from .common import U16, U32, Malformed, mac

L = "lldp"

OUI_PROFINET = 0x000ECF
OUI_IEEE_802_3 = 0x00120F
OUI_IEEE_802_1 = 0x0080C2

# PNO subtypes (spec/wire.md §4.3; tshark 4.0 packet-lldp.c profinet_subtypes). 3, 7 and 8 are
# not decoded by tshark 4.0 (content shown as lldp.unknown_subtype.content, checked by probe).
PROFINET_SUBTYPES = {1: "Measured Delay Values", 2: "Port Status", 3: "Alias", 4: "MRP Port Status",
                     5: "Chassis MAC", 6: "PTCP Status", 7: "MAU Type Extension",
                     8: "MRP Interconnection Port Status", 9: "TSN Domain",
                     10: "TSN NME Management Address", 11: "TSN NME Name UUID",
                     12: "TSN NME Parameter UUID", 13: "TSN Time Domain"}
RTC2_PORT_STATUS = {0: "OFF", 1: "SYNCDATA_LOADED", 2: "RTCLASS2_UP", 3: "Reserved"}
RTC3_PORT_STATUS = {0: "OFF", 1: "Reserved", 2: "RTCLASS3_UP", 3: "RTCLASS3_DOWN", 4: "RTCLASS3_RUN"}
MRRT_PORT_STATUS = {0: "OFF", 1: "MRRT_CONFIGURED", 2: "MRRT_UP"}
TIME_DOMAIN_NUMBERS = {0x00: "Global Time", 0x01: "Global Time Redundant",
                       0x20: "Working Clock", 0x21: "Working Clock Redundant"}

# Fixed layouts: (key, kind) read in order; kinds: u8/u16/u32, mac, uuid, bytesN
PROFINET_LAYOUTS = {
    1: (("port_rx_delay_local", "u32"), ("port_rx_delay_remote", "u32"),
        ("port_tx_delay_local", "u32"), ("port_tx_delay_remote", "u32"), ("cable_delay_local", "u32")),
    2: (("rtc2_port_status", "u16"), ("_rtc3", "u16")),
    4: (("mrp_domain_uuid", "uuid"), ("mrrt_port_status", "u16")),
    5: (("cm_mac_add", "mac"),),
    6: (("master_source_address", "mac"), ("subdomain_uuid", "uuid"), ("ir_data_uuid", "uuid"),
        ("_length_of_period", "u32"), ("_red_period_begin", "u32"),
        ("_orange_period_begin", "u32"), ("_green_period_begin", "u32")),
    9: (("tsn_domain_uuid", "uuid"),),
    11: (("tsn_nme_name_uuid", "uuid"),),
    12: (("tsn_nme_parameter_uuid", "uuid"),),
    13: (("time_domain_number", "u16"), ("time_domain_uuid", "uuid"), ("time_domain_master_identity", "bytes8")),
}
# PTCP Status period words: bit 31 valid, bits 30-0 ns (suffix of the tshark field name)
PERIOD_WORDS = (("_length_of_period", "length_of_period", "length"),
                ("_red_period_begin", "red_period_begin", "offset"),
                ("_orange_period_begin", "orange_period_begin", "offset"),
                ("_green_period_begin", "green_period_begin", "offset"))

# IEEE 802.3 subtypes (spec/wire.md §4.4; tshark 4.0 dissect_ieee_802_3_tlv)
IEEE_802_3_SUBTYPES = {1: "MAC/PHY Configuration/Status", 2: "Power Via MDI", 3: "Link Aggregation",
                       4: "Maximum Frame Size", 5: "EEE (Energy-Efficient Ethernet)"}
PMD_CAPS = (("1000base_tfd", 0x0001), ("1000base_t", 0x0002), ("1000base_xfd", 0x0004),
            ("1000base_x", 0x0008), ("fdx_bpause", 0x0010), ("fdx_spause", 0x0020),
            ("fdx_apause", 0x0040), ("fdx_pause", 0x0080), ("100base_t2fd", 0x0100),
            ("100base_t2", 0x0200), ("100base_txfd", 0x0400), ("100base_tx", 0x0800),
            ("100base_t4", 0x1000), ("10base_tfd", 0x2000), ("10base_t", 0x4000), ("other", 0x8000))
# operational MAU types seen on PROFINET ports (RFC 4836 dot3MauType; spec/wire.md §4.4)
MAU_TYPES = {0: "Unknown", 15: "100BaseTXHD", 16: "100BaseTXFD", 17: "100BaseFXHD", 18: "100BaseFXFD",
             29: "1000BaseTHD", 30: "1000BaseTFD"}
MDI_POWER_BITS = (("port_class", 0x1), ("supported", 0x2), ("enabled", 0x4), ("pse_pairs", 0x8))
EEE_FIELDS = ("transmit", "receive", "fallback_receive", "echo_transmit", "echo_receive")

# IEEE 802.1 subtypes decoded here (tshark 4.0 dissect_ieee_802_1_tlv)
IEEE_802_1_SUBTYPES = {1: "Port VLAN ID", 2: "Port and Protocol VLAN ID", 3: "VLAN Name",
                       4: "Protocol Identity", 7: "Link Aggregation"}


# -- field helpers (the basic TLVs in lldp.py use them too) -----------------------------------
def bits(value: int, table) -> dict:
    return {name: int(bool(value & m)) for name, m in table}


def colon_hex(b: bytes) -> str:
    return mac(b)  # colon hex, the form tshark prints for FT_BYTES


def text(b: bytes) -> str:
    return b.decode("utf-8", "replace")


def _guid(b: bytes) -> str:
    return str(uuid.UUID(bytes=bytes(b)))


def _layout(data: bytes, off: int, end: int, layout, what: str) -> dict:
    out = {}
    for key, kind in layout:
        n = {"u8": 1, "u16": 2, "u32": 4, "mac": 6, "uuid": 16}.get(kind) or int(kind[5:])
        if off + n > end:
            raise Malformed(L, f"{what}: TLV too short for {key.strip('_')}")
        b = data[off:off + n]
        if kind == "u8":
            v = b[0]
        elif kind == "u16":
            v = U16.unpack(b)[0]
        elif kind == "u32":
            v = U32.unpack(b)[0]
        elif kind == "mac":
            v = mac(b)
        elif kind == "uuid":
            v = _guid(b)
        else:
            v = colon_hex(b)
        out[key] = v
        off += n
    return out


# -- the organisation-specific TLVs -----------------------------------------------------------
def _profinet(sub: int, data: bytes, off: int, end: int) -> dict:
    d = {"subtype": sub, "name": PROFINET_SUBTYPES.get(sub, f"Reserved (0x{sub:02x})")}
    layout = PROFINET_LAYOUTS.get(sub)
    if layout is not None:
        d.update(_layout(data, off, end, layout, "PROFINET " + d["name"]))
    elif sub == 10:
        # TSN NME management address: string length u8 (counts the subtype), subtype u8, address
        if end - off < 2:
            raise Malformed(L, "PROFINET TSN NME Management Address too short")
        slen = data[off]
        d["tsn_nme_management_addr_str_length"] = slen
        d["tsn_nme_management_addr_subtype"] = data[off + 1]
        if slen < 1 or off + 1 + slen > end:
            raise Malformed(L, f"PROFINET TSN NME address length {slen} does not fit the TLV")
        d["tsn_nme_management_addr"] = colon_hex(data[off + 2:off + 1 + slen])
    else:
        d["content"] = colon_hex(data[off:end])
        if sub == 3:
            d["alias"] = text(data[off:end])
    if "_rtc3" in d:
        w = d.pop("_rtc3")
        d["rtc3_port_status"] = w & 0x7
        d["rtc3_port_status_reserved"] = (w >> 3) & 0x1FF
        d["rtc3_port_status_fragmentation"] = (w >> 12) & 1
        d["rtc3_port_status_preambleLength"] = (w >> 13) & 1
        d["rtc2_port_status_name"] = RTC2_PORT_STATUS.get(d["rtc2_port_status"], "Reserved")
        d["rtc3_port_status_name"] = RTC3_PORT_STATUS.get(d["rtc3_port_status"], "Reserved")
    if "mrrt_port_status" in d:
        d["mrrt_port_status_name"] = MRRT_PORT_STATUS.get(d["mrrt_port_status"], "Reserved")
    if "time_domain_number" in d:
        d["time_domain_name"] = TIME_DOMAIN_NUMBERS.get(d["time_domain_number"], "Reserved")
    for raw, name, part in PERIOD_WORDS:
        if raw in d:
            w = d.pop(raw)
            d[name + "_valid"] = w >> 31
            d[name + "_" + part] = w & 0x7FFFFFFF
    return d


def _ieee_802_3(sub: int, data: bytes, off: int, end: int) -> dict:
    d = {"subtype": sub, "name": IEEE_802_3_SUBTYPES.get(sub, f"Unknown (0x{sub:02x})")}
    n = end - off
    if sub == 1:
        if n < 5:
            raise Malformed(L, "IEEE 802.3 MAC/PHY TLV too short")
        an, caps, mau = data[off], U16.unpack_from(data, off + 1)[0], U16.unpack_from(data, off + 3)[0]
        d["mac_phy_auto_neg_status"] = {"value": an, "supported": an & 1, "enabled": (an >> 1) & 1}
        # tshark also shows the capability word in "inverse (wrong) bit order"
        inv = int(f"{caps:016b}"[::-1], 2)
        d["pmd_auto_neg_advertised_caps"] = {"value": caps, **bits(caps, PMD_CAPS)}
        d["pmd_auto_neg_advertised_caps_inv"] = bits(inv, PMD_CAPS)
        d["pmd_mau_type"] = mau
        d["pmd_mau_type_name"] = MAU_TYPES.get(mau, "Unknown")
    elif sub == 2:
        if n < 3:
            raise Malformed(L, "IEEE 802.3 Power via MDI TLV too short")
        s = data[off]
        d["mdi_power_support"] = {"value": s, **bits(s, MDI_POWER_BITS)}
        d["mdi_pse_pair"] = data[off + 1]
        d["mdi_power_class"] = data[off + 2]
        if n >= 8:  # 802.3at extension: type/source/priority, requested and allocated power
            t = data[off + 3]
            d["mdi_power_type"] = t >> 6
            d["mdi_power_source"] = (t >> 4) & 3
            d["mdi_power_priority"] = t & 0xF
            d["mdi_pde_requested"] = U16.unpack_from(data, off + 4)[0]
            d["mdi_pse_allocated"] = U16.unpack_from(data, off + 6)[0]
    elif sub == 3:
        if n < 5:
            raise Malformed(L, "IEEE 802.3 Link Aggregation TLV too short")
        s = data[off]
        d["aggregation_status"] = {"value": s, "cap": s & 1, "enabled": (s >> 1) & 1}
        d["aggregated_port_id"] = U32.unpack_from(data, off + 1)[0]
    elif sub == 4:
        if n < 2:
            raise Malformed(L, "IEEE 802.3 Maximum Frame Size TLV too short")
        d["max_frame_size"] = U16.unpack_from(data, off)[0]
    elif sub == 5:
        if n < 10:
            raise Malformed(L, "IEEE 802.3 EEE TLV too short")
        d["eee"] = {k: U16.unpack_from(data, off + 2 * i)[0] for i, k in enumerate(EEE_FIELDS)}
    else:
        d["content"] = colon_hex(data[off:end])
    return d


def _ieee_802_1(sub: int, data: bytes, off: int, end: int) -> dict:
    d = {"subtype": sub, "name": IEEE_802_1_SUBTYPES.get(sub, f"Unknown (0x{sub:02x})")}
    n = end - off
    short = Malformed(L, f"IEEE 802.1 {d['name']} TLV too short")
    if sub == 1:
        if n < 2:
            raise short
        d["port_vlan_id"] = U16.unpack_from(data, off)[0]
    elif sub == 2:
        if n < 3:
            raise short
        f = data[off]
        d["port_and_vlan_id_flag"] = {"value": f, "supported": (f >> 1) & 1, "enabled": (f >> 2) & 1}
        d["port_proto_vlan_id"] = U16.unpack_from(data, off + 1)[0]
    elif sub == 3:
        if n < 3 or 3 + data[off + 2] > n:
            raise short
        d["vlan_id"] = U16.unpack_from(data, off)[0]
        d["vlan_name_len"] = data[off + 2]
        d["vlan_name"] = text(data[off + 3:off + 3 + data[off + 2]])
    elif sub == 4:
        if n < 1 or 1 + data[off] > n:
            raise short
        d["proto_id_length"] = data[off]
        d["proto_id"] = colon_hex(data[off + 1:off + 1 + data[off]])
    elif sub == 7:
        if n < 5:
            raise short
        s = data[off]
        d["aggregation_status"] = {"value": s, "cap": s & 1, "enabled": (s >> 1) & 1, "porttype": (s >> 2) & 3}
        d["aggregated_port_id"] = U32.unpack_from(data, off + 1)[0]
    else:
        d["content"] = colon_hex(data[off:end])
    return d


ORG_DECODERS = {OUI_PROFINET: ("profinet", _profinet), OUI_IEEE_802_3: ("ieee_802_3", _ieee_802_3),
                OUI_IEEE_802_1: ("ieee_802_1", _ieee_802_1)}


def org_tlv(ev, data, off, n):
    if n < 4:
        raise Malformed(L, f"organisation-specific TLV of {n} bytes (needs OUI + subtype)")
    oui = (data[off] << 16) | (data[off + 1] << 8) | data[off + 2]
    sub = data[off + 3]
    ev.setdefault("org_oui", []).append(oui)
    known = ORG_DECODERS.get(oui)
    if known is None:
        ev.setdefault("org_unknown", []).append(
            {"oui": oui, "unknown_subtype": sub, "content": colon_hex(data[off + 4:off + n])})
        return
    key, fn = known
    ev.setdefault(key, []).append(fn(sub, data, off + 4, off + n))

