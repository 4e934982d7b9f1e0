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
