"""The ``cycles`` table from CycleBatch columns: thinned and converted as arrays, never a dict per row.

Volume as the MCAP export offers it (pndiss/mcap_export.py):
- ``full``: every data object of every cyclic frame;
- ``on_change`` (default): a row when the words, IOPS or ``judged`` change against the axis' previous
  row in that direction, plus a keyframe: the first row of every ``keyframe_s`` time slot (so a
  reader finds the current values at most one slot back);
- ``decimate:N``: every Nth row of the axis and direction; ``on_change,decimate:N`` both;
- ``none``: no cycles table.
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np
import pyarrow as pa

from .. import telegrams as tg
from .schema import CYCLES_HEAD, TABLES, arrow_schema, bit_columns, ts_array

ROW_GROUP = 1 << 16   # rows held before a row group is written
COALESCE = 1 << 11    # rows of one axis and direction gathered before they become one Arrow batch (the
                      # engine's batches are often small; Arrow's per-batch cost is per column, ~40 of them)


def parse_mode(mode) -> tuple[bool, int, bool]:
    """(on_change, decimate, enabled) from "full" / "on_change" / "decimate:N" / "on_change,decimate:N" / "none"."""
    if mode is None or mode == "none":
        return False, 1, False
    on_change, dec = False, 1
    for part in str(mode).replace("+", ",").split(","):
        part = part.strip()
        if part == "on_change":
            on_change = True
        elif part.startswith("decimate:") and part[9:].isdigit() and int(part[9:]) >= 1:
            dec = int(part[9:])
        elif part != "full":
            raise ValueError(f"cycles mode {mode!r}: expected full, on_change, decimate:N or none")
    return on_change, dec, True


class _Axis:
    """What thinning remembers of one axis and direction between batches."""
    __slots__ = ("n", "last", "last_slot")

    def __init__(self):
        self.n = 0            # rows seen (decimation counts them)
        self.last = None      # the previous row's key values (on_change)
        self.last_slot = None


class CycleTable:
    """Writes the cycles table of one capture to ``path`` (a Parquet file) as batches arrive."""

    def __init__(self, path: str, capture_hash: str, mode="on_change", keyframe_s: float = 1.0):
        self.on_change, self.decimate, self.enabled = parse_mode(mode)
        self.mode = "none" if not self.enabled else str(mode)
        self.keyframe_ns = max(1, int(keyframe_s * 1e9))
        self.path, self.capture_hash = path, capture_hash
        self.schema = arrow_schema("cycles", {"pndiss.cycles_mode": self.mode})
        self.types = {n: t for n, t in TABLES["cycles"]}
        self.sig_names = list(tg.SIGNALS)
        self.bits = bit_columns()
        self.axes: dict = {}
        self.pending: list[pa.RecordBatch] = []
        self.pending_rows = 0
        self.gather: dict = {}   # shape of a batch (axis, direction, its signals) -> [kept parts, rows]
        self.rows = 0
        self.seen = 0
        self.writer = None

    # -- thinning -------------------------------------------------------------------------
    def _keep(self, key, b) -> np.ndarray | None:
        n = len(b)
        st = self.axes.get(key)
        if st is None:
            st = self.axes[key] = _Axis()
        idx0, st.n = st.n, st.n + n
        if not self.on_change and self.decimate == 1:
            return None   # every row
        keep = np.zeros(n, bool)
        if self.decimate > 1:
            keep |= (np.arange(idx0, idx0 + n) % self.decimate) == 0
        if self.on_change:
            cols = [b.iops.astype(np.int64), b.judged.astype(np.int64)]
            cols += [np.asarray(b.signals[s]).astype(np.int64, copy=False) for s in sorted(b.signals)]
            m = np.stack(cols)
            prev = np.empty_like(m)
            prev[:, 1:] = m[:, :-1]
            if st.last is not None and len(st.last) == m.shape[0]:
                prev[:, 0] = st.last
                keep |= (m != prev).any(axis=0)
            else:
                keep[0] = True
                if n > 1:
                    keep[1:] |= (m[:, 1:] != prev[:, 1:]).any(axis=0)
            st.last = m[:, -1].copy()
            slot = b.ts_ns // self.keyframe_ns
            first = np.empty(n, bool)
            first[1:] = slot[1:] != slot[:-1]
            first[0] = st.last_slot is None or slot[0] != st.last_slot
            keep |= first
            st.last_slot = slot[-1]
        return keep

    # -- batches -----------------------------------------------------------------------------
    def add(self, b) -> None:
        if not self.enabled or len(b) == 0:
            return
        self.seen += len(b)
        ax = b.axis
        key = (ax.get("device_mac"), ax.get("api"), ax.get("slot"), ax.get("subslot"), b.direction)
        keep = self._keep(key, b)
        part = b if keep is None else replace(b, frame=b.frame[keep], ts_ns=b.ts_ns[keep], iops=b.iops[keep],
                                               judged=b.judged[keep],
                                               signals={k: np.asarray(v)[keep] for k, v in b.signals.items()})
        if len(part) == 0:
            return
        shape = (key, b.frame_id, tuple(ax.items()), tuple((k, np.asarray(v).dtype.str) for k, v in b.signals.items()))
        g = self.gather.get(shape)
        if g is None:
            g = self.gather[shape] = [[], 0]
        g[0].append(part)
        g[1] += len(part)
        if g[1] >= COALESCE:
            self._gathered(shape)
            if self.pending_rows >= ROW_GROUP:
                self._write()

    def _gathered(self, shape) -> None:
        """The parts gathered for one shape as one Arrow batch (rows of one axis stay in frame order)."""
        parts, n = self.gather.pop(shape)
        if len(parts) == 1:
            b = parts[0]
        else:
            b0 = parts[0]
            cat = np.concatenate
            b = replace(b0, frame=cat([p.frame for p in parts]), ts_ns=cat([p.ts_ns for p in parts]),
                        iops=cat([p.iops for p in parts]), judged=cat([p.judged for p in parts]),
                        signals={k: cat([np.asarray(p.signals[k]) for p in parts]) for k in b0.signals})
        rb = self._record_batch(b, None)
        self.pending.append(rb)
        self.pending_rows += rb.num_rows

    def _record_batch(self, b, keep) -> pa.RecordBatch:
        def sel(a):
            return a if keep is None else a[keep]
        frame = sel(np.asarray(b.frame, np.int64))
        n = len(frame)
        ax = b.axis
        ts = sel(np.asarray(b.ts_ns, np.int64))
        const = {"capture_hash": self.capture_hash, "direction": b.direction, "frame_id": b.frame_id,
                 **{k: ax.get(k) for k in ("station", "device_mac", "api", "slot", "subslot", "telegram",
                                           "telegram_source", "profile")}}
        cols = {}
        for name, t in CYCLES_HEAD:
            if name in const:
                v = const[name]
                cols[name] = pa.nulls(n, t) if v is None else pa.repeat(pa.scalar(v, t), n)
        cols["frame"] = pa.array(frame)
        cols["ts_ns"] = pa.array(ts)
        cols["ts"] = ts_array(ts)
        cols["iops"] = pa.array(sel(np.asarray(b.iops)).astype(np.int16))
        cols["judged"] = pa.array(sel(np.asarray(b.judged, bool)))
        words = {}
        for s in self.sig_names:
            if s in b.signals:
                words[s] = sel(np.asarray(b.signals[s]))
                cols[s] = pa.array(words[s]).cast(self.types[s])
            else:
                cols[s] = pa.nulls(n, self.types[s])
        profile = ax.get("profile") or "generic"
        have = {}
        for sig, w in words.items():
            for bname, shift, mask in tg.bit_fields(sig, profile):
                have[f"{sig}.{bname}"] = (w.astype(np.uint64) >> np.uint64(shift)) & np.uint64(mask)
        for col, t in self.bits:
            cols[col] = pa.array(have[col]).cast(t) if col in have else pa.nulls(n, t)
        return pa.RecordBatch.from_arrays([cols[f.name] for f in self.schema], schema=self.schema)

    def _write(self) -> None:
        import pyarrow.parquet as pq
        if not self.pending:
            return
        if self.writer is None:
            # counters, times and positions move by small steps: delta encoding makes them a few bits
            # a row and writes faster than dictionaries of distinct values; the axis' strings repeat
            strs = [f.name for f in self.schema if pa.types.is_string(f.type)]
            deltas = {f.name: "DELTA_BINARY_PACKED" for f in self.schema
                      if pa.types.is_integer(f.type) or pa.types.is_timestamp(f.type)}
            self.writer = pq.ParquetWriter(self.path, self.schema, compression="zstd", use_dictionary=strs,
                                           column_encoding=deltas)
        self.writer.write_table(pa.Table.from_batches(self.pending, schema=self.schema))
        self.rows += self.pending_rows
        self.pending, self.pending_rows = [], 0

    def close(self) -> int:
        """Write what is held; returns the rows written (0: no file was made)."""
        for shape in list(self.gather):
            self._gathered(shape)
        if self.pending:
            self._write()
        if self.writer is not None:
            self.writer.close()
            self.writer = None
        return self.rows


    def abort(self) -> None:
        """Close the file without writing what is held (an interrupted capture)."""
        self.pending, self.pending_rows = [], 0
        self.gather = {}
        if self.writer is not None:
            try:
                self.writer.close()
            except Exception:  # already failing (a full disk): the file is removed anyway
                pass
            self.writer = None
