"""PN-DCP (FrameIDs 0xFEFC-0xFEFF): Identify / Get / Set / Hello requests and responses.

``decode(data, off, frame_id)`` reads the PDU that starts at ``data[off]`` (the byte after the
FrameID) and runs to ``len(data)`` (Ethernet pad included; DCPDataLength bounds the blocks).
Field names follow tshark 4.0's ``pn_dcp.*`` fields so tests/tshark_map/dcp.json maps them 1:1.
Layout facts: spec/wire.md §3 and tshark 4.0.17 ``packet-pn-dcp.c`` behaviour, checked on
synthetic frames (tests/test_dcp.py). Naming rules: spec/network.md §2.1.

The value tables are dcp_tables.py's, the blocks dcp_blocks.py's; the naming rules and
``DcpTracker`` (DCP-NAME-DUPLICATE, IP-ASSIGN-OCCUPIED) are dcp_rules.py's.
"""
from __future__ import annotations

from .common import Malformed
from .dcp_blocks import decode_block, suboption_entry, u16
from .dcp_rules import name_events
from .dcp_tables import GET, HELLO, IDENTIFY, LAYER, SERVICE_TYPES, SERVICES, SET


def decode(data: bytes, off: int, frame_id: int, cut: bool = False) -> dict:
    """Decode the DCP PDU at data[off:] (after the FrameID). Raises Malformed on bad input. ``cut``: the capture's
    snap length cut the frame -- the whole blocks it kept are decoded (as tshark does) and ``truncated`` says the
    rest is missing (the caller reports the frame as cut)."""
    if len(data) - off < 10:
        raise Malformed(LAYER, f"header needs 10 bytes, {max(len(data) - off, 0)} left")
    sid, stype = data[off], data[off + 1]
    xid = int.from_bytes(data[off + 2:off + 6], "big")
    dlen = u16(data, off + 8)
    d = {"service_id": sid, "service_type": stype, "xid": xid,
         "service": SERVICES.get(sid, "reserved"),
         "service_type_name": SERVICE_TYPES.get(stype, "reserved"), "data_length": dlen}
    if sid == IDENTIFY and stype == 0:
        d["response_delay"] = u16(data, off + 6)  # multicast header
    else:
        d["reserved16"] = u16(data, off + 6)
    start = off + 10
    end = start + dlen
    if end > len(data):
        if not cut:
            raise Malformed(LAYER, f"DCPDataLength {dlen} exceeds the {len(data) - start} bytes left")
        d["truncated"] = f"DCPDataLength {dlen} exceeds the {len(data) - start} bytes left"
        end = len(data)
    blocks: list[dict] = []
    d["blocks"] = blocks
    if sid not in (GET, SET, IDENTIFY, HELLO) or stype not in SERVICE_TYPES:
        d["undecoded"] = True  # tshark stops here too
        return d
    response = stype != 0
    if sid == GET and not response:  # Get request: Option/Suboption pairs, no lengths
        if dlen & 1:
            raise Malformed(LAYER, f"Get request with an odd DCPDataLength ({dlen})")
        if "truncated" in d:
            end = start + ((end - start) & ~1)   # the whole pairs the snap length kept
        d["selectors"] = [suboption_entry(data[i], data[i + 1]) for i in range(start, end, 2)]
        return d
    if (sid == IDENTIFY and response) or (sid == HELLO and not response) or (sid == GET and response):
        prefix = "block_info"
    elif sid == SET and not response:
        prefix = "block_qualifier"
    else:
        prefix = None  # Identify filters, Set responses, Hello "responses"
    o = start
    while o < end:
        try:
            b, o = decode_block(data, o, end, prefix, sid)
        except Malformed:
            if "truncated" in d:
                break   # the block the snap length cut: the ones before it stand
            raise
        blocks.append(b)
    station = _station(d, sid, response)
    if station:  # the object under its own name: 'station' is a NameOfStation string in every event kind
        d["station_info"] = station
        if isinstance(station.get("name"), str):
            d["station"] = station["name"]
    events = name_events(d, sid, response)
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
