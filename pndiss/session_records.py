"""Record accesses for the PNIO-CM session tracker: IODWrite / IODRead in, ``record``,
``record_result`` and ``param`` events out (decoded by pndiss.records). 0xB02E/0xB02F accesses pair
into ``param`` events, and a P922 read labels the submodule's telegram. The device profile is chosen
here too: from I&M0 once read, else from DCP.

A mixin of pndiss.session.SessionTracker: the tracker's own tables and counts.
"""
from __future__ import annotations

from . import armap
from .proto import pnio_cm
from .proto.common import Malformed

try:  # the records helper's package; without it records are emitted undecoded
    from . import records as _records
except ImportError:  # pragma: no cover - only while the records package is missing
    _records = None

IDX_PARAM = (0xB02E, 0xB02F)  # PROFIdrive parameter access, local / global (spec/records.md)
IDX_IM0 = 0xAFF0
P922 = 922  # telegram selection (spec/records.md)

MAX_CALLS = 4096      # open requests remembered for pairing (oldest dropped first)
MAX_RECORD_ROWS = 2000  # record accesses / Connects kept for the report (events carry all of them)


def param_pairer():
    """The 0xB02E/0xB02F request/response pairer, None without the records package."""
    return _records.ParamPairer() if _records is not None else None


class RecordLayer:
    """SessionTracker mixin: record writes and reads, parameter accesses, the device profile."""

    def _ar_of(self, ar_uuid):
        return self.ars.get(ar_uuid)

    def _rec_event(self, fn, ts, hb, op, data, device, controller, request_frame) -> dict:
        ar = self._ar_of(hb["ar_uuid"])
        if ar is not None:
            device, controller = ar["device_mac"], ar["controller_mac"]
        if device and hb["index"] == 0xFFFF and op == "write":
            self._ffff_written(device, fn)
        profile = self.profile_for(device)[0] if device else "generic"
        ev = {"frame": fn, "ts_ns": ts, "kind": "record", "op": op, "index": hb["index"],
              "index_name": _records.index_name(hb["index"]) if _records else f"0x{hb['index']:04X}",
              "api": hb["api"], "slot": hb["slot_nr"], "subslot": hb["subslot_nr"],
              "device_mac": device, "controller_mac": controller, "station": self.station_name(device),
              "ar_uuid": hb["ar_uuid"], "request_frame": request_frame, "seq_number": hb["seq_number"],
              "length": len(data), "data": data.hex(), "profile": profile}
        if "record_blocks" in hb:  # PDev/diagnosis/I&M records are blocks: name them
            ev["blocks"] = hb["record_blocks"]
        if _records is not None:
            try:
                ev["decoded"] = _records.decode_record(hb["index"], data, write=op == "write", profile=profile)
            except Malformed as e:
                ev["decode_error"] = f"{e.layer}: {e.reason}"
                # (the frame decoded, what the record holds did not: Trust) -- an empty read answer, a device's "not
                # ready yet" to a poll, holds nothing to decode
                if data:
                    self.counts["records_undecoded"] += 1
                    if self.first_record_undecoded is None:
                        self.first_record_undecoded = [fn, hb["index"], ev["decode_error"]]
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
            # the event as written now; the report's row (ev) gets the response's result later (_write_results),
            # the event stream has it as a record_result event -- not on an event a sink may still hold
            self.a.emit(dict(ev))
            self.a.cyclic.on_record(ev)
            if hb["index"] in IDX_PARAM and self.pairer is not None and isinstance(ev.get("decoded"), dict):
                # capture loss since a pending one, seen in the device's own streams (the engine walks those up to
                # this frame; another device's may be ahead or behind it)
                gaps = getattr(getattr(self.a, "cyclic", None), "gaps", None)
                self.pairer.request(self._param_key(hb, ev["device_mac"], ev["controller_mac"]),
                                    ev["decoded"], fn, ts, gaps.last_gap(ev["device_mac"]) if gaps is not None else None)
            evs.append(ev)
            self._row(ev)
        if evs:
            self.pending_writes[key] = evs
            if len(self.pending_writes) > MAX_CALLS:
                self.pending_writes.pop(next(iter(self.pending_writes)))

    def _write_results(self, fn, ts, pdu, key, src) -> None:
        evs = self.pending_writes.pop(key, [])
        results = [b for b in pnio_cm.records(pdu) if b["block_type"] == 0x8008]
        if len(results) > 1:  # multiple write: the outer 0xE040 header, then one per inner write
            results = [b for b in results if b["index"] != 0xE040]
        if not evs:
            self._unseen_writes(fn, ts, results, src)
            return
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
            res_ev = {"frame": fn, "ts_ns": ts, "kind": "record_result", "op": "write", "index": ev["index"],
                      "index_name": ev["index_name"], "api": ev["api"], "slot": ev["slot"],
                      "subslot": ev["subslot"], "device_mac": ev["device_mac"], "request_frame": ev["frame"],
                      "ok": st["ok"], "status": st}
            self.a.emit(res_ev)
            if not st["ok"]:   # a refused write wrote nothing: its record is not in force, its request not pending
                self.a.cyclic.on_write_refused(dict(res_ev, ar_uuid=ev.get("ar_uuid")))   # (not the event emitted)
                if ev["index"] in IDX_PARAM and self.pairer is not None:
                    self.pairer.refused(self._param_key({"ar_uuid": ev.get("ar_uuid") or pnio_cm.NIL_UUID,
                                                         "api": ev["api"], "slot_nr": ev["slot"],
                                                         "subslot_nr": ev["subslot"]},
                                                        ev["device_mac"], ev["controller_mac"]), ev["frame"])
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
            if hb["index"] in IDX_PARAM and self.pairer is not None and not isinstance(dec, dict) \
                    and ev.get("decode_error"):
                dec = _records.profidrive.undecodable_response(data, ev["decode_error"])
            if hb["index"] in IDX_PARAM and self.pairer is not None and isinstance(dec, dict):
                self._param(fn, ts, hb, ev, dec)
        if req is not None and not pdu["status"]["ok"]:
            for hb in pnio_cm.records(req):  # an error response has no header: report the request's
                self.a.emit({"frame": fn, "ts_ns": ts, "kind": "record_result", "op": "read",
                             "index": hb["index"], "index_name": _records.index_name(hb["index"]) if _records
                             else f"0x{hb['index']:04X}", "api": hb["api"], "slot": hb["slot_nr"],
                             "subslot": hb["subslot_nr"], "device_mac": src, "request_frame": call["frame"],
                             "ok": False, "status": pdu["status"]})

    def _unseen_writes(self, fn, ts, results, src) -> None:
        """Write responses whose request the capture lost: the response still proves the write (a user
        parameter record written before PrmEnd, #66); its data is unknown."""
        for r in results:
            ar = self._ar_of(r["ar_uuid"])
            ev = {"frame": fn, "ts_ns": ts, "kind": "record_result", "op": "write", "index": r["index"],
                  "index_name": _records.index_name(r["index"]) if _records else f"0x{r['index']:04X}",
                  "api": r["api"], "slot": r["slot_nr"], "subslot": r["subslot_nr"],
                  "device_mac": ar["device_mac"] if ar is not None else src, "request_frame": None,
                  "ar_uuid": r["ar_uuid"], "ok": r["status"]["ok"], "status": r["status"]}
            self.a.emit(ev)
            if r["index"] == 0xFFFF and r["status"]["ok"]:
                self._ffff_written(ev["device_mac"], fn)
            self.a.cyclic.on_write_result(ev)

    def _ffff_written(self, device: str, fn: int) -> None:
        """A write of record 0xFFFF (its request, or a successful response of a lost one): PS/PSM evidence
        for profile_for, which decides the device's profile again with it."""
        if device not in self.ffff_writes:
            self.ffff_writes[device] = fn
            self.profiles.pop(device, None)

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
        if hb["index"] == 0xB02F and len(self.encoder_slots(rec["device_mac"])) > 1:
            return   # its DO-ID may name another encoder module of the device (cyclic_axes.on_record): no relabel
        for prm in p.get("params", []):
            if prm.get("pnu") == P922 and not prm.get("error") and prm.get("values") and (prm.get("subindex") or 0) == 0 \
                    and (prm.get("attribute") is None or prm["attribute"] & 0xF0 == 0x10):   # the value, not (0x20) a text
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
                if do.telegram_source in ("map", armap.NOT_OWNED) or not do.length:
                    continue   # (a shared input: another AR controls the submodule)
                if do.telegram_source == "length" and (do.api, do.slot, do.subslot) in misfit:
                    # the wire's data lengths fit the guessed telegram, not P922's: keep the lengths as the
                    # configuration; the encoder reports TELEGRAM-SELECTION-MISMATCH (behaviour.md §9 #65)
                    continue
                same = (do.api, do.slot, do.subslot) == (api, slot, subslot)
                if same or do.telegram is None or do.telegram_source in ("length", "gsdml"):
                    # P922 names the telegram of a submodule whose lengths fit none (then the cyclic
                    # length check reports TELEGRAM-LENGTH-MISMATCH, #64) or that was only guessed
                    do.telegram, do.telegram_source = t, "P922"

    def encoder_slots(self, device) -> set:
        """Slots of the device whose submodules carry a telegram in one of its ARs: its encoder modules (one
        Encoder Object per module, network.md §1.7), whoever's AR they are in (a shared device)."""
        return {do.slot for fm in self._maps_of(device) for do in fm.objects if do.telegram is not None}

    def _maps_of(self, device):
        for ar in self.ars.values():
            if ar["device_mac"] == device and ar["ok"]:
                yield from ar["maps"]

    def _row(self, ev) -> None:
        if len(self.record_rows) < MAX_RECORD_ROWS:
            self.record_rows.append(ev)

    # ---------------------------------------------------------------- device profile
    def identity_changed(self, device_mac: str) -> None:
        """DCP told the device's vendor, device ID or type anew: its profile is decided again when next asked (the
        axes that have one keep it; a new AR's axes take the new one). Not over I&M0, which beats DCP."""
        if device_mac not in self.im0:
            self.profiles.pop(device_mac, None)

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
        elif st.get("vendor_id") is None and not st.get("type_of_station") and device_mac in self.connect_ident:
            # (only where DCP said nothing of the device: its type-of-station string names the profile too)
            vid, did = self.connect_ident[device_mac]
            got = _records.select_profile(vid, did, None, source="the Connect's object UUID")
        else:
            got = _records.select_profile(st.get("vendor_id"), st.get("device_id"), st.get("type_of_station"),
                                          source="DCP")
        if got[0] == "generic" and device_mac in self.ffff_writes:
            # only PS/PSM keeps its encoder parameters at index 0xFFFF, and its manual gives no vendor ID
            # (records.md §1, network.md §1.11): a device written there is PS/PSM whatever its IDs
            got = ("psm", f"record 0xFFFF written in frame {self.ffff_writes[device_mac]}: PS/PSM's encoder "
                          f"parameter record (002_d69f444daf0f8af2.txt:982-1020); {got[1]}")
        words = self.word_profiles.get(device_mac)
        if got[0] == "generic" and words is not None and len(words[0]) == 1:
            got = (words[0][0], f"the control/status words of its telegram, inferred from frames {words[1][0]}-"
                                f"{words[1][1]}, set bits only profile {words[0][0]} defines; {got[1]}")
        self.profiles[device_mac] = got
        return got
