"""Streaming pcap / pcapng reader.

Reads the file in fixed-size chunks (never the whole file, never an mmap whose touched pages
would count against RSS) and yields ``(frame_number, ts_ns, linktype, data)`` tuples.
Frame numbers are 1-based and count records exactly as Wireshark's ``frame.number``: tshark 4.0's
wiretap hands custom blocks (0x00000BAD / 0x40000BAD) and systemd journal export blocks to the
dissectors as records of their own, so they are frames too (link type LINKTYPE_NONE here, counted
``not_profinet``). Blocks tshark refuses (a type's minimum length, unequal leading/trailing lengths,
an EPB capturing more than 262,144 bytes, an SPB shorter than its packet) end the read with
CaptureError as they end tshark's (tests/test_pcapng_blocks.py compares each kind with tshark).
Timestamps are integer nanoseconds since the epoch, clamped to [0, 2^63) and counted in ReadInfo
when if_tsresol / if_tsoffset / a 64-bit value put them where no sink can show them.

A file that ends inside a record raises :class:`CaptureError` *after* yielding every complete
frame, so callers can report the frames read so far.
"""
from __future__ import annotations

import os
import stat
import struct
from typing import BinaryIO, Iterator

from .readinfo import TS_MAX, ReadInfo  # noqa: F401  (ReadInfo: what the reader learns besides frames)

LINKTYPE_ETHERNET = 1
LINKTYPE_LINUX_SLL = 113
LINKTYPE_LINUX_SLL2 = 276
LINKTYPE_NETANALYZER = 240   # Hilscher netANALYZER, the TAP of many PROFINET commissioning kits

MAX_RECORD = 0x4000000  # 64 MiB: larger captured lengths mean a corrupt file
MAX_PACKET = 262144     # tshark 4.0 refuses a pcapng packet block capturing more (WTAP_MAX_PACKET_SIZE_STANDARD)
LINKTYPE_NONE = -1      # a frame that is no packet (pcapng custom / journal block): tshark numbers it too

CHUNK = 1 << 22  # 4 MiB reads: large enough to amortise syscalls, small enough for flat RSS

PCAP_MAGICS = {  # magic as read little-endian -> (byte order, ns resolution)
    0xA1B2C3D4: ("<", False),
    0xA1B23C4D: ("<", True),
    0xD4C3B2A1: (">", False),
    0x4D3CB2A1: (">", True),
}
PCAPNG_SHB = 0x0A0D0D0A


class CaptureError(Exception):
    """Unusable or damaged capture file; ``frames`` is how many frames were read before it. ``cut_short``: the
    file ends inside a record (a capture still being written, or a dumpcap killed), tshark 4.0's "appears to
    have been cut short in the middle of a packet"; the frames before it are whole."""

    def __init__(self, message: str, frames: int = 0, cut_short: bool = False):
        super().__init__(message)
        self.frames = frames
        self.cut_short = cut_short


class ChunkBuffer:
    """A window over the file: ``need(n)`` guarantees n bytes at ``pos`` or reports EOF."""

    __slots__ = ("f", "buf", "pos", "eof", "base", "info", "hashed")

    def __init__(self, f: BinaryIO, info: ReadInfo | None = None):
        self.f = f
        self.buf = b""
        self.pos = 0
        self.eof = False
        self.info = info if info is not None else ReadInfo()
        try:
            self.base = f.tell() if f.seekable() else None   # file offset of buf[0]
        except OSError:
            self.base = None
        self.hashed = self.base or 0   # file offset up to which the bytes went into the hash

    def _hash(self, start: int, data: bytes) -> None:
        """Hash the part of ``data`` (read at file offset ``start``) not hashed yet."""
        end = start + len(data)
        if end > self.hashed:
            self.info.feed(memoryview(data)[self.hashed - start:])
            self.hashed = end

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
            self._hash(self.base, self.buf)
            if len(self.buf) < want:
                self.eof = self.info.complete = True
            return len(self.buf) >= n
        parts = [self.buf[self.pos:]]
        while avail < n and not self.eof:
            chunk = self.f.read(max(CHUNK, n - avail))
            if not chunk:
                self.eof = self.info.complete = True
                break
            self._hash(self.hashed, chunk)
            parts.append(chunk)
            avail += len(chunk)
        self.buf = b"".join(parts)
        self.pos = 0
        return avail >= n

    def at_end(self) -> bool:
        return not self.need(1)


class NotACapture(CaptureError):
    """The input is no pcap/pcapng at all (wrong magic, empty): every command refuses it at once."""


def capture_magic(head: bytes) -> bool:
    """``head`` (a file's first bytes) starts a pcap or pcapng file."""
    if len(head) < 4:
        return False
    magic = struct.unpack_from("<I", head, 0)[0]
    return magic in PCAP_MAGICS or magic == PCAPNG_SHB


def _check_magic(path: str, head: bytes) -> int:
    if len(head) < 4:
        raise NotACapture(f"{path}: empty file or too short to be a capture (no pcap/pcapng header)")
    magic = struct.unpack_from("<I", head, 0)[0]
    if not capture_magic(head):
        raise NotACapture(f"{path}: not a pcap or pcapng file (magic 0x{magic:08x})")
    return magic


def refuse_non_capture(path: str) -> None:
    """Raise NotACapture unless ``path`` starts like a pcap/pcapng file: the one check every command
    (analyze, export, plot, report, fleet) runs before it creates any output. Reads 4 bytes of a
    regular file or device (/dev/zero, /dev/urandom: refused at once); a FIFO or stdin cannot be
    peeked without losing the bytes, so there the reader's own first read refuses it."""
    try:
        mode = os.stat(path).st_mode
    except OSError:
        return  # the caller's path check (or open_capture) says why
    if not (stat.S_ISREG(mode) or stat.S_ISCHR(mode) or stat.S_ISBLK(mode)):
        return
    from .inputs import open_input  # a gzip/zstd/xz capture is judged by what it holds
    head = b""
    try:
        with open_input(path) as f:
            while len(head) < 4:
                more = f.read(4 - len(head))
                if not more:
                    break
                head += more
    except OSError as e:
        raise CaptureError(f"cannot open {path}: {e.strerror}") from None
    _check_magic(path, head)


def open_capture(path: str, batch=None, info: ReadInfo | None = None,
                 first: int = 0) -> Iterator[tuple[int, int, int, bytes]]:
    """Yield frames of the pcap/pcapng file at ``path``; raise CaptureError on bad input.

    ``batch`` (the engine, pndiss/engine.py) is offered the buffered records now and then: it may consume a
    whole steady run of them itself (those frames are then not yielded; frame numbers still count
    them) or say after how many frames to ask again. ``info`` (a ReadInfo) receives the input's
    hash and the count of clamped time stamps. ``first``: frames before this file (the pieces of a ring
    buffer are numbered as one capture)."""
    from .inputs import open_input  # '-', pipes, gzip/zstd/xz (pndiss/inputs.py)

    f = open_input(path)
    with f:
        b = ChunkBuffer(f, info)
        b.need(4)
        magic = _check_magic(path, b.buf[b.pos:b.pos + 4])
        if magic in PCAP_MAGICS:
            yield from _read_pcap(path, b, *PCAP_MAGICS[magic], batch, first)
        else:
            from .pcapng_read import read_pcapng   # (the pcapng reader imports this module's helpers)
            yield from read_pcapng(path, b, batch, first)


NEVER = 1 << 62  # frame number at which to offer records to the batch path when there is none


def record_converter(linktype: int, fcs: int):
    """How a record of this link type becomes what the decoders take: None (as it is), netanalyzer(),
    or an Ethernet frame with its FCS cut off (pcapng if_fcslen, pcap FCS length bits: tshark 4.0 strips
    it too, and without this the APDU status would be read from the FCS)."""
    if linktype == LINKTYPE_NETANALYZER:
        return netanalyzer
    if fcs and linktype == LINKTYPE_ETHERNET:
        return lambda data: (LINKTYPE_ETHERNET, data[:-fcs] if len(data) > fcs else data)
    return None


def netanalyzer(data) -> tuple[int, bytes]:
    """A netANALYZER record: a 4-byte little-endian header, then the Ethernet frame with its FCS
    (Wireshark's packet-netanalyzer.c hands the frame to the Ethernet-with-FCS dissector). An Ethernet
    frame (header version 1, or 2 of type 0; not a GPIO event) comes back as plain Ethernet, the way
    tshark's pn_rt sees it; a GPIO event, buffer state or time tick is a frame with no packet."""
    if len(data) >= 22 and not data[1] & 0x01:
        version = (data[1] >> 2) & 0xF
        if version == 1 or (version == 2 and data[3] >> 4 == 0):
            return LINKTYPE_ETHERNET, data[4:-4]
    return LINKTYPE_NONE, data


def _read_pcap(path: str, b: ChunkBuffer, bo: str, ns: bool, batch=None, first: int = 0) -> Iterator[tuple[int, int, int, bytes]]:
    if not b.need(24):
        raise CaptureError(f"{path}: pcap file header truncated")
    raw_lt = struct.unpack_from(bo + "I", b.buf, b.pos + 20)[0]
    linktype = raw_lt & 0x03FFFFFF   # bit 26: an FCS of (bits 28-31) x 16 bits follows every frame
    conv = record_converter(linktype, (raw_lt >> 28) * 2 if raw_lt & 0x04000000 else 0)
    b.pos += 24
    unpack = struct.Struct(bo + "IIII").unpack_from
    mult = 1 if ns else 1000
    n = first
    info = b.info
    take = batch.pcap(bo, linktype, mult, conv) if batch is not None else None
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
            sec, frac, incl, orig = unpack(buf, pos)
            start = pos + 16
            stop = start + incl
            if stop > end or incl > MAX_RECORD:
                break
            n += 1
            if incl < orig:
                info.cut(n, incl, orig)
            if conv is None:
                yield n, sec * 1_000_000_000 + frac * mult, linktype, buf[start:stop]
            else:
                yield (n, sec * 1_000_000_000 + frac * mult, *conv(buf[start:stop]))
            pos = stop
        b.pos = pos
        # The next record is not wholly buffered: read more, or say why the file ends here.
        if not b.need(16):
            if len(b.buf) - b.pos:
                raise CaptureError(f"{path}: truncated record header after frame {n}", n, cut_short=True)
            return
        incl = unpack(b.buf, b.pos)[2]
        if incl > MAX_RECORD:
            raise CaptureError(f"{path}: corrupt record after frame {n} (captured length {incl})", n)
        if not b.need(16 + incl):
            raise CaptureError(f"{path}: frame {n + 1} truncated ({len(b.buf) - b.pos - 16} of {incl} bytes)", n,
                               cut_short=True)
