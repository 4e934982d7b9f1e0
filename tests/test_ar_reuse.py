"""A controller that connects again with the AR UUID of its earlier connection. The axis goes on, but
each connection is judged on its own: the second needs its own 0xBF00 before PrmEnd (#66), its parameter
requests may start their references again (#78), and its 0xBF00 is compared with the first's (#31)."""
from __future__ import annotations

import os
import shutil
import uuid

import pytest

import capedit
from pndiss.analyzer import analyze_file
from pndiss.capture import open_capture
from pndiss.settings import Settings
from pndiss.sim.pcapng import Writer


def _events(path, fast=False, kinds=("violation", "ar", "record")):
    evs = []
    analyze_file(path, Settings(fast_path=fast), sink=lambda e: evs.append(e) if e["kind"] in kinds else None)
    return evs


@pytest.fixture(scope="module")
def caps(tmp_path_factory):
    """The simulated restart (two AR UUIDs); the same with the second connection's UUID replaced by the
    first's; and that with the second connection's 0xBF00 write (request and response) dropped."""
    tmp = str(tmp_path_factory.mktemp("reuse"))
    src = capedit.simulate(os.path.join(tmp, "two.pcapng"), "--scenario", "preset", "--cycles", "600",
                           "--restart", "300", "--records", "plain")
    evs = _events(src, kinds=("ar", "record", "record_result"))
    first, second = [uuid.UUID(e["ar_uuid"]).bytes for e in evs if e["kind"] == "ar"]
    bf00 = [e for e in evs if e["kind"] == "record" and e["index"] == 0xBF00]
    assert len(bf00) == 2
    frames = [(ts, bytes(d).replace(second, first)) for _fn, ts, _lt, d in open_capture(src)]
    res = [e["frame"] for e in evs if e["kind"] == "record_result" and e.get("request_frame") == bf00[1]["frame"]]
    drop = {bf00[1]["frame"], *res}   # the write request and its response (a lost request alone proves nothing lost)
    assert len(drop) == 2
    out = {"two": src}
    for name, keep in (("same", lambda i: True), ("same-no-bf00", lambda i: i not in drop)):
        out[name] = os.path.join(tmp, name + ".pcapng")
        with open(out[name], "wb") as f:
            w = Writer(f)
            for i, (ts, d) in enumerate(frames, 1):
                if keep(i):
                    w.write(ts, d)
    return out


def _rules(path, fast=False):
    return [(e["rule"], e["frame"]) for e in _events(path, fast, ("violation",))]


def test_reused_uuid_judged_like_two_connections(caps):
    assert first_ar_twice(caps["same"])
    assert _rules(caps["same"]) == _rules(caps["two"]) == []
    assert _rules(caps["same"], fast=True) == []


def test_second_connection_needs_its_own_bf00(caps):
    for fast in (False, True):
        got = _rules(caps["same-no-bf00"], fast)
        assert [r for r, _f in got] == ["STARTUP-NO-PARAM-RECORD"], got


def first_ar_twice(path) -> bool:
    ars = [e["ar_uuid"] for e in _events(path, kinds=("ar",))]
    return len(ars) == 2 and ars[0] == ars[1]


@pytest.mark.skipif(shutil.which("tshark") is None, reason="tshark not installed")
def test_plugin_same(caps):
    from test_lua_plugin import rule_rows
    assert rule_rows(caps["same"]) == set()
    assert {(f, r) for f, r, _d in rule_rows(caps["same-no-bf00"])} == \
        {(f, r) for r, f in _rules(caps["same-no-bf00"])}


def test_lua_checker_replays_the_new_connection(caps):
    """Checker.new_connection through the Lua port (tests/luachk): the same violations and state."""
    from luachk.record import LUA, Recorder, replay
    if shutil.which(LUA) is None:
        pytest.skip(f"{LUA} not installed")
    for name in ("same", "same-no-bf00"):
        with Recorder() as rec:
            analyze_file(caps[name], Settings(fast_path=False))
        assert any(op["op"] == "newconn" for op in rec.ops)
        res = replay(rec)
        assert not res["problems"], res["problems"][:10]


# -- a power cycle: the device restarts without a Release, the controller connects again ---------------

@pytest.mark.parametrize("ar_type", (None, 0x0003, 0x0020), ids=("iocar", "iocarcir", "iocarsr"))
def test_power_cycle_is_no_capture_loss(caps, tmp_path, ar_type):
    """The restart with its Release lost (the encoder lost power; the link went down): the controller's new
    Connect ends the AR it held with the device (aborted at the response), and the device's streams, which
    may start the new AR's cycle counter before that response, are no capture loss (the helper audit's
    power_cycle: two capture gaps of ~2,000 cycles, and the first AR in data exchange for ever)."""
    evs = _events(caps["two"], kinds=("rpc",))
    release = {e["frame"] for e in evs if e.get("opnum") == 1}
    assert len(release) == 4   # two Releases: request and response each
    last_two = sorted(release)[:2]   # the first AR's Release
    second = sorted(e["frame"] for e in evs if e.get("opnum") == 0)[2]   # the second Connect's request
    path = str(tmp_path / "power-cycle.pcapng")
    renum = capedit.rewrite(caps["two"], path, lambda fn, _d: fn not in last_two)
    if ar_type is not None:   # the second AR of another AR type with IOCRs (CiR, system redundancy): it replaces too
        import struct
        src, path = path, str(tmp_path / "power-cycle-artype.pcapng")
        with open(path, "wb") as f:
            w = Writer(f)
            for fn, ts, _lt, d in open_capture(src):
                d = bytearray(d)
                if fn == renum[second]:
                    assert d[142:144] == b"\x01\x01"   # the ARBlockReq right after the NDR header
                    d[148:150] = struct.pack(">H", ar_type)
                w.write(ts, bytes(d))
    kinds = ("violation", "capture_gap", "ar_phase")
    for fast in (False, True):
        got = _events(path, fast, kinds)
        assert not [e for e in got if e["kind"] == "capture_gap"]
        phases = [(e["phase"], e.get("cause", "")) for e in got if e["kind"] == "ar_phase"]
        assert phases.count(("aborted", phases[3][1])) == 1 and phases[3][1].startswith("a new Connect")
        want = [(e["rule"], renum[e["frame"]]) for e in _events(caps["two"], fast, ("violation",))]
        assert [(e["rule"], e["frame"]) for e in got if e["kind"] == "violation"] == want


@pytest.mark.skipif(shutil.which("tshark") is None, reason="tshark not installed")
def test_power_cycle_plugin_same(caps, tmp_path):
    from test_lua_plugin import compare
    evs = _events(caps["two"], kinds=("rpc",))
    first_release = sorted(e["frame"] for e in evs if e.get("opnum") == 1)[:2]
    path = str(tmp_path / "power-cycle.pcapng")
    capedit.rewrite(caps["two"], path, lambda fn, _d: fn not in first_release)
    n, bad, lua_viol, viol = compare(path)
    assert n and not bad, bad[:5]
    assert lua_viol == viol


@pytest.mark.parametrize("ar_type,iocrs,aborts", [(0x0006, False, False), (0x0001, False, False)],
                         ids=("supervisor-ar", "io-ar-without-iocrs"))
def test_a_connect_beside_the_ar_does_not_end_it(tmp_path, ar_type, iocrs, aborts):
    """A SoftPLC's engineering tool opens an AR from the controller's MAC (a supervisor AR reading I&M0): it
    runs beside the IO AR, which keeps being judged (the review of the power-cycle change: it was aborted and
    254 of its 277 cycles went unjudged)."""
    import struct

    import rpc_frames as R
    src = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "captures", "parking-t81-scancon.pcapng")
    if not os.path.exists(src):
        pytest.skip("captures/parking-t81-scancon.pcapng is missing")
    other = "0badc0de-0000-4000-8000-000000000001"
    arb = bytearray(R.ar_block_req(station="tool", ar_uuid=other))
    arb[6:8] = struct.pack(">H", ar_type)
    act = "00000009-0000-1010-8000-000000000009"
    req = R.frame(R.CONTROLLER_MAC, R.DEVICE_MAC, R.CONTROLLER_IP, R.DEVICE_IP, 49153, 34964,
                  R.dcerpc(0, 0, R.ndr_request(bytes(arb) + R.alarmcr_req()), act=act))
    res = R.frame(R.DEVICE_MAC, R.CONTROLLER_MAC, R.DEVICE_IP, R.CONTROLLER_IP, 49154, 49153,
                  R.dcerpc(2, 0, R.ndr_response(R.ar_block_res(other) + R.alarmcr_res(), little=True), act=act,
                           little=True, flags1=0x0A))
    path = str(tmp_path / "beside.pcapng")
    capedit.insert(src, path, {500: [req, res]})
    want = analyze_file(src, Settings()).summary()["cyclic"]["encoders"][0]["cycles"]
    for fast in (False, True):
        evs = _events(path, fast, ("ar_phase", "ar"))
        assert any(e["kind"] == "ar" and e["ar_uuid"] == other for e in evs)
        assert not [e for e in evs if e["kind"] == "ar_phase" and e["phase"] == "aborted"]
        assert analyze_file(path, Settings(fast_path=fast)).summary()["cyclic"]["encoders"][0]["cycles"] == want
    if shutil.which("tshark"):
        from test_lua_plugin import compare
        n, bad, lua_viol, viol = compare(path)
        assert n and not bad and lua_viol == viol
