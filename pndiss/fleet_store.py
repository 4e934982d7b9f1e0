"""The dataset as `pndiss fleet` sees it: which captures it holds, and one capture written into it.

A thin, picklable handle (Dask sends it to every task) over pndiss/dataset/: the writer there
analyses a capture and writes its files, named by content hash, under temporary names renamed into
place, the ``captures`` row last -- a capture counts as done only when all its tables are in place.
"""
from __future__ import annotations

import glob
import os

# the columns a plan needs of the captures already done (skip, retry, --fail-on over skipped files)
DONE_COLUMNS = ["capture_hash", "file", "size_bytes", "error", "errors", "warnings", "infos", "violations"]


class DatasetStore:
    def __init__(self, root: str):
        self.root = root

    def done(self) -> dict[str, dict]:
        """capture hash -> its ``captures`` row (DONE_COLUMNS; ``error`` set when it failed)."""
        from . import dataset

        if not dataset.done_hashes(self.root):
            return {}
        import pyarrow.dataset as pads
        t = pads.dataset(dataset.files(self.root, "captures"), format="parquet").to_table(columns=DONE_COLUMNS)
        return {r["capture_hash"]: r for r in t.to_pylist()}

    def row(self, sha: str) -> dict | None:
        """The ``captures`` row of a capture the dataset holds completely (DONE_COLUMNS), else None."""
        import pyarrow.parquet as pq

        f = os.path.join(self.root, "captures", sha + ".parquet")
        try:
            rows = pq.read_table(f, columns=DONE_COLUMNS).to_pylist()
        except (OSError, ValueError):   # not there (or not whole: never, it is renamed into place)
            return None
        return rows[0] if rows else None

    def write(self, path: str, sha: str, settings, cycles: str, write_thread: bool = False) -> dict:
        """Analyse ``path`` into the dataset under content hash ``sha`` ('' when it could not be
        read: the writer records why); its ``captures`` row (``error`` set when the file could not
        be analysed, what was read kept)."""
        from .dataset import write_capture

        if sha:
            self.clear_attempts(sha)
        return _small(write_capture(path, self.root, settings, cycles=cycles, capture_hash=sha or None,
                                    write_thread=write_thread))

    def record_failure(self, path: str, sha: str, error: str, settings, cycles: str) -> dict:
        """The ``captures`` row, with its error, of a capture whose analysis never returned."""
        from .dataset.writer import record_failure

        self.clear_attempts(sha)
        return _small(record_failure(self.root, path, sha, error, settings, cycles))

    def clear_attempts(self, sha: str) -> None:
        """Remove what a killed earlier attempt at this capture left under temporary names
        (``.<hash>.<pid>.tmp``, never read): the capture is written again from scratch."""
        for f in glob.glob(os.path.join(glob.escape(self.root), "*", f".{sha}.*.tmp")):
            try:
                os.remove(f)
            except OSError:
                pass


def _small(row: dict) -> dict:
    """The row without its bulky JSON (settings, event counts): it travels back from a worker."""
    return {k: v for k, v in row.items() if k not in ("settings", "events")}
