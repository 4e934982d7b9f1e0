"""Fast path for report-only analysis (no event sink): cyclic PN-RT frames skip the generic dispatch.

Real captures are 99.9% cyclic frames of a few (FrameID, src, dst) streams. The reference path
(Analyzer.feed) decodes the link layer, formats both MACs, classifies the FrameID and builds a full
``rt`` event dict for each of them, although without a sink nobody reads that dict except the
cyclic tracker. Here the first frame of a stream goes the reference way; later frames whose first
16 bytes (MACs, EtherType, FrameID) match it are recognised with one dict lookup and handed to
``CyclicTracker.on_cyclic`` (on_frame without the ``rt`` dict). Counters (accounting, event kinds,
frame classes) are tallied per stream and added at the end, so summary() is unchanged.

Only Ethernet II (link type 1) frames, untagged or with one 802.1Q tag, with EtherType 0x8892, a cyclic FrameID and room for
the APDU status take this path; everything else, and every frame when a sink is set, goes through
Analyzer.feed. Switch: Settings.fast_path / env PNDISS_FAST_PATH=0 (tests/test_fastpath.py checks
both paths give the same results on every capture).
"""
from __future__ import annotations

import os

from .proto import rt
from .proto.common import Malformed, mac

ETH_PNRT = b"\x88\x92"
VLAN_8021Q = b"\x81\x00"


def enabled(settings, sink) -> bool:
    """The fast path applies without a sink, unless switched off by the setting or the environment."""
    return sink is None and settings.fast_path and os.environ.get("PNDISS_FAST_PATH", "1") != "0"


class _Stream:
    """One cyclic (FrameID, src, dst) stream: its tracker key and the frames it took."""

    __slots__ = ("key", "cls", "n", "bad")

    def __init__(self, key: tuple, cls: str):
        self.key = key
        self.cls = cls
        self.n = 0      # frames taken by the fast path
        self.bad = 0    # of which malformed (a data object beyond the C_SDU)


def batch_enabled() -> bool:
    """Cyclic streams demultiplexed and judged per axis (pndiss/engine.py); env PNDISS_BATCH=0 keeps the
    frame-by-frame fast path."""
    return os.environ.get("PNDISS_BATCH", "1") != "0"


def run_file(a, path: str, progress=None) -> None:
    run_files(a, [path], progress)


def run_files(a, paths, progress=None, check=None, collector=None) -> None:
    """The capture (one file, or the pieces of one ring buffer in order) into analyzer ``a``: the reader's
    buffered windows go to the engine, which takes every frame it can index; the rest come one by one
    through run(). ``check(a, previous, path)`` runs before each further piece."""
    from .capture import open_capture
    from .driver import ring_piece

    streams = new_streams(a)
    one = stepper(a, streams)
    engine = None
    if batch_enabled():
        from .engine import Engine
        engine = Engine(a, streams, one, progress, collector)

    def frames():
        first = 0
        for k, path in enumerate(paths):
            if k and check is not None:
                fn, ts = last[0], last[1]
                if engine is not None and engine.last_fn > (fn or 0):
                    fn, ts = engine.last_fn, engine.last_ts
                _settle(a, streams, fn, ts)   # the time reached so far, for the check
                check(a, paths[k - 1], path)
            yield from ring_piece(a, path, open_capture(path, batch=engine, info=a.reader, first=first))
            first = max(last[2], engine.last_fn if engine is not None else 0)
    last = [None, None, 0]

    def tracked():
        for f in frames():
            last[0], last[1], last[2] = f[0], f[1], f[0]
            yield f
    src = tracked() if len(paths) > 1 else open_capture(paths[0], batch=engine, info=a.reader)
    if progress is not None:
        src = _with_progress(src, progress)
    run(a, src, streams, engine, one)


def _with_progress(frames, progress):
    for f in frames:
        yield f
        if not f[0] & 0xFFF:
            progress(f[0])


def stepper(a, streams: dict):
    """The per-frame step: a frame of a known cyclic stream straight to the cyclic tracker, any other
    through Analyzer.feed (learning the stream of a cyclic PN-RT frame on the way)."""
    get = streams.get
    feed = a.feed
    on_cyclic = a.cyclic.on_cyclic
    cut_of = a.reader.cut_of   # a frame the snap length cut has no APDU status: Analyzer.feed says malformed

    def one(fn, ts, lt, data):
        if lt == 1 and len(data) >= 24:
            # untagged: MACs + EtherType + FrameID; one 802.1Q tag (the usual priority tag): 4 more
            off = 18 if data[12] == 0x81 else 14
            key = data[:off + 2]
            s = get(key, False)
            if s and cut_of(fn) is None:
                s.n += 1
                a.cur_frame = fn   # the frame being processed: what emitted events belong to (Analyzer.at)
                try:
                    # DataStatus: DataValid (0x04) and ProviderState RUN (0x10), wire.md §2.3
                    on_cyclic(s.key, fn, ts, rt.judgeable(data[-2], data[-1]), data, off + 2)
                except Malformed as e:
                    s.bad += 1
                    a.add_malformed(fn, ts, e.layer, e.reason)
                return
            feed(fn, ts, lt, data)
            if not s and data[off - 2:off] == ETH_PNRT:   # no per-header state for frames that are no PN-RT
                s = learn_stream(data, off)
                if s is not None:
                    streams[key] = s
        else:
            feed(fn, ts, lt, data)
    return one


def run(a, frames, streams: dict | None = None, engine=None, one=None) -> None:
    """Feed ``frames`` ((fn, ts, linktype, data) tuples) into analyzer ``a``. ``streams`` is shared
    with the ``engine`` (which takes frames of the streams learned here)."""
    if streams is None:
        streams = new_streams(a)   # data[:16] -> _Stream of a fast cyclic stream (nothing for other frames)
    if one is None:
        one = stepper(a, streams)
    fn = ts = None
    order = a.reader.order   # time order (ReadInfo); the engine counts its windows itself
    try:
        for fn, ts, lt, data in frames:
            order(fn, ts)
            one(fn, ts, lt, data)
    finally:
        if engine is not None and engine.last_fn > (fn or 0):
            fn, ts = engine.last_fn, engine.last_ts   # the capture ended in a window the engine took
        _settle(a, streams, fn, ts)


def new_streams(a, settle=None):
    """The fast path's stream table, bounded by Settings.max_streams: an evicted stream's frame counts go
    to the analyzer at once (``settle``, default settle_counts) and the stream is learned again if it
    comes back."""
    settle = settle or settle_counts
    return a.limits.table(a.settings.max_streams, "streams", lambda _k, s: settle(a, [s]))


def learn_stream(data: bytes, off: int):
    """A _Stream when frames starting with data[:off + 2] are cyclic PN-RT (untagged, or one 802.1Q tag
    when off is 18), else None."""
    if data[off - 2:off] != ETH_PNRT or (off == 18 and data[12:14] != VLAN_8021Q):
        return None
    fid = (data[off] << 8) | data[off + 1]
    cls, cyclic = rt.classify(fid, False)
    if not cyclic:
        return None
    return _Stream((fid, mac(data[6:12]), mac(data[0:6])), cls)


def settle_counts(a, streams) -> int:
    """Add the frames the fast-path ``streams`` took (objects with n, bad, cls) to the analyzer's totals,
    the same numbers Analyzer.feed keeps, and reset them; returns how many frames that was."""
    total = 0
    for s in streams:
        if not s or not s.n:
            continue
        total += s.n
        a.counts["decoded"] += s.n - s.bad
        a.counts["malformed"] += s.bad
        a.kinds["rt"] += s.n
        a.frame_classes[s.cls] += s.n
        s.n = s.bad = 0
    a.frames += total
    return total


def _settle(a, streams: dict, fn, ts) -> None:
    """The fast path's counts into the analyzer; its last frame becomes the analyzer's current one."""
    total = settle_counts(a, streams.values())
    if total and fn is not None:
        a.cur_frame, a.cur_ts = fn, ts
        a.last_ts = ts
