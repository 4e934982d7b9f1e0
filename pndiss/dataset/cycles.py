"""The ``cycles`` table from CycleBatch columns: thinned and converted as arrays, never a dict per row.

Volume as the MCAP export offers it (pndiss/mcap_export.py):
- ``full``: every data object of every cyclic frame;
- ``on_change`` (default): a row when the words (their sign-of-life counters left out: they step every
  cycle, telegrams.CHANGE_MASKS), IOPS or ``judged`` change against the axis' previous
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
from ..telegrams import CHANGE_MASKS
from . import arrays
from .schema import CYCLES_HEAD, arrow_schema, bit_columns, ts_array

ROW_GROUP = 1 << 16   # rows held before a row group is written
CONST_BYTES = 8 << 20  # memory of the cached constant columns (station names, MACs, ...) at most
STATS_COLUMNS = ("api", "slot", "subslot", "telegram", "frame_id", "frame", "ts_ns", "ts")   # see _write
STR_DICT = pa.dictionary(pa.int32(), pa.string())   # how the axis's strings reach the writer (see __init__)
COALESCE = 1 << 12    # rows of one axis and direction gathered before they are thinned and become one Arrow
                      # batch (the engine's batches are often small; per-batch costs are per column, ~60 of them)


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

    def __init__(self, path: str, capture_hash: str, mode="on_change", keyframe_s: float = 1.0,
                 write_thread: bool = True):
        self.on_change, self.decimate, self.enabled = parse_mode(mode)
        self.mode = "none" if not self.enabled else str(mode)
        self.keyframe_ns = max(1, int(keyframe_s * 1e9))
        self.path, self.capture_hash = path, capture_hash
        plain = arrow_schema("cycles", {"pndiss.cycles_mode": self.mode})
        # The strings of a row (hash, station, MAC, profile, direction) are the axis' and repeat on
        # every row: handed to the writer as dictionary arrays (one value, zero indices), they are
        # written without hashing a million equal strings. The file says "string" all the same: it
        # is written without the Arrow schema (store_schema=False) and with the metadata added.
        self.schema = pa.schema([pa.field(f.name, STR_DICT) if pa.types.is_string(f.type) else f for f in plain],
                                metadata=plain.metadata)
        self.types = {f.name: f.type for f in self.schema}
        self.sig_names = list(tg.SIGNALS)
        self.bit_np = {c: (np.uint8 if t == pa.uint8() else np.int64) for c, t in bit_columns()}
        self.names = self.schema.names
        self._consts: dict = {}
        self._consts_bytes = 0
        self._failed: BaseException | None = None   # a row group that could not be written
        self._bit_plans: dict = {}
        self.axes: dict = {}
        self.pending: list[pa.RecordBatch] = []
        self.pending_rows = 0
        self.gather: dict = {}   # (axis, direction) -> [batches in frame order, rows, their shape]
        self.rows = 0
        self.seen = 0
        self.writer = None
        # Row groups are encoded and written on one thread (Arrow releases the GIL for the whole call)
        # while the engine goes on; at most one row group in flight bounds the memory. Thinning and
        # conversion stay here: many small GIL-releasing calls on a second thread cost more than they save.
        self.write_thread = write_thread
        self._pool = None
        self._inflight = None

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
            cols += [np.asarray(b.signals[s]).astype(np.int64, copy=False) & CHANGE_MASKS.get(s, -1)
                     for s in sorted(b.signals)]   # (not the sign-of-life counters: telegrams.CHANGE_MASKS)
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
        # Gather the batches of one axis and direction; thinning and conversion work on the gathered
        # rows at once (the engine's batches are often a few hundred rows: per-batch costs would rule).
        # The axis is kept as it is now: the engine's dict may change after the hand-over.
        ax = b.axis
        axis_items = tuple(ax.items())
        key = (ax.get("device_mac"), ax.get("api"), ax.get("slot"), ax.get("subslot"), b.direction)
        shape = (b.frame_id, axis_items, tuple((k, np.asarray(v).dtype.str) for k, v in b.signals.items()))
        g = self.gather.get(key)
        if g is not None and g[2] != shape:   # the axis changed (a relabel): what came before goes first
            self._gathered(key)
            g = None
        if g is None:
            g = self.gather[key] = [[], 0, shape]
        g[0].append(b)
        g[1] += len(b)
        if g[1] >= COALESCE:
            self._gathered(key)

    def _gathered(self, key) -> None:
        """The rows gathered for one axis and direction, thinned, as one Arrow batch (in frame order)."""
        parts, n, (_fid, axis_items, _dt) = self.gather.pop(key)
        b0 = parts[0]
        if len(parts) == 1:
            b = replace(b0, axis=dict(axis_items))
        else:
            cat = np.concatenate
            b = replace(b0, axis=dict(axis_items), frame=cat([p.frame for p in parts]),
                        ts_ns=cat([p.ts_ns for p in parts]), iops=cat([p.iops for p in parts]),
                        judged=cat([p.judged for p in parts]),
                        signals={k: cat([np.asarray(p.signals[k]) for p in parts]) for k in b0.signals})
        keep = self._keep(key, b)
        if keep is not None and not keep.any():
            return
        rb = self._record_batch(b, keep)
        self.pending.append(rb)
        self.pending_rows += rb.num_rows
        if self.pending_rows >= ROW_GROUP:   # after every gather: an axis flushed on each shape change too
            self._write()

    def _bit_plan(self, sig: str, profile: str):
        """(columns, shifts, masks, numpy types) of the named bits of ``sig`` for ``profile``, or None."""
        k = (sig, profile)
        if k not in self._bit_plans:
            rows = [(f"{sig}.{n}", sh, mk) for n, sh, mk in tg.bit_fields(sig, profile) if f"{sig}.{n}" in self.bit_np]
            self._bit_plans[k] = None if not rows else (
                [r[0] for r in rows], np.array([[r[1]] for r in rows], np.uint64),
                np.array([[r[2]] for r in rows], np.uint64), [self.bit_np[r[0]] for r in rows])
        return self._bit_plans[k]

    def _const(self, name: str, t: pa.DataType, v, n: int) -> pa.Array:
        """A column of ``n`` times ``v``: a slice of one array per (column, value) kept for the
        capture (slicing is free; building n strings per batch, and a scalar each time, is not)."""
        key = (name, v)
        a = self._consts.get(key)
        if a is None or len(a) < n:
            m = max(n, 2 * len(a) if a is not None else COALESCE)
            if v is None:
                a = pa.nulls(m, t)
            elif t == STR_DICT:
                a = pa.DictionaryArray.from_arrays(arrays.numeric(np.zeros(m, np.int32)), arrays.strings([v]))
            else:
                a = arrays.repeat(v, t, m)
            if self._consts_bytes + a.nbytes > CONST_BYTES:   # many axes, long names: start again, bounded
                self._consts.clear()
                self._consts_bytes = 0
            self._consts[key] = a
            self._consts_bytes += a.nbytes
        return a.slice(0, n)

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
        for name, _t in CYCLES_HEAD:
            if name in const:
                cols[name] = self._const(name, self.types[name], const[name], n)
        cols["frame"] = arrays.numeric(frame)
        cols["ts_ns"] = arrays.numeric(ts)
        cols["ts"] = ts_array(ts)
        cols["iops"] = arrays.numeric(sel(np.asarray(b.iops)).astype(np.int16, copy=False))
        cols["judged"] = arrays.numeric(sel(np.asarray(b.judged, bool)))
        words = {}
        for s in self.sig_names:
            if s in b.signals:
                w = words[s] = sel(np.asarray(b.signals[s]))
                t = self.types[s]
                cols[s] = arrays.numeric(w, t)   # a safe cast: a value out of range raises
        profile = ax.get("profile") or "generic"
        for sig, w in words.items():
            plan = self._bit_plan(sig, profile)
            if plan is None:
                continue
            names, shifts, masks, dtypes = plan
            # every bit field of the word at once: row j of the (fields, rows) matrix is field j
            m = (w.astype(np.uint64, copy=False)[None, :] >> shifts) & masks
            narrow = m.astype(np.uint8)   # mask <= the column's width: exact
            for j, col in enumerate(names):
                cols[col] = arrays.numeric(narrow[j] if dtypes[j] is np.uint8 else m[j].astype(np.int64))
        return pa.RecordBatch.from_arrays([cols[c] if c in cols else self._const(c, self.types[c], None, n)
                                           for c in self.names], schema=self.schema)

    def _write(self) -> None:
        import pyarrow.parquet as pq
        if not self.pending:
            return
        if self.writer is None:
            # counters, times and positions move by small steps: delta encoding makes them a few bits
            # a row and writes faster than dictionaries of distinct values; bit fields (uint8) are
            # written plain (faster still, zstd makes them as small); the axis' strings repeat
            strs = [f.name for f in self.schema if f.type == STR_DICT]
            deltas = {f.name: "DELTA_BINARY_PACKED" for f in self.schema
                      if (pa.types.is_integer(f.type) and f.type != pa.uint8()) or pa.types.is_timestamp(f.type)}
            # min/max statistics where a reader prunes row groups by them (the axis' numbers, frames,
            # times); not on the constant strings (their min/max over dictionary arrays cost ~12 % of
            # the encoding) nor on signals and bits (bench/NOTES.md, "The Parquet sink")
            stats = [n for n in STATS_COLUMNS if n in self.types]
            # an older pyarrow without add_key_value_metadata keeps the Arrow schema (and so the metadata)
            add_kv = hasattr(pq.ParquetWriter, "add_key_value_metadata")
            self.writer = pq.ParquetWriter(self.path, self.schema, compression="zstd", use_dictionary=strs,
                                           column_encoding=deltas, store_schema=not add_kv, write_statistics=stats)
            if add_kv:
                self.writer.add_key_value_metadata(self.schema.metadata)
        if self._failed is not None:   # the file is broken: nothing more goes into it
            raise self._failed
        table = pa.Table.from_batches(self.pending, schema=self.schema)
        self.pending, self.pending_rows = [], 0
        if not self.write_thread:
            self._written(table)
            return
        self._wait()
        if self._pool is None:
            from concurrent.futures import ThreadPoolExecutor
            self._pool = ThreadPoolExecutor(1, thread_name_prefix="pndiss-parquet-cycles")
        self._inflight = self._pool.submit(self._written, table)

    def _written(self, table) -> None:
        """Write one row group; rows count once they are in the file, a failure is kept."""
        try:
            self.writer.write_table(table)
        except BaseException as e:
            self._failed = e
            raise
        self.rows += table.num_rows

    def _wait(self) -> None:
        """The row group in flight written; its error (a full disk, say) raised here."""
        f, self._inflight = self._inflight, None
        if f is not None:
            f.result()

    def _stop(self) -> None:
        if self._pool is not None:
            self._pool.shutdown(wait=True)
            self._pool = None

    def close(self) -> int:
        """Write what is held; returns the rows written (0: no file was made)."""
        try:
            for key in list(self.gather):
                self._gathered(key)
            if self.pending:
                self._write()
            self._wait()
        finally:
            self._stop()
        if self._failed is not None:
            raise self._failed
        if self.writer is not None:
            self.writer.close()
            self.writer = None
        return self.rows

    def abort(self) -> None:
        """Close the file without writing what is held (an interrupted capture)."""
        self.pending, self.pending_rows = [], 0
        self.gather = {}
        try:
            self._wait()
        except Exception:  # already failing (a full disk): the file is removed anyway
            pass
        self._stop()
        if self.writer is not None:
            try:
                self.writer.close()
            except Exception:  # already failing (a full disk): the file is removed anyway
                pass
            self.writer = None
