"""Test-only producer for the column sinks: a capture's reference-path events regrouped into the
engine's batches (StreamBatch per cyclic stream, CycleBatch per data object and direction) and
the remaining events, delivered with flush points as the driver does (tests/test_colfmt.py,
bench/colfmt.py)."""
from __future__ import annotations

import copy

import numpy as np

from pndiss import telegrams as tg
from pndiss.analyzer import Analyzer
from pndiss.capture import open_capture
from pndiss.sinks import CycleBatch, StreamBatch


def _profile(ev: dict) -> str:
    """The profile whose bit maps give the event's bits (the event does not name it)."""
    for p in ("generic", *tg.PROFILES):
        if tg.bits(ev["signals"], p) == ev["bits"]:
            return p
    return "generic"


class Recorded:
    """One reference run: ``items`` in emission order, each ("ev", frame emitted at, event) or a row
    ("rt", frame, key, ts, bytes, off, fm snapshot) / ("tg", frame, axis, direction, frame_id, event)."""

    def __init__(self, path: str, settings=None):
        a = Analyzer(settings)
        items = []
        cur = {}
        # copied at emission, as a sink sees them (the session adds to some events later)
        a.sink = lambda ev: items.append(("ev", a.cur_frame, copy.deepcopy(ev)))
        a.frame_events = True   # a sink of every kind: rt / telegram events as the reference path builds them
        self.fm_snap: dict = {}
        for fn, ts, lt, data in open_capture(path, info=a.reader):
            start = len(items)
            a.feed(fn, ts, lt, data)
            for j in range(start, len(items)):
                _, at, ev = items[j]
                k = ev.get("kind")
                if k == "rt" and j == start and "cycle_counter" in ev and lt == 1 and ev["frame"] == fn:
                    off = 18 if data[12:14] in (b"\x81\x00", b"\x88\xa8", b"\x91\x00") else 14
                    if data[off - 2:off] != b"\x88\x92" or (data[off] << 8 | data[off + 1]) != ev["frame_id"]:
                        continue
                    key = (ev["frame_id"], ev["src"], ev["dst"])
                    fm = a.session.lookup(*key)
                    sig = None if fm is None else (id(fm), fm.source, fm.released, fm.frame_id)
                    if key not in cur or cur[key][0] != sig:
                        cur[key] = (sig, copy.copy(fm))
                    items[j] = ("rt", fn, key, ts, bytes(data), off, cur[key][1], ev)
                elif k == "telegram":
                    ax = {"station": ev["station"], "device_mac": ev["device_mac"], "api": ev["api"],
                          "slot": ev["slot"], "subslot": ev["subslot"], "telegram": ev["telegram"],
                          "telegram_source": ev["telegram_source"], "profile": _profile(ev)}
                    items[j] = ("tg", ev["frame"], ax, ev["direction"], ev["frame_id"], ev)
        a.finish()
        self.items = items
        self.analyzer = a


def plan(rec: Recorded, every: int = 4096) -> list:
    """The driver's calls for the recorded run: per stretch of ``every`` frames the events emitted
    in it, then its rows as batches, then ("flush", last frame of the stretch); ("close",) at the end."""
    calls = []
    last = 0
    rts, tgs = {}, {}

    def flush(upto):
        for (key, _fm), rows in rts.items():
            calls.extend(("stream", b) for b in _stream_batches(key, rows))
        calls.extend(("cycle", _cycle_batch(key, rows)) for key, rows in tgs.items())
        rts.clear()
        tgs.clear()
        calls.append(("flush", upto) if upto is not None else ("close",))

    for it in rec.items:
        at = it[1]
        if at is not None and at - last >= every:
            flush(at - 1)
            last = at
        if it[0] == "ev":
            calls.append(("event", it[2], at))
        elif it[0] == "rt":
            _, fn, key, ts, data, off, fm, _ev = it
            rts.setdefault((key, id(fm)), []).append((fn, ts, data, off, fm))
        else:
            _, fn, ax, d, fid, ev = it
            tgs.setdefault((tuple(sorted(ax.items())), d, fid), []).append(ev)
    flush(None)
    return calls


def play(calls, sinks, positions: bool = False) -> None:
    """Make the calls on every sink, as far as each declares it consumes them; ``positions``: pass
    each event's emitting frame (``at``)."""
    for c in calls:
        what = c[0]
        for s in sinks:
            if what == "event":
                if s.wants(c[1]["kind"]):
                    if positions:
                        s.event(c[1], c[2])
                    else:
                        s.event(c[1])
            elif what == "stream":
                if s.streams:
                    s.stream_batch(c[1])
            elif what == "cycle":
                if s.cycles:
                    s.cycle_batch(c[1])
            elif what == "flush":
                s.flush_point(c[1])
            else:
                s.close()


def deliver(rec: Recorded, sinks, every: int = 4096, positions: bool = False) -> None:
    play(plan(rec, every), sinks, positions)


def _stream_batches(key, rows):
    """One batch per captured length and header size, rows in frame order."""
    by = {}
    for r in rows:
        by.setdefault((len(r[2]), r[3]), []).append(r)
    for (n, off), rs in by.items():
        yield StreamBatch(key=key, frame=np.array([r[0] for r in rs], np.int64),
                          ts_ns=np.array([r[1] for r in rs], np.int64),
                          data=np.frombuffer(b"".join(r[2] for r in rs), np.uint8).reshape(len(rs), n),
                          off=off, fm=rs[0][4])


def _cycle_batch(key, evs):
    ax, d, fid = dict(key[0]), key[1], key[2]
    names = list(evs[0]["signals"])
    sig = {}
    for nm in names:
        s = tg.SIGNALS[nm]
        dt = np.uint64 if s["size"] == 8 and not s["signed"] else np.int64
        sig[nm] = np.array([e["signals"][nm] for e in evs], dt)
    return CycleBatch(axis=ax, direction=d, frame_id=fid,
                      frame=np.array([e["frame"] for e in evs], np.int64),
                      ts_ns=np.array([e["ts_ns"] for e in evs], np.int64),
                      iops=np.array([-1 if e["iops"] is None else e["iops"] for e in evs], np.int16),
                      judged=np.array([e["judged"] for e in evs], bool), signals=sig)
