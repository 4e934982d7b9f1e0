"""The other half of the captures of tests/test_tshark_diff.py (same checks; a second file so that
xdist's --dist loadfile compares both halves in parallel)."""
import os

import pytest

from test_tshark_diff import ALL, TOTAL, _figure, check_capture

FILES = ALL[1::2]


@pytest.mark.parametrize("path", FILES, ids=[os.path.basename(f) for f in FILES])
def test_fields_equal_tshark(path):
    check_capture(path)


def test_zz_total_printed(capsys):
    with capsys.disabled():
        print("\n" + _figure(TOTAL) + " (this test process so far; the terminal summary has the whole run)")
    assert FILES
