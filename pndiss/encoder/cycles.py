"""One cycle (``Cycle``) and a stretch of consecutive cycles (``Columns``) as the value rules read them:
the per-cycle predicates of encoder/value_rules.py take a Cycle, their NumPy twins the Columns."""
from __future__ import annotations

import numpy as np

SAFE = 1 << 62                                   # beyond this the NumPy twins do not judge (int64 arithmetic)


def serr_state(SERR: int, X2) -> int:
    """The value of the checker's ``sensor_error`` timeline state a cycle leaves (Checker._timeline):
    the error code in XIST2 (1 without XIST2) during a sensor error, else 0."""
    return (X2 if X2 is not None else 1) if SERR else 0


class Cycle:
    """What the value rules read of one cycle (ints; None where the telegram has no such signal)."""

    __slots__ = ("SERR", "ATX", "PKA", "PDONE", "DLS", "X1", "X2", "X3", "NIST", "pos2", "ppos2", "motion", "pmotion",
                 "pX3", "zsw2", "g1zsw", "has_g1", "started_D", "serr_state", "pserr_state", "pPKA")

    @classmethod
    def of(cls, ac: dict, pa: dict | None, has_g1: bool, started_D: bool = False) -> "Cycle":
        c = cls()
        c.zsw2 = zsw2 = ac.get("zsw2_enc", 0)
        c.g1zsw = g1zsw = ac.get("g1_zsw", 0)
        c.DLS = zsw2 >> 12
        c.PDONE = (g1zsw >> 12) & 1
        c.ATX = ATX = (g1zsw >> 13) & 1
        c.PKA = (g1zsw >> 14) & 1
        c.SERR = SERR = (g1zsw >> 15) & 1
        c.X1, c.X2, c.X3 = X1, X2, X3 = ac.get("g1_xist1"), ac.get("g1_xist2"), ac.get("g1_xist3")
        c.NIST = ac.get("nist_b", ac.get("nist_a"))
        # position of the preset arithmetic and continuity: X3 in telegram 84, else X2 while ATX (§1.6, §4.3)
        c.pos2 = X3 if X3 is not None else (X2 if ATX and not SERR else None)
        c.motion = X1 if X1 is not None else X3
        c.serr_state = serr_state(SERR, X2)
        if pa is None:
            c.ppos2 = c.pmotion = c.pX3 = c.pserr_state = c.pPKA = None
        else:
            pz = pa.get("g1_zsw", 0)
            c.ppos2 = pa.get("g1_xist3") if "g1_xist3" in pa else (
                pa.get("g1_xist2") if (pz >> 13) & 1 and not (pz >> 15) & 1 else None)
            c.pmotion = pa.get("g1_xist1") if X1 is not None else pa.get("g1_xist3")
            c.pX3 = pa.get("g1_xist3")
            c.pserr_state = serr_state((pz >> 15) & 1, pa.get("g1_xist2"))
            c.pPKA = (pz >> 14) & 1
        c.has_g1 = has_g1
        c.started_D = started_D
        return c


class Columns:
    """The same for a stretch of m consecutive cycles (NumPy columns). Row 0's previous cycle is the
    checker's last one (k.prev_ac). Columns holding a value beyond SAFE become Python-int object arrays
    so the twins stay exact (those rows go to the checker anyway)."""

    def __init__(self, k, cols: dict, has_g1: bool):
        def col(name):
            a = cols.get(name)
            if a is None:
                return None
            a = np.asarray(a)
            if a.dtype == np.uint64 and len(a) and int(a.max()) >= SAFE:
                return a.astype(object)
            return a.astype(np.int64)
        zsw2, g1zsw = col("zsw2_enc"), col("g1_zsw")
        m = len(next(a for a in cols.values() if a is not None)) if cols else 0
        self.m = m
        zero = np.zeros(m, dtype=np.int64)
        self.zsw2 = zsw2 = zero if zsw2 is None else zsw2
        self.g1zsw = g1zsw = zero if g1zsw is None else g1zsw
        self.DLS = zsw2 >> 12
        self.PDONE, self.ATX, self.PKA, self.SERR = ((g1zsw >> b) & 1 for b in (12, 13, 14, 15))
        self.X1, self.X2, self.X3 = X1, X2, X3 = col("g1_xist1"), col("g1_xist2"), col("g1_xist3")
        nb = col("nist_b")
        self.NIST = nb if nb is not None else col("nist_a")
        self.has_g1 = has_g1
        pa = k.prev_ac
        self.started_D = k.started_D | (np.cumsum(self.DLS != 0) > 0)

        def prev(arr, name):
            """arr shifted by one row; row 0 from the checker's last cycle; and where that exists."""
            if arr is None:
                return None, None
            p = np.empty(m, dtype=object if arr.dtype == object else np.int64)
            p[1:] = arr[:-1]
            have = np.ones(m, dtype=bool)
            v0 = None if pa is None else pa.get(name)
            if v0 is None:
                p[0], have[0] = 0, False
            elif v0 >= SAFE and p.dtype != object:
                p = p.astype(object)
                p[0] = v0
            else:
                p[0] = v0
            return p, have
        self.pX3, pX3_have = prev(X3, "g1_xist3")
        pz = np.empty(m, dtype=np.int64)
        pz[1:] = g1zsw[:-1]
        pz[0] = 0 if pa is None else pa.get("g1_zsw", 0)
        atx_ok = (self.ATX == 1) & (self.SERR == 0)
        self.pPKA = (pz >> 14) & 1
        if X3 is not None:
            self.pos2, self.pos2_ok = X3, np.ones(m, dtype=bool)
            self.ppos2, self.ppos2_ok = self.pX3, pX3_have
        elif X2 is not None:
            self.pos2, self.pos2_ok = X2, atx_ok
            self.ppos2, have = prev(X2, "g1_xist2")
            self.ppos2_ok = have & (((pz >> 13) & 1) == 1) & (((pz >> 15) & 1) == 0)
        else:
            self.pos2 = self.ppos2 = None
        if X1 is not None:
            self.motion = X1
            self.pmotion, self.pmotion_ok = prev(X1, "g1_xist1")
        elif X3 is not None:
            self.motion = X3
            self.pmotion, self.pmotion_ok = self.pX3, pX3_have
        else:
            self.motion = self.pmotion = None
        self.pX3_ok = pX3_have
        # the sensor_error timeline value of each row and of the row before (-1: no previous cycle)
        self.serr_state = np.where(self.SERR == 1, X2 if X2 is not None else 1, 0)
        self.pserr_state = np.empty(m, dtype=np.int64)
        self.pserr_state[1:] = self.serr_state[:-1]
        if m:
            self.pserr_state[0] = -1 if pa is None else serr_state((int(pz[0]) >> 15) & 1, pa.get("g1_xist2"))
