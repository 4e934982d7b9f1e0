"""The conforming device model (ReferenceEncoder) against the checker, and the worked examples of
behaviour.md §4.4 / cyclic.md §8.1 through the position arithmetic."""
import pytest
from hypothesis import given, settings, strategies as st

from encoder_table import make_cfg
from pndiss import telegrams as tg
from pndiss.encoder import Checker, ReferenceEncoder, position as P


def drive(cfg, script, shaft=lambda n: 5000):
    """Run the model with setpoints from ``script(n)`` and judge every cycle; encoder-side violations."""
    enc, chk = ReferenceEncoder(cfg), Checker(cfg)
    out, acts = [], []
    for n in range(len(script)):
        sp = script[n]
        ac = enc.respond(sp, shaft(n))
        acts.append(ac)
        out += chk.cycle(n, n, sp, ac)
    out += chk.finish()
    return [e for e in out if e["kind"] == "violation" and e["side"] == "encoder"], acts, enc


def setpoints(n, *, g1=0x2000, events=(), ctrl=True, iso_cls=False):
    """n cycles of setpoints; ``events`` = {cycle: g1_stw} changes; C-LS counts when iso_cls."""
    out, g, cls = [], g1, 0
    ev = dict(events)
    for i in range(n):
        g = ev.get(i, g)
        cls = (cls % 15) + 1 if iso_cls else 0
        out.append({"stw2_enc": (cls << 12) | (0x0400 if ctrl else 0), "g1_stw": g})
    return out


@pytest.mark.parametrize("profile", ["lika", "scancon", "hohner", "psm", "generic"])
@pytest.mark.parametrize("telegram", [81, 82, 83, 84])
def test_model_conforms_through_preset_park_and_error(profile, telegram):
    cfg = make_cfg(profile=profile, telegram=telegram, class4=1, shift=0)
    script = setpoints(60, events={5: 0x3000, 8: 0x2000, 12: 0x3800, 15: 0x2000, 20: 0x6000, 25: 0x2000,
                                   40: 0xA000, 43: 0x2000})
    enc = ReferenceEncoder(cfg)
    assert enc.write_parameter(65000, 1000) == (True, None)
    chk = Checker(cfg)
    out = chk.on_record({"kind": "param", "frame": 0, "request_id": "change parameter", "ok": True, "request_ref": 1,
                         "params": [{"pnu": 65000, "subindex": 0, "values": [], "error": None,
                                     "written": {"values": [1000]}}]})
    for n, sp in enumerate(script):
        if n == 35:
            enc.inject_error(0x1001)
        out += chk.cycle(n, n, sp, enc.respond(sp, 4000 + (n // 50)))
    out += chk.finish()
    bad = [(e["rule"], e["message"]) for e in out if e["kind"] == "violation" and e["side"] == "encoder"]
    assert bad == []
    states = {(e["state"], e.get("value_name", e["value"])) for e in out if e["kind"] == "state"}
    assert ("preset", "done") in states and ("parked", 1) in states and ("sensor_error", 0x1001) in states


def test_model_conforms_isochronous_sign_of_life():
    cfg = make_cfg(profile="scancon", iso=True, shift=0)
    viol, acts, _ = drive(cfg, setpoints(40, iso_cls=True))
    assert viol == []
    dls = [a["zsw2_enc"] >> 12 for a in acts]
    assert dls[0] == 0 and all(dls[i + 1] == (dls[i] % 15) + 1 for i in range(1, 39))


def test_checker_catches_a_faulty_model():
    # the same model with its control-requested bit stuck at 0 must be caught (#13)
    cfg = make_cfg(profile="hohner", shift=0)
    enc, chk = ReferenceEncoder(cfg), Checker(cfg)
    rules = set()
    for n, sp in enumerate(setpoints(10)):
        ac = enc.respond(sp, 100)
        ac["zsw2_enc"] &= ~0x0200
        rules |= {e["rule"] for e in chk.cycle(n, n, sp, ac) if e["kind"] == "violation"}
    rules |= {e["rule"] for e in chk.finish() if e["kind"] == "violation"}
    assert rules == {"CTRLREQ-MISMATCH"}


@pytest.mark.parametrize("telegram", [860, 86, 88, 101])
def test_model_preset_telegrams(telegram):
    cfg = make_cfg(profile="psm" if telegram != 860 else "scancon", telegram=telegram, shift=0)
    name = tg.layout(telegram, "setpoint").names[0]
    top = 63 if name.endswith("_c") else 31
    script = [{name: 0}] * 3 + [{name: (1 << top) | 777}] * 2 + [{name: 0}] * 20
    viol, acts, _ = drive(cfg, script)
    assert viol == []
    pos = acts[-1].get("g1_xist1", acts[-1].get("g1_xist3"))
    assert pos == 777


def test_lika_relative_preset_example():
    # behaviour.md §4.4 #1 (000_37bf2397999f1108.txt:1823-1829): 5000 + P65000 1000 -> 6000 in XIST1 and XIST2
    cfg = make_cfg(profile="lika")
    script = setpoints(6, events={3: 0x3800})
    enc = ReferenceEncoder(cfg)
    enc.write_parameter(65000, 1000)
    acts = [enc.respond(sp, 5000) for sp in script]
    first_done = next(a for a in acts if a["g1_zsw"] & 0x1000)
    assert first_done["g1_xist1"] == 6000 and first_done["g1_xist2"] == 6000


def test_scancon_left_aligned_preset_example():
    # behaviour.md §4.4 #2: 25-bit SCANCON profile 4.0, shift 7; XIST2 0x001D2B64 -> XIST1 0x0E95B200,
    # absolute preset 100 -> XIST2 = 100, XIST1 = 100 << 7 = 0x00003200
    assert P.aligned_xist1(0x001D2B64, 7) == 0x0E95B200
    cfg = make_cfg(profile="scancon", class4=1, preset_control=0, shift=7, st_phys=8192, mt_phys=4096)
    enc = ReferenceEncoder(cfg)
    enc.write_parameter(65000, 100)
    acts = [enc.respond(sp, 0x001D2B64) for sp in setpoints(5, events={2: 0x3000})]
    assert acts[0]["g1_xist1"] == 0x0E95B200 and acts[0]["g1_xist2"] == 0x001D2B64
    assert acts[2]["g1_xist2"] == 100 and acts[2]["g1_xist1"] == 0x00003200
    # with preset control disabled (SCANCON coding 1) XIST1 keeps the unshifted-by-preset position
    cfg.preset_control = 1
    enc = ReferenceEncoder(cfg)
    enc.write_parameter(65000, 100)
    acts = [enc.respond(sp, 0x001D2B64) for sp in setpoints(5, events={2: 0x3000})]
    assert acts[2]["g1_xist2"] == 100 and acts[2]["g1_xist1"] == 0x0E95B200


def test_hohner_preset_control_is_inverted():
    # behaviour.md §7 D14: HOHNER 0 (default) = does not affect XIST1, 1 = affects
    assert not make_cfg(profile="hohner", class4=1, preset_control=0).xist1_preset_affected
    assert make_cfg(profile="hohner", class4=1, preset_control=1).xist1_preset_affected
    assert make_cfg(profile="lika", class4=1, preset_control=0).xist1_preset_affected
    assert not make_cfg(profile="lika", class4=0, preset_control=0).xist1_preset_affected


def test_preset_arithmetic_formulas():
    # §4.3: absolute offset makes pos = P; relative shifts by P; 860 clamps to R - 1
    R = 1 << 25
    off = P.preset_offset(0, 100, s_now=1_911_652, offset=0, R=R)
    assert P.with_offset(1_911_652, off, R) == 100
    off2 = P.preset_offset(1, 1000, s_now=5000, offset=0, R=R)
    assert P.with_offset(5000, off2, R) == 6000
    assert P.preset_860(R + 5, R) == R - 1 and P.preset_860(5, R) == 5
    assert P.delta(R - 1, 0, R) == 1 and P.delta(0, R - 1, R) == -1


def test_scaling_red_zone_example():
    # behaviour.md §4.4 #3: 16384 x 3600 / 360000 = 163.84 -> LIKA red zone 58,982,400 mod 360,000 = 302,400
    assert (16384 * 3600) % 360_000 == 302_400
    s = P.scaled(65536 * 16383 + 65535, class4=1, scaling=1, mupr=3600, tmr=360_000, st_phys=65536, mt_phys=16384)
    assert 0 <= s < 360_000


@settings(max_examples=200, deadline=None)
@given(mode=st.integers(0, 1), p=st.integers(0, (1 << 25) - 1), s=st.integers(0, (1 << 25) - 1),
       offset=st.integers(0, (1 << 25) - 1))
def test_preset_then_position_matches_expected(mode, p, s, offset):
    R = 1 << 25
    before = P.with_offset(s, offset, R)
    new = P.preset_offset(mode, p, s, offset, R)
    assert P.with_offset(s, new, R) == P.expected_after_preset(mode, p, before, R)


def test_write_parameter_refusals():
    enc = ReferenceEncoder(make_cfg(class4=0))
    assert enc.write_parameter(65000, 1) == (False, 0x11)
    enc = ReferenceEncoder(make_cfg())
    assert enc.write_parameter(65000, 1 << 25) == (False, 0x02)
    assert enc.write_parameter(922, 83) == (False, 0x01)


@settings(max_examples=200, deadline=None)
@given(profile=st.sampled_from(["lika", "scancon", "hohner", "psm", "generic"]),
       telegram=st.sampled_from(sorted(tg.TELEGRAMS)), iso=st.booleans(),
       raw=st.lists(st.binary(min_size=40, max_size=40), min_size=1, max_size=25))
def test_checker_survives_random_cycles(profile, telegram, iso, raw):
    """Random words through the checker: only well-formed events come out, nothing raises."""
    from pndiss import rules
    cfg = make_cfg(profile=profile, telegram=telegram, iso=iso, shift=None)
    chk = Checker(cfg)
    evs = []
    for i, b in enumerate(raw):
        sp = tg.decode(telegram, "setpoint", b[:20])
        ac = tg.decode(telegram, "actual", b[20:40])
        evs += chk.gap(i, i, "x") if b[0] == 0 else chk.cycle(i, i, sp, ac)
    evs += chk.finish()
    for e in evs:
        assert e["kind"] in ("violation", "state") and isinstance(e["frame"], int)
        if e["kind"] == "violation":
            assert e["rule"] in rules.RULES and e["last_frame"] >= e["frame"]
