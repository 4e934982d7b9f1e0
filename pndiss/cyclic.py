"""Cyclic tracker: PN-RT cyclic frames -> telegram signals -> the reference encoder per axis.

For every cyclic frame the tracker finds the frame's layout (``session.lookup``, cached per
(frame ID, src, dst)), cuts each mapped data object out of the C_SDU, decodes it with
pndiss.telegrams and pairs the controller's setpoint (output frame) with the device's actual
value (input frame) of the same cycle: each input frame closes a cycle with the latest setpoint.
IOPS and DataStatus gate what is judged: data from a provider in STOP, with DataValid = 0 or IOPS
bad is reported (telegram event, ``judged`` false) but not fed to the checker. So does the AR's phase
(pndiss.session_ar PHASES): an AR whose Connect was seen is judged from its PrmEnd on, whatever its
IOxS said before (devices that send GOOD data during parameterisation are not judged on it), until
its Release / abort, and
STARTUP-NO-PARAM-RECORD is decided at the PrmEnd (on_phase), not from cyclic timing.

The axes (one reference-encoder Checker per AR/submodule), their telegram and profile, the AR
phases and the records they follow are cyclic_axes.py's, a mixin of CyclicTracker.

Hot path: an unchanged C_SDU reuses the previous decode (same dict objects), and the checker
skips identical cycles when no rule has anything pending; ``telegram`` events are built only when
the analyzer has a sink.
"""
from __future__ import annotations

import zlib

from . import limits, rules
from . import telegrams as tg
from .armap import NOT_OWNED
from .cyclic_axes import Axis, AxisTracking
from .encoder.acyclic import tg_length_problem
from .gaps import GapTracker
from .infer import Inference
from .proto.common import Malformed
from .proto.rt import judgeable

IOPS_GOOD = 0x80          # IOxS DataState bit (wire.md §2.3, IEC 61158-6-10)
RELOOKUP_EVERY = 1024     # frames between lookups of a still unmapped frame ID
# AR phases whose cyclic data is not judged: Connect seen but no PrmEnd yet (the settings are not final), or
# the AR ended (released / aborted: frames still mapped to it belong to no data exchange, e.g. the next
# AR's device sending before its Connect response; nothing is judged in the silence between two ARs)
NOT_JUDGED_PHASES = ("parameterisation", "released", "aborted")
MAX_SILENT = 64   # silent streams listed in the summary
JUDGED_FIRST = ("prm_end", "application_ready")  # phases the first judged cycle moves to data_exchange
_MISSING = object()


HELD_MAX = 3   # held-setpoint pairings in a row (_own_setpoint): more is clock drift, not capture jitter


class _Obj:
    """One data object of a mapped frame, compiled once."""

    __slots__ = ("do", "telegram", "source", "layout", "start", "end", "iops_at", "iocs_at", "key", "last", "sig",
                 "bits", "length_checked", "rejected", "ax")

    def __init__(self, do, telegram, source, layout, key, iocs_at=None):
        self.do = do
        self.telegram = telegram
        self.source = source
        self.layout = layout
        self.start = do.offset
        self.end = do.offset + do.length
        self.iops_at = do.offset + do.length
        # an actual value's frame carries the device's IOCS of the same submodule's outputs: BAD = it does not
        # consume the setpoints (IOxS DataState, wire.md §2.5), so the pair is not judged
        self.iocs_at = iocs_at
        self.key = key
        self.last = None
        self.sig = None
        self.bits = None
        self.length_checked = False
        self.rejected = None
        self.ax = None            # its Axis once known (axes are never replaced): saves a tuple hash per frame


class _Frame:
    __slots__ = ("fm", "direction", "objs", "last_csdu", "misses")

    def __init__(self, fm, direction, objs):
        self.fm = fm
        self.direction = direction
        self.objs = objs
        self.last_csdu = None
        self.misses = 0


class CyclicTracker(AxisTracking):
    def __init__(self, analyzer):
        self.a = analyzer
        self.s = analyzer.settings
        self.misses: dict = {}        # unmapped key -> frames seen since the last lookup
        # (frame_id, src, dst) -> _Frame | None; bounded (Settings.max_streams), misses go with their key
        lim = limits.of(analyzer)
        self.frames: dict = lim.table(self.s.max_streams, "streams",
                                                  lambda k, _v: self.misses.pop(k, None))
        self.map_generation = None    # session.map_generation the cached layouts belong to
        self.axes: dict = lim.table(self.s.max_streams, "streams")   # axis key -> Axis
        self.unmapped = 0
        # unmapped key -> frames: those of a stream an AR maps later (a device sending before the Connect
        # response, as real devices do) are not "unknown streams" in the verdict's trust signals
        self.unmapped_by_key: dict = lim.table(self.s.max_streams, "streams")
        self.trailers: dict = {}      # stream key -> its frames' bytes after the IOCR's C_SDU (_trailer_check)
        self.trailer_checked: set = set()   # streams looked at for a trailer (per map generation)
        self.trim_to: dict = {}       # stream key -> its C_SDU length by the Connect, where its frames are longer
        self.fcs_kept: dict = {}      # stream key -> a frame of it ending in its own FCS, the capture not saying so
        self.no_telegram = 0          # frames of a known AR that carry no encoder telegram (IO devices)
        self.mapped = 0
        self.gated = 0
        cap = self.s.max_stations
        self.records: dict = lim.table(cap, "profiles")  # device -> [record/param events] (replayed into new axes)
        self.bf00: dict = lim.table(cap, "profiles")     # device MAC -> (ar_uuid, decoded 0xBF00) of the latest write
        self.prev_bf00: dict = lim.table(cap, "profiles")  # device MAC -> decoded 0xBF00 of an earlier connection (#31)
        self.bf00_before: dict = {}   # (device MAC, frame of a 0xBF00 write) -> self.bf00's entry before it (refusals)
        self.alarm_seq: dict = {}     # (device MAC, alarm endpoint, priority) -> last alarm's sequence number (resends)
        # (device MAC, AR UUID) -> response frame of a 0xBF00 write whose request the capture lost
        self.bf00_unseen: dict = lim.table(cap, "profiles")
        self.byte_order = "little" if self.s.byte_order == "little" else "big"
        # With a sink: called as telegram_sink(obj, frame, frame_id, fn, ts, iops, judged) instead of building
        # a ``telegram`` event dict per frame (the MCAP exporter formats its message from obj.sig itself).
        self.telegram_sink = None
        # Called as stream_sink(key, fn, ts, frame, off) for every cyclic frame the tracker sees (the column
        # sinks' rows of frames that go one by one, pndiss/batches.py); off: where the FrameID starts.
        self.stream_sink = None
        # bounded like self.frames; not a Limits table: the flood that evicts here is counted there already
        self.gaps = GapTracker(getattr(self.s, "capture_gaps", True), limits.BoundedDict(self.s.max_streams, "streams"))
        self.gaps.reader_of = lambda: getattr(self.a, "reader", None)   # (the driver replaces the reader)
        self.infer = Inference(analyzer, getattr(self.s, "infer_telegrams", True))

    def count_unmapped(self, key: tuple, n: int) -> None:
        self.unmapped += n
        self.unmapped_by_key[key] = self.unmapped_by_key.get(key, 0) + n

    def unmapped_before_ar(self) -> int:
        """Unmapped frames of streams that an AR of the capture maps by now (sent before its Connect response)."""
        maps = self.a.session.maps
        return sum(n for k, n in self.unmapped_by_key.items() if k in maps)

    # -- frame layout ------------------------------------------------------------------------------
    def _frame(self, key, rt_ev) -> _Frame | None:
        fr = self.frames.get(key, _MISSING)
        if fr is not _MISSING:
            if fr is not None:
                return fr
            self.misses[key] += 1
            if self.misses[key] % RELOOKUP_EVERY:
                return None  # still unmapped; the session may learn the AR later, so ask again now and then
        fm = self.a.session.lookup(*key)
        if fm is None:
            self.frames[key] = None
            self.misses.setdefault(key, 0)
            return None
        objs = []
        direction = "setpoint" if fm.direction == "output" else "actual"
        if fm.send_clock_factor and fm.reduction_ratio:
            self.gaps.step_from(key, fm.send_clock_factor * fm.reduction_ratio)
        for do in fm.objects:
            if not do.length:
                continue
            telegram, source = do.telegram, do.telegram_source
            if self.s.telegram and source != NOT_OWNED and (telegram is None or (
                    str(source).startswith("length") and int(self.s.telegram) in tg.TELEGRAMS and all(
                    tg.length(int(self.s.telegram), d) == tg.length(telegram, d) for d in tg.DIRECTIONS))):
                # beats a length guess of the same lengths (81 for OEM 100), not another device's telegram
                telegram, source = int(self.s.telegram), "settings.telegram"
            # No telegram from the session (map, P922, GSDML, or both directions' lengths): not an
            # encoder submodule. A one-direction length guess would call any IO module a telegram.
            if telegram not in tg.TELEGRAMS:
                continue
            ax_key = (fm.ar_uuid or (fm.controller_mac, fm.device_mac), do.api, do.slot, do.subslot)
            iocs_at = next((c.offset for c in fm.iocs if (c.api, c.slot, c.subslot) == (do.api, do.slot, do.subslot)),
                           None) if direction == "actual" else None
            objs.append(_Obj(do, telegram, source, tg.layout(telegram, direction, self.byte_order), ax_key, iocs_at))
        fr = _Frame(fm, direction, objs)
        self.frames[key] = fr
        return fr

    # -- per frame ---------------------------------------------------------------------------------
    def on_frame(self, rt_ev: dict, pdu: bytes, csdu_off: int) -> None:
        self.on_cyclic((rt_ev["frame_id"], rt_ev["src"], rt_ev["dst"]), rt_ev["frame"], rt_ev["ts_ns"],
                       judgeable(rt_ev["ds"], rt_ev["transfer_status"]), pdu, csdu_off, rt_ev)

    def on_cyclic(self, key: tuple, fn: int, ts: int, ds_ok: bool, pdu: bytes, csdu_off: int,
                  rt_ev: dict | None = None) -> None:
        """on_frame without the rt event (pndiss/fast.py): key = (frame_id, src, dst); rt_ev is needed only
        with a sink (telegram events copy from it)."""
        gen = self.a.session.map_generation
        if gen != self.map_generation:  # a Connect or a P922 read changed the AR maps: look up again
            self.map_generation = gen
            self.frames.clear()
            self.misses.clear()
            self.trailer_checked.clear()
        if self.stream_sink is not None:
            self.stream_sink(key, fn, ts, pdu, csdu_off - 2)
        if key not in self.trailer_checked:   # once per stream and map generation, before copies are told apart
            fm = self.a.session.lookup(*key)
            if fm is None:
                self._fcs_check(key, fn, pdu)   # (a stream of no known AR: only said, nothing to read it by)
            if fm is None or self._trailer_check(key, fm, fn, pdu, csdu_off):
                self.trailer_checked.add(key)
        cut = self.trim_to.get(key)
        if cut is not None and len(pdu) > csdu_off + cut + 4:
            # bytes after the C_SDU + APDU status the Connect gives (a TAP's trailer, an FCS kept): the status and
            # cycle counter are where the Connect puts them, not at the frame's end (the engine sends these one
            # by one: engine.Window._categories)
            pdu = pdu[:csdu_off + cut + 4]
            ds_ok = judgeable(pdu[-2], pdu[-1])
        # a mirror port's copy of the previous frame is no cycle; capture loss: cycles this stream sent that
        # the capture does not hold (pndiss/gaps.py)
        cc, last = (pdu[-4] << 8) | pdu[-3], (pdu[-2], bytes(pdu[csdu_off:len(pdu) - 4]))
        if self.gaps.duplicate(key, fn, ts, cc, last):
            return
        miss = self.gaps.advance(key, fn, ts, cc, last)
        fr = self.frames.get(key)
        if fr is None:  # not cached, or cached as unmapped (then _frame counts the miss)
            fr = self._frame(key, rt_ev)
            if fr is None or not fr.objs:
                if miss:
                    self._capture_gap(key, fn, ts, miss, fr)
                if fr is None and self.infer.enabled:
                    # mid-session: learn from the content (the DataStatus says which frames may be samples)
                    self.infer.offer(key, fn, pdu[csdu_off:len(pdu) - 4], ts, pdu[-2])
                if fr is None:
                    self.count_unmapped(key, 1)
                else:
                    self.no_telegram += 1
                return
        elif not fr.objs:  # an AR's frame without an encoder telegram (an ordinary IO device)
            if miss:
                self._capture_gap(key, fn, ts, miss, fr)
            self.no_telegram += 1
            return
        if miss:
            self._capture_gap(key, fn, ts, miss, fr)
        self.mapped += 1
        if fr.fm.phase in NOT_JUDGED_PHASES:
            ds_ok = False   # before PrmEnd or after the AR's end: reported, not judged
            if fr.fm.phase != "parameterisation":
                self.gaps.restart(key)   # the AR ended: a later AR on this stream is no capture loss
        elif fr.fm.primary_only and not pdu[-2] & 1:
            ds_ok = False   # the backup AR of a redundant system: the device acts on the primary's outputs
        csdu = pdu[csdu_off:len(pdu) - 4]
        same = csdu == fr.last_csdu
        fr.last_csdu = csdu
        sink = self.a.frame_events or self.telegram_sink is not None or None
        direction = fr.direction
        n_csdu = len(csdu)
        for o in fr.objs:
            do = o.do
            t = do.telegram
            if t is not None and t != o.telegram and t != o.rejected and not (
                    o.source == "settings.telegram" and str(do.telegram_source).startswith("length")):
                self._relabel(o, fr)  # the session learnt the telegram (P922) after the first frame
            if not same or o.sig is None:
                if o.end > n_csdu:
                    raise Malformed("telegram", f"data object {do.slot}/{do.subslot} ends at byte {o.end} of a "
                                                f"{n_csdu}-byte C_SDU")
                if not o.length_checked:
                    o.length_checked = True
                    self._length_check(o, fr, fn, ts)
                if do.length < o.layout.length:
                    continue
                o.sig = o.layout.decode(csdu, o.start)
                o.bits = None
            iops = csdu[o.iops_at] if o.iops_at < n_csdu else None
            ok = ds_ok and iops is not None and iops & IOPS_GOOD
            if o.iocs_at is not None and ok:   # the device consumes the setpoints (its IOCS of them is GOOD)
                ok = o.iocs_at < n_csdu and csdu[o.iocs_at] & IOPS_GOOD
            ax = o.ax
            if ax is None:
                ax = self.axes.get(o.key)
                if ax is None:
                    ax = self._axis(o, fr)
                elif ax.telegram != o.telegram or ax.source != o.source:   # (or P922 confirmed a length guess)
                    # layouts were rebuilt after the session relabelled the telegram (P922): the
                    # checker took it from the P922 read itself; keep the axis' report in step
                    ax.telegram, ax.source, ax.ambiguous = o.telegram, o.source, None   # weighed again
                o.ax = ax
            chk = ax.checker
            if direction not in chk.io_len:
                chk.io_len[direction] = do.length
                self._refine_profile(ax)
            if sink is not None:  # after the axis exists: its bits follow the axis profile
                # (judged: not while the telegram is only guessed from lengths that fit several -- an audit)
                jok = bool(ok) and not ax.ambiguous
                if self.telegram_sink is None:
                    self._telegram_event(o, fr, rt_ev, iops, jok)
                else:
                    self.telegram_sink(o, fr, key[0], fn, ts, iops, jok)
            if direction == "setpoint":
                before = ax.sp_before
                ax.sp_before = ax.sp if ax.sp_ok else None
                if miss or (ax.sp_new and not self.gaps.faster(key, ax.ac_key)):
                    # setpoint cycles lost, or one was never paired: no edge across (an output CR faster than
                    # the input CR leaves setpoints unpaired by design: the device acts on the latest) -- unless
                    # the next actual value turns out to be the unpaired one's, captured late (_own_setpoint)
                    if not miss and ax.held is None and ax.phase is not None and ax.held_paired < HELD_MAX:
                        ax.held = (ax.sp, ax.sp_frame, ax.sp_ok, before, ax.sp_ts)
                    else:
                        ax.sp_break, ax.held = True, None
                ax.sp, ax.sp_frame, ax.sp_ok, ax.sp_ts = o.sig, fn, bool(ok), ts
                ax.sp_new, ax.sp_key, ax.nosp = True, key, 0
                pend = ax.pend
                if pend is not None:  # an actual value came before its setpoint (RT clocks drift): pair them now
                    ax.pend = None
                    if miss:  # ... unless its setpoint is among the lost ones: that cycle is not judged
                        ax.sp_break = False
                        self._out(ax.checker.lost(pend[1], pend[2], 1))
                    else:
                        ax.sp_new, ax.held_paired = False, 0
                        ax.phase = pend[2] - ts
                        self._judge(ax, *pend)
                continue
            ax.ac_key = key
            if ax.ambiguous is None:
                ax.ambiguous = self._ambiguous(ax, o)
            if ax.sp is None:
                continue  # no setpoint seen yet: nothing to pair
            if ax.held is not None and self._own_setpoint(ax, miss, ts, o.sig, fn, ok):
                continue
            if ax.pend is not None:  # two actual values, no setpoint between: the first one's setpoint is lost
                pend, ax.pend = ax.pend, None
                ax.nosp += 1
                self._out(ax.checker.lost(pend[1], pend[2], 1))
            if miss or ax.sp_break or not ax.sp_new:
                # elapsed cycles, not captured frames: the cycles the capture lost are not judged
                if self._unpaired(ax, key, miss, fn, ts, o.sig, bool(ok)):
                    continue
            ax.sp_new, ax.held_paired = False, 0
            ax.phase = ts - ax.sp_ts
            self._judge(ax, o.sig, fn, ts, ok)

    def _own_setpoint(self, ax: Axis, miss: int, ts: int, sig: dict, fn: int, ok) -> bool:
        """A setpoint came while the one before it was unpaired (``ax.held``): when this actual value lies from the
        held one as the last pair's values lay from theirs (``ax.phase``), it is the held one's, captured a
        little late (time-stamp jitter swapped two frames): paired with it, the newer setpoint waits for the next
        value and the pairing keeps its phase (within half a cycle). Otherwise the held one was never paired
        (as before: a break). At most HELD_MAX times in a row: clocks drifting past a cycle look the same again
        every cycle, and then the latest setpoint is the value's (``held_paired``); jitter is now and then."""
        h, ax.held = ax.held, None
        h_sig, h_frame, h_ok, h_before, h_ts = h
        d0, d1, T = abs(ts - h_ts - ax.phase), abs(ts - ax.sp_ts - ax.phase), self.gaps.period_ns(ax.sp_key)
        if miss or not T or d0 >= d1 or 2 * d0 >= T:   # within half a cycle of the phase: jitter, not a change
            ax.sp_break = True
            return False
        cur = (ax.sp, ax.sp_frame, ax.sp_ok, ax.sp_before, ax.sp_ts)
        ax.sp, ax.sp_frame, ax.sp_ok, ax.sp_before, ax.sp_ts = h_sig, h_frame, h_ok, h_before, h_ts
        ax.phase = ts - h_ts
        ax.held_paired += 1
        self._judge(ax, sig, fn, ts, ok)
        ax.sp, ax.sp_frame, ax.sp_ok, ax.sp_before, ax.sp_ts = cur
        return True

    def _judge(self, ax: Axis, sig: dict, fn: int, ts: int, ok) -> None:
        """One cycle: the actual value ``sig`` with the axis' setpoint (gated on DataStatus / IOPS)."""
        chk = ax.checker
        if not (ok and ax.sp_ok) or ax.ambiguous:
            self.gated += 1
            if ax.ambiguous:
                chk.unsure_cycles += 1   # (said apart from the DataStatus reasons: verdict.not_checked)
            self._out(chk.gap(fn, ts, "not valid"))
            return
        if ax.fm is not None and ax.fm.phase in JUDGED_FIRST:
            self._exchange(ax.fm, fn, ts)
        evs = chk.cycle(fn, ts, ax.sp, sig, ax.sp_frame, ax.sp_before, ax.sp_ts)
        if evs:
            self._out(evs)

    def _unpaired(self, ax: Axis, key: tuple, miss: int, fn: int, ts: int, sig: dict, ok: bool) -> bool:
        """Capture loss around this actual value: the lost cycles elapse unjudged (Checker.lost). True when
        the value waits for its own setpoint (the latest one was paired already and both streams run at
        one step): the next setpoint is paired with it, or, if that setpoint was lost, it is not judged."""
        stale = not ax.sp_new and self.gaps.same_step(ax.sp_key, key)
        if not (miss or ax.sp_break or stale):
            return False
        brk, ax.sp_break = ax.sp_break, False
        if miss or brk:
            self._out(ax.checker.lost(fn, ts, miss))
        if stale:
            ax.pend = (sig, fn, ts, ok)
        return stale

    def _capture_gap(self, key: tuple, fn: int, ts: int, miss: int, fr) -> None:
        fm = fr.fm if fr is not None else None
        st = self.a.stations.by_mac
        station = fm.station if fm is not None else None
        if station is None:
            station = (st.get(key[1]) or st.get(key[2]) or {}).get("name")
        ev = {"frame": fn, "ts_ns": ts, "kind": "capture_gap", "station": station, "frame_id": key[0],
              "src": key[1], "dst": key[2], "direction": fm.direction if fm is not None else None,
              "cycles_missing": miss, "prev_frame": self.gaps.prev, "next_frame": fn}
        self.gaps.keep({k: ev[k] for k in ("frame_id", "src", "dst", "station", "direction",
                                          "prev_frame", "next_frame", "cycles_missing")})
        self.a.emit(ev)

    def _out(self, evs) -> None:
        if evs:
            emit = self.a.emit
            for ev in evs:
                emit(ev)

    def _telegram_event(self, o: _Obj, fr: _Frame, rt_ev: dict, iops, ok: bool) -> None:
        fm, do = fr.fm, o.do
        if o.bits is None:
            ax = self.axes.get(o.key)
            o.bits = tg.bits(o.sig, ax.profile if ax else "generic")
        ev = {"frame": rt_ev["frame"], "ts_ns": rt_ev["ts_ns"], "kind": "telegram", "direction": fr.direction,
              "telegram": o.telegram, "telegram_source": o.source, "station": fm.station,
              "device_mac": fm.device_mac, "api": do.api, "slot": do.slot, "subslot": do.subslot,
              "frame_id": rt_ev["frame_id"], "iops": iops, "judged": ok, "signals": o.sig, "bits": o.bits}
        if o.bits.get("g1_zsw.sensor_error") and "g1_xist2" in o.sig:  # G1_XIST2 holds an error code (cyclic.md §9)
            ev["xist2_error"] = {"code": o.sig["g1_xist2"], "text": tg.error_text(o.sig["g1_xist2"])}
        self.a.emit(ev)

    def _length_check(self, o: _Obj, fr: _Frame, fn: int, ts: int) -> None:
        # once per data object and telegram: the layouts are compiled again whenever any AR's maps change (a
        # Connect of another device), which is no new finding
        if o.source == "length (guess)" or o.do.length_checked_for == o.telegram:
            return
        o.do.length_checked_for = o.telegram
        words = tg_length_problem(o.telegram, fr.direction, o.do.length)
        if words:
            # 64: IO data length fits the telegram (000_37bf2397999f1108.txt:1474-1538)
            side = "controller" if fr.direction == "setpoint" else "encoder"
            self.a.emit(rules.violation("TELEGRAM-LENGTH-MISMATCH", fn, ts, f"{words} (telegram from {o.source})",
                                        side=side, station=fr.fm.station, device_mac=fr.fm.device_mac,
                                        slot=o.do.slot, subslot=o.do.subslot))
            ax = self.axes.get(o.key)
            if ax is not None and ax.checker is not None:
                ax.checker.counts.setdefault("TELEGRAM-LENGTH-MISMATCH", {"events": 0, "cycles": 0, "first_frame": fn,
                                                                         "severity": "error", "side": side,
                                                                         "message": words})["events"] += 1

    def _trailer_check(self, key: tuple, fm, fn: int, pdu: bytes, csdu_off: int) -> bool:
        """Bytes after the C_SDU + APDU status the Connect gave the stream (its IOCR DataLength, at least 40):
        a TAP or switch appending its own trailer (time stamps, port), or an FCS kept in a capture that does not
        say so. Wireshark reads the cycle counter and status at the frame's end -- the trailer's (independent
        audits: thousands of "lost" cycles and stale frames, the encoder barely judged, "no violations"); the
        analysis reads them where the Connect puts them (``trim_to``) and names the streams."""
        dl = fm.data_length
        n_csdu = len(pdu) - csdu_off - 4
        longer = bool(dl) and n_csdu > max(40, dl)
        here = longer and _status_at(pdu, csdu_off + max(40, dl))
        end = _status_at(pdu, len(pdu) - 4)
        if longer and not here and not end:
            return False   # no valid status at either place yet (a start-up's frame): the next frames decide
        self.trim_to.pop(key, None)   # (decided afresh: a new Connect on the stream brings its own length)
        if here and not end:
            # a status where the Connect puts it and none at the end (a stack that pads its C_SDU beyond 40 bytes
            # keeps its status at the end: that is no trailer)
            self.trim_to[key] = max(40, dl)
            if key not in self.trailers and len(self.trailers) < MAX_SILENT:
                self.trailers[key] = {"frame_id": key[0], "src": key[1], "dst": key[2], "station": fm.station,
                                      "first_frame": fn, "data_length": dl, "extra_bytes": n_csdu - max(40, dl),
                                      "fcs": _ends_in_fcs(pdu)}
        return True

    def _fcs_check(self, key: tuple, fn: int, pdu) -> None:
        """A stream no AR maps whose frame ends in a valid FCS: the capture keeps the Frame Check Sequence without
        saying so (no if_fcslen, no FCS bit in the pcap link type), so Wireshark and the content inference read the
        FCS as cycle counter and status -- a mid-session capture then judges nothing. Named in Trust (cut it off)."""
        if key not in self.fcs_kept and len(self.fcs_kept) < MAX_SILENT and _ends_in_fcs(pdu):
            self.fcs_kept[key] = {"frame_id": key[0], "src": key[1], "dst": key[2], "first_frame": fn}

    # -- results -----------------------------------------------------------------------------------
    def finish(self) -> None:
        self.infer.finish()
        for ax in self.axes.values():
            if ax.checker is not None:
                self._unsent(ax)
                self._out(ax.checker.finish())

    def _unsent(self, ax: Axis) -> None:
        """The setpoints stopped for good (capture or connection end) while actual values went on (a PLC that lost
        power: the device sends for its DataHold time): those cycles were never sent, not lost by the capture --
        not judged, like a cycle without valid data (an independent audit: counted as lost cycles)."""
        if ax.nosp and ax.checker is not None:
            ax.checker.unsent(ax.nosp)
            self.gated += ax.nosp
        ax.nosp = 0

    def summary(self) -> dict:
        encs = []
        for ax in self.axes.values():
            chk = ax.checker
            s = chk.summary()
            info = ax.info if ax.info.get("station") else {   # (an AR found from content before DCP named it)
                **ax.info, "station": self.a.session.station_name(ax.info.get("device_mac"))}
            encs.append({**info, "telegram": ax.telegram, "telegram_source": ax.source, "profile": ax.profile,
                         "profile_reason": ax.reason, **s,
                         # the length guess fits several telegrams of the profile: reported, not judged
                         **({"telegram_unsure": tg.telegrams_for_length(ax.checker.io_len.get("actual"),
                                                                        ax.checker.io_len.get("setpoint"))}
                            if ax.ambiguous else {})})
            unseen = self.bf00_unseen_for(ax)
            if unseen is not None and not s.get("bf00_seen"):
                encs[-1]["bf00_request_lost"] = unseen
            fm = getattr(ax, "fm", None)
            ar = self.a.session.ars.get(fm.ar_uuid) if fm is not None and fm.ar_uuid else None
            if ar is not None and ar.get("phase") in ("released", "aborted") and ar.get("phases"):
                encs[-1]["ar_ended"] = {"phase": ar["phase"], "frame": ar["phases"][-1]["frame"]}
            if ar is not None:   # which connection: a device reconnected has one axis per AR
                encs[-1]["ar_uuid"], encs[-1]["ar_frame"] = ar.get("ar_uuid"), ar.get("frame")
        before = self.unmapped_before_ar()
        return {"silent_streams": self._silent(), "longer_than_iocr": list(self.trailers.values()),
                "fcs_undeclared": list(self.fcs_kept.values()),
                "frames_mapped": self.mapped, "frames_unmapped": self.unmapped - before,
                "frames_before_ar": before, "frames_no_telegram": self.no_telegram, "cycles_gated": self.gated,
                # every violation, not only the encoders' (DCP, ...): one counting point (Analyzer.violations)
                "encoders": encs, "violations_by_severity": self.a.violations_by_severity(),
                "capture_gaps": self.gaps.summary(), "content_inference": self.infer.summary()}

    def _silent(self) -> list:
        """Mapped streams whose frames stopped well before the capture's end (max(200 ms, 50 cycles)) while their
        AR was neither released nor aborted in the capture: the device or the controller went silent (power, a
        cable) -- which the cycle counter cannot show, as no later frame of the stream comes."""
        end = self.a.last_ts
        out = []
        if end is None:
            return out
        for key, st in self.gaps.streams.items():
            fm = self.a.session.lookup(*key)
            if fm is None or st.ts is None or fm.released or fm.phase in ("released", "aborted"):
                continue
            rel = self.a.session.unknown_releases.get(frozenset(key[1:]))
            if rel is not None and abs(st.ts - rel) <= 1_000_000_000:
                continue   # it stopped at a Release between the two, of an AR the capture saw no Connect of
            cycle = fm.cycle_time_ns or fm.learnt_cycle_ns or 1_000_000
            quiet = end - st.ts
            if quiet > max(200_000_000, 50 * cycle):
                out.append({"frame_id": key[0], "src": key[1], "dst": key[2], "station": fm.station,
                            "direction": fm.direction, "last_frame": st.frame, "silent_ns": quiet})
        out.sort(key=lambda r: r["last_frame"])
        return out[:MAX_SILENT]

    def report_sections(self) -> list:
        from .cyclic_report import sections
        from .gaps_report import section
        summ = self.summary()
        from .infer_report import sections as infer_sections
        return [x for x in [section(summ["capture_gaps"])] if x is not None] + infer_sections(summ) + sections(summ)


def _ends_in_fcs(pdu) -> bool:
    """The frame's last 4 bytes are the Ethernet CRC-32 of the bytes before them (little-endian on the wire)."""
    return len(pdu) >= 64 and zlib.crc32(pdu[:-4]) == int.from_bytes(pdu[-4:], "little")


def _status_at(pdu: bytes, at: int) -> bool:
    """An APDU status at ``at`` (cycle counter, DataStatus, TransferStatus): DataValid set, TransferStatus 0."""
    return at + 4 <= len(pdu) and bool(pdu[at + 2] & 0x04) and pdu[at + 3] == 0
