"""Faults of the preset scenario: the G1_STW.12 / G1_ZSW.12 handshake (telegrams 81-84), the value
applied, and the cyclic preset of telegrams 860 and 89."""
from __future__ import annotations

from ..scenarios import injectable
from .base import AckKept, ScenarioFault, WhileZsw, alter, register


def sc_k(sess):
    return sess.scenario.k_req


class _Preset(ScenarioFault):
    """A preset fault. ``enc_faults`` go into the first encoder's model every cycle; ``plc_at``
    {cycles after the request: (PLC attribute, value)} changes the PLC's model; with ``tag_at``
    the controller's frame that many cycles after the request is tagged."""

    scenario = "preset"
    enc_faults: dict = {}
    plc_at: dict = {}
    tag_at = None

    def before_cycle(self, sess, k, st, plc, enc, last_in):
        if st.i == 0:
            enc.faults.update(self.enc_faults)
            change = self.plc_at.get(k - sc_k(sess)) if self.plc_at else None
            if change:
                setattr(plc, *change)

    def after_plc(self, sess, k, st, out, tags):
        if self.tag_at is not None and st.i == 0 and k == sc_k(sess) + self.tag_at:
            tags.add(self.tag)


class _AfterAck(_Preset):
    """From the first acknowledgement (G1_ZSW.12 at cycle ``ack``), cycles ack+lo .. ack+hi-1 are
    tagged, with ``words`` {word: (bits kept, bits set)} changed."""

    lo = hi = 0
    words: dict = {}
    ack = None

    def after_enc(self, sess, k, st, actual, tags):
        if st.i:
            return
        if actual["g1_zsw"] & 0x1000 and self.ack is None:
            self.ack = k
        if self.ack is not None and self.ack + self.lo <= k < self.ack + self.hi:
            for word, (keep, set_) in self.words.items():
                alter(actual, word, keep, set_)
            tags.add(self.tag)


# ------------------------------------------------------------------------ preset (81-84)

@injectable("PRESET-ACK-MISSING")
class PresetAckMissing(_Preset):
    why = "the encoder never acknowledges the preset request (G1_ZSW.12 stays 0)"
    knobs = {"hold_request": True}
    enc_faults = {"preset_ack_missing": True}

    def after_plc(self, sess, k, st, out, tags):
        if st.i == 0 and out.get("g1_stw", 0) & 0x1000:
            tags.add(self.tag)


register(_AfterAck, "PRESET-ACK-DROPPED", knobs={"hold_after_ack": 8}, lo=3, hi=8, words={"g1_zsw": (~0x1000, 0)},
         why="the encoder drops G1_ZSW.12 while the PLC still holds the request")
register(_AfterAck, "XIST-DURING-STORE", lo=1, hi=16, words={s: (0, 0) for s in ("g1_xist1", "g1_xist2", "g1_xist3")},
         why="after the preset the encoder sends position 0 for 15 ms (storing the offset; 5-10 ms allowed)",
         also=("POSITION-DISCONTINUITY",))
register(AckKept, "PRESET-ACK-NOT-CLEARED", scenario="preset", request=0x1000, ack=0x1000,
         why="the encoder keeps G1_ZSW.12 for 20 cycles after the request falls")

# the PLC changes its request while the (slow) acknowledgement is awaited
register(_Preset, "PRESET-REQ-EARLY-RELEASE", enc_faults={"preset_delay": 6}, tag_at=2,
         plc_at={2: ("preset_req", False)},
         why="the PLC drops G1_STW.12 one cycle after raising it, before the (slow) acknowledgement")
register(_Preset, "PRESET-MODE-CHANGED", enc_faults={"preset_delay": 5}, tag_at=2,
         plc_at={2: ("preset_mode", 1), 3: ("preset_mode", 0)},
         why="the PLC toggles the home position mode bit while the preset request waits for its acknowledgement")
register(_Preset, "PRESET-NOT-STANDSTILL", knobs={"shaft": ((0.0, 0.0, 30.0), (0.1, 30.0, 30.0))}, tag_at=0,
         why="the PLC requests the preset while the shaft turns at 30 rpm", also=("POSITION-DISCONTINUITY",))


@injectable("PRESET-REQ-STUCK")
class PresetReqStuck(_Preset):
    why = "the PLC holds G1_STW.12 for 40 cycles after the acknowledgement"
    knobs = {"hold_after_ack": 40}

    def after_plc(self, sess, k, st, out, tags):
        if st.i == 0 and out["g1_stw"] & 0x1000 and k > sc_k(sess) + 12:
            tags.add(self.tag)


@injectable("PRESET-VALUE-WRONG")
class PresetValueWrong(_Preset, WhileZsw):
    why = "the encoder applies the preset 5 counts off the P65000 value"
    enc_faults = {"preset_error": 5}
    when = 0x1000


@injectable("PRESET-CLASS4-DISABLED")
class PresetClass4Disabled(_Preset):
    why = "class 4 disabled in 0xBF00, the PLC requests a preset anyway (the encoder ignores it)"
    knobs = {"skip_p65000": True}
    tag_at = 0

    def setup(self, sess, sc, params):
        super().setup(sess, sc, params)
        params["class4"] = 0


@injectable("PRESET-EXECUTED-WHEN-NOT-ALLOWED")
class PresetExecutedWhenNotAllowed(PresetClass4Disabled, WhileZsw):
    why = "class 4 disabled, the encoder executes and acknowledges the preset"
    also = ("PRESET-CLASS4-DISABLED",)
    enc_faults = {"ignore_class4": True}
    when = 0x1000

    def before_cycle(self, sess, k, st, plc, enc, last_in):
        super().before_cycle(sess, k, st, plc, enc, last_in)
        if st.i == 0:
            enc.preset_value = 1000


@injectable("PRESET-REEXECUTED")
class PresetReexecuted(_AfterAck):
    why = "relative preset; the encoder applies the offset again while the request is still held"
    knobs = {"hold_after_ack": 8, "mode": 1}
    lo, hi = 4, 5

    def before_cycle(self, sess, k, st, plc, enc, last_in):
        if st.i == 0 and self.ack is not None and k == self.ack + 4:
            enc.offset = (enc.offset + enc.preset_value) % enc.p["tmr"]


# ------------------------------------------------------------------------ cyclic preset telegrams

class _CyclicPreset(_Preset):
    """Telegrams with a cyclic preset (860, 89): no P65000 write before the request."""

    telegram = 860
    knobs = {"skip_p65000": True}


@injectable("PRESET860-VALUE-OUT-OF-RANGE")
class Preset860OutOfRange(_CyclicPreset):
    why = "telegram 860: the PLC presets a value >= the total measuring range (the encoder clamps to R-1)"
    tag_at = 0

    def setup(self, sess, sc, params):
        super().setup(sess, sc, params)
        sc.value = params["tmr"] + 100

    def before_cycle(self, sess, k, st, plc, enc, last_in):
        if st.i == 0 and k == sc_k(sess):
            enc.preset_value = enc.p["tmr"] - 1


@injectable("PRESET860-WRONG")
class Preset860Wrong(_CyclicPreset):
    why = "telegram 860: the encoder applies the preset 7 counts off"
    enc_faults = {"cyclic_preset_error": 7}

    def after_enc(self, sess, k, st, actual, tags):
        if st.i == 0 and sc_k(sess) <= k < sc_k(sess) + 3:
            tags.add(self.tag)


@injectable("PRESET860-TRIGGER-HELD")
class Preset860TriggerHeld(_CyclicPreset):
    why = "telegram 860: the PLC holds the trigger bit 31 for 50 cycles"
    knobs = {"skip_p65000": True, "trigger_cycles": 50}

    def after_plc(self, sess, k, st, out, tags):
        if st.i == 0 and sc_k(sess) + 13 <= k < sc_k(sess) + 50:
            tags.add(self.tag)


@injectable("PRESET89-ACK-MISSING")
class Preset89AckMissing(_CyclicPreset):
    why = "telegram 89: the encoder never sets XIST_PRESET_ACK (ZSW2_ENC bit 0)"
    telegram = 89
    profile = "psm"

    def after_enc(self, sess, k, st, actual, tags):
        if st.i == 0 and actual.get("zsw2_enc", 0) & 1:
            actual["zsw2_enc"] &= ~1
            tags.add(self.tag)
