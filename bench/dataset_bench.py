"""Dataset benchmarks (issue #14): the Parquet sink's cycles table and a query over 1,000 captures.

    PYTHONPATH=. python3 bench/dataset_bench.py [--rows N] [--captures N]

1. The ``cycles`` writer fed engine-sized CycleBatches (64 k rows) of one moving axis: rows/s taken
   in, per mode (full, on_change, decimate:10), and the file size.
2. A dataset of N captures (the real captures of captures/ analysed once, their tables copied under
   N content hashes): `dataset.open` + "violations by station and rule" in DuckDB, best of 3.
About a minute on this machine (the rates are also given per CPU second: on a shared machine the
wall clock measures the neighbours); nothing is written outside a temporary directory.
"""
from __future__ import annotations

import argparse
import glob
import hashlib
import os
import sys
import tempfile
import time

import numpy as np
import pyarrow.parquet  # noqa: F401  (imported before the clock starts)

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from pndiss import dataset  # noqa: E402
from pndiss.dataset.cycles import CycleTable  # noqa: E402
from pndiss.dataset.reader import referenced  # noqa: E402
from pndiss.sinks import CycleBatch  # noqa: E402

AXIS = {"station": "encoder-1", "device_mac": "02:00:00:00:01:01", "api": 0x3D00, "slot": 1, "subslot": 2,
        "telegram": 81, "telegram_source": "connect", "profile": "generic"}


def sink_rate(n: int, mode: str, tmp: str) -> tuple[float, float, int, int]:
    i = np.arange(n, dtype=np.int64)
    ts = 1_767_225_600 * 10**9 + i * 1_000_000
    x1 = i * 7                                           # a moving axis: every row changes
    sig = {"zsw2_enc": ((i % 15) + 1) << 12 | (1 << 9), "g1_zsw": np.full(n, 0x2000, np.int64),
           "g1_xist1": x1, "g1_xist2": x1}
    path = os.path.join(tmp, f"cycles-{mode.replace(':', '')}.parquet")
    t = CycleTable(path, "0" * 64, mode)
    step = 1 << 16
    t0, c0 = time.perf_counter(), time.process_time()
    for s in range(0, n, step):
        sl = slice(s, s + step)
        m = len(i[sl])
        t.add(CycleBatch(axis=AXIS, direction="actual", frame_id=0x8000, frame=i[sl] * 2, ts_ns=ts[sl],
                         iops=np.full(m, 0x80, np.int16), judged=np.ones(m, bool),
                         signals={k: v[sl] for k, v in sig.items()}))
    rows = t.close()
    dt, cpu = time.perf_counter() - t0, time.process_time() - c0
    return n / dt, n / cpu, rows, os.path.getsize(path) if rows else 0


def many_captures(n: int, tmp: str) -> str:
    import pyarrow as pa
    import pyarrow.parquet as pq

    real = os.path.join(tmp, "real")
    for cap in sorted(glob.glob(os.path.join(ROOT, "captures", "*.pcapng")))[::6]:
        dataset.write_capture(cap, real, cycles="none")
    tables = {}
    for h in dataset.done_hashes(real):
        tables[h] = {t: pq.read_table(dataset.table_path(real, t, h)) for t in dataset.TABLES
                     if os.path.exists(dataset.table_path(real, t, h))}
    out = os.path.join(tmp, "many")
    srcs = sorted(tables)
    for k in range(n):
        fake = hashlib.sha256(f"capture {k}".encode()).hexdigest()
        for t, tab in tables[srcs[k % len(srcs)]].items():
            os.makedirs(os.path.join(out, t), exist_ok=True)
            tab = tab.set_column(0, "capture_hash", pa.array([fake] * len(tab), pa.string()))
            pq.write_table(tab, dataset.table_path(out, t, fake))
    os.makedirs(os.path.join(out, "_versions"), exist_ok=True)
    open(os.path.join(out, "_versions", str(dataset.SCHEMA_VERSION)), "w").close()
    return out


def main() -> None:
    ap = argparse.ArgumentParser()
    ap.add_argument("--rows", type=int, default=1_000_000)
    ap.add_argument("--captures", type=int, default=1000)
    a = ap.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        print(f"cycles writer, one moving axis, {a.rows:,} rows in 64 k-row batches:")
        for mode in ("full", "on_change", "decimate:10"):
            rate, cpu_rate, rows, size = sink_rate(a.rows, mode, tmp)
            # per CPU second too: on a shared machine the wall clock measures the neighbours
            print(f"  {mode:12s} {rate / 1e6:5.2f} M rows/s taken ({cpu_rate / 1e6:5.2f} M per CPU second), "
                  f"{rows:9,} rows written, {size / 1e6:6.2f} MB")
        t0 = time.perf_counter()
        ds = many_captures(a.captures, tmp)
        print(f"dataset of {a.captures:,} captures made in {time.perf_counter() - t0:.1f} s")
        q = "SELECT station, rule, count(*) FROM violations GROUP BY ALL"
        best = None
        for _ in range(3):
            t0 = time.perf_counter()
            con = dataset.open(ds, tables=referenced(q))
            rows = con.execute(q).fetchall()
            dt = time.perf_counter() - t0
            best = dt if best is None else min(best, dt)
        print(f"  violations by station and rule: {len(rows)} groups, {sum(r[2] for r in rows):,} violations, "
              f"open + query {best:.3f} s (best of 3)")


if __name__ == "__main__":
    main()
