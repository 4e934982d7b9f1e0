"""MCAP export over the batch engine's steady runs (pndiss/batch.py, issue #8).

The engine hands stretches of steady rows (one cycle of every stream of a run per row) to the
checkers at once; nothing is emitted for them. The export still needs one APDU message per frame
and one telegram message per data object and frame, in frame order. Here a bulk stretch is turned
into messages column by column with NumPy (timestamps, cycle counters, DataStatus, IOPS, every
signal as a strided view of the reader's buffer) and the JSON text comes from the same per-channel
templates as mcap_export's per-frame fast path (_RtFast / _TgFast): '%d' of Python ints and cached
text made by the reference encoder. Single rows (anything not steady) go frame by frame: the APDU
message, then the tracker (whose telegram_sink writes the telegram message), as the export loop
does for frames outside runs.

Whatever the vectorised form does not cover (volume control, a channel shared by two columns, an
object without IOPS or without its templates yet, a word combination whose bits text is not cached
and carries a G1_XIST2 error code, a timestamp resolution that is not a power of ten) goes through
the per-frame functions for that stretch; tests/test_mcap.py checks the files against the reference
path on every capture.
"""
from __future__ import annotations

import struct
from itertools import compress
import numpy as np

from . import batch
from . import telegrams as tg
from .cyclic import IOPS_GOOD
from .proto.common import Malformed

SEQ_MASK = 0xFFFFFFFF
_JSON_BOOL = (b"false", b"true")
_I64_MAX = (1 << 63) - 1


def export_engine(a, exp, streams: dict, progress=None):
    return _Engine(a, streams, progress, exp)


class _Engine(batch.Engine):
    def __init__(self, a, streams, progress, exp):
        super().__init__(a, streams, progress)
        self.exp = exp
        self.ts_info = None   # how the reader's records hold their timestamps (for whole columns)

    def pcapng(self, bo: str, ifaces: list):
        self.ts_info = ("pcapng", bo, ifaces)
        return super().pcapng(bo, ifaces)

    def pcap(self, bo: str, linktype: int, mult: int):
        self.ts_info = ("pcap", bo, mult)
        return super().pcap(bo, linktype, mult)


class _ExportRun(batch._Run):
    def _frame(self, s, fn: int, ts: int, data) -> None:
        """Single rows: the APDU message, then the tracker (whose telegram_sink writes the telegram message)."""
        self.e.exp._apdu_direct(s, fn, ts, data)

    def _bulk(self, r: int, e: int) -> None:
        super()._bulk(r, e)
        # the tracker now holds the last row's decodes; the messages come from the frame bytes
        objs = [[o for o in c.fr.objs if o.do.length >= o.layout.length] if c.kind == "mapped" else []
                for c in self.cols]
        kept = [(o, o.sig) for lst in objs for o in lst]
        if not self._bulk_columns(r, e, objs):
            self._bulk_frames(r, e, objs)
        for o, sig in kept:
            o.sig = sig
            o.bits = None

    # -- frame by frame (the general form) ----------------------------------------------------------
    def _bulk_frames(self, r: int, e: int, objs) -> None:
        exp = self.e.exp
        buf, ts_of = self.buf, self.ts_of
        apdu, telegram = exp._apdu_direct, exp._telegram_direct
        P = len(self.cols)
        for row in range(r, e):
            for j, c in enumerate(self.cols):
                p = self._frame_pos(row, j)
                fn = self.n + row * P + j + 1
                ts = ts_of(buf, p)
                d = p + c.data - c.boff
                data = buf[d:d + c.cap]
                apdu(c.s, fn, ts, data)
                if objs[j]:
                    coff = len(c.key)
                    csdu = data[coff:c.cap - 4]
                    n_csdu = c.cap - 4 - coff
                    ds_ok = data[-2] & 0x14 == 0x14
                    fid = c.s.key[0]
                    for o in objs[j]:
                        o.sig = o.layout.decode(csdu, o.start)
                        o.bits = None   # the tracker's bits cache follows its decode (the slow way reads it)
                        iops = csdu[o.iops_at] if o.iops_at < n_csdu else None
                        telegram(o, c.fr, fid, fn, ts, iops, bool(ds_ok and iops is not None and iops & IOPS_GOOD))

    # -- whole columns ------------------------------------------------------------------------------
    def _col(self, r: int, rows: int, c, k: int, dtype: str = "u1"):
        """Byte k of column c's frame data (as ``dtype``) in rows r.. r+rows-1, as a strided view."""
        return np.ndarray((rows,), dtype=dtype, buffer=self.buf,
                          offset=self.pos + r * self.S + c.data + k, strides=(self.S,))

    def _times(self, r: int, rows: int, c) -> list | None:
        """Timestamps (ns) of column c's records in the rows, as the reader computes them."""
        info = self.e.ts_info
        rec = self.pos + r * self.S + c.boff     # the record header of the first row
        if info is None:
            return None

        def field(at, dt):
            return np.ndarray((rows,), dtype=dt, buffer=self.buf, offset=rec + at, strides=(self.S,))
        if info[0] == "pcapng":
            bo, ifaces = info[1], info[2]
            ifid = struct.unpack_from(bo + "I", self.buf, rec + 8)[0]   # one interface per column (batch.py checks)
            _lt, _conv, off, mult = ifaces[ifid][:4]
            if not mult:
                return None
            t = (field(12, bo + "u4").astype(np.uint64) << np.uint64(32)) | field(16, bo + "u4").astype(np.uint64)
            if int(t.max()) > (_I64_MAX - abs(off)) // mult:
                return None
            ts = t.astype(np.int64) * mult + off
        else:
            bo, mult = info[1], info[2]
            ts = field(0, bo + "u4").astype(np.int64) * 1_000_000_000 + field(4, bo + "u4").astype(np.int64) * mult
        out = ts.tolist()
        if out[0] != self.ts_of(self.buf, rec) or out[-1] != self.ts_of(self.buf, rec + (rows - 1) * self.S):
            return None   # not the reader's arithmetic after all: frame by frame
        return out

    def _bulk_columns(self, r: int, e: int, objs) -> bool:
        """Rows [r, e) as whole columns; False (nothing written, nothing changed) when the stretch
        needs _bulk_frames."""
        exp = self.e.exp
        rows = e - r
        P = len(self.cols)
        first_fn = self.n + r * P + 1
        chans = set()
        lists = []    # per channel, in message order within a row: see _List
        for j, c in enumerate(self.cols):
            s = c.s
            ch = s.ch
            if ch in chans or ch.prev_cc is None:
                return False
            chans.add(ch)
            ts = self._times(r, rows, c)
            if ts is None:
                return False
            tsa = np.array(ts, dtype=np.int64)
            if tsa.min() < 0:
                return False   # the reference writes time 0 for those: frame by frame
            fns = range(first_fn + j, first_fn + j + rows * P, P)
            seq = np.arange(fns.start, fns.stop, fns.step, dtype=np.int64) & SEQ_MASK
            cap = c.cap
            cc = (self._col(r, rows, c, cap - 4).astype(np.int64) << 8) | self._col(r, rows, c, cap - 3)
            ds = self._col(r, rows, c, cap - 2).astype(np.int64)
            tr = self._col(r, rows, c, cap - 1).astype(np.int64)
            key = (cap << 16) | (ds << 8) | tr
            tails = s.tails
            for k in set(key.tolist()):
                if k not in tails:
                    i = int(np.argmax(key == k))
                    d = self.pos + (r + i) * self.S + c.data
                    exp._apdu_tail(s, self.buf[d:d + cap], k)
            tail = [tails[k] for k in key.tolist()]
            prev_cc = np.empty(rows, dtype=np.int64)
            prev_cc[0] = ch.prev_cc
            prev_cc[1:] = cc[:-1]
            prev_t = np.empty(rows, dtype=np.int64)
            prev_t[0] = ch.prev_t
            prev_t[1:] = tsa[:-1]
            d_cycle = (cc - prev_cc) & 0xFFFF
            dt = (tsa - prev_t).tolist()
            lst = _List(ch, tsa, seq)
            if exp.on_change:   # _rt's key: DataStatus, TransferStatus, cycle counter step (no IOPS/IOCS)
                last = (int(ds[-1]), int(tr[-1]), int(d_cycle[-1]), None, None)
                lst.thin(exp, _changed((int(ds[0]), int(tr[0]), int(d_cycle[0]), None, None) != ch.last_key,
                                       (ds, tr, d_cycle)), last)
            elif exp._thin:
                lst.thin(exp, None, None)
            lst.texts(s.fmt, zip(fns, cc.tolist(), tail, d_cycle.tolist(), dt))
            lists.append(lst)
            lst.apdu = (int(cc[-1]), ts[-1])
            if objs[j] and not self._tg_columns(r, rows, c, objs[j], fns, tsa, seq, ds, chans, lists):
                return False
        # every list is ready: merge row by row, write, then move the channels' state on
        k = len(lists)
        if all(lst.keep is None for lst in lists):
            n = rows * k
            datas = [None] * n
            cids = np.empty(n, np.uint16)
            lts = np.empty(n, np.int64)
            pubs = np.empty(n, np.int64)
            seqs = np.empty(n, np.int64)
            for q, lst in enumerate(lists):
                datas[q::k] = lst.data
                cids[q::k] = lst.ch.id
                lts[q::k] = lst.lt
                pubs[q::k] = lst.ts
                seqs[q::k] = lst.seq
        else:   # volume control kept different rows per channel: order by (row, place in the row)
            order = np.argsort(np.concatenate([lst.rows * k + q for q, lst in enumerate(lists)]), kind="stable")
            flat = [d for lst in lists for d in lst.data]
            datas = [flat[i] for i in order.tolist()]
            cids = np.concatenate([np.full(len(lst.data), lst.ch.id, np.uint16) for lst in lists])[order]
            lts = np.concatenate([lst.lt for lst in lists])[order]
            pubs = np.concatenate([lst.ts for lst in lists])[order]
            seqs = np.concatenate([lst.seq for lst in lists])[order]
        if datas:
            exp.w.add_batch(cids, lts, datas, pubs, seqs)
        for lst in lists:
            lst.settle(exp, rows)
        return True

    def _tg_columns(self, r, rows, c, objs, fns, tsa, seq, ds, chans, lists) -> bool:
        exp = self.e.exp
        coff = len(c.key)
        n_csdu = c.cap - 4 - coff
        ds_ok = (ds & 0x14) == 0x14
        for o in objs:
            st = exp._tgs.get(o)
            if (st is None or st.ch is None or st.ch in chans or st.layout is not o.layout
                    or st.source != o.source or st.profile != o.ax.profile or o.iops_at >= n_csdu):
                return False
            ch = st.ch
            chans.add(ch)
            lay = o.layout
            bo = "<" if lay.byte_order == "little" else ">"
            arrs, at = [], coff + o.start
            for nm in lay.names:
                sig = tg.SIGNALS[nm]
                arrs.append(self._col(r, rows, c, at, f"{bo}{'i' if sig['signed'] else 'u'}{sig['size']}"))
                at += sig["size"]
            cols = [x.tolist() for x in arrs]
            iops = self._col(r, rows, c, coff + o.iops_at)
            judged = list(map(_JSON_BOOL.__getitem__, (ds_ok & ((iops & IOPS_GOOD) != 0)).tolist()))
            # the bits text per row, keyed as _TgFast.words keys it: the word, or a tuple of words
            idx = [i for i, n in enumerate(lay.names) if n in tg.BITMAPS]
            wk = (cols[idx[0]] if len(idx) == 1 else list(zip(*[cols[i] for i in idx]))) if idx else [None] * rows
            texts = {}
            for w in set(wk):
                b = st.bits.get(w)
                if b is None:
                    i = wk.index(w)
                    b = exp._tg_bits(st, dict(zip(lay.names, [col[i] for col in cols])))
                    if b is None:
                        return False   # a G1_XIST2 error code: the event has one more field
                texts[w] = b
            bits = list(map(texts.__getitem__, wk))
            lst = _List(ch, tsa, seq)
            if exp.on_change:   # _telegram's key: the signals
                first = dict(zip(lay.names, [col[0] for col in cols]))
                last = (None, None, dict(zip(lay.names, [col[-1] for col in cols])))
                lst.thin(exp, _changed((None, None, first) != ch.last_key, arrs), last)
            elif exp._thin:
                lst.thin(exp, None, None)
            lst.texts(st.fmt_all, zip(fns, iops.tolist(), judged, *cols, bits))
            lst.st = st
            lists.append(lst)
        return True


def _changed(first: bool, arrays) -> list:
    """Per row: some array differs from the row before (row 0: ``first``)."""
    ch = np.zeros(len(arrays[0]), dtype=bool)
    for a in arrays:
        ch[1:] |= a[1:] != a[:-1]
    ch[0] = first
    return ch.tolist()


class _List:
    """The messages of one channel in a bulk stretch: which rows are written (volume control), their
    texts, log times, publish times and sequences, and what the channel's state becomes."""

    __slots__ = ("ch", "ts", "seq", "lt", "data", "keep", "rows", "n", "lw", "dropped", "key", "apdu", "st")

    def __init__(self, ch, tsa, seq):
        self.ch, self.ts, self.seq = ch, tsa, seq
        self.keep = self.rows = self.key = self.apdu = self.st = None

    def thin(self, exp, changed, last_key) -> None:
        """McapExporter._keep for every row, without touching the channel yet (see settle)."""
        ch = self.ch
        N, K, oc = exp.decimate, exp.keyframe_ns, exp.on_change
        n, lw = ch.n, ch.last_written_t
        keep = []
        for i, t in enumerate(self.ts.tolist()):
            n += 1
            if oc:
                k = changed[i] or lw is None or t - lw >= K or (N > 1 and (n - 1) % N == 0)
            else:
                k = N == 1 or (n - 1) % N == 0
            if k:
                lw = t
            keep.append(k)
        self.keep, self.n, self.lw, self.key = keep, n, lw, last_key
        self.dropped = len(keep) - sum(keep)
        self.rows = np.flatnonzero(keep)
        self.ts, self.seq = self.ts[self.rows], self.seq[self.rows]

    def texts(self, fmt: bytes, args) -> None:
        if self.keep is not None:
            args = compress(args, self.keep)
        self.data = list(map(fmt.__mod__, args))
        self.lt = np.maximum.accumulate(np.maximum(self.ts, self.ch.last_t)) if len(self.ts) else self.ts

    def settle(self, exp, rows: int) -> None:
        ch = self.ch
        if self.apdu is not None:
            ch.prev_cc, ch.prev_t = self.apdu
        if len(self.data):
            ch.last_t = int(self.lt[-1])
            ch.last_written_t = int(self.ts[-1])
            ch.written += len(self.data)
        if self.keep is not None:
            ch.n, ch.last_written_t = self.n, self.lw
            exp.dropped += self.dropped
            if exp.on_change:
                ch.last_key = self.key
        if self.st is not None:
            self.st.n += rows
            self.st.sig = self.st.inner = None


_Engine.run_class = _ExportRun   # its single rows write the APDU messages too
