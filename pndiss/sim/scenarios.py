"""Named scenarios and fault injection for ``pndiss simulate``.

A scenario shapes a clean session (shaft motion, PLC requests, device events); an injection
(``--inject RULE_ID[@CYCLE]``) makes one side break one rule of the catalogue
(pndiss/data/rules.json, spec/behaviour.md §9) and records where it did in the ground truth.
"""
from __future__ import annotations

import json
import os
from typing import TYPE_CHECKING

from ..rules import RULES
from . import pcapng
from .config import Config

if TYPE_CHECKING:   # the session builds frames with scapy (~0.5 s to import): not for `pndiss analyze`
    from .session import SimSession

STANDSTILL = ((0.0, 0.0, 0.0),)


class Scenario:
    """Hooks the session calls; the base class is the plain start-up + run."""

    name = "startup"
    help = "DCP, LLDP, Connect, 0xBF00, PrmEnd/ApplicationReady, I&M0 + parameter reads, cyclic run with a speed ramp"
    shaft = None   # ((fraction of the run, rpm at start, rpm at end), ...); None = session default
    skip_bf00 = False
    bf00_bytes = None
    bf00_tags = ()

    def __init__(self):
        self.injections: list[Injection] = []
        self.param_override: dict = {}      # pnu -> (device-values transform, tags)
        self.dcp_extra: list = []           # ("name"|"ip", station index, value, tags)
        self.bmp_extra: list = []           # injections with an access(sess, st, ts, dev)
        self.connect_tags = ()
        self.first_cyclic_tags = ()
        self.reject_bf00 = False

    def prepare(self, sess: SimSession, params: dict) -> None:
        self.cycles = sess.cfg.cycles
        for inj in self.injections:
            inj.prepare(sess, self, params)

    def at(self, frac: float) -> int:
        return max(1, int(self.cycles * frac))

    def before_cycle(self, sess, k, st, plc, enc, last_in) -> None:
        self.cycle(sess, k, st, plc, enc, last_in)
        for inj in self.injections:
            inj.before_cycle(sess, k, st, plc, enc, last_in)

    def cycle(self, sess, k, st, plc, enc, last_in) -> None:
        pass

    def after_plc(self, sess, k, st, out, tags) -> None:
        for inj in self.injections:
            inj.after_plc(sess, k, st, out, tags)

    def after_enc(self, sess, k, st, actual, tags) -> None:
        for inj in self.injections:
            inj.after_enc(sess, k, st, actual, tags)

    def patch(self, sess, k, st, out_frame, in_frame, tags_o, tags_i) -> None:
        for inj in self.injections:
            inj.patch(sess, k, st, out_frame, in_frame, tags_o, tags_i)

    def finish(self, sess) -> None:
        for inj in self.injections:
            inj.finish(sess)


class Preset(Scenario):
    name = "preset"
    help = "standstill; P65000 = 1000 written over 0xB02E, then the G1_STW.12/G1_ZSW.12 preset handshake (telegrams 86-89/100/101/860: the cyclic preset trigger)"
    shaft = ((0.0, 0.0, 0.0), (0.05, 0.0, 30.0), (0.2, 30.0, 0.0), (0.3, 0.0, 0.0))   # still from 30 %
    value = 1000
    mode = 0                 # G1_STW.11: 0 absolute, 1 relative (cyclic.md §5.3)
    hold_request = False     # never give up waiting for the acknowledgement
    hold_after_ack = 0       # cycles the PLC keeps the request after the acknowledgement
    trigger_cycles = 5       # cycles the cyclic preset trigger bit stays set (cyclic.md §10)
    skip_p65000 = False

    def prepare(self, sess, params):
        self.cycles = sess.cfg.cycles
        self.k_req = self.at(0.5)
        super().prepare(sess, params)
        self.acked = None

    def cycle(self, sess, k, st, plc, enc, last_in):
        if k == 1 and not self.skip_p65000:
            # written here, not in prepare(): the cyclic time base exists only once the run starts
            sess.write_param(sess.cyc_ts(max(self.k_req - 40, 2)), st, 65000, self.value)
        cyclic_preset = "g1_stw" not in plc.out_fields.names
        if k == 1 and not cyclic_preset:
            enc.preset_value = self.value
        if k == self.k_req:
            if cyclic_preset:
                plc.preset_out, plc.preset_trig = self.value, True
                enc.preset_value = min(self.value, enc.p["tmr"] - 1)
            else:
                plc.preset_req, plc.preset_mode = True, self.mode
        elif plc.preset_req and last_in and last_in.get("g1_zsw", 0) & 0x1000:
            if self.acked is None:
                self.acked = k
            if k >= self.acked + self.hold_after_ack:
                plc.preset_req = False   # step 3 of the handshake (cyclic.md §7.2)
        elif plc.preset_trig and k >= self.k_req + self.trigger_cycles:
            plc.preset_trig = False      # cyclic preset telegrams: trigger bit back to 0 (cyclic.md §10)
        if k == self.k_req + 200 and plc.preset_req and not self.hold_request:
            plc.preset_req = False       # never acknowledged: give up


class Parking(Scenario):
    name = "parking"
    help = "standstill; G1_STW.14 parks the sensor for a while, then releases it"
    shaft = STANDSTILL

    def cycle(self, sess, k, st, plc, enc, last_in):
        if k == self.at(0.3):
            plc.park = True
        elif k == self.at(0.6):
            plc.park = False


class SensorError(Scenario):
    name = "sensor-error"
    help = "the encoder reports sensor error 0x1001 (G1_ZSW.15, code in G1_XIST2) with a diagnosis alarm, the cause goes away, the PLC acknowledges (G1_STW.15 / G1_ZSW.11), the diagnosis disappears"
    code = 0x1001            # memory error (cyclic.md §9)
    channel_error = 0x9000   # Lika alarm-channel ChannelErrorType "memory error" (cyclic.md §9 note)
    ack_cycles = None        # give up acknowledging after this many cycles (None: wait for G1_ZSW.11)
    ack_hold = 0             # keep G1_STW.15 this many cycles after G1_ZSW.11
    no_ack = False

    def cycle(self, sess, k, st, plc, enc, last_in):
        if k == self.at(0.3):
            enc.error_code, enc.error_cleared = self.code, False
            sess.alarm(sess.cyc_ts(k) + 300_000, st, appears=True, channel_error=self.channel_error)
        elif k == self.at(0.45):
            enc.error_cleared = True
        elif k == self.at(0.5) and not self.no_ack:
            plc.ack = True
            self.ack_from = k
            self.ackip = None
        elif k == self.at(0.55):
            sess.alarm(sess.cyc_ts(k) + 300_000, st, appears=False, channel_error=self.channel_error)
        if plc.ack:
            if self.ack_cycles is not None and k >= self.ack_from + self.ack_cycles:
                plc.ack = False
            elif last_in and last_in.get("g1_zsw", 0) & 0x0800:
                self.ackip = k if self.ackip is None else self.ackip
                if k >= self.ackip + self.ack_hold:
                    plc.ack = False


class SolMasterSkip(Scenario):
    name = "sol-master-skip"
    help = "the PLC skips one controller sign-of-life value half-way (injects SOL-MASTER-SKIP)"

    def __init__(self):
        super().__init__()
        self.injections.append(make_injection("SOL-MASTER-SKIP", None))


class Motion(Scenario):
    name = "motion"
    help = "ramps up to 600 rpm, constant speed, reverse ramp to -300 rpm, stop"
    shaft = ((0.0, 0.0, 0.0), (0.05, 0.0, 600.0), (0.25, 600.0, 600.0), (0.5, 600.0, -300.0),
             (0.75, -300.0, 0.0), (0.9, 0.0, 0.0))


class Routine(Scenario):
    """A plant's working day on one axis, over and over: every ``period`` cycles a preset handshake, a
    parking request and its release, and a sensor error that goes away and is acknowledged -- the
    traffic between them is steady, the events are where a checker earns its keep (the engine's
    benchmark set (c), bench/run)."""
    name = "routine"
    help = "standstill; every 3 s a preset handshake, parking and its release, a sensor error with its acknowledgement"
    shaft = STANDSTILL
    period = 3000            # cycles between two rounds (3 s at 1 ms)
    value = 1000

    def prepare(self, sess, params):
        super().prepare(sess, params)
        self.acked = self.ackip = None

    def cycle(self, sess, k, st, plc, enc, last_in):
        if k == 1:   # the preset value, written once over 0xB02E (the cyclic time base exists only now)
            sess.write_param(sess.cyc_ts(2), st, 65000, self.value)
        ph = k % self.period
        P = self.period
        if ph == P // 10:
            plc.preset_req, plc.preset_mode = True, 0
            enc.preset_value = self.value
            self.acked = None
        elif plc.preset_req and last_in and last_in.get("g1_zsw", 0) & 0x1000:
            plc.preset_req = False       # step 3 of the handshake (cyclic.md §7.2)
        elif plc.preset_req and ph == P // 10 + 200:
            plc.preset_req = False
        if ph == 3 * P // 10:
            plc.park = True
        elif ph == 4 * P // 10:
            plc.park = False
        if ph == 6 * P // 10:
            enc.error_code, enc.error_cleared = SensorError.code, False
        elif ph == 65 * P // 100:
            enc.error_cleared = True
        elif ph == 7 * P // 10:
            plc.ack = True
            self.ackip = None
        if plc.ack and last_in and last_in.get("g1_zsw", 0) & 0x0800:
            plc.ack = False


SCENARIOS = {c.name: c for c in (Scenario, Preset, Parking, SensorError, SolMasterSkip, Motion, Routine)}


# --------------------------------------------------------------------------------- injections
class Injection:
    """One rule broken on purpose. ``tag`` marks the frames that carry the fault."""

    rule = ""
    side = None
    why = ""
    scenario = None     # scenario the fault needs (None: any)
    telegram = None     # telegram the fault needs
    profile = None      # profile the fault needs
    encoders = 1        # encoders the fault needs
    also = ()           # rules the same wire fault necessarily breaks too
    settings: dict = {}  # analyzer settings needed to see the fault

    def __init__(self, rule: str, cycle: int | None):
        self.rule, self.cycle_arg = rule, cycle
        self.tag = f"inj:{rule}"

    def prepare(self, sess, sc, params):
        self.k = self.cycle_arg if self.cycle_arg is not None else sc.at(0.5)
        self.tmr = params["tmr"]
        self.setup(sess, sc, params)
        sess.injected.append({"rule": self.rule, "side": self.side or RULES[self.rule]["side"],
                              "cycle": self.k, "tag": self.tag, "how": self.why,
                              "also_possible": list(getattr(self, "also", ())),
                              "settings": {k: v for k, v in getattr(self, "settings", {}).items()
                                           # isochronous: sign-of-life is monitored anyway
                                           if not (sess.cfg.irt and k == "sol_monitor_rt")}})

    def setup(self, sess, sc, params):
        pass

    def before_cycle(self, sess, k, st, plc, enc, last_in):
        pass

    def after_plc(self, sess, k, st, out, tags):
        pass

    def after_enc(self, sess, k, st, actual, tags):
        pass

    def patch(self, sess, k, st, o, i, tags_o, tags_i):
        pass

    def finish(self, sess):
        pass


INJECTIONS: dict[str, type] = {}
NOT_INJECTABLE: dict[str, str] = {}


def injectable(rule):
    def deco(cls):
        cls.rule = rule
        INJECTIONS[rule] = cls
        return cls
    return deco


def make_injection(rule: str, cycle: int | None) -> Injection:
    return INJECTIONS[rule](rule, cycle)


from . import faults as _faults  # noqa: E402,F401  (registers the injections)


# --------------------------------------------------------------------------------- output
def write_capture(cfg: Config, path: str, expected: bool = True) -> dict:
    sc = SCENARIOS[cfg.scenario]()
    for rule, cyc in cfg.injects:
        sc.injections.append(make_injection(rule, cyc))
    from .session import SimSession
    sess = SimSession(cfg, sc)
    frames, truth = sess.build()
    with open(path, "wb") as f:
        w = pcapng.Writer(f)
        for fr in frames:
            w.write(fr.ts, fr.data)
    if expected:
        with open(expected_path(path), "w", encoding="utf-8") as f:
            json.dump(truth, f, indent=1, sort_keys=True)
            f.write("\n")
    return truth


def expected_path(path: str) -> str:
    base = path[:-7] if path.endswith(".pcapng") else os.path.splitext(path)[0]
    return base + ".expected.json"
