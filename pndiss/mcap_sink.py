"""MCAP export as a sink of the one driver: the telegram and APDU topics written from columns.

The same file as pndiss/mcap_export.py's McapExporter writes for the same capture (channels,
schemas, messages, volume control): the exporter stays the one place that names topics, makes
channels and schemas and writes every other event; this sink holds the engine's row batches
(``CycleBatch``: telegram topics, ``StreamBatch``: APDU topics) and the events until
``flush_point``, merges them in the reference's order (pndiss/colrows.py) and writes the rows'
messages column-wise: per channel the volume control, log-time clamp, cycle-counter step and
time delta as arrays, the JSON text and the record headers by pndiss/coltext.py, straight into
the writer's chunk (McapWriter.add_records). A channel's first message goes through the exporter
(it creates the channel and its schema from that message, as the reference does).

Use: ``McapSink(path, capture_path, settings, on_change=False, decimate=1,
keyframe_ns=1_000_000_000, compression="zstd")``; ``reader_info`` as McapExporter's; ``close()``
at the end; ``summary()`` as McapExporter.summary.
"""
from __future__ import annotations

import numpy as np

from . import colrows
from .coltext import INT, Pool, Val, thin
from .mcap_export import McapExporter
from .mcap_schemas import dumps as _dumps
from .mcap_topics import RT_CONST, TG_CONST
from .telegrams import CHANGE_MASKS

SEQ_MASK = 0xFFFFFFFF


class _State:
    """A channel's volume-control and clamp state while a flush computes it (McapExporter._Chan's fields)."""
    __slots__ = ("exists", "last_t", "n", "last_key", "lw", "written", "prev_cc", "prev_t")

    def __init__(self, ch):
        self.exists = ch is not None
        if ch is None:
            self.last_t, self.n, self.last_key, self.lw, self.written, self.prev_cc, self.prev_t = 0, 0, None, None, 0, None, None
        else:
            self.last_t, self.n, self.last_key, self.lw = ch.last_t, ch.n, ch.last_key, ch.last_written_t
            self.written, self.prev_cc, self.prev_t = ch.written, ch.prev_cc, ch.prev_t

    def store(self, ch) -> None:
        ch.last_t, ch.n, ch.last_key, ch.last_written_t = self.last_t, self.n, self.last_key, self.lw
        ch.written, ch.prev_cc, ch.prev_t = self.written, self.prev_cc, self.prev_t


class _Rows:
    """The kept rows of one batch part: template, values, record header fields, merge keys."""
    __slots__ = ("key", "tmpl", "vals", "k", "frames", "seq", "lt", "pub", "rank", "order", "first")


class McapSink(colrows.HeldSink):
    kinds = None      # every event kind; cyclic frames' rt / telegram events come as rows
    cycles = True
    streams = True
    digest = True     # the file's metadata names the capture's SHA-256

    def __init__(self, path: str | None = None, capture_path: str | None = None, settings=None, *,
                 on_change: bool = False, decimate: int = 1, keyframe_ns: int = 1_000_000_000,
                 compression: str = "zstd", chunk_size: int = 1024 * 1024, exp: McapExporter | None = None):
        if exp is None:   # else: write into an exporter made by the caller (McapExporter.run)
            exp = McapExporter(path, capture_path, settings, on_change=on_change, decimate=decimate,
                               compression=compression, chunk_size=chunk_size)
            exp.keyframe_ns = int(keyframe_ns)
        self.exp = exp
        self.held = colrows.Held(dict)
        self.pool = Pool()
        self._recipes: dict = {}
        self.hold_rows = colrows.HOLD_ROWS   # rows held before a flush point writes them

    @property
    def reader_info(self):
        return self.exp.reader_info

    @reader_info.setter
    def reader_info(self, info) -> None:
        self.exp.reader_info = info

    # -- the sink contract ------------------------------------------------------------------------
    def finish(self) -> None:
        """Write every held row and event (the exporter stays open)."""
        if not self.exp.closed:
            self._flush(None)

    def close(self) -> None:
        if not self.exp.closed:
            self._flush(None)
            self.exp.close()

    def summary(self) -> dict:
        return self.exp.summary()

    # -- one flush ------------------------------------------------------------------------------
    def _channel(self, key: tuple):
        if key[0] == "rt":
            return self.exp.stream_channel(*key[1:])
        return self.exp.telegram_channel(*key[1:])

    def _flush(self, frame) -> None:
        parts, evs = self.held.take(frame)
        groups: dict = {}
        for kind, b, lo, hi in parts:
            if kind == "rt":
                key = ("rt", *b.key)
            else:
                ax = b.axis
                key = ("tg", ax.get("device_mac"), ax.get("api"), ax.get("slot"), ax.get("subslot"), b.direction)
            groups.setdefault(key, []).append((kind, b, lo, hi))
        events = [(f, r, o, ("ev", ev)) for f, r, o, ev in colrows.place(evs, colrows.axis_frames(parts))]
        srcs: list[_Rows] = []
        states = []
        for key, ps in groups.items():
            ps.sort(key=lambda p: int(p[1].frame[p[2]]))
            st = _State(self._channel(key))
            made = None
            # parts of one channel that interleave (a stream whose frame length changes back and forth)
            # would need one joint state: their rows go the reference way, as events
            if all(int(a[1].frame[a[3] - 1]) < int(c[1].frame[c[2]]) for a, c in zip(ps, ps[1:])):
                made = [self._rows(key, st, p) for p in ps]
            if made is None or any(m is None for m in made):
                for kind, b, lo, hi in ps:
                    for i in range(lo, hi):
                        ev = colrows.rt_event(b, i, False) if kind == "rt" else colrows.telegram_event(b, i)
                        rank = colrows.RANK_RT if kind == "rt" else colrows.RANK_TELEGRAM
                        order = 0 if kind == "rt" else colrows.object_order(b.axis)
                        events.append((ev["frame"], rank, order, ("ev", ev)))
                continue
            states.append((key, st))
            for r in made:
                if r.first is not None:
                    events.append((r.first["frame"], r.rank, r.order, ("first", key, r.first)))
                srcs.append(r)
        if not srcs and not events:
            return
        # every source's rows as one set of columns (row g of source s: offset[s] + r)
        self._cat(srcs)
        colrows.merge([(s.frames, s.rank, s.order) for s in srcs], events, self._write_rows, self._event)
        for key, st in states:
            ch = self._channel(key)
            if ch is not None:
                st.store(ch)

    def _cat(self, srcs) -> None:
        n = sum(len(s.frames) for s in srcs)
        self.tmpl = np.empty(n, np.int64)
        self.vbase = np.empty(n, np.int64)
        self.cid = np.zeros(n, np.int64)
        self.seq = np.empty(n, np.int64)
        self.lt = np.empty(n, np.int64)
        self.pub = np.empty(n, np.int64)
        self.where: dict = {}       # channel key -> row slices (their channel id is set once it exists)
        vals, at, vat = [], 0, 0
        for s in srcs:
            m = len(s.frames)
            sl = slice(at, at + m)
            self.tmpl[sl] = s.tmpl
            self.vbase[sl] = vat + np.arange(m, dtype=np.int64) * s.k
            self.seq[sl], self.lt[sl], self.pub[sl] = s.seq, s.lt, s.pub
            ch = self._channel(s.key)
            if ch is not None:
                self.cid[sl] = ch.id
            else:
                self.where.setdefault(s.key, []).append(sl)
            vals.append(s.vals)
            at += m
            vat += len(s.vals)
        self.vals = np.concatenate(vals) if vals else np.zeros(0, np.int64)

    def _event(self, item) -> None:
        if item[0] == "ev":
            self.exp.on_event(item[1])
            return
        _, key, ev = item
        self.exp.on_event(ev)    # the channel's first message: the exporter makes the channel
        ch = self._channel(key)
        for sl in self.where.pop(key, ()):
            self.cid[sl] = ch.id

    def _write_rows(self, idx) -> None:
        cid, lt = self.cid[idx], self.lt[idx]
        w = self.exp.w

        def emit(data, ends, lo, hi):
            w.add_records(data, ends, cid[lo:hi], lt[lo:hi])
        self.pool.render(self.tmpl[idx], self.vbase[idx], self.vals, emit,
                         hdr=(cid, self.seq[idx], lt, self.pub[idx]))

    # -- one batch part's rows ----------------------------------------------------------------------
    def _compile(self, kind: str, b, lo: int) -> tuple:
        """(template id, recipe) of the messages of rows like b's row lo; (None, None): not columns."""
        if kind == "rt":
            got = colrows.rt_shape(b, lo, False, self.pool, _dumps)
            if got is None:
                return None, None
            shape, recipe = got
            msg = {k: v for k, v in shape.items() if k not in RT_CONST}
            n = 7 if recipe[0] else 5
            msg["d_cycle"], msg["dt_ns"] = Val(INT, n), Val(INT, n + 1)   # the columns _rows adds
        else:
            shape, recipe = colrows.telegram_shape(b, lo, self.pool, _dumps)
            msg = {k: v for k, v in shape.items() if k not in TG_CONST}
        return self.pool.template(msg, _dumps), recipe

    def _rows(self, key, st: _State, part) -> _Rows | None:
        kind, b, lo, hi = part
        exp = self.exp
        n = hi - lo
        sig = colrows.rt_signature(b) if kind == "rt" else colrows.telegram_signature(b)
        got = self._recipes.get(sig)
        if got is None:
            got = self._recipes[sig] = self._compile(kind, b, lo)
        if got[0] is None:
            return None
        tmpl, recipe = got
        if kind == "rt":
            cols = colrows.rt_columns(b, lo, hi, recipe)
            if cols is None:
                return None
            cc, ds, tr = cols[2], cols[3], cols[4]
        else:
            cols = colrows.telegram_columns(b, lo, hi, recipe, self.pool, _dumps)
        frames, ts = cols[0], cols[1]
        first = not st.exists
        pub = np.maximum(ts, 0)    # _write: a negative capture time is written as 0
        if kind == "rt":
            prev_cc = np.empty(n, np.int64)
            prev_t = np.empty(n, np.int64)
            prev_cc[1:], prev_t[1:] = cc[:-1], ts[:-1]
            prev_cc[0], prev_t[0] = (cc[0], ts[0]) if first else (st.prev_cc, st.prev_t)
            d_cycle = (cc - prev_cc) & 0xFFFF
            cols += [d_cycle, ts - prev_t]
        exp.seen[kind if kind == "rt" else "telegram"] = exp.seen.get(kind if kind == "rt" else "telegram", 0) + n - first
        if exp.on_change or exp.decimate > 1:
            changed = np.zeros(n, np.bool_)
            if exp.on_change:
                if kind == "rt":
                    keys = (ds, tr, d_cycle)
                    k0 = (int(ds[0]), int(tr[0]), None if first else int(d_cycle[0]), None, None)
                else:
                    names = colrows.signal_names(b)
                    # (not the sign-of-life counters: telegrams.CHANGE_MASKS, as mcap_topics._telegram)
                    keys = [c & CHANGE_MASKS[nm] if nm in CHANGE_MASKS else c
                            for nm, c in zip(names, cols[4:4 + len(names)])]
                    k0 = (None, None, {nm: int(c[0]) for nm, c in zip(names, keys)})
                for c in keys:
                    changed[1:] |= c[1:] != c[:-1]
                changed[0] = first or k0 != st.last_key
                if first and kind == "rt" and n > 1:
                    changed[1] = True    # the first sample had no cycle-counter step
                if kind == "rt":
                    st.last_key = (int(ds[-1]), int(tr[-1]), None if first and n == 1 else int(d_cycle[-1]), None, None)
                else:
                    st.last_key = (None, None, {nm: int(c[-1]) for nm, c in zip(names, keys)})
            keep, st.n, lw, has = thin(ts, pub, changed, st.n, st.lw if st.lw is not None else 0, st.lw is not None,
                                       exp.decimate, exp.on_change, exp.keyframe_ns)
            st.lw = int(lw) if has else None
            rows = np.flatnonzero(keep)
            exp.dropped += n - len(rows)
        else:
            rows = np.arange(n)
            st.lw = int(pub[-1])
        if kind == "rt":
            st.prev_cc, st.prev_t = int(cc[-1]), int(ts[-1])
        st.exists = True
        r = _Rows()
        r.key = key
        r.rank = colrows.RANK_RT if kind == "rt" else colrows.RANK_TELEGRAM
        r.order = 0 if kind == "rt" else colrows.object_order(b.axis)
        r.first = None
        if len(rows):
            lt = np.maximum.accumulate(np.maximum(pub[rows], st.last_t))
            st.last_t = int(lt[-1])
            st.written += len(rows)
        else:
            lt = np.zeros(0, np.int64)
        if first:   # row 0 is always kept: it goes the reference way and makes the channel
            r.first = colrows.rt_event(b, lo, False) if kind == "rt" else colrows.telegram_event(b, lo)
            rows, lt = rows[1:], lt[1:]
        r.tmpl = tmpl
        r.k = len(cols)
        r.vals = np.column_stack(cols)[rows].ravel() if len(rows) else np.zeros(0, np.int64)
        r.frames = frames[rows]
        r.seq = np.where(r.frames >= 0, r.frames & SEQ_MASK, 0)
        r.lt = lt
        r.pub = pub[rows]
        return r
