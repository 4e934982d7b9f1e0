"""PN-RT fragmentation (FrameID 0xFF80-0xFF8F, FRAG_PDU): FragDataLength, FragStatus and the
reassembly of the fragments into the frame they carry.

As tshark 4.0 (packet-pn-rt.c dissect_FRAG_PDU_heur): after the FrameID come FragDataLength
(1 byte, in units of 8 bytes) and FragStatus (MoreFollows 0x80, a reserved/error bit 0x40,
FragmentNumber 0x3F, zero based), then the fragment's bytes up to the end of the frame. A frame
whose bytes are fewer than FragDataLength x 8 is not reassembled. Fragment 0 opens a new PDU for
its FrameID's low nibble; the one without MoreFollows completes it. The reassembled bytes start
with the EtherType of the PDU they carry (0x8892: a PN-RT PDU again).
"""
from __future__ import annotations

from .common import Malformed

L = "pn_rt"
MAX_FRAGMENTS = 64       # FragmentNumber has 6 bits
MAX_BYTES = 64 * 1024    # bound of one reassembled PDU


def decode(pdu: bytes, off: int) -> dict:
    """FRAG_PDU header at pdu[off] (after the FrameID): the ``frag`` fields of the rt event."""
    if len(pdu) - off < 2:
        raise Malformed(L, f"FRAG_PDU of {len(pdu) - off} bytes has no FragDataLength/FragStatus")
    flen, st = pdu[off], pdu[off + 1]
    n = len(pdu) - off - 2
    return {"frag_data_length": flen, "frag_status": st, "more_follows": st >> 7, "error": (st >> 6) & 1,
            "fragment_number": st & 0x3F, "data_bytes": n, "fits": n >= flen * 8}


class Reassembler:
    """Fragments by FrameID low nibble, as tshark keys them; bounded (a new fragment 0 drops an
    unfinished PDU of the same key, which is reported)."""

    def __init__(self) -> None:
        self.open: dict[int, dict] = {}

    def add(self, frame_id: int, fn: int, d: dict, data: bytes) -> tuple[bytes | None, list[int], str | None]:
        """(reassembled bytes or None, frames of the PDU, problem or None) after one fragment."""
        key = frame_id & 0xF
        num = d["fragment_number"]
        problem = None
        if not d["fits"]:
            return None, [], f"FragDataLength {d['frag_data_length']} x 8 exceeds the {d['data_bytes']} bytes of the frame"
        if num == 0:
            old = self.open.pop(key, None)
            if old is not None:
                problem = f"fragments in frames {old['frames']} never completed (new fragment 0)"
            self.open[key] = {"parts": {}, "frames": [], "size": 0}
        cur = self.open.get(key)
        if cur is None:
            return None, [], f"fragment {num} without its fragment 0"
        if num in cur["parts"] or len(cur["parts"]) >= MAX_FRAGMENTS or cur["size"] + len(data) > MAX_BYTES:
            self.open.pop(key, None)
            return None, cur["frames"] + [fn], f"fragment {num} repeated or PDU too large: dropped"
        cur["parts"][num] = data
        cur["frames"].append(fn)
        cur["size"] += len(data)
        if d["more_follows"]:
            return None, cur["frames"], problem
        self.open.pop(key, None)
        if sorted(cur["parts"]) != list(range(len(cur["parts"]))):
            return None, cur["frames"], f"fragments {sorted(cur['parts'])} of the PDU are not contiguous"
        return b"".join(cur["parts"][i] for i in range(len(cur["parts"]))), cur["frames"], problem
