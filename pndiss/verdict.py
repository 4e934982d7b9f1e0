"""The verdict: what a commissioning engineer reads first (and last, and alone with ``-q``).

``ViolationLog`` sees every violation event the analyzer emits (one dict update per violation, no
per-frame work) and keeps one row per (rule, side, station): bounded by the catalogue times the
stations. ``build`` joins it with the summary into counts by severity and side, the first frame
of each rule, the capture's trust signals and what was not checked and why.
"""
from __future__ import annotations

from collections import Counter

from . import telegrams as tg
from .armap import NOT_OWNED
from .session_ar import diff_state as _diff_state
from .encoder.config import DEFAULT_SOURCE
from .encoder.value_rules import CONTINUITY_PROFILES
from .rules import RULES

MAX_ROWS = 2000  # (rule, side, station) rows kept; more are counted, not listed
SEV_ORDER = {"error": 2, "warning": 1, "info": 0}
# time going back by more than this is a merge out of order, not two interfaces' clocks a few µs apart
BACKWARDS_NS = 1_000_000


class ViolationLog:
    def __init__(self):
        self.rows: dict[tuple, dict] = {}
        self.total = 0
        self.by_sev: Counter = Counter()
        self.by_sev_side: Counter = Counter()
        self.overflow = 0
        self.keep = None  # optional filter (--station/--time): ev -> bool
        self.on_new = None  # optional callback (--follow): called with each counted violation
        self.by_rule: dict[str, dict] = {}  # rule -> events, cycles, first frame, ... (summary["violations"])

    def add(self, ev: dict) -> None:
        if self.keep is not None and not self.keep(ev):
            return
        sev, side = ev.get("severity", "error"), ev.get("side", "?")
        self._by_rule(ev, sev, side)
        self.total += 1
        self.by_sev[sev] += 1
        self.by_sev_side[(sev, side)] += 1
        key = (ev.get("rule"), side, ev.get("station") or ev.get("device_mac") or ev.get("mac") or "")
        r = self.rows.get(key)
        frame = ev.get("frame", 0)
        if r is None:
            if len(self.rows) >= MAX_ROWS:
                self.overflow += 1
            else:
                self.rows[key] = {"rule": key[0], "side": side, "severity": sev, "station": key[2], "events": 1,
                                  "first_frame": frame, "message": ev.get("message", "")}
        else:
            r["events"] += 1
            if frame < r["first_frame"]:
                r["first_frame"], r["message"] = frame, ev.get("message", r["message"])
        if self.on_new is not None:
            self.on_new(ev)

    def _by_rule(self, ev: dict, sev: str, side: str) -> None:
        frame = ev.get("frame", 0)
        v = self.by_rule.get(ev.get("rule"))
        if v is None:
            v = self.by_rule[ev.get("rule")] = {"events": 0, "cycles": 0, "first_frame": frame, "severity": sev,
                                                "side": side, "message": ev.get("message"), "not_axis": 0}
        v["events"] += 1
        v["cycles"] += ev.get("cycles") or 1
        v["first_frame"] = min(v["first_frame"], frame)
        if ev.get("slot") is None:  # no encoder axis names it (DCP, ...): the report lists it on its own
            if not v["not_axis"]:
                v["not_axis_first"] = (frame, side, ev.get("message"))
            v["not_axis"] += 1

    def by_severity(self) -> dict:
        return {s: self.by_sev.get(s, 0) for s in ("error", "warning", "info")}

    def totals(self) -> dict:
        """The JSON summary's ``violations`` entry: counts by severity and by rule (first frame first)."""
        return {"by_severity": self.by_severity(),
                "by_rule": {r: dict(v) for r, v in sorted(self.by_rule.items(), key=lambda kv: kv[1]["first_frame"])}}

    def summary(self) -> dict:
        """The JSON summary's ``verdict`` entry (pndiss/data/summary.schema.json)."""
        return {"total": self.total, "by_severity": self.by_severity(),
                "by_severity_side": {f"{sev}/{side}": n for (sev, side), n in sorted(self.by_sev_side.items())},
                "rows": self.as_list(), "rows_not_listed": self.overflow}

    def as_list(self) -> list[dict]:
        return sorted(self.rows.values(), key=lambda r: (r["first_frame"], r["rule"]))


def _plural(n: int, word: str) -> str:
    return f"{n:,} {word}" + ("" if n == 1 else "s")


def headline(log: ViolationLog) -> str:
    """'2 errors (1 controller, 1 encoder), 1 warning — first at frame 1419' or 'no violations'."""
    if not log.total:
        return "no violations"
    parts = []
    for sev in ("error", "warning", "info"):
        n = log.by_sev.get(sev, 0)
        if not n:
            continue
        sides = [f"{log.by_sev_side[(sev, s)]:,} {s}" for s in ("controller", "encoder")
                 if log.by_sev_side.get((sev, s))]
        other = n - sum(log.by_sev_side.get((sev, s), 0) for s in ("controller", "encoder"))
        if other:
            sides.append(f"{other:,} other")
        parts.append(_plural(n, sev) + (f" ({', '.join(sides)})" if sides else ""))
    rows = log.as_list()
    first = f" — first at frame {rows[0]['first_frame']} ({rows[0]['rule']})" if rows else ""
    return ", ".join(parts) + first


def no_profinet(summary: dict) -> bool:
    acc = summary.get("accounting", {})
    return summary.get("frames", 0) > 0 and acc.get("decoded", 0) == 0 and acc.get("malformed", 0) == 0


def one_line(summary: dict, log: ViolationLog, with_name: bool = True) -> str:
    """The verdict in one line (the end of the report, ``-q``, the summary's verdict.line)."""
    name = summary.get("capture", "") if with_name else "verdict"
    if summary.get("frames", 0) == 0:
        return f"{name}: no frames in the capture"
    if no_profinet(summary):
        return f"{name}: no PROFINET frames found ({summary['frames']:,} frames, none of them PROFINET)"
    return f"{name}: {headline(log)} in {summary['frames']:,} frames"


# rules whose verdict depends on the V3.1 / V4.1 mode (0xBF00 byte 0 bit 5): their catalogue condition names it
MODE_RULES = frozenset(i for i, r in RULES.items() if "compat" in r["condition"])


MODULE_STATES = {0: "no module", 1: "a wrong module"}   # ModuleDiffBlock ModuleState (wire.md §6.7); 2 proper, 3 substitute


def trust(summary: dict) -> list[str]:
    """Signals on how far the capture can be trusted: gaps, unmapped streams, malformed frames."""
    out = []
    acc = summary.get("accounting", {})
    cyc = summary.get("cyclic", {})
    gaps = cyc.get("capture_gaps") or {}
    n = gaps.get("count") or summary.get("events", {}).get("capture_gap", 0)
    if n:
        lost = gaps.get("cycles_missing")
        extra = f", {lost:,} cycles lost" if isinstance(lost, int) else ""
        out.append(f"capture gaps: {n:,} (frames missing from the capture, seen in the cycle counter{extra}: lost by "
                   "the capture, or on the network -- a link down, an MRP ring reconfiguring -- when the other streams "
                   "are whole over the same time); rules over those cycles are not judged")
    if gaps.get("duplicates"):
        fd = gaps.get("first_duplicate") or [None, None]
        out.append(f"duplicate frames: {gaps['duplicates']:,} cyclic frames are copies of the frame before them "
                   f"(same cycle counter, status and data; first: frame {fd[0]} of frame {fd[1]}): "
                   "a mirror port seeing them twice; counted once as a cycle")
    if gaps.get("stale"):
        fs = gaps.get("first_stale") or [None, None]
        out.append(f"stale frames: {gaps['stale']:,} cyclic frames carry a cycle counter that is not newer than their "
                   f"stream's frame before them (first: frame {fs[0]}, after frame {fs[1]}): late copies of a mirror port "
                   "or a provider repeating its counter; a consumer discards them (PROFINET cycle-counter check), "
                   "so they are no cycles here either")
    for q in cyc.get("silent_streams") or ():
        who = (f"the device {q['src']}'s input frames" if q.get("direction") == "input"
               else f"the controller {q['src']}'s output frames")
        out.append(f"{q.get('station') or q['dst']}: {who} (frame ID 0x{q['frame_id']:04X}) stopped at frame "
                   f"{q['last_frame']:,}, {q['silent_ns'] / 1e9:,.3f} s before the capture ends, with no Release or abort "
                   "of their AR in the capture: the sender went silent (power, a cable, a crash?) -- no rule judges "
                   "cycles that never came")
    sc = (summary.get("session") or {}).get("counts") or {}
    if sc.get("responses_before_request", 0) >= 2:
        out.append(f"responses before their requests: {sc['responses_before_request']:,} DCE/RPC responses are stamped "
                   f"before the request they answer, by up to {sc['responses_before_request_max_ns'] / 1e6:,.3f} ms: "
                   "the capture's interfaces' clocks differ (two NICs, a TAP's ports) -- the two directions are "
                   "that far apart in time, so setpoints may pair with the wrong actual values and response times "
                   "are wrong; capture through one interface or a TAP that stamps both ports with one clock")
    if sc.get("records_undecoded"):
        f, idx, why = (summary.get("session") or {}).get("first_record_undecoded") or [None, 0, ""]
        out.append(f"records that do not decode: {sc['records_undecoded']:,} record data (first: frame {f}, index "
                   f"0x{idx:04X}: {why}) -- what they hold is not judged; a parameter response still answers its "
                   "request (its header is judged, its values are not)")
    fk = cyc.get("fcs_undeclared") or ()
    if fk:
        out.append(f"FCS kept: the frames of {len(fk)} cyclic stream(s) no Connect in the capture maps end in their "
                   f"own Ethernet FCS (first frame {min(q['first_frame'] for q in fk):,}) the capture does not "
                   "declare: Wireshark, and the analysis of a stream known only from its content, read those 4 bytes "
                   "as cycle counter and status -- cut them off (editcap -C -4) or capture with the FCS declared")
    tr = cyc.get("longer_than_iocr") or ()
    if tr:
        extra = sorted({q["extra_bytes"] for q in tr})
        who = sorted({q.get("station") or q["dst"] for q in tr})
        out.append(f"trailer: the cyclic frames of {len(tr)} stream(s) carry {'/'.join(map(str, extra))} byte(s) after "
                   f"the C_SDU and APDU status their Connect gives (first frame {min(q['first_frame'] for q in tr):,}; "
                   f"{', '.join(who[:4])}{' ...' if len(who) > 4 else ''}): "
                   + ("their own Ethernet FCS, which the capture does not declare. " if all(q.get("fcs") for q in tr)
                      else "a TAP's or switch's trailer, or an FCS the capture does not declare? ")
                   + "The analysis reads cycle counter and status where the Connect puts "
                   "them; Wireshark (and the rt / APDU fields of the outputs) reads them at the frame's end, where "
                   "they are the trailer's -- capture without the trailer, or cut it off (editcap -C)")
    inp = summary.get("input") or {}
    for d in inp.get("damaged") or ():
        what = ("cut short in the middle of a packet (a capture still being written, or a capture tool stopped "
                "abruptly)" if d["cut_short"] else "damaged (a corrupt block tshark refuses too)")
        out.append(f"{d['file']} is {what}: its read ended after frame {d['after_frame']:,}; the frames before it "
                   "are analysed, what the file held after it is not")
    if inp.get("frames_cut"):
        out.append(f"{inp['frames_cut']:,} frame(s) cut by the capture's snap length (kept {inp['frames_cut_to_bytes']:,} "
                   f"bytes at most; first at frame {inp['frames_cut_first_frame']}): what was cut off is not decoded, and "
                   "a layer that runs past the kept bytes counts as malformed -- capture with a larger snap length "
                   "(dumpcap -s 0)")
    if inp.get("tool_dropped") or inp.get("interface_dropped"):
        said = []
        if inp.get("tool_dropped"):
            said.append(f"{inp['tool_dropped']:,} packet(s) in the packets' drop counts (first before frame "
                        f"{inp['tool_dropped_first_frame']})")
        if inp.get("interface_dropped"):
            said.append(f"{inp['interface_dropped']:,} in its interface statistics")
        out.append("the capture tool reports packets it dropped: " + " and ".join(said) + " -- frames never "
                   "written; a cyclic stream's loss shows in its cycle counter, and a parameter request pending across "
                   "a reported loss is not judged (its response may be among the lost); capture on a less loaded "
                   "machine, a TAP or a larger buffer (dumpcap -B)")
    if gaps.get("clock_steps"):
        fc = gaps.get("first_clock_step") or [None, None, 0]
        out.append(f"the capture's clock stepped: {gaps['clock_steps']:,} time(s) a stream's time stamps jumped, with the "
                   f"whole capture's, by what its cycle counter contradicts (first at frame {fc[0]}, "
                   f"{fc[2] / 1e9:+,.3f} s after frame {fc[1]}): "
                   "the capture PC's clock was set (NTP?); what was lost there is what the counter says (a capture "
                   "gap above if any), not the time; time spans across it are wrong")
    if (inp.get("timestamps_backwards_max_ns") or 0) >= BACKWARDS_NS:
        out.append(f"frames out of time order: time goes back {inp['timestamps_backwards']:,} time(s), by up to "
                   f"{inp['timestamps_backwards_max_ns'] / 1e6:,.3f} ms (first at frame "
                   f"{inp['timestamps_backwards_first_frame']}): interfaces or files merged without sorting? Frames "
                   "are judged in file order, so setpoints may pair with the wrong actual values; sort it with "
                   "`reordercap IN OUT` (Wireshark) and analyse that -- unless the same streams go on across a few "
                   "large steps back: then the capture PC's clock was set back (NTP?), file order is right, and "
                   "sorting would interleave the two stretches")
    if cyc.get("frames_unmapped"):
        out.append(f"unmapped streams: {cyc['frames_unmapped']:,} cyclic frames of no AR the capture shows "
                   "(no Connect in the capture maps them -- or, in a Linux cooked capture without destination "
                   "addresses, several ARs of one sender share their frame ID -- and nothing was inferred from the "
                   "content): if some are encoders, give them with --map or --set telegram=N; an ordinary IO "
                   "device's need nothing")
    if acc.get("malformed"):
        out.append(f"malformed frames: {acc['malformed']:,} (listed below)")
    for ar in (summary.get("session") or {}).get("ars", []):
        for m in ar.get("module_diff") or ():
            subs = {x["subslot"]: _diff_state(x["state"]) for x in m.get("submodules", ())}
            what = MODULE_STATES.get(m.get("module_state"))
            bad = sorted(f"{m['slot']}/{k} {v}" for k, v in subs.items() if v in ("wrong submodule", "no submodule"))
            if what or bad:
                out.append(f"{ar.get('station') or ar.get('device_mac')} reports {what or 'its module'} in slot {m['slot']}"
                           + (f" ({', '.join(bad)})" if bad else "") + f" (ModuleDiffBlock of the Connect response, frame "
                           f"{ar.get('frame')}): the configuration does not match what is plugged; the controller writes "
                           "such a submodule no parameters, and its cycles are judged only while its IOPS are GOOD")
    for e in cyc.get("encoders", []):
        who = f"{e.get('station') or e.get('device_mac')} {e['slot']}/{e['subslot']}"
        tsrc = _source(e, "telegram", e.get("telegram_source"))
        if "length" in str(tsrc) or "settings" in str(tsrc) or "default" in str(tsrc):
            out.append(f"assumed: {who} telegram {e.get('telegram')} ({tsrc})")
        runs = {int(k): v for k, v in (e.get("controller_sol_runs") or {}).items()}
        if runs and (e.get("violations") or {}).get("SOL-MASTER-STALL") and _value(e, "k") == 1:
            j, n = max(runs.items(), key=lambda kv: kv[1])
            if j > 1 and n >= 0.9 * sum(runs.values()):
                out.append(f"assumed: {who} k = 1 (settings.master_cycle_ratio), but the controller holds {n:,} of its "
                           f"{sum(runs.values()):,} sign-of-life values exactly {j} cycles: an application cycle of "
                           f"{j} bus cycles (001_9461bb7bc8c2767b.txt:1671, 1677)? --set master_cycle_ratio={j}")
        csrc = _source(e, "compat", None)
        hit = sorted(r for r in (e.get("violations") or {}) if r in MODE_RULES)
        if hit and "default" in str(csrc):
            out.append(f"assumed: {who} V4.1 mode (no 0xBF00 in the capture) for {', '.join(hit)}; "
                       "--set compat=0 if it runs in V3.1 compatibility mode (SIMATIC technology objects)")
        if e.get("bf00_request_lost") is not None:
            out.append(f"assumed: {who} parameters: 0xBF00 was written (response in frame {e['bf00_request_lost']}) "
                       "but the capture lost its request, so the values are unknown; judged with the profile "
                       "defaults (--set compat=, class4=, ... to give them)")
        psrc = _source(e, "profile", e.get("profile_reason"))
        if "not a known" in str(psrc) or "default" in str(psrc):
            out.append(f"assumed: {who} profile {e.get('profile')} ({psrc})")
    return out


def _source(e: dict, key: str, fallback):
    s = (e.get("settings") or {}).get(key)
    return s.get("source") if isinstance(s, dict) and s.get("source") else fallback


def _value(e: dict, key: str):
    s = (e.get("settings") or {}).get(key)
    return s.get("value") if isinstance(s, dict) else None


def not_checked(summary: dict) -> list[str]:
    """What the reference encoder did not judge, and the setting that would make it."""
    out = []
    encs = summary.get("cyclic", {}).get("encoders", [])
    no_sol = [e for e in encs if _value(e, "SOLMON") is False and not _value(e, "iso")
              and not _value(e, "sol_monitor_rt")]
    if no_sol:
        out.append(f"sign-of-life: not checked for {_names(no_sol)} (RT AR, not isochronous; "
                   "monitoring is optional there): --set sol_monitor_rt=1 to check it")
    no_range = [e for e in encs if "st_phys" in (e.get("settings") or {}) and _value(e, "st_phys") is None]
    if no_range:
        out.append(f"position range against the hardware: not checked for {_names(no_range)} (steps and "
                   "revolutions unknown): --set st_phys=N --set mt_phys=N")
    # POSITION-DISCONTINUITY needs an endless shaft's range R and a profile that says the count is continuous
    # (value_rules._continuity_profile): a generic or inferred axis, or an unknown range, is not judged
    no_cont = [e for e in encs if not (e.get("profile") in CONTINUITY_PROFILES or (
        e.get("profile") == "psm" and _value(e, "scaling"))) or _value(e, "R") is None]
    if no_cont:
        out.append(f"position jumps (POSITION-DISCONTINUITY): not checked for {_names(no_cont)} (profile "
                   f"{'/'.join(sorted({str(e.get('profile')) for e in no_cont}))} or range unknown: only an endless "
                   "shaft of a known vendor with a known range is continuous by its manual): --profile VENDOR and "
                   "--set st_phys=N --set mt_phys=N")
    open_ = [e for e in encs if _value(e, "telegram") in tg.CONTROL_WORDS and
             str(_source(e, "compat", "")).endswith(DEFAULT_SOURCE)]
    if open_:
        out.append(f"control by PLC (CTRLREQ-*, CMD-*-WITHOUT-CONTROL): not judged for {_names(open_)} "
                   "(compatibility mode unknown: no 0xBF00 in the capture, and the words never showed it): "
                   "--set compat=0 (V3.1) or compat=1 (V4.1)")
    for e in encs:
        if e.get("preset_open_at_end") is not None:
            end = e.get("ar_ended")
            when = (f"when its AR was {end['phase']} (frame {end['frame']})" if end and end["frame"] > e["preset_open_at_end"]
                    else "when the capture ended")
            out.append(f"{e.get('station') or e.get('device_mac')} {e['slot']}/{e['subslot']}: the preset requested in "
                       f"frame {e['preset_open_at_end']} was not acknowledged yet {when}, before "
                       "D_preset was over (PRESET-ACK-MISSING not judged)")
    filt = [e for e in encs if e.get("velocity_filter_frame") is not None]
    if filt:
        out.append(f"NIST sign against the motion (NIST-SIGN): not checked for {_names(filt)} (a SCANCON velocity "
                   "filter was written, record 0x1000: Normal and Coarse lag a reversal by ~17 and ~173 cycles, and "
                   "the record's codes are not documented)")
    unjudged = [e for e in encs if e.get("presets_unjudged")]
    if unjudged:
        n = sum(e["presets_unjudged"] for e in unjudged)
        out.append(f"preset results: {n:,} preset(s) of {_names(unjudged)} not judged (P65000 unknown: no write in "
                   "the capture -- a saved value survives power-up -- or a parameter change whose request the capture "
                   "lost): --set p65000=N")
    for e in encs:
        if e.get("telegram_unsure"):
            cands = " or ".join(str(t) for t in e["telegram_unsure"])
            out.append(f"{e.get('station') or e.get('device_mac')} {e['slot']}/{e['subslot']}: no cycle judged -- "
                       f"the telegram is only guessed from the data lengths, which fit {cands} of profile "
                       f"{e.get('profile')} (cyclic.md §14): --map FILE (per station), --gsdml FILE, a P922 read in the capture, "
                       "or --set telegram=N (for every submodule of those lengths)")
    seen = set()
    for a in (summary.get("session") or {}).get("ars", []):
        for cr in a.get("iocrs") or ():
            for o in cr.get("objects") or ():
                k = (a.get("ar_uuid"), o.get("slot"), o.get("subslot"))
                if o.get("telegram_source") == NOT_OWNED and k not in seen:
                    seen.add(k)
                    out.append(f"{a.get('station') or a.get('device_mac')} {o.get('slot')}/{o.get('subslot')} in the AR of "
                               f"{a.get('controller_station') or a.get('controller_mac')}: "
                               + (o.get("telegram_note") or "not judged in this AR (another AR controls it)"))
    cyc = summary.get("cyclic", {})
    n = cyc.get("frames_before_ar") or 0
    if n >= 100 or (n and (cyc.get("content_inference") or {}).get("inferred")):   # not a start-up's few frames
        out.append(f"{n:,} cyclic frame{'s' if n != 1 else ''} of streams an AR of the capture maps came before that "
                   "AR was known (before its Connect response, before the telegram was inferred from the content, or of "
                   "an earlier AR on the same frame IDs the capture does not show): not judged")
    gated = sum(e.get("gated_cycles", 0) - e.get("unsure_cycles", 0) for e in encs if not e.get("telegram_unsure"))
    unsure = [e for e in encs if e.get("unsure_cycles") and not e.get("telegram_unsure")]
    if unsure:
        out.append(f"{sum(e['unsure_cycles'] for e in unsure):,} cycles of {_names(unsure)} not judged before the "
                   "telegram was known (only guessed from data lengths that fit several telegrams of the profile, "
                   "e.g. PS/PSM 81 or 100, until a P922 read named it)")
    if gated:
        out.append(f"{gated:,} cycles not judged (provider stopped, DataValid 0, TransferStatus not 0, IOPS bad, or "
                   "the device's IOCS of the setpoints bad: outputs it does not consume)")
    io = summary.get("cyclic", {}).get("frames_no_telegram", 0)
    if io:
        out.append(f"{io:,} cyclic frames of ARs without an encoder telegram (ordinary IO devices): decoded "
                   "(IOPS/IOCS in the rt events), no encoder rules apply")
    if summary.get("frames") and not encs and not no_profinet(summary) and not io:
        out.append("cyclic data: no encoder telegram found (no Connect, --map or --set telegram)")
    return out


def _names(encs: list[dict]) -> str:
    names = [str(e.get("station") or e.get("device_mac")) for e in encs]
    return ", ".join(names[:4]) + (f" and {len(names) - 4} more" if len(names) > 4 else "")
