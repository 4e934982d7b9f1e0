"""The fast path (pndiss/fast.py) gives the same results as the reference path (Analyzer.feed).

Every capture in captures/ and the public captures runs both ways: without a sink (the fast path's
case) the summaries must be equal and so must every event the trackers emit (violations, state,
malformed ... recorded by wrapping Analyzer.emit; only the per-frame ``rt`` events, which the fast
path counts instead of building, are left out of the stream and compared through the summary's
counts); with a JSONL sink the streams must be byte-identical whatever the setting says.
Hypothesis mutates frames of a simulated session and checks the same, and that nothing but the
pipeline's own accounting comes out of it.
"""
from __future__ import annotations

import glob
import io
import json
import os

import pytest
from hypothesis import HealthCheck, given, settings as hsettings, strategies as st

from pndiss import fast
from pndiss.analyzer import Analyzer, analyze_file
from pndiss.capture import open_capture
from pndiss.settings import Settings

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CAPTURES = sorted(glob.glob(os.path.join(ROOT, "captures", "*.pcap*"))
                  + glob.glob("/work/shared/captures/public/*.pcap*"))


def _run(frames, fast_path: bool):
    """(summary without settings, emitted events other than rt) of one pass over ``frames``."""
    a = Analyzer(Settings(fast_path=fast_path))
    seen = []
    emit = a.emit

    def record(ev):
        if ev["kind"] != "rt":
            seen.append(json.dumps(ev, sort_keys=True, default=str))
        emit(ev)

    a.emit = record
    if fast.enabled(a.settings, a.sink):
        fast.run(a, frames)
    else:
        for fn, ts, lt, data in frames:
            a.feed(fn, ts, lt, data)
    a.finish()
    s = a.summary()
    s.pop("settings")
    return json.loads(json.dumps(s, sort_keys=True, default=str)), seen


def test_captures_exist():
    assert len(CAPTURES) > 20


@pytest.mark.parametrize("path", CAPTURES, ids=os.path.basename)
def test_same_results_without_sink(path):
    frames = list(open_capture(path))
    s_fast, ev_fast = _run(frames, True)
    s_ref, ev_ref = _run(frames, False)
    assert s_fast == s_ref
    assert ev_fast == ev_ref


@pytest.mark.parametrize("path", CAPTURES[::7], ids=os.path.basename)
def test_same_stream_with_sink(path):
    outs = []
    for fp in (True, False):
        buf = io.StringIO()
        a = analyze_file(path, Settings(fast_path=fp), lambda ev: buf.write(json.dumps(ev, default=str) + "\n"))
        outs.append((buf.getvalue(), a.summary()["accounting"]))
    assert outs[0] == outs[1]


def test_fast_path_taken_and_switches(monkeypatch):
    """Without a sink the fast path runs; the setting and the environment switch it off."""
    s = Settings()
    assert fast.enabled(s, None)
    assert not fast.enabled(s, print)
    assert not fast.enabled(Settings(fast_path=False), None)
    monkeypatch.setenv("PNDISS_FAST_PATH", "0")
    assert not fast.enabled(s, None)


def test_fast_path_skips_dispatch():
    """On a cyclic capture the fast path really bypasses Analyzer.feed for the cyclic streams."""
    path = next(p for p in CAPTURES if os.path.basename(p).startswith("fault-sol"))
    frames = list(open_capture(path))
    a = Analyzer(Settings())
    calls = 0
    feed = a.feed

    def counted(*args):
        nonlocal calls
        calls += 1
        feed(*args)

    a.feed = counted
    fast.run(a, frames)
    assert a.frames == len(frames)
    assert calls < len(frames) // 2


def _base_frames():
    path = next(p for p in CAPTURES if os.path.basename(p).startswith("fault-sol"))
    return list(open_capture(path))[:400]


_BASE = None


@hsettings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.lists(st.tuples(st.integers(0, 399), st.integers(0, 200), st.integers(0, 255), st.booleans()),
                max_size=12))
def test_mutated_frames_same_both_ways(muts):
    """Mutated, truncated frames: both paths agree, and only the pipeline's accounting comes out."""
    global _BASE
    if _BASE is None:
        _BASE = _base_frames()
    frames = list(_BASE)
    for i, pos, val, cut in muts:
        i %= len(frames)
        fn, ts, lt, data = frames[i]
        b = bytearray(data)
        if cut:
            del b[pos % (len(b) + 1):]
        elif b:
            b[pos % len(b)] = val
        frames[i] = (fn, ts, lt, bytes(b))
    s_fast, ev_fast = _run(frames, True)
    s_ref, ev_ref = _run(frames, False)
    assert s_fast == s_ref
    assert ev_fast == ev_ref
    assert sum(s_fast["accounting"].values()) == len(frames)
