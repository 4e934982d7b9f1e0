"""Fault injections, one per catalogue rule (spec/behaviour.md §9, pndiss/data/rules.json).

Each breaks its rule on one side from cycle ``k`` (``--inject RULE@CYCLE``; default: half-way
through the run) on the first encoder, and tags the frames that carry the fault so the ground truth
names first/last frame. ``scenario`` names the scenario the fault needs (the regenerate script and
the docs use it); ``also`` lists rules the same wire fault necessarily breaks as well; ``settings``
are analyzer settings needed to see it (e.g. sign-of-life monitoring outside isochronous mode).

One module per family: cyclic.py (the cyclic words, no scenario needed), preset.py, parking.py,
sensor_error.py (their scenarios), records.py (0xBF00, telegram), dcp.py, bmp.py (base mode
parameter access); base.py holds the kinds they build on. Importing the package registers them all.
"""
from __future__ import annotations

from ..scenarios import NOT_INJECTABLE
from . import bmp, cyclic, dcp, parking, preset, records, sensor_error  # noqa: F401  (registers the injections)

NOT_INJECTABLE.update({
    "SOL-MASTER-WINDOW": "needs a master application cycle k > 1 (TMAPC > TDP); the simulator runs k = 1",
    "SOL-FAULT-MISSING": "needs the encoder's sign-of-life failure counter (isochronous mode); produced only as a "
                         "side effect of SOL-MASTER-STALL",
    "SOL-FAULT-SPURIOUS": "needs an isochronous AR (the failure counter runs only with sign-of-life monitoring)",
    "SOL-FAULT-CLEARED-WITHOUT-ACK": "needs an isochronous AR with a 0x0F02 fault",
    "SYNC-FAULT-DLS-NONZERO": "needs an isochronous (IRT) AR; the simulator writes RT_CLASS_1 only",
    "PRESET-XIST1-AFFECTED-WHEN-DISABLED": "the same wire fault also breaks XIST2-INCONSISTENT / PRESET-VALUE-WRONG "
                                           "in ways that depend on the vendor coding (behaviour.md §7 D14); "
                                           "not separable",
    "PRESET-XIST1-NOT-AFFECTED-WHEN-ENABLED": "same as PRESET-XIST1-AFFECTED-WHEN-DISABLED",
    "PRESET-WITHOUT-NEW-PARAMS": "needs two connections with different 0xBF00 in one capture",
    "BMP-MULTI-NOT-ABORTED": "needs a multi-parameter change with an aborting error; not modelled yet",
    "XIST2-INCONSISTENT": "needs a shift factor (P979.3) != 0 variant; the simulator is right-aligned",
    "BMP-ORDER": "not decidable from a capture: a response block carries no PNU, so answers in another order "
                 "look like wrong values (docs/rules.md); the reversed answer still exists as BmpOrder for tests",
})
