"""pndiss agrees with tshark 4.0 field for field on every capture (public and our own), and every
field tshark emits on a PROFINET frame is compared unless tests/tshark_coverage.json says why not.

Printed on every run (the coverage figure): tshark fields seen (with a value, on PROFINET frames),
fields compared, fields excluded (with reasons) or still open, field values compared, mismatches, and
the frames a map with ``requires`` left out (cyclic frames between a Connect request and response).
"""
import os

import pytest

from conftest import record_count, record_names
from tsharkdiff import capture_files, compare, load_coverage, load_maps, need_tshark, profinet_fields

ALL = capture_files()
FILES = ALL[0::2]  # the other half: tests/test_tshark_diff_2.py (two files: xdist --dist loadfile runs them in parallel)
TOTAL = {"values": 0, "mismatches": 0, "skipped": 0, "seen": set(), "compared": set(), "excluded": set(), "open": set(),
         "labels": set()}
N = len(ALL)


def _figure(t: dict) -> str:
    return (f"tshark coverage: {len(t['seen'])} PROFINET fields seen with values, "
            f"{len(t['compared'])} compared, {len(t['excluded'])} excluded, {len(t['open'])} open; "
            f"{t['values']} values compared, {t['mismatches']} mismatches; {t['skipped']} frames not compared "
            f"for maps with 'requires' (tests/tshark_map/iodata.json quirks)")


def check_capture(path):
    """Compare one capture with tshark and account its fields (shared with test_tshark_diff_2.py)."""
    need_tshark()
    cov = load_coverage()
    done: set = set()
    skipped: dict = {}
    compared, diffs = compare(path, load_maps(), done, skipped)
    n_skipped = sum(len(v) for v in skipped.values())
    seen, labels = profinet_fields(path)
    done &= seen
    excluded = (seen - done) & set(cov["excluded"])
    still_open = (seen - done) & set(cov["open"])
    missing = seen - done - excluded - still_open
    TOTAL["values"] += compared
    TOTAL["mismatches"] += len(diffs)
    TOTAL["skipped"] += n_skipped
    for k, v in (("seen", seen), ("compared", done), ("excluded", excluded), ("open", still_open),
                 ("labels", labels)):
        TOTAL[k] |= v
    record_count(f"tshark differential: field values compared over {N} captures", compared)
    record_count(f"tshark differential: mismatches over {N} captures", len(diffs))
    record_count(f"tshark differential: frames not compared for maps with 'requires' over {N} captures", n_skipped)
    record_names(f"tshark coverage: PROFINET fields seen with values over {N} captures", seen)
    record_names(f"tshark coverage: PROFINET fields compared over {N} captures", done)
    record_names("tshark coverage: PROFINET fields excluded (tests/tshark_coverage.json)", excluded)
    record_names("tshark coverage: PROFINET fields open (not decoded yet)", still_open)
    print(f"\n{os.path.basename(path)}: {len(seen)} fields seen, {len(done)} compared, {len(excluded)} excluded, "
          f"{len(still_open)} open; {compared} values compared, {len(diffs)} mismatches, {n_skipped} frames skipped")
    assert not diffs, f"{len(diffs)} mismatches, first ones:\n" + "\n".join(diffs[:30])
    assert not missing, (f"{len(missing)} fields tshark shows on PROFINET frames are neither compared nor "
                         f"on the exclusion list: {sorted(missing)}")


@pytest.mark.parametrize("path", FILES, ids=[os.path.basename(f) for f in FILES])
def test_fields_equal_tshark(path):
    check_capture(path)


def test_coverage_list_is_reasoned():
    """Every exclusion has a reason; nothing is both excluded and mapped."""
    cov = load_coverage()
    mapped = {tf.replace(".", "_") for m in load_maps() for tf in m["fields"].values()}
    for part in ("excluded", "open"):
        for name, why in cov[part].items():
            assert isinstance(why, str) and len(why) > 10, name
            assert name not in mapped, f"{name} is mapped and {part}"


def test_zz_total_printed(capsys):
    """Print this file's part of the figure (runs after the parametrised files; pytest keeps file
    order); the whole figure over both files is in the terminal summary (conftest.record_names)."""
    with capsys.disabled():
        print("\n" + _figure(TOTAL) + " (this test process so far; the terminal summary has the whole run)")
        if TOTAL["open"]:
            print("open (not decoded yet): " + ", ".join(sorted(TOTAL["open"])))
    assert N >= 1
