"""The walk over one encoder axis' frames in a segment: pairs applied at once, the rest one by one.

See pndiss/pairing.py for what a pair is and when a run of pairs is applied at once. What a bulk
step changes is exactly what the reference path's frames would have changed (cyclic.py on_cyclic:
counters, the gap tracker, the latest C_SDU and decode per stream, the axis' setpoint; the checker:
``Checker.advance_steady``, or the gated count), so the next frame one by one finds the state the
reference path would have left.
"""
from __future__ import annotations

import numpy as np

from .cyclic import IOPS_GOOD, JUDGED_FIRST, NOT_JUDGED_PHASES
from .streamcols import BLOCK, RETRY_MAX, Cols

ENDED = ("released", "aborted")
MIN_PAIRS = 4   # alternating pairs an attempt needs (RT drift + jitter flips the order every few hundred cycles)


class AxisWalk:
    def __init__(self, w, g):
        self.w = w
        self.t = w.e.t
        self.ax = g.ax
        k = 0 if g.fr[0].direction == "setpoint" else 1
        self.frS, self.frA = g.fr[k], g.fr[1 - k]
        self.oS, self.oA = self.frS.objs[0], self.frA.objs[0]
        self.S = Cols(w, g.streams[k], g.pos[k])
        self.A = Cols(w, g.streams[1 - k], g.pos[1 - k])
        idx = np.concatenate((g.pos[k], g.pos[1 - k]))
        typ = np.concatenate((np.zeros(len(g.pos[k]), dtype=np.int8), np.ones(len(g.pos[1 - k]), dtype=np.int8)))
        o = np.argsort(idx, kind="stable")
        self.idx = idx[o]
        self.typ = typ[o]
        self.cumS = np.concatenate(([0], np.cumsum(self.typ == 0)))
        self.sigS = self.sigA = None
        self.okS = self.okA = None
        self.bad_cols = False
        self.q = self.fails = 0      # where run() stopped (it resumes there)

    # -- columns, once per segment ------------------------------------------------------------------
    def _ok(self, c: Cols, o, fr):
        iops = c.iops(o)
        if iops is None or fr.fm.phase in NOT_JUDGED_PHASES:
            return np.zeros(len(c.p), dtype=bool)
        ok = c.ds & ((iops & IOPS_GOOD) != 0)
        if o.iocs_at is not None:   # cyclic.py: the device's IOCS of the setpoints it consumes
            ok &= c.good(o.iocs_at)
        return ok & c.primary() if fr.fm.primary_only else ok   # cyclic.py: a backup AR's frames not judged

    def _columns(self) -> bool:
        if self.sigS is None:
            S, A = self.S, self.A
            if self.bad_cols or not S.obj(self.oS) or not A.obj(self.oA):
                self.bad_cols = True
                return False
            self.sigS = S.signals(self.oS)
            self.sigA = A.signals(self.oA)
            self.okS = self._ok(S, self.oS, self.frS)
            self.okA = self._ok(A, self.oA, self.frA)
        return True

    # -- the walk ----------------------------------------------------------------------------------
    def run(self, stop=None) -> None:
        """The axis' frames before window index ``stop`` (None: all); a later call goes on from there."""
        N = len(self.typ) if stop is None else int(np.searchsorted(self.idx, stop))
        q, fails = self.q, self.fails
        while q < N:
            k = 1
            if q + 1 < N and self._clean():
                e = self._stretch(q, N) if self._columns() else 0
                if e > 0:
                    self._bulk(q, e)
                    q += 2 * e
                    fails = 0
                    continue
                if e == 0:   # the columns said no: back off (an attempt's column work is dear)
                    fails += 1
                    k = min(RETRY_MAX, 1 << min(fails - 1, 6))
            for i in range(q, min(N, q + k)):
                self.w.single(int(self.idx[i]), self.S.s if self.typ[i] == 0 else self.A.s)
            q = min(N, q + k)
        self.q, self.fails = max(self.q, q), fails

    def _clean(self) -> bool:
        """The axis' state lets the next two frames pair from scratch, and nothing about its data objects
        needs the frame-by-frame code (a relabel, a first-frame check, a length the layout does not fit)."""
        ax = self.ax
        chk = ax.checker
        if ax.sp_new or ax.pend is not None or ax.sp_break or ax.held is not None or ax.sp is None \
                or ax.ambiguous is None or ax.sp_key != self.S.s.key or not chk.std:
            return False
        if chk.solmon and not (ax.sp_ok and ax.sp is chk.prev_sp and chk.sol_bulk_ready()):
            return False
        for o, fr in ((self.oS, self.frS), (self.oA, self.frA)):
            dt = o.do.telegram
            if o.ax is not ax or (dt is not None and dt != o.telegram and dt != o.rejected) or not o.length_checked \
                    or o.sig is None or o.do.length < o.layout.length or fr.direction not in chk.io_len \
                    or fr.fm.phase in ENDED:
                return False
        return self.t.gaps.same_step(self.S.s.key, self.A.s.key)

    def _stretch(self, q: int, N: int) -> int:
        """How many pairs from merged position q (before N) the reference would only advance through (0: none,
        -1: none because of the checker's state, known before any column work: the next frame may try again)."""
        sr = int(self.cumS[q])
        ar = q - sr
        if sr >= len(self.okS) or ar >= len(self.okA):
            return 0   # no pair left of one of the streams
        ax = self.ax
        chk = ax.checker
        judged = not ax.ambiguous and bool(self.okS[sr] and self.okA[ar])
        # the checker's state first: while it cannot be advanced at once, no array work at all (retries are many)
        if judged and (not chk.bulk_ready() or self.frA.fm.phase in JUDGED_FIRST):
            return -1
        if judged:
            sg, ag = self.sigS.get, self.sigA.get
            key0 = tuple(int(c[r]) & m if c is not None else 0 for c, r, m in (
                (sg("stw2_enc"), sr, 0x0FFF), (sg("g1_stw"), sr, -1), (ag("zsw2_enc"), ar, 0x0FFF), (ag("g1_zsw"), ar, -1)))
            if key0 != chk.prev_key:
                return -1
        if not judged and not chk.idle():
            return -1
        T = self.typ[q:min(N, q + 2 * BLOCK)]
        P = len(T) // 2
        distinct = T[0:2 * P:2] != T[1:2 * P:2]
        if not distinct.all():
            P = int(np.argmin(distinct))
        if P < MIN_PAIRS:
            return 0   # a few pairs go one by one cheaper than the column work of an attempt (~140 us)
        S, A = self.S, self.A
        if judged:
            # the key's first change ends the stretch: found first, so the costlier columns below are computed
            # only for the rows a bulk step can take (a preset, parking or error every few hundred cycles)
            sg, ag = self.sigS.get, self.sigA.get
            keydiff = np.zeros(P, dtype=bool)
            for c, r, m in ((sg("stw2_enc"), sr, 0x0FFF), (sg("g1_stw"), sr, -1), (ag("zsw2_enc"), ar, 0x0FFF),
                            (ag("g1_zsw"), ar, -1)):
                if c is not None:
                    k = c[r:r + P] & m
                    keydiff[1:] |= k[1:] != k[:-1]
            if keydiff.any():
                P = int(np.argmax(keydiff))
        gaps = self.t.gaps
        ok = self.okS[sr:sr + P] & self.okA[ar:ar + P]
        bad = S.gaps_bad(gaps, sr, sr + P) | A.gaps_bad(gaps, ar, ar + P) | S.capbad[sr:sr + P] | A.capbad[ar:ar + P]
        if judged:
            ident = S.same_prev(self.frS.last_csdu, sr, sr + P) & A.same_prev(self.frA.last_csdu, ar, ar + P)
            bad |= ~ok | ident
            if not bad[0]:   # the value rules' vectorised twins (pndiss/encoder/registry.py)
                sS = {k: v[sr:sr + P] for k, v in self.sigS.items()}
                sA = {k: v[ar:ar + P] for k, v in self.sigA.items()}
                bad |= chk.vector_unsafe({**sS, **sA}, "g1_stw" in sS and "g1_zsw" in sA)
        elif not ax.ambiguous:
            bad |= ok
        return int(np.argmax(bad)) if bad.any() else P

    def _bulk(self, q: int, e: int) -> None:
        w, t, ax = self.w, self.t, self.ax
        S, A = self.S, self.A
        sr = int(self.cumS[q])
        ar = q - sr
        sl, al = sr + e - 1, ar + e - 1
        S.s.n += e
        A.s.n += e
        t.mapped += 2 * e
        w.e.frames_bulk += 2 * e
        S.bulk_gaps(t.gaps, sr, sr + e)
        A.bulk_gaps(t.gaps, ar, ar + e)
        old_sp, old_ok = ax.sp, ax.sp_ok
        for c, fr, o, r in ((S, self.frS, self.oS, sl), (A, self.frA, self.oA, al)):
            csdu = c.csdu(r)
            if csdu != fr.last_csdu:
                fr.last_csdu = csdu
                o.sig = o.layout.decode(csdu, o.start)
                o.bits = None
        okS = self.okS
        if e >= 2:
            if not okS[sl - 1]:
                ax.sp_before = None
            elif S.csdu(sl - 1) == self.frS.last_csdu:
                ax.sp_before = self.oS.sig
            else:
                ax.sp_before = self.oS.layout.decode(S.csdu(sl - 1), self.oS.start)
        else:
            ax.sp_before = old_sp if old_ok else None
        ax.sp = self.oS.sig
        ax.sp_frame = int(S.fn[sl])
        ax.sp_ok = bool(okS[sl])
        ax.sp_new = ax.sp_break = False
        ax.pend = None
        ax.nosp = 0
        ax.sp_key = S.s.key
        ax.sp_ts = int(S.ts[sl])
        ax.held_paired = 0
        ax.phase = int(self.A.ts[al]) - ax.sp_ts   # (cyclic.py: the last pair's time from setpoint to actual)
        col = w.e.col
        if col is not None:
            self._columns_out(col, sr, ar, e)
        chk = ax.checker
        if ax.ambiguous or not (okS[sr] and self.okA[ar]):
            t.gated += e
            chk.gated += e
            if ax.ambiguous:
                chk.unsure_cycles += e
            return
        X = self.sigA.get("g1_xist1", self.sigA.get("g1_xist3"))
        motion = [int(v) for v in X[max(ar, al - 2):al + 1]] if X is not None else [None] * min(3, e)
        stw2 = self.sigS.get("stw2_enc")
        zsw2 = self.sigA.get("zsw2_enc")
        cls = bool((stw2[sr:sr + e] >> 12).any()) if stw2 is not None else False
        dls = bool((zsw2[ar:ar + e] >> 12).any()) if zsw2 is not None else False
        chk.advance_steady(e, int(A.fn[al]), int(A.ts[al]), ax.sp_frame, ax.sp, self.oA.sig, motion, cls, dls, ax.sp_ts)
        if chk.solmon:
            chk.advance_sign_of_life(e, ax.sp_before)

    def _columns_out(self, col, sr: int, ar: int, e: int) -> None:
        """The bulk rows for the column sinks: both streams' frames, both directions' telegrams."""
        for c, o, fr, r, sig, ok in ((self.S, self.oS, self.frS, sr, self.sigS, self.okS),
                                     (self.A, self.oA, self.frA, ar, self.sigA, self.okA)):
            if col.str:
                c.bulk_frames(col, r, r + e)
            if col.cyc:
                iops = c.iops(o)
                iops = iops[r:r + e].astype(np.int16) if iops is not None else np.full(e, -1, dtype=np.int16)
                col.bulk_cycles(o, fr, c.s.key[0], c.fn[r:r + e], c.ts[r:r + e], iops,
                                ok[r:r + e] & (not self.ax.ambiguous),   # (cyclic.py: not while only guessed)
                                {k: v[r:r + e] for k, v in sig.items()})
