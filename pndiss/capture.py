"""Streaming pcap / pcapng reader.

Reads the file in fixed-size chunks (never the whole file, never an mmap whose touched pages
would count against RSS) and yields ``(frame_number, ts_ns, linktype, data)`` tuples.
Frame numbers are 1-based and count packet blocks exactly as Wireshark's ``frame.number``;
timestamps are integer nanoseconds since the epoch.

A file that ends inside a record raises :class:`CaptureError` *after* yielding every complete
frame, so callers can report the frames read so far.
"""
from __future__ import annotations

import struct
from typing import BinaryIO, Iterator

LINKTYPE_ETHERNET = 1
LINKTYPE_LINUX_SLL = 113
LINKTYPE_LINUX_SLL2 = 276

MAX_RECORD = 0x4000000  # 64 MiB: larger captured lengths mean a corrupt file
CHUNK = 1 << 22  # 4 MiB reads: large enough to amortise syscalls, small enough for flat RSS

PCAP_MAGICS = {  # magic as read little-endian -> (byte order, ns resolution)
    0xA1B2C3D4: ("<", False),
    0xA1B23C4D: ("<", True),
    0xD4C3B2A1: (">", False),
    0x4D3CB2A1: (">", True),
}
PCAPNG_SHB = 0x0A0D0D0A


class CaptureError(Exception):
    """Unusable or damaged capture file; ``frames`` is how many frames were read before it."""

    def __init__(self, message: str, frames: int = 0):
        super().__init__(message)
        self.frames = frames


class _Buffer:
    """A window over the file: ``need(n)`` guarantees n bytes at ``pos`` or reports EOF."""

    __slots__ = ("f", "buf", "pos", "eof", "base")

    def __init__(self, f: BinaryIO):
        self.f = f
        self.buf = b""
        self.pos = 0
        self.eof = False
        try:
            self.base = f.tell() if f.seekable() else None   # file offset of buf[0]
        except OSError:
            self.base = None

    def need(self, n: int) -> bool:
        avail = len(self.buf) - self.pos
        if avail >= n:
            return True
        if self.eof:
            return False
        if self.base is not None:
            # a regular file: read the window afresh from the first unused byte (re-reading the
            # unused tail is cheaper than joining it to the next chunk: one copy of 4 MiB less)
            self.base += self.pos
            self.f.seek(self.base)
            want = max(CHUNK, n)
            self.buf = self.f.read(want)
            self.pos = 0
            if len(self.buf) < want:
                self.eof = True
            return len(self.buf) >= n
        parts = [self.buf[self.pos:]]
        while avail < n and not self.eof:
            chunk = self.f.read(max(CHUNK, n - avail))
            if not chunk:
                self.eof = True
                break
            parts.append(chunk)
            avail += len(chunk)
        self.buf = b"".join(parts)
        self.pos = 0
        return avail >= n

    def at_end(self) -> bool:
        return not self.need(1)


def open_capture(path: str, batch=None) -> Iterator[tuple[int, int, int, bytes]]:
    """Yield frames of the pcap/pcapng file at ``path``; raise CaptureError on bad input.

    ``batch`` (pndiss/batch.py) is offered the buffered records now and then: it may consume a
    whole steady run of them itself (those frames are then not yielded; frame numbers still count
    them) or say after how many frames to ask again."""
    from .inputs import open_input  # '-', pipes, gzip/zstd/xz (pndiss/inputs.py)

    f = open_input(path)
    with f:
        b = _Buffer(f)
        if not b.need(4):
            raise CaptureError(f"{path}: empty file or too short to be a capture (no pcap/pcapng header)")
        magic = struct.unpack_from("<I", b.buf, 0)[0]
        if magic in PCAP_MAGICS:
            yield from _read_pcap(path, b, *PCAP_MAGICS[magic], batch)
        elif magic == PCAPNG_SHB:
            yield from _read_pcapng(path, b, batch)
        else:
            raise CaptureError(f"{path}: not a pcap or pcapng file (magic 0x{magic:08x})")


NEVER = 1 << 62  # frame number at which to offer records to the batch path when there is none


def _read_pcap(path: str, b: _Buffer, bo: str, ns: bool, batch=None) -> Iterator[tuple[int, int, int, bytes]]:
    if not b.need(24):
        raise CaptureError(f"{path}: pcap file header truncated")
    linktype = struct.unpack_from(bo + "I", b.buf, b.pos + 20)[0] & 0x0FFFFFFF  # upper bits: FCS info
    b.pos += 24
    unpack = struct.Struct(bo + "IIII").unpack_from
    mult = 1 if ns else 1000
    n = 0
    take = batch.pcap(bo, linktype, mult) if batch is not None else None
    retry = 0 if take is not None else NEVER
    while True:
        # Inner loop over the records already buffered: no method call per frame.
        buf, pos, end = b.buf, b.pos, len(b.buf)
        while pos + 16 <= end:
            if n >= retry:  # the batch path takes a steady run, or says when to ask again
                r = take(buf, pos, end, n)
                if r.__class__ is tuple:
                    pos, n = r
                    continue
                retry = n + r
            sec, frac, incl, _orig = unpack(buf, pos)
            start = pos + 16
            stop = start + incl
            if stop > end or incl > MAX_RECORD:
                break
            n += 1
            yield n, sec * 1_000_000_000 + frac * mult, linktype, buf[start:stop]
            pos = stop
        b.pos = pos
        # The next record is not wholly buffered: read more, or say why the file ends here.
        if not b.need(16):
            if len(b.buf) - b.pos:
                raise CaptureError(f"{path}: truncated record header after frame {n}", n)
            return
        incl = unpack(b.buf, b.pos)[2]
        if incl > MAX_RECORD:
            raise CaptureError(f"{path}: corrupt record after frame {n} (captured length {incl})", n)
        if not b.need(16 + incl):
            raise CaptureError(f"{path}: frame {n + 1} truncated ({len(b.buf) - b.pos - 16} of {incl} bytes)", n)


def _tsres_to_ns(resol: int):
    """Return a function converting pcapng timestamp units to ns (if_tsresol, default 10^-6)."""
    if resol & 0x80:
        shift = resol & 0x7F
        return lambda t: (t * 1_000_000_000) >> shift
    exp = resol
    if exp <= 9:
        m = 10 ** (9 - exp)
        return lambda t: t * m
    d = 10 ** (exp - 9)
    return lambda t: t // d


def _read_pcapng(path: str, b: _Buffer, batch=None) -> Iterator[tuple[int, int, int, bytes]]:
    n = 0
    retry = 0 if batch is not None else NEVER
    bo = "<"
    epb_bo = {"<": struct.Struct("<IIIIII"), ">": struct.Struct(">IIIIII")}  # type, length, if, ts hi/lo, caplen
    ifaces: list[tuple[int, object, int, int]] = []  # (linktype, ts->ns function, tsoffset ns, multiplier or 0)
    while True:
        if not b.need(12):
            if len(b.buf) - b.pos:
                raise CaptureError(f"{path}: truncated block header after frame {n}", n)
            return
        btype = struct.unpack_from(bo + "I", b.buf, b.pos)[0]
        if btype == PCAPNG_SHB:  # byte order may change per section
            bom = b.buf[b.pos + 8:b.pos + 12]
            if bom == b"\x4d\x3c\x2b\x1a":
                bo = "<"
            elif bom == b"\x1a\x2b\x3c\x4d":
                bo = ">"
            else:
                raise CaptureError(f"{path}: corrupt pcapng section header after frame {n}", n)
            ifaces = []
        blen = struct.unpack_from(bo + "I", b.buf, b.pos + 4)[0]
        if blen < 12 or blen % 4 or blen > MAX_RECORD:
            raise CaptureError(f"{path}: corrupt pcapng block (length {blen}) after frame {n}", n)
        if not b.need(blen):
            raise CaptureError(f"{path}: pcapng block truncated after frame {n}", n)
        if btype == 6 and ifaces:
            # Inner loop over the Enhanced Packet Blocks already buffered (99.9% of a capture):
            # one precompiled unpack per block, no method call; anything else goes the long way.
            buf, pos, end = b.buf, b.pos, len(b.buf)
            unpack = epb_bo[bo].unpack_from
            nif = len(ifaces)
            take = batch.pcapng(bo, ifaces) if batch is not None else None
            while pos + 28 <= end:
                if n >= retry:  # the batch path takes a steady run, or says when to ask again
                    r = take(buf, pos, end, n)
                    if r.__class__ is tuple:
                        pos, n = r
                        continue
                    retry = n + r
                btype, blen, ifid, hi, lo, cap = unpack(buf, pos)
                if btype != 6 or ifid >= nif or blen % 4 or blen < 32 + cap or pos + blen > end:
                    break
                lt, conv, off, mult = ifaces[ifid]
                n += 1
                yield n, (((hi << 32) | lo) * mult if mult else conv((hi << 32) | lo)) + off, lt, buf[pos + 28:pos + 28 + cap]
                pos += blen
            if pos != b.pos:
                b.pos = pos
                continue
            btype, blen = 6, struct.unpack_from(bo + "I", buf, pos + 4)[0]  # not even one: the long way says why
        p = b.pos
        body = p + 8
        if btype == 6:  # Enhanced Packet Block
            ifid, hi, lo, cap, _orig = struct.unpack_from(bo + "IIIII", b.buf, body)
            if ifid >= len(ifaces) or 20 + cap > blen - 12:
                raise CaptureError(f"{path}: bad enhanced packet block after frame {n}", n)
            lt, conv, off, _ = ifaces[ifid]
            n += 1
            yield n, conv((hi << 32) | lo) + off, lt, b.buf[body + 20:body + 20 + cap]
        elif btype == 3:  # Simple Packet Block: interface 0, no timestamp
            if not ifaces:
                raise CaptureError(f"{path}: simple packet block before any interface after frame {n}", n)
            orig = struct.unpack_from(bo + "I", b.buf, body)[0]
            cap = min(orig, blen - 16)
            n += 1
            yield n, 0, ifaces[0][0], b.buf[body + 4:body + 4 + cap]
        elif btype == 2:  # obsolete Packet Block
            ifid, _drops, hi, lo, cap, _orig = struct.unpack_from(bo + "HHIIII", b.buf, body)
            if ifid >= len(ifaces) or 20 + cap > blen - 12:
                raise CaptureError(f"{path}: bad packet block after frame {n}", n)
            lt, conv, off, _ = ifaces[ifid]
            n += 1
            yield n, conv((hi << 32) | lo) + off, lt, b.buf[body + 20:body + 20 + cap]
        elif btype == 1:  # Interface Description Block
            lt = struct.unpack_from(bo + "H", b.buf, body)[0]
            resol, tsoff = 6, 0
            o, end = body + 8, p + blen - 4
            while o + 4 <= end:
                code, olen = struct.unpack_from(bo + "HH", b.buf, o)
                if code == 0:
                    break
                if code == 9 and olen >= 1:
                    resol = b.buf[o + 4]
                elif code == 14 and olen >= 8:
                    tsoff = struct.unpack_from(bo + "q", b.buf, o + 4)[0] * 1_000_000_000
                o += 4 + ((olen + 3) & ~3)
            # decimal resolutions up to ns are a plain multiply: the hot loop inlines it
            ifaces.append((lt, _tsres_to_ns(resol), tsoff, 10 ** (9 - resol) if resol <= 9 else 0))
        b.pos = p + blen
