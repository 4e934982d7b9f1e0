"""Column batches for the sinks that consume cycles and cyclic frames (pndiss/sinks.py).

Rows come from two places: the engine's bulk stretches hand whole columns (``bulk_cycles``,
``bulk_frames``); every frame that goes one by one -- through ``CyclicTracker.on_cyclic``, on
either path -- adds one row through the tracker's hooks (``cycle_row``, ``frame_row``). Per
key (axis + direction, or stream) the single rows wait in lists and are turned into a batch before
the next bulk batch of that key and at every flush, so each key's rows reach the sinks in frame
order; ``flush(frame)`` then tells the sinks that everything up to that frame was delivered.
"""
from __future__ import annotations

import dataclasses

import numpy as np

from .sinks import CycleBatch, StreamBatch


class Collector:
    def __init__(self, analyzer, sinks):
        self.a = analyzer
        self.cyc = [s for s in sinks if s.cycles]
        self.str = [s for s in sinks if s.streams]
        self.sinks = sinks
        self.pend_c: dict = {}     # (axis key, direction) -> [identity, axis dict, frame_id, layout names, rows]
        self.pend_s: dict = {}     # stream key -> [(caplen, id(frame map)), off, rows, frame map]
        self.maps: dict = {}       # id(live frame map) -> (live map, its copy the batches carry)

    def attach(self) -> None:
        t = self.a.cyclic
        if self.cyc:
            t.telegram_sink = self.cycle_row
        if self.str:
            t.stream_sink = self.frame_row

    # -- one row at a time (the tracker's hooks) --------------------------------------------------
    def _axis(self, o, fm) -> dict:
        """The axis as a telegram event names it: station and device from the frame's map (a DCP rename
        shows from its frame on), the data object, the axis' telegram, profile and AR."""
        ax = o.ax or self.a.cyclic.axes.get(o.key)
        info = dict(ax.info) if ax is not None else {}
        do = o.do
        info.update(station=fm.station, device_mac=fm.device_mac, api=do.api, slot=do.slot, subslot=do.subslot,
                    telegram=o.telegram, telegram_source=o.source, profile=ax.profile if ax is not None else "generic",
                    ar_uuid=ax.fm.ar_uuid if ax is not None and ax.fm is not None else None)
        return info

    def cycle_row(self, o, fr, frame_id: int, fn: int, ts: int, iops, ok: bool) -> None:
        self.a.kinds["telegram"] += 1   # a telegram event as a row: counted as the dict would be
        self.a.rows_at = fn             # this frame's events from now on come after its telegram rows
        k = (o.key, fr.direction)
        ax = o.ax
        # rows of one batch share the axis' identity as the sinks see it (FrameID, station, telegram, its
        # source, profile, AR)
        ident = (frame_id, fr.fm.station, o.telegram, o.source, ax.profile if ax is not None else None,
                 ax.fm.ar_uuid if ax is not None and ax.fm is not None else None)
        p = self.pend_c.get(k)
        if p is None or p[0] != ident:   # a new identity: the rows pending go first (frame order per axis)
            self._flush_c(k)
            p = self.pend_c[k] = [ident, self._axis(o, fr.fm), frame_id, o.layout.names, []]
        p[4].append((fn, ts, -1 if iops is None else iops, ok, o.sig))

    def _rt_map(self, key: tuple):
        """The frame map an rt event of ``key`` decodes its ``iodata`` with now, as a copy that stays as it
        is: a sink may write held rows after the AR's Release has marked the live map released."""
        fm = self.a.session.lookup(*key)
        if fm is None or fm.released:
            return None
        got = self.maps.get(id(fm))
        if got is None or got[0] is not fm:
            if len(self.maps) >= 4096:   # bounded (hostile captures: 100 k ARs); pending rows keep their copies
                self.maps.clear()
            got = self.maps[id(fm)] = (fm, dataclasses.replace(fm))
        return got[1]

    def frame_row(self, key: tuple, fn: int, ts: int, data: bytes, off: int) -> None:
        fm = self._rt_map(key)   # the rt event's iodata map at this frame
        ident = (len(data), id(fm))
        p = self.pend_s.get(key)
        if p is None or p[0] != ident:   # another length or map: the rows pending go first (frame order)
            self._flush_s(key)
            p = self.pend_s[key] = [ident, off, [], fm]
        p[2].append((fn, ts, data))

    # -- whole columns (the engine) -----------------------------------------------------------------
    def bulk_cycles(self, o, fr, frame_id: int, fn, ts, iops, ok, sig: dict) -> None:
        direction = fr.direction
        self.a.kinds["telegram"] += len(fn)
        self._flush_c((o.key, direction))   # the axis' single rows before these
        b = CycleBatch(self._axis(o, fr.fm), direction, frame_id, np.asarray(fn, dtype=np.int64),
                       np.asarray(ts, dtype=np.int64), np.asarray(iops, dtype=np.int16), np.asarray(ok, dtype=bool),
                       {n: sig[n] for n in o.layout.names if n in sig})
        for s in self.cyc:
            s.cycle_batch(b)

    def bulk_frames(self, key: tuple, fn, ts, data2d, off: int) -> None:
        fm = self._rt_map(key)   # constant within a segment (the session changes at global frames)
        self._flush_s(key)   # the stream's single rows before these
        b = StreamBatch(key, np.asarray(fn, dtype=np.int64), np.asarray(ts, dtype=np.int64), data2d, off, fm)
        for s in self.str:
            s.stream_batch(b)

    # -- flushing -------------------------------------------------------------------------------------
    def _flush_c(self, k) -> None:
        p = self.pend_c.get(k)
        if not p or not p[4]:
            return
        _ident, info, fid, names, rows = p
        p[4] = []
        fn, ts, iops, ok, sigs = zip(*rows)
        sig = {}
        for n in names:
            vals = [s.get(n, 0) for s in sigs]
            sig[n] = np.array(vals, dtype=np.uint64 if any(v >= 1 << 63 for v in vals) else np.int64)
        b = CycleBatch(info, k[1], fid, np.array(fn, dtype=np.int64), np.array(ts, dtype=np.int64),
                       np.array(iops, dtype=np.int16), np.array(ok, dtype=bool), sig)
        for s in self.cyc:
            s.cycle_batch(b)

    def _flush_s(self, key) -> None:
        p = self.pend_s.get(key)
        if not p or not p[2]:
            return
        (caplen, _fm_id), off, rows, fm = p
        p[2] = []
        fn, ts, data = zip(*rows)
        arr = np.frombuffer(b"".join(data), dtype=np.uint8).reshape(len(data), caplen)
        b = StreamBatch(key, np.array(fn, dtype=np.int64), np.array(ts, dtype=np.int64), arr, off, fm)
        for s in self.str:
            s.stream_batch(b)

    def flush(self, frame: int) -> None:
        """Every row up to ``frame`` out; the sinks hear that everything up to it was delivered."""
        for k in self.pend_c:
            self._flush_c(k)
        for k in self.pend_s:
            self._flush_s(k)
        self.pend_c.clear()   # only the keys of this window's single rows (a flood of streams stays bounded)
        self.pend_s.clear()
        for s in self.sinks:
            s.flush_point(frame)
