"""The violation catalogue as data (pndiss/data/rules.json, generated from spec/behaviour.md §9
by tools/gen_rules.py) and the one constructor every part uses for violation events.

A violation event (JSONL contract, docs/events.md): ``kind`` = "violation", ``rule`` (catalogue
ID), ``side`` ("controller" | "encoder"), ``severity`` ("error" | "warning" | "info"),
``frame`` (first frame), ``last_frame``, ``message`` (observed vs expected), ``source``.
"""
from __future__ import annotations

import json
import os

_PATH = os.path.join(os.path.dirname(__file__), "data", "rules.json")
with open(_PATH, encoding="utf-8") as _f:
    RULES: dict[str, dict] = {r["id"]: r for r in json.load(_f)}

SEVERITIES = ("info", "warning", "error")


def violation(rule: str, frame: int, ts_ns: int, message: str, *, last_frame: int | None = None,
              side: str | None = None, **extra) -> dict:
    """Build a violation event; ``side`` is needed only for rules the catalogue gives to either side."""
    r = RULES[rule]  # KeyError = a typo in a rule ID: a bug, caught by the tests
    s = side or r["side"]
    if s not in ("controller", "encoder"):
        raise ValueError(f"{rule}: the catalogue leaves the side open; pass side=")
    ev = {"frame": frame, "ts_ns": ts_ns, "kind": "violation", "rule": rule, "side": s,
          "severity": r["severity"], "last_frame": frame if last_frame is None else last_frame,
          "message": message, "source": r["source"]}
    ev.update(extra)
    return ev
