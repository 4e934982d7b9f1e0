"""Connectionless DCE/RPC (the 80-byte datagram header) and its fragment reassembly.

Layout and field names: spec/wire.md §5.1 (tshark 4.0 packet-dcerpc.c `dissect_dcerpc_dg`).
The data representation (drep) byte 0 high nibble picks the integer byte order of the header,
the three UUIDs (first three UUID fields) and, later, the PNIO NDR header.
"""
from __future__ import annotations

import functools
import struct
from datetime import datetime, timezone

from .common import FrameList, Malformed, PendingBuffers

HDR_LEN = 80

# packet types, spec/wire.md §5.1 (tshark dcerpc.pkt_type)
PKT_TYPES = {0: "Request", 1: "Ping", 2: "Response", 3: "Fault", 4: "Working", 5: "Nocall",
             6: "Reject", 7: "Ack", 8: "Cl_cancel", 9: "Fack", 10: "Cancel_ack"}
REQUEST, RESPONSE, FAULT, FACK = 0, 2, 3, 9

# flags1 / flags2 bits, spec/wire.md §5.1 (tshark dcerpc.dg_flags1_* / dg_flags2_*)
FLAGS1 = {"rsrvd_80": 0x80, "broadcast": 0x40, "idempotent": 0x20, "maybe": 0x10,
          "nofack": 0x08, "frag": 0x04, "last_frag": 0x02, "rsrvd_01": 0x01}
FLAGS2 = {"rsrvd_80": 0x80, "rsrvd_40": 0x40, "rsrvd_20": 0x20, "rsrvd_10": 0x10,
          "rsrvd_08": 0x08, "rsrvd_04": 0x04, "cancel_pending": 0x02, "rsrvd_01": 0x01}
F1_FRAG, F1_LAST = 0x04, 0x02

# integer parts of the header after the three UUIDs, per byte order
_TAIL = {"big": struct.Struct(">IIIHHHHH"), "little": struct.Struct("<IIIHHHHH")}
_UUID3 = {"big": struct.Struct(">IHH"), "little": struct.Struct("<IHH")}
_FACK = {"big": struct.Struct(">BxHIIHH"), "little": struct.Struct("<BxHIIHH")}


def get_uuid(data: bytes, off: int, order: str = "big") -> str:
    """A UUID at data[off:off+16]: first three fields in ``order``, last eight bytes as-is (the text
    uuid.UUID gives, written directly: three of them in every DCE/RPC header)."""
    u = bytes(data[off:off + 16])
    if len(u) < 16:
        raise struct.error(f"unpack requires a buffer of 16 bytes at offset {off}")
    if order == "little":
        u = u[3::-1] + u[5:3:-1] + u[7:5:-1] + u[8:]
    h = u.hex()
    return f"{h[:8]}-{h[8:12]}-{h[12:16]}-{h[16:20]}-{h[20:]}"


@functools.lru_cache(maxsize=64)   # a server's boot time is the same in every datagram it sends
def boot_time(v: int) -> str:
    """Server boot time as tshark's ek prints an absolute time (UTC, nanoseconds)."""
    return datetime.fromtimestamp(v, timezone.utc).strftime("%Y-%m-%dT%H:%M:%S.000000000Z")


def decode_header(data: bytes, off: int, end: int) -> dict:
    """The 80-byte connectionless header at data[off:end]; ``body_off``/``body_end`` locate this
    datagram's fragment body (frag_len bytes)."""
    if end - off < HDR_LEN:
        raise Malformed("dcerpc", f"header truncated ({end - off} of 80 bytes)")
    ver, ptype, f1, f2 = data[off], data[off + 1], data[off + 2], data[off + 3]
    if ver != 4:
        raise Malformed("dcerpc", f"RPC version {ver}, connectionless is 4")
    if ptype > 10:
        raise Malformed("dcerpc", f"packet type {ptype} > 10")
    d0, d1, d2 = data[off + 4], data[off + 5], data[off + 6]
    if d0 & 0xEE or d1 > 3:  # tshark's heuristic refuses these drep values
        raise Malformed("dcerpc", f"invalid data representation {d0:02x}:{d1:02x}:{d2:02x}")
    order = "little" if d0 & 0x10 else "big"
    boot, if_ver, seq, opnum, ihint, ahint, flen, fnum = _TAIL[order].unpack_from(data, off + 56)
    body = off + HDR_LEN
    if body + flen > end:
        raise Malformed("dcerpc", f"fragment length {flen} exceeds the {end - body} bytes after the header")
    h = {
        "ver": ver, "pkt_type": ptype, "pkt_type_name": PKT_TYPES[ptype],
        "dg_flags1": f1, "dg_flags2": f2,
        "drep": f"{d0:02x}:{d1:02x}:{d2:02x}", "drep_byteorder": d0 >> 4, "drep_character": d0 & 0x0F,
        "drep_fp": d1, "byte_order": order,
        "dg_serial_hi": data[off + 7],
        "obj_id": get_uuid(data, off + 8, order),
        "dg_if_id": get_uuid(data, off + 24, order),
        "dg_act_id": get_uuid(data, off + 40, order),
        "dg_server_boot": boot_time(boot), "server_boot": boot,
        "dg_if_ver": if_ver, "dg_seqnum": seq, "opnum": opnum,
        "dg_ihint": ihint, "dg_ahint": ahint,
        "dg_frag_len": flen, "dg_frag_num": fnum,
        "dg_auth_proto": data[off + 78], "dg_serial_lo": data[off + 79],
        "body_off": body, "body_end": body + flen,
    }
    for name, bit in FLAGS1.items():
        h["dg_flags1_" + name] = bool(f1 & bit)
    for name, bit in FLAGS2.items():
        h["dg_flags2_" + name] = bool(f2 & bit)
    return h


def decode_fack(data: bytes, off: int, end: int, order: str) -> dict:
    """FACK body (tshark `dissect_dcerpc_dg_fack`): version, window, max TSDU/fragment size,
    serial number, selective-ack length (the selective-ack words are not decoded)."""
    if end - off < _FACK[order].size:
        return {}  # tshark shows nothing for an empty FACK body either
    v, win, tsdu, mfrag, serial, sel = _FACK[order].unpack_from(data, off)
    return {"fack_vers": v, "fack_window_size": win, "fack_max_tsdu": tsdu,
            "fack_max_frag_size": mfrag, "fack_serial_num": serial, "fack_selack_len": sel}


class FragmentReassembler(PendingBuffers):
    """Reassembles fragmented DCE/RPC bodies: key (activity UUID, sequence number, packet type).

    Bounded like pndiss.proto.ip.IpReassembler: ``max_calls`` pending calls, ``max_bytes`` in all,
    ``max_call_bytes`` per call, ``timeout_ns`` per call; dropped calls come back from
    :meth:`expire` as ``(frames, reason)``.
    """

    what = "DCE/RPC reassembly"

    def __init__(self, max_calls: int = 64, max_bytes: int = 4 << 20, max_call_bytes: int = 1 << 20,
                 timeout_ns: int = 30 * 10**9):
        super().__init__(timeout_ns)
        self.max_calls = max_calls
        self.max_bytes = max_bytes
        self.max_call_bytes = max_call_bytes
        # calls completed within the time-out: key -> (time, last fragment number). A client resends a fragment
        # not yet acknowledged (FACK) when the server is slow; one of a completed call is a copy, not a new call
        self.done: dict[tuple, tuple[int, int]] = {}

    def completed(self, h: dict, ts: int) -> bool:
        """The fragment belongs to a call completed less than the time-out ago (a resend): nothing to add."""
        d = self.done.get((h["dg_act_id"], h["dg_seqnum"], h["pkt_type"]))
        return d is not None and ts - d[0] <= self.timeout_ns and h["dg_frag_num"] <= d[1]

    def add(self, fn: int, ts: int, h: dict, data: bytes) -> tuple[bytes, list[int]] | None:
        """Add one fragment; returns (whole body, frames) when the last one closes the set.
        O(1) per fragment: ``contig`` counts the fragments 0, 1, ... present without a gap (before:
        every fragment rescanned all numbers up to the last one, quadratic for a call with a hole)."""
        key = (h["dg_act_id"], h["dg_seqnum"], h["pkt_type"])
        body = data[h["body_off"]:h["body_end"]]
        p = self.pending.get(key)
        if p is None:
            while len(self.pending) >= self.max_calls:
                self._drop(next(iter(self.pending)), "DCE/RPC reassembly buffer full")
            p = self.pending[key] = {"ts": ts, "frames": FrameList(), "parts": {}, "bytes": 0, "last": None,
                                     "contig": 0}
        p["frames"].add(fn)
        parts = p["parts"]
        if h["dg_frag_num"] not in parts:
            parts[h["dg_frag_num"]] = body
            p["bytes"] += len(body)
            self.bytes += len(body)
            c = p["contig"]
            while c in parts:   # each number is passed once in the call's life
                c += 1
            p["contig"] = c
        if h["dg_flags1"] & F1_LAST:
            p["last"] = h["dg_frag_num"]
        if p["bytes"] > self.max_call_bytes:
            self._drop(key, f"DCE/RPC call exceeds {self.max_call_bytes} bytes")
            return None
        while self.bytes > self.max_bytes and self.pending:
            self._drop(next(iter(self.pending)), "DCE/RPC reassembly byte budget exceeded")
        if key not in self.pending or p["last"] is None or p["contig"] <= p["last"]:
            return None
        del self.pending[key]
        self.bytes -= p["bytes"]
        self.done.pop(key, None)
        self.done[key] = (ts, p["last"])
        while len(self.done) > 4 * self.max_calls:   # bounded: the oldest go first
            del self.done[next(iter(self.done))]
        return b"".join(p["parts"][i] for i in range(p["last"] + 1)), p["frames"]
