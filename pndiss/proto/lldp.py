"""LLDP (EtherType 0x88CC) with the PROFINET (OUI 00-0E-CF), IEEE 802.3 and 802.1 TLVs.

Layouts follow spec/wire.md §4 and what tshark 4.0 packet-lldp.c shows (field names and
value forms checked with ``tshark -T ek`` on the public captures and on synthetic frames,
tests/test_lldp.py). Keys of the event mirror the tshark field names so that
tests/tshark_map/lldp.json maps them 1:1. Byte strings are colon hex (tshark's FT_BYTES form).
"""
from __future__ import annotations

import ipaddress
import struct
import uuid

from .common import Malformed, ipv4, mac, need
from .mrp import decode as decode_mrp  # noqa: F401  (the analyzer's entry point for EtherType 0x88E3)

L = "lldp"

# TLV types (IEEE 802.1AB; spec/wire.md §4.1)
TLV_NAMES = {0: "End of LLDPDU", 1: "Chassis Id", 2: "Port Id", 3: "Time to Live",
             4: "Port Description", 5: "System Name", 6: "System Description",
             7: "System Capabilities", 8: "Management Address", 127: "Organization Specific"}

# Chassis/Port ID subtypes (spec/wire.md §4.1 table)
CHASSIS_SUBTYPES = {0: "Reserved", 1: "Chassis component", 2: "Interface alias", 3: "Port component",
                    4: "MAC address", 5: "Network address", 6: "Interface name", 7: "Locally assigned"}
PORT_SUBTYPES = {0: "Reserved", 1: "Interface alias", 2: "Port component", 3: "MAC address",
                 4: "Network address", 5: "Interface name", 6: "Agent circuit Id", 7: "Locally assigned"}
# tshark 4.0: the chassis ID of every non-MAC/non-address subtype is FT_BYTES (lldp.chassis.id),
# the port ID a string (lldp.port.id) (spec/wire.md §4.1 quirk; checked on synthetic frames)
CHASSIS_MAC, CHASSIS_NET = 4, 5
PORT_MAC, PORT_NET = 3, 4

# IANA address family numbers used by the network-address subtypes and the management address
ADDR_FAMILIES = {1: "IPv4", 2: "IPv6", 6: "802"}
ADDR_SIZES = {1: 4, 2: 16}

# System capability bits (lldp.tlv.system_cap.* masks, tshark -G fields)
CAP_BITS = (("other", 0x01), ("repeater", 0x02), ("bridge", 0x04), ("wlan_access_pt", 0x08),
            ("router", 0x10), ("telephone", 0x20), ("docsis_cable_device", 0x40), ("station_only", 0x80))

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

_U16 = struct.Struct(">H")
_U32 = struct.Struct(">I")


def _bits(value: int, table) -> dict:
    return {name: int(bool(value & m)) for name, m in table}


def _hex(b: bytes) -> str:
    return mac(b)  # colon hex, the form tshark prints for FT_BYTES


def _text(b: bytes) -> str:
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
            v = _U16.unpack(b)[0]
        elif kind == "u32":
            v = _U32.unpack(b)[0]
        elif kind == "mac":
            v = mac(b)
        elif kind == "uuid":
            v = _guid(b)
        else:
            v = _hex(b)
        out[key] = v
        off += n
    return out


def _oid(b: bytes) -> str:
    """BER object identifier -> dotted text (tshark FT_OID form)."""
    if not b:
        return ""
    parts, acc = [], 0
    for x in b:
        acc = (acc << 7) | (x & 0x7F)
        if not x & 0x80:
            parts.append(acc)
            acc = 0
    if b[-1] & 0x80:
        raise Malformed(L, "management address OID ends inside a sub-identifier")
    first = parts[0]
    head = [min(first // 40, 2), first - 40 * min(first // 40, 2)]
    return ".".join(str(p) for p in head + parts[1:])


def _address(ev: dict, prefix: str, family: int, b: bytes) -> None:
    if family == 1 and len(b) == 4:
        ev[prefix + "ip4"] = ipv4(b)
    elif family == 2 and len(b) == 16:
        ev[prefix + "ip6"] = _ip6(b)
    else:
        ev[prefix + "hex"] = _hex(b)


def _ip6(b: bytes) -> str:
    return str(ipaddress.IPv6Address(bytes(b)))


# -- basic TLVs ------------------------------------------------------------------------------
def _chassis(ev, data, off, n):
    if n < 2:
        raise Malformed(L, f"Chassis ID TLV of {n} bytes (needs subtype + ID)")
    st, b = data[off], data[off + 1:off + n]
    c = {"subtype": st, "subtype_name": CHASSIS_SUBTYPES.get(st, "Reserved")}
    if st == CHASSIS_MAC:
        if len(b) != 6:
            raise Malformed(L, f"Chassis ID MAC of {len(b)} bytes")
        c["id_mac"] = mac(b)
    elif st == CHASSIS_NET:
        c["net_subtype"] = b[0]
        _address(c, "id_", b[0], b[1:])
    else:
        c["id"] = _hex(b)
        c["text"] = _text(b)
    ev["chassis"] = c


def _port(ev, data, off, n):
    if n < 2:
        raise Malformed(L, f"Port ID TLV of {n} bytes (needs subtype + ID)")
    st, b = data[off], data[off + 1:off + n]
    p = {"subtype": st, "subtype_name": PORT_SUBTYPES.get(st, "Reserved")}
    if st == PORT_MAC:
        if len(b) != 6:
            raise Malformed(L, f"Port ID MAC of {len(b)} bytes")
        p["id_mac"] = mac(b)
    elif st == PORT_NET:
        p["net_subtype"] = b[0]
        _address(p, "id_", b[0], b[1:])
    else:
        p["id"] = _text(b)
    ev["port"] = p


def _ttl(ev, data, off, n):
    if n < 2:
        raise Malformed(L, f"TTL TLV of {n} bytes")
    ev["ttl"] = _U16.unpack_from(data, off)[0]


def _caps(ev, data, off, n):
    if n < 4:
        raise Malformed(L, f"System Capabilities TLV of {n} bytes")
    sysc, enc = _U16.unpack_from(data, off)[0], _U16.unpack_from(data, off + 2)[0]
    ev["system_cap"] = {"value": sysc, **_bits(sysc, CAP_BITS)}
    ev["enable_system_cap"] = {"value": enc, **_bits(enc, CAP_BITS)}


def _mgmt(ev, data, off, n):
    end = off + n
    if n < 1:
        raise Malformed(L, "empty Management Address TLV")
    alen = data[off]
    # address string length counts the subtype byte; then if-subtype 1, if-number 4, oid-len 1
    if alen < 1 or off + 1 + alen + 6 > end:
        raise Malformed(L, f"Management Address TLV of {n} bytes with address length {alen}")
    fam = data[off + 1]
    # tshark reads IPv4/IPv6 addresses by family size, whatever the length says: refuse a mismatch
    if ADDR_SIZES.get(fam, alen - 1) != alen - 1:
        raise Malformed(L, f"management address length {alen - 1} does not fit family {fam}")
    m = {"address_len": alen, "address_subtype": fam}
    _address(m, "addr_", data[off + 1], data[off + 2:off + 1 + alen])
    o = off + 1 + alen
    m["interface_subtype"] = data[o]
    m["interface_number"] = _U32.unpack_from(data, o + 1)[0]
    olen = data[o + 5]
    m["obj_len"] = olen
    if olen:
        if o + 6 + olen > end:
            raise Malformed(L, "Management Address OID runs past the TLV")
        m["obj_id"] = _oid(data[o + 6:o + 6 + olen])
    ev.setdefault("mgmt", []).append(m)


# -- organisation-specific TLVs ---------------------------------------------------------------
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
        d["tsn_nme_management_addr"] = _hex(data[off + 2:off + 1 + slen])
    else:
        d["content"] = _hex(data[off:end])
        if sub == 3:
            d["alias"] = _text(data[off:end])
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
        an, caps, mau = data[off], _U16.unpack_from(data, off + 1)[0], _U16.unpack_from(data, off + 3)[0]
        d["mac_phy_auto_neg_status"] = {"value": an, "supported": an & 1, "enabled": (an >> 1) & 1}
        # tshark also shows the capability word in "inverse (wrong) bit order"
        inv = int(f"{caps:016b}"[::-1], 2)
        d["pmd_auto_neg_advertised_caps"] = {"value": caps, **_bits(caps, PMD_CAPS)}
        d["pmd_auto_neg_advertised_caps_inv"] = _bits(inv, PMD_CAPS)
        d["pmd_mau_type"] = mau
        d["pmd_mau_type_name"] = MAU_TYPES.get(mau, "Unknown")
    elif sub == 2:
        if n < 3:
            raise Malformed(L, "IEEE 802.3 Power via MDI TLV too short")
        s = data[off]
        d["mdi_power_support"] = {"value": s, **_bits(s, MDI_POWER_BITS)}
        d["mdi_pse_pair"] = data[off + 1]
        d["mdi_power_class"] = data[off + 2]
        if n >= 8:  # 802.3at extension: type/source/priority, requested and allocated power
            t = data[off + 3]
            d["mdi_power_type"] = t >> 6
            d["mdi_power_source"] = (t >> 4) & 3
            d["mdi_power_priority"] = t & 0xF
            d["mdi_pde_requested"] = _U16.unpack_from(data, off + 4)[0]
            d["mdi_pse_allocated"] = _U16.unpack_from(data, off + 6)[0]
    elif sub == 3:
        if n < 5:
            raise Malformed(L, "IEEE 802.3 Link Aggregation TLV too short")
        s = data[off]
        d["aggregation_status"] = {"value": s, "cap": s & 1, "enabled": (s >> 1) & 1}
        d["aggregated_port_id"] = _U32.unpack_from(data, off + 1)[0]
    elif sub == 4:
        if n < 2:
            raise Malformed(L, "IEEE 802.3 Maximum Frame Size TLV too short")
        d["max_frame_size"] = _U16.unpack_from(data, off)[0]
    elif sub == 5:
        if n < 10:
            raise Malformed(L, "IEEE 802.3 EEE TLV too short")
        d["eee"] = {k: _U16.unpack_from(data, off + 2 * i)[0] for i, k in enumerate(EEE_FIELDS)}
    else:
        d["content"] = _hex(data[off:end])
    return d


def _ieee_802_1(sub: int, data: bytes, off: int, end: int) -> dict:
    d = {"subtype": sub, "name": IEEE_802_1_SUBTYPES.get(sub, f"Unknown (0x{sub:02x})")}
    n = end - off
    short = Malformed(L, f"IEEE 802.1 {d['name']} TLV too short")
    if sub == 1:
        if n < 2:
            raise short
        d["port_vlan_id"] = _U16.unpack_from(data, off)[0]
    elif sub == 2:
        if n < 3:
            raise short
        f = data[off]
        d["port_and_vlan_id_flag"] = {"value": f, "supported": (f >> 1) & 1, "enabled": (f >> 2) & 1}
        d["port_proto_vlan_id"] = _U16.unpack_from(data, off + 1)[0]
    elif sub == 3:
        if n < 3 or 3 + data[off + 2] > n:
            raise short
        d["vlan_id"] = _U16.unpack_from(data, off)[0]
        d["vlan_name_len"] = data[off + 2]
        d["vlan_name"] = _text(data[off + 3:off + 3 + data[off + 2]])
    elif sub == 4:
        if n < 1 or 1 + data[off] > n:
            raise short
        d["proto_id_length"] = data[off]
        d["proto_id"] = _hex(data[off + 1:off + 1 + data[off]])
    elif sub == 7:
        if n < 5:
            raise short
        s = data[off]
        d["aggregation_status"] = {"value": s, "cap": s & 1, "enabled": (s >> 1) & 1, "porttype": (s >> 2) & 3}
        d["aggregated_port_id"] = _U32.unpack_from(data, off + 1)[0]
    else:
        d["content"] = _hex(data[off:end])
    return d


ORG_DECODERS = {OUI_PROFINET: ("profinet", _profinet), OUI_IEEE_802_3: ("ieee_802_3", _ieee_802_3),
                OUI_IEEE_802_1: ("ieee_802_1", _ieee_802_1)}


def _org(ev, data, off, n):
    if n < 4:
        raise Malformed(L, f"organisation-specific TLV of {n} bytes (needs OUI + subtype)")
    oui = (data[off] << 16) | (data[off + 1] << 8) | data[off + 2]
    sub = data[off + 3]
    ev.setdefault("org_oui", []).append(oui)
    known = ORG_DECODERS.get(oui)
    if known is None:
        ev.setdefault("org_unknown", []).append(
            {"oui": oui, "unknown_subtype": sub, "content": _hex(data[off + 4:off + n])})
        return
    key, fn = known
    ev.setdefault(key, []).append(fn(sub, data, off + 4, off + n))


def _string(key):
    def f(ev, data, off, n):
        ev[key] = _text(data[off:off + n])
    return f


TLV_DECODERS = {1: _chassis, 2: _port, 3: _ttl, 4: _string("port_desc"), 5: _string("system_name"),
                6: _string("system_desc"), 7: _caps, 8: _mgmt, 127: _org}


def decode(data: bytes, off: int) -> dict:
    """LLDPDU starting at ``data[off]`` (first TLV) -> event fields (raises Malformed)."""
    ev: dict = {"tlv_type": [], "tlv_len": []}
    end = len(data)
    while True:
        need(data, off, 2, L, "TLV header")
        hdr = _U16.unpack_from(data, off)[0]
        t, n = hdr >> 9, hdr & 0x1FF
        off += 2
        if off + n > end:
            raise Malformed(L, f"{TLV_NAMES.get(t, f'TLV type {t}')} TLV of {n} bytes runs past the frame")
        ev["tlv_type"].append(t)
        ev["tlv_len"].append(n)
        if t == 0:
            break
        fn = TLV_DECODERS.get(t)
        if fn is None:
            ev.setdefault("unknown_tlv", []).append({"type": t, "hex": data[off:off + n].hex()})
        else:
            fn(ev, data, off, n)
        off += n
    for mandatory, idx in (("chassis", 0), ("port", 1), ("ttl", 2)):
        if mandatory not in ev or len(ev["tlv_type"]) <= idx or ev["tlv_type"][idx] != idx + 1:
            raise Malformed(L, f"mandatory TLV {TLV_NAMES[idx + 1]} missing or out of order")
    ev["station_info"] = _station(ev)  # 'station' is a NameOfStation string in every event kind
    if isinstance(ev["station_info"].get("name"), str):
        ev["station"] = ev["station_info"]["name"]
    return ev


def _station(ev: dict) -> dict:
    """Facts about the sender for the station table (analyzer.stations.from_lldp)."""
    c, p = ev["chassis"], ev["port"]
    st: dict = {"chassis_id": c.get("text") or c.get("id_mac") or c.get("id_ip4") or c.get("id_ip6")
                or c.get("id_hex"), "port_id": p.get("id") or p.get("id_mac") or p.get("id_ip4")}
    pn = ev.get("profinet")
    # PROFINET puts NameOfStation into a locally assigned chassis ID; the older style sends
    # "port-xxx.<NameOfStation>" as port ID with a descriptive chassis ID (spec/wire.md §4.2)
    if pn:
        port_id = p.get("id") or ""
        if p["subtype"] == 7 and "." in port_id:
            st["name"] = port_id.split(".", 1)[1]
        elif c["subtype"] == 7 and c.get("text"):
            st["name"] = c["text"]
    if "system_name" in ev:
        st["system_name"] = ev["system_name"]
    for m in ev.get("mgmt", ()):
        if "addr_ip4" in m:
            st["mgmt_ip"] = m["addr_ip4"]
            break
    for d in pn or ():
        if "cm_mac_add" in d:
            st["chassis_mac"] = d["cm_mac_add"]
    return {k: v for k, v in st.items() if v is not None}
