"""Record and Connect block families (pndiss/proto/pdrecords.py, cmblocks.py) and the IOxS of
cyclic frames (pndiss/iodata.py): known values from hand-built blocks, and property tests (random,
truncated and mutated bodies give a block dict or Malformed, never another exception). The values
tshark shows for the same blocks in real captures are compared by tests/test_tshark_diff.py."""
from __future__ import annotations

import struct

from hypothesis import HealthCheck, given, settings, strategies as st

import rpc_frames as rf
from pndiss import armap, iodata
from pndiss.proto import cmblocks, pdrecords, pnio_cm
from pndiss.proto.common import Malformed

FAST = settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])


def _decode(blocks: bytes) -> list[dict]:
    out: list[dict] = []
    pnio_cm.decode_blocks(blocks, 0, len(blocks), out)
    return out


def _pad4(b: bytes, start: int) -> bytes:
    return b + bytes((-(start + len(b))) % 4)


def port_data_real(peer: bool = True) -> bytes:
    body = b"\0\0" + struct.pack(">HH", 0, 0x8001) + bytes([8]) + b"port-001" + bytes([1 if peer else 0])
    body = _pad4(body, 6)
    if peer:
        p = bytes([8]) + b"port-004" + bytes([6]) + b"switch"
        body += p
        body = _pad4(body, 6)
        body += struct.pack(">I", 0x80000010) + bytes.fromhex("000e8cef75c5")
        body = _pad4(body, 6)
    body += struct.pack(">H", 0x10)
    body = _pad4(body, 6)
    body += struct.pack(">IIBB", 0, 1, 0, 1)
    body = _pad4(body, 6)
    body += struct.pack(">I", 1)
    return rf.block(0x020F, body)


def diagnosis(usi: int = 0x8002) -> bytes:
    body = struct.pack(">IHHHHH", 0, 0, 0x8001, 0x8000, 0x0800, usi)
    body += struct.pack(">HHHHI", 0x8000, 0x0800, 0x8001, 0x8005, 0)
    body += struct.pack(">HHHHI", 0x8000, 0x0800, 0x8000, 0x8000, 7)
    return rf.block(0x0010, body, vlow=1)


def sync_data() -> bytes:
    body = b"\0\0" + bytes(range(16)) + struct.pack(">IIII", 0, 0, 1000, 960) + struct.pack(">HHHHH", 1, 6, 2, 0, 1)
    body += bytes([0, 255, 4]) + b"sync"
    return rf.block(0x0203, _pad4(body, 6), vlow=2)


def test_port_data_real_values():
    b = _decode(port_data_real())[0]
    assert (b["own_port_id"], b["number_of_peers"], b["mau_type_name"], b["link_state_link_name"],
            b["media_type_name"]) == ("port-001", 1, "100BASETXFD", "up", "Copper cable")
    p = b["peers"][0]
    assert (p["peer_port_id"], p["peer_chassis_id"], p["peer_macadd"]) == ("port-004", "switch", "00:0e:8c:ef:75:c5")
    assert (p["line_delay_format_indicator"], p["line_delay_value"]) == (1, 0x10)


def test_diagnosis_entries_in_words():
    b = _decode(diagnosis())[0]
    assert (b["slot_nr"], b["subslot_nr"], b["usi_name"]) == (0, 0x8001, "ExtChannelDiagnosis")
    assert [i["channel_error_type_name"] for i in b["items"]] == ["Remote mismatch", "Data transmission impossible"]
    assert [i["ext_channel_error_type_name"] for i in b["items"]] == ["No peer detected", "Link State mismatch - Link down"]
    assert b["items"][0]["ext_channel_error_type8001"] == 0x8005 and b["items"][1]["ext_channel_add_value"] == 7


def test_sync_and_mrp_and_fs_blocks():
    b = _decode(sync_data())[0]
    assert (b["pllwindow"], b["sync_send_factor"], b["ptcp_master_priority_2"], b["ptcp_subdomain_name"]) == \
        (1000, 960, 255, "sync")
    mrp = rf.block(0x0213, bytes([0, 1]) + rf.block(0x0233, bytes([0, 0]) + bytes(16) + struct.pack(">I", 3)), vlow=1)
    blocks = _decode(mrp)
    assert [x["block_type"] for x in blocks] == [0x0213, 0x0233]
    assert (blocks[1]["mrp_check_mrm"], blocks[1]["mrp_check_domainUUID"]) == (1, 1)
    fs = _decode(rf.block(0x010B, b"\0\0" + rf.block(0x0601, b"\0\0" + struct.pack(">I", 1) + bytes(16))))
    assert fs[1]["fs_parameter_mode_name"] == "ON"
    sr = _decode(rf.block(0x010A, struct.pack(">HI", 3, 0x5)))[0]
    assert (sr["RedundancyDataHoldFactor"], sr["sr_properties_InputValidOnBackupAR"], sr["sr_properties_Mode"]) == (3, 1, 1)


def test_identification_data():
    body = struct.pack(">HIH", 1, 0, 1) + struct.pack(">HIH", 1, 0x4D49, 1) + struct.pack(">HI", 1, 8)
    b = _decode(rf.block(0x0013, body, vlow=1))[0]
    assert b["apis"][0]["slots"][0]["module_ident_number"] == 0x4D49
    assert b["apis"][0]["slots"][0]["subslots"][0]["submodule_ident_number"] == 8


BLOCK_TYPES = sorted(set(pdrecords.BODIES) | set(cmblocks.BODIES) | {t for t, _ in pdrecords.PREFIX_BODIES})
SEEDS = [port_data_real(), port_data_real(False), diagnosis(), diagnosis(0x8003), sync_data()]


def _check(blocks: bytes) -> None:
    try:
        out = _decode(blocks)
    except Malformed as e:
        assert e.layer and e.reason
        return
    assert all(isinstance(b, dict) and "block_type" in b for b in out)


@FAST
@given(st.sampled_from(BLOCK_TYPES), st.integers(0, 2), st.binary(max_size=120))
def test_random_bodies(bt, vlow, body):
    _check(rf.block(bt, body, vlow=vlow))


@FAST
@given(st.sampled_from(SEEDS), st.data())
def test_truncated_and_mutated(seed, data):
    b = bytearray(seed)
    for _ in range(data.draw(st.integers(0, 6))):
        b[data.draw(st.integers(4, len(b) - 1))] = data.draw(st.integers(0, 255))
    cut = data.draw(st.integers(6, len(b)))
    b[2:4] = struct.pack(">H", max(2, cut - 4))  # the header follows the cut, so the body is what is short
    _check(bytes(b[:cut]))


# --- IOxS ------------------------------------------------------------------------------------------
def _fm(objs, iocs, source="connect"):
    fm = armap.FrameMap(frame_id=0x8000, direction="input", source=source)
    fm.objects = [armap.DataObject(api=0, slot=s, subslot=ss, offset=o, length=n, module_ident=1, submodule_ident=2)
                  for s, ss, o, n in objs]
    fm.iocs = [armap.IocsEntry(api=0, slot=s, subslot=ss, offset=o) for s, ss, o in iocs]
    return fm


def test_ioxs_of_every_submodule_until_the_first_gap():
    fm = _fm([(0, 1, 0, 0), (1, 1, 1, 2), (3, 1, 9, 1)], [(2, 1, 4)])
    d = iodata.decode(fm, bytes([0x80, 1, 2, 0x80, 0x60, 0, 0, 0, 0, 0, 0, 0]))
    assert [o["slot"] for o in d["objects"]] == [0, 1] and [i["slot"] for i in d["iocs"]] == [2]
    assert d["objects"][0]["iops"]["state"] == "good" and d["iocs"][0]["iocs"]["instance"] == 3
    assert d["gap_at"] == 5
    assert iodata.decode(_fm([(0, 1, 0, 0)], [], source="length"), b"\x80") is None


@FAST
@given(st.lists(st.tuples(st.integers(0, 3), st.integers(0, 40), st.integers(0, 4)), max_size=8),
       st.lists(st.integers(0, 40), max_size=4), st.binary(max_size=48))
def test_ioxs_random_layouts(objs, iocs, csdu):
    fm = _fm([(i, 1, o, n) for i, (_, o, n) in enumerate(objs)], [(9, 1, o) for o in iocs])
    d = iodata.decode(fm, csdu)
    for o in d["objects"]:
        assert o["iops"]["value"] == csdu[fm.objects[[x.slot for x in fm.objects].index(o["slot"])].offset + o["length"]]
    assert all(0 <= i["iocs"]["value"] <= 255 for i in d["iocs"])


# --- RT fragmentation (FrameID 0xFF80-0xFF8F) -------------------------------------------------------
def _frag_frames(name: bytes = b"encoder-with-a-rather-long-name-for-two-fragments-x1"):
    import synframes as sf
    blk = struct.pack(">BBHH", 2, 2, len(name) + 2, 1) + name
    blk += bytes(len(blk) % 2)
    dcp = struct.pack(">BBIHH", 4, 0, 0x1234, 0, len(blk)) + blk
    inner = struct.pack(">HH", 0x8892, 0xFEFD) + dcp
    first, rest = inner[:48], inner[48:]
    f0 = sf.pn_rt(0xFF80, bytes([6, 0x80]) + first)
    f1 = sf.pn_rt(0xFF80, bytes([(len(rest) + 7) // 8, 0x01]) + rest)
    return [f0, f1]


def test_rt_fragments_reassembled_and_equal_tshark(tmp_path):
    import synframes as sf
    from tsharkdiff import need_tshark

    from pndiss.analyzer import analyze_file

    frames = _frag_frames()
    need_tshark()
    compared, diffs = sf.diff(tmp_path, frames, "frag.pcap")
    assert compared > 0 and not diffs, diffs[:10]
    evs = []
    analyze_file(sf.write_pcap(str(tmp_path / "frag2.pcap"), frames), sink=evs.append)
    frag = [e["frag"] for e in evs if e["kind"] == "rt" and "frag" in e]
    assert [(f["fragment_number"], f["more_follows"]) for f in frag] == [(0, 1), (1, 0)]
    assert frag[1]["reassembled_frames"] == [1, 2]
    dcp = [e for e in evs if e["kind"] == "dcp"]
    assert len(dcp) == 1 and dcp[0]["frame"] == 2


@FAST
@given(st.lists(st.tuples(st.integers(0, 255), st.integers(0, 255), st.binary(max_size=64)), max_size=6))
def test_rt_fragment_random(parts):
    from pndiss.proto import rtfrag

    r = rtfrag.Reassembler()
    for i, (flen, status, data) in enumerate(parts):
        pdu = struct.pack(">H", 0xFF81) + bytes([flen, status]) + data
        d = rtfrag.decode(pdu, 2)
        whole, frames, problem = r.add(0xFF81, i + 1, d, pdu[4:])
        assert whole is None or isinstance(whole, bytes)
        assert problem is None or isinstance(problem, str)


@FAST
@given(st.lists(st.tuples(st.integers(0xFF80, 0xFF8F), st.binary(max_size=80)), min_size=1, max_size=8))
def test_rt_fragment_frames_through_the_pipeline(frames):
    """Random FRAG_PDUs (and whatever their reassembly carries) are decoded or malformed, counted once."""
    import synframes as sf

    from pndiss.analyzer import Analyzer

    a = Analyzer(sink=lambda ev: None)
    for i, (fid, body) in enumerate(frames):
        a.feed(i + 1, i, 1, sf.pn_rt(fid, body))
    a.finish()
    assert sum(a.counts.values()) == len(frames)
