"""Test captures made from simulated ones the way a plant makes them: frames the capture lost, a capture
started mid-session. Reads with pndiss.capture, writes pcapng with pndiss.sim.pcapng (one Ethernet
interface, ns timestamps)."""
from __future__ import annotations

import os
import subprocess
import sys

from pndiss.capture import open_capture
from pndiss.proto import rt
from pndiss.sim.pcapng import Writer

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def simulate(out: str, *args: str) -> str:
    """``pndiss simulate ... -o out`` of this checkout; returns out."""
    subprocess.run([sys.executable, "-m", "pndiss", "simulate", *args, "-o", out], check=True, cwd=ROOT,
                   env=dict(os.environ, PYTHONPATH=ROOT), capture_output=True)
    return out


def write(path: str, frames) -> str:
    """A pcapng of ``frames`` [(time stamp ns, bytes)] in that order; returns path."""
    with open(path, "wb") as f:
        w = Writer(f)
        for ts, d in frames:
            w.write(ts, d)
    return path


def rewrite(src: str, dst: str, keep) -> dict:
    """Copy the frames of src for which keep(fn, data) is true into dst; returns {old frame no.: new frame no.}."""
    renum = {}
    with open(dst, "wb") as f:
        w = Writer(f)
        for fn, ts, _lt, data in open_capture(src):
            if keep(fn, data):
                renum[fn] = w.write(ts, bytes(data))
    return renum


def insert(src: str, dst: str, after: dict) -> None:
    """src with extra frames: ``after`` = {frame number: [frame bytes, ...]}, each written 1 us apart after it."""
    with open(dst, "wb") as f:
        w = Writer(f)
        for fn, ts, _lt, data in open_capture(src):
            w.write(ts, bytes(data))
            for i, extra in enumerate(after.get(fn, ()), 1):
                w.write(ts + 1000 * i, bytes(extra))


def cyclic_streams(path: str) -> dict:
    """(frame_id, src MAC bytes) -> [frame numbers] of the cyclic PN-RT frames (untagged or one VLAN tag)."""
    out: dict = {}
    for fn, _ts, _lt, d in open_capture(path):
        off = 18 if d[12:14] == b"\x81\x00" else 14
        if d[off - 2:off] != b"\x88\x92":
            continue
        fid = d[off] << 8 | d[off + 1]
        if rt.classify(fid, False)[1]:
            out.setdefault((fid, bytes(d[6:12])), []).append(fn)
    return out


def swap(src: str, dst: str, firsts: set) -> None:
    """Copy src to dst with each frame numbered in ``firsts`` and the frame after it in reverse order (time
    stamps stay in place): a setpoint and an actual value whose order flipped (RT clocks drifting)."""
    fr = [(ts, bytes(d)) for _fn, ts, _lt, d in open_capture(src)]
    for f in sorted(firsts):
        i = f - 1
        fr[i], fr[i + 1] = (fr[i][0], fr[i + 1][1]), (fr[i + 1][0], fr[i][1])
    with open(dst, "wb") as f:
        w = Writer(f)
        for ts, d in fr:
            w.write(ts, d)
