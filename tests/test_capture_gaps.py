"""Capture loss is not a protocol fault (issue #12 item 2).

Simulated sessions with sign-of-life monitoring (sol_monitor_rt) lose frames the way a mirror port does:
a setpoint here, an actual value there, both frames of a cycle, runs of either, one across the 16-bit
cycle counter wrap. The cycle counter says how many cycles each gap hides: each becomes a
``capture_gap`` event, the summary counts them, the report says so, and no sign-of-life rule fires
for them; the injected fault elsewhere in the same file is still found, exactly. The batch path, the
frame-by-frame path and the Lua plugin agree.
"""
from __future__ import annotations

import collections
import json
import os
import shutil
import subprocess
import sys
import struct

import pytest
from hypothesis import given, settings as hsettings, strategies as st

import capedit
from pndiss.analyzer import analyze_file
from pndiss.gaps import GapTracker
from pndiss.settings import Settings

ROOT = capedit.ROOT
SP, AC = 0x8001, 0x8000          # the simulator's output / input frame IDs (controller -> device, device -> controller)


def _streams(path):
    by = {fid: fns for (fid, _src), fns in capedit.cyclic_streams(path).items()}
    return by[SP], by[AC]


def _lossy(tmp, name, inject, drops):
    """A simulated session with `inject` and the cyclic frames drops = [(stream, [cycle indexes])] removed;
    returns (path, expected gaps [(frame_id, prev, next, missing)] in the new numbering, fault frame)."""
    src = capedit.simulate(os.path.join(tmp, name + "-full.pcapng"), "--cycles", "400", *inject)
    exp = json.load(open(src[:-len(".pcapng")] + ".expected.json", encoding="utf-8"))
    sp, ac = _streams(src)
    gone = set()
    for fid, idx in drops:
        gone |= {(sp if fid == SP else ac)[i] for i in idx}
    dst = os.path.join(tmp, name + ".pcapng")
    ren = capedit.rewrite(src, dst, lambda fn, _d: fn not in gone)
    want = []
    for fid, fns in ((SP, sp), (AC, ac)):
        kept = [f for f in fns if f not in gone]
        for a, b in zip(kept, kept[1:]):
            k = fns.index(b) - fns.index(a) - 1
            if k:
                want.append((fid, ren[a], ren[b], k))
    fault = exp["faults"][0]
    return dst, sorted(want), fault["rule"], ren[fault["first_frame"]]


# cycle indexes: the fault sits at cycle 150 (SOL-DEVICE-SKIP) / 200 (SOL-MASTER-SKIP, the scenario's)
DROPS = [(SP, [40]), (AC, [60]), (SP, [90]), (AC, [90]), (SP, [250, 251, 252]), (AC, [300, 301, 302, 303]),
         (SP, [320, 322]), (AC, [341, 342, 343, 344])]   # the input stream's counter wraps near cycle 343


@pytest.fixture(scope="module")
def lossy(tmp_path_factory):
    tmp = str(tmp_path_factory.mktemp("gaps"))
    return {
        "device": _lossy(tmp, "dev", ["--inject", "SOL-DEVICE-SKIP@150"], DROPS),
        "master": _lossy(tmp, "mst", ["--scenario", "sol-master-skip"], [d for d in DROPS if 200 not in d[1]]),
    }


def _analyze(path, **kw):
    evs = []
    a = analyze_file(path, Settings(sol_monitor_rt=True, fast_path=False, **kw),
                     sink=lambda e: evs.append(e) if e["kind"] in ("violation", "capture_gap") else None)
    return a, evs


@pytest.mark.parametrize("which", ("device", "master"))
def test_gaps_reported_and_only_the_real_fault(lossy, which):
    path, want, rule, frame = lossy[which]
    a, evs = _analyze(path)
    viol = [(e["rule"], e["frame"]) for e in evs if e["kind"] == "violation"]
    assert viol == [(rule, frame)]
    gaps = [e for e in evs if e["kind"] == "capture_gap"]
    assert sorted((e["frame_id"], e["prev_frame"], e["next_frame"], e["cycles_missing"]) for e in gaps) == want
    for e in gaps:
        assert e["frame"] == e["next_frame"]
        assert e["direction"] == ("output" if e["frame_id"] == SP else "input")
        assert e["src"] == ("02:00:00:00:00:01" if e["frame_id"] == SP else "02:00:00:00:01:01")
    summ = a.summary()["cyclic"]
    assert summ["capture_gaps"]["count"] == len(want)
    assert summ["capture_gaps"]["cycles_missing"] == sum(w[3] for w in want)
    enc = summ["encoders"][0]
    assert enc["lost_cycles"] > 0 and enc["violations"].keys() == {rule}


def test_without_gap_detection_the_loss_looks_like_faults(lossy):
    """The same file with capture_gaps off (what the analysis did before): the lost frames become
    sign-of-life violations, so the test above really tells loss from faults."""
    path, _want, rule, _frame = lossy["device"]
    _a, evs = _analyze(path, capture_gaps=False)
    rules = collections.Counter(e["rule"] for e in evs if e["kind"] == "violation")
    assert set(rules) - {rule}


def test_batch_path_same(lossy):
    """A gap breaks a steady run: the batch path (no sink) gives the reference path's summary."""
    for path, *_ in lossy.values():
        ref = analyze_file(path, Settings(sol_monitor_rt=True, fast_path=False)).summary()
        bat = analyze_file(path, Settings(sol_monitor_rt=True)).summary()
        ref.pop("settings"), bat.pop("settings")
        assert json.dumps(ref, sort_keys=True, default=str) == json.dumps(bat, sort_keys=True, default=str)
        off = analyze_file(path).summary()   # sign-of-life monitoring off: the batch engine runs in bulk
        assert off["cyclic"]["capture_gaps"] == ref["cyclic"]["capture_gaps"]


def test_report_and_summary_json(lossy, tmp_path):
    path, want, *_ = lossy["device"]
    out = tmp_path / "s.json"
    p = subprocess.run([sys.executable, "-m", "pndiss", "analyze", path, "--set", "sol_monitor_rt=1",
                        "--summary-json", str(out)], capture_output=True, text=True, cwd=ROOT,
                       env=dict(os.environ, PYTHONPATH=ROOT, COLUMNS="200"))
    assert p.returncode == 0, p.stderr
    assert f"Frames missing: {len(want)} gap(s), {sum(w[3] for w in want)} cycle(s)" in p.stdout
    g = json.load(open(out, encoding="utf-8"))["cyclic"]["capture_gaps"]
    assert g["count"] == len(want)
    assert {(r["frame_id"], r["prev_frame"], r["next_frame"], r["cycles_missing"]) for r in g["gaps"]} == set(want)


@pytest.mark.skipif(shutil.which("tshark") is None, reason="tshark not installed")
def test_lua_plugin_same_violations(lossy):
    from test_lua_plugin import rule_rows, settings_pref
    for path, _want, rule, frame in lossy.values():
        rows = {(fn, r) for fn, r, _d in rule_rows(path, *settings_pref({"sol_monitor_rt": True}))}
        assert rows == {(frame, rule)}


# -- the counter arithmetic on its own -------------------------------------------------------------

def _feed(g, key, counters):
    return [g.advance(key, i, i, c) for i, c in enumerate(counters)]


def test_wrap_learnt_step_and_connect_step():
    g = GapTracker()
    cc = [(65000 + 32 * i) % 65536 for i in range(40)]
    del cc[20:23]
    got = _feed(g, (1, "a", "b"), cc)
    assert got[20] == 3 and sum(got) == 3
    g.step_from((2, "a", "b"), 64)
    assert _feed(g, (2, "a", "b"), [0, 192, 256])[1:] == [2, 0]   # step from the Connect: trusted at once


def test_non_uniform_counter_never_gaps():
    g = GapTracker()
    got = _feed(g, (1, "a", "b"), [(31 * i + (i % 3)) % 65536 for i in range(200)])
    assert sum(got) == 0 and not g.summary()["streams"][0]["uniform"]


def test_repeated_counter_is_no_gap():
    g = GapTracker()
    assert sum(_feed(g, (1, "a", "b"), [32 * (i // 2) for i in range(40)])) == 0


@hsettings(max_examples=200, deadline=None)
@given(step=st.sampled_from((1, 8, 16, 32, 64, 128, 256, 1024)), start=st.integers(0, 65535),
       n=st.integers(12, 200), drops=st.lists(st.integers(8, 199), max_size=30))
def test_missing_cycles_add_up(step, start, n, drops):
    """Any frames dropped after the first eight (the step is learnt): the gaps add up to the drops."""
    keep = [i for i in range(n) if i not in set(drops)]
    cc = [(start + step * i) % 65536 for i in keep]
    g = GapTracker()
    got = _feed(g, (1, "a", "b"), cc)
    want = sum(b - a - 1 for a, b in zip(keep, keep[1:]))
    if step * (max((b - a for a, b in zip(keep, keep[1:])), default=1)) < 65536:
        assert sum(got) == want


@pytest.fixture(scope="module")
def flipped(tmp_path_factory):
    """RT: controller and device on their own clocks, so the order of setpoint and actual frames flips
    (cycles 60-119 actual first; 200-229 alternating, a jittery crossing). No frame is lost."""
    tmp = str(tmp_path_factory.mktemp("flip"))
    src = capedit.simulate(os.path.join(tmp, "full.pcapng"), "--cycles", "400", "--inject", "SOL-DEVICE-SKIP@150")
    exp = json.load(open(src[:-len(".pcapng")] + ".expected.json", encoding="utf-8"))
    sp, _ac = _streams(src)
    dst = os.path.join(tmp, "flip.pcapng")
    capedit.swap(src, dst, {sp[i] for i in range(60, 120)} | {sp[i] for i in range(200, 230, 2)})
    return dst, exp["faults"][0]


def test_order_flips_pair_each_value_with_its_setpoint(flipped):
    path, fault = flipped
    a, evs = _analyze(path)
    assert [(e["rule"], e["frame"]) for e in evs if e["kind"] == "violation"] == [(fault["rule"], fault["first_frame"])]
    assert not [e for e in evs if e["kind"] == "capture_gap"]
    enc = a.summary()["cyclic"]["encoders"][0]
    assert enc["cycles"] == 400 and enc["lost_cycles"] == 0   # every cycle judged, none lost
    bat = analyze_file(path, Settings(sol_monitor_rt=True)).summary()["cyclic"]["encoders"][0]
    assert bat["cycles"] == 400 and bat["violations"].keys() == {fault["rule"]}


@pytest.mark.skipif(shutil.which("tshark") is None, reason="tshark not installed")
def test_lua_plugin_same_on_flips(flipped):
    from test_lua_plugin import rule_rows, settings_pref
    path, fault = flipped
    rows = {(fn, r) for fn, r, _d in rule_rows(path, *settings_pref({"sol_monitor_rt": True}))}
    assert rows == {(fault["first_frame"], fault["rule"])}


def test_pause_longer_than_the_counter_wraps():
    """2.5 s without frames (the 16-bit counter wraps every 2.048 s at 31.25 us): the time stamps count."""
    g = GapTracker()
    key = (1, "a", "b")
    for i in range(10):
        assert g.advance(key, i, i * 1_000_000, (32 * i) % 65536) == 0
    i = 10 + 2500
    assert g.advance(key, 10, i * 1_000_000, (32 * i) % 65536) == 2500   # cycles 10..2509 missing


# -- a mirror port's copies: every cyclic frame captured twice, 5 us apart -------------------------

@pytest.fixture(scope="module", params=[5_000, 600_000, 1_500_000], ids=["copy-5us", "copy-600us", "copy-1.5ms"])
def doubled(tmp_path_factory, request):
    """A preset session with a fault (so handshake deadlines matter), each frame followed by its copy, 5 us
    later or -- a mirror port's queue -- 0.6 of the 1 ms cycle later (behind the next frames of other streams)
    or 1.5 cycles later (behind its own stream's next frame: its counter is older then).
    Returns (path, the original's violations [(rule, frame)] renumbered, number of cyclic copies)."""
    from pndiss.capture import open_capture
    from pndiss.sim.pcapng import Writer
    tmp = str(tmp_path_factory.mktemp("dup"))
    src = capedit.simulate(os.path.join(tmp, "full.pcapng"), "--scenario", "preset", "--cycles", "300",
                           "--inject", "PRESET-ACK-MISSING")
    cyc = {f for fns in capedit.cyclic_streams(src).values() for f in fns}
    rows = []
    for fn, ts, _lt, d in open_capture(src):
        # every frame: DCP, LLDP, RPC (a retransmission to DCE/RPC) and cyclic
        rows += [(ts, 0, fn, bytes(d)), (ts + request.param, 1, None, bytes(d))]
    rows.sort(key=lambda r: (r[0], r[1]))
    ren = {}
    n = len(cyc)
    dst = os.path.join(tmp, f"doubled-{request.param}.pcapng".replace("1500000", "1.5ms"))
    with open(dst, "wb") as f:
        w = Writer(f)
        for ts, _o, fn, d in rows:
            got = w.write(ts, d)
            if fn is not None:
                ren[fn] = got
    evs = []
    analyze_file(src, Settings(fast_path=False), sink=lambda e: evs.append(e) if e["kind"] == "violation" else None)
    want = [(e["rule"], ren[e["frame"]]) for e in evs]
    assert want and "PRESET-ACK-MISSING" in {r for r, _f in want}
    return dst, want, n


def test_copies_of_frames_are_no_cycles(doubled):
    """Without this the copies halved every deadline (10-11 false errors in the audit's capture)."""
    path, want, n = doubled
    evs = []
    a = analyze_file(path, Settings(fast_path=False), sink=lambda e: evs.append(e) if e["kind"] == "violation" else None)
    assert [(e["rule"], e["frame"]) for e in evs] == want
    s = a.summary()
    g = s["cyclic"]["capture_gaps"]
    # a copy behind its stream's next frame carries an older counter: stale, not a copy (the last frames of a
    # stream before a pause have no next frame before their copy: copies)
    late = "1.5ms" in path
    assert g["duplicates"] + g["stale"] == n and g["count"] == 0
    assert (g["stale"] > 0.99 * n) if late else (g["stale"] == 0)
    ref, fast = analyze_file(path, Settings(fast_path=False)).summary(), analyze_file(path).summary()
    ref.pop("settings"), fast.pop("settings")
    assert json.dumps(ref, sort_keys=True, default=str) == json.dumps(fast, sort_keys=True, default=str)


def test_copies_of_rpc_responses_run_once(doubled):
    """A copy of a read response gave its record and parameter events twice; a copy of a write response
    looked like a write whose request the capture lost."""
    path = doubled[0]
    kinds = ("record", "record_result", "param", "ar", "ar_phase")

    def count(p):
        c = collections.Counter()
        analyze_file(p, Settings(fast_path=False), sink=lambda e: c.update([e["kind"]]) if e["kind"] in kinds else None)
        return c
    orig = count(os.path.join(os.path.dirname(path), "full.pcapng"))
    assert orig["param"] and orig["record_result"]
    assert count(path) == orig


def test_a_frame_whose_counter_is_not_newer_is_discarded():
    """The consumer's cycle-counter check (PROFINET IO 2.4 §4.7.2.1.2: newer when (now - last) mod 2^16 is in
    1..61440): a frame repeating the counter, however late, or carrying an up to 4,095 units older one is no
    cycle -- a copy when it repeats the previous frame, else stale."""
    g = GapTracker()
    key, last = (1, "a", "b"), (0x35, b"\x00" * 40)
    g.step_from(key, 32)
    g.advance(key, 1, 0, 100, last)
    assert g.duplicate(key, 2, 5_000, 100, last)                                  # a copy, 5 us later
    assert g.duplicate(key, 3, 900_000, 100, last)                                # 0.9 of a cycle later
    assert not g.duplicate(key, 4, 5_000, 132, last)                              # the next counter
    assert not g.duplicate(key, 5, 5_000, 100 + 61440, last)                      # newest still newer
    assert g.duplicate(key, 6, 5_000, 100 + 61441, last)                          # 4,095 units older
    assert g.duplicate(key, 7, 5_000, 68, last)                                   # the frame before: stale
    assert g.duplicate(key, 8, 5_000, 100, (0x35, b"\x01" + b"\x00" * 39))      # same counter, other data
    assert not g.duplicate(key, 9, 1_100_000_000, 100, last)   # more than half a wrap (1.024 s) later: it wrapped
    s = g.summary()
    assert (s["duplicates"], s["first_duplicate"], s["stale"], s["first_stale"]) == (2, [2, 1], 3, [6, 1])


@pytest.mark.skipif(shutil.which("tshark") is None, reason="tshark not installed")
def test_lua_plugin_same_on_copies(doubled):
    from test_lua_plugin import rule_rows
    path, want, _n = doubled
    assert sorted((fn, r) for fn, r, _d in rule_rows(path)) == sorted((f, r) for r, f in want)


# -- a merge out of time order: each interface's frames written as one block ----------------------

def test_frames_out_of_time_order_are_reported(tmp_path):
    """Frames of two taps merged without sorting (all controller frames, then all device frames):
    every setpoint pairs with the wrong actual value, so the Trust section says so (both paths count
    the same), and tiny steps back (two interfaces' clocks) are counted but not worth a line."""
    from pndiss.capture import open_capture
    from pndiss.sim.pcapng import Writer
    from pndiss.verdict import trust
    src = capedit.simulate(str(tmp_path / "s.pcapng"), "--scenario", "preset", "--cycles", "300")
    frames = [(ts, bytes(d)) for _fn, ts, _lt, d in open_capture(src)]
    ctrl = next(d[6:12] for _ts, d in frames if d[12:14] == b"\x88\x92" and d[14:16] == b"\xfe\xfe")
    unsorted = [f for f in frames if f[1][6:12] == ctrl] + [f for f in frames if f[1][6:12] != ctrl]
    nudged = list(frames)
    nudged[100], nudged[101] = (nudged[101][0] + 2000, nudged[100][1]), (nudged[101][0], nudged[101][1])
    out = {}
    for name, fr in (("unsorted", unsorted), ("nudged", nudged), ("sorted", frames)):
        path = str(tmp_path / f"{name}.pcapng")
        with open(path, "wb") as f:
            w = Writer(f)
            for ts, d in fr:
                w.write(ts, d)
        got = [analyze_file(path, Settings(fast_path=fp)).summary() for fp in (True, False)]
        assert got[0]["input"] == got[1]["input"]
        out[name] = (got[0]["input"], trust(got[0]))
    inp, lines = out["unsorted"]
    assert inp["timestamps_backwards"] == 1 and inp["timestamps_backwards_max_ns"] > 100_000_000
    assert any("frames out of time order" in t and "reordercap" in t for t in lines)
    inp, lines = out["nudged"]
    assert inp["timestamps_backwards"] == 1 and inp["timestamps_backwards_max_ns"] < 1_000_000
    assert not any("out of time order" in t for t in lines)
    assert out["sorted"][0]["timestamps_backwards"] == 0


# -- a capture taken with a short snap length (tcpdump -s 96) -------------------------------------------------

def _write_cut(src: str, dst: str, snap: int, pcapng_out: bool) -> int:
    """src's frames with only their first ``snap`` bytes kept (the wire length recorded); returns how many."""
    from pndiss.capture import open_capture
    frames = [(ts, bytes(d)) for _fn, ts, _lt, d in open_capture(src)]
    n = 0
    with open(dst, "wb") as f:
        if pcapng_out:
            f.write(struct.pack("<IIIHHq", 0x0A0D0D0A, 28, 0x1A2B3C4D, 1, 0, -1) + struct.pack("<I", 28))
            f.write(struct.pack("<IIHHI", 1, 20, 1, 0, snap) + struct.pack("<I", 20))
        else:
            f.write(struct.pack("<IHHiIII", 0xA1B23C4D, 2, 4, 0, 0, snap, 1))
        for ts, d in frames:
            keep = d[:snap]
            n += len(keep) < len(d)
            if pcapng_out:
                pad = (-len(keep)) % 4
                blen = 32 + len(keep) + pad
                ts_us = ts // 1000
                f.write(struct.pack("<IIIIIII", 6, blen, 0, ts_us >> 32, ts_us & 0xFFFFFFFF, len(keep), len(d))
                        + keep + b"\0" * pad + struct.pack("<I", blen))
            else:
                f.write(struct.pack("<IIII", ts // 1_000_000_000, ts % 1_000_000_000, len(keep), len(d)) + keep)
    return n


@pytest.mark.parametrize("pcapng_out", (False, True), ids=("pcap", "pcapng"))
def test_frames_cut_by_the_snap_length(tmp_path, pcapng_out):
    """Frames cut by the snap length were malformed with a reason that blamed the frame ("total length
    exceeds the captured bytes"). Now the reader counts them (summary.input.frames_cut, a Trust line), each
    malformed reason says the capture cut it, and the engine leaves them to the reader: the same on both paths,
    and the same count as tshark's frames with frame.cap_len < frame.len."""
    from test_fastpath import _same_both_ways
    from pndiss.verdict import trust
    src = capedit.simulate(str(tmp_path / "full.pcapng"), "--scenario", "preset", "--cycles", "600")
    path = str(tmp_path / ("cut.pcapng" if pcapng_out else "cut.pcap"))
    n = _write_cut(src, path, 96, pcapng_out)
    assert n > 5
    _same_both_ways(path)
    a = analyze_file(path, Settings())
    s = a.summary()
    assert s["input"]["frames_cut"] == n and s["input"]["frames_cut_to_bytes"] == 96
    assert a.malformed and all("the capture cut the frame" in m["reason"] for m in a.malformed)
    assert any("cut by the capture's snap length" in line for line in trust(s))
    if shutil.which("tshark"):
        out = subprocess.run(["tshark", "-n", "-r", path, "-Y", "frame.cap_len < frame.len", "-T", "fields",
                              "-e", "frame.number"], capture_output=True, text=True).stdout.split()
        assert len(out) == n


def test_a_loss_of_whole_counter_wraps_is_seen_by_the_time_stamps():
    """2.048 s lost at 1 ms (65,536 counter units): the counter advances exactly one step, but no provider pauses
    that long (its consumer's watchdog would end the AR): the time stamps tell 2,048 lost cycles (found by an
    independent audit: the loss was judged as one cycle, giving false SKIP / DISCONTINUITY violations)."""
    g = GapTracker()
    key = (1, "a", "b")
    g.step_from(key, 32)
    ts = [i * 1_000_000 for i in range(10)] + [(9 + 2049) * 1_000_000]
    got = [g.advance(key, i, t, (32 * i if i < 10 else 32 * 10) % 65536) for i, t in enumerate(ts)]
    assert got[-1] == 2048 and sum(got) == 2048


def test_whole_wraps_lost_engine_same(tmp_path):
    """The same in a simulated session (every stream loses 2,048 cycles): the engine marks the row for the
    frame loop (streamcols.gaps_bad) and both paths report the gap, and no violation."""
    from test_fastpath import _same_both_ways
    from pndiss.capture import open_capture
    src = capedit.simulate(str(tmp_path / "s.pcapng"), "--scenario", "motion", "--cycles", "4000")
    frames = [(fn, ts) for fn, ts, _lt, _d in open_capture(src)]
    start = frames[0][1]
    lo, hi = start + 1_500_000_000, start + 1_500_000_000 + 2_048_000_000
    drop = {fn for fn, ts in frames if lo <= ts < hi}
    dst = str(tmp_path / "gap.pcapng")
    capedit.rewrite(src, dst, lambda fn, _d: fn not in drop)
    _same_both_ways(dst)
    a, evs = _analyze(dst)
    gaps = [e for e in evs if e["kind"] == "capture_gap"]
    assert gaps and all(abs(e["cycles_missing"] - 2048) <= 1 for e in gaps), [e["cycles_missing"] for e in gaps]
    assert not [e for e in evs if e["kind"] == "violation"]


def test_a_counter_that_contradicts_its_connect_is_not_trusted_again_at_every_map_change():
    """A provider whose cycle counter does not step by SendClockFactor x ReductionRatio (free-running): once its
    advances contradicted the Connect's step, a lookup of the maps again (any P922 read, any other Connect) does
    not make that step trusted again -- that gave capture gaps where an advance happened to be a multiple of it.
    A new AR on the stream (restart) takes its own Connect's step: a project downloaded with another cycle time."""
    from pndiss.gaps import GapTracker
    g, key = GapTracker(), (0x8000, "02:00:00:00:01:01", "02:00:00:00:00:01")
    g.step_from(key, 32)
    cc, fn = 0, 0
    for d in (32, 48, 40, 56, 48):   # off the step: irregular
        cc, fn = (cc + d) % 65536, fn + 1
        g.advance(key, fn, fn * 1_000_000, cc)
    g.step_from(key, 32)             # the maps looked up again
    cc, fn = (cc + 96) % 65536, fn + 1
    assert g.advance(key, fn, fn * 1_000_000, cc) == 0 and g.count == 0
    g.restart(key)                   # the AR ended; the next one connects at 2 ms
    g.step_from(key, 64)
    for d in (64, 64, 128):
        cc, fn = (cc + d) % 65536, fn + 1
        got = g.advance(key, fn, fn * 2_000_000, cc)
    assert got == 1 and g.count == 1


@pytest.mark.parametrize("jump_ns, cycles_lost, whole_capture, want_lost, step_said", [
    (1_500_000_000, 0, True, 0, True),          # the clock set 1.5 s ahead, nothing lost: no 1,500 "lost" cycles
    (20_000_000_000, 0, True, 0, True),         # 20 s ahead
    (3_600_000_000_000, 0, True, 0, True),      # an hour ahead: some count fits the counter within drift, but one step
    (0, 2500, True, 2500, False),               # the whole capture lost 2.5 s (a ring-buffer file missing): counted
    (0, 4096, True, 4096, False),               # ... exactly two wraps, each counter one step on, the times agree: lost
    (1_500_000_000, 3, True, 3, True),          # the clock stepped and three frames were lost with it: the counter's 3
    (0, 2048, False, 2048, False),              # a real loss of exactly one wrap (the counter one step on): counted
    (0, 2500, False, 2500, False),              # a real loss of 2.5 s: counted
    (10_000_000, 2500, False, 2500, False),     # ... its time stamp 10 ms late (a TAP's batch): still 2,500
    (1_500_000_000, 0, False, 1500, False),     # the stream alone paused, its counter restarted (a device reboot)
    (1_000_000_000, 0, True, 0, True),          # 1 s ahead, under half a wrap: named too (an independent audit)
    (600_000_000, 3, True, 3, True),            # 0.6 s ahead and three frames lost with it: the counter's 3, named
    (0, 700, True, 700, False),                 # the whole capture lost 0.7 s: the counter agrees, counted, no step
    (1_000_000_000, 0, False, 0, False),        # one stream's frames 1 s apart, the others going on: not the clock
])
def test_a_clock_step_is_no_loss(jump_ns, cycles_lost, whole_capture, want_lost, step_said):
    """A pause of half a counter wrap or more is counted from the time stamps where the counter agrees (k + 1 steps
    equal its advance modulo a wrap, within drift and 20 ms of time-stamp error); where it contradicts them and the
    whole capture's time jumped there (no frame of any stream), the capture PC's clock stepped (NTP): reported as
    such, no cycles lost (an independent audit: 12,000 and 28.8 million "cycles lost, seen in the cycle counter").
    A stream that alone went quiet with its counter restarting is a device, not the clock (the review of
    2026-11-25)."""
    from pndiss.gaps import with_counter
    g = GapTracker()
    key = (1, "a", "b")
    g.step_from(key, 32)
    for i in range(10):
        assert g.advance(key, i, i * 1_000_000, (32 * i) % 65536) == 0
    j = 10 + cycles_lost
    t = j * 1_000_000 + jump_ns
    if whole_capture:
        from types import SimpleNamespace
        g.reader_of = lambda: SimpleNamespace(jumps=[(9 * 1_000_000 + 200_000, t - 300_000)], last_drop_ts=None)
    cc = (32 * j) % 65536 if jump_ns != 1_500_000_000 or whole_capture else 12345
    assert g.advance(key, 10, t, cc) == want_lost
    assert bool(g.summary()["clock_steps"]) == step_said
    assert with_counter(1500, 32, 32) is None and with_counter(2048, 32, 32) == 2048 and with_counter(2050, 32, 32) == 2048


def test_a_sender_gone_silent_is_reported(tmp_path):
    """An encoder that loses power mid-capture: its input frames stop, no Release or abort follows in the capture.
    The summary lists the silent stream and the Trust section says so -- before, nothing did (an independent audit);
    the cycle counter cannot show it, as no later frame of the stream comes."""
    from pndiss.capture import open_capture
    from pndiss.verdict import trust
    src = capedit.simulate(str(tmp_path / "s.pcapng"), "--scenario", "startup", "--cycles", "1500")
    frames = [(ts, bytes(d)) for _fn, ts, _lt, d in open_capture(src)]
    dev = bytes.fromhex("020000000101")   # the simulator's encoder (sim/stations.py mac(1, 1))
    def rt(d):   # cyclic RT_CLASS_1, with or without its priority tag
        o = 16 if d[12:14] == b"\x81\x00" else 12
        return d[o:o + 2] == b"\x88\x92" and 0x80 <= d[o + 2] < 0xC0
    cyc_ts = [ts for ts, d in frames if rt(d)]
    cut = cyc_ts[len(cyc_ts) // 2]
    # every frame of the device stops half-way; the capture ends before the controller's Release
    kept = [(ts, d) for ts, d in frames if not (d[6:12] == dev and ts > cut) and ts <= cyc_ts[-1]]
    path = capedit.write(str(tmp_path / "silent.pcapng"), kept)
    s = analyze_file(path).summary()
    silent = s["cyclic"]["silent_streams"]
    assert [q["direction"] for q in silent] == ["input"] and silent[0]["src"] == dev.hex(":")
    assert any("stopped at frame" in t and "went silent" in t for t in trust(s))
    full = analyze_file(src).summary()
    assert not full["cyclic"]["silent_streams"]


def test_open_preset_of_an_ended_ar_says_so():
    """A preset still open when its AR was aborted (the encoder lost power): 'not acknowledged when its AR was
    aborted (frame N)', not 'when the capture ended' (an independent audit)."""
    from pndiss.verdict import not_checked
    enc = {"station": "enc", "slot": 1, "subslot": 2, "preset_open_at_end": 6660, "settings": {}}
    s = {"cyclic": {"encoders": [dict(enc, ar_ended={"phase": "aborted", "frame": 6682})]}}
    assert any("when its AR was aborted (frame 6682)" in x for x in not_checked(s))
    s = {"cyclic": {"encoders": [enc]}}
    assert any("when the capture ended" in x for x in not_checked(s))


def test_cycles_the_controller_never_sent_are_not_lost(tmp_path):
    """The PLC loses power mid-capture: its output frames stop, the encoder sends on. The cycles after the last
    setpoint were never sent -- not judged (gated), not 'lost' (an independent audit: counted as lost cycles);
    the same loss with the setpoint stream going on afterwards stays lost. Engine and reference agree."""
    from pndiss.capture import open_capture
    from test_fastpath import _same_both_ways
    src = capedit.simulate(str(tmp_path / "s.pcapng"), "--scenario", "startup", "--cycles", "1500")
    frames = [(ts, bytes(d)) for _fn, ts, _lt, d in open_capture(src)]
    def out(d):   # a cyclic frame of the controller's output CR
        o = 16 if d[12:14] == b"\x81\x00" else 12
        return d[o:o + 2] == b"\x88\x92" and int.from_bytes(d[o + 2:o + 4], "big") == SP
    sp_ts = [ts for ts, d in frames if out(d)]
    cut, hold = sp_ts[len(sp_ts) // 2], sp_ts[len(sp_ts) // 2 + 20]

    def write(name, keep):
        return capedit.write(str(tmp_path / name), [(ts, d) for ts, d in frames if keep(ts, d)])
    # the controller stops; the capture ends 20 cycles later (the device's DataHold)
    stopped = write("stopped.pcapng", lambda ts, d: ts <= hold and not (out(d) and ts > cut))
    base = analyze_file(src).summary()["cyclic"]["encoders"][0]
    enc = analyze_file(stopped).summary()["cyclic"]["encoders"][0]
    assert enc["lost_cycles"] == 0 and enc["gated_cycles"] >= base["gated_cycles"] + 15
    # the same setpoints missing, but the controller's stream goes on after them: the capture lost them
    lossy = write("lossy.pcapng", lambda ts, d: ts <= hold + 100_000_000 and not (out(d) and cut < ts <= hold))
    enc = analyze_file(lossy).summary()["cyclic"]["encoders"][0]
    assert enc["lost_cycles"] >= 15
    _same_both_ways(stopped)
    _same_both_ways(lossy)


def test_a_taps_trailer_on_cyclic_frames_is_said(tmp_path):
    """A TAP that appends 6 bytes to every frame: the cycle counter and status are read at the frame's end (as
    Wireshark does), so the stream's gaps and judged cycles are the trailer's. The summary names the streams whose
    frames are longer than their IOCR's C_SDU + APDU status and Trust says why nothing there means much (an
    independent audit: 24,576 "lost" cycles, "no violations", no word why); the untouched capture says nothing."""
    from pndiss.capture import open_capture
    from pndiss.verdict import trust
    from test_fastpath import _same_both_ways
    src = capedit.simulate(str(tmp_path / "s.pcapng"), "--cycles", "300", "--io-devices", "1")
    path = capedit.write(str(tmp_path / "trailer.pcapng"),
                         [(ts, bytes(d) + bytes.fromhex("3f3e3d3c3b3a")) for _fn, ts, _lt, d in open_capture(src)])
    s = analyze_file(path).summary()
    tr = s["cyclic"]["longer_than_iocr"]
    # (the encoder's input frames at standstill all look like copies of the first, read at the trailer: the check
    # runs where a frame's data objects are decoded, so the setpoint stream names it)
    assert tr and {q["extra_bytes"] for q in tr} == {6} and SP in {q["frame_id"] for q in tr}
    # the IO device's streams too, and none of them "went silent" (their frames looked like copies of the first)
    assert {q["frame_id"] for q in tr} >= {0x8100, 0x8101} and not s["cyclic"]["silent_streams"]
    assert any(t.startswith("trailer:") and "editcap -C" in t for t in trust(s))
    clean = analyze_file(src).summary()
    assert clean["cyclic"]["longer_than_iocr"] == [] and not any(t.startswith("trailer:") for t in trust(clean))
    # the analysis reads counter and status where the Connect puts them: judged as the capture without the trailer
    # (an independent audit: a kept FCS or a 4-byte trailer left nothing judged and said "no violations")
    assert s["cyclic"]["capture_gaps"]["count"] == 0 and not s["cyclic"]["capture_gaps"].get("stale")
    assert [(e["cycles"], e["gated_cycles"]) for e in s["cyclic"]["encoders"]] == \
        [(e["cycles"], e["gated_cycles"]) for e in clean["cyclic"]["encoders"]]
    # a stack that pads its C_SDU beyond 40 bytes keeps the status at the frame's end: no trailer, read there

    def rt(d):
        o = 16 if d[12:14] == b"\x81\x00" else 12
        return d[o:o + 2] == b"\x88\x92" and 0x80 <= d[o + 2] < 0xC0
    padded = capedit.write(str(tmp_path / "padded.pcapng"), [(ts, bytes(d)[:-4] + bytes(4) + bytes(d)[-4:] if rt(d)
                                                               else bytes(d)) for _fn, ts, _lt, d in open_capture(src)])
    p = analyze_file(padded).summary()
    assert p["cyclic"]["longer_than_iocr"] == [] and p["cyclic"]["capture_gaps"]["count"] == 0
    assert [(e["cycles"], e["gated_cycles"]) for e in p["cyclic"]["encoders"]] == \
        [(e["cycles"], e["gated_cycles"]) for e in clean["cyclic"]["encoders"]]
    _same_both_ways(path)


def test_responses_stamped_before_their_requests_are_said(tmp_path):
    """Two NICs (or a TAP's two ports) whose clocks differ by 3 ms: the device's frames are stamped 3 ms early,
    the file sorted by stamp, and every DCE/RPC response of the device precedes its request. That cannot be: the
    summary counts them (session.counts.responses_before_request, with the largest lead) and Trust says the
    interfaces' clocks differ (an independent audit: accepted silently, violations against both sides). The
    capture as made says nothing."""
    from pndiss.capture import open_capture
    from pndiss.verdict import trust
    src = capedit.simulate(str(tmp_path / "s.pcapng"), "--cycles", "600")
    dev = bytes.fromhex("020000000101")
    frames = sorted(((ts - 3_000_000 if d[6:12] == dev else ts), bytes(d)) for _fn, ts, _lt, d in open_capture(src))
    path = capedit.write(str(tmp_path / "skew.pcapng"), frames)
    s = analyze_file(path).summary()
    c = s["session"]["counts"]
    assert c["responses_before_request"] >= 2 and 0 < c["responses_before_request_max_ns"] <= 3_000_000
    assert any(t.startswith("responses before their requests:") for t in trust(s))
    clean = analyze_file(src).summary()
    assert clean["session"]["counts"]["responses_before_request"] == 0


def test_an_undeclared_fcs_of_a_mid_session_capture_is_said(tmp_path):
    """A capture that starts mid-session (no Connect: the streams are known only from their content) and keeps
    every frame's Ethernet FCS without declaring it: Wireshark and the content inference read the FCS as cycle counter
    and status. The summary names the streams whose frames end in their own valid FCS and Trust says to cut it; the
    same capture without the FCS says nothing (a 4-byte trailer that is no CRC is no FCS either)."""
    import zlib
    from pndiss.capture import open_capture
    from pndiss.verdict import trust
    src = capedit.simulate(str(tmp_path / "s.pcapng"), "--cycles", "600", "--start-mid-session", "200")
    frames = [(ts, bytes(d)) for _fn, ts, _lt, d in open_capture(src)]
    fcs = capedit.write(str(tmp_path / "fcs.pcapng"), [(ts, d + zlib.crc32(d).to_bytes(4, "little")) for ts, d in frames])
    s = analyze_file(fcs).summary()
    fk = s["cyclic"]["fcs_undeclared"]
    assert fk and {q["frame_id"] for q in fk} >= {SP}
    assert any(t.startswith("FCS kept:") and "editcap -C -4" in t for t in trust(s))
    assert not analyze_file(src).summary()["cyclic"]["fcs_undeclared"]
    junk = capedit.write(str(tmp_path / "junk.pcapng"), [(ts, d + b"\x01\x02\x03\x04") for ts, d in frames])
    assert not analyze_file(junk).summary()["cyclic"]["fcs_undeclared"]


def test_an_outage_with_an_irregular_counter_is_no_clock_step():
    """0.7 s of the whole capture lost, and a stream whose counter moved by no whole number of its steps across it
    (it does not follow the time): no clock step named beside the capture gap (a review: two contradictory Trust
    lines); the same jump with the counter one step on is the clock."""
    from types import SimpleNamespace
    for cc_after, step_said in ((17072, False), (32 * 11, True)):
        g = GapTracker()
        key = (1, "a", "b")
        g.step_from(key, 32)
        for i in range(10):
            g.advance(key, i, i * 1_000_000, (32 * i) % 65536)
        t = 9 * 1_000_000 + 700_000_000
        g.reader_of = lambda: SimpleNamespace(jumps=[(9 * 1_000_000, t)], last_drop_ts=None)
        g.advance(key, 10, t, (32 * 9 + cc_after) % 65536 if not step_said else (32 * 10) % 65536)
        assert bool(g.summary()["clock_steps"]) == step_said


def test_a_trailer_decided_late_is_read_the_same_by_the_engine(tmp_path):
    """A 4-byte trailer on every frame, and the encoder's first 900 input frames with DataValid 0 (a device starting
    up), the trailer counting like a cycle counter: no valid status at either place, so the stream's trailer is
    decided only at its first valid frame. The engine reads the same counters and judges the same cycles as the
    reference path (it sends a stream not decided yet one by one: engine.Window._categories)."""
    from pndiss.capture import open_capture
    from test_fastpath import _same_both_ways
    src = capedit.simulate(str(tmp_path / "s.pcapng"), "--cycles", "1500", "--inject", "RESERVED-BIT-SET-G1ZSW@1200")
    out, seen = [], 0
    for _fn, ts, _lt, d in open_capture(src):
        d = bytearray(d)
        o = 16 if d[12:14] == b"\x81\x00" else 12
        if d[o:o + 2] == b"\x88\x92" and (d[o + 2] << 8 | d[o + 3]) == AC and seen < 900:
            seen += 1
            d[-2] &= ~0x04   # DataValid 0 (the real status: no trailer yet)
        out.append((ts, bytes(d) + bytes(d[-4:-2]) + b"\x00\x3c"))   # a trailer that counts like a cycle counter
    path = capedit.write(str(tmp_path / "late.pcapng"), out)
    _same_both_ways(path)
    s = analyze_file(path).summary()
    assert AC in {q["frame_id"] for q in s["cyclic"]["longer_than_iocr"]}
    assert not s["cyclic"]["capture_gaps"]["count"]


def test_a_streams_step_in_the_summary_is_its_gaps_after_its_ar_ended():
    """A stream whose AR ended (Release: the counter starts afresh with the next AR) still shows in the summary the
    step its gaps were counted in, from the Connect -- not 0 / learnt (an independent audit)."""
    g = GapTracker()
    key = (0x8001, "a", "b")
    g.step_from(key, 32)
    cc = 0
    for i, d in enumerate([32] * 5 + [96] + [32] * 3):
        cc = (cc + d) % 65536
        g.advance(key, i, i * 1_000_000, cc)
    g.restart(key)
    row = g.summary()["streams"][0]
    assert (row["gaps"], row["cycles_missing"], row["step"], row["step_source"]) == (1, 2, 32, "connect")
