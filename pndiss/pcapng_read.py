"""The pcapng half of the capture reader (pndiss/capture.py opens the file and hands a pcapng here): sections,
interfaces (if_tsresol, if_tsoffset, if_fcslen), Enhanced / Simple / obsolete Packet Blocks with their options
(epb_flags' FCS length, epb_dropcount), Interface Statistics Blocks (the tool's drop counts), custom and journal
blocks numbered as tshark numbers them; the blocks tshark refuses end the read with its message. A buffered run of
plain EPBs goes to the engine's frame index (``batch``), the rest one by one."""
from __future__ import annotations

import struct
from typing import Iterator

from .capture import (LINKTYPE_ETHERNET, LINKTYPE_NONE, MAX_PACKET, MAX_RECORD, NEVER, PCAPNG_SHB, TS_MAX,
                      CaptureError, ChunkBuffer, record_converter)

# pcapng block types, tshark 4.0 minimum total lengths (wiretap/pcapng.c) and whether the block is a frame
BT_SHB, BT_IDB, BT_PB, BT_SPB, BT_NRB, BT_ISB, BT_EPB = 0x0A0D0D0A, 1, 2, 3, 4, 5, 6
BT_JOURNAL, BT_DSB, BT_CB, BT_CB_NOCOPY = 9, 10, 0x00000BAD, 0x40000BAD
MIN_LEN = {BT_SHB: 28, BT_IDB: 20, BT_PB: 32, BT_SPB: 16, BT_NRB: 16, BT_ISB: 24, BT_EPB: 32,
           BT_JOURNAL: 35, BT_DSB: 20, BT_CB: 16, BT_CB_NOCOPY: 16}
MIN_NAMES = {BT_SHB: "an SHB", BT_IDB: "an IDB", BT_PB: "a PB", BT_SPB: "an SPB", BT_NRB: "an NRB",
             BT_ISB: "an ISB", BT_EPB: "an EPB", BT_JOURNAL: "a systemd journal export block",
             BT_DSB: "a DSB", BT_CB: "a CB", BT_CB_NOCOPY: "a CB"}

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


def read_pcapng(path: str, b: ChunkBuffer, batch=None, first: int = 0) -> Iterator[tuple[int, int, int, bytes]]:
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
            ifaces.append((lt, _tsres_to_ns(resol), tsoff, mult, snap, _ts_limit(mult, tsoff), record_converter(lt, fcs), fcs))
        b.pos = p + blen
