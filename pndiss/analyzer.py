"""The pipeline: frames in, events out, every frame accounted for.

``Analyzer.feed`` takes one captured frame, dispatches it by link layer / EtherType / FrameID to
the protocol modules and hands every resulting event to the sink. Each frame ends up in exactly
one bucket: ``decoded``, ``not_profinet`` or ``malformed`` (with a ``malformed`` event that
names the frame, the layer and the reason).

Events are plain dicts with at least ``frame``, ``ts_ns`` and ``kind`` (docs/events.md).
"""
from __future__ import annotations

from collections import Counter
from typing import Callable

from . import stations as st
from .activity import Activity
from .proto import alarm, dcp, lldp, ptcp, rt
from .proto.common import Malformed, mac
from .proto.eth import decode_link
from .settings import Settings

ETH_PNRT = 0x8892
ETH_LLDP = 0x88CC
ETH_MRP = 0x88E3
ETH_IPV4 = 0x0800

MAX_KEPT_MALFORMED = 1000  # the summary keeps the first ones; the JSONL stream has all


class Analyzer:
    def __init__(self, settings: Settings | None = None, sink: Callable[[dict], None] | None = None):
        from .session import SessionTracker  # PNIO-CM / AR map (imports records)
        from .cyclic import CyclicTracker    # telegrams + reference encoder

        self.settings = settings or Settings()
        self.sink = sink
        self.counts = {"decoded": 0, "not_profinet": 0, "malformed": 0}
        self.kinds: Counter = Counter()
        # every violation, whatever emitted it (encoder checker, DCP, records): the one counting point of
        # the summary's violations_by_severity, the report and --fail-on (issue #12 item 5)
        self.violations: dict[str, dict] = {}
        self.frame_classes: Counter = Counter()
        self.malformed: list[dict] = []
        self.frames = 0
        self.first_ts: int | None = None
        self.last_ts: int | None = None
        self.stations = st.Stations()
        self.activity = Activity()
        self.dcp_tracker = dcp.DcpTracker()
        self.session = SessionTracker(self)
        self.cyclic = CyclicTracker(self)
        # (frame, ts) of the frame being processed, for events emitted by trackers
        self.cur_frame = 0
        self.cur_ts = 0

    # -- output ---------------------------------------------------------------------------
    def emit(self, ev: dict) -> None:
        self.kinds[ev["kind"]] += 1
        if ev["kind"] == "violation":
            self._count_violation(ev)
        if self.sink is not None:
            self.sink(ev)

    def _count_violation(self, ev: dict) -> None:
        v = self.violations.get(ev["rule"])
        if v is None:
            v = self.violations[ev["rule"]] = {"events": 0, "cycles": 0, "first_frame": ev["frame"],
                                               "severity": ev["severity"], "side": ev.get("side"),
                                               "message": ev.get("message"), "not_axis": 0}
        v["events"] += 1
        v["cycles"] += ev.get("cycles") or 1
        v["first_frame"] = min(v["first_frame"], ev["frame"])
        if ev.get("slot") is None:  # no encoder axis names it (DCP, ...): the report lists it on its own
            if not v["not_axis"]:
                v["not_axis_first"] = (ev["frame"], ev.get("side"), ev.get("message"))
            v["not_axis"] += 1

    def violations_by_severity(self) -> dict:
        sev = {"error": 0, "warning": 0, "info": 0}
        for v in self.violations.values():
            sev[v["severity"]] = sev.get(v["severity"], 0) + v["events"]
        return sev

    def event(self, kind: str, **fields) -> dict:
        """Emit an event stamped with the current frame and time."""
        ev = {"frame": self.cur_frame, "ts_ns": self.cur_ts, "kind": kind}
        ev.update(fields)
        self.emit(ev)
        return ev

    def _malformed(self, fn: int, ts: int, layer: str, reason: str) -> None:
        ev = {"frame": fn, "ts_ns": ts, "kind": "malformed", "layer": layer, "reason": reason}
        if len(self.malformed) < MAX_KEPT_MALFORMED:
            self.malformed.append(ev)
        self.emit(ev)

    # -- input ----------------------------------------------------------------------------
    def feed(self, fn: int, ts: int, linktype: int, data: bytes) -> None:
        self.frames += 1
        self.cur_frame, self.cur_ts = fn, ts
        if self.first_ts is None:
            self.first_ts = ts
        self.last_ts = ts
        try:
            dst, src, et, off, tags = decode_link(linktype, data)
            if et == ETH_PNRT:
                status = self._pn_rt(fn, ts, data, off, mac(src), mac(dst), tags, udp=False)
            elif et == ETH_LLDP:
                status = self._lldp(fn, ts, data, off, mac(src), mac(dst))
            elif et == ETH_IPV4:
                status = self.session.on_ipv4(fn, ts, data, off, mac(src), mac(dst))
            elif et == ETH_MRP:
                status = self._mrp(fn, ts, data, off, mac(src), mac(dst))
            else:
                status = "not_profinet"
        except Malformed as e:
            self._malformed(fn, ts, e.layer, e.reason)
            status = "malformed"
        self.counts[status] += 1

    def finish(self) -> None:
        """End of capture: flush pending reassemblies, open handshakes and state machines."""
        self.session.finish()
        self.cyclic.finish()

    # -- dispatch ---------------------------------------------------------------------------
    def _pn_rt(self, fn, ts, data, off, src, dst, tags, udp: bool, end: int | None = None) -> str:
        """PN-RT PDU at data[off:end] (end defaults to the end of the frame, pad included)."""
        pdu = data if end is None else data[:end]
        if len(pdu) - off < 2:
            raise Malformed("pn_rt", "PDU too short for a FrameID")
        frame_id = (pdu[off] << 8) | pdu[off + 1]
        cls, cyclic = rt.classify(frame_id, udp)
        self.frame_classes[cls] += 1
        ev = {"frame": fn, "ts_ns": ts, "kind": "rt", "src": src, "dst": dst,
              "frame_id": frame_id, "frame_class": cls}
        if tags:
            ev["vlan"] = [{"tpid": t[0], "priority": t[1], "dei": t[2], "id": t[3]} for t in tags]
        if cyclic:
            if len(pdu) - off < 6:
                self.emit(ev)
                raise Malformed("pn_rt", f"cyclic PDU of {len(pdu) - off} bytes has no room for the APDU status")
            ev.update(rt.decode_apdu_status(pdu, off))
            self.emit(ev)
            self.cyclic.on_frame(ev, pdu, off + 2)
            return "decoded"
        self.emit(ev)
        body = off + 2
        if cls.startswith("DCP"):
            d = dcp.decode(pdu, body, frame_id)
            d.update(frame=fn, ts_ns=ts, kind="dcp", src=src, dst=dst, frame_id=frame_id)
            extras = d.pop("events", ())  # e.g. invalid NameOfStation
            self.emit(d)
            self.activity.on_event(d)
            self.stations.from_dcp(d, src, dst)
            for extra in extras:
                if extra["kind"] == "violation":
                    extra.setdefault("last_frame", fn)
                self.event(**extra)
            for v in self.dcp_tracker.on_dcp(d, src, dst):  # duplicate name, occupied IP
                self.emit(v)
        elif cls.startswith("Alarm"):
            d = alarm.decode(pdu, body, frame_id)
            d.update(frame=fn, ts_ns=ts, kind="alarm", src=src, dst=dst, frame_id=frame_id)
            self.emit(d)
            if d.get("pdu_type", {}).get("type") == alarm.ERR:
                self.session.on_rta_error(fn, ts, src, dst)   # the AR is aborted
            self.activity.on_event(d)
            self.stations.seen(src)
        elif cls in rt.PTCP_CLASSES:
            d = ptcp.decode(pdu, body, frame_id)
            d.update(frame=fn, ts_ns=ts, kind="ptcp", src=src, dst=dst, frame_id=frame_id, frame_class=cls)
            self.emit(d)
            self.activity.on_event(d)
        return "decoded"

    def _lldp(self, fn, ts, data, off, src, dst) -> str:
        d = lldp.decode(data, off)
        d.update(frame=fn, ts_ns=ts, kind="lldp", src=src, dst=dst)
        self.emit(d)
        self.activity.on_event(d)
        self.stations.from_lldp(d, src)
        return "decoded"

    def _mrp(self, fn, ts, data, off, src, dst) -> str:
        d = lldp.decode_mrp(data, off)
        d.update(frame=fn, ts_ns=ts, kind="mrp", src=src, dst=dst)
        self.emit(d)
        return "decoded"

    # -- results ----------------------------------------------------------------------------
    def report_sections(self) -> list:
        """The report's table of violations not tied to an encoder (DCP, records, ...)."""
        from .violation_report import sections
        return sections(self.violations)

    def summary(self) -> dict:
        return {
            "frames": self.frames,
            "accounting": dict(self.counts),
            "first_ts_ns": self.first_ts,
            "last_ts_ns": self.last_ts,
            "events": dict(self.kinds),
            "frame_classes": dict(self.frame_classes),
            "stations": self.stations.as_list(),
            "activity": self.activity.summary(),
            "malformed": self.malformed,
            "violations": {"by_severity": self.violations_by_severity(),
                           "by_rule": {r: dict(v) for r, v in sorted(self.violations.items(),
                                                                      key=lambda kv: kv[1]["first_frame"])}},
            "session": self.session.summary(),
            "cyclic": self.cyclic.summary(),
            "settings": self.settings.as_dict(),
        }


def analyze_file(path: str, settings: Settings | None = None, sink=None, progress=None) -> Analyzer:
    """Run the whole pipeline over a capture file. Raises capture.CaptureError on bad files
    (after feeding every complete frame, so ``exc.frames`` frames were analysed)."""
    from .capture import open_capture

    from .capture import CaptureError

    from . import fast

    a = Analyzer(settings, sink)
    try:
        if fast.enabled(a.settings, sink):
            fast.run_file(a, path, progress)   # same results: steady runs batched, cyclic frames without the dispatch
        else:
            frames = open_capture(path)
            if progress is not None:
                frames = _with_progress(frames, progress)
            for fn, ts, lt, data in frames:
                a.feed(fn, ts, lt, data)
    except CaptureError as e:
        a.finish()
        e.analyzer = a
        raise
    a.finish()
    return a


def _with_progress(frames, progress):
    """Pass frames through, calling progress(frame number) every 4096 frames."""
    for f in frames:
        yield f
        if not f[0] & 0xFFF:
            progress(f[0])
