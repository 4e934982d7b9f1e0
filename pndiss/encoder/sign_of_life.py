"""Sign-of-life monitoring of the reference encoder's checker (behaviour.md §3, §9.1, #1-11).

The controller's C-LS is judged once per controller frame, the DO's failure counter C (+10 per
deviation, -1 per good cycle) decides when the encoder owes a 0x0F02 fault, and the device's DLS
must step by one. sol_bulk_ready / advance_sign_of_life let a bulk engine move a monitor at rest
over many good cycles at once (pndiss/engine.py).

A mixin of pndiss.encoder.Checker (_state.py): the checker's own state, reported through its runs.
"""
from __future__ import annotations

from .config import next_ls
from .registry import E_MASTER_SOL, E_SYNC


class SignOfLife:
    """Checker mixin: the controller's and the device's sign-of-life."""

    def _sign_of_life(self, CLS, pCLS, DLS, pDLS, SERR, X2, first) -> None:
        c, k = self.cfg, self.cfg.k
        if self.started_C and self.sp_new:   # one judgement per controller frame (RT drift: see cycle())
            if not first and self.sp_before is not None:
                pCLS = self.sp_before.get("stw2_enc", 0) >> 12
            if CLS == 0:
                # 1: C-LS 0 is never sent once started (001_9461bb7bc8c2767b.txt:484)
                self._hit("SOL-MASTER-ZERO", "controller sign-of-life 0 after start; expected 1..15", controller=True)
            elif not first and pCLS and CLS not in (pCLS, next_ls(pCLS)):
                # 2: +1 per TMAPC, never a double step (001_9461bb7bc8c2767b.txt:482, 1693)
                self._hit("SOL-MASTER-SKIP", f"controller sign-of-life {pCLS} -> {CLS}; expected {pCLS} or {next_ls(pCLS)}",
                          controller=True)
            # failure counter of the DO (§3.3 R-SOLC-1/2): +10 per deviation, -1 per good TMAPC
            if first or pCLS is None:
                self.cls_run = 1
            elif CLS == pCLS:
                self.cls_run += 1
                if self.cls_run > k:
                    # 3: frozen controller (001_9461bb7bc8c2767b.txt:1693, 1708-1712)
                    self._hit("SOL-MASTER-STALL", f"controller sign-of-life stuck at {CLS} for more than k={k} cycles",
                              controller=True)
                    if (self.cls_run - 1) % k == 0:
                        self.C += 10
            else:
                if k > 1 and self.cls_runs_done > 0 and self.cls_run < k:
                    # 4: each value is held k cycles (001_9461bb7bc8c2767b.txt:1671, 1677)
                    self._hit("SOL-MASTER-WINDOW", f"controller sign-of-life {pCLS} held {self.cls_run} cycles; expected k={k}",
                              controller=True)
                self.cls_runs_done += 1
                self._run_ended(self.cls_run, 1)
                self.cls_run = 1
                if CLS == 0 or (pCLS and CLS != next_ls(pCLS)):
                    self.C += 10
                else:
                    self.C = max(0, self.C - 1)
            self.C_hist.append(self.C)
            over = self.C >= self.sol_limit if c.sol_threshold_ge else self.C > self.sol_limit
            if over and self.solf_due is None and not self.sol_fault_seen:
                self.solf_due = (self.n + self.L, self.f, self.ts)
        if SERR and X2 == E_MASTER_SOL:
            self.sol_fault_seen = True
            self.solf_due = None
        elif self.solf_due is not None and self.n >= self.solf_due[0]:
            _, f0, ts0 = self.solf_due
            # 9: the encoder reports 0x0F02 once the counter passes 10N (000_37bf2397999f1108.txt:2624-2626)
            self._emit("SOL-FAULT-MISSING", f0, ts0, f"failure counter C={self.C} > 10*N={self.sol_limit} but no "
                       f"G1_ZSW.15 with G1_XIST2=0x0F02 within {self.L} cycles", last=self.f)
            self.solf_due = None
            self.sol_fault_seen = True
        if self.C <= self.sol_limit and not SERR:
            self.sol_fault_seen = False  # re-armed once the counter is back under the threshold
        if SERR and X2 == E_MASTER_SOL and self.prev_ac is not None and not (self.prev_ac.get("g1_zsw", 0) >> 15) & 1:
            if self.n >= self.sol_known_at and all(v < self.sol_limit for v in self.C_hist):
                # 10: no 0x0F02 without enough failures (001_9461bb7bc8c2767b.txt:1777-1781)
                self._hit("SOL-FAULT-SPURIOUS", f"0x0F02 raised while the failure counter stayed below 10*N={self.sol_limit} "
                          f"(C={self.C})")
        if DLS:
            if not self.started_D and not first and pDLS == 0 and pCLS is not None and CLS == pCLS \
                    and not (self.started_C and self.cls_run <= self.L + 1):
                # 7: the DO starts on a C-LS change (001_9461bb7bc8c2767b.txt:1734-1736), within L_max cycles of
                # it as every reaction (with k > 1 the controller holds the value it changed)
                self._hit("SOL-DEVICE-EARLY-START", f"encoder sign-of-life started ({DLS}) without a controller sign-of-life change")
            self.started_D = True
            if not first and pDLS and DLS != next_ls(pDLS):
                # 6: +1 every DP cycle (001_9461bb7bc8c2767b.txt:504-506, 1730)
                self._hit("SOL-DEVICE-SKIP", f"encoder sign-of-life {pDLS} -> {DLS}; expected {next_ls(pDLS)}")
        elif self.started_D and not (SERR and X2 == E_SYNC):
            # 5: DLS 0 only with sync fault 0x0F04 (001_9461bb7bc8c2767b.txt:1802-1804)
            self._hit("SOL-DEVICE-ZERO", "encoder sign-of-life 0 after start without sync fault 0x0F04")

    def _run_ended(self, length: int, n: int) -> None:
        """``n`` controller sign-of-life values were held ``length`` cycles each (the summary's histogram: a
        controller whose application cycle is k bus cycles holds every value k cycles, verdict.trust)."""
        if n > 0 and length > 0:   # (0: the run began on a frame whose setpoint was not new)
            h = self.cls_run_hist
            if length in h or len(h) < 32:
                h[length] = h.get(length, 0) + n

    # -- what a bulk engine may ask (pndiss/engine.py) -------------------------------------------
    def sol_bulk_ready(self) -> bool:
        """Sign-of-life monitoring can be advanced at once (advance_sign_of_life) when both counters run, each
        value is held one cycle (k = 1), the failure counter is 0 and no fault report is awaited."""
        return (self.cfg.k == 1 and self.started_C and self.started_D and self.C == 0 and self.solf_due is None)

    def advance_sign_of_life(self, cycles: int, sp_before: dict | None) -> None:
        """``cycles`` monitored cycles in which C-LS and DLS each stepped by one (next_ls) and no sensor error
        was reported -- what the caller checked on its arrays: each is a new controller frame judged good,
        so the failure counter stays 0 and the values' runs are one cycle long (§3.3)."""
        self.cls_runs_done += cycles
        if cycles:
            self._run_ended(self.cls_run, 1)
            self._run_ended(1, cycles - 1)
        self.cls_run = 1
        self.C_hist.extend([0] * min(cycles, self.C_hist.maxlen or cycles))
        self.sol_fault_seen = False
        self.last_fc = self.fc
        self.sp_before = sp_before
