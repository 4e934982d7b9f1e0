"""Generate docs/rules.md: the coverage ledger of the 92-rule violation catalogue.

A rule counts as implemented when its ID appears as a string literal in a checking module of
pndiss/ (the simulator's fault injectors do not count) and a test under tests/ names it; the
ledger lists where. Rules nobody checks need a reason in NOT_DECIDABLE (or are listed as open).
tests/test_rules_ledger.py fails when docs/rules.md is stale. Run: python3 tools/gen_rule_ledger.py
"""
from __future__ import annotations

import json
import os
import re
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(ROOT, "docs", "rules.md")
SKIP_DIRS = ("pndiss/sim",)            # fault injectors name rules but do not check them

# Why a rule cannot be decided from a capture (or only partly).
NOT_DECIDABLE: dict = {}
PARTIAL = {
    "BMP-ORDER": "a PROFIdrive response repeats no PNU/subindex (001_9461bb7bc8c2767b.txt:1891-1900): decided where the "
                 "blocks of a multi-parameter read that hold values (error blocks keep their places) hold the requested "
                 "element counts in another order (records/profidrive.order_broken), or two of them each the other "
                 "parameter's declared data type (types_swapped); blocks of equal counts and types swapped cannot be "
                 "told",
    "PARK-ERROR-REPORTED": "SERR rising, or a diagnosis alarm of the axis' submodule appearing, while parked; an AR "
                           "inferred from the cyclic content has no slot/subslot, so its alarms are not correlated",
    "BF00-ERROR-NOT-REPORTED": "0x1002 in G1_XIST2, or a 0x9011 diagnosis alarm of the axis' submodule, within D_preset "
                               "cycles",
    "BF00-VALID-REJECTED": "0x1002 in G1_XIST2 or a 0x9011 diagnosis alarm after a valid record (an AR inferred from content has no slot: its alarms are not correlated)",
    "SOL-MASTER-ZERO": "only with SOLMON (iso from the RT class, or settings.iso / sol_monitor_rt)",
    "BMP-PIPELINED": "a request pending from before capture loss in the device's own streams is forgotten, not "
                     "\"overwritten\" (its response may have been read in the lost part)",
    "POSITION-OUT-OF-RANGE": "needs R: 0xBF00 TMR with scaling, or settings st_phys/mt_phys",
    "PRESET860-VALUE-OUT-OF-RANGE": "needs R (as POSITION-OUT-OF-RANGE)",
    "STARTUP-NO-PARAM-RECORD": "decided at the AR's PrmEnd (0xBF00 / PS/PSM 0xFFFF written since the Connect, alone or "
                               "in a MultipleWrite 0xE040); only for ARs whose Connect and PrmEnd are in the capture",
    "PRESET-WITHOUT-NEW-PARAMS": "needs two connections of the same device in one capture",
    "BMP-UNKNOWN-PNU": "needs a P980 read in the capture (P981.. continue the list; P980..P989 themselves and PNU 0, "
                       "the controller's bad request, are not judged)",
    "XIST2-INCONSISTENT": "profile generic: only with the shift read (P979) or given (an unknown vendor's X1 may be a 4.1 counter); "
                          "without a captured 0xBF00 not after a preset",
    "PARK-OUTPUTS-NOT-CLEARED": "LIKA; G1_XIST2 may keep a sensor error's code while SERR is still shown (#49 allows L_max)",
    "SERR-XIST2-NOT-RESTORED": "not while parked (parking clears the error and keeps the position out, R-ABS-4)",
    "POSITION-DISCONTINUITY": "plausible step = settings.max_position_step, else R/8 [INFERENCE]; LIKA with R no power of two: a "
                              "jump to or from within a step of 0 is its red zone's physical wrap [INFERENCE]; not in a cycle with G1_ZSW.12 (a preset's result, also one whose request a gap hid); "
                              "judged on G1_XIST2 (or X3), and on LIKA's G1_XIST1 where no X2 carries the position "
                              "(000_37bf2397999f1108.txt:1579-1580; not from or to 0: parked or in error) -- PS/PSM's and "
                              "the generic profile's X1 only through X2 (its alignment is theirs to say)",
    "PRESET-CLASS4-DISABLED": "class 4 from a captured 0xBF00 or --set class4, not a vendor default",
    "BMP-CLASS4-WRITE-ACCEPTED": "class 4 from a captured 0xBF00 or --set class4, not a vendor default",
    "PRESET-XIST1-AFFECTED-WHEN-DISABLED": "needs the preset control bit of a captured 0xBF00",
    "PRESET-XIST1-NOT-AFFECTED-WHEN-ENABLED": "needs the preset control bit of a captured 0xBF00",
    "SOL-FAULT-SPURIOUS": "the failure counter must be known below 10N: not judged for 10N+10 cycles after capture loss",
    "SOL-DEVICE-EARLY-START": "the encoder may start within L_max cycles of a controller sign-of-life change (k > 1 "
                              "holds the changed value)",
    "PRESET-NOT-STANDSTILL": "standstill by the position over W(n,-2,0) only: the velocity lags a stop (SCANCON/Hohner "
                             "filter it, 001_9461bb7bc8c2767b.txt:970-983, 004_59bef5ae9f41db55.txt:828-838; Lika every "
                             "100 ms, 000_37bf2397999f1108.txt:1919), so a nonzero NIST alone is no motion",
    "PARK-WHILE-RUNNING": "standstill by the position only (as PRESET-NOT-STANDSTILL)",
    "NIST-SIGN": "3 cycles in a row; LIKA computes NIST every 100 ms (000_37bf2397999f1108.txt:1919), so there the run "
                 "must outlast two intervals + L_max (telegrams.json velocity_update_ms); SCANCON/Hohner filter NIST "
                 "by default ('Fine', an average old:new 7:3, 001_9461bb7bc8c2767b.txt:970-983), so there 3 "
                 "cycles of lag are allowed (velocity_filter_cycles [INFERENCE]); a 0x1000 write (another filter) "
                 "switches the rule off",
}


def _literals(path: str) -> set[str]:
    with open(path, encoding="utf-8") as f:
        return set(re.findall(r"[\"']([A-Z0-9]+(?:-[A-Z0-9]+)+)[\"']", f.read()))


def _scan(top: str, skip=()) -> dict[str, list[str]]:
    found: dict[str, list[str]] = {}
    for root, dirs, files in os.walk(os.path.join(ROOT, top)):
        rel_root = os.path.relpath(root, ROOT)
        if any(rel_root.startswith(s) for s in skip):
            continue
        dirs.sort()
        for fn in sorted(files):
            if fn.endswith(".py"):
                rel = os.path.join(rel_root, fn)
                for lit in _literals(os.path.join(ROOT, rel)):
                    found.setdefault(lit, []).append(rel)
    return found


def build() -> str:
    with open(os.path.join(ROOT, "pndiss", "data", "rules.json"), encoding="utf-8") as f:
        rules = json.load(f)
    code = _scan("pndiss", SKIP_DIRS)
    tests = _scan("tests")
    lines = ["# Rule coverage ledger", "",
             "GENERATED by tools/gen_rule_ledger.py from pndiss/data/rules.json and the source tree; do not edit.",
             "A rule is *implemented* when a checking module of pndiss/ names it and a test names it.", "",
             "| # | Rule | Side | Severity | Status | Checked in | Test names it | Note |",
             "|---|---|---|---|---|---|---|---|"]
    counts = {"implemented": 0, "not decidable": 0, "open": 0}
    for r in rules:
        rid = r["id"]
        where = sorted(p for p in code.get(rid, []) if not p.startswith("pndiss/data"))
        tested = sorted(tests.get(rid, []))
        if rid in NOT_DECIDABLE:
            status, note = "not decidable from a capture", NOT_DECIDABLE[rid]
            counts["not decidable"] += 1
        elif where and tested:
            status, note = "implemented", PARTIAL.get(rid, "")
            counts["implemented"] += 1
        else:
            status, note = "open", "no checker and test name it yet"
            counts["open"] += 1
        lines.append(f"| {r['n']} | `{rid}` | {r['side']} | {r['severity']} | {status} | "
                     f"{', '.join(where) or '-'} | {'yes' if tested else '-'} | {note} |")
    lines += ["", f"Totals: {counts['implemented']} implemented, {counts['not decidable']} not decidable from a capture, "
                  f"{counts['open']} open (of {len(rules)}).", ""]
    return "\n".join(lines)


if __name__ == "__main__":
    text = build()
    if "--check" in sys.argv:
        with open(OUT, encoding="utf-8") as f:
            sys.exit(0 if f.read() == text else 1)
    with open(OUT, "w", encoding="utf-8") as f:
        f.write(text)
    print(text.splitlines()[-1])
