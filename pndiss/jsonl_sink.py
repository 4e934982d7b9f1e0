"""JSONL as a sink of the one driver: one JSON event per line, the per-frame events from columns.

``JsonlSink(fileobj)`` writes what ``pndiss analyze --jsonl`` writes on the reference path, line
for line: the ``rt`` event of every cyclic frame (from the engine's ``StreamBatch``) and the
``telegram`` event of every data object (``CycleBatch``) are written from columns by
pndiss/coltext.py with templates compiled from the events themselves (pndiss/colrows.py), every
other event as the reference writes it (JSON, a violation's time set to its frame's: events.py
FrameTimes). Rows and events are held until ``flush_point`` and merged in the reference's order.

``JsonlSink(fileobj, kinds={"violation", ...})`` (``--events KINDS``) writes only those kinds;
then the rows are consumed only for the frame times a violation's ``ts_ns`` is set from.
"""
from __future__ import annotations

import json

import numpy as np

from . import colrows
from .coltext import Pool
from .errors import UsageError
from .events import ColumnFrameTimes, json_default


_dumps = json.JSONEncoder(separators=(",", ":"), default=json_default).encode


class JsonlSink(colrows.HeldSink):
    def __init__(self, fileobj, kinds=None, where: str | None = None):
        self.f = fileobj
        self.where = where   # the path named when writing fails (a full disk: exit 2)
        self.kinds = None if kinds is None else frozenset(kinds)
        self.rt = self.wants("rt")
        self.tg = self.wants("telegram")
        # frame times: a violation's ts_ns is its frame's (FrameTimes), cyclic frames included
        self.streams = self.rt or self.wants("violation")
        self.cycles = self.tg
        self.times = ColumnFrameTimes()
        self.held = colrows.Held(dict)
        self.pool = Pool()
        self._recipes: dict = {}
        self.hold_rows = colrows.HOLD_ROWS   # rows held before a flush point writes them
        self.out: list[bytes] = []
        self._binary = not hasattr(fileobj, "encoding")

    # -- the sink contract ------------------------------------------------------------------------
    def cycle_batch(self, batch) -> None:
        if self.tg:
            self.held.batch("tg", batch)

    def close(self) -> None:
        self._flush(None)

    # -- one flush ------------------------------------------------------------------------------
    def _flush(self, frame) -> None:
        parts, evs = self.held.take(frame)
        events = colrows.place(evs, colrows.axis_frames(parts))
        rows, srcs = [], []
        for kind, b, lo, hi in parts:
            tmpl = cols = None
            if kind == "tg" or self.rt:
                sig = colrows.rt_signature(b) if kind == "rt" else colrows.telegram_signature(b)
                got = self._recipes.get(sig)
                if got is None:
                    got = self._recipes[sig] = self._compile(kind, b, lo)
                tmpl, recipe = got
                if tmpl is not None:
                    cols = (colrows.rt_columns(b, lo, hi, recipe) if kind == "rt"
                            else colrows.telegram_columns(b, lo, hi, recipe, self.pool, _dumps))
                if cols is None:    # a link header the columns do not cover: event by event
                    for i in range(lo, hi):
                        events.append((int(b.frame[i]), colrows.RANK_RT, 0, colrows.rt_event(b, i, True)))
                    self._times(b, lo, hi)
                    continue
            if kind == "rt":
                rank, order = colrows.RANK_RT, 0
            else:
                rank, order = colrows.RANK_TELEGRAM, colrows.object_order(b.axis)
            if cols is None:     # rows only for the frame times
                srcs.append((None, np.asarray(b.frame[lo:hi], np.int64), np.asarray(b.ts_ns[lo:hi], np.int64), 0))
            else:
                srcs.append((tmpl, cols[0], cols[1], np.column_stack(cols).ravel(), len(cols)))
            rows.append((srcs[-1][1], rank, order))
        self._cat(srcs)
        colrows.merge(rows, events, self._write_rows, self._event)
        self._write()

    def _compile(self, kind: str, b, lo: int) -> tuple:
        """(template id, recipe) of the lines of rows like b's row lo; (None, None): not columns."""
        got = (colrows.rt_shape(b, lo, True, self.pool, _dumps) if kind == "rt"
               else colrows.telegram_shape(b, lo, self.pool, _dumps))
        if got is None:
            return None, None
        return self.pool.template(got[0], _dumps, b"\n"), got[1]

    def _times(self, b, lo, hi) -> None:
        self.times.rows(np.asarray(b.frame[lo:hi], np.int64), np.asarray(b.ts_ns[lo:hi], np.int64))

    def _cat(self, srcs) -> None:
        n = sum(len(s[1]) for s in srcs)
        self.tmpl = np.full(n, -1, np.int64)
        self.vbase = np.zeros(n, np.int64)
        self.frames = np.empty(n, np.int64)
        self.ts = np.empty(n, np.int64)
        vals, at, vat = [], 0, 0
        for s in srcs:
            m = len(s[1])
            sl = slice(at, at + m)
            self.frames[sl], self.ts[sl] = s[1], s[2]
            if s[0] is not None:
                self.tmpl[sl] = s[0]
                self.vbase[sl] = vat + np.arange(m, dtype=np.int64) * s[4]
                vals.append(s[3])
                vat += len(s[3])
            at += m
        self.vals = np.concatenate(vals) if vals else np.zeros(0, np.int64)

    def _write_rows(self, idx) -> None:
        f, t = self.frames[idx], self.ts[idx]
        self.times.rows(f, t)
        tm = self.tmpl[idx]
        if (tm < 0).any():
            idx = idx[tm >= 0]
            tm = tm[tm >= 0]
        if len(idx):
            self._write()
            self.pool.render(tm, self.vbase[idx], self.vals, lambda data, ends, lo, hi: self._put(data))

    def _event(self, ev) -> None:
        ev = self.times.fix(ev)
        if self.kinds is None or ev["kind"] in self.kinds:
            self.out.append((_dumps(ev) + "\n").encode())

    def _write(self) -> None:
        if self.out:
            data = b"".join(self.out)
            self.out = []
            self._put(data)

    def _put(self, data) -> None:
        try:
            if self._binary:
                self.f.write(data)
            else:   # a text file (stdout, open(..., "w")): the JSON text is ASCII
                self.f.write(bytes(data).decode("ascii"))
        except BrokenPipeError:
            raise
        except OSError as e:
            if self.where is None:
                raise
            raise UsageError(f"cannot write {self.where}: {e.strerror}") from None
