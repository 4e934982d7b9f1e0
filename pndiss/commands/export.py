"""``pndiss export CAPTURE -o out.mcap``: the analysis as an MCAP timeline for Foxglove."""
from __future__ import annotations

import os
import sys

from .analyze import add_settings_args, check_capture_path, settings_from_args


def add_parser(sub) -> None:
    p = sub.add_parser("export", help="write the decoded capture as MCAP (Foxglove), docs/mcap.md")
    p.add_argument("capture", help="pcap or pcapng file")
    p.add_argument("-o", "--output", required=True, metavar="OUT.mcap", help="MCAP file to write")
    p.add_argument("--on-change", action="store_true",
                   help="cyclic topics: write a sample only when its words change, plus keyframes")
    p.add_argument("--keyframe", type=float, default=1.0, metavar="SECONDS",
                   help="with --on-change: write a sample at least this often per channel (default 1 s)")
    p.add_argument("--decimate", type=int, default=1, metavar="N",
                   help="cyclic topics: write every Nth sample per channel (with --on-change: also every Nth)")
    p.add_argument("--compression", choices=("none", "lz4", "zstd"), default="zstd",
                   help="chunk compression (default zstd)")
    p.add_argument("--layout", metavar="FILE.json",
                   help="also write a Foxglove layout for this file: position/speed plots and control/status "
                        "words per axis, the violations log (Layouts > Import from file)")
    add_settings_args(p)
    p.add_argument("-q", "--quiet", action="store_true", help="no summary line")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..capture import CaptureError, NotACapture, refuse_non_capture
    from ..errors import UsageError

    from ..driver import analyze
    from ..mcap_export import UnsupportedCompression
    from ..mcap_sink import McapSink

    check_capture_path(args.capture)
    refuse_non_capture(args.capture)   # /dev/zero, /dev/urandom, a text file: exit 2 before any output
    if args.decimate < 1:
        raise UsageError("--decimate must be 1 or more")
    if args.keyframe <= 0:
        raise UsageError("--keyframe must be a positive number of seconds")
    settings = settings_from_args(args)
    try:
        # a sink of the one driver (pndiss/driver.py): its telegram and APDU messages come from the engine's
        # columns (pndiss/mcap_sink.py), every other message from events
        sink = McapSink(args.output, args.capture, settings, on_change=args.on_change, decimate=args.decimate,
                        keyframe_ns=int(args.keyframe * 1e9), compression=args.compression)
        exp = sink.exp
    except OSError as e:
        raise UsageError(f"cannot write {args.output}: {e.strerror}") from None
    except UnsupportedCompression as e:  # lz4 is not a hard dependency
        raise UsageError(f"--compression {args.compression}: module {e} is not installed") from None
    from ..report import ProgressReporter
    progress = None if args.no_progress or args.quiet else ProgressReporter(args.capture, True, "exporting")
    error = None
    a = None
    try:
        a = analyze(args.capture, settings, [sink], progress.update if progress else None)
    except CaptureError as e:
        error = e
        a = getattr(e, "analyzer", None)
    finally:
        if progress:
            progress.close()
        if a is not None:
            sink.reader_info = a.reader   # the input's hash, read while streaming
        sink.close()
    if isinstance(error, NotACapture):   # a FIFO that carried no capture: nothing worth keeping
        try:
            os.unlink(args.output)
        except OSError:
            pass
        raise error
    if args.layout:
        from ..foxglove_layout import write as write_layout
        from ..mcap_topics import VIOLATIONS_TOPIC
        try:
            write_layout(args.layout, exp.telegram_channels, VIOLATIONS_TOPIC)
        except OSError as e:
            raise UsageError(f"cannot write {args.layout}: {e.strerror}") from None
    if error is not None:
        print(f"pndiss: error: {error} ({error.frames} frames read before it); "
              f"{args.output} holds what was read", file=sys.stderr)
        return 2
    if not args.quiet:
        topics = exp.topic_counts()
        print(f"{args.output}: {sum(topics.values())} messages on {len(topics)} topics"
              + (f", {exp.dropped} cyclic samples left out" if exp.dropped else ""), file=sys.stderr)
    return 0
