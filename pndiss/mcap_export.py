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

Two ways in, one file out: ``on_event`` takes event dicts (the reference path, any sink user);
``run`` analyses a capture through the one driver with pndiss/mcap_sink.py as its sink: the cyclic
frames' messages come from the engine's columns, without event dicts, through pndiss/mcap_writer.py.
tests/test_mcap.py requires both to write the same bytes (docs/mcap.md).
"""
from __future__ import annotations

import hashlib
import json
import os
import re


from . import __version__
from .mcap_writer import McapWriter


class UnsupportedCompression(Exception):
    """The compression module (lz4) is not installed; str() is the module name."""

# -- schemas -------------------------------------------------------------------------------
# One declared table; per-channel schemas only add the names seen in the channel's first
# event (signals, bits) so Foxglove's message-path completion knows them. Extra fields are
# always allowed: events grow as the decoders land.
# Foxglove turns a jsonschema into datatypes and refuses the whole channel on anything else
# than (foxglove/studio packages/mcap-support/src/parseJsonSchema.ts): one "type" string of
# boolean/string/number/integer, "object" WITH "properties", "array" WITH typed "items", or a
# "oneOf" of numeric consts. No type lists, no "null", no untyped properties.
_JSON_TYPES = ((bool, "boolean"), (int, "number"), (float, "number"), (str, "string"))


def _type_of(v) -> dict | None:
    """Schema of a scalar seen in a first message, None for what is better left undeclared."""
    for t, name in _JSON_TYPES:
        if isinstance(v, t):
            return {"type": name}
    return None


def _obj(title: str, props: dict, required=("frame",)) -> dict:
    return {"title": title, "type": "object", "properties": props,
            "required": list(required), "additionalProperties": True}


_FRAME = {"type": "integer", "minimum": 0, "description": "frame number in the capture (1-based)"}

SCHEMAS: dict[str, dict] = {
    "telegram": _obj("pndiss.Telegram", {
        "frame": _FRAME,
        "signals": {"type": "object", "description": "decoded signals (raw words and scaled values)",
                    "additionalProperties": True, "properties": {}},
        "bits": {"type": "object", "description": "control / status word bits",
                 "additionalProperties": True, "properties": {}},
    }),
    "apdu": _obj("pndiss.Apdu", {
        "frame": _FRAME,
        "cycle_counter": {"type": "integer", "minimum": 0, "maximum": 65535},
        "d_cycle": {"type": "integer", "description": "cycle counter step since the previous frame (mod 2^16)"},
        "dt_ns": {"type": "integer", "description": "time since the previous frame of this channel"},
        "ds": {"type": "integer", "description": "DataStatus byte"},
        "transfer_status": {"type": "integer"},
        "c_sdu_len": {"type": "integer"},
        **{n: {"type": "integer", "enum": [0, 1]} for n in (
            "ds_primary", "ds_redundancy", "ds_valid", "ds_res3", "ds_operate", "ds_ok",
            "ds_Reserved_2", "ds_ignore")},
    }, required=("frame", "cycle_counter")),
    "state": _obj("pndiss.EncoderState", {
        "frame": _FRAME,
        "state": {"type": "string", "description": "which state machine (control_by_plc, preset ...)"},
    }),
    "records": _obj("pndiss.Record", {
        "frame": _FRAME,
        "kind": {"type": "string", "enum": ["record", "param", "record_result"]},
        "op": {"type": "string"}, "index": {"type": "integer"}, "index_name": {"type": "string"},
        "api": {"type": "integer"}, "slot": {"type": "integer"}, "subslot": {"type": "integer"},
        "data": {"type": "string", "description": "record data, hex"},
        "decoded": {"type": "object", "properties": {}},
        "params": {"type": "array", "items": {"type": "object", "properties": {}}},
        "ok": {"type": "boolean"},
    }, required=("frame", "kind")),
    "event": _obj("pndiss.Event", {
        "frame": _FRAME,
        "kind": {"type": "string"},
        "src": {"type": "string"}, "dst": {"type": "string"},
    }, required=("frame", "kind")),
    "malformed": _obj("pndiss.Malformed", {
        "frame": _FRAME, "kind": {"type": "string"},
        "layer": {"type": "string"}, "reason": {"type": "string"},
    }, required=("frame", "layer", "reason")),
    # foxglove.Log as Foxglove publishes it (foxglove schemas: Log.json, LogLevel 0..5)
    "log": {
        "title": "foxglove.Log", "description": "A log message", "type": "object",
        "properties": {
            "timestamp": {"type": "object", "title": "time", "properties": {
                "sec": {"type": "integer", "minimum": 0},
                "nsec": {"type": "integer", "minimum": 0, "maximum": 999999999}}},
            "level": {"title": "foxglove.LogLevel", "oneOf": [
                {"title": t, "const": i} for i, t in enumerate(
                    ("UNKNOWN", "DEBUG", "INFO", "WARNING", "ERROR", "FATAL"))]},
            "message": {"type": "string"},
            "name": {"type": "string"},
            "file": {"type": "string"},
            "line": {"type": "integer", "minimum": 0, "maximum": 4294967295},
        },
    },
}
SCHEMA_NAMES = {k: v["title"] for k, v in SCHEMAS.items()}

# event kind -> (schema key, fixed topic) for the events that are not per-station
_FIXED = {"dcp": ("event", "/pn/dcp"), "lldp": ("event", "/pn/lldp"), "alarm": ("event", "/pn/alarms"),
          "malformed": ("malformed", "/pn/malformed")}
VIOLATIONS_TOPIC = "/pn/violations"
LEVELS = {"info": 2, "warning": 3, "error": 4}  # violation severity -> foxglove.LogLevel
_SETPOINT = {"setpoint", "output", "out", "o", "controller"}  # direction words meaning ctrl -> encoder

# fields that are constant per channel: they go to channel metadata, not into every message
_TG_CONST = frozenset(("kind", "ts_ns", "station", "device_mac", "controller_mac", "api", "slot",
                       "subslot", "telegram", "direction", "frame_id"))
_RT_CONST = frozenset(("kind", "ts_ns", "src", "dst", "frame_id", "frame_class", "iodata"))  # iodata: per-frame IOxS detail (pndiss/iodata.py), not on the timeline
TG_CONST, RT_CONST = _TG_CONST, _RT_CONST
_UNSAFE = re.compile(r"[^A-Za-z0-9._-]")


def _default(o):
    if isinstance(o, (bytes, bytearray, memoryview)):
        return bytes(o).hex()
    if isinstance(o, (set, frozenset, tuple)):
        return list(o)
    return str(o)


_dumps = json.JSONEncoder(separators=(",", ":"), default=_default, allow_nan=False).encode
# for the column writer (pndiss/mcap_sink.py): the message encoder and the event fields that are channel
# metadata, not message members (defined below)
dumps = _dumps


def _clean(v):
    """JSON-safe copy for the rare message the fast path refuses: NaN/inf -> null (JSON has no
    such numbers, Foxglove would choke), non-string keys -> strings."""
    if isinstance(v, dict):
        return {k if isinstance(k, str) else str(k): _clean(x) for k, x in v.items()}
    if isinstance(v, (list, tuple, set, frozenset)):
        return [_clean(x) for x in v]
    if isinstance(v, float) and (v != v or v in (float("inf"), float("-inf"))):
        return None
    return v


def _encode(msg: dict) -> bytes:
    try:
        return _dumps(msg).encode()
    except (ValueError, TypeError):
        return _dumps(_clean(msg)).encode()


class _Chan:
    """What one channel remembers: id, last time written (monotonic clamp), volume-control state."""
    __slots__ = ("id", "topic", "last_t", "n", "written", "last_key", "last_written_t", "prev_cc", "prev_t")

    def __init__(self, cid: int, topic: str):
        self.id, self.topic = cid, topic
        self.last_t = 0
        self.n = 0             # samples seen (for decimation)
        self.written = 0
        self.last_key = None   # what on_change compares
        self.last_written_t = None
        self.prev_cc = None    # apdu: previous cycle counter / time, for d_cycle and dt_ns
        self.prev_t = None


COMPRESSIONS = ("none", "lz4", "zstd")


class McapExporter:
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
        self._chans: dict[tuple, _Chan] = {}
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

    def _chan(self, ckey: tuple, topic: str, skey: str, meta: dict, schema: dict | None = None) -> _Chan:
        sid = self._schema_id(skey, schema or SCHEMAS[skey])
        topic = self._unique(topic)
        cid = self.w.register_channel(topic, "json", sid, {k: str(v) for k, v in meta.items() if v is not None})
        ch = self._chans[ckey] = _Chan(cid, topic)
        return ch

    def _write(self, ch: _Chan, ev: dict, msg: dict) -> None:
        ts = ev.get("ts_ns") or 0
        if not isinstance(ts, int) or ts < 0:
            ts = 0
        # MCAP readers expect per-channel time order; a capture (or a late violation) may step
        # back in time, so the log time is clamped; publish_time keeps the capture time.
        t = ts if ts >= ch.last_t else ch.last_t
        ch.last_t = t
        fn = ev.get("frame")
        seq = fn & 0xFFFFFFFF if isinstance(fn, int) and fn >= 0 else 0
        self.w.add_message(ch.id, t, _encode(msg), ts, seq)
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

    def _keep(self, ch: _Chan, key, ts: int) -> bool:
        """Volume control for a cyclic sample (no options: every sample)."""
        ch.n += 1
        if not self.on_change:
            if self.decimate == 1 or (ch.n - 1) % self.decimate == 0:
                return True
            self.dropped += 1
            return False
        changed = key != ch.last_key
        ch.last_key = key
        if (changed or ch.last_written_t is None or ts - ch.last_written_t >= self.keyframe_ns
                or (self.decimate > 1 and (ch.n - 1) % self.decimate == 0)):
            return True
        self.dropped += 1
        return False

    def _label(self, mac: str | None, name: str | None = None) -> str:
        """Topic label of a station: NameOfStation when known at first use, else the MAC."""
        if not isinstance(name, str):
            name = None
        if not mac:
            return _UNSAFE.sub("_", name) if name else "unknown"
        mac = str(mac)
        lab = self._labels.get(mac)
        if lab is None:
            nm = name or self._names.get(mac)
            lab = _UNSAFE.sub("_", nm if nm else mac.replace(":", "-"))
            if lab in self._used_labels:  # two stations with one name (a DCP fault): add the MAC
                lab = f"{lab}_{mac.replace(':', '-')}"
            self._labels[mac] = lab
            self._used_labels.add(lab)
        return lab

    def _learn(self, mac, name) -> None:
        if isinstance(mac, str) and isinstance(name, str) and name and mac not in self._names:
            self._names[mac] = name

    # -- for the column writers (pndiss/mcap_sink.py) -----------------------------------------
    def stream_channel(self, frame_id, src, dst) -> _Chan | None:
        """The APDU channel of a cyclic stream, None before its first message (``_rt`` makes it)."""
        return self._chans.get(("rt", frame_id, src, dst))

    def telegram_channel(self, mac, api, slot, subslot, side: str) -> _Chan | None:
        """The telegram channel of a data object's direction, None before its first message."""
        return self._chans.get(("tg", mac, api, slot, subslot, side))

    # -- events -----------------------------------------------------------------------------
    def on_event(self, ev: dict) -> None:
        kind = ev.get("kind")
        self.seen[kind] = self.seen.get(kind, 0) + 1
        h = self._kinds.get(kind)
        if h is not None:
            h(ev)
            return
        if kind == "dcp" or kind == "lldp" or kind == "ar":
            self._learn_station(kind, ev)
        skey, topic = _FIXED.get(kind) or ("event", f"/pn/{_UNSAFE.sub('_', str(kind))}")
        ckey = ("k", topic)
        ch = self._chans.get(ckey) or self._chan(ckey, topic, skey, {"kind": kind})
        self._write(ch, ev, ev)

    def _learn_station(self, kind: str, ev: dict) -> None:
        if kind == "ar":
            for k in ("controller_mac", "controller"):
                if isinstance(ev.get(k), str):
                    self._controllers.add(ev[k])
            self._learn(ev.get("device_mac"), ev.get("station"))
            return
        info = ev.get("station_info")
        if isinstance(info, dict):
            name = info.get("name") or info.get("name_of_station")
            # a DCP Set request names its target, every other DCP/LLDP frame its sender
            target = ev.get("dst") if ev.get("service") == "Set" and ev.get("service_type") == 0 else ev.get("src")
            self._learn(target, name)

    def _rt(self, ev: dict) -> None:
        cc = ev.get("cycle_counter")
        if cc is None:  # acyclic carrier (DCP, alarm, PTCP): its payload has its own topic
            return
        src, dst, fid = ev.get("src"), ev.get("dst"), ev.get("frame_id")
        ckey = ("rt", fid, src, dst)
        ch = self._chans.get(ckey)
        if ch is None:
            # Frame IDs are chosen per receiver, so both directions of an AR may use the same
            # one: with the roles known (Connect) the topic names the device and the direction.
            fids = f"0x{fid:04x}" if isinstance(fid, int) else _UNSAFE.sub("_", str(fid))
            if src in self._controllers or dst in self._controllers:
                dev, way = (dst, "output") if src in self._controllers else (src, "input")
                topic = f"/pn/{self._label(dev)}/apdu/{fids}/{way}"
            else:
                dev, way = src, None
                topic = f"/pn/{self._label(dev)}/apdu/{fids}"
            ch = self._chan(ckey, topic, "apdu", {
                "src": src, "dst": dst, "frame_id": fids, "frame_class": ev.get("frame_class"),
                "device_mac": dev, "direction": way})
        ts = ev.get("ts_ns") or 0
        d_cycle = None if ch.prev_cc is None else (cc - ch.prev_cc) & 0xFFFF
        dt = None if ch.prev_t is None else ts - ch.prev_t
        ch.prev_cc, ch.prev_t = cc, ts
        if (self.on_change or self.decimate > 1) and not self._keep(
                ch, (ev.get("ds"), ev.get("transfer_status"), d_cycle, ev.get("iops"), ev.get("iocs")), ts):
            return
        msg = {k: v for k, v in ev.items() if k not in _RT_CONST}
        if d_cycle is not None:
            msg["d_cycle"] = d_cycle
            msg["dt_ns"] = dt
        self._write(ch, ev, msg)

    def _telegram(self, ev: dict) -> None:
        mac = ev.get("device_mac")
        d = str(ev.get("direction", "")).lower()
        side = "setpoint" if d in _SETPOINT else "actual"
        api, slot, sub, tg = ev.get("api"), ev.get("slot"), ev.get("subslot"), ev.get("telegram")
        ckey = ("tg", mac, api, slot, sub, side)
        ch = self._chans.get(ckey)
        if ch is None:
            self._learn(mac, ev.get("station"))
            lab = self._label(mac, ev.get("station"))
            tgs = f"{tg:02d}" if isinstance(tg, int) else str(tg or "unknown")
            topic = f"/pn/{lab}/{slot}.{sub}/tg{tgs}/{side}"
            schema = json.loads(json.dumps(SCHEMAS["telegram"]))
            schema["title"] = f"pndiss.Telegram{tgs}{side.capitalize()}"
            for part in ("signals", "bits"):
                if isinstance(ev.get(part), dict):
                    props = schema["properties"][part]["properties"]
                    for k, v in ev[part].items():
                        t = _type_of(v)
                        if t is not None:
                            props[str(k)] = t
            ch = self._chan(ckey, topic, "telegram", {
                "device_mac": mac, "station": ev.get("station"), "api": api, "slot": slot,
                "subslot": sub, "telegram": tg, "direction": side,
                "frame_id": f"0x{ev['frame_id']:04x}" if isinstance(ev.get("frame_id"), int) else ev.get("frame_id")},
                schema)
            self.telegram_channels.append({
                "topic": ch.topic, "station": ev.get("station") or mac, "slot": slot, "subslot": sub,
                "telegram": tg, "side": side,
                **{part: [str(k) for k in ev[part]] if isinstance(ev.get(part), dict) else []
                   for part in ("signals", "bits")}})
        if (self.on_change or self.decimate > 1) and not self._keep(
                ch, (ev.get("words"), ev.get("raw"), ev.get("signals")), ev.get("ts_ns") or 0):
            return
        self._write(ch, ev, {k: v for k, v in ev.items() if k not in _TG_CONST})

    def _station_chan(self, ev: dict, what: str, skey: str) -> _Chan:
        mac = ev.get("device_mac")
        self._learn(mac, ev.get("station"))
        lab = self._label(mac, ev.get("station"))
        ckey = (what, lab)
        return self._chans.get(ckey) or self._chan(ckey, f"/pn/{lab}/{what}", skey,
                                                   {"device_mac": mac, "station": ev.get("station")})

    def _state(self, ev: dict) -> None:
        self._write(self._station_chan(ev, "encoder_state", "state"), ev, ev)

    def _record(self, ev: dict) -> None:
        self._write(self._station_chan(ev, "records", "records"), ev, ev)

    def _violation(self, ev: dict) -> None:
        ckey = ("violations",)
        ch = self._chans.get(ckey) or self._chan(ckey, VIOLATIONS_TOPIC, "log", {})
        ts = ev.get("ts_ns") or 0
        fn, last = ev.get("frame"), ev.get("last_frame")
        where = f"frame {fn}" if last in (None, fn) else f"frames {fn}-{last}"
        rule = str(ev.get("rule", "?"))
        msg = {
            "timestamp": {"sec": ts // 1_000_000_000, "nsec": ts % 1_000_000_000},
            "level": LEVELS.get(ev.get("severity"), 0),
            "message": f"{rule} ({ev.get('side', '?')}, {where}): {ev.get('message', '')}",
            "name": rule,
            "file": os.path.basename(self.capture_path) if self.capture_path else "",
            "line": fn & 0xFFFFFFFF if isinstance(fn, int) and fn >= 0 else 0,
        }
        self._write(ch, ev, msg)

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
            if self.reader_info is not None:   # hashed while it was read: never a second pass
                meta["capture_sha256"] = self.reader_info.sha256()
                if self.reader_info.ts_clamped:   # log times of these messages are clamped to [0, 2^63) ns
                    meta["timestamps_clamped"] = str(self.reader_info.ts_clamped)
            else:
                meta["capture_sha256"] = _sha256(self.capture_path)
        if self.settings is not None:
            s = self.settings.as_dict() if hasattr(self.settings, "as_dict") else dict(self.settings)
            meta["settings"] = json.dumps(s, sort_keys=True, default=_default)
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
