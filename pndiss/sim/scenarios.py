"""Named scenarios and fault injection for ``pndiss simulate``.

A scenario shapes a clean session (shaft motion, PLC requests, device events); an injection
(``--inject RULE_ID[@CYCLE]``) makes one side break one rule of the catalogue
(pndiss/data/rules.json, spec/behaviour.md §9) and records where it did in the ground truth.
"""
from __future__ import annotations

import json
import os

from ..rules import RULES
from . import pcapng
from .session import Config, SimSession, SUB_MAP

STANDSTILL = ((0.0, 0.0, 0.0),)


class Scenario:
    """Hooks the session calls; the base class is the plain start-up + run."""

    name = "startup"
    help = "DCP, LLDP, Connect, 0xBF00, PrmEnd/ApplicationReady, I&M0 + parameter reads, cyclic run with a speed ramp"
    shaft = None
    skip_bf00 = False
    bf00_bytes = None
    bf00_tags = ()

    def __init__(self):
        self.injections: list[Injection] = []

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

    def patch(self, sess, k, st, out_frame, in_frame, tags_o, tags_i) -> None:
        for inj in self.injections:
            inj.patch(sess, k, st, out_frame, in_frame, tags_o, tags_i)

    def finish(self, sess) -> None:
        for inj in self.injections:
            inj.finish(sess)


class Preset(Scenario):
    name = "preset"
    help = "standstill; P65000 = 1000 written over 0xB02E, then the G1_STW.12/G1_ZSW.12 preset handshake"
    shaft = ((0.0, 0.0, 0.0), (0.1, 0.0, 30.0), (0.3, 30.0, 0.0), (0.45, 0.0, 0.0))
    value = 1000

    def prepare(self, sess, params):
        super().prepare(sess, params)
        k = self.at(0.5)
        for st in sess.stations:
            sess.write_param(sess.cyc_ts(k - 40), st, 65000, self.value, tags=getattr(self, "write_tags", ()))
        self.k_req = k

    def cycle(self, sess, k, st, plc, enc, last_in):
        if k == 1:
            enc.preset_value = self.value
        if k == self.k_req:
            plc.preset_req = True
            if plc.preset_out is None and "g1_stw" not in plc.out_fields.names:
                plc.preset_out, plc.preset_trig = self.value, True
        elif plc.preset_req and last_in and last_in.get("g1_zsw", 0) & 0x1000:
            plc.preset_req = False   # step 3 of the handshake (cyclic.md §7.2)
        elif plc.preset_trig and k >= self.k_req + 5:
            plc.preset_trig = False  # cyclic preset telegrams: trigger bit back to 0 (cyclic.md §10)
        if k == self.k_req + 200 and plc.preset_req:  # never acknowledged: give up
            plc.preset_req = False


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
    help = "the encoder reports sensor error 0x1001 (G1_ZSW.15, code in G1_XIST2), the cause goes away, the PLC acknowledges (G1_STW.15 / G1_ZSW.11)"
    code = 0x1001   # memory error (cyclic.md §9)

    def cycle(self, sess, k, st, plc, enc, last_in):
        if k == self.at(0.3):
            enc.error_code, enc.error_cleared = self.code, False
        elif k == self.at(0.45):
            enc.error_cleared = True
        elif k == self.at(0.5):
            plc.ack = True
        elif plc.ack and last_in and last_in.get("g1_zsw", 0) & 0x0800:
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
    shaft = ((0.0, 0.0, 0.0), (0.1, 0.0, 600.0), (0.5, 600.0, 600.0), (1.0, 600.0, -300.0),
             (1.5, -300.0, 0.0), (1.8, 0.0, 0.0))


SCENARIOS = {c.name: c for c in (Scenario, Preset, Parking, SensorError, SolMasterSkip, Motion)}


# --------------------------------------------------------------------------------- injections
class Injection:
    """One rule broken on purpose. ``tag`` marks the frames that carry the fault."""

    rule = ""
    side = None
    why = ""

    def __init__(self, rule: str, cycle: int | None):
        self.rule, self.cycle_arg = rule, cycle
        self.tag = f"inj:{rule}"

    def prepare(self, sess, sc, params):
        self.k = self.cycle_arg if self.cycle_arg is not None else sc.at(0.5)
        sess.injected.append({"rule": self.rule, "side": self.side or RULES[self.rule]["side"],
                              "cycle": self.k, "tag": self.tag, "how": self.why})
        self.setup(sess, sc, params)

    def setup(self, sess, sc, params):
        pass

    def before_cycle(self, sess, k, st, plc, enc, last_in):
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
