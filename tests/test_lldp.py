"""LLDP and MRP decoders: tshark agreement on synthetic frames, station facts, Malformed cases,
and property tests (random / truncated / mutated bytes give a dict or Malformed, nothing else)."""
import os
import struct

import pytest
from hypothesis import given, settings, strategies as st

from pndiss.analyzer import Analyzer
from pndiss.proto import lldp, mrp
from pndiss.proto.common import Malformed
from synframes import (OUI_8021, OUI_8023, OUI_PN, eth, lldpdu, mgmt_ipv4, org, tlv, write_pcap)
from tsharkdiff import compare, load_maps, need_tshark

PN_TLVS = (org(OUI_PN, 1, struct.pack(">5I", 236, 308, 116, 92, 21134))
           + org(OUI_PN, 2, bytes.fromhex("0002 3004"))
           + org(OUI_PN, 3, b"port-001.encoder-1")
           + org(OUI_PN, 4, bytes(range(16)) + b"\x00\x02")
           + org(OUI_PN, 5, bytes.fromhex("0002a2112233"))
           + org(OUI_PN, 6, bytes.fromhex("0002a2445566") + bytes(range(16)) + bytes(range(16, 32))
                 + struct.pack(">4I", 0x80000000 | 1_000_000, 4096, 0x80000000 | 512, 0x7FFFFFFF))
           + org(OUI_PN, 7, b"\x00\x10")
           + org(OUI_PN, 9, bytes(range(16)))
           + org(OUI_PN, 10, bytes.fromhex("05 01 c0a80001"))
           + org(OUI_PN, 11, bytes(range(1, 17))) + org(OUI_PN, 12, bytes(range(2, 18)))
           + org(OUI_PN, 13, bytes.fromhex("0020") + bytes(range(16)) + bytes(range(8))))
IEEE_TLVS = (org(OUI_8023, 1, bytes.fromhex("03 6c01 0010"))
             + org(OUI_8023, 2, bytes.fromhex("0f 01 02"))
             + org(OUI_8023, 2, bytes.fromhex("07 01 03 51 0010 0020"))
             + org(OUI_8023, 3, bytes.fromhex("03 00000007"))
             + org(OUI_8023, 4, bytes.fromhex("05ee"))
             + org(OUI_8023, 5, struct.pack(">5H", 1, 2, 3, 4, 5))
             + org(OUI_8021, 1, bytes.fromhex("0001"))
             + org(OUI_8021, 2, bytes.fromhex("06 0005"))
             + org(OUI_8021, 3, bytes.fromhex("0007 04") + b"vlan")
             + org(OUI_8021, 4, bytes.fromhex("02 8892"))
             + org(OUI_8021, 7, bytes.fromhex("07 00000009")))
BASIC_TLVS = (tlv(4, b"Port 1") + tlv(5, b"ENC-1") + tlv(6, b"Absolute encoder PROFINET")
              + tlv(7, bytes.fromhex("0080 0080")) + mgmt_ipv4(bytes([192, 168, 0, 51]))
              + tlv(8, bytes([17, 2]) + bytes(range(16)) + b"\x02" + struct.pack(">I", 2) + b"\x00")
              + tlv(8, bytes([7, 6]) + bytes(range(6)) + b"\x01" + struct.pack(">I", 0) + b"\x00"))

FRAMES = [
    lldpdu(extra=BASIC_TLVS + PN_TLVS + IEEE_TLVS),
    lldpdu(name=bytes.fromhex("0002a2000001"), chassis_subtype=4, extra=PN_TLVS[:36]),
    tlv(1, b"\x05\x01\x0a\x00\x00\x01") + tlv(2, b"\x04\x01\x0a\x00\x00\x02") + tlv(3, b"\x00\x78")
    + tlv(2 + 18, b"xyz") + org(bytes.fromhex("001122"), 5, b"abc") + tlv(0, b""),
    tlv(1, b"\x01chassis") + tlv(2, b"\x03" + bytes.fromhex("0002a2000009")) + tlv(3, b"\x00\x14") + tlv(0, b""),
    lldpdu(name=b"plain-host", extra=tlv(5, b"host")),
]


def _my_maps(*kinds):
    return [m for m in load_maps() if m["kind"] in kinds]


def test_synthetic_lldp_matches_tshark(tmp_path):
    need_tshark()
    path = write_pcap(os.path.join(tmp_path, "lldp.pcap"), [eth(0x88CC, f) for f in FRAMES])
    compared, diffs = compare(path, _my_maps("lldp"))
    assert not diffs, "\n".join(diffs[:20])
    assert compared > 300  # every frame was really compared, field by field


def test_profinet_tlvs_decoded():
    ev = lldp.decode(FRAMES[0], 0)
    pn = {d["subtype"]: d for d in ev["profinet"]}
    assert pn[1]["cable_delay_local"] == 21134 and pn[1]["port_rx_delay_remote"] == 308
    assert pn[2]["rtc2_port_status_name"] == "RTCLASS2_UP"
    assert pn[2]["rtc3_port_status_name"] == "RTCLASS3_RUN" and pn[2]["rtc3_port_status_preambleLength"] == 1
    assert pn[3]["alias"] == "port-001.encoder-1"
    assert pn[4]["mrrt_port_status_name"] == "MRRT_UP"
    assert pn[4]["mrp_domain_uuid"] == "00010203-0405-0607-0809-0a0b0c0d0e0f"
    assert pn[6]["length_of_period_valid"] == 1 and pn[6]["length_of_period_length"] == 1_000_000
    assert pn[6]["green_period_begin_valid"] == 0 and pn[6]["green_period_begin_offset"] == 0x7FFFFFFF
    assert pn[13]["time_domain_name"] == "Working Clock"
    mp = ev["ieee_802_3"][0]
    assert mp["pmd_mau_type_name"] == "100BaseTXFD" and mp["pmd_auto_neg_advertised_caps"]["100base_txfd"] == 1
    assert ev["mgmt"][0]["obj_id"] == "1.3.6.1.4.1.24686"


def test_station_facts_profinet_name():
    st_ = lldp.decode(FRAMES[0], 0)["station_info"]
    assert st_["name"] == "encoder-1" and st_["port_id"] == "port-001"
    assert st_["mgmt_ip"] == "192.168.0.51" and st_["chassis_mac"] == "00:02:a2:11:22:33"
    assert st_["system_name"] == "ENC-1"
    # no PNO TLV: a locally assigned chassis ID is not taken as a NameOfStation
    assert "name" not in lldp.decode(FRAMES[4], 0)["station_info"]
    # MAC chassis ID: no name either, but the chassis ID is kept
    st2 = lldp.decode(FRAMES[1], 0)["station_info"]
    assert "name" not in st2 and st2["chassis_id"] == "00:02:a2:00:00:01"


def test_station_name_from_older_port_id_style():
    # older netX style: descriptive chassis text, "port-xxx.<NameOfStation>" as port ID
    raw = lldpdu(name=b"netX controller", port=b"port-002.controller-nick", extra=org(OUI_PN, 5, bytes(6)))
    assert lldp.decode(raw, 0)["station_info"]["name"] == "controller-nick"


def test_analyzer_station_table():
    a = Analyzer()
    a.feed(1, 0, 1, eth(0x88CC, FRAMES[0]))
    assert a.counts["decoded"] == 1
    row = a.stations.by_mac["00:02:a2:00:00:01"]
    assert row["name"] == "encoder-1" and row["mgmt_ip"] == "192.168.0.51"


@pytest.mark.parametrize("raw, why", [
    (tlv(1, b"\x07abc")[:-1], "runs past"),
    (tlv(1, b"\x07abc") + tlv(3, b"\x00\x14") + tlv(0, b""), "mandatory"),
    (tlv(1, b"\x07") + tlv(2, b"\x07p") + tlv(3, b"\x00\x14") + tlv(0, b""), "Chassis ID"),
    (lldpdu(extra=tlv(127, b"\x00\x0e")), "organisation"),
    (lldpdu(extra=org(OUI_PN, 1, bytes(8))), "too short"),
    (lldpdu(extra=tlv(8, bytes([5, 2, 1, 2, 3, 4, 2, 0, 0, 0, 1, 0]))), "family"),
    (tlv(1, b"\x07abc") + tlv(2, b"\x07p") + tlv(3, b"\x00\x14"), "TLV header"),
])
def test_malformed(raw, why):
    with pytest.raises(Malformed) as e:
        lldp.decode(raw, 0)
    assert why in e.value.reason and e.value.layer == "lldp"


def _check(fn, data):
    try:
        out = fn(data)
    except Malformed:
        return
    assert isinstance(out, dict)


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=200))
def test_lldp_random_bytes(data):
    _check(lambda d: lldp.decode(d, 0), data)


@settings(max_examples=300, deadline=None)
@given(st.sampled_from(FRAMES), st.integers(0, 600), st.integers(0, 600), st.integers(0, 255))
def test_lldp_truncated_and_mutated(frame, cut, pos, val):
    _check(lambda d: lldp.decode(d, 0), frame[:cut])
    if pos < len(frame):
        _check(lambda d: lldp.decode(d, 0), frame[:pos] + bytes([val]) + frame[pos + 1:])


# -- MRP --------------------------------------------------------------------------------------------
MRP_COMMON = bytes([1, 18]) + struct.pack(">H", 7) + bytes(range(16)) + b"\x00\x00"
MRP_FRAMES = [
    struct.pack(">H", 1) + bytes([2, 18]) + struct.pack(">H", 0x8000) + bytes.fromhex("001122334455")
    + struct.pack(">HHHI", 0, 1, 3, 0x1234) + bytes([1, 18]) + struct.pack(">H", 5) + bytes(range(16))
    + b"\x00\x00",
    struct.pack(">H", 1) + bytes([3, 10]) + struct.pack(">H", 0xA000) + bytes.fromhex("001122334455")
    + struct.pack(">H", 20) + bytes([1, 18]) + struct.pack(">H", 6) + bytes(range(16)) + b"\x00\x00",
    struct.pack(">H", 1) + bytes([5, 12]) + bytes.fromhex("001122334455") + struct.pack(">HHH", 1, 20, 1)
    + b"\x00\x00" + bytes([1, 18]) + struct.pack(">H", 7) + bytes(range(16)) + b"\x00\x00",
    # Option TLVs: Siemens with Ed1 data + vendor SubOption2, Siemens AutoMgr SubOption2, PROFINET OUI
    struct.pack(">H", 1) + bytes([0x7F, 8]) + bytes.fromhex("080006 04 0055 f502") + b"ab" + MRP_COMMON,
    struct.pack(">H", 1) + bytes([0x7F, 22]) + bytes.fromhex("080006 01 0210 9000") + bytes(range(6))
    + bytes.fromhex("a000") + bytes(range(6, 12)) + bytes(2) + MRP_COMMON,
    struct.pack(">H", 1) + bytes([0x7F, 4]) + bytes.fromhex("000ecf 01") + MRP_COMMON,
    struct.pack(">H", 1) + bytes([0x06, 4]) + bytes.fromhex("01020304") + MRP_COMMON,
]


def test_mrp_matches_tshark(tmp_path):
    need_tshark()
    frames = [eth(0x88E3, f, dst=bytes.fromhex("011e94000001")) for f in MRP_FRAMES]
    compared, diffs = compare(write_pcap(os.path.join(tmp_path, "mrp.pcap"), frames), _my_maps("mrp"))
    assert not diffs, "\n".join(diffs)
    assert compared >= 60


def test_mrp_fields():
    d = lldp.decode_mrp(MRP_FRAMES[0], 0)  # the re-export in lldp keeps the analyzer's entry point
    assert d["version"] == 1 and [t["name"] for t in d["tlvs"]] == ["Test", "Common", "End"]
    assert d["tlvs"][0]["ring_state_name"] == "Ring closed" and d["tlvs"][0]["time_stamp"] == 0x1234
    assert d["tlvs"][1]["domain_uuid"] == "00010203-0405-0607-0809-0a0b0c0d0e0f"
    assert mrp.decode(MRP_FRAMES[2], 0)["tlvs"][0]["name"] == "LinkUp"
    sie = mrp.decode(MRP_FRAMES[4], 0)["tlvs"][0]
    assert sie["sub_option2"]["other_mrm_prio"] == 0xA000 and sie["sub_option2"]["sa"] == "00:01:02:03:04:05"
    # tshark 4.0 leaves a PROFINET-OUI option undecoded and re-aligns: the next TLV read is End
    assert [t["name"] for t in mrp.decode(MRP_FRAMES[5], 0)["tlvs"]] == ["Option", "End"]
    with pytest.raises(Malformed):
        mrp.decode(MRP_FRAMES[0][:12], 0)


@settings(max_examples=300, deadline=None)
@given(st.sampled_from(MRP_FRAMES), st.integers(0, 80), st.integers(0, 80), st.integers(0, 255),
       st.binary(max_size=80))
def test_mrp_property(frame, cut, pos, val, rnd):
    _check(lambda d: mrp.decode(d, 0), rnd)
    _check(lambda d: mrp.decode(d, 0), frame[:cut])
    if pos < len(frame):
        _check(lambda d: mrp.decode(d, 0), frame[:pos] + bytes([val]) + frame[pos + 1:])
