"""Batch path (issue #8): steady runs of cyclic frames handled per run with NumPy, not per frame.

A cyclic session is a few (FrameID, src, dst) streams sending frames of constant length in a fixed
order, so in the file a stretch of records repeats with a period of P records (S bytes): a
setpoint and an actual frame per cycle give P = 2. ``Engine`` is offered the reader's buffer
(pndiss/capture.py, ``batch=``), finds such a run, checks every record header and every frame
prefix (MACs, EtherType, VLAN tag, FrameID) of it with one vectorised comparison against the
first period, and takes the telegram words, DataStatus and IOPS of all rows as strided columns.

Nothing is judged here that the reference path would judge differently. Per row (one cycle of
every stream in the run) the engine decides with the arrays whether the row is *simple*: the
checker of every axis is in its steady state (control/status words as before, nothing pending, no
rule run open), the row changes none of that, and no per-cycle value rule can fire in it. A
stretch of simple rows is applied at once (``Checker.advance_steady`` plus the tracker's counters,
latest decodes and setpoints); every other row -- a control word change, a gated cycle, a value
rule hit, the L_max+1 cycles after any of them -- goes frame by frame through
``CyclicTracker.on_cyclic`` exactly like pndiss/fast.py does. Runs that do not fit (unknown
streams, a relabel pending, sign-of-life monitoring, non-standard telegrams) are left to the reader,
which yields their frames one by one.

tests/test_fastpath.py compares this path with the reference path on every capture and on
mutated long sessions.
"""
from __future__ import annotations

import struct

import numpy as np

from . import telegrams as tg
from .capture import MAX_PACKET, MAX_RECORD, TS_MAX
from .cyclic import IOPS_GOOD, NOT_JUDGED_PHASES, RELOOKUP_EVERY
from .proto.common import Malformed

MAX_PERIOD = 8       # streams in one repeating pattern (setpoint + actual of up to 4 devices)
MIN_ROWS = 16        # shorter runs are not worth the set-up: the reader yields them
BLOCK = 4096         # rows judged per vectorised pass (state may change at any non-simple row)
RETRY_MAX = 64       # frames the reader yields before it offers the buffer again after a miss
U32 = 1 << 32
ETH_PNRT = b"\x88\x92"

_DT = {1: "u1", 2: "u2", 4: "u4", 8: "u8"}


def _view(buf, off: int, m: int, S: int, dt: str):
    """The field of type dt at buf[off] of each of m rows S bytes apart: a strided view, no copy."""
    return np.ndarray((m,), dtype=dt, buffer=buf, offset=off, strides=(S,))


def _chunks(off: int, ln: int):
    """A byte range as (offset, dtype) pieces of 8, 4, 2 and 1 bytes (compared without a gather)."""
    out = []
    for size, dt in ((8, "u8"), (4, "u4"), (2, "u2"), (1, "u1")):
        while ln >= size:
            out.append((off, dt))
            off += size
            ln -= size
    return out


class _Col:
    """One record of the period: its stream and where its fields lie in a row."""

    __slots__ = ("s", "key", "boff", "data", "cap", "csdu", "n_csdu", "fr", "kind", "ds", "last", "cc", "ccbad")

    def __init__(self, s, key, boff, data, cap, off):
        self.s = s                  # fast._Stream
        self.key = key              # frame prefix (dict key of fast.run)
        self.boff = boff            # record offset in the period
        self.data = boff + data     # frame data offset in the row
        self.cap = cap
        self.csdu = self.data + off + 2      # C_SDU start in the row (after the FrameID)
        self.n_csdu = cap - off - 6          # up to the APDU status (4 bytes)
        self.fr = None
        self.kind = None            # "mapped", "empty" (no encoder objects) or "unmapped"
        self.ds = None              # DataStatus DataValid + RUN per row
        self.last = None
        self.cc = None              # CycleCounter per row
        self.ccbad = None           # per row: the counter did not advance by exactly the stream's step


class _Ax:
    """One axis seen in the run: its setpoint / actual data objects and per-row arrays."""

    __slots__ = ("ax", "sp", "ac", "sp_col", "ac_col", "ok", "ident", "keydiff", "v", "pv", "has_g1")

    def __init__(self, ax):
        self.ax = ax
        self.sp = self.ac = None    # _Obj
        self.sp_col = self.ac_col = None


class Engine:
    run_class = None                    # _Run, set below it; pndiss/mcap_batch.py's engine has its own

    def __init__(self, a, streams: dict, progress=None):
        self.a = a
        self.t = a.cyclic
        self.streams = streams          # fast.run's prefix -> _Stream (learned from the first frames)
        self.progress = progress
        self.misses = 0                 # consecutive offers that found no run (backoff)
        self.last_fn = 0
        self.last_ts = None
        self.rows_bulk = 0              # diagnostics for bench/NOTES.md
        self.rows_single = 0
        self.ts_check = None            # pcapng: per row, the record's time stamp needs no clamping

    # -- reader interface ------------------------------------------------------------------------
    def pcapng(self, bo: str, ifaces: list):
        hdr = struct.Struct(bo + "IIIIII").unpack_from
        tsu = struct.Struct(bo + "II").unpack_from
        tail = struct.Struct(bo + "I").unpack_from
        ifid_of = struct.Struct(bo + "I").unpack_from

        def ts_check(buf, p, m, S):
            lim = ifaces[ifid_of(buf, p + 8)[0]][5]   # largest raw value of the plain multiply (capture.py)
            if lim < 0:
                return np.zeros(m, dtype=bool)
            hi = _view(buf, p + 12, m, S, bo + "u4").astype(np.uint64)
            lo = _view(buf, p + 16, m, S, bo + "u4").astype(np.uint64)
            return ((hi << np.uint64(32)) | lo) <= np.uint64(min(lim, (1 << 64) - 1))

        self.ts_check = ts_check

        def block(buf, p, end):
            if p + 28 > end:
                return None
            btype, blen, ifid, _hi, _lo, cap = hdr(buf, p)
            if btype != 6 or ifid >= len(ifaces) or blen % 4 or blen < 32 + cap or p + blen > end \
                    or ifaces[ifid][0] != 1 or cap > MAX_PACKET or tail(buf, p + blen - 4)[0] != blen:
                return None   # the reader's checks (tshark's): it says why, frame by frame
            # the fields every record of a column must repeat: type, length, interface; caplen; trailing length
            return blen, 28, cap, ((p, 12), (p + 20, 4), (p + blen - 4, 4))

        def ts_of(buf, p):
            ifid = struct.unpack_from(bo + "I", buf, p + 8)[0]
            _lt, conv, off, mult = ifaces[ifid][:4]
            hi, lo = tsu(buf, p + 12)
            t = (hi << 32) | lo
            t = (t * mult if mult else conv(t)) + off
            return t if 0 <= t <= TS_MAX else (0 if t < 0 else TS_MAX)   # clamped as the reader does

        return lambda buf, pos, end, n: self._take(buf, pos, end, n, block, ts_of)

    def pcap(self, bo: str, linktype: int, mult: int):
        self.ts_check = None   # pcap time stamps always fit (32-bit seconds)
        hdr = struct.Struct(bo + "IIII").unpack_from
        tsu = struct.Struct(bo + "II").unpack_from

        def block(buf, p, end):
            if linktype != 1 or p + 16 > end:
                return None
            incl = hdr(buf, p)[2]
            if incl > MAX_RECORD or p + 16 + incl > end:
                return None
            return 16 + incl, 16, incl, ((p + 8, 4),)

        def ts_of(buf, p):
            sec, frac = tsu(buf, p)
            return sec * 1_000_000_000 + frac * mult

        return lambda buf, pos, end, n: self._take(buf, pos, end, n, block, ts_of)

    def _miss(self) -> int:
        self.misses += 1
        return min(RETRY_MAX, 1 << min(self.misses, 6))

    # -- one run ---------------------------------------------------------------------------------
    def _take(self, buf, pos, end, n, block, ts_of):
        """Consume a steady run at buf[pos:end] and return (new pos, new frame count), or the number
        of frames the reader should yield itself before offering the buffer again."""
        cols_checks, S = self._period(buf, pos, end, block)
        if cols_checks is None:
            return self._miss()
        m = (end - pos) // S
        if m < MIN_ROWS:
            return self._miss()
        cols = [c for c, _ in cols_checks]
        run = self.run_class(self, buf, pos, n, cols, S, ts_of)
        if not run.prepare():
            return 1 if run.skip == 2 else self._miss()
        # every record of the run repeats its column's header fields and frame prefix
        good = np.ones(m, dtype=bool)
        for c, checks in cols_checks:
            for p, ln in tuple(checks) + ((pos + c.data, len(c.key)),):
                for q, dt in _chunks(p, ln):
                    V = _view(buf, q, m, S, dt)
                    good &= V == V[0]
        if self.ts_check is not None:   # time stamps the reader would clamp (and count) go frame by frame
            for c, _checks in cols_checks:
                good &= self.ts_check(buf, pos + c.boff, m, S)
        if not good.all():
            m = int(np.argmin(good))
            if m < MIN_ROWS:
                return self._miss()
        run.arrays(m)
        self.misses = 0
        m = run.process()
        P = len(cols)
        self.last_fn = n + m * P
        self.last_ts = ts_of(buf, pos + (m - 1) * S + cols[-1].boff)
        if self.progress is not None and (self.last_fn >> 12) != (n >> 12):
            self.progress(self.last_fn & ~0xFFF)
        return pos + m * S, n + m * P

    def _period(self, buf, pos, end, block):
        """The shortest repeating pattern of records at pos: ([(_Col, header checks)], S) or (None, 0)."""
        recs = []
        p = pos
        for _ in range(2 * MAX_PERIOD):
            b = block(buf, p, end)
            if b is None:
                break
            blen, doff, cap, checks = b
            if cap < 24:
                break
            d = p + doff
            off = 18 if buf[d + 12] == 0x81 else 14
            key = buf[d:d + off + 2]
            recs.append((p, blen, doff, cap, off, key, checks))
            p += blen
        for P in range(1, len(recs) // 2 + 1):
            head = recs[:P]
            if any((head[i][1], head[i][3], head[i][5]) != (recs[P + i][1], recs[P + i][3], recs[P + i][5])
                   for i in range(P)):
                continue
            if len({r[5] for r in head}) != P:
                return None, 0   # one stream twice in a period: the pairing is not row-wise
            cols = []
            for p, blen, doff, cap, off, key, checks in head:
                s = self.streams.get(key)
                if not s:
                    return None, 0   # not (yet) a known cyclic stream: the reader learns it
                cols.append((_Col(s, key, p - pos, doff, cap, off), checks))
            return cols, sum(r[1] for r in head)
        return None, 0


class _Run:
    """One run: m rows of P records; the per-row arrays and the walk over the rows."""

    def __init__(self, eng: Engine, buf, pos, n, cols, S, ts_of):
        self.e = eng
        self.buf = buf
        self.pos = pos
        self.n = n
        self.A = None
        self.m = 0
        self.cols = cols
        self.S = S
        self.ts_of = ts_of
        self.axes: list[_Ax] = []
        self.skip = 0
        self.relookup = None     # first row at which an unmapped stream asks the session again

    def f(self, col: int, dt: str):
        """The rows' field of type dt at byte ``col`` of a row (strided view)."""
        return _view(self.buf, self.pos + col, self.m, self.S, dt)

    def u(self, col: int, size: int, big: bool, signed: bool = False):
        """Column of the rows' unsigned (or signed) integers at byte ``col`` (int64, uint64 for 8 bytes)."""
        raw = self.f(col, (">" if big else "<") + ("i" if signed else "u") + str(size))
        return raw.astype(np.uint64) if size == 8 and not signed else raw.astype(np.int64)

    # -- set-up ---------------------------------------------------------------------------------
    def prepare(self) -> bool:
        t = self.e.t
        a = self.e.a
        if t.map_generation != a.session.map_generation:
            return False
        by_axis: dict = {}
        for j, c in enumerate(self.cols):
            fr = t.frames.get(c.s.key, False)
            if fr is False:
                return False  # not looked up yet: one frame the normal way does it
            if fr is None:
                if t.infer.wants(c.s.key):
                    return False  # content inference still samples this stream: frame by frame
                c.kind = "unmapped"
                left = RELOOKUP_EVERY - t.misses.get(c.s.key, 0) % RELOOKUP_EVERY - 1
                self.relookup = left if self.relookup is None else min(self.relookup, left)
                continue
            c.fr = fr
            if not fr.objs:
                c.kind = "empty"
                continue
            c.kind = "mapped"
            for o in fr.objs:
                do = o.do
                dt = do.telegram
                if dt is not None and dt != o.telegram and dt != o.rejected:
                    self.skip = 1  # a relabel is due (P922): the normal path does it
                    return False
                if o.end > c.n_csdu or not o.length_checked:
                    return False   # malformed frames / first frames: the reader yields them
                if do.length < o.layout.length:
                    if o.sig is not None:
                        return False
                    continue       # never decoded, never judged (cyclic.py skips it every frame)
                ax = o.ax
                if ax is None or o.sig is None or fr.direction not in ax.checker.io_len:
                    return False
                x = by_axis.get(id(ax))
                if x is None:
                    x = by_axis[id(ax)] = _Ax(ax)
                    self.axes.append(x)
                if fr.direction == "setpoint":
                    if x.sp is not None:
                        return False
                    x.sp, x.sp_col = o, j
                else:
                    if x.ac is not None:
                        return False
                    if ax.ambiguous is None:
                        return False
                    x.ac, x.ac_col = o, j
        for x in self.axes:
            if x.sp is not None and x.ac is not None and x.sp_col > x.ac_col:
                self.skip = 2      # start the run at the setpoint (one record later): both lie in one row
                return False
            if x.ac is not None:
                chk = x.ax.checker
                if not chk.std or chk.solmon:
                    return False   # preset telegrams / sign-of-life monitoring: frame by frame
        return True

    def arrays(self, m: int) -> None:
        """The m verified rows: per-row arrays of every stream and axis."""
        self.m = m
        gaps = self.e.t.gaps.streams
        for c in self.cols:
            # capture loss breaks a steady run: a row is simple only where every stream's counter advanced by
            # exactly its step (pndiss/gaps.py decides the others frame by frame)
            st = gaps.get(c.s.key)
            c.cc = self.f(c.data + c.cap - 4, ">u2").astype(np.int64)
            if st is None or st.cc is None or not st.step:
                c.ccbad = np.ones(m, dtype=bool)
            else:
                d = np.empty(m, dtype=np.int64)
                d[1:] = c.cc[1:] - c.cc[:-1]
                d[0] = c.cc[0] - st.cc
                c.ccbad = (d % 0x10000) != st.step
            if c.kind == "mapped":
                c.ds = (self.f(c.data + c.cap - 2, "u1") & 0x14) == 0x14   # DataValid and provider RUN (wire.md §2.3)
        for x in self.axes:
            if x.ac is not None:
                self._arrays(x)

    def _csdu_same(self, c: _Col):
        """Per row: the C_SDU equals the previous frame's of that stream (cyclic.py reuses the decode)."""
        if c.last is None:
            same = np.ones(self.m, dtype=bool)
            for q, dt in _chunks(c.csdu, c.n_csdu):
                V = self.f(q, dt)
                same[1:] &= V[1:] == V[:-1]
            d = self.pos + c.csdu
            same[0] = c.fr.last_csdu is not None and self.buf[d:d + c.n_csdu] == c.fr.last_csdu
            c.last = same
        return c.last

    def _obj(self, c: _Col, o, names):
        """Signals ``names`` of data object o in column c, per row (None when the telegram has none)."""
        lay = o.layout
        big = lay.byte_order != "little"
        out = {}
        pos = 0
        for nm in lay.names:
            sig = tg.SIGNALS[nm]
            if nm in names:
                out[nm] = self.u(c.csdu + o.start + pos, sig["size"], big, sig["signed"])
            pos += sig["size"]
        return out

    def _ok(self, c: _Col, o):
        if o.iops_at >= c.n_csdu or c.fr.fm.phase in NOT_JUDGED_PHASES:   # before PrmEnd / after the AR: cyclic.py
            return np.zeros(self.m, dtype=bool)
        return c.ds & ((self.f(c.csdu + o.iops_at, "u1") & IOPS_GOOD) != 0)

    def _arrays(self, x: _Ax) -> None:
        ax = x.ax
        acol = self.cols[x.ac_col]
        v = self._obj(acol, x.ac, ("zsw2_enc", "g1_zsw", "g1_xist1", "g1_xist2", "g1_xist3", "nist_a", "nist_b"))
        ok = self._ok(acol, x.ac)
        ac_same = self._csdu_same(acol)
        m = self.m
        if x.sp is not None:
            scol = self.cols[x.sp_col]
            sv = self._obj(scol, x.sp, ("stw2_enc", "g1_stw"))
            ok = ok & self._ok(scol, x.sp)
            ident = ac_same & self._csdu_same(scol)
            stw2 = sv.get("stw2_enc")
            g1stw = sv.get("g1_stw")
            x.has_g1 = "g1_stw" in sv
        else:   # the axis' setpoint stream is not in the run: the latest one stands
            sp = ax.sp
            if sp is not None and not ax.sp_ok:
                ok = np.zeros(m, dtype=bool)
            ident = ac_same
            stw2 = np.full(m, sp.get("stw2_enc", 0) if sp else 0, dtype=np.int64)
            g1stw = np.full(m, sp.get("g1_stw", 0) if sp else 0, dtype=np.int64)
            x.has_g1 = sp is not None and "g1_stw" in sp
        if stw2 is None:
            stw2 = np.zeros(m, dtype=np.int64)
        if g1stw is None:
            g1stw = np.zeros(m, dtype=np.int64)
        zsw2 = v.get("zsw2_enc", np.zeros(m, dtype=np.int64))
        g1zsw = v.get("g1_zsw", np.zeros(m, dtype=np.int64))
        x.has_g1 = x.has_g1 and "g1_zsw" in v
        keydiff = np.zeros(m, dtype=bool)
        for w in (stw2 & 0x0FFF, g1stw, zsw2 & 0x0FFF, g1zsw):
            keydiff[1:] |= w[1:] != w[:-1]
        x.ok = ok
        x.ident = ident
        x.keydiff = keydiff
        v["stw2"], v["g1stw"], v["zsw2"], v["g1zsw"] = stw2, g1stw, zsw2, g1zsw
        x.v = v

    # -- the walk over the rows -------------------------------------------------------------------
    def process(self) -> int:
        """Walk the rows; return how many were consumed (all, unless an unmapped stream's periodic
        session lookup ran in one: then the stream map may have changed and the reader goes on)."""
        r, m = 0, self.m
        while r < m:
            e = self._stretch(r)
            if e > r:
                self._bulk(r, e)
                self.e.rows_bulk += e - r
                r = e
            else:
                self._row(r)
                self.e.rows_single += 1
                r += 1
                if self.relookup is not None and r > self.relookup:
                    break
        return r

    def _stretch(self, r: int) -> int:
        """End of the stretch of simple rows from row r (r itself when row r is not simple)."""
        end = min(self.m, r + BLOCK)
        if self.relookup is not None:
            if r >= self.relookup:
                return r
            end = min(end, self.relookup)
        for c in self.cols:
            bad = c.ccbad[r:end]
            if bad[0]:
                return r
            if bad.any():
                end = r + int(np.argmax(bad))
        t = self.e.t
        for x in self.axes:
            if x.ac is None:
                continue
            ax = x.ax
            chk = ax.checker
            if ax.sp_new or ax.sp_break or ax.pend is not None or (x.sp is None and t.gaps.same_step(ax.sp_key, self.cols[x.ac_col].s.key)):
                return r   # a setpoint unpaired or missing (cyclic.py's _unpaired decides)
            if x.sp is None and ax.sp is None:
                continue   # no setpoint yet: the actual pairs with nothing
            if ax.ambiguous or not x.ok[r]:
                # gated: only the counters move while the checker has nothing to flush
                if not chk.idle():
                    return r
                bad = x.ok[r:end] & (not ax.ambiguous)
            else:
                if not chk.bulk_ready():
                    return r
                v = x.v
                key = (int(v["stw2"][r]) & 0x0FFF, int(v["g1stw"][r]), int(v["zsw2"][r]) & 0x0FFF, int(v["g1zsw"][r]))
                if key != chk.prev_key:
                    return r
                bad = self._not_simple(x, chk, r, end)
            if bad[0]:
                return r
            if bad.any():
                end = r + int(np.argmax(bad))
        return end

    def _not_simple(self, x: _Ax, chk, r: int, end: int):
        """Per row of [r, end): the row is not a steady, hit-free cycle of this checker: not judged, the
        same frames again, a key change, or what the checker's registry says (Checker.vector_unsafe)."""
        v = x.v
        sl = slice(r, end)
        bad = (~x.ok[sl]) | x.ident[sl]
        bad[1:] |= x.keydiff[r + 1:end]
        cols = {"stw2_enc": v["stw2"][sl], "g1_stw": v["g1stw"][sl], "zsw2_enc": v["zsw2"][sl], "g1_zsw": v["g1zsw"][sl]}
        for name in ("g1_xist1", "g1_xist2", "g1_xist3", "nist_a", "nist_b"):
            if name in v:
                cols[name] = v[name][sl]
        return bad | chk.vector_unsafe(cols, x.has_g1)

    # -- applying rows ---------------------------------------------------------------------------
    def _frame_pos(self, r: int, j: int) -> int:
        return self.pos + r * self.S + self.cols[j].boff

    def _row(self, r: int) -> None:
        """Row r frame by frame, exactly as pndiss/fast.py feeds a known cyclic stream."""
        a = self.e.a
        on_cyclic = self.e.t.on_cyclic
        buf = self.buf
        P = len(self.cols)
        for j, c in enumerate(self.cols):
            p = self._frame_pos(r, j)
            fn = self.n + r * P + j + 1
            ts = self.ts_of(buf, p)
            d = p + c.data - c.boff
            data = buf[d:d + c.cap]
            s = c.s
            s.n += 1
            self._frame(s, fn, ts, data)
            try:
                on_cyclic(s.key, fn, ts, data[-2] & 0x14 == 0x14, data, len(c.key))
            except Malformed as e:
                s.bad += 1
                a._malformed(fn, ts, e.layer, e.reason)

    def _frame(self, s, fn: int, ts: int, data) -> None:
        """A frame of a single row, before the tracker sees it (the MCAP export writes its APDU message)."""

    def _bulk(self, r: int, e: int) -> None:
        """Rows [r, e): every stream's frames counted, the latest decodes kept, each checker advanced."""
        t = self.e.t
        cnt = e - r
        last = e - 1
        P = len(self.cols)
        buf = self.buf
        gaps = t.gaps.streams
        for j, c in enumerate(self.cols):
            c.s.n += cnt
            st = gaps[c.s.key]   # every row advanced by the step (_stretch): as many exact steps
            st.cc = int(c.cc[last])
            st.frame = self.n + last * P + j + 1
            st.ts = self.ts_of(buf, self._frame_pos(last, j))
            st.seen += cnt
            if c.kind == "unmapped":
                t.count_unmapped(c.s.key, cnt)
                t.misses[c.s.key] += cnt
                continue
            if c.kind == "empty":
                t.no_telegram += cnt
                continue
            t.mapped += cnt
            d = self._frame_pos(last, j) + c.data - c.boff
            csdu = buf[d + len(c.key):d + c.cap - 4]
            c.fr.last_csdu = csdu
            for o in c.fr.objs:
                if o.do.length < o.layout.length:
                    continue
                o.sig = o.layout.decode(csdu, o.start)
                o.bits = None
        for x in self.axes:
            ax = x.ax
            if x.ac is not None:
                ax.sp_new = False   # each row paired its setpoint (_stretch)
            elif x.sp is not None:  # setpoints only: the later ones overwrote unpaired ones (cyclic.py)
                ax.sp_break = ax.sp_break or ax.sp_new or cnt > 1
                ax.sp_new = True
            if x.sp is not None:
                ax.sp = x.sp.sig
                ax.sp_before = None   # only sign-of-life monitoring reads it, and those axes never run in bulk
                ax.sp_frame = self.n + last * P + x.sp_col + 1
                ax.sp_ok = bool(self._ok(self.cols[x.sp_col], x.sp)[last])
            if x.ac is None or ax.sp is None:
                continue
            chk = ax.checker
            if ax.ambiguous or not x.ok[r]:
                t.gated += cnt
                chk.gated += cnt
                continue
            fn = self.n + last * P + x.ac_col + 1
            ts = self.ts_of(buf, self._frame_pos(last, x.ac_col))
            v = x.v
            X1, X3 = v.get("g1_xist1"), v.get("g1_xist3")
            ref = X1 if X1 is not None else X3
            motion = [int(q) for q in ref[max(r, e - 3):e]] if ref is not None else [None] * min(3, cnt)
            DLS = v["zsw2"][r:e] >> 12
            CLS = v["stw2"][r:e] >> 12
            chk.advance_steady(cnt, fn, ts, ax.sp_frame, ax.sp, x.ac.sig, motion,
                               bool(CLS.any()), bool(DLS.any()))


Engine.run_class = _Run
