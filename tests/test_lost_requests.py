"""Start-up RPC frames the capture lost. A write response whose request is missing still proves the
write: the user parameter record written before PrmEnd (#66) is not reported missing, its values are
unknown and the verdict says the profile defaults were judged. Losing both frames is #66 as before."""
from __future__ import annotations

import os
import shutil

import pytest

import capedit
from pndiss.analyzer import analyze_file
from pndiss.settings import Settings
from pndiss.verdict import trust


def _frames(path):
    """(frame of the 0xBF00 write request, frame of its response)."""
    got = {}
    analyze_file(path, Settings(fast_path=False),
                 sink=lambda e: got.update({e["kind"]: e}) if e["kind"] in ("record", "record_result")
                 and e.get("index") == 0xBF00 else None)
    return got["record"]["frame"], got["record_result"]["frame"]


@pytest.fixture(scope="module")
def caps(tmp_path_factory):
    tmp = str(tmp_path_factory.mktemp("lost"))
    src = capedit.simulate(os.path.join(tmp, "full.pcapng"), "--scenario", "preset", "--cycles", "300",
                           "--records", "plain")
    req, res = _frames(src)
    out = {}
    for name, gone in (("request", {req}), ("both", {req, res})):
        out[name] = os.path.join(tmp, name + ".pcapng")
        capedit.rewrite(src, out[name], lambda fn, _d, gone=gone: fn not in gone)
    return out


def _rules(path, fast):
    evs = []
    a = analyze_file(path, Settings(fast_path=fast), sink=lambda e: evs.append(e) if e["kind"] == "violation" else None)
    return a, [e["rule"] for e in evs]


def test_response_proves_the_write(caps):
    for fast in (False, True):
        a, rules = _rules(caps["request"], fast)
        assert rules == []
        lines = trust(a.summary())
        assert any("0xBF00 was written (response in frame" in t and "lost its request" in t for t in lines), lines


def test_both_lost_is_no_write(caps):
    for fast in (False, True):
        _a, rules = _rules(caps["both"], fast)
        assert rules == ["STARTUP-NO-PARAM-RECORD"]


@pytest.mark.skipif(shutil.which("tshark") is None, reason="tshark not installed")
def test_plugin_same(caps):
    from test_lua_plugin import rule_rows
    assert rule_rows(caps["request"]) == set()
    assert {r for _f, r, _d in rule_rows(caps["both"])} == {"STARTUP-NO-PARAM-RECORD"}
