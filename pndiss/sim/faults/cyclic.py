"""Faults in the cyclic words that need no scenario: sign-of-life, control by PLC, absolute value
and positions, the speed's sign, reserved bits and acknowledgements nobody asked for."""
from __future__ import annotations

from ..model import sol_next
from ..scenarios import STANDSTILL, Injection, injectable
from .base import SOL_SETTINGS, Bits, Cyclic, Knob, register

# ------------------------------------------------------------------------ one word for n cycles
# (rule, side: "plc" the controller's setpoint / "enc" the encoder's actual values, word, bits kept,
#  bits set, cycles, how, further attributes)
for _rule, _where, _word, _keep, _set, _n, _why, _more in (
    ("SOL-MASTER-ZERO", "plc", "stw2_enc", 0x0FFF, 0, 1,
     "the PLC sends controller sign-of-life 0 for one cycle",
     # the value after the 0 is not next(0) [rule 2 may also see it]
     dict(settings=SOL_SETTINGS, also=("SOL-MASTER-SKIP",))),
    ("SOL-DEVICE-ZERO", "enc", "zsw2_enc", 0x0FFF, 0, 1,
     "the encoder sends sign-of-life 0 for one cycle (no 0x0F04 error)",
     dict(settings=SOL_SETTINGS, also=("SOL-DEVICE-ZERO-RT", "SOL-DEVICE-SKIP"))),
    ("SOL-DEVICE-ZERO-RT", "enc", "zsw2_enc", 0x0FFF, 0, 5,
     "the encoder sends sign-of-life 0 for 5 cycles in RT operation", {}),
    ("CTRLREQ-MISMATCH", "enc", "zsw2_enc", ~0x0600 & 0xFFFF, 0, 5,
     "the encoder clears 'control requested' for 5 cycles while the PLC keeps control", {}),
    ("PRESET-ACK-SPURIOUS", "enc", "g1_zsw", -1, 0x1000, 5,
     "the encoder sets G1_ZSW.12 for 5 cycles without a request", {}),
    ("ACKIP-SPURIOUS", "enc", "g1_zsw", -1, 0x0800, 5,
     "the encoder sets G1_ZSW.11 for 5 cycles without an acknowledgement request",
     # the same bit pattern: ACKIP = 1 while SACK = 0 for more than L_max cycles
     dict(also=("ACKIP-STUCK",))),
    ("SACK-WITHOUT-ERROR", "plc", "g1_stw", -1, 0x8000, 3,
     "the PLC pulses G1_STW.15 for 3 cycles with no sensor error", {}),
    ("RESERVED-BIT-SET-STW2", "plc", "stw2_enc", -1, 0x0002, 10,
     "the PLC sets STW2_ENC bit 1 (reserved) for 10 cycles", {}),
    ("RESERVED-BIT-SET-G1STW", "plc", "g1_stw", -1, 0x0200, 10,
     "the PLC sets G1_STW bit 9 (reserved) for 10 cycles", {}),
    ("RESERVED-BIT-SET-ZSW2", "enc", "zsw2_enc", -1, 0x0020, 10,
     "the encoder sets ZSW2_ENC bit 5 (reserved) for 10 cycles", {}),
    ("RESERVED-BIT-SET-G1ZSW", "enc", "g1_zsw", -1, 0x0400, 10,
     "the encoder sets G1_ZSW bit 10 (reserved) for 10 cycles", {}),
):
    register(Bits, _rule, where=_where, word=_word, keep=_keep, set_=_set, n=_n, why=_why, **_more)


# ------------------------------------------------------------------------ sign-of-life

class _SolSkip(Knob):
    """One side's sign-of-life counter jumps ahead by one at cycle k."""

    settings = SOL_SETTINGS

    def turn_on(self, sess, plc, enc):
        (plc if self.where == "plc" else enc).faults["sol_skip_at"] = self.k

    def flagged(self, k, words):
        return k == self.k


register(_SolSkip, "SOL-MASTER-SKIP", where="plc",
         why="the PLC skips one controller sign-of-life value (its counter jumps ahead by one)")
register(_SolSkip, "SOL-DEVICE-SKIP", why="the encoder skips one sign-of-life value (its counter jumps ahead by one)")


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


# ------------------------------------------------------------------------ absolute value / positions

@injectable("ABSVAL-ACK-MISSING")
class AbsvalAckMissing(Cyclic):
    why = "the encoder clears G1_ZSW.13 (and XIST2) for 5 cycles although the PLC requests it"
    n = 5

    def change(self, w, k):
        w["g1_zsw"] &= ~0x2000
        w["g1_xist2"] = 0


class _AbsvalDropped(Injection):
    """The PLC drops G1_STW.13 for 20 cycles from k; ``after_enc`` says what the encoder does."""

    def after_plc(self, sess, k, st, out, tags):
        if st.i == 0 and self.k <= k < self.k + 20:
            out["g1_stw"] &= ~0x2000


@injectable("ABSVAL-ACK-STUCK")
class AbsvalAckStuck(_AbsvalDropped):
    why = "the PLC drops G1_STW.13 for 20 cycles; the encoder keeps G1_ZSW.13"

    def after_enc(self, sess, k, st, actual, tags):
        if st.i == 0 and self.k <= k < self.k + 20:
            actual["g1_zsw"] |= 0x2000
            actual["g1_xist2"] = actual["g1_xist1"]
            tags.add(self.tag)


@injectable("XIST2-NOT-ZERO")
class Xist2NotZero(_AbsvalDropped):
    why = "the PLC drops G1_STW.13 for 20 cycles; the encoder clears G1_ZSW.13 but keeps the position in XIST2"
    profile = "lika"  # #39 is a LIKA rule (behaviour.md §9.5)

    def after_enc(self, sess, k, st, actual, tags):
        if st.i == 0 and self.k <= k < self.k + 20:
            actual["g1_xist2"] = actual["g1_xist1"] or 1
            tags.add(self.tag)


@injectable("POSITION-OUT-OF-RANGE")
class PositionOutOfRange(Cyclic):
    why = "the encoder reports XIST1/XIST2 = total measuring range + 5 for one cycle"
    also = ("POSITION-DISCONTINUITY",)

    def change(self, w, k):
        w["g1_xist1"] = w["g1_xist2"] = self.tmr + 5


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
