"""Faults of the parking scenario: G1_STW.14 / G1_ZSW.14 and what the encoder sends while parked."""
from __future__ import annotations

from ..scenarios import injectable
from .base import ScenarioFault, WhileZsw, register


class _ParkFault(ScenarioFault):
    scenario = "parking"


# while parked (G1_ZSW.14) the encoder changes one word
register(WhileZsw, "PARK-ACK-MISSING", scenario="parking", when=0x4000, word="g1_zsw", keep=~0x4000,
         why="the encoder never sets G1_ZSW.14 while parked",
         also=("ABSVAL-ACK-MISSING",))   # G1_ZSW.13 is 0 while parked, which needs G1_ZSW.14 to excuse it
register(WhileZsw, "PARK-OUTPUTS-NOT-CLEARED", scenario="parking", when=0x4000, word="g1_xist1", keep=0, set_=12345,
         why="while parked the encoder keeps sending the position in XIST1",
         profile="lika")  # #47 is a LIKA rule (behaviour.md §9.6)


@injectable("PARK-ACK-NOT-CLEARED")
class ParkAckNotCleared(_ParkFault):
    why = "the encoder keeps G1_ZSW.14 for 20 cycles after parking is released"

    def after_enc(self, sess, k, st, actual, tags):
        kr = sess.scenario.at(0.6)
        if st.i == 0 and kr + 1 <= k < kr + 21:
            actual["g1_zsw"] = (actual["g1_zsw"] | 0x4000) & ~0x2000
            actual["g1_xist1"] = actual["g1_xist2"] = 0
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
    knobs = {"shaft": ((0.0, 60.0, 60.0),)}

    def after_plc(self, sess, k, st, out, tags):
        if st.i == 0 and k == sess.scenario.at(0.3):
            tags.add(self.tag)
