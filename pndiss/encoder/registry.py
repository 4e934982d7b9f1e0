"""Every rule the reference encoder checks, declared once (issue #13 item 2).

A ``Rule`` (encoder/rule.py) names a catalogue ID (pndiss/data/rules.json gives its side, severity
and spec source), what kind of rule it is, the checker state it needs and, for deadline rules, the
attribute holding the open deadline: ``pending(k)`` -- "a deadline is running, no cycle may be
skipped" -- is derived from these entries, not kept by hand.

VALUE_RULES (encoder/value_rules.py) carry their per-cycle predicate and its NumPy twin side by side;
``vector_unsafe`` ORs the twins for a bulk engine. FOLLOWS holds the recurring "status bit follows
control bit within L_max" shape as table rows that one generic loop judges (Python: Checker._follows,
Lua via the generated tables, tools/gen_lua.py).
"""
from __future__ import annotations

from typing import Callable

from .. import rules as R_
from .cycles import SAFE, Columns, Cycle  # noqa: F401  (the registry's public face)
from .rule import Rule, Trigger  # noqa: F401
from .value_rules import (CHECKER_CYCLES, E_MASTER_SOL, E_PARAM, E_SYNC, LIKA_CODES, VALUE_RULES,  # noqa: F401
                          active_value_rules, all_rows, sign_of_life_unsafe, vector_unsafe)


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


FOLLOW_GROUPS = tuple(_FOLLOWS_BY_GROUP)   # every group _cycle_std judges (Checker.windows_quiet asks them all)


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
                       "BMP-ILLEGAL-REQID-RESPONSE BMP-NOT-MIRRORED BMP-RESPID-MISMATCH BMP-NEG-FORMAT BMP-ORDER "
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
