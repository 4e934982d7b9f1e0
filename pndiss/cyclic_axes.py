"""The encoder axes of the cyclic tracker: one reference-encoder Checker per AR/submodule.

An axis is created at its first cyclic frame (or at its AR's PrmEnd) and configured from the settings,
the session's profile choice and the records seen before it; it follows what the session learns later
(a P922 read relabels its telegram, a PS/PSM-only telegram refines its profile) and what the AR does
(PrmEnd decides STARTUP-NO-PARAM-RECORD, #66). Record and parameter events go to the axes of their
device, and are kept to be replayed into axes that appear later.

A mixin of pndiss.cyclic.CyclicTracker: the tracker's own tables.
"""
from __future__ import annotations

from . import rules
from . import telegrams as tg
from .encoder import Checker, EncoderConfig
from .encoder.config import CONNECT_CYCLE, COUNTER_CYCLE
from .proto.eth import NO_DST

BF00_INDEXES = (0xBF00, 0xFFFF)

_NONE = object()   # no entry (on_write_refused)
ENDED = ("released", "aborted")   # AR phases after which its axes take no other AR's events
ALARM_RESEND_NS = 10_000_000_000  # an RTA resends an unacknowledged alarm within its timeout (seconds)


class Axis:
    """One encoder (AR/submodule): its checker, latest setpoint and identity."""

    __slots__ = ("key", "info", "checker", "sp", "sp_frame", "sp_ok", "telegram", "source", "profile", "reason",
                 "fm", "ambiguous", "sp_before", "sp_new", "sp_break", "sp_key", "ac_key", "pend", "sp_ts", "phase",
                 "held", "held_paired", "nosp")

    def __init__(self, key, info):
        self.key = key
        self.info = info
        self.checker = None
        self.sp = None
        self.sp_frame = None
        self.sp_ok = False
        self.sp_before = None     # the setpoint frame before sp (the controller's sign-of-life is judged on them)
        self.telegram = None
        self.source = None
        self.profile = "generic"
        self.reason = ""
        self.fm = None
        self.ambiguous = None     # telegram guessed from a length that fits several: report, don't judge
        self.sp_new = False       # the latest setpoint is not paired with an actual value yet
        self.sp_break = False     # setpoint cycles lost (or one never paired) since the last paired cycle
        self.sp_key = None        # the setpoint's stream key
        self.ac_key = None        # the actual value's stream key
        self.pend = None          # (signals, frame, ts, ok) of an actual value waiting for its setpoint
        self.sp_ts = None         # capture time of the latest setpoint
        self.phase = None         # actual minus setpoint capture time of the last pair (cyclic.py _own_setpoint)
        self.held = None          # (signals, frame, ok, before, ts) of an unpaired setpoint a newer one followed
        self.held_paired = 0      # pairs in a row of a held setpoint's (cyclic.py _own_setpoint, HELD_MAX)
        self.nosp = 0             # cycles counted lost since the latest setpoint (no setpoint between two actual
                                  # values): if no setpoint follows, the controller stopped sending (unsent_cycles)


class AxisTracking:
    """CyclicTracker mixin: the axes, their telegram and profile, the AR phases and records they follow."""

    # -- encoders ----------------------------------------------------------------------------------
    def _axis(self, o, fr) -> Axis:
        fm, do = fr.fm, o.do
        info = {"station": fm.station, "device_mac": fm.device_mac, "api": do.api, "slot": do.slot, "subslot": do.subslot}
        ax = Axis(o.key, info)
        ax.fm = fm
        ax.telegram, ax.source = o.telegram, o.source
        prof = getattr(self.a.session, "profile_for", None)
        ax.profile, ax.reason = prof(fm.device_mac) if prof else (self.s.profile if self.s.profile != "auto" else "generic",
                                                                  "settings" if self.s.profile != "auto" else "no session profile")
        iso = None
        fid = fm.frame_id
        if fid is not None:
            iso = tg_is_irt(fid)
        cycle, cycle_source = fm.cycle_time_ns, CONNECT_CYCLE
        if cycle is None and fm.learnt_cycle_ns:
            cycle, cycle_source = fm.learnt_cycle_ns, COUNTER_CYCLE
        cfg = EncoderConfig.from_settings(self.s, profile=ax.profile, telegram=o.telegram, cycle_ns=cycle,
                                          cycle_source=cycle_source, iso=iso, profile_reason=ax.reason,
                                          telegram_source=o.source)
        if fm.learnt_k and not str(cfg.sources.get("k", "")).startswith("settings."):
            # as record 0x8030 does (encoder/acyclic.py): replaces the default k = 1, not a k given with --set
            cfg.k, cfg.sources["k"] = fm.learnt_k
        ax.checker = Checker(cfg, info)
        ax.checker.io_len[fr.direction] = do.length
        self._refine_profile(ax)
        ax.checker.prev_bf00 = self.prev_bf00.get(fm.device_mac)
        self.axes[o.key] = ax
        for ev in self.records.get(fm.device_mac, ()):  # records seen before the first cyclic frame, in order
            if (ev.get("ar_uuid") is None or fm.ar_uuid is None or ev.get("ar_uuid") == fm.ar_uuid) \
                    and addressed_to(ax, ev, self.a.session):
                self._out(ax.checker.on_record(ev))  # a 0xBF00 among them configures the checker
        return ax

    def _relabel(self, o, fr) -> None:
        t = o.do.telegram
        ax = self.axes.get(o.key)
        if t not in tg.TELEGRAMS or (ax is not None and ax.checker.p922_rejected == t):
            o.rejected = t  # P922 contradicts the AR's lengths: the checker reported it, keep the AR's view
            return
        o.telegram, o.source = t, o.do.telegram_source
        o.layout = tg.layout(t, fr.direction, self.byte_order)
        o.sig = o.bits = None
        o.length_checked = False
        if ax is None:
            return
        ax.telegram, ax.source, ax.ambiguous = t, o.source, False
        ax.sp = ax.sp_before = None  # decoded with the old layout, as a held setpoint and a waiting actual value are
        ax.held = ax.pend = None
        c = ax.checker.cfg
        if c.telegram != t or "length" in str(c.sources.get("telegram")):
            c.telegram = t
            c.sources["telegram"] = o.source or "session"
        self._refine_profile(ax)
        chk = ax.checker
        chk.reconfigure()
        self._out(chk.end_runs())  # the open runs end with the old layout

    def _ambiguous(self, ax, o) -> bool:
        """A length guess is judged when both data lengths leave one candidate among the profile's telegrams,
        or a standard telegram among several of a profile without OEM telegrams of the same lengths;
        otherwise cycles are reported, not judged, until P922 names the telegram (cyclic.md §14)."""
        return self._guess_fits_several(ax, o.source)

    @staticmethod
    def _guess_fits_several(ax, source) -> bool:
        if "length" not in str(source):
            return False
        io = ax.checker.io_len
        # telegrams of the same layout are one candidate (PS/PSM 86 = 860, 002_d69f444daf0f8af2.txt:729, 940)
        cands = {(tuple(map(tuple, tg.TELEGRAMS[t]["setpoint"])), tuple(map(tuple, tg.TELEGRAMS[t]["actual"])))
                 for t in tg.telegrams_for_length(io.get("actual"), io.get("setpoint"))
                 if ax.profile in tg.TELEGRAMS[t]["profiles"] or (ax.profile == "generic" and t in tg.STANDARD)}
        # PS/PSM has OEM telegrams of the standard ones' lengths (100: 4/12 bytes as 81, 101: 8/16): 81 being
        # mandatory (002_d69f444daf0f8af2.txt:528) says the device supports it, not that the AR runs it
        return len(cands) > 1 and (ax.telegram not in tg.STANDARD or ax.profile == "psm")

    def _refine_profile(self, ax) -> None:
        """A 'generic' device is PS/PSM when it uses a telegram only PS/PSM has (86-89/100/101, cyclic.md §2)
        or when the session learnt so later (a write of record 0xFFFF, session_records.profile_for)."""
        if ax.profile != "generic":
            return
        t = ax.telegram
        reason = None
        if t in tg.TELEGRAMS and tg.TELEGRAMS[t]["profiles"] == ["psm"] and not (
                "length" in str(ax.source) and tg.telegrams_for_length(ax.checker.io_len.get("actual"),
                                                                       ax.checker.io_len.get("setpoint")) != [t]):
            # a length guess proves the vendor only when no other telegram fits
            reason = f"telegram {t} exists only in PS/PSM (cyclic.md §2); {ax.reason}"
        else:
            got = self._session_profile(ax.info["device_mac"])
            if got is None or got[0] != "psm":
                return
            reason = got[1]
        ax.profile, ax.reason = "psm", reason
        ax.ambiguous = None   # PS/PSM has OEM telegrams of the standard lengths: the guess is weighed again
        for fr in self.frames.values():  # bits were cached with the old profile
            for ob in (fr.objs if fr else ()):
                if ob.key == ax.key:
                    ob.bits = None
        if ax.checker is not None:
            ax.checker.cfg.profile = "psm"
            ax.checker.cfg.sources["profile"] = ax.reason
            ax.checker.reconfigure()
            for ev in self.records.get(ax.info["device_mac"], ()):  # PS/PSM keeps its parameters at 0xFFFF
                if ev.get("kind") == "record" and ev.get("index") == 0xFFFF and addressed_to(ax, ev, self.a.session):
                    self._out(ax.checker.on_record(ev))

    # -- AR phases (SessionTracker.set_phase, session_ar.py) --------------------------------------------
    def on_phase(self, ar: dict, phase: str, fn: int, ts: int) -> None:
        if phase == "prm_end":
            for ax in self._ar_axes(ar):
                self._startup(ax, fn, ts)
        elif phase in ("released", "aborted"):
            self.restart_gaps(key for key, _fm in self.a.session.frame_keys(ar))   # a later AR: no capture loss

    def restart_between(self, a: str, b: str) -> None:
        """Every cyclic stream between MACs ``a`` and ``b`` starts a new cycle counter (a new AR between them)."""
        self.restart_gaps([k for k in self.gaps.streams if {k[1], k[2]} == {a, b}])

    def restart_gaps(self, keys) -> None:
        """These streams' next frames start a new cycle counter (an AR ends or is being replaced)."""
        for key in keys:
            self.gaps.restart(key)

    def _exchange(self, fm, fn: int, ts: int) -> None:
        """The AR's first judged cycle: its phase becomes data_exchange."""
        ar = self.a.session.ars.get(fm.ar_uuid)
        if ar is not None and any(m is fm for m in ar["maps"]):
            self.a.session.set_phase(ar, "data_exchange", fn, ts, "first judged cycle")
        else:
            fm.phase = "data_exchange"

    def _ar_axes(self, ar: dict) -> list:
        """The encoder axes of an AR, created now if no cyclic frame of them came yet (like on_cyclic would)."""
        gen = self.a.session.map_generation
        if gen != self.map_generation:
            self.map_generation = gen
            self.frames.clear()
            self.misses.clear()
        out = []
        for key, fm in self.a.session.frame_keys(ar):
            fr = self.frames.get(key)
            if fr is None:
                fr = self._frame(key, None)
            if fr is None or fr.fm is not fm:
                continue
            for o in fr.objs:
                ax = o.ax or self.axes.get(o.key)
                if ax is None:
                    ax = self._axis(o, fr)
                o.ax = ax
                if fr.direction not in ax.checker.io_len:
                    ax.checker.io_len[fr.direction] = o.do.length
                    self._refine_profile(ax)
                if ax not in out:
                    out.append(ax)
        return out

    def _startup(self, ax: Axis, fn: int, ts: int) -> None:
        """66: 0xBF00 (PS/PSM 0xFFFF) is written at every start-up, before PrmEnd (000_37bf2397999f1108.txt:
        1162-1163), on its own or inside a MultipleWrite (0xE040: pndiss.session emits the inner writes)."""
        chk = ax.checker
        if ax.fm is None or ax.fm.source != "connect" or not chk.cfg.std or chk.bf00_seen \
                or (self._unsure(ax) and ax.profile == "generic"):
            # (a length guess that fits several telegrams of a known vendor -- PS/PSM 81 or 100 -- is an encoder
            # either way, and #66 asks for no telegram layout; of an unknown vendor it may be no encoder at all)
            return
        if self.bf00_unseen_for(ax) is not None:
            return  # its request was lost, its response shows the write (verdict.trust says so)
        if any(do.locked for do in ax.fm.objects if (do.slot, do.subslot) == (ax.info["slot"], ax.info["subslot"])):
            return  # another AR owns the module (ModuleDiffBlock): this AR does not parameterise it
        ev = rules.violation("STARTUP-NO-PARAM-RECORD", fn, ts,
                             "PrmEnd without a write of 0xBF00" + (" / 0xFFFF" if ax.profile == "psm" else "")
                             + " since the Connect of this AR", **ax.info)
        chk.counts["STARTUP-NO-PARAM-RECORD"] = {"events": 1, "cycles": 1, "first_frame": ev["frame"],
                                                 "severity": ev["severity"], "side": ev["side"],
                                                 "message": ev["message"]}
        self.a.emit(ev)

    def _unsure(self, ax: Axis) -> bool:
        """A telegram only guessed from lengths that fit several is not judged (cyclic.md §14): nor is #66."""
        return self._guess_fits_several(ax, ax.source)

    def on_reconnect(self, ar: dict, fn: int, ts: int) -> None:
        """An AR UUID connected again (session_ar: controllers may reuse it): its axes go on with the new frame
        maps, and each checker starts a new connection (Checker.new_connection)."""
        uid, dev = ar["ar_uuid"], ar["device_mac"]
        old = self.bf00.get(dev)
        if old is not None and old[0] == uid:
            self.prev_bf00[dev] = old[1]     # what the next 0xBF00 is compared with (#31)
            del self.bf00[dev]
        self.bf00_unseen.pop((dev, uid), None)
        self.restart_gaps(key for key, _fm in self.a.session.frame_keys(ar))   # a new connection: new counters
        maps = [fm for _key, fm in self.a.session.frame_keys(ar)]
        for ax in self.axes.values():
            if ax.key[0] != uid:
                continue
            same = [fm for fm in maps if ax.fm is not None and fm.direction == ax.fm.direction]
            ax.fm = (same or maps or [ax.fm])[0]
            self._unsent(ax)   # the old connection's setpoints ended there
            ax.sp = ax.sp_frame = ax.sp_before = ax.pend = ax.ac_key = ax.held = None   # the pairing starts afresh
            ax.sp_ok = ax.sp_new = ax.sp_break = False
            self._out(ax.checker.new_connection(self.prev_bf00.get(dev)))
            self._reconnect_config(ax, maps)

    def _reconnect_config(self, ax, maps) -> None:
        """The new Connect's telegram and cycle for the axis' submodule: a project downloaded with another telegram
        or cycle time reconnects with the same AR UUID (an independent audit: the old telegram's lengths stayed,
        a false TELEGRAM-SELECTION-MISMATCH); the data lengths come again with the new connection's frames."""
        chk = ax.checker
        c = chk.cfg
        chk.io_len.clear()
        changed = False
        for fm in maps:
            for do in fm.objects:
                if (do.api, do.slot, do.subslot) == ax.key[1:] and do.telegram in tg.TELEGRAMS and do.telegram != c.telegram:
                    c.telegram, c.sources["telegram"] = do.telegram, do.telegram_source or "Connect"
                    ax.telegram, ax.source = do.telegram, do.telegram_source
                    changed = True
        cyc = ax.fm.cycle_time_ns if ax.fm is not None else None
        if cyc and cyc != c.cycle_ns:
            c.cycle_ns, c.sources["cycle_ns"] = cyc, CONNECT_CYCLE
            changed = True
        if changed:
            self._refine_profile(ax)
            chk.reconfigure()

    # -- records -----------------------------------------------------------------------------------
    def on_write_result(self, ev: dict) -> None:
        """A write response whose request the capture lost (session_records._unseen_writes): a successful
        one of the user parameter record proves the start-up write #66 asks for; its values stay unknown."""
        dev = ev.get("device_mac")
        if not ev.get("ok") or ev.get("index") not in BF00_INDEXES:
            return
        if ev["index"] == 0xFFFF:
            for ax in list(self.axes.values()):  # the response may have named the device PS/PSM
                if ax.info["device_mac"] == dev and ax.profile == "generic":
                    self._refine_profile(ax)
            got = self._session_profile(dev)
            if got is None or got[0] != "psm":
                return   # 0xFFFF is the user parameter record of PS/PSM only
        self.bf00_unseen[(dev, ev.get("ar_uuid"))] = ev["frame"]

    def on_alarm(self, ev: dict) -> None:
        """A DATA-RTA alarm notification (pndiss/proto/alarm.py) from a device: the encoder axes on its
        submodule judge its diagnosis (Checker.on_alarm). The RTA resends a notification until it is
        acknowledged, with the same sequence number: that is the same alarm, judged once."""
        # per AR: a device may use one alarm reference towards two controllers (a shared device)
        key = (ev.get("src"), ev.get("dst"), ev.get("alarm_src_endpoint"), ev.get("priority"))
        last = self.alarm_seq.get(key)
        ts = ev.get("ts_ns", 0)
        resend = last is not None and last[0] == ev.get("send_seq_num") and ts - last[1] <= ALARM_RESEND_NS
        self.alarm_seq[key] = (ev.get("send_seq_num"), ts)   # the window slides with each resend
        if resend:
            return
        if len(self.alarm_seq) > 256:
            self.alarm_seq.pop(next(iter(self.alarm_seq)))
        dst = ev.get("dst")
        if dst == NO_DST:
            dst = None   # a Linux cooked capture names no destination
        for ax in self.axes.values():
            # an ended AR's axis: the alarm is the next AR's; the alarm goes to the controller of one AR (an AR a
            # controller left without a Release in the capture does not take the next controller's alarms)
            if ax.info["device_mac"] == ev.get("src") and ax.info.get("slot") == ev.get("slot_nr") \
                    and ax.info.get("subslot") == ev.get("subslot_nr") and (ax.fm is None or (
                        ax.fm.phase not in ENDED and (dst is None or ax.fm.controller_mac in (None, dst)))):
                self._out(ax.checker.on_alarm(ev))

    def on_new_ar(self, device: str) -> None:
        """A Connect of the device succeeded: its alarm sequence numbers start again (a new AR's first alarm is
        no resend of the old AR's)."""
        for key in [k for k in self.alarm_seq if k[0] == device]:
            del self.alarm_seq[key]

    def on_write_refused(self, ev: dict) -> None:
        """A write the device answered with an error (a ``record_result``, ok false, its request seen): the
        record it carried was applied at the request (on_record), so its checkers take the previous one back
        (Checker.write_refused). A refused 0xBF00 leaves the parameters that were in force."""
        dev = ev.get("device_mac")
        if ev.get("index") not in BF00_INDEXES:
            return
        old = self.bf00_before.pop((dev, ev.get("request_frame")), _NONE)
        if old is not _NONE:
            if old is None:
                self.bf00.pop(dev, None)
            else:
                self.bf00[dev] = old
        for ax in self.axes.values():
            if ax.info["device_mac"] == dev:
                self._out(ax.checker.write_refused(ev.get("request_frame")))

    def _session_profile(self, dev):
        """(profile, reason) the session gives the device, or None (a tracker without one, in tests)."""
        prof = getattr(self.a.session, "profile_for", None)
        return prof(dev) if prof else None

    def bf00_unseen_for(self, ax: Axis):
        """The response frame of a 0xBF00 write of this axis's AR whose request was lost, or None."""
        if not self.bf00_unseen or ax.fm is None:
            return None
        return self.bf00_unseen.get((ax.info["device_mac"], ax.fm.ar_uuid))

    def on_record(self, ev: dict) -> None:
        """``record`` / ``param`` events from the session tracker, in capture order."""
        dev = ev.get("device_mac")
        if ev.get("kind") == "record" and ev.get("index") in BF00_INDEXES and ev.get("op") == "write":
            old = self.bf00.get(dev)
            if old is not None and old[0] != ev.get("ar_uuid"):
                self.prev_bf00[dev] = old[1]
            self.bf00_before[(dev, ev.get("frame"))] = old   # a refused write puts it back (on_write_refused)
            if len(self.bf00_before) > 64:
                self.bf00_before.pop(next(iter(self.bf00_before)))
            self.bf00[dev] = (ev.get("ar_uuid"), ev.get("decoded") or {})
        lst = self.records.setdefault(dev, [])
        kept = len(lst) < 256
        if kept:
            lst.append(ev)
        if ev.get("kind") == "param" and ev.get("index") == 0xB02F and len(self.a.session.encoder_slots(dev)) > 1:
            # a global access: its DO-ID names the drive object, in a numbering only the device knows (records.md
            # §3.2) -- on a device with several encoder modules its values may be any of them: judged for what holds
            # for every axis, not applied to one (an independent audit: P65000 of DO 2 judged as slot 1's preset)
            ev = dict(ev, do_unknown=True)
        for ax in self.axes.values():
            # records of the axis' AR; parameter accesses of any AR of the device while the axis' AR is up: an
            # engineering tool's Device Access AR writes the encoder's one P65000 too (behaviour.md §9.3 #27), and
            # its answers are the device's
            if ax.info["device_mac"] == dev and (ev.get("ar_uuid") is None or ax.fm is None or ax.fm.ar_uuid is None
                                                  or ev.get("ar_uuid") == ax.fm.ar_uuid
                                                  or (ev.get("kind") == "param" and ax.fm.phase not in ENDED)) \
                    and addressed_to(ax, ev, self.a.session):
                if ax.checker.prev_bf00 is None:  # an axis of a restarted AR seen before its own 0xBF00 (#31)
                    ax.checker.prev_bf00 = self.prev_bf00.get(dev)
                if ax.profile == "generic" and ev.get("index") == 0xFFFF and ev.get("profile") == "psm":
                    self._refine_profile(ax)  # replays the device's 0xFFFF records, this one if kept
                    if kept:
                        continue
                self._out(ax.checker.on_record(ev))


def addressed_to(ax: Axis, ev: dict, session=None) -> bool:
    """A record or parameter access for this axis: one addressed to another encoder module of the device is that
    module's (one Encoder Object per module and slot, network.md §1.7; its parameter channel is its own), also
    when another controller's AR owns that module (a shared device); one addressed elsewhere (the DAP, a slot
    no AR's telegrams name, an axis inferred from content) is every axis' of the device."""
    slot = ev.get("slot")
    if slot is None or slot == ax.info.get("slot") or ax.fm is None:
        return True
    if any(do.slot == slot and do.telegram is not None for do in ax.fm.objects):
        return False
    slots = getattr(session, "encoder_slots", None)
    return slots is None or slot not in slots(ax.info["device_mac"])


def tg_is_irt(frame_id: int) -> bool:
    """RT_CLASS_3 frame IDs (0x0100-0x0FFF) mean IRT, i.e. isochronous operation (wire.md §2.2)."""
    return 0x0100 <= frame_id < 0x1000
