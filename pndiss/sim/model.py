"""Device model glue: the PLC's output words and the reference encoder's input words, cycle by cycle.

Words are packed with ``pndiss.telegrams`` (the one telegram table); signal names are its
snake_case names. Behaviour follows spec/behaviour.md §2-§4 / cyclic.md §5-§7:
control by PLC, preset handshake (G1_STW.12 / G1_ZSW.12), parking (G1_STW.14), sensor error and
acknowledgement (G1_ZSW.15 / G1_STW.15 / G1_ZSW.11), sign-of-life next(v) = v mod 15 + 1.
"""
from __future__ import annotations

import math

from .. import telegrams as T

# Which telegrams each profile offers (cyclic.md §2 catalogue): Lika 81-84 only, 860 at
# SCANCON/Hohner/PSM, the PS/PSM-only family 86-89/100/101.
PROFILE_TELEGRAMS = {
    "lika": (81, 82, 83, 84),
    "scancon": (81, 82, 83, 84, 860),
    "hohner": (81, 82, 83, 84, 860),
    "psm": (81, 82, 83, 84, 86, 87, 88, 89, 100, 101, 860),
    "generic": (81, 82, 83, 84, 860),
}


def io_layout(telegram: int):
    """(setpoint, actual) compiled layouts from the one telegram table (pndiss.telegrams)."""
    return T.layout(telegram, "setpoint"), T.layout(telegram, "actual")


def sol_next(v: int) -> int:
    """Sign-of-life successor, 1..15, skipping 0 (cyclic.md §6)."""
    return v % 15 + 1


# --------------------------------------------------------------------------- shaft motion
class Shaft:
    """Shaft angle in revolutions as a function of time: standstill, constant speed and linear ramps.

    segments: [(t_start_s, rpm_start, rpm_end)], each lasting until the next start; the last one
    holds its end speed. The angle is integrated exactly per segment (no drift with cycle count).
    """

    def __init__(self, segments=((0.0, 0.0, 0.0),), rev0: float = 0.0):
        self.segs = []
        rev, prev = rev0, None
        for i, (t0, r0, r1) in enumerate(segments):
            t1 = segments[i + 1][0] if i + 1 < len(segments) else None
            self.segs.append((t0, t1, r0, r1, rev))
            if t1 is not None:
                dt = t1 - t0
                rev += (r0 + r1) / 2 * dt / 60.0
            prev = r1
        self._last = prev

    def at(self, t: float) -> tuple[float, float]:
        """(revolutions, rpm) at time t seconds."""
        for t0, t1, r0, r1, rev in reversed(self.segs):
            if t >= t0:
                dt = t - t0
                if t1 is None:
                    return rev + r1 * dt / 60.0, r1 if dt > 0 else r0
                a = (r1 - r0) / (t1 - t0)
                rpm = r0 + a * dt
                return rev + (r0 * dt + a * dt * dt / 2) / 60.0, rpm
        return self.segs[0][4], 0.0


# --------------------------------------------------------------------------- encoder
class Encoder:
    """The reference encoder's cyclic behaviour (device side)."""

    def __init__(self, profile: str, telegram: int, *, params: dict, shaft: Shaft, cycle_s: float):
        self.profile, self.telegram = profile, telegram
        self.out_fields, self.in_fields = io_layout(telegram)
        self.p = dict(params)
        self.shaft, self.cycle_s = shaft, cycle_s
        # Control requested: ZSW2_ENC bit 9 (Lika/SCANCON/Hohner), bit 10 on PS/PSM (cyclic.md §5.2)
        self.ctrl_req_bit = T.bit_position("zsw2_enc", "control_requested", profile)
        self.offset = 0
        self.offset_xist1_base = 0   # XIST1 offset when presets do not affect it
        self.preset_value = 0
        self.sol = 0               # encoder sign-of-life, 0 until the controller's one starts
        self.last_c_sol = None
        self.preset_ack = False
        self.ack_busy = 0
        self.error_code = 0        # sensor error code shown in G1_XIST2 while G1_ZSW.15
        self.error_cleared = False # the cause is gone; the next acknowledgement clears it
        self.parked = False
        self.last_trig = 0
        # fault knobs set by scenarios / injections: name -> bool or value
        self.faults: dict = {}

    def apply_preset(self, raw: int, relative: bool) -> None:
        tmr = self.p["tmr"]
        if relative:
            self.offset = (self.offset + self.preset_value) % tmr
        else:
            self.offset = (self.preset_value + self.faults.get("preset_error", 0) - raw) % tmr

    def raw_counts(self, t: float) -> tuple[int, float]:
        rev, rpm = self.shaft.at(t)
        mupr, tmr = self.p["mupr"], self.p["tmr"]
        if self.p.get("direction"):
            rev = -rev
            rpm = -rpm
        return int(math.floor(rev * mupr)) % tmr, rpm

    def velocity(self, rpm: float) -> int:
        unit = self.p.get("velocity_unit", 0)  # cyclic.md §11.2: 0 steps/s, 1 /100 ms, 2 /10 ms, 3 rpm
        sps = rpm / 60.0 * self.p["mupr"]
        return int(round({0: sps, 1: sps / 10, 2: sps / 100, 3: rpm}.get(unit, sps)))

    def step(self, k: int, out: dict) -> dict:
        """Input words for cycle k, given the output words last received."""
        f = self.faults
        t = k * self.cycle_s
        raw, rpm = self.raw_counts(t)
        tmr = self.p["tmr"]
        stw2, g1stw = out.get("stw2_enc", 0), out.get("g1_stw", 0)
        ctrl = bool(stw2 & 0x0400) or not self.p.get("compat", 1)
        # --- preset (G1_STW.12 request, mode bit 11), cyclic.md §7.2; needs class 4 (§7.2 preconditions)
        allowed = ctrl or f.get("ignore_ctrl")
        if allowed and g1stw & 0x1000 and not self.preset_ack and not f.get("preset_ack_missing") \
                and (self.p.get("class4", 1) or f.get("ignore_class4")):
            self.preset_wait = getattr(self, "preset_wait", 0) + 1
            if self.preset_wait > f.get("preset_delay", 0):
                self.apply_preset(raw, bool(g1stw & 0x0800))
                self.preset_ack = True
        elif not g1stw & 0x1000:
            self.preset_wait = 0
            if not f.get("preset_ack_stuck"):
                self.preset_ack = False
        # cyclic preset telegrams: bit 31/63 trigger (cyclic.md §10)
        for name in ("g1_xist_preset_b", "g1_xist_preset_c"):
            if name in out:
                bits = 32 if name.endswith("b") else 64
                v = out[name]
                trig = v >> (bits - 1)
                if trig and not self.last_trig:
                    pv = min(v & ((1 << (bits - 1)) - 1), tmr - 1)   # clamped to R-1 (cyclic.md §10)
                    self.offset = (pv + f.get("cyclic_preset_error", 0) - raw) % tmr
                self.last_trig = trig
        if "g1_xist_preset_b1" in out:  # telegram 89: STW2_ENC bit 0 trigger, ZSW2_ENC bit 0 ack [derived]
            if stw2 & 1 and not self.last_trig:
                self.offset = (out["g1_xist_preset_b1"] - raw) % tmr
            self.last_trig = stw2 & 1
        pos = (raw + self.offset) % tmr
        # --- parking (cyclic.md §7.3)
        self.parked = bool(g1stw & 0x4000) and allowed
        # --- sensor error and its acknowledgement (cyclic.md §7.4)
        if self.error_code and g1stw & 0x8000 and allowed:
            self.ack_busy = 1
        elif self.ack_busy and not g1stw & 0x8000:
            self.ack_busy = 0
            if self.error_cleared and not f.get("error_sticky"):
                self.error_code = 0
        # --- sign-of-life: starts once the controller's one runs (cyclic.md §6)
        c_sol = stw2 >> 12
        if self.sol == 0 and c_sol and self.last_c_sol is not None and c_sol != self.last_c_sol:
            self.sol = 1
        elif self.sol:
            self.sol = sol_next(self.sol)
            if f.get("sol_skip_at") == k:
                self.sol = sol_next(self.sol)
            if f.get("sol_freeze"):
                self.sol = self.last_sol
        self.last_sol = self.sol
        self.last_c_sol = c_sol
        sol = 0 if f.get("sol_zero") else self.sol
        zsw2 = sol << 12
        if ctrl and self.p.get("compat", 1):
            zsw2 |= 1 << self.ctrl_req_bit
        if self.error_code and self.profile == "psm":
            zsw2 |= 0x0008   # PS/PSM ZSW2_ENC bit 3 "fault present" (cyclic.md §5.2)
        if self.telegram == 89 and stw2 & 1:
            zsw2 |= 1  # XIST_PRESET_ACK [derived, cyclic.md §10]
        g1zsw = 0
        # G1_XIST1 preset control: 0 = preset affects XIST1 (L/S/P), inverted on Hohner (records.md §5.2)
        affects = (not self.p.get("preset_control")) != (self.profile == "hohner")
        if f.get("xist1_preset_inverted"):
            affects = not affects
        xist1 = pos if affects else (raw + self.offset_xist1_base) % tmr
        xist2 = 0
        if self.parked:
            g1zsw = 0x4000
            xist1 = 0
        else:
            if self.error_code:
                g1zsw |= 0x8000
                xist2 = self.error_code
            elif g1stw & 0x2000 and allowed:
                g1zsw |= 0x2000
                xist2 = pos
            if self.preset_ack:
                g1zsw |= 0x1000
            if self.ack_busy:
                g1zsw |= 0x0800
        g1zsw |= f.get("g1zsw_or", 0)
        zsw2 |= f.get("zsw2_or", 0)
        vel = self.velocity(rpm)
        return {"zsw2_enc": zsw2, "g1_zsw": g1zsw, "g1_xist1": xist1, "g1_xist2": xist2 if self.telegram != 100 else pos,
                "g1_xist3": pos, "nist_a": max(-32768, min(32767, vel)), "nist_b": vel, "acc_b": 0}


# --------------------------------------------------------------------------- controller
class Plc:
    """The IO controller's output words: control by PLC, sign-of-life, request bits per scenario."""

    def __init__(self, telegram: int, sol_start: int = 1):
        self.telegram = telegram
        self.out_fields, self.in_fields = io_layout(telegram)
        self.sol = sol_start
        self.g1stw = 0x2000          # request absolute value cyclically (SCANCON example, cyclic.md §5.3)
        self.ctrl = True
        self.faults: dict = {}
        self.preset_req = False
        self.preset_mode = 0
        self.park = False
        self.ack = False
        self.preset_out = None       # value for the cyclic preset telegrams
        self.preset_trig = False

    def step(self, k: int, last_in: dict | None) -> dict:
        f = self.faults
        if k:
            self.sol = sol_next(self.sol)
            if f.get("sol_skip_at") == k:
                self.sol = sol_next(self.sol)
        sol = 0 if f.get("sol_zero") else self.sol
        if f.get("sol_repeat_at") == k:
            sol = self.prev_sol
        self.prev_sol = sol
        stw2 = sol << 12 | (0x0400 if self.ctrl else 0) | f.get("stw2_or", 0)
        g1 = self.g1stw | (0x1000 if self.preset_req else 0) | (self.preset_mode << 11 if self.preset_req else 0) \
            | (0x4000 if self.park else 0) | (0x8000 if self.ack else 0) | f.get("g1stw_or", 0)
        if self.telegram == 89 and self.preset_trig:
            stw2 |= 1
        out = {"stw2_enc": stw2, "g1_stw": g1}
        if self.preset_out is not None:
            trig = 1 if self.preset_trig else 0
            out["g1_xist_preset_b"] = (trig << 31) | (self.preset_out & 0x7FFFFFFF)
            out["g1_xist_preset_c"] = (trig << 63) | (self.preset_out & ((1 << 63) - 1))
            out["g1_xist_preset_b1"] = self.preset_out & 0xFFFFFFFF
        else:
            out["g1_xist_preset_b"] = out["g1_xist_preset_c"] = out["g1_xist_preset_b1"] = 0
        return out
