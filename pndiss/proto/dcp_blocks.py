"""PN-DCP blocks: the block header (Option, Suboption, DCPBlockLength, BlockInfo/BlockQualifier)
and the value decoders per (option, suboption). Field names follow tshark 4.0's ``pn_dcp.*``
fields (docs/dcp.md lists them); the PDU header is dcp.py's.
"""
from __future__ import annotations

import uuid

from .common import Malformed, ipv4, mac
from .dcp_tables import (BLOCK_ERRORS, DEVICE_INITIATIVE, DHCP_CONTROL, IP_BLOCK_INFO, LAYER, OPTIONS, PREFIXED,
                         RESET_QUALIFIER, ROLE_BITS, RSI_BITS, SET, SIGNAL_VALUES, SUBOPTION_FIELD, SUBOPTIONS)


def u16(b: bytes, o: int) -> int:
    return (b[o] << 8) | b[o + 1]


def _string(v: bytes) -> str:
    """tshark's ENC_ASCII view: the value ends at a NUL, non-ASCII bytes become U+FFFD."""
    return v.split(b"\0", 1)[0].decode("ascii", "replace")


def _fixed(v: bytes, n: int, what: str) -> None:
    if len(v) < n:
        raise Malformed(LAYER, f"{what} value has {len(v)} bytes, needs {n}")


def _rest(d: dict, v: bytes, n: int) -> dict:
    """Bytes after a fixed-size value (tshark would misread them as the next block)."""
    if len(v) > n:
        d["extra"] = v[n:].hex()
    return d


def suboption_entry(option: int, suboption: int) -> dict:
    """An Option/Suboption pair as in Get requests, Device Options and Control/Response."""
    return {"option": option, "suboption": suboption,
            SUBOPTION_FIELD.get(option, "suboption_manuf"): suboption}


# -- value decoders: bytes after BlockInfo/BlockQualifier -> fields ---------------------------
def _ip_mac(v):
    _fixed(v, 6, "IP/MAC")
    return _rest({"mac_address": mac(v[:6])}, v, 6)


def _ip_param(v):
    _fixed(v, 12, "IP parameter")
    return _rest({"ip": ipv4(v[0:4]), "netmask": ipv4(v[4:8]), "gateway": ipv4(v[8:12])}, v, 12)


def _ip_suite(v):
    # IP, mask, gateway + 4 DNS servers; tshark reuses the ip/mask/gateway/gateway fields for
    # DNS 1-4 (spec/wire.md §8), hence dns1..dns4 next to the plain list.
    _fixed(v, 28, "Full IP suite")
    d = {"ip": ipv4(v[0:4]), "netmask": ipv4(v[4:8]), "gateway": ipv4(v[8:12])}
    dns = [ipv4(v[o:o + 4]) for o in (12, 16, 20, 24)]
    d["dns"] = dns
    d.update(dns1=dns[0], dns2=dns[1], dns3=dns[2], dns4=dns[3])
    return _rest(d, v, 28)


def _vendor_value(v):
    return {"devicevendorvalue": _string(v)}


def _name(v):
    return {"nameofstation": _string(v)}


def _alias(v):
    return {"aliasname": _string(v)}


def _device_id(v):
    _fixed(v, 4, "Device ID")
    return _rest({"vendor_id": u16(v, 0), "device_id": u16(v, 2)}, v, 4)


def _role(v):
    _fixed(v, 2, "Device Role")
    r = v[0]
    return _rest({"device_role": r, "reserved8": v[1],
                  "roles": [n for bit, n in ROLE_BITS if r & bit]}, v, 2)


def _options(v):
    if len(v) & 1:
        raise Malformed(LAYER, f"Device Options list has an odd length ({len(v)})")
    return {"options": [suboption_entry(v[i], v[i + 1]) for i in range(0, len(v), 2)]}


def _instance(v):
    _fixed(v, 2, "Device Instance")
    return _rest({"instance_high": v[0], "instance_low": v[1]}, v, 2)


def _oem_id(v):
    _fixed(v, 4, "OEM Device ID")
    return _rest({"oem_vendor_id": u16(v, 0), "oem_device_id": u16(v, 2)}, v, 4)


def _rsi(v):
    _fixed(v, 2, "RSI Properties")
    x = u16(v, 0)
    d = {"rsi_properties_value": x, "rsi": {n: bool(x >> i & 1) for i, n in enumerate(RSI_BITS)}}
    d["rsi"]["otherbits"] = x >> 6
    return _rest(d, v, 2)


def _dhcp_client_id(v):
    # option code, length, then 1 byte (1 = client ID is the MAC, else NameOfStation) or
    # an arbitrary client ID (length > 1) (spec/wire.md §3.3)
    _fixed(v, 2, "DHCP client identifier")
    n = v[1]
    d = {"dhcp_option_code": v[0], "dhcp_parameter_length": n}
    if n:
        _fixed(v, 2 + n, "DHCP client identifier")
        d["dhcp_parameter_data"] = v[2]
        if n == 1:
            d["client_id_kind"] = "MAC address" if v[2] == 1 else "NameOfStation"
        else:
            d["client_id_kind"] = "arbitrary"
            d["dhcp_client_id"] = _string(v[3:2 + n])
    return _rest(d, v, 2 + n)


def _dhcp_control(v):
    _fixed(v, 3, "Control DHCP")
    return _rest({"dhcp_option_code": v[0], "dhcp_parameter_length": v[1],
                  "dhcp_parameter_data": v[2], "dhcp_control": DHCP_CONTROL.get(v[2], "reserved")}, v, 3)


def _qualifier(v):
    _fixed(v, 2, "Control")
    q = u16(v, 0)
    return _rest({"block_qualifier": q}, v, 2)


def _signal(v):
    _fixed(v, 4, "Control/Signal")
    s = u16(v, 2)
    return _rest({"block_qualifier": u16(v, 0), "signal_value": s,
                  "signal": SIGNAL_VALUES.get(s, "reserved")}, v, 4)


def _response(v):
    _fixed(v, 3, "Control/Response")
    e = v[2]
    return _rest({"response": suboption_entry(v[0], v[1]), "block_error": e,
                  "block_error_text": BLOCK_ERRORS.get(e, "reserved")}, v, 3)


def _factory_reset(v):
    _fixed(v, 2, "Reset Factory Settings")
    q = u16(v, 0)
    return _rest({"block_qualifier_reset": q, "reset": "Default" if q == 0 else "reserved"}, v, 2)


def _reset_to_factory(v):
    _fixed(v, 2, "Reset to Factory")
    q = u16(v, 0)
    return _rest({"block_qualifier_reset": q, "reset": RESET_QUALIFIER.get(q, "reserved")}, v, 2)


def _initiative(v):
    _fixed(v, 2, "Device Initiative")
    x = u16(v, 0)
    return _rest({"deviceinitiative_value": x,
                  "deviceinitiative": DEVICE_INITIATIVE.get(x, "reserved")}, v, 2)


def _uuid(v: bytes) -> str:
    return str(uuid.UUID(bytes=bytes(v[:16])))


def _tsn_domain(v):
    _fixed(v, 16, "TSN Domain Name")
    return {"tsn_domain_uuid": _uuid(v), "tsn_domain_name": _string(v[16:])}


def _tsn_prio(v):
    _fixed(v, 2, "NME Manager")
    return _rest({"nme_prio": u16(v, 0)}, v, 2)


def _tsn_param_uuid(v):
    _fixed(v, 16, "NME Parameter UUID")
    return _rest({"nme_parameter_uuid": _uuid(v)}, v, 16)


def _tsn_agent(v):
    _fixed(v, 16, "NME Agent")
    return _rest({"nme_agent": _uuid(v)}, v, 16)


def _tsn_cim(v):
    # CIM interface VDI: VendorID, DeviceID (tshark splits each into high/low bytes),
    # InstanceHigh, InstanceLow
    _fixed(v, 6, "CIM Interface")
    return _rest({"cim_vendor_id": u16(v, 0), "cim_device_id": u16(v, 2),
                  "vendor_id_high": v[0], "vendor_id_low": v[1], "device_id_high": v[2],
                  "device_id_low": v[3], "instance_id_high": v[4], "instance_id_low": v[5]}, v, 6)


VALUE_DECODERS = {
    (1, 1): _ip_mac, (1, 2): _ip_param, (1, 3): _ip_suite,
    (2, 1): _vendor_value, (2, 2): _name, (2, 3): _device_id, (2, 4): _role, (2, 5): _options,
    (2, 6): _alias, (2, 7): _instance, (2, 8): _oem_id, (2, 10): _rsi,
    (3, 61): _dhcp_client_id, (3, 255): _dhcp_control,
    (5, 1): _qualifier, (5, 2): _qualifier, (5, 3): _signal, (5, 4): _response,
    (5, 5): _factory_reset, (5, 6): _reset_to_factory,
    (7, 1): _tsn_domain, (7, 2): _tsn_prio, (7, 3): _tsn_param_uuid, (7, 4): _tsn_agent,
    (7, 5): _tsn_cim,
}


def decode_block(data: bytes, o: int, end: int, prefix: str | None, service_id: int) -> tuple[dict, int]:
    """One block at data[o:end]; returns (block, offset after the block and its pad)."""
    if o + 4 > end:
        raise Malformed(LAYER, f"block header truncated at offset {o} (DCPDataLength ends at {end})")
    opt, sub = data[o], data[o + 1]
    blen = u16(data, o + 2)
    vend = o + 4 + blen
    if vend > end:
        raise Malformed(LAYER, f"block {opt}/{sub} of {blen} bytes runs past DCPDataLength (offset {o})")
    b = {"option": opt, "suboption": sub, "block_length": blen,
         "option_name": OPTIONS.get(opt, "Manufacturer specific" if 0x80 <= opt < 0xFF else "Reserved")}
    fam = SUBOPTION_FIELD.get(opt)
    if fam is not None:
        b[fam] = sub
        b["suboption_name"] = SUBOPTIONS[opt].get(sub, "Unknown")
    elif 0x80 <= opt < 0xFF:
        b["suboption_manuf"] = sub
    else:
        b["reserved_option"] = True  # tshark 4.0 misparses these (reads the option byte only)
    v = data[o + 4:vend]
    has_prefix = prefix is not None and (opt in PREFIXED or (opt == 1 and sub in (1, 2, 3)))
    if has_prefix:
        if blen < 2:
            raise Malformed(LAYER, f"block {opt}/{sub} too short for its {prefix} ({blen} bytes)")
        p = u16(v, 0)
        v = v[2:]
        if prefix == "block_qualifier":
            b["block_qualifier"] = p
        elif (opt, sub) == (1, 2):  # IP parameter has its own BlockInfo (spec/wire.md §3.2)
            b["ip_block_info"] = p
            b["ip_status"] = IP_BLOCK_INFO.get(p, "reserved")
            b["ip_conflict"] = bool(p & 0x80)
        else:
            b["block_info"] = p
    if opt == 5 and service_id == SET and blen == 0:
        b["erroneous"] = True  # tshark: "Erroneous DCPSet block"
    elif opt == 6:
        b.update(_initiative(v))  # tshark decodes the value whatever the suboption
    elif opt == 0xFF and sub == 0xFF:
        if v:  # the ALL selector has no value; keep stray bytes visible
            b["undecoded"] = v.hex()
    else:
        dec = VALUE_DECODERS.get((opt, sub))
        if dec is not None:
            b.update(dec(v))
        elif v:
            b["undecoded"] = v.hex()
    nxt = vend + (blen & 1)  # odd blocks are followed by one pad byte
    return b, nxt
