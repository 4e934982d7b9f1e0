"""``pndiss simulate``: CLI, determinism, tshark 4.0 acceptance of every frame type, fault injection,
fast path, and property tests for the frame builders and the pcapng writer."""
from __future__ import annotations

import hashlib
import io
import json
import os
import shutil
import sys
import struct
import subprocess

import pytest
from hypothesis import given, settings, strategies as st

from pndiss import telegrams as T
from pndiss.capture import open_capture
from pndiss.cli import main
from pndiss.rules import RULES
from pndiss.sim import frames as F
from pndiss.sim import pcapng
from pndiss.sim.model import PROFILE_TELEGRAMS, Shaft, sol_next
from pndiss.sim.scenarios import INJECTIONS, NOT_INJECTABLE, SCENARIOS
from pndiss.sim.config import send_clock

HAVE_TSHARK = shutil.which("tshark") is not None
# tshark expert severities: warning 0x00600000, error 0x00800000
BAD_FILTER = "_ws.malformed || _ws.expert.severity >= 8388608"


def tshark(path, *args):
    r = subprocess.run(["tshark", "-n", "-r", str(path), *args], capture_output=True, text=True, timeout=300)
    assert r.returncode == 0, r.stderr
    return r.stdout


def sim(tmp_path, name="c.pcapng", *args):
    out = tmp_path / name
    assert main(["simulate", "-o", str(out), *args]) == 0
    return out


def sha(path):
    return hashlib.sha256(path.read_bytes()).hexdigest()


# ------------------------------------------------------------------------------------- CLI

def test_help_lists_every_scenario_and_option(capsys):
    with pytest.raises(SystemExit):
        main(["simulate", "--help"])
    out = capsys.readouterr().out
    for name in SCENARIOS:
        assert name in out
    for opt in ("--scenario", "--profile", "--telegram", "--cycle-time", "--cycles", "--duration",
                "--encoders", "--inject", "--seed", "-o", "--startup", "--records", "--good-before-prmend",
                "--restart", "--restart-scaling", "--restart-gap", "--capture-loss", "--start-mid-session",
                "--drift-ppm", "--jitter-us", "--irt", "--io-devices", "--param-polls", "--it-traffic"):
        assert opt in out
    for rule in list(INJECTIONS)[:5]:
        assert rule in out


@pytest.mark.parametrize("args", [
    ["--profile", "lika", "--telegram", "860"],
    ["--profile", "scancon", "--telegram", "88"],
    ["--telegram", "99"],
    ["--cycle-time", "0.3"],
    ["--inject", "NO-SUCH-RULE"],
    ["--inject", "SYNC-FAULT-DLS-NONZERO"],       # in the catalogue, not injectable
    ["--inject", "SOL-MASTER-SKIP@0"],
    ["--encoders", "0"],
    ["--scenario", "startup", "--inject", "PRESET-NOT-STANDSTILL"],   # a preset-scenario fault
    ["--inject", "PRESET-NOT-STANDSTILL", "--inject", "PARK-ACK-MISSING"],   # two scenarios at once
    ["--restart-scaling", "mupr=4096"],                       # without --restart
    ["--restart", "20", "--restart-scaling", "speed=3"],
    ["--restart", "20", "--restart-scaling", "mupr=x"],
    ["--restart", "0"],
    ["--capture-loss", "0.9"],
    ["--start-mid-session", "45"],                             # fewer than 10 cycles left
    ["--cycle-time", "1,2"],                                   # two cycle times, one encoder
    ["--encoders", "2", "--cycle-time", "1,0.3"],
    ["--io-devices", "17"],
    ["--io-devices", "1", "--startup", "tidy"],
    ["--good-before-prmend", "--startup", "tidy"],
    ["--drift-ppm", "-1"],
    ["--param-polls", "5"],
    ["--it-traffic", "-3"],
])
def test_impossible_combinations_exit_2(tmp_path, capsys, args):
    assert main(["simulate", "-o", str(tmp_path / "x.pcapng"), "--cycles", "50", *args]) == 2
    assert "error" in capsys.readouterr().err


def test_inject_without_scenario_takes_the_faults_scenario(tmp_path):
    """A fault that needs the preset handshake picks --scenario preset when none is given."""
    out = sim(tmp_path, "p.pcapng", "--cycles", "400", "--profile", "scancon", "--telegram", "83",
              "--inject", "PRESET-NOT-STANDSTILL")
    truth = json.loads((tmp_path / "p.expected.json").read_text())
    assert truth["config"]["scenario"] == "preset"
    assert [f["rule"] for f in truth["faults"]] == ["PRESET-NOT-STANDSTILL"]
    assert out.stat().st_size > 0


def test_same_seed_same_bytes_other_seed_differs(tmp_path):
    a = sim(tmp_path, "a.pcapng", "--cycles", "300", "--scenario", "preset", "--seed", "7")
    b = sim(tmp_path, "b.pcapng", "--cycles", "300", "--scenario", "preset", "--seed", "7")
    c = sim(tmp_path, "c.pcapng", "--cycles", "300", "--scenario", "preset", "--seed", "8")
    assert sha(a) == sha(b) != sha(c)
    assert (tmp_path / "a.expected.json").read_bytes() == (tmp_path / "b.expected.json").read_bytes()


def test_duration_and_cycle_time(tmp_path):
    p = sim(tmp_path, "d.pcapng", "--duration", "0.5", "--cycle-time", "2", "--startup", "tidy",
            "--drift-ppm", "0", "--jitter-us", "0")
    exp = json.loads((tmp_path / "d.expected.json").read_text())
    assert exp["config"]["cycles"] == 250
    iocr = exp["stations"][0]["iocrs"][0]
    assert (iocr["send_clock_factor"], iocr["reduction_ratio"]) == (32, 2)
    ts = [t for _, t, _, d in open_capture(str(p)) if len(d) > 20 and d[16:18] == b"\x88\x92"
          and int.from_bytes(d[18:20], "big") == iocr["frame_id"]]
    assert len(ts) == 250 and {b - a for a, b in zip(ts, ts[1:])} == {2_000_000}


# ------------------------------------------------------------------------------------- tshark

@pytest.mark.skipif(not HAVE_TSHARK, reason="tshark not installed")
def test_tshark_decodes_every_frame_type(tmp_path):
    p = sim(tmp_path, "s.pcapng", "--cycles", "400", "--scenario", "sensor-error", "--profile", "lika")
    assert tshark(p, "-Y", BAD_FILTER) == ""
    kinds = json.loads((tmp_path / "s.expected.json").read_text())["frame_kinds"]
    pre_in, pre_out = kinds["cyclic.in.startup"], kinds["cyclic.out.startup"]
    assert pre_in > pre_out > 0       # the device's frames start before the Connect response
    checks = {
        "pn_dcp.service_id == 5 && pn_dcp.service_type == 0": 2,      # Identify all + by name
        "pn_dcp.service_id == 5 && pn_dcp.service_type == 1": 2,      # Identify responses
        "pn_dcp.service_id == 4 && pn_dcp.service_type == 0": 2,      # Set name, Set IP
        "lldp.tlv.type == 1": 3,                                       # controller + 2 encoder ports
        "dcerpc.opnum == 0 && dcerpc.pkt_type == 0": 1,               # Connect
        "pn_io.index == 0xbf00 && dcerpc.pkt_type == 0": 1,           # Write 0xBF00 ...
        "pn_io.index == 0xe040 && dcerpc.pkt_type == 0": 1,           # ... inside one MultipleWrite
        "pn_rt.frame_id == 0x8001 && pn_rt.ds == 0x25": pre_out,      # ProviderState STOP at start-up
        "pn_io.index == 0xaff0 && dcerpc.pkt_type == 2": 1,           # Read I&M0 response
        "pn_io.index == 0xb02e": 4 * 5,                                # 5 parameter reads (w+r, req+res)
        "pn_io.control_command.prmend == 1": 1,
        "pn_io.control_command.applready == 1": 1,
        "pn_io.control_command.release == 1": 1,
        "pn_io.alarm_type": 4,                                         # appears/disappears + their acks
        "pn_rt.frame_id == 0x8000": 400 + pre_in,
        "pn_rt.frame_id == 0x8001": 400 + pre_out,
    }
    for flt, n in checks.items():
        got = len(tshark(p, "-Y", flt).splitlines())
        assert got == n, (flt, got)
    # cyclic counters +32 per 1 ms, APDU status 0x35, IOxS 0x80
    rows = tshark(p, "-Y", "pn_rt.frame_id == 0x8000", "-T", "fields", "-e", "pn_rt.cycle_counter",
                  "-e", "pn_rt.ds").split("\n")
    cc = [int(r.split("\t")[0]) for r in rows if r]
    assert all((b - a) % 65536 == 32 for a, b in zip(cc, cc[1:]))
    assert {r.split("\t")[1] for r in rows if r} == {"0x35"}
    # the parameter reads decode as PROFIdrive
    pnus = tshark(p, "-Y", "pn_io.profidrive.parameter.number", "-T", "fields", "-e", "pn_io.profidrive.parameter.number")
    assert {"922", "964", "965", "979", "65001"} <= set(pnus.split())


@pytest.mark.skipif(not HAVE_TSHARK, reason="tshark not installed")
@pytest.mark.parametrize("profile,telegram", [(p, t) for p, ts in PROFILE_TELEGRAMS.items() for t in ts
                                              if p in ("psm", "generic")])
def test_tshark_accepts_every_telegram(tmp_path, profile, telegram):
    p = sim(tmp_path, "t.pcapng", "--cycles", "30", "--profile", profile, "--telegram", str(telegram))
    assert tshark(p, "-Y", BAD_FILTER) == ""
    exp = json.loads((tmp_path / "t.expected.json").read_text())
    data = exp["stations"][0]["iocrs"][0]["objects"][-1]
    assert data["length"] == T.length(telegram, "actual")


# ------------------------------------------------------------------------------------- content

def _cyclic(path, fid):
    for fn, ts, lt, d in open_capture(str(path)):
        if len(d) > 20 and d[16:18] == b"\x88\x92" and int.from_bytes(d[18:20], "big") == fid:
            yield fn, d


def test_sign_of_life_and_preset_handshake(tmp_path):
    p = sim(tmp_path, "p.pcapng", "--cycles", "400", "--scenario", "preset", "--profile", "scancon")
    exp = json.loads((tmp_path / "p.expected.json").read_text())
    st0 = exp["stations"][0]
    inp, out = st0["iocrs"]
    off_in = 20 + inp["objects"][-1]["offset"]
    iops_in = off_in + inp["objects"][-1]["length"]
    # data exchange only: DataStatus RUN from the controller, IOPS GOOD from the device
    sp = [T.decode(81, "setpoint", d, off=20) for _, d in _cyclic(p, out["frame_id"]) if d[-2] == 0x35]
    ac = [T.decode(81, "actual", d, off=off_in) for _, d in _cyclic(p, inp["frame_id"]) if d[iops_in] == 0x80]
    assert len(sp) == len(ac) == 400
    cls = [s["stw2_enc"] >> 12 for s in sp]
    dls = [a["zsw2_enc"] >> 12 for a in ac]
    assert all(b == sol_next(a) for a, b in zip(cls, cls[1:]))
    assert dls[0] == 0 and all(b == sol_next(a) for a, b in zip(dls[1:], dls[2:]))
    req = [i for i, s in enumerate(sp) if s["g1_stw"] & 0x1000]
    ack = [i for i, a in enumerate(ac) if a["g1_zsw"] & 0x1000]
    assert req and ack and ack[0] >= req[0] and req[-1] <= ack[-1]
    assert ac[ack[0]]["g1_xist2"] == 1000       # P65000 = 1000, absolute preset at standstill


@pytest.mark.parametrize("rule", sorted(INJECTIONS))
def test_every_injection_tags_frames(rule):
    from pndiss.sim.curated import fault_config
    from pndiss.sim.scenarios import SCENARIOS, make_injection
    from pndiss.sim.session import SimSession
    cfg = fault_config(rule)
    cfg.cycles = 200
    sc = SCENARIOS[cfg.scenario]()
    sc.injections.append(make_injection(rule, None))
    frames, truth = SimSession(cfg, sc).build()
    (f,) = truth["faults"]
    assert f["rule"] == rule and f["side"] in ("controller", "encoder")
    assert 1 <= f["first_frame"] <= f["last_frame"] <= len(frames)
    assert set(f["also_possible"]) <= set(RULES)


def test_injectable_and_not_cover_the_catalogue():
    assert set(INJECTIONS) | set(NOT_INJECTABLE) == set(RULES)
    assert not set(INJECTIONS) & set(NOT_INJECTABLE)


def test_docs_list_every_rule():
    import os
    doc = open(os.path.join(os.path.dirname(__file__), "..", "docs", "simulate.md"), encoding="utf-8").read()
    for rule in RULES:
        assert rule in doc, rule


# ------------------------------------------------------------------------------------- fast path

def test_fast_path_matches_layout_and_is_deterministic(tmp_path):
    from pndiss.sim.fastpath import FAST_THRESHOLD, STEPS
    n = FAST_THRESHOLD
    a = sim(tmp_path, "f1.pcapng", "--cycles", str(n), "--encoders", "2")
    b = sim(tmp_path, "f2.pcapng", "--cycles", str(n), "--encoders", "2")
    assert sha(a) == sha(b)
    exp = json.loads((tmp_path / "f1.expected.json").read_text())
    frames = list(open_capture(str(a)))
    assert len(frames) == exp["frames"]
    assert all(x[1] <= y[1] for x, y in zip(frames, frames[1:]))   # time order kept around acyclic frames
    st0 = exp["stations"][1]
    inp = st0["iocrs"][0]
    off = 20 + inp["objects"][-1]["offset"]
    iops = 20 + inp["objects"][-1]["offset"] + inp["objects"][-1]["length"]
    every = [(d, T.decode(81, "actual", d, off=off)) for fn, ts, lt, d in frames
             if len(d) > 20 and int.from_bytes(d[18:20], "big") == inp["frame_id"]]
    cc = [int.from_bytes(d[-4:-2], "big") for d, _ in every]   # start-up frames and data exchange: one count
    assert all((y - x) % 65536 == 32 for x, y in zip(cc, cc[1:]))
    rows = [r for r in every if r[0][iops] == 0x80]
    assert len(rows) == n and 0 < len(every) - n < 100 and all(d[iops] == 0 for d, _ in every[:len(every) - n])
    pos = [a["g1_xist1"] for _, a in rows]
    assert all((y - x) % (8192 * 4096) == STEPS for x, y in zip(pos, pos[1:]))
    dls = [a["zsw2_enc"] >> 12 for _, a in rows]
    assert all(y == sol_next(x) for x, y in zip(dls[1:], dls[2:]))


# ------------------------------------------------------------------------------------- properties

@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.integers(0, 2**64 - 1), st.binary(min_size=0, max_size=200)), max_size=20))
def test_pcapng_writer_round_trips(recs):
    buf = io.BytesIO()
    w = pcapng.Writer(buf)
    for ts, data in recs:
        w.write(ts, data)
    path_bytes = buf.getvalue()
    import tempfile
    import os
    with tempfile.NamedTemporaryFile(suffix=".pcapng", delete=False) as f:
        f.write(path_bytes)
    try:
        got = [(ts, bytes(d)) for _, ts, _, d in open_capture(f.name)]
    finally:
        os.unlink(f.name)
    from pndiss.capture import TS_MAX   # the reader clamps what no sink can show (issue #17)
    assert got == [(min(ts, TS_MAX), d) for ts, d in recs]


@settings(max_examples=200, deadline=None)
@given(st.integers(0, 255), st.integers(0, 255), st.binary(max_size=64), st.one_of(st.none(), st.integers(0, 0xFFFF)))
def test_dcp_block_even_and_decodable(opt, sub, value, info):
    from pndiss.proto import dcp
    from pndiss.proto.common import Malformed
    b = F.dcp_block(opt, sub, value, info)
    assert len(b) % 2 == 0
    (ln,) = struct.unpack(">H", b[2:4])
    assert ln == len(value) + (0 if info is None else 2)
    # a whole Identify response round-trips through our decoder (or is Malformed, nothing else)
    frame = F._dcp("02:00:00:00:00:01", "02:00:00:00:00:02", 0xFEFF, 5, 1, 1, [b])
    try:
        dcp.decode(frame, 16, 0xFEFF)
    except Malformed:
        pass


@settings(max_examples=200, deadline=None)
@given(st.integers(1, 3000), st.lists(st.tuples(st.floats(0, 10), st.floats(-600, 600), st.floats(-600, 600)),
                                      min_size=1, max_size=5))
def test_shaft_is_continuous(k, segs):
    segs = sorted(segs, key=lambda s: s[0])
    segs[0] = (0.0, segs[0][1], segs[0][2])
    sh = Shaft(tuple(segs))
    t = k / 1000
    a, _ = sh.at(t)
    b, _ = sh.at(t + 1e-6)
    assert abs(b - a) <= 600 / 60 * 1e-6 + 1e-9


@settings(max_examples=200, deadline=None)
@given(st.floats(0.01, 1000))
def test_send_clock_is_exact_or_refused(ms):
    try:
        scf, rr = send_clock(ms)
    except ValueError:
        return
    assert scf * rr * 31.25 == pytest.approx(ms * 1000)
    assert scf in (8, 16, 32) and rr & (rr - 1) == 0


@settings(max_examples=200, deadline=None)
@given(st.sampled_from(sorted(T.TELEGRAMS)), st.binary(min_size=0, max_size=24))
def test_telegram_words_round_trip(tel, raw):
    from pndiss.proto.common import Malformed
    lay = T.layout(tel, "actual")
    try:
        vals = lay.decode(raw)
    except Malformed:
        assert len(raw) < lay.length
        return
    assert lay.encode(vals) == raw[:lay.length]


# ------------------------------------------------------------------------------------- start-up

@pytest.mark.skipif(not HAVE_TSHARK, reason="tshark not installed")
@pytest.mark.parametrize("mode", [(), ("--records", "plain"), ("--good-before-prmend",),
                                  ("--good-before-prmend", "--records", "plain", "--encoders", "2")])
def test_startup_modes_order_and_tshark(tmp_path, mode):
    p = sim(tmp_path, "u.pcapng", "--cycles", "60", *mode)
    assert tshark(p, "-Y", BAD_FILTER) == ""
    rows = [r.split("\t") for r in tshark(
        p, "-Y", "pn_rt.frame_id == 0x8000 || pn_rt.frame_id == 0x8001 || pn_io.index || pn_io.control_command",
        "-T", "fields", "-e", "frame.number", "-e", "pn_rt.frame_id", "-e", "pn_io.index", "-e", "dcerpc.pkt_type",
        "-e", "pn_io.control_command.prmend", "-e", "pn_io.control_command.applready", "-e", "pn_io.ioxs",
        "-E", "occurrence=f").splitlines()]
    first_in = next(int(r[0]) for r in rows if r[1] == "32768")
    first_out = next(int(r[0]) for r in rows if r[1] == "32769")
    bf00 = int(tshark(p, "-Y", "pn_io.index == 0xbf00 && dcerpc.pkt_type == 0", "-T", "fields",
                      "-e", "frame.number").split()[0])
    prm_end = next(int(r[0]) for r in rows if r[4] == "1")
    app_ready = next(int(r[0]) for r in rows if r[5] == "1")
    conn_res = int(tshark(p, "-Y", "dcerpc.opnum == 0 && dcerpc.pkt_type == 2", "-T", "fields",
                          "-e", "frame.number").split()[0])
    assert first_in < conn_res < first_out < bf00 < prm_end < app_ready
    good = [int(r[0]) for r in rows if r[1] == "32768" and r[6] == "0x80"]
    if "--good-before-prmend" in mode:
        assert good[0] == first_in                      # GOOD from the device's first frame
        assert sum(1 for r in rows if r[1] and first_out <= int(r[0]) < bf00) >= 3
    else:
        assert good[0] > app_ready                      # GOOD only after ApplicationReady
    mw = tshark(p, "-Y", "pn_io.index == 0xe040 && dcerpc.pkt_type == 0")
    assert bool(mw) == ("plain" not in mode)


@pytest.mark.skipif(not HAVE_TSHARK, reason="tshark not installed")
def test_restart_new_ar_new_scaling_and_silence(tmp_path):
    p = sim(tmp_path, "r.pcapng", "--cycles", "500", "--restart", "200", "--restart-scaling", "mupr=4096,direction=1")
    assert tshark(p, "-Y", BAD_FILTER) == ""
    exp = json.loads((tmp_path / "r.expected.json").read_text())
    ar1, ar2 = exp["stations"][0]["ars"]
    assert ar1["ar_uuid"] != ar2["ar_uuid"] and ar2["session_key"] == ar1["session_key"] + 1
    assert (ar1["params"]["mupr"], ar2["params"]["mupr"], ar2["params"]["direction"]) == (8192, 4096, 1)
    uuids = tshark(p, "-Y", "dcerpc.opnum == 0 && dcerpc.pkt_type == 0", "-T", "fields", "-e", "pn_io.ar_uuid",
                   "-E", "occurrence=f").split()
    assert uuids == [ar1["ar_uuid"], ar2["ar_uuid"]]
    # the second AR's 0xBF00 carries the new MUPR (bytes 1-8, records.md §5.1)
    data = tshark(p, "-Y", "pn_io.index == 0xbf00 && dcerpc.pkt_type == 0", "-T", "fields", "-e", "frame.number")
    assert len(data.split()) == 2
    # silence: no cyclic frame of the station between the Release response and the new Connect
    rel = int(tshark(p, "-Y", "pn_io.control_command.release == 1", "-T", "fields",
                     "-e", "frame.number").split()[0])         # the request; its response follows
    assert ar1["last_frame"] <= rel + 2 and ar2["first_frame"] > rel + 2
    ts = {fn: t for fn, t, _, _ in open_capture(str(p))}
    assert ts[ar2["first_frame"]] - ts[ar1["last_frame"]] >= 200_000_000
    assert main(["simulate", "-o", str(tmp_path / "x.pcapng"), "--cycles", "300", "--restart", "290"]) == 2


def test_capture_loss_gaps_come_from_what_was_dropped(tmp_path):
    p = sim(tmp_path, "l.pcapng", "--cycles", "800", "--capture-loss", "0.02", "--inject", "SOL-DEVICE-SKIP")
    exp = json.loads((tmp_path / "l.expected.json").read_text())
    assert exp["needs"] == ["capture_gap"] and exp["capture_gaps"]
    full = sim(tmp_path, "f.pcapng", "--cycles", "800", "--inject", "SOL-DEVICE-SKIP")
    n_full = json.loads((tmp_path / "f.expected.json").read_text())["frames"]
    assert n_full - exp["frames"] == exp["capture_loss"]["frames_dropped"] == sum(
        g["cycles_missing"] for g in exp["capture_gaps"])
    frames = {fn: d for fn, _, _, d in open_capture(str(p))}
    step = 32
    for g in exp["capture_gaps"]:
        a, b = frames[g["prev_frame"]], frames[g["next_frame"]]
        for d in (a, b):
            assert int.from_bytes(d[18:20], "big") == g["frame_id"] and d[6:12].hex(":") == g["src"]
        # the cycle counter says how many cycles passed (wire.md §2.3)
        cc = (int.from_bytes(b[-4:-2], "big") - int.from_bytes(a[-4:-2], "big")) % 65536
        assert cc == step * (g["cycles_missing"] + 1)
        between = [d for fn, d in frames.items() if g["prev_frame"] < fn < g["next_frame"]
                   and len(d) > 20 and d[18:20] == a[18:20] and d[6:12] == a[6:12]]
        assert not between
    # the injected fault's frames are all there
    f = exp["faults"][0]
    assert f["first_frame"] is not None and frames[f["first_frame"]]
    assert sha(p) == sha(sim(tmp_path, "l2.pcapng", "--cycles", "800", "--capture-loss", "0.02",
                             "--inject", "SOL-DEVICE-SKIP"))
    del full


def test_mid_session_capture_has_no_startup(tmp_path):
    p = sim(tmp_path, "m.pcapng", "--cycles", "600", "--telegram", "83", "--start-mid-session", "300")
    exp = json.loads((tmp_path / "m.expected.json").read_text())
    assert exp["needs"] == ["mid_session"]
    frames = list(open_capture(str(p)))
    ms = exp["mid_session"]
    assert all(t >= ms["start_ns"] for _, t, _, _ in frames)
    # no DCP, no Connect: PN-RT frames are cyclic only, UDP only the parameter reads' successors / Release
    fids = {int.from_bytes(d[18:20] if d[12:14] == b"\x81\x00" else d[14:16], "big")
            for _, _, _, d in frames if b"\x88\x92" in (d[12:14], d[16:18])}
    assert fids and all(f < 0xFC00 for f in fids)
    assert tshark(p, "-Y", "dcerpc.opnum == 0 || pn_io.index == 0xbf00 || pn_io.index == 0xe040") == "" \
        if HAVE_TSHARK else True
    inp = next(s for s in ms["streams"] if s["direction"] == "input")
    assert (inp["telegram"], inp["data_length"]) == (83, T.length(83, "actual"))
    rows = [d for _, _, _, d in frames if len(d) > 20 and int.from_bytes(d[18:20], "big") == inp["frame_id"]]
    assert len(rows) == 300
    first = T.decode(83, "actual", rows[0], off=20 + inp["data_offset"])
    assert first["zsw2_enc"] >> 12 != 0            # sign-of-life already running


# ------------------------------------------------------------------------------------- RT realism

def _fid_order(p, lo=0x8000, hi=0x8010):
    fids = [int.from_bytes(d[18:20], "big") for _, _, _, d in open_capture(str(p))
            if len(d) > 20 and d[16:18] == b"\x88\x92" and lo <= int.from_bytes(d[18:20], "big") < hi]
    return fids


def test_drift_and_jitter_change_the_frame_order(tmp_path):
    drift = _fid_order(sim(tmp_path, "d.pcapng", "--cycles", "3000", "--encoders", "3"))
    fixed = _fid_order(sim(tmp_path, "f.pcapng", "--cycles", "3000", "--encoders", "3",
                           "--drift-ppm", "0", "--jitter-us", "0"))
    n = len(fixed)
    assert len(drift) == n
    orders = lambda ids: {tuple(ids[i:i + 6]) for i in range(600, n - 6, 6)}   # noqa: E731  (data exchange)
    assert len(orders(fixed)) == 1 and len(orders(drift)) > 1
    # each stream stays in order, its cycle counter steps by one cycle
    frames = [(t, d) for _, t, _, d in open_capture(str(tmp_path / "d.pcapng"))]
    assert all(a[0] <= b[0] for a, b in zip(frames, frames[1:]))
    for fid in range(0x8000, 0x8006):
        cc = [int.from_bytes(d[-4:-2], "big") for _, d in frames
              if len(d) > 20 and d[16:18] == b"\x88\x92" and int.from_bytes(d[18:20], "big") == fid]
        assert all((b - a) % 65536 == 32 for a, b in zip(cc, cc[1:]))


def test_cycle_time_per_encoder(tmp_path):
    p = sim(tmp_path, "c.pcapng", "--cycles", "400", "--encoders", "2", "--cycle-time", "1,4")
    exp = json.loads((tmp_path / "c.expected.json").read_text())
    rr = [s["iocrs"][0]["reduction_ratio"] for s in exp["stations"]]
    assert rr == [1, 4] and {s["iocrs"][0]["send_clock_factor"] for s in exp["stations"]} == {32}
    for st_, step, n in zip(exp["stations"], (32, 128), (400, 100)):
        fid = st_["iocrs"][0]["frame_id"]
        rows = [d for _, _, _, d in open_capture(str(p)) if len(d) > 20 and int.from_bytes(d[18:20], "big") == fid]
        cc = [int.from_bytes(d[-4:-2], "big") for d in rows]
        assert all((b - a) % 65536 == step for a, b in zip(cc, cc[1:]))
        assert sum(1 for d in rows if d[20 + st_["iocrs"][0]["objects"][-1]["offset"]
                                       + st_["iocrs"][0]["objects"][-1]["length"]] == 0x80) == n
    assert main(["simulate", "-o", str(tmp_path / "x.pcapng"), "--encoders", "3", "--cycle-time", "1,2"]) == 2


@pytest.mark.skipif(not HAVE_TSHARK, reason="tshark not installed")
def test_irt_and_io_devices(tmp_path):
    p = sim(tmp_path, "i.pcapng", "--cycles", "800", "--irt", "--io-devices", "2")
    assert tshark(p, "-Y", BAD_FILTER) == ""
    exp = json.loads((tmp_path / "i.expected.json").read_text())
    assert exp["stations"][0]["iocrs"][0]["frame_id"] == 0x0100
    assert exp["stations"][0]["iocrs"][0]["send_clock_factor"] == 8          # 250 us
    rt = tshark(p, "-Y", "dcerpc.opnum == 0 && dcerpc.pkt_type == 0", "-T", "fields",
                "-e", "pn_io.iocr_properties.rtclass").split()
    assert len(rt) == 3 and {int(x, 16) for r in rt for x in r.split(",")} == {3}    # every IOCR RT_CLASS_3
    names = tshark(p, "-Y", "pn_dcp.suboption_device_nameofstation", "-T", "fields",
                   "-e", "pn_dcp.suboption_device_nameofstation").split()
    assert {"io-device-1", "io-device-2", "encoder-1"} <= set(names)
    io = exp["io_devices"]
    assert [d["name"] for d in io] == ["io-device-1", "io-device-2"]
    fid = io[0]["iocrs"][0]["frame_id"]
    rows = [d for _, _, _, d in open_capture(str(p)) if len(d) > 20 and int.from_bytes(d[18:20], "big") == fid]
    good = [d for d in rows if d[20 + 5] == 0x80]      # DI IOPS after 4 DAP IOPS + 1 data byte
    assert len(good) == 800 and len({d[20 + 4] for d in good}) > 1    # the inputs change
    assert len(rows) > len(good)                                       # start-up frames with IOPS BAD


def test_fast_path_capture_loss(tmp_path):
    from pndiss.sim.fastpath import FAST_THRESHOLD
    p = sim(tmp_path, "fl.pcapng", "--cycles", str(FAST_THRESHOLD), "--capture-loss", "0.001")
    exp = json.loads((tmp_path / "fl.expected.json").read_text())
    frames = {fn: (t, d) for fn, t, _, d in open_capture(str(p))}
    assert len(frames) == exp["frames"] and exp["needs"] == ["capture_gap"]
    assert 100 < exp["capture_loss"]["frames_dropped"] < 300
    ts = [t for t, _ in frames.values()]
    assert all(a <= b for a, b in zip(ts, ts[1:]))
    for g in exp["capture_gaps"]:
        a, b = frames[g["prev_frame"]][1], frames[g["next_frame"]][1]
        assert int.from_bytes(a[18:20], "big") == int.from_bytes(b[18:20], "big") == g["frame_id"]
        assert a[6:12].hex(":") == g["src"]
        assert (int.from_bytes(b[-4:-2], "big") - int.from_bytes(a[-4:-2], "big")) % 65536 == 32 * (
            g["cycles_missing"] + 1)


@pytest.mark.skipif(not HAVE_TSHARK, reason="tshark not installed")
def test_restart_by_abort(tmp_path):
    p = sim(tmp_path, "a.pcapng", "--cycles", "400", "--restart", "150", "--restart-mode", "abort")
    assert tshark(p, "-Y", BAD_FILTER) == ""
    err = tshark(p, "-Y", "pn_io.pdu_type.type == 4", "-T", "fields", "-e", "pn_io.error_code2").split()
    assert err == ["13"]                                   # AR abort.req
    assert tshark(p, "-Y", "pn_io.control_command.release == 1", "-T", "fields", "-e", "frame.number").split() \
        and len(tshark(p, "-Y", "pn_io.control_command.release == 1").splitlines()) == 1   # only at the end
    exp = json.loads((tmp_path / "a.expected.json").read_text())
    assert exp["stations"][0]["ars"][0]["ended_by"] == "abort" and exp["clean"]


def test_plant_traffic_parameter_polls_and_it_frames(tmp_path):
    """--param-polls / --it-traffic (sim/plant.py, bench set (d)): every poll is a base-mode read pndiss decodes
    as a parameter with the truth's value, the IT frames are counted as not PROFINET (none malformed), tshark
    decodes every frame cleanly, the engine equals the reference path, and a correct plant has no violation."""
    sys.path.insert(0, os.path.dirname(__file__))
    from test_fastpath import _same_both_ways
    p = sim(tmp_path, "plant.pcapng", "--scenario", "motion", "--encoders", "2", "--io-devices", "2",
            "--cycle-time", "1,2", "--param-polls", "50", "--it-traffic", "2000", "--duration", "1.5")
    truth = json.loads((tmp_path / "plant.expected.json").read_text())
    polls = [x for x in truth["params"] if x["pnu"] in (964, 965, 979)]
    assert len(polls) > 2 * 20   # the start-up reads and about 25 polls per encoder
    if HAVE_TSHARK:
        assert tshark(p, "-Y", BAD_FILTER) == ""
    eng = _same_both_ways(str(p))
    assert eng.frames_inert > 1000
    jl = tmp_path / "ev.jsonl"
    assert main(["analyze", str(p), "-q", "--no-progress", "--jsonl", str(jl), "--events", "param,violation",
                 "--summary-json", str(tmp_path / "s.json")]) == 0
    evs = [json.loads(x) for x in jl.read_text().splitlines()]
    assert not [e for e in evs if e["kind"] == "violation"]
    params = [e for e in evs if e["kind"] == "param"]
    assert len(params) == len(truth["params"])
    acc = json.loads((tmp_path / "s.json").read_text())["accounting"]
    assert acc["malformed"] == 0 and acc["not_profinet"] == truth["frame_kinds"]["it"]
