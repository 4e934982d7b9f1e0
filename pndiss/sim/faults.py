"""Fault injections, one class per catalogue rule (spec/behaviour.md §9, pndiss/data/rules.json).

Each class breaks its rule on one side from cycle ``k`` (``--inject RULE@CYCLE``; default: half-way
through the run) on the first encoder, and tags the frames that carry the fault so the ground truth
names first/last frame. ``scenario`` names the scenario the fault needs (the regenerate script and
the docs use it); ``also`` lists rules the same wire fault necessarily breaks as well; ``settings``
are analyzer settings needed to see it (e.g. sign-of-life monitoring outside isochronous mode).
"""
from __future__ import annotations

from .model import sol_next
from .scenarios import STANDSTILL, Injection, NOT_INJECTABLE, injectable

# ------------------------------------------------------------------------ helpers


class Cyclic(Injection):
    """A fault in the words of one side during cycles k .. k+n-1 (first encoder)."""

    n = 1
    where = "enc"      # "enc": the encoder's actual values; "plc": the controller's setpoint

    def active(self, k, st):
        return st.i == 0 and self.k <= k < self.k + self.n

    def after_plc(self, sess, k, st, out, tags):
        if self.where == "plc" and self.active(k, st):
            if self.change(out, k) is not False:
                tags.add(self.tag)

    def after_enc(self, sess, k, st, actual, tags):
        if self.where == "enc" and self.active(k, st):
            if self.change(actual, k) is not False:
                tags.add(self.tag)

    def change(self, words, k):
        raise NotImplementedError


class Knob(Injection):
    """A fault switched on in the PLC or encoder model at cycle k; tags frames while ``flagged``."""

    where = "enc"

    def before_cycle(self, sess, k, st, plc, enc, last_in):
        if st.i == 0 and k == self.k:
            self.turn_on(sess, plc, enc)

    def turn_on(self, sess, plc, enc):
        raise NotImplementedError

    def flagged(self, k, words) -> bool:
        return False

    def after_plc(self, sess, k, st, out, tags):
        if self.where == "plc" and st.i == 0 and k >= self.k and self.flagged(k, out):
            tags.add(self.tag)

    def after_enc(self, sess, k, st, actual, tags):
        if self.where == "enc" and st.i == 0 and k >= self.k and self.flagged(k, actual):
            tags.add(self.tag)


SOL_SETTINGS = {"sol_monitor_rt": True}   # SOLMON outside isochronous mode (behaviour.md §3.1 R-CLS-5)


def _set_sol(words, v):
    words["stw2_enc" if "stw2_enc" in words and "zsw2_enc" not in words else "zsw2_enc"] = \
        (words.get("stw2_enc" if "zsw2_enc" not in words else "zsw2_enc", 0) & 0x0FFF) | (v << 12)


# ------------------------------------------------------------------------ sign-of-life

@injectable("SOL-MASTER-SKIP")
class SolMasterSkip(Knob):
    why = "the PLC skips one controller sign-of-life value (its counter jumps ahead by one)"
    where = "plc"
    settings = SOL_SETTINGS

    def turn_on(self, sess, plc, enc):
        plc.faults["sol_skip_at"] = self.k

    def flagged(self, k, words):
        return k == self.k


@injectable("SOL-MASTER-ZERO")
class SolMasterZero(Cyclic):
    why = "the PLC sends controller sign-of-life 0 for one cycle"
    where = "plc"
    settings = SOL_SETTINGS
    also = ("SOL-MASTER-SKIP",)   # the value after the 0 is not next(0) [rule 2 may also see it]

    def change(self, w, k):
        w["stw2_enc"] &= 0x0FFF


@injectable("SOL-MASTER-STALL")
class SolMasterStall(Cyclic):
    why = "the PLC freezes its sign-of-life for 3 cycles"
    where = "plc"
    n = 3
    settings = SOL_SETTINGS
    also = ("SOL-MASTER-SKIP", "SOL-FAULT-MISSING")

    def change(self, w, k):
        if k == self.k:
            self.v = (w["stw2_enc"] >> 12)
            self.v = self.v - 1 if self.v > 1 else 15   # repeat the previous value
        w["stw2_enc"] = (w["stw2_enc"] & 0x0FFF) | self.v << 12


@injectable("SOL-DEVICE-SKIP")
class SolDeviceSkip(Knob):
    why = "the encoder skips one sign-of-life value (its counter jumps ahead by one)"
    settings = SOL_SETTINGS

    def turn_on(self, sess, plc, enc):
        enc.faults["sol_skip_at"] = self.k

    def flagged(self, k, words):
        return k == self.k


@injectable("SOL-DEVICE-ZERO")
class SolDeviceZero(Cyclic):
    why = "the encoder sends sign-of-life 0 for one cycle (no 0x0F04 error)"
    settings = SOL_SETTINGS
    also = ("SOL-DEVICE-ZERO-RT", "SOL-DEVICE-SKIP")

    def change(self, w, k):
        w["zsw2_enc"] &= 0x0FFF


@injectable("SOL-DEVICE-ZERO-RT")
class SolDeviceZeroRt(Cyclic):
    why = "the encoder sends sign-of-life 0 for 5 cycles in RT operation"
    n = 5

    def change(self, w, k):
        w["zsw2_enc"] &= 0x0FFF


@injectable("SOL-DEVICE-EARLY-START")
class SolDeviceEarlyStart(Injection):
    why = "the controller starts its sign-of-life late (cycle 20); the encoder starts at cycle 10 anyway"
    settings = SOL_SETTINGS

    def setup(self, sess, sc, params):
        self.k = 10

    def after_plc(self, sess, k, st, out, tags):
        if st.i == 0 and k < 20:
            out["stw2_enc"] &= 0x0FFF

    def after_enc(self, sess, k, st, actual, tags):
        if st.i:
            return
        if k < 10:
            actual["zsw2_enc"] &= 0x0FFF
            return
        self.dls = 1 if k == 10 else sol_next(self.dls)   # one continuous count from cycle 10
        actual["zsw2_enc"] = (actual["zsw2_enc"] & 0x0FFF) | self.dls << 12
        if k < 20:
            tags.add(self.tag)


# ------------------------------------------------------------------------ control by PLC

@injectable("CTRLREQ-MISMATCH")
class CtrlReqMismatch(Cyclic):
    why = "the encoder clears 'control requested' for 5 cycles while the PLC keeps control"
    n = 5

    def change(self, w, k):
        w["zsw2_enc"] &= ~0x0600 & 0xFFFF


@injectable("CTRLREQ-SET-IN-COMPAT")
class CtrlReqSetInCompat(Injection):
    why = "V3.1 compatibility mode (0xBF00 compat = 0) but the encoder sets 'control requested'"

    def setup(self, sess, sc, params):
        params["compat"] = 0
        self.bit = 1 << (10 if sess.cfg.profile == "psm" else 9)

    def after_enc(self, sess, k, st, actual, tags):
        if st.i == 0 and k >= self.k:
            actual["zsw2_enc"] |= self.bit
            tags.add(self.tag)


class _NoControl(Injection):
    """The PLC drops 'control by PLC' from k to k+30 and requests parking at k+5..k+15."""

    def setup(self, sess, sc, params):
        sc.shaft = STANDSTILL

    def before_cycle(self, sess, k, st, plc, enc, last_in):
        if st.i:
            return
        plc.ctrl = not (self.k <= k < self.k + 30)
        plc.park = self.k + 5 <= k < self.k + 15


@injectable("CMD-WITHOUT-CONTROL")
class CmdWithoutControl(_NoControl):
    why = "the PLC requests parking while 'control by PLC' is 0 (the encoder ignores it)"

    def after_plc(self, sess, k, st, out, tags):
        if st.i == 0 and k == self.k + 5:
            tags.add(self.tag)


@injectable("CMD-EXECUTED-WITHOUT-CONTROL")
class CmdExecutedWithoutControl(_NoControl):
    why = "the encoder parks although 'control by PLC' is 0"
    also = ("CMD-WITHOUT-CONTROL",)

    def before_cycle(self, sess, k, st, plc, enc, last_in):
        super().before_cycle(sess, k, st, plc, enc, last_in)
        if st.i == 0:
            enc.faults["ignore_ctrl"] = self.k <= k < self.k + 30

    def after_enc(self, sess, k, st, actual, tags):
        if st.i == 0 and self.k + 5 <= k < self.k + 15:
            tags.add(self.tag)


# ------------------------------------------------------------------------ preset (81-84)

class _PresetFault(Knob):
    scenario = "preset"

    def setup(self, sess, sc, params):
        self.k = sc.k_req if hasattr(sc, "k_req") else self.k


@injectable("PRESET-ACK-MISSING")
class PresetAckMissing(Injection):
    why = "the encoder never acknowledges the preset request (G1_ZSW.12 stays 0)"
    scenario = "preset"

    def setup(self, sess, sc, params):
        sc.hold_request = True

    def before_cycle(self, sess, k, st, plc, enc, last_in):
        if st.i == 0:
            enc.faults["preset_ack_missing"] = True

    def after_plc(self, sess, k, st, out, tags):
        if st.i == 0 and out.get("g1_stw", 0) & 0x1000:
            tags.add(self.tag)


@injectable("PRESET-ACK-SPURIOUS")
class PresetAckSpurious(Cyclic):
    why = "the encoder sets G1_ZSW.12 for 5 cycles without a request"
    n = 5

    def change(self, w, k):
        w["g1_zsw"] |= 0x1000


@injectable("PRESET-ACK-DROPPED")
class PresetAckDropped(Injection):
    why = "the encoder drops G1_ZSW.12 while the PLC still holds the request"
    scenario = "preset"

    def setup(self, sess, sc, params):
        sc.hold_after_ack = 8
        self.seen = None

    def after_enc(self, sess, k, st, actual, tags):
        if st.i:
            return
        if actual["g1_zsw"] & 0x1000 and self.seen is None:
            self.seen = k
        if self.seen is not None and self.seen + 3 <= k < self.seen + 8:
            actual["g1_zsw"] &= ~0x1000
            tags.add(self.tag)


@injectable("PRESET-ACK-NOT-CLEARED")
class PresetAckNotCleared(Injection):
    why = "the encoder keeps G1_ZSW.12 for 20 cycles after the request falls"
    scenario = "preset"

    def setup(self, sess, sc, params):
        self.fall = None

    def after_plc(self, sess, k, st, out, tags):
        if st.i == 0 and getattr(self, "req_seen", False) and not out["g1_stw"] & 0x1000 and self.fall is None:
            self.fall = k
        if st.i == 0 and out["g1_stw"] & 0x1000:
            self.req_seen = True

    def after_enc(self, sess, k, st, actual, tags):
        if st.i == 0 and self.fall is not None and k < self.fall + 20:
            actual["g1_zsw"] |= 0x1000
            tags.add(self.tag)


@injectable("PRESET-REQ-EARLY-RELEASE")
class PresetReqEarlyRelease(Injection):
    why = "the PLC drops G1_STW.12 one cycle after raising it, before the (slow) acknowledgement"
    scenario = "preset"

    def before_cycle(self, sess, k, st, plc, enc, last_in):
        if st.i == 0:
            enc.faults["preset_delay"] = 6
            if k == sc_k(sess) + 2:
                plc.preset_req = False

    def after_plc(self, sess, k, st, out, tags):
        if st.i == 0 and k == sc_k(sess) + 2:
            tags.add(self.tag)


def sc_k(sess):
    return sess.scenario.k_req


@injectable("PRESET-REQ-STUCK")
class PresetReqStuck(Injection):
    why = "the PLC holds G1_STW.12 for 40 cycles after the acknowledgement"
    scenario = "preset"

    def setup(self, sess, sc, params):
        sc.hold_after_ack = 40

    def after_plc(self, sess, k, st, out, tags):
        if st.i == 0 and out["g1_stw"] & 0x1000 and k > sc_k(sess) + 12:
            tags.add(self.tag)


@injectable("PRESET-MODE-CHANGED")
class PresetModeChanged(Injection):
    why = "the PLC toggles the home position mode bit while the preset request waits for its acknowledgement"
    scenario = "preset"

    def before_cycle(self, sess, k, st, plc, enc, last_in):
        if st.i == 0:
            enc.faults["preset_delay"] = 5
            if k == sc_k(sess) + 2:
                plc.preset_mode = 1
            elif k == sc_k(sess) + 3:
                plc.preset_mode = 0

    def after_plc(self, sess, k, st, out, tags):
        if st.i == 0 and k == sc_k(sess) + 2:
            tags.add(self.tag)


@injectable("PRESET-NOT-STANDSTILL")
class PresetNotStandstill(Injection):
    why = "the PLC requests the preset while the shaft turns at 30 rpm"
    scenario = "preset"
    also = ("POSITION-DISCONTINUITY",)

    def setup(self, sess, sc, params):
        sc.shaft = ((0.0, 0.0, 30.0), (0.1, 30.0, 30.0))

    def after_plc(self, sess, k, st, out, tags):
        if st.i == 0 and k == sc_k(sess):
            tags.add(self.tag)


@injectable("PRESET-VALUE-WRONG")
class PresetValueWrong(Injection):
    why = "the encoder applies the preset 5 counts off the P65000 value"
    scenario = "preset"

    def before_cycle(self, sess, k, st, plc, enc, last_in):
        if st.i == 0:
            enc.faults["preset_error"] = 5

    def after_enc(self, sess, k, st, actual, tags):
        if st.i == 0 and actual["g1_zsw"] & 0x1000:
            tags.add(self.tag)


@injectable("PRESET-CLASS4-DISABLED")
class PresetClass4Disabled(Injection):
    why = "class 4 disabled in 0xBF00, the PLC requests a preset anyway (the encoder ignores it)"
    scenario = "preset"

    def setup(self, sess, sc, params):
        params["class4"] = 0
        sc.skip_p65000 = True

    def after_plc(self, sess, k, st, out, tags):
        if st.i == 0 and k == sc_k(sess):
            tags.add(self.tag)


@injectable("PRESET-EXECUTED-WHEN-NOT-ALLOWED")
class PresetExecutedWhenNotAllowed(PresetClass4Disabled):
    why = "class 4 disabled, the encoder executes and acknowledges the preset"
    also = ("PRESET-CLASS4-DISABLED",)

    def before_cycle(self, sess, k, st, plc, enc, last_in):
        if st.i == 0:
            enc.faults["ignore_class4"] = True
            enc.preset_value = 1000

    def after_enc(self, sess, k, st, actual, tags):
        if st.i == 0 and actual["g1_zsw"] & 0x1000:
            tags.add(self.tag)


@injectable("PRESET-REEXECUTED")
class PresetReexecuted(Injection):
    why = "relative preset; the encoder applies the offset again while the request is still held"
    scenario = "preset"

    def setup(self, sess, sc, params):
        sc.hold_after_ack = 8
        sc.mode = 1
        self.ack = None

    def before_cycle(self, sess, k, st, plc, enc, last_in):
        if st.i == 0 and self.ack is not None and k == self.ack + 4:
            enc.offset = (enc.offset + enc.preset_value) % enc.p["tmr"]

    def after_enc(self, sess, k, st, actual, tags):
        if st.i == 0 and actual["g1_zsw"] & 0x1000 and self.ack is None:
            self.ack = k
        if st.i == 0 and self.ack is not None and k == self.ack + 4:
            tags.add(self.tag)


@injectable("XIST-DURING-STORE")
class XistDuringStore(Injection):
    why = "after the preset the encoder sends position 0 for 15 ms (storing the offset; 5-10 ms allowed)"
    scenario = "preset"
    also = ("POSITION-DISCONTINUITY",)

    def setup(self, sess, sc, params):
        self.ack = None

    def after_enc(self, sess, k, st, actual, tags):
        if st.i:
            return
        if actual["g1_zsw"] & 0x1000 and self.ack is None:
            self.ack = k
        if self.ack is not None and self.ack < k < self.ack + 16:
            for s in ("g1_xist1", "g1_xist2", "g1_xist3"):
                actual[s] = 0
            tags.add(self.tag)


# ------------------------------------------------------------------------ cyclic preset telegrams

@injectable("PRESET860-VALUE-OUT-OF-RANGE")
class Preset860OutOfRange(Injection):
    why = "telegram 860: the PLC presets a value >= the total measuring range (the encoder clamps to R-1)"
    scenario = "preset"
    telegram = 860

    def setup(self, sess, sc, params):
        sc.value = params["tmr"] + 100
        sc.skip_p65000 = True

    def before_cycle(self, sess, k, st, plc, enc, last_in):
        if st.i == 0 and k == sc_k(sess):
            enc.preset_value = enc.p["tmr"] - 1

    def after_plc(self, sess, k, st, out, tags):
        if st.i == 0 and k == sc_k(sess):
            tags.add(self.tag)


@injectable("PRESET860-WRONG")
class Preset860Wrong(Injection):
    why = "telegram 860: the encoder applies the preset 7 counts off"
    scenario = "preset"
    telegram = 860

    def setup(self, sess, sc, params):
        sc.skip_p65000 = True

    def before_cycle(self, sess, k, st, plc, enc, last_in):
        if st.i == 0:
            enc.faults["cyclic_preset_error"] = 7

    def after_enc(self, sess, k, st, actual, tags):
        if st.i == 0 and sc_k(sess) <= k < sc_k(sess) + 3:
            tags.add(self.tag)


@injectable("PRESET860-TRIGGER-HELD")
class Preset860TriggerHeld(Injection):
    why = "telegram 860: the PLC holds the trigger bit 31 for 50 cycles"
    scenario = "preset"
    telegram = 860

    def setup(self, sess, sc, params):
        sc.skip_p65000 = True
        sc.trigger_cycles = 50

    def after_plc(self, sess, k, st, out, tags):
        if st.i == 0 and sc_k(sess) + 13 <= k < sc_k(sess) + 50:
            tags.add(self.tag)


@injectable("PRESET89-ACK-MISSING")
class Preset89AckMissing(Injection):
    why = "telegram 89: the encoder never sets XIST_PRESET_ACK (ZSW2_ENC bit 0)"
    scenario = "preset"
    telegram = 89
    profile = "psm"

    def setup(self, sess, sc, params):
        sc.skip_p65000 = True

    def after_enc(self, sess, k, st, actual, tags):
        if st.i == 0 and actual.get("zsw2_enc", 0) & 1:
            actual["zsw2_enc"] &= ~1
            tags.add(self.tag)


# ------------------------------------------------------------------------ absolute value / positions

@injectable("ABSVAL-ACK-MISSING")
class AbsvalAckMissing(Cyclic):
    why = "the encoder clears G1_ZSW.13 (and XIST2) for 5 cycles although the PLC requests it"
    n = 5

    def change(self, w, k):
        w["g1_zsw"] &= ~0x2000
        w["g1_xist2"] = 0


@injectable("ABSVAL-ACK-STUCK")
class AbsvalAckStuck(Injection):
    why = "the PLC drops G1_STW.13 for 20 cycles; the encoder keeps G1_ZSW.13"

    def after_plc(self, sess, k, st, out, tags):
        if st.i == 0 and self.k <= k < self.k + 20:
            out["g1_stw"] &= ~0x2000

    def after_enc(self, sess, k, st, actual, tags):
        if st.i == 0 and self.k <= k < self.k + 20:
            actual["g1_zsw"] |= 0x2000
            actual["g1_xist2"] = actual["g1_xist1"]
            tags.add(self.tag)


@injectable("XIST2-NOT-ZERO")
class Xist2NotZero(Injection):
    why = "the PLC drops G1_STW.13 for 20 cycles; the encoder clears G1_ZSW.13 but keeps the position in XIST2"
    profile = "lika"  # #39 is a LIKA rule (behaviour.md §9.5)

    def after_plc(self, sess, k, st, out, tags):
        if st.i == 0 and self.k <= k < self.k + 20:
            out["g1_stw"] &= ~0x2000

    def after_enc(self, sess, k, st, actual, tags):
        if st.i == 0 and self.k <= k < self.k + 20:
            actual["g1_xist2"] = actual["g1_xist1"] or 1
            tags.add(self.tag)


@injectable("POSITION-OUT-OF-RANGE")
class PositionOutOfRange(Cyclic):
    why = "the encoder reports XIST1/XIST2 = total measuring range + 5 for one cycle"
    also = ("POSITION-DISCONTINUITY",)

    def change(self, w, k):
        w["g1_xist1"] = w["g1_xist2"] = sess_tmr(self) + 5


def sess_tmr(inj):
    return inj.tmr


@injectable("POSITION-DISCONTINUITY")
class PositionDiscontinuity(Injection):
    why = "the encoder's position jumps by a quarter of the range at standstill (no preset)"
    profile = "scancon"  # #42 applies to SCANCON/Hohner/PSM with scaling (behaviour.md §9.5)

    def setup(self, sess, sc, params):
        sc.shaft = STANDSTILL

    def before_cycle(self, sess, k, st, plc, enc, last_in):
        if st.i == 0 and k == self.k:
            enc.offset = (enc.offset + enc.p["tmr"] // 4) % enc.p["tmr"]

    def after_enc(self, sess, k, st, actual, tags):
        if st.i == 0 and k == self.k:
            tags.add(self.tag)


@injectable("NIST-SIGN")
class NistSign(Cyclic):
    why = "telegram 83: the encoder reports the speed with the wrong sign for 50 cycles while turning"
    telegram = 83
    n = 50

    def setup(self, sess, sc, params):
        sc.shaft = ((0.0, 60.0, 60.0),)

    def change(self, w, k):
        w["nist_b"] = -abs(w["nist_b"]) or -1
        if "nist_a" in w:
            w["nist_a"] = -abs(w["nist_a"]) or -1


# ------------------------------------------------------------------------ parking

class _ParkFault(Injection):
    scenario = "parking"


@injectable("PARK-ACK-MISSING")
class ParkAckMissing(_ParkFault):
    why = "the encoder never sets G1_ZSW.14 while parked"
    also = ("ABSVAL-ACK-MISSING",)   # G1_ZSW.13 is 0 while parked, which needs G1_ZSW.14 to excuse it
    def after_enc(self, sess, k, st, actual, tags):
        if st.i == 0 and actual["g1_zsw"] & 0x4000:
            actual["g1_zsw"] &= ~0x4000
            tags.add(self.tag)


@injectable("PARK-ACK-NOT-CLEARED")
class ParkAckNotCleared(_ParkFault):
    why = "the encoder keeps G1_ZSW.14 for 20 cycles after parking is released"

    def after_enc(self, sess, k, st, actual, tags):
        kr = sess.scenario.at(0.6)
        if st.i == 0 and kr + 1 <= k < kr + 21:
            actual["g1_zsw"] = (actual["g1_zsw"] | 0x4000) & ~0x2000
            actual["g1_xist1"] = actual["g1_xist2"] = 0
            tags.add(self.tag)


@injectable("PARK-OUTPUTS-NOT-CLEARED")
class ParkOutputsNotCleared(_ParkFault):
    why = "while parked the encoder keeps sending the position in XIST1"
    profile = "lika"  # #47 is a LIKA rule (behaviour.md §9.6)

    def after_enc(self, sess, k, st, actual, tags):
        if st.i == 0 and actual["g1_zsw"] & 0x4000:
            actual["g1_xist1"] = 12345
            tags.add(self.tag)


@injectable("PARK-ERROR-REPORTED")
class ParkErrorReported(_ParkFault):
    why = "while parked the encoder raises sensor error 0x1001"
    also = ("ZSW-ATX-AND-SERR", "PARK-OUTPUTS-NOT-CLEARED", "SERR-XIST2-NOT-RESTORED")

    def after_enc(self, sess, k, st, actual, tags):
        kp = sess.scenario.at(0.3)
        if st.i == 0 and kp + 20 <= k < kp + 40:
            actual["g1_zsw"] |= 0x8000
            actual["g1_xist2"] = 0x1001
            tags.add(self.tag)


@injectable("PARK-ERRORS-NOT-CLEARED")
class ParkErrorsNotCleared(_ParkFault):
    why = "a sensor error is active when the PLC parks; the encoder keeps reporting it while parked"
    profile = "lika"  # #49 is a LIKA rule (behaviour.md §9.6)
    also = ("PARK-OUTPUTS-NOT-CLEARED",)  # the error code in XIST2 is an output that parking must clear (#47)

    def before_cycle(self, sess, k, st, plc, enc, last_in):
        kp = sess.scenario.at(0.3)
        if st.i == 0 and k == kp - 20:
            enc.error_code, enc.error_cleared = 0x1001, False

    def after_enc(self, sess, k, st, actual, tags):
        kp = sess.scenario.at(0.3)
        if st.i == 0 and actual["g1_zsw"] & 0x4000:
            actual["g1_zsw"] |= 0x8000
            actual["g1_xist2"] = 0x1001
            if k < kp + 5:
                tags.add(self.tag)


@injectable("PARK-WHILE-RUNNING")
class ParkWhileRunning(_ParkFault):
    why = "the PLC parks the sensor while the shaft turns at 60 rpm"

    def setup(self, sess, sc, params):
        sc.shaft = ((0.0, 60.0, 60.0),)

    def after_plc(self, sess, k, st, out, tags):
        if st.i == 0 and k == sess.scenario.at(0.3):
            tags.add(self.tag)


# ------------------------------------------------------------------------ sensor error / acknowledgement

class _SerrFault(Injection):
    scenario = "sensor-error"


@injectable("ZSW-ATX-AND-SERR")
class ZswAtxAndSerr(_SerrFault):
    why = "the encoder keeps G1_ZSW.13 set together with G1_ZSW.15"

    def after_enc(self, sess, k, st, actual, tags):
        if st.i == 0 and actual["g1_zsw"] & 0x8000:
            actual["g1_zsw"] |= 0x2000
            tags.add(self.tag)


@injectable("SERR-CODE-INVALID")
class SerrCodeInvalid(_SerrFault):
    why = "the encoder signals a sensor error with G1_XIST2 = 0"

    def after_enc(self, sess, k, st, actual, tags):
        if st.i == 0 and actual["g1_zsw"] & 0x8000:
            actual["g1_xist2"] = 0
            tags.add(self.tag)


@injectable("ACKIP-MISSING")
class AckipMissing(_SerrFault):
    why = "the encoder never sets G1_ZSW.11 while the PLC acknowledges the error"

    def setup(self, sess, sc, params):
        sc.ack_cycles = 5

    def after_enc(self, sess, k, st, actual, tags):
        if st.i == 0 and actual["g1_zsw"] & 0x0800:
            actual["g1_zsw"] &= ~0x0800
        if st.i == 0 and sess.scenario.at(0.5) <= k < sess.scenario.at(0.5) + 5:
            tags.add(self.tag)


@injectable("ACKIP-SPURIOUS")
class AckipSpurious(Cyclic):
    why = "the encoder sets G1_ZSW.11 for 5 cycles without an acknowledgement request"
    n = 5
    also = ("ACKIP-STUCK",)   # the same bit pattern: ACKIP = 1 while SACK = 0 for more than L_max cycles

    def change(self, w, k):
        w["g1_zsw"] |= 0x0800


@injectable("ACKIP-STUCK")
class AckipStuck(_SerrFault):
    why = "the encoder keeps G1_ZSW.11 for 20 cycles after the PLC released G1_STW.15"

    def setup(self, sess, sc, params):
        self.fall = None

    def after_plc(self, sess, k, st, out, tags):
        if st.i == 0:
            if out["g1_stw"] & 0x8000:
                self.sack = True
            elif getattr(self, "sack", False) and self.fall is None:
                self.fall = k

    def after_enc(self, sess, k, st, actual, tags):
        if st.i == 0 and self.fall is not None and k < self.fall + 20:
            actual["g1_zsw"] |= 0x0800
            tags.add(self.tag)


@injectable("SERR-CLEARED-WITHOUT-ACK")
class SerrClearedWithoutAck(_SerrFault):
    why = "the encoder clears the sensor error by itself, before the PLC acknowledges"

    def before_cycle(self, sess, k, st, plc, enc, last_in):
        if st.i == 0 and k == sess.scenario.at(0.45):
            enc.error_code = 0
            sess.scenario.no_ack = True

    def after_enc(self, sess, k, st, actual, tags):
        if st.i == 0 and k == sess.scenario.at(0.45):
            tags.add(self.tag)


@injectable("SERR-XIST2-NOT-RESTORED")
class SerrXist2NotRestored(_SerrFault):
    why = "after the error is acknowledged the encoder does not bring the position back into XIST2 for 20 cycles"
    also = ("ABSVAL-ACK-MISSING",)   # G1_ZSW.13 stays 0 although requested
    def setup(self, sess, sc, params):
        self.fall = None

    def after_enc(self, sess, k, st, actual, tags):
        if st.i:
            return
        if getattr(self, "was", False) and not actual["g1_zsw"] & 0x8000 and self.fall is None:
            self.fall = k
        self.was = bool(actual["g1_zsw"] & 0x8000) or getattr(self, "was", False) and self.fall is None
        if self.fall is not None and k < self.fall + 20:
            actual["g1_zsw"] &= ~0x2000
            actual["g1_xist2"] = 0
            tags.add(self.tag)


@injectable("SACK-WITHOUT-ERROR")
class SackWithoutError(Cyclic):
    why = "the PLC pulses G1_STW.15 for 3 cycles with no sensor error"
    where = "plc"
    n = 3

    def change(self, w, k):
        w["g1_stw"] |= 0x8000


@injectable("SACK-HELD")
class SackHeld(_SerrFault):
    why = "the PLC holds G1_STW.15 for 60 cycles after the encoder shows the acknowledgement in progress"

    def setup(self, sess, sc, params):
        sc.ack_hold = 60

    def after_plc(self, sess, k, st, out, tags):
        ka = sess.scenario.at(0.5)
        if st.i == 0 and ka + 15 <= k < ka + 60 and out["g1_stw"] & 0x8000:
            tags.add(self.tag)


@injectable("FAULT-PRESENT-INCONSISTENT")
class FaultPresentInconsistent(_SerrFault):
    why = "PS/PSM: sensor error set but ZSW2_ENC bit 3 'fault present' stays 0"
    profile = "psm"

    def after_enc(self, sess, k, st, actual, tags):
        if st.i == 0 and actual["g1_zsw"] & 0x8000:
            actual["zsw2_enc"] &= ~0x0008
            tags.add(self.tag)


# ------------------------------------------------------------------------ reserved bits

class _Reserved(Cyclic):
    n = 10


@injectable("RESERVED-BIT-SET-STW2")
class ReservedStw2(_Reserved):
    why = "the PLC sets STW2_ENC bit 1 (reserved) for 10 cycles"
    where = "plc"

    def change(self, w, k):
        w["stw2_enc"] |= 0x0002


@injectable("RESERVED-BIT-SET-G1STW")
class ReservedG1stw(_Reserved):
    why = "the PLC sets G1_STW bit 9 (reserved) for 10 cycles"
    where = "plc"

    def change(self, w, k):
        w["g1_stw"] |= 0x0200


@injectable("RESERVED-BIT-SET-ZSW2")
class ReservedZsw2(_Reserved):
    why = "the encoder sets ZSW2_ENC bit 5 (reserved) for 10 cycles"

    def change(self, w, k):
        w["zsw2_enc"] |= 0x0020


@injectable("RESERVED-BIT-SET-G1ZSW")
class ReservedG1zsw(_Reserved):
    why = "the encoder sets G1_ZSW bit 10 (reserved) for 10 cycles"

    def change(self, w, k):
        w["g1_zsw"] |= 0x0400


# ------------------------------------------------------------------------ start-up, records, telegram

@injectable("TELEGRAM-LENGTH-MISMATCH")
class TelegramLengthMismatch(Injection):
    why = "the Connect configures 3 more input bytes than the telegram has (15, no telegram has that; P922 says 81)"
    side = "encoder"

    def setup(self, sess, sc, params):
        from .session import Station
        sess.stations = [Station(i, sess.cfg, sess.rng, extra_in=3) for i in range(sess.cfg.encoders)]
        sc.connect_tags = {self.tag}


@injectable("TELEGRAM-SELECTION-MISMATCH")
class TelegramSelectionMismatch(Injection):
    why = "a P922 read answers telegram 82 while 81 is configured"

    def setup(self, sess, sc, params):
        sc.param_override[922] = (lambda d: dict(d, telegram=d["telegram"] + 1), {self.tag})


@injectable("P965-VERSION-MISMATCH")
class P965VersionMismatch(Injection):
    why = "a read of P965 subindex 1 (profile version) answers 31 while 0xBF00 selects V4.1 (compat = 1)"

    def setup(self, sess, sc, params):
        sc.bmp_extra.append(self)

    def access(self, sess, st, ts, dev):
        from . import recdata
        ref = sess.next_ref()
        req = recdata.param_request(ref, 1, [(965, 1, 0, None, 0x1F)])
        sess.bmp(ts, st, req, recdata.param_response(ref, 1, [(0x1F, ["1f"])]), tags={self.tag})


@injectable("STARTUP-NO-PARAM-RECORD")
class StartupNoParamRecord(Injection):
    why = "the controller starts cyclic data exchange without writing 0xBF00"

    def setup(self, sess, sc, params):
        sc.skip_bf00 = True
        sc.first_cyclic_tags = {self.tag}


class _Bf00Fault(Injection):
    """A faulty 0xBF00 record; the conforming encoder reports parameterisation error 0x1002 in
    G1_XIST2 and a 0x9011 channel diagnosis (cyclic.md §9, 000_37bf2397999f1108.txt:2605-2639)."""

    reject = True
    bad = {}

    def setup(self, sess, sc, params):
        vals = dict(params)
        vals.update(self.bad)
        from . import recdata
        sc.bf00_bytes = recdata.bf00(sess.cfg.profile, **vals)
        sc.bf00_tags = {self.tag}
        sc.reject_bf00 = self.reject


@injectable("BF00-LENGTH")
class Bf00Length(_Bf00Fault):
    why = "the controller writes a 30-byte 0xBF00 (31 expected)"
    bad = {"length": 30}


@injectable("BF00-RESERVED-NONZERO")
class Bf00ReservedNonzero(_Bf00Fault):
    why = "the controller writes 0xBF00 with reserved byte 25 = 0x55"
    bad = {"reserved_bytes": bytes(6) + b"\x55"}


@injectable("BF00-VALUE-OUT-OF-RANGE")
class Bf00ValueOutOfRange(_Bf00Fault):
    why = "the controller writes 0xBF00 with velocity unit 9 (0..3 allowed)"
    bad = {"velocity_unit": 9}


@injectable("BF00-ERROR-NOT-REPORTED")
class Bf00ErrorNotReported(_Bf00Fault):
    why = "an invalid 0xBF00 (velocity unit 9) is followed by normal data exchange without an error"
    bad = {"velocity_unit": 9}
    reject = False
    also = ("BF00-VALUE-OUT-OF-RANGE",)


@injectable("BF00-VALID-REJECTED")
class Bf00ValidRejected(_Bf00Fault):
    why = "a valid 0xBF00 is answered with parameterisation error 0x1002 and a 0x9011 diagnosis"
    bad = {}


# ------------------------------------------------------------------------ DCP

@injectable("DCP-NAME-INVALID")
class DcpNameInvalid(Injection):
    why = "the controller sends DCP Set NameOfStation 'Encoder_1!' (invalid characters); the device refuses"

    def setup(self, sess, sc, params):
        sc.dcp_extra.append(("name", 0, b"Encoder_1!", {self.tag}))


@injectable("DCP-NAME-DUPLICATE")
class DcpNameDuplicate(Injection):
    why = "the controller assigns encoder-1's name to encoder-2 as well (needs --encoders 2)"
    encoders = 2

    def setup(self, sess, sc, params):
        if len(sess.stations) < 2:
            raise ValueError("DCP-NAME-DUPLICATE needs --encoders 2 or more")
        sc.dcp_extra.append(("name", 1, sess.stations[0].name.encode(), {self.tag}))


@injectable("IP-ASSIGN-OCCUPIED")
class IpAssignOccupied(Injection):
    why = "the controller assigns encoder-1's IP address to encoder-2 (needs --encoders 2)"
    encoders = 2

    def setup(self, sess, sc, params):
        if len(sess.stations) < 2:
            raise ValueError("IP-ASSIGN-OCCUPIED needs --encoders 2 or more")
        sc.dcp_extra.append(("ip", 1, sess.stations[0].ip, {self.tag}))


# ------------------------------------------------------------------------ base mode parameter access

class _Bmp(Injection):
    """One extra parameter access at cycle k (built by ``access(sess, st, ts)``)."""

    def setup(self, sess, sc, params):
        sc.bmp_extra.append(self)

    def access(self, sess, st, ts, dev):
        raise NotImplementedError


def _refs(sess):
    return sess.next_ref()


@injectable("BMP-PIPELINED")
class BmpPipelined(_Bmp):
    why = "the controller writes a second parameter request before reading the first response"
    also = ("BMP-NOT-MIRRORED", "BMP-DATATYPE")   # responses then pair with the wrong request
    def access(self, sess, st, ts, dev):
        from . import recdata
        r1, r2 = sess.next_ref(), sess.next_ref()
        q1 = recdata.param_request(r1, 1, [(922, 0, 0, None, 0x06)])
        q2 = recdata.param_request(r2, 1, [(965, 0, 0, None, 0x06)])
        f1, v1 = recdata.read_block(922, dev, sess.cfg.profile)
        f2, v2 = recdata.read_block(965, dev, sess.cfg.profile)
        sess.write_record(ts, st, 0xB02E, q1, what="bmp.write")
        sess.write_record(ts + 1_000_000, st, 0xB02E, q2, what="bmp.write", tags={self.tag})
        sess.read_record(ts + 2_000_000, st, 0xB02E, recdata.param_response(r1, 1, [(f1, v1)]), what="bmp.read")
        sess.read_record(ts + 3_000_000, st, 0xB02E, recdata.param_response(r2, 1, [(f2, v2)]), what="bmp.read")


@injectable("BMP-REQREF-ZERO")
class BmpReqrefZero(_Bmp):
    why = "the controller sends a parameter request with request reference 0"

    def access(self, sess, st, ts, dev):
        sess.read_param(ts, st, 922, dev, tags={self.tag}, ref=0)


@injectable("BMP-REQREF-NOT-CHANGED")
class BmpReqrefNotChanged(_Bmp):
    why = "the controller reuses the previous request reference"

    def access(self, sess, st, ts, dev):
        sess.read_param(ts, st, 922, dev)
        sess.read_param(ts + 5_000_000, st, 965, dev, tags={self.tag}, ref=sess.bmp_ref)


@injectable("BMP-BAD-REQUEST")
class BmpBadRequest(_Bmp):
    why = "the controller requests attribute 0x50 (reserved); the device answers error 0x16"

    def access(self, sess, st, ts, dev):
        from . import recdata
        from ..records import build as B
        ref = sess.next_ref()
        req = B.build_param_request(ref, 1, [{"pnu": 922, "attribute": 0x50}], axis=1)
        sess.bmp(ts, st, req, recdata.param_response(ref, 0x81, [(0x44, [0x16])]), tags={self.tag})


@injectable("BMP-ILLEGAL-REQID-RESPONSE")
class BmpIllegalReqidResponse(_Bmp):
    why = "request ID 0x05 (illegal); the device answers 0x81 / error 0x16 instead of 0x80 / 0x21"
    also = ("BMP-BAD-REQUEST", "BMP-RESPID-MISMATCH")

    def access(self, sess, st, ts, dev):
        from . import recdata
        ref = sess.next_ref()
        req = recdata.param_request(ref, 5, [(922, 0, 0, None, 0x06)])
        sess.bmp(ts, st, req, recdata.param_response(ref, 0x81, [(0x44, [0x16])]), tags={self.tag})


@injectable("BMP-NOT-MIRRORED")
class BmpNotMirrored(_Bmp):
    why = "the device answers with a different request reference"

    def access(self, sess, st, ts, dev):
        from . import recdata
        ref = sess.next_ref()
        f, v = recdata.read_block(922, dev, sess.cfg.profile)
        sess.read_param(ts, st, 922, dev, tags={self.tag}, ref=ref,
                        response=recdata.param_response((ref + 1) & 0xFF or 1, 1, [(f, v)]))


@injectable("BMP-RESPID-MISMATCH")
class BmpRespidMismatch(_Bmp):
    why = "the device answers a read request with response ID 0x02 (positive change, no values)"

    def access(self, sess, st, ts, dev):
        ref = sess.next_ref()
        sess.read_param(ts, st, 922, dev, tags={self.tag}, ref=ref, response=bytes([ref, 2, 1, 1]))


@injectable("BMP-NEG-FORMAT")
class BmpNegFormat(_Bmp):
    why = "a negative response carries error number 0x0116 (the high byte is reserved, max 0x00FF)"

    def access(self, sess, st, ts, dev):
        from . import recdata
        ref = sess.next_ref()
        req = recdata.param_request(ref, 1, [(922, 0, 0, None, 0x06)])
        sess.bmp(ts, st, req, recdata.param_response(ref, 0x81, [(0x44, [0x0116])]), tags={self.tag})


class BmpOrder(_Bmp):  # not injectable: see NOT_INJECTABLE["BMP-ORDER"]
    why = "a two-parameter read (P922, P979) is answered in reverse order"
    also = ("BMP-DATATYPE", "TELEGRAM-SELECTION-MISMATCH")   # blocks are paired by position

    def access(self, sess, st, ts, dev):
        from . import recdata
        ref = sess.next_ref()
        f1, v1 = recdata.read_block(922, dev, sess.cfg.profile)
        f2, v2 = recdata.read_block(979, dev, sess.cfg.profile)
        req = recdata.param_request(ref, 1, [(922, 0, 0, None, f1), (979, 0, len(v2), None, f2)])
        sess.bmp(ts, st, req, recdata.param_response(ref, 1, [(f2, v2), (f1, v1)]), tags={self.tag})


@injectable("BMP-WRITE-RO-ACCEPTED")
class BmpWriteRoAccepted(_Bmp):
    why = "the device accepts a change of read-only P922"
    profile = "lika"   # the read-only list is Lika's (000_37bf2397999f1108.txt:1953-2164)
    def access(self, sess, st, ts, dev):
        from . import recdata
        ref = sess.next_ref()
        req = recdata.param_request(ref, 2, [(922, 0, 0, [dev["telegram"]], 0x06)])
        sess.bmp(ts, st, req, recdata.param_response(ref, 2, [(0x40, [])]), tags={self.tag})


@injectable("BMP-PRESET-LIMIT-ACCEPTED")
class BmpPresetLimitAccepted(_Bmp):
    why = "the device accepts P65000 = total measuring range + 1000"

    def access(self, sess, st, ts, dev):
        from . import recdata
        ref = sess.next_ref()
        req = recdata.param_request(ref, 2, [(65000, 0, 0, [dev["tmr"] + 1000], 0x43)])
        sess.bmp(ts, st, req, recdata.param_response(ref, 2, [(0x40, [])]), tags={self.tag})


@injectable("BMP-UNKNOWN-PNU")
class BmpUnknownPnu(_Bmp):
    why = "the device answers a read of P12345 (not in its P980 list) with a value"

    def access(self, sess, st, ts, dev):
        from . import recdata
        sess.read_param(ts - 10_000_000, st, 980, dev)
        ref = sess.next_ref()
        req = recdata.param_request(ref, 1, [(12345, 0, 0, None, 0x06)])
        sess.bmp(ts, st, req, recdata.param_response(ref, 1, [(0x06, [7])]), tags={self.tag})


@injectable("BMP-DATATYPE")
class BmpDatatype(_Bmp):
    why = "the device answers a P922 read (Unsigned16) with format Unsigned32"

    def access(self, sess, st, ts, dev):
        from . import recdata
        ref = sess.next_ref()
        req = recdata.param_request(ref, 1, [(922, 0, 0, None, 0x06)])
        sess.bmp(ts, st, req, recdata.param_response(ref, 1, [(0x07, [dev["telegram"]])]), tags={self.tag})


@injectable("P971-NOT-CONFIRMED")
class P971NotConfirmed(_Bmp):
    why = "after P971 := 1 every later read of P971 still returns 1"
    profile = "lika"   # P971 store semantics are Lika's (000_37bf2397999f1108.txt:1975-1982)
    def access(self, sess, st, ts, dev):
        from . import recdata
        ref = sess.next_ref()
        req = recdata.param_request(ref, 2, [(971, 0, 0, [1], 0x06)])
        sess.bmp(ts, st, req, recdata.param_response(ref, 2, [(0x40, [])]))
        d = dict(dev, p971=1)
        sess.read_param(ts + 20_000_000, st, 971, d, tags={self.tag})
        sess.read_param(ts + 60_000_000, st, 971, d, tags={self.tag})


@injectable("BMP-CLASS4-WRITE-ACCEPTED")
class BmpClass4WriteAccepted(_Bmp):
    why = "class 4 disabled in 0xBF00, the device accepts a P65000 change"
    also = ("PRESET-CLASS4-DISABLED",)

    def setup(self, sess, sc, params):
        super().setup(sess, sc, params)
        params["class4"] = 0

    def access(self, sess, st, ts, dev):
        from . import recdata
        ref = sess.next_ref()
        req = recdata.param_request(ref, 2, [(65000, 0, 0, [1000], 0x43)])
        sess.bmp(ts, st, req, recdata.param_response(ref, 2, [(0x40, [])]), tags={self.tag})


@injectable("BMP-PROFILE-PARAM-UNREADABLE")
class BmpProfileParamUnreadable(_Bmp):
    why = "a read of P979 after run-up is refused with error 0x11"

    def access(self, sess, st, ts, dev):
        from . import recdata
        ref = sess.next_ref()
        req = recdata.param_request(ref, 1, [(979, 0, 6, None, 0x07)])
        sess.bmp(ts, st, req, recdata.param_response(ref, 0x81, [(0x44, [0x11])]), tags={self.tag})


# ------------------------------------------------------------------------ not injectable (why)
NOT_INJECTABLE.update({
    "SOL-MASTER-WINDOW": "needs a master application cycle k > 1 (TMAPC > TDP); the simulator runs k = 1",
    "SOL-FAULT-MISSING": "needs the encoder's sign-of-life failure counter (isochronous mode); produced only as a "
                         "side effect of SOL-MASTER-STALL",
    "SOL-FAULT-SPURIOUS": "needs an isochronous AR (the failure counter runs only with sign-of-life monitoring)",
    "SOL-FAULT-CLEARED-WITHOUT-ACK": "needs an isochronous AR with a 0x0F02 fault",
    "SYNC-FAULT-DLS-NONZERO": "needs an isochronous (IRT) AR; the simulator writes RT_CLASS_1 only",
    "PRESET-XIST1-AFFECTED-WHEN-DISABLED": "the same wire fault also breaks XIST2-INCONSISTENT / PRESET-VALUE-WRONG "
                                           "in ways that depend on the vendor coding (behaviour.md §7 D14); "
                                           "not separable",
    "PRESET-XIST1-NOT-AFFECTED-WHEN-ENABLED": "same as PRESET-XIST1-AFFECTED-WHEN-DISABLED",
    "PRESET-WITHOUT-NEW-PARAMS": "needs two connections with different 0xBF00 in one capture",
    "BMP-MULTI-NOT-ABORTED": "needs a multi-parameter change with an aborting error; not modelled yet",
    "XIST2-INCONSISTENT": "needs a shift factor (P979.3) != 0 variant; the simulator is right-aligned",
    "BMP-ORDER": "not decidable from a capture: a response block carries no PNU, so answers in another order "
                 "look like wrong values (docs/rules.md); the reversed answer still exists as BmpOrder for tests",
})
