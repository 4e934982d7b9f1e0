"""pndiss agrees with tshark 4.0 field for field on every capture (public and our own)."""
import os

import pytest

from conftest import record_count
from tsharkdiff import capture_files, compare, load_maps, need_tshark

FILES = capture_files()
TOTAL = {"values": 0}


@pytest.mark.parametrize("path", FILES, ids=[os.path.basename(f) for f in FILES])
def test_fields_equal_tshark(path):
    need_tshark()
    compared, diffs = compare(path, load_maps())
    TOTAL["values"] += compared
    record_count(f"tshark differential: field values compared over {len(FILES)} captures", compared)
    print(f"\n{os.path.basename(path)}: compared {compared} field values with tshark")
    assert not diffs, f"{len(diffs)} mismatches, first ones:\n" + "\n".join(diffs[:30])


def test_zz_total_printed(capsys):
    """Print the grand total (runs after the parametrised files; pytest keeps file order)."""
    with capsys.disabled():
        print(f"\ntshark differential: {TOTAL['values']} field values compared over {len(FILES)} captures")
    assert len(FILES) >= 1
