"""What the column sinks (mcap_sink.py, jsonl_sink.py) share: the event a row stands for, and
the order in which held rows and events are written.

Held rows are written once ``HOLD_ROWS`` of them are held (or at the end): the per-stream work of
a flush then covers many driver batches.

Rows are the engine's ``StreamBatch`` (one per cyclic frame: the reference path's ``rt`` event)
and ``CycleBatch`` (one per data object and frame: its ``telegram`` event). ``rt_event`` and
``telegram_event`` build those events for one row, as Analyzer._pn_rt and
CyclicTracker._telegram_event do: the sinks use them for a channel's first message, to compile
their templates, and for what the column form does not cover.

Order: the reference writes, per frame, the rt event, then capture gaps and a length mismatch,
then each data object's telegram event, then what judging the frame emitted. Events reach a sink
in capture order but without the frame that emitted them, so an event is placed at its own frame,
or at the latest frame an earlier event was placed at (a violation decided later names an earlier
frame); rows and events are merged by (frame, rank, object, arrival).
"""
from __future__ import annotations

from dataclasses import replace

import numpy as np

from . import iodata
from . import telegrams as tg
from .proto import rt
from .proto.eth import decode_link
from .sinks import Sink

RANK_RT, RANK_BEFORE, RANK_TELEGRAM, RANK_AFTER = 0, 1, 2, 3
HOLD_ROWS = 1 << 15   # rows held before a flush point writes them (more: no faster, 300 MB peak RSS at 1 << 18)


def _rank(ev: dict) -> int:
    k = ev.get("kind")
    if k == "capture_gap" or (k == "violation" and ev.get("rule") == "TELEGRAM-LENGTH-MISMATCH"):
        return RANK_BEFORE
    return RANK_AFTER


def object_order(axis: dict) -> int:
    """Order of a frame's telegram rows (the reference follows the data objects' order in the frame)."""
    try:
        return (int(axis.get("slot") or 0) << 16) | int(axis.get("subslot") or 0)
    except (TypeError, ValueError):
        return 0


def signal_names(batch) -> tuple:
    """A CycleBatch's signals in the order the telegram layout decodes them."""
    t, d = batch.axis.get("telegram"), batch.direction
    if t in tg.TELEGRAMS and d in tg.DIRECTIONS:
        names = tg.layout(t, d).names
        if set(names) == set(batch.signals):
            return names
    return tuple(batch.signals)


def rt_event(b, i: int, with_iodata: bool) -> dict:
    """The ``rt`` event of row i of StreamBatch ``b``."""
    row = b.data[i].tobytes()
    fid, src, dst = b.key
    ev = {"frame": int(b.frame[i]), "ts_ns": int(b.ts_ns[i]), "kind": "rt", "src": src, "dst": dst,
          "frame_id": fid, "frame_class": rt.classify(fid)[0]}
    tags = decode_link(1, row)[4]
    if tags:
        ev["vlan"] = [{"tpid": t[0], "priority": t[1], "dei": t[2], "id": t[3]} for t in tags]
    ev.update(rt.decode_apdu_status(row, b.off))
    if with_iodata:
        io = iodata.decode(b.fm, row[b.off + 2:len(row) - 4])
        if io is not None:
            ev["iodata"] = io
    return ev


def telegram_event(b, i: int) -> dict:
    """The ``telegram`` event of row i of CycleBatch ``b``."""
    ax = b.axis
    sig = {n: int(b.signals[n][i]) for n in signal_names(b)}
    bits = tg.bits(sig, ax.get("profile") or "generic")
    iops = int(b.iops[i])
    ev = {"frame": int(b.frame[i]), "ts_ns": int(b.ts_ns[i]), "kind": "telegram", "direction": b.direction,
          "telegram": ax.get("telegram"), "telegram_source": ax.get("telegram_source"), "station": ax.get("station"),
          "device_mac": ax.get("device_mac"), "api": ax.get("api"), "slot": ax.get("slot"),
          "subslot": ax.get("subslot"), "frame_id": b.frame_id, "iops": None if iops < 0 else iops,
          "judged": bool(b.judged[i]), "signals": sig, "bits": bits}
    if bits.get("g1_zsw.sensor_error") and "g1_xist2" in sig:   # as CyclicTracker._telegram_event
        ev["xist2_error"] = {"code": sig["g1_xist2"], "text": tg.error_text(sig["g1_xist2"])}
    return ev


def sensor_error_rows(b, names, profile: str):
    """Rows whose telegram event carries ``xist2_error`` (sensor error bit set, G1_XIST2 present)."""
    if "g1_zsw" not in names or "g1_xist2" not in names:
        return None
    for name, shift, mask in tg.bit_fields("g1_zsw", profile):
        if name == "sensor_error":
            return ((np.asarray(b.signals["g1_zsw"], np.int64) >> shift) & mask) != 0
    return None


class Held:
    """Events and row batches a sink holds until ``flush_point``."""

    def __init__(self, freeze=dict):
        # events are copied on arrival (``freeze``; a shallow copy: what the analyzer still does to an
        # event after emitting it is adding a member -- a record write gets its ``result`` when the
        # response comes -- and the reference wrote it before that)
        self.freeze = freeze
        self.events: list = []     # (frame placed at, rank, order, event)
        self.batches: list = []    # [kind, batch, first row not yet taken]
        self.rows = 0              # rows held
        self.pos = None

    def event(self, ev: dict, at: int | None = None, after_rows: bool | None = None) -> None:
        """``at``: the frame whose processing emitted ``ev``, when the driver knows it (exact order);
        ``after_rows``: False when that frame's telegram rows had not begun (the event goes before them)."""
        for fn in (at,) if at is not None else (ev.get("frame"), ev.get("last_frame")):
            # without ``at``: a violation is decided at its last frame or later
            if fn.__class__ is int and (self.pos is None or fn > self.pos):
                self.pos = fn
        rank = _rank(ev)
        if after_rows is False and rank == RANK_AFTER:
            rank = RANK_BEFORE
        self.events.append((self.pos if self.pos is not None else 0, rank, 0, self.freeze(ev), at is not None))

    def batch(self, kind: str, b) -> None:
        if len(b):
            self.batches.append([kind, b, 0])
            self.rows += len(b)

    def take(self, frame: int | None):
        """(parts (kind, batch, lo, hi) with rows up to ``frame`` (None: all), events) and forget them."""
        parts, keep = [], []
        for item in self.batches:
            kind, b, lo = item
            hi = len(b) if frame is None else int(np.searchsorted(b.frame, frame, side="right"))
            if hi > lo:
                parts.append((kind, b, lo, hi))
            if hi < len(b):
                item[2] = max(lo, hi)
                keep.append(item)
        self.batches = keep
        self.rows = sum(len(b) - lo for _, b, lo in keep)
        evs, self.events = self.events, []
        if frame is not None and (self.pos is None or frame > self.pos):
            self.pos = frame
        return _coalesce(parts), evs


def _coalesce(parts) -> list:
    """Parts of one stream / data object with one template, one after the other in frame order, as
    one part: the per-part work of a flush is paid once per stream, not once per driver batch."""
    groups: dict = {}
    for p in parts:
        kind, b = p[0], p[1]
        sig = rt_signature(b) if kind == "rt" else telegram_signature(b)
        groups.setdefault(sig, []).append(p)
    out = []
    for ps in groups.values():
        ps.sort(key=lambda p: int(p[1].frame[p[2]]))
        if len(ps) == 1 or any(int(a[1].frame[a[3] - 1]) >= int(c[1].frame[c[2]]) for a, c in zip(ps, ps[1:])):
            out += ps
            continue
        kind, b0 = ps[0][0], ps[0][1]

        def cat(get):
            return np.concatenate([get(b)[lo:hi] for _, b, lo, hi in ps])
        if kind == "rt":
            nb = replace(b0, frame=cat(lambda b: b.frame), ts_ns=cat(lambda b: b.ts_ns), data=cat(lambda b: b.data))
        else:
            nb = replace(b0, frame=cat(lambda b: b.frame), ts_ns=cat(lambda b: b.ts_ns), iops=cat(lambda b: b.iops),
                         judged=cat(lambda b: b.judged),
                         signals={n: cat(lambda b, n=n: b.signals[n]) for n in b0.signals})
        out.append((kind, nb, 0, len(nb)))
    return out


def merge(rows, events, on_rows, on_event) -> None:
    """Write held rows and events in the reference's order. ``rows``: list of (frames, rank, order)
    arrays per source (row r of source s is global row offset[s] + r); ``events``: list of (frame,
    rank, order, payload). Calls on_rows(global row indices) for each run of rows between events
    and on_event(payload) for each event, in order."""
    n_rows = sum(len(f) for f, _, _ in rows)
    n = n_rows + len(events)
    if not n:
        return
    frame = np.empty(n, np.int64)
    rank = np.empty(n, np.int64)
    sub = np.empty(n, np.int64)
    at = 0
    for f, r, o in rows:
        k = len(f)
        frame[at:at + k] = f
        rank[at:at + k] = r
        sub[at:at + k] = o
        at += k
    for j, e in enumerate(events):
        frame[at + j], rank[at + j], sub[at + j] = e[0], e[1], e[2]
    seq = np.arange(n, dtype=np.int64)   # rows of a source, events: in arrival order
    order = np.lexsort((seq, sub, rank, frame))
    evs = np.flatnonzero(order >= n_rows)
    start = 0
    for e in evs.tolist():
        if e > start:
            on_rows(order[start:e])
        on_event(events[int(order[e]) - n_rows][3])
        start = e + 1
    if start < n:
        on_rows(order[start:])


# -- shapes: a row's event with a coltext.Val in place of every per-row value -------------------------
OPTIONAL = "\x03"   # coltext.Pool.template: an optional member (xist2_error)


def rt_signature(b) -> tuple:
    """What an rt row's template depends on besides its values (a sink caches templates by it)."""
    fm = b.fm
    return ("rt", b.key, b.off, b.data.shape[1], None if fm is None else (id(fm), fm.source, fm.released))


def _ioxs_ids(pool, dumps) -> np.ndarray:
    """Pool entries of the 256 IOxS texts (iodata.ioxs), made once per pool."""
    if pool.ioxs_ids is None:
        pool.ioxs_ids = np.array([pool.entry(dumps(iodata.ioxs(v)).encode()) for v in range(256)], np.int64)
    return pool.ioxs_ids


def rt_shape(b, lo: int, with_iodata: bool, pool, dumps):
    """(event shape, recipe) of StreamBatch b's rows like row ``lo``; None when their link header
    is not one the columns cover (stacked VLAN tags): the caller builds their events one by one.
    The recipe turns rows into the shape's columns (``rt_columns``)."""
    from .coltext import BITS, INT, PICK, Val

    ev = rt_event(b, lo, with_iodata)
    cap = b.data.shape[1]
    shape = dict(ev)
    shape["frame"], shape["ts_ns"] = Val(INT, 0), Val(INT, 1)
    shape["cycle_counter"], shape["ds"], shape["transfer_status"] = Val(INT, 2), Val(INT, 3), Val(INT, 4)
    for mask, name in rt.DS_BITS:
        shape[name] = Val(BITS, 3, mask.bit_length() - 1, 1)
    n = 5
    if b.off == 18 and len(ev.get("vlan", ())) == 1:
        shape["vlan"] = [{"tpid": Val(INT, 5), "priority": Val(BITS, 6, 13, 7), "dei": Val(BITS, 6, 12, 1),
                          "id": Val(BITS, 6, 0, 0xFFF)}]
        n = 7
    elif b.off != 14 or "vlan" in ev:
        return None
    offs, ids = [], None
    if "iodata" in ev:   # every IOxS byte a pick from the 256 texts iodata.ioxs gives
        ids = _ioxs_ids(pool, dumps)

        def marker(o):
            offs.append(b.off + 2 + o)
            return Val(PICK, n + len(offs) - 1)
        shape["iodata"] = iodata.decode(b.fm, list(range(cap - b.off - 6)), marker)
    return shape, (b.off == 18 and n == 7, offs, ids)


def rt_columns(b, lo: int, hi: int, recipe) -> list | None:
    """int64 columns of rows lo..hi-1 for ``recipe`` (None: a row's VLAN header differs from it)."""
    from .proto.eth import VLAN_TPIDS

    tagged, offs, ids = recipe
    d = b.data[lo:hi]
    cap = d.shape[1]
    cols = [np.asarray(b.frame[lo:hi], np.int64), np.asarray(b.ts_ns[lo:hi], np.int64),
            (d[:, cap - 4].astype(np.int64) << 8) | d[:, cap - 3], d[:, cap - 2].astype(np.int64),
            d[:, cap - 1].astype(np.int64)]
    if tagged:
        tpid = (d[:, 12].astype(np.int64) << 8) | d[:, 13]
        ok = (tpid == VLAN_TPIDS[0]) | (tpid == VLAN_TPIDS[1]) | (tpid == VLAN_TPIDS[2])
        if not ok.all() or (d[:, 16] != 0x88).any() or (d[:, 17] != 0x92).any():
            return None
        cols += [tpid, (d[:, 14].astype(np.int64) << 8) | d[:, 15]]
    for o in offs:
        cols.append(ids[d[:, o]])
    return cols


def telegram_signature(b) -> tuple:
    ax = b.axis
    return ("tg", tuple(ax.items()), b.direction, b.frame_id, tuple((n, c.dtype.str) for n, c in b.signals.items()))


def telegram_shape(b, lo: int, pool, dumps):
    """(event shape, recipe) of CycleBatch b's rows like row ``lo`` (see ``telegram_columns``)."""
    from .coltext import BITS, INT, NINT, PICK, U64, Val

    ev = telegram_event(b, lo)
    names = signal_names(b)
    profile = b.axis.get("profile") or "generic"
    shape = {k: v for k, v in ev.items() if k != "xist2_error"}
    shape["frame"], shape["ts_ns"], shape["iops"], shape["judged"] = Val(INT, 0), Val(INT, 1), Val(NINT, 2), Val(PICK, 3)
    sig, at = {}, {}
    for i, n in enumerate(names):
        sig[n] = Val(U64 if b.signals[n].dtype == np.uint64 else INT, 4 + i)
        at[n] = 4 + i
    shape["signals"] = sig
    shape["bits"] = {f"{s}.{name}": Val(BITS, at[s], shift, mask)
                     for s in names if s in tg.BITMAPS for name, shift, mask in tg.bit_fields(s, profile)}
    xist = "g1_zsw" in names and "g1_xist2" in names
    if xist:
        shape[OPTIONAL] = Val(PICK, 4 + len(names))
    return shape, (names, profile, xist, pool.entry(b"true"), pool.entry(b"false"), pool.entry(b""))


def telegram_columns(b, lo: int, hi: int, recipe, pool, dumps) -> list:
    names, profile, xist, true, false, empty = recipe
    cols = [np.asarray(b.frame[lo:hi], np.int64), np.asarray(b.ts_ns[lo:hi], np.int64),
            np.asarray(b.iops[lo:hi], np.int64), np.where(np.asarray(b.judged[lo:hi], bool), true, false)]
    for n in names:
        c = np.asarray(b.signals[n][lo:hi])
        cols.append(c.view(np.int64) if c.dtype == np.uint64 else c.astype(np.int64))
    if xist:
        err = sensor_error_rows(b, names, profile)[lo:hi]
        xs = np.full(hi - lo, empty, np.int64)
        if err.any():
            code = cols[4 + names.index("g1_xist2")]
            for c in np.unique(code[err]).tolist():
                text = dumps({"xist2_error": {"code": c, "text": tg.error_text(c)}}).encode()
                xs[err & (code == c)] = pool.entry(b"," + text[1:-1])
        cols.append(xs)
    return cols


def place(events, axes: dict) -> list:
    """Events with a better frame for the ones decided later than they name: a cyclic rule's
    violation names the cycle (its actual value's frame; a run or deadline: first and last) and is
    decided when the axis' next actual value is judged, when that is among the held rows (``axes``:
    (device_mac, slot, subslot) -> sorted frames of its actual-value rows). Arrival order is kept
    (frames never decrease)."""
    out, prev = [], None
    for f, r, o, ev, exact in events:
        last = ev.get("last_frame")
        if not exact and ev.get("kind") == "violation" and last.__class__ is int and r == RANK_AFTER:
            fr = axes.get((ev.get("device_mac"), ev.get("slot"), ev.get("subslot")))
            if fr is not None and len(fr) and fr[min(int(np.searchsorted(fr, last)), len(fr) - 1)] == last:
                i = int(np.searchsorted(fr, last, side="right"))
                if i < len(fr) and fr[i] > f:
                    f = int(fr[i])
        if prev is not None and f < prev:
            f = prev
        prev = f
        out.append((f, r, o, ev))
    return out


def axis_frames(parts) -> dict:
    """(device_mac, slot, subslot) -> sorted frames of the actual-value rows among ``parts``."""
    by: dict = {}
    for kind, b, lo, hi in parts:
        if kind == "tg" and b.direction == "actual":
            ax = b.axis
            by.setdefault((ax.get("device_mac"), ax.get("slot"), ax.get("subslot")), []).append(b.frame[lo:hi])
    return {k: np.sort(np.concatenate(v)) for k, v in by.items()}


class HeldSink(Sink):
    """The column sinks' side of the sink contract (pndiss/mcap_sink.py, pndiss/jsonl_sink.py): events and
    rows are held (``self.held``, a Held) and written merged in the reference order once ``hold_rows``
    rows wait at a flush point; the subclass writes (``_flush``)."""

    def event(self, ev: dict, at: int | None = None, after_rows: bool | None = None) -> None:
        self.held.event(ev, at, after_rows)

    def cycle_batch(self, batch) -> None:
        self.held.batch("tg", batch)

    def stream_batch(self, batch) -> None:
        self.held.batch("rt", batch)

    def flush_point(self, frame: int) -> None:
        if self.held.rows >= self.hold_rows:
            self._flush(frame)

