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

    def event(self, ev: dict) -> None:
        t = KIND_TABLE.get(ev.get("kind"))
        if t is not None:
            self.tables[t].add(ev)

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
            if tr.n:
                pq.write_table(tr.table(), self.path_of(name), compression="zstd")
                self.written[name] = tr.n
        n = self.cyc.close()
        if n:
            self.written["cycles"] = n

    def abort(self) -> None:
        """Stop without writing (the writer removes the temporary files)."""
        self.cyc.abort()
