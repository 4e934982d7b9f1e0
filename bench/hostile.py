#!/usr/bin/env python3
"""Hostile-input benchmarks (issues #17, #18): captures built as an attacker would, fast (bytes, no
scapy), and the time / peak RSS of `pndiss analyze` on each size, to show cost linear in frames and
memory flat. Usage:

    bench/hostile.py [--only NAME[,NAME]] [--scale 0.1] [--out DIR] [--record]

--scale shrinks every size (CI smoke runs); --record appends the table to bench/RESULTS.md.
The generators are imported by tests/test_hostile.py (small sizes) as well.
"""
from __future__ import annotations

import argparse
import os
import struct
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(ROOT, "tests"))

import rpc_frames as rf  # noqa: E402  (the tests' frame builders: one Connect template)

PCAP_HDR = struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, 1)
T0 = 1_700_000_000


class PcapWriter:
    """Frames to a classic pcap file, 1 µs apart (so nothing times out unless a test wants it)."""

    def __init__(self, path: str, start_us: int = 0):
        self.f = open(path, "wb")
        self.f.write(PCAP_HDR)
        self.n = 0
        self.us = start_us
        self.parts: list[bytes] = []

    def add(self, data: bytes, step_us: int = 1) -> None:
        self.us += step_us
        self.parts.append(struct.pack("<IIII", T0 + self.us // 1_000_000, self.us % 1_000_000, len(data), len(data)))
        self.parts.append(data)
        self.n += 1
        if len(self.parts) >= 20000:
            self.f.write(b"".join(self.parts))
            self.parts.clear()

    def close(self) -> int:
        self.f.write(b"".join(self.parts))
        self.f.close()
        return self.n


def _mac(i: int) -> bytes:
    """A locally administered unicast MAC for number i (distinct for i < 2^40)."""
    return bytes([0x02]) + i.to_bytes(5, "big")


def _rand_macs(n: int, seed: int = 1):
    import numpy as np
    r = np.random.default_rng(seed).integers(0, 1 << 40, size=n, dtype=np.int64)
    return [_mac(int(x)) for x in r]


# ------------------------------------------------------------------ generators
def gen_ars(path: str, n: int) -> int:
    """n distinct Connects (request + response): each its own AR UUID, activity and device MAC."""
    req, res = rf.connect_pair([(1, 0x51, 3, 12, 4), (2, 1, 0, 0, 0)])
    ar = rf.uuid_bytes(rf.AR_UUID)
    act = "00000007-0000-1010-8000-000000000007"
    act_be, act_le = rf.uuid_bytes(act), rf.uuid_bytes(act, True)
    dev = rf.mac_bytes(rf.DEVICE_MAC)
    assert ar in req and ar in res and act_be in req and act_le in res and dev in req
    w = PcapWriter(path)
    for i in range(n):
        tag = (i + 1).to_bytes(6, "big")
        a2 = ar[:10] + tag
        x_be = act_be[:10] + tag
        x_le = act_le[:10] + tag
        d2 = b"\x02\x01" + (i + 1).to_bytes(4, "big")
        w.add(req.replace(ar, a2).replace(act_be, x_be).replace(dev, d2))
        w.add(res.replace(ar, a2).replace(act_le, x_le).replace(dev, d2))
    return w.close()


def dcp_identify_response(src: bytes, name: bytes, xid: int = 1) -> bytes:
    """A DCP Identify response (FrameID 0xFEFF) with NameOfStation and IP parameter blocks."""
    def blk(opt, sub, value):
        b = struct.pack(">BBHH", opt, sub, 2 + len(value), 0) + value
        return b + (b"\0" if len(b) % 2 else b"")
    blocks = blk(2, 2, name) + blk(1, 2, bytes([192, 168, (xid >> 8) & 0xFF, xid & 0xFF]) + bytes([255, 255, 255, 0]) + bytes(4))
    dcp = struct.pack(">HBBIHH", 0xFEFF, 5, 1, xid, 0, len(blocks)) + blocks
    eth = b"\x02\x00\x00\x00\x00\x01" + src + b"\x88\x92" + dcp
    return eth + bytes(max(0, 60 - len(eth)))


def gen_dcp(path: str, n: int) -> int:
    """n DCP Identify responses, each from a random source MAC with its own name and IP."""
    w = PcapWriter(path)
    for i, m in enumerate(_rand_macs(n, 2)):
        w.add(dcp_identify_response(m, b"dev-%d" % i, i & 0xFFFF))
    return w.close()


def gen_cyclic_random(path: str, n: int, macs: int) -> int:
    """n cyclic PN-RT frames (FrameID 0x8000, 40-byte C_SDU) from ``macs`` random source MACs in turn."""
    ms = _rand_macs(macs, 3)
    body = bytes(40)
    dst = b"\x02\x00\x00\x00\x00\x01"
    w = PcapWriter(path)
    for i in range(n):
        cc = i & 0xFFFF
        w.add(dst + ms[i % macs] + b"\x88\x92\x80\x00" + body + struct.pack(">HBB", cc, 0x35, 0))
    return w.close()


def gen_rpc_hole(path: str, n: int, last: int = 65000) -> int:
    """One DCE/RPC call in n fragments: the last fragment (number ``last``) first, then 0, 1, ...
    65535 over and over, without ``last - 1``: a hole just before the end, so a reassembler that
    checks "all of 0..last present?" per fragment rescans ~65,000 numbers each time (issue #18 item 2)."""
    w = PcapWriter(path)
    act = "00000009-0000-1010-8000-000000000009"
    body = b"\x55" * 8
    nums = [last] + [i for i in range(65536) if i not in (last - 1, last)]
    cache: dict[int, bytes] = {}
    for i in range(n):
        num = nums[0] if i == 0 else nums[1 + (i - 1) % (len(nums) - 1)]
        fr = cache.get(num)
        if fr is None:
            flags = 0x24 | (0x02 if num == last else 0)
            fr = cache[num] = rf.frame(rf.CONTROLLER_MAC, rf.DEVICE_MAC, rf.CONTROLLER_IP, rf.DEVICE_IP, 49153,
                                       34964, rf.dcerpc(0, 3, body, act=act, flags1=flags, frag_num=num))
        w.add(fr, step_us=0)
    return w.close()


def gen_ip_hole(path: str, n: int) -> int:
    """One IPv4 datagram in n fragments of 8 bytes from the end backwards, offset 0 never (a hole),
    repeated: it never completes (issue #17 item 4, issue #18 item 2)."""
    w = PcapWriter(path)
    payload = b"\xaa" * 8
    top = 65528 // 8
    cache: dict[int, bytes] = {}
    for i in range(n):
        unit = top - (i % (top - 1))     # top .. 2, then again
        fr = cache.get(unit)
        if fr is None:
            mf = 0 if unit == top else 0x2000
            pkt = rf.ipv4(rf.CONTROLLER_IP, rf.DEVICE_IP, payload, ident=0x4242, flags_frag=mf | unit)
            fr = cache[unit] = rf.eth(rf.CONTROLLER_MAC, rf.DEVICE_MAC, pkt)
        w.add(fr, step_us=0)
    return w.close()


def gen_pending_rpc(path: str, n: int) -> int:
    """n first fragments of n different calls: none completes (evicted or timed out)."""
    w = PcapWriter(path)
    body = b"\x55" * 100
    for i in range(n):
        w.add(rf.frame(rf.CONTROLLER_MAC, rf.DEVICE_MAC, rf.CONTROLLER_IP, rf.DEVICE_IP, 49153, 34964,
                       rf.dcerpc(0, 3, body, act=f"00000000-0000-1010-8000-{i:012x}", flags1=0x24)))
    return w.close()


# ------------------------------------------------------------------ runner
def in_child(fn, *args) -> int:
    """fn(*args) -> int in a forked child. Linux carries a process's peak RSS over fork and exec into the
    child's ru_maxrss: a parent that built a 10 M-frame capture would lend the measured analyze its size."""
    r, w = os.pipe()
    pid = os.fork()
    if pid == 0:
        os.close(r)
        code = 1
        try:
            os.write(w, str(fn(*args)).encode())
            code = 0
        finally:
            os._exit(code)
    os.close(w)
    with os.fdopen(r) as f:
        out = f.read()
    _, status = os.waitpid(pid, 0)
    if status != 0:
        raise RuntimeError(f"generator {fn.__name__} failed")
    return int(out)


BENCHES = {
    # name -> (generator, sizes, description)
    "rpc_hole": (gen_rpc_hole, [10_000, 100_000, 1_000_000], "fragments of one RPC call, last first, a hole"),
    "ip_hole": (gen_ip_hole, [10_000, 100_000, 1_000_000], "fragments of one IPv4 datagram with a hole"),
    "ars": (gen_ars, [1_000, 10_000, 100_000], "distinct Connects (ARs); frames = 2 per AR"),
    "pending_rpc": (gen_pending_rpc, [20_000, 200_000], "first fragments of distinct RPC calls"),
    "dcp": (gen_dcp, [1_000, 100_000, 1_000_000], "DCP Identify responses from random MACs"),
    "cyclic_random": (lambda p, n: gen_cyclic_random(p, n, max(1, n // 3)), [300_000, 3_000_000],
                      "cyclic PN-RT frames from n/3 random source MACs"),
    "cyclic_macs": (lambda p, n: gen_cyclic_random(p, n, max(1, n // 10)), [10_000_000],
                    "cyclic PN-RT frames from n/10 random source MACs (#18: 10 M frames, 1 M MACs)"),
}


def measure(path: str) -> tuple[float, float, int, str]:
    """(wall s, CPU s, peak RSS MB, summary note) of `pndiss analyze --summary-json` on path. CPU time
    (user + sys, wait4) is the figure to compare on a shared machine: wall time follows the load."""
    import json
    out = path + ".summary.json"
    cmd = [sys.executable, "-m", "pndiss", "analyze", path, "-q", "--no-progress", "--summary-json", out]
    env = dict(os.environ, PYTHONPATH=ROOT)
    t = time.perf_counter()
    p = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    _, status, ru = os.wait4(p.pid, 0)
    dt = time.perf_counter() - t
    cpu = ru.ru_utime + ru.ru_stime
    err = p.stderr.read().decode(errors="replace").strip()
    if status != 0:
        return dt, cpu, ru.ru_maxrss // 1024, f"exit {os.waitstatus_to_exitcode(status)}: {err[-200:]}"
    with open(out) as f:
        s = json.load(f)
    os.unlink(out)
    acc = s["accounting"]
    ok = sum(acc.values()) == s["frames"]
    note = (f"accounting {'ok' if ok else 'BROKEN'} (malformed {acc['malformed']:,}); "
            f"stations {len(s['stations']):,}; evicted {s.get('limits', {}).get('evicted', {})}")
    return dt, cpu, ru.ru_maxrss // 1024, note


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--only", help="comma-separated benchmark names: " + ", ".join(BENCHES))
    ap.add_argument("--sizes", help="comma-separated sizes instead of each benchmark's own")
    ap.add_argument("--scale", type=float, default=1.0, help="multiply every size (e.g. 0.1)")
    ap.add_argument("--out", default="/tmp/pndiss-hostile", help="directory for the generated captures")
    ap.add_argument("--record", action="store_true", help="append the table to bench/RESULTS.md")
    ap.add_argument("--keep", action="store_true", help="keep the generated captures")
    args = ap.parse_args()
    os.makedirs(args.out, exist_ok=True)
    names = args.only.split(",") if args.only else list(BENCHES)
    results = os.path.join(HERE, "RESULTS.md")
    if args.record:   # the section's head now, each row as soon as it is measured (a long run may be cut)
        import datetime
        import platform
        commit = subprocess.run(["git", "-C", ROOT, "rev-parse", "--short", "HEAD"], capture_output=True,
                                text=True).stdout.strip()
        head = [f"\n## Hostile inputs (issues #17, #18): `bench/hostile.py {' '.join(sys.argv[1:])}`\n",
                f"Commit {commit}, {datetime.datetime.utcnow():%Y-%m-%d %H:%M} UTC, {platform.machine()}, "
                f"{os.cpu_count()} cores shared with other jobs (load average {os.getloadavg()[0]:.1f} at the start). "
                "Wall time, CPU time (user + sys) and peak RSS (wait4) of `pndiss analyze -q --summary-json` per "
                "capture, start-up (~1-2 s CPU) included; CPU µs/frame is the figure to compare across sizes on this "
                "shared machine (wall time follows the other jobs' load).\n",
                "| input | n | frames | wall (s) | CPU (s) | CPU µs/frame | peak RSS (MB) | summary |",
                "|---|---:|---:|---:|---:|---:|---:|---|"]
        with open(results, "a", encoding="utf-8") as f:
            f.write("\n".join(head) + "\n")
    for name in names:
        gen, sizes, what = BENCHES[name]
        for size in ([int(x) for x in args.sizes.split(",")] if args.sizes else sizes):
            n = max(10, int(size * args.scale))
            path = os.path.join(args.out, f"{name}-{n}.pcap")
            t = time.perf_counter()
            frames = in_child(gen, path, n)
            tg = time.perf_counter() - t
            dt, cpu, rss, note = measure(path)
            print(f"{name:14s} n={n:>10,} frames={frames:>11,} gen {tg:6.1f}s  analyze {dt:7.2f}s wall "
                  f"{cpu:7.2f}s CPU ({cpu / frames * 1e6:8.1f} µs CPU/frame)  peak RSS {rss:5d} MB  {note}", flush=True)
            if args.record:
                with open(results, "a", encoding="utf-8") as f:
                    f.write(f"| {name}: {what} | {n:,} | {frames:,} | {dt:.1f} | {cpu:.1f} | "
                            f"{cpu / frames * 1e6:.1f} | {rss} | {note} |\n")
            if not args.keep:
                os.unlink(path)
    return 0


if __name__ == "__main__":
    sys.exit(main())
