"""Event dicts -> typed columns of one table (schema.py says which columns and types).

Events are few next to cycles (violations, records, parameter accesses), so one dict per row is
fine here; the cycles table never comes through this module.
"""
from __future__ import annotations

import json

import pyarrow as pa

from .arrays import column
from .schema import JSON, TABLES, arrow_schema, arrow_type, ts_array


def _json(v) -> str:
    return json.dumps(v, separators=(",", ":"), sort_keys=True, default=_default)


def _default(o):
    if isinstance(o, (bytes, bytearray, memoryview)):
        return bytes(o).hex()   # as the JSONL writer does
    if isinstance(o, (set, frozenset, tuple)):
        return list(o)
    return str(o)


def _fits(t, v) -> bool:
    if pa.types.is_string(t):
        return isinstance(v, str)
    if pa.types.is_boolean(t):
        return isinstance(v, bool)
    if pa.types.is_integer(t) or pa.types.is_timestamp(t):   # timestamps are held as ns
        return isinstance(v, int) and not isinstance(v, bool) and -(1 << 63) <= v < (1 << 63)
    if pa.types.is_floating(t):
        return isinstance(v, (int, float)) and not isinstance(v, bool)
    return False


class TableRows:
    """Rows of one table, held as column lists until ``table()``."""

    def __init__(self, name: str, capture_hash: str | None = None):
        self.name = name
        self.cols = TABLES[name]
        self.names = [n for n, _ in self.cols]
        self.data: dict[str, list] = {n: [] for n in self.names}
        self.capture_hash = capture_hash
        self.n = 0

    def add(self, row: dict) -> None:
        # columns the table derives (not event fields): an event's own value of that name goes to extra
        derived = {"capture_hash", "ts", "extra"} if self.capture_hash is not None else {"ts", "extra"}
        extra = {k: v for k, v in row.items() if (k not in self.data or k in derived) and v is not None}
        if "kind" not in self.data:   # the table says the kind
            extra.pop("kind", None)
        if self.name == "captures":   # the writer's own row: its time stamps are the columns
            extra = {k: v for k, v in extra.items() if k not in derived}
        for n, t in self.cols:
            if n == "capture_hash" and self.capture_hash is not None:
                v = self.capture_hash
            elif n == "ts":
                v = row.get("ts_ns") if isinstance(row.get("ts_ns"), int) else None
            elif n == "extra":
                v = None   # filled below, once the wrongly typed values are known
            else:
                v = row.get(n)
                if v is not None:
                    if t == JSON:
                        v = _json(v)
                    elif not _fits(t, v):
                        extra[n] = v   # never a wrongly typed cell: the value moves to extra
                        v = None
            self.data[n].append(v)
        if extra and "extra" in self.data:
            self.data["extra"][-1] = _json(extra)
        self.n += 1

    def clear(self) -> None:
        """Forget the rows held (they were written); ``n`` goes on counting."""
        self.data = {k: [] for k in self.names}

    def held(self) -> int:
        return len(self.data[self.names[0]]) if self.names else 0

    def table(self) -> pa.Table:
        schema = arrow_schema(self.name)
        arrays = []
        for (n, t), f in zip(self.cols, schema):
            if pa.types.is_timestamp(f.type):   # held as ns integers
                arrays.append(ts_array(self.data[n]))
            else:
                arrays.append(column(self.data[n], arrow_type(t)))
        return pa.Table.from_arrays(arrays, schema=schema)
