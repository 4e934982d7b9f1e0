"""Synthetic frames for the LLDP/MRP/PTCP/alarm tests: build Ethernet frames from our own bytes,
write them to a classic pcap in a temporary folder, and compare pndiss with tshark on them.
"""
from __future__ import annotations

import os
import struct

from tsharkdiff import compare, load_maps

SRC = bytes.fromhex("0002a2000001")
DST_LLDP = bytes.fromhex("0180c200000e")


def eth(ethertype: int, payload: bytes, src: bytes = SRC, dst: bytes = DST_LLDP) -> bytes:
    frame = dst + src + struct.pack(">H", ethertype) + payload
    return frame + bytes(max(0, 60 - len(frame)))  # Ethernet minimum size, as on the wire


def pn_rt(frame_id: int, body: bytes, dst: bytes = bytes.fromhex("0002a2000002")) -> bytes:
    return eth(0x8892, struct.pack(">H", frame_id) + body, dst=dst)


def write_pcap(path: str, frames: list[bytes]) -> str:
    with open(path, "wb") as f:
        f.write(struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, 1))
        for i, fr in enumerate(frames):
            f.write(struct.pack("<IIII", 1_700_000_000 + i, 0, len(fr), len(fr)))
            f.write(fr)
    return path


def diff(tmp_path, frames: list[bytes], name: str = "syn.pcap") -> tuple[int, list[str]]:
    """(values compared, mismatches) of pndiss against tshark on ``frames``."""
    path = write_pcap(os.path.join(str(tmp_path), name), frames)
    return compare(path, load_maps())


# -- LLDP ---------------------------------------------------------------------------------------
OUI_PN, OUI_8023, OUI_8021 = bytes.fromhex("000ecf"), bytes.fromhex("00120f"), bytes.fromhex("0080c2")


def tlv(t: int, value: bytes) -> bytes:
    return struct.pack(">H", (t << 9) | len(value)) + value


def org(oui: bytes, sub: int, data: bytes) -> bytes:
    return tlv(127, oui + bytes([sub]) + data)


def lldpdu(name: bytes = b"encoder-1", port: bytes = b"port-001", extra: bytes = b"",
           chassis_subtype: int = 7) -> bytes:
    """An LLDPDU as a PROFINET device sends it: NameOfStation as a locally assigned chassis ID."""
    return (tlv(1, bytes([chassis_subtype]) + name) + tlv(2, b"\x07" + port) + tlv(3, b"\x00\x14")
            + extra + tlv(0, b""))


def mgmt_ipv4(ip: bytes, oid: bytes = bytes.fromhex("2b0601040181c06e")) -> bytes:
    return tlv(8, bytes([5, 1]) + ip + b"\x02" + struct.pack(">I", 1) + bytes([len(oid)]) + oid)


# -- RTA alarms -----------------------------------------------------------------------------------
def rta(pdu_type: int, add_flags: int, send: int, ack: int, sdu: bytes = b"",
        dst_ep: int = 0x8001, src_ep: int = 0x8002) -> bytes:
    return struct.pack(">HHBBHHH", dst_ep, src_ep, pdu_type, add_flags, send, ack, len(sdu)) + sdu


def block(btype: int, body: bytes) -> bytes:
    return struct.pack(">HHBB", btype, len(body) + 2, 1, 0) + body


def notification(alarm_type: int, specifier: int, items: bytes, api: int = 0x3D00, slot: int = 1,
                 subslot: int = 1, module: int = 0x11, submodule: int = 0x101, high: bool = False) -> bytes:
    body = struct.pack(">HIHHIIH", alarm_type, api, slot, subslot, module, submodule, specifier) + items
    return block(0x0001 if high else 0x0002, body)


def channel_item(number: int, props: int, error_type: int) -> bytes:
    return struct.pack(">HHHH", 0x8000, number, props, error_type)


def ext_channel_item(number: int, props: int, error_type: int, ext_type: int, add_value: int) -> bytes:
    return struct.pack(">HHHHHI", 0x8002, number, props, error_type, ext_type, add_value)
