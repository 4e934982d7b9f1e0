"""Frame index: where every record of a buffered window lies, found with NumPy, not a loop per frame.

The reader (pndiss/capture.py) holds a window of the file; the engine (pndiss/engine.py) asks for the
records from ``pos`` on as arrays (block offset, data offset, captured length, interface, raw time
stamp). A pcapng record chain is serial -- each block's length says where the next one starts -- but
every block starts 4-byte aligned, so the window seen as 32-bit words gives every candidate at once:
an Enhanced Packet Block is a word 6 whose length word is sane and whose trailing length repeats it.
A word 6 inside packet data that looks like a block too is possible (IO data is small integers), so
the candidates are verified as a chain (each block's end is the next candidate); where a candidate
is not on the chain it is dropped and the check goes on. The index stops at the first record that is
no such EPB (an IDB, a custom block, a corrupt block): the reader takes that one its own careful way,
with tshark's checks and messages.

pcap records are not aligned; their chain is walked with one unpack per record (still no per-frame
tuple, bytes slice or generator step).
"""
from __future__ import annotations

import struct

import numpy as np

from .capture import MAX_PACKET, MAX_RECORD

MIN_EPB = 32


class Index:
    """Records of a window: parallel arrays, one entry per frame, in file order."""

    __slots__ = ("block", "data", "cap", "ifid", "raw_ts", "end", "orig", "fcs")

    def __init__(self, block, data, cap, ifid, raw_ts, end: int, orig=None, fcs=None):
        self.block = block      # int64 offset of the record in the buffer
        self.data = data        # int64 offset of its packet data
        self.cap = cap          # int64 captured length
        self.ifid = ifid        # int64 interface id (pcapng), 0 for pcap
        self.raw_ts = raw_ts    # uint64 raw time stamp: pcapng (hi << 32 | lo) units, pcap (sec, frac) packed
        self.end = end          # buffer offset after the last indexed record
        self.orig = cap if orig is None else orig   # int64 length on the wire (> cap: the capture cut it)
        self.fcs = fcs          # int64 FCS length its epb_flags option states (0: none), or None: no options

    def __len__(self) -> int:
        return len(self.block)


EMPTY = np.zeros(0, dtype=np.int64)


def _empty(pos: int) -> Index:
    return Index(EMPTY, EMPTY, EMPTY, EMPTY, EMPTY.astype(np.uint64), pos)


def pcapng(buf, pos: int, end: int, bo: str, nif: int) -> Index:
    """EPBs from ``pos`` (a block start) up to the first record that is not a plain, whole EPB."""
    nw = (end - pos) >> 2
    if nw < MIN_EPB // 4:
        return _empty(pos)
    W = np.frombuffer(buf, dtype=bo + "u4", count=nw, offset=pos)
    c = np.flatnonzero(W == 6)
    if not len(c) or c[0] != 0:
        return _empty(pos)
    c = c[c + 7 < nw]
    blen = W[c + 1].astype(np.int64)
    nwb = blen >> 2
    ok = (blen & 3 == 0) & (blen >= MIN_EPB) & (blen <= MAX_RECORD) & (c + nwb <= nw)
    c, blen, nwb = c[ok], blen[ok], nwb[ok]
    cap = W[c + 5].astype(np.int64)
    ok = (W[c + nwb - 1] == blen) & (W[c + 2] < nif) & (cap <= MAX_PACKET) & (cap + MIN_EPB <= blen)
    c, nwb = c[ok], nwb[ok]
    c = _chain(c, c + nwb)
    if not len(c):
        return _empty(pos)
    fcs = None
    nwb = (W[c + 1] >> 2).astype(np.int64)
    opt = c + 7 + ((W[c + 5].astype(np.int64) + 3) >> 2)      # word of the first option
    if (opt < c + nwb - 1).any():
        # options (a TAP's epb_flags with the packet's FCS length, pcapng spec §4.3.1): the first six looked at;
        # a block whose options say nothing within those ends the index (the reader reads it option by option)
        fcs, todo = np.zeros(len(c), dtype=np.int64), opt < c + nwb - 1
        careful = np.zeros(len(c), dtype=bool)
        for _ in range(6):
            w = W[np.where(todo, opt, 0)].astype(np.int64)
            code, olen = (w & 0xFFFF, w >> 16) if bo == "<" else (w >> 16, w & 0xFFFF)
            hit = todo & (code == 2) & (olen == 4) & (opt + 1 < c + nwb - 1)
            fcs = np.where(hit, (W[np.where(hit, opt + 1, 0)].astype(np.int64) >> 5) & 0xF, fcs)
            # an epb_dropcount the tool filled in: the reader takes that packet (pcapng_read.epb_options counts it)
            drop = todo & (code == 4) & (olen == 8) & (opt + 2 < c + nwb - 1)
            lo, hi = W[np.where(drop, opt + 1, 0)], W[np.where(drop, opt + 2, 0)]
            drop &= ((lo | hi) != 0) & ~((lo == 0xFFFFFFFF) & (hi == 0xFFFFFFFF))   # (all ones: unknown)
            careful |= drop
            todo &= ~drop & (code != 0)
            opt = opt + 1 + ((olen + 3) >> 2)
            todo &= opt < c + nwb - 1
        careful |= todo
        if careful.any():
            k = int(np.argmax(careful))
            if k == 0:
                return _empty(pos)
            c, fcs = c[:k], fcs[:k]
    last = int(c[-1])
    stop = pos + ((last + int(W[last + 1] >> 2)) << 2)
    raw = (W[c + 3].astype(np.uint64) << np.uint64(32)) | W[c + 4].astype(np.uint64)
    return Index(pos + (c << 2), pos + (c << 2) + 28, W[c + 5].astype(np.int64), W[c + 2].astype(np.int64), raw, stop,
                 W[c + 6].astype(np.int64), fcs)


def _chain(c, nxt):
    """The candidates that lie on the record chain from c[0]: where nxt[k] is not c[k + 1], candidate
    k + 1 (and any other before nxt[k]) sits inside block k and is dropped; the chain ends where the
    next block is no candidate."""
    keep_parts = []
    while len(c):
        bad = nxt[:-1] != c[1:]
        if not bad.any():
            keep_parts.append(c)
            break
        k = int(np.argmax(bad))
        keep_parts.append(c[:k + 1])
        # resume at the true next block, if it is a candidate
        j = int(np.searchsorted(c, nxt[k]))
        if j >= len(c) or c[j] != nxt[k]:
            break
        c, nxt = c[j:], nxt[j:]
    return np.concatenate(keep_parts) if len(keep_parts) > 1 else (keep_parts[0] if keep_parts else c)


_PCAP_HDR = {"<": struct.Struct("<I"), ">": struct.Struct(">I")}


def pcap(buf, pos: int, end: int, bo: str, limit: int = 1 << 20) -> Index:
    """pcap records from ``pos`` while whole and sane (at most ``limit``)."""
    unpack = _PCAP_HDR[bo].unpack_from
    offs = []
    add = offs.append
    p = pos
    while p + 16 <= end and len(offs) < limit:
        incl = unpack(buf, p + 8)[0]
        q = p + 16 + incl
        if q > end or incl > MAX_RECORD:
            break
        add(p)
        p = q
    if not offs:
        return _empty(pos)
    b = np.array(offs, dtype=np.int64)
    m = len(b)
    u = np.frombuffer(buf, dtype=np.uint8, count=end - pos, offset=pos)
    rel = b - pos
    dt = np.dtype(bo + "u4")

    def word(k):
        idx = rel[:, None] + (k + np.arange(4))
        return u[idx].copy().view(dt).reshape(m).astype(np.int64)

    sec, frac, incl, orig = word(0), word(4), word(8), word(12)
    raw = (sec.astype(np.uint64) << np.uint64(32)) | frac.astype(np.uint64)
    return Index(b, b + 16, incl, np.zeros(m, dtype=np.int64), raw, p, orig)
