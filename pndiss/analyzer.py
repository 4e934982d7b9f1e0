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

from . import iodata, limits
from . import stations as st
from .activity import Activity
from .proto import alarm, dcp, dcp_rules, lldp, ptcp, rt, rtfrag
from .proto.common import Malformed, mac
from .proto.eth import decode_link
from .settings import Settings
from .verdict import ViolationLog

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
        # per-frame events (rt / telegram dicts) are built only when a sink wants them (the driver decides from
        # the sinks' capabilities, pndiss/driver.py; a plain sink gets every kind)
        self.frame_events = sink is not None
        self._held = None     # events held while the engine walks stream groups (hold / release)
        self._hold_fn = 0
        self.at = 0           # the frame whose processing emitted the event being emitted (sinks merge on it)
        # the frame whose telegram rows a column sink already got (batches.Collector sets it): an event of
        # that frame emitted before its first row goes before the rows (a relabel's or a profile's events)
        self.rows_at = -1
        self.after_rows = True
        self._releasing = None
        self.counts = {"decoded": 0, "not_profinet": 0, "malformed": 0}
        self.kinds: Counter = Counter()
        self.frame_classes: Counter = Counter()
        self.malformed: list[dict] = []
        self.limits = limits.Limits()   # bounded per-key tables and what they evicted
        self.frames = 0
        self.first_ts: int | None = None
        self.last_ts: int | None = None
        cap = self.settings.max_stations
        self.stations = st.Stations(self.limits.table(cap, "stations"))
        self.activity = Activity()
        self.violations = ViolationLog()
        # its per-name / per-IP / per-MAC claims: bounded like the stations
        self.dcp_tracker = dcp_rules.DcpTracker(lambda: self.limits.table(cap, "dcp_claims"))
        self.session = SessionTracker(self)
        self.cyclic = CyclicTracker(self)
        self.rt_frags = rtfrag.Reassembler()  # FRAG_PDUs (FrameID 0xFF80-0xFF8F)
        # (frame, ts) of the frame being processed, for events emitted by trackers
        self.cur_frame = 0
        self.cur_ts = 0
        from .capture import ReadInfo
        self.reader = ReadInfo()   # filled by the capture reader: input hash, clamped time stamps

    # -- output ---------------------------------------------------------------------------
    def emit(self, ev: dict) -> None:
        if self._held is not None:
            self._held.append((self._hold_fn, len(self._held), ev, self.rows_at == self._hold_fn))
            return
        kind = ev["kind"]
        self.kinds[kind] += 1
        if kind == "violation":  # the verdict (pndiss/verdict.py) sees every one, with or without a sink
            self.violations.add(ev)
        if self.sink is not None:
            if self._releasing is None:
                self.at = self.cur_frame
                self.after_rows = self.rows_at == self.cur_frame
            self.sink(ev)

    # -- the engine walks independent stream groups one after the other (pndiss/engine.py): their events
    # are held, tagged with the frame being processed, and released in the reference path's order
    def hold(self):
        prev, self._held = self._held, []
        return prev

    def hold_at(self, fn: int) -> None:
        self._hold_fn = fn

    def release(self, prev) -> None:
        held, self._held = self._held, prev
        if held:
            held.sort(key=lambda h: (h[0], h[1]))
            self._releasing = True
            try:
                for h in held:
                    self.at, self.after_rows = h[0], h[3]
                    self.emit(h[2])
            finally:
                self._releasing = None

    def violations_by_severity(self) -> dict:
        return self.violations.by_severity()

    def event(self, kind: str, **fields) -> dict:
        """Emit an event stamped with the current frame and time."""
        ev = {"frame": self.cur_frame, "ts_ns": self.cur_ts, "kind": kind}
        ev.update(fields)
        self.emit(ev)
        return ev

    def add_malformed(self, fn: int, ts: int, layer: str, reason: str) -> None:
        """A malformed frame found by another module (session reassembly, the bulk engines)."""
        self._malformed(fn, ts, layer, reason)

    def pn_rt(self, fn, ts, data, off, src, dst, tags, udp: bool, end: int | None = None) -> str:
        """PROFINET RT data carried elsewhere (RT over UDP, session.py)."""
        return self._pn_rt(fn, ts, data, off, src, dst, tags, udp, end)

    def _malformed(self, fn: int, ts: int, layer: str, reason: str) -> None:
        cut = self.reader.cut_of(fn)
        if cut is not None:   # not the sender's fault: the capture kept only the first bytes (tshark: "Packet size limited")
            reason = f"{reason} (the capture cut the frame: {cut[0]} of {cut[1]} bytes kept, snap length)"
        ev = {"frame": fn, "ts_ns": ts, "kind": "malformed", "layer": layer, "reason": reason}
        # the first MAX_KEPT_MALFORMED in frame order: the engine processes a device's DCE/RPC datagrams and alarms
        # before other devices' earlier frames (as gaps.GapTracker.keep)
        self.malformed.append(ev)
        if len(self.malformed) >= 2 * MAX_KEPT_MALFORMED:
            self.malformed.sort(key=lambda m: m["frame"])
            del self.malformed[MAX_KEPT_MALFORMED:]
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

    def count_inert(self, n: int, fn: int, ts: int, first_ts: int) -> None:
        """``n`` frames feed() would only count as not PROFINET (pndiss/engine.py: an IT network's TCP, ARP,
        IPv6 ... on the PROFINET segment), the last of them frame ``fn`` at ``ts``."""
        self.frames += n
        self.counts["not_profinet"] += n
        self.cur_frame, self.cur_ts = fn, ts
        if self.first_ts is None:
            self.first_ts = first_ts
        self.last_ts = ts

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
            if end is None and self.reader.cut_of(fn) is not None:
                # the APDU status (cycle counter, DataStatus) is the frame's last 4 bytes on the wire: not kept
                self.emit(ev)
                raise Malformed("pn_rt", "cyclic frame without its APDU status")
            ev.update(rt.decode_apdu_status(pdu, off))
            if self.frame_events:  # IOPS/IOCS of every submodule (pndiss/iodata.py), for event readers
                io = iodata.decode(self.session.lookup(frame_id, src, dst), pdu[off + 2:len(pdu) - 4])
                if io is not None:
                    ev["iodata"] = io
            self.emit(ev)
            self.cyclic.on_frame(ev, pdu, off + 2)
            return "decoded"
        if cls == "FRAG":  # RT fragmentation: header, reassembly, then the PDU it carried (pndiss/proto/rtfrag.py)
            f = ev["frag"] = rtfrag.decode(pdu, off + 2)
            whole, frames, problem = self.rt_frags.add(frame_id, fn, f, pdu[off + 4:])
            if problem:
                f["problem"] = problem
            if whole is not None:
                f["reassembled_frames"], f["reassembled_length"] = frames, len(whole)
            self.emit(ev)
            if whole is not None and len(whole) >= 4 and (whole[0] << 8) | whole[1] == 0x8892:
                return self._pn_rt(fn, ts, whole, 2, src, dst, tags, udp)
            return "decoded"
        self.emit(ev)
        body = off + 2
        if cls.startswith("DCP"):
            d = dcp.decode(pdu, body, frame_id, cut=end is None and self.reader.cut_of(fn) is not None)
            cut = d.pop("truncated", None)
            d.update(frame=fn, ts_ns=ts, kind="dcp", src=src, dst=dst, frame_id=frame_id)
            extras = d.pop("events", ())  # e.g. invalid NameOfStation
            self.emit(d)
            self.activity.on_event(d)
            changed = self.stations.from_dcp(d, src, dst)
            if changed is not None:
                # a device's identity arrived after its profile was decided (a capture started mid-session: the
                # DCP Identify of its reboot comes after the inferred AR): decided again for its next AR
                self.session.identity_changed(changed)
            for extra in extras:
                if extra["kind"] == "violation":
                    extra.setdefault("last_frame", fn)
                self.event(**extra)
            for v in self.dcp_tracker.on_dcp(d, src, dst):  # duplicate name, occupied IP
                self.emit(v)
            if cut:   # its whole blocks are used (a station's vendor and name), the frame counts as cut
                raise Malformed("dcp", cut)
        elif cls.startswith("Alarm"):
            d = alarm.decode(pdu, body, frame_id)
            d.update(frame=fn, ts_ns=ts, kind="alarm", src=src, dst=dst, frame_id=frame_id)
            self.emit(d)
            eps = (d.get("alarm_src_endpoint"), d.get("alarm_dst_endpoint"))
            if d.get("pdu_type", {}).get("type") == alarm.ERR:
                self.session.on_rta_error(fn, ts, src, dst, d.get("status"), eps)   # the AR is aborted
            else:
                self.session.on_alarm_endpoints(src, dst, eps)
                if d.get("alarm_type") is not None:
                    self.cyclic.on_alarm(d)   # a diagnosis of an encoder submodule (#48, #70)
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
        return sections(self.violations.by_rule)

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
            "malformed": sorted(self.malformed, key=lambda m: m["frame"])[:MAX_KEPT_MALFORMED],
            "violations": self.violations.totals(),
            "session": self.session.summary(),
            "cyclic": self.cyclic.summary(),
            "settings": self.settings.as_dict(),
            "input": self.reader.as_dict(),
            "limits": limits.summary(self),
        }


def analyze_file(path: str, settings: Settings | None = None, sink=None, progress=None,
                 verdict_hooks: dict | None = None) -> Analyzer:
    """Run the whole pipeline over a capture file (pndiss/driver.py with ``sink`` consuming every event
    kind). Raises capture.CaptureError on bad files after feeding every complete frame (``exc.analyzer``)."""
    from .driver import analyze

    return analyze(path, settings, [sink] if sink is not None else [], progress, verdict_hooks)


def _with_progress(frames, progress):
    """Pass frames through, calling progress(frame number) every 4096 frames."""
    for f in frames:
        yield f
        if not f[0] & 0xFFF:
            progress(f[0])
