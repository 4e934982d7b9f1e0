"""What `pndiss report` needs from one analysis run, gathered as an event sink.

``ReportCollector.on_event`` sits where every other output sits (analyzer.analyze_file's sink):
the whole-capture ``plot.Timeline`` (position/speed/bits per axis), the violations, parameter
accesses and records (bounded lists), and for a bounded number of violations the telegram events
of their axis around their frames: a per-axis ring of recent telegram events gives the frames
before the violation (it is often decided later than the frame it names), and the context keeps
collecting until ``after`` frames past its last frame. Plots are made from these afterwards
(pndiss/html_report.py).
"""
from __future__ import annotations

from collections import deque

from .plot import Timeline

MAX_ROWS = 2000          # violations / parameter accesses / records kept for the tables
MAX_CONTEXTS = 24        # violations that get a plot of their own
PER_RULE = 2             # ... at most this many of one rule (the first ones)
RING = 1500              # telegram events remembered per axis


def axis_key(ev: dict) -> tuple | None:
    """(device MAC, slot, subslot) as plot.Timeline keys its encoders; None without an axis."""
    if ev.get("slot") is None or ev.get("device_mac") is None:
        return None
    return (str(ev.get("device_mac")), str(ev.get("slot")), str(ev.get("subslot")))


class Context:
    """One violation and the telegram events of its axis around it."""
    __slots__ = ("violation", "key", "events", "until")

    def __init__(self, violation: dict, key: tuple, events: list, until: int):
        self.violation, self.key, self.events, self.until = violation, key, events, until


class ReportCollector:
    def __init__(self, before: int = 60, after: int = 60, max_points: int = 4000):
        self.timeline = Timeline(max_points)
        self.before, self.after = before, after
        self.violations: list[dict] = []
        self.n_violations = 0
        self.params: list[dict] = []
        self.records: list[dict] = []
        self.n_params = self.n_records = 0
        self.contexts: list[Context] = []
        self._per_rule: dict[str, int] = {}
        self._recent: dict[tuple, deque] = {}
        self._open: list[Context] = []

    def on_event(self, ev: dict) -> None:
        self.timeline.on_event(ev)
        kind = ev.get("kind")
        if kind == "telegram":
            self._telegram(ev)
        elif kind == "violation":
            self.n_violations += 1
            if len(self.violations) < MAX_ROWS:
                self.violations.append(ev)
            self._context(ev)
        elif kind == "param":
            self.n_params += 1
            if len(self.params) < MAX_ROWS:
                self.params.append(ev)
        elif kind in ("record", "record_result"):
            self.n_records += 1
            if len(self.records) < MAX_ROWS:
                self.records.append(ev)

    def _telegram(self, ev: dict) -> None:
        key = axis_key(ev)
        if key is None:
            return
        ring = self._recent.get(key)
        if ring is None:
            ring = self._recent[key] = deque(maxlen=RING)
        ring.append(ev)
        if self._open:
            fn = ev.get("frame") or 0
            for c in list(self._open):
                if c.key == key:
                    if fn > c.until:
                        self._open.remove(c)
                    else:
                        c.events.append(ev)

    def _context(self, ev: dict) -> None:
        key = axis_key(ev)
        rule = str(ev.get("rule"))
        if key is None or len(self.contexts) >= MAX_CONTEXTS or self._per_rule.get(rule, 0) >= PER_RULE:
            return
        fn = ev.get("frame") if isinstance(ev.get("frame"), int) else 0
        last = ev.get("last_frame") if isinstance(ev.get("last_frame"), int) else fn
        lo, until = fn - self.before, max(fn, last) + self.after
        events = [e for e in self._recent.get(key, ()) if lo <= (e.get("frame") or 0) <= until]
        c = Context(ev, key, events, until)
        self.contexts.append(c)
        self._per_rule[rule] = self._per_rule.get(rule, 0) + 1
        newest = self._recent[key][-1].get("frame") or 0 if self._recent.get(key) else 0
        if newest < until:
            self._open.append(c)
