"""A PS/PSM encoder the capture does not identify (no DCP, no I&M0; its manual gives no vendor ID) is
recognised by the write of its parameter record 0xFFFF (records.md §1: only PS/PSM keeps its encoder
parameters there). Judged as a generic V4.1 encoder it would get three false errors: no 0xBF00 before
PrmEnd, ZSW2 bit 10 'reserved', and 'control requested' on bit 9 instead of PS/PSM's bit 10."""
from __future__ import annotations

import os
import shutil

import pytest

import capedit
from pndiss.analyzer import analyze_file
from pndiss.settings import Settings


def _no_dcp(fn, d):
    off = 18 if d[12:14] == b"\x81\x00" else 14
    return not (d[off - 2:off] == b"\x88\x92" and 0xFEFC <= (d[off] << 8 | d[off + 1]) <= 0xFEFF)


@pytest.fixture(scope="module")
def caps(tmp_path_factory):
    tmp = str(tmp_path_factory.mktemp("psm"))
    out = {}
    # plain start-up (0xFFFF before the first cyclic frame is judged); GOOD data from the first frame
    # with the record written a few cycles later (the axis exists already and changes profile)
    for name, extra in (("startup", []), ("late-write", ["--good-before-prmend"])):
        src = capedit.simulate(os.path.join(tmp, name + "-full.pcapng"), "--profile", "psm", "--telegram", "81",
                               "--scenario", "preset", "--cycles", "400", "--records", "plain", *extra)
        dst = os.path.join(tmp, name + ".pcapng")
        capedit.rewrite(src, dst, _no_dcp)
        out[name] = dst
    return out


def _run(path, **kw):
    evs = []
    a = analyze_file(path, Settings(**kw), sink=lambda e: evs.append(e) if e["kind"] == "violation" else None)
    return a, evs


@pytest.mark.parametrize("name", ("startup", "late-write"))
def test_ffff_write_names_psm(caps, name):
    for fast in (False, True):
        a, evs = _run(caps[name], fast_path=fast)
        assert [(e["rule"], e["frame"]) for e in evs] == [], (fast, evs)
        axes = a.summary()["cyclic"]["encoders"]
        assert [x["profile"] for x in axes] == ["psm"]
        assert "record 0xFFFF written in frame" in axes[0]["profile_reason"]


def test_forced_generic_keeps_the_false_errors(caps):
    """The negative: the user's --profile wins over the evidence, and generic rules then fire."""
    _a, evs = _run(caps["startup"], fast_path=False, profile="generic")
    # (CTRLREQ-MISMATCH no longer: without 0xBF00 the mode is learnt, and "control requested" read at the
    # generic bit 9 held 0 under control by PLC reads as V3.1 -- tests/test_compat_learning.py)
    assert {"STARTUP-NO-PARAM-RECORD", "RESERVED-BIT-SET-ZSW2"} <= {e["rule"] for e in evs}


@pytest.mark.skipif(shutil.which("tshark") is None, reason="tshark not installed")
@pytest.mark.parametrize("name", ("startup", "late-write"))
def test_plugin_same(caps, name):
    from test_lua_plugin import rule_rows
    assert rule_rows(caps[name]) == set()
    assert {r for _f, r, _d in rule_rows(caps[name], "-o", "pndiss.profile:generic")} >= {"RESERVED-BIT-SET-ZSW2"}
