"""The value rules of the reference encoder: judged from one cycle's values, the previous cycle's and
the configuration. Each has its per-cycle predicate ``check(k, c)`` (k: the Checker, c: a ``Cycle``)
and right beside it the vectorised twin ``vector(k, V)`` on a stretch of cycles (V: ``Columns``),
which a bulk engine uses to find the cycles the checker must see itself (``Checker.vector_unsafe``).
CHECKER_CYCLES are not rules but per-cycle conditions that change the checker's state (a sensor error,
a shift to learn, values beyond int64 arithmetic); they have twins too. tests/test_registry.py proves
every twin equal to its predicate on random columns. encoder/registry.py declares them with the rest.
"""
from __future__ import annotations

import numpy as np

from .. import telegrams as tg
from . import position as P
from .cycles import SAFE, Columns
from .rule import Rule, Trigger

U32 = 1 << 32
LIKA_CODES = frozenset(tg.XIST2_ERRORS)          # LIKA's full list (behaviour.md §9.7 #51)
E_MASTER_SOL, E_SYNC, E_PARAM = 0x0F02, 0x0F04, 0x1002   # cyclic.md §9
CONTINUITY_PROFILES = ("scancon", "hohner", "lika")   # endless shaft continuous modulo R (#42); LIKA: _red_zone
SHIFT_GIVEN = ("P979", "settings.")              # a shift read from the device or given, not inferred (#40)


def _none(V) -> np.ndarray:
    return np.zeros(V.m, dtype=bool)


def _b(a) -> np.ndarray:
    return np.asarray(a, dtype=bool)


# ---------------------------------------------------------------------------------- value rules
# 8: RT mode, DLS back to 0 once running (RT examples show DLS != 0, 001_9461bb7bc8c2767b.txt:2221);
# before its first change the DO may still wait for a C-LS change (R-DLS-2)
def _dls_zero_rt(k, c):
    return not k.cfg.iso and c.DLS == 0 and c.started_D


def _dls_zero_rt_v(k, V):
    if k.cfg.iso:
        return _none(V)
    return (V.DLS == 0) & V.started_D


# 12: sync fault 0x0F04 must come with DLS = 0 (001_9461bb7bc8c2767b.txt:1802-1804)
def _sync_dls(k, c):
    return bool(k.cfg.iso and c.SERR and c.X2 == E_SYNC and c.DLS != 0)


def _sync_dls_v(k, V):
    if not k.cfg.iso or V.X2 is None:
        return _none(V)
    return _b((V.SERR == 1) & (V.X2 == E_SYNC) & (V.DLS != 0))


# 38: never both (000_37bf2397999f1108.txt:1911-1914)
def _atx_serr(k, c):
    return bool(c.ATX and c.SERR)


def _atx_serr_v(k, V):
    return (V.ATX == 1) & (V.SERR == 1)


# 39: LIKA sends 0 in XIST2 without request (000_37bf2397999f1108.txt:1626-1629)
def _x2_zero(k, c):
    return bool(k.lika and c.X2 is not None and not c.ATX and not c.SERR and not c.PKA and c.X2 != 0)


def _x2_zero_v(k, V):
    if not k.lika or V.X2 is None:
        return _none(V)
    return _b((V.ATX == 0) & (V.SERR == 0) & (V.PKA == 0) & (V.X2 != 0))


# 40: X1 == X2 << P979.3 (001_9461bb7bc8c2767b.txt:2223-2224)
def _x40_applies(k) -> bool:
    c = k.cfg
    if c.profile == "generic" and not c.sources.get("shift", "").startswith(SHIFT_GIVEN):
        return False   # a vendor not known: its X1 may be a profile 4.1 counter (001_9461bb7bc8c2767b.txt:442-447)
    if k.preset_done and c.preset_control_open():
        return False   # after a preset X1 = X2 << shift only if the preset moved X1: the 0xBF00 says, none seen
    return (not c.class4 or c.xist1_preset_affected) and not c.xist1_counter


def _x2_inconsistent(k, c):
    return bool(c.ATX and not c.SERR and c.X1 is not None and c.X2 is not None and c.X3 is None and _x40_applies(k)
                and not (c.PDONE and k.cfg.preset_control_open())   # (the preset's own cycle: preset_done next)
                and c.X1 != (c.X2 << (k.cfg.shift or 0)) % U32)


def _x2_inconsistent_v(k, V):
    if V.X1 is None or V.X2 is None or V.X3 is not None or not _x40_applies(k):
        return _none(V)
    hit = _b((V.ATX == 1) & (V.SERR == 0) & (V.X1 != ((V.X2 << (k.cfg.shift or 0)) & (U32 - 1))))
    return hit & (V.PDONE == 0) if k.cfg.preset_control_open() else hit


# 41: position inside [0, R) (000_37bf2397999f1108.txt:2394-2434)
def _out_of_range(k, c):
    R = k.R
    return bool(R and c.ATX and not c.SERR and ((c.X2 is not None and c.X2 >= R) or (k.lika and c.X1 is not None and c.X1 >= R)))


def _out_of_range_v(k, V):
    R = k.R
    if not R:
        return _none(V)
    out = _none(V)
    if V.X2 is not None:
        out |= _b(V.X2 >= R)
    if k.lika and V.X1 is not None:
        out |= _b(V.X1 >= R)
    return (V.ATX == 1) & (V.SERR == 0) & out


# 42: endless shaft is continuous modulo R (001_9461bb7bc8c2767b.txt:993-995)
def _continuity_applies(k) -> bool:
    return _continuity_profile(k) and k.pre is None and k.pdone_since is None


def _step(k) -> int:
    return k.cfg.max_position_step or max(1, k.R // 8)


def _positions(k, c):
    """The two positions the continuity rule compares: G1_XIST2 (or X3) of this and the cycle before; where neither
    carries the position (the PLC did not request it), LIKA's G1_XIST1, which is the absolute position too
    (000_37bf2397999f1108.txt:1579-1580; an independent audit: a glitch there went unseen), between two cycles with
    no sensor error and no parking -- and neither value 0, what LIKA shows parked or in error (the bit and the value
    may change a cycle apart: a review). PS/PSM and the generic profile are not judged there (X1's alignment is
    theirs to say)."""
    if c.pos2 is not None or c.ppos2 is not None:
        return c.pos2, c.ppos2
    if k.lika and c.X3 is None and c.X1 and c.pmotion and c.SERR == 0 and c.pserr_state == 0 and not c.pPKA:
        s = k.cfg.shift or 0
        return c.X1 >> s, c.pmotion >> s
    return None, None


def _discontinuity(k, c):
    # (a jump in a cycle with G1_ZSW.12 is a preset's, also one whose request a capture gap hid)
    pos, ppos = _positions(k, c)
    if pos is None or ppos is None or c.PKA or c.PDONE or not _continuity_applies(k):
        return False  # generic: unknown
    step = _step(k)
    if abs(P.delta(ppos, pos, k.R)) <= step:
        return False
    return not (_red_zone(k) and (_near_zero(pos, k.R, step) or _near_zero(ppos, k.R, step)))


def _red_zone(k) -> bool:
    """LIKA's red zone (000_37bf2397999f1108.txt:2520-2538): a scaled range R that does not divide the physical one
    (a power of two) leaves a rest the count runs through before it jumps where the physical range wraps -- to 0
    moving forward, from 0 moving back. With R a power of two there is none: any jump is a fault, as on the other
    endless shafts (an independent audit: no LIKA jump was judged)."""
    return k.cfg.profile == "lika" and k.R & (k.R - 1) != 0


def _near_zero(x, R: int, step: int):
    # (the red zone's end jumps to 0, and back from 0: the top of the range wraps continuously, no exemption there)
    return x <= step


def _discontinuity_v(k, V):
    if not _continuity_applies(k):
        return _none(V)
    R = k.R
    step = _step(k)

    def jumps(pos, ppos, ok):
        pos, ppos = (pos, ppos) if R < SAFE else (pos.astype(object), ppos.astype(object))
        d = (pos - ppos) % R
        d = np.where(d > R // 2, d - R, d)
        hit = ok & (V.PKA == 0) & (V.PDONE == 0) & _b(np.abs(d) > step)
        if _red_zone(k):
            hit &= ~(_b(_near_zero(pos, R, step)) | _b(_near_zero(ppos, R, step)))
        return hit
    hit = _none(V) if V.pos2 is None else jumps(V.pos2, V.ppos2, V.pos2_ok & V.ppos2_ok)
    if k.lika and V.X3 is None and V.X1 is not None:   # _positions: LIKA's G1_XIST1 where no X2 carries it
        s = k.cfg.shift or 0
        neither = np.ones(V.m, dtype=bool) if V.pos2 is None else ~V.pos2_ok & ~V.ppos2_ok
        ok = neither & V.pmotion_ok & (V.SERR == 0) & (V.pserr_state == 0) & (V.pPKA == 0) & _b(V.X1 != 0) \
            & _b(V.pmotion != 0)
        hit |= jumps(V.X1 >> s, V.pmotion >> s, ok)
    return hit


def _discontinuity_msg(k, c):
    pos, ppos = _positions(k, c)
    d = P.delta(ppos, pos, k.R)
    return f"position {ppos} -> {pos} (step {d}) exceeds the plausible {_step(k)} per cycle (R={k.R})"


# 44: NIST sign follows the motion [INFERENCE] (001_9461bb7bc8c2767b.txt:962); counts after 3 cycles in a row
def _nist_d(pos, ppos) -> int:
    bits = 64 if pos > U32 or ppos > U32 else 32
    return P.delta(ppos, pos, 1 << bits)


def _nist_sign(k, c):
    if c.motion is None or c.pmotion is None or not c.NIST:
        return False
    d = _nist_d(c.motion, c.pmotion)
    return bool(d and (d > 0) != (c.NIST > 0))


def _nist_sign_v(k, V):
    if V.NIST is None or V.motion is None:
        return _none(V)
    mot, pmot = V.motion, V.pmotion
    wide = _b((mot > U32) | (pmot > U32))
    d32 = (mot - pmot) % U32
    d32 = np.where(d32 > U32 // 2, d32 - U32, d32)
    d64 = (mot - pmot) % (1 << 64) if mot.dtype == object or pmot.dtype == object else mot - pmot
    if mot.dtype == object or pmot.dtype == object:
        d64 = np.where(d64 > (1 << 63), d64 - (1 << 64), d64)
    d = np.where(wide, d64, d32)
    return V.pmotion_ok & (V.NIST != 0) & _b(d != 0) & (_b(d > 0) != (V.NIST > 0))


def _nist_msg(k, c):
    return f"NIST={c.NIST} while the position moves by {_nist_d(c.motion, c.pmotion)} per cycle"


# 47: LIKA clears outputs while parked (000_37bf2397999f1108.txt:3149-3159); a sensor error parking clears within
# L_max (#49) keeps its code in G1_XIST2 until then (#51)
def _park_outputs(k, c):
    return bool(k.lika and c.PKA and ((c.X1 or 0) or (not c.SERR and (c.X2 or 0)) or c.PDONE or c.ATX))


def _park_outputs_v(k, V):
    if not k.lika:
        return _none(V)
    busy = (V.PDONE == 1) | (V.ATX == 1)
    if V.X1 is not None:
        busy |= _b(V.X1 != 0)
    if V.X2 is not None:
        busy |= _b(V.X2 != 0) & (V.SERR == 0)
    return (V.PKA == 1) & busy


# 51: SERR needs an error code in XIST2 (000_37bf2397999f1108.txt:2617-2639)
def _serr_code(k, c):
    return bool(c.SERR and c.X2 is not None and (c.X2 == 0 or (k.lika and c.X2 not in LIKA_CODES)))


def _serr_code_v(k, V):
    if V.X2 is None:
        return _none(V)
    bad = _b(V.X2 == 0)
    if k.lika:
        bad |= ~np.isin(V.X2, np.array(sorted(LIKA_CODES), dtype=V.X2.dtype))
    return (V.SERR == 1) & bad


def _serr_code_msg(k, c):
    return f"sensor error with G1_XIST2=0x{c.X2:X}; expected " + (
        "one of " + ", ".join(f"0x{x:04X}" for x in sorted(LIKA_CODES)) if k.lika else "a non-zero code")


# 71: a valid parameter set must be accepted (000_37bf2397999f1108.txt:2636-2639)
def _bf00_rejected(k, c):
    return bool(c.SERR and c.X2 == E_PARAM and k.bf00_valid_frame is not None and k.bf00_invalid is None)


def _bf00_rejected_v(k, V):
    if V.X2 is None or k.bf00_valid_frame is None or k.bf00_invalid is not None:
        return _none(V)
    return _b((V.SERR == 1) & (V.X2 == E_PARAM))


def _v(rule, check, vector, message, needs=(), min_run=1, applies=None, run_lag=None) -> Rule:
    return Rule(rule, "value", needs=needs, check=check, vector=vector, message=message, min_run=min_run,
                run_lag=run_lag, applies=applies)


def _continuity_profile(k) -> bool:
    return k.R is not None and (k.cfg.profile in CONTINUITY_PROFILES or (k.psm and bool(k.cfg.scaling)))


def active_value_rules(k) -> tuple:
    """(check, id, min_run, message) of the value rules the configuration of checker k can fire at all,
    in judging order (the checker asks again whenever its configuration changes)."""
    return tuple((r.check, r.id, max(r.min_run, r.run_lag(k) + 1) if r.run_lag else r.min_run, r.message)
                 for r in VALUE_RULES if r.applies is None or r.applies(k))


# in the order the checker judges them (runs that end in the same cycle are reported in this order)
VALUE_RULES: tuple[Rule, ...] = (
    _v("SOL-DEVICE-ZERO-RT", _dls_zero_rt, _dls_zero_rt_v, needs=("started_D",), applies=lambda k: not k.cfg.iso,
       message=lambda k, c: f"encoder sign-of-life 0 in RT data exchange (ZSW2_ENC=0x{c.zsw2:04X}); expected 1..15"),
    _v("SYNC-FAULT-DLS-NONZERO", _sync_dls, _sync_dls_v, applies=lambda k: k.cfg.iso,
       message=lambda k, c: f"G1_XIST2=0x0F04 with encoder sign-of-life {c.DLS}; expected 0"),
    _v("ZSW-ATX-AND-SERR", _atx_serr, _atx_serr_v,
       message=lambda k, c: f"G1_ZSW=0x{c.g1zsw:04X} has transmit-absolute-value and sensor-error together"),
    _v("XIST2-NOT-ZERO", _x2_zero, _x2_zero_v, applies=lambda k: k.lika,
       message=lambda k, c: f"G1_XIST2={c.X2} with G1_ZSW.13=0 and no error; expected 0"),
    _v("XIST2-INCONSISTENT", _x2_inconsistent, _x2_inconsistent_v, needs=("shift",),
       message=lambda k, c: f"G1_XIST1=0x{c.X1:08X}, expected G1_XIST2 << {k.cfg.shift or 0} = "
                            f"0x{(c.X2 << (k.cfg.shift or 0)) % U32:08X}"),
    _v("POSITION-OUT-OF-RANGE", _out_of_range, _out_of_range_v, applies=lambda k: bool(k.R),
       message=lambda k, c: f"position G1_XIST2={c.X2} G1_XIST1={c.X1} >= R={k.R}"),
    _v("POSITION-DISCONTINUITY", _discontinuity, _discontinuity_v, _discontinuity_msg, needs=("pre", "pdone_since"),
       applies=_continuity_profile),
    # a SCANCON velocity filter written (0x1000): Normal (96:4) and Coarse (996:4) lag a reversal by ~17 / ~173
    # cycles, and the record's codes are not documented (001_9461bb7bc8c2767b.txt:970-983): not judged then
    # LIKA computes NIST every 100 ms (000_37bf2397999f1108.txt:1919): it may keep its sign ~200 ms after a reversal
    _v("NIST-SIGN", _nist_sign, _nist_sign_v, _nist_msg, min_run=3, applies=lambda k: k.velocity_filter is None,
       run_lag=lambda k: k.cfg.velocity_lag_cycles),
    _v("PARK-OUTPUTS-NOT-CLEARED", _park_outputs, _park_outputs_v, applies=lambda k: k.lika,
       message=lambda k, c: f"parked with G1_XIST1={c.X1} G1_XIST2={c.X2} G1_ZSW=0x{c.g1zsw:04X}; expected 0s"),
    _v("SERR-CODE-INVALID", _serr_code, _serr_code_v, _serr_code_msg),
    _v("BF00-VALID-REJECTED", _bf00_rejected, _bf00_rejected_v, needs=("bf00_valid_frame", "bf00_invalid"),
       message=lambda k, c: f"0x1002 parametrization error after a valid 0xBF00 (frame {k.bf00_valid_frame})"),
)


# ---------------------------------------------------------------------------------- cycles the checker must see
def _shift_learnable(k, c):
    return bool(not k.shift_known and c.has_g1 and c.ATX and not c.SERR and c.X1 is not None and c.X2)


def _shift_learnable_v(k, V):
    if k.shift_known or not V.has_g1 or V.X1 is None or V.X2 is None:
        return _none(V)
    return (V.ATX == 1) & (V.SERR == 0) & _b(V.X2 != 0)


def _serr_changes(k, c):
    return bool(c.SERR and (k.solmon or c.pserr_state != c.serr_state))


def _serr_changes_v(k, V):
    if k.solmon:
        return V.SERR == 1
    return (V.SERR == 1) & (V.pserr_state != V.serr_state)


def _big(k, c):
    return any(v is not None and v >= SAFE for v in (c.X3, c.pX3)) or _continuity_big(k)


def _continuity_big(k) -> bool:
    c = k.cfg
    return k.R is not None and k.R >= SAFE and (c.profile in CONTINUITY_PROFILES or (k.psm and bool(c.scaling)))


def _big_v(k, V):
    if _continuity_big(k):
        return np.ones(V.m, dtype=bool)
    if V.X3 is None:
        return _none(V)
    return _b(V.X3 >= SAFE) | (V.pX3_ok & _b(V.pX3 >= SAFE))


CHECKER_CYCLES: tuple[Trigger, ...] = (
    # a sensor error the timeline does not show yet (its first cycle, a new code): a state event. A
    # cycle of a sensor error that goes on unchanged changes nothing in a steady checker (_cycle_steady);
    # under sign-of-life monitoring it decides the fault report (_sign_of_life): every such cycle counts
    Trigger("sensor error", _serr_changes, _serr_changes_v),
    # LIKA parking clears the outputs (#47): judged cycle by cycle
    Trigger("LIKA parking", lambda k, c: bool(k.lika and c.PKA), lambda k, V: (V.PKA == 1) if k.lika else _none(V)),
    # P979.3 still unknown: the first ATX cycle with both positions learns it (§1.6 R-X1-4)
    Trigger("shift to learn", _shift_learnable, _shift_learnable_v),
    # 64-bit positions or a modulus beyond int64: the reference arithmetic (Python ints) judges them
    Trigger("beyond int64", _big, _big_v),
)


def all_rows(cols: dict) -> np.ndarray:
    """Every row of the stretch (the checker must see them all)."""
    n = len(next(iter(cols.values()))) if cols else 0
    return np.ones(n, dtype=bool)


def sign_of_life_unsafe(cols: dict, stw2_before: int, zsw2_before: int) -> np.ndarray:
    """Twin of Checker._sign_of_life's quiet path (k = 1, both counters running, failure counter 0): rows
    where C-LS or DLS is 0 or does not step by one (1..15, 15 -> 1; behaviour.md §3) go to the checker."""
    z = np.zeros(len(next(iter(cols.values()))) if cols else 0, dtype=np.int64)
    cls = cols.get("stw2_enc", z) >> 12
    dls = cols.get("zsw2_enc", z) >> 12
    pc = np.empty_like(cls)
    pd = np.empty_like(dls)
    if len(cls):
        pc[0], pd[0] = stw2_before >> 12, zsw2_before >> 12
        pc[1:], pd[1:] = cls[:-1], dls[:-1]
    return (cls == 0) | (cls != pc % 15 + 1) | (dls == 0) | (dls != pd % 15 + 1)


def vector_unsafe(k, cols: dict, has_g1: bool) -> np.ndarray:
    """Per row: a value rule fires or the checker must see the cycle (see Checker.vector_unsafe)."""
    V = Columns(k, cols, has_g1)
    bad = np.zeros(V.m, dtype=bool)
    for r in VALUE_RULES:
        bad |= r.vector(k, V)
    for t in CHECKER_CYCLES:
        bad |= t.vector(k, V)
    return bad
