"""The dataset's tables: every column's name and type, declared once (docs/dataset.md renders it).

Column names are the JSONL event fields (docs/events.md). Scalars get an Arrow type; nested values
(lists, objects: ``params``, ``decoded``, ``iocrs`` ...) are JSON text (type ``JSON``), which
DuckDB, Spark and Polars parse with their JSON functions. A field an event carries that its table
does not declare, or a value of another type than declared, goes into the ``extra`` JSON object
of its row: nothing the analyser said is lost, and the declared columns never change type.

Bump SCHEMA_VERSION when a column changes type or meaning (adding a column does not need it:
readers union files by column name).
"""
from __future__ import annotations

import numpy as np
import pyarrow as pa

from .. import telegrams as tg
from .arrays import timestamps

SCHEMA_VERSION = 1

JSON = "json"   # a column of JSON text (pa.string() in the file)
STR, I64, I32, BOOL, F64 = pa.string(), pa.int64(), pa.int32(), pa.bool_(), pa.float64()
# UTC without a zone, in µs: every reader takes it as it is (Spark cannot read ns time stamps);
# the exact time is the ``ts_ns`` integer beside it
TS = pa.timestamp("us")

# every table's first columns: which capture, which frame, when (``ts`` is ``ts_ns`` as a timestamp,
# for SQL date arithmetic; not a JSONL field)
EVENT_HEAD = [("capture_hash", STR), ("frame", I64), ("ts_ns", I64), ("ts", TS)]
AXIS = [("station", STR), ("device_mac", STR), ("api", I64), ("slot", I64), ("subslot", I64)]

TABLES: dict[str, list] = {
    "captures": [
        ("capture_hash", STR), ("file", STR), ("size_bytes", I64), ("frames", I64),
        ("decoded", I64), ("not_profinet", I64), ("malformed", I64),
        ("first_ts_ns", I64), ("last_ts_ns", I64), ("first_ts", TS), ("last_ts", TS),
        ("duration_s", F64), ("events", JSON), ("violations", I64), ("errors", I64),
        ("warnings", I64), ("infos", I64), ("capture_gaps", I64), ("cycles_missing", I64),
        ("stations", I64), ("axes", I64), ("cycles_mode", STR), ("cycle_rows", I64),
        ("pndiss_version", STR), ("schema_version", I32), ("settings", JSON),
        ("error", STR), ("written_at", TS),
    ],
    "violations": EVENT_HEAD + [
        ("rule", STR), ("side", STR), ("severity", STR), ("last_frame", I64), ("message", STR),
        ("source", STR), ("cycles", I64), *AXIS, ("ip_address", STR), ("mac", STR), ("name", STR),
        ("other_frame", I64), ("other_mac", STR), ("extra", JSON),
    ],
    "params": EVENT_HEAD + [
        *AXIS, ("controller_mac", STR), ("ar_uuid", STR), ("index", I64), ("profile", STR),
        ("request_frame", I64), ("response_frame", I64), ("request_ts_ns", I64),
        ("request_ref", I64), ("request_id", I64), ("request_id_name", STR), ("request_id_code", I64),
        ("response_ref", I64), ("response_id", I64), ("response_id_name", STR), ("axis", I64),
        ("response_axis", I64), ("no_of_parameters", I64), ("response_no_of_parameters", I64),
        ("ok", BOOL), ("params", JSON), ("pairing", JSON), ("superseded_request_frames", JSON),
        ("extra", JSON),
    ],
    # ``record`` events (write request / read response with its data) and ``record_result``
    # events (the response to a write, PNIO status), told apart by ``kind``
    "records": EVENT_HEAD + [
        ("kind", STR), ("op", STR), ("index", I64), ("index_name", STR), *AXIS,
        ("controller_mac", STR), ("ar_uuid", STR), ("request_frame", I64), ("seq_number", I64),
        ("length", I64), ("data", STR), ("profile", STR), ("decoded", JSON), ("result", JSON),
        ("blocks", JSON), ("ok", BOOL), ("status", JSON), ("extra", JSON),
    ],
    "stations": [
        ("capture_hash", STR), ("mac", STR), ("name", STR), ("frames", I64),
        ("type_of_station", STR), ("vendor_id", I64), ("device_id", I64), ("role", I64),
        ("ip", STR), ("netmask", STR), ("gateway", STR), ("chassis_id", STR), ("port_id", STR),
        ("mgmt_ip", STR), ("chassis_mac", STR), ("lldp_port_of", STR), ("extra", JSON),
    ],
    "ars": EVENT_HEAD + [
        ("ar_uuid", STR), ("request_frame", I64), ("ok", BOOL), ("status", JSON), ("ar_type", I64),
        ("ar_type_name", STR), ("session_key", I64), ("controller_mac", STR), ("device_mac", STR),
        ("controller_station", STR), ("station", STR), ("controller_ip", STR), ("device_ip", STR),
        ("phase", STR), ("phases", JSON), ("released", BOOL), ("source", STR), ("confidence", STR),
        ("iocrs", JSON), ("alarm_cr", JSON), ("expected_submodules", JSON), ("module_diff", JSON),
        ("evidence", JSON), ("learnt_from", JSON), ("telegram", JSON), ("extra", JSON),
    ],
    "ar_phases": EVENT_HEAD + [
        ("ar_uuid", STR), ("phase", STR), ("previous_phase", STR), ("cause", STR),
        ("station", STR), ("device_mac", STR), ("controller_mac", STR), ("extra", JSON),
    ],
    "states": EVENT_HEAD + [
        *AXIS, ("state", STR), ("value", I64), ("value_name", STR), ("previous", I64),
        ("previous_name", STR), ("extra", JSON),
    ],
    "capture_gaps": EVENT_HEAD + [
        ("station", STR), ("frame_id", I64), ("direction", STR), ("src", STR), ("dst", STR),
        ("cycles_missing", I64), ("prev_frame", I64), ("next_frame", I64), ("extra", JSON),
    ],
    # one row per encoder axis of the summary (cyclic.encoders): what the analyser made of it
    "axes": [
        ("capture_hash", STR), *AXIS, ("telegram", I64), ("telegram_source", STR),
        ("profile", STR), ("cycles", I64), ("gated_cycles", I64), ("lost_cycles", I64),
        ("settings", JSON), ("extra", JSON),
    ],
}

# event kind -> table (stations and axes come from the summary, captures from the writer)
KIND_TABLE = {"violation": "violations", "param": "params", "record": "records",
              "record_result": "records", "ar": "ars", "ar_phase": "ar_phases", "state": "states",
              "capture_gap": "capture_gaps"}


def _signal_type(name: str) -> pa.DataType:
    s = tg.SIGNALS[name]
    return pa.uint64() if s["size"] == 8 and not s["signed"] else pa.int64()


def bit_columns() -> list[tuple[str, pa.DataType]]:
    """(column, type) of every named bit field of any profile, in table order: uint8, or int64 for a
    field wider than 8 bits (the 31-bit preset values of telegram 860)."""
    out: dict = {}
    for sig, rows in tg.BITMAPS.items():
        for b in rows:
            col = f"{sig}.{b['name']}"
            wide = b["width"] > 8 or out.get(col) == pa.int64()
            out[col] = pa.int64() if wide else pa.uint8()
    return list(out.items())


# per-axis cyclic data: one row per data object of a cyclic frame (setpoint or actual), every
# signal of the telegram table (null where the telegram lacks it) and every named bit (null where
# the axis' telegram or profile lacks it). Bit columns are named as the JSONL ``bits`` keys.
CYCLES_HEAD = [
    ("capture_hash", STR), *AXIS, ("telegram", I64), ("telegram_source", STR), ("profile", STR),
    ("direction", STR), ("frame_id", I64), ("frame", I64), ("ts_ns", I64), ("ts", TS),
    ("iops", pa.int16()), ("judged", BOOL),
]
TABLES["cycles"] = (CYCLES_HEAD + [(n, _signal_type(n)) for n in tg.SIGNALS]
                    + bit_columns())


def ts_array(ns) -> pa.Array:
    """A TS column from integer ns since the epoch (None: null), cut to µs."""
    if isinstance(ns, np.ndarray):
        return timestamps(ns, TS)
    ns = list(ns)
    return timestamps([0 if v is None else v for v in ns], TS, np.fromiter((v is not None for v in ns), bool, len(ns)))


def arrow_type(t) -> pa.DataType:
    return pa.string() if t == JSON else t


def arrow_schema(table: str, metadata: dict | None = None) -> pa.Schema:
    """The table's Arrow schema with the dataset's metadata (schema version, table, pndiss version)."""
    from .. import __version__
    meta = {"pndiss.schema_version": str(SCHEMA_VERSION), "pndiss.table": table,
            "pndiss.version": __version__, **(metadata or {})}
    return pa.schema([pa.field(n, arrow_type(t)) for n, t in TABLES[table]], metadata=meta)


def type_name(t) -> str:
    """The type as docs/dataset.md names it."""
    return "JSON (string)" if t == JSON else str(t)


ABOUT = {
    "captures": "one row per capture file (also a failed one, with `error`): content hash, frames and their "
                "accounting, time span, violation and capture-gap counts, pndiss and schema version, settings",
    "violations": "`violation` events: rule, side, severity, first/last frame, message, the axis",
    "params": "`param` events: a PROFIdrive parameter access (0xB02E/0xB02F) request + response; `params` "
              "holds the parameters (pnu, name, values, error)",
    "records": "`record` events (record data: write request / read response, `decoded` content, e.g. I&M0) "
               "and `record_result` events (the PNIO status of a write), told apart by `kind`",
    "stations": "the summary's stations: every MAC seen with what DCP and LLDP said about it",
    "ars": "`ar` events: an application relationship (Connect), IOCRs, telegrams and their source",
    "ar_phases": "`ar_phase` events: parameterisation -> prm_end -> application_ready -> data_exchange -> "
                 "released / aborted",
    "states": "`state` events: state changes of a reference encoder (control by PLC, preset, parking, ...)",
    "capture_gaps": "`capture_gap` events: cycles of a cyclic stream the capture lost (not judged)",
    "axes": "the summary's encoder axes (one per data object with a telegram): telegram and its source, "
            "profile, `cycles` (elapsed: judged, lost, or never sent by a controller that stopped; a deadline counts "
            "them), `gated_cycles` (reported, not judged: IOPS / DataStatus, no setpoint sent), `lost_cycles` (cycles "
            "not judged because a setpoint or an actual value is missing from the capture: either direction), the "
            "settings in force",
    "cycles": "per-axis cyclic data, one row per data object of a cyclic frame (setpoint or actual): every "
              "signal and every bit of the telegram table (full, on change or decimated)",
}


def markdown() -> str:
    """The tables section of docs/dataset.md (tools/gen_dataset_doc.py writes it; a test keeps it current)."""
    out = [f"Schema version **{SCHEMA_VERSION}**.", ""]
    for t, cols in TABLES.items():
        out += [f"### `{t}`", "", ABOUT[t] + ".", "", "| column | type |", "|---|---|"]
        if t == "cycles":
            head = len(CYCLES_HEAD) + len(tg.SIGNALS)
            out += [f"| `{n}` | {type_name(ty)} |" for n, ty in cols[:head]]
            out += ["", f"and {len(cols) - head} bit columns, named as the JSONL `bits` keys (`signal.bit`; quote "
                        "them in SQL: `\"g1_zsw.sensor_error\"`), uint8 unless noted: "
                        + ", ".join(f"`{n}`" + ("" if ty == pa.uint8() else f" ({ty})") for n, ty in cols[head:])
                        + "."]
        else:
            out += [f"| `{n}` | {type_name(ty)} |" for n, ty in cols]
        out.append("")
    return "\n".join(out)
