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

# pcapng block types, tshark 4.0 minimum total lengths (wiretap/pcapng.c) and whether the block is a frame
BT_SHB, BT_IDB, BT_PB, BT_SPB, BT_NRB, BT_ISB, BT_EPB = 0x0A0D0D0A, 1, 2, 3, 4, 5, 6
BT_JOURNAL, BT_DSB, BT_CB, BT_CB_NOCOPY = 9, 10, 0x00000BAD, 0x40000BAD
MIN_LEN = {BT_SHB: 28, BT_IDB: 20, BT_PB: 32, BT_SPB: 16, BT_NRB: 16, BT_ISB: 24, BT_EPB: 32,
           BT_JOURNAL: 35, BT_DSB: 20, BT_CB: 16, BT_CB_NOCOPY: 16}
MIN_NAMES = {BT_SHB: "an SHB", BT_IDB: "an IDB", BT_PB: "a PB", BT_SPB: "an SPB", BT_NRB: "an NRB",
             BT_ISB: "an ISB", BT_EPB: "an EPB", BT_JOURNAL: "a systemd journal export block",
             BT_DSB: "a DSB", BT_CB: "a CB", BT_CB_NOCOPY: "a CB"}
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


class _Buffer:
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


def _check_magic(path: str, head: bytes) -> int:
    if len(head) < 4:
        raise NotACapture(f"{path}: empty file or too short to be a capture (no pcap/pcapng header)")
    magic = struct.unpack_from("<I", head, 0)[0]
    if magic not in PCAP_MAGICS and magic != PCAPNG_SHB:
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
        b = _Buffer(f, info)
        b.need(4)
        magic = _check_magic(path, b.buf[b.pos:b.pos + 4])
        if magic in PCAP_MAGICS:
            yield from _read_pcap(path, b, *PCAP_MAGICS[magic], batch, first)
        else:
            yield from _read_pcapng(path, b, batch, first)


NEVER = 1 << 62  # frame number at which to offer records to the batch path when there is none


UNKNOWN_COUNT = (1 << 64) - 1   # a pcapng counter option the tool could not fill in (dumpcap: G_MAXUINT64)


def epb_options(buf, o: int, end: int, bo: str) -> tuple[int, int]:
    """(FCS length, packets dropped) an Enhanced Packet Block's options state: epb_flags bits 5-8 (a TAP writes the
    FCS length per packet) and epb_dropcount (packets the interface and the OS lost between this packet and the one
    before it; pcapng spec §4.3.1). ``o``: its first option, ``end``: its trailing length."""
    fcs = drops = 0
    while o + 4 <= end:
        code, olen = struct.unpack_from(bo + "HH", buf, o)
        if code == 0:
            break
        if code == 2 and olen == 4 and o + 8 <= end:
            fcs = (struct.unpack_from(bo + "I", buf, o + 4)[0] >> 5) & 0xF
        elif code == 4 and olen == 8 and o + 12 <= end:
            drops = struct.unpack_from(bo + "Q", buf, o + 4)[0]
            if drops == UNKNOWN_COUNT:   # (the tool could not tell)
                drops = 0
        o += 4 + ((olen + 3) & ~3)
    return fcs, drops


def _convert(linktype: int, fcs: int):
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


def _read_pcap(path: str, b: _Buffer, bo: str, ns: bool, batch=None, first: int = 0) -> Iterator[tuple[int, int, int, bytes]]:
    if not b.need(24):
        raise CaptureError(f"{path}: pcap file header truncated")
    raw_lt = struct.unpack_from(bo + "I", b.buf, b.pos + 20)[0]
    linktype = raw_lt & 0x03FFFFFF   # bit 26: an FCS of (bits 28-31) x 16 bits follows every frame
    conv = _convert(linktype, (raw_lt >> 28) * 2 if raw_lt & 0x04000000 else 0)
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


def _tsres_to_ns(resol: int):
    """Return a function converting pcapng timestamp units to ns (if_tsresol, default 10^-6).
    Any resolution is accepted as tshark does: 0x00 and 0x80 are seconds, 10^-127 and 2^-127
    make every time stamp 0."""
    if resol & 0x80:
        shift = resol & 0x7F
        return lambda t: (t * 1_000_000_000) >> shift
    exp = resol
    if exp <= 9:
        m = 10 ** (9 - exp)
        return lambda t: t * m
    d = 10 ** (exp - 9)
    return lambda t: t // d


def _ts_limit(mult: int, off: int) -> int:
    """Largest raw time stamp the EPB loop may multiply by ``mult`` (+ ``off``) without leaving
    [0, TS_MAX]: above it (or below 0 after a negative if_tsoffset) the time stamp is clamped."""
    if not mult or off < 0:
        return -1   # not a plain multiply, or an offset that may go negative: check every frame
    return max(-1, (TS_MAX - off) // mult)


def _read_pcapng(path: str, b: _Buffer, batch=None, first: int = 0) -> Iterator[tuple[int, int, int, bytes]]:
    n = first
    retry = 0 if batch is not None else NEVER
    bo = "<"
    epb_bo = {"<": struct.Struct("<IIIIIII"), ">": struct.Struct(">IIIIIII")}  # type, length, if, ts hi/lo, cap, orig
    # (linktype, ts->ns function, tsoffset ns, multiplier or 0, snaplen, largest raw ts of the fast multiply)
    ifaces: list[tuple] = []
    info = b.info
    last_ts = 0
    sections = 0

    def bad(what: str) -> CaptureError:
        return CaptureError(f"{path}: corrupt pcapng block after frame {n}: {what} (tshark refuses it too)", n)

    def ts_of(fn: int, iface, raw: int) -> int:
        t = iface[1](raw) + iface[2]
        return t if 0 <= t <= TS_MAX else info.clamp(fn, t)

    while True:
        if not b.need(12):
            if len(b.buf) - b.pos:
                raise CaptureError(f"{path}: truncated block header after frame {n}", n, cut_short=True)
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
            sections += 1
        blen = struct.unpack_from(bo + "I", b.buf, b.pos + 4)[0]
        if blen < 12 or blen % 4 or blen > MAX_RECORD:
            raise CaptureError(f"{path}: corrupt pcapng block (length {blen}) after frame {n}", n)
        if not b.need(blen):
            raise CaptureError(f"{path}: pcapng block truncated after frame {n}", n, cut_short=True)
        if btype == 6 and ifaces:
            # Inner loop over the Enhanced Packet Blocks already buffered (99.9% of a capture):
            # one precompiled unpack per block, no method call; anything else goes the long way.
            buf, pos, end = b.buf, b.pos, len(b.buf)
            unpack = epb_bo[bo].unpack_from
            trail = struct.Struct(bo + "I").unpack_from
            nif = len(ifaces)
            take = batch.pcapng(bo, ifaces) if batch is not None else None
            while pos + 28 <= end:
                if n >= retry:  # the batch path takes a steady run, or says when to ask again
                    r = take(buf, pos, end, n)
                    if r.__class__ is tuple:
                        pos, n = r
                        last_ts = info.last_ts   # the engine's last frame's time (an SPB / custom block after it)
                        continue
                    retry = n + r
                btype, blen, ifid, hi, lo, cap, orig = unpack(buf, pos)
                if btype != 6 or ifid >= nif or blen % 4 or blen < 32 + cap or pos + blen > end \
                        or cap > MAX_PACKET or trail(buf, pos + blen - 4)[0] != blen:
                    break
                iface = ifaces[ifid]
                n += 1
                if cap < orig:
                    info.cut(n, cap, orig)
                t = (hi << 32) | lo
                if t <= iface[5]:
                    t = t * iface[3] + iface[2]
                else:
                    t = ts_of(n, iface, t)
                last_ts = t
                if blen > 32 + ((cap + 3) & ~3):
                    f, drops = epb_options(buf, pos + 28 + ((cap + 3) & ~3), pos + blen - 4, bo)
                    if drops:
                        info.tool_dropped(n, drops, t)
                    if f and iface[0] == LINKTYPE_ETHERNET:
                        # the packet's own FCS length (epb_flags) over the interface's (tshark does the same)
                        yield n, t, iface[0], buf[pos + 28:pos + 28 + (cap - f if cap > f else cap)]
                        pos += blen
                        continue
                if iface[6] is None:
                    yield n, t, iface[0], buf[pos + 28:pos + 28 + cap]
                else:
                    yield (n, t, *iface[6](buf[pos + 28:pos + 28 + cap]))
                pos += blen
            if pos != b.pos:
                b.pos = pos
                continue
            btype, blen = 6, struct.unpack_from(bo + "I", buf, pos + 4)[0]  # not even one: the long way says why
        p = b.pos
        body = p + 8
        # what tshark 4.0 checks of every block: its type's minimum length, both lengths equal
        if blen < MIN_LEN.get(btype, 12):
            raise bad(f"total block length {blen} of {MIN_NAMES[btype]} is less than its minimum {MIN_LEN[btype]}")
        if btype != BT_SPB:
            tail = struct.unpack_from(bo + "I", b.buf, p + blen - 4)[0]
            if tail != blen:
                raise bad(f"total block lengths (first {blen} and second {tail}) don't match")
        if btype == BT_EPB or btype == BT_PB:
            if btype == BT_EPB:
                ifid, hi, lo, cap, orig = struct.unpack_from(bo + "IIIII", b.buf, body)
                _drops = 0
            else:
                ifid, _drops, hi, lo, cap, orig = struct.unpack_from(bo + "HHIIII", b.buf, body)
            if ifid >= len(ifaces):
                raise bad(f"interface index {ifid} is not less than the section's interface count {len(ifaces)}")
            if cap > MAX_PACKET:
                raise bad(f"captured length {cap} is larger than {MAX_PACKET}")
            if 32 + cap > blen:
                raise bad(f"total block length {blen} is too small for {cap} bytes of packet data")
            n += 1
            if cap < orig:
                info.cut(n, cap, orig)
            last_ts = ts_of(n, ifaces[ifid], (hi << 32) | lo)
            iface, data = ifaces[ifid], b.buf[body + 20:body + 20 + cap]
            f, drops = epb_options(b.buf, body + 20 + ((cap + 3) & ~3), p + blen - 4, bo) \
                if btype == BT_EPB and blen > 32 + ((cap + 3) & ~3) else (0, 0)
            if btype == BT_PB and 0 < _drops < 0xFFFF:   # the obsolete Packet Block's drops_count (0xFFFF: unknown)
                drops = _drops
            if drops:
                info.tool_dropped(n, drops, last_ts)
            if f and iface[0] == LINKTYPE_ETHERNET:   # the packet's own FCS length (epb_flags) over the interface's
                yield n, last_ts, iface[0], data[:-f] if len(data) > f else data
            else:
                yield (n, last_ts, iface[0], data) if iface[6] is None else (n, last_ts, *iface[6](data))
        elif btype == BT_SPB:  # Simple Packet Block: interface 0, no timestamp, no options
            if not ifaces:
                raise bad("simple packet block before any interface description")
            orig = struct.unpack_from(bo + "I", b.buf, body)[0]
            snap = ifaces[0][4]
            cap = min(orig, snap) if snap else orig
            if 16 + cap > blen:
                raise bad(f"total block length {blen} is too small for {cap} bytes of packet data")
            at = p + 12 + ((cap + 3) & ~3)   # tshark reads the trailing length right after the data
            tail = struct.unpack_from(bo + "I", b.buf, at)[0]
            if tail != blen:
                raise bad(f"total block lengths (first {blen} and second {tail}) don't match")
            n += 1
            if cap < orig:
                info.cut(n, cap, orig)
            iface, data = ifaces[0], b.buf[body + 4:body + 4 + cap]
            # an SPB has no time stamp (tshark shows 1970): the time of the frame before it, so no rule sees a
            # jump of 55 years and back around it (an independent audit: hundreds of false capture gaps)
            t = last_ts or 0
            yield (n, t, iface[0], data) if iface[6] is None else (n, t, *iface[6](data))
        elif btype == BT_CB or btype == BT_CB_NOCOPY or btype == BT_JOURNAL:
            # tshark 4.0 shows custom blocks (any PEN) and systemd journal entries as frames of their
            # own; without counting them every later frame number would be one off Wireshark's
            n += 1
            start = body + 4 if btype != BT_JOURNAL else body
            yield n, last_ts, LINKTYPE_NONE, b.buf[start:p + blen - 4]
        elif btype == BT_ISB:  # Interface Statistics Block: the tool's own counts of what it lost (cumulative)
            ifid = struct.unpack_from(bo + "I", b.buf, body)[0]
            o, end = body + 12, p + blen - 4
            lost = 0
            while o + 4 <= end:
                code, olen = struct.unpack_from(bo + "HH", b.buf, o)
                if code == 0:
                    break
                if code in (5, 7) and olen == 8 and o + 12 <= end:   # isb_ifdrop, isb_osdrop
                    v = struct.unpack_from(bo + "Q", b.buf, o + 4)[0]
                    lost += v if v != UNKNOWN_COUNT else 0   # dumpcap writes all ones when pcap_stats() failed
                o += 4 + ((olen + 3) & ~3)
            info.interface_dropped((path, sections, ifid), lost)
        elif btype == BT_IDB:  # Interface Description Block
            lt, _res, snap = struct.unpack_from(bo + "HHI", b.buf, body)
            resol, tsoff, fcs = 6, 0, 0
            o, end = body + 8, p + blen - 4
            while o + 4 <= end:
                code, olen = struct.unpack_from(bo + "HH", b.buf, o)
                if code == 0:
                    break
                if code == 9 and olen >= 1:
                    resol = b.buf[o + 4]
                elif code == 14 and olen >= 8:
                    tsoff = struct.unpack_from(bo + "q", b.buf, o + 4)[0] * 1_000_000_000
                elif code == 13 and olen >= 1:   # if_fcslen: each frame ends in an FCS of that many bytes
                    fcs = b.buf[o + 4]
                o += 4 + ((olen + 3) & ~3)
            # decimal resolutions up to ns are a plain multiply: the hot loop inlines it
            mult = 10 ** (9 - resol) if resol <= 9 else 0
            # (link type, ts -> ns, offset, multiplier, snaplen, fast-multiply limit, record conversion or None)
            # (+ the FCS length: the engine cuts an Ethernet FCS itself, pndiss/engine.py)
            ifaces.append((lt, _tsres_to_ns(resol), tsoff, mult, snap, _ts_limit(mult, tsoff), _convert(lt, fcs), fcs))
        b.pos = p + blen
