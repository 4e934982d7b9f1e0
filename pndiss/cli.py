"""Command line: ``pndiss <command> ...``. Thin: parse, call the pipeline, render.

Each command is a module in ``pndiss.commands`` with ``add_parser(subparsers)`` and
``run(args) -> int``. Exit codes: 0 ok, 1 violations at/above ``--fail-on``, 2 unusable input
or arguments, 3 internal error (a bug: please report it with ``--debug`` output).
"""
from __future__ import annotations

import argparse
import importlib
import pkgutil
import sys

from . import __version__
from . import commands
from .errors import UsageError


def build_parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    """The parser; with ``argv`` naming a command, only that command's module is imported (the
    simulator pulls in scapy, which costs seconds of start-up that `analyze` must not pay)."""
    p = argparse.ArgumentParser(prog="pndiss", description="PROFINET encoder dissector and log analyzer")
    p.add_argument("--version", action="version", version=f"pndiss {__version__}")
    p.add_argument("--debug", action="store_true", help="show Python tracebacks on internal errors")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True
    names = sorted(m.name for m in pkgutil.iter_modules(commands.__path__))
    wanted = next((a for a in (argv or []) if not a.startswith("-")), None)
    for name in ([wanted] if wanted in names else names):
        importlib.import_module(f"{commands.__name__}.{name}").add_parser(sub)
    return p


def main(argv: list[str] | None = None) -> int:
    from .capture import CaptureError

    if argv is None:
        argv = sys.argv[1:]
    parser = build_parser(argv)
    args = parser.parse_args(argv)
    try:
        return args.func(args)
    except (CaptureError, UsageError) as e:
        print(f"pndiss: error: {e}", file=sys.stderr)
        return 2
    except KeyboardInterrupt:
        print("pndiss: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        return 0
    except Exception as e:  # never a traceback for users; --debug shows it
        if args.debug:
            raise
        print(f"pndiss: internal error: {type(e).__name__}: {e} (run with --debug for details)", file=sys.stderr)
        return 3


if __name__ == "__main__":
    sys.exit(main())
