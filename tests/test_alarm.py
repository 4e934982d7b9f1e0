"""Alarm (RTA) decoder: synthetic DATA/ACK/NACK/ERR PDUs checked against tshark, names of the
encoder channel error types, Malformed cases and property tests."""
import os
import struct

import pytest
from hypothesis import given, settings, strategies as st

from pndiss.analyzer import Analyzer, analyze_file
from pndiss.proto import alarm
from pndiss.proto.common import Malformed
from synframes import (block, channel_item, ext_channel_item, notification, pn_rt, rta, write_pcap)
from tsharkdiff import compare, load_maps, need_tshark

APPEARS, DISAPPEARS = 0x0800, 0x1000  # ChannelProperties.Specifier 1 / 2, failure, whole submodule
# Diagnosis appears: Lika "commissioning diagnostic" 0x9011 on the whole submodule (channel 0x8000)
DIAG_APPEARS = rta(0x11, 0x11, 0, 0xFFFE, notification(0x0001, 0xA801, channel_item(0x8000, APPEARS, 0x9011)))
# same fault with ExtChannelDiagnosis, plus a plain channel item behind its own USI
DIAG_EXT = rta(0x11, 0x11, 1, 0xFFFE, notification(
    0x0001, 0xA802, ext_channel_item(0x8000, APPEARS, 0x9011, 0x8000, 7) + channel_item(1, 0x2905, 0x9000)))
# Diagnosis disappears: alarm type 0x000C, specifier bits cleared, items with Specifier 2
DIAG_GONE = rta(0x11, 0x11, 2, 0xFFFE, notification(
    0x000C, 0x0003, ext_channel_item(0x8000, DISAPPEARS, 0x9011, 0x8000, 0) + channel_item(0x8000, DISAPPEARS, 0x9000)))
# network diagnosis (remote mismatch, no peer) and a manufacturer USI, on the high-priority CR
REMOTE = rta(0x11, 0x11, 3, 0xFFFE, notification(
    0x0001, 0xA804, ext_channel_item(0x8000, APPEARS, 0x8001, 0x8005, 0)
    + ext_channel_item(1, APPEARS, 0x8000, 0x8000, 0) + ext_channel_item(1, APPEARS, 0x7FFF, 1, 0)
    + ext_channel_item(1, APPEARS, 0x0010, 0x8000, 5)))
MANUF = rta(0x11, 0x11, 4, 0xFFFE, notification(0x0002, 0x1005, struct.pack(">H", 0x0042) + b"\x01\x02\x03",
                                                 high=True))
QUALIFIED = rta(0x11, 0x11, 5, 0xFFFE, notification(
    0x0001, 0xA806, struct.pack(">HHHHHII", 0x8003, 1, 0x0600, 0x0100, 0x8000, 0, 1 << 7)))
# MaintenanceItem (block 0x0F00, demanded + required) then a channel item; undecoded USIs
MAINT = rta(0x11, 0x11, 7, 0xFFFE, notification(
    0x0001, 0xA807, struct.pack(">HHHBBHI", 0x8100, 0x0F00, 8, 1, 0, 0, 3) + channel_item(1, APPEARS, 0x0001)))
MULTIPLE = rta(0x11, 0x11, 8, 0xFFFE, notification(0x0001, 0xA808, struct.pack(">H", 0x8001) + b"\1\2\3\4"))
PROFILE_USI = rta(0x11, 0x11, 9, 0xFFFE, notification(0x0001, 0xA809, struct.pack(">H", 0x9000) + b"\1\2\3\4"))
ACK_BLOCK = rta(0x11, 0x01, 6, 2, block(0x8002, struct.pack(">HIHHH", 0x0001, 0x3D00, 1, 1, 0xA801) + bytes(4)))
RTA_ACK = rta(0x13, 0x01, 0xFFFF, 0)
RTA_NACK = rta(0x12, 0x01, 0xFFFF, 0)
RTA_ERR = rta(0x14, 0x01, 0xFFFF, 0xFFFE, bytes.fromhex("cf81fd05"))

PDUS = [(0xFE01, DIAG_APPEARS), (0xFE01, DIAG_EXT), (0xFE01, DIAG_GONE), (0xFE01, REMOTE), (0xFC01, MANUF),
        (0xFE01, QUALIFIED), (0xFE01, MAINT), (0xFE01, MULTIPLE), (0xFE01, PROFILE_USI), (0xFE01, ACK_BLOCK), (0xFE01, RTA_ACK), (0xFE01, RTA_NACK), (0xFE01, RTA_ERR)]


def test_synthetic_alarms_match_tshark(tmp_path):
    need_tshark()
    path = write_pcap(os.path.join(tmp_path, "alarm.pcap"), [pn_rt(fid, pdu) for fid, pdu in PDUS])
    compared, diffs = compare(path, [m for m in load_maps() if m["kind"] == "alarm"])
    assert not diffs, "\n".join(diffs[:20])
    assert compared > 330


def test_diagnosis_appears_lika_9011():
    d = alarm.decode(DIAG_APPEARS, 0, 0xFE01)
    assert d["pdu_type_name"] == "DATA-RTA-PDU" and d["priority"] == "low"
    assert d["window_size"] == 1 and d["tack"] == 1 and d["ack_seq_num"] == 0xFFFE
    assert d["alarm_type_name"] == "Diagnosis" and d["api"] == 0x3D00
    sp = d["alarm_specifier"]
    assert (sp["sequence"], sp["channel"], sp["manufacturer"], sp["submodule"], sp["ardiagnosis"]) == (1, 1, 0, 1, 1)
    (item,) = d["items"]
    assert item["usi_name"] == "ChannelDiagnosis" and item["channel_number"] == 0x8000
    assert item["channel_properties"]["specifier_name"] == "Appears"
    assert item["channel_error_type_name"] == "Electromag interference too high"  # tshark's PA text
    assert item["encoder_error"].startswith("Commissioning diagnostic")         # the encoder meaning


def test_ext_and_disappears():
    d = alarm.decode(DIAG_EXT, 0, 0xFE01)
    ext, plain = d["items"]
    assert ext["usi_name"] == "ExtChannelDiagnosis" and ext["ext_channel_add_value"] == 7
    assert ext["ext_channel_error_type"] == 0x8000  # 0x9011 >= 0x7FFF: tshark's plain field
    assert plain["encoder_error"].startswith("Memory error")
    assert plain["channel_properties"]["direction_name"] == "Input"
    g = alarm.decode(DIAG_GONE, 0, 0xFE01)
    assert g["alarm_type_name"] == "Diagnosis disappears"
    assert {i["channel_properties"]["specifier_name"] for i in g["items"]} == {"Disappears"}
    assert g["alarm_specifier"]["channel"] == 0 and g["alarm_specifier"]["sequence"] == 3
    r = alarm.decode(REMOTE, 0, 0xFE01)["items"]
    assert r[0]["ext_channel_error_type_name"] == "No peer detected"
    assert r[1]["ext_channel_error_type0800"] == 0x8000
    assert r[3]["ext_channel_error_type_name"] == "Accumulative Info"


def test_manufacturer_ack_err():
    m = alarm.decode(MANUF, 0, 0xFC01)
    assert m["priority"] == "high" and m["block"]["name"] == "Alarm Notification High"
    assert m["alarm_type_name"] == "Process" and m["items"][0]["data"] == "010203"
    assert m["alarm_specifier"]["manufacturer"] == 1
    a = alarm.decode(ACK_BLOCK, 0, 0xFE01)
    assert a["block"]["name"] == "Alarm Ack Low" and a["status"]["ok"]
    e = alarm.decode(RTA_ERR, 0, 0xFE01)
    assert e["pdu_type_name"] == "ERR-RTA-PDU" and not e["status"]["ok"]
    assert "AR consumer DHT/WDT expired" in e["status"]["text"]
    assert alarm.decode(RTA_NACK, 0, 0xFE01)["pdu_type_name"] == "NACK-RTA-PDU"
    mt = alarm.decode(MAINT, 0, 0xFE01)["items"]
    assert mt[0]["maintenance_status"] == {"value": 3, "required": 1, "demanded": 1}
    assert mt[1]["channel_error_type_name"] == "Short circuit"
    assert alarm.decode(PROFILE_USI, 0, 0xFE01)["items"][0]["usi_name"] == "Reserved for profiles"
    q = alarm.decode(QUALIFIED, 0, 0xFE01)["items"][0]
    assert q["qualified_channel_qualifier"] == 1 << 7 and q["channel_properties"]["maintenance"] == 3


def test_analyzer_emits_alarm_event():
    events = []
    a = Analyzer(sink=events.append)
    a.feed(1, 0, 1, pn_rt(0xFE01, DIAG_APPEARS))
    (ev,) = [e for e in events if e["kind"] == "alarm"]
    assert ev["frame"] == 1 and ev["items"][0]["channel_error_type"] == 0x9011


@pytest.mark.parametrize("pdu, why", [
    (DIAG_APPEARS[:10], "RTA header"),
    (DIAG_APPEARS[:-3], "VarPartLen"),
    (rta(0x14, 0x01, 0xFFFF, 0xFFFE, b"\xcf\x81"), "PNIOStatus"),
    (rta(0x11, 0x11, 0, 0, notification(1, 0xA801, channel_item(1, APPEARS, 1))[:-2]), "block length"),
    (rta(0x11, 0x11, 0, 0, notification(1, 0xA801, struct.pack(">HHH", 0x8000, 1, 2))), "ChannelDiagnosis"),
    (rta(0x11, 0x11, 0, 0, block(0x0002, bytes(10))), "alarm header"),
])
def test_malformed(pdu, why):
    with pytest.raises(Malformed) as e:
        alarm.decode(pdu, 0, 0xFE01)
    assert why in e.value.reason and e.value.layer == "alarm"


def _check(data):
    try:
        out = alarm.decode(data, 0, 0xFE01)
    except Malformed:
        return
    assert isinstance(out, dict)


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=120))
def test_random_bytes(data):
    _check(data)


@settings(max_examples=300, deadline=None)
@given(st.sampled_from([p for _, p in PDUS]), st.integers(0, 120), st.integers(0, 120), st.integers(0, 255))
def test_truncated_and_mutated(pdu, cut, pos, val):
    _check(pdu[:cut])
    if pos < len(pdu):
        _check(pdu[:pos] + bytes([val]) + pdu[pos + 1:])


# -- alarms of a capture reach the encoder axes (#48): resends, other submodules, the plugin ---------------

def test_alarm_while_parked_in_a_capture(tmp_path):
    """A diagnosis alarm of the parked encoder's submodule is PARK-ERROR-REPORTED once, although the RTA sends
    it twice (same sequence number); one of another subslot is not the encoder's. Both paths and the plugin."""
    import shutil

    import capedit
    from pndiss.settings import Settings
    from synframes import eth
    from test_fastpath import _same_both_ways
    src = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "captures", "parking-t81-scancon.pcapng")
    if not os.path.exists(src):
        pytest.skip("captures/parking-t81-scancon.pcapng is missing")
    dev, plc = bytes.fromhex("020000000101"), bytes.fromhex("020000000001")   # parked from frame 664 to 1264

    def alarm_frame(seq, subslot):
        pdu = rta(0x11, 0x11, seq, 0xFFFE, notification(0x0001, 0xA801, channel_item(0x8000, APPEARS, 0x9000),
                                                          subslot=subslot))
        return eth(0x8892, struct.pack(">H", 0xFE01) + pdu, src=dev, dst=plc)
    path = str(tmp_path / "parked-alarm.pcapng")
    capedit.insert(src, path, {800: [alarm_frame(7, 2)],     # the encoder submodule (slot 1 / subslot 2)
                               850: [alarm_frame(7, 2)],     # the RTA's resend of it (not acknowledged yet)
                               900: [alarm_frame(8, 1)]})    # the next alarm: another submodule of the device
    _same_both_ways(path)
    evs = []
    analyze_file(path, Settings(), sink=lambda e: evs.append(e) if e["kind"] == "violation" else None)
    assert [(e["rule"], e["frame"]) for e in evs if e["rule"] == "PARK-ERROR-REPORTED"] == [("PARK-ERROR-REPORTED", 801)]
    if shutil.which("tshark"):
        from test_lua_plugin import compare as plugin_compare
        n, bad, lua_viol, viol = plugin_compare(path)
        assert n and not bad and lua_viol == viol and (801, "PARK-ERROR-REPORTED") in lua_viol
