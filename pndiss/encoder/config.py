"""What one encoder is configured to do: the settings in force for the reference encoder.

Resolution order for every value (behaviour.md §0.3): the captured 0xBF00 record / parameter
reads, then the user's settings (CLI --set / config file), then the vendor default from the
telegram table (profile_defaults, behaviour.md §7 D13-D15). ``sources`` records which one won,
so the report can print the settings in force with their origin.
"""
from __future__ import annotations

DEFAULT_SOURCE = "default (telegrams.json profile_defaults)"   # a profile default, nothing captured or given

import math
from dataclasses import dataclass, field, fields

from .. import telegrams as tg

U32 = 1 << 32


def next_ls(v: int) -> int:
    """Next sign-of-life value: 1..15, 15 -> 1, never 0 (behaviour.md §0.2, cyclic.md §6)."""
    return (v % 15) + 1


CONNECT_CYCLE = "Connect (SendClockFactor x ReductionRatio)"
# no Connect in the capture (mid-session, content inference): the cycle counter's step is the provider's cycle
# (wire.md §2.3), confirmed over several frames (pndiss/gaps.py) -- better than the 1 ms of behaviour.md §0.1
COUNTER_CYCLE = "learnt from the cycle counter step of the encoder's input frames (no Connect in the capture)"


@dataclass
class EncoderConfig:
    profile: str = "generic"
    telegram: int = 81
    compat: int = 1                   # 0 = V3.1 compatibility mode, 1 = V4.1 (0xBF00 byte 0 bit 5)
    class4: int = 1                   # 0xBF00 byte 0 bit 1
    preset_control: int | None = None  # raw 0xBF00 byte 0 bit 2 (meaning per vendor: xist1_preset_affected)
    scaling: int = 0                  # 0xBF00 byte 0 bit 3
    direction: int = 0                # 0xBF00 byte 0 bit 0 (code sequence)
    mupr: int | None = None           # measuring units per revolution (bytes 1-8)
    tmr: int | None = None            # total measuring range (bytes 9-16)
    st_phys: int | None = None
    mt_phys: int | None = None
    max_master_sol_failures: int = 1  # byte 17 (compat mode only, §3.3 R-SOLC-3)
    velocity_unit: int = 0            # byte 18
    shift: int | None = None          # P979 sub 3 (XIST1 shift); None = infer from the first ATX cycle
    iso: bool = False
    k: int = 1                        # TMAPC / TDP
    l_max: int = 2
    preset_deadline_ms: float = 10.0
    cycle_ns: int | None = None
    sol_threshold_ge: bool = False
    sol_monitor_rt: bool = False
    max_position_step: int | None = None
    p65000: int | None = None         # P65000 before a write is seen; None = unknown
    p925: int | None = None           # tolerated master sign-of-life failures in V4.1 mode, when P925 is seen
    sources: dict = field(default_factory=dict)

    # -- derived (cheap properties; the checker copies what it needs into locals) --------------
    @property
    def defaults(self) -> dict:
        return tg.PROFILE_DEFAULTS.get(self.profile, tg.PROFILE_DEFAULTS["generic"])

    @property
    def std(self) -> bool:
        """STD: telegram with STW2_ENC/ZSW2_ENC (81-84; PS/PSM 89) (behaviour.md §9 preamble)."""
        return self.telegram in tg.CONTROL_WORDS

    @property
    def xist1_preset_affected(self) -> bool:
        """Does a preset move G1_XIST1? Class 4 on and the vendor's 'enabled' coding (§7 D14)."""
        pc = self.defaults["preset_control"] if self.preset_control is None else self.preset_control
        return bool(self.class4) and pc == self.defaults["preset_control_affects_xist1"]

    @property
    def xist1_counter(self) -> bool:
        """SCANCON/HOHNER profile 4.1: XIST1 is a wrapping 32-bit counter (behaviour.md §1.6 R-X1-3)."""
        return self.defaults["xist1_counter"] and not self.shift

    @property
    def solmon(self) -> bool:
        """SOLMON = STD and iso and (not SCANCON or compat = 1); settings.sol_monitor_rt drops iso (§9)."""
        return self.std and (self.iso or self.sol_monitor_rt) and (self.profile != "scancon" or self.compat == 1)

    @property
    def modulus(self) -> int | None:
        """R: TMR with class 4 and scaling on, else ST_phys x MT_phys (behaviour.md §4.1 [INFERENCE])."""
        if self.class4 and self.scaling and self.tmr:
            return self.tmr
        if self.st_phys and self.mt_phys:
            return self.st_phys * self.mt_phys
        return None

    @property
    def n_sol(self) -> int:
        """N tolerated master sign-of-life failures: byte 17 in V3.1 mode; in V4.1 P925 when the capture shows
        it (written or read; "P925 may optionally control the monitoring"), else 1 (§3.3 R-SOLC-3)."""
        if self.compat == 0:
            return self.max_master_sol_failures
        return self.p925 if self.p925 else 1

    @property
    def d_preset(self) -> int:
        """D_preset = ceil(10 ms / T_cycle) + L_max; T_cycle 1 ms when unknown (behaviour.md §0.1)."""
        t = self.cycle_ns or 1_000_000
        return math.ceil(self.preset_deadline_ms * 1e6 / t) + self.l_max

    @property
    def store_cycles(self) -> int:
        """Cycles in 10 ms: the longest allowed position gap after a preset (§9.5 #43)."""
        t = self.cycle_ns or 1_000_000
        return max(1, math.ceil(10e6 / t))

    @property
    def velocity_lag_cycles(self) -> int:
        """Cycles a correct NIST may keep the old sign after a reversal: two of the device's velocity
        intervals (a value computed over an interval that straddles the reversal, then held for one
        interval) plus L_max, plus the lag of the default velocity filter (an independent audit: SCANCON/Hohner
        'Fine'); 0 for a device that computes NIST every cycle unfiltered (#44)."""
        u = self.defaults.get("velocity_update_ms", 0)
        f = self.defaults.get("velocity_filter_cycles", 0)   # a default filter's lag (SCANCON/Hohner 'Fine' 7:3)
        if not u:
            return f   # (NIST and the position travel in one frame: no controller latency in it -- a review)
        t = self.cycle_ns or 1_000_000
        return math.ceil(2 * u * 1e6 / t) + self.l_max + f

    def compat_open(self) -> bool:
        """The compatibility mode is not known from the capture (no 0xBF00 seen: a capture started
        mid-session, a lost write) nor given (--set compat): the checker learns it from the words
        (words.py ``_learn_compat``) and judges #13-#16 only from then on. LIKA wants compat = 0 under a
        SIMATIC technology object (000_37bf2397999f1108.txt:1280-1281): the default would blame the encoder."""
        return self.sources.get("compat", "").endswith(DEFAULT_SOURCE)

    def class4_open(self) -> bool:
        """Class 4 functionality neither captured (0xBF00) nor given (--set class4): a vendor default (SCANCON's
        and Hohner's is off) is no fact of a device the PLC parameterises at every start-up -- the class 4
        rules (#17, #18, #91) are not judged, a preset is judged as allowed."""
        return self.sources.get("class4", "").endswith(DEFAULT_SOURCE)

    def preset_control_open(self) -> bool:
        """The G1_XIST1 preset control bit not captured (no 0xBF00): what a preset does to G1_XIST1 is not
        judged (#28, #29, the G1_XIST1 value after a preset)."""
        return self.sources.get("preset_control", "").endswith(DEFAULT_SOURCE)

    def in_force(self) -> dict:
        """The settings in force, with where each came from (for summary() and the report)."""
        out = {}
        for f in fields(self):
            if f.name == "sources":
                continue
            out[f.name] = {"value": getattr(self, f.name), "source": self.sources.get(f.name, "default")}
        out["R"] = {"value": self.modulus, "source": "derived (behaviour.md §4.1)"}
        out["D_preset"] = {"value": self.d_preset, "source": "derived (behaviour.md §0.1)"}
        out["SOLMON"] = {"value": self.solmon, "source": "derived (behaviour.md §9)"}
        out["xist1_preset_affected"] = {"value": self.xist1_preset_affected, "source": "derived (§7 D14)"}
        return out

    @classmethod
    def from_settings(cls, settings=None, *, profile: str = "generic", telegram: int = 81,
                      bf00: dict | None = None, cycle_ns: int | None = None, iso: bool | None = None,
                      cycle_source: str = CONNECT_CYCLE,
                      profile_reason: str | None = None, telegram_source: str | None = None) -> "EncoderConfig":
        c = cls(profile=profile if profile in tg.PROFILE_DEFAULTS else "generic", telegram=telegram)
        src = c.sources
        src["profile"] = profile_reason or "given"
        src["telegram"] = telegram_source or "given"
        d = c.defaults
        for name in ("class4", "preset_control", "scaling", "compat"):
            setattr(c, name, d[name])
            src[name] = f"{c.profile} {DEFAULT_SOURCE}"
        s = settings
        if s is not None:
            for name, attr in (("l_max", "l_max"), ("preset_deadline_ms", "preset_deadline_ms"),
                               ("sol_threshold_ge", "sol_threshold_ge"), ("sol_monitor_rt", "sol_monitor_rt"),
                               ("master_cycle_ratio", "k"), ("st_phys", "st_phys"), ("mt_phys", "mt_phys"),
                               ("xist1_shift", "shift"), ("max_position_step", "max_position_step"),
                               ("compat", "compat"), ("class4", "class4"), ("p65000", "p65000")):
                v = getattr(s, name, None)
                if v is None:
                    continue
                if attr not in ("sol_threshold_ge", "sol_monitor_rt", "preset_deadline_ms"):
                    v = int(v)  # --set delivers strings for fields whose default is None
                setattr(c, attr, v)
                src[attr] = f"settings.{name}"
        if bf00:  # the captured 0xBF00 wins over settings and defaults (behaviour.md §0.3)
            for key, attr in (("compat", "compat"), ("class4", "class4"), ("preset_control", "preset_control"),
                              ("scaling", "scaling"), ("direction", "direction"), ("code_sequence", "direction"),
                              ("mupr", "mupr"), ("tmr", "tmr"), ("max_master_sol_failures", "max_master_sol_failures"),
                              ("velocity_unit", "velocity_unit")):
                if bf00.get(key) is not None:
                    setattr(c, attr, int(bf00[key]))
                    src[attr] = "captured 0xBF00"
        if iso is not None:
            c.iso = bool(iso)
            src["iso"] = "capture (IOCR RT class)"
        if s is not None and getattr(s, "iso", None) is not None:
            c.iso = bool(s.iso)
            src["iso"] = "settings.iso"
        if cycle_ns:
            c.cycle_ns = cycle_ns
            src["cycle_ns"] = cycle_source
        return c
