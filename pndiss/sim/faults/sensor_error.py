"""Faults of the sensor-error scenario: G1_ZSW.15 with its code in G1_XIST2, the acknowledgement
(G1_STW.15 / G1_ZSW.11) and the position's return."""
from __future__ import annotations

from ..scenarios import injectable
from .base import AckKept, ScenarioFault, WhileZsw, register


class _SerrFault(ScenarioFault):
    scenario = "sensor-error"


# while the sensor error is shown (G1_ZSW.15) the encoder changes one word
register(WhileZsw, "ZSW-ATX-AND-SERR", scenario="sensor-error", when=0x8000, word="g1_zsw", set_=0x2000,
         why="the encoder keeps G1_ZSW.13 set together with G1_ZSW.15")
register(WhileZsw, "SERR-CODE-INVALID", scenario="sensor-error", when=0x8000, word="g1_xist2", keep=0,
         why="the encoder signals a sensor error with G1_XIST2 = 0")
register(WhileZsw, "FAULT-PRESENT-INCONSISTENT", scenario="sensor-error", when=0x8000, word="zsw2_enc", keep=~0x0008,
         why="PS/PSM: sensor error set but ZSW2_ENC bit 3 'fault present' stays 0", profile="psm")


@injectable("ACKIP-MISSING")
class AckipMissing(_SerrFault):
    why = "the encoder never sets G1_ZSW.11 while the PLC acknowledges the error"
    knobs = {"ack_cycles": 5}

    def after_enc(self, sess, k, st, actual, tags):
        if st.i == 0 and actual["g1_zsw"] & 0x0800:
            actual["g1_zsw"] &= ~0x0800
        if st.i == 0 and sess.scenario.at(0.5) <= k < sess.scenario.at(0.5) + 5:
            tags.add(self.tag)


register(AckKept, "ACKIP-STUCK", scenario="sensor-error", request=0x8000, ack=0x0800,
         why="the encoder keeps G1_ZSW.11 for 20 cycles after the PLC released G1_STW.15")


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


@injectable("SACK-HELD")
class SackHeld(_SerrFault):
    why = "the PLC holds G1_STW.15 for 60 cycles after the encoder shows the acknowledgement in progress"
    knobs = {"ack_hold": 60}

    def after_plc(self, sess, k, st, out, tags):
        ka = sess.scenario.at(0.5)
        if st.i == 0 and ka + 15 <= k < ka + 60 and out["g1_stw"] & 0x8000:
            tags.add(self.tag)
