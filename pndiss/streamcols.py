"""Columns of one cyclic stream within a segment (pndiss/engine.py), and the vectorised checks on them.

``Cols`` gathers what the walks need from the window without a Python loop per frame: cycle counter,
DataStatus, captured length, and one data object's bytes; ``signals`` decodes the telegram words as
columns (the value rules' vectorised twins that judge them live in pndiss/encoder/value_rules.py).
"""
from __future__ import annotations

import numpy as np

from . import telegrams as tg
from .gaps import LEARN, WRAP
from .readinfo import JUMP_NS
from .proto.rt import DS_JUDGED

BLOCK = 4096         # pairs judged per vectorised pass
RETRY_MAX = 64       # frames one by one after a failed attempt before the next (backoff)


class Cols:
    """One stream's frames in a segment: counters, status, and (``obj``) one data object's bytes."""

    def __init__(self, w, s, p):
        u8 = w.u8
        d = w.data[p]
        cap = w.cap[p]
        self.w = w
        self.s = s
        self.p = p
        self.fn = w.n + 1 + p
        self.ts = w.ts[p]
        self.d = d
        self.cap0 = int(cap[0])
        self.capbad = cap != self.cap0
        end = d + cap   # each row's own end: a shorter frame may end the buffer (its APDU status is its last 4 bytes)
        self.cc = (u8[end - 4].astype(np.int64) << 8) | u8[end - 3]
        self.ds = ((u8[end - 2] & DS_JUDGED) == DS_JUDGED) & (u8[end - 1] == 0)   # rt.judgeable, vectorised
        self._end = end
        self.off = 18 if w.tagged[p[0]] else 14
        self.L = self.cap0 - self.off - 6                # C_SDU length (up to the APDU status)
        self.M = None
        self.start = 0

    def primary(self):
        """DataStatus.State per frame: Primary (wire.md §2.3; a system redundancy AR judges only those)."""
        return (self.w.u8[self._end - 2] & 1) == 1

    def obj(self, o) -> bool:
        """Gather the bytes of data object ``o`` (its IOPS byte included when the C_SDU has it)."""
        end = min(o.iops_at + 1, self.L)
        if o.end > self.L or o.start >= end:
            return False
        self.start = o.start
        base = self.d + self.off + 2 + o.start
        # rows of another length (capbad, never bulk) may be shorter than this layout: clamped to the buffer
        ix = base[:, None] + np.arange(end - o.start)
        if self.capbad.any():
            np.minimum(ix, len(self.w.u8) - 1, out=ix)
        self.M = self.w.u8[ix]
        return True

    def good(self, k: int):
        """Per row: the IOxS byte at C_SDU offset ``k`` says GOOD (False where the C_SDU ends before it)."""
        if k >= self.L:
            return np.zeros(len(self.p), dtype=bool)
        return (self.w.u8[self.d + self.off + 2 + k] & 0x80) != 0

    def iops(self, o):
        """Per row the IOPS byte of the data object, or None when the C_SDU ends before it."""
        return self.M[:, o.iops_at - self.start] if o.iops_at < self.L else None

    def gaps_bad(self, gaps, a: int, b: int):
        """Per row of [a, b): the gap tracker would not see an exact one-step advance (or learns something)."""
        st = gaps.streams.get(self.s.key)
        n = b - a
        if st is None or st.cc is None:
            return np.ones(n, dtype=bool)
        if not gaps.enabled:
            return np.zeros(n, dtype=bool)
        if not st.step:
            return np.ones(n, dtype=bool)
        prev = np.empty(n, dtype=np.int64)
        prev[1:] = self.cc[a:b - 1]
        # row a follows the last frame the tracker took, not row a-1: a stale frame (an older counter) is
        # discarded and leaves the tracker where it was (gaps.duplicate)
        prev[0] = st.cc
        bad = ((self.cc[a:b] - prev) % WRAP) != st.step
        if st.ts is not None:   # a pause of half a second or more: a wrap, or a clock step (gaps.advance)
            t = self.ts[a:b]
            bad[0] |= int(t[0]) - st.ts >= JUMP_NS
            bad[1:] |= (t[1:] - t[:-1]) >= JUMP_NS
        return bad

    def bulk_gaps(self, gaps, a: int, b: int) -> None:
        st = gaps.streams.get(self.s.key)
        if st is None:   # evicted (more streams than Settings.max_streams): counted there, not followed
            return
        st.cc = int(self.cc[b - 1])
        st.frame = int(self.fn[b - 1])
        st.ts = int(self.ts[b - 1])
        r = b - 1   # the last row as cyclic.py keeps it: (DataStatus, C_SDU)
        st.last = (int(self.w.u8[int(self.d[r]) + int(self.w.cap[self.p[r]]) - 2]), bytes(self.csdu(r)))
        if gaps.enabled:
            st.seen += b - a
            if st.seen >= LEARN:
                st.irregular = 0

    def bulk_frames(self, col, a: int, b: int) -> None:
        """Rows [a, b) (one captured length) as a StreamBatch for the sinks of cyclic frames."""
        rows = self.w.u8[self.d[a:b, None] + np.arange(self.cap0)]
        col.bulk_frames(self.s.key, self.fn[a:b], self.ts[a:b], rows, self.off)

    def csdu(self, r: int) -> bytes:
        """Row r's whole C_SDU (as cyclic.py keeps it)."""
        q = int(self.d[r]) + self.off + 2
        return self.w.buf[q:q + self.L]

    def same_prev(self, last_csdu, a: int, b: int):
        """Per row: the data object's bytes equal the stream's previous frame's (a superset of the rows whose
        whole C_SDU is unchanged, the reference's identical-input case: such rows are never bulk)."""
        M = self.M
        same = np.empty(b - a, dtype=bool)
        same[1:] = (M[a + 1:b] == M[a:b - 1]).all(axis=1)
        if a:
            same[0] = (M[a - 1] == M[a]).all()
        else:
            k = self.start
            same[0] = last_csdu is not None and last_csdu[k:k + M.shape[1]] == M[a].tobytes()
        return same

    def signals(self, o, names=None) -> dict:
        """Columns of the data object's signals (int64; 8-byte unsigned as uint64)."""
        lay = o.layout
        little = lay.byte_order == "little"
        out = {}
        pos = 0
        M = self.M
        for nm in lay.names:
            sig = tg.SIGNALS[nm]
            size = sig["size"]
            if names is None or nm in names:
                raw = M[:, pos:pos + size]
                if not little:
                    raw = raw[:, ::-1]
                v = np.ascontiguousarray(raw).view("<u%d" % size).reshape(len(M))
                if sig["signed"]:
                    v = v.view("<i%d" % size)
                out[nm] = v.astype(np.uint64) if size == 8 and not sig["signed"] else v.astype(np.int64)
            pos += size
        return out
