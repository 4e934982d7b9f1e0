"""The one driver: reads the capture once, runs the engine, serves every sink (pndiss/sinks.py).

Every command that analyses a capture comes here (``analyze``; analyzer.analyze_file is this with
one plain callable as the sink). The driver owns the reader, progress, the frame loop, the finish
and the counting; sinks only say what they consume:

- no sink wants per-frame events (``rt`` / ``telegram``): the engine (pndiss/engine.py) takes the
  steady cyclic traffic in bulk, sinks get the events of their kinds -- at engine speed;
- some sink wants per-frame events: the reference path (Analyzer.feed on every frame), the oracle
  of the tests (also chosen by ``Settings.fast_path = False`` / env PNDISS_FAST_PATH=0).

Several files are one capture when they are the pieces of one ring buffer (dumpcap -b): they are
read in the order of their first time stamp, frame numbers run on across them (as after mergecap
-a), so an axis' history -- its pairing, deadlines, capture gaps -- runs across file boundaries.
Pieces that overlap in time are not a ring buffer: refused, as mergecap would interleave them.

A damaged file (cut short in the middle of a packet -- the newest piece of a live ring buffer, a dumpcap
killed -- or a corrupt block) ends its piece, as it ends tshark's read: every whole frame before it is
analysed, a ring buffer goes on with its next piece, and the driver raises CaptureError at the end with
``e.analyzer`` holding the whole analysis (the command reports it, then exits 2 as tshark does).
"""
from __future__ import annotations

import inspect
import os

from .proto import rt
from .sinks import FRAME_KINDS, FuncSink, Sink


def _as_sinks(sinks) -> list:
    out = []
    for s in sinks or ():
        if s is None:
            continue
        out.append(s if isinstance(s, Sink) else FuncSink(s))
    return out


def _column(s) -> bool:
    """A column sink gets cyclic frames and telegrams as columns (StreamBatch / CycleBatch), never as the
    per-frame ``rt`` / ``telegram`` dicts of cyclic frames."""
    return bool(s.cycles or s.streams)


def _per_frame(ev: dict) -> bool:
    """An event a column sink gets as a row instead: a telegram, or the rt event of a cyclic frame the
    tracker saw (one with its APDU status; a frame too short for it is malformed and has no row)."""
    k = ev["kind"]
    return k == "telegram" or (k == "rt" and "cycle_counter" in ev and rt.classify(ev.get("frame_id", 0))[1])


def _dispatch(a, sinks: list):
    """One callable for the analyzer: each event to the sinks that want its kind, with the frame whose
    processing emitted it (``at``) for the sinks that merge events with column rows."""
    if not sinks:
        return None
    table = []
    for s in sinks:
        if s.kinds is not None and not s.kinds:
            continue
        try:
            params = inspect.signature(s.event).parameters
        except (TypeError, ValueError):
            params = {}
        at = 2 if "after_rows" in params else 1 if "at" in params else 0
        table.append((s.event, s.kinds, at, _column(s)))

    def emit(ev, _table=tuple(table)):
        kind = ev["kind"]
        for fn, k, at, col in _table:
            if (k is None or kind in k) and not (col and kind in FRAME_KINDS and _per_frame(ev)):
                if at == 2:
                    fn(ev, a.at, a.after_rows)
                elif at:
                    fn(ev, a.at)
                else:
                    fn(ev)
    return emit


def engine_allowed(settings, sinks) -> bool:
    """The engine serves the sinks unless one of them wants per-frame events (or it is switched off)."""
    if not settings.fast_path or os.environ.get("PNDISS_FAST_PATH", "1") == "0":
        return False
    return not frame_events(sinks)


def frame_events(sinks) -> bool:
    """Some sink wants per-frame events (rt / telegram of cyclic frames) as dicts."""
    return any(not _column(s) and (s.kinds is None or s.kinds & FRAME_KINDS) for s in sinks)


def analyze(paths, settings=None, sinks=(), progress=None, verdict_hooks: dict | None = None,
            known_sha256: str | None = None):
    """Analyse the capture (one path, or the pieces of one ring buffer) and return the Analyzer.
    Raises capture.CaptureError on bad input after every complete frame was analysed (``e.analyzer``).
    ``known_sha256``: the input's digest, taken by the caller (it is not taken again)."""
    from .analyzer import Analyzer
    from .capture import CaptureError, ReadInfo

    if isinstance(paths, (str, os.PathLike)):
        paths = [paths]
    sinks = _as_sinks(sinks)
    a = Analyzer(settings)
    # the input's digest only for a sink that shows it (an MCAP file's metadata), or as the caller took it
    a.reader = ReadInfo(known_sha256, digest=any(s.digest for s in sinks))
    a.sink = _dispatch(a, sinks)
    a.frame_events = frame_events(sinks)
    hooks = dict(verdict_hooks or {})
    scope = hooks.pop("scope", None)
    if scope is not None:  # --station/--time: the verdict counts only what is in scope
        scope.bind(a)
        a.violations.keep = scope.keep
    for k, v in hooks.items():
        setattr(a.violations, k, v)
    fast_ok = engine_allowed(a.settings, sinks)
    col = None
    if any(s.cycles or s.streams for s in sinks):
        from .batches import Collector
        col = Collector(a, sinks)
        col.attach()
    try:
        _run(a, ring_order(paths) if len(paths) > 1 else paths, fast_ok, progress, col)
    except CaptureError as e:
        if len(paths) > 1 or not a.frames:
            # not a damaged piece (ring_piece takes those): pieces that are no ring buffer, nothing readable
            a.finish()
            if col is not None:
                col.flush(a.frames)
            e.analyzer = a
            raise
        a.reader.damage(paths[0], e, a.frames)   # one file: the reader's error ends the read
    a.finish()
    if col is not None:
        col.flush(a.frames)
    if a.reader.damaged:
        e = damaged_error(a.reader.damaged, a.frames)
        e.analyzer = a
        raise e
    return a


def damaged_error(damaged: list, frames: int):
    """One CaptureError for the damaged files of a capture (the first one's message, how many more)."""
    from .capture import CaptureError

    first = damaged[0]
    more = f"; {len(damaged) - 1} more damaged file(s) (see the summary's input.damaged)" if len(damaged) > 1 else ""
    return CaptureError(first["message"] + more, frames, cut_short=all(d["cut_short"] for d in damaged))


def ring_piece(a, path: str, frames):
    """The frames of one piece of a ring buffer; a piece that ends damaged ends there, the next one follows."""
    from .capture import CaptureError

    try:
        yield from frames
    except CaptureError as e:
        a.reader.damage(path, e, a.frames)


def _run(a, paths, fast_ok: bool, progress, col=None) -> None:
    from . import fast
    from .capture import open_capture

    if fast_ok:
        fast.run_files(a, paths, progress, check=_check_order, collector=col)
        return
    first = 0
    for k, path in enumerate(paths):
        if k:
            _check_order(a, paths[k - 1], path)
        order = a.reader.order   # time order (ReadInfo)
        frames = open_capture(path, info=a.reader, first=first)
        for fn, ts, lt, data in (ring_piece(a, path, frames) if len(paths) > 1 else frames):
            order(fn, ts)
            a.feed(fn, ts, lt, data)
            if not fn & 0xFFF:
                if progress is not None:
                    progress(fn)
                if col is not None:
                    col.flush(fn)
        first = a.frames


def ring_order(paths) -> list:
    """The pieces of one ring buffer in the order of their first time stamps."""
    from .capture import TS_MAX, CaptureError, open_capture

    firsts = []
    for p in paths:
        ts0 = None
        try:
            for _fn, ts, _lt, _data in open_capture(p):
                ts0 = ts
                break
        except CaptureError as e:
            if not e.cut_short:
                raise
            ts0 = TS_MAX   # cut short before its first frame: the piece being written, the newest (ring_piece says)
        firsts.append((ts0 if ts0 is not None else 0, p))
    firsts.sort()
    return [p for _t, p in firsts]


RING_SLACK_NS = 1_000_000_000   # a dumpcap on several interfaces writes each one's buffer in turn: a piece may
                                # start a little before the last frame of the one before (counted as out of order)


def _check_order(a, prev: str, path: str) -> None:
    """A piece must start where the previous one ended (the time the analyzer reached), give or take the
    reordering of a multi-interface dumpcap (RING_SLACK_NS, as within one file)."""
    from .capture import CaptureError, open_capture

    try:
        for _fn, ts, _lt, _data in open_capture(path):
            if a.last_ts is not None and ts < a.last_ts - RING_SLACK_NS:
                raise CaptureError(f"{path} starts before {prev} ends: these files are not the pieces of one ring "
                                   f"buffer (merge them with mergecap first)", a.frames)
            break
    except CaptureError as e:
        if not e.cut_short:
            raise
        # cut short before its first frame: reading it says so (ring_piece)
