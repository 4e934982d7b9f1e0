"""alarm: placeholder until its decoder lands (returns the bare header only)."""
from __future__ import annotations


def decode(data: bytes, off: int, frame_id: int) -> dict:
    return {}
