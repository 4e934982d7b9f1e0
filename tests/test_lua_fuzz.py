"""Property test of the plugin's Lua decoders: whatever bytes sit in the record data of the
0xB02E/0xB02F/0xBF00/I&M0 accesses and in the telegram C_SDUs, tshark shows no Lua error.

One hypothesis example = one capture (a simulated session whose record data and cyclic data
bytes are replaced by generated ones), so few examples cover thousands of decoder calls.
"""
from __future__ import annotations

import os
import shutil
import subprocess
import sys

import pytest

hyp = pytest.importorskip("hypothesis")
from hypothesis import HealthCheck, given, settings, strategies as st  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))

from test_lua_plugin import PLUGIN, _read_pcapng_frames, _write_pcap  # noqa: E402

pytestmark = pytest.mark.skipif(shutil.which("tshark") is None, reason="tshark not installed")

_BASE = {}


def base_session(tmp_dir):
    """Frames of a short simulated Lika session + where its record data and C_SDUs are."""
    if "frames" not in _BASE:
        from pndiss.analyzer import analyze_file

        path = os.path.join(tmp_dir, "base.pcapng")
        subprocess.run([sys.executable, "-m", "pndiss", "simulate", "--scenario", "preset", "--profile", "lika",
                        "--cycles", "150", "--no-expected", "-o", path], check=True, capture_output=True, cwd=ROOT)
        evs = []
        analyze_file(path, sink=evs.append)
        frames = _read_pcapng_frames(path)
        spots = []   # (frame index, first byte, length): record data sits at the end of the frame
        for ev in evs:
            if ev["kind"] == "record" and ev["length"]:
                spots.append((ev["frame"] - 1, len(frames[ev["frame"] - 1]) - ev["length"], ev["length"]))
            elif ev["kind"] == "telegram":
                fr = frames[ev["frame"] - 1]
                spots.append((ev["frame"] - 1, 20, len(fr) - 24))   # VLAN-tagged: C_SDU after 20 bytes
        _BASE.update(frames=frames, spots=spots)
    return _BASE["frames"], _BASE["spots"]


@settings(max_examples=6, deadline=None, suppress_health_check=list(HealthCheck))
@given(st.data())
def test_random_record_and_cyclic_bytes(tmp_path_factory, data):
    tmp = str(tmp_path_factory.mktemp("luafuzz"))
    frames, spots = base_session(tmp)
    out = list(frames)
    for i, start, n in spots:
        if data.draw(st.booleans()):
            fr = bytearray(out[i])
            fr[start:start + n] = data.draw(st.binary(min_size=n, max_size=n))
            out[i] = bytes(fr)
    path = os.path.join(tmp, "fuzz.pcap")
    _write_pcap(path, out)
    p = subprocess.run(["tshark", "-n", "-r", path, "-X", f"lua_script:{PLUGIN}", "-V"],
                       capture_output=True, text=True, timeout=300)
    assert p.returncode == 0
    assert "Lua" not in p.stderr.replace("Running as user", ""), p.stderr
    assert "Lua Error" not in p.stdout


def test_short_frames_equal_to_each_other(tmp_path):
    """The fuzz campaign's seed5051-m12: a telegram frame cut short (its data object ends beyond the
    C_SDU: malformed), then a frame with the very same bytes -- the tracker keeps the object's last
    values for an unchanged C_SDU (as cyclic.py does), and the tree must not read past the frame."""
    frames, spots = base_session(str(tmp_path))
    i, start, n = next((i, s, n) for i, s, n in spots if s == 20 and n > 12 and i > 100)
    fr = frames[i]
    short = fr[:start + 4] + fr[-4:]          # 4 bytes of C_SDU, then the APDU status
    out = frames[:i + 1] + [short, short] + frames[i + 1:]
    path = str(tmp_path / "short.pcap")
    _write_pcap(path, out)
    for two in ([], ["-2"]):
        p = subprocess.run(["tshark", "-n", "-r", path, "-X", f"lua_script:{PLUGIN}", "-V", *two],
                           capture_output=True, text=True, timeout=300)
        assert p.returncode == 0
        assert "Lua Error" not in p.stdout and "Lua" not in p.stderr.replace("Running as user", ""), p.stderr[-500:]
