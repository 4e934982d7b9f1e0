"""The Wireshark plugin in one pass (issue #16 item 6), with the real tshark and no `-2`.

* `tshark -r F -q -z expert` lists the violations decided on their own frame (expert infos of
  the first pass), rule for rule as many as a single pass shows with `-Y pndiss.rule`;
* the Info column names them;
* `tshark -r F -q -z pndiss,violations` lists at the end of the single pass every violation
  (frame, rule) the Python core reports, including those decided later (deadlines,
  controller-side rules, end of capture).
"""
from __future__ import annotations

import collections
import os
import re
import shutil

import pytest

from pndiss.settings import Settings
from test_lua_plugin import (fault_captures, public_captures, python_expect, rule_rows,
                             settings_pref, sidecar_settings, tshark)

pytestmark = pytest.mark.skipif(shutil.which("tshark") is None, reason="tshark not installed")

ROW = re.compile(r"^(\d+)\s+(\S+)\s+(error|warning|info)\s+(\S+)\s+(\d+|end)\s")
EXPERT = re.compile(r"^\s*(\d+)\s+\S+\s+PNDISS\s+([A-Z0-9-]+) \((controller|encoder)\): ")   # RULE (side): message


def tap_rows(out: str) -> set:
    """(frame, rule) of the -z pndiss,violations table; the count line must agree."""
    m = re.search(r"^pndiss violations: (\d+)$", out, re.M)
    assert m, out[-2000:]
    rows = {(int(x.group(1)), x.group(2)) for x in map(ROW.match, out.splitlines()) if x}
    assert len(rows) == int(m.group(1))
    return rows


def expert_counts(out: str) -> collections.Counter:
    """rule -> how many expert infos `-z expert` counted for it (summaries carry the message)."""
    c = collections.Counter()
    for line in out.splitlines():
        m = EXPERT.match(line)
        if m:
            c[m.group(2)] += int(m.group(1))
    return c


def _settings(path):
    st = sidecar_settings(path) if "/captures/fault-" in path else {}
    s = Settings()
    for k, v in st.items():
        setattr(s, k, v)
    return s, settings_pref(st)


CASES = [p for p, _ in fault_captures()] + public_captures()


@pytest.mark.parametrize("path", CASES, ids=os.path.basename)
def test_one_pass_expert_and_tap(path):
    s, pref = _settings(path)
    _, viol = python_expect(path, s)
    rc, out, err = tshark(path, "-q", "-z", "expert,note", "-z", "pndiss,violations", *pref, two_pass=False)
    assert rc == 0 and "Lua" not in err, err
    assert tap_rows(out) == viol
    one = collections.Counter(r for _, r, _ in rule_rows(path, *pref, two_pass=False))
    assert expert_counts(out) == one
    if "/captures/fault-" in path:
        # what -z expert lists in one pass holds every violation decided on its own frame
        immediate = collections.Counter(r for f, r, d in rule_rows(path, *pref) if d == f)
        assert not immediate - one, immediate - one


def test_late_violations_only_in_tap():
    """The tap is needed: some fault capture has a violation that -z expert cannot show in one pass
    (decided on a later frame), and the tap still lists it."""
    for path, _ in fault_captures():
        s, pref = _settings(path)
        two = rule_rows(path, *pref)
        late = {(f, r) for f, r, d in two if d != f}
        if late:
            rc, out, err = tshark(path, "-q", "-z", "pndiss,violations", *pref, two_pass=False)
            assert late <= tap_rows(out)
            return
    pytest.fail("no fault capture with a violation decided after its frame")


def test_info_column_names_rules():
    """Single-pass tshark's packet list: a frame with a violation shows its rule in the Info column;
    a deciding frame names the rule and the earlier frame."""
    for path, _ in fault_captures()[:40]:
        s, pref = _settings(path)
        rc, out, err = tshark(path, "-Y", "pndiss.rule or pndiss.late_rule", "-T", "fields", "-e", "frame.number",
                              "-e", "pndiss.rule", "-e", "pndiss.late_rule", "-e", "pndiss.late_rule.frame",
                              "-e", "_ws.col.Info", *pref, two_pass=False)
        assert rc == 0 and "Lua" not in err, err
        for line in out.splitlines():
            fn, rules, late, late_fr, info = line.split("\t")
            assert "[pndiss: " in info, line
            for r in filter(None, rules.split(",")):
                assert r in info, line
            for r, f in zip(filter(None, late.split(",")), late_fr.split(",")):
                assert f"{r} (frame {f})" in info, line



def test_two_pass_tap_without_a_tree_says_so():
    """tshark -2 builds no protocol tree for a tap on its first pass: the list then says pndiss decoded nothing
    and how to get it, rather than a clean "0 violations" on a faulty capture (an independent audit); the side of
    a rule the catalogue leaves open is the event's (TELEGRAM-LENGTH-MISMATCH of an actual value: the encoder)."""
    path = next(p for p, _ in fault_captures() if os.path.basename(p).startswith("fault-telegram-length-mismatch"))
    rc, out, err = tshark(path, "-q", "-z", "pndiss,violations")
    assert rc == 0 and "WARNING: the first pass had no protocol tree" in out and "-Y frame" in out, out
    rc, out, err = tshark(path, "-q", "-z", "pndiss,violations", "-Y", "frame")
    assert "WARNING" not in out
    rows = [x for x in map(ROW.match, out.splitlines()) if x]
    assert [(r.group(2), r.group(4)) for r in rows] == [("TELEGRAM-LENGTH-MISMATCH", "encoder")]


def test_settings_preference_none_and_unknown_keys():
    """The Settings preference reads KEY=none as --set does (from the capture: iso from the Connect), and says which
    items it ignored (an unknown key, a bad value) instead of dropping them silently (an independent audit: iso=none
    turned isochronous mode off and lost every sign-of-life violation)."""
    path = next(p for p, _ in fault_captures() if os.path.basename(p).startswith("fault-sol-master-skip"))
    st = sidecar_settings(path)
    rc, out, err = tshark(path, "-q", "-z", "pndiss,violations", *settings_pref(st), two_pass=False)
    want = tap_rows(out)
    assert ("SOL-MASTER-SKIP" in {r for _f, r in want}) and "WARNING" not in out
    pref = settings_pref(st)[1] + ",iso=none,lmax=3,l_max=abc" if st else "pndiss.settings:iso=none,lmax=3,l_max=abc"
    rc, out, err = tshark(path, "-q", "-z", "pndiss,violations", "-o", pref, two_pass=False)
    assert tap_rows(out) == want
    assert "ignored lmax=3, l_max=abc" in out and "ignored lmax=3, l_max=abc" in err


def test_two_pass_without_a_tree_noted_on_a_capture_without_cyclic_data(tmp_path):
    """A capture of DCP frames only (a commissioning tool's scan): tshark -2 -V without a display filter learns
    nothing on its first pass; every frame then carries the note saying so, as on cyclic captures (an independent
    audit: such captures looked clean)."""
    import capedit
    src = os.path.join(os.path.dirname(__file__), "..", "captures", "startup-t81-generic.pcapng")
    if not os.path.exists(src):
        pytest.skip("captures/startup-t81-generic.pcapng is missing")
    dcp = str(tmp_path / "dcp.pcapng")
    capedit.rewrite(src, dcp, lambda fn, d: d[12:14] == b"\x88\x92" and d[14] == 0xFE and d[15] >= 0xFC)
    rc, out, err = tshark(dcp, "-V")
    assert rc == 0 and "the first pass had no protocol tree" in out
    rc, out, err = tshark(dcp, "-V", "-Y", "frame")
    assert "the first pass had no protocol tree" not in out


def test_descriptive_fields_filter_without_a_visible_tree():
    """pndiss.judged, pndiss.direction ... filter in plain tshark (no -V): a display filter dissects with an invisible
    tree, in Wireshark too (an independent audit: -Y 'pndiss.judged' matched nothing without -V)."""
    path = next(p for p, _ in fault_captures() if os.path.basename(p).startswith("fault-absval-ack-missing"))
    counts = {}
    for flt in ("pndiss.judged", "pndiss.direction == \"actual\"", "pndiss.telegram"):
        rc, out, err = tshark(path, "-Y", flt, two_pass=False)
        counts[flt] = len(out.splitlines())
    assert counts["pndiss.judged"] == counts["pndiss.telegram"] > 100
    assert 0 < counts["pndiss.direction == \"actual\""] < counts["pndiss.telegram"]


def test_one_pass_expert_text_is_the_observation():
    """A run rule's expert info in one pass carries what its checker observed, not the catalogue section's title
    (an independent audit: "CTRLREQ-MISMATCH: 9.2 Control by PLC / Control requested" in Wireshark's packet list)."""
    path = next(p for p, _ in fault_captures() if os.path.basename(p).startswith("fault-ctrlreq-mismatch"))
    rc, out, err = tshark(path, "-q", "-z", "expert", *_settings(path)[1], two_pass=False)
    lines = [line for line in out.splitlines() if "CTRLREQ-MISMATCH (" in line]
    assert lines and all("ZSW2_ENC.9" in line for line in lines), lines
