"""The telegram table and its decoder; the cyclic tracker wired into the Analyzer."""
import json
import re
import struct

import pytest
from hypothesis import given, settings, strategies as st

from pndiss import telegrams as tg
from pndiss.analyzer import Analyzer
from pndiss.armap import DataObject, FrameMap
from pndiss.proto.common import Malformed

# cyclic.md §2 catalogue: (setpoint bytes, actual bytes), taken from the spec text, not the table
SPEC_LENGTHS = {81: (4, 12), 82: (4, 14), 83: (4, 16), 84: (4, 20), 86: (4, 8), 87: (4, 4), 88: (8, 12),
                89: (6, 10), 100: (4, 12), 101: (8, 16), 860: (4, 8)}


def test_lengths_match_the_catalogue():
    assert set(tg.TELEGRAMS) == set(SPEC_LENGTHS)
    for t, (o, i) in SPEC_LENGTHS.items():
        assert (tg.length(t, "setpoint"), tg.length(t, "actual")) == (o, i), t


def test_every_entry_cites_its_source_and_names_are_stable():
    for name, s in tg.SIGNALS.items():
        assert re.fullmatch(r"[a-z0-9_]+", name) and s["source"]
    for t, d in tg.TELEGRAMS.items():
        assert d["source"]
    for sig, rows in tg.BITMAPS.items():
        for b in rows:
            assert re.fullmatch(r"[a-z0-9_]+", b["name"]) and b["source"], (sig, b)
    names = tg.field_names()
    assert len(names) == len(set(names))
    assert {"pndiss.g1_zsw.sensor_error", "pndiss.stw2_enc.control_by_plc", "pndiss.g1_xist1"} <= set(names)


def test_bit_maps_do_not_overlap_per_profile():
    for sig in tg.BITMAPS:
        for prof in tg.PROFILES:
            used = 0
            for _, shift, mask in tg.bit_fields(sig, prof):
                assert not used & (mask << shift), (sig, prof)
                used |= mask << shift


def test_scancon_worked_example_words():
    # cyclic.md §5.2/§5.3: ZSW2_ENC 0xF200 = sign-of-life 15 + control requested; G1_ZSW 0x2000 = bit 13
    data = bytes.fromhex("F200 2000 0E95B200 001D2B64".replace(" ", ""))
    sig = tg.decode(81, "actual", data)
    assert sig == {"zsw2_enc": 0xF200, "g1_zsw": 0x2000, "g1_xist1": 0x0E95B200, "g1_xist2": 0x001D2B64}
    b = tg.bits(sig, "scancon")
    assert b["zsw2_enc.sign_of_life"] == 15 and b["zsw2_enc.control_requested"] == 1
    assert b["g1_zsw.transmit_absolute_value"] == 1 and b["g1_zsw.sensor_error"] == 0
    sp = tg.bits(tg.decode(81, "setpoint", bytes.fromhex("04002000")), "scancon")
    assert sp["stw2_enc.control_by_plc"] == 1 and sp["stw2_enc.sign_of_life"] == 0 and sp["g1_stw.request_absolute_value"] == 1


def test_psm_variant_bits():
    # cyclic.md §5.2: PS/PSM puts control requested on bit 10 and names bits 0-3, 7
    b = tg.bits({"zsw2_enc": 0x0400}, "psm")
    assert b["zsw2_enc.control_requested"] == 1 and "zsw2_enc.fault_present" in b
    assert tg.bits({"zsw2_enc": 0x0400}, "lika")["zsw2_enc.control_requested"] == 0
    assert "zsw2_enc.fault_present" not in tg.bits({"zsw2_enc": 0}, "lika")
    assert tg.reserved_mask("zsw2_enc", "lika") == 0xFFFF & ~(0x0200 | 0xF000)
    assert tg.reserved_mask("g1_zsw", "psm") == 0x0400


def test_signedness_and_byte_order():
    # NIST_A/NIST_B signed (cyclic.md §11.1); byte_order='little' for the PS/PSM claim (§1)
    data = bytes.fromhex("0000 0000 00000000 00000000 FFFF".replace(" ", ""))
    assert tg.decode(82, "actual", data)["nist_a"] == -1
    little = struct.pack("<HHIIi", 1, 2, 3, 4, -5)
    assert tg.decode(83, "actual", little, byte_order="little") == {
        "zsw2_enc": 1, "g1_zsw": 2, "g1_xist1": 3, "g1_xist2": 4, "nist_b": -5}
    assert tg.decode(860, "setpoint", bytes.fromhex("80000064"))["g1_xist_preset_b"] == 0x80000064
    assert tg.bits({"g1_xist_preset_b": 0x80000064})["g1_xist_preset_b.value"] == 100


def test_error_words_and_units():
    assert "sign-of-life" in tg.error_text(0x0F02) and "device-specific" in tg.error_text(0x4242)
    assert tg.velocity_unit_name(3) == "rpm"


@settings(max_examples=300, deadline=None)
@given(t=st.sampled_from(sorted(tg.TELEGRAMS)), d=st.sampled_from(tg.DIRECTIONS), data=st.binary(max_size=24),
       order=st.sampled_from(["big", "little"]))
def test_decode_random_bytes(t, d, data, order):
    try:
        out = tg.decode(t, d, data, byte_order=order)
    except Malformed as e:
        assert e.layer == "telegram" and len(data) < tg.length(t, d)
        return
    assert list(out) == list(tg.layout(t, d).names)
    assert tg.encode(t, d, out, byte_order=order) == data[:tg.length(t, d)]


@settings(max_examples=200, deadline=None)
@given(t=st.sampled_from(sorted(tg.TELEGRAMS)), d=st.sampled_from(tg.DIRECTIONS), data=st.data())
def test_truncated_and_mutated(t, d, data):
    good = bytes(range(1, tg.length(t, d) + 1))
    cut = data.draw(st.integers(0, len(good)))
    pos = data.draw(st.integers(0, len(good)))
    mutated = bytearray(good[:cut])
    if pos < len(mutated):
        mutated[pos] ^= data.draw(st.integers(1, 255))
    try:
        sig = tg.decode(t, d, bytes(mutated), off=data.draw(st.integers(-2, 3)))
        assert isinstance(sig, dict)
        tg.bits(sig, data.draw(st.sampled_from(tg.PROFILES)))
    except Malformed:
        pass


def test_unknown_telegram_is_malformed():
    with pytest.raises(Malformed):
        tg.decode(999, "actual", b"\0" * 20)


def test_table_file_is_plain_json():
    with open(tg._PATH, encoding="utf-8") as f:
        raw = json.load(f)
    assert set(raw) >= {"signals", "telegrams", "bitmaps", "xist2_errors", "velocity_units", "profile_defaults"}


# ---- wiring: hand-built frames through the Analyzer with a FrameMap --------------------------
CTRL, DEV = "00:0e:cf:00:00:01", "00:0e:cf:00:00:02"


def _frame(dst, src, frame_id, csdu, ds=0x35, cc=0):
    mac = lambda m: bytes.fromhex(m.replace(":", ""))  # noqa: E731
    csdu = csdu + b"\0" * max(0, 40 - len(csdu))  # PN-RT pads the C_SDU itself, APDU status stays last
    body = struct.pack(">H", frame_id) + csdu + struct.pack(">HBB", cc & 0xFFFF, ds, 0)
    return mac(dst) + mac(src) + b"\x88\x92" + body


def _maps(telegram=81, in_len=12, source="map"):
    out = FrameMap(frame_id=0x8001, direction="output", controller_mac=CTRL, device_mac=DEV, station="enc1",
                   objects=[DataObject(0, 1, 2, 0, 4, telegram=telegram, telegram_source=source)], source="connect")
    inp = FrameMap(frame_id=0x8000, direction="input", controller_mac=CTRL, device_mac=DEV, station="enc1",
                   objects=[DataObject(0, 1, 2, 0, in_len, telegram=telegram, telegram_source=source)], source="connect")
    return {0x8001: out, 0x8000: inp}


def _analyze(cycles, maps, sink=True):
    events = []
    a = Analyzer(sink=events.append if sink else None)
    a.session.lookup = lambda fid, src, dst: maps.get(fid)
    fn = 0
    for sp, ac, ok in cycles:
        iops = b"\x80" if ok else b"\x00"
        fn += 1
        # the counter advances every cycle (a frame with its predecessor's counter and bytes is a mirror's copy)
        a.feed(fn, fn * 1000, 1, _frame(DEV, CTRL, 0x8001, sp + iops + b"\x80", cc=32 * fn))
        fn += 1
        a.feed(fn, fn * 1000, 1, _frame(CTRL, DEV, 0x8000, ac + iops + b"\x80", cc=32 * fn))
    a.finish()
    return a, events


def test_analyzer_wiring_decodes_pairs_and_checks():
    sp = bytes.fromhex("14002000")
    good = bytes.fromhex("1200 2000 00000005 00000005".replace(" ", ""))
    bad = bytes.fromhex("1000 2000 00000005 00000005".replace(" ", ""))   # control requested missing
    a, ev = _analyze([(sp, good, True)] * 3 + [(sp, bad, True)] * 5 + [(sp, bad, False)] * 2, _maps())
    tel = [e for e in ev if e["kind"] == "telegram"]
    assert len(tel) == 20 and {e["direction"] for e in tel} == {"setpoint", "actual"}
    act = [e for e in tel if e["direction"] == "actual"]
    assert act[0]["signals"]["g1_xist1"] == 5 and act[0]["bits"]["zsw2_enc.control_requested"] == 1
    assert act[0]["station"] == "enc1" and (act[0]["slot"], act[0]["subslot"]) == (1, 2)
    assert [e["judged"] for e in act][-2:] == [False, False]
    viol = [e for e in ev if e["kind"] == "violation"]
    # no PrmEnd in this session: STARTUP-NO-PARAM-RECORD is decided at PrmEnd only (issue #12)
    assert [v["rule"] for v in viol] == ["CTRLREQ-MISMATCH"]
    mism = viol[0]
    assert mism["frame"] == 8 and mism["last_frame"] == 16 and mism["station"] == "enc1"
    s = a.summary()["cyclic"]
    assert s["violations_by_severity"] == {"error": 1, "warning": 0, "info": 0}
    enc = s["encoders"][0]
    assert enc["cycles"] == 8 and enc["gated_cycles"] == 2 and enc["settings"]["telegram"]["value"] == 81
    assert a.counts["malformed"] == 0


def test_analyzer_without_sink_builds_no_telegram_events():
    sp = bytes.fromhex("14002000")
    good = bytes.fromhex("1200 2000 00000005 00000005".replace(" ", ""))
    a, _ = _analyze([(sp, good, True)] * 4, _maps(), sink=False)
    assert "telegram" not in a.kinds and a.summary()["cyclic"]["encoders"][0]["cycles"] == 4


def test_analyzer_length_mismatch_and_short_csdu():
    sp = bytes.fromhex("14002000")
    ac = bytes.fromhex("1200 2000 00000005 00000005 0000".replace(" ", ""))
    _, ev = _analyze([(sp, ac, True)], _maps(telegram=81, in_len=14))
    lm = [e for e in ev if e["kind"] == "violation" and e["rule"] == "TELEGRAM-LENGTH-MISMATCH"]
    assert len(lm) == 1 and lm[0]["side"] == "encoder" and "12 bytes" in lm[0]["message"]
    # a map that points past the C_SDU makes the frame malformed, with a reason
    maps = _maps()
    maps[0x8000].objects[0].offset = 36
    a, ev = _analyze([(sp, ac, True)], maps)
    assert a.counts["malformed"] == 1
    assert any(e["kind"] == "malformed" and e["layer"] == "telegram" for e in ev)


def test_analyzer_reports_xist2_error_words():
    sp = bytes.fromhex("1400A000")
    err = bytes.fromhex("1200 8000 00000005 00000F02".replace(" ", ""))
    _, ev = _analyze([(sp, err, True)] * 2, _maps())
    act = [e for e in ev if e["kind"] == "telegram" and e["direction"] == "actual"]
    assert act[0]["xist2_error"]["code"] == 0x0F02 and "sign-of-life" in act[0]["xist2_error"]["text"]
    assert act[0]["bits"]["g1_zsw.sensor_error"] == 1
    assert any(e["kind"] == "state" and e["state"] == "sensor_error" and e["value"] == 0x0F02 for e in ev)


def test_report_sections_render():
    from rich.console import Console
    sp = bytes.fromhex("14002000")
    bad = bytes.fromhex("1000 2000 00000005 00000005".replace(" ", ""))
    good = bytes.fromhex("1200 2000 00000005 00000005".replace(" ", ""))   # control requested: V4.1 (no 0xBF00 says it)
    a, _ = _analyze([(sp, good, True)] + [(sp, bad, True)] * 5, _maps())
    con = Console(record=True, width=200)
    for sec in a.cyclic.report_sections():
        con.print(sec)
    text = con.export_text()
    assert "CTRLREQ-MISMATCH" in text and "Settings in force" in text and "enc1" in text


def test_records_before_the_first_cyclic_frame_are_replayed():
    # a 0xBF00 written before any cyclic frame configures the checker (compat = 0: CREQ must be 0)
    sp = bytes.fromhex("14002000")
    ac = bytes.fromhex("1200 2000 00000005 00000005".replace(" ", ""))
    events = []
    a = Analyzer(sink=events.append)
    maps = _maps()
    a.session.lookup = lambda fid, src, dst: maps.get(fid)
    a.cyclic.on_record({"frame": 1, "ts_ns": 1, "kind": "record", "op": "write", "index": 0xBF00, "length": 31,
                        "device_mac": DEV, "data": "00" * 31, "decoded": {"compat": 0, "class4": 1, "problems": []}})
    for fn in range(2, 8, 2):
        a.feed(fn, fn, 1, _frame(DEV, CTRL, 0x8001, sp + b"\x80\x80"))
        a.feed(fn + 1, fn + 1, 1, _frame(CTRL, DEV, 0x8000, ac + b"\x80\x80"))
    a.finish()
    rules = {e["rule"] for e in events if e["kind"] == "violation"}
    assert "CTRLREQ-SET-IN-COMPAT" in rules and "STARTUP-NO-PARAM-RECORD" not in rules
    enc = a.summary()["cyclic"]["encoders"][0]
    assert enc["settings"]["compat"]["value"] == 0 and "0xBF00" in enc["settings"]["compat"]["source"]
