"""The Parquet dataset (pndiss/dataset/, docs/dataset.md) and `pndiss query`.

Built from real captures of captures/ (some copied with their clock moved to another day and the
I&M0 software revision changed, as a plant's captures of one encoder over weeks would be); every
table is compared with the JSONL events `pndiss analyze --jsonl` writes for the same capture.
"""
from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
import threading
import time

import pytest
from hypothesis import given, settings as hsettings, strategies as st

pa = pytest.importorskip("pyarrow")
pq = pytest.importorskip("pyarrow.parquet")
duckdb = pytest.importorskip("duckdb")

from pndiss import dataset  # noqa: E402
from pndiss.capture import open_capture  # noqa: E402
from pndiss.dataset.cycles import CycleTable  # noqa: E402
from pndiss.cli import main as cli_main  # noqa: E402
from pndiss.settings import Settings  # noqa: E402
from pndiss.dataset.schema import JSON, KIND_TABLE, TABLES  # noqa: E402
from pndiss.sim.pcapng import Writer  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CAPS = os.path.join(ROOT, "captures")
DAY = 86400 * 10**9
EPOCH = 1_767_225_600 * 10**9   # the simulator's 2026-01-01

# captures compared table by table with their JSONL: faults, capture loss, restarts, presets
COMPARED = ["fault-preset-ack-missing", "plant-rt-loss-t81", "plant-restart-abort", "preset-t89-psm",
            "plant-irt-loss-sol-skip", "plant-mid-session-t83", "preset-t860-hohner", "startup-t89-psm"]


def jsonl_events(cap: str, *opts: str) -> list[dict]:
    out = subprocess.run([sys.executable, "-m", "pndiss", "analyze", cap, "--jsonl", "-", "-q", *opts], cwd=ROOT,
                         env=dict(os.environ, PYTHONPATH=ROOT), capture_output=True, text=True, check=True)
    return [json.loads(line) for line in out.stdout.splitlines()]


def moved(src: str, dst: str, days: int, sw_minor: int | None = None) -> str:
    """Copy of ``src`` with every time stamp ``days`` later and, when given, the I&M0 software
    revision V1.<sw_minor>.0 instead of the simulator's V1.0.0 (after serial number and hardware revision)."""
    with open(dst, "wb") as f:
        w = Writer(f)
        for _fn, ts, _lt, data in open_capture(src):
            data = bytearray(data)
            i = data.find(b"SIM0")
            if sw_minor is not None and i > 0 and data[i + 18:i + 22] == b"V\x01\x00\x00":
                data[i + 20] = sw_minor
            w.write(ts + days * DAY, bytes(data))
    return dst


def one(con, sql: str, *params):
    """The single value of ``sql`` (fetchall: the result is complete before the next statement)."""
    return con.execute(sql, list(params)).fetchall()[0][0]


def rows(ds: str, table: str, capture_hash: str) -> list[dict]:
    path = dataset.table_path(ds, table, capture_hash)
    return pq.read_table(path).to_pylist() if os.path.exists(path) else []


def as_event(row: dict, table: str) -> dict:
    """A row back into the event it came from: its non-null columns (JSON parsed) and ``extra``."""
    types = dict(TABLES[table])
    ev = {}
    for k, v in row.items():
        if k in ("capture_hash", "ts", "extra") or v is None:
            continue
        ev[k] = json.loads(v) if types[k] == JSON else v
    ev.update(json.loads(row["extra"]) if row.get("extra") else {})
    return ev


@pytest.fixture(scope="module")
def built(tmp_path_factory):
    """Dataset of the compared captures (cycles in full) plus their JSONL events."""
    ds = str(tmp_path_factory.mktemp("ds") / "ds")
    out = {}
    for name in COMPARED:
        cap = os.path.join(CAPS, name + ".pcapng")
        row = dataset.write_capture(cap, ds, cycles="full")
        assert row["error"] is None if "error" in row else True
        out[name] = (row, jsonl_events(cap))
    return ds, out


def test_tables_equal_jsonl_events(built):
    ds, caps = built
    seen = set()
    for name, (row, events) in caps.items():
        h = row["capture_hash"]
        assert row["frames"] == max(e["frame"] for e in events)
        for table in sorted(set(KIND_TABLE.values())):
            want = [{k: v for k, v in e.items() if v is not None and (k != "kind" or table == "records")}
                    for e in events if KIND_TABLE.get(e["kind"]) == table]
            got = [as_event(r, table) for r in rows(ds, table, h)]
            assert got == want, (name, table)
            if want:
                seen.add(table)
    # the captures exercise every event table
    assert seen == set(KIND_TABLE.values())


def test_cycles_full_equal_telegram_events(built):
    ds, caps = built
    for name, (row, events) in caps.items():
        tel = [e for e in events if e["kind"] == "telegram"]
        got = rows(ds, "cycles", row["capture_hash"])
        assert row["cycle_rows"] == len(got) == len(tel), name
        key = lambda e: (e["frame"], e["direction"])  # noqa: E731
        for e, r in zip(sorted(tel, key=key), sorted(got, key=key)):
            assert (r["frame"], r["ts_ns"], r["direction"], r["station"], r["slot"], r["subslot"], r["telegram"],
                    r["judged"], r["iops"]) == (e["frame"], e["ts_ns"], e["direction"], e["station"], e["slot"],
                                                e["subslot"], e["telegram"], e["judged"], e["iops"]), name
            assert {k: r[k] for k in e["signals"]} == e["signals"]
            assert {k: r[k] for k in e["bits"]} == e["bits"]
            # a signal or bit the telegram does not have is null, never 0
            assert all(r[k] is None for k, _ in TABLES["cycles"] if "." in k and k not in e["bits"])


@pytest.mark.parametrize("mode", ["on_change", "decimate:7", "on_change,decimate:50"])
def test_cycles_thinned(tmp_path, mode):
    """on_change keeps the value in force at every cycle: the last kept row of the axis at or before a
    frame has that frame's signals (the sign-of-life counters left out: telegrams.CHANGE_MASKS, they step
    every cycle); decimate:N keeps every Nth row of each axis and direction."""
    from pndiss.telegrams import CHANGE_MASKS
    cap = os.path.join(CAPS, "preset-t81-lika.pcapng")
    ds = str(tmp_path / "ds")
    h = dataset.write_capture(cap, ds, cycles=mode, keyframe_s=0.25)["capture_hash"]
    got = rows(ds, "cycles", h)
    tel = [e for e in jsonl_events(cap) if e["kind"] == "telegram"]
    assert 0 < len(got) < len(tel)
    by_axis: dict = {}
    for r in got:
        by_axis.setdefault((r["device_mac"], r["slot"], r["subslot"], r["direction"]), []).append(r)
    if mode.startswith("decimate"):
        n = int(mode.split(":")[1])
        for k, rs in by_axis.items():
            frames = [e["frame"] for e in tel if (e["device_mac"], e["slot"], e["subslot"], e["direction"]) == k]
            assert [r["frame"] for r in rs] == frames[::n]
        return
    for e in tel:
        rs = by_axis[(e["device_mac"], e["slot"], e["subslot"], e["direction"])]
        last = max((r for r in rs if r["frame"] <= e["frame"]), key=lambda r: r["frame"])
        m = CHANGE_MASKS
        assert {k: last[k] & m.get(k, -1) for k in e["signals"]} == {k: v & m.get(k, -1) for k, v in e["signals"].items()}
        assert last["judged"] == e["judged"]
    for rs in by_axis.values():   # a keyframe at least every slot of 0.25 s
        ts = [r["ts_ns"] for r in rs]
        assert max(b - a for a, b in zip(ts, ts[1:])) < 0.5e9


def _batch(n, start=0, station="enc-1"):
    import numpy as np

    from pndiss.sinks import CycleBatch
    i = np.arange(start, start + n, dtype=np.int64)
    return CycleBatch(axis={"station": station, "device_mac": "02:00:00:00:00:01", "api": 0x3D00, "slot": 1,
                            "subslot": 2, "telegram": 81, "telegram_source": "connect", "profile": "generic"},
                      direction="actual", frame_id=0x8001, frame=i, ts_ns=i * 1_000_000,
                      iops=np.full(n, 0x80, np.int16), judged=np.ones(n, bool),
                      signals={"g1_xist1": i * 3, "g1_zsw": np.full(n, 0x2000, np.int64)})


def test_cycles_writer_thread(tmp_path, monkeypatch):
    """Row groups of the cycles table are encoded and written on a thread: what was added is what is
    written (the axis as it was when added, rows in frame order), at most one row group is in flight,
    and an error on the thread (a full disk) is raised in the caller's thread, never lost or hung on."""
    import pyarrow.parquet as pq

    from pndiss.dataset import cycles
    monkeypatch.setattr(cycles, "COALESCE", 16)
    monkeypatch.setattr(cycles, "ROW_GROUP", 32)
    t = CycleTable(str(tmp_path / "c.parquet"), "0" * 64, "full")
    in_flight, most, where = [0], [0], []
    real_write = pq.ParquetWriter.write_table

    def slow_write(self, table, *a, **k):
        in_flight[0] += 1
        most[0] = max(most[0], in_flight[0])
        where.append(threading.current_thread() is threading.main_thread())
        time.sleep(0.005)
        real_write(self, table, *a, **k)
        in_flight[0] -= 1
    monkeypatch.setattr(pq.ParquetWriter, "write_table", slow_write)
    for k in range(50):
        b = _batch(10, 10 * k)
        t.add(b)
        b.axis["station"] = "renamed later"   # the engine's dict may change after the hand-over
    assert t.close() == 500
    tab = pq.read_table(str(tmp_path / "c.parquet"))
    assert tab.column("frame").to_pylist() == list(range(500))
    assert set(tab.column("station").to_pylist()) == {"enc-1"}
    assert most[0] == 1 and where and not any(where)   # off the caller's thread, one at a time
    # without the thread (a Dask worker, one core): the same file, written by the caller
    where.clear()
    t2 = CycleTable(str(tmp_path / "c2.parquet"), "0" * 64, "full", write_thread=False)
    for k in range(50):
        t2.add(_batch(10, 10 * k))
    assert t2.close() == 500 and pq.read_table(str(tmp_path / "c2.parquet")).equals(tab)
    assert where and all(where)
    # an axis whose shape changes every batch (two frame IDs): row groups are still written as
    # they fill, not all held until the end
    t3 = CycleTable(str(tmp_path / "c3.parquet"), "0" * 64, "full")
    for k in range(40):
        b = _batch(5, 5 * k)
        b.frame_id = 0x8001 + k % 2
        t3.add(b)
        if k == 30:
            assert t3.rows >= 64 or in_flight[0]   # written (or being written) before close
    assert t3.close() == 200 and pq.ParquetFile(str(tmp_path / "c3.parquet")).metadata.num_row_groups > 2
    monkeypatch.undo()

    def full_disk(self, table, *a, **k):
        raise OSError(28, "No space left on device")
    monkeypatch.setattr(pq.ParquetWriter, "write_table", full_disk)
    monkeypatch.setattr(cycles, "COALESCE", 16)
    monkeypatch.setattr(cycles, "ROW_GROUP", 32)
    for n in (3, 2000):   # raised at close, or at a later add
        t = CycleTable(str(tmp_path / f"d{n}.parquet"), "0" * 64, "full")
        with pytest.raises(OSError, match="No space"):
            for k in range(n):
                t.add(_batch(16, 16 * k))
            t.close()
        assert t.rows == 0   # nothing counted that is not in the file
        with pytest.raises(OSError, match="No space"):   # and close() after it says so again
            t.close()
        t.abort()   # what the dataset writer does next: returns, no thread left
        assert not [th for th in threading.enumerate() if th.name.startswith("pndiss-parquet-cycles")]


def test_schema_and_metadata(built):
    ds, caps = built
    for table in TABLES:
        for f in dataset.files(ds, table):
            s = pq.read_schema(f)
            assert s.metadata[b"pndiss.schema_version"] == str(dataset.SCHEMA_VERSION).encode()
            assert s.metadata[b"pndiss.table"] == table.encode()
            assert [(x.name, x.type) for x in s] == [(n, pa.string() if t == JSON else t) for n, t in TABLES[table]]
    con = dataset.open(ds)
    assert one(con, "SELECT count(*) FROM captures") == len(caps)
    assert set(con.execute("SELECT DISTINCT schema_version FROM captures").fetchall()) == {(dataset.SCHEMA_VERSION,)}


def test_failures_recorded_and_interruption_leaves_nothing(tmp_path, monkeypatch):
    ds = str(tmp_path / "ds")
    bad = tmp_path / "notes.pcapng"
    bad.write_text("not a capture")
    trunc = tmp_path / "cut.pcapng"
    trunc.write_bytes(open(os.path.join(CAPS, "fault-preset-ack-missing.pcapng"), "rb").read()[:40000])
    r1 = dataset.write_capture(str(bad), ds)
    r2 = dataset.write_capture(str(trunc), ds)
    assert "not a" in r1["error"] and r1.get("frames") is None
    assert r2["error"] and r2["frames"] > 0   # what was read before the damage is kept
    con = dataset.open(ds)
    assert sorted(x[0] is not None for x in con.execute("SELECT error FROM captures").fetchall()) == [True, True]
    assert one(con, "SELECT count(*) FROM cycles") > 0
    # a process killed while writing: no file under a real name, no temporary left behind
    from pndiss.dataset import sink as sink_mod

    def killed(self):
        raise KeyboardInterrupt
    cap = os.path.join(CAPS, "preset-t81-lika.pcapng")
    monkeypatch.setattr(sink_mod.ParquetSink, "close", killed)
    with pytest.raises(KeyboardInterrupt):
        dataset.write_capture(cap, ds)
    monkeypatch.undo()
    # ... and interrupted in the middle of the analysis, with the cycles file open
    calls = []
    opened = []

    def killed_late(self, batch, orig=sink_mod.ParquetSink.cycle_batch):
        calls.append(1)
        if opened:   # the first batch after one was written (how the engine batches is not this test's business)
            raise KeyboardInterrupt
        orig(self, batch)
    monkeypatch.setattr(sink_mod.ParquetSink, "cycle_batch", killed_late)
    monkeypatch.setattr("pndiss.dataset.cycles.ROW_GROUP", 16)
    monkeypatch.setattr("pndiss.dataset.cycles.COALESCE", 1)
    real_write = CycleTable._write
    monkeypatch.setattr(CycleTable, "_write", lambda self: (real_write(self), opened.append(self.writer)))
    with pytest.raises(KeyboardInterrupt):
        dataset.write_capture(cap, ds, cycles="full")
    monkeypatch.undo()
    assert len(calls) >= 2 and opened and opened[-1] is not None   # the cycles file was open
    h = dataset.content_hash(cap)
    assert h not in dataset.done_hashes(ds)
    assert not [n for t in TABLES for n in os.listdir(os.path.join(ds, t)) if n.startswith(".")]
    # a table file whose capture row never came (killed between the renames) is not seen
    orphan = dataset.table_path(ds, "violations", h)
    pq.write_table(pa.table({"capture_hash": [h], "rule": ["X"]}), orphan)
    assert one(dataset.open(ds), "SELECT count(*) FROM violations WHERE rule = 'X'") == 0
    row = dataset.write_capture(cap, ds)   # the re-run replaces it
    assert h in dataset.done_hashes(ds) and not os.path.exists(orphan)
    assert row["violations"] == one(dataset.open(ds), "SELECT count(*) FROM violations WHERE capture_hash = ?", h)


# -- the questions of issue #14 -------------------------------------------------------------------

@pytest.fixture(scope="module")
def plant(tmp_path_factory):
    """One plant's captures over two months: encoder firmware V1.0.0 until 2026-02-20, then V1.1.0
    (I&M0 read at each start-up);
    a preset acknowledge missing in January and in February; sign-of-life faults only after the update."""
    d = tmp_path_factory.mktemp("plant")
    caps = [
        moved(os.path.join(CAPS, "fault-preset-ack-missing.pcapng"), str(d / "jan-preset.pcapng"), 9),
        moved(os.path.join(CAPS, "startup-t81-generic.pcapng"), str(d / "feb-start.pcapng"), 35),
        moved(os.path.join(CAPS, "fault-preset-ack-missing.pcapng"), str(d / "feb-preset.pcapng"), 40),
        moved(os.path.join(CAPS, "plant-rt-loss-t81.pcapng"), str(d / "feb-loss.pcapng"), 45),
        moved(os.path.join(CAPS, "fault-sol-device-skip.pcapng"), str(d / "feb-sol.pcapng"), 51, 1),
        moved(os.path.join(CAPS, "fault-sol-master-skip.pcapng"), str(d / "mar-sol.pcapng"), 62, 1),
        os.path.join(CAPS, "startup-t81-generic-3enc.pcapng"),
    ]
    ds = str(d / "ds")
    for c in caps:   # this plant monitors the sign-of-life on RT too
        assert dataset.write_capture(c, ds, Settings(sol_monitor_rt=True), cycles="none").get("error") is None
    return ds, caps


def test_which_encoders_had_preset_ack_missing_last_month(plant):
    ds, _ = plant
    con = dataset.open(ds)
    got = con.execute("""
        SELECT DISTINCT c.file, v.station, v.device_mac, v.slot, v.subslot
        FROM violations v JOIN captures c USING (capture_hash)
        WHERE v.rule = 'PRESET-ACK-MISSING'
          AND v.ts >= date_trunc('month', TIMESTAMP '2026-03-05') - INTERVAL 1 MONTH
          AND v.ts <  date_trunc('month', TIMESTAMP '2026-03-05')""").fetchall()
    assert [(os.path.basename(f), *rest) for f, *rest in got] == [
        ("feb-preset.pcapng", "encoder-1", "02:00:00:00:01:01", 1, 2)]


FIRMWARE_SQL = """
    WITH fw AS (
        SELECT station, ts, json_extract_string(decoded, '$.sw_revision_prefix')
               || json_extract(decoded, '$.sw_revision_functional_enhancement')::VARCHAR || '.'
               || json_extract(decoded, '$.sw_revision_bug_fix')::VARCHAR AS rev
        FROM records WHERE kind = 'record' AND "index" = 45040),     -- I&M0
    upd AS (SELECT station, min(ts) AS t FROM fw WHERE rev = ? GROUP BY station),
    sol AS (SELECT station, min(ts) AS first_fault FROM violations WHERE rule LIKE 'SOL-%' GROUP BY station)
    SELECT sol.station, sol.first_fault >= upd.t AS after_update
    FROM sol JOIN upd USING (station)"""


def test_sign_of_life_faults_started_after_the_firmware_update(plant):
    ds, _ = plant
    con = dataset.open(ds)
    assert con.execute(FIRMWARE_SQL, ["V1.1"]).fetchall() == [("encoder-1", True)]
    # the same question about the firmware before: faults seen with it? no, they began later
    assert con.execute(FIRMWARE_SQL, ["V1.0"]).fetchall() == [("encoder-1", True)]
    first_new = one(con, "SELECT min(ts) FROM records WHERE \"index\" = 45040 AND decoded LIKE "
                         "'%\"sw_revision_bug_fix\":1%'")
    assert str(first_new).startswith("2026-02-21")
    # and it can be answered "no": a fault moved before the update makes it false
    con.execute("CREATE TABLE v2 AS SELECT * FROM violations")
    con.execute("UPDATE v2 SET ts = TIMESTAMP '2026-01-05' WHERE rule LIKE 'SOL-%' AND station = 'encoder-1' "
                "AND frame = (SELECT min(frame) FROM v2 WHERE rule LIKE 'SOL-%')")
    assert con.execute(FIRMWARE_SQL.replace("FROM violations", "FROM v2"), ["V1.1"]).fetchall() == [
        ("encoder-1", False)]


def test_violations_by_station_and_rule(plant):
    ds, caps = plant
    want: dict = {}
    for c in caps:
        for e in jsonl_events(c, "--set", "sol_monitor_rt=1"):
            if e["kind"] == "violation":
                k = (e.get("station"), e["rule"])
                want[k] = want.get(k, 0) + 1
    got = dataset.open(ds).execute("SELECT station, rule, count(*) FROM violations GROUP BY ALL").fetchall()
    assert {(s, r): n for s, r, n in got} == want and len(want) >= 3


def test_query_command(plant, capsys):
    ds, _ = plant
    assert cli_main(["query", ds, "SELECT station, rule, count(*) AS n FROM violations GROUP BY ALL ORDER BY n DESC",
                     "--format", "json"]) == 0
    out = [json.loads(line) for line in capsys.readouterr().out.splitlines()]
    assert out and all(set(r) == {"station", "rule", "n"} for r in out)
    assert cli_main(["query", ds, "SELECT file, first_ts FROM captures ORDER BY file", "--format", "csv"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == "file,first_ts" and len(lines) == 8 and "2026-02-" in lines[2]
    # wire strings in the terminal table are shown inert
    assert cli_main(["query", ds, "SELECT 'enc[/]' || chr(27) || ']0;pwn' AS name"]) == 0
    out = capsys.readouterr().out
    assert "\x1b" not in out and "enc[/]\\x1b]0;pwn" in out
    for argv, msg in ((["query", ds, "SELEC 1"], "query failed"),
                      (["query", ds, "SELECT * FROM nope"], "query failed"),
                      (["query", os.path.join(ds, "missing"), "SELECT 1"], "no such dataset"),
                      (["query", os.path.dirname(ds), "SELECT 1"], "not a pndiss dataset")):
        assert cli_main(argv) == 2
        err = capsys.readouterr().err
        assert msg in err and "Traceback" not in err and len(err.strip().splitlines()) == 1


def test_older_schema_files_read_with_the_new(built, tmp_path):
    """A dataset holding files of two schema versions: columns are united by name, a column the
    older file lacks reads as null."""
    ds, caps = built
    d = str(tmp_path / "mixed")
    shutil.copytree(ds, d)
    h = "0" * 64
    pq.write_table(pa.table({"capture_hash": [h], "file": ["old.pcapng"], "frames": [3], "schema_version": [0]}),
                   dataset.table_path(d, "captures", h))
    pq.write_table(pa.table({"capture_hash": [h], "frame": [2], "rule": ["OLD-RULE"], "station": ["old"]}),
                   dataset.table_path(d, "violations", h))
    open(os.path.join(d, "_versions", "0"), "w").close()
    con = dataset.open(d)
    assert con.execute("SELECT severity, frame FROM violations WHERE rule = 'OLD-RULE'").fetchall() == [(None, 2)]
    assert one(con, "SELECT count(*) FROM captures") == len(caps) + 1


JSONISH = st.recursive(st.none() | st.booleans() | st.integers(-(1 << 70), 1 << 70) | st.text(max_size=8),
                       lambda c: st.lists(c, max_size=3) | st.dictionaries(st.text(max_size=5), c, max_size=3),
                       max_leaves=6)


@hsettings(max_examples=150, deadline=None)
@given(kind=st.sampled_from(sorted(KIND_TABLE)),
       fields=st.dictionaries(st.sampled_from(["station", "rule", "slot", "ok", "params", "decoded", "cycles",
                                               "message", "value", "extra", "phase", "zz_new", "ts"]) | st.text(max_size=6),
                              JSONISH, max_size=6))
def test_rows_keep_every_field(kind, fields):
    """Whatever an event carries -- declared or not, of the declared type or not -- its row gives it
    back: declared columns keep their type, the rest goes to ``extra``."""
    from pndiss.dataset.rows import TableRows
    ev = {**fields, "frame": 7, "ts_ns": 10**18, "kind": kind}
    table = KIND_TABLE[kind]
    tr = TableRows(table, "h")
    tr.add(ev)
    t = tr.table()   # typed as declared, or this raises
    row = t.to_pylist()[0]
    want = {k: v for k, v in json.loads(json.dumps(ev)).items()
            if v is not None and (k != "kind" or table == "records")}
    assert as_event(row, table) == want


def test_stations_axes_and_captures_equal_the_summary(built, tmp_path):
    ds, caps = built
    name = "plant-restart-abort"
    cap = os.path.join(CAPS, name + ".pcapng")
    out = str(tmp_path / "s.json")
    subprocess.run([sys.executable, "-m", "pndiss", "analyze", cap, "--summary-json", out, "-q"], cwd=ROOT,
                   env=dict(os.environ, PYTHONPATH=ROOT), capture_output=True, check=True)
    summ = json.load(open(out))
    row, _ = caps[name]
    h = row["capture_hash"]
    assert [as_event(r, "stations") for r in rows(ds, "stations", h)] == [
        {k: v for k, v in s.items() if v is not None} for s in summ["stations"]]
    assert [as_event(r, "axes") for r in rows(ds, "axes", h)] == [
        {k: v for k, v in e.items() if v is not None} for e in summ["cyclic"]["encoders"]]
    (c,) = rows(ds, "captures", h)
    assert (c["frames"], c["decoded"], c["not_profinet"], c["malformed"], c["first_ts_ns"], c["last_ts_ns"]) == (
        summ["frames"], *summ["accounting"].values(), summ["first_ts_ns"], summ["last_ts_ns"])
    assert json.loads(c["settings"]) == summ["settings"]
    # event counts as the analyser made them (today's reference path adds the telegram events it
    # builds for the cycles table; the terminal run's fast path has none)
    events = json.loads(c["events"])
    assert events.pop("telegram", 0) > 0 and events == {k: v for k, v in summ["events"].items() if k != "telegram"}
    assert c["violations"] == summ["verdict"]["total"] and c["file"] == cap
    assert c["capture_hash"] == dataset.content_hash(cap) and c["cycles_mode"] == "full"


# -- Arrow arrays built from their buffers (pndiss/dataset/arrays.py) ---------------------------
_TYPES = [pa.int64(), pa.int32(), pa.int16(), pa.uint8(), pa.uint64(), pa.bool_(), pa.float64(), pa.string(),
          pa.timestamp("ns")]


def _values(t):
    if pa.types.is_string(t):
        return st.text()
    if pa.types.is_boolean(t):
        return st.booleans()
    if pa.types.is_floating(t):
        return st.floats(allow_nan=False)
    if pa.types.is_timestamp(t):
        return st.integers(-2**63, 2**63 - 1)
    bits, signed = t.bit_width, pa.types.is_signed_integer(t)
    return st.integers(-2 ** (bits - 1) if signed else 0, 2 ** (bits - 1) - 1 if signed else 2 ** bits - 1)


@st.composite
def _typed_values(draw):
    t = draw(st.sampled_from(_TYPES))
    return t, draw(st.lists(st.none() | _values(t), max_size=40))


@hsettings(max_examples=300, deadline=None)
@given(_typed_values(), st.integers(0, 70))
def test_arrays_equal_pa_array(tv, n):
    """The buffer-built arrays equal pa.array's, nulls and all; repeats equal n scalars."""
    from pndiss.dataset import arrays
    np = pytest.importorskip("numpy")
    t, values = tv
    got = arrays.column(values, t)
    assert got.type == t and got.validate(full=True) is None
    assert got.equals(pa.array(values, t))
    present = [v for v in values if v is not None]
    if present:
        assert arrays.repeat(present[0], t, n).equals(pa.array([present[0]] * n, t))
        if not pa.types.is_string(t) and not pa.types.is_timestamp(t):
            a = np.array(present, t.to_pandas_dtype())
            assert arrays.numeric(a[::2]).equals(pa.array(a[::2]))   # a strided view too
    assert arrays.repeat(None, t, n).equals(pa.nulls(n, t))


@hsettings(max_examples=200, deadline=None)
@given(st.lists(st.none() | st.integers(-2**63, 2**63 - 1), max_size=30))
def test_ts_array_cuts_as_arrow_casts(ns):
    """ts: ns since the epoch cut toward zero to µs, as the two casts pa.array(...).cast(ns).cast(us,
    safe=False) cut (lists with nulls, and numpy columns)."""
    np = pytest.importorskip("numpy")
    from pndiss.dataset.schema import TS, ts_array
    want = pa.array(ns, pa.int64()).cast(pa.timestamp("ns")).cast(TS, safe=False)
    assert ts_array(ns).equals(want)
    full = [0 if v is None else v for v in ns]
    assert ts_array(np.array(full, np.int64)).equals(pa.array(full, pa.int64()).cast(pa.timestamp("ns")).cast(TS, safe=False))


def test_writing_a_dataset_does_not_import_pandas(tmp_path):
    """pa.array's pandas check imports pandas (0.2 s, ~40 MB) in every capture process: not ours."""
    cap = os.path.join(CAPS, "plant-rt-loss-t81.pcapng")
    code = ("import sys; from pndiss import dataset; from pndiss.settings import Settings; "
            f"dataset.write_capture({cap!r}, {str(tmp_path / 'ds')!r}, Settings(), cycles='full'); "
            "print('pandas' in sys.modules)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, cwd=ROOT, timeout=120)
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip().splitlines()[-1] == "False"


def test_event_tables_flushed_as_row_groups(tmp_path, monkeypatch):
    """An event table goes to its file in row groups of FLUSH_ROWS while the capture runs (memory flat over a long
    plant capture's parameter polls), and reads back whole: every row, in order, the same as one write."""
    import pyarrow.parquet as pq
    from pndiss.dataset import sink as S
    monkeypatch.setattr(S, "FLUSH_ROWS", 4)
    paths = {}

    def path_of(t):
        paths[t] = str(tmp_path / f"{t}.parquet")
        return paths[t]
    snk = S.ParquetSink(path_of, "h" * 64, cycles_mode="none")
    evs = [{"kind": "param", "frame": 10 + i, "ts_ns": 1_000 * i, "station": "enc", "device_mac": "m",
            "request_ref": i % 256, "ok": True, "params": [{"pnu": 979, "values": [i]}]} for i in range(11)]
    for ev in evs:
        snk.event(ev)
    snk.close()
    f = pq.ParquetFile(paths["params"])
    t = f.read()
    assert f.metadata.num_row_groups == 3 and snk.written["params"] == 11
    assert t.column("frame").to_pylist() == [e["frame"] for e in evs]
    assert t.column("request_ref").to_pylist() == [e["request_ref"] for e in evs]
