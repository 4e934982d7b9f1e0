"""PN-DCP decoder (pndiss.proto.dcp, dcp_blocks, dcp_rules): synthetic frames checked against
tshark 4.0, field round-trips, NameOfStation rules, DcpTracker, and property tests (dict or
Malformed, nothing else)."""
from __future__ import annotations

import os
import struct

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as hs

from pndiss.analyzer import Analyzer
from pndiss.proto import dcp, dcp_rules, dcp_tables
from pndiss.proto.common import Malformed
from tsharkdiff import PUBLIC, compare, load_maps, need_tshark

CTRL = bytes.fromhex("00000c07ac01")   # controller / tool MAC
DEV = bytes.fromhex("0080f4000001")    # device MAC
DEV2 = bytes.fromhex("0080f4000002")
MCAST = bytes.fromhex("010ecf000000")
HELLO_MC = bytes.fromhex("010ecf000001")
BI = b"\0\0"          # BlockInfo "reserved"
PERM = b"\0\1"        # BlockQualifier "save permanent"


# -- frame builders (own bytes, layouts from spec/wire.md §3) ---------------------------------
def blk(opt: int, sub: int, val: bytes) -> bytes:
    b = bytes([opt, sub]) + struct.pack(">H", len(val)) + val
    return b + (b"\0" if len(val) & 1 else b"")


def pdu(sid: int, stype: int, xid: int, blocks, delay: int = 0) -> bytes:
    body = b"".join(blocks)
    return struct.pack(">BBIHH", sid, stype, xid, delay, len(body)) + body


def frame(fid: int, body: bytes, dst=MCAST, src=CTRL) -> bytes:
    f = dst + src + b"\x88\x92" + struct.pack(">H", fid) + body
    return f + bytes(max(0, 60 - len(f)))


def ip4(s: str) -> bytes:
    return bytes(int(x) for x in s.split("."))


def write_pcap(path, frames) -> None:
    with open(path, "wb") as f:
        f.write(struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, 1))
        for i, fr in enumerate(frames):
            f.write(struct.pack("<IIII", 1_700_000_000 + i, 0, len(fr), len(fr)) + fr)


def dec(fr: bytes) -> dict:
    return dcp.decode(fr, 16, (fr[14] << 8) | fr[15])


# A set of frames covering every service and every option/suboption tshark 4.0 decodes
# (only well-formed ones: tshark misreads reserved options and over-long fixed values).
SUITE = ["1.2.3.4", "255.255.0.0", "1.2.0.1", "8.8.8.8", "8.8.4.4", "9.9.9.9", "1.1.1.1"]
SYNTH = {
    "hello": frame(0xFEFC, pdu(6, 0, 0x11, [
        blk(2, 2, BI + b"enc-1"), blk(2, 3, BI + b"\x01\x2a\x00\x11"), blk(2, 4, BI + b"\x09\x00"),
        blk(1, 2, b"\x00\x81" + ip4("192.168.0.5") + ip4("255.255.255.0") + ip4("192.168.0.1")),
        blk(2, 7, BI + b"\x00\x01"), blk(2, 8, BI + b"\x00\x2a\x03\x13"),
        blk(2, 6, BI + b"port-001.enc-1"), blk(2, 10, BI + b"\x00\x2b"), blk(6, 1, BI + b"\x00\x01"),
        blk(2, 1, BI + b"LIKA HS58")]), dst=HELLO_MC, src=DEV),
    "get_req": frame(0xFEFD, pdu(3, 0, 0x22, [b"\x01\x02", b"\x02\x02", b"\x05\x04", b"\xff\xff",
                                           b"\x80\x01", b"\x04\x00", b"\x07\x01", b"\x03\x3d"]), dst=DEV),
    "get_rsp": frame(0xFEFD, pdu(3, 1, 0x22, [
        blk(1, 3, BI + b"".join(ip4(a) for a in SUITE)), blk(1, 1, BI + DEV),
        blk(5, 4, b"\x02\x02\x03"), blk(3, 61, BI + b"\x3d\x01\x01"), blk(3, 255, BI + b"\xff\x01\x02"),
        blk(3, 61, BI + b"\x3d\x05\x00abcd"), blk(3, 12, BI + b"xy"), blk(2, 10, BI + b"\xff\xff")]), dst=CTRL, src=DEV),
    "set_req": frame(0xFEFD, pdu(4, 0, 0x33, [
        blk(5, 1, b"\0\0"), blk(2, 2, PERM + b"encoder-7"),
        blk(1, 2, PERM + ip4("10.0.0.2") + ip4("255.0.0.0") + ip4("0.0.0.0")),
        blk(5, 3, b"\0\0\x01\x00"), blk(5, 5, b"\0\0"), blk(5, 6, b"\0\x08"), blk(5, 2, b"\0\0")]), dst=DEV),
    "set_rsp": frame(0xFEFD, pdu(4, 1, 0x33, [blk(5, 4, b"\x02\x02\x00"), blk(5, 4, b"\x01\x02\x06"),
                                           blk(5, 4, b"\x05\x03\x00")]), dst=CTRL, src=DEV),
    "set_misc": frame(0xFEFD, pdu(4, 0, 0x34, [
        blk(3, 61, PERM + b"\x3d\x00"), blk(3, 255, PERM + b"\xff\x01\x01"), blk(6, 1, PERM + b"\0\0"),
        blk(1, 1, PERM + DEV), blk(5, 1, b""), blk(5, 6, b"\0\x13"),
        blk(1, 3, PERM + b"".join(ip4(a) for a in SUITE))]), dst=DEV),
    "ident_req": frame(0xFEFE, pdu(5, 0, 0x44, [blk(2, 2, b"enc-1"), blk(0xFF, 0xFF, b""),
                                             blk(2, 3, b"\x01\x2a\x00\x11"), blk(2, 6, b"port-001.x"),
                                             blk(1, 2, bytes(12))], delay=1)),
    "ident_rsp": frame(0xFEFF, pdu(5, 1, 0x44, [
        blk(2, 5, BI + b"\x02\x02\x02\x07\x01\x02"), blk(2, 1, BI + b"ET200SP"), blk(2, 2, BI + b"enc-1"),
        blk(2, 3, BI + b"\x00\x2a\x03\x13"), blk(2, 4, BI + b"\x01\x00"),
        blk(1, 2, b"\x00\x01" + ip4("192.168.0.10") + ip4("255.255.255.0") + ip4("192.168.0.1")),
        blk(0x80, 3, b"\1\2\3"), blk(0xFF, 1, b"ab")]), dst=CTRL, src=DEV),
    "tsn": frame(0xFEFD, pdu(3, 1, 0x55, [
        blk(7, 1, BI + bytes(range(16)) + b"tsndom"), blk(7, 2, BI + b"\0\5"), blk(7, 3, BI + bytes(range(16, 32))),
        blk(7, 4, BI + bytes(16)), blk(7, 5, BI + b"\x01\x2a\x03\x13\x05\x06"),
        blk(6, 3, BI + b"\0\1"), blk(1, 9, BI + b"qq"), blk(2, 9, BI + b"ww"), blk(5, 9, b"ee")]), dst=CTRL, src=DEV),
    "unsupported": frame(0xFEFD, pdu(3, 5, 0x66, [blk(2, 2, BI + b"x")]), dst=CTRL, src=DEV),
    "bad_service": frame(0xFEFD, pdu(9, 0, 0x67, [blk(2, 2, BI + b"x")]), dst=DEV),
    "bad_type": frame(0xFEFD, pdu(5, 2, 0x68, [blk(2, 2, BI + b"x")]), dst=DEV),
    "odd_strings": frame(0xFEFF, pdu(5, 1, 0x69, [blk(2, 1, BI + b"A\xaeB\x00C"), blk(2, 2, BI)]), dst=CTRL, src=DEV),
}


# -- tshark agrees on every synthetic frame --------------------------------------------------
def test_synthetic_frames_match_tshark(tmp_path):
    need_tshark()
    path = str(tmp_path / "dcp_synth.pcap")
    write_pcap(path, list(SYNTH.values()))
    maps = [m for m in load_maps() if m["kind"] in ("dcp", "rt")]
    compared, diffs = compare(path, maps)
    assert not diffs, "\n".join(diffs[:20])
    # every frame contributes, and the DCP map covers most of its fields
    assert compared > 250, compared


def test_map_covers_every_decoded_field_tshark_knows(tmp_path):
    """Each pn_dcp field tshark shows for the synthetic frames is mapped (nothing silently unchecked)."""
    need_tshark()
    from tsharkdiff import tshark_ek
    path = str(tmp_path / "dcp_cov.pcap")
    write_pcap(path, list(SYNTH.values()))
    mapped = {tf.replace(".", "_") for m in load_maps() if m["kind"] == "dcp" for tf in m["fields"].values()}
    seen = {k for fr in tshark_ek(path).values() for k in fr if k.startswith("pn_dcp_")}
    unmapped = seen - mapped - {"pn_dcp_block"}  # FT_NONE subtree marker
    assert not unmapped, sorted(unmapped)


# -- decoded values round-trip what the builders put in ---------------------------------------
def test_header_fields():
    d = dec(SYNTH["ident_req"])
    assert (d["service"], d["service_id"], d["service_type"], d["xid"]) == ("Identify", 5, 0, 0x44)
    assert d["response_delay"] == 1 and "reserved16" not in d
    assert d["data_length"] == sum(4 + b["block_length"] + (b["block_length"] & 1) for b in d["blocks"])
    r = dec(SYNTH["ident_rsp"])
    assert r["reserved16"] == 0 and "response_delay" not in r
    assert all("block_info" in b or b["option"] in (1, 0x80, 0xFF) for b in r["blocks"])


def test_hello_station_and_fields():
    d = dec(SYNTH["hello"])
    st = d["station_info"]
    assert st["name"] == "enc-1" and st["alias"] == "port-001.enc-1"
    assert (st["vendor_id"], st["device_id"]) == (0x012A, 0x0011)
    assert (st["oem_vendor_id"], st["oem_device_id"]) == (0x002A, 0x0313)
    assert st["ip"] == "192.168.0.5" and st["gateway"] == "192.168.0.1"
    assert st["type_of_station"] == "LIKA HS58" and st["role"] == 9
    ipb = next(b for b in d["blocks"] if (b["option"], b["suboption"]) == (1, 2))
    assert ipb["ip_conflict"] is True and "conflict" in ipb["ip_status"]
    role = next(b for b in d["blocks"] if b.get("suboption_device") == 4)
    assert role["roles"] == ["IO-Device", "PN-Supervisor"]
    rsi = next(b for b in d["blocks"] if b.get("suboption_device") == 10)
    assert [k for k, v in rsi["rsi"].items() if v is True] == ["ip_stack", "clrpc_interface",
                                                               "rsi_ar_read_implicit", "rsi_cim_read_implicit"]


def test_get_request_selectors_and_response():
    d = dec(SYNTH["get_req"])
    assert [(s["option"], s["suboption"]) for s in d["selectors"]] == [
        (1, 2), (2, 2), (5, 4), (255, 255), (128, 1), (4, 0), (7, 1), (3, 61)]
    assert "station_info" not in d and d["blocks"] == []
    r = dec(SYNTH["get_rsp"])
    suite = r["blocks"][0]
    assert [suite["ip"], suite["netmask"], suite["gateway"]] + suite["dns"] == SUITE
    ctl = r["blocks"][2]
    assert ctl["response"]["option"] == 2 and ctl["block_error"] == 3
    cid = [b for b in r["blocks"] if b.get("suboption_dhcp") == 61]
    assert cid[0]["client_id_kind"] == "MAC address" and cid[1]["dhcp_client_id"] == "abcd"
    assert r["blocks"][4]["dhcp_control"].startswith("Use DHCP")
    assert r["blocks"][6]["undecoded"] == b"xy".hex()
    assert r["station_info"]["ip"] == SUITE[0]


def test_set_request_control_blocks():
    d = dec(SYNTH["set_req"])
    kinds = [(b["option"], b["suboption"]) for b in d["blocks"]]
    assert kinds == [(5, 1), (2, 2), (1, 2), (5, 3), (5, 5), (5, 6), (5, 2)]
    assert d["blocks"][1]["block_qualifier"] == 1 and d["blocks"][3]["signal"] == "Flash once"
    assert d["blocks"][5]["reset"] == dcp_tables.RESET_QUALIFIER[8]
    assert d["station_info"] == {"name": "encoder-7", "ip": "10.0.0.2", "netmask": "255.0.0.0", "gateway": "0.0.0.0"}
    m = dec(SYNTH["set_misc"])
    assert m["blocks"][4].get("erroneous") is True
    r = dec(SYNTH["set_rsp"])
    assert [b["block_error_text"] for b in r["blocks"]] == [dcp_tables.BLOCK_ERRORS[0], dcp_tables.BLOCK_ERRORS[6], dcp_tables.BLOCK_ERRORS[0]]
    assert "station_info" not in r


def test_identify_request_filters_are_no_station_facts():
    d = dec(SYNTH["ident_req"])
    assert "station" not in d and "events" not in d
    assert d["blocks"][0]["nameofstation"] == "enc-1" and "block_info" not in d["blocks"][0]


def test_unknown_service_and_type_stop_decoding():
    for k in ("bad_service", "bad_type"):
        d = dec(SYNTH[k])
        assert d["blocks"] == [] and d.get("undecoded") is True
    d = dec(SYNTH["unsupported"])
    assert d["service_type_name"].startswith("Response - Request not") and d["blocks"][0]["block_info"] == 0
    assert "station" not in d


def test_tsn_and_strings():
    d = dec(SYNTH["tsn"])
    assert d["blocks"][0]["tsn_domain_name"] == "tsndom"
    assert d["blocks"][0]["tsn_domain_uuid"].replace("-", "") == bytes(range(16)).hex()
    assert d["blocks"][4]["cim_vendor_id"] == 0x012A and d["blocks"][5]["deviceinitiative_value"] == 1
    s = dec(SYNTH["odd_strings"])
    assert s["blocks"][0]["devicevendorvalue"] == "A\ufffdB"  # NUL ends it, 0xAE is not ASCII
    assert s["blocks"][1]["nameofstation"] == ""


def test_data_length_bounds_blocks_and_pad_is_ignored():
    f = SYNTH["ident_rsp"] + b"\xde\xad\xbe\xef"  # trailing garbage after DCPDataLength
    assert len(dec(f)["blocks"]) == len(dec(SYNTH["ident_rsp"])["blocks"])
    short = bytearray(SYNTH["ident_rsp"])
    short[24:26] = struct.pack(">H", 6)  # shorter than the first block
    with pytest.raises(Malformed):
        dec(bytes(short))
    long_ = bytearray(SYNTH["ident_rsp"])
    long_[24:26] = struct.pack(">H", 4000)
    with pytest.raises(Malformed):
        dec(bytes(long_))
    with pytest.raises(Malformed):
        dcp.decode(b"\xfe\xfe\x05\x00", 2, 0xFEFE)


# -- NameOfStation rules (spec/network.md §2.1) ----------------------------------------------
@pytest.mark.parametrize("name", ["encoder-1", "line1.enc-2", "a", "X208-BORD", "a" * 63 + "." + "b" * 63, ""])
def test_valid_names(name):
    assert dcp_rules.name_problems(name) == []


@pytest.mark.parametrize("name,word", [
    ("dev_2", "characters"), ("Encoder 1", "characters"), ("-enc", "'-'"), ("enc-", "'-'"),
    ("a" * 64, "label"), ("x." * 64 + "x", "more than 127"), ("a..b", "empty label"),
    ("line.-x", "'-'"), ("port-001", "port name"), ("192.168.0.1", "IPv4"), ("enc\u00e4", "characters"),
])
def test_invalid_names(name, word):
    probs = dcp_rules.name_problems(name)
    assert probs and any(word in p for p in probs), probs


def test_set_with_bad_name_is_a_violation_event_the_analyzer_stamps():
    bad = frame(0xFEFD, pdu(4, 0, 1, [blk(2, 2, PERM + b"Encoder 1")]), dst=DEV)
    d = dec(bad)
    (v,) = d["events"]
    assert v["kind"] == "violation" and v["rule"] == "DCP-NAME-INVALID" and "frame" not in v
    got = []
    a = Analyzer(sink=got.append)
    a.feed(7, 123, 1, bad)
    viol = [e for e in got if e["kind"] == "violation"]
    assert len(viol) == 1 and viol[0]["frame"] == 7 and viol[0]["ts_ns"] == 123
    assert viol[0]["side"] == "controller" and viol[0]["severity"] == dcp_rules.rules.RULES["DCP-NAME-INVALID"]["severity"]


def test_identify_response_with_bad_name_is_flagged_not_violated():
    rsp = frame(0xFEFF, pdu(5, 1, 1, [blk(2, 2, BI + b"dev_2")]), dst=CTRL, src=DEV)
    (e,) = dec(rsp)["events"]
    assert e["kind"] == "dcp_name_invalid" and e["name"] == "dev_2"
    req = frame(0xFEFE, pdu(5, 0, 1, [blk(2, 2, b"dev_2")], delay=1))
    assert "events" not in dec(req)  # an Identify filter is not a name assignment


# -- DcpTracker (DCP-NAME-DUPLICATE, IP-ASSIGN-OCCUPIED) ---------------------------------------
def _ident_rsp(name: str, ip: str, src: bytes) -> bytes:
    return frame(0xFEFF, pdu(5, 1, 1, [blk(2, 2, BI + name.encode()),
                                       blk(1, 2, b"\0\1" + ip4(ip) + ip4("255.255.255.0") + ip4("0.0.0.0"))]),
                 dst=CTRL, src=src)


def _ident_req(xid: int, name: str | None = None) -> bytes:
    return frame(0xFEFE, pdu(5, 0, xid, [blk(0xFF, 0xFF, b"") if name is None else blk(2, 2, name.encode())], 1))


def _ident_rsp_x(xid: int, name: str, ip: str, src: bytes) -> bytes:
    return frame(0xFEFF, pdu(5, 1, xid, [blk(2, 2, BI + name.encode()),
                                         blk(1, 2, b"\0\1" + ip4(ip) + ip4("255.255.255.0") + ip4("0.0.0.0"))]),
                 dst=CTRL, src=src)


def _set(dst: bytes, name: str | None = None, ip: str | None = None) -> bytes:
    bl = []
    if name is not None:
        bl.append(blk(2, 2, PERM + name.encode()))
    if ip is not None:
        bl.append(blk(1, 2, PERM + ip4(ip) + ip4("255.255.255.0") + ip4("0.0.0.0")))
    return frame(0xFEFD, pdu(4, 0, 2, bl), dst=dst)


def _run(frames):
    """Feed frames through the decoder and a DcpTracker as the analyzer would."""
    t = dcp_rules.DcpTracker()
    out = []
    for i, fr in enumerate(frames, 1):
        ev = dec(fr)
        ev.update(frame=i, ts_ns=i * 1000)
        out += t.on_dcp(ev, fr[6:12].hex(":"), fr[0:6].hex(":"))
    return out


def test_name_duplicate_on_set_and_on_two_responders():
    v = _run([_ident_rsp("enc-1", "10.0.0.5", DEV), _set(DEV2, name="enc-1")])
    assert [x["rule"] for x in v] == ["DCP-NAME-DUPLICATE"] and v[0]["frame"] == 2
    assert v[0]["other_mac"] == DEV.hex(":") and v[0]["mac"] == DEV2.hex(":")
    v = _run([_ident_rsp("enc-1", "10.0.0.5", DEV), _ident_rsp("enc-1", "10.0.0.6", DEV2),
              _ident_rsp("enc-1", "10.0.0.6", DEV2)])
    assert [x["rule"] for x in v] == ["DCP-NAME-DUPLICATE"]  # reported once


def test_no_duplicate_after_rename_or_for_same_device():
    assert _run([_ident_rsp("enc-1", "10.0.0.5", DEV), _set(DEV, name="enc-1"),
                 _ident_rsp("enc-1", "10.0.0.5", DEV)]) == []
    # DEV is renamed first, so its old name is free
    assert _run([_ident_rsp("enc-1", "10.0.0.5", DEV), _set(DEV, name="enc-9"), _set(DEV2, name="enc-1")]) == []
    assert _run([_set(DEV, name=""), _set(DEV2, name="")]) == []
    # a name reset (empty name) frees the name for another device
    assert _run([_ident_rsp("enc-1", "10.0.0.5", DEV), _set(DEV, name=""), _set(DEV2, name="enc-1")]) == []


def test_ip_assign_occupied():
    v = _run([_ident_rsp("enc-1", "10.0.0.5", DEV), _set(DEV2, ip="10.0.0.5")])
    assert [x["rule"] for x in v] == ["IP-ASSIGN-OCCUPIED"] and v[0]["ip_address"] == "10.0.0.5"
    assert _run([_ident_rsp("enc-1", "10.0.0.5", DEV), _set(DEV, ip="10.0.0.5")]) == []
    assert _run([_ident_rsp("enc-1", "0.0.0.0", DEV), _set(DEV2, ip="0.0.0.0")]) == []
    # DEV moved to another address first
    assert _run([_ident_rsp("a", "10.0.0.5", DEV), _set(DEV, ip="10.0.0.9"), _set(DEV2, ip="10.0.0.5")]) == []
    assert _run([_ident_rsp("a", "10.0.0.5", DEV), _ident_rsp("a", "0.0.0.0", DEV), _set(DEV2, ip="10.0.0.5")]) == []


def test_replaced_device_gives_its_name_and_ip_to_the_new_one():
    """The controller's Identify goes unanswered by the failed device; the replacement answers with no name
    and gets the old name and IP (000_37bf2397999f1108.txt:1052-1069): no duplicate, no occupied IP."""
    old = _ident_rsp_x(1, "enc-1", "10.0.0.5", DEV)
    for req in (_ident_req(2), _ident_req(2, "enc-1")):
        assert _run([old, req, _ident_rsp_x(2, "", "0.0.0.0", DEV2),
                     _set(DEV2, name="enc-1"), _set(DEV2, ip="10.0.0.5")]) == []
    # the old device answers the Identify: it is alive, both rules fire
    v = _run([old, _ident_req(2), _ident_rsp_x(2, "enc-1", "10.0.0.5", DEV), _ident_rsp_x(2, "", "0.0.0.0", DEV2),
              _set(DEV2, name="enc-1"), _set(DEV2, ip="10.0.0.5")])
    assert [x["rule"] for x in v] == ["DCP-NAME-DUPLICATE", "IP-ASSIGN-OCCUPIED"]
    # an Identify nobody answered in the capture (its responses go to a tool on another port) says nothing
    v = _run([old, _ident_req(2), _set(DEV2, name="enc-1")])
    assert [x["rule"] for x in v] == ["DCP-NAME-DUPLICATE"]
    # ... unless another Identify of the same controller shows its answers reach the capture: the name Identify
    # nobody answered, then one (by AliasName, the neighbour's port) the replacement answers -- an S7's replacement
    # without exchangeable medium (an independent audit: a false DCP-NAME-DUPLICATE)
    assert _run([old, _ident_req(2, "enc-1"), _ident_req(3, "port-002.plc-1"), _ident_rsp_x(3, "", "0.0.0.0", DEV2),
                 _set(DEV2, name="enc-1"), _set(DEV2, ip="10.0.0.5")]) == []
    # an Identify for another name says nothing about the holder
    v = _run([old, _ident_req(2, "enc-2"), _set(DEV2, name="enc-1")])
    assert [x["rule"] for x in v] == ["DCP-NAME-DUPLICATE"]
    # the Identify a response answers is still open: two devices answering it with one name are a duplicate
    v = _run([old, _ident_req(2), _ident_rsp_x(2, "enc-1", "10.0.0.6", DEV2), _ident_rsp_x(2, "enc-1", "10.0.0.5", DEV)])
    assert [x["rule"] for x in v] == ["DCP-NAME-DUPLICATE"]
    # the old device comes back after its name was given away: a duplicate again
    v = _run([old, _ident_req(2), _ident_rsp_x(2, "", "0.0.0.0", DEV2), _set(DEV2, name="enc-1"),
              _ident_rsp_x(3, "enc-1", "10.0.0.5", DEV)])
    assert [x["rule"] for x in v] == ["DCP-NAME-DUPLICATE"]


# -- property tests: a dict or Malformed, nothing else ----------------------------------------
def _real_dcp_frames() -> list[bytes]:
    """DCP frames of the public captures (when present) plus the synthetic ones."""
    out = list(SYNTH.values())
    from pndiss.capture import open_capture
    for name in ("node-profinetdcp_dcpscan.pcap", "python-profinet_connectrequest.pcap",
                 "tcpnscanner_pn-dcp.set-req.pcap", "iti_ChangeIPUsingDCP.pcap"):
        p = os.path.join(PUBLIC, name)
        if not os.path.exists(p):
            continue
        for _fn, _ts, lt, data in open_capture(p):
            if lt == 1 and len(data) > 16:
                off = 12
                while data[off:off + 2] == b"\x81\x00":
                    off += 4
                if data[off:off + 2] == b"\x88\x92" and data[off + 2] == 0xFE and data[off + 3] >= 0xFC:
                    out.append(bytes(data[:12]) + bytes(data[off:]))  # VLAN tags dropped
    return out


REAL = _real_dcp_frames()


def _check(data: bytes, off: int = 16) -> None:
    try:
        d = dcp.decode(data, off, 0xFEFD)
    except Malformed:
        return
    assert isinstance(d, dict) and isinstance(d["blocks"], list)


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(hs.binary(max_size=200), hs.integers(0, 20))
def test_random_bytes(data, off):
    _check(data, off)


@settings(max_examples=300, deadline=None)
@given(hs.sampled_from(REAL), hs.integers(0, 400))
def test_truncated_frames(fr, cut):
    _check(fr[:cut])


@settings(max_examples=300, deadline=None)
@given(hs.sampled_from(REAL), hs.lists(hs.tuples(hs.integers(0, 399), hs.integers(0, 255)), min_size=1, max_size=6))
def test_mutated_frames(fr, muts):
    b = bytearray(fr)
    for pos, val in muts:
        b[pos % len(b)] = val
    _check(bytes(b))


@settings(max_examples=200, deadline=None)
@given(hs.sampled_from(REAL), hs.lists(hs.tuples(hs.integers(16, 399), hs.integers(0, 255)), max_size=4))
def test_tracker_never_crashes(fr, muts):
    b = bytearray(fr)
    for pos, val in muts:
        b[pos % len(b)] = val
    try:
        ev = dcp.decode(bytes(b), 16, 0xFEFD)
    except Malformed:
        return
    ev.update(frame=1, ts_ns=1)
    assert isinstance(dcp_rules.DcpTracker().on_dcp(ev, "00:00:00:00:00:01", "00:00:00:00:00:02"), list)


def test_identify_response_cut_by_the_snap_length_keeps_its_whole_blocks(tmp_path):
    """A DCP Identify response the snap length cut: its whole blocks (vendor text, name, DeviceID) are decoded and
    name the station, as tshark does; the frame counts as cut (malformed, the snap-length note); without the cut a
    DCPDataLength beyond the frame is malformed as before (an independent audit: the whole frame was dropped, the
    station went unnamed and the plugin, reading tshark's fields, disagreed)."""
    blocks = [blk(2, 1, BI + b"Lika XAC77"), blk(2, 2, BI + b"enc-a"), blk(2, 3, BI + b"\x02\x39\x01\x00"),
              blk(2, 4, BI + b"\x02\x00"), blk(1, 2, BI + ip4("10.0.0.5") + ip4("255.0.0.0") + ip4("0.0.0.0"))]
    fr = frame(0xFEFF, pdu(5, 1, 7, blocks), dst=CTRL, src=DEV)
    keep = 16 + 10 + sum(len(b) for b in blocks[:3]) + 3   # DeviceID whole, DeviceRole cut
    d = dcp.decode(fr[:keep], 16, 0xFEFF, cut=True)
    assert [b.get("suboption") for b in d["blocks"]] and len(d["blocks"]) == 3 and "truncated" in d
    with pytest.raises(Malformed):
        dcp.decode(fr[:keep], 16, 0xFEFF)
    p = tmp_path / "cut.pcap"
    with open(p, "wb") as f:
        f.write(struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, keep, 1))
        f.write(struct.pack("<IIII", 1_700_000_000, 0, keep, len(fr)) + fr[:keep])
    a = Analyzer()
    from pndiss.capture import open_capture
    for fn, ts, lt, data in open_capture(str(p), info=a.reader):
        a.feed(fn, ts, lt, data)
    s = a.summary()
    assert s["accounting"]["malformed"] == 1 and "snap length" in s["malformed"][0]["reason"]
    assert "enc-a" in str(s["stations"])


@pytest.mark.parametrize("keep", [27, 28, 29, 30])
def test_get_request_cut_anywhere_in_its_selectors(keep):
    """A DCP Get request the snap length cut inside its selector list: the whole pairs it kept, never a traceback
    (the review of 2026-11-25: an odd cut read past the kept bytes)."""
    fr = frame(0xFEFD, pdu(3, 0, 0x1234, [bytes([2, 2, 2, 1])]), dst=DEV, src=CTRL)
    d = dcp.decode(fr[:keep], 16, 0xFEFD, cut=True)
    assert len(d["selectors"]) == (keep - 26) // 2 and ("truncated" in d) == (keep < 30)
