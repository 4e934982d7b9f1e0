"""``pndiss plot CAPTURE -o timeline.png|.html``: position, speed, status bits and violations."""
from __future__ import annotations

import os
import sys

from .analyze import add_settings_args, check_capture_path, settings_from_args


def add_parser(sub) -> None:
    p = sub.add_parser("plot", help="draw a timeline (PNG needs pndiss[plot]; HTML needs nothing)")
    p.add_argument("capture", help="pcap or pcapng file")
    p.add_argument("-o", "--output", required=True, metavar="OUT.png|OUT.html",
                   help="picture to write; the suffix picks the format")
    p.add_argument("--max-points", type=int, default=4000, metavar="N",
                   help="samples kept per curve (longer captures are thinned evenly)")
    p.add_argument("--window", metavar="START:END",
                   help="show only this time range, in seconds on the plot's axis (e.g. 0.74:0.77)")
    add_settings_args(p)
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..analyzer import analyze_file
    from ..capture import CaptureError, NotACapture, refuse_non_capture
    from ..errors import UsageError
    from ..plot import PlotUnavailable, Timeline, render_html, render_png
    from ..report import ProgressReporter

    check_capture_path(args.capture)
    refuse_non_capture(args.capture)   # the same refusal as every command, before any work
    ext = os.path.splitext(args.output)[1].lower()
    if ext not in (".png", ".html", ".htm"):
        raise UsageError(f"{args.output}: the output must end in .png or .html")
    if args.max_points < 2:
        raise UsageError("--max-points must be 2 or more")
    if ext == ".png":  # fail before the analysis, not after it
        try:
            import matplotlib  # noqa: F401
        except ImportError:
            raise UsageError("PNG output needs matplotlib: pip install 'pndiss[plot]' "
                             "(or write .html, which needs nothing)") from None
    window = None
    if args.window:
        try:
            a, b = (float(v) for v in args.window.split(":"))
        except ValueError:
            raise UsageError(f"--window {args.window!r}: expected START:END in seconds") from None
        if not b > a:
            raise UsageError(f"--window {args.window!r}: END must be after START")
        window = (a, b)
    settings = settings_from_args(args)
    tl = Timeline(args.max_points)
    progress = None if args.no_progress else ProgressReporter(args.capture, True, "reading for the plot")
    damaged = False
    try:
        a = analyze_file(args.capture, settings, tl.on_event, progress.update if progress else None)
        tl.start = a.first_ts   # the time axis counts from the first frame, as --time does
    except NotACapture:
        raise   # a FIFO that carried no capture: exit 2, no picture
    except CaptureError as e:
        tl.start = getattr(getattr(e, "analyzer", None), "first_ts", None)
        print(f"pndiss: error: {e} ({e.frames} frames read before it); plotting what was read",
              file=sys.stderr)
        damaged = True   # exit 2 after the picture, as analyze, export and report do on a damaged file
    finally:
        if progress:
            progress.close()
    title = os.path.basename(args.capture)
    try:
        (render_png if ext == ".png" else render_html)(tl, args.output, title, window)
    except PlotUnavailable as e:
        raise UsageError(str(e)) from None
    except OSError as e:
        raise UsageError(f"cannot write {args.output}: {e.strerror}") from None
    return 2 if damaged else 0
