"""The reference encoder's checker: every transition and every cyclic rule in one place.

Like h11's _state.py, this file holds everything that decides what a conforming encoder and a
conforming controller must do, cycle by cycle; it knows nothing of frames on the wire, files or
clocks. It is fed one cycle at a time (the controller's setpoint and the encoder's actual value
of the same cycle, as signal dicts from pndiss.telegrams) plus record/parameter events, and
returns events: ``violation`` (built by pndiss.rules.violation) and ``state`` (timeline).

Notation follows behaviour.md §0.2 / §9: CLS, CTRL, HMODE, PREQ, AREQ, PARK, SACK (setpoint);
DLS, CREQ, ACKIP, PDONE, ATX, PKA, SERR, X1, X2, X3, NIST (actual). ``n`` counts judged cycles;
a window W(n, -L_max, 0) is kept as a short history of the setpoint bits.

A condition that holds over consecutive cycles gives ONE violation (first frame .. last frame);
deadline rules (ACK-MISSING and friends) fire once, at the deadline, naming the trigger frame.
"""
from __future__ import annotations

from collections import deque

from .. import rules as R_
from .. import telegrams as tg
from . import position as P
from . import registry as REG
from .config import EncoderConfig, U32, next_ls
from .cycles import serr_state
from .registry import E_MASTER_SOL, E_PARAM, E_SYNC, LIKA_CODES  # noqa: F401  (re-exported: tools/gen_lua.py)

PRESET_TELEGRAMS = {t: sig for t, (sig, _bit) in tg.PRESET_WORD.items()}   # §2.5, from the telegram table
BF00_INDEXES = (0xBF00, 0xFFFF)                  # PS/PSM uses 0xFFFF (behaviour.md §5.1)


STATE_CODES = {"idle": 0, "requested": 1, "done": 2}  # the preset handshake's states as numbers


def _coded(key: str, v) -> dict:
    """{key: number} for a state value, plus {key_name: word} when the checker keeps a word."""
    if isinstance(v, str):
        return {key: STATE_CODES.get(v, -1), f"{key}_name": v}
    return {key: v}


class Checker:
    def __init__(self, cfg: EncoderConfig, info: dict | None = None):
        self.cfg = cfg
        self.info = info or {}
        self.n = 0                     # judged cycles so far
        self.f = self.fc = 0           # frame of the actual value / of the setpoint
        self.last_fc = None            # setpoint frame of the previous judged cycle
        self.sp_new = True             # this cycle's setpoint frame was not judged before
        self.sp_before = None          # the controller's setpoint frame before this one (RT drift)
        self.ts = 0
        self.out: list[dict] = []      # events produced by the current call
        self._open: dict[str, dict] = {}   # coalescing runs of per-cycle conditions
        self.counts: dict[str, dict] = {}  # rule -> {"events", "cycles", "first_frame"}
        self.timeline: list[dict] = []     # first state changes (capped), for the report
        self.state_changes = 0
        self.gated = 0                 # cycles reported but not judged (IOPS/DataStatus)
        self.lost_cycles = 0           # cycles missing from the capture (not judged)
        self._reset_history()
        # acyclic knowledge (behaviour.md §2.0: state carried from cycle to cycle)
        self.p65000 = 0                # last written preset value, default 0 (000_37bf2397999f1108.txt:1787-1789)
        self.bf00_seen = False
        self.bf00_invalid: str | None = None   # why the last 0xBF00 was invalid (#67-69)
        self.bf00_valid_frame: int | None = None
        self.params_changed = False    # dir/MUPR/TMR differ from the previous connection (#31)
        self.preset_done = False
        self.first_frame: int | None = None
        self.shift_known = cfg.shift is not None
        self.state: dict = {}
        self.bf00_due = None           # (cycle, why): an invalid 0xBF00 must show 0x1002 (#70)
        self.prev_bf00: dict | None = None     # the device's 0xBF00 of the previous connection (#31)
        self.p971_pending = None       # (frame, reads that still returned 1) after P971 := 1 (#90)
        self.p980: set | None = None   # PNUs the device lists in P980 (#88)
        self.last_req_ref = None
        self.io_len: dict = {}         # data object length per direction, for P922 plausibility (#65)
        self.p922_rejected = None
        self._apply_cfg()

    # -- configuration ---------------------------------------------------------------------------
    def _apply_cfg(self) -> None:
        c = self.cfg
        self.std = c.std
        self.solmon = c.solmon
        self.R = c.modulus
        self.L = c.l_max
        self.D = c.d_preset
        self.lika = c.profile == "lika"
        self.psm = c.profile == "psm"
        self.creq_bit = tg.bit_position("zsw2_enc", "control_requested", "psm" if self.psm else "generic")
        self.res_stw2 = tg.reserved_mask("stw2_enc", c.profile)
        self.res_g1stw = tg.reserved_mask("g1_stw", c.profile)
        self.res_zsw2 = tg.reserved_mask("zsw2_enc", c.profile)
        self.res_g1zsw = tg.reserved_mask("g1_zsw", c.profile)
        self.sol_limit = 10 * c.n_sol  # fault at C > 10N (or >= with sol_threshold_ge), §3.3 R-SOLC-3
        hs = tg.PRESET_HANDSHAKE.get(c.telegram) if self.psm else None   # telegram 89 (cyclic.md §3.9)
        self.preset_bits = None if hs is None else tuple(
            tg.bit_position(*hs[k].split("."), profile="psm") for k in ("trigger", "ack"))
        self.value_rules = REG.active_value_rules(self)

    def reconfigure(self) -> None:
        """The configuration changed (0xBF00, P922, P979, a profile learned): re-derive what it implies."""
        self._apply_cfg()

    def end_runs(self) -> list[dict]:
        """The data layout changed (a telegram relabelled): every open run ends now and no edge, window or
        pending handshake reaches across. Returns the violations of the runs that ended."""
        self.out = []
        self._flush_all()
        self._reset_history()
        return self.out

    def _reset_history(self) -> None:
        """Forget the previous cycle (after a gap in judged data): no edges across a gap."""
        self.prev_sp = self.prev_ac = None
        self.hist = deque(maxlen=self.cfg.l_max + 1)   # (CTRL, PREQ, AREQ, PARK, SACK, VALID) per cycle
        self.pos_hist = deque(maxlen=3)                # X1 / position of W(n,-2,0), for standstill
        self.cls_run = 0
        self.cls_runs_done = 0
        self.C = 0                                     # master sign-of-life failure counter (§3.3)
        self.C_hist = deque(maxlen=self.cfg.l_max + 1)
        self.started_C = self.started_D = False
        self.pre = None            # pending preset handshake (§2.4)
        self.pdone_since = None    # cycle PDONE rose (for #24)
        self.pdone_clear_due = None
        self.p860 = None
        self.p89 = None
        self.sack_edge = None      # (n, frame, ts) of rise(SACK) with SERR = 1 (#52)
        self.sack_since_serr = False
        self.fack_since_serr = False
        self.serr_code = None
        self.ackip_since = None
        self.restore_due = None
        self.park_rise_due = None
        self.solf_due = None
        self.sol_fault_seen = False
        self.value_runs: dict = {}  # value rules counting cycles in a row (registry min_run, #44)
        self.store = None          # store window after a preset trigger (#43)
        self.same = 0
        self.prev_key = None       # control/status words without the sign-of-life nibbles
        self.steady_n = 0
        self.last_status = None    # (CTRL, CREQ, has_g1, {status bit: value}) of the last _cycle_std (windows_quiet)

    def gap(self, frame: int, ts: int, reason: str) -> list[dict]:
        """A cycle that is reported, not judged (provider STOP, DataValid = 0, IOPS bad)."""
        self.gated += 1
        return self._break()

    def lost(self, frame: int, ts: int, cycles: int) -> list[dict]:
        """``cycles`` cycles the capture does not hold (capture loss, pndiss/gaps.py) before ``frame``: they
        count as elapsed (n moves on, so deadlines count cycles, not captured frames) but are not judged; no
        edge, window or pending handshake reaches across them (not judged rather than a violation)."""
        self.lost_cycles += cycles
        self.n += cycles
        return self._break()

    def _break(self) -> list[dict]:
        """No judged cycle joins the next one: open runs end, the edge history starts afresh."""
        self.out = []
        if self.prev_ac is not None or self._open:
            self._flush_all()
            self._reset_history()
        return self.out

    # -- violations ------------------------------------------------------------------------------
    def _emit(self, rule: str, frame: int, ts: int, msg: str, last: int | None = None, side: str | None = None,
              cycles: int = 1) -> None:
        ev = R_.violation(rule, frame, ts, msg, last_frame=last, side=side, cycles=cycles, **self.info)
        c = self.counts.get(rule)
        if c is None:
            self.counts[rule] = {"events": 1, "cycles": cycles, "first_frame": frame, "severity": ev["severity"],
                                 "side": ev["side"], "message": msg}
        else:
            c["events"] += 1
            c["cycles"] += cycles
        self.out.append(ev)

    def emit(self, rule: str, frame: int, ts: int, msg: str, last: int | None = None, side: str | None = None,
             cycles: int = 1) -> None:
        """Report one violation of ``rule`` now (the record rules of acyclic.py); it lands in ``out``."""
        self._emit(rule, frame, ts, msg, last, side, cycles)

    def _hit(self, rule: str, msg: str, controller: bool = False, side: str | None = None) -> None:
        """The condition of a per-cycle rule holds in this cycle: open or extend its run."""
        o = self._open.get(rule)
        f = self.fc if controller else self.f
        if o is not None:
            if o["n"] == self.n - 1:
                o["n"] = self.n
                o["last"] = f
                o["cycles"] += 1
                return
            self._flush(rule)
        self._open[rule] = {"n": self.n, "first": f, "ts": self.ts, "last": f, "cycles": 1, "msg": msg, "side": side}

    def _flush(self, rule: str) -> None:
        o = self._open.pop(rule)
        self._emit(rule, o["first"], o["ts"], o["msg"], o["last"], o["side"], o["cycles"])

    def _flush_all(self) -> None:
        for rule in list(self._open):
            self._flush(rule)

    def _state(self, name: str, value) -> None:
        """Timeline: a state change of the encoder or the handshake (kind 'state')."""
        old = self.state.get(name)
        if old == value:
            return
        self.state[name] = value
        if old is None and not value:
            return  # the initial 'off' is not a change
        self.state_changes += 1
        # 'value' is a number in every state event (JSON: one type per field); words go to *_name
        ev = {"frame": self.f, "ts_ns": self.ts, "kind": "state", "state": name, **_coded("value", value),
              **_coded("previous", old)}
        ev.update(self.info)
        if len(self.timeline) < 200:
            self.timeline.append({"frame": self.f, "state": name, **_coded("value", value)})
        self.out.append(ev)

    # -- one cycle -------------------------------------------------------------------------------
    def cycle(self, frame: int, ts: int, sp: dict, ac: dict, sp_frame: int | None = None,
              sp_before: dict | None = None) -> list[dict]:
        """Judge one cycle: setpoint ``sp`` and actual value ``ac`` (signal dicts) of the same cycle.

        In RT controller and device run on their own clocks: an actual value may be paired with the same
        setpoint frame as the cycle before, or one setpoint frame may pass unpaired. ``sp_before`` is the
        setpoint frame before ``sp`` in the controller's own stream: the controller's sign-of-life is judged
        on that stream (once per new setpoint frame, against its predecessor), not on the pairing."""
        self.out = []
        self.f, self.ts = frame, ts
        self.fc = frame if sp_frame is None else sp_frame
        self.sp_new = self.fc != self.last_fc
        self.last_fc = self.fc
        self.sp_before = sp_before
        if self.first_frame is None:
            self.first_frame = frame
        # Fast path: identical inputs, nothing pending, history saturated -> nothing can change.
        if sp is self.prev_sp and ac is self.prev_ac and not self._open and self.same > self.L + 1 \
                and not self._pending():
            self.n += 1
            return self.out
        self.same = self.same + 1 if (sp is self.prev_sp and ac is self.prev_ac) else 0
        self.n += 1
        if self.std:
            key = (sp.get("stw2_enc", 0) & 0x0FFF, sp.get("g1_stw", 0), ac.get("zsw2_enc", 0) & 0x0FFF, ac.get("g1_zsw", 0))
            if key == self.prev_key and self.steady_n > self.L + 1 and not self._open and not self._pending_steady():
                self._cycle_steady(sp, ac)
            else:
                self.steady_n = self.steady_n + 1 if key == self.prev_key else 0
                self._cycle_std(sp, ac)
            self.prev_key = key
        elif self.cfg.telegram in PRESET_TELEGRAMS:
            self._cycle_preset_telegram(sp, ac)
        if self._open:
            for rule in [r for r, o in self._open.items() if o["n"] < self.n]:
                self._flush(rule)
        self.prev_sp, self.prev_ac = sp, ac
        return self.out

    def _pending(self) -> bool:
        return self.solmon or self._pending_steady()

    def _pending_steady(self) -> bool:
        """A deadline rule is running (registry.DEADLINES): no cycle may be skipped."""
        return REG.pending(self)

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
        DLS, CREQ = zsw2 >> 12, (zsw2 >> self.creq_bit) & 1
        ACKIP, PDONE, ATX, PKA, SERR = ((g1zsw >> b) & 1 for b in (11, 12, 13, 14, 15))
        X1, X2, X3 = ac.get("g1_xist1"), ac.get("g1_xist2"), ac.get("g1_xist3")
        NIST = ac.get("nist_b", ac.get("nist_a"))
        VALID = c.compat == 0 or CTRL == 1                        # §9 VALID[n]
        ps, pa = self.prev_sp, self.prev_ac
        first = ps is None
        if first:
            pCLS = pCTRL = pHMODE = pPREQ = pAREQ = pPARK = pSACK = None
            pDLS = pACKIP = pPDONE = pATX = pPKA = pSERR = pX1 = pX2 = None
        else:
            s2, g = ps.get("stw2_enc", 0), ps.get("g1_stw", 0)
            pCLS, pCTRL = s2 >> 12, (s2 >> 10) & 1
            pHMODE, pPREQ, pAREQ, pPARK, pSACK = ((g >> b) & 1 for b in (11, 12, 13, 14, 15))
            z2, gz = pa.get("zsw2_enc", 0), pa.get("g1_zsw", 0)
            pDLS = z2 >> 12
            pACKIP, pPDONE, pATX, pPKA, pSERR = ((gz >> b) & 1 for b in (11, 12, 13, 14, 15))
            pX1, pX2 = pa.get("g1_xist1"), pa.get("g1_xist2")
        rise = (lambda cur, prev: cur == 1 and prev == 0)
        fall = (lambda cur, prev: cur == 0 and prev == 1)
        self.hist.append((CTRL, PREQ, AREQ, PARK, SACK, VALID, PKA, SERR))
        H = self.hist
        full = len(H) == L + 1   # a window W(n,-L_max,0) is only judged once fully observed

        # position used by the preset arithmetic: X3 in telegram 84, else X2 while ATX (§1.6, §4.3)
        cv = REG.Cycle.of(ac, pa, has_g1)
        pos2, ppos2, motion_ref = cv.pos2, cv.ppos2, cv.motion
        # standstill judged on the cycles before this one (this one may already show the reaction)
        standstill = (len(set(self.pos_hist)) <= 1) and not NIST
        v_before = self._speed()
        self.pos_hist.append(motion_ref)

        self._value_rules(cv, CLS, pCLS, pDLS, first)
        shift = c.shift or 0

        # ---- 9.2 control by PLC -----------------------------------------------------------------
        self.last_status = (CTRL, CREQ, has_g1, {"ATX": ATX, "PKA": PKA, "ACKIP": ACKIP})
        if c.compat == 1:
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
            if not c.class4:
                # 17: preset needs class 4 functionality (001_9461bb7bc8c2767b.txt:846)
                self._hit("PRESET-CLASS4-DISABLED", f"preset requested (G1_STW.12 rise) with class 4 functionality off", controller=True)
            moving = not standstill
            if moving:
                # 26: presets only at standstill (001_9461bb7bc8c2767b.txt:844, 004_59bef5ae9f41db55.txt:772)
                self._hit("PRESET-NOT-STANDSTILL", f"preset requested while moving (positions {list(self.pos_hist)}, NIST={NIST})",
                          controller=True)
            allowed = VALID and c.class4 and not PKA and not SERR
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
            if not c.class4 or pPKA:
                # 18: no preset without class 4 or while parked (000_37bf2397999f1108.txt:2245-2265, 3140-3162)
                self._hit("PRESET-EXECUTED-WHEN-NOT-ALLOWED", "preset acknowledged (G1_ZSW.12 rise) while "
                          + ("class 4 functionality is off" if not c.class4 else "parked"))
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
                self._hit("PRESET-ACK-DROPPED", f"G1_ZSW.12 fell while G1_STW.12 stayed 1")
        if pre is not None and not first and fall(PREQ, pPREQ):
            if not pre["done"] and not PDONE and pre["allowed"]:
                # 23: the controller must hold PREQ until PDONE (000_37bf2397999f1108.txt:780-781)
                self._emit("PRESET-REQ-EARLY-RELEASE", self.fc, self.ts,
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
            self._emit("PRESET-REQ-STUCK", self.fc, self.ts, f"G1_STW.12 still 1 {self.D} cycles after G1_ZSW.12 rose",
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
            self.sack_since_serr = bool(SACK)
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
                self._emit("SACK-HELD", self.fc, self.ts, f"G1_STW.15 held {self.D} cycles after G1_ZSW.11 rose", cycles=self.D)
        elif not SACK:
            self.ackip_since = None
        if not first and fall(SERR, pSERR):
            code = self.serr_code
            acked = self.sack_since_serr or (self.psm and self.fack_since_serr)
            if not PKA and not acked:
                if code == E_MASTER_SOL:
                    # 11: a sign-of-life fault clears only after acknowledgement (001_9461bb7bc8c2767b.txt:1697)
                    self._hit("SOL-FAULT-CLEARED-WITHOUT-ACK", "0x0F02 sign-of-life fault cleared without G1_STW.15"
                              + (" / STW2_ENC.7" if self.psm else ""))
                else:
                    # 55: errors clear after acknowledgement [AMBIGUOUS] (000_37bf2397999f1108.txt:3182-3213)
                    self._hit("SERR-CLEARED-WITHOUT-ACK", f"sensor error 0x{(code or 0):X} cleared without G1_STW.15")
            if AREQ and VALID:
                self.restore_due = (n + L, self.f, self.ts)
        if self.restore_due is not None and n >= self.restore_due[0]:
            _, f0, ts0 = self.restore_due
            self.restore_due = None
            if not ATX and AREQ and not SERR:
                # 56: the position comes back into XIST2 (000_37bf2397999f1108.txt:3204-3209)
                self._emit("SERR-XIST2-NOT-RESTORED", f0, ts0, f"G1_ZSW.13 still 0 {L} cycles after the sensor error cleared",
                           last=self.f)
        if self.psm and SERR and not (zsw2 >> 3) & 1:
            # 59: PS/PSM fault present follows the sensor error [INFERENCE] (002_d69f444daf0f8af2.txt:576-582)
            self._hit("FAULT-PRESENT-INCONSISTENT", f"G1_ZSW.15=1 but ZSW2_ENC.3 (fault present)=0")

        # ---- 9.9 0xBF00 reaction (#70, #71) -----------------------------------------------------
        if self.bf00_due is not None:
            due, why = self.bf00_due
            if SERR and X2 == E_PARAM:
                self.bf00_due = None
            elif n >= due:
                # 70: an invalid parameter set must be reported (000_37bf2397999f1108.txt:2636-2639)
                self._emit("BF00-ERROR-NOT-REPORTED", self.f, self.ts,
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
        if self.cfg.compat == 1 and self._ctrlreq_mismatch(T, CTRL, CREQ):
            return False
        return not (has_g1 and any(next(self._follows_hits(g, status, T), None) for g in REG.FOLLOW_GROUPS))

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

    def sol_bulk_ready(self) -> bool:
        """Sign-of-life monitoring can be advanced at once (advance_sign_of_life) when both counters run, each
        value is held one cycle (k = 1), the failure counter is 0 and no fault report is awaited."""
        return (self.cfg.k == 1 and self.started_C and self.started_D and self.C == 0 and self.solf_due is None)

    def advance_sign_of_life(self, cycles: int, sp_before: dict | None) -> None:
        """``cycles`` monitored cycles in which C-LS and DLS each stepped by one (next_ls) and no sensor error
        was reported -- what the caller checked on its arrays: each is a new controller frame judged good,
        so the failure counter stays 0 and the values' runs are one cycle long (§3.3)."""
        self.cls_runs_done += cycles
        self.cls_run = 1
        self.C_hist.extend([0] * min(cycles, self.C_hist.maxlen or cycles))
        self.sol_fault_seen = False
        self.last_fc = self.fc
        self.sp_before = sp_before

    def advance_steady(self, cycles: int, frame: int, ts: int, sp_frame: int | None, sp: dict, ac: dict,
                       motion_refs: list, cls_seen: bool, dls_seen: bool) -> None:
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
        self.last_fc = self.fc
        self.same = 0
        self.pos_hist.extend(motion_refs)
        if cls_seen:
            self.started_C = True
        if dls_seen:
            self.started_D = True
        self.value_runs.clear()
        self.prev_sp, self.prev_ac = sp, ac

    # -- sign-of-life (§3) -----------------------------------------------------------------------
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
            if all(v < self.sol_limit for v in self.C_hist):
                # 10: no 0x0F02 without enough failures (001_9461bb7bc8c2767b.txt:1777-1781)
                self._hit("SOL-FAULT-SPURIOUS", f"0x0F02 raised while the failure counter stayed below 10*N={self.sol_limit} "
                          f"(C={self.C})")
        if DLS:
            if not self.started_D and not first and pDLS == 0 and pCLS is not None and CLS == pCLS:
                # 7: the DO starts on a C-LS change (001_9461bb7bc8c2767b.txt:1734-1736)
                self._hit("SOL-DEVICE-EARLY-START", f"encoder sign-of-life started ({DLS}) without a controller sign-of-life change")
            self.started_D = True
            if not first and pDLS and DLS != next_ls(pDLS):
                # 6: +1 every DP cycle (001_9461bb7bc8c2767b.txt:504-506, 1730)
                self._hit("SOL-DEVICE-SKIP", f"encoder sign-of-life {pDLS} -> {DLS}; expected {next_ls(pDLS)}")
        elif self.started_D and not (SERR and X2 == E_SYNC):
            # 5: DLS 0 only with sync fault 0x0F04 (001_9461bb7bc8c2767b.txt:1802-1804)
            self._hit("SOL-DEVICE-ZERO", "encoder sign-of-life 0 after start without sync fault 0x0F04")

    # -- preset arithmetic at the acknowledgement (§4.3, #27-29) ----------------------------------
    def _speed(self) -> int:
        """Largest position step of W(n-3, n-1): the motion tolerance per cycle (§4.3 [INFERENCE])."""
        h = [x for x in self.pos_hist if x is not None]
        m = self.R or U32
        return max((abs(P.delta(a, b, m)) for a, b in zip(h, h[1:])), default=0)

    def _check_preset_value(self, pre: dict, pos2, X1, shift: int) -> None:
        """#27-29 at the first frame with PDONE = 1: |observed - expected| <= v x cycles (§4.3)."""
        c = self.cfg
        if not pre["allowed"]:
            return
        P_, mode = pre["P"], pre["mode"]
        tol = pre["v"] * (self.n - pre["n"] + 1)
        m2 = self.R or U32
        near = (lambda a, b, m: abs(P.delta(b, a, m)) <= tol)
        words = "absolute" if mode == 0 else "relative"
        x2_ok = None
        if pos2 is not None and (mode == 0 or pre["pos2"] is not None):
            exp2 = P.expected_after_preset(mode, P_, pre["pos2"] or 0, self.R)
            x2_ok = near(pos2, exp2, m2)
            pre["after"] = pos2
            if not x2_ok:
                # 27: position after the preset (000_37bf2397999f1108.txt:1799-1807, 1818-1829)
                self._emit("PRESET-VALUE-WRONG", self.f, self.ts,
                           f"{words} preset P65000={P_}: position {pos2} in the first frame with G1_ZSW.12, expected {exp2}"
                           + (f" +- {tol}" if tol else ""))
        if X1 is None or pre["x1"] is None:
            return
        x1_before = pre["x1"]
        m1 = U32 if c.xist1_counter else m2
        sh = 0 if c.xist1_counter else shift
        base = x1_before if c.xist1_counter else (x1_before >> shift)
        moved_like_x2 = x2_ok and not near(pos2, pre["pos2"] if pre["pos2"] is not None else pos2 + tol + 1, m2)
        x1_kept = near(X1 >> sh, base, m1)
        if c.xist1_preset_affected:
            exp1 = P.expected_after_preset(mode, P_, base, m1)
            if x1_kept and moved_like_x2 and not near(exp1, base, m1):
                # 29: preset control enabled, XIST1 must follow (000_37bf2397999f1108.txt:2245-2249)
                self._emit("PRESET-XIST1-NOT-AFFECTED-WHEN-ENABLED", self.f, self.ts,
                           f"G1_XIST2 took the preset but G1_XIST1 stayed {X1}; expected {P.aligned_xist1(exp1, sh)}")
            elif not near(X1 >> sh, exp1, m1) or (X1 & ((1 << sh) - 1)):
                self._emit("PRESET-VALUE-WRONG", self.f, self.ts,
                           f"{words} preset P65000={P_}: G1_XIST1=0x{X1:08X} in the first frame with G1_ZSW.12, "
                           f"expected 0x{P.aligned_xist1(exp1, sh):08X}")
        elif not x1_kept and moved_like_x2:
            # 28: preset control disabled, XIST1 must not move (§7 D14 per-vendor coding)
            self._emit("PRESET-XIST1-AFFECTED-WHEN-DISABLED", self.f, self.ts,
                       f"G1_XIST1 changed {x1_before} -> {X1} at the preset although G1_XIST1 preset control is disabled")

    # -- preset-carrying telegrams 86/87/88/100/101/860 (§2.5, #32-34) ----------------------------
    def _cycle_preset_telegram(self, sp: dict, ac: dict) -> None:
        sig, top = tg.PRESET_WORD[self.cfg.telegram]   # the word and its trigger bit (cyclic.md §10)
        word = sp.get(sig, 0)
        PT, PV = (word >> top) & 1, word & ((1 << top) - 1)
        pos = ac.get("g1_xist1", ac.get("g1_xist3"))
        NIST = ac.get("nist_b")
        standstill = len(set(self.pos_hist)) <= 1 and not NIST
        v_before = self._speed()
        self.pos_hist.append(pos)
        ps = self.prev_sp
        pPT = None if ps is None else (ps.get(sig, 0) >> top) & 1
        n = self.n
        if pPT == 0 and PT == 1:
            exp = P.preset_860(PV, self.R)
            if self.R is not None and PV >= self.R:
                # 32: preset value below the total resolution (001_9461bb7bc8c2767b.txt:599, 612)
                self._hit("PRESET860-VALUE-OUT-OF-RANGE", f"preset value {PV} >= R={self.R}", controller=True)
            if not standstill:
                # 26: presets only at standstill (001_9461bb7bc8c2767b.txt:844)
                self._hit("PRESET-NOT-STANDSTILL", f"preset triggered while moving (positions {list(self.pos_hist)}, NIST={NIST})",
                          controller=True)
            self.p860 = {"n": n, "f": self.f, "fc": self.fc, "ts": self.ts, "exp": exp, "seen": False, "v": v_before,
                         "last": pos}
            self.preset_done = True
        p = self.p860
        if p is not None:
            m = self.R or (1 << (8 * tg.SIGNALS[sig]["size"]))
            if n > p["n"] and pos is not None and abs(P.delta(p["exp"], pos, m)) <= p["v"] * (n - p["n"] + 1):
                p["seen"] = True  # within the motion since the trigger (§4.3 tolerance)
            p["last"] = pos
            if n - p["n"] >= self.D and not p.get("judged"):
                p["judged"] = True
                if not p["seen"]:
                    # 33: absolute preset to min(PV, R-1) (001_9461bb7bc8c2767b.txt:924, 931)
                    self._emit("PRESET860-WRONG", p["f"], p["ts"], f"position never showed the preset {p['exp']} within "
                               f"D_preset={self.D} cycles (last {pos})", last=self.f)
            if PT and n - p["n"] == self.D + 1:
                # 34: the controller resets bit 31 (001_9461bb7bc8c2767b.txt:924)
                self._emit("PRESET860-TRIGGER-HELD", p["fc"], p["ts"], f"preset trigger (bit {top}) held more than {self.D} cycles",
                           last=self.fc)
            if not PT and p.get("judged"):
                self.p860 = None

    def _preset89(self, PTRIG, pPTRIG, PACK) -> None:
        n = self.n
        if pPTRIG == 0 and PTRIG == 1 and self.prev_sp is not None:
            self.p89 = (n, self.f, self.ts)
        if self.p89 is not None:
            n0, f0, ts0 = self.p89
            if PACK and n > n0:
                self.p89 = None
            elif n - n0 >= self.D:
                # 35: PS/PSM telegram 89 acknowledges in ZSW2_ENC.0 [INFERENCE] (002_d69f444daf0f8af2.txt:831, 850)
                self._emit("PRESET89-ACK-MISSING", f0, ts0, f"no XIST_PRESET_ACK (ZSW2_ENC.0) within {self.D} cycles", last=self.f)
                self.p89 = None

    def _timeline(self, CTRL, PREQ, PDONE, PKA, SERR, X2) -> None:
        self._state("control_by_plc", CTRL)
        self._state("preset", "done" if PDONE else ("requested" if PREQ else "idle"))
        self._state("parked", PKA)
        self._state("sensor_error", serr_state(SERR, X2))
        if self.solmon:
            self._state("sol_fault_counter_over", int(self.C > self.sol_limit))

    # -- acyclic input (records and parameter accesses, §5 and §9.9) -------------------------------
    def on_record(self, ev: dict) -> list[dict]:
        """A ``record`` or ``param`` event of this encoder's device, in capture order."""
        from .acyclic import check_record  # the record rules live next door (9.9 / 9.10)
        self.out = []
        check_record(self, ev)
        return self.out

    def finish(self) -> list[dict]:
        self.out = []
        pre = self.pre
        if pre is not None and not pre["done"] and pre["allowed"] and self.n - pre["n"] >= self.L:
            self._emit("PRESET-ACK-MISSING", pre["f"], pre["ts"],
                       f"no G1_ZSW.12 in the {self.n - pre['n']} cycles after the preset request (capture ended)", last=self.f)
        if self.params_changed and not self.preset_done and self.first_frame is not None:
            # 31: new dir/MUPR/TMR need a new preset (000_37bf2397999f1108.txt:2237-2240)
            self._emit("PRESET-WITHOUT-NEW-PARAMS", self.first_frame, 0,
                       "0xBF00 changed code sequence/MUPR/TMR against the previous connection and no preset followed")
        from .acyclic import finish as acyclic_finish
        acyclic_finish(self)
        self._flush_all()
        return self.out

    def summary(self) -> dict:
        return {"cycles": self.n, "gated_cycles": self.gated, "lost_cycles": self.lost_cycles, "settings": self.cfg.in_force(),
                "violations": self.counts, "state_changes": self.state_changes, "timeline": self.timeline[:50],
                "p65000": self.p65000, "bf00_seen": self.bf00_seen}

