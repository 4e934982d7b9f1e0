"""Application relations for the PNIO-CM session tracker: Connect, Release and Control (PrmEnd,
ApplicationReady), the AR's phases and the telegram each data object carries.

A Connect response completes an AR: its IOCRs become FrameMaps (pndiss.armap) keyed by (frame ID,
source MAC, destination MAC); each data object's telegram comes from the user map, a P922 read,
the GSDML or, last, its data lengths (docs/map.md).

A mixin of pndiss.session.SessionTracker: the tracker's own tables and counts.
"""
from __future__ import annotations

from . import armap
from . import telegrams as tg
from .session_records import MAX_RECORD_ROWS

API_PROFIDRIVE = 0x3A00  # spec/network.md §1.7
API_ENCODER = 0x3D00
DRIVE_APIS = (API_PROFIDRIVE, API_ENCODER)

# An AR's phases in order (issue #12): Connect -> parameterisation (records; IOPS BAD, provider STOP) ->
# PrmEnd -> ApplicationReady -> data exchange (first judged cycle) -> released / aborted. A phase only
# moves forward; cyclic data of an AR in 'parameterisation' is reported, not judged (pndiss.cyclic).
PHASES = ("parameterisation", "prm_end", "application_ready", "data_exchange", "released", "aborted")
_PHASE_RANK = {p: i for i, p in enumerate(PHASES)}

MAX_ARS = 4096          # ARs (and their frame maps) kept for lookups


def _telegram_lengths() -> list[tuple[int, int, int]]:
    """(telegram, setpoint bytes, actual bytes) in preference order: standard telegrams first,
    then manufacturer 860, then OEM ones (spec/cyclic.md §2, spec/behaviour.md §1.1)."""
    from . import telegrams as tg

    def size(t, direction):
        return sum(tg.SIGNALS[name]["size"] for name, _ in tg.TELEGRAMS[t][direction])

    return [(t, size(t, "setpoint"), size(t, "actual")) for t in tg.GUESS_ORDER]


_TG_LENGTHS: list[tuple[int, int, int]] | None = None


def guess_telegram(out_len: int, in_len: int, api: int, profile: str = "generic",
                   subslot: int | None = None) -> tuple[int | None, str | None]:
    """Telegram for a submodule with these output/input lengths (both directions must match).

    Telegrams whose lengths also fit plain IO modules (87: 4/4, 86 and 860: 4/8) are only guessed on
    the encoder API 0x3D00 (PS/PSM's encoder object, network.md §1.7; on the PROFIdrive API 0x3A00 4/4 is
    drive telegram 1), or on a device known as an encoder of a profile that has them (a Hohner or SCANCON
    860 on API 0, cyclic.md §2). Off those APIs, data in subslot 1 is no telegram
    either, unless the device is known as an encoder of a profile that has it: an encoder module has its
    access point there and the telegram in subslot 2 (000_37bf2397999f1108.txt:1444-1458, 2756), where a
    plain IO module keeps its data. A known profile's own telegrams come first.
    Returns (telegram, note) or (None, None).
    """
    global _TG_LENGTHS
    if _TG_LENGTHS is None:
        _TG_LENGTHS = _telegram_lengths()
    hits = [t for t, o, i in _TG_LENGTHS if (o, i) == (out_len, in_len)]
    if not hits:
        return None, None
    from . import telegrams as tg
    mine = [t for t in hits if profile != "generic" and profile in tg.TELEGRAMS[t]["profiles"]]
    if not mine and ((api != API_ENCODER and (out_len, in_len) in ((4, 4), (4, 8)))
                     or (api not in DRIVE_APIS and subslot == 1)):
        return None, None
    hits = mine or hits
    note = f"guessed from lengths out {out_len} / in {in_len}"
    if len(hits) > 1:
        note += f"; also fits {', '.join(map(str, hits[1:]))} (standard telegram preferred)"
    return hits[0], note


class ArLayer:
    """SessionTracker mixin: Connect / Release / Control responses in, ``ar`` and ``ar_phase`` events out."""

    def _connect_identity(self, device: str, obj_id) -> None:
        """The Connect request's DCE/RPC object UUID names the device: DEA00000-6C97-11D1-8271-{instance}{device
        ID}{vendor ID} (IEC 61158-6-10, as Wireshark decodes it) -- the vendor for profile_for where no DCP or I&M0
        of the device is in the capture (an independent audit: a LIKA encoder judged as generic). Taken at the
        request (session._cm), as the plugin does, so the response's telegram guess already has it."""
        s = str(obj_id or "").lower()
        if s.startswith("dea00000-6c97-11d1-8271-") and len(s) == 36 and device \
                and self.connect_ident.get(device) is None:
            try:
                self.connect_ident[device] = (int(s[32:36], 16), int(s[28:32], 16))
            except ValueError:
                return
            self.profiles.pop(device, None)   # decided again with it

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
        elif _replaces(arq, rb.get(0x0102)):
            self._superseded(controller, device, arq["ar_uuid"], fn, ts)
        # expected submodules: (api, slot, subslot) -> description per direction
        expected: dict[tuple, dict] = {}
        for b in rb.get(0x0104, []):
            for a in b.get("apis", []):
                for s in a["submodules"]:
                    e = {"module_ident": a["module_ident_number"], "submodule_ident": s["submodule_ident_number"],
                         "type": s["submodule_properties_type"],
                         "shared_input": bool(s.get("submodule_properties_shared_input"))}
                    for dd in s["data_descriptions"]:
                        ln = dd["submodule_data_length"]
                        if s.get(f"submodule_properties_reduce_{dd['direction']}_submodule_data_length"):
                            ln = 0   # this AR's IO data object has no data bytes (wire.md §6.6)
                        e[dd["direction"] or "other"] = (ln, dd["length_iops"], dd["length_iocs"])
                    expected[(a["api"], a["slot_nr"], s["subslot_nr"])] = e
        locked = {(a["api"], m["slot_nr"], sm["subslot_nr"]): diff_state(sm["submodule_state"])
                  for b in sb.get(0x8104, []) for a in b["apis"] for m in a["modules"] for sm in m["submodules"]}
        res_fid = {b["iocr_reference"]: b["frame_id"] for b in sb.get(0x8102, [])}
        station = arq.get("cminitiator_station_name")
        dev_station = self.station_name(device) or ((sb.get(0x8106) or [{}])[0].get("cminitiator_station_name"))
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
                                    reduction_ratio=cr["reduction_ratio"], watchdog_factor=cr["watchdog_factor"],
                                    primary_only=arq.get("artype_req") == SYSRED_AR_TYPE)
            other = "output" if direction == "input" else "input"
            for a in cr["apis"]:
                for o in a["io_data_objects"]:
                    e = expected.get((a["api"], o["slot_nr"], o["subslot_nr"]), {})
                    ln, iops, _ = e.get(direction or "", (0, 1, 1))
                    do = armap.DataObject(api=a["api"], slot=o["slot_nr"], subslot=o["subslot_nr"],
                                          offset=o["io_data_object_frame_offset"], length=ln, iops_len=iops,
                                          module_ident=e.get("module_ident"), submodule_ident=e.get("submodule_ident"))
                    if e.get("shared_input"):
                        # another AR controls the encoder: this AR only reads its inputs -- nothing to judge here,
                        # and a P922 read does not make it a telegram
                        do.telegram_source = armap.NOT_OWNED
                        note = "not judged in this AR: shared input (the encoder's own AR controls it)"
                    else:
                        note = self._assign_telegram(do, e, device, dev_station)
                        # locked by another AR for now (its IOPS say so until a hand-over, p-net's plug alarm and
                        # plug-PrmEnd): judged when GOOD, but it needs no 0xBF00 of this AR at its PrmEnd (#66)
                        do.locked = locked.get((a["api"], o["slot_nr"], o["subslot_nr"]))
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
        if ok:
            self._taken_over(frame_maps, arq, controller, device, fn, ts)
        alarm = (rb.get(0x0103) or [None])[0]
        alarm_res = (sb.get(0x8103) or [None])[0]
        ar = {"frame": fn, "ts_ns": ts, "kind": "ar", "source": "connect", "ar_uuid": ar_uuid,
              "request_frame": call["frame"],
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
        again = ok and ar_uuid in self.ars and self.ars[ar_uuid]["ok"]
        if ok or ar_uuid not in self.ars:  # a refused retry does not hide the AR that is up
            self.ars[ar_uuid] = rec   # bounded: the oldest AR goes, with its frame maps (_forget_ar)
        if ok:
            # another controller's AR known only from its content, on a frame ID the device now sends to this one:
            # it ended unseen (the PLC replaced, its abort not captured; a device sends one CR per frame ID)
            for fid, s_mac, d_mac in map_keys:
                for k, m in list(self.maps.items()):
                    if m.source == "content" and k[0] == fid and k[1] == s_mac == device and k[2] != d_mac:
                        self.end_inferred(device, k[2], "aborted", fn, ts,
                                          f"another controller's Connect (frame {fn}) took its frame ID 0x{fid:04X}")
            # (its streams started afresh at the Connect request: _connect_requested; not here -- the device may
            # send the new AR's frames before this response, and their state, a mirror port's copies, must stay)
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
        if ok and _replaces(arq, rb.get(0x0102)):
            self.a.cyclic.on_new_ar(device)   # (a supervisor AR beside it leaves the IO AR's alarm numbers)
        self.a.emit(ar)
        if again:   # the AR UUID of an earlier connection (controllers may reuse it): a new connection
            self.a.cyclic.on_reconnect(rec, fn, ts)

    def _connect_requested(self, pdu: dict, device: str, fn: int, ts: int) -> None:
        """A Connect request for another AR of a controller that holds one with the device: the device may
        provide the new AR's frames before its response (a new cycle counter), so the held AR's streams
        start their capture-loss tracking afresh now; the AR itself ends at the response (_superseded)."""
        blocks = [b for b in pdu.get("blocks", ()) if "undecoded" not in b]
        arq = next((b for b in blocks if b.get("block_type") == 0x0101), None)
        if arq is None or not _replaces(arq, [b for b in blocks if b.get("block_type") == 0x0102]):
            return
        self.end_inferred(arq["cminitiator_mac_add"], device, "aborted", fn, ts,
                          f"a new Connect of the same controller (frame {fn})")
        # ... and whatever ran between the two before, an AR the capture never knew (it started before the capture,
        # too short to infer): the device may send the new AR's frames before the response, with new counters
        self.a.cyclic.restart_between(arq["cminitiator_mac_add"], device)
        for old in self._held(arq["cminitiator_mac_add"], device, arq["ar_uuid"]):
            self.a.cyclic.restart_gaps([key for key, _fm in self.frame_keys(old)])

    def _superseded(self, controller: str, device: str, ar_uuid: str, fn: int, ts: int) -> None:
        """A controller holds one AR with a device: its new Connect (another AR UUID) means the AR that is
        up ended without a Release the capture holds (the device lost power, the link went down, the abort
        was not captured). It is aborted here, before the new AR's frame maps take its streams, so their
        cycle counters start afresh (no capture loss across the restart)."""
        for old in self._held(controller, device, ar_uuid):
            self.set_phase(old, "aborted", fn, ts, f"a new Connect of the same controller (frame {fn})")

    def _taken_over(self, frame_maps, arq, controller: str, device: str, fn: int, ts: int) -> None:
        """Another controller's AR that owns an encoder module this accepted Connect owns too ended unseen: a
        device gives a submodule to one AR (the other's would be locked, session_ar.diff_state); system
        redundancy's two ARs own the same modules by design."""
        if arq.get("artype_req") in (SYSRED_AR_TYPE, SUPERVISOR_AR_TYPE):
            return   # (a supervisor takes the module for a while and gives it back)
        mine = {(do.api, do.slot, do.subslot) for fm in frame_maps for do in fm.objects
                if do.telegram is not None and not do.locked}
        if not mine:
            return
        for old in list(self.ars.values()):
            if old["ok"] and old["device_mac"] == device and old["controller_mac"] != controller \
                    and old["ar_uuid"] != arq["ar_uuid"] and old.get("ar_type") != SYSRED_AR_TYPE \
                    and old.get("phase") not in ("released", "aborted", "refused") \
                    and any((do.api, do.slot, do.subslot) in mine for fm in old["maps"] for do in fm.objects
                            if do.telegram is not None):
                self.set_phase(old, "aborted", fn, ts,
                               f"another controller's Connect took its encoder module (frame {fn})")

    def _held(self, controller: str, device: str, ar_uuid: str) -> list:
        """The IO ARs other than ``ar_uuid`` this controller holds with this device (up: not ended or refused)."""
        return [ar for ar in self.ars.values()
                if ar["ar_uuid"] != ar_uuid and ar["ok"] and ar["controller_mac"] == controller
                and ar["device_mac"] == device and ar.get("phase") not in ("released", "aborted", "refused")
                # (an IO AR: a SoftPLC's supervisor or Device Access AR runs beside it, a new IO AR does not end it)
                and ar.get("ar_type") != SUPERVISOR_AR_TYPE and ar.get("iocrs")]

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
        if t in tg.TELEGRAMS and any(tg.length(t, d) != e[w][0] for w, d in (("output", "setpoint"), ("input", "actual"))
                                     if w in e):
            # an earlier connection's P922: this Connect's lengths say another telegram (a project downloaded with
            # a new one reconnects the same submodule), so it is stale
            del self.telegram_p922[(device, do.api, do.slot, do.subslot)]
            t = None
        if t is not None:
            do.telegram, do.telegram_source = t, "P922"
            return None
        if self.gsdml is not None and do.submodule_ident is not None:
            t = self.gsdml.telegram_for(do.module_ident, do.submodule_ident)
            if t is not None:
                do.telegram, do.telegram_source = t, "gsdml"
                return None
        if "input" in e and "output" in e:
            prof, why = self.profile_for(device)
            # the device's identity (DCP, I&M0, 0xFFFF), not --profile: that would make every plain 4/8-byte
            # IO module of a plant an encoder telegram
            t, note = guess_telegram(e["output"][0], e["input"][0], do.api,
                                     "generic" if why.startswith("set by --profile") else prof, do.subslot)
            if t is not None:
                do.telegram, do.telegram_source = t, "length"
                return note
        return None

    def _release(self, fn, ts, pdu, src: str | None = None, dst: str | None = None) -> None:
        self.counts["releases"] += 1
        for b in pdu["blocks"]:
            if b["block_type"] == 0x8114 and b.get("ar_uuid") not in self.ars and src and dst:
                # an AR the capture saw no Connect of: the AR known only from its content between these MACs, or a
                # supervisor / Device Access AR beside it (a SoftPLC's) -- its Release cannot say which, so the
                # inferred AR is not ended here (its next Connect ends it) but is not reported silent after it
                self.unknown_releases[frozenset((src, dst))] = ts
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

    def on_rta_error(self, fn, ts, src, dst, status: dict | None = None, endpoints: tuple = (None, None)) -> None:
        """An ERR-RTA-PDU between an AR's controller and device aborts the AR (wire.md §7.1); the cause says who
        sent it and its PNIOStatus (e.g. a consumer's data hold timer expired): who ended the AR, and why. Of
        several ARs between the two (a SoftPLC's supervisor or Device Access AR beside its IO AR) the one whose
        alarm references the PDU's endpoints name (``endpoints`` = (source, destination)); an AR whose references
        the capture does not know is taken when none names them; none at all: an AR known only from its content."""
        why = f": {status['text']}" if status and status.get("text") else ""
        cands = [ar for ar in reversed(list(self.ars.values()))
                 if {src, dst} == {ar["controller_mac"], ar["device_mac"]} and ar["ok"]
                 and ar["phase"] not in ("released", "aborted")]
        fits = [_names_endpoints(ar, src, endpoints) for ar in cands]
        pick = next((ar for ar, f in zip(cands, fits) if f is True), None) \
            or next((ar for ar, f in zip(cands, fits) if f is None), None)
        if pick is not None:
            who = "controller" if src == pick["controller_mac"] else "device"
            self.set_phase(pick, "aborted", fn, ts, f"ERR-RTA-PDU from the {who} {src}{why}")
            return
        refs = self.inferred_refs.get(frozenset((src, dst)))
        if refs is not None and None not in endpoints and (refs.get(src), refs.get(dst)) != tuple(endpoints):
            # the AR known only from its content numbers its alarms otherwise: another AR the capture never saw
            # connect (a SoftPLC's supervisor AR) ended -- as with its Release, the inferred AR runs on
            self.unknown_releases[frozenset((src, dst))] = ts
            return
        self.end_inferred(src, dst, "aborted", fn, ts, f"ERR-RTA-PDU from {src}{why}")

    def on_alarm_endpoints(self, src: str, dst: str, endpoints: tuple) -> None:
        """An alarm PDU (notification or acknowledgement) between two MACs: when no AR the capture knows numbers
        its alarms so and an AR known only from its content runs between them, its alarm references are these
        (each side's own is its source endpoint) -- what tells its ERR-RTA-PDU from another unseen AR's."""
        if None in endpoints or not any(fm.source == "content" and {fm.controller_mac, fm.device_mac} == {src, dst}
                                        for fm in self.maps.values()):
            return
        if any({src, dst} == {ar["controller_mac"], ar["device_mac"]} and _names_endpoints(ar, src, endpoints)
               for ar in self.ars.values()):
            return
        self.inferred_refs.setdefault(frozenset((src, dst)), {}).update({src: endpoints[0], dst: endpoints[1]})

    def end_inferred(self, a: str, b: str, phase: str, fn: int, ts: int, cause: str) -> None:
        """The AR between MACs ``a`` and ``b`` that the capture knows only from its cyclic content (no Connect:
        started mid-session) ended: its Release or ERR-RTA-PDU (the AR UUID is unknown, the MACs say it), or a
        new Connect of its controller. Its streams' cycle counters end with it: the next AR's providers count
        afresh (an independent audit: the new AR's first 101 cycles taken for stale copies, a fault in them
        missed; or the pause to the new Connect counted as capture loss)."""
        ended = [(k, fm) for k, fm in self.maps.items() if fm.source == "content"
                 and fm.phase not in ("released", "aborted") and {fm.controller_mac, fm.device_mac} == {a, b}]
        if not ended:
            return
        for _k, fm in ended:
            fm.phase = phase
            fm.released = phase == "released"
        self.a.cyclic.restart_gaps([k for k, _fm in ended])
        self.map_generation += 1
        fm = ended[0][1]
        self.a.emit({"frame": fn, "ts_ns": ts, "kind": "ar_phase", "ar_uuid": None, "phase": phase,
                     "previous_phase": None, "cause": cause + " (an AR inferred from content)",
                     "device_mac": fm.device_mac, "station": fm.station, "controller_mac": fm.controller_mac})

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
        if phase == "aborted":
            ar["abort_cause"] = cause   # who ended it and why (an ERR-RTA-PDU's sender and PNIOStatus)
        for fm in ar["maps"]:
            fm.phase = phase
        self.a.emit({"frame": fn, "ts_ns": ts, "kind": "ar_phase", "ar_uuid": ar["ar_uuid"], "phase": phase,
                     "previous_phase": old, "cause": cause, "device_mac": ar["device_mac"], "station": ar["station"],
                     "controller_mac": ar["controller_mac"]})
        self.a.cyclic.on_phase(ar, phase, fn, ts)


SYSRED_AR_TYPE = 0x0020       # IOCARSR: system redundancy (S2/R1), one AR per controller of the H system
SUPERVISOR_AR_TYPE = 0x0006   # IOSAR (wire.md; tshark pn_io_ar_type): an engineering tool beside the controller


def _names_endpoints(ar: dict, src: str, endpoints: tuple):
    """Whether an ERR-RTA-PDU from ``src`` with (source, destination) alarm endpoints belongs to ``ar``: True / False
    by its AlarmCR's local alarm references (the sender's own is the source), None when either side is unknown."""
    cr = ar.get("alarm_cr") or {}
    mine, theirs = (cr.get("controller_ref"), cr.get("device_ref")) if src == ar["controller_mac"] \
        else (cr.get("device_ref"), cr.get("controller_ref"))
    if None in (mine, theirs) or None in endpoints:
        return None
    return (mine, theirs) == tuple(endpoints)


def _replaces(arq: dict, iocrs) -> bool:
    """A Connect that takes over the cyclic data of an AR the controller holds with the device: an AR with
    IOCRs that is no supervisor AR (IOCARSingle, IOCARCIR, RT_CLASS_3, system redundancy). A supervisor
    or Device Access AR from the same MAC (a SoftPLC's engineering tool reading I&M0) runs beside it."""
    return arq.get("artype_req") != SUPERVISOR_AR_TYPE and bool(iocrs)


def diff_state(state: int) -> str | None:
    """What a ModuleDiffBlock SubmoduleState says when this AR has no working submodule of its own there (wire.md
    §6.7): another AR owns it, or the plugged submodule is the wrong one or none -- the controller then writes it
    no parameters (an independent audit: a false STARTUP-NO-PARAM-RECORD for a missing encoder). Else None."""
    if state & 0x8000:
        return ({2: "superordinated locked", 3: "locked by IO controller", 4: "locked by IO supervisor"}.get((state >> 7) & 0xF)
                or {2: "wrong submodule", 3: "no submodule"}.get((state >> 11) & 0xF))
    return {2: "locked by IO controller", 0: "no submodule", 1: "wrong submodule"}.get(state & 0x7FFF)


def _do_row(do: armap.DataObject) -> dict:
    return {"api": do.api, "slot": do.slot, "subslot": do.subslot, "offset": do.offset, "length": do.length,
            "iops_len": do.iops_len, "module_ident": do.module_ident, "submodule_ident": do.submodule_ident,
            "telegram": do.telegram, "telegram_source": do.telegram_source}


def ar_summary(ar: dict) -> dict:
    out = {k: v for k, v in ar.items() if k not in ("maps", "map_keys", "kind", "ts_ns")}
    # telegrams may have changed since the ar event (P922 read later): refresh from the maps
    objs = {(fm.frame_id, do.api, do.slot, do.subslot): do for fm in ar["maps"] for do in fm.objects}
    def row(cr, o):
        do = objs.get((cr["frame_id"], o["api"], o["slot"], o["subslot"]))
        if do is None:
            return o
        r = _do_row(do)
        if "telegram_note" in o and do.telegram_source in ("length", armap.NOT_OWNED):   # why guessed / not judged
            r["telegram_note"] = o["telegram_note"]
        return r
    out["iocrs"] = [dict(cr, objects=[row(cr, o) for o in cr["objects"]]) for cr in ar["iocrs"]]
    return out
