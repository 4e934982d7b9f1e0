"""`pndiss fleet` on a real dask.distributed LocalCluster of 2 worker processes (issue #14 item 2).

Over 24 captures of captures/ (and one longer simulated one): the dataset equals a sequential run's,
a worker killed while it analyses loses nothing (its file is analysed again and written from scratch),
a second run does no work, failures are recorded in ``captures`` and do not stop the rest.
"""
from __future__ import annotations

import glob
import gzip
import os
import shutil
import signal
import subprocess
import sys
import time

import pytest

distributed = pytest.importorskip("distributed", reason="dask.distributed not installed (pip install distributed)")
pq = pytest.importorskip("pyarrow.parquet", reason="pyarrow not installed")

from pndiss import fleet  # noqa: E402
from pndiss.capture import ReadInfo, open_capture  # noqa: E402
from pndiss.cli import main  # noqa: E402
from pndiss.fleet_inputs import content_hash, find_captures  # noqa: E402
from pndiss.fleet_store import DatasetStore  # noqa: E402
from pndiss.settings import Settings  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
ALL = sorted(glob.glob(os.path.join(ROOT, "captures", "*.pcapng")))
# every plant-like capture, then fault captures to make 24 (each its own violations)
CAPS = ([p for p in ALL if os.path.basename(p).startswith("plant-")]
        + [p for p in ALL if os.path.basename(p).startswith("fault-")])[:24]
VOLATILE = {"written_at"}   # the one column that differs between two writes of the same capture


@pytest.fixture(scope="module")
def inputs(tmp_path_factory):
    """24 captures in two folders (a directory input and a glob input) plus a longer one."""
    d = tmp_path_factory.mktemp("fleet-in")
    for i, p in enumerate(CAPS):
        sub = d / ("a" if i % 2 else "b")
        sub.mkdir(exist_ok=True)
        shutil.copy(p, sub / os.path.basename(p))
    long = d / "long" / "long.pcapng"   # a task that runs for seconds: the one whose worker is killed
    long.parent.mkdir()
    assert main(["simulate", "--encoders", "2", "--io-devices", "1", "--cycles", "3000", "--seed", "7",
                 "--no-expected", "-o", str(long)]) == 0
    return d


@pytest.fixture(scope="module")
def client():
    cluster = fleet.local_cluster(2)
    c = distributed.Client(cluster)
    yield c
    c.close()
    cluster.close()


@pytest.fixture(scope="module")
def sequential(inputs, tmp_path_factory):
    """The reference: every input in this process, one after another."""
    root = str(tmp_path_factory.mktemp("seq"))
    store = DatasetStore(root)
    p = fleet.plan(find_captures([str(inputs)]), store)
    out = fleet.run_local(p.todo, store, Settings(), "on_change")
    assert [o.status for o in out] == ["analysed"] * len(out)
    return root


def snapshot(root: str) -> dict:
    """table -> its rows (volatile columns dropped), order-normalised."""
    out = {}
    for table in sorted(os.listdir(root)):
        files = sorted(glob.glob(os.path.join(root, table, "*.parquet")))
        rows = []
        for f in files:
            for r in pq.read_table(f).to_pylist():
                rows.append(tuple(sorted((k, repr(v)) for k, v in r.items() if k not in VOLATILE)))
        out[table] = sorted(rows)
    return out


def test_inputs_dirs_globs_files_and_content_hash(inputs, tmp_path):
    found = find_captures([str(inputs / "a"), str(inputs / "b" / "*.pcapng"), str(inputs / "long" / "long.pcapng"),
                           str(inputs / "a")])   # named twice: once
    assert len(found) == len(CAPS) + 1 == len(set(found))
    # the skip hash is the reader's own hash (ReadInfo), also through gzip
    plain = CAPS[0]
    gz = tmp_path / "x.pcapng.gz"
    gz.write_bytes(gzip.compress(open(plain, "rb").read()))
    for path in (plain, str(gz)):
        info = ReadInfo()
        for _ in open_capture(path, info=info):
            pass
        assert content_hash(path) == info.sha256() != ""
    assert find_captures([str(tmp_path)]) == [str(gz)]   # .gz captures are found in directories
    # a digest the plan took already is not taken again: the reader reports it (read to the end) ...
    import pndiss.readinfo as capture_mod

    class NoHash:
        def __init__(self, *a):
            raise AssertionError("hashed again")
    real_sha = capture_mod.hashlib.sha256
    capture_mod.hashlib.sha256 = NoHash
    try:
        known = ReadInfo("ab" * 32)
        frames = sum(1 for _ in open_capture(plain, info=known))
    finally:
        capture_mod.hashlib.sha256 = real_sha
    assert known.sha256() == "ab" * 32 and frames > 0
    # ... and the analysis it feeds is the same
    from pndiss.driver import analyze
    a, b = analyze(plain), analyze(plain, known_sha256="ab" * 32)
    assert a.summary() == b.summary() and b.reader.sha256() == "ab" * 32


def test_parallel_equals_sequential_and_rerun_does_nothing(inputs, client, sequential, tmp_path, capsys):
    addr = client.scheduler.address
    root = str(tmp_path / "ds")
    args = ["fleet", str(inputs / "a"), str(inputs / "b" / "*.pcapng"), str(inputs / "long"), "-o", root,
            "--scheduler", addr, "--no-progress"]
    assert main(args) == 0
    err = capsys.readouterr().err
    n = len(CAPS) + 1
    assert f"{n} analysed, 0 skipped" in err
    assert snapshot(root) == snapshot(sequential)
    mtimes = {f: os.stat(f).st_mtime_ns for f in glob.glob(os.path.join(root, "*", "*"))}
    assert main(args) == 0   # the second run: every capture is done
    err = capsys.readouterr().err
    assert f"0 analysed, {n} skipped" in err
    assert {f: os.stat(f).st_mtime_ns for f in glob.glob(os.path.join(root, "*", "*"))} == mtimes
    # a copy under another name (compressed) is the same capture: still no work
    gz = tmp_path / "more" / "again.pcapng.gz"
    gz.parent.mkdir()
    gz.write_bytes(gzip.compress(open(CAPS[3], "rb").read()))
    assert main(args[:4] + [str(gz.parent)] + args[4:]) == 0
    assert f"0 analysed, {n} skipped (already in the dataset), 1 duplicate(s)" in capsys.readouterr().err


def test_local_workers_pinned_one_per_core_and_warm(client):
    """Each worker of the local cluster is set up by pndiss/fleet_worker.py as it starts: on a
    core of its own (when there are cores enough) and with the dataset writer already imported."""
    cores = sorted(os.sched_getaffinity(0))
    pinned = client.run(os.sched_getaffinity, 0)
    if len(cores) == 2:
        assert all(len(c) == 1 for c in pinned.values())
        assert len(set().union(*pinned.values())) == 2   # two workers, two cores
    else:
        assert all(c == set(cores) for c in pinned.values())   # not a worker per core: left to the OS
    loaded = client.run(lambda: all(m in sys.modules for m in ("pyarrow.parquet", "pndiss.dataset.writer")))
    assert all(loaded.values())
    pools = client.run(lambda: __import__("pyarrow").default_memory_pool().backend_name)
    assert set(pools.values()) == {"system"}   # fleet_worker.arrow_pool_env


def test_the_fleet_command_writes_with_the_system_allocator(tmp_path):
    """`pndiss fleet --workers 0` analyses in its own process: Arrow's pool is chosen before pyarrow's
    import; a pool the user chose stays."""
    code = ("import sys; from pndiss.cli import main; r = main(sys.argv[1:]); "
            "import pyarrow as pa; print(pa.default_memory_pool().backend_name)")
    args = [CAPS[0], "-o", str(tmp_path / "ds"), "--workers", "0", "-q"]
    env = {k: v for k, v in os.environ.items() if k != "ARROW_DEFAULT_MEMORY_POOL"}
    out = subprocess.run([sys.executable, "-c", code, "fleet", *args], capture_output=True, text=True, env=env,
                         cwd=os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    assert out.returncode == 0, out.stderr
    assert out.stdout.split()[-1] == "system"
    env["ARROW_DEFAULT_MEMORY_POOL"] = "mimalloc"
    out = subprocess.run([sys.executable, "-c", code, "fleet", *args], capture_output=True, text=True, env=env,
                         cwd=os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
    assert out.stdout.split()[-1] == "mimalloc"


def test_pin_only_when_cores_suffice():
    from pndiss.fleet_worker import pin
    before = os.sched_getaffinity(0)
    try:
        assert pin(0, None) is None and pin("a-name", "2") is None
        assert pin(0, str(len(before) + 1)) is None and os.sched_getaffinity(0) == before
        if len(before) > 1:   # fewer workers than cores: the OS may still move them
            assert pin(0, str(len(before) - 1)) is None and os.sched_getaffinity(0) == before
        got = pin(len(before), str(len(before)))   # the i-th worker takes the (i mod cores)-th core
        assert got == {sorted(before)[0]} == os.sched_getaffinity(0)
    finally:
        os.sched_setaffinity(0, before)


def test_worker_killed_mid_run_loses_nothing(inputs, client, sequential, tmp_path):
    root = str(tmp_path / "ds")
    store = DatasetStore(root)
    p = fleet.plan(find_captures([str(inputs)]), store)
    long = next(t for t in p.todo if t[0].endswith("long.pcapng"))
    assert long[1] is None   # no other input has its size: its task hashes it
    key = f"pndiss-fleet-{fleet.task_name(*long[:2])}-"
    pids = client.run(os.getpid)   # worker address -> pid
    killed, seen = [], []

    def killer():
        """Kill the worker the long capture runs on, half a second after it started there."""
        deadline = time.monotonic() + 120
        while time.monotonic() < deadline:
            snap = client.processing()
            seen.append(snap)
            busy = [w for w, ks in snap.items() if any(str(k).startswith(key) for k in ks)]
            if busy:
                time.sleep(0.5)
                os.kill(pids[busy[0]], signal.SIGKILL)
                killed.append((busy[0], pids[busy[0]]))
                return
            time.sleep(0.02)

    import threading
    t = threading.Thread(target=killer, daemon=True)
    t.start()
    out = fleet.run_dask(client, p.todo, store, Settings(), "on_change")
    t.join()
    assert killed, f"the long capture was never seen running: {seen[-3:]}"
    worker, pid = killed[0]
    assert pid not in client.run(os.getpid).values()   # that process is gone (its nanny started another)
    assert sorted(o.status for o in out) == ["analysed"] * len(p.todo)
    assert next(o for o in out if o.path == long[0]).row["frames"] > 10000
    assert snapshot(root) == snapshot(sequential)
    assert not glob.glob(os.path.join(root, "*", ".*.tmp"))   # nothing half-written left behind


def test_interrupted_run_continues(inputs, sequential, tmp_path):
    """The fleet command killed outright (SIGKILL, no clean-up) part-way: the next run does the rest."""
    import subprocess
    import sys

    root = tmp_path / "ds"
    cmd = [sys.executable, "-m", "pndiss", "fleet", str(inputs), "-o", str(root), "--workers", "0", "--no-progress"]
    env = {**os.environ, "PYTHONPATH": ROOT + os.pathsep + os.environ.get("PYTHONPATH", "")}
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    deadline = time.monotonic() + 120
    while len(glob.glob(str(root / "captures" / "*.parquet"))) < 3 and proc.poll() is None and time.monotonic() < deadline:
        time.sleep(0.02)
    proc.kill()
    proc.wait()
    done = len(glob.glob(str(root / "captures" / "*.parquet")))
    n = len(CAPS) + 1
    assert 3 <= done < n, "the run was not interrupted part-way"
    p = subprocess.run(cmd, env=env, capture_output=True, text=True)
    assert p.returncode == 0, p.stderr
    assert f"{n - done} analysed, {done} skipped" in p.stderr
    assert snapshot(str(root)) == snapshot(sequential)


def test_failed_files_recorded_and_the_rest_analysed(client, tmp_path, capsys):
    src = tmp_path / "in"
    src.mkdir()
    for p in CAPS[:4]:
        shutil.copy(p, src)
    (src / "junk.pcap").write_bytes(b"not a capture at all\n")
    data = open(CAPS[5], "rb").read()
    (src / "cut.pcapng").write_bytes(data[: len(data) // 2])
    root = str(tmp_path / "ds")
    args = ["fleet", str(src), "-o", root, "--scheduler", client.scheduler.address, "--no-progress"]
    assert main(args) == 2
    err = capsys.readouterr().err
    assert "4 analysed, 0 skipped" in err and "2 failed" in err
    assert "junk.pcap: not a pcap or pcapng file" in err and "cut.pcapng" in err
    rows = {os.path.basename(r["file"]): r for f in glob.glob(os.path.join(root, "captures", "*.parquet"))
            for r in pq.read_table(f).to_pylist()}
    assert len(rows) == 6
    assert "not a pcap or pcapng" in rows["junk.pcap"]["error"]
    assert rows["cut.pcapng"]["error"] and rows["cut.pcapng"]["frames"] > 0   # what was read is kept
    assert all(rows[os.path.basename(p)]["error"] is None for p in CAPS[:4])
    # the same inputs again: no work, the same exit code; --retry-failed tries the two again
    assert main(args) == 2
    assert "0 analysed, 6 skipped (already in the dataset; 2 of them failed before" in capsys.readouterr().err
    assert main(args + ["--retry-failed"]) == 2
    assert "0 analysed, 4 skipped" in capsys.readouterr().err


def test_local_cluster_starts_while_hashing_and_not_on_a_rerun(tmp_path, capsys, monkeypatch):
    """The local cluster starts in a thread while the inputs are hashed when some input is new to
    the dataset; a re-run with nothing to do starts none (it stays instant)."""
    root = str(tmp_path / "ds")
    caps = CAPS[:3]
    store = DatasetStore(root)
    assert fleet.likely_work(caps, store)   # an empty dataset
    started = []
    real = fleet.EarlyCluster

    def counted(workers):
        started.append(workers)
        return real(workers)
    monkeypatch.setattr(fleet, "EarlyCluster", counted)
    assert main(["fleet", *caps, "-o", root, "--workers", "2", "-q"]) == 0
    assert started == [2] and "3 analysed" in capsys.readouterr().err
    assert not fleet.likely_work(caps, store)
    assert fleet.likely_work(caps + [CAPS[5]], store)

    def no_cluster(*a, **k):
        raise AssertionError("a re-run with nothing to do started a cluster")
    monkeypatch.setattr(fleet, "connect", no_cluster)
    assert main(["fleet", *caps, "-o", root, "--workers", "2", "-q"]) == 0
    assert started == [2] and "0 analysed, 3 skipped" in capsys.readouterr().err
    # a capture that failed is done too (unless --retry-failed): still no cluster
    bad = tmp_path / "not-a-capture.pcapng"
    bad.write_bytes(b"no capture here" * 10)
    monkeypatch.undo()
    assert main(["fleet", str(bad), "-o", root, "--workers", "0", "-q"]) == 2   # recorded as failed
    capsys.readouterr()
    assert not fleet.likely_work([str(bad)], store) and fleet.likely_work([str(bad)], store, retry_failed=True)
    monkeypatch.setattr(fleet, "connect", no_cluster)
    assert main(["fleet", *caps, str(bad), "-o", root, "--workers", "2", "-q"]) == 2   # it failed before
    assert "0 analysed, 4 skipped" in capsys.readouterr().err


def test_fail_on_counts_skipped_captures_too(tmp_path, capsys):
    root = str(tmp_path / "ds")
    fault = next(p for p in CAPS if "fault-" in p)
    args = ["fleet", fault, "-o", root, "--workers", "0", "--fail-on", "error", "-q"]
    assert main(args) == 1
    assert main(args) == 1   # skipped now: its captures row still counts
    assert main(args[:-3]) == 0
    capsys.readouterr()


@pytest.mark.parametrize("argv, message", [
    (["/no/such/capture.pcapng"], "no such file or directory"),
    (["{caps}", "--workers", "-1"], "--workers"),
    (["{caps}", "--cycles", "sometimes"], "--cycles"),
    (["{caps}/*.nothing"], "no capture matches"),
])
def test_bad_arguments_exit_2(argv, message, tmp_path, capsys):
    caps = os.path.join(ROOT, "captures")
    argv = [a.replace("{caps}", caps) for a in argv]
    assert main(["fleet", *argv, "-o", str(tmp_path / "ds")]) == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err


def test_inputs_hashed_by_their_tasks_unless_a_size_may_be_a_copy(tmp_path):
    """Hashing every input up front on one machine delays the first task by minutes on a plant's worth of
    captures: an input no other input (or captured file) shares a size with is hashed by its own task. A copy
    is still never analysed twice: the same size is hashed up front; a compressed one's twin is found by the
    task (skipped) or after the run (duplicate)."""
    a, b, c = CAPS[0], CAPS[1], CAPS[2]
    assert len({os.path.getsize(x) for x in (a, b, c)}) == 3
    src = tmp_path / "in"
    src.mkdir()
    shutil.copy(a, src / "a.pcapng")
    shutil.copy(c, src / "c.pcapng")
    root = str(tmp_path / "ds")
    store = DatasetStore(root)
    p = fleet.plan(find_captures([str(src)]), store)
    assert [t[1] for t in p.todo] == [None, None]   # no size shared: each task hashes its own
    (src / "junk.pcap").write_bytes(b"not a capture\n" * 10)   # not compressed: hashed now, the others still not
    p = fleet.plan(find_captures([str(src)]), store)
    assert sorted((os.path.basename(t[0]), t[1] is None) for t in p.todo) == [
        ("a.pcapng", True), ("c.pcapng", True), ("junk.pcap", False)]
    (src / "junk.pcap").unlink()
    # a compressed input in the run: its content's size is unknown, any plain input may be its copy -- all hashed now
    (src / "b.pcapng.gz").write_bytes(gzip.compress(open(b, "rb").read()))
    p = fleet.plan(find_captures([str(src)]), store)
    todo = {os.path.basename(t[0]): t[1] for t in p.todo}
    assert todo == {"a.pcapng": content_hash(a), "b.pcapng.gz": content_hash(b), "c.pcapng": content_hash(c)}
    out = fleet.same_content(p.outcomes + fleet.run_local(p.todo, store, Settings(), "none"))
    assert sorted(o.status for o in out) == ["analysed"] * 3
    # the plain twin of the compressed capture the dataset holds: its size is new, its task finds it done
    shutil.copy(b, src / "b-plain.pcapng")
    p = fleet.plan([str(src / "b-plain.pcapng")], store)
    assert p.todo[0][1] is None
    out = fleet.run_local(p.todo, store, Settings(), "none")
    assert [o.status for o in out] == ["skipped"] and out[0].row["capture_hash"] == content_hash(b)
    # in one run with its compressed twin (a fresh dataset): analysed once, the other a duplicate (the plan hashes both)
    root2 = str(tmp_path / "ds2")
    store2 = DatasetStore(root2)
    p = fleet.plan([str(src / "b.pcapng.gz"), str(src / "b-plain.pcapng")], store2)
    out = fleet.same_content(p.outcomes + fleet.run_local(p.todo, store2, Settings(), "none"))
    assert sorted(o.status for o in out) == ["analysed", "duplicate"]
    assert len(glob.glob(os.path.join(root2, "captures", "*.parquet"))) == 1
