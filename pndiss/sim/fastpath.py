"""Placeholder until the fast path lands."""
FAST_THRESHOLD = 1 << 62


def write_fast(cfg, path, expected=True):  # pragma: no cover
    raise NotImplementedError
