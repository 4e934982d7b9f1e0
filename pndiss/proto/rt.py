"""PROFINET RT (EtherType 0x8892 and UDP port 34962): FrameID classes and the APDU status.

FrameID ranges as tshark 4.0.17 classifies them (spec/wire.md §2.2, from packet-pn-rt.c).
The APDU status of cyclic frames is the last 4 bytes of the PDU (wire.md §2.3): tshark hands
pn_rt the Ethernet payload including pad and assumes no FCS.
"""
from __future__ import annotations

from bisect import bisect_right

from .common import Malformed

# (first FrameID, class name, cyclic). Each row holds up to the next row's first ID.
# wire.md §2.2: 0x1000-0x7FFF are reserved unless the AR is time-aware (RT_CLASS_STREAM).
_RANGES = [
    (0x0000, "PTCP reserved", False),
    (0x0020, "PTCP RTSync with follow-up", False),
    (0x0022, "PTCP reserved", False),
    (0x0080, "PTCP RTSync", False),
    (0x0082, "PTCP reserved", False),
    (0x0100, "RTC3", True),
    (0x0700, "RTC3 redundant", True),
    (0x1000, "Reserved", False),
    (0x8000, "RTC1", True),
    (0xBC00, "RTC1 multicast", True),
    (0xC000, "RTC1 legacy", True),
    (0xF800, "RTC1 legacy multicast", True),
    (0xFC00, "Reserved", False),
    (0xFC01, "Alarm high", False),
    (0xFC02, "Reserved", False),
    (0xFE01, "Alarm low", False),
    (0xFE02, "RSI", False),
    (0xFE03, "Reserved", False),
    (0xFEFC, "DCP Hello", False),
    (0xFEFD, "DCP Get/Set", False),
    (0xFEFE, "DCP Identify request", False),
    (0xFEFF, "DCP Identify response", False),
    (0xFF00, "PTCP Announce", False),
    (0xFF02, "PTCP reserved", False),
    (0xFF20, "PTCP FollowUp", False),
    (0xFF22, "PTCP reserved", False),
    (0xFF40, "PTCP Delay", False),
    (0xFF44, "PTCP reserved", False),
    (0xFF60, "Reserved", False),
    (0xFF80, "FRAG", False),
    (0xFF90, "Reserved", False),
]
_STARTS = [r[0] for r in _RANGES]
# FrameIDs 0xFE00 and 0xFE03-0xFEFB are reserved RTA IDs (the row for 0xFC02 covers 0xFC02-0xFE00).

# Over UDP (RT_CLASS_UDP) the 0xC000-0xFBFF ranges are named differently (wire.md §2.2).
_UDP_NAMES = {"RTC1 legacy": "RT_CLASS_UDP", "RTC1 legacy multicast": "RT_CLASS_UDP multicast"}

# Family of the payload, for dispatch (what the analyzer does next).
PTCP_CLASSES = {n for _, n, _ in _RANGES if n.startswith("PTCP")}

DS_BITS = (  # DataStatus bit -> (event field == tshark pn_rt.<field>)
    (0x01, "ds_primary"),
    (0x02, "ds_redundancy"),
    (0x04, "ds_valid"),
    (0x08, "ds_res3"),
    (0x10, "ds_operate"),
    (0x20, "ds_ok"),
    (0x40, "ds_Reserved_2"),
    (0x80, "ds_ignore"),
)


def classify(frame_id: int, udp: bool = False) -> tuple[str, bool]:
    """(class name, cyclic) for a FrameID."""
    _, name, cyclic = _RANGES[bisect_right(_STARTS, frame_id) - 1]
    if udp:
        name = _UDP_NAMES.get(name, name)
    return name, cyclic


def data_status_words(ds: int) -> str:
    """Info-column words for DataStatus, as tshark prints them (wire.md §2.1)."""
    return ",".join((
        "Valid" if ds & 0x04 else "Invalid",
        "Primary" if ds & 0x01 else "Backup",
        "Ok" if ds & 0x20 else "Problem",
        "Run" if ds & 0x10 else "Stop",
    ))


DS_JUDGED = 0x14   # DataValid + ProviderState RUN (wire.md §2.3)


def judgeable(ds: int, transfer_status: int) -> bool:
    """A cyclic frame whose data a consumer takes: DataValid, provider in RUN and TransferStatus 0 (any other
    value marks a frame the network damaged; tshark: "ignore this frame", wire.md §2.3)."""
    return ds & DS_JUDGED == DS_JUDGED and transfer_status == 0


def decode_apdu_status(pdu: bytes, off: int) -> dict:
    """APDU status of a cyclic PDU that starts at ``off`` (the FrameID) and runs to the end."""
    n = len(pdu) - off
    if n < 6:
        raise Malformed("pn_rt", f"cyclic PDU of {n} bytes has no room for FrameID and APDU status")
    e = len(pdu)
    ds = pdu[e - 2]
    ev = {
        "cycle_counter": (pdu[e - 4] << 8) | pdu[e - 3],
        "ds": ds,
        "transfer_status": pdu[e - 1],
        "c_sdu_len": n - 6,
    }
    for mask, name in DS_BITS:
        ev[name] = 1 if ds & mask else 0
    return ev
