"""APDU status gates judging: a frame whose TransferStatus is not 0 was damaged on its way (tshark: "ignore this
frame", wire.md §2.3); like DataValid 0 or a provider in STOP its data is not judged (rt.judgeable), by the
reference path, the engine (streamcols) and the plugin."""
from __future__ import annotations

import shutil
import struct

from pndiss.analyzer import analyze_file
from pndiss.proto.rt import judgeable
from pndiss.settings import Settings
from test_linktypes import _frames
from test_multiaxis import multiaxis_capture


def test_judgeable():
    assert judgeable(0x35, 0) and judgeable(0x14, 0)
    assert not judgeable(0x35, 1) and not judgeable(0x35, 0x80)
    assert not judgeable(0x31, 0) and not judgeable(0x25, 0)   # DataValid 0 / provider STOP


def test_frames_with_transfer_status_are_not_judged(tmp_path):
    from test_fastpath import _same_both_ways
    src = multiaxis_capture(str(tmp_path / "ok.pcap"), slots=(1,))
    out = str(tmp_path / "xs.pcap")
    damaged = 0
    with open(out, "wb") as f:
        f.write(struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, 1))
        for fn, (sec, usec, fr) in enumerate(_frames(src), 1):
            if 200 <= fn < 220 and fr[12:14] == b"\x88\x92" and fr[6:12] == bytes.fromhex("020000000101"):
                # the device's frame: data zeroed (CREQ 0, sign-of-life 0) and TransferStatus 1
                fr = fr[:16] + bytes(12) + fr[28:-1] + b"\x01"
                damaged += 1
            elif 400 <= fn < 440 and fr[12:14] == b"\x88\x92" and fr[6:12] == bytes.fromhex("020000000101"):
                fr = fr[:-1] + b"\x80"   # data as sent: only the TransferStatus says "ignore" (the engine's bulk mask)
                damaged += 1
            f.write(struct.pack("<IIII", sec, usec, len(fr), len(fr)) + fr)
    assert damaged == 30
    evs = []
    a = analyze_file(out, Settings(), sink=lambda e: evs.append(e) if e["kind"] == "violation" else None)
    assert [e["rule"] for e in evs] == ["STARTUP-NO-PARAM-RECORD"]
    assert a.summary()["cyclic"]["encoders"][0]["gated_cycles"] == 30
    _same_both_ways(out)
    if shutil.which("tshark"):
        from test_lua_plugin import compare as plugin_compare
        n, bad, lua_viol, py_viol = plugin_compare(out)
        assert n and not bad and lua_viol == py_viol, bad[:5]
