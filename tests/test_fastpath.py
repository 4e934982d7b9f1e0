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
from hypothesis import HealthCheck, example, given, settings as hsettings, strategies as st

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
            a.reader.order(fn, ts)   # as pndiss.driver's reference path
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


# -- the engine (pndiss/engine.py): streams demultiplexed, steady pairs applied at once -----------------------------------

import struct
import subprocess
import sys

from pndiss import engine
from pndiss.capture import CaptureError


def _run_file(path: str, batched: bool):
    """(summary without settings, events other than rt, capture error, engine) of one pass over the file:
    the batch path (fast.run_file) or the reference path (Analyzer.feed on every frame)."""
    seen = []

    def record(ev):
        if ev["kind"] != "rt":
            seen.append(json.dumps(ev, sort_keys=True, default=str))

    a = Analyzer(Settings(fast_path=batched), record)
    a.frame_events = False   # a sink of the engine's kinds: no per-frame telegram events on either path
    err = eng = None
    try:
        if batched:
            streams: dict = {}
            one = fast.stepper(a, streams)
            eng = engine.Engine(a, streams, one)
            fast.run(a, open_capture(path, batch=eng, info=a.reader), streams, eng, one)
        else:
            for f in open_capture(path, info=a.reader):
                a.reader.order(f[0], f[1])   # as pndiss.driver's reference path
                a.feed(*f)
    except CaptureError as e:
        err = (str(e), e.frames)
    a.finish()
    s = a.summary()
    s.pop("settings")
    return json.loads(json.dumps(s, sort_keys=True, default=str)), seen, err, eng


def _same_both_ways(path: str):
    s_b, ev_b, err_b, eng = _run_file(path, True)
    s_r, ev_r, err_r, _ = _run_file(path, False)
    assert err_b == err_r
    assert s_b == s_r
    assert ev_b == ev_r
    return eng


@pytest.mark.parametrize("path", CAPTURES, ids=os.path.basename)
def test_batch_same_results(path):
    _same_both_ways(path)


def test_analyze_file_takes_the_batch_path(monkeypatch):
    """analyze_file without a sink goes through the engine; PNDISS_BATCH=0 keeps the frame-by-frame path."""
    path = next(p for p in CAPTURES if os.path.basename(p).startswith("fault-sol-device-zero-rt"))
    made = []
    real = engine.Engine

    def spy(*args, **kw):
        made.append(real(*args, **kw))
        return made[-1]

    monkeypatch.setattr(engine, "Engine", spy)
    a = analyze_file(path)
    assert made and made[0].frames_bulk > 0
    assert a.summary()["accounting"]["decoded"] == a.frames
    monkeypatch.setenv("PNDISS_BATCH", "0")
    analyze_file(path)
    assert len(made) == 1


# Long simulated sessions: the steady stretches the batch path is for, with faults placed anywhere.

def _simulate(tmpdir, name, *args) -> list:
    out = os.path.join(tmpdir, name + ".pcapng")
    subprocess.run([sys.executable, "-m", "pndiss", "simulate", *args, "--no-expected", "-o", out],
                   check=True, capture_output=True, cwd=ROOT)
    return list(open_capture(out))


@pytest.fixture(scope="module")
def sessions(tmp_path_factory):
    d = str(tmp_path_factory.mktemp("batch"))
    return {
        # T83: NIST present (rule 44 on arrays), motion both ways
        "motion83": _simulate(d, "m", "--scenario", "motion", "--telegram", "83", "--cycles", "1500",
                              "--inject", "NIST-SIGN@900"),
        # two encoders: four streams per period; a preset handshake and an injected out-of-range position
        "two81": _simulate(d, "t", "--scenario", "preset", "--telegram", "81", "--encoders", "2", "--cycles", "1200",
                           "--inject", "POSITION-OUT-OF-RANGE@700"),
        # SCANCON: position continuity (rule 42) on arrays, reserved bit injected
        "scancon84": _simulate(d, "s", "--scenario", "startup", "--profile", "scancon", "--telegram", "84",
                               "--cycles", "1200", "--inject", "RESERVED-BIT-SET-G1ZSW@600",
                               "--inject", "SOL-DEVICE-ZERO-RT@300"),
        # plant traffic: 3 moving encoders at 1/2/4 ms + 2 IO devices, drifting clocks and jitter (the frame
        # order changes all the time), 0.2 % capture loss
        "plant": _simulate(d, "p", "--scenario", "motion", "--encoders", "3", "--io-devices", "2",
                           "--cycle-time", "1,2,4", "--capture-loss", "0.002", "--cycles", "1500"),
        # isochronous with sign-of-life monitoring, loss, and a controller sign-of-life skip
        "irt": _simulate(d, "i", "--scenario", "motion", "--irt", "--encoders", "2", "--capture-loss", "0.001",
                         "--cycles", "3000", "--inject", "SOL-MASTER-SKIP@2000"),
        # presets, parking and sensor errors over and over (benchmark set (c))
        "routine": _simulate(d, "r", "--scenario", "routine", "--cycles", "7000"),
    }


def _write(path: str, frames, fmt: str, snaplen: int | None = None) -> None:
    """frames as pcapng (le/be) or pcap (le/be, us/ns); snaplen cuts the captured bytes, not the length."""
    with open(path, "wb") as f:
        if fmt.startswith("pcapng"):
            bo = "<" if fmt.endswith("le") else ">"
            f.write(struct.pack(bo + "IIIHHqI", 0x0A0D0D0A, 28, 0x1A2B3C4D, 1, 0, -1, 28))
            f.write(struct.pack(bo + "IIHHI" "HHB3x" "HH" "I", 1, 32, 1, 0, 0, 9, 1, 9, 0, 0, 32))
            for _fn, ts, _lt, data in frames:
                cap = data[:snaplen] if snaplen else data
                pad = -len(cap) & 3
                total = 32 + len(cap) + pad
                f.write(struct.pack(bo + "IIIIIII", 6, total, 0, ts >> 32, ts & 0xFFFFFFFF, len(cap), len(data))
                        + cap + b"\0" * pad + struct.pack(bo + "I", total))
        else:
            bo = "<" if fmt.endswith("le") else ">"
            ns = "-ns" in fmt
            f.write(struct.pack(bo + "IHHiIII", 0xA1B23C4D if ns else 0xA1B2C3D4, 2, 4, 0, 0, snaplen or 65535, 1))
            for _fn, ts, _lt, data in frames:
                cap = data[:snaplen] if snaplen else data
                sec, frac = divmod(ts, 1_000_000_000)
                f.write(struct.pack(bo + "IIII", sec, frac if ns else frac // 1000, len(cap), len(data)) + cap)


FORMATS = ("pcapng-le", "pcapng-be", "pcap-le", "pcap-be", "pcap-ns-le", "pcap-ns-be")


@pytest.mark.parametrize("fmt", FORMATS)
@pytest.mark.parametrize("name", ("motion83", "two81", "scancon84", "plant", "irt", "routine"))
def test_batch_long_sessions(sessions, tmp_path, name, fmt):
    """Every format, both byte orders: same results, and most cycles really went through in runs."""
    path = str(tmp_path / ("s." + fmt.split("-")[0]))
    _write(path, sessions[name], fmt)
    eng = _same_both_ways(path)
    # presets, parking and sensor errors every 3 s: their cycles (and L+1 after each change) go one by one
    assert eng.frames_bulk > (5 if name == "routine" else 10) * eng.frames_single


def test_batch_snaplen_truncated(sessions, tmp_path):
    """A snaplen shorter than the frames: every cyclic frame is cut (malformed or undecodable)."""
    for snap in (20, 30, 40):
        path = str(tmp_path / f"snap{snap}.pcap")
        _write(path, sessions["motion83"], "pcap-le", snaplen=snap)
        _same_both_ways(path)


_OTHER = bytes.fromhex("ffffffffffff020000000099" "0806") + bytes(46)   # an ARP-typed frame: not PROFINET


def _mutate(frames: list, muts) -> list:
    """The mutations of test_batch_mutated_sessions applied to a copy of ``frames``."""
    frames = list(frames)
    for kind, where, off, val in muts:
        i = int(where * len(frames))
        fn, ts, lt, data = frames[i]
        b = bytearray(data)
        lo = 20 if len(b) > 24 else 0
        p = lo + off % max(1, len(b) - 4 - lo)   # inside the C_SDU: telegram words, IOPS
        if kind == "byte":
            b[off % len(b)] = val
        elif kind == "bit":
            b[p] ^= 1 << (val & 7)
        elif kind == "zero2":   # a whole word (or sign-of-life nibble) 0
            b[p:p + 2] = bytes(len(b[p:p + 2]))
        elif kind == "freeze":
            first: dict = {}
            for k in range(i, min(len(frames), i + 2 + off % 40)):
                fk = frames[k]
                head, csdu = fk[3][:20], fk[3][20:-4]
                first.setdefault(head, csdu)
                if len(first[head]) == len(csdu):
                    frames[k] = (fk[0], fk[1], fk[2], head + first[head] + fk[3][-4:])
            continue
        elif kind == "burst":
            same = [k for k in range(i, len(frames)) if frames[k][3][:20] == data[:20]][:2 + val % 6]
            for k in same:
                fk = frames[k]
                bk = bytearray(fk[3])
                bk[p % len(bk)] ^= 1 << (val & 7)
                frames[k] = (fk[0], fk[1], fk[2], bytes(bk))
            continue
        elif kind == "cut":
            del b[off % (len(b) + 1):]
        elif kind == "drop":
            del frames[i]
            continue
        elif kind == "swap":   # a stretch of frames in another order (2..9 frames, rotated by val)
            k = min(len(frames), i + 2 + off % 8)
            seg = frames[i:k]
            r = val % max(1, len(seg))
            frames[i:k] = seg[r:] + seg[:r]
            continue
        elif kind == "lose":   # capture loss: every frame of one stream over a stretch
            head = data[:20]
            frames[i:] = [f for j, f in enumerate(frames[i:]) if not (j < 20 + off % 200 and f[3][:20] == head)]
            continue
        elif kind == "insert":
            frames.insert(i, (fn, ts, 1, _OTHER))
            continue
        elif kind == "dup":
            frames.insert(i, frames[i])
            continue
        frames[i] = (fn, ts, lt, bytes(b))
    return frames


@hsettings(max_examples=60, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                   HealthCheck.function_scoped_fixture])
@given(name=st.sampled_from(("motion83", "two81", "scancon84", "plant", "irt", "routine")), fmt=st.sampled_from(FORMATS),
       muts=st.lists(st.tuples(st.sampled_from(("byte", "bit", "zero2", "burst", "freeze", "cut", "drop", "insert",
                                                "dup", "swap", "lose")),
                               st.floats(0, 1, exclude_max=True), st.integers(0, 10_000), st.integers(0, 255)),
                     max_size=8))
def test_batch_mutated_sessions(sessions, tmp_path, name, fmt, muts):
    """Single-frame faults at random places in long steady stretches: a byte or a telegram bit changed
    (control/status words, sign-of-life, positions, DataStatus, IOPS, FrameID, MACs), a frame cut, dropped,
    doubled, or a non-PROFINET frame in the middle of a run; a burst repeats one change in the next
    frames of the stream (conditions over several cycles); a freeze repeats every stream's C_SDU for a few
    cycles (identical inputs: the checker's own shortcut); a stretch of frames reordered (RT drift, jitter);
    a stream losing frames (capture loss). Both paths agree on everything."""
    frames = _mutate(sessions[name], muts)
    path = str(tmp_path / ("m." + fmt.split("-")[0]))
    _write(path, frames, fmt)
    _same_both_ways(path)


def test_sensor_error_code_changes_mid_error(sessions, tmp_path):
    """A sensor error that goes on unchanged is applied in runs (the checker's steady path changes nothing
    but the timeline); a new error code in the middle of it is a `state` event the engine must not skip."""
    frames = list(sessions["routine"])
    code = (0x1001).to_bytes(4, "big")
    hits = [i for i, f in enumerate(frames) if f[3].count(code) == 1]
    assert len(hits) > 300, "the routine's sensor error (0x1001 in G1_XIST2) is not in the session"
    # the second half of the first error stretch reports 0x1003 instead
    first = [i for i in hits if i < hits[0] + 400]
    for i in first[len(first) // 2:]:
        fn, ts, lt, data = frames[i]
        frames[i] = (fn, ts, lt, data.replace(code, (0x1003).to_bytes(4, "big")))
    path = str(tmp_path / "serr.pcapng")
    _write(path, frames, "pcapng-le")
    _same_both_ways(path)
    s, ev, _err, eng = _run_file(path, True)
    states = [json.loads(e) for e in ev if '"kind": "state"' in e]
    codes = [e["value"] for e in states if e["state"] == "sensor_error"]
    assert 0x1001 in codes and 0x1003 in codes, codes
    assert eng.frames_bulk > 5 * eng.frames_single


def test_shorter_frame_of_a_stream_ends_the_file(sessions, tmp_path):
    """The fuzz campaign's crash (seed3030-m55): a stream's frame shorter than the stream's first frame
    in the window, and the last record of the file -- the engine's columns read each frame's counter and
    status at its own end and never past the buffer; both paths agree."""
    frames = list(sessions["plant"])[:3000]
    def cyclic(d):   # an RT_CLASS_1 frame, with or without its 802.1Q tag
        o = 16 if d[12:14] == b"\x81\x00" else 12
        return d[o:o + 2] == b"\x88\x92" and 0x80 <= d[o + 2] < 0xC0
    i = max(k for k, f in enumerate(frames) if cyclic(f[3]))
    fn, ts, lt, data = frames[i]
    short = data[:-44] + data[-4:]
    frames.append((len(frames) + 1, frames[-1][1] + 1000, len(short), short))
    for fmt in ("pcapng-le", "pcap-be"):
        path = str(tmp_path / ("s." + fmt.split("-")[0]))
        _write(path, frames, fmt)
        _same_both_ways(path)


_MUTS = st.lists(st.tuples(st.sampled_from(("byte", "bit", "zero2", "burst", "freeze", "cut", "drop", "insert", "dup",
                                            "swap", "lose")),
                           st.floats(0, 1, exclude_max=True), st.integers(0, 10_000), st.integers(0, 255)),
                 max_size=8)


@hsettings(max_examples=20, deadline=None, suppress_health_check=[HealthCheck.too_slow,
                                                                   HealthCheck.function_scoped_fixture])
@given(name=st.sampled_from(("two81", "scancon84", "plant", "routine")), muts=_MUTS)
# two stale frames in a row (frames moved back in time): the second one's counter is one step on from the
# first stale one but older than the last frame taken; the engine compared it with the stale one
@example(name="routine", muts=[("swap", 0.25, 7, 75), ("swap", 0.25, 7, 2)])
def test_full_jsonl_mutated_sessions(sessions, tmp_path, name, muts):
    """`analyze --jsonl` written from the engine's columns = the reference's lines on mutated sessions
    (the fuzz campaign found a cut cyclic frame's partial rt event, a station as the frame's map names
    it, and events a frame emits before its telegram rows)."""
    from test_engine_sinks import _engine_lines, _reference_lines
    path = str(tmp_path / "j.pcapng")
    _write(path, _mutate(sessions[name], muts)[:4000], "pcapng-le")
    assert _engine_lines(path) == _reference_lines(path)


@given(st.lists(st.lists(st.integers(0, 12), min_size=1, max_size=300), min_size=1, max_size=6))
@hsettings(max_examples=60, deadline=None)
def test_distinct_prefix_hashes_as_unique(windows):
    """engine._distinct answers as np.unique for window after window (the engine's table of earlier windows'
    hashes only replaces the sort): the same distinct values and inverse, a representative frame of each."""
    import numpy as np

    class Eng:
        hashes = np.empty(0, dtype=np.uint64)
    eng = Eng()
    for w in windows:
        h = (np.array(w, dtype=np.uint64) * np.uint64(0x9E3779B97F4A7C15))
        uh, first, inv = engine._distinct(h, eng)
        want_u, want_inv = np.unique(h, return_inverse=True)
        assert (uh == want_u).all() and (inv == want_inv).all()
        assert (h[first] == uh).all()


@pytest.mark.parametrize("fmt", ("pcapng-le", "pcap-le"))
def test_cyclic_frames_cut_by_the_snap_length(sessions, tmp_path, fmt):
    """A cyclic frame the snap length cut has no APDU status (its last 4 bytes on the wire): malformed, not a
    cycle, and no "cycle counter" read from its data bytes -- no false stale frames or capture gaps (an
    independent audit); the engine leaves such frames to the reader, and both paths agree."""
    frames = list(sessions["two81"])[:4000]
    path = str(tmp_path / ("cut." + fmt.split("-")[0]))
    _write(path, frames, fmt, snaplen=40)
    _same_both_ways(path)
    s = _run_file(path, True)[0]
    def cyclic(d):   # an RT_CLASS_1 frame, with or without its 802.1Q tag
        o = 16 if d[12:14] == b"\x81\x00" else 12
        return d[o:o + 2] == b"\x88\x92" and 0x80 <= d[o + 2] < 0xC0
    cyc = sum(1 for f in frames if cyclic(f[3]))
    assert cyc and s["accounting"]["malformed"] >= cyc
    assert not s["cyclic"]["capture_gaps"].get("stale") and not s["cyclic"]["capture_gaps"].get("count")


def _it_frames():
    """An IT network's frames on the PROFINET segment: OPC UA over TCP, an SNMP poll, ICMP, a tagged ARP."""
    import rpc_frames as R
    pc, sw = "02:00:00:00:0a:01", "02:00:00:00:0a:02"
    tcp = struct.pack(">HHIIBBHHH", 50123, 4840, 1, 1, 0x50, 0x18, 8192, 0, 0) + b"OPNF" + bytes(60)
    return [R.eth(pc, sw, R.ipv4("10.0.0.1", "10.0.0.2", tcp, proto=6)),
            R.eth(pc, sw, R.ipv4("10.0.0.1", "10.0.0.2", R.udp(50000, 161, b"\x30\x26\x02\x01\x01" + bytes(35)))),
            R.eth(sw, pc, R.ipv4("10.0.0.2", "10.0.0.1", b"\x00\x00\xff\xff\x00\x01\x00\x01" + bytes(32), proto=1)),
            bytes.fromhex("ffffffffffff020000000a018100000a0806") + bytes(28)]


def test_it_traffic_does_not_stop_the_engine(sessions, tmp_path):
    """TCP, SNMP, ICMP and tagged ARP every 40 frames (a plant's IT traffic on the PROFINET segment): no PNIO layer
    takes them, so they do not end the engine's segments -- the cycles still go in bulk, with the reference
    path's results (an independent audit: 0.8 % IPv4 frames made the engine slower than the reference). A UDP
    datagram that starts like connectionless DCE/RPC (version 4) still goes in capture order."""
    import rpc_frames as R
    it = _it_frames()
    odd = R.eth("02:00:00:00:0a:01", "02:00:00:00:0a:02", R.ipv4("10.0.0.1", "10.0.0.2", R.udp(5353, 5353, b"\x04" + bytes(90))))
    frames = []
    for k, (fn, ts, lt, data) in enumerate(sessions["plant"]):
        frames.append((fn, ts, lt, data))
        if k % 40 == 39:
            frames.append((0, ts + 1000, 1, it[(k // 40) % len(it)]))
        if k % 4000 == 3999:
            frames.append((0, ts + 2000, 1, odd))
    path = str(tmp_path / "it.pcapng")
    _write(path, frames, "pcapng-le")
    eng = _same_both_ways(path)
    assert eng.frames_bulk > 10 * eng.frames_single
    assert eng.frames_inert > 0   # TCP, ICMP, ARP: counted at once, not fed one by one


def _odd_it_frames():
    """Frames at the edge of 'only counted': a UDP length beyond the datagram (malformed), an IP total length
    beyond the frame, a TCP fragment, an 802.3 frame (STP), an inner QinQ TPID, a UDP datagram starting with 4."""
    import rpc_frames as R
    pc, sw = "02:00:00:00:0a:01", "02:00:00:00:0a:02"
    bad_udp = R.ipv4("10.0.0.1", "10.0.0.2", struct.pack(">HHHH", 50000, 161, 200, 0) + bytes(30))
    long_ip = bytearray(R.ipv4("10.0.0.1", "10.0.0.2", R.udp(50000, 161, bytes(30))))
    long_ip[2:4] = (1400).to_bytes(2, "big")
    tcp_frag = R.ipv4("10.0.0.1", "10.0.0.2", bytes(40), proto=6, flags_frag=0x2000)
    stp = bytes.fromhex("0180c2000000020000000a01") + (39).to_bytes(2, "big") + bytes.fromhex("424203") + bytes(36)
    qinq_inner = bytes.fromhex("ffffffffffff020000000a018100000a88a8000b0806") + bytes(28)
    return [R.eth(pc, sw, bad_udp), R.eth(pc, sw, bytes(long_ip)), R.eth(pc, sw, tcp_frag), stp, qinq_inner,
            R.eth(pc, sw, R.ipv4("10.0.0.1", "10.0.0.2", R.udp(5353, 5353, b"\x04" + bytes(90))))]


def test_odd_it_frames_counted_as_the_reference_does(sessions, tmp_path):
    """The frames at the edge of what the engine counts in bulk (Window._kinds: 4) and what the plain-UDP
    shortcut (session_rpc._plain_udp) passes: the same accounting, malformed frames and events as the reference."""
    odd = _odd_it_frames()
    frames = []
    for k, (fn, ts, lt, data) in enumerate(sessions["plant"]):
        frames.append((fn, ts, lt, data))
        if k % 50 == 49:
            frames.append((0, ts + 1000, 1, odd[(k // 50) % len(odd)]))
    path = str(tmp_path / "odd.pcapng")
    _write(path, frames, "pcapng-le")
    _same_both_ways(path)
    s = _run_file(path, True)[0]
    assert s["accounting"]["malformed"] > 0   # the UDP length beyond its datagram


@hsettings(max_examples=400, deadline=None)
@given(st.binary(min_size=8, max_size=80), st.sampled_from([0x45, 0x45, 0x46, 0x44, 0x55]),
       st.sampled_from([0, 0, 0x4000, 0x2000, 0x0001, 0x4000]), st.sampled_from([0, 0, 0, -1, 1, -20]),
       st.sampled_from([0, 0, 0, -1, 1, -4]), st.sampled_from([161, 34962, 34964, 5353, 49152]),
       st.sampled_from([None, 4, 0x30]))
@example(bytes(40), 0x45, 0, 0, 0, 161, 0x30)
def test_plain_udp_shortcut_is_the_full_path(payload, vihl, ff, dtotal, dulen, port, first):
    """session_rpc._plain_udp says "only counted" exactly where the full path (decode_ipv4, decode_udp, the port and
    DCE/RPC checks) returns not_profinet without raising: the same answer both ways on near-valid datagrams (total
    and UDP lengths right or one off, fragment bits, header lengths, PNIO ports, payloads that start like DCE/RPC)."""
    from pndiss.proto import dcerpc, ip
    from pndiss.proto.common import Malformed
    from pndiss.session_rpc import PORT_RPC
    ihl = (vihl & 15) * 4
    if first is not None and payload:
        payload = bytes([first]) + payload[1:]
    udp_len = 8 + len(payload) + dulen
    body = bytes(max(0, ihl - 20)) + struct.pack(">HHHH", 50000, port, udp_len & 0xFFFF, 0) + payload
    total = 20 + len(body) + dtotal
    hdr = struct.pack(">BBHHHBBH4s4s", vihl, 0, total & 0xFFFF, 1, ff, 64, 17, 0, bytes(4), bytes(4))
    data = bytes(14) + hdr + body
    a = Analyzer()
    ses = a.session
    short = ses._plain_udp(data, 14)
    try:
        h = ip.decode_ipv4(data, 14)
        u = ip.decode_udp(data, h["payload_off"], h["payload_end"])
        po, pe = u["payload_off"], u["payload_end"]
        ports = {u["srcport"], u["dstport"]}
        full = (not h["flags_mf"] and not h["frag_offset"] and h["proto"] == 17 and not ports & ses.rt_ports
                and PORT_RPC not in ports and (pe - po < dcerpc.HDR_LEN or data[po] != 4))
    except Malformed:
        full = False
    assert short == full
    if short:
        assert ses.on_ipv4(0, 0, data, 14, "a", "b") == "not_profinet"


def test_malformed_list_in_frame_order():
    """The summary's malformed frames are the first ones in frame order, whatever order the engine processed them
    in (a device's DCE/RPC datagrams and alarms go before other devices' earlier frames; the review of
    2026-11-25 found the list out of order)."""
    from pndiss.analyzer import MAX_KEPT_MALFORMED, Analyzer
    a = Analyzer()
    frames = [5000, 300, 7] + list(range(10_000, 10_000 + 3 * MAX_KEPT_MALFORMED)) + [1]
    for fn in frames:
        a.add_malformed(fn, fn, "test", "bad")
    got = [m["frame"] for m in a.summary()["malformed"]]
    assert got == sorted(frames)[:MAX_KEPT_MALFORMED]


def test_simple_packet_blocks_take_the_time_before_them(sessions, tmp_path):
    """A Simple Packet Block has no time stamp (tshark shows 1970): pndiss gives it the time of the frame before
    it, whether the reader or the engine took that one -- no capture gaps, no backward steps of 55 years (an
    independent audit: 537 false capture gaps and one fault reported three times)."""
    def blk(t, body):
        body += bytes(-len(body) % 4)
        return struct.pack("<II", t, 12 + len(body)) + body + struct.pack("<I", 12 + len(body))
    frames = list(sessions["plant"])[:20000]
    runs = {}
    for spb in (False, True):
        out = [blk(0x0A0D0D0A, struct.pack("<IHHq", 0x1A2B3C4D, 1, 0, -1)),
               blk(1, struct.pack("<HHI", 1, 0, 0) + struct.pack("<HHB3x", 9, 1, 9) + struct.pack("<HH", 0, 0))]
        for k, (_fn, ts, _lt, d) in enumerate(frames):
            d = bytes(d)
            if spb and k % 97 == 50:
                out.append(blk(3, struct.pack("<I", len(d)) + d))
            else:
                out.append(blk(6, struct.pack("<IIIII", 0, ts >> 32, ts & 0xFFFFFFFF, len(d), len(d)) + d))
        path = str(tmp_path / f"spb{int(spb)}.pcapng")
        with open(path, "wb") as f:
            f.write(b"".join(out))
        _same_both_ways(path)
        runs[spb] = _run_file(path, True)[0]
    assert runs[True]["cyclic"]["capture_gaps"] == runs[False]["cyclic"]["capture_gaps"]
    assert runs[True]["cyclic"]["violations_by_severity"] == runs[False]["cyclic"]["violations_by_severity"]
    def backwards(d):
        if isinstance(d, dict):
            return d.get("timestamps_backwards") or next((b for v in d.values() for b in [backwards(v)] if b), 0)
        return 0
    assert backwards(runs[True]) == backwards(runs[False]) == 0


def test_drop_count_inside_an_engine_window(sessions, tmp_path):
    """An EPB whose epb_dropcount says the tool lost packets before it, among thousands the engine indexes: the frame
    index leaves it to the reader, which counts it -- the same summary both ways."""
    def blk(t, body):
        body += bytes(-len(body) % 4)
        return struct.pack("<II", t, 12 + len(body)) + body + struct.pack("<I", 12 + len(body))
    out = [blk(0x0A0D0D0A, struct.pack("<IHHq", 0x1A2B3C4D, 1, 0, -1)),
           blk(1, struct.pack("<HHI", 1, 0, 0) + struct.pack("<HHB3x", 9, 1, 9) + struct.pack("<HH", 0, 0))]
    frames = list(sessions["plant"])[:20000]
    at = (len(frames) // 3, 2 * len(frames) // 3)
    for k, (_fn, ts, _lt, d) in enumerate(frames):
        d = bytes(d)
        opts = b""
        if k in at:   # epb_flags (inbound) first, then epb_dropcount
            opts = struct.pack("<HHI", 2, 4, 1) + struct.pack("<HHQ", 4, 8, 7) + struct.pack("<HH", 0, 0)
        out.append(blk(6, struct.pack("<IIIII", 0, ts >> 32, ts & 0xFFFFFFFF, len(d), len(d)) + d + bytes(-len(d) % 4)
                       + opts))
    path = str(tmp_path / "drops.pcapng")
    with open(path, "wb") as f:
        f.write(b"".join(out))
    eng = _same_both_ways(path)
    assert eng.frames_bulk > 10 * eng.frames_single
    s = _run_file(path, True)[0]
    assert s["input"]["tool_dropped"] == 14 and s["input"]["tool_dropped_first_frame"] == at[0] + 1


def test_every_violation_has_the_time_of_the_frame_it_names():
    """A controller-side rule names the setpoint frame (or a parameter rule its request frame) but was decided at a
    later frame: its ts_ns is still the named frame's time, in the analyzer's own events -- not repaired only by
    sinks that saw that frame's rt event (an independent audit: the MCAP log, the dataset and `--events
    violation` put a SOL-MASTER-SKIP one encoder frame late). Engine and reference path alike."""
    import glob as _glob
    from pndiss.capture import open_capture
    paths = sorted(_glob.glob(os.path.join(ROOT, "captures", "fault-*.pcapng")))
    if not paths:
        pytest.skip("no fault captures in captures/")
    seen = 0
    for path in paths:
        times = None
        for fast in (True, False):
            evs = []
            analyze_file(path, Settings(fast_path=fast),
                         sink=lambda e: evs.append(e) if e["kind"] == "violation" else None)
            if not evs:
                break
            times = times or {fn: t for fn, t, _l, _d in open_capture(path)}
            bad = [(e["rule"], e["frame"], e["ts_ns"] - times[e["frame"]]) for e in evs if e["ts_ns"] != times[e["frame"]]]
            assert not bad, (os.path.basename(path), fast, bad[:3])
            seen += sum(e["side"] == "controller" for e in evs)
    assert seen > 10
