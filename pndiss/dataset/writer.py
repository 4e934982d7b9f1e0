"""One capture into the dataset: analyse it, write its tables, then its ``captures`` row.

Layout: ``DATASET/<table>/<content hash>.parquet``, one file per table per capture (a table the
capture has no rows for has no file). Every file is written under a temporary name (``.<hash>.<pid>.tmp``,
which readers never match) and renamed into place; the ``captures`` file is renamed last and is
the mark that the capture is complete. A killed process leaves no half-written file under a real
name; readers (``reader.py``) ignore rows whose capture has no ``captures`` row, and the next run
rewrites that capture.
"""
from __future__ import annotations

import hashlib
import os
import time

from ..fleet_inputs import content_hash  # the reader's digest (decompressed bytes), also dataset.content_hash
from .schema import SCHEMA_VERSION, TABLES
from .sink import ParquetSink


def table_path(dataset_dir: str, table: str, capture_hash: str) -> str:
    return os.path.join(dataset_dir, table, f"{capture_hash}.parquet")


def done_hashes(dataset_dir: str) -> set[str]:
    """Content hashes of the captures the dataset holds completely (failed ones included)."""
    d = os.path.join(dataset_dir, "captures")
    try:
        names = os.listdir(d)
    except FileNotFoundError:
        return set()
    return {n[:-8] for n in names if n.endswith(".parquet") and not n.startswith(".")}


def write_capture(path: str, dataset_dir: str, settings=None, cycles="on_change", *,
                  capture_hash: str | None = None, keyframe_s: float = 1.0, progress=None,
                  write_thread: bool = True) -> dict:
    """Analyse ``path`` and write its rows into ``dataset_dir``; returns its ``captures`` row.

    A file that cannot be analysed (not a capture, damaged, unreadable) is recorded with its
    ``error`` (what was read before a damaged part is kept) and does not raise. ``write_thread``: the
    cycles table's row groups are encoded on a second thread (off where each process is one core)."""
    from .. import __version__
    from ..capture import CaptureError, refuse_non_capture
    from ..errors import UsageError
    from ..settings import Settings
    from ..driver import analyze
    from .cycles import parse_mode

    parse_mode(cycles)   # a bad mode is the caller's error: raise before any work
    settings = settings or Settings()
    row = {"file": path, "pndiss_version": __version__, "schema_version": SCHEMA_VERSION,
           "settings": settings.as_dict(), "cycles_mode": str(cycles), "written_at": time.time_ns()}
    try:
        h = capture_hash or content_hash(path)
        row["size_bytes"] = os.path.getsize(path)
    except OSError as e:
        h = "unreadable-" + hashlib.sha256(os.path.abspath(path).encode()).hexdigest()[:32]
        row.update(capture_hash=h, error=f"cannot read {path}: {e.strerror or e}")
        _commit(dataset_dir, h, {}, row)
        return row
    row["capture_hash"] = h
    tmp = f".{h}.{os.getpid()}.tmp"
    for t in TABLES:
        os.makedirs(os.path.join(dataset_dir, t), exist_ok=True)

    def path_of(table):
        return os.path.join(dataset_dir, table, tmp)

    sink = ParquetSink(path_of, h, cycles, keyframe_s, write_thread)
    try:
        a = None
        try:
            refuse_non_capture(path)
            # the one driver: events + the engine's columns (the file hashed above, not again)
            a = analyze(path, settings, [sink], progress, known_sha256=h)
        except (CaptureError, UsageError) as e:
            a = getattr(e, "analyzer", None)
            row["error"] = str(e)
        except Exception as e:  # a bug must not stop a fleet run: recorded, with its type
            row["error"] = f"internal error: {type(e).__name__}: {e}"
        summ = a.summary() if a is not None else None
        if summ is not None:
            sink.add_rows("stations", summ["stations"])
            sink.add_rows("axes", summ["cyclic"].get("encoders") or [])
        sink.close()
        if summ is not None:
            _fill(row, summ, sink)
        _commit(dataset_dir, h, sink.written, row, tmp)
    except BaseException:   # interrupted (Ctrl-C, a worker told to stop) or a full disk: no temporaries left
        sink.abort()
        _remove_tmp(dataset_dir, tmp)
        raise
    return row


def _fill(row: dict, summ: dict, sink: ParquetSink) -> None:
    acc = summ["accounting"]
    first, last = summ.get("first_ts_ns"), summ.get("last_ts_ns")
    sev = summ["violations"]["by_severity"]
    gaps = sink.tables["capture_gaps"]
    row.update(
        frames=summ["frames"], decoded=acc["decoded"], not_profinet=acc["not_profinet"],
        malformed=acc["malformed"], first_ts_ns=first, last_ts_ns=last, first_ts=first, last_ts=last,
        duration_s=(last - first) / 1e9 if first is not None and last is not None else None,
        events=summ["events"], violations=sum(sev.values()), errors=sev.get("error", 0),
        warnings=sev.get("warning", 0), infos=sev.get("info", 0), capture_gaps=gaps.n,
        cycles_missing=sum(x or 0 for x in gaps.data["cycles_missing"]),
        stations=sum(1 for s in summ["stations"] if "lldp_port_of" not in s),
        axes=len(summ["cyclic"].get("encoders") or []),
        cycle_rows=sink.cyc.rows, settings=summ["settings"])


def _commit(dataset_dir: str, h: str, written: dict, row: dict, tmp: str | None = None) -> None:
    """Rename the tables into place, drop what an earlier run wrote and this one did not, and
    write the captures row last (the mark that the capture is complete)."""
    import pyarrow.parquet as pq
    from .rows import TableRows

    from .reader import VERSIONS_DIR
    os.makedirs(os.path.join(dataset_dir, "captures"), exist_ok=True)
    os.makedirs(os.path.join(dataset_dir, VERSIONS_DIR), exist_ok=True)
    with open(os.path.join(dataset_dir, VERSIONS_DIR, str(SCHEMA_VERSION)), "a"):
        pass
    final = table_path(dataset_dir, "captures", h)
    if os.path.exists(final):
        os.remove(final)   # incomplete from here until the new row is in place
    for t in TABLES:
        if t == "captures":
            continue
        dst = table_path(dataset_dir, t, h)
        if t in written:
            os.replace(os.path.join(dataset_dir, t, tmp), dst)
        elif os.path.exists(dst):
            os.remove(dst)
    tr = TableRows("captures", h)
    tr.add(row)
    part = os.path.join(dataset_dir, "captures", f".{h}.{os.getpid()}.tmp")
    pq.write_table(tr.table(), part, compression="zstd")
    os.replace(part, final)


def _remove_tmp(dataset_dir: str, tmp: str) -> None:
    for t in TABLES:
        try:
            os.remove(os.path.join(dataset_dir, t, tmp))
        except OSError:
            pass


def record_failure(dataset_dir: str, path: str, capture_hash: str, error: str, settings=None,
                   cycles="on_change") -> dict:
    """The ``captures`` row of a capture whose analysis never returned (its worker died again and
    again, or the task was lost): written as ``write_capture`` writes a failed file's row, replacing
    whatever an attempt left; returns it. (pndiss fleet)"""
    from .. import __version__
    from ..settings import Settings

    row = {"file": path, "capture_hash": capture_hash, "pndiss_version": __version__,
           "schema_version": SCHEMA_VERSION, "settings": (settings or Settings()).as_dict(),
           "cycles_mode": str(cycles), "written_at": time.time_ns(), "error": error}
    try:
        row["size_bytes"] = os.path.getsize(path)
    except OSError:
        pass
    _commit(dataset_dir, capture_hash, {}, row)
    return row
