"""What every PNIO-CM block decoder shares: a bounds-checked big-endian cursor over one block body
and bit-field extraction as tshark shows it (field = (value & mask) >> lowest bit of mask).

The block-family modules (pnio_cm core, pdrecords, cmblocks) all decode with these, so a
truncated body raises the same Malformed everywhere.
"""
from __future__ import annotations

from .common import Malformed, mac
from .dcerpc import get_uuid

L = "pnio_cm"


class Cursor:
    """A tiny big-endian cursor: every read checks the bounds and raises Malformed."""

    __slots__ = ("b", "o", "end", "what", "start")

    def __init__(self, b: bytes, o: int, end: int, what: str):
        self.b, self.o, self.end, self.what = b, o, end, what
        self.start = o - 6  # the block header: alignment counts from there

    def take(self, n: int) -> int:
        if self.o + n > self.end:
            raise Malformed(L, f"{self.what} truncated at offset {self.o} (needs {n} more bytes, "
                               f"{self.end - self.o} left)")
        o = self.o
        self.o += n
        return o

    def u8(self) -> int:
        return self.b[self.take(1)]

    def u16(self) -> int:
        o = self.take(2)
        return (self.b[o] << 8) | self.b[o + 1]

    def u32(self) -> int:
        o = self.take(4)
        return int.from_bytes(self.b[o:o + 4], "big")

    def uuid(self) -> str:
        return get_uuid(self.b, self.take(16), "big")

    def mac(self) -> str:
        o = self.take(6)
        return mac(self.b[o:o + 6])

    def text(self, n: int) -> str:
        o = self.take(n)
        return self.b[o:o + n].decode("latin-1")

    def align4(self) -> None:
        """Skip the padding to the next 4-byte boundary, counted from the block header."""
        self.take((-(self.o - self.start)) % 4)

    def left(self) -> int:
        return self.end - self.o


def bits(v: int, table: tuple) -> dict:
    """Bit fields as tshark shows them: (name, mask) -> (v & mask) >> lowest bit of mask."""
    out = {}
    for name, mask in table:
        out[name] = (v & mask) >> ((mask & -mask).bit_length() - 1)
    return out
