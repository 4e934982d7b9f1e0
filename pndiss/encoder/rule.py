"""What a rule of the reference encoder is: the record encoder/registry.py keeps for each one."""
from __future__ import annotations

from dataclasses import dataclass
from typing import Callable

from .. import rules as R_


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
    run_lag: Callable | None = None  # value rules: (Checker) -> cycles a correct device may lag; the run
                                     # must then be longer than that too (a velocity computed every 100 ms)
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


@dataclass(frozen=True)
class Trigger:
    """A per-cycle condition that changes the checker's state (not a rule): no bulk skipping over it."""
    name: str
    check: Callable
    vector: Callable
