#!/usr/bin/env python3
"""Micro-benchmark of the column sinks (issue #13, sinks at engine speed): MCAP messages/s and
JSONL lines/s of McapSink / JsonlSink fed the batches of a realistic simulated capture.

    PYTHONPATH=. python3 bench/colfmt.py [--capture FILE] [--every N] [--repeat N]

Without --capture it simulates the issue's capture (a): 16 moving encoders and 16 ordinary IO
devices, RT 1/2/4 ms, drift and jitter, 2 s. The batches come from the reference path's events
(tests/colfmt_producer.py, not timed); timed is CPU time (one core) of the sink calls alone --
holding, merging, formatting, writing, closing -- against the reference's per-event formatting
of the same events (json per event for JSONL, McapExporter.on_event for MCAP).
"""
from __future__ import annotations

import argparse
import io
import json
import os
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)
sys.path.insert(0, os.path.join(ROOT, "tests"))

from colfmt_producer import Recorded, plan, play  # noqa: E402
from pndiss.capture import ReadInfo  # noqa: E402
from pndiss.jsonl_sink import JsonlSink  # noqa: E402
from pndiss.mcap_export import McapExporter  # noqa: E402
from pndiss.mcap_sink import McapSink  # noqa: E402

CI_KINDS = ("violation", "param", "record", "state", "capture_gap")


def simulate(path: str) -> None:
    subprocess.run([sys.executable, "-m", "pndiss", "simulate", "--encoders", "16", "--io-devices", "16",
                    "--cycle-time", "1,2,4,1,2,4,1,2,4,1,2,4,1,2,4,1", "--duration", "2", "--scenario", "motion",
                    "--no-expected", "-o", path], check=True, env={**os.environ, "PYTHONPATH": ROOT},
                   stdout=subprocess.DEVNULL)


def cpu(fn, repeat: int) -> float:
    best = None
    for _ in range(repeat):
        t = time.process_time()
        fn()
        d = time.process_time() - t
        best = d if best is None or d < best else best
    return best


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--capture")
    ap.add_argument("--every", type=int, default=4096, help="frames between flush points (default 4096)")
    ap.add_argument("--repeat", type=int, default=3, help="runs per figure, the best counts (default 3)")
    args = ap.parse_args()
    tmp = tempfile.mkdtemp(prefix="colfmt-")
    cap = args.capture or os.path.join(tmp, "a.pcapng")
    if not args.capture:
        simulate(cap)
    rec = Recorded(cap)
    calls = plan(rec, args.every)
    n_frames = rec.analyzer.frames
    events = [it[-1] if it[0] != "ev" else it[2] for it in rec.items]
    out = os.path.join(tmp, "x.mcap")
    rows = []

    def mcap(compression):  # noqa: E306
        s = McapSink(out, cap, None, compression=compression)
        s.reader_info = ReadInfo()   # the driver's reader hashes the capture, not the sink
        play(calls, [s])
        return sum(s.summary()["topics"].values())

    def mcap_ref(compression):
        e = McapExporter(out, cap, None, compression=compression)
        e.reader_info = ReadInfo()
        for ev in events:
            e.on_event(ev)
        e.close()
        return sum(e.summary()["topics"].values())

    for comp in ("none", "zstd"):
        n = mcap(comp)   # warm (numba's cache) and count
        t = cpu(lambda: mcap(comp), args.repeat)
        tr = cpu(lambda: mcap_ref(comp), 1)
        rows.append((f"McapSink, compression {comp}", n, "messages", t, tr))
    # the cyclic topics alone: what the columns write (the capture's set-up events -- RPC, DCP,
    # records -- go through the exporter's per-event path, a fixed cost of a short capture)
    every_call, cyclic = calls, [c for c in calls if c[0] != "event"]
    calls = cyclic
    n = mcap("none")
    t = cpu(lambda: mcap("none"), args.repeat)
    rows.append(("McapSink, cyclic rows only, compression none", n, "messages", t, float("nan")))

    def jsonl(kinds=None):
        f = io.BytesIO()
        play(calls, [JsonlSink(f, kinds)])
        return f.getvalue().count(b"\n")

    dumps = json.JSONEncoder(separators=(",", ":"), default=str).encode

    def jsonl_ref(kinds=None):
        f = io.StringIO()
        w = f.write
        for ev in events:
            if kinds is None or ev["kind"] in kinds:
                w(dumps(ev) + "\n")
        return f

    n = jsonl()
    rows.append(("JsonlSink, cyclic rows only (rt + telegram lines)", n, "lines", cpu(jsonl, args.repeat), float("nan")))
    calls = every_call
    n = jsonl()
    rows.append(("JsonlSink, full per-frame JSONL", n, "lines", cpu(jsonl, args.repeat), cpu(jsonl_ref, 1)))
    n = jsonl(CI_KINDS)
    rows.append((f"JsonlSink, --events {','.join(CI_KINDS)}", n, "lines",
                 cpu(lambda: jsonl(CI_KINDS), args.repeat), cpu(lambda: jsonl_ref(CI_KINDS), 1)))
    print(f"capture: {os.path.basename(cap)}, {n_frames:,} frames, flush every {args.every} frames; "
          f"CPU s of the sink calls (best of {args.repeat}); reference: per-event formatting of the same events")
    print("| sink | output | CPU s | per s | frames/s | reference CPU s | speed-up |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    for name, n, unit, t, tr in rows:
        ref = "- | -" if tr != tr else f"{tr:.3f} | {tr / t:.1f}x"
        print(f"| {name} | {n:,} {unit} | {t:.3f} | {n / t:,.0f} {unit}/s | {n_frames / t:,.0f} | {ref} |")
    return 0


if __name__ == "__main__":
    sys.exit(main())
