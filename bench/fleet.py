#!/usr/bin/env python3
"""The fleet benchmarks (issue #14): `pndiss fleet` on 1 vs 2 Dask worker processes, and DuckDB's
answer to "violations by station and rule" over the dataset of 1,000 small captures.

    PYTHONPATH=. python3 bench/fleet.py [--out bench/out] [--files 24,96] [--small 1000] [--parts speedup,query,volume]

Writes its figures into bench/RESULTS.md between ``<!-- fleet:begin -->`` and ``<!-- fleet:end -->``.
The captures are made by `pndiss simulate` (in this process, so scapy is imported once) and kept in
OUT/fleet-set and OUT/fleet-small for the next run; every run writes fresh datasets.
"""
from __future__ import annotations

import argparse
import glob
import json
import os
import platform
import re
import shutil
import statistics
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
ROOT = os.path.dirname(HERE)
sys.path.insert(0, ROOT)

# The benchmark set: plant-like sessions, each a different shape. Every option is a `pndiss simulate`
# option; the i-th capture takes VARIANTS[i % len] with seed i (RT clocks drift 50 ppm and jitter
# 20 us by default; --drift-ppm / --jitter-us vary them here).
VARIANTS = [
    "--encoders 3 --cycle-time 1,2,4 --io-devices 2 --capture-loss 0.001",
    "--encoders 2 --io-devices 3 --drift-ppm 100 --jitter-us 50",
    "--encoders 1 --telegram 83 --profile lika --io-devices 1 --capture-loss 0.002",
    "--encoders 4 --cycle-time 2 --io-devices 4 --drift-ppm 20",
    "--encoders 2 --cycle-time 1,2 --capture-loss 0.0005 --restart 4000",
    "--encoders 1 --scenario preset --profile scancon --io-devices 2 --inject PRESET-ACK-MISSING",
    "--encoders 2 --irt --io-devices 1 --capture-loss 0.001",
    "--encoders 3 --telegram 82 --io-devices 2 --start-mid-session 500",
]
SET_CYCLES = 60_000       # 1 ms cycles: 1 min of traffic (a ring-buffer file), about 0.2-0.5 M frames per capture
SMALL_CYCLES = 150
SMALL_VARIANTS = ["", "--encoders 2", "--inject SOL-DEVICE-ZERO-RT", "--io-devices 1",
                  "--scenario preset --inject PRESET-ACK-MISSING", "--capture-loss 0.01",
                  "--inject RESERVED-BIT-SET-ZSW2", "--profile lika --telegram 83"]
QUERY = ("SELECT station, rule, count(*) AS n FROM violations GROUP BY station, rule "
         "ORDER BY n DESC, station, rule")


def simulate(out: str, variants: list[str], n: int, cycles: int) -> list[str]:
    """n captures in ``out`` (made once; kept for later runs)."""
    from pndiss.cli import main as pndiss

    os.makedirs(out, exist_ok=True)
    paths = []
    for i in range(n):
        path = os.path.join(out, f"cap{i:04d}.pcapng")
        if not os.path.exists(path):
            args = ["simulate", *variants[i % len(variants)].split(), "--cycles", str(cycles),
                    "--seed", str(i + 1), "--no-expected", "-o", path + ".tmp"]
            if pndiss(args) != 0:
                raise SystemExit(f"simulate failed: {' '.join(args)}")
            os.replace(path + ".tmp", path)
        paths.append(path)
    return paths


def fleet(inputs: list[str], dataset: str, workers: int) -> tuple[float, str]:
    """(wall seconds, closing line) of one fresh run."""
    shutil.rmtree(dataset, ignore_errors=True)
    cmd = [sys.executable, "-m", "pndiss", "fleet", *inputs, "-o", dataset, "--workers", str(workers), "--no-progress"]
    t = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, env={**os.environ, "PYTHONPATH": ROOT})
    dt = time.perf_counter() - t
    if p.returncode not in (0, 1):
        raise SystemExit(f"fleet failed ({p.returncode}): {p.stderr[-800:]}")
    return dt, p.stderr.strip().splitlines()[-1]


def speedup(paths: list[str], out: str, cycles: int, commit: str) -> dict:
    """`pndiss fleet` over ``paths`` on 1 and 2 workers (the whole command), then per phase."""
    r = {"files": len(paths), "mb": sum(os.path.getsize(p) for p in paths) / 1e6, "commit": commit,
         "cycles": cycles, "load_before": os.getloadavg()[0], "runs": {}}
    for workers in (1, 2):
        before = os.times()
        dt, line = fleet(paths, os.path.join(out, f"fleet-ds{workers}"), workers)
        after = os.times()
        cpu = (after.children_user + after.children_system) - (before.children_user + before.children_system)
        r["runs"][str(workers)] = (dt, cpu, line)
        print(f"{len(paths)} files, {workers} worker(s): {dt:.1f} s wall, {cpu:.1f} s CPU  [{line}]", file=sys.stderr)
    r["phases"] = {str(w): phases(paths, os.path.join(out, f"fleet-ph{w}"), w) for w in (1, 2)}
    r["load_after"] = os.getloadavg()[0]
    from pndiss import dataset as ds
    r["frames"] = ds.open(os.path.join(out, "fleet-ds1")).sql("SELECT sum(frames) FROM captures").fetchall()[0][0]
    return r


def phases(paths: list[str], dataset: str, workers: int) -> dict:
    """The same work in this process, timed per phase: hashing and planning, the cluster's start, the
    analysis tasks (the part that runs in parallel), the cluster's shutdown."""
    from pndiss import fleet as fl
    from pndiss.fleet_store import DatasetStore
    from pndiss.settings import Settings

    shutil.rmtree(dataset, ignore_errors=True)
    os.makedirs(dataset)
    t0 = time.perf_counter()
    store = DatasetStore(dataset)
    p = fl.plan(paths, store)
    t1 = time.perf_counter()
    client, cluster = fl.connect(None, workers)
    t2 = time.perf_counter()
    fl.run_dask(client, p.todo, store, Settings(), "on_change")
    t3 = time.perf_counter()
    client.close()
    cluster.close()
    t4 = time.perf_counter()
    return {"plan": t1 - t0, "start": t2 - t1, "tasks": t3 - t2, "stop": t4 - t3}


def query_times(dataset: str, repeat: int = 5) -> dict:
    """The question answered by `pndiss query DS "SQL"` in a fresh process (imports included), and
    in a warm process through ``pndiss.dataset.open`` (views over the tables the query names).
    Wall and CPU seconds (CPU: all of DuckDB's threads; a loaded machine stretches the wall time)."""
    cmd = [sys.executable, "-m", "pndiss", "query", dataset, QUERY, "--format", "csv"]
    t = time.perf_counter()
    before = os.times()
    p = subprocess.run(cmd, capture_output=True, text=True, cwd=ROOT, env={**os.environ, "PYTHONPATH": ROOT}, check=True)
    after = os.times()
    out = {"cold": time.perf_counter() - t, "rows": len(p.stdout.strip().splitlines()) - 1, "repeat": repeat,
           "cold_cpu": (after.children_user + after.children_system) - (before.children_user + before.children_system)}
    from pndiss import dataset as ds
    from pndiss.dataset.reader import referenced
    wall, cpu = [], []
    for _ in range(repeat):
        t, c = time.perf_counter(), time.process_time()
        ds.open(dataset, tables=referenced(QUERY)).sql(QUERY).fetchall()
        wall.append(time.perf_counter() - t)
        cpu.append(time.process_time() - c)
    out["warm"], out["warm_cpu"] = statistics.median(wall), statistics.median(cpu)
    return out


VOLUME_SCENARIOS = {   # one axis, telegram 81, 1 ms, 60 s: the start-up scenario and the motion scenario
    "startup": "--scenario startup",
    "motion": "--scenario motion",
}
VOLUME_CYCLES = 60_000
VOLUME_MODES = ("full", "on_change", "decimate:100", "none")
YEAR_S = 365.25 * 86400


def volumes(out: str) -> list[tuple]:
    """(scenario, mode, frames, capture bytes, cycles-table bytes, cycle rows, other tables' bytes,
    seconds of traffic) of one axis written in every cycles mode."""
    from pndiss.dataset import write_capture

    caps = simulate_named(out, {k: f"{v} --telegram 81" for k, v in VOLUME_SCENARIOS.items()}, VOLUME_CYCLES)
    rows = []
    for name, path in caps.items():
        for mode in VOLUME_MODES:
            ds = os.path.join(out, f"vol-{name}-{mode.replace(':', '')}")
            shutil.rmtree(ds, ignore_errors=True)
            row = write_capture(path, ds, cycles=mode)
            cyc = du(os.path.join(ds, "cycles"))
            rows.append((name, mode, row["frames"], os.path.getsize(path), cyc, row["cycle_rows"],
                         du(ds) - cyc, row["duration_s"]))
    return rows


def simulate_named(out: str, variants: dict, cycles: int) -> dict:
    from pndiss.cli import main as pndiss

    os.makedirs(out, exist_ok=True)
    paths = {}
    for name, opts in variants.items():
        path = paths[name] = os.path.join(out, f"vol-{name}.pcapng")
        if not os.path.exists(path):
            args = ["simulate", *opts.split(), "--cycles", str(cycles), "--no-expected", "-o", path + ".tmp"]
            if pndiss(args) != 0:
                raise SystemExit(f"simulate failed: {' '.join(args)}")
            os.replace(path + ".tmp", path)
    return paths


def volume_lines(rows) -> list[str]:
    out = ["Dataset volume of one axis (telegram 81, 1 ms, `pndiss simulate --telegram 81 --cycles "
           f"{VOLUME_CYCLES}` with `--scenario startup` or `--scenario motion`), "
           "written by `pndiss.dataset.write_capture(..., cycles=MODE)`:",
           "",
           "| axis | cycles mode | capture MB | cycles rows | cycles table MB | other tables MB | cycles GB per axis-year |",
           "|---|---|---|---|---|---|---|"]
    for name, mode, _frames, cap, cyc, nrows, other, dur in rows:
        per_year = cyc / dur * YEAR_S / 1e9 if dur else float("nan")
        out.append(f"| {name} | {mode} | {cap / 1e6:.1f} | {nrows:,} | {cyc / 1e6:.2f} | {other / 1e6:.2f} | {per_year:.1f} |")
    cap_year = rows[0][3] / rows[0][7] * YEAR_S / 1e9
    out += ["", f"The capture itself: {cap_year:,.0f} GB per axis-year (pcapng). The other tables are the "
            "start-up's facts (stations, ARs, records, parameters, one file each per capture): they grow with "
            "the number of captures and events, not with the run time."]
    return out


def du(path: str) -> int:
    return sum(os.path.getsize(f) for f in glob.glob(os.path.join(path, "**", "*"), recursive=True)
               if os.path.isfile(f))


def write_section(text: str) -> None:
    path = os.path.join(HERE, "RESULTS.md")
    old = open(path, encoding="utf-8").read() if os.path.exists(path) else ""
    block = f"<!-- fleet:begin -->\n{text.rstrip()}\n<!-- fleet:end -->"
    pat = re.compile(r"<!-- fleet:begin -->.*?<!-- fleet:end -->", re.S)
    new = pat.sub(lambda _m: block, old) if pat.search(old) else old.rstrip() + "\n\n" + block + "\n"
    with open(path, "w", encoding="utf-8") as f:
        f.write(new)


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--out", default=os.path.join(HERE, "out"))
    ap.add_argument("--files", default="24,96",
                    help="sizes of the speed-up set, comma-separated: the first N captures of one set "
                         "(the fixed start-up weighs less on more work)")
    ap.add_argument("--set-cycles", type=int, default=SET_CYCLES, help="cycles per capture of the speed-up set")
    ap.add_argument("--small", type=int, default=1000)
    ap.add_argument("--parts", default="speedup,query,volume",
                    help="which parts to measure now (the others keep their last figures from OUT/fleet-results.json)")
    ap.add_argument("--reuse", action="store_true", help="query the 1,000-capture dataset of the last run again")
    args = ap.parse_args()
    parts = set(args.parts.split(","))
    res_path = os.path.join(args.out, "fleet-results.json")
    res = json.load(open(res_path)) if os.path.exists(res_path) else {}
    commit = subprocess.run(["git", "rev-parse", "--short", "HEAD"], capture_output=True, text=True, cwd=ROOT).stdout.strip()
    set_dir = os.path.join(args.out, f"fleet-set-{args.set_cycles}")
    small_dir = os.path.join(args.out, "fleet-small")
    if "speedup" in parts:
        res["speedup"] = {}
        for n in sorted(int(x) for x in args.files.split(",")):
            paths = simulate(set_dir, VARIANTS, n, args.set_cycles)
            res["speedup"][str(n)] = speedup(paths, args.out, args.set_cycles, commit)
    if "query" in parts:
        simulate(small_dir, SMALL_VARIANTS, args.small, SMALL_CYCLES)
        small_ds = os.path.join(args.out, "fleet-small-ds")
        load = os.getloadavg()[0]
        if args.reuse and os.path.isdir(small_ds) and "query" in res:   # the same dataset, queried again
            dt_small, load = res["query"]["fleet_s"], res["query"]["load"]
        else:
            dt_small, _line = fleet([small_dir], small_ds, 2)
        q = query_times(small_ds)
        q.update(n=args.small, fleet_s=dt_small, mb=du(small_ds) / 1e6, load=load, commit=commit)
        res["query"] = q
    if "volume" in parts:
        res["volume"] = {"rows": volumes(args.out), "commit": commit}
    os.makedirs(args.out, exist_ok=True)
    with open(res_path, "w") as f:
        json.dump(res, f, indent=1)
    lines = section(res)
    write_section("\n".join(lines))
    print("\n".join(lines))


def section(res: dict) -> list[str]:
    lines = ["## Fleet (`pndiss fleet` on Dask; DuckDB over the dataset) -- bench/fleet.py", "",
             f"Machine: {platform.machine()}, {os.cpu_count()} CPUs, Python {platform.python_version()}. "
             "The load average is stated per part: on a machine shared with other work (Linux autogroup "
             "scheduling gives each session a fair share of the CPUs), the worker processes of one "
             "`pndiss fleet` share that session's share, and 2 workers cannot beat 1 by much.", ""]
    sets = res.get("speedup") or {}
    if "runs" in sets:   # results of the one-size format
        sets = {str(sets["files"]): sets}
    for key in sorted(sets, key=int):
        r = sets[key]
        runs = {int(k): v for k, v in r["runs"].items()}
        speedup = runs[1][0] / runs[2][0]
        lines += [
            f"Benchmark set of {r['files']} captures (commit {r['commit']}; load average {r['load_before']:.1f} before, "
            f"{r['load_after']:.1f} after): {r['mb']:.0f} MB, {r['frames']:,} frames, the first {r['files']} of "
            f"`pndiss simulate --cycles {r.get('cycles', SET_CYCLES)} --seed I` with, in turn: "
            + "; ".join(f"`{v}`" for v in VARIANTS) + ".",
            "",
            "| run | wall s | CPU s (all processes) | frames/s | frames per CPU s | result |",
            "|---|---|---|---|---|---|",
            *(f"| `pndiss fleet SET -o DS --workers {w}` | {runs[w][0]:.1f} | {runs[w][1]:.1f} | "
              f"{r['frames'] / runs[w][0]:,.0f} | {r['frames'] / runs[w][1]:,.0f} | "
              f"{runs[w][2].split(' -> ')[-1].split(': ', 1)[-1]} |" for w in (1, 2)),
            "",
            f"**{r['files']} captures: 2 workers {speedup:.2f}x one worker** (wall time of the whole command, "
            "cluster start-up included; capture to Parquet dataset, cycles on_change).", ""]
        ph = r.get("phases")
        if ph:
            lines += ["The same work in one process, per phase (`fleet.plan`, `fleet.connect`, `fleet.run_dask`, "
                      "shutdown), wall seconds:", "",
                      "| workers | hash + plan | cluster start | analysis tasks | shutdown | total |",
                      "|---|---|---|---|---|---|",
                      *(f"| {w} | {ph[w]['plan']:.2f} | {ph[w]['start']:.2f} | {ph[w]['tasks']:.2f} | "
                        f"{ph[w]['stop']:.2f} | {sum(ph[w].values()):.2f} |" for w in ("1", "2")), "",
                      f"Analysis tasks on 2 workers: **{ph['1']['tasks'] / ph['2']['tasks']:.2f}x** one worker. "
                      "Hashing (every input is read once to name it by content), cluster start and shutdown "
                      "do not shrink with more workers; the command overlaps hashing with the start.", ""]
    q = res.get("query")
    if q:
        lines += [
            f"1,000-capture dataset (commit {q['commit']}; load average {q['load']:.1f}): {q['n']} captures of "
            f"`pndiss simulate --cycles {SMALL_CYCLES} --seed I` (variants "
            + ", ".join(f"`{v}`" if v else "defaults" for v in SMALL_VARIANTS) + "), analysed by "
            f"`pndiss fleet --workers 2` in {q['fleet_s']:.1f} s ({q['n'] / q['fleet_s']:.1f} captures/s), "
            f"dataset {q['mb']:.1f} MB.", "",
            f"\"Violations by station and rule\" (`{QUERY}`, {q['rows']} rows) with DuckDB:", "",
            "| how | wall s | CPU s |", "|---|---|---|",
            f"| `pndiss query DS \"SQL\" --format csv`, a fresh process (imports included) "
            f"| {q['cold']:.2f} | {q['cold_cpu']:.2f} |",
            f"| warm process: `pndiss.dataset.open(DS, tables=...)` + the query (median of {q['repeat']}) "
            f"| {q['warm']:.2f} | {q['warm_cpu']:.2f} |", ""]
    v = res.get("volume")
    if v:
        lines += [f"(commit {v['commit']}) " + volume_lines(v["rows"])[0], *volume_lines(v["rows"])[1:]]
    return lines


if __name__ == "__main__":
    main()
