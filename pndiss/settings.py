"""Settings in force for one analysis: CLI options, config file, and the spec's open points.

Every setting the spec marks [INFERENCE] or [AMBIGUOUS] lives here with the suggested default
and its source, so the report can print the settings in force (docs/settings.md lists them).
"""
from __future__ import annotations

import json
from dataclasses import asdict, dataclass, field, fields


@dataclass
class Settings:
    # Device profile: 'auto' picks it from I&M0 / DCP vendor+device ID (records.md, issue #3).
    profile: str = "auto"
    gsdml: list[str] = field(default_factory=list)
    map_file: str | None = None
    # --- open points of the spec (behaviour.md §0.1, §8.1) ---
    l_max: int = 2                    # reaction latency tolerance in cycles [INFERENCE] behaviour.md §0.1
    preset_deadline_ms: float = 10.0  # D_preset = ceil(10 ms / T_cycle) + L_max [INFERENCE] behaviour.md §0.1
    sol_threshold_ge: bool = False    # failure counter fault at C > 10*N (False) or C >= 10*N (True) [AMBIGUOUS] §3.3
    sol_monitor_rt: bool = False      # monitor sign-of-life also without isochronous mode [AMBIGUOUS] §3.1 R-CLS-5
    iso: bool | None = None           # isochronous mode configured; None = infer from the Connect
    master_cycle_ratio: int | None = None   # k = TMAPC / TDP [INFERENCE] behaviour.md §0.1; None: 1 until a 0x8030
    #                                         record or the content inference says otherwise (a given value stays)
    compat: int | None = None         # 0xBF00 byte 0 bit 5; None = from the captured 0xBF00, else the profile default
    class4: int | None = None         # 0xBF00 byte 0 bit 1; None = from the capture
    byte_order: str = "big"           # PS/PSM "Intel" claim, cyclic.md §1 [AMBIGUOUS]: 'big' or 'little'
    telegram: int | None = None       # telegram when neither the Connect/P922/GSDML nor --map tells it
    # --- reference encoder: values a capture rarely shows (behaviour.md §0.3, §4.1) ---
    st_phys: int | None = None        # hardware steps per revolution; None = unknown (range rules skipped)
    mt_phys: int | None = None        # hardware revolutions; None = unknown
    xist1_shift: int | None = None    # P979 sub 3; None = P979 read, else inferred from XIST1/XIST2 [INFERENCE] §1.6
    max_position_step: int | None = None  # plausible |position change| per cycle; None = R/8 [INFERENCE] §4.2 #42
    # preset value before the capture shows a P65000 write: None = unknown, preset results not judged. The
    # factory value is 0, but a written one survives power-up once saved with P971 (000:1787-1789, 2078-2079)
    p65000: int | None = None
    infer_telegrams: bool = True      # mid-session captures: find telegrams from the cyclic content (pndiss/infer.py)
    capture_gaps: bool = True         # tell capture loss from the cycle counter (pndiss/gaps.py); lost cycles are not judged
    fail_on: str | None = None        # 'info' | 'warning' | 'error': exit 1 at or above that severity
    # Report-only runs (no JSONL/MCAP sink) take pndiss/fast.py for cyclic frames; False (or env
    # PNDISS_FAST_PATH=0) forces the reference path. Same results either way (tests/test_fastpath.py).
    fast_path: bool = True
    # --- bounded per-key tables (issue #18): beyond a limit the oldest entry is evicted, and the summary
    # says how many were not tracked (pndiss/limits.py). Memory stays flat under floods of random keys.
    max_streams: int = 32768          # cyclic streams (FrameID, src, dst), layouts, axes (65,536: 151 MB, #18)
    max_stations: int = 10000         # stations by MAC (and DCP name/IP claims, device profiles)
    max_ars: int = 4096               # ARs with their frame maps
    max_calls: int = 4096             # RPC requests awaiting their response, record writes awaiting results

    @classmethod
    def from_file(cls, path: str) -> "Settings":
        """Read a TOML or JSON config file with the same keys as the dataclass fields."""
        with open(path, "rb") as f:
            raw = f.read()
        import tomllib   # (only a settings file needs it)
        data = json.loads(raw) if path.endswith(".json") else tomllib.loads(raw.decode())
        known = {f.name for f in fields(cls)}
        unknown = set(data) - known
        if unknown:
            from .errors import did_you_mean
            raise ValueError(f"unknown setting(s) in {path}: {', '.join(sorted(unknown))}"
                             + did_you_mean(sorted(unknown)[0], sorted(known)))
        return cls(**data)

    @classmethod
    def field_type(cls, name: str) -> str:
        """The declared type of a setting as written in the dataclass ('int | None', ...)."""
        for f in fields(cls):
            if f.name == name:
                return f.type if isinstance(f.type, str) else getattr(f.type, "__name__", str(f.type))
        raise KeyError(name)

    def as_dict(self) -> dict:
        return asdict(self)
