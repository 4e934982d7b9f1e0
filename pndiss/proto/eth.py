"""Link layer: Ethernet II, Linux cooked (SLL, SLL2), 802.1Q / 802.1ad / 0x9100 VLAN tags.

``decode_link`` returns (dst, src, ethertype, payload offset, vlan tags) without copying the
frame; tags are (TPID, PCP, DEI, VID) tuples, outermost first.
"""
from __future__ import annotations

from .common import Malformed

NO_DST = "00:00:00:00:00:00"   # the destination of a Linux cooked frame: its header carries none
VLAN_TPIDS = (0x8100, 0x88A8, 0x9100)  # tshark: 0x8100/0x9100 -> vlan, 0x88A8 -> ieee8021ad
MAX_TAGS = 16


def decode_link(linktype: int, data: bytes):
    """(dst_mac_bytes, src_mac_bytes, ethertype, payload_offset, tags) or raise Malformed."""
    if linktype == -1:  # capture.LINKTYPE_NONE: a pcapng custom/journal block tshark numbers as a frame
        return b"", b"", -1, 0, None
    if linktype == 1:
        if len(data) < 14:
            raise Malformed("eth", f"frame of {len(data)} bytes is shorter than an Ethernet header")
        dst, src = data[0:6], data[6:12]
        et = (data[12] << 8) | data[13]
        off = 14
    elif linktype == 113:  # Linux SLL: 16-byte header, protocol at 14
        if len(data) < 16:
            raise Malformed("sll", "Linux cooked header truncated")
        dst, src = b"\x00" * 6, data[6:12]
        et = (data[14] << 8) | data[15]
        off = 16
    elif linktype == 276:  # Linux SLL2: 20-byte header, protocol at 0
        if len(data) < 20:
            raise Malformed("sll2", "Linux cooked v2 header truncated")
        dst, src = b"\x00" * 6, data[12:18]
        et = (data[0] << 8) | data[1]
        off = 20
    else:
        raise Malformed("link", f"unsupported link type {linktype}")
    tags = None
    while et in VLAN_TPIDS:
        if len(data) < off + 4:
            raise Malformed("vlan", "802.1Q tag truncated")
        tci = (data[off] << 8) | data[off + 1]
        if tags is None:
            tags = []
        tags.append((et, tci >> 13, (tci >> 12) & 1, tci & 0xFFF))
        if len(tags) > MAX_TAGS:
            raise Malformed("vlan", "more than 16 stacked VLAN tags")
        et = (data[off + 2] << 8) | data[off + 3]
        off += 4
    return dst, src, et, off, tags
