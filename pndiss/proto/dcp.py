"""PN-DCP (FrameIDs 0xFEFC-0xFEFF): Identify / Get / Set / Hello requests and responses.

``decode(data, off, frame_id)`` reads the PDU that starts at ``data[off]`` (the byte after the
FrameID) and runs to ``len(data)`` (Ethernet pad included; DCPDataLength bounds the blocks).
Field names follow tshark 4.0's ``pn_dcp.*`` fields so tests/tshark_map/dcp.json maps them 1:1.
Layout facts: spec/wire.md §3 and tshark 4.0.17 ``packet-pn-dcp.c`` behaviour, checked on
synthetic frames (tests/test_dcp.py). Naming rules: spec/network.md §2.1.

``DcpTracker`` keeps the cross-frame state for DCP-NAME-DUPLICATE and IP-ASSIGN-OCCUPIED.
"""
from __future__ import annotations

import re
import uuid

from .. import rules
from .common import Malformed, ipv4, mac

LAYER = "pn_dcp"

# ServiceID / ServiceType (spec/wire.md §3.1; tshark pn_dcp.service_id / service_type)
SERVICES = {0: "reserved", 1: "Manufacturer specific", 2: "Manufacturer specific",
            3: "Get", 4: "Set", 5: "Identify", 6: "Hello"}
GET, SET, IDENTIFY, HELLO = 3, 4, 5, 6
SERVICE_TYPES = {0: "Request", 1: "Response Success", 5: "Response - Request not supported"}

# Options (spec/wire.md §3.3; tshark pn_dcp.option). 0x80-0xFE: manufacturer specific.
OPTIONS = {0: "Reserved", 1: "IP", 2: "Device properties", 3: "DHCP", 4: "Reserved",
           5: "Control", 6: "Device Initiative", 7: "TSN Domain", 0xFF: "All Selector"}

# tshark gives every option's suboption byte its own field (pn_dcp.suboption_ip, ..._device,
# ...); options it has no table for use pn_dcp.suboption_manuf (tshark 4.0 dissect_PNDCP_Option).
SUBOPTION_FIELD = {1: "suboption_ip", 2: "suboption_device", 3: "suboption_dhcp",
                   5: "suboption_control", 6: "suboption_deviceinitiative", 7: "suboption_tsn",
                   0xFF: "suboption_all"}

# Suboption names per option (spec/wire.md §3.3-3.4; tshark value tables)
SUBOPTIONS = {
    1: {1: "MAC address", 2: "IP parameter", 3: "Full IP suite"},
    2: {1: "Manufacturer specific (Type of Station)", 2: "Name of Station", 3: "Device ID",
        4: "Device Role", 5: "Device Options", 6: "Alias Name", 7: "Device Instance",
        8: "OEM Device ID", 10: "RSI Properties"},
    3: {12: "Host name", 43: "Vendor specific", 54: "Server identifier",
        55: "Parameter request list", 60: "Class identifier", 61: "DHCP client identifier",
        81: "FQDN, Fully Qualified Domain Name", 97: "UUID/GUID-based Client",
        255: "Control DHCP for address resolution"},
    5: {1: "Start Transaction", 2: "End Transaction", 3: "Signal", 4: "Response",
        5: "Reset Factory Settings", 6: "Reset to Factory"},
    6: {1: "Device Initiative"},
    7: {1: "TSN Domain Name", 2: "NME Manager", 3: "NME Parameter UUID", 4: "NME Agent",
        5: "CIM Interface"},
    0xFF: {0xFF: "ALL Selector"},
}

# Options whose blocks carry BlockInfo/BlockQualifier (tshark 4.0: IP only for its three known
# suboptions, Device/DHCP/DeviceInitiative/TSN always; Control, All, manufacturer never).
PREFIXED = {2, 3, 6, 7}

# IP-parameter BlockInfo (spec/wire.md §3.2; bit 7 = address conflict detected)
IP_BLOCK_INFO = {0: "IP not set", 1: "IP set", 2: "IP set by DHCP",
                 0x80: "IP not set (address conflict detected)",
                 0x81: "IP set (address conflict detected)",
                 0x82: "IP set by DHCP (address conflict detected)"}
BLOCK_QUALIFIER = {0: "Use the value temporary", 1: "Save the value permanent"}
# Reset to Factory qualifier (spec/wire.md §3.4, tshark pn_dcp.block_qualifier_reset)
RESET_QUALIFIER = {2: "Reset application data", 3: "Reset application data",
                   4: "Reset communication parameter", 5: "Reset communication parameter",
                   6: "Reset engineering parameter", 7: "Reset engineering parameter",
                   8: "Resets all stored data", 9: "Resets all stored data",
                   0x0A: "Reset engineering parameter", 0x0B: "Reset engineering parameter",
                   0x10: "Resets all stored data in the IOD or IOC to its factory values",
                   0x11: "Resets all stored data in the IOD or IOC to its factory values",
                   0x12: "Reset and restore data", 0x13: "Reset and restore data"}
BLOCK_ERRORS = {0: "Ok", 1: "Option unsupported", 2: "Suboption unsupported or no DataSet available",
                3: "Suboption not set", 4: "Resource error", 5: "SET not possible by local reasons",
                6: "In operation, SET not possible"}
SIGNAL_VALUES = {0x0100: "Flash once"}
# DeviceRoleDetails bits (spec/wire.md §3.7)
ROLE_BITS = ((0x01, "IO-Device"), (0x02, "IO-Controller"), (0x04, "IO-Multidevice"),
             (0x08, "PN-Supervisor"))
# RSI properties bits (spec/wire.md §3.3; tshark ..._rsi_properties_value.bit0-5)
RSI_BITS = ("ip_stack", "clrpc_interface", "rsi_ar_interface", "rsi_ar_read_implicit",
            "rsi_cim_interface", "rsi_cim_read_implicit")
DHCP_CONTROL = {0: "Don't use DHCP", 1: "Don't use DHCP, DHCP options reset to factory values",
                2: "Use DHCP with the given set of DHCP options"}
DEVICE_INITIATIVE = {0: "No Hello after power on", 1: "Hello after power on"}


def _u16(b: bytes, o: int) -> int:
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


def _suboption_entry(option: int, suboption: int) -> dict:
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
    return _rest({"vendor_id": _u16(v, 0), "device_id": _u16(v, 2)}, v, 4)


def _role(v):
    _fixed(v, 2, "Device Role")
    r = v[0]
    return _rest({"device_role": r, "reserved8": v[1],
                  "roles": [n for bit, n in ROLE_BITS if r & bit]}, v, 2)


def _options(v):
    if len(v) & 1:
        raise Malformed(LAYER, f"Device Options list has an odd length ({len(v)})")
    return {"options": [_suboption_entry(v[i], v[i + 1]) for i in range(0, len(v), 2)]}


def _instance(v):
    _fixed(v, 2, "Device Instance")
    return _rest({"instance_high": v[0], "instance_low": v[1]}, v, 2)


def _oem_id(v):
    _fixed(v, 4, "OEM Device ID")
    return _rest({"oem_vendor_id": _u16(v, 0), "oem_device_id": _u16(v, 2)}, v, 4)


def _rsi(v):
    _fixed(v, 2, "RSI Properties")
    x = _u16(v, 0)
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
    q = _u16(v, 0)
    return _rest({"block_qualifier": q}, v, 2)


def _signal(v):
    _fixed(v, 4, "Control/Signal")
    s = _u16(v, 2)
    return _rest({"block_qualifier": _u16(v, 0), "signal_value": s,
                  "signal": SIGNAL_VALUES.get(s, "reserved")}, v, 4)


def _response(v):
    _fixed(v, 3, "Control/Response")
    e = v[2]
    return _rest({"response": _suboption_entry(v[0], v[1]), "block_error": e,
                  "block_error_text": BLOCK_ERRORS.get(e, "reserved")}, v, 3)


def _factory_reset(v):
    _fixed(v, 2, "Reset Factory Settings")
    q = _u16(v, 0)
    return _rest({"block_qualifier_reset": q, "reset": "Default" if q == 0 else "reserved"}, v, 2)


def _reset_to_factory(v):
    _fixed(v, 2, "Reset to Factory")
    q = _u16(v, 0)
    return _rest({"block_qualifier_reset": q, "reset": RESET_QUALIFIER.get(q, "reserved")}, v, 2)


def _initiative(v):
    _fixed(v, 2, "Device Initiative")
    x = _u16(v, 0)
    return _rest({"deviceinitiative_value": x,
                  "deviceinitiative": DEVICE_INITIATIVE.get(x, "reserved")}, v, 2)


def _uuid(v: bytes) -> str:
    return str(uuid.UUID(bytes=bytes(v[:16])))


def _tsn_domain(v):
    _fixed(v, 16, "TSN Domain Name")
    return {"tsn_domain_uuid": _uuid(v), "tsn_domain_name": _string(v[16:])}


def _tsn_prio(v):
    _fixed(v, 2, "NME Manager")
    return _rest({"nme_prio": _u16(v, 0)}, v, 2)


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
    return _rest({"cim_vendor_id": _u16(v, 0), "cim_device_id": _u16(v, 2),
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


def _decode_block(data: bytes, o: int, end: int, prefix: str | None, service_id: int) -> tuple[dict, int]:
    """One block at data[o:end]; returns (block, offset after the block and its pad)."""
    if o + 4 > end:
        raise Malformed(LAYER, f"block header truncated at offset {o} (DCPDataLength ends at {end})")
    opt, sub = data[o], data[o + 1]
    blen = _u16(data, o + 2)
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
        p = _u16(v, 0)
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


def decode(data: bytes, off: int, frame_id: int) -> dict:
    """Decode the DCP PDU at data[off:] (after the FrameID). Raises Malformed on bad input."""
    if len(data) - off < 10:
        raise Malformed(LAYER, f"header needs 10 bytes, {max(len(data) - off, 0)} left")
    sid, stype = data[off], data[off + 1]
    xid = int.from_bytes(data[off + 2:off + 6], "big")
    dlen = _u16(data, off + 8)
    d = {"service_id": sid, "service_type": stype, "xid": xid,
         "service": SERVICES.get(sid, "reserved"),
         "service_type_name": SERVICE_TYPES.get(stype, "reserved"), "data_length": dlen}
    if sid == IDENTIFY and stype == 0:
        d["response_delay"] = _u16(data, off + 6)  # multicast header
    else:
        d["reserved16"] = _u16(data, off + 6)
    start = off + 10
    end = start + dlen
    if end > len(data):
        raise Malformed(LAYER, f"DCPDataLength {dlen} exceeds the {len(data) - start} bytes left")
    blocks: list[dict] = []
    d["blocks"] = blocks
    if sid not in (GET, SET, IDENTIFY, HELLO) or stype not in SERVICE_TYPES:
        d["undecoded"] = True  # tshark stops here too
        return d
    response = stype != 0
    if sid == GET and not response:  # Get request: Option/Suboption pairs, no lengths
        if dlen & 1:
            raise Malformed(LAYER, f"Get request with an odd DCPDataLength ({dlen})")
        d["selectors"] = [_suboption_entry(data[i], data[i + 1]) for i in range(start, end, 2)]
        return d
    if (sid == IDENTIFY and response) or (sid == HELLO and not response) or (sid == GET and response):
        prefix = "block_info"
    elif sid == SET and not response:
        prefix = "block_qualifier"
    else:
        prefix = None  # Identify filters, Set responses, Hello "responses"
    o = start
    while o < end:
        b, o = _decode_block(data, o, end, prefix, sid)
        blocks.append(b)
    station = _station(d, sid, response)
    if station:  # the object under its own name: 'station' is a NameOfStation string in every event kind
        d["station_info"] = station
        if isinstance(station.get("name"), str):
            d["station"] = station["name"]
    events = _name_events(d, sid, response)
    if events:
        d["events"] = events
    return d


# Block fields -> Stations keys (stations.py: a Set request describes its target, the rest
# describe their sender; Identify requests carry filters, not facts)
STATION_FIELDS = {"nameofstation": "name", "ip": "ip", "netmask": "netmask", "gateway": "gateway",
                  "vendor_id": "vendor_id", "device_id": "device_id", "devicevendorvalue": "type_of_station",
                  "aliasname": "alias", "oem_vendor_id": "oem_vendor_id", "oem_device_id": "oem_device_id"}


def _station(d: dict, sid: int, response: bool) -> dict:
    if not ((response and d["service_type"] == 1 and sid in (IDENTIFY, GET))
            or (not response and sid in (HELLO, SET))):
        return {}
    st = {}
    for b in d["blocks"]:
        if b.get("erroneous"):
            continue
        for k, sk in STATION_FIELDS.items():
            if k in b:
                st[sk] = b[k]
        if "device_role" in b:
            st["role"] = b["device_role"]
    return st


# -- NameOfStation rules (spec/network.md §2.1; catalogue rule DCP-NAME-INVALID) --------------
MAX_NAME = 127   # Lika manual (000_37bf2397999f1108.txt:956-968); IEC allows 240 octets [AMBIGUOUS]
MAX_LABEL = 63
_LABEL_OK = re.compile(r"[A-Za-z0-9-]*")
_PORT_NAME = re.compile(r"port-\d{3}(-\d{5})?")
_IPV4_LIKE = re.compile(r"\d+\.\d+\.\d+\.\d+")


def name_problems(name: str) -> list[str]:
    """Why ``name`` breaks the NameOfStation rules (empty list = fine). An empty name is a
    reset, not an error. Letters of either case are accepted (the manuals say "letters";
    the IEC lower-case rule is [UNVERIFIED] in spec/wire.md §3.6)."""
    if name == "":
        return []
    probs = []
    if len(name) > MAX_NAME:
        probs.append(f"{len(name)} characters (more than {MAX_NAME})")
    bad = sorted({c for c in name if not (c == "." or _LABEL_OK.fullmatch(c))})
    if bad:
        probs.append("characters other than letters, digits, '-' and '.': " + " ".join(repr(c) for c in bad))
    if name.startswith("-") or name.endswith("-"):
        probs.append("starts or ends with '-'")
    labels = name.split(".")
    last = len(labels) - 1
    for i, label in enumerate(labels):
        if label == "":
            probs.append("empty label (leading, trailing or double '.')")
            continue
        if len(label) > MAX_LABEL:
            probs.append(f"label of {len(label)} characters (more than {MAX_LABEL})")
        # DNS labels: no '-' at either end (the name's own ends are reported above)
        if (i > 0 and label[0] == "-") or (i < last and label[-1] == "-"):
            probs.append(f"label {label!r} starts or ends with '-'")
    # IEC 61158-6-10 extras quoted in spec/wire.md §3.6 [UNVERIFIED there]: not "port-xyz",
    # not an IPv4 literal
    if _PORT_NAME.fullmatch(name.split(".")[0].lower()):
        probs.append("has the form of a port name (port-xyz)")
    if _IPV4_LIKE.fullmatch(name):
        probs.append("has the form of an IPv4 address")
    return probs


def violation_event(rule: str, message: str, **extra) -> dict:
    """A violation for the ``events`` list of a decoded frame: the analyzer stamps frame and
    time (Analyzer.event), so this one drops the placeholders."""
    ev = rules.violation(rule, 0, 0, message, **extra)
    for k in ("frame", "ts_ns", "last_frame"):
        del ev[k]
    return ev


def _name_events(d: dict, sid: int, response: bool) -> list[dict]:
    out = []
    for b in d["blocks"]:
        name = b.get("nameofstation")
        if name is None:
            continue
        probs = name_problems(name)
        if not probs:
            continue
        if sid == SET and not response:
            out.append(violation_event("DCP-NAME-INVALID",
                                       f"Set NameOfStation {name!r}: " + "; ".join(probs), name=name))
        elif response or sid == HELLO:
            # a device reports a name that breaks the rules (not the controller's Set)
            out.append({"kind": "dcp_name_invalid", "name": name, "problems": probs,
                        "service": d["service"]})
    return out


class DcpTracker:
    """Cross-frame DCP state: which MAC holds which NameOfStation and IP, learned from Identify /
    Get responses and Hellos (the device's own word) and from Set requests (assignments).

    ``on_dcp(ev, src, dst)`` returns violation events (frame/time from ``ev``):
    DCP-NAME-DUPLICATE when a Set gives a name that another MAC holds, or two MACs report the
    same name; IP-ASSIGN-OCCUPIED when a Set assigns an IP that another MAC holds.
    Each (rule, value, MAC pair) is reported once.
    """

    def __init__(self, table=dict):
        # ``table()`` makes each per-key table (the analyzer passes bounded ones: pndiss/limits.py)
        self.name_at: dict[str, tuple[str, int]] = table()   # name -> (mac, frame seen)
        self.ip_at: dict[str, tuple[str, int]] = table()     # ip -> (mac, frame seen)
        self.mac_name: dict[str, str] = table()
        self.mac_ip: dict[str, str] = table()
        self.reported: set = set()

    def on_dcp(self, ev: dict, src: str, dst: str) -> list[dict]:
        st = ev.get("station_info")
        if not st:
            return []
        assign = ev.get("service_id") == SET and ev.get("service_type") == 0
        target = dst if assign else src
        fn, ts = ev.get("frame", 0), ev.get("ts_ns", 0)
        out = []
        name = st.get("name")
        if name:
            out += self._claim("name", name, target, assign, fn, ts)
        elif name == "":
            self._release(self.name_at, self.mac_name, target)  # name reset: the name is free
        ip = st.get("ip")
        if ip and ip != "0.0.0.0":
            out += self._claim("ip", ip, target, assign, fn, ts)
        elif ip == "0.0.0.0":
            self._release(self.ip_at, self.mac_ip, target)
        return out

    @staticmethod
    def _release(at: dict, by_mac: dict, mac_: str) -> None:
        old = by_mac.pop(mac_, None)
        if old is not None and at.get(old, ("",))[0] == mac_:
            del at[old]

    def _claim(self, what: str, value: str, mac_: str, assign: bool, fn: int, ts: int) -> list[dict]:
        at, by_mac = (self.name_at, self.mac_name) if what == "name" else (self.ip_at, self.mac_ip)
        out = []
        holder = at.get(value)
        if holder is not None and holder[0] != mac_ and by_mac.get(holder[0]) == value:
            other, seen = holder
            if what == "name":
                rule = "DCP-NAME-DUPLICATE"
                msg = (f"NameOfStation {value!r} {'assigned' if assign else 'reported'} for {mac_}, "
                       f"but {other} holds it (frame {seen})")
            else:
                rule = "IP-ASSIGN-OCCUPIED"
                msg = f"Set assigns IP {value} to {mac_}, but {other} uses it (frame {seen})"
            key = (rule, value, frozenset((mac_, other)))
            if (what == "name" or assign) and key not in self.reported:
                self.reported.add(key)
                # 'ip' is the IPv4 header object in rpc events: the address claimed is 'ip_address'
                out.append(rules.violation(rule, fn, ts, msg, **{"ip_address" if what == "ip" else what: value, "mac": mac_,
                                                                 "other_mac": other, "other_frame": seen}))
        old = by_mac.get(mac_)
        if old is not None and old != value and at.get(old, ("",))[0] == mac_:
            del at[old]
        by_mac[mac_] = value
        if holder is None or holder[0] == mac_ or by_mac.get(holder[0]) != value or assign:
            at[value] = (mac_, fn)
        return out
