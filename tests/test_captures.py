"""The curated captures in captures/: rebuilt byte for byte by captures/regenerate, accepted by
tshark 4.0, and analysed by ``pndiss analyze`` into exactly the injected faults (none in clean ones)."""
from __future__ import annotations

import collections
import glob
import json
import os
import shutil
import subprocess

import pytest

from pndiss.analyzer import analyze_file
from pndiss.settings import Settings
from pndiss.sim.curated import build_all, catalogue

HERE = os.path.dirname(os.path.abspath(__file__))
CAPS = os.path.join(HERE, "..", "captures")
STEMS = sorted(catalogue())


def test_every_catalogue_capture_is_checked_in():
    have = {os.path.basename(p)[:-7] for p in glob.glob(os.path.join(CAPS, "*.pcapng"))}
    assert set(STEMS) <= have
    for stem in STEMS:
        assert os.path.getsize(os.path.join(CAPS, stem + ".pcapng")) <= 1 << 20
        assert os.path.exists(os.path.join(CAPS, stem + ".expected.json"))


def test_regenerate_gives_identical_files(tmp_path):
    build_all(str(tmp_path))
    for stem in STEMS:
        for ext in (".pcapng", ".expected.json"):
            with open(os.path.join(CAPS, stem + ext), "rb") as a, open(tmp_path / (stem + ext), "rb") as b:
                assert a.read() == b.read(), f"{stem}{ext} differs from what captures/regenerate makes"


@pytest.mark.skipif(shutil.which("tshark") is None, reason="tshark not installed")
@pytest.mark.parametrize("stem", STEMS)
def test_tshark_no_malformed_no_expert_error(stem):
    r = subprocess.run(["tshark", "-n", "-r", os.path.join(CAPS, stem + ".pcapng"), "-Y",
                        "_ws.malformed || _ws.expert.severity >= 8388608"], capture_output=True, text=True)
    assert r.returncode == 0 and r.stdout == ""


@pytest.mark.parametrize("stem", STEMS)
def test_analyze_finds_exactly_the_injected_faults(stem):
    exp = json.load(open(os.path.join(CAPS, stem + ".expected.json"), encoding="utf-8"))
    s = Settings()
    for f in exp["faults"]:
        for k, v in f.get("settings", {}).items():
            setattr(s, k, v)
    evs = []
    analyze_file(os.path.join(CAPS, stem + ".pcapng"), s,
                 sink=lambda e: evs.append(e) if e["kind"] in ("violation", "malformed", "capture_gap") else None)
    # the capture loss the simulator made is what the analyzer reports from the cycle counters
    gap_keys = ("frame_id", "src", "prev_frame", "next_frame", "cycles_missing")
    got_gaps = sorted(tuple(e[k] for k in gap_keys) for e in evs if e["kind"] == "capture_gap")
    assert got_gaps == sorted(tuple(g[k] for k in gap_keys) for g in exp.get("capture_gaps", []))
    assert not [e for e in evs if e["kind"] == "malformed"]
    got = collections.Counter(e["rule"] for e in evs if e["kind"] == "violation")
    want = {f["rule"] for f in exp["faults"]}
    allowed = want | {r for f in exp["faults"] for r in f.get("also_possible", [])}
    assert want <= set(got), f"missing {sorted(want - set(got))}"
    assert set(got) <= allowed, f"unexpected {sorted(set(got) - allowed)}"
    # stations and AR map as simulated
    a = analyze_file(os.path.join(CAPS, stem + ".pcapng"), s)
    names = {x.get("name") for x in a.stations.as_list()}
    if "mid_session" not in exp.get("needs", []):   # no DCP in a mid-session capture: no names (test_mid_session)
        assert {st["name"] for st in exp["stations"]} <= names
