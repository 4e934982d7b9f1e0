"""Drive sinks from today's reference path: ``analyze_file`` with one callable as its sink.

The one driver (issue #13) calls ``event``/``cycle_batch``/``flush_point``/``close`` itself; until
it lands, ``run`` does it here: events of the wanted kinds go to ``event``, ``telegram`` events are
gathered per axis and direction into CycleBatches of up to BATCH rows. Swap ``run`` for the driver
and nothing else changes.
"""
from __future__ import annotations

import numpy as np

from .. import telegrams as tg
from ..events import FrameTimes
from ..sinks import CycleBatch

BATCH = 4096


def _profile_of(ev: dict) -> str:
    """The profile whose bit maps give exactly the event's bits (the analyser chose it)."""
    have = set(ev.get("bits") or ())
    sig = ev.get("signals") or {}
    for p in ("generic", *tg.PROFILES):
        if set(tg.bits(sig, p)) == have:
            return p
    return "generic"


class _Rows:
    __slots__ = ("axis", "direction", "frame_id", "frame", "ts", "iops", "judged", "sig")

    def __init__(self, ev: dict, direction: str):
        self.axis = {k: ev.get(k) for k in ("station", "device_mac", "api", "slot", "subslot", "telegram",
                                             "telegram_source")}
        self.axis["profile"] = _profile_of(ev)
        self.direction = direction
        self.frame_id = ev.get("frame_id")
        self.frame, self.ts, self.iops, self.judged = [], [], [], []
        self.sig = {k: [] for k in ev.get("signals") or ()}

    def batch(self) -> CycleBatch:
        return CycleBatch(
            axis=self.axis, direction=self.direction, frame_id=self.frame_id,
            frame=np.array(self.frame, np.int64), ts_ns=np.array(self.ts, np.int64),
            iops=np.array(self.iops, np.int16), judged=np.array(self.judged, bool),
            signals={k: np.array(v, np.uint64 if tg.SIGNALS.get(k, {}).get("size") == 8 else np.int64)
                     for k, v in self.sig.items()})


def run(path: str, settings, sinks, progress=None):
    """Analyse ``path`` with the reference path, feeding ``sinks``; returns the Analyzer.
    Raises what ``analyze_file`` raises (CaptureError carries ``.analyzer``)."""
    from ..analyzer import analyze_file
    from ..capture import CaptureError

    open_rows: dict = {}
    cyc = [s for s in sinks if s.cycles]

    def flush(key):
        r = open_rows.pop(key)
        if r.frame:
            b = r.batch()
            for s in cyc:
                s.cycle_batch(b)

    fix = FrameTimes().fix   # a violation's ts_ns is its frame's time, as in the JSONL

    def on_event(ev):
        ev = fix(ev)
        kind = ev["kind"]
        if kind == "telegram":
            if not cyc:
                return
            d = "setpoint" if str(ev.get("direction", "")).lower() in ("setpoint", "output") else "actual"
            key = (ev.get("device_mac"), ev.get("api"), ev.get("slot"), ev.get("subslot"), d)
            r = open_rows.get(key)
            sig = ev.get("signals") or {}
            if r is not None and (r.axis["telegram"] != ev.get("telegram") or r.frame_id != ev.get("frame_id")
                                  or r.sig.keys() != sig.keys()
                                  or r.axis["telegram_source"] != ev.get("telegram_source")):
                flush(key)
                r = None
            if r is None:
                r = open_rows[key] = _Rows(ev, d)
            r.frame.append(ev["frame"])
            r.ts.append(ev["ts_ns"])
            iops = ev.get("iops")
            r.iops.append(iops if isinstance(iops, int) else -1)
            r.judged.append(bool(ev.get("judged")))
            for k, v in sig.items():
                r.sig[k].append(v)
            if len(r.frame) >= BATCH:
                flush(key)
            return
        for s in sinks:
            if s.wants(kind):
                s.event(ev)

    try:
        a = analyze_file(path, settings, on_event, progress)
    except CaptureError:   # a damaged file: what was read before the damage is kept
        for key in list(open_rows):
            flush(key)
        raise
    for key in list(open_rows):
        flush(key)
    for s in sinks:
        s.flush_point(a.frames)
    return a
