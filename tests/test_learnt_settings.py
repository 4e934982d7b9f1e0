"""What the capture does not say: learnt from what it shows, or not judged.

The compatibility mode learnt from the words when no 0xBF00 says it (a capture started mid-session,
a lost write): behaviour.md §2.1-2.2, docs/settings.md ``compat``. Until the words show the mode, the
rules that depend on it (#13-#16) are not judged; with the mode given, the same rows are faults. A SCANCON
velocity filter written (record 0x1000, codes undocumented) leaves NIST's lag unknown: NIST-SIGN is not judged."""
from __future__ import annotations

import shutil

import pytest

import encoder_table as T
from pndiss.encoder import Checker

# telegram 81 rows: STW2_ENC G1_STW | ZSW2_ENC G1_ZSW G1_XIST1 G1_XIST2 (bit 10 of STW2_ENC = control by
# PLC, bit 9 of ZSW2_ENC = control requested; G1_STW.13 / G1_ZSW.13 = absolute value request / transmitted)
V41 = "0x0400 0x0000 | 0x0200 0x0000 5 0"
CTRL_NO_CREQ = "0x0400 0x0000 | 0x0000 0x0000 5 0"
IDLE = "0x0000 0x0000 | 0x0000 0x0000 5 0"
AREQ = "0x0000 0x2000 | 0x0000 0x0000 5 0"
ATX = "0x0000 0x2000 | 0x0000 0x2000 5 5"

# (name, rows, violations with compat open, learnt mode (None: still open), violations with compat = 1 given)
CASES = [
    ("v41 then control requested drops", [(V41, 5), (CTRL_NO_CREQ, 5)], {"CTRLREQ-MISMATCH"}, 1,
     {"CTRLREQ-MISMATCH"}),
    ("control requested held 0 under control", [(CTRL_NO_CREQ, 10)], set(), 0, {"CTRLREQ-MISMATCH"}),
    ("command executed without control", [(IDLE, 5), (AREQ, 1), (ATX, 5)], set(), 0,
     {"CMD-WITHOUT-CONTROL", "CMD-EXECUTED-WITHOUT-CONTROL"}),
    ("no control, no command", [(IDLE, 20)], set(), None, set()),
    ("v41 throughout", [(V41, 20)], set(), 1, set()),
]


def _run(rows, compat):
    chk = Checker(T.make_cfg(compat=compat))
    out = []
    for i, r in enumerate(T.expand(rows)):
        sp, ac = T.parse(r, 81)
        out += chk.cycle(i, i * 1000, sp, ac)
    out += chk.finish()
    return {e["rule"] for e in out if e["kind"] == "violation"}, chk


@pytest.mark.parametrize("name,rows,open_rules,learnt,given_rules", CASES, ids=[c[0] for c in CASES])
def test_mode_learnt_from_the_words(name, rows, open_rules, learnt, given_rules):
    got, chk = _run(rows, None)
    assert got == open_rules
    src = chk.cfg.sources["compat"]
    if learnt is None:
        assert chk.cfg.compat_open() and chk.compat_open
    else:
        assert chk.cfg.compat == learnt and src.startswith("learnt from the words (frame ")
    given, chk1 = _run(rows, 1)
    assert given == given_rules and not chk1.compat_open


P965 = {"kind": "param", "request_id": 0x01, "response_id": 0x01, "params": [{"pnu": 965, "subindex": 1, "values": [31]}]}


def test_p965_tells_the_mode():
    """P965.1 = 31 is V3.1 mode (behaviour.md §2.2): learnt while open, a fault when compat = 1 was given."""
    ev = P965
    got = T.run([dict(ev)], compat=None)
    assert got == []
    chk = Checker(T.make_cfg(compat=None))
    chk.on_record(dict(ev, frame=1, ts_ns=1))
    assert chk.cfg.compat == 0 and chk.cfg.sources["compat"] == "learnt from P965.1 = 31 (frame 1)"
    assert {e["rule"] for e in T.run([dict(ev)], compat=1)} == {"P965-VERSION-MISMATCH"}


@pytest.mark.skipif(shutil.which("lua5.2") is None, reason="lua5.2 not installed")
def test_lua_port_learns_the_same():
    from luachk.record import Recorder, replay
    with Recorder() as rec:
        for _name, rows, *_ in CASES:
            _run(rows, None)
            _run(rows, 1)
        T.run([dict(P965)] + [V41] * 3, compat=None)
        T.run([dict(P965)], compat=1)
    res = replay(rec)
    assert not res["problems"], "\n".join(res["problems"][:20])


# -- SCANCON's velocity filter (record 0x1000): NIST lags a reversal by an unknown number of cycles --------

FILTER = {"kind": "record", "op": "write", "index": 0x1000, "decoded": {"velocity_filter": 1}}
AGAINST = ["0x1400 0x2000 | 0x1200 0x2000 %d %d -10" % (i, i) for i in range(5, 15)]   # moving up, NIST < 0


def _against(n):
    """n cycles moving up with NIST < 0 (after a first row that has no motion yet)."""
    return ["0x1400 0x2000 | 0x1200 0x2000 %d %d -10" % (i, i) for i in range(5, 6 + n)]


LIKA_LAG = 2 * 100 + 2      # cycles at 1 ms: two 100 ms velocity intervals + L_max (telegrams.json velocity_update_ms)


def test_velocity_filter_written_nist_sign_not_judged():
    assert "NIST-SIGN" in T.rule_ids(AGAINST, profile="scancon", telegram=83)
    assert "NIST-SIGN" not in T.rule_ids([dict(FILTER)] + AGAINST, profile="scancon", telegram=83)
    # SCANCON's record only: a LIKA still judged (over its own, longer lag)
    assert "NIST-SIGN" in T.rule_ids([dict(FILTER)] + _against(LIKA_LAG + 1), profile="lika", telegram=83)


def test_lika_nist_lags_a_reversal_by_its_100ms_interval():
    """LIKA computes NIST every 100 ms (000_37bf2397999f1108.txt:1919): at a reversal it may keep the old sign
    for up to two intervals (one straddling the reversal, then held) + L_max; a longer run is the fault."""
    assert "NIST-SIGN" not in T.rule_ids(_against(LIKA_LAG), profile="lika", telegram=83)
    assert "NIST-SIGN" in T.rule_ids(_against(LIKA_LAG + 1), profile="lika", telegram=83)
    assert "NIST-SIGN" in T.rule_ids(_against(3), profile="generic", telegram=83)
    assert "NIST-SIGN" not in T.rule_ids(_against(2), profile="generic", telegram=83)


@pytest.mark.skipif(shutil.which("lua5.2") is None, reason="lua5.2 not installed")
def test_velocity_filter_lua_same():
    from luachk.record import Recorder, replay
    with Recorder() as rec:
        for prof in ("scancon", "lika"):
            T.run([dict(FILTER)] + AGAINST, profile=prof, telegram=83)
            T.run(AGAINST, profile=prof, telegram=83)
        for n in (LIKA_LAG, LIKA_LAG + 1):
            T.run(_against(n), profile="lika", telegram=83)
    res = replay(rec)
    assert not res["problems"], "\n".join(res["problems"][:20])
    assert "NIST-SIGN" in res["lua_rules"]


# -- diagnosis alarms of the encoder's submodule (#48, #70) ------------------------------------------------

PARKED = [("0x1400 0x4000 | 0x1200 0x0000 5 0", 1), ("0x1400 0x4000 | 0x1200 0x4000 0 0", 6)]   # PARK -> PKA
RUNNING = [("0x1400 0x2000 | 0x1200 0x2000 5 5", 6)]
REJECTED = [("0x1400 0x2000 | 0x1200 0xA000 5 0x1002", 6)]   # SERR with the parameterisation fault 0x1002


def _alarm(frame, cet=0x9000, specifier=1, alarm_type=1):
    return {"kind": "alarm", "frame": frame, "ts_ns": frame, "alarm_type": alarm_type, "slot_nr": 1, "subslot_nr": 2,
            "items": [{"channel_error_type": cet, "channel_properties": {"specifier": specifier}}]}


def _with_alarm(rows, alarm, compat=1, before=()):
    chk = Checker(T.make_cfg(compat=compat))
    out = []
    for ev in before:
        out += chk.on_record(dict(ev))
    n = 0
    for r in T.expand(rows):
        sp, ac = T.parse(r, 81)
        n += 1
        out += chk.cycle(n, n * 1000, sp, ac)
    if alarm is not None:
        out += chk.on_alarm(alarm)
    for r in T.expand(RUNNING * 5):
        sp, ac = T.parse(r, 81)
        n += 1
        out += chk.cycle(n, n * 1000, sp, ac)
    out += chk.finish()
    return [e["rule"] for e in out if e["kind"] == "violation"]


BAD_BF00 = {"kind": "record", "op": "write", "index": 0xBF00, "frame": 0, "ts_ns": 0, "length": 31, "data": "00" * 31,
            "decoded": {"compat": 1, "class4": 1, "mupr": 0, "problems": [
                {"rule": "BF00-VALUE-OUT-OF-RANGE", "message": "MUPR 0"}]}}


def test_alarm_while_parked_and_commissioning_diagnostic():
    assert "PARK-ERROR-REPORTED" in _with_alarm(PARKED, _alarm(99))                    # 48
    assert "PARK-ERROR-REPORTED" not in _with_alarm(PARKED, None)
    assert "PARK-ERROR-REPORTED" not in _with_alarm(PARKED, _alarm(99, specifier=2))   # a diagnosis disappears
    assert "PARK-ERROR-REPORTED" not in _with_alarm(RUNNING, _alarm(99))               # not parked
    assert "PARK-ERROR-REPORTED" not in _with_alarm(PARKED, _alarm(99, alarm_type=3))  # a pull alarm: no diagnosis
    # 70: an invalid 0xBF00 reported by the commissioning diagnostic 0x9011 (000_37bf2397999f1108.txt:2611-2615)
    assert "BF00-ERROR-NOT-REPORTED" in _with_alarm(RUNNING, None, before=[BAD_BF00])
    assert "BF00-ERROR-NOT-REPORTED" not in _with_alarm(RUNNING, _alarm(5, cet=0x9011), before=[BAD_BF00])
    assert "BF00-ERROR-NOT-REPORTED" in _with_alarm(RUNNING, _alarm(5, cet=0x9000), before=[BAD_BF00])
    # 71: a valid 0xBF00 rejected by the commissioning diagnostic, reported once; not when the data shows it
    good = dict(BAD_BF00, decoded={"compat": 1, "class4": 1, "mupr": 1})
    assert _with_alarm(RUNNING, _alarm(5, cet=0x9011), before=[good]).count("BF00-VALID-REJECTED") == 1
    assert "BF00-VALID-REJECTED" not in _with_alarm(RUNNING, _alarm(5, cet=0x9000), before=[good])
    assert "BF00-VALID-REJECTED" not in _with_alarm(RUNNING, _alarm(5, cet=0x9011), before=[BAD_BF00])
    assert _with_alarm(REJECTED, _alarm(5, cet=0x9011), before=[good]).count("BF00-VALID-REJECTED") == 1


@pytest.mark.skipif(shutil.which("lua5.2") is None, reason="lua5.2 not installed")
def test_alarms_lua_same():
    from luachk.record import lua_same
    assert {"PARK-ERROR-REPORTED", "BF00-ERROR-NOT-REPORTED", "BF00-VALID-REJECTED"} <= lua_same(
        test_alarm_while_parked_and_commissioning_diagnostic)


def _psm_later(rows_before, rows_after):
    chk = Checker(T.make_cfg(compat=None, profile="generic"))
    out, n = [], 0
    for r in T.expand(rows_before):
        sp, ac = T.parse(r, 81)
        n += 1
        out += chk.cycle(n, n * 1000, sp, ac)
    learnt = (chk.cfg.compat, chk.cfg.sources["compat"])
    chk.cfg.profile = "psm"   # what cyclic_axes._refine_profile does when a 0xFFFF write shows PS/PSM
    chk.cfg.sources["profile"] = "record 0xFFFF written"
    chk.reconfigure()
    for r in T.expand(rows_after):
        sp, ac = T.parse(r, 81)
        n += 1
        out += chk.cycle(n, n * 1000, sp, ac)
    out += chk.finish()
    return learnt, (chk.cfg.compat, chk.cfg.sources["compat"]), {e["rule"] for e in out if e["kind"] == "violation"}


def test_mode_learnt_at_the_generic_bit_is_learnt_again_for_psm():
    """PS/PSM's "control requested" is ZSW2_ENC bit 10 (behaviour.md §2.1): read at the generic bit 9 it looked
    held at 0, i.e. V3.1; once the device is known as PS/PSM the mode is learnt again at bit 10."""
    psm_v41 = ("0x0400 0x0000 | 0x0400 0x0000 5 0", 6)   # control by PLC, control requested at bit 10
    (m0, s0), (m1, s1), rules = _psm_later([psm_v41], [psm_v41])
    assert m0 == 0 and s0.startswith("learnt from the words")
    assert m1 == 1 and s1.startswith("learnt from the words") and "CTRLREQ-SET-IN-COMPAT" not in rules


@pytest.mark.skipif(shutil.which("lua5.2") is None, reason="lua5.2 not installed")
def test_mode_learnt_again_lua_same():
    from luachk.record import lua_same
    lua_same(test_mode_learnt_at_the_generic_bit_is_learnt_again_for_psm)


# -- P925: the tolerated master sign-of-life failures in V4.1 mode (behaviour.md §3.3 R-SOLC-3) ------------

def test_p925_sets_the_tolerated_failures():
    from pndiss.encoder import EncoderConfig
    c = T.make_cfg(profile="hohner")
    assert c.n_sol == 1
    chk = Checker(c)
    ev = {"kind": "param", "request_id": 0x02, "response_id": 0x02, "frame": 7, "response_frame": 7,
          "params": [{"pnu": 925, "subindex": 0, "values": [], "written": {"values": [3]}}]}
    chk.on_record(ev)
    assert chk.cfg.n_sol == 3 and chk.sol_limit == 30 and chk.cfg.sources["p925"] == "P925 written (frame 7)"
    chk.cfg.compat = 0          # V3.1 mode: 0xBF00 byte 17 instead
    assert chk.cfg.n_sol == chk.cfg.max_master_sol_failures
    read = {"kind": "param", "request_id": 0x01, "response_id": 0x01, "frame": 9, "response_frame": 9,
            "params": [{"pnu": 925, "subindex": 0, "values": [5]}]}
    chk2 = Checker(T.make_cfg(profile="hohner"))
    chk2.on_record(read)
    assert chk2.cfg.n_sol == 5
    assert isinstance(EncoderConfig().n_sol, int)


@pytest.mark.skipif(shutil.which("lua5.2") is None, reason="lua5.2 not installed")
def test_p925_lua_same():
    """The port takes P925 the same way: a master sign-of-life stall of 3 cycles is tolerated with P925 = 3
    (no SOL-FAULT-MISSING), and is a fault without it."""
    from luachk.record import Recorder, replay
    p925 = {"kind": "param", "request_id": 0x02, "response_id": 0x02, "frame": 0, "response_frame": 0,
            "params": [{"pnu": 925, "subindex": 0, "values": [], "written": {"values": [3]}}]}
    rows = []
    ls = 1
    for i in range(40):
        if not 20 <= i < 23:   # the controller's sign-of-life stalls for 3 cycles
            ls = ls % 15 + 1
        rows.append("0x%X 0x2000 | 0x%X 0x2000 5 5" % (0x0400 | ls << 12, 0x0200 | (i % 15 + 1) << 12))
    with Recorder() as rec:
        with_p = T.rule_ids([dict(p925)] + rows, profile="hohner", iso=True)
        without = T.rule_ids(rows, profile="hohner", iso=True)
    res = replay(rec)
    assert not res["problems"], "\n".join(res["problems"][:20])
    assert "SOL-FAULT-MISSING" not in with_p and "SOL-FAULT-MISSING" in without


# -- what the end of a capture or a lost request leaves open ----------------------------------------------

def test_capture_ends_inside_the_preset_window():
    """A capture that ends a few cycles after a preset request proves no missing acknowledgement: #19's
    window is D_preset (behaviour.md §9.3); after it the fault stands (the audit's end-of-capture sweep)."""
    from test_encoder_rules import G, REQ
    chk = Checker(T.make_cfg())
    rows = [G, (REQ, 5)]
    out = []
    for i, r in enumerate(T.expand(rows)):
        sp, ac = T.parse(r, 81)
        out += chk.cycle(i, i * 1000, sp, ac)
    out += chk.finish()
    assert "PRESET-ACK-MISSING" not in {e["rule"] for e in out if e["kind"] == "violation"}
    assert chk.summary()["preset_open_at_end"] == 1
    assert "PRESET-ACK-MISSING" in T.rule_ids([G, (REQ, 15)])


def test_lost_change_request_makes_p65000_unknown():
    """A change answered positively whose request the capture lost may have set P65000: presets after it
    are not judged on their value (the audit's lost_p65000_change_req: four false PRESET-VALUE-WRONG)."""
    lost = {"kind": "param", "request_id": None, "response_id": 0x02, "frame": 3, "response_frame": 3,
            "params": [], "pairing": ["no request"]}
    chk = Checker(T.make_cfg())
    assert chk.p65000 == 0
    chk.on_record(dict(lost))
    assert chk.p65000 is None


@pytest.mark.skipif(shutil.which("lua5.2") is None, reason="lua5.2 not installed")
def test_open_ends_lua_same():
    from test_encoder_rules import G, REQ
    from luachk.record import Recorder, replay
    lost = {"kind": "param", "request_id": None, "response_id": 0x02, "frame": 3, "response_frame": 3,
            "params": [], "pairing": ["no request"]}
    with Recorder() as rec:
        T.run([G, (REQ, 5)])
        T.run([G, (REQ, 15)])
        T.run([dict(lost), G, G])
    res = replay(rec)
    assert not res["problems"], "\n".join(res["problems"][:20])


def test_controller_holding_each_sign_of_life_k_cycles_is_named():
    """An isochronous controller whose application cycle is 2 bus cycles holds every sign-of-life value 2
    cycles: with k = 1 each hold is a stall (001_9461bb7bc8c2767b.txt:1671, 1677). The histogram of holds
    names k = 2 in the Trust section (the audit's irt_k2: 1,956 errors and no hint)."""
    from pndiss.verdict import trust
    rows, ls = [], 1
    for i in range(40):
        if i % 2 == 0:
            ls = ls % 15 + 1
        rows.append("0x%X 0x2000 | 0x%X 0x2000 5 5" % (0x0400 | ls << 12, 0x0200 | (i % 15 + 1) << 12))
    chk = Checker(T.make_cfg(profile="hohner", iso=True))
    out = []
    for i, r in enumerate(rows):
        sp, ac = T.parse(r, 81)
        out += chk.cycle(i, i * 1000, sp, ac)
    out += chk.finish()
    s = chk.summary()
    assert "SOL-MASTER-STALL" in {e["rule"] for e in out if e["kind"] == "violation"}
    assert s["controller_sol_runs"] == {"2": 19}
    enc = dict(s, station="enc", device_mac="m", slot=1, subslot=2)
    lines = trust({"cyclic": {"encoders": [enc]}, "accounting": {}})
    assert any("--set master_cycle_ratio=2" in line for line in lines)
    chk2 = Checker(T.make_cfg(profile="hohner", iso=True, k=2))   # with k = 2: no stall, no hint
    out2 = []
    for i, r in enumerate(rows):
        sp, ac = T.parse(r, 81)
        out2 += chk2.cycle(i, i * 1000, sp, ac)
    assert "SOL-MASTER-STALL" not in {e["rule"] for e in out2 if e["kind"] == "violation"}


def _t860(after):
    trig = 0x80000000 | 40_000_000                       # preset 40,000,000 above an unknown range
    rows = [("%d | 1000 0" % 40_000_000, 3), ("%d | 1000 0" % trig, 1), ("%d | %d 0" % (trig, after), 14),
            ("%d | %d 0" % (40_000_000, after), 3)]
    return T.rule_ids(rows, profile="hohner", telegram=860, st_phys=None, mt_phys=None, p65000=None)


def test_860_clamped_to_an_unknown_binary_range():
    """Telegram 860 presets to min(PV, R - 1) (001_9461bb7bc8c2767b.txt:931). With R unknown (no scaling,
    no st_phys/mt_phys) a steady 2^k - 1 below PV is that clamp (the audit's t860 on API 0: a false
    PRESET860-WRONG); any other position is still wrong."""
    assert "PRESET860-WRONG" not in _t860((1 << 25) - 1)
    assert "PRESET860-WRONG" in _t860((1 << 25) - 2)


@pytest.mark.skipif(shutil.which("lua5.2") is None, reason="lua5.2 not installed")
def test_860_clamp_lua_same():
    from luachk.record import lua_same
    assert "PRESET860-WRONG" in lua_same(test_860_clamped_to_an_unknown_binary_range)


def test_master_cycle_ratio_from_isochronous_mode_data():
    """Record 0x8030 IsochronousModeData names ControllerApplicationCycleFactor: the controller's sign-of-life counts
    once per that many cycles (k). Written before data exchange it replaces k = 1 (no false SOL-MASTER-STALL on a
    k = 2 controller); a k given with --set master_cycle_ratio stays. Python and the Lua checker."""
    from luachk.record import Recorder, replay
    rec = {"kind": "record", "op": "write", "index": 0x8030, "frame": 1, "ts_ns": 1,
           "data": "0204001c0100" + "0000" + "0001" + "0002" + "0002" + "00" * 16}   # slot 1, subslot 2, CACF 2
    rows = []
    for i in range(40):
        m, d = (i // 2) % 15 + 1, i % 15 + 1
        rows.append(f"0x{0x0400 | m << 12:04x} 0x2000 | 0x{0x0200 | d << 12:04x} 0x2000 5 5")
    with Recorder() as r:
        assert T.rule_ids([rec] + rows, iso=True) == set()
        assert {"SOL-MASTER-STALL"} <= T.rule_ids(rows, iso=True)
        assert T.rule_ids([rec] + rows, iso=True, k=3)   # k given: the record does not replace it (a fault for k = 3)
    if shutil.which("lua5.2"):
        res = replay(r)
        assert not res["problems"], "\n".join(res["problems"][:20])


# -- vendor defaults are no facts of a device the PLC parameterises at every start-up (no 0xBF00 in the capture) --

def _open_run(rows, profile, telegram=81, given=None):
    """rows through a checker whose 0xBF00 settings are the profile defaults (open) or ``given`` as --set would."""
    from pndiss.encoder import EncoderConfig
    from pndiss.settings import Settings
    cfg = EncoderConfig.from_settings(Settings(), profile=profile, telegram=telegram)
    for k, v in (given or {}).items():
        setattr(cfg, k, v)
        cfg.sources[k] = "settings." + k if k != "shift" else "P979.3 read (frame 1)"
    chk = Checker(cfg)
    out = []
    for i, r in enumerate(T.expand(rows)):
        sp, ac = T.parse(r, telegram)
        out += chk.cycle(i, i * 1000, sp, ac)
    out += chk.finish()
    return {e["rule"] for e in out if e["kind"] == "violation"}


STILL = ("0x1400 0x2000 | 0x1200 0x2000 1000 5", 3)
PRESET = [STILL, "0x1400 0x3000 | 0x1200 0x2000 1000 5", ("0x1400 0x3000 | 0x1200 0x3000 1000 0", 3),
          ("0x1400 0x2000 | 0x1200 0x2000 1000 0", 3)]
CLASS4 = {"PRESET-CLASS4-DISABLED", "PRESET-EXECUTED-WHEN-NOT-ALLOWED"}


def test_class4_default_is_not_judged():
    """Hohner's factory default is class 4 off (telegrams.json profile_defaults): a mid-session capture's presets
    are not both sides' errors on that default (an independent audit: every preset blamed twice)."""
    assert not _open_run(PRESET, "hohner") & CLASS4
    assert _open_run(PRESET, "hohner", given={"class4": 0}) >= CLASS4


def test_xist1_of_an_unknown_vendor_is_not_judged_against_xist2():
    """X1 = 1000 with X2 = 5: a profile 4.1 counter (SCANCON, Hohner) or a fault -- for a device of unknown vendor
    only when the shift was read (P979) or given; LIKA's X1 is X2 shifted (#40)."""
    rows = [("0x1400 0x2000 | 0x1200 0x2000 1000 5", 3)]
    assert "XIST2-INCONSISTENT" not in _open_run(rows, "generic")
    assert "XIST2-INCONSISTENT" in _open_run(rows, "generic", given={"shift": 0})
    assert "XIST2-INCONSISTENT" in _open_run(rows, "lika")


def test_preset_control_default_is_not_judged():
    """What a preset does to G1_XIST1 is the 0xBF00's preset control bit: without it, X1 is not judged (#28, #29)."""
    rows = [("0x1400 0x2000 | 0x1200 0x2000 40 5", 3), "0x1400 0x3000 | 0x1200 0x2000 40 5",
            ("0x1400 0x3000 | 0x1200 0x3000 40 0", 3), ("0x1400 0x2000 | 0x1200 0x2000 40 0", 3)]
    X1_RULES = {"PRESET-XIST1-NOT-AFFECTED-WHEN-ENABLED", "PRESET-XIST1-AFFECTED-WHEN-DISABLED"}
    assert not _open_run(rows, "lika", given={"p65000": 0, "shift": 3}) & X1_RULES
    assert _open_run(rows, "lika", given={"p65000": 0, "shift": 3, "preset_control": 0}) & X1_RULES


@pytest.mark.skipif(shutil.which("lua5.2") is None, reason="lua5.2 not installed")
def test_open_defaults_lua_same():
    from luachk.record import lua_same
    lua_same(lambda: (test_class4_default_is_not_judged(), test_xist1_of_an_unknown_vendor_is_not_judged_against_xist2(),
                      test_preset_control_default_is_not_judged()))


def test_inference_takes_no_samples_of_a_stopped_provider():
    """Content inference samples only frames of a provider in RUN with valid data: in STOP the data objects' IOPS
    are bad and the IOCS bytes beside them fit a wrong layout (an independent audit: 7-29 false errors)."""
    from pndiss.infer import Inference
    inf = Inference(type("A", (), {"session": None})())
    key = (0x8001, "02:00:00:00:00:01", "02:00:00:00:01:01")
    inf.offer(key, 1, bytes(10), 0, 0x05)   # DataValid, ProviderState STOP
    assert key not in inf.streams or not inf.streams[key].samples
    inf.offer(key, 2, bytes(10), 0, 0x35)   # RUN
    assert inf.streams[key].samples
