"""``pndiss analyze CAPTURE``: decode, check, report."""
from __future__ import annotations

import json
import os
import sys

from ..settings import Settings

SEVERITY_ORDER = {"info": 0, "warning": 1, "error": 2}


def add_parser(sub) -> None:
    p = sub.add_parser("analyze", help="decode a capture and report stations, telegrams and violations")
    p.add_argument("capture", nargs="+",
                   help="pcap or pcapng file, also .gz/.zst/.xz; '-' = stdin (a pipe from dumpcap -w -); several "
                        "files = the pieces of one ring buffer (dumpcap -b), analysed as one capture in time order")
    p.add_argument("--jsonl", metavar="PATH", help="write one JSON event per line to PATH ('-' = stdout)")
    p.add_argument("--events", metavar="KINDS",
                   help="only these event kinds in --jsonl, comma-separated (e.g. violation,param,record,state,"
                        "capture_gap); without rt/telegram the JSONL runs at the engine's speed")
    p.add_argument("--summary-json", metavar="PATH", help="write the summary as JSON to PATH ('-' = stdout)")
    add_settings_args(p)
    p.add_argument("--fail-on", choices=("info", "warning", "error"),
                   help="exit 1 when violations at or above this severity exist")
    p.add_argument("--mcap", metavar="PATH", help="also write an MCAP timeline to PATH")
    p.add_argument("--station", metavar="NAME|MAC",
                   help="only this station's violations and events (verdict, JSONL, exit code)")
    p.add_argument("--time", metavar="FROM..TO",
                   help="only violations and events in this range: seconds since the first frame "
                        "(e.g. 1.5..3, ..2, 10..) or UTC times (2026-01-01T08:00:00..2026-01-01T08:05:00)")
    p.add_argument("--follow", action="store_true",
                   help="print each violation as soon as it is decided (for live pipes)")
    p.add_argument("-q", "--quiet", action="store_true", help="only the one-line verdict")
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
    from ..errors import UsageError, did_you_mean

    for opt, path in (("--config", getattr(args, "config", None)), ("--map", getattr(args, "map_file", None)),
                      *(("--gsdml", g) for g in getattr(args, "gsdml", None) or ())):
        if path is not None:
            check_readable(path, opt)
    try:
        s = Settings.from_file(args.config) if getattr(args, "config", None) else Settings()
    except (OSError, ValueError, TypeError) as e:
        raise UsageError(f"cannot use config file: {e}") from None
    for name in ("profile", "map_file", "fail_on"):
        v = getattr(args, name, None)
        if v is not None:
            setattr(s, name, v)
    if getattr(args, "gsdml", None):
        s.gsdml = list(args.gsdml)
    for kv in getattr(args, "set", []) or []:
        key, sep, val = kv.partition("=")
        if not sep:
            raise UsageError(f"--set {kv!r}: expected KEY=VALUE (docs/settings.md)")
        if not hasattr(s, key):
            raise UsageError(f"--set {kv!r}: unknown setting {key!r}"
                             + did_you_mean(key, list(s.as_dict())) + " (docs/settings.md)")
        try:
            v = _coerce(Settings.field_type(key), val)
        except (KeyError, ValueError):
            raise UsageError(f"--set {kv!r}: bad value for {key} ({Settings.field_type(key)})") from None
        setattr(s, key, v)
    return s


def check_readable(path: str, what: str) -> None:
    """A file named on the command line: missing or unreadable is the user's to fix (exit 2)."""
    from ..errors import UsageError
    if not os.path.exists(path):
        raise UsageError(f"{what} {path}: no such file")
    if os.path.isdir(path):
        raise UsageError(f"{what} {path}: is a directory")
    if not os.access(path, os.R_OK):
        raise UsageError(f"{what} {path}: permission denied")


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


def close_out(f, path: str) -> None:
    """Close (or flush stdout): a full disk shows here for buffered writes (exit 2, not 3)."""
    from ..errors import UsageError
    try:
        if f is sys.stdout:
            f.flush()
        else:
            f.close()
    except BrokenPipeError:
        raise
    except OSError as e:
        raise UsageError(f"cannot write {path}: {e.strerror}") from None


def check_capture_path(path: str) -> None:
    from ..errors import UsageError
    if path == "-":
        if sys.stdin is None or sys.stdin.isatty():
            raise UsageError("-: stdin is a terminal, not a capture (pipe one in: dumpcap -w - | pndiss analyze -)")
        return
    if not os.path.exists(path):
        raise UsageError(f"{path}: no such file")
    if os.path.isdir(path):
        raise UsageError(f"{path}: is a directory, not a capture file")


# event kinds the analyzer emits (docs/events.md); --events checks against them
EVENT_KINDS = ("alarm", "ar", "ar_phase", "capture_gap", "dcp", "dcp_name_invalid", "ip_fragment", "lldp",
               "malformed", "mrp", "param", "ptcp", "record", "record_result", "rpc", "rt", "state", "telegram",
               "violation")


def event_kinds(text: str | None):
    """--events KINDS as a frozenset (None: every kind)."""
    from ..errors import UsageError, did_you_mean

    if text is None:
        return None
    kinds = [k.strip() for k in text.split(",") if k.strip()]
    for k in kinds:
        if k not in EVENT_KINDS:
            raise UsageError(f"--events: unknown event kind {k!r}{did_you_mean(k, EVENT_KINDS)} "
                             f"(kinds: {', '.join(EVENT_KINDS)})")
    return frozenset(kinds)


def run(args) -> int:
    from ..capture import CaptureError
    from ..driver import analyze
    from ..errors import UsageError
    from ..events import FrameTimes, Scope, json_default
    from ..sinks import FRAME_KINDS
    from ..verdict import one_line

    if args.jsonl == "-" and args.summary_json == "-":
        raise UsageError("--jsonl - and --summary-json - would mix two formats on stdout: "
                         "send one of them to a file")
    captures = args.capture
    if len(captures) > 1 and "-" in captures:
        raise UsageError("- (stdin) cannot be one piece of a ring buffer: give the files")
    from ..capture import refuse_non_capture
    for c in captures:
        check_capture_path(c)
        refuse_non_capture(c)   # the refusal every command shares (export, plot, report)
    args.capture = captures[0]
    kinds = event_kinds(args.events)
    if kinds is not None and not args.jsonl:
        raise UsageError("--events selects what --jsonl writes: give --jsonl PATH too")
    settings = settings_from_args(args)
    scope = Scope.from_args(args.station, args.time)
    sinks = []
    jsonl_sink = None
    jsonl = open_out(args.jsonl) if args.jsonl else None
    if jsonl is not None and scope is None and (kinds is None or kinds & FRAME_KINDS):
        # every frame's rt / telegram line: written from the engine's columns (pndiss/jsonl_sink.py)
        from ..jsonl_sink import JsonlSink
        jsonl_sink = JsonlSink(getattr(jsonl, "buffer", jsonl), kinds, args.jsonl)
        sinks.append(jsonl_sink)
    elif jsonl is not None:
        dumps = json.JSONEncoder(separators=(",", ":"), default=json_default).encode
        write = jsonl.write
        fix = FrameTimes().fix  # a violation's ts_ns is its frame's time
        where = args.jsonl

        def to_jsonl(ev, keep=scope.keep if scope else None):
            ev = fix(ev)
            if keep is None or keep(ev):
                try:
                    write(dumps(ev) + "\n")
                except BrokenPipeError:
                    raise
                except OSError as e:
                    raise UsageError(f"cannot write {where}: {e.strerror}") from None
        from ..sinks import FuncSink
        sinks.append(FuncSink(to_jsonl, kinds))
    mcap_writer = None
    if args.mcap:
        from ..mcap_sink import McapSink
        try:
            mcap_writer = McapSink(args.mcap, args.capture, settings)
        except OSError as e:
            raise UsageError(f"cannot write {args.mcap}: {e.strerror}") from None
        sinks.append(mcap_writer)

    # the terminal report goes to stderr when stdout carries data
    to_stderr = args.jsonl == "-" or args.summary_json == "-"
    # the terminal renderer (rich) only for a report, a progress bar or --follow: -q prints one plain line
    if not args.quiet or args.follow:
        from ..report import ProgressReporter, render_report, render_violation
    progress = None if args.no_progress or args.quiet or args.follow else ProgressReporter(args.capture, to_stderr)
    report_out = sys.stderr if to_stderr else sys.stdout
    hooks = {}
    if scope is not None:
        hooks["scope"] = scope
    if args.follow:
        hooks["on_new"] = lambda ev: render_violation(ev, report_out)
    error = None
    a = None
    try:
        try:
            a = analyze(captures, settings, sinks, progress.update if progress else None, hooks)
        except CaptureError as e:
            error = e
            a = e.analyzer if hasattr(e, "analyzer") else None
        if jsonl_sink is not None:
            jsonl_sink.close()   # the rows and events it still holds (after a damaged part too)
    finally:
        if progress:
            progress.close()
        if mcap_writer is not None:
            if a is not None:
                mcap_writer.reader_info = a.reader
            mcap_writer.close()
    if jsonl is not None:
        close_out(jsonl, args.jsonl)
    if error is not None and (a is None or not a.reader.damaged):
        print(f"pndiss: error: {error} ({error.frames} frames read before it)", file=sys.stderr)
        return 2
    if scope is not None:
        why = scope.unmatched(a)
        if why is not None:
            raise UsageError(why)
    summary = a.summary()
    summary["capture"] = args.capture
    if len(captures) > 1:   # a ring buffer's files, in time order: the capture is the first of them
        from ..driver import ring_order
        summary["capture_files"] = ring_order(captures)
        summary["capture"] = summary["capture_files"][0]
    if scope is not None:
        summary["scope"] = scope.describe()
        summary["scope_text"] = scope.text()
    summary["verdict"] = {**a.violations.summary(), "line": one_line(summary, a.violations)}
    if args.summary_json:
        out = open_out(args.summary_json)
        try:
            json.dump(summary, out, indent=2, default=json_default)
            out.write("\n")
        except OSError as e:
            if isinstance(e, BrokenPipeError):
                raise
            raise UsageError(f"cannot write {args.summary_json}: {e.strerror}") from None
        close_out(out, args.summary_json)
    if args.quiet:
        print("pndiss: " + one_line(summary, a.violations) + (f" (in scope: {scope.text()})" if scope else ""),
              file=report_out)
    else:
        render_report(summary, a, to_stderr)
    if error is not None:
        # a damaged file: the report covers every whole frame before the damage; exit 2 as tshark 4.0 does
        print(f"pndiss: error: {error} (the report covers the {a.frames:,} frames read)", file=sys.stderr)
        return 2
    return exit_code(a.violations, settings.fail_on)


def _hooks(hooks: dict) -> dict:
    """Only pass the verdict hooks when set (keeps other callers' signatures untouched)."""
    return {"verdict_hooks": hooks} if hooks else {}


def exit_code(log, fail_on: str | None) -> int:
    """1 when a violation at or above ``fail_on`` was counted (in --station/--time scope)."""
    if not fail_on:
        return 0
    floor = SEVERITY_ORDER[fail_on]
    for sev, n in log.by_sev.items():
        if n and SEVERITY_ORDER.get(sev, 2) >= floor:
            return 1
    return 0

