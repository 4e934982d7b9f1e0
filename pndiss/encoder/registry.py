"""Every rule the reference encoder checks, declared once (issue #13 item 2).

A ``Rule`` names a catalogue ID (pndiss/data/rules.json gives its side, severity and spec source),
what kind of rule it is, the checker state it needs and, for deadline rules, the attribute holding
the open deadline: ``pending(k)`` -- "a deadline is running, no cycle may be skipped" -- is derived
from these entries, not kept by hand.

VALUE rules are judged from one cycle's values, the previous cycle's and the configuration. Each
has its per-cycle predicate ``check(k, c)`` (k: the Checker, c: a ``Cycle``) and right beside it
the vectorised twin ``vector(k, V)`` on a stretch of cycles (V: ``Columns``), which a bulk engine
uses to find the cycles the checker must see itself (``Checker.vector_unsafe``). CHECKER_CYCLES
are not rules but per-cycle conditions that change the checker's state (a sensor error, a shift to
learn, values beyond int64 arithmetic): they have twins too. tests/test_registry.py proves every
twin equal to its predicate on random columns.

FOLLOWS holds the recurring "status bit follows control bit within L_max" shape as table rows that
one generic loop judges (Python here, Lua via the generated tables, tools/gen_lua.py).
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

import numpy as np

from .. import rules as R_
from .. import telegrams as tg
from . import position as P

U32 = 1 << 32
SAFE = 1 << 62                                   # beyond this the NumPy twins do not judge (int64 arithmetic)
LIKA_CODES = frozenset(tg.XIST2_ERRORS)          # LIKA's full list (behaviour.md §9.7 #51)
E_MASTER_SOL, E_SYNC, E_PARAM = 0x0F02, 0x0F04, 0x1002   # cyclic.md §9
CONTINUITY_PROFILES = ("scancon", "hohner")      # endless shaft continuous modulo R (#42)


@dataclass(frozen=True)
class Rule:
    id: str
    kind: str                       # value | window | edge | deadline | sign-of-life | preset | record | finish
    needs: tuple = ()               # checker state the rule reads or keeps
    deadline: str | None = None     # L_max, D_preset, 10 ms (store) -- deadline rules only
    state: str | None = None        # deadline rules: the checker attribute that holds the open deadline
    open_when: tuple = ()           # ... open only while one of these keys of it is true (else: while set)
    check: Callable | None = None   # value rules: (Checker, Cycle) -> bool
    vector: Callable | None = None  # value rules: (Checker, Columns) -> bool array, equal to check row by row
    message: Callable | None = None  # value rules: (Checker, Cycle) -> str
    min_run: int = 1                # value rules: cycles in a row the condition must hold to count
    applies: Callable | None = None  # value rules: (Checker) -> bool, a gate on the configuration only (the
                                     # checker re-evaluates it in reconfigure(); check() tests it again)

    @property
    def side(self) -> str:
        return R_.RULES[self.id]["side"]

    @property
    def source(self) -> str:
        return R_.RULES[self.id]["source"]

    def is_open(self, k) -> bool:
        v = getattr(k, self.state)
        if v is None:
            return False
        return not self.open_when or any(v[key] for key in self.open_when)


# ---------------------------------------------------------------------------------- one cycle
class Cycle:
    """What the value rules read of one cycle (ints; None where the telegram has no such signal)."""

    __slots__ = ("SERR", "ATX", "PKA", "PDONE", "DLS", "X1", "X2", "X3", "NIST", "pos2", "ppos2", "motion", "pmotion",
                 "pX3", "zsw2", "g1zsw", "has_g1", "started_D")

    @classmethod
    def of(cls, ac: dict, pa: dict | None, has_g1: bool, started_D: bool = False) -> "Cycle":
        c = cls()
        c.zsw2 = zsw2 = ac.get("zsw2_enc", 0)
        c.g1zsw = g1zsw = ac.get("g1_zsw", 0)
        c.DLS = zsw2 >> 12
        c.PDONE = (g1zsw >> 12) & 1
        c.ATX = ATX = (g1zsw >> 13) & 1
        c.PKA = (g1zsw >> 14) & 1
        c.SERR = SERR = (g1zsw >> 15) & 1
        c.X1, c.X2, c.X3 = X1, X2, X3 = ac.get("g1_xist1"), ac.get("g1_xist2"), ac.get("g1_xist3")
        c.NIST = ac.get("nist_b", ac.get("nist_a"))
        # position of the preset arithmetic and continuity: X3 in telegram 84, else X2 while ATX (§1.6, §4.3)
        c.pos2 = X3 if X3 is not None else (X2 if ATX and not SERR else None)
        c.motion = X1 if X1 is not None else X3
        if pa is None:
            c.ppos2 = c.pmotion = c.pX3 = None
        else:
            pz = pa.get("g1_zsw", 0)
            c.ppos2 = pa.get("g1_xist3") if "g1_xist3" in pa else (
                pa.get("g1_xist2") if (pz >> 13) & 1 and not (pz >> 15) & 1 else None)
            c.pmotion = pa.get("g1_xist1") if X1 is not None else pa.get("g1_xist3")
            c.pX3 = pa.get("g1_xist3")
        c.has_g1 = has_g1
        c.started_D = started_D
        return c


class Columns:
    """The same for a stretch of m consecutive cycles (NumPy columns). Row 0's previous cycle is the
    checker's last one (k.prev_ac). Columns holding a value beyond SAFE become Python-int object arrays
    so the twins stay exact (those rows go to the checker anyway)."""

    def __init__(self, k, cols: dict, has_g1: bool):
        def col(name):
            a = cols.get(name)
            if a is None:
                return None
            a = np.asarray(a)
            if a.dtype == np.uint64 and len(a) and int(a.max()) >= SAFE:
                return a.astype(object)
            return a.astype(np.int64)
        zsw2, g1zsw = col("zsw2_enc"), col("g1_zsw")
        m = len(next(a for a in cols.values() if a is not None)) if cols else 0
        self.m = m
        zero = np.zeros(m, dtype=np.int64)
        self.zsw2 = zsw2 = zero if zsw2 is None else zsw2
        self.g1zsw = g1zsw = zero if g1zsw is None else g1zsw
        self.DLS = zsw2 >> 12
        self.PDONE, self.ATX, self.PKA, self.SERR = ((g1zsw >> b) & 1 for b in (12, 13, 14, 15))
        self.X1, self.X2, self.X3 = X1, X2, X3 = col("g1_xist1"), col("g1_xist2"), col("g1_xist3")
        nb = col("nist_b")
        self.NIST = nb if nb is not None else col("nist_a")
        self.has_g1 = has_g1
        pa = k.prev_ac
        self.started_D = k.started_D | (np.cumsum(self.DLS != 0) > 0)

        def prev(arr, name):
            """arr shifted by one row; row 0 from the checker's last cycle; and where that exists."""
            if arr is None:
                return None, None
            p = np.empty(m, dtype=object if arr.dtype == object else np.int64)
            p[1:] = arr[:-1]
            have = np.ones(m, dtype=bool)
            v0 = None if pa is None else pa.get(name)
            if v0 is None:
                p[0], have[0] = 0, False
            elif v0 >= SAFE and p.dtype != object:
                p = p.astype(object)
                p[0] = v0
            else:
                p[0] = v0
            return p, have
        self.pX3, pX3_have = prev(X3, "g1_xist3")
        pz = np.empty(m, dtype=np.int64)
        pz[1:] = g1zsw[:-1]
        pz[0] = 0 if pa is None else pa.get("g1_zsw", 0)
        atx_ok = (self.ATX == 1) & (self.SERR == 0)
        if X3 is not None:
            self.pos2, self.pos2_ok = X3, np.ones(m, dtype=bool)
            self.ppos2, self.ppos2_ok = self.pX3, pX3_have
        elif X2 is not None:
            self.pos2, self.pos2_ok = X2, atx_ok
            self.ppos2, have = prev(X2, "g1_xist2")
            self.ppos2_ok = have & (((pz >> 13) & 1) == 1) & (((pz >> 15) & 1) == 0)
        else:
            self.pos2 = self.ppos2 = None
        if X1 is not None:
            self.motion = X1
            self.pmotion, self.pmotion_ok = prev(X1, "g1_xist1")
        elif X3 is not None:
            self.motion = X3
            self.pmotion, self.pmotion_ok = self.pX3, pX3_have
        else:
            self.motion = self.pmotion = None
        self.pX3_ok = pX3_have


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
    return (not c.class4 or c.xist1_preset_affected) and not c.xist1_counter


def _x2_inconsistent(k, c):
    return bool(c.ATX and not c.SERR and c.X1 is not None and c.X2 is not None and c.X3 is None and _x40_applies(k)
                and c.X1 != (c.X2 << (k.cfg.shift or 0)) % U32)


def _x2_inconsistent_v(k, V):
    if V.X1 is None or V.X2 is None or V.X3 is not None or not _x40_applies(k):
        return _none(V)
    return _b((V.ATX == 1) & (V.SERR == 0) & (V.X1 != ((V.X2 << (k.cfg.shift or 0)) & (U32 - 1))))


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


def _discontinuity(k, c):
    if c.pos2 is None or c.ppos2 is None or c.PKA or not _continuity_applies(k):
        return False  # LIKA jumps at the physical wrap (red zone); generic: unknown
    return abs(P.delta(c.ppos2, c.pos2, k.R)) > _step(k)


def _discontinuity_v(k, V):
    if V.pos2 is None or not _continuity_applies(k):
        return _none(V)
    R = k.R
    pos, ppos = (V.pos2, V.ppos2) if R < SAFE else (V.pos2.astype(object), V.ppos2.astype(object))
    d = (pos - ppos) % R
    d = np.where(d > R // 2, d - R, d)
    return V.pos2_ok & V.ppos2_ok & (V.PKA == 0) & _b(np.abs(d) > _step(k))


def _discontinuity_msg(k, c):
    d = P.delta(c.ppos2, c.pos2, k.R)
    return f"position {c.ppos2} -> {c.pos2} (step {d}) exceeds the plausible {_step(k)} per cycle (R={k.R})"


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


# 47: LIKA clears outputs while parked (000_37bf2397999f1108.txt:3149-3159)
def _park_outputs(k, c):
    return bool(k.lika and c.PKA and ((c.X1 or 0) or (c.X2 or 0) or c.PDONE or c.ATX))


def _park_outputs_v(k, V):
    if not k.lika:
        return _none(V)
    busy = (V.PDONE == 1) | (V.ATX == 1)
    for X in (V.X1, V.X2):
        if X is not None:
            busy |= _b(X != 0)
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


def _v(rule, check, vector, message, needs=(), min_run=1, applies=None) -> Rule:
    return Rule(rule, "value", needs=needs, check=check, vector=vector, message=message, min_run=min_run,
                applies=applies)


def _continuity_profile(k) -> bool:
    return k.R is not None and (k.cfg.profile in CONTINUITY_PROFILES or (k.psm and bool(k.cfg.scaling)))


def active_value_rules(k) -> tuple:
    """(check, id, min_run, message) of the value rules the configuration of checker k can fire at all,
    in judging order (the checker asks again whenever its configuration changes)."""
    return tuple((r.check, r.id, r.min_run, r.message) for r in VALUE_RULES if r.applies is None or r.applies(k))


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
    _v("NIST-SIGN", _nist_sign, _nist_sign_v, _nist_msg, min_run=3),
    _v("PARK-OUTPUTS-NOT-CLEARED", _park_outputs, _park_outputs_v, applies=lambda k: k.lika,
       message=lambda k, c: f"parked with G1_XIST1={c.X1} G1_XIST2={c.X2} G1_ZSW=0x{c.g1zsw:04X}; expected 0s"),
    _v("SERR-CODE-INVALID", _serr_code, _serr_code_v, _serr_code_msg),
    _v("BF00-VALID-REJECTED", _bf00_rejected, _bf00_rejected_v, needs=("bf00_valid_frame", "bf00_invalid"),
       message=lambda k, c: f"0x1002 parametrization error after a valid 0xBF00 (frame {k.bf00_valid_frame})"),
)


# ---------------------------------------------------------------------------------- cycles the checker must see
@dataclass(frozen=True)
class Trigger:
    """A per-cycle condition that changes the checker's state (not a rule): no bulk skipping over it."""
    name: str
    check: Callable
    vector: Callable


def _shift_learnable(k, c):
    return bool(not k.shift_known and c.has_g1 and c.ATX and not c.SERR and c.X1 is not None and c.X2)


def _shift_learnable_v(k, V):
    if k.shift_known or not V.has_g1 or V.X1 is None or V.X2 is None:
        return _none(V)
    return (V.ATX == 1) & (V.SERR == 0) & _b(V.X2 != 0)


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
    # a sensor error: the timeline, the acknowledgement flags and the error code follow it
    Trigger("sensor error", lambda k, c: bool(c.SERR), lambda k, V: V.SERR == 1),
    # LIKA parking clears the outputs (#47): judged cycle by cycle
    Trigger("LIKA parking", lambda k, c: bool(k.lika and c.PKA), lambda k, V: (V.PKA == 1) if k.lika else _none(V)),
    # P979.3 still unknown: the first ATX cycle with both positions learns it (§1.6 R-X1-4)
    Trigger("shift to learn", _shift_learnable, _shift_learnable_v),
    # 64-bit positions or a modulus beyond int64: the reference arithmetic (Python ints) judges them
    Trigger("beyond int64", _big, _big_v),
)


# ---------------------------------------------------------------------------------- "follows within L_max" rows
# status bit S of G1_ZSW must follow a control bit of G1_STW: the rule holds in a cycle where S has the
# value ``is`` although every cycle of the window W(n, -L_max, 0) met ``window`` (names of the checker's
# window history, see HIST). ``group``: where in the cycle the checker judges the row (report order).
HIST = ("CTRL", "PREQ", "AREQ", "PARK", "SACK", "VALID", "PKA", "SERR")
FOLLOWS: tuple[dict, ...] = (
    # 36: ATX follows AREQ (000_37bf2397999f1108.txt:1853-1859)
    {"rule": "ABSVAL-ACK-MISSING", "group": "absval", "status": "ATX", "is": 0,
     "window": {"AREQ": 1, "VALID": 1, "PKA": 0, "SERR": 0}, "message": "G1_STW.13=1 for {n} cycles but G1_ZSW.13=0"},
    # 37: ATX clears when AREQ clears (000_37bf2397999f1108.txt:1626-1629)
    {"rule": "ABSVAL-ACK-STUCK", "group": "absval", "status": "ATX", "is": 1,
     "window": {"AREQ": 0, "VALID": 1}, "message": "G1_STW.13=0 for {n} cycles but G1_ZSW.13=1"},
    # 45: PKA follows PARK (000_37bf2397999f1108.txt:3144-3150)
    {"rule": "PARK-ACK-MISSING", "group": "park", "status": "PKA", "is": 0,
     "window": {"PARK": 1, "VALID": 1}, "message": "G1_STW.14=1 for {n} cycles but G1_ZSW.14=0"},
    # 46: PKA clears when PARK clears (000_37bf2397999f1108.txt:3166-3173)
    {"rule": "PARK-ACK-NOT-CLEARED", "group": "park", "status": "PKA", "is": 1,
     "window": {"PARK": 0, "VALID": 1}, "message": "G1_STW.14=0 for {n} cycles but G1_ZSW.14=1"},
    # 54: ACKIP ends with the acknowledgement (000_37bf2397999f1108.txt:3201-3213)
    {"rule": "ACKIP-STUCK", "group": "ackip", "status": "ACKIP", "is": 1,
     "window": {"SACK": 0}, "message": "G1_ZSW.11=1 with G1_STW.15=0 for {n} cycles"},
)
_FOLLOWS_BY_GROUP: dict[str, tuple] = {}
for _row in FOLLOWS:
    _FOLLOWS_BY_GROUP.setdefault(_row["group"], ())
    _FOLLOWS_BY_GROUP[_row["group"]] += ((_row["rule"], _row["status"], _row["is"],
                                          tuple((HIST.index(f), bool(v)) for f, v in _row["window"].items()),
                                          _row["message"]),)


def follows(group: str):
    """The compiled rows of one group: (rule, status name, status value, ((history index, value), ...), message)."""
    return _FOLLOWS_BY_GROUP[group]


# ---------------------------------------------------------------------------------- deadline rules
def _d(rule, state, deadline, needs=(), open_when=()) -> Rule:
    return Rule(rule, "deadline", needs=needs or (state,), deadline=deadline, state=state, open_when=open_when)


DEADLINES: tuple[Rule, ...] = (
    # a preset request already reported as unanswered (#19) and still held is inert while the words stay the
    # same: only a PDONE / PREQ / mode edge (a key change) can touch it again
    _d("PRESET-ACK-MISSING", "pre", "D_preset", open_when=("done", "allowed")),
    _d("PRESET-REQ-STUCK", "pdone_since", "D_preset"),
    _d("PRESET-ACK-NOT-CLEARED", "pdone_clear_due", "L_max"),
    _d("PRESET860-WRONG", "p860", "D_preset"),
    _d("PRESET89-ACK-MISSING", "p89", "D_preset"),
    _d("ACKIP-MISSING", "sack_edge", "L_max"),
    _d("SACK-HELD", "ackip_since", "D_preset"),
    _d("SERR-XIST2-NOT-RESTORED", "restore_due", "L_max"),
    _d("PARK-ERRORS-NOT-CLEARED", "park_rise_due", "L_max"),
    _d("SOL-FAULT-MISSING", "solf_due", "L_max"),
    _d("BF00-ERROR-NOT-REPORTED", "bf00_due", "D_preset"),
    _d("XIST-DURING-STORE", "store", "10 ms"),
)


def open_deadlines(k) -> list[str]:
    """The deadline rules running in checker k (their trigger seen, their deadline not yet reached)."""
    return [r.id for r in DEADLINES if r.is_open(k)]


_OPEN = tuple((r.state, r.open_when) for r in DEADLINES)


def _pending_source() -> str:
    """pending(k) as one expression over the checker's attributes, written from DEADLINES (every judged
    cycle asks it, so it is compiled once instead of looping over the entries)."""
    terms = []
    for state, keys in _OPEN:
        t = f"d[{state!r}] is not None"
        if keys:
            t = f"({t} and ({' or '.join(f'd[{state!r}][{x!r}]' for x in keys)}))"
        terms.append(t)
    return "def pending(k):\n    d = k.__dict__\n    return bool(" + "\n        or ".join(terms) + ")\n"


_ns: dict = {}
exec(compile(_pending_source(), "<registry.DEADLINES>", "exec"), _ns)
pending: Callable = _ns["pending"]
pending.__doc__ = "Some deadline rule is running in checker k (its trigger seen, its deadline not reached)."


# ---------------------------------------------------------------------------------- the other rules
def _rules(kind: str, ids: str, needs=()) -> tuple[Rule, ...]:
    return tuple(Rule(i, kind, needs=needs) for i in ids.split())


OTHER_RULES: tuple[Rule, ...] = (
    _rules("sign-of-life", "SOL-MASTER-ZERO SOL-MASTER-SKIP SOL-MASTER-STALL SOL-MASTER-WINDOW SOL-DEVICE-ZERO "
                           "SOL-DEVICE-SKIP SOL-DEVICE-EARLY-START SOL-FAULT-SPURIOUS", ("cls_run", "C", "C_hist"))
    + _rules("window", "CTRLREQ-MISMATCH CMD-EXECUTED-WITHOUT-CONTROL PRESET-ACK-SPURIOUS PRESET-ACK-DROPPED "
                       "ACKIP-SPURIOUS", ("hist",))
    + tuple(Rule(r["rule"], "window", needs=("hist",)) for r in FOLLOWS)
    + _rules("edge", "CTRLREQ-SET-IN-COMPAT CMD-WITHOUT-CONTROL PRESET-CLASS4-DISABLED PRESET-EXECUTED-WHEN-NOT-ALLOWED "
                     "PRESET-REQ-EARLY-RELEASE PRESET-MODE-CHANGED PRESET-NOT-STANDSTILL PARK-ERROR-REPORTED "
                     "PARK-WHILE-RUNNING SACK-WITHOUT-ERROR FAULT-PRESENT-INCONSISTENT RESERVED-BIT-SET-STW2 "
                     "RESERVED-BIT-SET-G1STW RESERVED-BIT-SET-ZSW2 RESERVED-BIT-SET-G1ZSW", ("prev_sp", "prev_ac"))
    + _rules("edge", "SOL-FAULT-CLEARED-WITHOUT-ACK SERR-CLEARED-WITHOUT-ACK", ("sack_since_serr", "serr_code"))
    + _rules("preset", "PRESET-VALUE-WRONG PRESET-XIST1-AFFECTED-WHEN-DISABLED PRESET-XIST1-NOT-AFFECTED-WHEN-ENABLED "
                       "PRESET-REEXECUTED PRESET860-VALUE-OUT-OF-RANGE PRESET860-TRIGGER-HELD", ("pre", "p860", "pos_hist"))
    + _rules("finish", "PRESET-WITHOUT-NEW-PARAMS", ("params_changed", "preset_done"))
    + _rules("record", "TELEGRAM-SELECTION-MISMATCH BF00-LENGTH BF00-RESERVED-NONZERO BF00-VALUE-OUT-OF-RANGE "
                       "P965-VERSION-MISMATCH BMP-PIPELINED BMP-REQREF-ZERO BMP-REQREF-NOT-CHANGED BMP-BAD-REQUEST "
                       "BMP-ILLEGAL-REQID-RESPONSE BMP-NOT-MIRRORED BMP-RESPID-MISMATCH BMP-NEG-FORMAT "
                       "BMP-MULTI-NOT-ABORTED BMP-WRITE-RO-ACCEPTED BMP-PRESET-LIMIT-ACCEPTED BMP-UNKNOWN-PNU "
                       "BMP-DATATYPE P971-NOT-CONFIRMED BMP-CLASS4-WRITE-ACCEPTED BMP-PROFILE-PARAM-UNREADABLE",
             ("cfg", "p980", "last_req_ref"))
)

REGISTRY: dict[str, Rule] = {}
for _r in VALUE_RULES + DEADLINES + OTHER_RULES:
    if _r.id in REGISTRY:
        raise ValueError(f"rule {_r.id} declared twice")
    if _r.id not in R_.RULES:
        raise ValueError(f"rule {_r.id} is not in the catalogue (pndiss/data/rules.json)")
    REGISTRY[_r.id] = _r


def all_rows(cols: dict) -> np.ndarray:
    """Every row of the stretch (the checker must see them all)."""
    n = len(next(iter(cols.values()))) if cols else 0
    return np.ones(n, dtype=bool)


def vector_unsafe(k, cols: dict, has_g1: bool) -> np.ndarray:
    """Per row: a value rule fires or the checker must see the cycle (see Checker.vector_unsafe)."""
    V = Columns(k, cols, has_g1)
    bad = np.zeros(V.m, dtype=bool)
    for r in VALUE_RULES:
        bad |= r.vector(k, V)
    for t in CHECKER_CYCLES:
        bad |= t.vector(k, V)
    return bad


def lua_tables() -> dict:
    """What lua/pndiss_checker.lua reads of the registry (tools/gen_lua.py writes it into the tables)."""
    return {
        "follows": {g: [{"rule": r["rule"], "status": r["status"], "is": r["is"], "window": r["window"],
                         "message": r["message"]} for r in FOLLOWS if r["group"] == g] for g in _FOLLOWS_BY_GROUP},
        "deadlines": [{"rule": r.id, "state": r.state, "deadline": r.deadline, "open_when": list(r.open_when) or None}
                      for r in DEADLINES],
        "registry": {r.id: {"kind": r.kind, "deadline": r.deadline, "min_run": r.min_run if r.kind == "value" else None}
                     for r in REGISTRY.values()},
    }
