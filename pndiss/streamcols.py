"""Columns of one cyclic stream within a segment (pndiss/engine.py), and the vectorised checks on them.

``Cols`` gathers what the walks need from the window without a Python loop per frame: cycle counter,
DataStatus, captured length, and one data object's bytes; ``signals`` decodes the telegram words as
columns. ``unsafe_rows`` / ``sol_unsafe`` say in which cycles the reference encoder would do more than
advance (the value rules' vectorised twins, sign-of-life monitoring).
"""
from __future__ import annotations

import numpy as np

from . import telegrams as tg
from .gaps import LEARN, WRAP

BLOCK = 4096         # pairs judged per vectorised pass
SAFE = 1 << 62       # larger 64-bit values are left to the reference arithmetic
U32 = 1 << 32
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
        end = d + self.cap0
        self.cc = (u8[end - 4].astype(np.int64) << 8) | u8[end - 3]
        self.ds = (u8[end - 2] & 0x14) == 0x14          # DataValid and provider RUN (wire.md §2.3)
        self.off = 18 if w.tagged[p[0]] else 14
        self.L = self.cap0 - self.off - 6                # C_SDU length (up to the APDU status)
        self.M = None
        self.start = 0

    def obj(self, o) -> bool:
        """Gather the bytes of data object ``o`` (its IOPS byte included when the C_SDU has it)."""
        end = min(o.iops_at + 1, self.L)
        if o.end > self.L or o.start >= end:
            return False
        self.start = o.start
        base = self.d + self.off + 2 + o.start
        self.M = self.w.u8[base[:, None] + np.arange(end - o.start)]
        return True

    def iops(self, o):
        """Per row the IOPS byte of the data object, or None when the C_SDU ends before it."""
        return self.M[:, o.iops_at - self.start] if o.iops_at < self.L else None

    def gaps_bad(self, gaps, a: int, b: int):
        """Per row of [a, b): the gap tracker would not see an exact one-step advance (or learns something)."""
        st = gaps.streams.get(self.s.key)
        n = b - a
        if st is None or st.cc is None and a == 0:
            return np.ones(n, dtype=bool)
        if not gaps.enabled:
            return np.zeros(n, dtype=bool)
        if not st.step:
            return np.ones(n, dtype=bool)
        prev = np.empty(n, dtype=np.int64)
        prev[1:] = self.cc[a:b - 1]
        prev[0] = st.cc if a == 0 else self.cc[a - 1]
        return ((self.cc[a:b] - prev) % WRAP) != st.step

    def bulk_gaps(self, gaps, a: int, b: int) -> None:
        st = gaps.streams[self.s.key]
        st.cc = int(self.cc[b - 1])
        st.frame = int(self.fn[b - 1])
        st.ts = int(self.ts[b - 1])
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


def unsafe_rows(chk, v: dict, has_g1: bool):
    """Rows of a stretch where a value rule may fire or the checker must see the cycle itself: the value
    rules' vectorised twins (``Checker.vector_unsafe``, pndiss/encoder)."""
    vu = getattr(chk, "vector_unsafe", None)
    if vu is not None:
        return vu(v, has_g1)
    return _value_unsafe(chk, v, has_g1)


def sol_unsafe(stw2, zsw2, stw2_before: int, zsw2_before: int):
    """Rows where sign-of-life monitoring (k = 1) would see anything but both counters stepping by one
    (behaviour.md §3: C-LS and DLS run 1..15, 15 -> 1, never 0): those go through the checker."""
    n = len(stw2)
    cls = stw2 >> 12
    dls = zsw2 >> 12
    pc = np.empty(n, dtype=np.int64)
    pd = np.empty(n, dtype=np.int64)
    pc[0], pd[0] = stw2_before >> 12, zsw2_before >> 12
    pc[1:], pd[1:] = cls[:-1], dls[:-1]
    return (cls == 0) | (cls != pc % 15 + 1) | (dls == 0) | (dls != pd % 15 + 1)


def _value_unsafe(chk, v: dict, has_g1: bool):
    """Until the registry's twins land: today's vectorised value-rule checks (was batch._Run._not_simple)."""
    c = chk.cfg
    g1zsw = v.get("g1_zsw")
    n = len(next(iter(v.values())))
    if g1zsw is None:
        g1zsw = np.zeros(n, dtype=np.int64)
    zsw2 = v.get("zsw2_enc", np.zeros(n, dtype=np.int64))
    SERR = ((g1zsw >> 15) & 1).astype(bool)
    atx = ((g1zsw >> 13) & 1).astype(bool)
    PKA = ((g1zsw >> 14) & 1).astype(bool)
    bad = SERR.copy()
    if chk.lika:
        bad |= PKA
    X1, X2, X3 = v.get("g1_xist1"), v.get("g1_xist2"), v.get("g1_xist3")
    NIST = v.get("nist_b", v.get("nist_a"))
    pa = chk.prev_ac
    if X3 is not None:
        bad |= X3 >= SAFE
        X3 = X3.astype(np.int64)
    if not chk.shift_known and has_g1 and X1 is not None and X2 is not None:
        bad |= atx & ~SERR & (X2 != 0)
    if not c.iso:   # 8: RT mode, DLS back to 0 once running
        DLS = zsw2 >> 12
        started = chk.started_D | (np.cumsum(DLS != 0) > 0)
        bad |= (DLS == 0) & started
    if chk.lika and X2 is not None:   # 39
        bad |= ~atx & ~SERR & ~PKA & (X2 != 0)
    if X1 is not None and X2 is not None and X3 is None and (not c.class4 or c.xist1_preset_affected) \
            and not c.xist1_counter:   # 40
        bad |= atx & ~SERR & (X1 != ((X2 << (c.shift or 0)) & (U32 - 1)))
    R = chk.R
    if R:   # 41
        out = np.zeros(n, dtype=bool)
        if X2 is not None:
            out |= X2 >= R
        if chk.lika and X1 is not None:
            out |= X1 >= R
        bad |= atx & ~SERR & out

    def prev(name, arr):
        p = np.empty(n, dtype=np.int64)
        p[1:] = arr[:-1]
        p[0] = pa.get(name) or 0
        return p
    if R is not None and (c.profile in ("scancon", "hohner") or (chk.psm and c.scaling)):   # 42
        if R >= SAFE:
            bad[:] = True
        else:
            step = c.max_position_step or max(1, R // 8)
            pz = prev("g1_zsw", g1zsw)
            pos2 = None
            if X3 is not None:
                pos2, ppos2 = X3, prev("g1_xist3", X3)
                valid = np.ones(n, dtype=bool)
                if pa.get("g1_xist3") is None:
                    valid[0] = False
            elif X2 is not None:
                pos2, ppos2 = X2, prev("g1_xist2", X2)
                valid = atx & ~SERR & (((pz >> 13) & 1) == 1) & ((pz >> 15) == 0)
            if pos2 is not None:
                d = (pos2 - ppos2) % R
                d = np.where(d > R // 2, d - R, d)
                bad |= valid & ~PKA & (np.abs(d) > step)
    if NIST is not None:   # 44: any sign mismatch goes the normal way (it counts to 3)
        mot = X1 if X1 is not None else X3
        if mot is not None:
            pmot = prev("g1_xist1" if X1 is not None else "g1_xist3", mot)
            wide = (mot > U32 - 1) | (pmot > U32 - 1)
            d = (mot - pmot) % U32
            d = np.where(d > U32 // 2, d - U32, d)
            bad |= (NIST != 0) & (wide | ((d != 0) & ((d > 0) != (NIST > 0))))
            if pa.get("g1_xist1" if X1 is not None else "g1_xist3") is None:
                bad[0] = True
    return bad
