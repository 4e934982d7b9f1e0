"""Column sinks (pndiss/sinks.py) get the same rows from the engine as from the reference path.

A sink that consumes per-cycle columns (CycleBatch) and cyclic frames (StreamBatch) is served by the
engine at its speed: bulk stretches as whole columns, frames that go one by one as single rows. The
rows of every axis/direction and every stream must be the reference path's, in frame order.
"""
import glob
import os
import subprocess
import sys

import numpy as np
import pytest

from pndiss.driver import analyze
from pndiss.settings import Settings
from pndiss.sinks import Sink

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CAPTURES = sorted(glob.glob(os.path.join(ROOT, "captures", "*.pcapng")))


class Recorder(Sink):
    kinds = frozenset({"violation", "capture_gap"})
    cycles = True
    streams = True

    def __init__(self):
        self.cyc: dict = {}
        self.frames: dict = {}
        self.events = []
        self.points = []

    def event(self, ev):
        self.events.append((ev["frame"], ev["kind"], ev.get("rule")))

    def cycle_batch(self, b):
        key = (b.axis.get("ar_uuid"), b.axis.get("device_mac"), b.axis.get("slot"), b.axis.get("subslot"),
               b.direction, b.frame_id)
        rows = self.cyc.setdefault(key, [])
        names = sorted(b.signals)
        for i in range(len(b)):
            rows.append((int(b.frame[i]), int(b.ts_ns[i]), int(b.iops[i]), bool(b.judged[i]),
                         tuple((n, int(b.signals[n][i])) for n in names)))

    def stream_batch(self, b):
        rows = self.frames.setdefault(b.key, [])
        assert b.data.dtype == np.uint8 and b.data.shape[0] == len(b)
        for i in range(len(b)):
            rows.append((int(b.frame[i]), int(b.ts_ns[i]), b.data[i].tobytes(), b.off))

    def flush_point(self, frame):
        self.points.append(frame)


def _both(path):
    out = []
    for fast in (True, False):
        r = Recorder()
        a = analyze(path, Settings(fast_path=fast), [r])
        out.append((r, a))
    return out


def _check(path):
    (fast, a1), (ref, a2) = _both(path)
    assert fast.events == ref.events
    assert fast.cyc.keys() == ref.cyc.keys()
    for k in ref.cyc:
        assert fast.cyc[k] == ref.cyc[k], k
        frames = [r[0] for r in fast.cyc[k]]
        assert frames == sorted(frames) and len(set(frames)) == len(frames)   # frame order, each once
    assert fast.frames.keys() == ref.frames.keys()
    for k in ref.frames:
        assert fast.frames[k] == ref.frames[k], k
    assert fast.points == sorted(fast.points)
    n_frames = sum(len(v) for v in fast.frames.values())
    cyclic = {"RTC3", "RTC3 redundant", "RTC1", "RTC1 multicast", "RTC1 legacy", "RTC1 legacy multicast"}
    n_cyclic = sum(n for c, n in a1.summary()["frame_classes"].items() if c in cyclic)
    # every cyclic frame the tracker saw, once (a frame too short for the APDU status never reaches it)
    assert n_cyclic - a1.counts["malformed"] <= n_frames <= n_cyclic
    return fast


@pytest.mark.parametrize("path", [p for p in CAPTURES if os.path.basename(p).startswith(("plant-", "startup-t81",
                                                                                           "fault-sol", "fault-preset"))],
                         ids=os.path.basename)
def test_column_rows_equal_reference(path):
    _check(path)


def test_column_rows_plant_session(tmp_path):
    """Drifting clocks, several cycle times, IO devices, capture loss: the engine's bulk columns and the
    single rows together are exactly the reference path's."""
    out = str(tmp_path / "p.pcapng")
    subprocess.run([sys.executable, "-m", "pndiss", "simulate", "--scenario", "motion", "--encoders", "3",
                    "--io-devices", "2", "--cycle-time", "1,2,4", "--capture-loss", "0.002", "--cycles", "3000",
                    "--no-expected", "-o", out], check=True, capture_output=True, cwd=ROOT)
    rec = _check(out)
    assert sum(len(v) for v in rec.cyc.values()) > 10_000


def test_interface_time_offset_beyond_int64(tmp_path):
    """An IDB whose if_tsoffset (seconds) times 1e9 leaves int64 (the fuzz campaign made one): the engine
    leaves that interface to the reader, which clamps and counts the times; analyze and export still run,
    with the reference path's results."""
    import struct
    from pndiss.capture import open_capture
    from pndiss.cli import main as cli_main
    sim = str(tmp_path / "s.pcapng")
    assert cli_main(["simulate", "--cycles", "300", "--no-expected", "-o", sim]) == 0

    def block(btype, body):
        body += b"\0" * (-len(body) % 4)
        n = len(body) + 12
        return struct.pack("<II", btype, n) + body + struct.pack("<I", n)
    cap = str(tmp_path / "t.pcapng")
    opts = struct.pack("<HHB3x", 9, 1, 9) + struct.pack("<HHq", 14, 8, 1 << 62) + b"\0\0\0\0"
    with open(cap, "wb") as f:
        f.write(block(0x0A0D0D0A, struct.pack("<IHHq", 0x1A2B3C4D, 1, 0, -1)))
        f.write(block(1, struct.pack("<HHI", 1, 0, 65535) + opts))
        for k, (_fn, _ts, _lt, data) in enumerate(open_capture(sim)):
            f.write(block(6, struct.pack("<IIIII", 0, 0, k * 1000, len(data), len(data)) + data))
    fast = analyze(cap, Settings()).summary()
    ref = analyze(cap, Settings(fast_path=False)).summary()
    fast.pop("settings"), ref.pop("settings")
    assert fast == ref and fast["input"]["timestamps_clamped"] > 0
    assert cli_main(["export", cap, "-o", str(tmp_path / "t.mcap"), "-q"]) == 0


def test_engine_declines_a_flood_of_new_streams(tmp_path, monkeypatch):
    """20,000 cyclic frames from 20,000 random source MACs (a flood, no plant): learning a new stream per
    frame inside the engine's window would cost O(window) per stream; the engine hands such a window to
    the frame-by-frame path, with the reference results."""
    import random
    import struct

    from pndiss import engine as eng_mod

    def block(btype, body):
        body += b"\0" * (-len(body) % 4)
        n = len(body) + 12
        return struct.pack("<II", btype, n) + body + struct.pack("<I", n)
    rnd = random.Random(7)
    cap = str(tmp_path / "flood.pcapng")
    with open(cap, "wb") as f:
        f.write(block(0x0A0D0D0A, struct.pack("<IHHq", 0x1A2B3C4D, 1, 0, -1)))
        f.write(block(1, struct.pack("<HHI", 1, 0, 65535)))
        for k in range(20_000):
            src = bytes([2]) + rnd.randbytes(5)
            frame = (b"\x02\x00\x00\x00\x00\x01" + src + b"\x88\x92\x80\x00" + bytes(40)
                     + struct.pack(">HBB", (k * 32) & 0xFFFF, 0x35, 0))
            t = 1_767_225_600_000_000 + k * 1000
            f.write(block(6, struct.pack("<IIIII", 0, t >> 32, t & 0xFFFFFFFF, len(frame), len(frame)) + frame))
    made = []
    real = eng_mod.Engine

    def spy(*a, **kw):
        made.append(real(*a, **kw))
        return made[-1]
    monkeypatch.setattr(eng_mod, "Engine", spy)
    fast = analyze(cap, Settings()).summary()
    assert made and made[0].frames_bulk + made[0].frames_single + made[0].frames_global < 1000
    ref = analyze(cap, Settings(fast_path=False)).summary()
    fast.pop("settings"), ref.pop("settings")
    assert fast == ref and fast["frames"] == 20_000


# -- the full per-frame JSONL through the engine ------------------------------------------------------
PUBLIC = sorted(glob.glob(os.path.join(ROOT, "..", "shared", "captures", "public", "*.pcap*")))


def _reference_lines(path) -> list[str]:
    """The oracle: every event as a dict from the reference path, written as `analyze --jsonl` did
    before the column writer (one json.dumps per event, a violation's time set to its frame's)."""
    import json
    from pndiss.events import FrameTimes, json_default
    dumps = json.JSONEncoder(separators=(",", ":"), default=json_default).encode
    from pndiss.capture import CaptureError
    fix, out = FrameTimes().fix, []
    try:
        analyze(path, Settings(fast_path=False), [lambda ev: out.append(dumps(fix(ev)))])
    except CaptureError:   # a damaged capture: what was read before the damage
        pass
    return out


def _engine_lines(path, kinds=None) -> list[str]:
    import io
    from pndiss.jsonl_sink import JsonlSink
    f = io.BytesIO()
    s = JsonlSink(f, kinds)
    analyze(path, Settings(), [s])
    s.close()
    return f.getvalue().decode().splitlines()


@pytest.mark.parametrize("path", CAPTURES + PUBLIC, ids=os.path.basename)
def test_full_jsonl_through_engine_equals_reference(path):
    """`analyze --jsonl` writes every rt / telegram line from the engine's columns: line for line the
    reference's, iodata included (a map the AR's Release marks released after its rows were held)."""
    assert _engine_lines(path) == _reference_lines(path)


def test_full_jsonl_plant_session(tmp_path):
    out = str(tmp_path / "p.pcapng")
    subprocess.run([sys.executable, "-m", "pndiss", "simulate", "--scenario", "motion", "--encoders", "2",
                    "--io-devices", "2", "--cycle-time", "1,2", "--capture-loss", "0.002", "--cycles", "2000",
                    "--restart", "1200", "--no-expected", "-o", out], check=True, capture_output=True, cwd=ROOT)
    ref = _reference_lines(out)
    assert _engine_lines(out) == ref and len(ref) > 8000
    kinds = {"rt", "violation", "state"}
    assert _engine_lines(out, kinds) == [x for x in ref if any(f'"kind":"{k}"' in x for k in kinds)]


def test_cli_jsonl_uses_the_engine(tmp_path):
    """The command line's --jsonl (file and stdout) is the column writer's output, and equal to the oracle."""
    path = os.path.join(ROOT, "captures", "plant-3enc-cycles-io-devices.pcapng")
    if not os.path.exists(path):
        pytest.skip("captures/plant-3enc-cycles-io-devices.pcapng is missing")
    out = tmp_path / "e.jsonl"
    p = subprocess.run([sys.executable, "-m", "pndiss", "analyze", path, "--jsonl", str(out), "-q"],
                       capture_output=True, cwd=ROOT)
    assert p.returncode in (0, 1), p.stderr
    ref = _reference_lines(path)
    assert out.read_text().splitlines() == ref
    p = subprocess.run([sys.executable, "-m", "pndiss", "analyze", path, "--jsonl", "-", "-q"],
                       capture_output=True, cwd=ROOT)
    assert p.stdout.decode().splitlines() == ref


def test_cli_jsonl_of_a_damaged_capture(tmp_path):
    """A capture cut in the middle of a block: exit 2, and the JSONL holds every line of the frames read
    before the damage, as the reference writes them."""
    path = os.path.join(ROOT, "captures", "plant-3enc-cycles-io-devices.pcapng")
    if not os.path.exists(path):
        pytest.skip("captures/plant-3enc-cycles-io-devices.pcapng is missing")
    cut = tmp_path / "cut.pcapng"
    cut.write_bytes(open(path, "rb").read()[:300_000])
    out = tmp_path / "e.jsonl"
    p = subprocess.run([sys.executable, "-m", "pndiss", "analyze", str(cut), "--jsonl", str(out), "-q"],
                       capture_output=True, cwd=ROOT)
    assert p.returncode == 2 and b"truncated" in p.stderr
    ref = _reference_lines(str(cut))
    assert len(ref) > 1000 and out.read_text().splitlines() == ref
