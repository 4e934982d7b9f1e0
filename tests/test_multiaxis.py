"""A device with several encoders in one AR (behaviour/network.md §1.7: one Encoder Object per module): all
their setpoints travel in one output frame and all their actual values in one input frame. Each axis is
judged on its own, by the reference path, the engine (which must pair across the two shared streams in
capture order) and the plugin in real tshark."""
from __future__ import annotations

import shutil
import struct

import pytest

import rpc_frames as R
from pndiss.analyzer import analyze_file
from pndiss.settings import Settings

MAP_IDENT, T81_IDENT = 0xFFFF, 0x1051


def _pcap(path, frames, step_us=500):
    with open(path, "wb") as f:
        f.write(struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, 1))
        for i, fr in enumerate(frames):
            t = 1_700_000_000_000_000 + i * step_us
            f.write(struct.pack("<IIII", t // 1_000_000, t % 1_000_000, len(fr), len(fr)) + fr)


def multiaxis_capture(path, slots=(1, 2), cycles=300, fault_slot=None, fault_from=150, io_slot=None, api=0x3D00,
                      tel_subslot=2, bf00=None, param_fault_slot=None, lengths=(12, 4), ar_type=1, backup=None,
                      backup_zero=True, in_every=1):
    """A Connect of encoders in ``slots`` (telegram 81, 4 bytes out / 12 in, guessed from lengths on the
    encoder API), optionally an ordinary 2-byte input module in ``io_slot``, PrmEnd, then ``cycles`` cycles
    of a correct V4.1 encoder per slot; ``fault_slot`` holds control requested at 0 from ``fault_from``; ``bf00``:
    slot -> the 0xBF00 record written to that module before PrmEnd; ``param_fault_slot`` reports a
    parameterisation fault (G1_ZSW.15 with G1_XIST2 0x1002, cyclic.md §9) all along; ``lengths``: (in, out)
    bytes of each telegram submodule (the telegram 81 words cut or zero-padded to them); ``ar_type`` of the
    Connect; ``backup``: (first, end) cycles whose output frames say Backup (DataStatus 0x34), with zero setpoints
    unless not ``backup_zero``; ``in_every``: the input CR's reduction ratio against the output CR's 1 (an input
    frame every that many cycles)."""
    subs = []
    for s in slots:
        subs += [(s, 1, MAP_IDENT, 0, 0, 0)] if tel_subslot != 1 else []
        subs += [(s, tel_subslot, T81_IDENT, 3, *lengths)]
    if io_slot is not None:
        subs.append((io_slot, 1, 0x0321, 1, 2, 0))
    req, res = R.connect_pair(subs, api=api, ar_type=ar_type, rr=(in_every, 1))
    frames = [req, res]
    for k, (slot, data) in enumerate((bf00 or {}).items()):   # each module's user parameters (0xBF00)
        frames += R.write_pair(0xBF00, data, seq=2 + k, api=api, slot=slot)
    frames += R.prm_end_pair(seq=10)
    for i in range(cycles):
        sol = i % 15 + 1
        out, inp, iocs_in, iocs_out = b"", b"", b"", b""
        for s in slots:
            creq = 0 if (s == fault_slot and i >= fault_from) else 0x0200
            held = backup_zero and backup is not None and backup[0] <= i < backup[1]
            sp = bytes(4) if held else struct.pack(">HH", 0x0400 | sol << 12, 0)
            out += sp[:lengths[1]].ljust(lengths[1], b"\0") + b"\x80"
            g1zsw, x2 = (0x8000, 0x1002) if s == param_fault_slot else (0, 0)
            inp += struct.pack(">HHII", creq | sol << 12, g1zsw, 1000 * s + i, x2)[:lengths[0]].ljust(lengths[0], b"\0") + b"\x80"
        if io_slot is not None:
            inp += struct.pack(">H", i) + b"\x80"
        in_bytes, out_bytes = _layout(subs, inp, out)
        out_ds = 0x34 if backup is not None and backup[0] <= i < backup[1] else 0x35
        streams = [(R.CONTROLLER_MAC, R.DEVICE_MAC, 0x8001, out_bytes, out_ds)]
        if i % in_every == 0:
            streams.append((R.DEVICE_MAC, R.CONTROLLER_MAC, 0x8000, in_bytes, 0x35))
        for src, dst, fid, sdu, ds in streams:
            frames.append(R.eth(src, dst, struct.pack(">H", fid) + sdu.ljust(40, b"\0")
                                + struct.pack(">HBB", i * 32 % 65536, ds, 0), 0x8892))
    _pcap(path, frames)
    return path


def _layout(subs, inp, out):
    """C_SDUs as connect_pair's offsets put them: the input frame holds each input submodule's data + IOPS in
    the order of ``subs`` then an IOCS per output submodule; the output frame the reverse."""
    in_b, out_b = b"", b""
    ii = oi = 0
    for _slot, _ss, _ident, typ, in_len, out_len in subs:
        if typ in (0, 1, 3):
            n = in_len if typ else 0
            in_b += inp[ii:ii + n] + b"\x80"
            ii += n + (1 if n else 0)
        if typ in (2, 3):
            out_b += out[oi:oi + out_len] + b"\x80"
            oi += out_len + 1
    n_out = sum(1 for s in subs if s[3] in (2, 3))
    n_in = sum(1 for s in subs if s[3] in (0, 1, 3))
    return in_b + b"\x80" * n_out, out_b + b"\x80" * n_in


def _violations(path):
    evs = []
    a = analyze_file(path, Settings(), sink=lambda e: evs.append(e) if e["kind"] == "violation" else None)
    return [(e["rule"], e.get("slot"), e["frame"]) for e in evs], a


@pytest.mark.parametrize("fault_slot", [None, 1, 2])
def test_each_axis_of_a_shared_frame_is_judged(tmp_path, fault_slot):
    from test_fastpath import _same_both_ways
    path = multiaxis_capture(str(tmp_path / "two.pcap"), fault_slot=fault_slot, io_slot=3)
    viol, a = _violations(path)
    axes = a.summary()["cyclic"]["encoders"]
    # no 0xBF00 is written: each axis reports that at PrmEnd (frame 3)
    want = [("STARTUP-NO-PARAM-RECORD", 1, 3), ("STARTUP-NO-PARAM-RECORD", 2, 3)]
    if fault_slot is not None:
        want.append(("CTRLREQ-MISMATCH", fault_slot, 5 + 2 * 150 + 1))
    assert viol == want
    assert [(x["slot"], x["cycles"], x["lost_cycles"]) for x in axes] == [(1, 300, 0), (2, 300, 0)]
    _same_both_ways(path)   # the engine pairs both axes across the two shared streams
    if shutil.which("tshark"):
        from test_lua_plugin import compare as plugin_compare
        n, bad, lua_viol, py_viol = plugin_compare(path)
        assert n and not bad and lua_viol == py_viol, bad[:5]


@pytest.mark.parametrize("api, tel_subslot, lengths, judged", [(0, 2, (12, 4), True), (0, 1, (12, 4), False),
                                                             (0x3A00, 2, (4, 4), False), (0x3D00, 2, (4, 4), True)])
def test_length_guess_off_the_encoder_api(tmp_path, api, tel_subslot, lengths, judged):
    """On API 0 a 4/12-byte submodule behind an access point (subslot 2) is guessed telegram 81; one in subslot 1
    is a plain IO module's data (an analog module of an IO device), not an encoder. 4/4 bytes are PS/PSM's
    telegram 87 on the encoder API, drive telegram 1 on the PROFIdrive API -- in the core and the plugin."""
    path = multiaxis_capture(str(tmp_path / "api0.pcap"), slots=(1,), fault_slot=1, api=api, tel_subslot=tel_subslot,
                             lengths=lengths)
    viol, a = _violations(path)
    cyc = a.summary()["cyclic"]
    if judged and lengths == (4, 4):
        assert [e["telegram"] for e in cyc["encoders"]] == [87]
    elif judged:
        assert ("CTRLREQ-MISMATCH", 1, 306) in viol and len(cyc["encoders"]) == 1
    else:
        assert viol == [] and cyc["encoders"] == [] and cyc["frames_no_telegram"] == 600
    if shutil.which("tshark"):
        from test_lua_plugin import compare as plugin_compare
        n, bad, lua_viol, py_viol = plugin_compare(path)
        assert (n > 0) == judged and not bad and lua_viol == py_viol, bad[:5]


def _bf00(flags, mupr, tmr):
    """A valid 0xBF00 (V4.1: compat bit 5 set; one tolerated master sign-of-life failure; rpm)."""
    return bytes([flags | 0x20]) + struct.pack(">QQ", mupr, tmr) + bytes([1, 0]) + bytes(12)


def test_each_module_takes_its_own_user_parameters(tmp_path):
    """0xBF00 written per module with different settings: each axis is configured by its own slot's record (one
    Encoder Object per module, network.md §1.7), in the core and the plugin."""
    records = {1: _bf00(0x0A, 4096, 4096 * 8), 2: _bf00(0x01, 1000, 2000)}   # class 4 + scaling / CCW, no scaling
    path = multiaxis_capture(str(tmp_path / "bf00.pcap"), bf00=records)
    viol, a = _violations(path)
    assert viol == []
    got = {e["slot"]: {k: e["settings"][k] for k in ("class4", "scaling", "direction", "mupr", "tmr")}
           for e in a.summary()["cyclic"]["encoders"]}
    assert {s: {k: v["value"] for k, v in d.items()} for s, d in got.items()} == {
        1: {"class4": 1, "scaling": 1, "direction": 0, "mupr": 4096, "tmr": 32768},
        2: {"class4": 0, "scaling": 0, "direction": 1, "mupr": 1000, "tmr": 2000}}
    assert got[1]["mupr"]["source"] == "captured 0xBF00 (frame 3)" and got[2]["mupr"]["source"] == "captured 0xBF00 (frame 5)"
    from test_fastpath import _same_both_ways
    _same_both_ways(path)
    if shutil.which("tshark"):
        from test_lua_plugin import compare as plugin_compare
        n, bad, lua_viol, py_viol = plugin_compare(path)
        assert n and not bad and lua_viol == py_viol, bad[:5]


@pytest.mark.parametrize("reported", [False, True])
def test_an_invalid_record_of_one_module_is_that_axis_fault(tmp_path, reported):
    """Slot 2's 0xBF00 is invalid (MUPR 0). Its encoder runs on without reporting it: BF00-ERROR-NOT-REPORTED for
    that axis only; or it reports the fault (0x1002): nothing more. Slot 1's valid record stays in force for
    slot 1 either way: it is not blamed for slot 2's record (the plugin too)."""
    records = {1: _bf00(0x0A, 4096, 4096 * 8), 2: _bf00(0x00, 0, 2000)}
    path = multiaxis_capture(str(tmp_path / "bad2.pcap"), bf00=records, param_fault_slot=2 if reported else None)
    viol, _a = _violations(path)
    want = {("BF00-VALUE-OUT-OF-RANGE", 2)} | (set() if reported else {("BF00-ERROR-NOT-REPORTED", 2)})
    assert {(r, s) for r, s, _f in viol} == want
    if shutil.which("tshark"):
        from test_lua_plugin import compare as plugin_compare
        n, bad, lua_viol, py_viol = plugin_compare(path)
        assert n and not bad and lua_viol == py_viol, (bad[:5], lua_viol, py_viol)


@pytest.mark.parametrize("ar_type, zero, judged", [(0x0020, True, False), (0x0001, True, True), (0x0020, False, False)])
def test_backup_frames_of_a_redundant_ar_are_not_judged(tmp_path, ar_type, zero, judged):
    """System redundancy (ARType 0x0020): while its controller holds the AR as backup, the output frames say
    Backup (DataStatus.State 0, wire.md §2.3) and the device acts on the primary's: zero setpoints there are no
    cycles of the encoder. An ordinary AR's State bit is not looked at: the same frames are judged. Backup frames
    with the primary's setpoints (steady: the engine's vectorised mask) are not judged either."""
    from test_fastpath import _same_both_ways
    path = multiaxis_capture(str(tmp_path / "sr.pcap"), slots=(1,), ar_type=ar_type, backup=(100, 160),
                             backup_zero=zero, cycles=2000)
    viol, a = _violations(path)
    rules = {r for r, _s, _f in viol} - {"STARTUP-NO-PARAM-RECORD"}
    assert bool(rules) == judged, viol
    enc = a.summary()["cyclic"]["encoders"][0]
    assert enc["gated_cycles"] == (0 if judged else 60)
    _same_both_ways(path)
    if shutil.which("tshark"):
        from test_lua_plugin import compare as plugin_compare
        n, bad, lua_viol, py_viol = plugin_compare(path)
        assert n and not bad and lua_viol == py_viol, bad[:5]


@pytest.mark.parametrize("in_every", [2, 4])
def test_input_cr_slower_than_the_output_cr(tmp_path, in_every):
    """Input ReductionRatio 2 or 4 against the outputs' 1: several setpoints per actual value, the device acting on
    the latest; that is no lost cycle, and the windowed rules (CTRLREQ-MISMATCH here) still see their windows."""
    from test_fastpath import _same_both_ways
    path = multiaxis_capture(str(tmp_path / "rr.pcap"), slots=(1,), fault_slot=1, fault_from=300, cycles=1200,
                             in_every=in_every)
    viol, a = _violations(path)
    assert "CTRLREQ-MISMATCH" in {r for r, _s, _f in viol}, viol
    assert a.summary()["cyclic"]["encoders"][0]["lost_cycles"] == 0
    clean = multiaxis_capture(str(tmp_path / "rr-ok.pcap"), slots=(1,), cycles=1200, in_every=in_every)
    assert {r for r, _s, _f in _violations(clean)[0]} == {"STARTUP-NO-PARAM-RECORD"}
    _same_both_ways(path)
    if shutil.which("tshark"):
        from test_lua_plugin import compare as plugin_compare
        n, bad, lua_viol, py_viol = plugin_compare(path)
        assert n and not bad and lua_viol == py_viol, bad[:5]
