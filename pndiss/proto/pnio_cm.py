"""PNIO-CM: the NDR header of the PNIO stub, the PNIO status and the CM blocks.

Sources: spec/wire.md §5.3 (NDR header), §5.4 (PNIOStatus), §6 (blocks), all facts from tshark 4.0
packet-dcerpc-pn-io.c / packet-pn.c. Field names are tshark's (`pn_io.<name>`), so
tests/tshark_map/pnio_cm.json maps them one to one. Blocks are always big-endian; the NDR header
and its PNIOStatus follow the DCE/RPC drep.

``decode_stub`` returns a flat list of block dicts in wire order (nested blocks, e.g. inside
record data, follow their parent with ``depth`` + 1) plus the records carried by read/write
headers, so the session tracker need not walk the tree again.
"""
from __future__ import annotations

import struct

from . import cm_connect, cmblocks, pdrecords
from .cmblock import Cursor as _Cur  # shared with the block-family modules
from .common import Malformed

L = "pnio_cm"

# opnums, spec/wire.md §5.2
OPNUMS = {0: "Connect", 1: "Release", 2: "Read", 3: "Write", 4: "Control", 5: "Read Implicit"}

# block type names, spec/wire.md §6.2 (tshark pn_io_block_type)
BLOCK_NAMES = {
    0x0001: "AlarmNotificationHigh", 0x0002: "AlarmNotificationLow",
    0x0008: "IODWriteReqHeader", 0x0009: "IODReadReqHeader",
    0x0010: "DiagnosisData", 0x0012: "ExpectedIdentificationData", 0x0013: "RealIdentificationData",
    0x0014: "SubstituteValue", 0x0015: "RecordInputDataObjectElement",
    0x0016: "RecordOutputDataObjectElement", 0x0018: "ARData", 0x0019: "LogData", 0x001A: "APIData",
    0x001B: "SRLData",
    **{0x0020 + i: f"I&M{i}" for i in range(16)},
    0x0030: "I&M0FilterDataSubmodule", 0x0031: "I&M0FilterDataModule", 0x0032: "I&M0FilterDataDevice",
    0x0034: "I&M5Data",
    0x0101: "ARBlockReq", 0x0102: "IOCRBlockReq", 0x0103: "AlarmCRBlockReq",
    0x0104: "ExpectedSubmoduleBlockReq", 0x0105: "PrmServerBlockReq", 0x0106: "MCRBlockReq",
    0x0107: "SubFrameBlock", 0x0108: "ARVendorBlockReq", 0x0109: "IRInfoBlock", 0x010A: "SRInfoBlock",
    0x010B: "ARFSUBlock", 0x010C: "RSInfoBlock",
    0x0110: "IODControlReq Prm End", 0x0111: "IODControlReq Plug Prm End",
    0x0112: "IOXBlockReq Application Ready", 0x0113: "IOXBlockReq Plug Application Ready",
    0x0114: "IODReleaseReq", 0x0116: "IOXControlReq Ready for Companion",
    0x0117: "IOXControlReq Ready for RT_CLASS_3", 0x0118: "PrmBeginReq", 0x0119: "SubmoduleListBlock",
    0x0200: "PDPortDataCheck", 0x0201: "PDevData", 0x0202: "PDPortDataAdjust", 0x0203: "PDSyncData",
    0x0204: "IsochronousModeData", 0x0205: "PDIRData", 0x0206: "PDIRGlobalData",
    0x0207: "PDIRFrameData", 0x0208: "PDIRBeginEndData", 0x0209: "AdjustDomainBoundary",
    0x020A: "CheckPeers", 0x020B: "CheckLineDelay", 0x020C: "Checking MAUType",
    0x020E: "Adjusting MAUType", 0x020F: "PDPortDataReal", 0x0210: "AdjustMulticastBoundary",
    0x0211: "PDInterfaceMrpDataAdjust", 0x0212: "PDInterfaceMrpDataReal",
    0x0213: "PDInterfaceMrpDataCheck", 0x0214: "PDPortMrpDataAdjust", 0x0215: "PDPortMrpDataReal",
    0x0216: "MrpManagerParams", 0x0217: "MrpClientParams", 0x0219: "MrpRingStateData",
    0x021B: "AdjustLinkState", 0x021C: "CheckLinkState", 0x021E: "CheckSyncDifference",
    0x021F: "CheckMAUTypeDifference", 0x0220: "PDPortFODataReal", 0x0221: "FiberOpticManufacturerSpecific",
    0x0222: "PDPortFODataAdjust", 0x0223: "PDPortFODataCheck", 0x0224: "AdjustPeerToPeerBoundary",
    0x0225: "AdjustDCPBoundary", 0x0226: "AdjustPreambleLength", 0x0228: "FiberOpticDiagnosisInfo",
    0x022A: "PDIRSubframeData", 0x022B: "SubframeBlock", 0x0230: "PDNCDataCheck",
    0x0231: "MrpInstanceDataAdjust", 0x0232: "MrpInstanceDataReal", 0x0233: "MrpInstanceDataCheck",
    0x0240: "PDInterfaceDataReal", 0x0250: "PDInterfaceAdjust", 0x0251: "PDPortStatistic",
    0x0400: "MultipleBlockHeader", 0x0401: "COContainerContent", 0x0500: "RecordDataReadQuery",
    0x0600: "FSHello", 0x0601: "FSParameterBlock", 0x0602: "FastStartUpBlock",
    0x0608: "PDInterfaceFSUDataAdjust", 0x0609: "ARFSUDataAdjust",
    0x0F00: "MaintenanceItem", 0x0F05: "PE_EntityStatusData",
    0x8001: "AlarmAckHigh", 0x8002: "AlarmAckLow", 0x8008: "IODWriteResHeader", 0x8009: "IODReadResHeader",
    0x8101: "ARBlockRes", 0x8102: "IOCRBlockRes", 0x8103: "AlarmCRBlockRes", 0x8104: "ModuleDiffBlock",
    0x8105: "PrmServerBlockRes", 0x8106: "ARServerBlockRes", 0x8107: "ARRPCBlockRes",
    0x8108: "ARVendorBlockRes",
    0x8110: "IODControlRes Prm End", 0x8111: "IODControlRes Plug Prm End",
    0x8112: "IOXBlockRes Application Ready", 0x8113: "IOXBlockRes Plug Application Ready",
    0x8114: "IODReleaseRes", 0x8116: "IOXControlRes Ready for Companion",
    0x8117: "IOXControlRes Ready for RT_CLASS_3", 0x8118: "PrmBeginRes",
}

# --- PNIOStatus value tables, spec/wire.md §5.4 (tshark pn_io_error_code / _decode / _code1) ---
ERROR_CODE = {0x00: "OK", 0x81: "PNIO", 0xCF: "RTA error", 0xDA: "AlarmAck", 0xDB: "IODConnectRes",
              0xDC: "IODReleaseRes", 0xDD: "IODControlRes", 0xDE: "IODReadRes", 0xDF: "IODWriteRes"}
ERROR_DECODE = {0x00: "OK", 0x80: "PNIORW", 0x81: "PNIO"}
CODE1_PNIORW = {
    0xA0: "application: read error", 0xA1: "application: write error", 0xA2: "application: module failure",
    0xA7: "application: busy", 0xA8: "application: version conflict",
    0xA9: "application: feature not supported",
    0xB0: "access: invalid index", 0xB1: "access: write length error", 0xB2: "access: invalid slot/subslot",
    0xB3: "access: type conflict", 0xB4: "access: invalid area", 0xB5: "access: state conflict",
    0xB6: "access: access denied", 0xB7: "access: invalid range", 0xB8: "access: invalid parameter",
    0xB9: "access: invalid type", 0xBA: "access: backup",
    0xC0: "resource: read constraint conflict", 0xC1: "resource: write constraint conflict",
    0xC2: "resource: resource busy", 0xC3: "resource: resource unavailable",
}
CODE1_PNIO = {
    1: "Connect: Faulty ARBlockReq", 2: "Connect: Faulty IOCRBlockReq",
    3: "Connect: Faulty ExpectedSubmoduleBlockReq", 4: "Connect: Faulty AlarmCRBlockReq",
    5: "Connect: Faulty PrmServerBlockReq", 6: "Connect: Faulty MCRBlockReq",
    7: "Connect: Faulty ARRPCBlockReq", 8: "Read/Write Record: Faulty Record",
    9: "Connect: Faulty SubFrameBlock", 10: "Connect: Faulty IRTFrameBlock", 13: "Connect: Faulty RSInfoBlock",
    20: "IODControl: Faulty ControlBlockConnect", 21: "IODControl: Faulty ControlBlockPlug",
    22: "IOXControl: Faulty ControlBlock after a connect est.",
    23: "IOXControl: Faulty ControlBlock a plug alarm", 24: "IOXControl: Faulty ControlBlockPrmBegin",
    25: "IOXControl: Faulty SubmoduleListBlock", 40: "Release: Faulty ReleaseBlock",
    50: "Response: Faulty ARBlockRes", 51: "Response: Faulty IOCRBlockRes",
    52: "Response: Faulty AlarmCRBlockRes", 53: "Response: Faulty ModuleDifflock",
    54: "Response: Faulty ARRPCBlockRes", 55: "Response: Faulty ARServerBlockRes",
    56: "Response: Faulty ARVendorBlockRes",
    60: "AlarmAck Error Codes", 61: "CMDEV", 62: "CMCTL", 63: "CTLDINA", 64: "CMRPC", 65: "ALPMI",
    66: "ALPMR", 67: "LMPM", 68: "MAC", 69: "RPC", 70: "APMR", 71: "APMS", 72: "CPM", 73: "PPM",
    74: "DCPUCS", 75: "DCPUCR", 76: "DCPMCS", 77: "DCPMCR", 78: "FSPM", 79: "RSI", 80: "RSIR",
    253: "RTA_ERR_CLS_PROTOCOL", 255: "User specific",
}
CODE2_BY_CODE1 = {  # spec/wire.md §5.4 "Common ErrorCode2 tables"
    64: {0: "ArgsLength invalid", 1: "Unknown Blocks", 2: "IOCR Missing", 3: "Wrong AlarmCRBlock count",
         4: "Out of AR Resources", 5: "AR UUID unknown", 6: "State conflict",
         7: "Out of Provider, Consumer or Alarm Resources", 8: "Out of memory",
         9: "Pdev already owned", 10: "ARset: State conflict", 11: "ARset: Parameter conflict",
         12: "Pdev, port(s) without interface"},
    61: {0: "State Conflict", 1: "Resources"},
    62: {0: "State Conflict", 1: "Timeout", 2: "No data send"},
    60: {0: "Alarm Type Not Supported", 1: "Wrong Submodule State", 2: "IOCARSR Backup"},
    253: {1: "error within the coordination of sequence numbers", 2: "instance closed",
          3: "AR out of memory", 4: "AR add provider or consumer failed", 5: "AR consumer DHT/WDT expired",
          6: "AR cmi timeout", 7: "AR alarm-open failed", 8: "AR alarm-send.cnf(-)",
          9: "AR alarm-ack-send.cnf(-)", 10: "AR alarm data too long", 11: "AR alarm.ind(err)",
          12: "AR rpc-client call.cnf(-)", 13: "AR abort.req", 14: "AR re-run aborts existing",
          15: "AR release.ind received", 16: "AR device deactivated", 17: "AR removed",
          18: "AR protocol violation", 19: "AR name resolution error", 20: "AR RPC-Bind error",
          21: "AR RPC-Connect error", 22: "AR RPC-Read error", 23: "AR RPC-Write error",
          24: "AR RPC-Control error", 25: "AR forbidden pull or plug", 26: "AR AP removed",
          27: "AR link down", 28: "AR could not register multicast-mac address",
          31: "DCP, station name changed", 32: "DCP, reset to factory-settings", 37: "IP suite changed"},
}


def status(code: int, decode: int, code1: int, code2: int) -> dict:
    """PNIOStatus as numbers plus words (tshark's value tables); ``ok`` = all zero."""
    if decode == 0x80:
        c1 = CODE1_PNIORW.get(code1) or ("user specific" if (code1 & 0x0F) >= 0x0A or code1 >= 0xC8
                                         else f"class {code1 >> 4:#x} code {code1 & 0xF:#x}")
        c2 = "user specific" if code2 else "OK"
    elif decode == 0x81:
        c1 = CODE1_PNIO.get(code1, f"({code1})")
        if code1 in CODE2_BY_CODE1:
            c2 = CODE2_BY_CODE1[code1].get(code2, f"({code2})")
        elif 1 <= code1 <= 40:
            c2 = f"Error in Parameter {code2}"
        else:
            c2 = f"({code2})"
    else:
        c1, c2 = ("OK", "OK") if code1 == code2 == 0 else (f"({code1})", f"({code2})")
    ok = code == decode == code1 == code2 == 0
    return {"error_code": code, "error_decode": decode, "error_code1": code1, "error_code2": code2,
            "ok": ok, "text": "OK" if ok else
            f"{ERROR_CODE.get(code, hex(code))}/{ERROR_DECODE.get(decode, hex(decode))}: {c1}: {c2}"}


def status_be(b: bytes, off: int) -> dict:
    return status(b[off], b[off + 1], b[off + 2], b[off + 3])


# --- NDR header, spec/wire.md §5.3 ---------------------------------------------------------
_NDR = {"big": struct.Struct(">5I"), "little": struct.Struct("<5I")}
_U32 = {"big": struct.Struct(">I"), "little": struct.Struct("<I")}


def decode_ndr(stub: bytes, order: str, request: bool) -> tuple[dict, int]:
    """NDR header (request: ArgsMaximum ...; response: PNIOStatus ...); returns (fields, blocks offset)."""
    if request:
        if len(stub) < 20:
            raise Malformed(L, f"NDR request header truncated ({len(stub)} of 20 bytes)")
        amax, alen, mc, ao, ac = _NDR[order].unpack_from(stub, 0)
        return {"args_max": amax, "args_len": alen, "array_max_count": mc, "array_offset": ao,
                "array_act_count": ac}, 20
    if len(stub) < 20:
        raise Malformed(L, f"NDR response header truncated ({len(stub)} of 20 bytes)")
    st, alen, mc, ao, ac = _NDR[order].unpack_from(stub, 0)
    return {"status": status(st >> 24, (st >> 16) & 0xFF, (st >> 8) & 0xFF, st & 0xFF),
            "args_len": alen, "array_max_count": mc, "array_offset": ao, "array_act_count": ac}, 20


RW_HEADERS = {0x0008: "write", 0x0009: "read", 0x8008: "write", 0x8009: "read"}


def _rw_header(c: _Cur, d: dict) -> None:
    """IOD Read/Write Req/Res header, spec/wire.md §6.9 (64 bytes incl. the block header)."""
    bt = d["block_type"]
    d["seq_number"] = c.u16()
    d["ar_uuid"] = c.uuid()
    d["api"] = c.u32()
    d["slot_nr"] = c.u16()
    d["subslot_nr"] = c.u16()
    c.u16()  # padding
    d["index"] = c.u16()
    d["record_data_length"] = c.u32()
    if bt == 0x0009 and d["ar_uuid"] == "00000000-0000-0000-0000-000000000000":
        d["target_ar_uuid"] = c.uuid()  # Read Implicit names the AR it targets
    elif bt & 0x8000:
        d["add_val1"] = c.u16()
        d["add_val2"] = c.u16()
        if bt == 0x8008:
            st = c.take(4)
            d["status"] = status_be(c.b, st)


BODIES = {
    **cm_connect.BODIES,
    **{t: _rw_header for t in RW_HEADERS},
    **pdrecords.BODIES,
    **cmblocks.BODIES,
}

# Blocks whose body holds further blocks after a fixed prefix: (field, bytes) with None = padding.
# tshark packet-dcerpc-pn-io.c: PDPortDataCheck/Adjust (padding, slot, subslot), MultipleBlockHeader
# (padding, API, slot, subslot), COContainerContent (padding, API, slot, subslot, padding, index),
# ARFSUBlock (padding). Other record blocks are decoded by header only.
_SLOT = ((None, 2), ("slot_nr", 2), ("subslot_nr", 2))
CONTAINERS = {0x0200: _SLOT, 0x0202: _SLOT, 0x010B: ((None, 2),),
              0x0205: _SLOT, 0x022A: (("NumberOfSubframeBlocks", 2),),
              (0x0211, 1): ((None, 1), ("mrp_Number_MrpInstances", 1)),  # version 1.1 only
              (0x0213, 1): ((None, 1), ("mrp_Number_MrpInstances", 1)),
              0x0609: ((None, 2),),
              0x0400: ((None, 2), ("api", 4), ("slot_nr", 2), ("subslot_nr", 2)),
              0x0401: ((None, 2), ("api", 4), ("slot_nr", 2), ("subslot_nr", 2), (None, 2), ("index", 2))}

# Record indices whose data is a sequence of blocks (spec/wire.md §6.12: PDev, I&M filter,
# diagnosis, AR-level records); user and profile records (0x0000-0x7FFF, 0xB000-0xBFFF except
# the I&M block records) are plain bytes for the records helper.
BLOCK_RECORDS = frozenset({
    0x800A, 0x800B, 0x800C, 0x8020, 0x8027, 0x8028, 0x8029, 0x802A, 0x802B, 0x802C, 0x802D, 0x802E,
    0x802F, 0x8030, 0x8031, 0x8050, 0x8051, 0x8052, 0x8053, 0x8054, 0x8055, 0x8056, 0x8057,
    0x8060, 0x8061, 0x8062, 0x8063, 0x8070, 0x8071, 0x8072, 0x8080, 0x8090, 0x80B0,
    0xC00A, 0xC00B, 0xC00C, 0xE00A, 0xE00B, 0xE00C, 0xE050, 0xF00A, 0xF00B, 0xF00C, 0xF80C,
    0xF820, 0xF821, 0xF830, 0xF831, 0xF840, 0xF841, 0xF842,
    *range(0xAFF0, 0xB000),  # I&M0-15 records are I&M blocks (0x0020-0x002F)
})

MAX_DEPTH = 4
NIL_UUID = "00000000-0000-0000-0000-000000000000"


def decode_blocks(b: bytes, off: int, end: int, out: list, depth: int = 0) -> None:
    """Append every block in b[off:end] (and blocks nested in containers) to ``out``.

    Like tshark, each block advances by BlockLength whatever its body parser used; a body that
    does not fit its BlockLength raises Malformed.
    """
    while off < end:
        if end - off < 6:
            raise Malformed(L, f"{end - off} stray bytes where a block header (6 bytes) should start")
        bt = (b[off] << 8) | b[off + 1]
        blen = (b[off + 2] << 8) | b[off + 3]
        if blen < 2:
            raise Malformed(L, f"block {bt:#06x} with BlockLength {blen} < 2")
        bend = off + 4 + blen
        if bend > end:
            raise Malformed(L, f"block {bt:#06x} BlockLength {blen} runs {bend - end} bytes past its container")
        d = {"block_type": bt, "block_name": BLOCK_NAMES.get(bt, f"unknown ({bt:#06x})"),
             "block_length": blen, "block_version_high": b[off + 4], "block_version_low": b[off + 5],
             "depth": depth}
        out.append(d)
        body = BODIES.get(bt)
        if body is not None and d["block_version_high"] != 1:
            # like tshark ("Block version ... not implemented"): header only; users skip it
            d["undecoded"] = f"block version {d['block_version_high']}.{d['block_version_low']} not implemented"
        elif body is not None:
            c = _Cur(b, off + 6, bend, d["block_name"])
            body(c, d)
            if bt in RW_HEADERS:
                _rw_payload(b, c, d, end, out, depth)
                # the record data may lie past this block's end: continue after it
                off = d.pop("_next")
                continue
        elif (bt, d["block_version_low"]) in pdrecords.PREFIX_BODIES and d["block_version_high"] == 1:
            c = _Cur(b, off + 6, bend, d["block_name"])
            pdrecords.PREFIX_BODIES[(bt, d["block_version_low"])](c, d)
            if depth < MAX_DEPTH:
                decode_blocks(b, c.o, bend, out, depth + 1)  # MRP manager/client parameter blocks
        elif depth < MAX_DEPTH and (bt in CONTAINERS or (bt, d["block_version_low"]) in CONTAINERS):
            c = _Cur(b, off + 6, bend, d["block_name"])
            for name, size in CONTAINERS.get(bt) or CONTAINERS[(bt, d["block_version_low"])]:
                v = c.u32() if size == 4 else c.u16() if size == 2 else c.u8()
                if name is not None:
                    d[name] = v
            decode_blocks(b, c.o, bend, out, depth + 1)
        off = bend


def _rw_payload(b: bytes, c: _Cur, d: dict, end: int, out: list, depth: int) -> None:
    """Record data after a read/write header: 0xE040 inner writes, blocks or plain bytes."""
    bt = d["block_type"]
    hdr_end = c.end
    nxt = hdr_end
    has_data = bt == 0x0008 or bt == 0x8009  # write request / read response carry the data
    if bt == 0x8008 and d["index"] == 0xE040:
        # multiple write response: one IODWriteResHeader per inner write follows (§6.10)
        d["_next"] = hdr_end
        return
    if has_data:
        n = d["record_data_length"]
        if hdr_end + n > end:
            raise Malformed(L, f"record data of {n} bytes runs {hdr_end + n - end} bytes past the stub")
        data = b[hdr_end:hdr_end + n]
        nxt = hdr_end + n
        if bt == 0x0008 and d["index"] == 0xE040:
            d["inner"] = True
            o = hdr_end
            while o < nxt:  # inner writes, each padded to a 4-byte boundary from the stub start
                first = len(out)
                _one_inner(b, o, nxt, out, depth + 1)
                inner = out[first]
                o = inner.pop("_end")
                o += (-o) % 4 if o < nxt else 0
        else:
            d["data"] = data.hex()  # hex keeps events JSON-able
            if d["index"] in BLOCK_RECORDS and n >= 6 and depth < MAX_DEPTH:
                first = len(out)
                decode_blocks(b, hdr_end, nxt, out, depth + 1)
                d["record_blocks"] = [x["block_name"] for x in out[first:] if x["depth"] == depth + 1]
    d["_next"] = nxt


def _one_inner(b: bytes, off: int, end: int, out: list, depth: int) -> None:
    """One inner IODWriteReqHeader + its data inside a 0xE040 multiple write."""
    if end - off < 6:
        raise Malformed(L, "multiple write: truncated inner header")
    bt = (b[off] << 8) | b[off + 1]
    if bt != 0x0008:
        raise Malformed(L, f"multiple write: inner block {bt:#06x} is not an IODWriteReqHeader")
    mark = len(out)
    blen = (b[off + 2] << 8) | b[off + 3]
    bend = off + 4 + blen
    if bend > end or blen < 2:
        raise Malformed(L, f"multiple write: inner header BlockLength {blen} does not fit")
    d = {"block_type": bt, "block_name": BLOCK_NAMES[bt], "block_length": blen,
         "block_version_high": b[off + 4], "block_version_low": b[off + 5], "depth": depth}
    out.append(d)
    c = _Cur(b, off + 6, bend, "inner IODWriteReqHeader")
    _rw_header(c, d)
    n = d["record_data_length"]
    if bend + n > end:
        raise Malformed(L, f"multiple write: inner record data of {n} bytes runs past the outer record")
    d["data"] = b[bend:bend + n].hex()
    if d["index"] in BLOCK_RECORDS and n >= 6 and depth < MAX_DEPTH:
        first = len(out)
        decode_blocks(b, bend, bend + n, out, depth + 1)
        d["record_blocks"] = [x["block_name"] for x in out[first:] if x["depth"] == depth + 1]
    out[mark]["_end"] = bend + n


def decode_stub(stub: bytes, order: str, request: bool, opnum: int) -> dict:
    """A whole PNIO stub (NDR header + blocks). ``blocks`` is flat, wire order."""
    ndr, off = decode_ndr(stub, order, request)
    d = {"opnum": opnum, "operation": OPNUMS.get(opnum, f"opnum {opnum}"), **ndr, "blocks": []}
    alen = ndr["args_len"]
    end = off + alen
    if end > len(stub):
        raise Malformed(L, f"ArgsLength {alen} exceeds the {len(stub) - off} stub bytes")
    decode_blocks(stub, off, end, d["blocks"])
    return d


def records(pdu: dict) -> list[dict]:
    """Read/write headers of a decoded stub that carry or answer a record (inner writes included)."""
    return [b for b in pdu["blocks"] if b["block_type"] in RW_HEADERS and "undecoded" not in b]
