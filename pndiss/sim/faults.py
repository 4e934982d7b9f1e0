"""Fault injections, one class per catalogue rule (spec/behaviour.md §9, pndiss/data/rules.json).

Each class breaks its rule on one side at cycle ``k`` (``--inject RULE@CYCLE``; default: half-way)
and tags the frames that carry the fault, so the ground truth names first/last frame.
"""
from __future__ import annotations

from .scenarios import Injection, injectable


@injectable("SOL-MASTER-SKIP")
class SolMasterSkip(Injection):
    why = "the PLC skips one controller sign-of-life value"

    def before_cycle(self, sess, k, st, plc, enc, last_in):
        if k == self.k and st.i == 0:
            plc.faults["sol_skip_at"] = k

    def patch(self, sess, k, st, o, i, tags_o, tags_i):
        if k == self.k and st.i == 0:
            tags_o.add(self.tag)
