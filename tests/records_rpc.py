"""Test helper: wrap record data in PNIO-CM Read/Write RPC frames (Ethernet/IPv4/UDP/DCE-RPC v4/NDR)
so tshark can decode the records. Layouts: spec/wire.md (DCE/RPC CL header, NDR args, IODWriteReqHeader,
IODReadResHeader); only what tshark needs to call its record dissectors is filled in.
"""
from __future__ import annotations

import struct
import uuid

PNIO_DEVICE_IF = uuid.UUID("dea00001-6c97-11d1-8271-00a02442df7d")  # PNIO device interface (wire.md)
OPNUM_READ, OPNUM_WRITE = 2, 3
HDR_READ_REQ, HDR_READ_RES, HDR_WRITE_REQ, HDR_WRITE_RES = 0x0009, 0x8009, 0x0008, 0x8008


def _rpc(ptype: int, opnum: int, seq: int, activity: uuid.UUID, body: bytes) -> bytes:
    # DCE/RPC connectionless header, little-endian data representation (drep 0x10)
    obj = uuid.UUID("dea00000-6c97-11d1-8271-000100010239")
    return (bytes([4, ptype, 0x20, 0, 0x10, 0, 0, 0]) + obj.bytes_le + PNIO_DEVICE_IF.bytes_le
            + activity.bytes_le + struct.pack("<IIIHHHHHBB", 0, 1, seq, opnum, 0xFFFF, 0xFFFF,
                                              len(body), 0, 0, 0) + body)


def _iod_header(block_type: int, seq: int, api: int, slot: int, subslot: int, index: int,
                length: int, tail: bytes) -> bytes:
    ar = uuid.UUID("11223344-5566-7788-99aa-bbccddeeff00").bytes
    body = (struct.pack(">BBH", 1, 0, seq) + ar + struct.pack(">IHH2xHI", api, slot, subslot, index, length)
            + tail)
    return struct.pack(">HH", block_type, len(body)) + body


def _udp_ip(src_ip: bytes, dst_ip: bytes, sport: int, dport: int, payload: bytes,
            src_mac: bytes, dst_mac: bytes) -> bytes:
    udp = struct.pack(">HHHH", sport, dport, 8 + len(payload), 0) + payload
    ip = struct.pack(">BBHHHBBH4s4s", 0x45, 0, 20 + len(udp), 1, 0, 64, 17, 0, src_ip, dst_ip)
    s = sum(struct.unpack(">10H", ip))
    s = (s & 0xFFFF) + (s >> 16)
    s = (s & 0xFFFF) + (s >> 16)
    ip = ip[:10] + struct.pack(">H", ~s & 0xFFFF) + ip[12:]
    return dst_mac + src_mac + b"\x08\x00" + ip + udp


CTRL = (bytes.fromhex("020000000001"), bytes([192, 168, 0, 1]))
DEV = (bytes.fromhex("020000000002"), bytes([192, 168, 0, 2]))


def write_pair(seq: int, index: int, data: bytes, api=0, slot=1, subslot=1) -> list[bytes]:
    """Write request carrying ``data`` and its positive response."""
    act = uuid.UUID(int=0x1000 + seq)
    hdr = _iod_header(HDR_WRITE_REQ, seq, api, slot, subslot, index, len(data), bytes(24))
    args = hdr + data
    req = struct.pack("<IIIII", 4096, len(args), 4096, 0, len(args)) + args
    rhdr = _iod_header(HDR_WRITE_RES, seq, api, slot, subslot, index, len(data), bytes(4 + 4 + 16))
    res = bytes(4) + struct.pack("<IIII", len(rhdr), 4096, 0, len(rhdr)) + rhdr
    return [_udp_ip(CTRL[1], DEV[1], 49153, 34964, _rpc(0, OPNUM_WRITE, seq, act, req), CTRL[0], DEV[0]),
            _udp_ip(DEV[1], CTRL[1], 34964, 49153, _rpc(2, OPNUM_WRITE, seq, act, res), DEV[0], CTRL[0])]


def read_pair(seq: int, index: int, data: bytes, api=0, slot=1, subslot=1) -> list[bytes]:
    """Read request and its response carrying ``data``."""
    act = uuid.UUID(int=0x2000 + seq)
    hdr = _iod_header(HDR_READ_REQ, seq, api, slot, subslot, index, 4096, bytes(24))
    req = struct.pack("<IIIII", 4096, len(hdr), 4096, 0, len(hdr)) + hdr
    rhdr = _iod_header(HDR_READ_RES, seq, api, slot, subslot, index, len(data), bytes(4 + 20))
    args = rhdr + data
    res = bytes(4) + struct.pack("<IIII", len(args), 4096, 0, len(args)) + args
    return [_udp_ip(CTRL[1], DEV[1], 49153, 34964, _rpc(0, OPNUM_READ, seq, act, req), CTRL[0], DEV[0]),
            _udp_ip(DEV[1], CTRL[1], 34964, 49153, _rpc(2, OPNUM_READ, seq, act, res), DEV[0], CTRL[0])]


def write_pcap(path: str, frames: list[bytes]) -> None:
    with open(path, "wb") as f:
        f.write(struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, 1))
        for i, fr in enumerate(frames):
            f.write(struct.pack("<IIII", 1_700_000_000 + i, 0, len(fr), len(fr)) + fr)
