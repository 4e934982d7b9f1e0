"""Byte builders for PNIO-CM test frames: Ethernet/IPv4/UDP, the connectionless DCE/RPC header
(either byte order), the PNIO NDR header and CM blocks (layouts: spec/wire.md §5-§6)."""
from __future__ import annotations

import struct
import uuid

DEVICE_IF = "dea00001-6c97-11d1-8271-00a02442df7d"
CONTROLLER_MAC = "02:00:00:00:00:01"
DEVICE_MAC = "02:00:00:00:01:01"
CONTROLLER_IP = "192.168.0.1"
DEVICE_IP = "192.168.0.10"
AR_UUID = "12345678-9abc-def0-1234-56789abcdef0"
ACT = "00000007-0000-1010-8000-000000000007"
# who calls: the controller's MAC and IP, its AR and its RPC activity (the ``plc`` keyword of the pairs below)
PLC = (CONTROLLER_MAC, CONTROLLER_IP, AR_UUID, ACT)


def mac_bytes(m: str) -> bytes:
    return bytes(int(x, 16) for x in m.split(":"))


def ip_bytes(a: str) -> bytes:
    return bytes(int(x) for x in a.split("."))


def uuid_bytes(u: str, little: bool = False) -> bytes:
    b = uuid.UUID(u).bytes
    if little:
        return b[3::-1] + b[5:3:-1] + b[7:5:-1] + b[8:]
    return b


def ipv4(src: str, dst: str, payload: bytes, proto: int = 17, ident: int = 1, flags_frag: int = 0) -> bytes:
    hdr = struct.pack(">BBHHHBBH4s4s", 0x45, 0, 20 + len(payload), ident, flags_frag, 64, proto, 0,
                      ip_bytes(src), ip_bytes(dst))
    return hdr + payload


def udp(sport: int, dport: int, payload: bytes) -> bytes:
    return struct.pack(">HHHH", sport, dport, 8 + len(payload), 0x1234) + payload


def eth(src: str, dst: str, payload: bytes, ethertype: int = 0x0800) -> bytes:
    frame = mac_bytes(dst) + mac_bytes(src) + struct.pack(">H", ethertype) + payload
    return frame + b"\x00" * max(0, 60 - len(frame))


def frame(src_mac, dst_mac, src_ip, dst_ip, sport, dport, payload) -> bytes:
    return eth(src_mac, dst_mac, ipv4(src_ip, dst_ip, udp(sport, dport, payload)))


def dcerpc(ptype: int, opnum: int, body: bytes, *, act: str = "00000001-0000-1010-8000-000000000001",
           seq: int = 0, little: bool = False, flags1: int = 0x20, frag_num: int = 0,
           if_id: str = DEVICE_IF, obj: str = "dea00000-6c97-11d1-8271-000100010279") -> bytes:
    o = "<" if little else ">"
    hdr = bytes([4, ptype, flags1, 0, 0x10 if little else 0, 0, 0, 0])
    hdr += uuid_bytes(obj, little) + uuid_bytes(if_id, little) + uuid_bytes(act, little)
    hdr += struct.pack(o + "IIIHHHHH", 0, 1, seq, opnum, 0xFFFF, 0xFFFF, len(body), frag_num)
    hdr += bytes([0, 0])
    return hdr + body


def ndr_request(blocks: bytes, little: bool = False, args_max: int = 4096) -> bytes:
    o = "<" if little else ">"
    return struct.pack(o + "5I", args_max, len(blocks), args_max, 0, len(blocks)) + blocks


def ndr_response(blocks: bytes, little: bool = False, status: bytes = b"\0\0\0\0", args_max: int = 4096) -> bytes:
    o = "<" if little else ">"
    st = int.from_bytes(status, "big")
    return struct.pack(o + "5I", st, len(blocks), args_max, 0, len(blocks)) + blocks


def block(bt: int, body: bytes, vlow: int = 0) -> bytes:
    return struct.pack(">HHBB", bt, len(body) + 2, 1, vlow) + body


def ar_block_req(station: str = "plc", ar_uuid: str = AR_UUID, udp_port: int = 0x8892, ar_type: int = 1,
                 mac: str = CONTROLLER_MAC) -> bytes:
    name = station.encode()
    body = struct.pack(">H", ar_type) + uuid_bytes(ar_uuid) + struct.pack(">H", 1) + mac_bytes(mac)
    body += uuid_bytes("dea00000-6c97-11d1-8271-000100010279") + struct.pack(">IHHH", 0x11, 600, udp_port, len(name))
    return block(0x0101, body + name)


def ar_block_res(ar_uuid: str = AR_UUID) -> bytes:
    return block(0x8101, struct.pack(">H", 1) + uuid_bytes(ar_uuid) + struct.pack(">H", 1)
                 + mac_bytes(DEVICE_MAC) + struct.pack(">H", 0x8892))


def iocr_req(iocr_type: int, ref: int, frame_id: int, data_len: int, objects, iocs, api: int = 0,
             rt_class: int = 1, rr: int = 2) -> bytes:
    body = struct.pack(">HHHIHHHHHHIHHH", iocr_type, ref, 0x8892, rt_class, data_len, frame_id, 32, rr, 1, 0,
                       0xFFFFFFFF, 3, 3, 0xC000)
    body += b"\0" * 6 + struct.pack(">H", 1) + struct.pack(">IH", api, len(objects))
    for s, ss, off in objects:
        body += struct.pack(">HHH", s, ss, off)
    body += struct.pack(">H", len(iocs))
    for s, ss, off in iocs:
        body += struct.pack(">HHH", s, ss, off)
    return block(0x0102, body)


def iocr_res(iocr_type: int, ref: int, frame_id: int) -> bytes:
    return block(0x8102, struct.pack(">HHH", iocr_type, ref, frame_id))


def alarmcr_req() -> bytes:
    return block(0x0103, struct.pack(">HHIHHHHHH", 1, 0x8892, 0, 5, 3, 0x8001, 200, 0xC000, 0xA000))


def alarmcr_res() -> bytes:
    return block(0x8103, struct.pack(">HHH", 1, 0x8002, 200))


def expected(api: int, slot: int, module_ident: int, subs) -> bytes:
    """subs: [(subslot, ident, type, in_len, out_len)]; ``type`` is the whole SubmoduleProperties (bits 0-1 the
    type, bit 2 SharedInput, bits 3/4 ReduceInput/OutputSubmoduleDataLength: wire.md §6.6)"""
    body = struct.pack(">HIHIHH", 1, api, slot, module_ident, 0, len(subs))
    for ss, ident, typ, in_len, out_len in subs:
        body += struct.pack(">HIH", ss, ident, typ)
        if (typ & 3) in (0, 1, 3):
            body += struct.pack(">HHBB", 1, in_len if typ & 3 else 0, 1, 1)
        if (typ & 3) in (2, 3):
            body += struct.pack(">HHBB", 2, out_len, 1, 1)
    return block(0x0104, body)


def rw_header(bt: int, index: int, length: int, *, seq: int = 1, api: int = 0x3D00, slot: int = 1,
              subslot: int = 1, ar_uuid: str = AR_UUID, status: bytes = b"\0\0\0\0") -> bytes:
    body = struct.pack(">H", seq) + uuid_bytes(ar_uuid) + struct.pack(">IHHHHI", api, slot, subslot, 0, index, length)
    if bt == 0x8008:
        body += struct.pack(">HH", 0, 0) + status + b"\0" * 16
    elif bt == 0x8009:
        body += b"\0" * 24
    else:
        body += b"\0" * 24
    return block(bt, body)


def _pair(opnum: int, req_body: bytes, res_body: bytes, plc: tuple, seq: int = 0, little: bool = False):
    """(request, response) frames of one call of ``plc`` (PLC: mac, ip, AR UUID, activity) to the device."""
    mac, ip, _ar, act = plc
    req = frame(mac, DEVICE_MAC, ip, DEVICE_IP, 49153, 34964, dcerpc(0, opnum, req_body, act=act, seq=seq))
    res = frame(DEVICE_MAC, mac, DEVICE_IP, ip, 49154, 49153,
                dcerpc(2, opnum, res_body, act=act, seq=seq, little=little, flags1=0x0A))
    return req, res


def connect_pair(subs, api: int = 0x3D00, in_fid: int = 0x8000, out_fid: int = 0x8001, rt_class: int = 1,
                 rr: tuple = (2, 2), plc: tuple = PLC, diff: bytes = b"", **kw):
    """(request frame, response frame) of a Connect with ``subs``: (subslot, ident, type, in_len, out_len) of a
    slot-1 module, or (slot, subslot, ident, type, in_len, out_len) for modules in several slots; ``type`` may
    carry SubmoduleProperties bits (expected()): a reduced direction's IO data object has no data bytes.
    ``plc``: the calling controller and its AR (PLC); ``diff``: blocks appended to the response (a
    ModuleDiffBlock)."""
    subs = [s if len(s) == 6 else (1, *s) for s in subs]
    in_objs, out_objs, in_iocs, out_iocs = [], [], [], []
    ioff = ooff = 0
    for slot, ss, _ident, typ, in_len, out_len in subs:
        if (typ & 3) in (0, 1, 3):
            in_objs.append((slot, ss, ioff))
            ioff += (in_len if typ & 3 and not typ & 0x08 else 0) + 1
        if (typ & 3) in (2, 3):
            out_objs.append((slot, ss, ooff))
            ooff += (0 if typ & 0x10 else out_len) + 1
    for s, ss, _ in out_objs:
        in_iocs.append((s, ss, ioff))
        ioff += 1
    for s, ss, _ in in_objs:
        out_iocs.append((s, ss, ooff))
        ooff += 1
    exp = b""
    for slot in dict.fromkeys(s[0] for s in subs):
        exp += expected(api, slot, 0x100, [s[1:] for s in subs if s[0] == slot])
    kw.setdefault("ar_uuid", plc[2])
    req_blocks = (ar_block_req(mac=plc[0], **kw)
                  + iocr_req(1, 1, in_fid, max(40, ioff), in_objs, in_iocs, api, rt_class, rr[0])
                  + iocr_req(2, 2, 0xFFFF, max(40, ooff), out_objs, out_iocs, api, rt_class, rr[1]) + alarmcr_req()
                  + exp)
    res_blocks = ar_block_res(kw["ar_uuid"]) + iocr_res(1, 1, in_fid) + iocr_res(2, 2, out_fid) + alarmcr_res() + diff
    return _pair(0, ndr_request(req_blocks), ndr_response(res_blocks, little=True), plc, little=True)


def prm_end_pair(seq: int = 1, plc: tuple = PLC) -> tuple[bytes, bytes]:
    """(request, response) of the controller's Control(PrmEnd): IODControlReq 0x0110, ControlCommand 0x0001, and
    the device's IODControlRes 0x8110 with Done 0x0008 (wire.md §6.8)."""
    def body(bt, cmd):
        return block(bt, b"\0\0" + uuid_bytes(plc[2]) + struct.pack(">HHHH", 1, 0, cmd, 0))
    return _pair(4, ndr_request(body(0x0110, 0x0001)), ndr_response(body(0x8110, 0x0008)), plc, seq)


def release_pair(seq: int = 1, plc: tuple = PLC) -> tuple[bytes, bytes]:
    """(request, response) of the controller's Release: IODReleaseReq 0x0114, ControlCommand 0x0004 (Release), and
    the device's 0x8114 with Done 0x0008 (wire.md §6.8)."""
    def body(bt, cmd):
        return block(bt, b"\0\0" + uuid_bytes(plc[2]) + struct.pack(">HHHH", 1, 0, cmd, 0))
    return _pair(1, ndr_request(body(0x0114, 0x0004)), ndr_response(body(0x8114, 0x0008)), plc, seq)


def write_pair(index: int, data: bytes, *, seq: int = 2, api: int = 0x3D00, slot: int = 1, subslot: int = 1,
               plc: tuple = PLC, status: bytes = b"\0\0\0\0"):
    """(request, response) of a record write from the controller to the device: positive, or refused with the
    PNIOStatus ``status`` (in the NDR header and the IODWriteResHeader, wire.md §6.9)."""
    hdr = dict(seq=seq, api=api, slot=slot, subslot=subslot, ar_uuid=plc[2])
    return _pair(3, ndr_request(rw_header(0x0008, index, len(data), **hdr) + data),
                 ndr_response(rw_header(0x8008, index, len(data), status=status, **hdr), status=status), plc, seq)


def read_pair(index: int, data: bytes, *, seq: int = 2, api: int = 0x3D00, slot: int = 1, subslot: int = 1,
              plc: tuple = PLC):
    """(request, positive response with ``data``) of a record read from the controller."""
    hdr = dict(seq=seq, api=api, slot=slot, subslot=subslot, ar_uuid=plc[2])
    return _pair(2, ndr_request(rw_header(0x0009, index, 4096, **hdr)),
                 ndr_response(rw_header(0x8009, index, len(data), **hdr) + data), plc, seq)
