"""PNIO alarms: RTA PDUs on FrameID 0xFC01 (high) / 0xFE01 (low).

RTA header, PDU types DATA/NACK/ACK/ERR, the AlarmNotification and AlarmAck blocks and the
diagnosis items behind each UserStructureIdentifier (spec/wire.md §7, spec/network.md §4;
tshark 4.0 packet-dcerpc-pn-io.c dissect_PNIO_RTA / dissect_AlarmUserStructure). Keys follow the
tshark ``pn_io.*`` names (tests/tshark_map/alarm.json). Everything is big-endian: tshark decodes
RTA PDUs with a zero drep (spec/wire.md §7.1).
"""
from __future__ import annotations

import struct

from .common import Malformed, need
from .pnio_cm import status_be

L = "alarm"

_RTA = struct.Struct(">HHBBHHH")  # dst, src, PDUType, AddFlags, SendSeqNum, AckSeqNum, VarPartLen
_BLOCK = struct.Struct(">HHBB")   # BlockType, BlockLength, version high, version low
_NOTIF = struct.Struct(">HIHHIIH")  # AlarmType, API, Slot, Subslot, ModuleIdent, SubmoduleIdent, AlarmSpecifier
_ACK = struct.Struct(">HIHHH")    # AlarmType, API, Slot, Subslot, AlarmSpecifier (then PNIOStatus)
_U16 = struct.Struct(">H")
_U32 = struct.Struct(">I")

# PDUType low nibble (spec/wire.md §7.1; tshark pn_io.pdu_type.type)
PDU_TYPES = {1: "DATA-RTA-PDU", 2: "NACK-RTA-PDU", 3: "ACK-RTA-PDU", 4: "ERR-RTA-PDU"}
DATA, ERR = 1, 4

# Block types carried in a DATA-RTA-PDU (spec/wire.md §6.2)
BLOCK_TYPES = {0x0001: "Alarm Notification High", 0x0002: "Alarm Notification Low",
               0x8001: "Alarm Ack High", 0x8002: "Alarm Ack Low"}
NOTIFICATION_BLOCKS = (0x0001, 0x0002)
ACK_BLOCKS = (0x8001, 0x8002)

# AlarmType (spec/wire.md §7.2; tshark pn_io_alarm_type)
ALARM_TYPES = {0x0001: "Diagnosis", 0x0002: "Process", 0x0003: "Pull", 0x0004: "Plug", 0x0005: "Status",
               0x0006: "Update", 0x0007: "Redundancy", 0x0008: "Controlled by supervisor",
               0x0009: "Released", 0x000A: "Plug wrong submodule", 0x000B: "Return of submodule",
               0x000C: "Diagnosis disappears", 0x000D: "Multicast communication mismatch",
               0x000E: "Port data change notification", 0x000F: "Sync data changed notification",
               0x0010: "Isochronous mode problem notification", 0x0011: "Network component problem notification",
               0x0012: "Time data changed notification", 0x0013: "Dynamic Frame Packing problem notification",
               0x001E: "Upload and retrieval notification", 0x001F: "Pull module"}


def alarm_type_name(t: int) -> str:
    if t in ALARM_TYPES:
        return ALARM_TYPES[t]
    if 0x0020 <= t <= 0x007F:
        return "Manufacturer specific"
    if 0x0080 <= t <= 0x00FF:
        return "Reserved for profiles"
    return "Reserved"


# AlarmSpecifier bits (spec/wire.md §7.2; tshark pn_io.alarm_specifier.* masks)
SPECIFIER_BITS = (("sequence", 0x07FF, 0), ("channel", 0x0800, 11), ("manufacturer", 0x1000, 12),
                  ("submodule", 0x2000, 13), ("ardiagnosis", 0x8000, 15))

# UserStructureIdentifier (spec/wire.md §7.3): item sizes after the USI for the ones we decode
USI_NAMES = {0x8000: "ChannelDiagnosis", 0x8001: "Multiple", 0x8002: "ExtChannelDiagnosis",
             0x8003: "QualifiedChannelDiagnosis", 0x8100: "Maintenance", 0x8200: "Upload&Retrieval",
             0x8201: "iParameter", 0x8300: "Reporting system", 0x8301: "Reporting system",
             0x8302: "Reporting system", 0x8303: "Reporting system", 0x8310: "PE_EnergySavingStatus",
             0x8320: "Channel related process alarm reasons"}
USI_ITEM_SIZES = {0x8000: 6, 0x8002: 12, 0x8003: 16, 0x8100: 12}


def usi_name(usi: int) -> str:
    if usi < 0x8000:
        return "Manufacturer specific"
    if 0x9000 <= usi <= 0x9FFF:
        return "Reserved for profiles"
    return USI_NAMES.get(usi, "Reserved")


# ChannelProperties fields: (key, mask, shift) (spec/wire.md §7.3; tshark masks)
CHANNEL_PROPERTY_BITS = (("type", 0x00FF, 0), ("accumulative", 0x0100, 8), ("maintenance", 0x0600, 9),
                         ("specifier", 0x1800, 11), ("direction", 0xE000, 13))
CHANNEL_TYPES = {0: "submodule / unspecified", 1: "1 bit", 2: "2 bit", 3: "4 bit", 4: "8 bit",
                 5: "16 bit", 6: "32 bit", 7: "64 bit"}
CHANNEL_MAINTENANCE = {0: "Failure", 1: "Maintenance required", 2: "Maintenance demanded",
                       3: "see QualifiedChannelQualifier"}
CHANNEL_SPECIFIER = {0: "All subsequent disappears", 1: "Appears", 2: "Disappears",
                     3: "Disappears but other remain"}
CHANNEL_DIRECTION = {0: "Manufacturer specific", 1: "Input", 2: "Output", 3: "Input/Output"}

# ChannelErrorType (spec/wire.md §7.3, tshark texts)
CHANNEL_ERROR_TYPES = {
    0x0000: "Reserved", 0x0001: "Short circuit", 0x0002: "Undervoltage", 0x0003: "Overvoltage",
    0x0004: "Overload", 0x0005: "Overtemperature", 0x0006: "Line break", 0x0007: "Upper limit value exceeded",
    0x0008: "Lower limit value exceeded", 0x0009: "Error", 0x000A: "Simulation active",
    0x000F: "Parameter missing", 0x0010: "Parameterization fault", 0x0011: "Power supply fault",
    0x0012: "Fuse blown / open", 0x0013: "Manufacturer specific", 0x0014: "Ground fault",
    0x0015: "Reference point lost", 0x0016: "Process event lost / sampling error",
    0x0017: "Threshold warning", 0x0018: "Output disabled", 0x0019: "FunctionalSafety event",
    0x001A: "External fault", 0x001F: "Temporary fault",
    0x8000: "Data transmission impossible", 0x8001: "Remote mismatch", 0x8002: "Media redundancy mismatch",
    0x8003: "Sync mismatch", 0x8004: "IsochronousMode mismatch", 0x8005: "Multicast CR mismatch",
    0x8007: "Fiber optic mismatch", 0x8008: "Network component function mismatch",
    0x8009: "Time mismatch", 0x800A: "Dynamic frame packing function mismatch",
    0x800B: "Media redundancy with planned duplication mismatch", 0x800C: "System redundancy mismatch",
    0x800D: "Multiple interface mismatch", 0x8010: "Power failure over Single Pair Ethernet",
    # tshark 4.0 names 0x9000.. with PA-profile texts for every device (spec/wire.md §7.3 quirk)
    0x9000: "Sensor element exciter faulty", 0x9011: "Electromag interference too high",
}
# What the encoder profile means by the only two codes the manuals give (spec/network.md §4.2:
# Lika 000_37bf2397999f1108.txt:2605-2614; PROFIdrive ChannelErrorTypes, Lika P65001 fault bits 5/4)
ENCODER_CHANNEL_ERRORS = {
    0x9000: "Memory error (offset/preset values could not be read from non-volatile memory)",
    0x9011: "Commissioning diagnostic (error in the user parameter data assignment)",
}


def channel_error_type_name(t: int) -> str:
    if t in CHANNEL_ERROR_TYPES:
        return CHANNEL_ERROR_TYPES[t]
    if 0x0040 <= t <= 0x004F:
        return "PROFIsafe"
    if 0x0100 <= t <= 0x7FFF:
        return "Manufacturer specific"
    if 0x9000 <= t <= 0x9FFF:
        return "Reserved for profiles"
    return "Reserved"


# tshark 4.0 files ExtChannelErrorType under a field named after the ChannelErrorType range
# (found with synthetic frames: 0x8000 -> "...type0800", < 0x7FFF -> "...type0", other -> plain)
EXT_FIELD_BY_CET = {0x8000: "0800", 0x8001: "8001", 0x8002: "8002", 0x8003: "8003", 0x8004: "8004",
                    0x8005: "8005", 0x8007: "8007", 0x8008: "8008", 0x800A: "800A", 0x800B: "800B",
                    0x800C: "800C", 0x8010: "8010"}
# ExtChannelErrorType texts for the ranges that matter here (spec/wire.md §7.3)
EXT_CHANNEL_ERROR_TYPES = {
    "0": {0x8000: "Accumulative Info"},
    "0800": {0x8000: "Link State mismatch - Link down", 0x8001: "MAUType mismatch", 0x8002: "Line Delay mismatch"},
    "8001": {0x8000: "Peer name of station mismatch", 0x8001: "Peer name of port mismatch",
             0x8002: "Peer RT_CLASS_3 mismatch", 0x8003: "Peer MAUType mismatch",
             0x8004: "Peer MRP domain mismatch", 0x8005: "No peer detected",
             0x8007: "Peer Line Delay mismatch", 0x8008: "Peer PTCP mismatch",
             0x8009: "Peer Preamble Length mismatch", 0x800A: "Peer Fragmentation mismatch",
             0x800B: "Peer MRP Interconnection domain mismatch"},
}


def _ext_field(cet: int) -> str:
    if cet < 0x7FFF:  # tshark's "< 0x7FFF" test leaves 0x7FFF in the plain branch
        return "0"
    return EXT_FIELD_BY_CET.get(cet, "")


# PNIOStatus words for RTA (ERR PDUs, AlarmAck) (spec/wire.md §6.1)
# PNIOStatus words: the one table in pnio_cm (tshark's value tables, spec/wire.md §5.4)
pnio_status = status_be


def _fields(value: int, table) -> dict:
    return {k: (value & m) >> s for k, m, s in table}


def _specifier(v: int) -> dict:
    return {"value": v, **_fields(v, SPECIFIER_BITS)}


def _channel(data: bytes, o: int) -> dict:
    num, props, cet = struct.unpack_from(">HHH", data, o)
    p = {"value": props, **_fields(props, CHANNEL_PROPERTY_BITS)}
    p["specifier_name"] = CHANNEL_SPECIFIER[p["specifier"]]
    p["maintenance_name"] = CHANNEL_MAINTENANCE[p["maintenance"]]
    p["direction_name"] = CHANNEL_DIRECTION.get(p["direction"], "Reserved")
    item = {"channel_number": num, "channel_properties": p, "channel_error_type": cet,
            "channel_error_type_name": channel_error_type_name(cet)}
    if cet in ENCODER_CHANNEL_ERRORS:
        item["encoder_error"] = ENCODER_CHANNEL_ERRORS[cet]
    return item


def channel_item(data: bytes, o: int, usi: int) -> dict:
    """One channel / extended / qualified channel diagnosis entry at data[o] (USI 0x8000/0x8002/
    0x8003; the caller checked USI_ITEM_SIZES[usi] bytes are there). Also used for DiagnosisData
    records (pndiss/proto/cmblocks.py)."""
    item = _channel(data, o)
    if usi in (0x8002, 0x8003):
        xet, add = struct.unpack_from(">HI", data, o + 6)
        field = _ext_field(item["channel_error_type"])
        item["ext_channel_error_type" + field] = xet
        item["ext_channel_error_type_value"] = xet
        item["ext_channel_error_type_name"] = EXT_CHANNEL_ERROR_TYPES.get(field, {}).get(xet)
        item["ext_channel_add_value"] = add
    if usi == 0x8003:
        item["qualified_channel_qualifier"] = _U32.unpack_from(data, o + 12)[0]
    return item


def _items(data: bytes, o: int, end: int) -> list[dict]:
    """Diagnosis items: USI + item until the block is used up; one item per USI, as tshark reads."""
    items = []
    while o < end:
        if end - o < 2:
            raise Malformed(L, f"{end - o} byte left in the alarm block, too short for a UserStructureIdentifier")
        usi = _U16.unpack_from(data, o)[0]
        o += 2
        item = {"user_structure_identifier": usi, "usi_name": usi_name(usi)}
        items.append(item)
        size = USI_ITEM_SIZES.get(usi)
        if size is None:  # manufacturer data or an item tshark leaves undecoded: rest of the block
            item["data"] = data[o:end].hex()
            break
        if end - o < size:
            raise Malformed(L, f"{usi_name(usi)} item needs {size} bytes, block has {end - o} left")
        if usi == 0x8100:
            # MaintenanceItem: block header (type 0x0F00), 2 bytes padding, MaintenanceStatus u32
            btype, blen, vh, vl = _BLOCK.unpack_from(data, o)
            ms = _U32.unpack_from(data, o + 8)[0]
            item.update(block={"type": btype, "length": blen, "version_high": vh, "version_low": vl},
                        maintenance_status={"value": ms, "required": ms & 1, "demanded": (ms >> 1) & 1})
        else:
            item.update(channel_item(data, o, usi))
        o += size
    return items


def decode(data: bytes, off: int, frame_id: int) -> dict:
    """RTA PDU after the FrameID at ``data[off]`` -> event fields (raises Malformed)."""
    need(data, off, _RTA.size, L, "RTA header")
    dst, src, pt, af, sseq, aseq, vlen = _RTA.unpack_from(data, off)
    ptype = pt & 0x0F
    d = {"priority": "high" if frame_id == 0xFC01 else "low",
         "alarm_dst_endpoint": dst, "alarm_src_endpoint": src,
         "pdu_type": {"type": ptype, "version": pt >> 4}, "pdu_type_name": PDU_TYPES.get(ptype, "Reserved"),
         "window_size": af & 0x0F, "tack": af >> 4, "send_seq_num": sseq, "ack_seq_num": aseq,
         "var_part_len": vlen}
    o = off + _RTA.size
    need(data, o, vlen, L, "RTA-SDU (VarPartLen)")
    sdu_end = o + vlen
    if ptype == ERR:
        if vlen < 4:
            raise Malformed(L, f"ERR-RTA-PDU with VarPartLen {vlen} has no PNIOStatus")
        d["status"] = pnio_status(data, o)
    elif ptype == DATA:
        d.update(_data_block(data, o, sdu_end))
    return d


def _data_block(data: bytes, o: int, sdu_end: int) -> dict:
    if sdu_end - o < _BLOCK.size:
        raise Malformed(L, "DATA-RTA-PDU too short for a block header")
    btype, blen, vh, vl = _BLOCK.unpack_from(data, o)
    end = o + 4 + blen  # BlockLength counts from the version bytes on
    if blen < 2 or end > sdu_end:
        raise Malformed(L, f"alarm block length {blen} does not fit VarPartLen")
    d = {"block": {"type": btype, "length": blen, "version_high": vh, "version_low": vl,
                   "name": BLOCK_TYPES.get(btype, f"0x{btype:04x}")}}
    o += _BLOCK.size
    if btype in NOTIFICATION_BLOCKS:
        if end - o < _NOTIF.size:
            raise Malformed(L, "AlarmNotification block too short for the alarm header")
        at, api, slot, sub, mod, submod, spec = _NOTIF.unpack_from(data, o)
        d.update(alarm_type=at, alarm_type_name=alarm_type_name(at), api=api, slot_nr=slot,
                 subslot_nr=sub, module_ident_number=mod, submodule_ident_number=submod,
                 alarm_specifier=_specifier(spec), items=_items(data, o + _NOTIF.size, end))
    elif btype in ACK_BLOCKS:
        if end - o < _ACK.size + 4:
            raise Malformed(L, "AlarmAck block too short")
        at, api, slot, sub, spec = _ACK.unpack_from(data, o)
        d.update(alarm_type=at, alarm_type_name=alarm_type_name(at), api=api, slot_nr=slot,
                 subslot_nr=sub, alarm_specifier=_specifier(spec), status=pnio_status(data, o + _ACK.size))
    else:
        d["block"]["data"] = data[o:end].hex()
    return d
