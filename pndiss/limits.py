"""Bounded per-key tables (issue #18 item 1): a flood of distinct keys (random source MACs, ARs,
activity UUIDs, IP ids) must not grow memory without limit.

``BoundedDict`` is a dict with a capacity: inserting a new key beyond it evicts the oldest key
(insertion order, O(1)) and counts the eviction under a name; ``summary(analyzer)`` collects the
counts of every table an analysis created, so the summary says what was not tracked instead of
losing it silently. Capacities come from pndiss/settings.py (docs/settings.md).
"""
from __future__ import annotations

from collections import Counter, OrderedDict

# name -> (what one entry is, words for the summary note)
WHAT = {
    "streams": "cyclic streams (FrameID, source, destination)",
    "stations": "stations (MAC addresses)",
    "ars": "application relations (ARs)",
    "calls": "pending RPC requests",
    "reassembly": "reassembly buffers",
    "dcp_claims": "DCP name / IP claims",
    "profiles": "device profiles",
}
# the setting that bounds each table
SETTING = {"streams": "max_streams", "stations": "max_stations", "ars": "max_ars", "calls": "max_calls",
           "dcp_claims": "max_stations", "profiles": "max_stations"}


class BoundedDict(OrderedDict):
    """A dict of at most ``cap`` keys; ``d[k] = v`` for a new key at capacity evicts the oldest one
    and adds 1 to ``evicted`` (also ``on_evict(key, value)`` when given). Other dict methods are
    plain: only item assignment of new keys is bounded, which is how every table here grows.
    An OrderedDict: taking the oldest key of a plain dict that keeps losing its first keys scans
    the dead slots (O(cap) per eviction until the next resize), its linked list does not."""

    def __init__(self, cap: int, name: str, on_evict=None):
        super().__init__()
        self.cap = max(1, int(cap))
        self.name = name
        self.evicted = 0
        self.on_evict = on_evict

    def __setitem__(self, key, value) -> None:
        if len(self) >= self.cap and key not in self:
            old, v = self.popitem(last=False)
            self.evicted += 1
            if self.on_evict is not None:
                self.on_evict(old, v)
        OrderedDict.__setitem__(self, key, value)

    def setdefault(self, key, default=None):
        if key not in self:
            self[key] = default
        return self[key]


class Limits:
    """The bounded tables of one analysis, by name (several tables may share a name)."""

    def __init__(self):
        self.tables: list[BoundedDict] = []
        self.extra: Counter = Counter()   # evictions counted outside a BoundedDict (e.g. the fast path)

    def table(self, cap: int, name: str, on_evict=None) -> BoundedDict:
        d = BoundedDict(cap, name, on_evict)
        self.tables.append(d)
        return d

    def count(self, name: str, n: int = 1) -> None:
        self.extra[name] += n

    def evicted(self) -> dict[str, int]:
        # Tables that share a name hold the same keys (a stream's layout, its unmapped count, ...): the
        # name counts as its busiest table, not their sum, which would count one key once per table.
        out = Counter()
        for t in self.tables:
            out[t.name] = max(out[t.name], t.evicted)
        out.update(self.extra)
        return {k: v for k, v in out.items() if v}


def of(analyzer) -> Limits:
    """The analyzer's Limits; a stand-in analyzer without one (tests) gets its own."""
    lim = getattr(analyzer, "limits", None)
    if lim is None:
        lim = analyzer.limits = Limits()
    return lim


def summary(analyzer) -> dict:
    """{"evicted": {name: n}, "notes": ["12,345 stations (MAC addresses) beyond the limit of 10,000: not tracked", ...]}"""
    s = analyzer.settings
    ev = of(analyzer).evicted()
    notes = []
    for name, n in sorted(ev.items()):
        key = SETTING.get(name)
        cap = getattr(s, key, None) if key else None
        notes.append(f"{n:,} {WHAT.get(name, name)} beyond the limit"
                     + (f" of {cap:,}" if cap else "") + ": oldest not tracked"
                     + (f" (setting {key})" if key else ""))
    return {"evicted": ev, "notes": notes}
