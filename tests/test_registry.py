"""The rule registry (pndiss/encoder/registry.py, value_rules.py): every rule declared once, every value
rule with its NumPy twin, and the twin equal to the per-cycle predicate run row by row on random columns and
random configurations (hypothesis)."""
import inspect
import re
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

from pndiss import rules as R_
from pndiss import telegrams as tg
from pndiss.encoder import Checker, EncoderConfig
from pndiss.encoder import _state, registry as REG

ROOT = Path(__file__).resolve().parent.parent
U32 = 1 << 32


def test_every_value_rule_has_its_twin():
    values = [r for r in REG.REGISTRY.values() if r.kind == "value"]
    assert values, "no value rules declared"
    for r in values:
        assert callable(r.check), f"{r.id}: value rule without its per-cycle predicate"
        assert callable(r.vector), f"{r.id}: value rule without its vectorised twin"
        assert callable(r.message), f"{r.id}: value rule without its message"
    for t in REG.CHECKER_CYCLES:
        assert callable(t.check) and callable(t.vector), t.name


def test_value_rules_are_judged_only_through_the_registry():
    """Checker._value_rules may report nothing by hand: a new value rule has to be a registry entry (and so
    get its twin), or the bulk engine would skip the cycles it fires on."""
    src = inspect.getsource(_state.Checker._value_rules)
    assert not re.search(r'_hit\("', src) and not re.search(r'_emit\("', src), \
        "Checker._value_rules reports a rule by hand; declare it in encoder/registry.py VALUE_RULES"
    steady = inspect.getsource(_state.Checker._cycle_steady)
    assert not re.search(r'_hit\("', steady)


def test_every_rule_the_checker_reports_is_declared_once():
    found = set()
    for name in ("_state.py", "words.py", "presets.py", "sign_of_life.py", "steady.py", "acyclic.py", "registry.py",
                 "value_rules.py"):
        text = (ROOT / "pndiss" / "encoder" / name).read_text(encoding="utf-8")
        found |= {m for m in re.findall(r'"([A-Z0-9]+(?:-[A-Z0-9]+)+)"', text) if m in R_.RULES}
    missing = found - set(REG.REGISTRY)
    assert not missing, f"reported by the checker but not declared in encoder/registry.py: {sorted(missing)}"
    for r in REG.REGISTRY.values():
        assert r.side in ("controller", "encoder", "either") and r.source


def test_pending_is_derived_from_the_open_deadlines():
    chk = Checker(EncoderConfig())
    assert not chk._pending_steady() and REG.open_deadlines(chk) == []
    for r in REG.DEADLINES:
        assert hasattr(chk, r.state), f"{r.id}: the checker keeps no {r.state}"
        old = getattr(chk, r.state)
        setattr(chk, r.state, {k: True for k in r.open_when} if r.open_when else (1, 2, 3))
        assert chk._pending_steady() and REG.open_deadlines(chk) == [r.id]
        assert not chk.bulk_ready()
        setattr(chk, r.state, old)
    chk.pre = {"done": False, "allowed": False}   # a request already reported unanswered is inert
    assert not chk._pending_steady()


def test_follows_rows_name_the_window_history():
    for row in REG.FOLLOWS:
        assert row["rule"] in REG.REGISTRY and REG.REGISTRY[row["rule"]].kind == "window"
        assert set(row["window"]) <= set(REG.HIST) and "{n}" in row["message"]


# ---------------------------------------------------------------------------------- twins on random columns
STD = sorted(t for t in tg.TELEGRAMS if "stw2_enc" in dict(tg.TELEGRAMS[t]["setpoint"]))
SAFE = REG.SAFE


@st.composite
def setups(draw):
    profile = draw(st.sampled_from(tg.PROFILES))
    telegram = draw(st.sampled_from(STD))
    big_r = draw(st.sampled_from([False] * 6 + [True]))
    tmr = draw(st.sampled_from([None, 360, 4096, 1 << 20, U32 - 7])) if not big_r else (1 << 63) + 5
    cfg = EncoderConfig(profile=profile, telegram=telegram, compat=draw(st.sampled_from([0, 1])),
                        class4=draw(st.sampled_from([0, 1])), scaling=draw(st.sampled_from([0, 1])), tmr=tmr,
                        st_phys=draw(st.sampled_from([None, 8192])), mt_phys=draw(st.sampled_from([None, 4096])),
                        iso=draw(st.booleans()), shift=draw(st.sampled_from([None, 0, 3, 13])),
                        preset_control=draw(st.sampled_from([None, 0, 1])),
                        max_position_step=draw(st.sampled_from([None, 10, 100000])))
    chk = Checker(cfg)
    chk.started_D = draw(st.booleans())
    if cfg.shift is None:
        chk.shift_known = draw(st.booleans())
    chk.bf00_valid_frame = draw(st.sampled_from([None, 7]))
    chk.bf00_invalid = draw(st.sampled_from([None, "length"]))
    chk.pre = draw(st.sampled_from([None, {"done": False, "allowed": False}]))
    chk.pdone_since = draw(st.sampled_from([None, None, 3]))
    R = chk.R or 4096
    names = [n for n, _ in tg.TELEGRAMS[telegram]["actual"]]
    near_r = [R - 1, R, R + 1]
    pos = st.sampled_from([v for v in [0, 1, 5, 6, 1000, 1 << 31, U32 - 1, U32 - 3] + near_r if v < U32])  # 32-bit fields
    pos3 = st.sampled_from([0, 1, 5, 1000, U32 - 1, U32 + 3, SAFE - 1, SAFE, (1 << 63) + 1, (1 << 64) - 1]
                           + [v for v in near_r if v < 1 << 64])
    word = {
        "zsw2_enc": st.tuples(st.integers(0, 15), st.sampled_from([0, 0x200, 0x400, 0x8, 0x1, 0x800])).map(
            lambda t: (t[0] << 12) | t[1]),
        "g1_zsw": st.tuples(st.integers(0, 31), st.sampled_from([0, 0, 0x1, 0x400])).map(lambda t: (t[0] << 11) | t[1]),
        "g1_xist1": pos, "g1_xist2": st.one_of(pos, st.sampled_from(sorted(tg.XIST2_ERRORS) + [0x0F04, 0x1002, 0x7777])),
        "g1_xist3": pos3, "nist_a": st.sampled_from([0, 1, -1, 300, -300, 32767, -32768]),
        "nist_b": st.sampled_from([0, 1, -1, 70000, -70000]),
    }
    # mostly without a sensor error, or every row would go to the checker anyway
    quiet = draw(st.booleans())
    if quiet:
        word["g1_zsw"] = st.sampled_from([0x0000, 0x2000, 0x4000, 0x1000, 0x3000, 0x6000, 0x2800])
    m = draw(st.integers(1, 12))
    rows = [{n: draw(word[n]) for n in names} for _ in range(m)]
    prev = draw(st.one_of(st.none(), st.just(None).map(lambda _: {n: draw(word[n]) for n in names})))
    chk.prev_ac = prev
    return chk, names, rows


def _columns(names, rows) -> dict:
    return {n: np.array([r[n] for r in rows], dtype=np.uint64 if n == "g1_xist3" else np.int64) for n in names}


@settings(max_examples=250, deadline=None, suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large])
@given(setups())
def test_twins_equal_the_per_cycle_predicates(setup):
    chk, names, rows = setup
    has_g1 = "g1_zsw" in names
    cols = _columns(names, rows)
    V = REG.Columns(chk, cols, has_g1)
    started, pa = chk.started_D, chk.prev_ac
    expect = {e: [] for e in REG.VALUE_RULES + REG.CHECKER_CYCLES}
    for ac in rows:
        started = started or (ac.get("zsw2_enc", 0) >> 12) != 0   # "once data exchange has started" (#8)
        c = REG.Cycle.of(ac, pa, has_g1, started)
        for e in expect:
            expect[e].append(bool(e.check(chk, c)))
        pa = ac
    any_row = np.zeros(len(rows), dtype=bool)
    for e, want in expect.items():
        got = np.asarray(e.vector(chk, V), dtype=bool)
        name = getattr(e, "id", None) or e.name
        assert got.tolist() == want, f"{name}: twin {got.tolist()} != per-cycle {want} on {rows} (prev {chk.prev_ac})"
        any_row |= np.array(want, dtype=bool)
    unsafe = chk.vector_unsafe(cols, has_g1)
    if chk.solmon:
        assert unsafe.all()
    else:
        assert unsafe.tolist() == any_row.tolist()


def test_vector_unsafe_flags_what_the_checker_reports():
    """A capture-like stretch: LIKA, XIST2 sent without a request in row 2 only (#39)."""
    chk = Checker(EncoderConfig(profile="lika", telegram=81))
    chk.prev_ac = {"zsw2_enc": 0x1200, "g1_zsw": 0, "g1_xist1": 5, "g1_xist2": 0}
    chk.started_D = True
    rows = [{"zsw2_enc": 0x1200, "g1_zsw": 0, "g1_xist1": 5, "g1_xist2": x} for x in (0, 0, 9, 0)]
    cols = _columns(["zsw2_enc", "g1_zsw", "g1_xist1", "g1_xist2"], rows)
    assert chk.vector_unsafe(cols, True).tolist() == [False, False, True, False]
    cols["zsw2_enc"][3] = 0x0200    # DLS back to 0 in RT (#8)
    assert chk.vector_unsafe(cols, True).tolist() == [False, False, True, True]


@pytest.mark.parametrize("rule", [r.id for r in REG.VALUE_RULES])
def test_each_value_rule_is_exercised_by_the_rule_tables(rule):
    """Per-rule positive/negative cycle tables (tests/test_encoder_rules.py; the record-driven ones in
    tests/test_rules_records.py) name every value rule."""
    text = "".join((ROOT / "tests" / f).read_text(encoding="utf-8") for f in ("test_encoder_rules.py", "test_rules_records.py"))
    assert f'"{rule}"' in text


# ---------------------------------------------------------------------------------- windows after a key change
WINDOW_RULES = {r["rule"] for r in REG.FOLLOWS} | {"CTRLREQ-MISMATCH"}
G1 = [t for t in STD if "g1_stw" in dict(tg.TELEGRAMS[t]["setpoint"])]


@st.composite
def key_changes(draw):
    """A checker that saw one set of control/status words for a while, then another (the edge)."""
    cfg = EncoderConfig(profile=draw(st.sampled_from(tg.PROFILES)), telegram=draw(st.sampled_from(G1)),
                        compat=draw(st.sampled_from([0, 1])), class4=draw(st.sampled_from([0, 1])))

    def words():
        stw2 = draw(st.sampled_from([0, 0x400]))                        # control by PLC
        g1_stw = draw(st.sampled_from([0, 0x2000, 0x4000, 0x6000, 0x8000, 0xA000]))   # AREQ, PARK, SACK
        zsw2 = draw(st.sampled_from([0, 0x200, 0x400, 0x600]))          # control requested (either bit)
        g1_zsw = draw(st.sampled_from([0, 0x800, 0x2000, 0x4000, 0x6000, 0x2800, 0xA000]))  # ACKIP, ATX, PKA, SERR
        return {"stw2_enc": stw2, "g1_stw": g1_stw}, {"zsw2_enc": zsw2, "g1_zsw": g1_zsw, "g1_xist1": 100,
                                                      "g1_xist2": 100}
    return cfg, words(), words(), draw(st.integers(0, 3))


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(key_changes())
def test_windows_quiet_only_when_no_window_rule_can_fire(case):
    """Checker.windows_quiet() lets the bulk engine advance the cycles after a key change while the window
    W(n, -L_max, 0) still holds the old words: then no window rule (#13, the FOLLOWS rows) may start in
    them. Run per cycle (the reference) and check."""
    cfg, (sp0, ac0), (sp1, ac1), extra = case
    chk = Checker(cfg)
    L = chk.L
    events, n = [], 0

    def cycle(sp, ac):
        nonlocal n
        n += 1
        events.extend(chk.cycle(n, n * 1000, dict(sp), dict(ac)))   # new dicts: not the identical-input branch

    for _ in range(L + 3 + extra):
        cycle(sp0, ac0)
    cycle(sp1, ac1)   # the edge
    edge, quiet = n, chk.windows_quiet()
    for _ in range(L + 3):
        cycle(sp1, ac1)
    events.extend(chk.finish())
    late = sorted({e["rule"] for e in events if e.get("rule") in WINDOW_RULES and e["frame"] > edge})
    if quiet:
        assert not late, f"windows_quiet() after the edge, yet {late} started later ({sp0, ac0} -> {sp1, ac1})"


@st.composite
def key_runs(draw):
    """Runs of constant control/status words, some cut by lost cycles (capture loss)."""
    cfg = EncoderConfig(profile=draw(st.sampled_from(tg.PROFILES)), telegram=draw(st.sampled_from(G1)),
                        compat=draw(st.sampled_from([0, 1])), class4=draw(st.sampled_from([0, 1])),
                        l_max=draw(st.sampled_from([2, 2, 5])))
    words = st.tuples(st.sampled_from([0, 0x400]), st.sampled_from([0, 0x2000, 0x4000, 0x8000]),
                      st.sampled_from([0, 0x200, 0x400, 0x600]), st.sampled_from([0, 0x800, 0x2000, 0x4000, 0x6000]))
    runs = draw(st.lists(st.tuples(words, st.integers(1, 14), st.sampled_from([0, 0, 0, 1, 3]),
                                   st.integers(1, 6)), min_size=2, max_size=8))
    # often the same words again after lost cycles: the key goes on across the gap, the window starts afresh
    for i in range(1, len(runs)):
        if runs[i][2] and draw(st.booleans()):
            runs[i] = (runs[i - 1][0],) + runs[i][1:]
    return cfg, runs


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(key_runs())
def test_advance_steady_equals_the_cycles_it_replaces(case):
    """What a bulk engine does (advance_steady whenever bulk_ready() says so, in pieces of any size) reports
    exactly what the per-cycle checker reports: the windows after a key change and after lost cycles included."""
    cfg, runs = case
    ref, blk = Checker(cfg), Checker(cfg)
    out = {ref: [], blk: []}
    n = 0
    for (stw2, g1_stw, zsw2, g1_zsw), length, lost, piece in runs:
        if lost:
            for chk in (ref, blk):
                out[chk].extend(chk.lost(n + 1, (n + 1) * 1000, lost))
            n += lost
        i = 0
        while i < length:
            sp, ac = {"stw2_enc": stw2, "g1_stw": g1_stw}, {"zsw2_enc": zsw2, "g1_zsw": g1_zsw, "g1_xist1": 100, "g1_xist2": 100}
            if i > 0 and blk.bulk_ready() and not blk.vector_unsafe(
                    {k: np.array([v]) for k, v in {**sp, **ac}.items()}, True).any():
                m = min(piece, length - i)
                for j in range(m):   # the reference, cycle by cycle
                    out[ref].extend(ref.cycle(n + 1 + j, (n + 1 + j) * 1000, dict(sp), dict(ac)))
                blk.advance_steady(m, n + m, (n + m) * 1000, None, dict(sp), dict(ac), [100] * min(3, m), False, False)
                n += m
                i += m
                continue
            n += 1
            for chk in (ref, blk):
                out[chk].extend(chk.cycle(n, n * 1000, dict(sp), dict(ac)))
            i += 1
    for chk in (ref, blk):
        out[chk].extend(chk.finish())
    assert out[blk] == out[ref]
    assert blk.counts == ref.counts and blk.state == ref.state
