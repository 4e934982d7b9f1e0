"""Command line: ``pndiss <command> ...``. Thin: parse, call the pipeline, render.

Each command is a module in ``pndiss.commands`` with ``add_parser(subparsers)`` and
``run(args) -> int``. Exit codes: 0 ok (also when stdout is closed early, ``| head``), 1 violations at/above
``--fail-on``, 2 unusable input, arguments or output (missing file, full disk, unwritable path),
3 internal error only (a bug: please report it with ``--debug`` output).
"""
from __future__ import annotations

import argparse
import errno
import importlib
import os
import pkgutil
import re
import sys

from . import __version__
from . import commands
from .errors import UsageError


class Parser(argparse.ArgumentParser):
    """argparse with a "did you mean" for mistyped options, commands and choices."""

    def error(self, message: str):
        from .errors import did_you_mean
        m = re.search(r"unrecognized arguments: (.*)", message)
        if m:
            opts = sorted({o for p in _parsers(self) for a in p._actions for o in a.option_strings})
            for word in m.group(1).split():
                if word.startswith("-"):
                    message += did_you_mean(word.split("=")[0], opts)
                    break
        m = re.search(r"invalid choice: '([^']*)' \(choose from (.*)\)", message)
        if m:
            message += did_you_mean(m.group(1), re.findall(r"'([^']*)'", m.group(2)))
        super().error(message)


def _parsers(p: argparse.ArgumentParser) -> list:
    """``p`` and its sub-command parsers (for option suggestions made by the top-level parser)."""
    out = [p]
    for a in p._actions:
        if isinstance(a, argparse._SubParsersAction):
            out.extend(a.choices.values())
    return out


def build_parser(argv: list[str] | None = None) -> argparse.ArgumentParser:
    """The parser; with ``argv`` naming a command, only that command's module is imported (the
    simulator pulls in scapy, which costs seconds of start-up that `analyze` must not pay)."""
    p = Parser(prog="pndiss", description="PROFINET encoder dissector and log analyzer")
    p.add_argument("--version", action="version", version=f"pndiss {__version__}")
    p.add_argument("--debug", action="store_true", help="show Python tracebacks on internal errors")
    sub = p.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    sub.required = True
    names = sorted(m.name for m in pkgutil.iter_modules(commands.__path__))
    wanted = next((a.replace("-", "_") for a in (argv or []) if not a.startswith("-")), None)
    for name in ([wanted] if wanted in names else names):
        importlib.import_module(f"{commands.__name__}.{name}").add_parser(sub)
    return p


def main(argv: list[str] | None = None) -> int:
    """Run one command; exit code as in the module docstring. A closed stdout, even at the final
    flush, ends quietly with 0."""
    code = _main(argv)
    try:
        sys.stdout.flush()
    except BrokenPipeError:
        _quiet_stdout()
    except OSError as e:
        print(f"pndiss: error: cannot write stdout: {e.strerror}", file=sys.stderr)
        _quiet_stdout()
        code = 2
    return code


def _main(argv: list[str] | None) -> int:
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
        _quiet_stdout()
        return 0  # the reader went away (| head): what it wanted was written
    except OSError as e:
        if e.errno in USER_ERRNOS:  # a full disk, an unwritable or missing path: the user's to fix
            print(f"pndiss: error: {e.filename + ': ' if e.filename else ''}{e.strerror}", file=sys.stderr)
            return 2
        return _internal(args, e)
    except Exception as e:  # never a traceback for users; --debug shows it
        if type(e).__name__ in ("MapError", "GsdmlError"):  # bad --map / --gsdml file
            print(f"pndiss: error: {e}", file=sys.stderr)
            return 2
        return _internal(args, e)


USER_ERRNOS = {errno.ENOSPC, errno.EDQUOT, errno.EFBIG, errno.EROFS, errno.EACCES, errno.EPERM, errno.ENOENT,
               errno.EISDIR, errno.ENOTDIR, errno.EIO, errno.ENAMETOOLONG, errno.ENXIO}


def _internal(args, e: Exception) -> int:
    if args.debug:
        raise e
    print(f"pndiss: internal error: {type(e).__name__}: {e} (run with --debug for details)", file=sys.stderr)
    return 3


def _quiet_stdout() -> None:
    """Point stdout at /dev/null so the interpreter's final flush cannot fail again."""
    try:
        fd = os.open(os.devnull, os.O_WRONLY)
        os.dup2(fd, sys.stdout.fileno())
        os.close(fd)
    except (OSError, ValueError):
        pass


if __name__ == "__main__":
    sys.exit(main())
