"""The control and status word rules of the reference encoder's checker (behaviour.md §9.2-9.9).

One judged cycle of the standard telegrams (STW2_ENC / G1_STW against ZSW2_ENC / G1_ZSW): control by
PLC, the preset handshake, the absolute value request, parking, sensor error and acknowledgement,
reserved bits and the 0xBF00 reaction, in the order of behaviour.md §9. The window rules' conditions
(#13 and the registry's FOLLOWS rows) are written once here and answer windows_quiet too.

A mixin of pndiss.encoder.Checker (_state.py): the checker's own state, reported through its runs.
"""
from __future__ import annotations

from . import position as P
from . import registry as REG
from .config import U32
from .cycles import serr_state
from .registry import E_MASTER_SOL, E_PARAM


class WordRules:
    """Checker mixin: the control and status words of one standard-telegram cycle."""

    def _cycle_std(self, sp: dict, ac: dict) -> None:
        c, n, L = self.cfg, self.n, self.L
        stw2 = sp.get("stw2_enc", 0)
        g1stw = sp.get("g1_stw", 0)
        zsw2 = ac.get("zsw2_enc", 0)
        g1zsw = ac.get("g1_zsw", 0)
        has_g1 = "g1_stw" in sp and "g1_zsw" in ac
        CLS, CTRL = stw2 >> 12, (stw2 >> 10) & 1
        HMODE, PREQ, AREQ, PARK, SACK = ((g1stw >> b) & 1 for b in (11, 12, 13, 14, 15))
        FACK = (stw2 >> 7) & 1 if self.psm else 0
        CREQ = (zsw2 >> self.creq_bit) & 1
        ACKIP, PDONE, ATX, PKA, SERR = ((g1zsw >> b) & 1 for b in (11, 12, 13, 14, 15))
        X1, X2 = ac.get("g1_xist1"), ac.get("g1_xist2")
        NIST = ac.get("nist_b", ac.get("nist_a"))
        VALID = c.compat == 0 or CTRL == 1                        # §9 VALID[n]
        ps, pa = self.prev_sp, self.prev_ac
        first = ps is None
        if first:
            pCLS = pHMODE = pPREQ = pAREQ = pPARK = pSACK = None
            pDLS = pACKIP = pPDONE = pATX = pPKA = pSERR = pX1 = None
        else:
            s2, g = ps.get("stw2_enc", 0), ps.get("g1_stw", 0)
            pCLS = s2 >> 12
            pHMODE, pPREQ, pAREQ, pPARK, pSACK = ((g >> b) & 1 for b in (11, 12, 13, 14, 15))
            z2, gz = pa.get("zsw2_enc", 0), pa.get("g1_zsw", 0)
            pDLS = z2 >> 12
            pACKIP, pPDONE, pATX, pPKA, pSERR = ((gz >> b) & 1 for b in (11, 12, 13, 14, 15))
            pX1 = pa.get("g1_xist1")
        rise = (lambda cur, prev: cur == 1 and prev == 0)
        fall = (lambda cur, prev: cur == 0 and prev == 1)
        self.hist.append((CTRL, PREQ, AREQ, PARK, SACK, VALID, PKA, SERR))
        H = self.hist
        full = len(H) == L + 1   # a window W(n,-L_max,0) is only judged once fully observed

        # position used by the preset arithmetic: X3 in telegram 84, else X2 while ATX (§1.6, §4.3)
        cv = REG.Cycle.of(ac, pa, has_g1)
        pos2, ppos2, motion_ref = cv.pos2, cv.ppos2, cv.motion
        # standstill judged on the cycles before this one (this one may already show the reaction), by the position:
        # the velocity lags a stop (SCANCON/Hohner filter it, 001_9461bb7bc8c2767b.txt:970-983,
        # 004_59bef5ae9f41db55.txt:828-838; Lika computes it every 100 ms, 000_37bf2397999f1108.txt:1919, 2483)
        standstill = len(set(self.pos_hist)) <= 1
        v_before = self._speed()
        self.pos_hist.append(motion_ref)

        self._value_rules(cv, CLS, pCLS, pDLS, first)
        shift = c.shift or 0

        # ---- 9.2 control by PLC -----------------------------------------------------------------
        self.last_status = (CTRL, CREQ, has_g1, {"ATX": ATX, "PKA": PKA, "ACKIP": ACKIP})
        if self.compat_open:
            self._learn_compat(H, full, CTRL, CREQ, not first and has_g1 and (
                rise(PDONE, pPDONE) or rise(ATX, pATX) or rise(PKA, pPKA)))
        elif c.compat == 1:
            if full and self._ctrlreq_mismatch(H, CTRL, CREQ):
                # 13: CREQ follows CTRL within L_max (000_37bf2397999f1108.txt:3100-3106)
                self._hit("CTRLREQ-MISMATCH", f"control requested (ZSW2_ENC.{self.creq_bit})={CREQ} while control by PLC "
                                              f"(STW2_ENC.10)={CTRL} for {L + 1} cycles; expected {CTRL}")
            if CTRL == 0 and not first and has_g1 and (rise(PREQ, pPREQ) or rise(AREQ, pAREQ) or rise(PARK, pPARK)
                                                       or rise(SACK, pSACK)):
                # 15: commands without control are ignored (000_37bf2397999f1108.txt:1689-1691)
                self._hit("CMD-WITHOUT-CONTROL", f"G1_STW=0x{g1stw:04X} command edge while STW2_ENC.10=0 (V4.1 mode ignores it)",
                          controller=True)
            if full and all(h[0] == 0 for h in H) and not first and has_g1 and (
                    rise(PDONE, pPDONE) or rise(ATX, pATX) or rise(PKA, pPKA)):
                # 16: nothing may execute without control (000_37bf2397999f1108.txt:3108-3114)
                self._hit("CMD-EXECUTED-WITHOUT-CONTROL", f"G1_ZSW=0x{g1zsw:04X} acknowledged a command while control by PLC was 0 "
                                                          f"for {L + 1} cycles; expected no reaction")
        elif CREQ:
            # 14: V3.1 mode holds control requested at 0 (000_37bf2397999f1108.txt:2338-2346)
            self._hit("CTRLREQ-SET-IN-COMPAT", f"ZSW2_ENC.{self.creq_bit}=1 in V3.1 compatibility mode; expected 0")

        # ---- 9.8 reserved bits ------------------------------------------------------------------
        if stw2 & self.res_stw2:  # 60
            self._hit("RESERVED-BIT-SET-STW2", f"STW2_ENC=0x{stw2:04X} sets reserved bits 0x{stw2 & self.res_stw2:04X} ({c.profile})",
                      controller=True)
        if zsw2 & self.res_zsw2:  # 62
            self._hit("RESERVED-BIT-SET-ZSW2", f"ZSW2_ENC=0x{zsw2:04X} sets reserved bits 0x{zsw2 & self.res_zsw2:04X} ({c.profile})")
        if has_g1:
            if g1stw & self.res_g1stw:  # 61
                self._hit("RESERVED-BIT-SET-G1STW", f"G1_STW=0x{g1stw:04X} sets reserved bits 0x{g1stw & self.res_g1stw:04X} ({c.profile})",
                          controller=True)
            if g1zsw & self.res_g1zsw:  # 63
                self._hit("RESERVED-BIT-SET-G1ZSW", f"G1_ZSW=0x{g1zsw:04X} sets reserved bits 0x{g1zsw & self.res_g1zsw:04X} ({c.profile})")
        if self.preset_bits is not None and "stw2_enc" in sp:
            tb, ab = self.preset_bits
            self._preset89((stw2 >> tb) & 1, 0 if first else (ps.get("stw2_enc", 0) >> tb) & 1, (zsw2 >> ab) & 1)
        if not has_g1:
            self._timeline(CTRL, PREQ=0, PDONE=0, PKA=0, SERR=0, X2=None)
            return

        # ---- 9.3 preset (G1_STW.12 / G1_ZSW.12) -------------------------------------------------
        if not first and rise(PREQ, pPREQ):
            if not c.class4 and not c.class4_open():
                # 17: preset needs class 4 functionality (001_9461bb7bc8c2767b.txt:846)
                self._hit("PRESET-CLASS4-DISABLED", "preset requested (G1_STW.12 rise) with class 4 functionality off", controller=True)
            moving = not standstill
            if moving:
                # 26: presets only at standstill (001_9461bb7bc8c2767b.txt:844, 004_59bef5ae9f41db55.txt:772)
                self._hit("PRESET-NOT-STANDSTILL", f"preset requested while moving (positions {list(self.pos_hist)}, NIST={NIST})",
                          controller=True)
            allowed = VALID and (c.class4 or c.class4_open()) and not PKA and not SERR
            self.pre = {"n": n, "f": self.f, "fc": self.fc, "ts": self.ts, "mode": HMODE, "P": self.p65000,
                        "pos2": ppos2, "x1": pX1, "allowed": allowed, "moving": moving, "done": False,
                        "v": v_before}
            if allowed and (HMODE == 1 or self.p65000):
                self.store = {"n": n, "f": self.f, "ts": self.ts, "zero": 0}
        pre = self.pre
        if pre is not None and PREQ and not PDONE and not first and HMODE != pHMODE and pPREQ:
            # 25: the mode is latched at the edge [INFERENCE] (000_37bf2397999f1108.txt:1790-1793)
            self._hit("PRESET-MODE-CHANGED", f"G1_STW.11 changed {pHMODE}->{HMODE} while the preset request was pending",
                      controller=True)
        if not first and rise(PDONE, pPDONE):
            off = not c.class4 and not c.class4_open()
            if off or pPKA:
                # 18: no preset without class 4 or while parked (000_37bf2397999f1108.txt:2245-2265, 3140-3162)
                self._hit("PRESET-EXECUTED-WHEN-NOT-ALLOWED", "preset acknowledged (G1_ZSW.12 rise) while "
                          + ("class 4 functionality is off" if off else "parked"))
            if all(h[1] == 0 for h in H):
                # 20: PDONE only in answer to PREQ (000_37bf2397999f1108.txt:3123-3139)
                self._hit("PRESET-ACK-SPURIOUS", f"G1_ZSW.12 rose with G1_STW.12=0 in the last {len(H)} cycles")
            self.pdone_since = n
            self.preset_done = True
            if pre is not None and not pre["done"]:
                pre["done"] = True
                pre["done_n"] = n
                self._check_preset_value(pre, pos2, X1, shift)
        if not first and fall(PDONE, pPDONE):
            self.pdone_since = None
            if full and all(h[1] == 1 for h in H):
                # 21: PDONE holds while PREQ = 1 (000_37bf2397999f1108.txt:1806-1812)
                self._hit("PRESET-ACK-DROPPED", "G1_ZSW.12 fell while G1_STW.12 stayed 1")
        if pre is not None and not first and fall(PREQ, pPREQ):
            if not pre["done"] and not PDONE and pre["allowed"]:
                # 23: the controller must hold PREQ until PDONE (000_37bf2397999f1108.txt:780-781)
                self._emit("PRESET-REQ-EARLY-RELEASE", self.fc, self.tc,
                           f"G1_STW.12 released {n - pre['n']} cycles after the request (frame {pre['fc']}) before G1_ZSW.12 rose",
                           cycles=n - pre["n"])
            if PDONE or pre["done"]:
                self.pdone_clear_due = (n + L, self.f, self.ts)
            self.pre = pre = None
        if pre is not None and not pre["done"] and pre["allowed"] and n - pre["n"] >= self.D:
            # 19: PDONE within D_preset (000_37bf2397999f1108.txt:774-778, 001_9461bb7bc8c2767b.txt:541)
            self._emit("PRESET-ACK-MISSING", pre["f"], pre["ts"],
                       f"no G1_ZSW.12 within D_preset={self.D} cycles after the preset request", last=self.f, cycles=self.D)
            pre["allowed"] = False  # reported once
        if self.pdone_clear_due is not None:
            due, f0, ts0 = self.pdone_clear_due
            if PREQ:
                self.pdone_clear_due = None
            elif not PDONE:
                self.pdone_clear_due = None
            elif n >= due:
                # 22: PDONE clears within L_max after PREQ falls (000_37bf2397999f1108.txt:1810-1812)
                self._emit("PRESET-ACK-NOT-CLEARED", f0, ts0, f"G1_ZSW.12 still 1 {L} cycles after G1_STW.12 fell",
                           last=self.f, cycles=L)
                self.pdone_clear_due = None
        if self.pdone_since is not None and PREQ and n - self.pdone_since == self.D:
            # 24: the controller closes the handshake (000_37bf2397999f1108.txt:1832-1834)
            self._emit("PRESET-REQ-STUCK", self.fc, self.tc, f"G1_STW.12 still 1 {self.D} cycles after G1_ZSW.12 rose",
                       side=None, cycles=self.D)
        if pre is not None and pre["done"] and PREQ and PDONE and pre.get("after") is not None and pos2 is not None \
                and ppos2 is not None and pre["mode"] == 1 and abs(pre["P"]) > 2 * pre["v"] and self.n > pre["done_n"]:
            # 30: holding PREQ must not re-execute (relative shift applied twice) [INFERENCE] §2.4 R-PRE-1
            d = P.delta(ppos2, pos2, self.R or U32)
            if abs(d - pre["P"]) <= pre["v"]:
                self._hit("PRESET-REEXECUTED", f"position moved by the preset value {pre['P']} again ({ppos2} -> {pos2}) "
                                               f"while G1_STW.12 was held")
        st = self.store
        if st is not None and n > st["n"]:
            # 43: position zero for longer than 10 ms after the trigger (001_9461bb7bc8c2767b.txt:525)
            if pos2 == 0 or X1 == 0:
                st["zero"] += 1
                if st["zero"] == c.store_cycles + 1:
                    self._emit("XIST-DURING-STORE", st["f"], st["ts"],
                               f"position 0 for more than {c.store_cycles} cycles (10 ms) after the preset request", last=self.f)
                    self.store = None
            elif st["zero"] or n - st["n"] > self.D:
                self.store = None  # the store window is over

        # ---- 9.5 absolute value request and XIST contents ---------------------------------------
        if full:  # 36, 37: ATX follows AREQ (registry.FOLLOWS)
            self._follows("absval", {"ATX": ATX})

        # ---- 9.6 parking ------------------------------------------------------------------------
        if full:  # 45, 46: PKA follows PARK (registry.FOLLOWS)
            self._follows("park", {"PKA": PKA})
        if PKA and not first and pPKA and rise(SERR, pSERR):
            # 48: no new errors while parked (000_37bf2397999f1108.txt:1775-1777)
            self._hit("PARK-ERROR-REPORTED", f"sensor error raised while parked (G1_XIST2=0x{(X2 or 0):X})")
        if not first and rise(PKA, pPKA) and self.lika:
            self.park_rise_due = (n + L, self.f, self.ts)
        if self.park_rise_due is not None and n >= self.park_rise_due[0]:
            _, f0, ts0 = self.park_rise_due
            self.park_rise_due = None
            if SERR and PKA:
                # 49: parking clears errors (000_37bf2397999f1108.txt:1874-1875)
                self._emit("PARK-ERRORS-NOT-CLEARED", f0, ts0, f"sensor error still set {L} cycles after parking started",
                           last=self.f)
        if not first and rise(PARK, pPARK) and not standstill:
            # 50: parking while running is not allowed (000_37bf2397999f1108.txt:1876-1879)
            self._hit("PARK-WHILE-RUNNING", f"parking requested while moving (positions {list(self.pos_hist)}, NIST={NIST})",
                      controller=True)

        # ---- 9.7 sensor error and acknowledgement -----------------------------------------------
        if SERR and (first or not pSERR):
            # an error already on in the first cycle after a break (capture loss, a setpoint never paired, the
            # capture's start) began unseen: whether it was acknowledged is not known, so #11/#55 do not claim it
            self.sack_since_serr = bool(SACK) or first
            self.fack_since_serr = bool(FACK)
        if SERR:
            self.serr_code = X2
            self.sack_since_serr |= bool(SACK)
            self.fack_since_serr |= bool(FACK)
        if not first and rise(SACK, pSACK):
            if not SERR and not pSERR:
                # 57: acknowledging nothing (000_37bf2397999f1108.txt:1887-1891)
                self._hit("SACK-WITHOUT-ERROR", "G1_STW.15 raised with no sensor error", controller=True)
            elif SERR or pSERR:
                self.sack_edge = (n, self.f, self.ts)
        if self.sack_edge is not None:
            n0, f0, ts0 = self.sack_edge
            if ACKIP or not SERR:
                if ACKIP or not c.defaults["ackip_every_ack"]:
                    self.sack_edge = None
            if self.sack_edge is not None:
                lika_flow = c.defaults["ackip_every_ack"]
                if (lika_flow and n - n0 >= L) or (not lika_flow and n - n0 >= L + 1 and SACK and SERR):
                    # 52: ACKIP answers SACK (LIKA always; others if the reset takes > 1 cycle) (000_37bf2397999f1108.txt:3193-3199)
                    self._emit("ACKIP-MISSING", f0, ts0, f"no G1_ZSW.11 within {n - n0} cycles after G1_STW.15 rose with a sensor error",
                               last=self.f, cycles=n - n0)
                    self.sack_edge = None
                elif not lika_flow and not SACK:
                    self.sack_edge = None
        if not first and rise(ACKIP, pACKIP) and all(not h[4] for h in H):
            # 53: ACKIP only after SACK (000_37bf2397999f1108.txt:3193-3199)
            self._hit("ACKIP-SPURIOUS", f"G1_ZSW.11 rose with G1_STW.15=0 in the last {len(H)} cycles")
        if full:  # 54: ACKIP ends with the acknowledgement (registry.FOLLOWS)
            self._follows("ackip", {"ACKIP": ACKIP})
        if ACKIP and SACK:
            if self.ackip_since is None:
                self.ackip_since = n
            elif n - self.ackip_since == self.D:
                # 58: the controller releases SACK after ACKIP (000_37bf2397999f1108.txt:3201-3202)
                self._emit("SACK-HELD", self.fc, self.tc, f"G1_STW.15 held {self.D} cycles after G1_ZSW.11 rose", cycles=self.D)
        elif not SACK:
            self.ackip_since = None
        if not first and fall(SERR, pSERR):
            code = self.serr_code
            # (the acknowledgement of this very cycle counts: a device resetting within one bus cycle shows the
            # error gone in the first actual value after SACK -- an independent audit, SCANCON 001_...:540)
            acked = self.sack_since_serr or bool(SACK) or (self.psm and (self.fack_since_serr or bool(FACK)))
            if not PKA and not acked:
                if code == E_MASTER_SOL:
                    # 11: a sign-of-life fault clears only after acknowledgement (001_9461bb7bc8c2767b.txt:1697)
                    self._hit("SOL-FAULT-CLEARED-WITHOUT-ACK", "0x0F02 sign-of-life fault cleared without G1_STW.15"
                              + (" / STW2_ENC.7" if self.psm else ""))
                else:
                    # 55: errors clear after acknowledgement [AMBIGUOUS] (000_37bf2397999f1108.txt:3182-3213)
                    self._hit("SERR-CLEARED-WITHOUT-ACK", f"sensor error 0x{(code or 0):X} cleared without G1_STW.15")
            if AREQ and VALID and not PKA:   # (parking cleared it: parked, the position stays out, R-ABS-4)
                self.restore_due = (n + L, self.f, self.ts)
        if self.restore_due is not None and n >= self.restore_due[0]:
            _, f0, ts0 = self.restore_due
            self.restore_due = None
            if not ATX and AREQ and not SERR and not PKA:
                # 56: the position comes back into XIST2 (000_37bf2397999f1108.txt:3204-3209)
                self._emit("SERR-XIST2-NOT-RESTORED", f0, ts0, f"G1_ZSW.13 still 0 {L} cycles after the sensor error cleared",
                           last=self.f)
        if self.psm and SERR and not (zsw2 >> 3) & 1:
            # 59: PS/PSM fault present follows the sensor error [INFERENCE] (002_d69f444daf0f8af2.txt:576-582)
            self._hit("FAULT-PRESENT-INCONSISTENT", "G1_ZSW.15=1 but ZSW2_ENC.3 (fault present)=0")

        # ---- 9.9 0xBF00 reaction (#70, #71) -----------------------------------------------------
        if self.bf00_due is not None:
            due, why, f0, ts0 = self.bf00_due
            if SERR and X2 == E_PARAM:
                self.bf00_due = None
            elif n >= due:
                # 70: an invalid parameter set must be reported (000_37bf2397999f1108.txt:2636-2639); from the
                # write (the trigger, as the other deadline rules name theirs) to the deciding frame
                self._emit("BF00-ERROR-NOT-REPORTED", self.f if f0 is None else f0, self.ts if ts0 is None else ts0,
                           f"0xBF00 was invalid ({why}) but data exchange runs with no 0x1002 sensor error", last=self.f)
                self.bf00_due = None
        self._timeline(CTRL, PREQ, PDONE, PKA, SERR, X2)

    def _follows(self, group: str, status: dict) -> None:
        """The "status bit follows control bit within L_max" rows of one group (registry.FOLLOWS): the status
        bit still shows ``is`` although every cycle of the full window W(n, -L_max, 0) met the row's window."""
        for rule, msg in self._follows_hits(group, status, self.hist):
            self._hit(rule, msg.replace("{n}", str(self.L + 1)))

    @staticmethod
    def _follows_hits(group: str, status: dict, H):
        """The rows of ``group`` whose status and window (every cycle of ``H``) hold: (rule, message)."""
        for rule, name, value, window, msg in REG.follows(group):
            if status[name] == value and all(all(bool(h[i]) == v for i, v in window) for h in H):
                yield rule, msg

    @staticmethod
    def _ctrlreq_mismatch(H, CTRL, CREQ) -> bool:
        """#13's condition on a full window: control by PLC the same in every cycle, control requested not."""
        return all(h[0] == CTRL for h in H) and CREQ != CTRL

    def _learn_compat(self, H, full: bool, CTRL: int, CREQ: int, executed: bool) -> None:
        """The compatibility mode from the words, while nothing captured or given says it (cfg.compat_open):
        control requested set proves V4.1 (V3.1 holds it at 0, R-CTRL-3); held at 0 under control by PLC
        for L_max+1 cycles, or a command acknowledged while control by PLC was 0 as long, is V3.1
        (R-CTRL-2/4 would make either a fault). [INFERENCE] docs/settings.md `compat`. Until then #13-#16
        are not judged: either side could be right."""
        if CREQ:
            mode, why = 1, "control requested set"
        elif full and all(h[0] == 1 for h in H):
            mode, why = 0, f"control requested held 0 while control by PLC was 1 for {self.L + 1} cycles"
        elif full and executed and all(h[0] == 0 for h in H):
            mode, why = 0, "a command acknowledged while control by PLC was 0"
        else:
            return
        self.cfg.compat = mode
        self.cfg.sources["compat"] = f"learnt from the words (frame {self.f}: {why})"
        self._apply_cfg()

    def windows_quiet(self) -> bool:
        """No window rule (#13, the FOLLOWS rows) can fire while the words stay those of the last cycle.
        Each needs its condition on every cycle of W(n, -L_max, 0), the newest included: a rule whose
        condition fails on the last cycle's own tuple, or whose status is not the one it reports, stays
        quiet until the key changes. So the cycles after a key change, while the window still holds
        older tuples, may be advanced at once like steady ones (advance_steady)."""
        if self.last_status is None or not self.hist:
            return False
        CTRL, CREQ, has_g1, status = self.last_status
        T = (self.hist[-1],)
        if self.cfg.compat == 1 and not self.compat_open and self._ctrlreq_mismatch(T, CTRL, CREQ):
            return False
        if self.compat_open and CTRL == 1:   # a window that would teach the mode (_learn_compat)
            return False
        return not (has_g1 and any(next(self._follows_hits(g, status, T), None) for g in REG.FOLLOW_GROUPS))

    def _timeline(self, CTRL, PREQ, PDONE, PKA, SERR, X2) -> None:
        self._state("control_by_plc", CTRL)
        self._state("preset", "done" if PDONE else ("requested" if PREQ else "idle"))
        self._state("parked", PKA)
        self._state("sensor_error", serr_state(SERR, X2))
        if self.solmon:
            self._state("sol_fault_counter_over", int(self.C > self.sol_limit))
