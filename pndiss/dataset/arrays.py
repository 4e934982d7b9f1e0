"""Arrow arrays from numpy columns and Python values, without ``pa.array`` or ``pa.scalar``.

Both ask pyarrow's pandas shim whether their input is a pandas object, and the first question
imports pandas when it is installed (Dask brings it): 0.21 s and ~40 MB of RSS in every process
that writes a dataset, for nothing (bench/NOTES.md, "pandas without pandas"). The arrays here are
built from their buffers (``pa.Array.from_buffers``), as pyarrow itself lays them out.
"""
from __future__ import annotations

import numpy as np
import pyarrow as pa


def _buf(a: np.ndarray) -> pa.Buffer:
    return pa.py_buffer(np.ascontiguousarray(a))


def _validity(valid: np.ndarray | None):
    """The validity bitmap of ``valid`` (None: every value present)."""
    if valid is None or valid.all():
        return None, 0
    return _buf(np.packbits(valid, bitorder="little")), int(len(valid) - np.count_nonzero(valid))


def numeric(a, t: pa.DataType | None = None, valid: np.ndarray | None = None) -> pa.Array:
    """A 1-D numpy array (numbers or bools) as an Arrow array of its own type, cast to ``t`` if
    given (a safe cast: a value out of range raises, as pa.array would)."""
    a = np.asarray(a)
    vbuf, nulls = _validity(valid)
    if a.dtype == np.bool_:
        arr = pa.Array.from_buffers(pa.bool_(), len(a), [vbuf, _buf(np.packbits(a, bitorder="little"))], nulls)
    else:
        arr = pa.Array.from_buffers(pa.from_numpy_dtype(a.dtype), len(a), [vbuf, _buf(a)], nulls)
    return arr if t is None or arr.type == t else arr.cast(t)


_PER_UNIT = {"s": 10**9, "ms": 10**6, "us": 1000, "ns": 1}


def timestamps(ns, t: pa.DataType, valid: np.ndarray | None = None) -> pa.Array:
    """Integer ns since the epoch as timestamps of type ``t``, cut toward zero to its unit as Arrow's
    unsafe cast cuts (two casts cost 0.12 s per 1 M rows; this, a division)."""
    ns = np.asarray(ns, np.int64)
    div = _PER_UNIT[t.unit]
    q = ns // div
    if div > 1:
        q += (q < 0) & (ns % div != 0)   # floor -> toward zero
    vbuf, nulls = _validity(valid)
    return pa.Array.from_buffers(t, len(q), [vbuf, _buf(q)], nulls)


def strings(values: list, valid: np.ndarray | None = None) -> pa.Array:
    """str values (None where ``valid`` is False) as a string array."""
    data = [v.encode() if isinstance(v, str) else b"" for v in values]
    offsets = np.zeros(len(data) + 1, np.int64)
    np.cumsum(np.fromiter(map(len, data), np.int64, len(data)), out=offsets[1:])
    if offsets[-1] < 2 ** 31:
        t, offsets = pa.string(), offsets.astype(np.int32)
    else:
        t = pa.large_string()
    vbuf, nulls = _validity(valid)
    arr = pa.Array.from_buffers(t, len(data), [vbuf, _buf(offsets), pa.py_buffer(b"".join(data))], nulls)
    return arr if t == pa.string() else arr.cast(pa.string())


def _dtype(t: pa.DataType):
    """The numpy type that holds values of ``t`` (timestamps: their integers), or None."""
    if pa.types.is_timestamp(t):
        return np.dtype(np.int64)
    if pa.types.is_integer(t) or pa.types.is_floating(t) or pa.types.is_boolean(t):
        return np.dtype(t.to_pandas_dtype())   # a numpy dtype; pandas is not imported for it
    return None


def column(values, t: pa.DataType) -> pa.Array:
    """Python values (None: null) as an Arrow array of type ``t``: integers, bools, floats, strings
    and timestamps (as integers of their unit); any other type goes through pa.array."""
    values = list(values)
    valid = np.fromiter((v is not None for v in values), bool, len(values))
    if pa.types.is_string(t):
        return strings(values, valid)
    dtype = _dtype(t)
    if dtype is None:
        return pa.array(values, t)   # pragma: no cover - every dataset column is one of the above
    a = np.array([0 if v is None else v for v in values], dtype)
    if pa.types.is_timestamp(t):
        return numeric(a, None, valid).view(t)   # integers of t's unit already
    arr = numeric(a, None, valid)
    return arr if arr.type == t else arr.cast(t)


def repeat(v, t: pa.DataType, n: int) -> pa.Array:
    """``n`` times the value ``v`` (None: nulls) as type ``t``."""
    if v is None:
        return pa.nulls(n, t)
    if pa.types.is_string(t):
        b = v.encode()
        return pa.Array.from_buffers(pa.string(), n, [None, _buf(np.arange(n + 1, dtype=np.int32) * len(b)),
                                                      pa.py_buffer(b * n)])
    arr = numeric(np.full(n, v, _dtype(t)))
    return arr if arr.type == t else arr.cast(t)
