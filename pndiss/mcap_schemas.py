"""The MCAP export's message schemas and JSON encoding (docs/mcap.md).

Every message is JSON with a ``jsonschema`` schema, so Foxglove plots it without plugins; the schema
table below is what the exporter registers per channel, and ``encode`` is how every message (the
reference path's and the column writer's) becomes bytes.
"""
from __future__ import annotations

import json

# -- schemas -------------------------------------------------------------------------------
# One declared table; per-channel schemas only add the names seen in the channel's first
# event (signals, bits) so Foxglove's message-path completion knows them. Extra fields are
# always allowed: events grow as the decoders land.
# Foxglove turns a jsonschema into datatypes and refuses the whole channel on anything else
# than (foxglove/studio packages/mcap-support/src/parseJsonSchema.ts): one "type" string of
# boolean/string/number/integer, "object" WITH "properties", "array" WITH typed "items", or a
# "oneOf" of numeric consts. No type lists, no "null", no untyped properties.
_JSON_TYPES = ((bool, "boolean"), (int, "number"), (float, "number"), (str, "string"))


def type_of(v) -> dict | None:
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


def default(o):
    if isinstance(o, (bytes, bytearray, memoryview)):
        return bytes(o).hex()
    if isinstance(o, (set, frozenset, tuple)):
        return list(o)
    return str(o)


# the message encoder; also the column writer's (pndiss/mcap_sink.py)
dumps = json.JSONEncoder(separators=(",", ":"), default=default, allow_nan=False).encode


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


def encode(msg: dict) -> bytes:
    try:
        return dumps(msg).encode()
    except (ValueError, TypeError):
        return dumps(_clean(msg)).encode()
