"""The value rules and the steady cycles of the reference encoder's checker.

Value rules (encoder/registry.py VALUE_RULES) run every cycle, also when the control and status words
stay as they were; then the window, edge and deadline rules cannot change and only they run
(_cycle_steady). What a bulk engine may ask and do (pndiss/engine.py, pndiss/axiswalk.py): whether
the next cycles may go at once (bulk_ready, vector_unsafe) and advancing them (advance_steady).

A mixin of pndiss.encoder.Checker (_state.py): the checker's own state, reported through its runs.
"""
from __future__ import annotations

from . import registry as REG
from .config import U32


class SteadyCycles:
    """Checker mixin: value rules, steady cycles and their bulk advance."""

    def _value_rules(self, c: REG.Cycle, CLS, pCLS, pDLS, first) -> None:
        """The value rules (pndiss/encoder/registry.py): they run every cycle, also in steady state."""
        cfg = self.cfg
        SERR, ATX, X1, X2, DLS = c.SERR, c.ATX, c.X1, c.X2, c.DLS
        # learn the XIST1 shift (P979.3) from the first cycle with both positions (§1.6 R-X1-4)
        if not self.shift_known and c.has_g1 and ATX and not SERR and X1 is not None and X2:
            for s in range(0, 32):
                if (X2 << s) % U32 == X1:
                    cfg.shift = s
                    cfg.sources["shift"] = f"inferred from frame {self.f} (X1 = X2 << {s})"
                    break
            self.shift_known = True

        # ---- 9.1 sign-of-life -------------------------------------------------------------------
        if CLS:
            self.started_C = True
        if self.solmon:
            self._sign_of_life(CLS, pCLS, DLS, pDLS, SERR, X2, first)
        elif DLS:
            self.started_D = True
        c.started_D = self.started_D
        runs = self.value_runs
        for check, rule, min_run, message in self.value_rules:
            if check(self, c):
                if min_run > 1:
                    n = runs[rule] = runs.get(rule, 0) + 1
                    if n < min_run:
                        continue  # not yet: e.g. a filter lag at reversal (#44)
                self._hit(rule, message(self, c))
            elif min_run > 1:
                runs[rule] = 0

    def _cycle_steady(self, sp: dict, ac: dict) -> None:
        """Control and status words (sign-of-life aside) as in the last L_max+1 cycles, nothing pending and
        no rule running: window, edge and deadline rules cannot change, so only the value rules run."""
        ps, pa = self.prev_sp, self.prev_ac
        c = REG.Cycle.of(ac, pa, "g1_zsw" in ac)
        self.pos_hist.append(c.motion)
        self._value_rules(c, sp.get("stw2_enc", 0) >> 12, ps.get("stw2_enc", 0) >> 12, pa.get("zsw2_enc", 0) >> 12, False)
        if c.SERR:
            self._state("sensor_error", c.serr_state)

    def vector_unsafe(self, cols: dict, has_g1: bool):
        """Per row of a stretch of consecutive steady cycles of this axis (``cols``: NumPy columns named as
        the signals of pndiss/data/telegrams.json, row 0 following the checker's last cycle): True where a
        value rule's vectorised predicate fires or the checker must see the cycle itself (registry.py:
        VALUE_RULES and CHECKER_CYCLES). With sign-of-life monitoring (§3) a cycle is safe only when both
        counters step by one and the monitor is at rest (sol_bulk_ready); otherwise every cycle counts."""
        bad = REG.vector_unsafe(self, cols, has_g1)
        if self.solmon:
            if not self.sol_bulk_ready():
                return REG.all_rows(cols)
            bad |= REG.sign_of_life_unsafe(cols, self.prev_sp.get("stw2_enc", 0), self.prev_ac.get("zsw2_enc", 0))
        return bad

    # -- what a bulk engine may ask (pndiss/engine.py): read-only views of the state ------------------------
    def bulk_ready(self) -> bool:
        """The next cycle may go through advance_steady: a previous cycle on both sides, no open run, the
        key steady for more than L+1 cycles or no window rule able to fire on it (windows_quiet), nothing
        pending (no deadline open)."""
        return (self.prev_ac is not None and self.prev_sp is not None and not self._open
                and (self.steady_n > self.L + 1 or self.windows_quiet()) and not self._pending_steady())

    def idle(self) -> bool:
        """No history and no open run: gated cycles only count (gap() would flush nothing)."""
        return self.prev_ac is None and not self._open

    def advance_steady(self, cycles: int, frame: int, ts: int, sp_frame: int | None, sp: dict, ac: dict,
                       motion_refs: list, cls_seen: bool, dls_seen: bool, sp_ts: int | None = None) -> None:
        """``cycles`` calls of cycle() that all take the _cycle_steady branch and hit no rule, at once
        (pndiss/axiswalk.py). The caller has checked on its arrays what makes that so: sign-of-life
        monitoring off, the checker steady (same key, steady_n > L+1 or windows_quiet(), nothing open or pending), in every
        cycle a new decode (not the identical-input branch), no sensor error, the key unchanged and no
        value rule condition (shift learning, #8, #39-42, #44). Then a cycle only moves: n, the frame /
        time stamps, ``same`` (0 after a new decode), pos_hist, started_C/started_D, value_runs (0: no
        sign mismatch) and the previous signals. ``motion_refs`` are the last (up to 3) X1/X3 values,
        ``sp``/``ac`` the last cycle's signal dicts, cls_seen/dls_seen: some C-LS/DLS was non-zero."""
        self.out = []
        self.n += cycles
        # After a key change (windows_quiet) the reference runs _cycle_std while steady_n <= L+1: each such
        # cycle counts in steady_n and appends the key's tuple to the window (after a gap the window may
        # be shorter than steady_n says: exactly those appends, not a full window)
        k = min(cycles, self.L + 2 - self.steady_n) if self.steady_n <= self.L + 1 else 0
        if k:
            self.hist.extend([self.hist[-1]] * min(k, self.L + 1))
            self.steady_n += k
        self.f, self.ts = frame, ts
        self.fc = frame if sp_frame is None else sp_frame
        self.tc = ts if sp_ts is None else sp_ts
        self.last_fc = self.fc
        self.same = 0
        self.pos_hist.extend(motion_refs)
        if cls_seen:
            self.started_C = True
        if dls_seen:
            self.started_D = True
        self.value_runs.clear()
        self.prev_sp, self.prev_ac = sp, ac

