"""The curated capture set in captures/ (rebuilt by ``captures/regenerate``; tests/test_captures.py
checks the files in the repo are exactly what this list makes).

Clean captures: a start-up + run per vendor profile and telegram family, plus one per scenario.
Fault captures: one per injectable rule (``fault-<rule>.pcapng``), short (300 cycles at 1 ms),
on the scenario / telegram / profile the fault needs.
"""
from __future__ import annotations

import os

from .scenarios import INJECTIONS
from .config import Config

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


# Plant-like sessions for issue #12 (start-up phases, loss, mid-session, restarts, IO devices).
# "needs" in a sidecar (capture_gap, mid_session) names the analyzer features such a capture tests.
PLANT = {
    # GOOD data from the device's first frame, 0xBF00 (plain write) a few cycles after the Connect
    # response, still before PrmEnd: clean
    "plant-good-before-prmend-t81": dict(telegram=81, cycles=600, good_before_prmend=True, records="plain"),
    # the same with no 0xBF00 write at all: STARTUP-NO-PARAM-RECORD at PrmEnd
    "plant-good-before-prmend-no-bf00": dict(telegram=81, cycles=300, good_before_prmend=True,
                                             injects=[("STARTUP-NO-PARAM-RECORD", None)]),
    # 0xBF00 only inside the S7-style MultipleWrite (0xE040): clean
    "plant-bf00-in-multiplewrite-t83-lika": dict(profile="lika", telegram=83, cycles=600),
    # isochronous (RT_CLASS_3, 250 us) with capture loss, and one genuine encoder sign-of-life skip
    "plant-irt-loss-sol-skip": dict(telegram=81, cycle_ms=0.25, cycles=2400, irt=True, capture_loss=0.01,
                                    injects=[("SOL-DEVICE-SKIP", 1800)]),
    # RT with capture loss, clean
    "plant-rt-loss-t81": dict(telegram=81, cycles=1500, encoders=2, capture_loss=0.01),
    # captures that start in data exchange (no DCP/Connect/records), each with a cyclic fault
    "plant-mid-session-t81": dict(telegram=81, cycles=1000, start_mid_session=300,
                                  injects=[("ABSVAL-ACK-MISSING", 600)]),
    "plant-mid-session-t83": dict(telegram=83, cycles=1000, start_mid_session=300,
                                  injects=[("RESERVED-BIT-SET-G1ZSW", 600)]),
    # encoder 1 released and connected again with other scaling (MUPR 4096, TMR 2^24, direction ccw)
    "plant-restart-new-scaling": dict(telegram=81, cycles=1200, restart=500,
                                      restart_scaling={"mupr": 4096, "tmr": 1 << 24, "direction": 1}),
    # encoder 1's AR aborted by the controller (ERR-RTA-PDU), a new AR with the same settings: clean
    "plant-restart-abort": dict(telegram=81, cycles=600, restart=250, restart_mode="abort"),
    # three encoders at 1/2/4 ms, two IO devices, drifting clocks
    "plant-3enc-cycles-io-devices": dict(telegram=81, cycles=1000, encoders=3, cycle_list=[1.0, 2.0, 4.0],
                                         io_devices=2),
}


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
    for stem, kw in PLANT.items():
        out[stem] = Config(**{"scenario": "startup", "seed": SEED, **kw})
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
