"""A lean MCAP writer (mcap.dev/spec): chunked, indexed, with statistics and summary offsets.

Why not ``mcap.writer.Writer``: it builds a ``Message`` dataclass, a ``MessageIndex`` tuple and
six ``struct.pack`` calls through a ``BytesIO`` per message (~15 us each on this machine), which
alone caps an export at ~60 k messages/s. Here a message is one ``struct.pack`` of its 31-byte
record header plus the payload appended to a list, and its index entry two integers appended to
the channel's ``array('Q')``; everything else (message indexes, chunk times, statistics) is
derived once per chunk.

The file is laid out record for record as mcap-python 1.x lays it out for the same calls (same
chunking rule: a chunk is closed when its records exceed ``chunk_size`` bytes; schemas and
channels go into the chunk in progress and are repeated in the summary; Data End with a zero
CRC; summary groups schema, channel, statistics, chunk index, attachment index, metadata
index, then the summary offsets; footer CRC over the summary). tests/test_mcap.py checks the
bytes against mcap-python for arbitrary call sequences, so either reader sees the same file.
"""
from __future__ import annotations

import struct
import sys
import zlib
from array import array

MAGIC = b"\x89MCAP0\r\n"

# opcodes (spec: Records)
HEADER, FOOTER, SCHEMA, CHANNEL, MESSAGE, CHUNK, MESSAGE_INDEX, CHUNK_INDEX = 1, 2, 3, 4, 5, 6, 7, 8
ATTACHMENT_INDEX, STATISTICS, METADATA, METADATA_INDEX, SUMMARY_OFFSET, DATA_END = 0x0A, 0x0B, 0x0C, 0x0D, 0x0E, 0x0F

MSG_HEADER = struct.Struct("<BQHIQQ")  # opcode, record length, channel, sequence, log_time, publish_time
MSG_HEADER_LEN = MSG_HEADER.size       # 31: record header 9 + 22 fixed message fields
_REC = struct.Struct("<BQ")
_Q = struct.Struct("<Q")
_I = struct.Struct("<I")
_H = struct.Struct("<H")
_LITTLE = sys.byteorder == "little"
# the message record header as a packed NumPy record (add_batch); same layout as MSG_HEADER
_HDR = [("op", "u1"), ("len", "<u8"), ("cid", "<u2"), ("seq", "<u4"), ("lt", "<u8"), ("pub", "<u8")]


def _np():
    """NumPy, imported when a chunk is large enough to be worth it (it is a dependency since #8)."""
    import numpy
    return numpy


def _str(s: str) -> bytes:
    b = s.encode()
    return _I.pack(len(b)) + b


def _map(d: dict) -> bytes:
    body = b"".join(_str(k) + _str(v) for k, v in d.items())
    return _I.pack(len(body)) + body


def _record(op: int, body: bytes) -> bytes:
    return _REC.pack(op, len(body)) + body


def _u64s(a: array) -> bytes:
    if not _LITTLE:
        a = array("Q", a)
        a.byteswap()
    return a.tobytes()


def _compressor(compression: str):
    """(name written into the chunk record, function bytes -> bytes) for none / lz4 / zstd."""
    if compression in ("", "none"):
        return "", None
    if compression == "zstd":
        import zstandard  # mcap-python uses zstandard.compress(data) = level 3, content size in the frame
        return "zstd", zstandard.ZstdCompressor(level=3).compress
    if compression == "lz4":
        import lz4.frame  # ImportError when lz4 is not installed: the caller turns it into a usage error
        return "lz4", lz4.frame.compress
    raise ValueError(f"unknown compression {compression!r}")


class McapWriter:
    """Streaming MCAP writer; ``add_message`` is the hot path. Call ``start`` first and ``finish``
    at the end (it does not close the stream)."""

    def __init__(self, stream, chunk_size: int = 1024 * 1024, compression: str = "zstd"):
        self.f = stream
        self.chunk_size = chunk_size
        self.compression, self._compress = _compressor(compression)
        self.pos = 0                 # bytes written to the stream
        self.schemas: list[bytes] = []   # schema records, for the summary
        self.channels: list[bytes] = []  # channel records, for the summary
        self.chunk_indexes: list[bytes] = []
        self.metadata_indexes: list[bytes] = []
        self.counts: dict[int, int] = {}  # channel id -> messages, in order of each channel's first message
        self.n_messages = 0
        self.start_time = self.end_time = 0
        self.n_chunks = self.n_metadata = 0
        # the chunk in progress: its records as a list of byte strings, their total size, and per
        # channel (in order of first message) the flat (log_time, offset) pairs of its messages
        self.parts: list[bytes] = []
        self.size = 0
        self.index: dict[int, array] = {}

    # -- records outside chunks ----------------------------------------------------------------
    def _out(self, data: bytes) -> None:
        self.f.write(data)
        self.pos += len(data)

    def start(self, profile: str = "", library: str = "") -> None:
        self._out(MAGIC + _record(HEADER, _str(profile) + _str(library)))

    def register_schema(self, name: str, encoding: str, data: bytes) -> int:
        sid = len(self.schemas) + 1
        rec = _record(SCHEMA, _H.pack(sid) + _str(name) + _str(encoding) + _I.pack(len(data)) + data)
        self.schemas.append(rec)
        self._chunk_record(rec)
        return sid

    def register_channel(self, topic: str, message_encoding: str, schema_id: int, metadata: dict | None = None) -> int:
        cid = len(self.channels) + 1
        rec = _record(CHANNEL, _H.pack(cid) + _H.pack(schema_id) + _str(topic) + _str(message_encoding)
                      + _map(metadata or {}))
        self.channels.append(rec)
        self._chunk_record(rec)
        return cid

    def _chunk_record(self, rec: bytes) -> None:
        self.parts.append(rec)
        self.size += len(rec)
        if self.size > self.chunk_size:
            self._finish_chunk()

    def add_metadata(self, name: str, data: dict) -> None:
        # written at once, outside the chunk in progress (as mcap-python does)
        rec = _record(METADATA, _str(name) + _map(data))
        self.metadata_indexes.append(_record(METADATA_INDEX, _Q.pack(self.pos) + _Q.pack(len(rec)) + _str(name)))
        self.n_metadata += 1
        self._out(rec)

    # -- messages ------------------------------------------------------------------------------
    def add_message(self, channel_id: int, log_time: int, data: bytes, publish_time: int, sequence: int = 0) -> None:
        size = self.size
        ix = self.index.get(channel_id)
        if ix is None:
            ix = self.index[channel_id] = array("Q")
        ix.append(log_time)
        ix.append(size)
        self.parts.append(MSG_HEADER.pack(MESSAGE, 22 + len(data), channel_id, sequence, log_time, publish_time))
        self.parts.append(data)
        self.size = size = size + MSG_HEADER_LEN + len(data)
        if size > self.chunk_size:
            self._finish_chunk()

    def add_messages(self, msgs) -> None:
        """add_message for each (channel_id, log_time, data, publish_time, sequence) of ``msgs``."""
        parts, index, size, limit = self.parts, self.index, self.size, self.chunk_size
        pack = MSG_HEADER.pack
        for cid, t, data, pub, seq in msgs:
            ix = index.get(cid)
            if ix is None:
                ix = index[cid] = array("Q")
            ix.append(t)
            ix.append(size)
            parts.append(pack(MESSAGE, 22 + len(data), cid, seq, t, pub))
            parts.append(data)
            size += MSG_HEADER_LEN + len(data)
            if size > limit:
                self.size = size
                self._finish_chunk()
                parts, index, size = self.parts, self.index, 0
        self.size = size

    def add_batch(self, channel_ids, log_times, datas: list, publish_times, sequences) -> None:
        """add_message for each message of parallel columns (NumPy arrays, ``datas`` a list of bytes),
        with the records of a chunk's share laid out by NumPy instead of one pack per message."""
        import numpy as np

        n = len(datas)
        lens = np.fromiter(map(len, datas), np.int64, n)
        rec = lens + MSG_HEADER_LEN
        start = 0
        while start < n:
            ends = self.size + np.cumsum(rec[start:])     # offsets in the chunk after each record
            over = np.flatnonzero(ends > self.chunk_size)
            m = int(over[0]) + 1 if over.size else n - start   # the record that overflows closes the chunk
            stop = start + m
            ends = ends[:m]
            offs = ends - rec[start:stop]
            hdr = np.empty(m, _HDR)
            hdr["op"] = MESSAGE
            hdr["len"] = lens[start:stop] + 22
            hdr["cid"] = channel_ids[start:stop]
            hdr["seq"] = sequences[start:stop]
            hdr["lt"] = log_times[start:stop]
            hdr["pub"] = publish_times[start:stop]
            hb = hdr.tobytes()
            recs = [None] * (2 * m)
            recs[0::2] = [hb[i:i + MSG_HEADER_LEN] for i in range(0, m * MSG_HEADER_LEN, MSG_HEADER_LEN)]
            recs[1::2] = datas[start:stop]
            self.parts.append(b"".join(recs))
            cids = channel_ids[start:stop]
            lts = log_times[start:stop]
            ids, first = np.unique(cids, return_index=True)
            for cid in ids[np.argsort(first)].tolist():   # index order: each channel's first message
                sel = cids == cid
                pairs = np.empty((int(sel.sum()), 2), np.uint64)
                pairs[:, 0] = lts[sel]
                pairs[:, 1] = offs[sel]
                ix = self.index.get(cid)
                if ix is None:
                    ix = self.index[cid] = array("Q")
                ix.frombytes(pairs.tobytes())
            self.size = int(ends[-1])
            if over.size:
                self._finish_chunk()
            start = stop

    def add_records(self, data, ends, channel_ids, log_times) -> None:
        """Message records laid out already (pndiss/coltext.py writes them behind their headers):
        ``data`` (bytes-like) holds them back to back, ``ends`` (int64) their end offsets. Chunks
        close and indexes fill exactly as add_message would for each record in turn."""
        np = _np()
        n = len(ends)
        i = 0
        while i < n:
            base = 0 if i == 0 else int(ends[i - 1])
            # the record whose end passes chunk_size still goes into this chunk, then it closes
            j = int(np.searchsorted(ends, self.chunk_size - self.size + base, side="right")) + 1
            j = min(max(j, i + 1), n)
            end = int(ends[j - 1])
            offs = np.empty(j - i, np.uint64)
            offs[0] = self.size
            offs[1:] = ends[i:j - 1] - base + self.size
            self.parts.append(bytes(data[base:end]))
            cids = np.asarray(channel_ids[i:j])
            # per channel, in order of its first record here, its (log time, offset) pairs in order
            order = np.argsort(cids, kind="stable")
            sc = cids[order]
            starts = np.flatnonzero(np.r_[True, sc[1:] != sc[:-1]])
            pairs = np.empty((j - i, 2), np.uint64)
            pairs[:, 0] = np.asarray(log_times[i:j])[order]
            pairs[:, 1] = offs[order]
            flat = pairs.tobytes()
            bounds = np.r_[starts, j - i] * 16
            index = self.index
            for k in np.argsort(order[starts], kind="stable").tolist():
                cid = int(sc[starts[k]])
                ix = index.get(cid)
                if ix is None:
                    ix = index[cid] = array("Q")
                ix.frombytes(flat[bounds[k]:bounds[k + 1]])
            self.size += end - base
            if self.size > self.chunk_size:
                self._finish_chunk()
            i = j

    def _finish_chunk(self) -> None:
        index = self.index
        if not index:
            return  # schemas / channels only: they stay in the chunk in progress (mcap-python does the same)
        data = b"".join(self.parts)
        n = 0
        start = end = None
        counts = self.counts
        for cid, ix in index.items():
            k = len(ix) >> 1
            n += k
            counts[cid] = counts.get(cid, 0) + k
            if len(ix) > 64:
                times = _np().frombuffer(ix, _np().uint64)[0::2]
                lo, hi = int(times.min()), int(times.max())
            else:
                times = ix[0::2]
                lo, hi = min(times), max(times)
            if start is None or lo < start:
                start = lo
            if end is None or hi > end:
                end = hi
        end = max(end, 0)
        if self.n_messages == 0:
            self.start_time = start
        else:
            self.start_time = min(self.start_time, start)
        self.end_time = max(self.end_time, end)
        self.n_messages += n
        self.n_chunks += 1
        comp = self._compress(data) if self._compress is not None else data
        chunk = _record(CHUNK, _Q.pack(start) + _Q.pack(end) + _Q.pack(len(data)) + _I.pack(zlib.crc32(data))
                        + _str(self.compression) + _Q.pack(len(comp)) + comp)
        chunk_at = self.pos
        self._out(chunk)
        index_at = self.pos
        offsets, recs = [], []
        at = index_at
        for cid, ix in index.items():
            rec = _record(MESSAGE_INDEX, _H.pack(cid) + _I.pack(len(ix) * 8) + _u64s(ix))
            offsets.append(_H.pack(cid) + _Q.pack(at))
            recs.append(rec)
            at += len(rec)
        self._out(b"".join(recs))
        self.chunk_indexes.append(_record(CHUNK_INDEX, _Q.pack(start) + _Q.pack(end) + _Q.pack(chunk_at)
                                          + _Q.pack(len(chunk)) + _I.pack(len(offsets) * 10) + b"".join(offsets)
                                          + _Q.pack(at - index_at) + _str(self.compression)
                                          + _Q.pack(len(comp)) + _Q.pack(len(data))))
        self.parts = []
        self.size = 0
        self.index = {}

    # -- end -----------------------------------------------------------------------------------
    def finish(self) -> None:
        self._finish_chunk()
        self._out(_record(DATA_END, _I.pack(0)))
        summary_start = self.pos
        groups = []
        stats = _record(STATISTICS, _Q.pack(self.n_messages) + _H.pack(len(self.schemas)) + _I.pack(len(self.channels))
                        + _I.pack(0) + _I.pack(self.n_metadata) + _I.pack(self.n_chunks)
                        + _Q.pack(self.start_time) + _Q.pack(self.end_time) + _I.pack(len(self.counts) * 10)
                        + b"".join(_H.pack(c) + _Q.pack(k) for c, k in self.counts.items()))
        for op, recs in ((SCHEMA, self.schemas), (CHANNEL, self.channels), (STATISTICS, [stats]),
                         (CHUNK_INDEX, self.chunk_indexes), (ATTACHMENT_INDEX, []),
                         (METADATA_INDEX, self.metadata_indexes)):
            groups.append((op, b"".join(recs)))
        body, at = [], summary_start
        offsets = []
        for op, data in groups:
            offsets.append(_record(SUMMARY_OFFSET, bytes((op,)) + _Q.pack(at) + _Q.pack(len(data))))
            body.append(data)
            at += len(data)
        offset_start = at
        summary = b"".join(body) + b"".join(offsets)
        tail = _REC.pack(FOOTER, 20) + _Q.pack(summary_start if summary else 0) + _Q.pack(offset_start)
        crc = zlib.crc32(tail, zlib.crc32(summary))
        self._out(summary + tail + _I.pack(crc) + MAGIC)
