"""What `pndiss fleet` is given: files, directories (searched recursively) and globs, turned into
one list of captures; and each capture's content hash, computed cheaply before any analysis.

The hash is the SHA-256 of the capture's bytes as the reader sees them (a gzip/zstd/xz capture
decompressed), the same digest ``capture.ReadInfo`` computes while analysing: a capture renamed,
moved or compressed differently is still the same capture, and is analysed once.
"""
from __future__ import annotations

import glob
import hashlib
import os

from .errors import UsageError

# what a directory search picks up: the capture formats pndiss reads, plain or compressed
# (pndiss/inputs.py sniffs the compression by its magic; the names are only for the search)
CAPTURE_SUFFIXES = (".pcap", ".pcapng", ".cap")
COMPRESSED_SUFFIXES = ("", ".gz", ".zst", ".xz")
_NAMES = tuple(c + z for c in CAPTURE_SUFFIXES for z in COMPRESSED_SUFFIXES)
_GLOB_CHARS = set("*?[")


def is_capture_name(name: str) -> bool:
    return name.lower().endswith(_NAMES)


def find_captures(inputs: list[str]) -> list[str]:
    """Absolute paths of the captures named by ``inputs``, each once, in a stable order (sorted per
    input, inputs in the order given). A file named explicitly is taken whatever its name (the
    analysis refuses a non-capture as a failed file); directories and globs yield capture names only.
    An input that names nothing is the user's to fix (UsageError: exit 2)."""
    out: list[str] = []
    seen: set[str] = set()

    def add(path: str) -> None:
        real = os.path.realpath(path)
        if real not in seen:
            seen.add(real)
            out.append(os.path.abspath(path))

    for arg in inputs:
        if os.path.isdir(arg):
            found = sorted(_walk(arg))
            if not found:
                raise UsageError(f"{arg}: directory holds no capture (*.pcap, *.pcapng, also .gz/.zst/.xz)")
            for p in found:
                add(p)
        elif os.path.exists(arg):
            if not os.path.isfile(arg):
                raise UsageError(f"{arg}: not a regular file (fleet reads files, not pipes or devices)")
            add(arg)
        elif _GLOB_CHARS & set(arg):
            found = sorted(p for p in glob.glob(arg, recursive=True)
                           if os.path.isfile(p) and is_capture_name(p))
            found += sorted(q for p in glob.glob(arg, recursive=True) if os.path.isdir(p) for q in _walk(p))
            if not found:
                raise UsageError(f"{arg}: no capture matches")
            for p in found:
                add(p)
        else:
            raise UsageError(f"{arg}: no such file or directory")
    return out


def _walk(top: str):
    for root, dirs, files in os.walk(top):
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))   # .git, a dataset's temp dirs
        for name in files:
            if is_capture_name(name) and not name.startswith("."):
                yield os.path.join(root, name)


def content_hash(path: str) -> str:
    """SHA-256 of the capture's (decompressed) bytes, read to the end: ReadInfo's digest without
    parsing a frame. A damaged compressed file hashes what decompresses before the damage (the
    analysis then fails on it and is recorded under this hash). Raises OSError when unreadable."""
    from .capture import CaptureError
    from .inputs import open_input

    h = hashlib.sha256()
    try:
        f = open_input(path)
    except CaptureError as e:
        raise OSError(str(e)) from None
    with f:
        while True:
            try:
                block = f.read(1 << 20)
            except CaptureError:
                break   # damaged compression: hash what came before it
            if not block:
                break
            h.update(block)
    return h.hexdigest()
