"""MCAP export for Foxglove: the event stream as JSON messages on per-encoder topics.

Every message is JSON with a ``jsonschema`` schema, so Foxglove plots it without plugins.
log_time = publish_time = capture time in integer ns, sequence = frame number. Topics
(docs/mcap.md):

  /pn/<station>/<slot>.<subslot>/tg<NN>/setpoint|actual  telegram events (one per direction)
  /pn/<station>/apdu/<frame_id>                           rt events of cyclic frames
  /pn/<station>/encoder_state                             state events (State Transitions panel)
  /pn/<station>/records                                   record / param / record_result events
  /pn/dcp  /pn/lldp  /pn/alarms  /pn/malformed            protocol events
  /pn/<kind>                                              any other event kind (rpc, ar, ptcp ...)
  /pn/violations                                          violations as foxglove.Log

One topic root (/pn/); every schema name is unique in a file (a telegram channel's schema is named
after its telegram and direction, a second one with other fields gets a suffix).

Streaming: per channel a few scalars, never a list of messages; the mcap writer keeps one
index entry per chunk. Volume control applies to the cyclic topics (telegram + apdu):
``on_change`` writes a sample only when its words / status change, plus a keyframe at least
every ``keyframe_ns``; ``decimate`` N also writes every Nth sample (alone: only every Nth).

Topics and messages per event kind are mcap_topics.py's (a mixin of McapExporter), schemas and the
JSON encoding mcap_schemas.py's; this file holds the file, the writer and the channel registry.

Two ways in, one file out: ``on_event`` takes event dicts (the reference path, any sink user);
``run`` analyses a capture through the one driver with pndiss/mcap_sink.py as its sink: the cyclic
frames' messages come from the engine's columns, without event dicts, through pndiss/mcap_writer.py.
tests/test_mcap.py requires both to write the same bytes (docs/mcap.md).
"""
from __future__ import annotations

import hashlib
import json
import os

from . import __version__
from .mcap_schemas import SCHEMAS, default, encode
from .mcap_topics import Channel, Topics
from .mcap_writer import McapWriter


class UnsupportedCompression(Exception):
    """The compression module (lz4) is not installed; str() is the module name."""


COMPRESSIONS = ("none", "lz4", "zstd")


class McapExporter(Topics):
    """Channels, schemas and messages for the event stream. ``on_event`` takes any event dict (the
    reference path); ``run`` analyses a capture and writes cyclic frames without event dicts (the
    fast path, same messages). ``_reference=True`` writes with mcap-python's Writer and makes ``run``
    use the plain event path: what the tests compare the fast path with."""

    def __init__(self, path: str, capture_path: str | None, settings=None, *, on_change: bool = False,
                 decimate: int = 1, keyframe_s: float = 1.0, compression: str = "zstd",
                 chunk_size: int = 1024 * 1024, _reference: bool = False):
        if compression not in COMPRESSIONS:
            raise ValueError(f"compression must be one of {', '.join(COMPRESSIONS)}")
        if decimate < 1:
            raise ValueError("decimate must be >= 1")
        self.path, self.capture_path, self.settings = path, capture_path, settings
        self.reader_info = None   # capture.ReadInfo of the run: the input's hash, taken while it was read
        self.on_change, self.decimate = on_change, int(decimate)
        self.keyframe_ns = int(keyframe_s * 1e9)
        self.compression = compression
        try:
            self._f = open(path, "wb")
        except OSError as e:
            from .errors import UsageError
            raise UsageError(f"cannot write {path}: {e.strerror}") from None
        self.reference = _reference
        try:
            if _reference:
                from mcap.writer import CompressionType, Writer
                self.w = Writer(self._f, chunk_size=chunk_size,
                                compression={"none": CompressionType.NONE, "lz4": CompressionType.LZ4,
                                             "zstd": CompressionType.ZSTD}[compression])
            else:
                self.w = McapWriter(self._f, chunk_size=chunk_size, compression=compression)
        except ImportError as e:  # lz4 not installed: leave no empty file behind
            self._f.close()
            os.remove(path)
            raise UnsupportedCompression(e.name or compression) from None
        except Exception:
            self._f.close()
            os.remove(path)
            raise
        self.w.start(profile="", library=f"pndiss {__version__}")
        self._schemas: dict[bytes, int] = {}
        self._schema_names: set[str] = set()
        self.telegram_channels: list[dict] = []  # topic, station, slot, subslot, telegram, side, signals, bits
        self._chans: dict[tuple, Channel] = {}
        self._names: dict[str, str] = {}    # MAC -> NameOfStation, as learnt from the events
        self._labels: dict[str, str] = {}   # MAC -> topic label, fixed at first use
        self._used_labels: set[str] = set()
        self._controllers: set[str] = set()  # MACs that are the controller of an AR
        self._topics: set[str] = set()
        self.seen: dict[str, int] = {}       # events seen per kind
        self.dropped = 0                     # cyclic samples left out by on_change / decimate
        self.closed = False
        self._kinds = {"rt": self._rt, "telegram": self._telegram, "state": self._state,
                       "record": self._record, "param": self._record, "record_result": self._record,
                       "violation": self._violation}
        self._thin = self.on_change or self.decimate > 1

    # -- plumbing ---------------------------------------------------------------------------
    def _schema_id(self, key: str, schema: dict) -> int:
        data = json.dumps(schema, sort_keys=True).encode()
        sid = self._schemas.get(data)
        if sid is None:
            # two different schemas never share a name (Foxglove keys datatypes by it)
            name, n = schema["title"], 1
            while name in self._schema_names:
                n += 1
                name = f"{schema['title']}_{n}"
            self._schema_names.add(name)
            body = data if name == schema["title"] else json.dumps({**schema, "title": name}, sort_keys=True).encode()
            sid = self._schemas[data] = self.w.register_schema(name, "jsonschema", body)
        return sid

    def _chan(self, ckey: tuple, topic: str, skey: str, meta: dict, schema: dict | None = None) -> Channel:
        sid = self._schema_id(skey, schema or SCHEMAS[skey])
        topic = self._unique(topic)
        cid = self.w.register_channel(topic, "json", sid, {k: str(v) for k, v in meta.items() if v is not None})
        ch = self._chans[ckey] = Channel(cid, topic)
        return ch

    def _write(self, ch: Channel, ev: dict, msg: dict) -> None:
        ts = ev.get("ts_ns") or 0
        if not isinstance(ts, int) or ts < 0:
            ts = 0
        # MCAP readers expect per-channel time order; a capture (or a late violation) may step
        # back in time, so the log time is clamped; publish_time keeps the capture time.
        t = ts if ts >= ch.last_t else ch.last_t
        ch.last_t = t
        fn = ev.get("frame")
        seq = fn & 0xFFFFFFFF if isinstance(fn, int) and fn >= 0 else 0
        self.w.add_message(ch.id, t, encode(msg), ts, seq)
        ch.written += 1
        ch.last_written_t = ts

    def _unique(self, topic: str) -> str:
        """A topic no other channel has (a guard: the naming scheme should already ensure it)."""
        if topic not in self._topics:
            self._topics.add(topic)
            return topic
        n = 2
        while f"{topic}~{n}" in self._topics:
            n += 1
        self._topics.add(f"{topic}~{n}")
        return f"{topic}~{n}"
    # -- for the column writers (pndiss/mcap_sink.py) -----------------------------------------
    def stream_channel(self, frame_id, src, dst) -> Channel | None:
        """The APDU channel of a cyclic stream, None before its first message (``_rt`` makes it)."""
        return self._chans.get(("rt", frame_id, src, dst))

    def telegram_channel(self, mac, api, slot, subslot, side: str) -> Channel | None:
        """The telegram channel of a data object's direction, None before its first message."""
        return self._chans.get(("tg", mac, api, slot, subslot, side))
    def run(self, path: str, settings=None, progress=None):
        """Analyse ``path`` into this file; returns the Analyzer (as analyzer.analyze_file does).
        Raises capture.CaptureError like analyze_file, after writing everything read before it."""
        from .analyzer import analyze_file
        from .capture import CaptureError

        if self.reference:
            try:
                a = analyze_file(path, settings, self.on_event, progress)
            except CaptureError as e:
                self.reader_info = getattr(getattr(e, "analyzer", None), "reader", None)
                raise
            self.reader_info = a.reader
            return a
        # the engine's columns through the column sink (pndiss/mcap_sink.py) into this exporter
        from .driver import analyze
        from .mcap_sink import McapSink
        sink = McapSink(exp=self)
        try:
            a = analyze(path, settings, [sink], progress)
        except CaptureError as e:
            self.reader_info = getattr(getattr(e, "analyzer", None), "reader", None)
            sink.finish()
            raise
        self.reader_info = a.reader
        sink.finish()
        return a

    def topic_counts(self) -> dict[str, int]:
        out: dict[str, int] = {}
        for ch in self._chans.values():
            out[ch.topic] = out.get(ch.topic, 0) + ch.written
        return out

    def summary(self) -> dict:
        return {"path": self.path, "topics": self.topic_counts(), "events_seen": dict(self.seen),
                "dropped_samples": self.dropped, "compression": self.compression,
                "on_change": self.on_change, "decimate": self.decimate}

    def close(self) -> None:
        if self.closed:
            return
        self.closed = True
        meta = {"pndiss_version": __version__, "compression": self.compression,
                "on_change": str(self.on_change).lower(), "decimate": str(self.decimate),
                "keyframe_ns": str(self.keyframe_ns)}
        if self.capture_path:
            meta["capture"] = os.path.basename(self.capture_path)
            meta["capture_path"] = self.capture_path
            digest = self.reader_info.sha256() if self.reader_info is not None else None
            # hashed while it was read (the engine's run: the sink asked for it); else one more pass
            meta["capture_sha256"] = _sha256(self.capture_path) if digest is None else digest
            if self.reader_info is not None and self.reader_info.ts_clamped:   # log times clamped to [0, 2^63) ns
                meta["timestamps_clamped"] = str(self.reader_info.ts_clamped)
        if self.settings is not None:
            s = self.settings.as_dict() if hasattr(self.settings, "as_dict") else dict(self.settings)
            meta["settings"] = json.dumps(s, sort_keys=True, default=default)
        self.w.add_metadata("pndiss", meta)
        self.w.finish()
        self._f.close()


def _sha256(path: str) -> str:
    """Hash of a capture this exporter did not read itself (a sink of `analyze`): only a regular file,
    which ends; a FIFO or a device (/dev/zero) would be read forever or lost."""
    if not os.path.isfile(path):
        return ""
    h = hashlib.sha256()
    try:
        with open(path, "rb") as f:
            for block in iter(lambda: f.read(1 << 20), b""):
                h.update(block)
    except OSError:
        return ""
    return h.hexdigest()
