"""The curated capture set in captures/ (rebuilt by ``captures/regenerate``; tests/test_captures.py
checks the files in the repo are exactly what this list makes).

Clean captures: a start-up + run per vendor profile and telegram family, plus one per scenario.
Fault captures: one per injectable rule (``fault-<rule>.pcapng``), short (300 cycles at 1 ms),
on the scenario / telegram / profile the fault needs.
"""
from __future__ import annotations

import os

from .scenarios import INJECTIONS
from .session import Config

SEED = 1
FAULT_CYCLES = 300

# (file stem, scenario, profile, telegram, cycles, encoders)
CLEAN = [
    ("startup-t81-generic", "startup", "generic", 81, 2000, 1),    # the README's first command
    ("startup-t81-lika", "startup", "lika", 81, 1000, 1),
    ("startup-t82-lika", "startup", "lika", 82, 1000, 1),
    ("startup-t83-scancon", "startup", "scancon", 83, 1000, 1),
    ("startup-t84-hohner", "startup", "hohner", 84, 1000, 1),
    ("startup-t81-psm", "startup", "psm", 81, 1000, 1),
    ("startup-t86-psm", "startup", "psm", 86, 1000, 1),
    ("startup-t87-psm", "startup", "psm", 87, 1000, 1),
    ("startup-t88-psm", "startup", "psm", 88, 1000, 1),
    ("startup-t89-psm", "startup", "psm", 89, 1000, 1),
    ("startup-t100-psm", "startup", "psm", 100, 1000, 1),
    ("startup-t101-psm", "startup", "psm", 101, 1000, 1),
    ("startup-t860-scancon", "startup", "scancon", 860, 1000, 1),
    ("startup-t81-generic-3enc", "startup", "generic", 81, 1000, 3),
    ("preset-t81-lika", "preset", "lika", 81, 1000, 1),
    ("preset-t860-hohner", "preset", "hohner", 860, 1000, 1),
    ("preset-t89-psm", "preset", "psm", 89, 1000, 1),
    ("parking-t81-scancon", "parking", "scancon", 81, 1000, 1),
    ("sensor-error-t81-lika", "sensor-error", "lika", 81, 1000, 1),
    ("motion-t83-generic", "motion", "generic", 83, 2000, 1),
]


def fault_config(rule: str) -> Config:
    cls = INJECTIONS[rule]
    tel = cls.telegram or 81
    prof = cls.profile or ("psm" if tel in (86, 87, 88, 89, 100, 101) else "generic")
    return Config(scenario=cls.scenario or "startup", profile=prof, telegram=tel, cycles=FAULT_CYCLES,
                  encoders=cls.encoders, injects=[(rule, None)], seed=SEED)


def catalogue() -> dict[str, Config]:
    """file stem -> Config for every curated capture."""
    out = {stem: Config(scenario=sc, profile=p, telegram=t, cycles=c, encoders=e, seed=SEED)
           for stem, sc, p, t, c, e in CLEAN}
    for rule in sorted(INJECTIONS):
        out["fault-" + rule.lower()] = fault_config(rule)
    return out


def build_all(outdir: str, only: list[str] | None = None, log=None) -> list[str]:
    from .scenarios import write_capture
    os.makedirs(outdir, exist_ok=True)
    done = []
    for stem, cfg in catalogue().items():
        if only and stem not in only:
            continue
        path = os.path.join(outdir, stem + ".pcapng")
        write_capture(cfg, path)
        done.append(path)
        if log:
            log(path)
    return done
