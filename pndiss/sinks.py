"""Sinks: every output says what it consumes, so one driver serves all of them at engine speed.

The driver (pndiss/driver.py) reads the capture once and runs the engine; an output never reads
the capture itself. What a sink declares decides how much work the engine does per frame:

- ``kinds``: the event kinds it wants (``None``: every kind). Events of no wanted kind are never
  built for it. ``rt`` and ``telegram`` are per-frame kinds: a sink that wants them gets the
  frame-by-frame path (the reference decoders build one dict per frame).
- ``cycles``: per-cycle columns of every encoder axis (``CycleBatch``), produced from the engine's
  columns without a dict per frame -- the Parquet ``cycles`` table and the MCAP telegram topics.
- ``streams``: every cyclic frame of every stream as columns (``StreamBatch``: the frames' bytes as a
  2-D array) -- the MCAP APDU topics and the full per-frame JSONL, written column-wise.

Delivery order: events arrive in capture order. Cycle and stream batches arrive per axis / stream
with their rows in frame order; batches of different axes are not ordered among themselves, nor
against events, but every event and row up to frame N has been delivered when ``flush_point(N)``
is called (a sink that writes one
time-ordered stream merges what it holds up to N).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

# per-frame event kinds: a sink wanting one of them needs the frame-by-frame path
FRAME_KINDS = frozenset({"rt", "telegram"})


@dataclass
class CycleBatch:
    """Rows of one axis' data object in one direction: one row per cyclic frame, in frame order."""

    axis: dict                 # station, device_mac, api, slot, subslot, telegram, telegram_source, profile, ar_uuid
    direction: str             # "setpoint" (controller -> device) or "actual" (device -> controller)
    frame_id: int
    frame: np.ndarray          # int64 frame numbers (as Wireshark counts them)
    ts_ns: np.ndarray          # int64 capture time, ns since the epoch
    iops: np.ndarray           # int16 IOPS byte of the data object, -1 when the frame has none
    judged: np.ndarray         # bool: DataStatus, IOPS and AR phase let the reference encoder judge it
    signals: dict = field(default_factory=dict)  # signal name (telegrams.json) -> int64 / uint64 column

    def __len__(self) -> int:
        return len(self.frame)


@dataclass
class StreamBatch:
    """Frames of one cyclic stream (FrameID, src, dst) of one captured length, in frame order."""

    key: tuple                 # (frame_id, src MAC "aa:bb:..", dst MAC)
    frame: np.ndarray          # int64 frame numbers
    ts_ns: np.ndarray          # int64 capture time, ns since the epoch
    data: np.ndarray           # uint8 (rows, caplen): each frame's bytes from the destination MAC on
    off: int                   # where the FrameID starts in a row (14 untagged, 18 with one 802.1Q tag)
    fm: object = None          # the session's FrameMap for these rows (Analyzer._pn_rt's lookup): the
                               # JSONL rt lines' ``iodata``; a batch ends where the map changes

    def __len__(self) -> int:
        return len(self.frame)


class Sink:
    """Base class: a sink that consumes nothing. Override what you declare."""

    kinds: frozenset | None = frozenset()
    cycles: bool = False
    streams: bool = False
    digest: bool = False    # the input's SHA-256 (ReadInfo.sha256): hashed while read only when a sink says so

    def wants(self, kind: str) -> bool:
        return self.kinds is None or kind in self.kinds

    def event(self, ev: dict) -> None:
        """One event (a dict as docs/events.md describes) of a kind in ``kinds``."""

    def cycle_batch(self, batch: CycleBatch) -> None:
        """Rows of per-cycle columns (only when ``cycles`` is true)."""

    def stream_batch(self, batch: StreamBatch) -> None:
        """Frames of one cyclic stream as columns (only when ``streams`` is true)."""

    def flush_point(self, frame: int) -> None:
        """Every event and cycle row up to ``frame`` has been delivered."""

    def close(self) -> None:
        """End of the capture: write what is held, close files."""


def needs_frames(sinks) -> bool:
    """True when some sink wants per-frame events (the frame-by-frame path must run)."""
    return any(s.kinds is None or s.kinds & FRAME_KINDS for s in sinks)


class FuncSink(Sink):
    """A plain callable as a sink of the given kinds (``None``: all): tests and the JSONL writer."""

    def __init__(self, fn, kinds=None):
        self.fn = fn
        self.kinds = None if kinds is None else frozenset(kinds)

    def event(self, ev: dict) -> None:
        self.fn(ev)
