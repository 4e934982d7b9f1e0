"""What every protocol module shares: the Malformed exception and small formatting helpers.

Decoders are plain functions ``decode(data, ...) -> dict``. They never let an IndexError or
struct.error escape: bad input raises :class:`Malformed` with the layer and a reason, which the
analyzer turns into a ``malformed`` event (frame number, layer, reason).
"""
from __future__ import annotations

import struct


class Malformed(Exception):
    """The bytes do not form a valid PDU of ``layer``; ``reason`` says why, in words."""

    def __init__(self, layer: str, reason: str):
        super().__init__(f"{layer}: {reason}")
        self.layer = layer
        self.reason = reason


def need(data: bytes, off: int, n: int, layer: str, what: str) -> None:
    """Raise Malformed unless ``n`` bytes are available at ``off``."""
    if off < 0 or off + n > len(data):
        raise Malformed(layer, f"{what} truncated (needs {n} bytes at offset {off}, frame has {len(data)})")


_MAC_CACHE: dict[bytes, str] = {}


def mac(b: bytes) -> str:
    """'aa:bb:cc:dd:ee:ff'; cached, since a capture has few distinct MACs and many frames."""
    s = _MAC_CACHE.get(b)
    if s is None:
        s = ":".join(f"{x:02x}" for x in b)
        if len(_MAC_CACHE) < 65536:  # bounded: a flood of random MACs must not grow memory
            _MAC_CACHE[bytes(b)] = s
    return s


def ipv4(b: bytes) -> str:
    return ".".join(str(x) for x in b)


def u8(d: bytes, o: int) -> int:
    return d[o]


U16 = struct.Struct(">H")
U32 = struct.Struct(">I")


def u16(d: bytes, o: int) -> int:
    return U16.unpack_from(d, o)[0]


def u32(d: bytes, o: int) -> int:
    return U32.unpack_from(d, o)[0]
