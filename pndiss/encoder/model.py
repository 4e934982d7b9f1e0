"""A conforming encoder: what the reference encoder answers to a setpoint (for the simulator).

Sans-IO: ``respond(setpoint, shaft_position)`` is one cycle, returning the actual-value signals of
the configured telegram. Reactions come in the same cycle (latency 0, inside every L_max). The
behaviour is the one the checker (_state.py) demands; test_encoder_model.py runs the checker
over this model and expects no encoder-side violation.
"""
from __future__ import annotations

from .. import telegrams as tg
from . import position as P
from .config import EncoderConfig, next_ls

_PRESET_WORD = tg.PRESET_WORD   # telegram -> (preset word, trigger bit), from the telegram table (cyclic.md §10)


class ReferenceEncoder:
    def __init__(self, cfg: EncoderConfig):
        self.cfg = cfg
        self.layout = tg.layout(cfg.telegram, "actual")
        self.off2 = 0            # offset applied to XIST2/XIST3 (§4.2 step 4)
        self.off1 = 0            # offset applied to XIST1 (differs when preset control is disabled, step 5)
        self.p65000 = 0          # preset value, default 0 (000_37bf2397999f1108.txt:1787-1789)
        self.dls = 0
        self.prev = {}
        self.areq = 0            # last evaluated absolute-value request (V4.1: only while CTRL = 1)
        self.park = 0
        self.error: int | None = None
        self.persistent = False
        self.acking = False
        self.pdone = 0
        self.prev_pos = None
        self.ptrig_ack = 0

    # -- acyclic --------------------------------------------------------------------------------
    def write_parameter(self, pnu: int, value: int, subindex: int = 0) -> tuple[bool, int | None]:
        """A BMP change request; (ok, error number). Rules #86, #87, #91 (behaviour.md §5.3)."""
        c = self.cfg
        if pnu == 65000:
            if not c.class4:
                return False, 0x11      # not possible in this operating state [INFERENCE] R-PAR-2
            R = c.modulus
            if R is not None and not 0 <= value < R:
                return False, 0x02      # limit exceeded (001_9461bb7bc8c2767b.txt:847)
            self.p65000 = value         # stored only (R-PAR-1)
            return True, None
        if pnu in (922, 964, 965, 975, 979, 980, 61001, 65001):
            return False, 0x01          # read-only (001_9461bb7bc8c2767b.txt:2041)
        return False, 0x00              # impermissible PNU

    def inject_error(self, code: int, persistent: bool = False) -> None:
        """Raise a sensor error: SERR = 1 and the code in G1_XIST2 (R-ERR-1)."""
        self.error = code
        self.persistent = persistent

    # -- one cycle ------------------------------------------------------------------------------
    def _scaled(self, raw: int) -> int:
        c = self.cfg
        return P.scaled(raw, direction=c.direction, class4=c.class4, scaling=c.scaling, mupr=c.mupr, tmr=c.tmr,
                        st_phys=c.st_phys, mt_phys=c.mt_phys)

    def respond(self, setpoint: dict, shaft_position: int) -> dict:
        c = self.cfg
        s = self._scaled(shaft_position)
        R = c.modulus
        if c.telegram in _PRESET_WORD:
            out = self._respond_preset_telegram(setpoint, s, R)
        else:
            out = self._respond_std(setpoint, s, R)
        self.prev = dict(setpoint)
        return {k: out.get(k, 0) for k in self.layout.names}

    def _respond_std(self, sp: dict, s: int, R) -> dict:
        c = self.cfg
        stw2, g1stw = sp.get("stw2_enc", 0), sp.get("g1_stw", 0)
        pstw2, pg1 = self.prev.get("stw2_enc", 0), self.prev.get("g1_stw", 0)
        cls, ctrl = stw2 >> 12, (stw2 >> 10) & 1
        valid = c.compat == 0 or ctrl == 1                       # R-CTRL-2/3
        hmode, preq, areq, park, sack = ((g1stw >> b) & 1 for b in (11, 12, 13, 14, 15))
        ppreq, psack = (pg1 >> 12) & 1, (pg1 >> 15) & 1
        # sign-of-life: start on a C-LS change (iso) or at once (RT), +1 per cycle (§3.2)
        if self.dls:
            self.dls = next_ls(self.dls)
        elif not c.solmon or (self.prev and cls and cls != pstw2 >> 12):
            self.dls = 1
        if valid:
            self.areq, self.park = areq, park
            if park:  # parking clears errors and raises none (R-PARK-1)
                self.error = None
                self.acking = False
            if preq and not ppreq and c.class4 and not park and self.error is None:
                self._preset(hmode, self.p65000, s, R)            # R-PRE-9/10
                self.pdone = 1
            if sack and not psack and self.error is not None:
                self.acking = True                                # R-ERR-2 step 2
        if not preq:
            self.pdone = 0                                        # R-PRE-4
        if self.acking and not sack:                              # R-ERR-2 step 4a/4b
            self.acking = False
            if not self.persistent:
                self.error = None
        parked = self.park
        serr = int(self.error is not None and not parked)
        atx = int(self.areq and not serr and not parked)
        pos2 = P.with_offset(s, self.off2, R)
        pos1 = P.with_offset(s, self.off1, R)
        x1 = 0 if parked else P.aligned_xist1(pos1, c.shift or 0)
        x2 = 0 if parked else (self.error if serr else (pos2 if atx else 0))
        g1zsw = (int(self.acking and serr) << 11) | (int(self.pdone and not parked) << 12) | (atx << 13) \
            | (int(parked) << 14) | (serr << 15)
        creq_bit = tg.bit_position("zsw2_enc", "control_requested", "psm" if c.profile == "psm" else "generic")
        zsw2 = (self.dls << 12) | ((ctrl if c.compat == 1 else 0) << creq_bit)
        if c.profile == "psm":
            zsw2 |= serr << 3                                     # fault present (§2.8 [INFERENCE])
            if c.telegram in tg.PRESET_HANDSHAKE:
                zsw2 |= self._preset89(sp, s, R)
        nist = self._nist(pos2)
        return {"zsw2_enc": zsw2, "g1_zsw": g1zsw, "g1_xist1": x1, "g1_xist2": x2, "g1_xist3": 0 if parked else pos2,
                "nist_a": max(-32768, min(32767, nist)), "nist_b": nist}

    def _preset(self, mode: int, value: int, s: int, R) -> None:
        self.off2 = P.preset_offset(mode, value, s, self.off2, R)
        if self.cfg.xist1_preset_affected:  # §4.2 step 5 (D14 per-vendor coding)
            self.off1 = self.off2

    def _preset89(self, sp: dict, s: int, R) -> int:
        hs = tg.PRESET_HANDSHAKE[self.cfg.telegram]   # trigger / acknowledge bits (cyclic.md §3.9)
        (tw, tname), (aw, aname) = (hs[k].split(".") for k in ("trigger", "ack"))
        tb, ab = tg.bit_position(tw, tname, "psm"), tg.bit_position(aw, aname, "psm")
        trig = (sp.get(tw, 0) >> tb) & 1
        if trig and not (self.prev.get(tw, 0) >> tb) & 1:
            self._preset(0, sp.get(hs["value"], 0), s, R)  # [INFERENCE] §2.5 R-P89-1
        return trig << ab

    def _respond_preset_telegram(self, sp: dict, s: int, R) -> dict:
        name, top = _PRESET_WORD[self.cfg.telegram]
        w, pw = sp.get(name, 0), self.prev.get(name, 0)
        if (w >> top) & 1 and not (pw >> top) & 1:
            self.off2 = P.preset_offset(0, P.preset_860(w & ((1 << top) - 1), R), s, self.off2, R)  # R-P860-1/2
            self.off1 = self.off2
        pos = P.with_offset(s, self.off2, R)
        nist = self._nist(pos)
        return {"g1_xist1": pos, "g1_xist3": pos, "nist_b": nist, "acc_b": 0}

    def _nist(self, pos: int) -> int:
        """Velocity in steps/s from the last cycle's motion (unit 0, §4.6)."""
        prev, self.prev_pos = self.prev_pos, pos
        if prev is None:
            return 0
        m = self.cfg.modulus or (1 << 32)
        d = P.delta(prev, pos, m)
        t = self.cfg.cycle_ns or 1_000_000
        return max(-(1 << 31), min((1 << 31) - 1, d * 1_000_000_000 // t))
