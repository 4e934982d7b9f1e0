"""Opening a capture the way a Wireshark user expects: ``-`` is stdin, pipes and FIFOs are read as
a stream (frames are analysed as they arrive: ``dumpcap -w - | pndiss analyze - --follow``), and
gzip, zstd and xz captures are decompressed on the fly (sniffed by their magic, not their name).

``open_input`` returns a binary file object for capture.py's reader. Streams are wrapped so that
``read(n)`` returns what has arrived (at most n bytes) instead of blocking until n bytes came, and
say they cannot seek (the reader then never seeks back). ``position(path)`` tells progress bars how
far into the (compressed) file the reader is.
"""
from __future__ import annotations

import gzip
import lzma
import os
import stat
import sys

from .capture import CaptureError

GZIP_MAGIC = b"\x1f\x8b"
ZSTD_MAGIC = b"\x28\xb5\x2f\xfd"
XZ_MAGIC = b"\xfd7zXZ\x00"

_open: dict[str, object] = {}  # path -> raw file, for position()


class _Stream:
    """A non-seekable reader that returns what is available (read1), turning decompressor errors
    into CaptureError (one line, exit 2)."""

    def __init__(self, f, path: str, what: str | None = None):
        self.f = f
        self.path = path
        self.what = what
        self._read = getattr(f, "read1", None) or f.read

    def read(self, n: int = -1) -> bytes:
        try:
            return self._read(n if n and n > 0 else 1 << 20)
        except EOFError:
            raise CaptureError(f"{self.path}: {self.what} data ends early (truncated file)", cut_short=True) from None
        except (OSError, lzma.LZMAError, ValueError) as e:
            if self.what is None:
                raise
            raise CaptureError(f"{self.path}: damaged {self.what} data ({e})") from None

    def seekable(self) -> bool:
        return False

    def close(self) -> None:
        self.f.close()

    def __enter__(self):
        return self

    def __exit__(self, *exc):
        self.close()


def is_stream(path: str) -> bool:
    """stdin, a pipe, a FIFO or a character device: no size, no seeking."""
    if path == "-":
        return True
    try:
        return not stat.S_ISREG(os.stat(path).st_mode)
    except OSError:
        return False


def size(path: str) -> int | None:
    """Bytes in the file when known (for progress), None for streams."""
    if is_stream(path):
        return None
    try:
        return os.path.getsize(path)
    except OSError:
        return None


def position(path: str) -> int | None:
    """How many bytes of the file at ``path`` the reader has consumed so far, if known."""
    f = _open.get(path)
    try:
        return f.tell() if f is not None and not f.closed else None
    except (OSError, ValueError):
        return None


def compressed(head: bytes) -> bool:
    """``head`` (a file's first bytes) starts a gzip, xz or zstd stream (what open_input decompresses)."""
    return head.startswith(GZIP_MAGIC) or head.startswith(XZ_MAGIC) or head.startswith(ZSTD_MAGIC)


def open_input(path: str):
    """A binary reader for the capture at ``path`` (``-`` = stdin); raise CaptureError when unusable."""
    if path == "-":
        raw = sys.stdin.buffer
    else:
        try:
            raw = open(path, "rb")
        except OSError as e:
            raise CaptureError(f"cannot open {path}: {e.strerror}") from None
    stream = is_stream(path)
    try:
        head = raw.peek(8)[:8] if stream else raw.read(8)
        if not stream:
            raw.seek(0)
    except OSError as e:
        raise CaptureError(f"cannot read {path}: {e.strerror}") from None
    if not stream:
        _open[path] = raw
    if head.startswith(GZIP_MAGIC):
        return _Stream(gzip.GzipFile(fileobj=raw, mode="rb"), path, "gzip")
    if head.startswith(XZ_MAGIC):
        return _Stream(lzma.LZMAFile(raw, mode="rb"), path, "xz")
    if head.startswith(ZSTD_MAGIC):
        import zstandard
        reader = zstandard.ZstdDecompressor().stream_reader(raw, read_across_frames=True)
        return _Stream(_ZstdReader(reader), path, "zstd")
    return _Stream(raw, path) if stream else raw


class _ZstdReader:
    """zstandard's reader raises ZstdError (not an OSError): make it one."""

    def __init__(self, r):
        self.r = r

    def read(self, n: int) -> bytes:
        import zstandard
        try:
            return self.r.read(n)
        except zstandard.ZstdError as e:
            raise OSError(str(e)) from None

    def close(self) -> None:
        self.r.close()
