"""Event stream helpers for the machine sinks: a violation stamped with its frame's time, and the
--station / --time scope.

A violation is often decided frames after the frame it names (deadlines, the controller's earlier
setpoint frame); its checker stamps the deciding time. ``FrameTimes`` remembers the time of the
last 65,536 frame numbers it saw (a fixed ring: constant memory) and puts the named frame's time on
the violation, so ``ts_ns`` always belongs to ``frame``.
"""
from __future__ import annotations

import re
import time

RING = 1 << 16


def json_default(o):
    """What JSON cannot say natively, as every JSONL / summary writer says it: bytes as hex, sets and
    tuples as lists, anything else as its text."""
    if isinstance(o, (bytes, bytearray, memoryview)):
        return bytes(o).hex()
    if isinstance(o, (set, frozenset, tuple)):
        return list(o)
    return str(o)


class FrameTimes:
    def __init__(self):
        self.frames = [0] * RING
        self.times = [0] * RING

    def fix(self, ev: dict) -> dict:
        fn = ev.get("frame")
        if fn.__class__ is not int:
            return ev
        i = fn & (RING - 1)
        if ev["kind"] == "violation":
            if self.frames[i] == fn and ev.get("ts_ns") != self.times[i]:
                ev = dict(ev)
                ev["ts_ns"] = self.times[i]
        elif self.frames[i] != fn:
            self.frames[i] = fn
            self.times[i] = ev["ts_ns"]
        return ev


class ColumnFrameTimes(FrameTimes):
    """FrameTimes that also learns from rows of frames (the column JSONL writers: pndiss/jsonl_sink.py),
    its ring as NumPy arrays so a batch of rows is one assignment."""

    def __init__(self):
        import numpy as np
        self.frames = np.zeros(RING, np.int64)
        self.times = np.zeros(RING, np.int64)

    def fix(self, ev: dict) -> dict:   # FrameTimes.fix on the arrays (their items are NumPy ints)
        fn = ev.get("frame")
        if fn.__class__ is not int or not -(1 << 63) <= fn < 1 << 63:
            return ev
        i = fn & (RING - 1)
        if ev["kind"] == "violation":
            if int(self.frames[i]) == fn and ev.get("ts_ns") != int(self.times[i]):
                ev = dict(ev)
                ev["ts_ns"] = int(self.times[i])
        elif int(self.frames[i]) != fn and ev["ts_ns"].__class__ is int and -(1 << 63) <= ev["ts_ns"] < 1 << 63:
            self.frames[i] = fn
            self.times[i] = ev["ts_ns"]
        return ev

    def rows(self, frames, times) -> None:
        """What ``fix`` would have learnt from one event of each of these frames (in frame order)."""
        if len(frames) > RING:
            frames, times = frames[-RING:], times[-RING:]
        i = frames & (RING - 1)
        new = self.frames[i] != frames
        self.frames[i[new]] = frames[new]
        self.times[i[new]] = times[new]


def _utc(ns: int) -> str:
    return time.strftime("%Y-%m-%dT%H:%M:%S", time.gmtime(ns // 1_000_000_000)) + f".{ns % 1_000_000_000:09d}"[:7]


def _mac(s: str) -> str | None:
    s = s.strip().lower().replace("-", ":")
    return s if re.fullmatch(r"([0-9a-f]{2}:){5}[0-9a-f]{2}", s) else None


_MAC_FIELDS = ("device_mac", "controller_mac", "src", "dst", "mac")


def _when(text: str, what: str):
    """Seconds (relative, float) or an absolute UTC time (ns)."""
    from .errors import UsageError
    text = text.strip()
    if not text:
        return None
    try:
        return ("rel", float(text))
    except ValueError:
        pass
    m = re.fullmatch(r"(\d{4}-\d{2}-\d{2})[T ](\d{2}:\d{2}:\d{2})(\.\d+)?Z?", text)
    if not m:
        raise UsageError(f"--time: {what} {text!r} is neither seconds since the first frame nor a UTC time "
                         "like 2026-01-01T08:00:00.5")
    import calendar   # (only a --time bound needs it: imported here, not at every start)
    sec = calendar.timegm(time.strptime(f"{m.group(1)} {m.group(2)}", "%Y-%m-%d %H:%M:%S"))
    frac = m.group(3) or ".0"
    return ("abs", sec * 1_000_000_000 + int(round(float(frac) * 1e9)))


class Scope:
    """--station NAME|MAC and --time FROM..TO: which events and violations are in scope."""

    def __init__(self, station: str | None, span):
        self.station = station
        self.mac = _mac(station) if station else None
        self.macs: set[str] = {self.mac} if self.mac else set()
        self.span = span
        self.a = None

    @classmethod
    def from_args(cls, station: str | None, time_range: str | None) -> "Scope | None":
        from .errors import UsageError
        if station is None and time_range is None:
            return None
        span = None
        if time_range is not None:
            lo, sep, hi = time_range.partition("..")
            if not sep:
                raise UsageError(f"--time {time_range!r}: expected FROM..TO (either side may be empty)")
            span = (_when(lo, "FROM"), _when(hi, "TO"))
            if span[0] is not None and span[1] is not None and span[0][0] == span[1][0] and span[0][1] > span[1][1]:
                raise UsageError(f"--time {time_range!r}: FROM is after TO")
        return cls(station, span)

    def unmatched(self, analyzer) -> str | None:
        """Why this scope holds nothing of the capture -- a station no frame names, a time range outside it -- or
        None. A typo in a CI gate (--station xac77-l --fail-on error) must not pass as "no violations"."""
        a = analyzer
        if self.station is not None:
            encs = a.cyclic.summary()["encoders"]
            ars = list(a.session.ars.values())
            # (a controller's name only as DCP names it: keep() maps names to MACs by the station table)
            names = {s.get("name") for s in a.stations.by_mac.values()} | {e.get("station") for e in encs} | {
                ar.get("station") for ar in ars}
            # every MAC the capture shows a station by: DCP / LLDP / alarms, ARs, encoder axes, cyclic streams
            macs = set(a.stations.by_mac) | {e.get("device_mac") for e in encs} | {
                ar.get(k) for ar in ars for k in ("device_mac", "controller_mac")} | {
                m for key in a.cyclic.gaps.streams for m in key[1:]}
            if self.station.lower() not in {str(n).lower() for n in names if n} and (self.mac is None or self.mac not in macs):
                known = sorted(n for n in names if n) or sorted(m for m in macs if m)
                ip = re.fullmatch(r"\d{1,3}(\.\d{1,3}){3}", self.station.strip())
                return (f"--station {self.station}: "
                        + ("takes a NameOfStation or a MAC address, not an IP address" if ip else
                           "no station of that name or MAC in the capture")
                        + (f" (stations: {', '.join(known[:12])}{' ...' if len(known) > 12 else ''})" if known else ""))
        if self.span is not None and a.first_ts is not None:
            lo, hi = self.span
            first, last = a.first_ts, a.last_ts
            if (lo is not None and self._ns(lo) > last) or (hi is not None and self._ns(hi) < first):
                return (f"--time: the range holds no frame of the capture (it spans 0 to {(last - first) / 1e9:,.3f} s, "
                        "seconds since its first frame)")
        return None

    def bind(self, analyzer) -> None:
        self.a = analyzer

    def text(self) -> str:
        """The scope as the user gave it: 'station X, time FROM..TO'."""
        out = []
        if self.station:
            out.append(f"station {self.station}")
        if self.span:
            out.append("time " + "..".join("" if w is None else (f"{w[1]:g} s" if w[0] == "rel" else
                                                                 _utc(w[1])) for w in self.span))
        return ", ".join(out)

    def describe(self) -> dict:
        d = {}
        if self.station:
            d["station"] = self.station
        if self.span:
            d["time"] = [None if w is None else {"relative_s" if w[0] == "rel" else "utc_ns": w[1]}
                         for w in self.span]
        return d

    def _ns(self, w) -> int:
        if w[0] == "abs":
            return w[1]
        t0 = self.a.first_ts if self.a is not None and self.a.first_ts is not None else 0
        return t0 + int(w[1] * 1e9)

    def keep(self, ev: dict) -> bool:
        if self.span is not None:
            ts = ev.get("ts_ns")
            lo, hi = self.span
            if ts.__class__ is int and ((lo is not None and ts < self._ns(lo)) or (hi is not None and ts > self._ns(hi))):
                return False
        if self.station is None:
            return True
        st = ev.get("station")
        if st.__class__ is str and st.lower() == self.station.lower():   # (NameOfStation: a DNS name, any case)
            mac = ev.get("device_mac")
            if mac and mac not in self.macs:
                self.macs.add(mac)  # the name's MAC: frames that carry only MACs are in scope too
            return True
        for k in _MAC_FIELDS:
            v = ev.get(k)
            if v is not None and v in self.macs:
                return True
        if ev.get("side") == "controller" and ev.get("kind") == "violation" and self.macs and self.a is not None:
            # a controller-side rule names the device's axis: in scope of the controller of the device's AR(s)
            dev = ev.get("device_mac")
            if dev and self.macs & self.a.session.controllers_of(dev):
                return True
        if not self.mac and self.a is not None and not self.macs:
            for mac, s in self.a.stations.by_mac.items():
                if str(s.get("name") or "").lower() == self.station.lower():
                    self.macs.add(mac)
        return False
