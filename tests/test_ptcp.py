"""PTCP decoder: every header kind and TLV block on synthetic frames against tshark, the delay
frames of the public captures, Malformed cases and property tests."""
import os
import struct

import pytest
from hypothesis import given, settings, strategies as st

from pndiss.proto import ptcp
from pndiss.proto.common import Malformed
from synframes import pn_rt, write_pcap
from tsharkdiff import PUBLIC, compare, load_maps, need_tshark


def tl(t: int, body: bytes) -> bytes:
    return struct.pack(">H", (t << 9) | len(body)) + body


END = tl(0, b"")
SUBDOMAIN = tl(1, bytes.fromhex("0002a2010203") + bytes(range(16)))
TIME = tl(2, struct.pack(">HII", 3, 1000, 500))
TIME_EXT = tl(3, struct.pack(">HH", 0x0001, 37) + b"\0\0")
MASTER = tl(4, struct.pack(">BBBBh", 0x8A, 0xFF, 0xFF, 0x21, -5) + b"\0\0")
RTDATA = tl(0x7F, bytes.fromhex("000ecf01") + bytes(range(16)))
OTHER_OPT = tl(0x7F, bytes.fromhex("00112205") + b"\0\0")
DELAY_PARAM = tl(6, bytes(range(1, 7)))  # next TLV follows at +8: already 4-aligned
PORT_PARAM = tl(5, b"\0\0" + struct.pack(">II", 308, 92))
PORT_TIME = tl(7, b"\0\0" + struct.pack(">I", 3337017994))

PDUS = [
    (0x0080, struct.pack(">IIIHBxI", 0, 0, 300, 77, 5, 9) + SUBDOMAIN + TIME + TIME_EXT + MASTER + RTDATA + END),
    (0x0020, struct.pack(">IIIHBxI", 0, 0, 0, 78, 0, 0) + SUBDOMAIN + END),
    (0xFF00, bytes(12) + struct.pack(">H", 8) + bytes(6) + SUBDOMAIN + MASTER + OTHER_OPT + END),
    (0xFF20, bytes(12) + struct.pack(">H", 9) + b"\0\0" + struct.pack(">i", -42) + SUBDOMAIN + END),
    (0xFF40, bytes(12) + struct.pack(">H", 10) + b"\0\0" + bytes(4) + DELAY_PARAM + END),
    (0xFF41, bytes(12) + struct.pack(">H", 10) + b"\0\0" + bytes(4) + DELAY_PARAM + PORT_PARAM + PORT_TIME + END),
    (0xFF42, bytes(12) + struct.pack(">H", 10) + b"\0\0" + struct.pack(">I", 89490) + DELAY_PARAM + END),
    (0xFF43, bytes(12) + struct.pack(">H", 11) + b"\0\0" + bytes(4) + tl(0x10, b"\1\2") + END + bytes(4)),
]


def _maps():
    return [m for m in load_maps() if m["kind"] == "ptcp"]


def test_synthetic_ptcp_matches_tshark(tmp_path):
    need_tshark()
    path = write_pcap(os.path.join(tmp_path, "ptcp.pcap"),
                      [pn_rt(fid, body, dst=bytes.fromhex("0180c200000e")) for fid, body in PDUS])
    compared, diffs = compare(path, _maps())
    assert not diffs, "\n".join(diffs[:20])
    assert compared > 100


@pytest.mark.parametrize("name", ["node-profinetdcp_dcpscan.pcap", "profinet_io_cm_mixed_1.pcap"])
def test_public_delay_frames(name):
    path = os.path.join(PUBLIC, name)
    if not os.path.exists(path):
        pytest.skip("public captures not present")
    need_tshark()
    compared, diffs = compare(path, _maps())
    assert not diffs and compared > 200


def test_fields():
    d = ptcp.decode(PDUS[0][1], 0, 0x0080)
    assert d["pdu"] == "RTSync (Clock)" and d["sequence_id"] == 77 and d["delay_ns"] == 3014
    names = [b["name"] for b in d["blocks"]]
    assert names == ["Subdomain", "Time", "TimeExtension", "Master", "Organizational Specific", "End"]
    m = d["blocks"][3]
    assert m["master_priority1_act"] == 1 and m["master_priority1_level"] == 1
    assert m["master_priority1_name"] == "Secondary sync master" and m["clockvariance"] == -5
    assert d["blocks"][4]["irdata_uuid"] == "00010203-0405-0607-0809-0a0b0c0d0e0f"
    r = ptcp.decode(PDUS[5][1], 0, 0xFF41)
    assert [b.get("t2portrxdelay") for b in r["blocks"]][1] == 308 and r["blocks"][0]["port_mac_address"] == "01:02:03:04:05:06"
    assert ptcp.decode(PDUS[3][1], 0, 0xFF20)["delay1ns_fup"] == -42
    assert ptcp.decode(bytes(30), 0, 0xFF44)["pdu"] == "Reserved FrameID 0xff44"


@pytest.mark.parametrize("fid, body, why", [
    (0xFF40, bytes(12), "PTCP header"),
    (0xFF40, bytes(12) + struct.pack(">H", 1) + bytes(6) + DELAY_PARAM, "TLV header"),
    (0x0080, bytes(20) + tl(1, bytes(22))[:10], "Subdomain"),
])
def test_malformed(fid, body, why):
    with pytest.raises(Malformed) as e:
        ptcp.decode(body, 0, fid)
    assert why in e.value.reason and e.value.layer == "ptcp"


def _check(data, fid):
    try:
        out = ptcp.decode(data, 0, fid)
    except Malformed:
        return
    assert isinstance(out, dict)


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=120), st.sampled_from([0x20, 0x80, 0xFF00, 0xFF20, 0xFF40, 0xFF43, 0xFF50]))
def test_random_bytes(data, fid):
    _check(data, fid)


@settings(max_examples=300, deadline=None)
@given(st.sampled_from(PDUS), st.integers(0, 140), st.integers(0, 140), st.integers(0, 255))
def test_truncated_and_mutated(pdu, cut, pos, val):
    fid, body = pdu
    _check(body[:cut], fid)
    if pos < len(body):
        _check(body[:pos] + bytes([val]) + body[pos + 1:], fid)
