"""``pndiss fleet INPUTS... -o DATASET``: every capture into one Parquet dataset, in parallel on Dask
(pndiss/fleet.py), each capture once (a re-run skips what the dataset holds)."""
from __future__ import annotations

import os
import sys
import time

from .analyze import SEVERITY_ORDER, add_settings_args, settings_from_args

SEVERITY_COLUMNS = {"error": "errors", "warning": "warnings", "info": "infos"}   # captures table counts


def add_parser(sub) -> None:
    p = sub.add_parser("fleet", help="analyse many captures into one Parquet dataset, in parallel on Dask "
                                     "(each capture once: a re-run skips what is done)")
    p.add_argument("inputs", nargs="+", metavar="INPUT",
                   help="capture files, directories (searched recursively for *.pcap, *.pcapng, also .gz/.zst/.xz) "
                        "or globs ('plant/**/*.pcapng')")
    p.add_argument("-o", "--output", required=True, metavar="DATASET", help="dataset directory (created when missing)")
    p.add_argument("--workers", type=int, default=None, metavar="N",
                   help="worker processes of the local Dask cluster (default: the CPU count); 0 = no Dask, "
                        "one file after another in this process")
    p.add_argument("--scheduler", metavar="ADDRESS",
                   help="use a running dask.distributed scheduler (tcp://host:8786) instead of a local cluster; "
                        "its workers must see INPUTS and DATASET under the same paths (docs/scale.md)")
    p.add_argument("--cycles", default="on_change", metavar="MODE",
                   help="per-axis cycles table: on_change (default), full, decimate:N, on_change,decimate:N "
                        "or none (docs/dataset.md)")
    p.add_argument("--retry-failed", action="store_true", help="analyse again the captures recorded as failed")
    add_settings_args(p)
    p.add_argument("--fail-on", choices=("info", "warning", "error"),
                   help="exit 1 when a capture named has violations at or above this severity")
    p.add_argument("-q", "--quiet", action="store_true", help="only the closing line")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..fleet_worker import arrow_pool
    arrow_pool()   # before pyarrow's import (a --workers 0 run writes the dataset in this process)
    from .. import fleet
    from ..errors import UsageError
    from ..fleet_inputs import find_captures

    if args.workers is not None and args.workers < 0:
        raise UsageError("--workers: a number of worker processes, 0 or more")
    if args.scheduler and args.workers is not None:
        raise UsageError("--workers starts a local cluster; a --scheduler's cluster has its own workers")
    from ..dataset.cycles import parse_mode
    try:
        parse_mode(args.cycles)
    except ValueError as e:
        raise UsageError(f"--cycles: {e}") from None
    settings = settings_from_args(args)
    # workers open --map / --gsdml themselves, maybe on another machine or in another directory
    if settings.map_file:
        settings.map_file = os.path.abspath(settings.map_file)
    settings.gsdml = [os.path.abspath(g) for g in settings.gsdml]
    paths = find_captures(args.inputs)
    store = open_store(args.output)
    t0 = time.perf_counter()
    say = _Say(args.quiet)
    client = cluster = progress = early = None
    workers = args.workers or os.cpu_count() or 1
    try:
        if args.scheduler:   # a remote cluster hashes the files where they are
            client, cluster = fleet.connect(args.scheduler, 0)
        elif args.workers != 0 and fleet.likely_work(paths, store, args.retry_failed):
            early = fleet.EarlyCluster(workers)   # starts while the inputs are hashed
        p = fleet.plan(paths, store, args.retry_failed, client)
        progress = None if args.no_progress or args.quiet else FleetProgress(len(p.todo))
        on_done = progress.done if progress else None
        for o in p.outcomes:
            if o.status == "failed":
                _report_failure(o, progress)
        if not p.todo:
            results = []
        elif args.workers == 0:
            results = fleet.run_local(p.todo, store, settings, args.cycles, on_done, retry_failed=args.retry_failed)
        else:
            if client is None:   # started only when there is work: a re-run with nothing to do is instant
                client, cluster = early.take() if early else fleet.connect(None, workers)
                early = None
            results = fleet.run_dask(client, p.todo, store, settings, args.cycles, on_done, retry_failed=args.retry_failed)
    finally:
        if progress:
            progress.close()
        if early is not None:   # guessed wrong (nothing to do) or interrupted: stop what was started
            early.close()
        if client is not None:
            client.close()
        if cluster is not None:
            cluster.close()
    outcomes = fleet.same_content(p.outcomes + results)
    n = {s: sum(o.status == s for o in outcomes) for s in ("analysed", "skipped", "duplicate", "failed")}
    failed_before = sum(o.status == "skipped" and bool((o.row or {}).get("error")) for o in outcomes)
    if progress is None:  # the bar said each failure as it came; a quiet run says them here
        for o in results:
            if o.status == "failed":
                _report_failure(o, None)
    say(f"pndiss: fleet: {len(paths)} capture(s) -> {args.output}: {n['analysed']} analysed, "
        f"{n['skipped']} skipped (already in the dataset"
        + (f"; {failed_before} of them failed before: --retry-failed" if failed_before else "") + "), "
        + (f"{n['duplicate']} duplicate(s) of another input, " if n["duplicate"] else "")
        + f"{n['failed']} failed; {time.perf_counter() - t0:.1f} s", force=True)
    return exit_code(outcomes, settings.fail_on)


def open_store(dataset: str):
    from ..errors import UsageError
    from ..fleet_store import DatasetStore

    if os.path.exists(dataset) and not os.path.isdir(dataset):
        raise UsageError(f"{dataset}: exists and is not a directory (the dataset is a directory)")
    try:
        os.makedirs(dataset, exist_ok=True)
    except OSError as e:
        raise UsageError(f"cannot create {dataset}: {e.strerror}") from None
    if not os.access(dataset, os.W_OK | os.X_OK):
        raise UsageError(f"{dataset}: not writable")
    return DatasetStore(os.path.abspath(dataset))


def exit_code(outcomes, fail_on: str | None) -> int:
    """3 when a capture failed on a bug, 2 when one was unusable, 1 for violations at or above
    ``fail_on`` in any capture named (skipped ones counted from their dataset row), else 0."""
    from ..fleet import error_kind
    # a capture recorded as failed by an earlier run fails this one too: same inputs, same exit code
    kinds = {error_kind(o.error or (o.row or {}).get("error") or "")
             for o in outcomes if o.status == "failed" or (o.row or {}).get("error")}
    if "internal" in kinds:
        return 3
    if "input" in kinds:
        return 2
    if fail_on:
        floor = SEVERITY_ORDER[fail_on]
        for o in outcomes:
            row = o.row or {}
            for sev, col in SEVERITY_COLUMNS.items():
                if row.get(col) and SEVERITY_ORDER[sev] >= floor:
                    return 1
    return 0


def _report_failure(o, progress) -> None:
    line = f"pndiss: fleet: {o.error}" if o.error.startswith(o.path) else f"pndiss: fleet: {o.path}: {o.error}"
    if progress is not None:
        progress.print(line)
    else:
        print(line, file=sys.stderr, flush=True)


class _Say:
    def __init__(self, quiet: bool):
        self.quiet = quiet

    def __call__(self, text: str, force: bool = False) -> None:
        if force or not self.quiet:
            print(text, file=sys.stderr, flush=True)


class FleetProgress:
    """Progress over files: a rich bar on a TTY, a plain line every few seconds otherwise (as
    report.ProgressReporter does for frames)."""

    def __init__(self, total: int):
        self.total = total
        self.n = 0
        self.failed = 0
        self.stream = sys.stderr
        self.start = self.last = time.monotonic()
        self.bar = None
        if self.stream.isatty() and total:
            from rich.console import Console
            from rich.progress import BarColumn, MofNCompleteColumn, Progress, TextColumn, TimeRemainingColumn
            self.bar = Progress(TextColumn("{task.description}"), BarColumn(), MofNCompleteColumn(),
                                TextColumn("files, ETA"), TimeRemainingColumn(),
                                console=Console(file=self.stream), transient=True)
            self.task = self.bar.add_task("fleet", total=total)
            self.bar.start()

    def done(self, outcome) -> None:
        self.n += 1
        if outcome.status == "failed":
            self.failed += 1
            _report_failure(outcome, self)
        if self.bar is not None:
            self.bar.update(self.task, completed=self.n,
                            description="fleet" + (f" ({self.failed} failed)" if self.failed else ""))
            return
        now = time.monotonic()
        if now - self.last > 5 or self.n == self.total:
            print(f"pndiss: fleet: {self.n}/{self.total} files ({now - self.start:.0f} s)", file=self.stream, flush=True)
            self.last = now

    def print(self, line: str) -> None:
        if self.bar is not None:
            self.bar.console.print(line, markup=False, highlight=False, emoji=False)
        else:
            print(line, file=self.stream, flush=True)

    def close(self) -> None:
        if self.bar is not None:
            self.bar.stop()
