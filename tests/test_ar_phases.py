"""AR phases as the checker's clock (issue #12 items 1, 4, 5 and the restart): STARTUP-NO-PARAM-RECORD is
decided at PrmEnd, cyclic data before PrmEnd / after the AR's end is not judged, a restarted AR is judged
with its own 0xBF00, violations without an encoder axis count everywhere, and setpoint/actual frames whose
order drifts (RT, two clocks) give the same verdict on both paths and in the plugin."""
from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest

from pndiss.analyzer import analyze_file
from pndiss.capture import open_capture
from pndiss.settings import Settings
from pndiss.sim import pcapng

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CAPS = os.path.join(ROOT, "captures")
ENV = dict(os.environ, PYTHONPATH=ROOT)


def simulate(tmp_path, name, *args) -> str:
    out = str(tmp_path / f"{name}.pcapng")
    r = subprocess.run([sys.executable, "-m", "pndiss", "simulate", "--cycles", "300", "-o", out, *args],
                       capture_output=True, text=True, env=ENV)
    assert r.returncode == 0, r.stderr
    return out


def events(path, settings=None, fast=False):
    evs = []
    os.environ["PNDISS_FAST_PATH"] = "1" if fast else "0"
    try:
        a = analyze_file(path, settings or Settings(), sink=None if fast else evs.append)
    finally:
        os.environ.pop("PNDISS_FAST_PATH", None)
    return a, evs


def kinds(evs, kind):
    return [e for e in evs if e["kind"] == kind]


def lua_equal(path):
    """The plugin reports the same (frame, rule) pairs as Python (tests/test_lua_plugin.py's comparison)."""
    lp = pytest.importorskip("test_lua_plugin")
    n, bad, lua_viol, viol = lp.compare(path)
    assert not bad, bad[:5]
    assert lua_viol == viol


# ---- 1. start-up: PrmEnd decides #66 ----------------------------------------------------------------------
def test_good_data_before_prmend_and_bf00_after_first_frames_is_clean(tmp_path):
    path = simulate(tmp_path, "gb", "--startup", "realistic", "--good-before-prmend", "--records", "plain")
    a, evs = events(path)
    rec = [e for e in kinds(evs, "record") if e["index"] == 0xBF00 and e["op"] == "write"]
    first_cyclic = min(e["frame"] for e in kinds(evs, "telegram"))
    prm_end = [e for e in kinds(evs, "ar_phase") if e["phase"] == "prm_end"]
    # the capture is what the test says: GOOD cyclic data first, then 0xBF00, then PrmEnd
    good = [e for e in kinds(evs, "telegram") if e["iops"] == 0x80 and e["frame"] < rec[0]["frame"]]
    assert first_cyclic < rec[0]["frame"] < prm_end[0]["frame"] and good
    assert not kinds(evs, "violation")
    assert not any(e["judged"] for e in kinds(evs, "telegram") if e["frame"] < prm_end[0]["frame"])
    assert a.summary()["violations"]["by_severity"] == {"error": 0, "warning": 0, "info": 0}
    lua_equal(path)


def test_no_bf00_before_prmend_is_reported_at_the_prmend_frame(tmp_path):
    path = simulate(tmp_path, "nobf", "--startup", "realistic", "--inject", "STARTUP-NO-PARAM-RECORD")
    _, evs = events(path)
    (v,) = kinds(evs, "violation")
    prm_end = [e for e in kinds(evs, "ar_phase") if e["phase"] == "prm_end"]
    control = [e for e in kinds(evs, "rpc") if e["frame"] == v["frame"]]
    assert v["rule"] == "STARTUP-NO-PARAM-RECORD" and v["frame"] == prm_end[0]["frame"]
    assert control and control[0]["operation"] == "Control" and "PrmEnd" in v["message"]
    fast, _ = events(path, fast=True)
    assert fast.summary()["violations"] == events(path)[0].summary()["violations"]
    lua_equal(path)


def test_bf00_only_inside_a_multiple_write_is_clean(tmp_path):
    path = simulate(tmp_path, "mw", "--startup", "realistic", "--good-before-prmend", "--records", "multiplewrite")
    _, evs = events(path)
    (rec,) = [e for e in kinds(evs, "record") if e["index"] == 0xBF00]
    rpc = [e for e in kinds(evs, "rpc") if e["frame"] == rec["frame"]][0]
    outer = [b for b in rpc["pnio"]["blocks"] if b.get("index") == 0xE040]
    assert outer, "0xBF00 travels inside a MultipleWrite (0xE040)"
    assert not kinds(evs, "violation")
    lua_equal(path)


def test_ar_phases_in_events_and_summary(tmp_path):
    path = simulate(tmp_path, "ph", "--startup", "realistic")
    a, evs = events(path)
    (ar,) = kinds(evs, "ar")
    assert ar["phase"] == "parameterisation"
    seq = [e["phase"] for e in kinds(evs, "ar_phase")]
    assert seq == ["prm_end", "application_ready", "data_exchange", "released"]
    (s,) = a.summary()["session"]["ars"]
    assert s["phase"] == "released" and [p["phase"] for p in s["phases"]][0] == "parameterisation"


# ---- restart: a second AR is judged with its own 0xBF00 -----------------------------------------------------
def _restart_capture(path, *, second_good_before_prmend=True):
    from pndiss.sim.scenarios import SCENARIOS
    from pndiss.sim.config import Config
    from pndiss.sim.session import SimSession

    def frames(seed, mupr, tmr, **kw):
        cfg = Config(scenario="startup", seed=seed, cycles=300, mupr=mupr, tmr=tmr, **kw)
        return SimSession(cfg, SCENARIOS["startup"]()).build()[0]

    a = frames(1, 8192, 8192 * 4096)
    b = frames(2, 1000, 1000 * 16, good_before_prmend=second_good_before_prmend)
    shift = a[-1].ts + 500_000_000 - b[0].ts   # Release of the first AR, half a second, a new Connect
    with open(path, "wb") as f:
        w = pcapng.Writer(f)
        for fr in a:
            w.write(fr.ts, fr.data)
        for fr in b:
            w.write(fr.ts + shift, fr.data)
    return path


def test_restart_with_new_scaling_judges_the_second_ar_with_its_settings(tmp_path):
    path = _restart_capture(str(tmp_path / "restart.pcapng"))
    a, evs = events(path)
    ars = kinds(evs, "ar")
    assert len(ars) == 2 and ars[0]["ar_uuid"] != ars[1]["ar_uuid"]
    encs = a.summary()["cyclic"]["encoders"]
    assert len(encs) == 2
    second = [e for e in kinds(evs, "record") if e["index"] == 0xBF00 and e["ar_uuid"] == ars[1]["ar_uuid"]][0]
    assert encs[1]["settings"]["mupr"]["value"] == 1000 and encs[1]["settings"]["tmr"]["value"] == 16000
    assert f"frame {second['frame']}" in encs[1]["settings"]["mupr"]["source"]
    assert encs[0]["settings"]["mupr"]["value"] == 8192 and encs[1]["cycles"] > 250
    # nothing for the silence between the ARs, nor for the new device's frames before its Connect response;
    # the new MUPR/TMR without a preset afterwards is #31 (behaviour.md §9 #31, info), on the second AR
    (v,) = kinds(evs, "violation")
    assert v["rule"] == "PRESET-WITHOUT-NEW-PARAMS" and v["frame"] > second["frame"]
    assert list(encs[1]["violations"]) == ["PRESET-WITHOUT-NEW-PARAMS"] and not encs[0]["violations"]
    fast, _ = events(path, fast=True)
    assert fast.summary()["cyclic"] == a.summary()["cyclic"]
    lua_equal(path)


# ---- violations without an encoder axis count everywhere ---------------------------------------------------
@pytest.mark.parametrize("rule", ["DCP-NAME-DUPLICATE", "DCP-NAME-INVALID", "IP-ASSIGN-OCCUPIED"])
def test_dcp_violations_count_in_summary_report_and_fail_on(tmp_path, rule):
    cap = os.path.join(CAPS, f"fault-{rule.lower()}.pcapng")
    a, evs = events(cap)
    n = len([e for e in kinds(evs, "violation") if e["rule"] == rule])
    s = a.summary()
    sev = s["violations"]["by_rule"][rule]["severity"]
    assert n >= 1 and s["violations"]["by_rule"][rule]["events"] == n
    assert s["violations"]["by_severity"][sev] >= n and s["cyclic"]["violations_by_severity"][sev] >= n
    r = subprocess.run([sys.executable, "-m", "pndiss", "analyze", cap, "--no-progress", "--fail-on", "info"],
                       capture_output=True, text=True, env=ENV)
    assert r.returncode == 1, r.stderr
    assert "Violations not tied to an encoder" in r.stdout and rule in r.stdout
    clean = subprocess.run([sys.executable, "-m", "pndiss", "analyze", os.path.join(CAPS, "startup-t81-generic.pcapng"),
                            "-q", "--fail-on", "info"], capture_output=True, text=True, env=ENV)
    assert clean.returncode == 0


# ---- RT drift: setpoint and actual frames change order ---------------------------------------------------------
def drift(src: str, dst: str, stretch: int = 40) -> int:
    """Reorder cyclic frames like two free-running clocks do: in alternating stretches of `stretch` cyclic
    frames the device's clock lags, so each device frame comes after the controller's next frame to that
    device (never before the setpoint it answers: a device cannot react to a frame not yet sent); the
    controller's sign-of-life therefore looks repeated and skipped to a pairing by order. Timestamps stay
    monotone. Returns how many device frames were moved."""
    def cyclic(d):
        off = 16 if d[12:14] == b"\x81\x00" else 12   # the simulator's frames carry a priority tag
        return d[off:off + 2] == b"\x88\x92" and 0x80 <= d[off + 2] < 0xFC

    out, held, n, moved = [], {}, 0, 0
    ctrl = None
    for _, ts, _, d in open_capture(src):
        if not cyclic(d):
            out.append((ts, d))
            continue
        n += 1
        lag = (n // stretch) % 2 == 1
        src_mac, dst_mac = d[6:12], d[0:6]
        if ctrl is None and src_mac.endswith(b"\x00\x00\x01"):
            ctrl = src_mac   # the simulator's controller: 02:00:00:00:00:01
        if src_mac == ctrl:
            out.append((ts, d))
            if dst_mac in held:
                out.append((ts, held.pop(dst_mac)))
                moved += 1
        elif lag and src_mac not in held:
            held[src_mac] = d
        else:
            if src_mac in held:
                out.append((ts, held.pop(src_mac)))
            out.append((ts, d))
    out += [(out[-1][0], d) for d in held.values()]
    with open(dst, "wb") as f:
        w = pcapng.Writer(f)
        for ts, d in out:
            w.write(ts, d)
    return moved


@pytest.mark.parametrize("stem", ["startup-t81-generic-3enc", "preset-t81-lika", "fault-preset-ack-missing",
                                  "fault-ackip-stuck", "fault-position-discontinuity", "sensor-error-t81-lika",
                                  "fault-sol-master-skip", "fault-sol-device-skip", "fault-sol-master-stall"])
def test_drifting_frame_order_keeps_the_verdict(tmp_path, stem):
    cap = os.path.join(CAPS, stem + ".pcapng")
    exp = json.load(open(os.path.join(CAPS, stem + ".expected.json"), encoding="utf-8"))
    s = Settings()
    for f in exp["faults"]:
        for k, v in f.get("settings", {}).items():
            setattr(s, k, v)
    out = str(tmp_path / "drift.pcapng")
    assert drift(cap, out) > 50
    ref, evs = events(out, s)
    fast, _ = events(out, s, fast=True)
    orig, _ = events(cap, s, fast=True)
    assert set(ref.summary()["violations"]["by_rule"]) == set(orig.summary()["violations"]["by_rule"])
    assert fast.summary()["cyclic"] == ref.summary()["cyclic"]
    assert fast.summary()["violations"] == ref.summary()["violations"]
    if not exp["faults"]:
        assert not kinds(evs, "violation")


@pytest.mark.parametrize("stem", ["fault-sol-master-skip", "fault-sol-device-early-start"])
def test_drifting_frame_order_plugin_equal(tmp_path, stem):
    """The controller's sign-of-life judged on its own stream (Checker.cycle sp_before) in the plugin too."""
    lp = pytest.importorskip("test_lua_plugin")
    cap = os.path.join(CAPS, stem + ".pcapng")
    out = str(tmp_path / "drift.pcapng")
    assert drift(cap, out) > 50
    st = lp.sidecar_settings(cap)
    s = Settings()
    for k, v in st.items():
        setattr(s, k, v)
    n, bad, lua_viol, viol = lp.compare(out, s, lp.settings_pref(st)[1:])
    assert not bad, bad[:5]
    assert lua_viol == viol and viol
