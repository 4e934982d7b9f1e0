"""A minimal pcapng writer: one Section Header, one Ethernet interface, Enhanced Packet Blocks.

Block layouts: pcapng spec (draft-ietf-opsawg-pcapng) §4.1 SHB, §4.2 IDB, §4.3 EPB. Timestamps are
nanoseconds (if_tsresol option = 9) so the simulator's integer-ns clock is written exactly and the
file is byte-identical for the same inputs (no wall clock, no hostname/OS options).
"""
from __future__ import annotations

import struct

LINKTYPE_ETHERNET = 1

# SHB: type, length, byte-order magic, version 1.0, section length -1 (unknown), no options
_SHB = struct.pack("<IIIHHqI", 0x0A0D0D0A, 28, 0x1A2B3C4D, 1, 0, -1, 28)
# IDB with if_tsresol (option 9) = 9 -> 10^-9 s units, then opt_endofopt
_IDB = struct.pack("<IIHHI" "HHB3x" "HH" "I", 1, 32, LINKTYPE_ETHERNET, 0, 0, 9, 1, 9, 0, 0, 32)
_EPB_HEAD = struct.Struct("<IIIIIII")  # type 6, total len, if id, ts high, ts low, caplen, origlen


def header() -> bytes:
    return _SHB + _IDB


def epb(ts_ns: int, frame: bytes) -> bytes:
    n = len(frame)
    pad = -n & 3
    total = 32 + n + pad
    return b"".join((_EPB_HEAD.pack(6, total, 0, ts_ns >> 32, ts_ns & 0xFFFFFFFF, n, n),
                     frame, b"\0" * pad, struct.pack("<I", total)))


class Writer:
    """Buffered writer; ``write(ts_ns, frame)`` per frame, ``write_raw`` for pre-built EPB chunks."""

    def __init__(self, f):
        self.f = f
        self.f.write(header())
        self.frames = 0

    def write(self, ts_ns: int, frame: bytes) -> int:
        self.f.write(epb(ts_ns, frame))
        self.frames += 1
        return self.frames

    def write_raw(self, chunk, nframes: int) -> None:
        self.f.write(chunk)
        self.frames += nframes
