"""lldp: placeholder until its decoder lands."""
from __future__ import annotations


def decode(data: bytes, off: int) -> dict:
    return {}


def decode_mrp(data: bytes, off: int) -> dict:
    return {}
