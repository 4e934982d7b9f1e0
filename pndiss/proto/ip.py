"""IPv4 header, UDP header and a bounded, timed-out IPv4 fragment reassembler.

Field names follow tshark 4.0 (packet-ip.c, packet-udp.c) so tests/tshark_map/{ip,udp}.json can
compare them one to one. Only what PNIO-CM needs: options are skipped (their bytes are counted
in the header length), checksums are reported, not verified (tshark: "validation disabled").
"""
from __future__ import annotations

import heapq

from .common import FrameList, Malformed, PendingBuffers, ipv4

IP_HDR_MIN = 20
UDP_HDR = 8
PROTO_UDP = 17

# tshark ip.checksum_status / udp.checksum_status: 2 = "Unverified" (validation off by default)
CHECKSUM_UNVERIFIED = 2


def decode_ipv4(data: bytes, off: int) -> dict:
    """IPv4 header at data[off:]; adds ``payload_off``/``payload_end`` (end from Total Length,
    so Ethernet padding is excluded)."""
    if len(data) - off < IP_HDR_MIN:
        raise Malformed("ip", f"IPv4 header truncated ({len(data) - off} of 20 bytes)")
    vihl = data[off]
    version, ihl = vihl >> 4, (vihl & 0x0F) * 4
    if version != 4:
        raise Malformed("ip", f"version {version} in an IPv4 EtherType frame")
    if ihl < IP_HDR_MIN:
        raise Malformed("ip", f"header length {ihl} < 20")
    total = (data[off + 2] << 8) | data[off + 3]
    if total < ihl:
        raise Malformed("ip", f"total length {total} < header length {ihl}")
    if off + total > len(data):
        raise Malformed("ip", f"total length {total} exceeds the {len(data) - off} captured bytes")
    tos = data[off + 1]
    ff = (data[off + 6] << 8) | data[off + 7]
    return {
        "version": version,
        "hdr_len": ihl,
        "dsfield": tos,
        "dsfield_dscp": tos >> 2,
        "dsfield_ecn": tos & 3,
        "len": total,
        "id": (data[off + 4] << 8) | data[off + 5],
        "flags": ff >> 13,  # tshark 4.0 shows the 3 flag bits as a value 0..7
        "flags_rb": bool(ff & 0x8000),
        "flags_df": bool(ff & 0x4000),
        "flags_mf": bool(ff & 0x2000),
        "frag_offset": (ff & 0x1FFF) * 8,  # tshark 4.0 shows bytes, not 8-byte units
        "ttl": data[off + 8],
        "proto": data[off + 9],
        "checksum": (data[off + 10] << 8) | data[off + 11],
        "checksum_status": CHECKSUM_UNVERIFIED,
        "src": ipv4(data[off + 12:off + 16]),
        "dst": ipv4(data[off + 16:off + 20]),
        "payload_off": off + ihl,
        "payload_end": off + total,
    }


def decode_udp(data: bytes, off: int, end: int) -> dict:
    """UDP header at data[off:end]; ``payload_end`` from the UDP length."""
    if end - off < UDP_HDR:
        raise Malformed("udp", f"UDP header truncated ({end - off} of 8 bytes)")
    length = (data[off + 4] << 8) | data[off + 5]
    if length < UDP_HDR or off + length > end:
        raise Malformed("udp", f"UDP length {length} does not fit the {end - off} bytes of the IP payload")
    return {
        "srcport": (data[off] << 8) | data[off + 1],
        "dstport": (data[off + 2] << 8) | data[off + 3],
        "length": length,
        "checksum": (data[off + 6] << 8) | data[off + 7],
        # tshark udp.checksum.status: 3 "Not present" for a zero checksum (optional in IPv4)
        "checksum_status": CHECKSUM_UNVERIFIED if data[off + 6] | data[off + 7] else 3,
        "payload_off": off + UDP_HDR,
        "payload_end": off + length,
    }


class IpReassembler(PendingBuffers):
    """IPv4 fragment reassembly (RFC 791), key (src, dst, proto, id).

    Bounded: at most ``max_datagrams`` pending datagrams and ``max_bytes`` buffered payload;
    a datagram waits at most ``timeout_ns`` (RFC 1122 suggests 60-120 s; 30 s is plenty on a
    LAN). Whatever is dropped comes back from :meth:`add`/:meth:`expire` as ``(frames, reason)``
    so the caller can report it as malformed.
    """

    what = "IPv4 reassembly"

    def __init__(self, max_datagrams: int = 64, max_bytes: int = 1 << 20, timeout_ns: int = 30 * 10**9,
                 max_datagram: int = 65535):
        super().__init__(timeout_ns)
        self.max_datagrams = max_datagrams
        self.max_bytes = max_bytes
        self.max_datagram = max_datagram
        self.last_frames: list[int] = []  # frames of the datagram add() completed last

    def add(self, fn: int, ts: int, hdr: dict, data: bytes) -> bytes | None:
        """Add one fragment (``hdr`` from decode_ipv4). Returns the whole IP payload once
        complete, else None. Frames of dropped datagrams are collected for :meth:`expire`.

        O(log n) per fragment, whatever the order: ``contig`` is the end of the gap-free prefix
        and a heap holds the fragments not yet joined to it; the datagram is built once, when the
        prefix reaches the total length (before: a rebuild per fragment, quadratic for a datagram
        with a hole, the shape of CVE-2016-9372)."""
        key = (hdr["src"], hdr["dst"], hdr["proto"], hdr["id"])
        payload = data[hdr["payload_off"]:hdr["payload_end"]]
        start = hdr["frag_offset"]
        end = start + len(payload)
        if end > self.max_datagram:
            self.dropped.append((FrameList([fn]), f"IPv4 fragment ends at {end}, beyond 65535"))
            return None
        p = self.pending.get(key)
        if p is None:
            while len(self.pending) >= self.max_datagrams:  # oldest first (dicts keep order)
                self._drop(next(iter(self.pending)), "IPv4 reassembly buffer full")
            p = self.pending[key] = {"ts": ts, "frames": FrameList(), "parts": {}, "bytes": 0, "total": None,
                                     "contig": 0, "heap": []}
        p["frames"].add(fn)
        parts = p["parts"]
        if start not in parts:  # a repeated offset keeps the first copy
            parts[start] = payload
            p["bytes"] += len(payload)
            self.bytes += len(payload)
            heap = p["heap"]
            contig = p["contig"]
            if start <= contig:
                if end > contig:
                    contig = end
            else:
                heapq.heappush(heap, (start, end))
            while heap and heap[0][0] <= contig:   # each fragment joins the prefix once
                e = heapq.heappop(heap)[1]
                if e > contig:
                    contig = e
            p["contig"] = contig
        if not hdr["flags_mf"]:
            p["total"] = end
        while self.bytes > self.max_bytes and self.pending:
            self._drop(next(iter(self.pending)), "IPv4 reassembly byte budget exceeded")
        if key not in self.pending or p["total"] is None or p["contig"] < p["total"]:
            return None
        buf = bytearray()
        for s in sorted(parts):   # once per datagram: later offsets overwrite overlaps, as before
            part = parts[s]
            buf[s:s + len(part)] = part
        del self.pending[key]
        self.bytes -= p["bytes"]
        self.last_frames = p["frames"]
        return bytes(buf[:p["total"]])
