"""PNIO-CM sessions: IPv4/UDP/DCE-RPC frames in; ``rpc``, ``ar``, ``record``, ``param`` events
out; the AR map (pndiss.armap) the cyclic decoder looks frames up in.

One tracker, one layer per module (as Wireshark's profinet plugin has one file per layer), each a
mixin of SessionTracker: session_rpc.py (IPv4 / UDP / DCE-RPC), session_ar.py (Connect, Release,
Control, AR phases, telegram assignment), session_records.py (record accesses, parameter pairing,
P922, device profile). This file holds the tracker's tables, the PNIO-CM dispatch and what the
other trackers ask of it.
"""
from __future__ import annotations

from collections import OrderedDict

from . import armap, limits
from .proto import dcerpc, ip
from .proto.eth import NO_DST
from .session_ar import ArLayer, ar_summary
from .session_records import MAX_CALLS, RecordLayer, param_pairer
from .session_rpc import PORT_RT_UDP, RpcLayer

RESEND_WINDOW_NS = 10_000_000_000   # a client resends an unanswered DCE/RPC request within seconds (wire.md §5.1)
EARLY_WINDOW_NS = 1_000_000_000     # a request stamped after its own response by less: interfaces' clocks apart


class SessionTracker(RpcLayer, ArLayer, RecordLayer):
    def __init__(self, analyzer):
        self.a = analyzer
        s = analyzer.settings
        self.ipr = ip.IpReassembler()
        self.rpcr = dcerpc.FragmentReassembler()
        lim = limits.of(analyzer)  # bounded per-key tables (pndiss/limits.py): evictions are counted and reported
        self.calls: dict = lim.table(s.max_calls, "calls")   # (act, seq) -> request info
        # ar_uuid -> latest AR of that UUID; an evicted AR takes its frame maps along (O(its maps))
        self.ars: dict[str, dict] = lim.table(s.max_ars, "ars", self._forget_ar)
        self.ar_list: list[dict] = []             # every Connect outcome, in order (report/summary)
        self.orphans: OrderedDict = OrderedDict()  # (act, seq) -> Connect response seen before its request
        self.answered: OrderedDict = OrderedDict()  # (act, seq) -> (frame of its response, its request's pdu): copies run once
        self.maps: dict[tuple, armap.FrameMap] = {}
        self.rt_ports = {PORT_RT_UDP}
        self.ip_datagrams: dict[tuple, bool] = {}  # IP fragment key -> PNIO? (bounded with ipr)
        self.record_rows: list[dict] = []
        self.pending_writes: dict[tuple, list] = {}  # (act, seq) -> record events awaiting results
        self.profiles: dict[str, tuple[str, str]] = lim.table(s.max_stations, "profiles")
        self.word_profiles: dict = lim.table(s.max_stations, "profiles")   # device -> (profiles, frames): infer.py
        self.im0: dict[str, dict] = lim.table(s.max_stations, "profiles")   # device MAC -> I&M0 decoded
        self.ffff_writes: dict[str, int] = lim.table(s.max_stations, "profiles")  # device MAC -> frame of a 0xFFFF write
        self.connect_ident: dict = lim.table(s.max_stations, "profiles")   # device MAC -> (vendor ID, device ID), Connect
        self.telegram_p922: dict[tuple, int] = lim.table(s.max_stations, "profiles")  # (device mac, api, slot, subslot) -> P922
        self.counts = {"rpc": 0, "rpc_fragments": 0, "rpc_retransmissions": 0, "ip_fragments": 0, "records": 0, "params": 0,
                       "connects": 0, "connect_refused": 0, "releases": 0, "responses_before_request": 0,
                       "responses_before_request_max_ns": 0, "records_undecoded": 0}
        self.first_record_undecoded = None   # [frame, index, reason] of the first record whose data did not decode
        self.pairer = param_pairer()
        self.usermap = None
        self.gsdml = None
        if getattr(s, "map_file", None):
            from .usermap import load_map
            self.usermap = load_map(s.map_file)
        if getattr(s, "gsdml", None):
            from .gsdml import GsdmlIndex
            self.gsdml = GsdmlIndex(s.gsdml)
        self._fallback: dict[tuple, armap.FrameMap | None] = {}
        self._fallback_gen = 0   # the map generation the cached answers are of
        self.map_generation = 0  # bumped whenever a lookup answer may change (cache key for callers)
        self.inferred_refs: dict = lim.table(s.max_stations, "releases")   # {MAC, MAC} -> {MAC: its alarm reference}
        #                                                                 of the AR known only from its content
        self.unknown_releases: dict = lim.table(s.max_stations, "releases")   # {MAC, MAC} -> time of a Release of
        #                                                                    an AR no Connect of the capture named

    # ---------------------------------------------------------------- PNIO-CM
    def _cm(self, fn, ts, ev, pdu, key, src, dst) -> None:
        op = pdu["opnum"]
        request = "args_max" in pdu
        if request:
            call = self.calls.get(key)
            if call is not None and call["frame"] != fn and call["pdu"] is not None:
                # the same activity and sequence number again before the response: DCE/RPC over UDP resends a
                # request until it is answered, and a mirror port may capture it twice; the call runs once
                self.counts["rpc_retransmissions"] += 1
                return
            done = self.answered.get(key)
            if done is not None and done[1] is None and call is not None and call["frame"] == fn \
                    and 0 <= ts - done[2] <= EARLY_WINDOW_NS:
                # its response came first, stamped earlier: the capture's interfaces' clocks differ (two NICs, a
                # TAP's ports written apart) -- what the server answered cannot precede the question
                self.counts["responses_before_request"] += 1
                self.counts["responses_before_request_max_ns"] = max(self.counts["responses_before_request_max_ns"],
                                                                     ts - done[2])
            if done is not None and done[1] == pdu and ts - done[2] <= RESEND_WINDOW_NS and (call is None or call["frame"] == fn):
                # the same call again after its response (the client missed it and resends; the server answers
                # from its cache, at most once): the same request bytes under an answered act|seq run once. A
                # new request reusing the act|seq (a restarted controller, a tool replaying a fixed Connect:
                # profinet_io_cm_connect, years apart) differs, or comes later than any client resends, and runs
                self.counts["rpc_retransmissions"] += 1
                self.calls.pop(key, None)
                return
            if call is not None and call["frame"] == fn or (call is not None and call["pdu"] is None):
                call["pdu"] = pdu
            if op == 0:
                self._connect_identity(dst, (call or {}).get("obj_id"))   # (as the plugin: at the request)
                self._connect_requested(pdu, dst, fn, ts)
            if op == 3:
                self._writes(fn, ts, pdu, key, src, dst)
            elif op == 4:
                self._control(fn, ts, pdu)  # PrmEnd from the controller, ApplicationReady from the device
            elif op == 0 and key in self.orphans and call is not None:
                # the capture holds the response before its request (seen in profinet_io_cm_connect)
                rfn, rts, rpdu, rsrc, rdst = self.orphans.pop(key)
                self.calls.pop(key, None)
                self._connect(rfn, rts, pdu, rpdu, call, rsrc, rdst)
            return
        call = self.calls.pop(key, None)
        if call is None and key in self.answered:
            # the response again (a mirror port's copy, or the server resending it): its effects run once
            self.counts["rpc_retransmissions"] += 1
            return
        self.answered[key] = (fn, call["pdu"] if call is not None else None, ts)
        if len(self.answered) > MAX_CALLS:
            self.answered.popitem(last=False)
        req = call["pdu"] if call is not None and call["opnum"] == op else None
        if op == 0 and req is not None:
            self._connect(fn, ts, req, pdu, call, src, dst)
        elif op == 0:
            self.orphans[key] = (fn, ts, pdu, src, dst)
            if len(self.orphans) > 64:
                self.orphans.popitem(last=False)
        elif op == 1:
            self._release(fn, ts, pdu, src, dst)
        elif op == 3:
            self._write_results(fn, ts, pdu, key, src)
        elif op in (2, 5):
            self._reads(fn, ts, pdu, req, call, src, dst)

    def station_name(self, mac: str | None) -> str | None:
        """The NameOfStation of a MAC, as DCP/the ARs taught it, or None."""
        if mac is None:
            return None
        s = self.a.stations.by_mac.get(mac)
        return s.get("name") if s else None

    # ---------------------------------------------------------------- interface for the others
    def lookup(self, frame_id: int, src: str, dst: str):
        """FrameMap (pndiss.armap) for a cyclic frame, or None: Connect first, then --map."""
        fm = self.maps.get((frame_id, src, dst))
        if fm is not None:
            return fm
        k = (frame_id, src, dst)
        if self._fallback_gen != self.map_generation:   # a Connect, an AR's end or a P922 changed the maps
            self._fallback_gen = self.map_generation
            self._fallback.clear()
        if k in self._fallback:
            return self._fallback[k]
        fm = None
        if dst == NO_DST:
            # a Linux cooked capture (SLL/SLL2, tcpdump -i any) has no destination address: the frame ID and
            # its sender name the stream when exactly one map in force has them
            found = [m for (f, s, _d), m in self.maps.items() if f == frame_id and s == src]
            fm = found[0] if len(found) == 1 else None
        if fm is None and self.usermap is not None:
            fm = self.usermap.frame_map(frame_id, src, dst)
        if len(self._fallback) >= MAX_CALLS:
            self._fallback.clear()
        self._fallback[k] = fm
        return fm

    def frame_keys(self, ar: dict) -> list:
        """(frame ID, src, dst) lookup keys of an AR's frame maps still in force (a later AR may reuse them)."""
        return [(k, self.maps[k]) for k in ar["map_keys"] if any(self.maps.get(k) is m for m in ar["maps"])]

    def controllers_of(self, device: str) -> set:
        """The MACs of the controllers the capture shows holding an AR with ``device`` (Connects, inferred maps)."""
        return {ar["controller_mac"] for ar in self.ars.values() if ar.get("device_mac") == device} | {
            fm.controller_mac for fm in self.maps.values() if fm.device_mac == device and fm.controller_mac}

    def has_connect(self, controller: str, device: str) -> bool:
        """A Connect between these MACs was seen (an AR, or a request still open): no content inference."""
        macs = {controller, device}
        return any(ar["device_mac"] in macs and ar["controller_mac"] in macs for ar in self.ars.values()) or \
            any(c["opnum"] == 0 and {c["src"], c["dst"]} == macs for c in self.calls.values())

    def add_inferred(self, res: dict) -> None:
        """Frame maps found from the cyclic content (pndiss/infer.py): used like a Connect's, source said."""
        station = self.station_name(res["device_mac"])
        # the cycle the encoder reports in: its input stream's counter step (else the output's), once confirmed
        period = self.a.cyclic.gaps.confirmed_period_ns
        keys = {s["direction"]: (s["frame_id"], s["src"], s["dst"]) for s in res["streams"]}
        cycle = period(keys["input"]) or period(keys["output"])
        hold = res["evidence"].get("sign_of_life_hold", 1)
        learnt_k = (hold, f"the controller holds each sign-of-life value {hold} cycles in the frames the telegram "
                          f"was inferred from ({res['learnt_from'][0]}-{res['learnt_from'][1]})") if hold > 1 else None
        axis = res.get("axis", 0)
        for s in res["streams"]:
            # slot / subslot are unknown: 0/0, and 0/k for a device's further axes (their own data objects)
            do = armap.DataObject(api=0, slot=0, subslot=axis, offset=s["offset"], length=s["length"],
                                  telegram=res["telegram"], telegram_source=res["source"])
            key = (s["frame_id"], s["src"], s["dst"])
            if axis and key in self.maps and self.maps[key].source == "content":
                self.maps[key].objects.append(do)
                continue
            self.maps[key] = armap.FrameMap(
                frame_id=s["frame_id"], direction=s["direction"], controller_mac=res["controller_mac"],
                device_mac=res["device_mac"], station=station, data_length=s["c_sdu_len"], objects=[do],
                source="content", learnt_cycle_ns=cycle, learnt_k=learnt_k)
        fits = res["evidence"].get("profiles") or []
        if fits and "generic" not in fits and not res.get("axis"):   # (further axes fit what the first fits)
            # the words set bits only these profiles define (infer.py): profile_for takes it over a generic guess
            self.word_profiles[res["device_mac"]] = (fits, res["learnt_from"])
            if self.profiles.get(res["device_mac"], ("",))[0] == "generic":
                del self.profiles[res["device_mac"]]
        self.map_generation += 1   # (lookup's fallback cache follows the generation)
        self.a.emit({"frame": res["frame"], "ts_ns": res["ts_ns"], "kind": "ar", "source": res["source"],
                     "station": station, "device_mac": res["device_mac"], "controller_mac": res["controller_mac"],
                     "telegram": res["telegram"], "confidence": res["confidence"], "evidence": res["evidence"],
                     "learnt_from": res["learnt_from"], "iocrs": res["streams"]})

    def finish(self) -> None:
        self._report_dropped(self.ipr.expire(None), "ip")
        self._report_dropped(self.rpcr.expire(None), "dcerpc")

    def summary(self) -> dict:
        return {
            "counts": dict(self.counts),
            "first_record_undecoded": self.first_record_undecoded,
            "ars": [ar_summary(a) for a in self.ar_list],
            "profiles": {m: {"profile": p, "reason": r} for m, (p, r) in self.profiles.items()},
            "records": [{"frame": r["frame"], "op": r["op"], "index": r["index"], "index_name": r["index_name"],
                         "station": r["station"], "device_mac": r["device_mac"], "slot": r["slot"],
                         "subslot": r["subslot"], "length": r["length"], "result": r.get("result")}
                        for r in self.record_rows],
        }

    def report_sections(self) -> list:
        from .session_report import sections
        return sections(self)
