"""IOPS and IOCS of every submodule in a cyclic frame whose layout is known (any AR, not only
encoder telegrams: ordinary IO devices too).

tshark 4.0 (packet-pn-rtc-one.c) shows, for a cyclic frame of an AR whose Connect it saw, each
IOCS of the frame and each IODataObject (ModuleIdentNumber, SubmoduleIdentNumber, IOPS), every
IOxS with its bits DataState / Instance / Reserved / Extension (spec/wire.md §2.4). The rt event
gets them as ``iodata`` (tests/tshark_map/iodata.json); the layout comes from the AR map
(pndiss/armap.py) the session tracker built from the Connect.
"""
from __future__ import annotations

# IOxS bits (tshark pn_io.ioxs.*): DataState 0x80, Instance 0x60, reserved 0x1E, Extension 0x01
IOXS_BITS = (("datastate", 0x80, 7), ("instance", 0x60, 5), ("res14", 0x1E, 1), ("extension", 0x01, 0))
# tshark 4.0 decodes per-submodule IO data (dissect_PNIO_C_SDU_RTC1) for RT_CLASS_1 and RT_CLASS_UDP
# frame IDs only (wire.md §2.2); an RTC3 C_SDU is shown as "PROFINET IO Cyclic Service Data Unit: N byte"
RTC1_FIRST, RTC_UDP_LAST = 0x8000, 0xFBFF
IOXS_INSTANCE = {0: "Detected by subslot", 1: "Detected by slot", 2: "Detected by IO device",
                 3: "Detected by IO controller"}


def ioxs(v: int) -> dict:
    """One IOxS byte: value, bits and the words tshark prints (good/bad, who detected it)."""
    d = {"value": v}
    for name, mask, shift in IOXS_BITS:
        d[name] = (v & mask) >> shift
    d["state"] = "good" if v & 0x80 else "bad"
    d["instance_name"] = IOXS_INSTANCE[d["instance"]]
    return d


def decode(fm, csdu: bytes, ioxs_of=ioxs) -> dict | None:
    """``iodata`` of one cyclic frame: the IOCS entries and data objects of its FrameMap, each
    IOxS decoded; None when the map did not come from a Connect in this capture or the AR was
    released (tshark shows nothing then). ``ioxs_of`` decodes one IOxS byte (the JSONL column
    writer passes C_SDU offsets instead of bytes and gets its template: pndiss/jsonl_sink.py)."""
    if fm is None or fm.source != "connect" or fm.released:  # tshark forgets the AR at its Release too
        return None
    if not RTC1_FIRST <= fm.frame_id <= RTC_UDP_LAST:
        return None  # RT_CLASS_3 (IRT) frames: tshark 4.0 shows their C_SDU as one block, no IOxS
    n = len(csdu)
    # tshark walks the C_SDU from byte 0 in frame-offset order and calls everything from the first
    # byte no IOCS / data object / IOPS starts at "GAP and RTCPadding": items after a gap are not shown
    items = sorted([(e.offset, 0, e) for e in fm.iocs] + [(do.offset, 1, do) for do in fm.objects],
                   key=lambda t: (t[0], t[1]))
    iocs, objs = [], []
    pos = 0
    for off, is_obj, x in items:
        end = off + (x.length + x.iops_len if is_obj else x.length)
        # a Connect may declare an IOPS or IOCS length of 0: the IOxS byte read below must still be in the C_SDU
        if off != pos or end > n or (off + x.length >= n if is_obj else off >= n):
            break
        pos = end
        if not is_obj:
            iocs.append({"api": x.api, "slot": x.slot, "subslot": x.subslot, "iocs": ioxs_of(csdu[off])})
        else:
            objs.append({"api": x.api, "slot": x.slot, "subslot": x.subslot, "length": x.length,
                         "module_ident_number": x.module_ident, "submodule_ident_number": x.submodule_ident,
                         "iops": ioxs_of(csdu[off + x.length])})
    return {"direction": fm.direction, "iocs": iocs, "objects": objs, "gap_at": pos if pos < n else None}
