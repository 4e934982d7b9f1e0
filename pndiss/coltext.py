"""JSON text of many messages at once, from columns (the column sinks: mcap_sink.py, jsonl_sink.py).

A message shape (an MCAP telegram message, a JSONL rt line ...) is compiled once into a template:
the reference encoder (``json`` with the sink's settings) writes the shape's dict with a marker in
place of every per-row value, and the text is cut at the markers. Constant text, key order and
escaping are therefore the reference's own; per row only the values are written, by a compiled
loop (``render``) that fills one buffer for a whole run of messages, optionally each behind its
MCAP message record header. Values are int64 columns: decimal numbers (signed, or the bits of a
uint64), a bit field of one, ``null`` for a negative one (IOPS absent), or a pick from a pool of
ready texts (bits of a DataStatus, an IOxS byte, an error code).

numba compiles ``render`` (prebuilt wheels, no compiler needed; ~0.1 us per message against
~0.8 us for Python's ``%`` formatting). Without numba the same function runs as plain Python:
right, but slow.
"""
from __future__ import annotations

import re

import numpy as np

try:
    from numba import njit
except ImportError:  # pragma: no cover - same code, interpreted
    def njit(*args, **kwargs):
        return (lambda f: f) if not args or not callable(args[0]) else args[0]

CONST, INT, NINT, PICK, BITS, U64 = range(6)
MSG_HEADER_LEN = 31          # MCAP message record: opcode, length, channel, sequence, log time, publish time
_MARK = re.compile(rb'"\\u0001(\d+)\\u0002"')


class Val:
    """A per-row value in a template dict: column ``col`` of the source's value matrix."""
    __slots__ = ("op", "col", "shift", "mask")

    def __init__(self, op: int, col: int, shift: int = 0, mask: int = 0):
        self.op, self.col, self.shift, self.mask = op, col, shift, mask


def _marked(obj, vals: list):
    if isinstance(obj, Val):
        vals.append(obj)
        return f"\x01{len(vals) - 1}\x02"
    if isinstance(obj, dict):
        return {k: _marked(v, vals) for k, v in obj.items()}
    if isinstance(obj, list):
        return [_marked(v, vals) for v in obj]
    return obj


class Pool:
    """Every constant text and pickable text, as one byte array with offsets (what ``render`` reads)."""

    def __init__(self):
        self.ids: dict[bytes, int] = {}
        self.parts: list[bytes] = []
        self.ops: list[tuple] = []        # template id -> its ops (kind, a, b, c)
        self.bound: list[int] = []        # template id -> most bytes one message can take
        self._arrays = None
        self._buf = None
        self.texts: dict[bytes, int] = {}  # compiled text -> template id
        self.ioxs_ids = None               # pool entries of the 256 IOxS texts (colrows.rt_shape)

    def entry(self, text: bytes) -> int:
        i = self.ids.get(text)
        if i is None:
            i = self.ids[text] = len(self.parts)
            self.parts.append(text)
            self._arrays = None
        return i

    def template(self, obj, dumps, suffix: bytes = b"") -> int:
        """Compile ``obj`` (a dict with ``Val`` markers) as ``dumps`` writes it, plus ``suffix``."""
        vals: list[Val] = []
        # a key named "\x03" stands for an optional member: its PICK writes ',"name":value' or nothing
        text = dumps(_marked(obj, vals)).encode().replace(b',"\\u0003":', b"") + suffix
        done = self.texts.get(text)
        if done is not None:
            return done
        ops, bound, pos = [], 0, 0
        for m in _MARK.finditer(text):
            if m.start() > pos:
                ops.append((CONST, self.entry(text[pos:m.start()]), 0, 0))
                bound += m.start() - pos
            v = vals[int(m.group(1))]
            ops.append((v.op, v.col, v.shift, v.mask))
            bound += 21 if v.op != PICK else 0   # picks: added per row by the caller's pool bound
            pos = m.end()
        if pos < len(text):
            ops.append((CONST, self.entry(text[pos:]), 0, 0))
            bound += len(text) - pos
        self.ops.append(tuple(ops))
        self.bound.append(bound)
        self._arrays = None
        self.texts[text] = len(self.ops) - 1
        return len(self.ops) - 1

    def arrays(self):
        if self._arrays is None:
            lens = np.fromiter((len(p) for p in self.parts), np.int64, len(self.parts))
            off = np.zeros(len(lens) + 1, np.int64)
            np.cumsum(lens, out=off[1:])
            pool = np.frombuffer(b"".join(self.parts), np.uint8) if self.parts else np.zeros(0, np.uint8)
            flat = [o for ops in self.ops for o in ops]
            op_off = np.zeros(len(self.ops) + 1, np.int64)
            np.cumsum([len(o) for o in self.ops], out=op_off[1:])
            ops = np.array(flat, np.int64).reshape(-1, 4) if flat else np.zeros((0, 4), np.int64)
            n_pick = np.array([sum(1 for o in t if o[0] == PICK) for t in self.ops], np.int64)
            self._arrays = (pool, off, op_off, np.ascontiguousarray(ops), np.array(self.bound, np.int64),
                            int(lens.max()) if len(lens) else 0, n_pick)
        return self._arrays

    def render(self, tmpl, vbase, vals, emit, hdr=None, step: int = 8192) -> None:
        """Messages m = 0.. of template ``tmpl[m]`` with values ``vals[vbase[m]:]``, ``step`` at a
        time into one reused buffer: ``emit(bytes, ends, lo, hi)`` per step (ends: end offsets of
        messages lo..hi-1 in the bytes). ``hdr`` = (channel ids, sequences, log times, publish
        times): each message behind its MCAP message record header. The bytes are a view of the
        buffer, valid until ``emit`` returns."""
        pool, off, op_off, ops, bound, longest, n_pick = self.arrays()
        m = len(tmpl)
        tmpl = np.asarray(tmpl, np.int64)
        vbase = np.asarray(vbase, np.int64)
        z = np.zeros(m, np.int64)
        cid, seq, lt, pub = (np.asarray(x, np.int64) for x in hdr) if hdr is not None else (z, z, z, z)
        per = bound[tmpl] + n_pick[tmpl] * longest + (MSG_HEADER_LEN if hdr is not None else 0)
        for lo in range(0, m, step):
            hi = min(m, lo + step)
            size = int(per[lo:hi].sum())
            if self._buf is None or len(self._buf) < size:
                self._buf = np.empty(max(size, 1 << 20), np.uint8)   # reused: fresh pages cost more than the text
            ends = np.empty(hi - lo, np.uint64)
            _render(self._buf, ends, tmpl[lo:hi], vbase[lo:hi], vals, op_off, ops, pool, off,
                    hdr is not None, cid[lo:hi], seq[lo:hi], lt[lo:hi], pub[lo:hi])
            emit(self._buf[:int(ends[-1])], ends.astype(np.int64), lo, hi)


# Positions are uint64 throughout: numba's negative-index wrap-around check on signed indices keeps
# LLVM from vectorising the copies (measured: 30x slower on 140-byte constants).
@njit(cache=True, nogil=True)
def _digits(out, p, u):
    """Decimal of the unsigned value ``u`` (a uint64) at out[p:]; returns the new end."""
    ten = np.uint64(10)
    if u < ten:   # bits, DataStatus flags: one digit
        out[p] = np.uint8(np.uint64(48) + u)
        return p + np.uint64(1)
    n = np.uint64(1)
    t = u
    while t >= ten:
        t //= ten
        n += np.uint64(1)
    q = p + n
    i = q
    while i > p:
        i -= np.uint64(1)
        out[i] = np.uint8(np.uint64(48) + u % ten)
        u //= ten
    return q


@njit(cache=True, nogil=True)
def _le(out, p, v, n):
    u = np.uint64(v)
    for i in range(n):
        out[p + np.uint64(i)] = np.uint8(u & np.uint64(0xFF))
        u >>= np.uint64(8)


@njit(cache=True, nogil=True)
def _copy(out, p, pool, s, e):
    n = e - s
    for i in range(n):
        out[p + i] = pool[s + i]
    return p + n


@njit(cache=True, nogil=True)
def _render(out, ends, tmpl, vbase, vals, op_off, ops, pool, off, hdr, cid, seq, lt, pub):
    one = np.uint64(1)
    p = np.uint64(0)
    for m in range(len(tmpl)):
        start = p
        if hdr:
            p += np.uint64(31)
        t = tmpl[m]
        base = vbase[m]
        for o in range(op_off[t], op_off[t + 1]):
            k = ops[o, 0]
            a = ops[o, 1]
            if k == 0 or k == 3:   # CONST, PICK (the value is a pool entry)
                e = a if k == 0 else vals[base + a]
                p = _copy(out, p, pool, np.uint64(off[e]), np.uint64(off[e + 1]))
            else:
                v = vals[base + a]
                if k == 4:   # BITS
                    v = (v >> ops[o, 2]) & ops[o, 3]
                if k == 5:   # U64: the column holds the bits of a uint64
                    p = _digits(out, p, np.uint64(v))
                elif k == 2 and v < 0:   # NINT: null
                    out[p] = 110
                    out[p + one] = 117
                    out[p + np.uint64(2)] = 108
                    out[p + np.uint64(3)] = 108
                    p += np.uint64(4)
                elif v < 0:
                    out[p] = 45
                    p = _digits(out, p + one, np.uint64(-(v + 1)) + one)
                else:
                    p = _digits(out, p, np.uint64(v))
        if hdr:
            out[start] = 5
            _le(out, start + one, p - start - np.uint64(9), 8)
            _le(out, start + np.uint64(9), cid[m], 2)
            _le(out, start + np.uint64(11), seq[m], 4)
            _le(out, start + np.uint64(15), lt[m], 8)
            _le(out, start + np.uint64(23), pub[m], 8)
        ends[m] = p


@njit(cache=True, nogil=True)
def thin(ts, pub, changed, n0, lw0, has_lw, decimate, on_change, keyframe_ns):
    """McapExporter._keep for a run of samples: (keep mask, samples counted, last written time, has it).
    ``ts``: the times _keep compares; ``pub``: the times written (lw becomes them)."""
    keep = np.zeros(len(ts), np.bool_)
    n = n0
    lw = lw0
    for i in range(len(ts)):
        n += 1
        if not on_change:
            k = decimate == 1 or (n - 1) % decimate == 0
        else:
            k = changed[i] or not has_lw or ts[i] - lw >= keyframe_ns or (decimate > 1 and (n - 1) % decimate == 0)
        if k:
            lw = pub[i]
            has_lw = True
        keep[i] = k
    return keep, n, lw, has_lw
