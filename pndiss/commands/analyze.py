"""``pndiss analyze CAPTURE``: decode, check, report."""
from __future__ import annotations

import json
import os
import sys

from ..settings import Settings

SEVERITY_ORDER = {"info": 0, "warning": 1, "error": 2}


def add_parser(sub) -> None:
    p = sub.add_parser("analyze", help="decode a capture and report stations, telegrams and violations")
    p.add_argument("capture", help="pcap or pcapng file")
    p.add_argument("--jsonl", metavar="PATH", help="write one JSON event per line to PATH ('-' = stdout)")
    p.add_argument("--summary-json", metavar="PATH", help="write the summary as JSON to PATH ('-' = stdout)")
    add_settings_args(p)
    p.add_argument("--fail-on", choices=("info", "warning", "error"),
                   help="exit 1 when violations at or above this severity exist")
    p.add_argument("--mcap", metavar="PATH", help="also write an MCAP timeline to PATH")
    p.add_argument("-q", "--quiet", action="store_true", help="no terminal report")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def add_settings_args(p) -> None:
    """Options shared by every command that analyses a capture."""
    p.add_argument("--config", metavar="FILE", help="settings file (TOML or JSON), see docs/settings.md")
    p.add_argument("--profile", choices=("auto", "lika", "scancon", "hohner", "psm", "generic"),
                   help="device profile (default: auto, from I&M0 / DCP vendor and device ID)")
    p.add_argument("--gsdml", metavar="FILE", action="append", help="GSDML file for submodule -> telegram")
    p.add_argument("--map", metavar="FILE", dest="map_file",
                   help="user map: frame ID/slot/subslot -> telegram (docs/map.md)")
    p.add_argument("--set", metavar="KEY=VALUE", action="append", default=[],
                   help="override one setting, e.g. --set l_max=3 (docs/settings.md)")


def settings_from_args(args) -> Settings:
    from ..errors import UsageError

    try:
        s = Settings.from_file(args.config) if getattr(args, "config", None) else Settings()
    except (OSError, ValueError) as e:
        raise UsageError(f"cannot use config file: {e}") from None
    for name in ("profile", "map_file", "fail_on"):
        v = getattr(args, name, None)
        if v is not None:
            setattr(s, name, v)
    if getattr(args, "gsdml", None):
        s.gsdml = list(args.gsdml)
    for kv in getattr(args, "set", []) or []:
        key, sep, val = kv.partition("=")
        if not sep or not hasattr(s, key):
            raise UsageError(f"--set {kv!r}: expected KEY=VALUE with a known key (docs/settings.md)")
        try:
            v = _coerce(Settings.field_type(key), val)
        except (KeyError, ValueError):
            raise UsageError(f"--set {kv!r}: bad value for {key}") from None
        setattr(s, key, v)
    return s


_BOOLS = {"1": True, "true": True, "yes": True, "on": True, "0": False, "false": False, "no": False, "off": False}


def _coerce(typ: str, val: str):
    """Convert a --set value by the dataclass field's declared type ('int | None', 'bool', ...)."""
    if val.lower() in ("none", "null") and "None" in typ:
        return None
    if typ.startswith("bool"):
        return _BOOLS[val.lower()]
    if typ.startswith("int"):
        return int(val, 0)
    if typ.startswith("float"):
        return float(val)
    if typ.startswith("list"):
        return [x for x in val.split(",") if x]
    return val


def open_out(path: str):
    if path == "-":
        return sys.stdout
    try:
        return open(path, "w", encoding="utf-8")
    except OSError as e:
        from ..errors import UsageError
        raise UsageError(f"cannot write {path}: {e.strerror}") from None


def check_capture_path(path: str) -> None:
    from ..errors import UsageError
    if not os.path.exists(path):
        raise UsageError(f"{path}: no such file")
    if os.path.isdir(path):
        raise UsageError(f"{path}: is a directory, not a capture file")


def run(args) -> int:
    from ..analyzer import analyze_file
    from ..capture import CaptureError
    from ..report import ProgressReporter, render_report

    check_capture_path(args.capture)
    from ..capture import refuse_non_capture
    refuse_non_capture(args.capture)   # the refusal every command shares (export, plot, report)
    settings = settings_from_args(args)
    sinks = []
    jsonl = open_out(args.jsonl) if args.jsonl else None
    if jsonl is not None:
        dumps = json.JSONEncoder(separators=(",", ":"), default=_json_default).encode
        write = jsonl.write
        sinks.append(lambda ev: write(dumps(ev) + "\n"))
    mcap_writer = None
    if args.mcap:
        from ..mcap_export import McapExporter
        mcap_writer = McapExporter(args.mcap, args.capture, settings)
        sinks.append(mcap_writer.on_event)
    sink = sinks[0] if len(sinks) == 1 else (lambda ev: [s(ev) for s in sinks]) if sinks else None
    # the terminal report goes to stderr when stdout carries data
    to_stderr = args.jsonl == "-" or args.summary_json == "-"
    progress = None if args.no_progress or args.quiet else ProgressReporter(args.capture, to_stderr)
    error = None
    try:
        try:
            if mcap_writer is not None and len(sinks) == 1:  # the exporter alone: its fast path, same file
                a = mcap_writer.run(args.capture, settings, progress.update if progress else None)
            else:
                a = analyze_file(args.capture, settings, sink, progress.update if progress else None)
        except CaptureError as e:
            error = e
            a = e.analyzer if hasattr(e, "analyzer") else None
    finally:
        if progress:
            progress.close()
        if mcap_writer is not None:
            mcap_writer.close()
        if jsonl is not None and jsonl is not sys.stdout:
            jsonl.close()
    if error is not None:
        print(f"pndiss: error: {error} ({error.frames} frames read before it)", file=sys.stderr)
        return 2
    summary = a.summary()
    summary["capture"] = args.capture
    if args.summary_json:
        out = open_out(args.summary_json)
        json.dump(summary, out, indent=2, default=_json_default)
        out.write("\n")
        if out is not sys.stdout:
            out.close()
    if not args.quiet:
        render_report(summary, a, to_stderr)
    return exit_code(summary, settings.fail_on)


def exit_code(summary: dict, fail_on: str | None) -> int:
    if not fail_on:
        return 0
    floor = SEVERITY_ORDER[fail_on]
    for sev, n in summary.get("cyclic", {}).get("violations_by_severity", {}).items():
        if n and SEVERITY_ORDER.get(sev, 2) >= floor:
            return 1
    return 0


def _json_default(o):
    if isinstance(o, (bytes, bytearray, memoryview)):
        return bytes(o).hex()
    if isinstance(o, (set, frozenset, tuple)):
        return list(o)
    return str(o)
