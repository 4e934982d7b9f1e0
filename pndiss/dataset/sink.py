"""The Parquet sink: events of the dataset's kinds into their tables, cycle batches into ``cycles``.

It follows the sink contract (pndiss/sinks.py): it names the event kinds it needs and takes the
per-cycle columns as ``CycleBatch``es. Each table goes to the path ``path_of(table)`` gives (the
writer hands temporary names and renames them when the capture is complete).
"""
from __future__ import annotations

from ..sinks import Sink
from .cycles import CycleTable
from .rows import TableRows
from .schema import KIND_TABLE

# rows of an event table held before they go to the file as a row group: memory stays flat however long the capture
# (a plant's parameter polls: tens of thousands of record and param rows per 10 M frames held 100 MB)
FLUSH_ROWS = 8192


class ParquetSink(Sink):
    kinds = frozenset(KIND_TABLE)
    cycles = True

    def __init__(self, path_of, capture_hash: str, cycles_mode="on_change", keyframe_s: float = 1.0,
                 write_thread: bool = True):
        self.path_of = path_of
        self.capture_hash = capture_hash
        self.tables = {t: TableRows(t, capture_hash) for t in sorted(set(KIND_TABLE.values()))}
        self.cyc = CycleTable(path_of("cycles"), capture_hash, cycles_mode, keyframe_s, write_thread)
        self.cycles = self.cyc.enabled
        self.written: dict[str, int] = {}   # table -> rows, after close()
        self._writers: dict = {}            # table -> its open ParquetWriter (once a row group was flushed)

    def event(self, ev: dict) -> None:
        t = KIND_TABLE.get(ev.get("kind"))
        if t is not None:
            tr = self.tables[t]
            tr.add(ev)
            if tr.held() >= FLUSH_ROWS:
                self._flush(t)

    def _flush(self, name: str) -> None:
        import pyarrow.parquet as pq
        tr = self.tables[name]
        table = tr.table()
        w = self._writers.get(name)
        if w is None:
            w = self._writers[name] = pq.ParquetWriter(self.path_of(name), table.schema, compression="zstd")
        w.write_table(table)
        tr.clear()

    def cycle_batch(self, batch) -> None:
        self.cyc.add(batch)

    def add_rows(self, table: str, rows) -> None:
        """Rows that come from the summary, not from events (stations, axes)."""
        tr = self.tables.get(table)
        if tr is None:
            tr = self.tables[table] = TableRows(table, self.capture_hash)
        for r in rows:
            tr.add(r)

    def close(self) -> None:
        """Write every table that has rows (an empty table makes no file)."""
        import pyarrow.parquet as pq
        for name, tr in self.tables.items():
            if name in self._writers:   # flushed before: the rest as its last row group
                if tr.held():
                    self._flush(name)
                self._writers.pop(name).close()
                self.written[name] = tr.n
            elif tr.n:
                pq.write_table(tr.table(), self.path_of(name), compression="zstd")
                self.written[name] = tr.n
        n = self.cyc.close()
        if n:
            self.written["cycles"] = n

    def abort(self) -> None:
        """Stop without writing (the writer removes the temporary files)."""
        for w in self._writers.values():
            w.close()
        self._writers.clear()
        self.cyc.abort()
