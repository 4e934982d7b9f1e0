"""``pndiss report CAPTURE -o report.html``: one self-contained HTML report (pndiss/html_report.py)."""
from __future__ import annotations

import os
import sys

from .analyze import add_settings_args, check_capture_path, settings_from_args


def add_parser(sub) -> None:
    p = sub.add_parser("report", help="write one self-contained HTML report (verdict, stations, axes, "
                                      "violations with plots, parameters, records) to send to a colleague")
    p.add_argument("capture", help="pcap or pcapng file")
    p.add_argument("-o", "--output", required=True, metavar="REPORT.html", help="HTML file to write")
    add_settings_args(p)
    p.set_defaults(func=run)


def run(args) -> int:
    from ..analyzer import analyze_file
    from ..capture import CaptureError, NotACapture, refuse_non_capture
    from ..errors import UsageError

    check_capture_path(args.capture)
    refuse_non_capture(args.capture)   # the same refusal as every command, before any work
    if os.path.splitext(args.output)[1].lower() not in (".html", ".htm"):
        raise UsageError(f"{args.output}: the report is HTML: name it .html")
    try:  # fail before the analysis, not after it
        import matplotlib  # noqa: F401
    except ImportError:
        raise UsageError("the report's plots need matplotlib: pip install 'pndiss[plot]'") from None
    from ..html_report import render
    from ..report_data import ReportCollector

    settings = settings_from_args(args)
    col = ReportCollector()
    damaged = False
    try:
        a = analyze_file(args.capture, settings, col.on_event)
    except NotACapture:
        raise   # a FIFO that carried no capture: exit 2, no report
    except CaptureError as e:
        print(f"pndiss: error: {e} ({e.frames} frames read before it); reporting what was read", file=sys.stderr)
        a = getattr(e, "analyzer", None)
        if a is None:
            return 2
        damaged = True   # the report of what was read, then exit 2 as analyze (and tshark) do
    summary = a.summary()
    summary["capture"] = args.capture
    text = render(summary, col, args.capture)
    try:
        with open(args.output, "w", encoding="utf-8") as f:
            f.write(text)
    except OSError as e:
        raise UsageError(f"cannot write {args.output}: {e.strerror}") from None
    print(f"{args.output}: {col.n_violations} violation(s), {len(col.timeline.encoders)} axis/axes", file=sys.stderr)
    return 2 if damaged else 0
