"""PNIO-CM sessions: IPv4/UDP/DCE-RPC frames in; ``rpc``, ``ar``, ``record``, ``param`` events
out; the AR map (pndiss.armap) the cyclic decoder looks frames up in.

Per frame: IPv4 (fragments reassembled, bounded) -> UDP -> RT_CLASS_UDP on 34962 or
connectionless DCE/RPC with a PNIO interface UUID (fragments reassembled, bounded) -> PNIO-CM
stub (pndiss.proto.pnio_cm). Requests and responses pair by activity UUID + sequence number.
A Connect response completes an AR: its IOCRs become FrameMaps keyed by (frame ID, source MAC,
destination MAC). Record writes/reads go to pndiss.records; 0xB02E/0xB02F accesses pair into
``param`` events, and a P922 read labels the submodule's telegram.
"""
from __future__ import annotations

from collections import OrderedDict

from . import armap, limits
from .proto import dcerpc, ip, pnio_cm
from .proto.common import Malformed

try:  # the records helper's package; without it records are emitted undecoded
    from . import records as _records
except ImportError:  # pragma: no cover - only while the records package is missing
    _records = None

PORT_RT_UDP = 0x8892    # 34962, RT_CLASS_UDP (spec/wire.md §1)
PORT_RPC = 0x8894       # 34964, PNIO-CM endpoint mapper / RPC server (spec/wire.md §1)

# PNIO interface UUIDs (spec/wire.md §5.2) and the endpoint mapper (DCE 1.1 RPC, tshark packet-epm.c)
INTERFACES = {
    "dea00001-6c97-11d1-8271-00a02442df7d": "PNIO Device",
    "dea00002-6c97-11d1-8271-00a02442df7d": "PNIO Controller",
    "dea00003-6c97-11d1-8271-00a02442df7d": "PNIO Supervisor",
    "dea00004-6c97-11d1-8271-00a02442df7d": "PNIO ParameterServer",
}
EPM_UUID = "e1af8308-5d1f-11c9-91a4-08002b14a0fa"

API_PROFIDRIVE = 0x3A00  # spec/network.md §1.7
API_ENCODER = 0x3D00
DRIVE_APIS = (API_PROFIDRIVE, API_ENCODER)
IDX_PARAM = (0xB02E, 0xB02F)  # PROFIdrive parameter access, local / global (spec/records.md)
IDX_IM0 = 0xAFF0
P922 = 922  # telegram selection (spec/records.md)

# An AR's phases in order (issue #12): Connect -> parameterisation (records; IOPS BAD, provider STOP) ->
# PrmEnd -> ApplicationReady -> data exchange (first judged cycle) -> released / aborted. A phase only
# moves forward; cyclic data of an AR in 'parameterisation' is reported, not judged (pndiss.cyclic).
PHASES = ("parameterisation", "prm_end", "application_ready", "data_exchange", "released", "aborted")
_PHASE_RANK = {p: i for i, p in enumerate(PHASES)}

MAX_CALLS = 4096      # open requests remembered for pairing (oldest dropped first)
MAX_RECORD_ROWS = 2000  # record accesses / Connects kept for the report (events carry all of them)
MAX_ARS = 4096          # ARs (and their frame maps) kept for lookups


def _telegram_lengths() -> list[tuple[int, int, int]]:
    """(telegram, setpoint bytes, actual bytes) in preference order: standard telegrams first,
    then manufacturer 860, then OEM ones (spec/cyclic.md §2, spec/behaviour.md §1.1)."""
    from . import telegrams as tg

    def size(t, direction):
        return sum(tg.SIGNALS[name]["size"] for name, _ in tg.TELEGRAMS[t][direction])

    return [(t, size(t, "setpoint"), size(t, "actual")) for t in tg.GUESS_ORDER]


_TG_LENGTHS: list[tuple[int, int, int]] | None = None


def guess_telegram(out_len: int, in_len: int, api: int) -> tuple[int | None, str | None]:
    """Telegram for a submodule with these output/input lengths (both directions must match).

    Telegrams whose lengths also fit plain IO modules (87: 4/4, 86 and 860: 4/8) are only
    guessed on the PROFIdrive or encoder API. Returns (telegram, note) or (None, None).
    """
    global _TG_LENGTHS
    if _TG_LENGTHS is None:
        _TG_LENGTHS = _telegram_lengths()
    hits = [t for t, o, i in _TG_LENGTHS if (o, i) == (out_len, in_len)]
    if not hits:
        return None, None
    if api not in DRIVE_APIS and (out_len, in_len) in ((4, 4), (4, 8)):
        return None, None
    note = f"guessed from lengths out {out_len} / in {in_len}"
    if len(hits) > 1:
        note += f"; also fits {', '.join(map(str, hits[1:]))} (standard telegram preferred)"
    return hits[0], note


class SessionTracker:
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
        self.maps: dict[tuple, armap.FrameMap] = {}
        self.rt_ports = {PORT_RT_UDP}
        self.ip_datagrams: dict[tuple, bool] = {}  # IP fragment key -> PNIO? (bounded with ipr)
        self.record_rows: list[dict] = []
        self.pending_writes: dict[tuple, list] = {}  # (act, seq) -> record events awaiting results
        self.profiles: dict[str, tuple[str, str]] = lim.table(s.max_stations, "profiles")
        self.im0: dict[str, dict] = lim.table(s.max_stations, "profiles")   # device MAC -> I&M0 decoded
        self.telegram_p922: dict[tuple, int] = lim.table(s.max_stations, "profiles")  # (device mac, api, slot, subslot) -> P922
        self.counts = {"rpc": 0, "rpc_fragments": 0, "ip_fragments": 0, "records": 0, "params": 0,
                       "connects": 0, "connect_refused": 0, "releases": 0}
        self.pairer = _records.ParamPairer() if _records is not None else None
        self.usermap = None
        self.gsdml = None
        if getattr(s, "map_file", None):
            from .usermap import load_map
            self.usermap = load_map(s.map_file)
        if getattr(s, "gsdml", None):
            from .gsdml import GsdmlIndex
            self.gsdml = GsdmlIndex(s.gsdml)
        self._fallback: dict[tuple, armap.FrameMap | None] = {}
        self.map_generation = 0  # bumped whenever a lookup answer may change (cache key for callers)

    # ---------------------------------------------------------------- IPv4 / UDP
    def on_ipv4(self, fn, ts, data, off, src, dst) -> str:
        if len(data) - off >= 20 and data[off + 9] != ip.PROTO_UDP:
            return "not_profinet"  # TCP, ICMP, IGMP ...: no header work for traffic we do not decode
        try:
            h = ip.decode_ipv4(data, off)
        except Malformed:
            if self._pn_ports(data, off + 20):
                raise
            return "not_profinet"  # e.g. a snaplen-cut datagram of some other protocol
        self._expire(ts)
        if h["flags_mf"] or h["frag_offset"]:
            return self._ip_fragment(fn, ts, data, h, src, dst)
        if h["proto"] != ip.PROTO_UDP:
            return "not_profinet"
        return self._udp(fn, ts, data, h["payload_off"], h["payload_end"], h, src, dst)

    def _ip_fragment(self, fn, ts, data, h, src, dst) -> str:
        if h["proto"] != ip.PROTO_UDP:
            return "not_profinet"
        key = (h["src"], h["dst"], h["proto"], h["id"])
        if h["frag_offset"] == 0:  # the first fragment shows the UDP ports and the RPC header
            p, e = h["payload_off"], h["payload_end"]
            ports = (data[p] << 8 | data[p + 1], data[p + 2] << 8 | data[p + 3]) if e - p >= 4 else ()
            pn = bool(set(ports) & (self.rt_ports | {PORT_RPC})) or self._looks_pnio(data, p + 8, e)
            self.ip_datagrams[key] = pn
            if len(self.ip_datagrams) > 4 * self.ipr.max_datagrams:
                self.ip_datagrams.pop(next(iter(self.ip_datagrams)))
            if not pn:
                return "not_profinet"
        elif self.ip_datagrams.get(key) is False:
            return "not_profinet"
        self.counts["ip_fragments"] += 1
        whole = self.ipr.add(fn, ts, h, data)
        self.a.emit({"frame": fn, "ts_ns": ts, "kind": "ip_fragment", "src": src, "dst": dst,
                     "ip": _ipf(h), "complete": whole is not None,
                     "frames": list(self.ipr.last_frames) if whole is not None else None})
        self._report_dropped(self.ipr.expire(ts), "ip")
        if whole is None:
            return "decoded"
        self.ip_datagrams.pop(key, None)
        hh = dict(h, payload_off=0, payload_end=len(whole), len=len(whole) + h["hdr_len"])
        st = self._udp(fn, ts, whole, 0, len(whole), hh, src, dst)
        return "decoded" if st == "not_profinet" else st

    def _pn_ports(self, b: bytes, p: int) -> bool:
        """UDP ports at b[p:] (an option-less IPv4 header assumed) are PNIO's."""
        if len(b) - p < 4:
            return False
        ports = {(b[p] << 8) | b[p + 1], (b[p + 2] << 8) | b[p + 3]}
        return bool(ports & (self.rt_ports | {PORT_RPC}))

    @staticmethod
    def _looks_pnio(b: bytes, p: int, e: int) -> bool:
        if e - p < dcerpc.HDR_LEN or b[p] != 4 or b[p + 1] > 10:
            return False
        try:
            return dcerpc.get_uuid(b, p + 24, "little" if b[p + 4] & 0x10 else "big") in INTERFACES
        except Exception:  # noqa: BLE001 - a guess on a partial datagram only
            return False

    def _udp(self, fn, ts, data, off, end, h, src, dst) -> str:
        u = ip.decode_udp(data, off, end)
        sp, dp = u["srcport"], u["dstport"]
        po, pe = u["payload_off"], u["payload_end"]
        if dp in self.rt_ports or sp in self.rt_ports:
            return self.a.pn_rt(fn, ts, data, po, src, dst, None, udp=True, end=pe)
        on_rpc_port = PORT_RPC in (sp, dp)
        if pe - po < dcerpc.HDR_LEN or data[po] != 4:
            if on_rpc_port and pe - po > 0:
                raise Malformed("dcerpc", f"UDP {sp}->{dp}: {pe - po} bytes are no connectionless DCE/RPC PDU")
            return "not_profinet"
        try:
            hdr = dcerpc.decode_header(data, po, pe)
        except Malformed:
            if on_rpc_port:
                raise
            return "not_profinet"
        iface = INTERFACES.get(hdr["dg_if_id"])
        if iface is None and not (on_rpc_port and hdr["dg_if_id"] == EPM_UUID):
            return "not_profinet"
        self._rpc(fn, ts, data, hdr, h, u, src, dst, iface or "EPM")
        return "decoded"

    # ---------------------------------------------------------------- DCE/RPC
    def _rpc(self, fn, ts, data, hdr, h, u, src, dst, iface) -> None:
        self.counts["rpc"] += 1
        ptype = hdr["pkt_type"]
        dc = {k: v for k, v in hdr.items() if k not in ("body_off", "body_end", "byte_order", "server_boot")}
        ev = {"frame": fn, "ts_ns": ts, "kind": "rpc", "src": src, "dst": dst,
              "src_ip": h["src"], "dst_ip": h["dst"], "ip": _ipf(h), "udp": _udpf(u),
              "dcerpc": dc, "interface": iface, "packet_type": hdr["pkt_type_name"],
              "opnum": hdr["opnum"], "operation": pnio_cm.OPNUMS.get(hdr["opnum"]) if iface != "EPM" else None}
        if ptype == dcerpc.FACK:
            dc.update(dcerpc.decode_fack(data, hdr["body_off"], hdr["body_end"], hdr["byte_order"]))
        key = (hdr["dg_act_id"], hdr["dg_seqnum"])
        conv = (h["src"], u["srcport"], h["dst"], u["dstport"])
        if ptype == dcerpc.RESPONSE:
            req = self.calls.get(key)
            if req is not None and req["opnum"] == hdr["opnum"]:
                ev["request_frame"] = req["frame"]
                ev["request_ts_ns"] = req["ts"]
                # tshark pairs only inside one UDP conversation (ports swapped): packet-dcerpc.c
                if req["conv"] == (conv[2], conv[3], conv[0], conv[1]):
                    dc["request_in"] = req["frame"]
                    dc["time"] = f"{(ts - req['ts']) / 1e9:.9f}"
        stub = None
        if hdr["dg_flags1"] & dcerpc.F1_FRAG:
            self.counts["rpc_fragments"] += 1
            got = self.rpcr.add(fn, ts, hdr, data)
            ev["fragment"] = {"num": hdr["dg_frag_num"], "last": bool(hdr["dg_flags1"] & dcerpc.F1_LAST),
                              "complete": got is not None}
            self._report_dropped(self.rpcr.expire(ts), "dcerpc")
            if got is not None:
                stub, frames = got
                ev["fragment"]["frames"] = frames
        else:
            stub = data[hdr["body_off"]:hdr["body_end"]]
        # a request counts from the frame that completes it (tshark's request_in does the same)
        if ptype == dcerpc.REQUEST and stub is not None and key not in self.calls:
            self.calls[key] = {"frame": fn, "ts": ts, "opnum": hdr["opnum"], "conv": conv, "pdu": None,
                               "src": src, "dst": dst}
        if stub is None or iface == "EPM" or ptype not in (dcerpc.REQUEST, dcerpc.RESPONSE) or not stub:
            self.a.emit(ev)
            return
        try:
            pdu = pnio_cm.decode_stub(stub, hdr["byte_order"], ptype == dcerpc.REQUEST, hdr["opnum"])
        except Malformed:
            self.a.emit(ev)  # the header was fine: keep it, then report the stub
            raise
        ev["pnio"] = pdu
        if "status" in pdu:
            ev["pnio_status"] = pdu["status"]
        self.a.emit(ev)
        self._cm(fn, ts, ev, pdu, key, src, dst)

    def _report_dropped(self, dropped, layer) -> None:
        """One malformed event per dropped reassembly; its frames, counted as decoded when they came,
        move to the malformed bucket, so the accounting agrees with the events (issue #18 item 5)."""
        counts = getattr(self.a, "counts", None)
        for frames, reason in dropped:
            total = getattr(frames, "total", len(frames))
            last = getattr(frames, "last", None) or frames[-1]
            if counts is not None:
                counts["decoded"] -= total
                counts["malformed"] += total
            self.counts["reassembly_dropped_frames"] = self.counts.get("reassembly_dropped_frames", 0) + total
            self.a.add_malformed(last, self.a.cur_ts, layer,
                              f"{reason}; frames ({total}): "
                              f"{', '.join(map(str, frames[:20]))}"
                              + (f" ... {last}" if total > 20 else ""))

    def _expire(self, ts) -> None:
        if self.ipr.pending:
            self._report_dropped(self.ipr.expire(ts), "ip")
        if self.rpcr.pending:
            self._report_dropped(self.rpcr.expire(ts), "dcerpc")

    # ---------------------------------------------------------------- PNIO-CM
    def _cm(self, fn, ts, ev, pdu, key, src, dst) -> None:
        op = pdu["opnum"]
        request = "args_max" in pdu
        if request:
            call = self.calls.get(key)
            if call is not None and call["frame"] == fn or (call is not None and call["pdu"] is None):
                call["pdu"] = pdu
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
        req = call["pdu"] if call is not None and call["opnum"] == op else None
        if op == 0 and req is not None:
            self._connect(fn, ts, req, pdu, call, src, dst)
        elif op == 0:
            self.orphans[key] = (fn, ts, pdu, src, dst)
            if len(self.orphans) > 64:
                self.orphans.popitem(last=False)
        elif op == 1:
            self._release(fn, ts, pdu)
        elif op == 3:
            self._write_results(fn, ts, pdu, key)
        elif op in (2, 5):
            self._reads(fn, ts, pdu, req, call, src, dst)

    def _station(self, mac: str | None) -> str | None:
        if mac is None:
            return None
        s = self.a.stations.by_mac.get(mac)
        return s.get("name") if s else None

    def _connect(self, fn, ts, req, res, call, src, dst) -> None:
        self.counts["connects"] += 1
        rb, sb = {}, {}
        for blocks, by in ((req["blocks"], rb), (res["blocks"], sb)):
            for b in blocks:
                if "undecoded" not in b:  # a block version tshark does not decode either
                    by.setdefault(b["block_type"], []).append(b)
        arq = (rb.get(0x0101) or [None])[0]
        if arq is None:
            return
        ars = (sb.get(0x8101) or [None])[0]
        ok = res["status"]["ok"]
        controller = arq["cminitiator_mac_add"]
        device = ars["cmresponder_macadd"] if ars else src  # the responder sent this frame
        if not ok:
            self.counts["connect_refused"] += 1
        # expected submodules: (api, slot, subslot) -> description per direction
        expected: dict[tuple, dict] = {}
        for b in rb.get(0x0104, []):
            for a in b.get("apis", []):
                for s in a["submodules"]:
                    e = {"module_ident": a["module_ident_number"], "submodule_ident": s["submodule_ident_number"],
                         "type": s["submodule_properties_type"]}
                    for dd in s["data_descriptions"]:
                        e[dd["direction"] or "other"] = (dd["submodule_data_length"], dd["length_iops"],
                                                        dd["length_iocs"])
                    expected[(a["api"], a["slot_nr"], s["subslot_nr"])] = e
        res_fid = {b["iocr_reference"]: b["frame_id"] for b in sb.get(0x8102, [])}
        station = arq.get("cminitiator_station_name")
        dev_station = self._station(device) or ((sb.get(0x8106) or [{}])[0].get("cminitiator_station_name"))
        ar_uuid = arq["ar_uuid"]
        iocrs, frame_maps, map_keys = [], [], []
        for cr in rb.get(0x0102, []):
            fid = res_fid.get(cr["iocr_reference"], cr["frame_id"])
            direction = {1: "input", 2: "output", 3: "input"}.get(cr["iocr_type"])
            info = {"iocr_type": cr["iocr_type"], "direction": cr["direction"], "iocr_reference": cr["iocr_reference"],
                    "frame_id": fid, "requested_frame_id": cr["frame_id"], "data_length": cr["data_length"],
                    "send_clock_factor": cr["send_clock_factor"], "reduction_ratio": cr["reduction_ratio"],
                    "phase": cr["phase"], "watchdog_factor": cr["watchdog_factor"],
                    "data_hold_factor": cr["data_hold_factor"], "rt_class": cr["iocr_properties_rtclass"],
                    "objects": [], "iocs": []}
            fm = None
            if direction is not None and ok:
                s_mac, d_mac = (device, controller) if direction == "input" else (controller, device)
                if cr["iocr_type"] == 3:
                    d_mac = cr["iocr_multicast_mac_add"]
                fm = armap.FrameMap(frame_id=fid, direction=direction, controller_mac=controller, device_mac=device,
                                    station=dev_station, ar_uuid=ar_uuid, data_length=cr["data_length"],
                                    send_clock_factor=cr["send_clock_factor"],
                                    reduction_ratio=cr["reduction_ratio"], watchdog_factor=cr["watchdog_factor"])
            other = "output" if direction == "input" else "input"
            for a in cr["apis"]:
                for o in a["io_data_objects"]:
                    e = expected.get((a["api"], o["slot_nr"], o["subslot_nr"]), {})
                    ln, iops, _ = e.get(direction or "", (0, 1, 1))
                    do = armap.DataObject(api=a["api"], slot=o["slot_nr"], subslot=o["subslot_nr"],
                                          offset=o["io_data_object_frame_offset"], length=ln, iops_len=iops,
                                          module_ident=e.get("module_ident"), submodule_ident=e.get("submodule_ident"))
                    note = self._assign_telegram(do, e, device, dev_station)
                    info["objects"].append(dict(_do_row(do), telegram_note=note) if note else _do_row(do))
                    if fm is not None:
                        fm.objects.append(do)
                for o in a["iocs"]:
                    e = expected.get((a["api"], o["slot_nr"], o["subslot_nr"]), {})
                    iocs_len = e.get(other, (0, 1, 1))[2]
                    ic = armap.IocsEntry(api=a["api"], slot=o["slot_nr"], subslot=o["subslot_nr"],
                                         offset=o["iocs_frame_offset"], length=iocs_len)
                    info["iocs"].append({"api": ic.api, "slot": ic.slot, "subslot": ic.subslot,
                                         "offset": ic.offset, "length": ic.length})
                    if fm is not None:
                        fm.iocs.append(ic)
            if fm is not None:
                self.maps[(fid, s_mac, d_mac)] = fm
                frame_maps.append(fm)
                map_keys.append((fid, s_mac, d_mac))
            iocrs.append(info)
        alarm = (rb.get(0x0103) or [None])[0]
        alarm_res = (sb.get(0x8103) or [None])[0]
        ar = {"frame": fn, "ts_ns": ts, "kind": "ar", "ar_uuid": ar_uuid, "request_frame": call["frame"],
              "ok": ok, "status": res["status"], "ar_type": arq["artype_req"], "ar_type_name": arq["ar_type_name"],
              "session_key": arq["session_key"], "controller_mac": controller, "device_mac": device,
              "controller_station": station, "station": dev_station,
              "controller_ip": call["conv"][0], "device_ip": call["conv"][2],
              "iocrs": iocrs,
              "alarm_cr": None if alarm is None else {
                  "controller_ref": alarm["localalarmref"], "device_ref": alarm_res and alarm_res["localalarmref"],
                  "rta_timeout_factor": alarm["rta_timeoutfactor"], "rta_retries": alarm["rta_retries"],
                  "max_alarm_data_length": alarm["maxalarmdatalength"],
                  "transport": "RTA_CLASS_UDP" if alarm["alarmcr_properties_transport"] else "RTA_CLASS_1"},
              "expected_submodules": [{"api": k[0], "slot": k[1], "subslot": k[2], "module_ident": v["module_ident"],
                                       "submodule_ident": v["submodule_ident"],
                                       "input_length": v.get("input", (None,))[0],
                                       "output_length": v.get("output", (None,))[0]}
                                      for k, v in expected.items()],
              "module_diff": [{"api": a["api"], "slot": m["slot_nr"], "module_state": m["module_state"],
                               "submodules": [{"subslot": s["subslot_nr"], "state": s["submodule_state"]}
                                              for s in m["submodules"]]}
                              for b in sb.get(0x8104, []) for a in b["apis"] for m in a["modules"]],
              "released": False, "phase": "parameterisation" if ok else "refused",
              "phases": [{"phase": "parameterisation", "frame": fn}] if ok else []}
        for fm in frame_maps:
            fm.phase = ar["phase"]
        rec = dict(ar, maps=frame_maps, map_keys=map_keys, phases=list(ar["phases"]))
        if ok or ar_uuid not in self.ars:  # a refused retry does not hide the AR that is up
            self.ars[ar_uuid] = rec   # bounded: the oldest AR goes, with its frame maps (_forget_ar)
        for cr in rb.get(0x0102, []):  # RT_CLASS_UDP: follow the UDP port the AR names
            if cr["iocr_properties_rtclass"] == 4:
                self.rt_ports.add(arq["cminitiator_udprtport"])
                if ars:
                    self.rt_ports.add(ars["cmresponder_udprtport"])
        if len(self.ar_list) < MAX_RECORD_ROWS:
            self.ar_list.append(rec)
        if dev_station:
            self.a.stations.update(device, name=dev_station)
        self.map_generation += 1
        self.a.emit(ar)

    def _forget_ar(self, _uuid, old: dict) -> None:
        """An AR evicted from the bounded table: drop its frame maps (those no newer AR replaced)."""
        for k in old["map_keys"]:   # where its maps sit in self.maps
            fm = self.maps.get(k)
            if fm is not None and any(fm is m for m in old["maps"]):
                del self.maps[k]
        self.map_generation += 1

    def _assign_telegram(self, do: armap.DataObject, e: dict, device: str, station: str | None) -> str | None:
        """user map > P922 > GSDML > length guess (docs/map.md); returns the guess's note, if any."""
        if self.usermap is not None:
            t = self.usermap.telegram_for(device, station, do.api, do.slot, do.subslot)
            if t is not None:
                do.telegram, do.telegram_source = t, "map"
                return None
        t = self.telegram_p922.get((device, do.api, do.slot, do.subslot))
        if t is not None:
            do.telegram, do.telegram_source = t, "P922"
            return None
        if self.gsdml is not None and do.submodule_ident is not None:
            t = self.gsdml.telegram_for(do.module_ident, do.submodule_ident)
            if t is not None:
                do.telegram, do.telegram_source = t, "gsdml"
                return None
        if "input" in e and "output" in e:
            t, note = guess_telegram(e["output"][0], e["input"][0], do.api)
            if t is not None:
                do.telegram, do.telegram_source = t, "length"
                return note
        return None

    def _release(self, fn, ts, pdu) -> None:
        self.counts["releases"] += 1
        for b in pdu["blocks"]:
            if b["block_type"] == 0x8114 and b.get("ar_uuid") in self.ars:
                ar = self.ars[b["ar_uuid"]]
                ar["released"] = True
                ar["release_frame"] = fn
                for fm in ar["maps"]:  # kept for late frames; armap.FrameMap has no field for it yet
                    fm.released = True
                self.set_phase(ar, "released", fn, ts, "Release")

    def _control(self, fn, ts, pdu) -> None:
        for b in pdu["blocks"]:
            ar = self.ars.get(b.get("ar_uuid"))
            if ar is not None and "command" in b:
                ar.setdefault("control", []).extend(c for c in b["command"] if c != "done")
                if "prmend" in b["command"]:
                    self.set_phase(ar, "prm_end", fn, ts, "PrmEnd")
                if "applready" in b["command"]:
                    self.set_phase(ar, "application_ready", fn, ts, "ApplicationReady")

    def on_rta_error(self, fn, ts, src, dst) -> None:
        """An ERR-RTA-PDU between an AR's controller and device aborts the AR (wire.md §7.1)."""
        for ar in reversed(list(self.ars.values())):
            if {src, dst} == {ar["controller_mac"], ar["device_mac"]} and ar["ok"] \
                    and ar["phase"] not in ("released", "aborted"):
                self.set_phase(ar, "aborted", fn, ts, "ERR-RTA-PDU")
                return

    def set_phase(self, ar: dict, phase: str, fn: int, ts: int, cause: str) -> None:
        """Move an AR forward to ``phase``: its frame maps, an ``ar_phase`` event, the cyclic tracker
        (STARTUP-NO-PARAM-RECORD is decided at PrmEnd). A step back (ApplicationReady after the first
        judged cycle) is kept as a milestone of the AR, not as a phase change."""
        old = ar.get("phase")
        if old not in _PHASE_RANK or _PHASE_RANK[phase] <= _PHASE_RANK[old]:
            if old in _PHASE_RANK:
                ar.setdefault("milestones", []).append({"phase": phase, "frame": fn})
            return
        ar["phase"] = phase
        ar["phases"].append({"phase": phase, "frame": fn})
        for fm in ar["maps"]:
            fm.phase = phase
        self.a.emit({"frame": fn, "ts_ns": ts, "kind": "ar_phase", "ar_uuid": ar["ar_uuid"], "phase": phase,
                     "previous_phase": old, "cause": cause, "device_mac": ar["device_mac"], "station": ar["station"],
                     "controller_mac": ar["controller_mac"]})
        self.a.cyclic.on_phase(ar, phase, fn, ts)

    # ---------------------------------------------------------------- records
    def _ar_of(self, ar_uuid):
        return self.ars.get(ar_uuid)

    def _rec_event(self, fn, ts, hb, op, data, device, controller, request_frame) -> dict:
        ar = self._ar_of(hb["ar_uuid"])
        if ar is not None:
            device, controller = ar["device_mac"], ar["controller_mac"]
        profile = self.profile_for(device)[0] if device else "generic"
        ev = {"frame": fn, "ts_ns": ts, "kind": "record", "op": op, "index": hb["index"],
              "index_name": _records.index_name(hb["index"]) if _records else f"0x{hb['index']:04X}",
              "api": hb["api"], "slot": hb["slot_nr"], "subslot": hb["subslot_nr"],
              "device_mac": device, "controller_mac": controller, "station": self._station(device),
              "ar_uuid": hb["ar_uuid"], "request_frame": request_frame, "seq_number": hb["seq_number"],
              "length": len(data), "data": data.hex(), "profile": profile}
        if "record_blocks" in hb:  # PDev/diagnosis/I&M records are blocks: name them
            ev["blocks"] = hb["record_blocks"]
        if _records is not None:
            try:
                ev["decoded"] = _records.decode_record(hb["index"], data, write=op == "write", profile=profile)
            except Malformed as e:
                ev["decode_error"] = f"{e.layer}: {e.reason}"
        return ev

    def _param_key(self, hb, device, controller):
        ar = hb["ar_uuid"] if hb["ar_uuid"] != pnio_cm.NIL_UUID else (controller, device)
        return (ar, hb["api"], hb["slot_nr"], hb["subslot_nr"])

    def _writes(self, fn, ts, pdu, key, src, dst) -> None:
        evs = []
        for hb in pnio_cm.records(pdu):
            if hb["block_type"] != 0x0008 or hb.get("inner") or "data" not in hb:
                continue
            ev = self._rec_event(fn, ts, hb, "write", bytes.fromhex(hb["data"]), dst, src, fn)
            self.counts["records"] += 1
            self.a.emit(ev)
            self.a.cyclic.on_record(ev)
            if hb["index"] in IDX_PARAM and self.pairer is not None and isinstance(ev.get("decoded"), dict):
                self.pairer.request(self._param_key(hb, ev["device_mac"], ev["controller_mac"]),
                                    ev["decoded"], fn, ts)
            evs.append(ev)
            self._row(ev)
        if evs:
            self.pending_writes[key] = evs
            if len(self.pending_writes) > MAX_CALLS:
                self.pending_writes.pop(next(iter(self.pending_writes)))

    def _write_results(self, fn, ts, pdu, key) -> None:
        evs = self.pending_writes.pop(key, [])
        results = [b for b in pnio_cm.records(pdu) if b["block_type"] == 0x8008]
        if len(results) > 1:  # multiple write: the outer 0xE040 header, then one per inner write
            results = [b for b in results if b["index"] != 0xE040]
        for ev in evs:
            res = next((r for r in results if r["index"] == ev["index"] and r["slot_nr"] == ev["slot"]
                        and r["subslot_nr"] == ev["subslot"] and not r.get("_used")), None)
            if res is None and pdu.get("status") is not None and not pdu["status"]["ok"]:
                st = pdu["status"]
            elif res is not None:
                res["_used"] = True
                st = res["status"]
            else:
                continue
            ev["result"] = st["text"]
            self.a.emit({"frame": fn, "ts_ns": ts, "kind": "record_result", "op": "write", "index": ev["index"],
                         "index_name": ev["index_name"], "api": ev["api"], "slot": ev["slot"],
                         "subslot": ev["subslot"], "device_mac": ev["device_mac"], "request_frame": ev["frame"],
                         "ok": st["ok"], "status": st})
        for r in results:
            r.pop("_used", None)

    def _reads(self, fn, ts, pdu, req, call, src, dst) -> None:
        for hb in pnio_cm.records(pdu):
            if hb["block_type"] != 0x8009:
                continue
            data = bytes.fromhex(hb.get("data", ""))
            ev = self._rec_event(fn, ts, hb, "read", data, src, dst, call["frame"] if call else None)
            ev["result"] = pdu["status"]["text"]
            self.counts["records"] += 1
            self.a.emit(ev)
            self.a.cyclic.on_record(ev)
            self._row(ev)
            dec = ev.get("decoded")
            if hb["index"] == IDX_IM0 and isinstance(dec, dict) and ev["device_mac"]:
                self.im0[ev["device_mac"]] = dec
                self.profiles.pop(ev["device_mac"], None)
            if hb["index"] in IDX_PARAM and self.pairer is not None and isinstance(dec, dict):
                self._param(fn, ts, hb, ev, dec)
        if req is not None and not pdu["status"]["ok"]:
            for hb in pnio_cm.records(req):  # an error response has no header: report the request's
                self.a.emit({"frame": fn, "ts_ns": ts, "kind": "record_result", "op": "read",
                             "index": hb["index"], "index_name": _records.index_name(hb["index"]) if _records
                             else f"0x{hb['index']:04X}", "api": hb["api"], "slot": hb["slot_nr"],
                             "subslot": hb["subslot_nr"], "device_mac": src, "request_frame": call["frame"],
                             "ok": False, "status": pdu["status"]})

    def _param(self, fn, ts, hb, rec, dec) -> None:
        key = self._param_key(hb, rec["device_mac"], rec["controller_mac"])
        p = self.pairer.response(key, dec, fn, ts, rec["profile"])
        ev = {"frame": fn, "ts_ns": ts, "kind": "param", "index": hb["index"], "api": hb["api"],
              "slot": hb["slot_nr"], "subslot": hb["subslot_nr"], "device_mac": rec["device_mac"],
              "controller_mac": rec["controller_mac"], "station": rec["station"], "ar_uuid": hb["ar_uuid"],
              "profile": rec["profile"]}
        ev.update(p)
        self.counts["params"] += 1
        self.a.emit(ev)
        self.a.cyclic.on_record(ev)
        for prm in p.get("params", []):
            if prm.get("pnu") == P922 and not prm.get("error") and prm.get("values") and (prm.get("subindex") or 0) == 0:
                self._p922(rec["device_mac"], hb["api"], hb["slot_nr"], hb["subslot_nr"], prm["values"][0])

    def _p922(self, device, api, slot, subslot, value) -> None:
        """A P922 read names the telegram: relabel the submodule's data objects (unless --map says)."""
        try:
            t = int(value)
        except (TypeError, ValueError):
            return
        self.telegram_p922[(device, api, slot, subslot)] = t
        self.map_generation += 1
        # parameter access goes to the DAP/parameter-access submodule, not always the telegram's:
        # apply to the telegram submodules of this device unless a more specific entry exists
        from . import telegrams as tg
        if t not in tg.TELEGRAMS:
            return
        # a submodule has one telegram: a length guess yields to P922 only if P922's telegram fits the
        # submodule's data lengths in BOTH directions
        misfit = set()
        for fm in self._maps_of(device):
            direction = "actual" if fm.direction == "input" else "setpoint"
            for do in fm.objects:
                if do.length and do.telegram_source == "length" and tg.length(t, direction) != do.length:
                    misfit.add((do.api, do.slot, do.subslot))
        for fm in self._maps_of(device):
            for do in fm.objects:
                if do.telegram_source == "map" or not do.length:
                    continue
                if do.telegram_source == "length" and (do.api, do.slot, do.subslot) in misfit:
                    # the wire's data lengths fit the guessed telegram, not P922's: keep the lengths as the
                    # configuration; the encoder reports TELEGRAM-SELECTION-MISMATCH (behaviour.md §9 #65)
                    continue
                same = (do.api, do.slot, do.subslot) == (api, slot, subslot)
                if same or do.telegram is None or do.telegram_source in ("length", "gsdml"):
                    # P922 names the telegram of a submodule whose lengths fit none (then the cyclic
                    # length check reports TELEGRAM-LENGTH-MISMATCH, #64) or that was only guessed
                    do.telegram, do.telegram_source = t, "P922"

    def _maps_of(self, device):
        for ar in self.ars.values():
            if ar["device_mac"] == device and ar["ok"]:
                yield from ar["maps"]

    def _row(self, ev) -> None:
        if len(self.record_rows) < MAX_RECORD_ROWS:
            self.record_rows.append(ev)

    # ---------------------------------------------------------------- interface for the others
    def lookup(self, frame_id: int, src: str, dst: str):
        """FrameMap (pndiss.armap) for a cyclic frame, or None: Connect first, then --map."""
        fm = self.maps.get((frame_id, src, dst))
        if fm is not None:
            return fm
        k = (frame_id, src, dst)
        if k in self._fallback:
            return self._fallback[k]
        fm = self.usermap.frame_map(frame_id, src, dst) if self.usermap is not None else None
        if len(self._fallback) >= MAX_CALLS:
            self._fallback.clear()
        self._fallback[k] = fm
        return fm

    def frame_keys(self, ar: dict) -> list:
        """(frame ID, src, dst) lookup keys of an AR's frame maps still in force (a later AR may reuse them)."""
        return [(k, self.maps[k]) for k in ar["map_keys"] if any(self.maps.get(k) is m for m in ar["maps"])]

    def has_connect(self, controller: str, device: str) -> bool:
        """A Connect between these MACs was seen (an AR, or a request still open): no content inference."""
        macs = {controller, device}
        return any(ar["device_mac"] in macs and ar["controller_mac"] in macs for ar in self.ars.values()) or \
            any(c["opnum"] == 0 and {c["src"], c["dst"]} == macs for c in self.calls.values())

    def add_inferred(self, res: dict) -> None:
        """Frame maps found from the cyclic content (pndiss/infer.py): used like a Connect's, source said."""
        station = self._station(res["device_mac"])
        for s in res["streams"]:
            do = armap.DataObject(api=0, slot=0, subslot=0, offset=s["offset"], length=s["length"],
                                  telegram=res["telegram"], telegram_source=res["source"])
            self.maps[(s["frame_id"], s["src"], s["dst"])] = armap.FrameMap(
                frame_id=s["frame_id"], direction=s["direction"], controller_mac=res["controller_mac"],
                device_mac=res["device_mac"], station=station, data_length=s["c_sdu_len"], objects=[do],
                source="content")
        self._fallback.clear()
        self.map_generation += 1
        self.a.emit({"frame": res["frame"], "ts_ns": res["ts_ns"], "kind": "ar", "source": res["source"],
                     "station": station, "device_mac": res["device_mac"], "controller_mac": res["controller_mac"],
                     "telegram": res["telegram"], "confidence": res["confidence"], "evidence": res["evidence"],
                     "learnt_from": res["learnt_from"], "iocrs": res["streams"]})

    def profile_for(self, device_mac: str | None) -> tuple[str, str]:
        s = self.a.settings.profile
        if s and s != "auto":
            return s, f"set by --profile {s}"
        if device_mac in self.profiles:
            return self.profiles[device_mac]
        if _records is None:
            return "generic", "records package missing"
        im0 = self.im0.get(device_mac)
        st = self.a.stations.by_mac.get(device_mac) or {}
        if im0 is not None and im0.get("vendor_id") is not None:
            got = _records.select_profile(im0.get("vendor_id"), st.get("device_id"), im0.get("order_id"),
                                          source="I&M0")
        else:
            got = _records.select_profile(st.get("vendor_id"), st.get("device_id"), st.get("type_of_station"),
                                          source="DCP")
        self.profiles[device_mac] = got
        return got

    def finish(self) -> None:
        self._report_dropped(self.ipr.expire(None), "ip")
        self._report_dropped(self.rpcr.expire(None), "dcerpc")

    def summary(self) -> dict:
        return {
            "counts": dict(self.counts),
            "ars": [_ar_summary(a) for a in self.ar_list],
            "profiles": {m: {"profile": p, "reason": r} for m, (p, r) in self.profiles.items()},
            "records": [{"frame": r["frame"], "op": r["op"], "index": r["index"], "index_name": r["index_name"],
                         "station": r["station"], "device_mac": r["device_mac"], "slot": r["slot"],
                         "subslot": r["subslot"], "length": r["length"], "result": r.get("result")}
                        for r in self.record_rows],
        }

    def report_sections(self) -> list:
        from .session_report import sections
        return sections(self)


def _ipf(h: dict) -> dict:
    return {k: v for k, v in h.items() if k not in ("payload_off", "payload_end")}


def _udpf(u: dict) -> dict:
    return {k: v for k, v in u.items() if k not in ("payload_off", "payload_end")}


def _do_row(do: armap.DataObject) -> dict:
    return {"api": do.api, "slot": do.slot, "subslot": do.subslot, "offset": do.offset, "length": do.length,
            "iops_len": do.iops_len, "module_ident": do.module_ident, "submodule_ident": do.submodule_ident,
            "telegram": do.telegram, "telegram_source": do.telegram_source}


def _ar_summary(ar: dict) -> dict:
    out = {k: v for k, v in ar.items() if k not in ("maps", "map_keys", "kind", "ts_ns")}
    # telegrams may have changed since the ar event (P922 read later): refresh from the maps
    objs = {(fm.frame_id, do.api, do.slot, do.subslot): do for fm in ar["maps"] for do in fm.objects}
    out["iocrs"] = [dict(cr, objects=[_do_row(objs[(cr["frame_id"], o["api"], o["slot"], o["subslot"])])
                                      if (cr["frame_id"], o["api"], o["slot"], o["subslot"]) in objs else o
                                      for o in cr["objects"]]) for cr in ar["iocrs"]]
    return out
