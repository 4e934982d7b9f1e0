"""`pndiss fleet`: many captures into one dataset, each analysed once, in parallel on Dask.

The plan is made here, the work is done by Dask: every capture is hashed (fleet_inputs.py), the
ones whose hash the dataset already holds are skipped, the rest become one Dask task each on a
``distributed`` cluster -- a LocalCluster of worker processes, or an existing scheduler (Kubernetes,
an HPC queue: whatever Dask's deployment tools started). A task analyses one capture and writes its
files into the dataset itself (the dataset's writer names them by content hash and renames them into
place, so a killed worker leaves nothing half-written); only a small summary row travels back.

Failures: an analysis that raises is recorded as the capture's ``captures`` row with its error and
does not stop the rest. A worker process that dies (killed, out of memory) is replaced by its
nanny; the scheduler gives its task to another worker (``distributed.scheduler.allowed-failures``
times) and the file is written again from scratch. A task that still cannot finish is recorded as
failed. An interrupted run leaves whole captures behind; the next run skips them and continues.
"""
from __future__ import annotations

import collections
import os
import time
import uuid
from dataclasses import dataclass, field

from .errors import UsageError
from .capture import capture_magic
from .fleet_inputs import content_hash
from .inputs import compressed

@dataclass
class Outcome:
    """What became of one input."""

    path: str
    sha256: str
    status: str                  # analysed | skipped | duplicate | failed
    error: str | None = None
    error_kind: str | None = None  # input | internal (failed only)
    row: dict | None = None      # the captures row (analysed, or skipped when the dataset has it)
    seconds: float = 0.0
    same_as: str | None = None   # duplicate: the input with the same content


@dataclass
class Plan:
    todo: list = field(default_factory=list)      # (path, sha256, size)
    outcomes: list = field(default_factory=list)  # skipped / duplicate / unreadable, known before any work


def plan(paths: list[str], store, retry_failed: bool = False, client=None, hash_threads: int = 4) -> Plan:
    """Decide what to analyse. An input that may be a copy of another input or of a capture the dataset
    holds (the same size, or compressed: its content's size is not known) is hashed now: in threads here
    (hashlib releases the GIL), or on the cluster's workers when ``client`` is given (a remote cluster:
    the files are on its storage). Every other input is hashed by its own task, on the workers, in
    parallel, as the analysis starts (a plant's worth of captures: no minutes of hashing up front on
    one machine before the first task); ``sha256`` is None in ``todo`` for them."""
    done = store.done()   # sha256 -> captures row (with "error" set for a failed capture)
    sizes = {p: _plain_size(p) for p in paths}
    seen = collections.Counter(sizes.values())
    taken = {r.get("size_bytes") for r in done.values()}
    if any(_compressed(p) for p, z in sizes.items() if z is None):
        now = list(paths)   # a compressed input's content size is unknown: any plain one may be its copy -- all now
    else:   # (not a capture, unreadable: hashed now too -- the writer records it under that hash)
        now = [p for p in paths if sizes[p] is None or seen[sizes[p]] > 1 or sizes[p] in taken]
    if client is not None:
        run = uuid.uuid4().hex[:12]   # task keys of this run: another run on the same scheduler has its own
        hashed = client.gather(client.map(hash_one, now, pure=False,
                                          key=[f"pndiss-hash-{run}-{i}" for i in range(len(now))]))
    else:
        from concurrent.futures import ThreadPoolExecutor
        with ThreadPoolExecutor(max(1, hash_threads)) as ex:
            hashed = list(ex.map(hash_one, now))
    by_path = {h[0]: h for h in hashed}
    p = Plan()
    first: dict[str, str] = {}
    for path in paths:
        if path not in by_path:   # no other input or captured file has its size: hashed by its task
            p.todo.append((path, None, sizes[path]))
            continue
        _path, sha, size, err = by_path[path]
        if err is not None:   # the writer records it (with its reason) under a hash of its path
            p.todo.append((path, "", 0))
        elif sha in first:
            p.outcomes.append(Outcome(path, sha, "duplicate", same_as=first[sha]))
        else:
            first[sha] = path
            row = done.get(sha)
            if row is not None and not (retry_failed and row.get("error")):
                p.outcomes.append(Outcome(path, sha, "skipped", row=row))
            else:
                p.todo.append((path, sha, size))
    return p


def _plain_size(path: str) -> int | None:
    """The size of an uncompressed pcap / pcapng file (its content's size), else None (compressed,
    not a capture, unreadable: hashed up front, as the content's size is unknown)."""
    head, size = _head(path)
    return size if capture_magic(head) else None


def _compressed(path: str) -> bool:
    """gzip, xz or zstd (pndiss/inputs.py opens them)."""
    return compressed(_head(path)[0])


def _head(path: str) -> tuple[bytes, int]:
    """A file's first 8 bytes and its size (b"", 0 when unreadable)."""
    try:
        with open(path, "rb") as f:
            return f.read(8), os.fstat(f.fileno()).st_size
    except OSError:
        return b"", 0


def task_name(path: str, sha: str | None) -> str:
    """What names an input's task: its content hash, or, not hashed yet, a digest of its path."""
    import hashlib
    return sha or "p" + hashlib.sha256(os.path.abspath(path).encode()).hexdigest()[:32]


def hash_one(path: str) -> tuple:
    """(path, content hash, size, None), or (path, "", 0, why) when it cannot be read."""
    try:
        return path, content_hash(path), os.path.getsize(path), None
    except OSError as e:
        return path, "", 0, e.strerror or str(e)


def analyse_one(store, path: str, sha: str | None, settings, cycles: str, write_thread: bool = False,
                retry_failed: bool = False) -> Outcome:
    """The Dask task: analyse one capture into the dataset. A file that cannot be analysed is
    recorded with its error by the writer and comes back as ``failed``, never raised. ``sha`` None:
    the plan left the hashing to this task; a capture the dataset holds already comes back ``skipped``
    (a copy under another name: the plan hashes those of the same size, this is the rest). A Dask worker
    is one core (``threads_per_worker=1``, as many workers as cores): no writer thread of its own there;
    ``--workers 0`` (one process, the other cores idle) writes the cycles table on a second thread."""
    t0 = time.perf_counter()
    if sha is None:
        _path, sha, _size, _err = hash_one(path)
        row = store.row(sha) if sha else None
        if row is not None and not (retry_failed and row.get("error")):
            return Outcome(path, sha, "skipped", row=row, seconds=time.perf_counter() - t0)
    row = store.write(path, sha, settings, cycles, write_thread)
    dt = time.perf_counter() - t0
    error = row.get("error")
    if error:
        return Outcome(path, sha, "failed", error, error_kind(error), row=row, seconds=dt)
    return Outcome(path, sha, "analysed", row=row, seconds=dt)


def same_content(outcomes: list[Outcome]) -> list[Outcome]:
    """Inputs hashed by their tasks that turned out to hold the same content as another input of the run
    (a compressed copy: the plan hashes only copies it can tell by size): ``duplicate`` of the first."""
    first: dict[str, str] = {}
    for o in outcomes:
        if o.status in ("analysed", "skipped") and o.sha256:   # (a plan's duplicate names its first already)
            if o.sha256 in first:   # (skipped: the twin came first)
                o.status, o.same_as = "duplicate", first[o.sha256]
            else:
                first[o.sha256] = o.path
    return outcomes


def error_kind(error: str) -> str:
    """'internal' for a bug (the writer says "internal error: ..."), else 'input' (damaged, not a capture)."""
    return "internal" if error.startswith("internal error") else "input"


def run_local(todo, store, settings, cycles: str, on_done=None, retry_failed: bool = False) -> list[Outcome]:
    """The same work in this process, one file after another (``--workers 0``; the reference run)."""
    out = []
    for path, sha, _size in todo:
        o = analyse_one(store, path, sha, settings, cycles, write_thread=True, retry_failed=retry_failed)
        out.append(o)
        if on_done is not None:
            on_done(o)
    return out


def run_dask(client, todo, store, settings, cycles: str, on_done=None, retries: int = 2,
             retry_failed: bool = False) -> list[Outcome]:
    """One task per capture, the biggest first (a long file started last would leave the other
    workers idle at the end); outcomes in completion order."""
    from distributed import as_completed

    order = sorted(todo, key=lambda t: -t[2])
    run = uuid.uuid4().hex[:12]   # a run writing another dataset on the same scheduler must not share our tasks
    futures = {}
    for rank, (path, sha, _size) in enumerate(order):
        fut = client.submit(analyse_one, store, path, sha, settings, cycles, False, retry_failed,
                            key=f"pndiss-fleet-{task_name(path, sha)}-{run}", pure=False, retries=retries,
                            priority=len(order) - rank)
        futures[fut] = (path, sha)
    out = []
    for fut in as_completed(futures):
        path, sha = futures[fut]
        try:
            o = fut.result()
        except Exception as e:  # noqa: BLE001 -- KilledWorker after allowed-failures, a lost scheduler ...
            text = f"internal error: the task did not finish: {type(e).__name__}: {e}"
            if sha is None:   # the task was to hash it: here, then
                sha = hash_one(path)[1]
            row = store.record_failure(path, sha, text, settings, cycles)
            o = Outcome(path, sha, "failed", text, "internal", row=row)
        fut.release()
        out.append(o)
        if on_done is not None:
            on_done(o)
    return out


def local_cluster(workers: int):
    """A LocalCluster of ``workers`` single-threaded worker processes (the analysis is CPU-bound
    Python: threads would share one GIL), quiet, without the dashboard's web server."""
    import logging

    from distributed import LocalCluster
    from .fleet_worker import PIN_ENV, arrow_pool_env
    return LocalCluster(n_workers=workers, threads_per_worker=1, processes=True, dashboard_address=None,
                        silence_logs=logging.ERROR, preload=["pndiss.fleet_worker"],
                        env={PIN_ENV: str(workers), **arrow_pool_env()})


def likely_work(paths: list[str], store, retry_failed: bool = False) -> bool:
    """Whether some input is probably not in the dataset yet: a path it holds no row for (a failed
    one counts as done unless ``retry_failed``, as the plan treats it). Only a guess, to start the
    cluster while the inputs are hashed; the hashes decide."""
    known = {os.path.abspath(r["file"]) for r in store.done().values()
             if r.get("file") and not (retry_failed and r.get("error"))}
    return any(os.path.abspath(p) not in known for p in paths)


class EarlyCluster:
    """A local cluster started in a thread (spawning workers and importing distributed take ~1 s,
    hashing the inputs as long again: they overlap). ``take()`` waits for it; ``close()`` stops it."""

    def __init__(self, workers: int):
        import threading
        self._out: list = []
        self._thread = threading.Thread(target=self._start, args=(workers,), name="pndiss-cluster-start",
                                        daemon=True)
        self._thread.start()

    def _start(self, workers: int) -> None:
        try:
            self._out.append(("ok", connect(None, workers)))
        except BaseException as e:  # noqa: BLE001 - handed to the main thread by take()
            self._out.append(("error", e))

    def take(self):
        """(client, cluster), or the exception starting it raised."""
        self._thread.join()
        what, v = self._out[0]
        if what == "error":
            raise v
        return v

    def close(self) -> None:
        """Stop it (waiting for its start first: a half-started cluster would leave processes)."""
        self._thread.join()   # a second Ctrl-C here goes through to the caller
        what, v = self._out[0]
        if what == "error":   # it never started: nothing to stop
            return
        client, cluster = v
        try:
            client.close()
        finally:
            cluster.close()


def connect(scheduler: str | None, workers: int):
    """(client, cluster or None): a client of an existing scheduler, or of a new LocalCluster."""
    from distributed import Client

    if scheduler:
        try:
            return Client(scheduler, timeout="20s"), None
        except (OSError, TimeoutError) as e:
            raise UsageError(f"--scheduler {scheduler}: cannot connect ({e})") from None
    cluster = local_cluster(workers)
    try:
        return Client(cluster), cluster
    except BaseException:
        cluster.close()
        raise
