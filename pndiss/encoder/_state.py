"""The reference encoder's checker: its state, its runs of violations and the cycle dispatch.

Like h11's _state.py, the checker holds everything that decides what a conforming encoder and a
conforming controller must do, cycle by cycle; it knows nothing of frames on the wire, files or
clocks. It is fed one cycle at a time (the controller's setpoint and the encoder's actual value
of the same cycle, as signal dicts from pndiss.telegrams) plus record/parameter events, and
returns events: ``violation`` (built by pndiss.rules.violation) and ``state`` (timeline).

The rules are split by family into mixins of the one Checker class (one state, no per-cycle
indirection): words.py (control and status words, §9.2-9.9, and the window rules), presets.py
(preset arithmetic and the preset-carrying telegrams), sign_of_life.py (§3), steady.py (value rules,
steady cycles and what a bulk engine may advance at once); acyclic.py holds the record rules.

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
from . import registry as REG
from .config import DEFAULT_SOURCE, EncoderConfig
from .presets import PresetRules
from .sign_of_life import SignOfLife
from .steady import SteadyCycles
from .words import WordRules

PRESET_TELEGRAMS = {t: sig for t, (sig, _bit) in tg.PRESET_WORD.items()}   # §2.5, from the telegram table
BF00_INDEXES = (0xBF00, 0xFFFF)                  # PS/PSM uses 0xFFFF (behaviour.md §5.1)


STATE_CODES = {"idle": 0, "requested": 1, "done": 2}  # the preset handshake's states as numbers


def _coded(key: str, v) -> dict:
    """{key: number} for a state value, plus {key_name: word} when the checker keeps a word."""
    if isinstance(v, str):
        return {key: STATE_CODES.get(v, -1), f"{key}_name": v}
    return {key: v}


class Checker(WordRules, PresetRules, SignOfLife, SteadyCycles):
    def __init__(self, cfg: EncoderConfig, info: dict | None = None):
        self.cfg = cfg
        self.info = info or {}
        self.n = 0                     # judged cycles so far
        self.f = self.fc = 0           # frame of the actual value / of the setpoint
        self.tc = 0                    # time of the setpoint frame fc
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
        self.unsure_cycles = 0         # ... of them while the telegram was only guessed from lengths fitting several
        self.lost_cycles = 0           # cycles missing from the capture (not judged)
        self.sol_known_at = 0          # cycle from which the failure counter C is known again after a loss (#10)
        self._reset_history()
        # acyclic knowledge (behaviour.md §2.0: state carried from cycle to cycle)
        # last written preset value; until a write is seen, settings.p65000 (None = unknown: the factory 0 may have
        # been replaced and saved with P971, 000_37bf2397999f1108.txt:1787-1789, 2078-2079)
        self.p65000 = cfg.p65000
        self.presets_unjudged = 0      # presets acknowledged while P65000 was unknown (their result not judged)
        self.velocity_filter = None    # frame of a SCANCON velocity filter write (0x1000): NIST-SIGN not judged
        self.preset_open_at_end = None  # frame of a preset request the capture ended on before D_preset (not judged)
        self.cls_run_hist: dict = {}    # cycles a controller sign-of-life value was held -> how many values (monitored)
        self.bf00_seen = False
        self.bf00_invalid: str | None = None   # why the last 0xBF00 was invalid (#67-69)
        self.bf00_valid_frame: int | None = None
        self.params_changed = False    # dir/MUPR/TMR differ from the previous connection (#31)
        self.preset_done = False
        self.first_frame: int | None = None
        self.shift_known = cfg.shift is not None
        self.state: dict = {}
        self.bf00_due = None           # (cycle, why): an invalid 0xBF00 must show 0x1002 (#70)
        self.bf00_undo = None          # (frame, config, state) a 0xBF00 write replaced, until its response
        self.prev_bf00: dict | None = None     # the device's 0xBF00 of the previous connection (#31)
        self.p971_pending = None       # (frame, reads that still returned 1) after P971 := 1 (#90)
        self.p980: set | None = None   # PNUs the device lists in P980 (#88)
        self.last_req_ref: dict = {}   # AR UUID -> request reference of its last parameter request (#78)
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
        creq = tg.bit_position("zsw2_enc", "control_requested", "psm" if self.psm else "generic")
        if getattr(self, "creq_bit", creq) != creq and c.sources.get("compat", "").startswith("learnt from the words"):
            # learnt at the other bit (a PS/PSM device judged generic until its 0xFFFF showed it): learn again
            c.compat = c.defaults["compat"]
            c.sources["compat"] = f"{c.profile} {DEFAULT_SOURCE}"
        self.creq_bit = creq
        self.compat_open = c.compat_open()   # the mode is learnt from the words (words.py _learn_compat)
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
        out = self._break()
        # the encoder's failure counter went on over the lost cycles: C (started afresh at 0) is a lower bound until
        # a counter at the fault threshold would have counted down (SOL-FAULT-SPURIOUS claims C stayed below it)
        self.sol_known_at = self.n + self.sol_limit + 10
        return out

    def unsent(self, cycles: int) -> None:
        """``cycles`` of the cycles counted ``lost`` turned out never sent (the controller's setpoints stopped):
        not judged, as a cycle without valid data (they already elapsed)."""
        self.lost_cycles -= cycles
        self.gated += cycles

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
        self._open[rule] = {"n": self.n, "first": f, "ts": self.tc if controller else self.ts, "last": f, "cycles": 1,
                            "msg": msg, "side": side}

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
              sp_before: dict | None = None, sp_ts: int | None = None) -> list[dict]:
        """Judge one cycle: setpoint ``sp`` and actual value ``ac`` (signal dicts) of the same cycle.

        In RT controller and device run on their own clocks: an actual value may be paired with the same
        setpoint frame as the cycle before, or one setpoint frame may pass unpaired. ``sp_before`` is the
        setpoint frame before ``sp`` in the controller's own stream: the controller's sign-of-life is judged
        on that stream (once per new setpoint frame, against its predecessor), not on the pairing."""
        self.out = []
        self.f, self.ts = frame, ts
        self.fc = frame if sp_frame is None else sp_frame
        self.tc = ts if sp_ts is None else sp_ts   # the setpoint frame's time: a controller violation's (it names fc)
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

    # -- acyclic input (records and parameter accesses, §5 and §9.9) -------------------------------
    def on_record(self, ev: dict) -> list[dict]:
        """A ``record`` or ``param`` event of this encoder's device, in capture order."""
        from .acyclic import check_record  # the record rules live next door (9.9 / 9.10)
        self.out = []
        check_record(self, ev)
        return self.out

    def on_alarm(self, ev: dict) -> list[dict]:
        """A diagnosis alarm of this encoder's submodule (acyclic.check_alarm), in capture order."""
        from .acyclic import check_alarm
        self.out = []
        check_alarm(self, ev)
        return self.out

    def write_refused(self, request_frame) -> list[dict]:
        """The device refused the record write of ``request_frame`` (a negative write response): a
        0xBF00 applied at its request is taken back (acyclic.write_refused)."""
        from .acyclic import write_refused
        self.out = []
        write_refused(self, request_frame)
        return self.out

    def finish(self) -> list[dict]:
        self.out = []
        pre = self.pre
        if pre is not None and not pre["done"] and pre["allowed"]:
            if self.n - pre["n"] >= self.D:   # (judged in its cycle already: pre["allowed"] is then False)
                self._emit("PRESET-ACK-MISSING", pre["f"], pre["ts"],
                           f"no G1_ZSW.12 in the {self.n - pre['n']} cycles after the preset request (capture ended)",
                           last=self.f)
            else:   # 19's window W(n, 1, D_preset) is not over: the encoder may still acknowledge
                self.preset_open_at_end = pre["f"]
        self._end_connection()
        self._flush_all()
        return self.out

    def _end_connection(self) -> None:
        if self.params_changed and not self.preset_done and self.first_frame is not None:
            # 31: new dir/MUPR/TMR need a new preset (000_37bf2397999f1108.txt:2237-2240)
            self._emit("PRESET-WITHOUT-NEW-PARAMS", self.first_frame, 0,
                       "0xBF00 changed code sequence/MUPR/TMR against the previous connection and no preset followed")
        from .acyclic import finish as acyclic_finish
        acyclic_finish(self)

    def new_connection(self, prev_bf00: dict | None) -> list[dict]:
        """The same AR connected again (a controller may reuse its AR UUID, so the axis goes on): the ending
        connection's #31 and #90 are judged as at the end of a capture (a pending preset handshake was broken
        already by the cycles not judged before the new Connect) and the next one starts with what a new
        checker knows (#66 asks for its own 0xBF00, #78 for new request references); counts, the timeline
        and P65000 go on. ``prev_bf00``: the 0xBF00 of the connection that ended (#31)."""
        self.out = []
        self._end_connection()
        self._flush_all()
        self._reset_history()
        self.bf00_seen = False
        self.bf00_invalid = self.bf00_valid_frame = self.bf00_due = None
        self.params_changed = self.preset_done = False
        self.first_frame = None
        self.prev_bf00 = prev_bf00
        self.last_req_ref = {}
        return self.out

    def summary(self) -> dict:
        return {"cycles": self.n, "gated_cycles": self.gated, "unsure_cycles": self.unsure_cycles,
                "lost_cycles": self.lost_cycles, "settings": self.cfg.in_force(),
                "violations": self.counts, "state_changes": self.state_changes, "timeline": self.timeline[:50],
                "p65000": self.p65000, "bf00_seen": self.bf00_seen,
                "presets_unjudged": self.presets_unjudged, "velocity_filter_frame": self.velocity_filter,
                "preset_open_at_end": self.preset_open_at_end,
                "controller_sol_runs": {str(k): v for k, v in sorted(self.cls_run_hist.items())}}
