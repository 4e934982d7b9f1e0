"""Timeline: what it keeps from the events, the PNG and HTML it draws, and the CLI."""
from __future__ import annotations

import glob
import os
import re
import sys

import pytest
from hypothesis import given, settings as hsettings, strategies as st

from pndiss.cli import main as cli_main
from pndiss.plot import MAX_MARKERS, Series, Timeline, render_html, render_png

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CAPTURES = sorted(glob.glob(os.path.join(ROOT, "captures", "*.pcap*"))
                  + glob.glob(os.path.join(ROOT, "..", "shared", "captures", "public", "*.pcap*")))
SMALL = [c for c in CAPTURES if os.path.getsize(c) < 2_000_000]


def preset_run(n=600, preset_at=300, position=5000):
    """A telegram-82-like stream: preset request at ``preset_at``, ack three cycles later."""
    evs = []
    for i in range(n):
        t = 1_000_000_000 + i * 1_000_000
        req = 1 if preset_at <= i < preset_at + 40 else 0
        ack = 1 if preset_at + 3 <= i < preset_at + 43 else 0
        pos = position + i if i < preset_at + 3 else i - preset_at - 3
        common = {"frame": 2 * i + 1, "ts_ns": t, "kind": "telegram", "device_mac": "00:0e:cf:00:00:01",
                  "station": "enc-1", "api": 0x3D00, "slot": 1, "subslot": 2, "telegram": 82}
        evs.append(dict(common, direction="setpoint", signals={"G1_STW": 0x0400 | req << 12},
                        bits={"G1_STW": {"bit10": 1, "bit12": req}}))
        evs.append(dict(common, frame=2 * i + 2, direction="actual",
                        signals={"G1_XIST1": pos, "NIST_A": 1, "G1_ZSW": ack << 12},
                        bits={"G1_ZSW": {"bit12": ack, "bit13": 0}}))
    return evs


def test_timeline_keeps_samples_and_transitions():
    evs = preset_run()
    tl = Timeline()
    for ev in evs:
        tl.on_event(ev)
    (enc,) = tl.encoders.values()
    actual = [e for e in evs if e["direction"] == "actual"]
    assert enc.position_name == "G1_XIST1" and enc.speed_name == "NIST_A"
    assert enc.position.v == [e["signals"]["G1_XIST1"] for e in actual]
    assert enc.position.t == [e["ts_ns"] for e in actual]
    ack = enc.lanes["enc G1_ZSW.bit12"].changes
    assert [v for _, v in ack] == [0, 1, 0]
    assert ack[1][0] == actual[303]["ts_ns"]
    shown = [n for n, _ in tl.shown_lanes(enc)]
    assert shown == ["ctrl G1_STW.bit12", "enc G1_ZSW.bit12"]  # bits that never move are left out
    assert tl.violations == [] and tl.violation_count == 0


def test_series_bounded():
    s = Series(64)
    for i in range(10_000):
        s.add(i, i * 2)
    assert len(s.t) < 64
    assert s.t[0] == 0 and all(v == 2 * t for t, v in zip(s.t, s.v))
    steps = {b - a for a, b in zip(s.t, s.t[1:])}
    assert steps == {s.stride}  # evenly thinned


def test_violation_markers_capped():
    tl = Timeline()
    for i in range(MAX_MARKERS + 50):
        tl.on_event({"frame": i, "ts_ns": i, "kind": "violation", "rule": f"R-{i}", "severity": "warning"})
    assert len(tl.violations) == MAX_MARKERS and tl.violation_count == MAX_MARKERS + 50


def test_png(tmp_path):
    pytest.importorskip("matplotlib")
    tl = Timeline()
    for ev in preset_run():
        tl.on_event(ev)
    tl.on_event({"frame": 9, "ts_ns": 1_100_000_000, "kind": "violation", "rule": "R-PRE-1", "severity": "error"})
    out = tmp_path / "t.png"
    render_png(tl, str(out), "preset")
    data = out.read_bytes()
    assert data[:8] == b"\x89PNG\r\n\x1a\n" and len(data) > 10_000


def test_html_self_contained(tmp_path):
    tl = Timeline()
    for ev in preset_run():
        tl.on_event(ev)
    tl.on_event({"frame": 9, "ts_ns": 1_100_000_000, "kind": "violation", "rule": "R-PRE-<1>", "severity": "error"})
    out = tmp_path / "t.html"
    render_html(tl, str(out), "preset & co")
    doc = out.read_text()
    assert "<svg" in doc and "R-PRE-&lt;1&gt;" in doc and "preset &amp; co" in doc
    assert not re.search(r"<script|src=|href=", doc)  # no network, no external files
    assert doc.count("<polyline") == 2 + 2  # position, speed, two moving bit lanes
    w, h = (float(v) for v in re.search(r'<svg[^>]* width="([\d.]+)" height="([\d.]+)"', doc).groups())
    pts = [tuple(map(float, p.split(","))) for pl in re.findall(r'points="([^"]*)"', doc) for p in pl.split()]
    assert pts and all(0 <= x <= w and 0 <= y <= h for x, y in pts)  # everything inside the picture


@hsettings(max_examples=200, deadline=None)
@given(st.lists(st.fixed_dictionaries(
    {"kind": st.sampled_from(["telegram", "violation", "rt"]),
     "ts_ns": st.one_of(st.integers(0, 2**62), st.none(), st.text(max_size=2))},
    optional={"signals": st.dictionaries(st.sampled_from(["G1_XIST1", "NIST_B", "x"]),
                                         st.one_of(st.integers(), st.floats(), st.text(max_size=2), st.none()), max_size=3),
              "bits": st.recursive(st.dictionaries(st.text(max_size=3), st.one_of(st.booleans(), st.integers(0, 1), st.floats())),
                                   lambda c: st.dictionaries(st.text(max_size=3), c, max_size=2), max_leaves=5),
              "direction": st.sampled_from(["setpoint", "actual", 3, None]),
              "device_mac": st.one_of(st.text(max_size=3), st.none()), "rule": st.text(max_size=4),
              "severity": st.text(max_size=6)}), max_size=15))
def test_arbitrary_events_render(tmp_path_factory, evs):
    tl = Timeline(max_points=8)
    for ev in evs:
        tl.on_event(ev)
    d = tmp_path_factory.mktemp("h")
    render_html(tl, str(d / "t.html"))
    assert (d / "t.html").stat().st_size > 0


@pytest.mark.skipif(not SMALL, reason="no captures")
def test_cli_plot(tmp_path):
    pytest.importorskip("matplotlib")
    cap = max(SMALL, key=os.path.getsize)
    assert cli_main(["plot", cap, "-o", str(tmp_path / "t.png")]) == 0
    assert (tmp_path / "t.png").read_bytes()[:4] == b"\x89PNG"
    assert cli_main(["plot", cap, "-o", str(tmp_path / "t.html")]) == 0
    assert "<svg" in (tmp_path / "t.html").read_text()
    assert cli_main(["plot", cap, "-o", str(tmp_path / "t.jpg")]) == 2


@pytest.mark.skipif(not SMALL, reason="no captures")
def test_cli_plot_without_matplotlib(tmp_path, monkeypatch, capsys):
    for name in list(sys.modules):
        if name == "matplotlib" or name.startswith("matplotlib."):
            monkeypatch.delitem(sys.modules, name)
    monkeypatch.setitem(sys.modules, "matplotlib", None)  # import fails as if not installed
    assert cli_main(["plot", SMALL[0], "-o", str(tmp_path / "t.png")]) == 2
    assert "pndiss[plot]" in capsys.readouterr().err
    assert not (tmp_path / "t.png").exists()
    assert cli_main(["plot", SMALL[0], "-o", str(tmp_path / "t.html")]) == 0  # HTML needs nothing


def test_window(tmp_path):
    tl = Timeline()
    for ev in preset_run():
        tl.on_event(ev)
    t_in, t_out = 1_000_000_000 + 305 * 1_000_000, 1_000_000_000 + 500 * 1_000_000
    tl.on_event({"frame": 1, "ts_ns": t_in, "kind": "violation", "rule": "R-IN", "severity": "error"})
    tl.on_event({"frame": 2, "ts_ns": t_out, "kind": "violation", "rule": "R-OUT", "severity": "error"})
    out = tmp_path / "w.html"
    render_html(tl, str(out), "w", window=(0.295, 0.310))  # seconds after the first sample
    doc = out.read_text()
    assert "R-IN" in doc and "R-OUT" not in doc
    pos = re.findall(r'points="([^"]*)"', doc)[0].split()
    assert len(pos) == 16  # samples 295..310 of the 1 ms run
    # the lane starts at the window with the value it had there, then the two transitions
    ack = re.findall(r'points="([^"]*)"', doc)[3].split()
    assert len(ack) == 1 + 2 * 1 + 1  # start, one step (two points), end: ack rises at 303, falls at 343


@pytest.mark.skipif(not SMALL, reason="no captures")
def test_cli_window_errors(tmp_path):
    for bad in ("1", "a:b", "2:1"):
        assert cli_main(["plot", SMALL[0], "-o", str(tmp_path / "t.html"), "--window", bad]) == 2


def test_time_axis_counts_from_the_first_frame(tmp_path):
    """The plot's seconds are the capture's (from its first frame, as --time counts), not from the first cyclic
    sample: a violation marker's time is the violation's time since the first frame (an independent audit: 4.7 ms
    apart, so a time read off the plot was not the --time value)."""
    from pndiss.analyzer import analyze_file
    cap = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "captures",
                       "fault-absval-ack-missing.pcapng")
    evs = []
    a = analyze_file(cap, sink=evs.append)
    v = [e for e in evs if e["kind"] == "violation"][0]
    first_tg = min(e["ts_ns"] for e in evs if e["kind"] == "telegram")
    assert first_tg > a.first_ts   # the Connect and the parameters come first
    out = tmp_path / "t.html"
    assert cli_main(["plot", cap, "-o", str(out), "--no-progress"]) == 0
    at = re.findall(r"<title>" + re.escape(v["rule"]) + r" \([a-z]+\) at ([0-9.]+) s</title>", out.read_text())
    assert at and abs(float(at[0]) - (v["ts_ns"] - a.first_ts) / 1e9) < 1e-6
