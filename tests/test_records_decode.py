"""pndiss.records against the manuals' own examples (spec/records.md) and the pairing rules."""
import struct

import pytest

from pndiss.records import ParamPairer, decode_record, index_name, param_info, select_profile
from pndiss.records.build import build_bf00, build_im0, build_param_request, build_param_response
from pndiss.records.profidrive import decode_response
from pndiss.proto.common import Malformed

# ---- PROFIdrive base mode --------------------------------------------------------------------

SCANCON_PRESET = bytes.fromhex("00020001" "1000FDE80000" "430100000064")  # 001_...:862-866


def test_scancon_preset_write_example():
    d = decode_record(0xB02E, SCANCON_PRESET, write=True, profile="scancon")
    assert d["index_name"] == "PROFIDrive Parameter Access - Local"
    assert (d["request_ref"], d["request_id"], d["axis"], d["no_of_parameters"]) == (0, 2, 0, 1)
    assert d["request_id_name"] == "change parameter"
    (p,) = d["params"]
    assert (p["attribute"], p["count"], p["pnu"], p["subindex"]) == (0x10, 0, 65000, 0)
    assert p["name"] == "Preset value"
    assert (p["format"], p["no_of_values"], p["values"]) == (0x43, 1, [100])
    assert "trailing_bytes" not in d


def test_builder_reproduces_scancon_example():
    assert build_param_request(0, 2, [{"pnu": 65000, "format": 0x43, "values": [100]}]) == SCANCON_PRESET


@pytest.mark.parametrize("raw,code,sub", [("0082000144010002", 2, None), ("00820001440200020000", 2, 0)])
def test_negative_responses(raw, code, sub):  # records.md §3.9 derived rows
    d = decode_record(0xB02E, bytes.fromhex(raw), write=False)
    assert d["response_id"] == 0x82 and not d["ok"]
    (b,) = d["params"]
    assert b["error"] == {"code": code, "text": "low or high limit exceeded"}
    assert b.get("error_subindex") == sub


def test_positive_change_response_has_no_blocks():
    d = decode_record(0xB02E, bytes.fromhex("00020001"), write=False)
    assert d["ok"] and d["params"] == [] and d["no_of_parameters"] == 1


def test_negative_response_with_zero_blocks_only():
    d = decode_record(0xB02E, bytes.fromhex("098100024000" "4000"), write=False)
    assert [b["format_name"] for b in d["params"]] == ["Zero", "Zero"] and not d["ok"]


def test_every_format_width():
    blocks = [{"format": 0x02, "values": [-3]}, {"format": 0x03, "values": [-300, 7]},
              {"format": 0x04, "values": [-100]}, {"format": 0x07, "values": [2**32 - 1]},
              {"format": 0x08, "values": [1.5]}, {"format": 0x09, "values": ["ABC"]},
              {"format": 0x0A, "values": [1, 2, 3]}, {"format": 0x0F, "values": [2.25]},
              {"format": 0x37, "values": [-(2**40)]}, {"format": 0x38, "values": [2**63]},
              {"format": 0x1F, "values": ["3d29"]}, {"format": 0x72, "values": [-5]},
              {"format": 0x41, "values": [7]}, {"error": 0x16}]
    d = decode_response(build_param_response(1, 0x81, blocks))
    assert len(d["params"]) == len(blocks)
    for b, got in zip(blocks, d["params"]):
        if "error" in b:
            assert got["error"]["code"] == 0x16
        else:
            assert got["values"] == b["values"], got


def test_odd_blocks_are_padded_and_skipped():
    raw = bytes.fromhex("0101000241010700" "41010800")
    d = decode_record(0xB02E, raw, write=False)
    assert [b["values"] for b in d["params"]] == [[7], [8]]


@pytest.mark.parametrize("raw", ["0102", "01020001" "1000FDE8", "01020001" "1000FDE80000" "4302000000"])
def test_truncated_param_records_are_malformed(raw):
    with pytest.raises(Malformed):
        decode_record(0xB02E, bytes.fromhex(raw), write=True)


def _pair(req: bytes, rsp: bytes, profile="generic"):
    pp = ParamPairer()
    key = ("ar", 0, 1, 1)
    pp.request(key, decode_record(0xB02E, req, write=True, profile=profile), 10, 1000)
    return pp.response(key, decode_record(0xB02E, rsp, write=False, profile=profile), 12, 2000, profile=profile)


def test_pairing_gives_every_value_its_address():
    req = build_param_request(5, 1, [{"pnu": 65001, "subindex": 6, "count": 2}, {"pnu": 922}])
    rsp = build_param_response(5, 1, [{"format": 0x07, "values": [0x401, 0xFFFFFFFF]}, {"format": 0x06, "values": [81]}])
    ev = _pair(req, rsp, "lika")
    assert ev["pairing"] == [] and ev["ok"] and ev["request_frame"] == 10 and ev["response_frame"] == 12
    assert ev["request_id"] == 1 and ev["request_id_name"] == "request parameter" and ev["response_id"] == 1
    a, b = ev["params"]
    assert (a["pnu"], a["subindex"], a["count"], a["values"]) == (65001, 6, 2, [0x401, 0xFFFFFFFF])
    assert [e["name"] for e in a["elements"]] == ["encoder profile version", "operating time"]
    assert (b["pnu"], b["name"], b["values"]) == (922, "Telegram selection", [81])


def test_pairing_problems():
    req = build_param_request(5, 2, [{"pnu": 65000, "format": 0x43, "values": [1]}], axis=1)
    ev = _pair(req, build_param_response(6, 0x81, [{"error": 2}, {"error": 3}], axis=2))
    text = " | ".join(ev["pairing"])
    for frag in ("request ref mismatch", "response id mismatch", "axis not mirrored", "number of parameters"):
        assert frag in text
    pp = ParamPairer()
    ev = pp.response("k", decode_response(bytes.fromhex("00020001")), 3, 0)
    assert ev["pairing"] == ["no request"] and ev["request_frame"] is None


def test_pairing_reports_overwritten_request():
    pp = ParamPairer()
    pp.request("k", decode_record(0xB02E, build_param_request(1, 1, [{"pnu": 922}]), write=True), 1, 0)
    pp.request("k", decode_record(0xB02E, build_param_request(2, 1, [{"pnu": 922}]), write=True), 2, 0)
    ev = pp.response("k", decode_response(build_param_response(2, 1, [{"format": 0x06, "values": [81]}])), 3, 0)
    assert ev["superseded_request_frames"] == [1] and ev["request_frame"] == 2


def test_pairing_retry_of_the_same_request_is_no_new_request():
    """A function block's retry writes the very same request again (its job timer ran out): the first stays
    pending, nothing is overwritten (rule #76 is about a new request before the response)."""
    pp = ParamPairer()
    req = decode_record(0xB02E, build_param_request(1, 1, [{"pnu": 922}]), write=True)
    pp.request("k", req, 1, 0)
    pp.request("k", dict(req), 2, 0)
    ev = pp.response("k", decode_response(build_param_response(1, 1, [{"format": 0x06, "values": [81]}])), 3, 0)
    assert "superseded_request_frames" not in ev and ev["request_frame"] == 1 and ev["pairing"] == []


def test_pairing_refused_early_write_keeps_the_pending_request():
    """A device busy with request 1 refuses request 2 ("state conflict"): request 1 is still the one its
    response answers, and the controller's early write is still #76 (the pairing note says pipelined)."""
    pp = ParamPairer()
    pp.request("k", decode_record(0xB02E, build_param_request(1, 1, [{"pnu": 922}]), write=True), 1, 0)
    pp.request("k", decode_record(0xB02E, build_param_request(2, 1, [{"pnu": 65000}]), write=True), 2, 0)
    pp.refused("k", 2)
    ev = pp.response("k", decode_response(build_param_response(1, 1, [{"format": 0x06, "values": [83]}])), 3, 0)
    assert ev["request_frame"] == 1 and ev["params"][0]["pnu"] == 922 and "superseded_request_frames" not in ev
    assert ev["pairing"] == ["request(s) in frame(s) 2 pipelined before this response was read (refused by the device)"]


def test_pairing_illegal_request_id_answered_0x80():
    """An illegal request ID is answered with response ID 0x80 (001_9461bb7bc8c2767b.txt:2073): no mismatch; nor is a
    manufacturer-specific one (0x40-0x7F) the device does not offer, refused the documented way (0x80 / 0x21)."""
    for qid, rid, mismatch in ((0x03, 0x80, False), (0x03, 0x83, False), (0x01, 0x80, True), (0x40, 0x80, False),
                               (0x7F, 0x80, False), (0x40, 0xC0, False), (0x40, 0x81, True)):
        req = decode_record(0xB02E, build_param_request(1, qid, [{"pnu": 922}]), write=True)
        pp = ParamPairer()
        pp.request("k", req, 1, 0)
        ev = pp.response("k", decode_response(build_param_response(1, rid, [{"error": 0x21}])), 2, 0)
        assert any("response id mismatch" in p for p in ev["pairing"]) == mismatch, (qid, rid)


def test_negative_change_keeps_written_value_and_error():
    ev = _pair(SCANCON_PRESET, bytes.fromhex("0082000144010002"), "scancon")
    (p,) = ev["params"]
    assert p["written"] == {"format": 0x43, "values": [100]} and p["error"]["code"] == 2 and not ev["ok"]


def test_param_database_profiles():
    assert param_info(65000, "lika")["type"] == "Unsigned32" and param_info(65000, "scancon")["type_code"] == 0x04
    assert param_info(65001, "psm")["subindex"][18].startswith("offset 64 bit")
    assert param_info(65001, "lika")["subindex"][11] == "velocity measuring unit"
    assert param_info(922)["access"] == "ro" and param_info(101, "psm")["name"].startswith("Sensor format")
    assert param_info(101, "lika") is None
    for pnu in (922, 925, 964, 965, 971, 974, 975, 979, 980, 61000, 61001, 65000, 65001):
        info = param_info(pnu, "psm")
        assert info and info["source"] and ".txt:" in info["source"]


# ---- I&M ---------------------------------------------------------------------------------------

def test_im0_lika_example():
    # hand-built: Lika vendor 0x0239 (000_...:1962), HW 1, SW V1.1.0 (000_...:856-873), encoder profile
    raw = (bytes.fromhex("0020003801000239") + b"XAC7716/16384PT-xx".ljust(20) + b"123456".ljust(16)
           + bytes.fromhex("0001" "56010100" "0002" "3D00" "0000" "0101" "0000"))
    d = decode_record(0xAFF0, raw, write=False)
    assert d["index_name"] == "I&M0" and d["vendor_id"] == 0x0239 and d["vendor_name"].startswith("Lika")
    assert d["order_id"] == "XAC7716/16384PT-xx" and d["serial_number"] == "123456"
    assert d["sw_revision"] == "V1.1.0" and d["hw_revision"] == 1 and d["revision_counter"] == 2
    assert d["profile_id"] == 0x3D00 and d["profile_name"] == "Encoder profile" and d["im_version"] == "1.1"
    assert d["notes"] == []
    assert build_im0(0x0239, "XAC7716/16384PT-xx", "123456", 1, ("V", 1, 1, 0), 2, 0x3D00, 0, (1, 1), 0) == raw


def test_im0_short_and_im1():
    with pytest.raises(Malformed):
        decode_record(0xAFF0, build_im0()[:40], write=False)
    im1 = struct.pack(">HHBB", 0x21, 0x38, 1, 0) + b"axis 1".ljust(32) + b"hall 2".ljust(22)
    d = decode_record(0xAFF1, im1, write=True)
    assert (d["tag_function"], d["tag_location"]) == ("axis 1", "hall 2")


# ---- 0xBF00 user parameters --------------------------------------------------------------------

def _bf00(b0, mupr, tmr, sol, vu, tail=bytes(12)):
    return bytes([b0]) + mupr.to_bytes(8, "big") + tmr.to_bytes(8, "big") + bytes([sol, vu]) + tail


def test_lika_defaults_xac7716():
    # Lika defaults (000_...:3513-3532): class 4 on, compat 1 (V4.1), MUPR = 2^16, TMR = 2^30, SoL 1, steps/s
    d = decode_record(0xBF00, _bf00(0x22, 1 << 16, 1 << 30, 1, 0), write=True, profile="lika")
    assert (d["code_sequence"], d["class4"], d["preset_control"], d["scaling"], d["alarm_channel_control"],
            d["compat"]) == (0, 1, 0, 0, 0, 1)
    assert d["mupr"] == 65536 and d["tmr"] == 1 << 30 and d["revolutions"] == 16384
    assert d["velocity_unit_name"] == "steps/s" and d["problems"] == [] and d["preset_affects_xist1"]


def test_scancon_pc_worx_example():
    # PC Worx screen: MUPR 8192, TMR 33554432, SoL 1, steps/s; SCANCON default scaling on (001_...:806, 2201-2203)
    d = decode_record(0xBF00, _bf00(0x28, 8192, 33554432, 1, 0), write=True, profile="scancon")
    assert d["scaling"] == 1 and d["compat"] == 1 and d["class4"] == 0
    assert (d["mupr"], d["tmr"], d["max_master_sol_failures"]) == (8192, 33554432, 1) and d["problems"] == []
    assert "diagnostic telegram" in d["alarm_channel_meaning"]


def test_hohner_preset_control_is_inverted():
    raw = _bf00(0x22, 8192, 1 << 25, 1, 3)
    assert decode_record(0xBF00, raw, write=True, profile="hohner")["preset_affects_xist1"] is False
    assert decode_record(0xBF00, raw, write=True, profile="lika")["preset_affects_xist1"] is True
    assert decode_record(0xBF00, raw, write=True, profile="hohner")["velocity_unit_name"] == "RPM"


def test_psm_record_at_ffff():
    # PSM defaults (002_...:985-1009): class 4 1, preset control 1 (disabled), compat 1, rotary, SoL 0 allowed
    raw = _bf00(0x26 | 0x40, 4096, 1 << 24, 0, 4, struct.pack(">f", 3000.0) + bytes(8))
    d = decode_record(0xFFFF, raw, write=True, profile="psm")
    assert d["index_name"].startswith("Encoder standard parameter")
    assert d["encoder_type_name"] == "linear" and d["velocity_reference"] == 3000.0 and d["problems"] == []
    assert not d["preset_affects_xist1"] and d["mupr_low"] == 4096 and d["tmr_high"] == 0
    assert "data" in decode_record(0xFFFF, raw, write=True, profile="lika")


@pytest.mark.parametrize("profile,raw,rules", [
    ("lika", _bf00(0x22, 8192, 1 << 25, 1, 0)[:30], {"BF00-LENGTH"}),
    ("lika", _bf00(0x62, 8192, 1 << 25, 1, 0), {"BF00-RESERVED-NONZERO"}),
    ("lika", _bf00(0x22, 8192, 1 << 25, 1, 0, bytes(11) + b"\x01"), {"BF00-RESERVED-NONZERO"}),
    ("scancon", _bf00(0x62, 8192, 1 << 25, 1, 0), set()),
    ("lika", _bf00(0x22, 0, 1, 0, 4), {"BF00-VALUE-OUT-OF-RANGE"}),
    ("psm", _bf00(0x22, 8192, 1 << 25, 0, 4), set()),
    ("psm", _bf00(0x22, 8192, 1 << 25, 0, 5), {"BF00-VALUE-OUT-OF-RANGE"}),
    ("generic", b"", {"BF00-LENGTH"}),
])
def test_bf00_problems(profile, raw, rules):
    d = decode_record(0xBF00, raw, write=True, profile=profile)
    assert {p["rule"] for p in d["problems"]} == rules
    assert all(p["message"] for p in d["problems"])


def test_bf00_out_of_range_counts_each_field():
    d = decode_record(0xBF00, _bf00(0x22, 0, 1, 0, 4), write=True, profile="lika")
    assert len(d["problems"]) == 4


@pytest.mark.parametrize("profile", ["lika", "scancon", "hohner", "psm", "generic"])
def test_build_bf00_round_trip(profile):
    raw = build_bf00(profile, direction=1, scaling=1, mupr=3600, tmr=3600 * 512, max_master_sol_failures=3,
                     velocity_unit=2)
    d = decode_record(0xBF00, raw, write=True, profile=profile)
    assert len(raw) == 31 and d["problems"] == []
    assert (d["direction"], d["scaling"], d["mupr"], d["tmr"], d["max_master_sol_failures"], d["velocity_unit"]) \
        == (1, 1, 3600, 3600 * 512, 3, 2)


# ---- names and profiles -------------------------------------------------------------------------

def test_index_names():
    assert index_name(0xAFF0) == "I&M0" and index_name(0xB02F).endswith("Global")
    assert index_name(0xBF00) == "Encoder user parameter data"
    assert "0x1234" in index_name(0x1234)
    d = decode_record(0x8028, b"\x01\x02", write=False)
    assert d["data"] == "0102" and d["index_name"].startswith("RecordInputDataObjectElement")


@pytest.mark.parametrize("args,profile", [
    ((0x0239, 3), "lika"), ((0x002A, 0x0313), "generic"), ((None, None, "SAG-EIXXB-1213-XXXX"), "scancon"),
    ((0x1234, 1, "SCANCON SAG"), "scancon"), ((None, None, "ExM58x-xxxPNxxxx1213"), "hohner"),
    ((None, None, "ENA58IL-R11BA-B17"), "hohner"), ((None, None, "PS/PSM Type 0"), "psm"),
    ((None, None, "LIKA ROTACOD"), "lika"), ((0x0099, None, "ET 200SP"), "generic"),
])
def test_select_profile(args, profile):
    got, reason = select_profile(*args)
    assert got == profile and reason


def test_select_profile_reason_words():
    assert select_profile(0x0239, 1, source="DCP") == ("lika", "vendor ID 0x0239 (Lika Electronic) from DCP")
    prof, reason = select_profile(0x1234, 5)
    assert prof == "generic" and "0x1234" in reason and "not a known encoder vendor" in reason


def test_unknown_format_is_malformed():
    with pytest.raises(Malformed, match="format 0x39"):
        decode_record(0xB02E, bytes.fromhex("0101000139010000"), write=False)


def test_psm_vendor_records():
    # OEM sensor configuration default 33/33 = real configuration (002_...:1049-1083)
    d = decode_record(0x1000, bytes([33, 33]), write=True, profile="psm")
    assert d["uses_real_configuration"] and (d["singleturn_bits"], d["multiturn_bits"]) == (33, 33)
    d = decode_record(0x1000, bytes([13, 12]), write=True, profile="psm")
    assert not d["uses_real_configuration"] and d["multiturn_bits"] == 12
    # parameter control: NV-RAM init (default), read-only write protection, P65005 read only (002_...:1022-1047)
    d = decode_record(0x1001, bytes([0b0100101, 0]), write=True, profile="psm")
    assert (d["init_control_name"], d["write_protect_name"], d["p65005_write_protect_name"],
            d["reset_control_write_protect"]) == ("NV-RAM", "read only", "read only", 0)
    assert decode_record(0x1000, b"\x02", write=True, profile="scancon")["velocity_filter"] == 2
    assert "data" in decode_record(0x1001, b"\x01\x00", write=True, profile="lika")


def test_pairing_forgets_a_request_pending_from_before_capture_loss():
    """The capture lost frames after a request was written (a capture gap): its response may have been read in
    the lost part, so the next request overwrites nothing (no BMP-PIPELINED; found by an independent audit: a
    lost ring file)."""
    pp = ParamPairer()
    pp.request("k", decode_record(0xB02E, build_param_request(1, 1, [{"pnu": 922}]), write=True), 1, 100)
    pp.request("k", decode_record(0xB02E, build_param_request(2, 1, [{"pnu": 922}]), write=True), 9, 900, gap_ts=500)
    ev = pp.response("k", decode_response(build_param_response(2, 1, [{"format": 0x06, "values": [81]}])), 10, 950)
    assert "superseded_request_frames" not in ev and ev["request_frame"] == 9
    pp.request("k", decode_record(0xB02E, build_param_request(3, 1, [{"pnu": 922}]), write=True), 11, 960, gap_ts=500)
    pp.request("k", decode_record(0xB02E, build_param_request(4, 1, [{"pnu": 922}]), write=True), 12, 970, gap_ts=500)
    ev = pp.response("k", decode_response(build_param_response(4, 1, [{"format": 0x06, "values": [81]}])), 13, 980)
    assert ev["superseded_request_frames"] == [11]   # a gap before the pending request: still overwritten


def test_pairing_a_response_the_file_puts_after_the_next_write():
    """A TAP writing its two ports in batches: request 1 (t=100), request 2 (t=300), then in the file the response to
    request 1 stamped t=200 -- before request 2 in time. It answers request 1 (its reference), nothing was
    overwritten, request 2 stays pending (an independent audit: a false BMP-PIPELINED against the controller and two
    mismatches against the encoder). The same response stamped after request 2 is the controller's fault still."""
    req = lambda ref: decode_record(0xB02E, build_param_request(ref, 1, [{"pnu": 922}]), write=True)   # noqa: E731
    rsp = lambda ref: decode_response(build_param_response(ref, 1, [{"format": 0x06, "values": [81]}]))   # noqa: E731
    pp = ParamPairer()
    pp.request("k", req(1), 1, 100)
    pp.request("k", req(2), 2, 300)
    ev = pp.response("k", rsp(1), 3, 200)
    assert ev["pairing"] == [] and ev["request_frame"] == 1 and "superseded_request_frames" not in ev
    ev = pp.response("k", rsp(2), 4, 400)
    assert ev["pairing"] == [] and ev["request_frame"] == 2
    pp = ParamPairer()
    pp.request("k", req(1), 1, 100)
    pp.request("k", req(2), 2, 300)
    ev = pp.response("k", rsp(1), 3, 350)
    assert ev["superseded_request_frames"] == [1] and ev["request_frame"] == 2


def test_pairing_blocks_out_of_request_order():
    """#84 (001_9461bb7bc8c2767b.txt:1925): a response repeats no PNU, but when the blocks of a positive
    multi-parameter read hold the requested element counts in another order the order is provably wrong: a
    pairing note (BMP-ORDER) -- paired by position, P922 was judged on P979's six values (an independent audit:
    a false TELEGRAM-SELECTION-MISMATCH). The same counts in order, or equal counts, say nothing."""
    req = decode_record(0xB02E, build_param_request(1, 1, [{"pnu": 922}, {"pnu": 979, "count": 6}]), write=True)
    for blocks, broken in (([{"format": 0x43, "values": [1] * 6}, {"format": 0x06, "values": [81]}], True),
                           ([{"format": 0x06, "values": [81]}, {"format": 0x43, "values": [1] * 6}], False)):
        pp = ParamPairer()
        pp.request("k", req, 1, 0)
        ev = pp.response("k", decode_response(build_param_response(1, 1, blocks)), 2, 0)
        assert any("not in request order" in p for p in ev["pairing"]) == broken, ev["pairing"]
    same = decode_record(0xB02E, build_param_request(2, 1, [{"pnu": 922}, {"pnu": 925}]), write=True)
    pp = ParamPairer()
    pp.request("k", same, 1, 0)
    ev = pp.response("k", decode_response(build_param_response(2, 1, [{"format": 0x06, "values": [1]}] * 2)), 2, 0)
    assert not ev["pairing"]


def test_pairing_order_in_a_partly_negative_response_and_by_data_type():
    """#84 in a partly negative multi-parameter read: the error block keeps its place, the others' counts still prove
    the swap; and with equal counts, two blocks that each hold the other parameter's declared data type (P922
    Unsigned16, P65000 Unsigned32 in LIKA) do too (an independent audit: P922 judged on P979's or P65000's values,
    a false TELEGRAM-SELECTION-MISMATCH). The right order, or one wrong type alone (BMP-DATATYPE's), says nothing."""
    def pair(params, rid, blocks, profile="lika"):
        pp = ParamPairer()
        pp.request("k", decode_record(0xB02E, build_param_request(1, 1, params), write=True, profile=profile), 1, 0)
        return pp.response("k", decode_response(build_param_response(1, rid, blocks)), 2, 0, profile=profile)["pairing"]
    three = [{"pnu": 922}, {"pnu": 979, "count": 6}, {"pnu": 925}]
    swapped = [{"format": 0x07, "values": [1] * 6}, {"format": 0x06, "values": [81]}, {"error": 0x00}]
    assert any("elements requested [1, 6, 1]" in p for p in pair(three, 0x81, swapped))
    assert not pair(three, 0x81, [swapped[1], swapped[0], swapped[2]])
    two = [{"pnu": 922}, {"pnu": 65000}]
    p = pair(two, 1, [{"format": 0x07, "values": [5000]}, {"format": 0x06, "values": [81]}])
    assert p == ["value blocks not in request order (data types requested [Unsigned16, Unsigned32], "
                 "answered [Unsigned32, Unsigned16])"]
    assert not pair(two, 1, [{"format": 0x06, "values": [81]}, {"format": 0x07, "values": [5000]}])
    assert not pair(two, 1, [{"format": 0x07, "values": [81]}, {"format": 0x07, "values": [5000]}])


def test_date_and_time_formats_are_sized():
    """The data types a master must understand (001_...:2029) beyond the manuals' own: a Date (0x32, 7 octets and a
    pad byte) in a multi-parameter read leaves the next block where it is (an independent audit: the whole response
    was dropped, the request stayed pending)."""
    raw = bytes.fromhex("0201000306010051" "3201" "7e1b0c0e091505" "00" "0701" "00001388")
    d = decode_record(0xB02E, raw, write=False)
    assert [(b["format_name"], b["values"]) for b in d["params"]] == \
        [("Unsigned16", [0x51]), ("Date", ["7e1b0c0e091505"]), ("Unsigned32", [5000])]


def test_undecodable_response_answers_its_request():
    """A response whose value blocks do not decode (a reserved format, a count the record does not hold) still
    answers the request written before it: the request is no longer pending (so the controller's next job is not
    'pipelined'), the header is judged (a parameter count not mirrored), the values are not."""
    from pndiss.records.profidrive import undecodable_response
    pp = ParamPairer()
    key = ("ar", 0, 1, 1)
    req = build_param_request(2, 1, [{"pnu": 922}, {"pnu": 65000}, {"pnu": 979, "subindex": 1, "count": 6}])
    pp.request(key, decode_record(0xB02E, req, write=True), 10, 1000)
    bad = bytes.fromhex("020100044501000500")   # No. of Parameters 4 for 3, and a reserved format 0x45
    with pytest.raises(Malformed):
        decode_record(0xB02E, bad, write=False)
    ev = pp.response(key, undecodable_response(bad, "profidrive: format 0x45 unknown"), 12, 2000)
    assert ev["request_frame"] == 10 and not ev["ok"] and ev["decode_error"]
    assert "value blocks do not decode: values not judged" in ev["pairing"]
    assert any(p.startswith("number of parameters mismatch") for p in ev["pairing"])
    assert all(not p["values"] for p in ev["params"])
    # the next job pairs with its own request: nothing overwritten
    pp.request(key, decode_record(0xB02E, build_param_request(3, 1, [{"pnu": 922}]), write=True), 20, 3000)
    ev = pp.response(key, decode_record(0xB02E, build_param_response(3, 1, [{"format": 6, "values": [81]}]),
                                        write=False), 22, 4000)
    assert ev["pairing"] == [] and ev["request_frame"] == 20
    assert undecodable_response(b"\x01\x02", "short") is None


def test_one_count_fault_one_note():
    """A response that drops the last of three blocks and says 2 parameters: one fault, one note (number of
    parameters), not a second one for its blocks (an independent audit: two BMP-NOT-MIRRORED)."""
    req = build_param_request(1, 1, [{"pnu": 922}, {"pnu": 925}, {"pnu": 65000}])
    two = [{"format": 0x06, "values": [81]}, {"format": 0x06, "values": [1]}]
    assert _pair(req, build_param_response(1, 1, two))["pairing"] == \
        ["number of parameters mismatch (request 3, response 2)"]


def test_fixed_size_octet_string_counted_in_octets():
    """P965 answered "OctetString2, 2 values" with its 2 bytes (the count in octets, as some devices write it): one
    element, the profile number and version -- not a response that does not decode (an independent audit's Lika
    session); 2 values of 4 bytes still read as two elements."""
    d = decode_record(0xB02E, bytes([2, 1, 1, 1, 0x1F, 2, 0x3D, 31]), write=False)
    assert d["params"][0]["values"] == ["3d1f"] and d["params"][0]["no_of_values"] == 2
    d = decode_record(0xB02E, bytes([2, 1, 1, 1, 0x1F, 2, 0x3D, 0x29, 0x3D, 0x1F]), write=False)
    assert d["params"][0]["values"] == ["3d29", "3d1f"]
    # ... also first of a multi-parameter response (a review: its 2 values swallowed the next block's header)
    d = decode_record(0xB02E, bytes([2, 1, 1, 2, 0x1F, 2, 0x3D, 31, 0x06, 1, 0, 81]), write=False)
    assert [p["values"] for p in d["params"]] == [["3d1f"], [81]]
