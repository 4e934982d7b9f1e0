"""The fuzz campaign (bench/fuzz, issue #17) with a small budget: mutated captures through every
sink and the Lua plugin; 0 crashes, 0 hangs, 0 Lua errors, accounting intact. The big budget is run
by hand (bench/RESULTS.md). Select with `-m fuzz`."""
import os
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


@pytest.mark.fuzz
def test_fuzz_campaign_small_budget(tmp_path):
    out = tmp_path / "fuzz.json"
    r = subprocess.run([sys.executable, os.path.join(ROOT, "bench", "fuzz"), "--mutants", "8", "--lua-every", "4",
                        "--png-every", "4", "--seed", "5", "-q", "--json", str(out),
                        "--keep-dir", str(tmp_path / "fail")],
                       capture_output=True, text=True, timeout=1200, env=dict(os.environ, PYTHONPATH=ROOT))
    assert "fuzz: seed 5: 8 mutants" in r.stdout, r.stdout + r.stderr
    assert r.returncode == 0, r.stdout + r.stderr[-2000:]
    import json
    fig = json.loads(out.read_text())["figures"]
    assert fig["frames"] > 0 and fig["commands"] >= 24
