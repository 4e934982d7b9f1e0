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


def _fuzz_module():
    import importlib.machinery
    import importlib.util
    loader = importlib.machinery.SourceFileLoader("bench_fuzz", os.path.join(ROOT, "bench", "fuzz"))
    spec = importlib.util.spec_from_loader("bench_fuzz", loader)
    mod = importlib.util.module_from_spec(spec)
    loader.exec_module(mod)
    return mod


def test_lua_errors_are_seen_in_both_modes(tmp_path):
    """The campaign's cheap Lua check (a display filter on the expert info, no -V text) must see a plugin
    error as the -V scan does, one pass and -2; the real plugin on a real capture shows none."""
    import shutil
    if not shutil.which("tshark"):
        pytest.skip("tshark not installed")
    fz = _fuzz_module()
    cap = os.path.join(ROOT, "captures", "startup-t81-generic.pcapng")
    bad = tmp_path / "bad.lua"
    bad.write_text('local p = Proto("fuzzbad", "bad")\n'
                   'function p.dissector(tvb, pinfo, tree)\n'
                   '  if pinfo.number % 50 == 0 then error("boom " .. pinfo.number) end\n'
                   '  tree:add(p, tvb())\nend\nregister_postdissector(p)\n')
    real = fz.PLUGIN
    fz.PLUGIN = str(bad)
    for two in (False, True):
        for verbose in (False, True):
            status, msg = fz.lua_errors(cap, two, 120, verbose)
            assert status == "lua_error" and "boom 50" in msg, (two, verbose, msg)
    fz.PLUGIN = real
    assert fz.lua_errors(cap, True, 120) == ("ok", "")


def test_concatenated_mutants(tmp_path):
    """--mutant-frames lays mutated seeds end to end, each seed's time after the previous one."""
    import random
    fz = _fuzz_module()
    seeds = [(p, fz.read_seed(p)) for p in fz.seed_files()[:6]]
    seeds = [(p, fr) for p, fr in seeds if fr]
    frames, changed, names = fz.build_mutant(random.Random(3), seeds, 5000)
    assert len(frames) >= 5000 and len(names) >= 2 and changed > 0
    # the first frame of each seed after the first starts after the previous seed's last frame
    starts = [i for i in range(1, len(frames)) if frames[i][0] - frames[i - 1][0] == 1_000_000]
    assert starts, "no seed boundary found"
