"""LLDP (EtherType 0x88CC) with the PROFINET (OUI 00-0E-CF), IEEE 802.3 and 802.1 TLVs.

Layouts follow spec/wire.md §4 and what tshark 4.0 packet-lldp.c shows (field names and
value forms checked with ``tshark -T ek`` on the public captures and on synthetic frames,
tests/test_lldp.py). Keys of the event mirror the tshark field names so that
tests/tshark_map/lldp.json maps them 1:1. Byte strings are colon hex (tshark's FT_BYTES form).
This module walks the LLDPDU and decodes the basic TLVs; the organisation-specific ones
(PROFINET, IEEE 802.3/802.1) are lldp_org.py's.
"""
from __future__ import annotations

import ipaddress

from .common import U16, U32, Malformed, ipv4, mac, need
from .lldp_org import L, bits, colon_hex, org_tlv, text
from .mrp import decode as decode_mrp  # noqa: F401  (the analyzer's entry point for EtherType 0x88E3)

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
        ev[prefix + "hex"] = colon_hex(b)


def _ip6(b: bytes) -> str:
    return str(ipaddress.IPv6Address(bytes(b)))


# -- basic TLVs ------------------------------------------------------------------------------
def _id(data, off, n, what: str, names: dict, mac_subtype: int, net_subtype: int) -> tuple[dict, bytes]:
    """Chassis/Port ID: the subtype, and the ID when it is a MAC or a network address (the other
    subtypes are the caller's: chassis and port show them differently)."""
    if n < 2:
        raise Malformed(L, f"{what} TLV of {n} bytes (needs subtype + ID)")
    st, b = data[off], data[off + 1:off + n]
    d = {"subtype": st, "subtype_name": names.get(st, "Reserved")}
    if st == mac_subtype:
        if len(b) != 6:
            raise Malformed(L, f"{what} MAC of {len(b)} bytes")
        d["id_mac"] = mac(b)
    elif st == net_subtype:
        d["net_subtype"] = b[0]
        _address(d, "id_", b[0], b[1:])
    return d, b


def _chassis(ev, data, off, n):
    c, b = _id(data, off, n, "Chassis ID", CHASSIS_SUBTYPES, CHASSIS_MAC, CHASSIS_NET)
    if c["subtype"] not in (CHASSIS_MAC, CHASSIS_NET):
        c["id"] = colon_hex(b)
        c["text"] = text(b)
    ev["chassis"] = c


def _port(ev, data, off, n):
    p, b = _id(data, off, n, "Port ID", PORT_SUBTYPES, PORT_MAC, PORT_NET)
    if p["subtype"] not in (PORT_MAC, PORT_NET):
        p["id"] = text(b)
    ev["port"] = p


def _ttl(ev, data, off, n):
    if n < 2:
        raise Malformed(L, f"TTL TLV of {n} bytes")
    ev["ttl"] = U16.unpack_from(data, off)[0]


def _caps(ev, data, off, n):
    if n < 4:
        raise Malformed(L, f"System Capabilities TLV of {n} bytes")
    sysc, enc = U16.unpack_from(data, off)[0], U16.unpack_from(data, off + 2)[0]
    ev["system_cap"] = {"value": sysc, **bits(sysc, CAP_BITS)}
    ev["enable_system_cap"] = {"value": enc, **bits(enc, CAP_BITS)}


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
    m["interface_number"] = U32.unpack_from(data, o + 1)[0]
    olen = data[o + 5]
    m["obj_len"] = olen
    if olen:
        if o + 6 + olen > end:
            raise Malformed(L, "Management Address OID runs past the TLV")
        m["obj_id"] = _oid(data[o + 6:o + 6 + olen])
    ev.setdefault("mgmt", []).append(m)


def _string(key):
    def f(ev, data, off, n):
        ev[key] = text(data[off:off + n])
    return f


TLV_DECODERS = {1: _chassis, 2: _port, 3: _ttl, 4: _string("port_desc"), 5: _string("system_name"),
                6: _string("system_desc"), 7: _caps, 8: _mgmt, 127: org_tlv}


def decode(data: bytes, off: int) -> dict:
    """LLDPDU starting at ``data[off]`` (first TLV) -> event fields (raises Malformed)."""
    ev: dict = {"tlv_type": [], "tlv_len": []}
    end = len(data)
    while True:
        need(data, off, 2, L, "TLV header")
        hdr = U16.unpack_from(data, off)[0]
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
