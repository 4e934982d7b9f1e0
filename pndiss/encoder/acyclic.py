"""Record and parameter rules of the reference encoder (behaviour.md §5, §9.9 #64-71/75, §9.10).

Fed ``record`` events (0xBF00 / 0xFFFF user parameters) and ``param`` events (a paired 0xB02E
request/response from pndiss.records.ParamPairer) in capture order. Updates the checker's
configuration (0xBF00 values, P65000, P979 shift) and emits violations through the checker.
"""
from __future__ import annotations

from .. import telegrams as tg
from ..records.profidrive import legal_request_id
from .value_rules import E_PARAM

BF00_LEN = 31                                    # 000_37bf2397999f1108.txt:2171, 002_d69f444daf0f8af2.txt:1020
BF00_INDEXES = (0xBF00, 0xFFFF)                  # PS/PSM: 0xFFFF (behaviour.md §5.1)
# LIKA's read-only PNUs (behaviour.md §9.10 #86, 000_37bf2397999f1108.txt:1953-2168)
READ_ONLY = {"lika": {922, 964, 965, 975, 979, 980, 61001, 65001},
             "psm": {922, 925, 964, 965, 975, 979, 980, 61001, 65001}}   # PS/PSM "Get" (002_d69f444daf0f8af2.txt:1089-1166)
_LISTS = (980, 989)   # the lists of defined parameters, P980 continued in P981.. (records.md §4.6)
PROFILE_PNUS = {922, 964, 965, 975, 979, 980, 65000, 65001}    # profile parameters readable after run-up (#92)
COMMISSIONING_DIAG = 0x9011   # channel error type: user parameter data assignment error (000_37bf2397999f1108.txt:2611-2615)
ISO_MODE_DATA = 0x8030   # record index of IsochronousModeData (pnio_cm.py record names)
ABORTING_ERRORS = {0x05, 0x16, 0x17, 0x18}       # 001_9461bb7bc8c2767b.txt:2089, 2099 (#85)
# words of the ParamPairer's pairing problems -> rule (behaviour.md §9.10 #76, #81)
PAIRING_RULES = (("not in request order", "BMP-ORDER"), ("overwritten", "BMP-PIPELINED"), ("pipelined", "BMP-PIPELINED"),
                 ("response id mismatch", "BMP-RESPID-MISMATCH"), ("ref", "BMP-NOT-MIRRORED"), ("axis", "BMP-NOT-MIRRORED"), ("number of param", "BMP-NOT-MIRRORED"),
                 ("value blocks for", "BMP-NOT-MIRRORED"))
RECORD_RULES = {"BF00-LENGTH", "BF00-RESERVED-NONZERO", "BF00-VALUE-OUT-OF-RANGE", "BMP-BAD-REQUEST",
                "BMP-REQREF-ZERO", "BMP-NEG-FORMAT", "BMP-ILLEGAL-REQID-RESPONSE", "BMP-RESPID-MISMATCH"}


# 0xBF00 / 0xFFFF decoded keys -> EncoderConfig attributes (a captured record sets them)
BF00_FIELDS = (("compat", "compat"), ("class4", "class4"), ("preset_control", "preset_control"),
               ("scaling", "scaling"), ("direction", "direction"), ("code_sequence", "direction"),
               ("mupr", "mupr"), ("tmr", "tmr"), ("max_master_sol_failures", "max_master_sol_failures"),
               ("velocity_unit", "velocity_unit"))


def check_record(chk, ev: dict) -> None:
    kind = ev.get("kind")
    if kind == "record":
        _record(chk, ev)
    elif kind == "param":
        _param(chk, ev)


def _record_bytes(ev: dict) -> bytes:
    """A record event's data: a hex string (the events) or bytes (hand-made events)."""
    d = ev.get("data")
    return bytes.fromhex(d) if isinstance(d, str) else bytes(d or b"")


def _iso_mode_data(chk, ev: dict) -> None:
    """Record 0x8030 IsochronousModeData (block 0x0204: header, 2 padding bytes, slot, subslot, then
    ControllerApplicationCycleFactor, as IEC 61158-6-10 device stacks read it): the controller's application
    cycle is that many data cycles, and its sign-of-life counts once per application cycle -- k (behaviour.md
    §0.1). It replaces the default k = 1, not a k given with --set master_cycle_ratio."""
    data = _record_bytes(ev)
    if len(data) < 14 or data[0:2] != b"\x02\x04":
        return
    f = int.from_bytes(data[12:14], "big")
    c = chk.cfg
    if f > 1 and not str(c.sources.get("k", "")).startswith("settings."):
        c.k = f
        c.sources["k"] = f"record 0x8030 ControllerApplicationCycleFactor (frame {ev.get('frame')})"
        chk.reconfigure()


def _v(chk, rule, ev, msg, frame=None, side=None, last=None):
    f = ev.get("frame", 0) if frame is None else frame
    # a violation named at the request frame has the request's time (the MCAP log, the dataset: the frame it names)
    ts = ev["request_ts_ns"] if f == ev.get("request_frame") and ev.get("request_ts_ns") is not None else ev.get("ts_ns", 0)
    chk.emit(rule, f, ts, msg, last=last, side=side)


def _record(chk, ev: dict) -> None:
    idx = ev.get("index")
    if idx in (0xB02E, 0xB02F) and ev.get("op") == "write":
        _bmp_request(chk, ev)
        return
    if idx == ISO_MODE_DATA and ev.get("op") == "write":
        _iso_mode_data(chk, ev)
        return
    if idx == 0x1000 and ev.get("op") == "write" and chk.cfg.profile == "scancon" and chk.velocity_filter is None:
        chk.velocity_filter = ev.get("frame", 0)   # its lag is unknown: NIST-SIGN is not judged (value_rules.py)
        chk.reconfigure()
        return
    if idx not in BF00_INDEXES or ev.get("op") != "write":
        return
    if idx == 0xFFFF and chk.cfg.profile != "psm":
        return
    c = chk.cfg
    was_seen = chk.bf00_seen
    chk.bf00_seen = True
    problems: list[str] = []
    d = ev.get("decoded") or {}
    if "problems" in d:  # pndiss.records already judged #67-69 (records/userparams.py)
        for p in d["problems"]:
            rule = p.get("rule") if isinstance(p, dict) else None
            if rule in RECORD_RULES:
                problems.append(p.get("message", rule))
                _v(chk, rule, ev, "0x%04X: %s" % (idx, p.get("message", rule)))
    else:
        _own_bf00_checks(chk, ev, idx, d, problems)
    # the captured parameter set is now in force (behaviour.md §2.0: re-read whenever written); what it
    # replaces is kept until the response: a refused write wrote nothing (write_refused)
    chk.bf00_undo = (ev.get("frame"), {a: (getattr(c, a), c.sources.get(a)) for _k, a in BF00_FIELDS},
                     (chk.bf00_invalid, chk.bf00_due, chk.bf00_valid_frame, chk.params_changed, was_seen))
    # an invalid set is not the device's configuration: it answers it with 0x1002 (behaviour.md §4.5),
    # and a device that does not report it is judged for that (#70), not against the invalid values too
    for key, attr in BF00_FIELDS if not problems else ():
        if d.get(key) is not None:
            setattr(c, attr, int(d[key]))
            c.sources[attr] = f"captured 0xBF00 (frame {ev.get('frame')})"
    chk.reconfigure()
    if problems:
        chk.bf00_invalid = "; ".join(problems)
        chk.bf00_due = (chk.n + chk.D, chk.bf00_invalid, ev.get("frame"), ev.get("ts_ns"))   # (+ the write: #70's trigger)
        chk.bf00_valid_frame = None
    else:
        chk.bf00_invalid = None
        chk.bf00_due = None
        chk.bf00_valid_frame = ev.get("frame")
    prev = chk.prev_bf00
    if prev is not None and d:
        keys = ("direction", "code_sequence", "mupr", "tmr")
        if any(prev.get(k) != d.get(k) for k in keys if k in d or k in prev):
            chk.params_changed = True


def check_alarm(chk, ev: dict) -> None:
    """A diagnosis alarm (AlarmType 1) whose channel diagnosis appears (ChannelProperties.Specifier 1):
    #70 takes the commissioning diagnostic 0x9011 as the report of an invalid 0xBF00, and #48 forbids
    reporting an error while parked."""
    if ev.get("alarm_type") != 1:
        return
    appears = [it for it in ev.get("items") or () if (it.get("channel_properties") or {}).get("specifier") == 1]
    if not appears:
        return
    codes = ", ".join(f"0x{it.get('channel_error_type', 0):04X}" for it in appears)
    pa = chk.prev_ac   # the last cycle's actual values: G1_ZSW.14 parked, SERR and G1_XIST2
    if any(it.get("channel_error_type") == COMMISSIONING_DIAG for it in appears):
        if chk.bf00_due is not None:
            chk.bf00_due = None   # 70: reported as "user parameter data assignment error" (000_37bf2397999f1108.txt:2611-2615)
        elif chk.bf00_valid_frame is not None and chk.bf00_invalid is None:
            # 71: a valid 0xBF00 rejected. Once per rejection: the cyclic rule reports the same fault when the
            # data already shows it (SERR with 0x1002) and stands down after this report.
            in_data = pa is not None and (pa.get("g1_zsw", 0) >> 15) & 1 and pa.get("g1_xist2") == E_PARAM
            if not in_data:
                _v(chk, "BF00-VALID-REJECTED", ev, f"commissioning diagnostic 0x9011 after a valid 0xBF00 "
                                                   f"(frame {chk.bf00_valid_frame})")
                chk.bf00_valid_frame = None
    if pa is not None and (pa.get("g1_zsw", 0) >> 14) & 1:
        # 48: no error reports while parked (000_37bf2397999f1108.txt:1775-1777)
        _v(chk, "PARK-ERROR-REPORTED", ev, f"diagnosis alarm (channel error type {codes}) while parked")


def write_refused(chk, request_frame) -> None:
    """The device answered the 0xBF00 / 0xFFFF write of ``request_frame`` with an error: the parameters
    in force before it are again (#66 still sees the write: the controller did write at start-up)."""
    undo, chk.bf00_undo = chk.bf00_undo, None
    if undo is None or undo[0] != request_frame:
        return
    c = chk.cfg
    for attr, (value, source) in undo[1].items():
        setattr(c, attr, value)
        if source is None:
            c.sources.pop(attr, None)
        else:
            c.sources[attr] = source
    chk.bf00_invalid, chk.bf00_due, chk.bf00_valid_frame, chk.params_changed, _seen = undo[2]
    chk.reconfigure()


def _own_bf00_checks(chk, ev, idx, d, problems) -> None:
    """#67-69 from the raw bytes, when no records decoder judged them."""
    c = chk.cfg
    data = _record_bytes(ev)
    n = ev.get("length", len(data))
    if n != BF00_LEN:
        problems.append(f"length {n}")
        # 67: 31 bytes (000_37bf2397999f1108.txt:2171)
        _v(chk, "BF00-LENGTH", ev, f"0x{idx:04X} written with {n} bytes; expected {BF00_LEN}")
    if c.profile == "lika" and len(data) >= 1 and ((data[0] & 0xC0) or any(data[19:31])):
        problems.append("reserved bits")
        # 68: LIKA byte 0 bits 6-7 and bytes 19-30 are reserved (000_37bf2397999f1108.txt:2195, 2211)
        _v(chk, "BF00-RESERVED-NONZERO", ev, f"0xBF00 reserved content set (byte 0 = 0x{data[0]:02X})")
    rng = []
    mupr, tmr = d.get("mupr"), d.get("tmr")
    if mupr is not None and (mupr < 1 or (c.st_phys and mupr > c.st_phys)):
        rng.append(f"MUPR={mupr} outside [1, {c.st_phys or '?'}]")
    if tmr is not None and (tmr < 2 or (c.st_phys and c.mt_phys and tmr > c.st_phys * c.mt_phys)):
        rng.append(f"TMR={tmr} outside [2, {(c.st_phys or 0) * (c.mt_phys or 0) or '?'}]")
    if d.get("max_master_sol_failures") == 0 and c.profile != "psm":
        rng.append("max master sign-of-life failures = 0")
    vu = d.get("velocity_unit")
    if vu is not None and vu > (4 if c.profile == "psm" else 3):
        rng.append(f"velocity unit {vu}")
    if rng:
        problems.extend(rng)
        # 69: value ranges of the parameter set (000_37bf2397999f1108.txt:2395-2480)
        _v(chk, "BF00-VALUE-OUT-OF-RANGE", ev, "0xBF00 " + "; ".join(rng))


def _bmp_request(chk, ev: dict) -> None:
    """#79: a request written to the PAP must be well formed (001_9461bb7bc8c2767b.txt:2013-2030)."""
    d = ev.get("decoded") or {}
    if d.get("kind") != "parameter request":
        return
    bad = []
    rid = d.get("request_id")
    if not legal_request_id(rid):
        bad.append(f"request ID 0x{rid:02X}" if isinstance(rid, int) else "request ID")
    n = d.get("no_of_parameters")
    if isinstance(n, int) and not 1 <= n <= 39:
        bad.append(f"{n} parameters")
    if (d.get("length") or 0) > 240:
        bad.append(f"length {d['length']} > 240")
    for p in d.get("params") or ():
        a, cnt, pnu, sub = p.get("attribute"), p.get("count"), p.get("pnu"), p.get("subindex")
        if isinstance(a, int) and (a & 0x0F or a & 0xF0 not in (0x10, 0x20, 0x30)):
            bad.append(f"attribute 0x{a:02X}")
        if isinstance(cnt, int) and cnt > 234:
            bad.append(f"{cnt} elements")
        if pnu == 0:
            bad.append("PNU 0")
        if sub == 0xFFFF:
            bad.append("subindex 0xFFFF")
        nv = p.get("no_of_values")
        if rid == 2 and isinstance(nv, int) and isinstance(cnt, int) and cnt and nv != cnt:
            bad.append(f"PNU {pnu}: {nv} values for {cnt} elements")
    if bad:
        _v(chk, "BMP-BAD-REQUEST", ev, "parameter request: " + "; ".join(bad))


def _param(chk, ev: dict) -> None:
    qid = ev.get("request_id")  # the code (0x02 = change parameter); hand-made events may give the name
    change = qid == 0x02 if isinstance(qid, int) else "change" in str(ev.get("request_id_name") or qid or "")
    frame = ev.get("response_frame", ev.get("frame", 0))
    if ev.get("request_id") is None and ev.get("response_id") == 0x02:
        # a parameter changed by a request the capture lost: P65000 may be what changed, so the preset value
        # is unknown from here (presets not judged on their result, docs/settings.md p65000)
        chk.p65000 = None
    for prob in ev.get("pairing") or ():
        words = str(prob).lower()
        for key, rule in PAIRING_RULES:
            if key in words:
                # 76 / 81: one request at a time, mirrored header (001_9461bb7bc8c2767b.txt:1822, 1908, 1921); an
                # overwritten request is the fault of the write that overwrote it (decided at this response)
                at = ev.get("request_frame") if key == "overwritten" and ev.get("request_frame") else frame
                _v(chk, rule, ev, f"parameter access: {prob}", frame=at, last=frame)
                break
    ref = ev.get("request_ref")
    if isinstance(ref, int):
        if ref == 0:
            # 77: request reference 0 is reserved (001_9461bb7bc8c2767b.txt:2013)
            _v(chk, "BMP-REQREF-ZERO", ev, "request reference 0x00 (reserved)", frame=ev.get("request_frame", frame))
        elif ref == chk.last_req_ref.get(ev.get("ar_uuid")):
            # 78: a new reference per request (001_9461bb7bc8c2767b.txt:1908) -- of the same AR: an engineering
            # tool's Device Access AR has a parameter channel of its own
            _v(chk, "BMP-REQREF-NOT-CHANGED", ev, f"request reference {ref} repeated", frame=ev.get("request_frame", frame))
        chk.last_req_ref[ev.get("ar_uuid")] = ref
    params = ev.get("params") or []
    rid = ev.get("response_id")
    qid = ev.get("request_id_code")
    if isinstance(qid, int) and not legal_request_id(qid) and isinstance(rid, int):
        codes = [p["error"].get("code") for p in params if isinstance(p.get("error"), dict)]
        if rid != 0x80 or (codes and codes[0] != 0x21):
            # 80: an illegal request ID is answered 0x80 / error 0x21 (001_9461bb7bc8c2767b.txt:2073)
            _v(chk, "BMP-ILLEGAL-REQID-RESPONSE", ev, f"request ID 0x{qid:02X} answered with response ID 0x{rid:02X}"
               + (f", error 0x{codes[0]:02X}" if codes else "") + "; expected 0x80 with error 0x21", frame=frame)
    if ev.get("decode_error"):
        # its value blocks did not decode (profidrive.undecodable_response): the header is judged above, no
        # parameter's result is known -- a P65000 change may or may not have been taken
        if change and any(p.get("pnu") == 65000 for p in params):
            chk.p65000 = None
        return
    if isinstance(rid, int) and rid & 0x80 == 0 and any(p.get("error") for p in params):
        # 82: a positive response cannot carry errors (001_9461bb7bc8c2767b.txt:1914-1920)
        _v(chk, "BMP-RESPID-MISMATCH", ev, f"positive response ID 0x{rid:02X} with a parameter error", frame=frame)
    if any("not in request order" in str(x) for x in ev.get("pairing") or ()):
        return   # 84: paired by position, each block would be judged as another parameter's values
    neg = isinstance(rid, int) and rid & 0x80
    if neg and len(params) == 1 and isinstance(params[0].get("format"), int) and params[0]["format"] != 0x44:
        # 83: the one block of a negative single-parameter response is the error (format 0x44, 001_...:1970-1978)
        _v(chk, "BMP-NEG-FORMAT", ev, f"PNU {params[0].get('pnu')}: negative response whose block has format "
           f"0x{params[0]['format']:02X}; an error entry has format 0x44", frame=frame)
    aborted = False
    for p in params:
        pnu, sub, err = p.get("pnu"), p.get("subindex", 0), p.get("error")
        code = err.get("code") if isinstance(err, dict) else None
        vals = p.get("values") or []
        if code is not None and code > 0xFF:
            # 83: error numbers are one byte (001_9461bb7bc8c2767b.txt:2031)
            _v(chk, "BMP-NEG-FORMAT", ev, f"PNU {pnu}: error number 0x{code:X} > 0xFF", frame=frame)
        elif neg and p.get("format") == 0x44 and p.get("no_of_values") not in (1, 2):
            # 83: an error entry holds the error number and at most one more value (001_...:1970-1978)
            _v(chk, "BMP-NEG-FORMAT", ev, f"PNU {pnu}: error entry with {p.get('no_of_values')} values; "
               "expected 1 or 2", frame=frame)
        if change and len(params) > 1:
            if aborted and err is None:
                # 85: errors 0x05/0x16/0x17/0x18 abort the rest (001_9461bb7bc8c2767b.txt:2089, 2099)
                _v(chk, "BMP-MULTI-NOT-ABORTED", ev, f"PNU {pnu} reported changed after an aborting error", frame=frame)
            if code in ABORTING_ERRORS:
                aborted = True
        if chk.p980 is not None and pnu and pnu not in chk.p980 and not _LISTS[0] <= pnu <= _LISTS[1] \
                and (err is None or code != 0x00) and not ev.get("do_unknown"):
            # 88: unknown PNU -> error 0x00 (001_9461bb7bc8c2767b.txt:2040). The lists P980..P989 never list
            # themselves; PNU 0 is the controller's bad request (#79), any error answers it
            _v(chk, "BMP-UNKNOWN-PNU", ev, f"PNU {pnu} is not in P980 but was answered "
               + ("positively" if err is None else f"with error 0x{code:02X}"), frame=frame)
        if not _value_attribute(p):
            pass   # a description or text (attribute 0x20 / 0x30): not the parameter's value
        elif change:
            _change(chk, ev, p, pnu, sub, err, vals, frame)
        elif err is None and vals:
            _read(chk, ev, p, pnu, sub, vals, frame)
        elif code == 0x11 and pnu in PROFILE_PNUS:
            # 92: profile parameters readable in every state (001_9461bb7bc8c2767b.txt:1830)
            _v(chk, "BMP-PROFILE-PARAM-UNREADABLE", ev, f"read of P{pnu} refused with 0x11 after run-up", frame=frame)


def _value_attribute(p: dict) -> bool:
    """The access is to the parameter's value (attribute 0x10; records.md §3.4), or the request was not seen."""
    a = p.get("attribute")
    return a is None or a & 0xF0 == 0x10


def _p925(chk, v, how: str, frame) -> None:
    """P925 tolerated master sign-of-life failures (V4.1 mode, behaviour.md §3.3 R-SOLC-3)."""
    if isinstance(v, int) and 0 < v < 0x10000 and v != chk.cfg.p925:
        chk.cfg.p925 = v
        chk.cfg.sources["p925"] = f"P925 {how} (frame {frame})"
        chk.reconfigure()


def _change(chk, ev, p, pnu, sub, err, vals, frame) -> None:
    c = chk.cfg
    vals = (p.get("written") or {}).get("values") or vals  # a positive change answer has no values
    if ev.get("do_unknown"):
        # a global access whose DO-ID may name another of the device's encoders (cyclic_axes.on_record): what it
        # changed is unknown here -- P65000 too (presets then not judged on their result, docs/settings.md p65000)
        if pnu == 65000 and err is None:
            chk.p65000 = None
        _read_only(chk, ev, pnu, err, frame)
        return
    if pnu == 925 and err is None and vals:
        _p925(chk, vals[0], "written", frame)
    if pnu == 65000:
        v = vals[0] if vals else None
        if not c.class4 and not c.class4_open():
            # 17: P65000 needs class 4 functionality (001_9461bb7bc8c2767b.txt:846)
            _v(chk, "PRESET-CLASS4-DISABLED", ev, "P65000 change request while class 4 functionality is off",
               frame=ev.get("request_frame", frame))
            if err is None:
                # 91: refusal expected [AMBIGUOUS] (001_9461bb7bc8c2767b.txt:2389-2391)
                _v(chk, "BMP-CLASS4-WRITE-ACCEPTED", ev, "P65000 change accepted with class 4 functionality off", frame=frame)
        R = c.modulus
        if err is None and isinstance(v, int) and R is not None and v > R:
            # 87: P65000 greater than the range -> error 0x02 (001_9461bb7bc8c2767b.txt:847, 004_...:782; R itself
            # is not "greater": an independent audit)
            _v(chk, "BMP-PRESET-LIMIT-ACCEPTED", ev, f"P65000={v} > R={R} accepted; expected error 0x02", frame=frame)
        if err is None and isinstance(v, int):
            chk.p65000 = v  # R-PAR-1: stored only, no preset (001_9461bb7bc8c2767b.txt:845)
    _read_only(chk, ev, pnu, err, frame)
    if pnu == 971 and err is None and vals and vals[0] == 1 and c.profile == "lika":
        chk.p971_pending = [frame, 0, ev.get("ts_ns", 0)]


def _read_only(chk, ev, pnu, err, frame) -> None:
    ro = READ_ONLY.get(chk.cfg.profile)
    if ro and pnu in ro and err is None:
        # 86: read-only parameters refuse changes with 0x01 (001_9461bb7bc8c2767b.txt:2041)
        _v(chk, "BMP-WRITE-RO-ACCEPTED", ev, f"change of read-only P{pnu} answered positively; expected error 0x01", frame=frame)


def _read(chk, ev, p, pnu, sub, vals, frame) -> None:
    c = chk.cfg
    v = vals[0]
    _datatype(chk, ev, p, pnu, frame)
    if ev.get("do_unknown"):
        return   # the value may be another encoder's of the device (cyclic_axes.on_record)
    guessed = "length" in str(c.sources.get("telegram", ""))
    fits = isinstance(v, int) and v in tg.TELEGRAMS and all(tg.length(v, d) == n for d, n in chk.io_len.items())
    if pnu == 922 and guessed and fits:
        # the AR's telegram was only guessed from the lengths: P922 names it (the session relabels the map)
        c.telegram = v
        c.sources["telegram"] = f"P922 read (frame {frame})"
        chk.reconfigure()
    elif pnu == 922 and isinstance(v, int) and c.telegram and v != c.telegram:
        if guessed:
            chk.p922_rejected = v  # the AR's data lengths are the configuration; keep them
        # 65: P922 names the configured telegram (000_37bf2397999f1108.txt:1953-1956)
        _v(chk, "TELEGRAM-SELECTION-MISMATCH", ev, f"P922 reads {v}; the AR runs telegram {c.telegram}"
           + (" (data lengths: " + ", ".join(f"{d} {n} bytes" for d, n in sorted(chk.io_len.items(), reverse=True)) + ")"
              if chk.io_len else ""), frame=frame)
    elif pnu == 965 and c.profile != "psm" and p965_version(sub, v) is not None:
        v = p965_version(sub, v)
        exp = 31 if c.compat == 0 else 41
        if chk.compat_open and v in (31, 41):   # the profile version tells the mode (behaviour.md §2.2)
            c.compat = 0 if v == 31 else 1
            c.sources["compat"] = f"learnt from P965.1 = {v} (frame {frame})"
            chk.reconfigure()
        elif v != exp:
            # 75: P965.1 = 31 in V3.1 mode, 41 in V4.1 (000_37bf2397999f1108.txt:2369-2372)
            _v(chk, "P965-VERSION-MISMATCH", ev, f"P965.1 = {v} with compatibility mode {c.compat}; expected {exp}", frame=frame)
    elif pnu == 979 and sub == 3 and isinstance(v, int) and 0 <= v < 32:
        c.shift = v
        c.sources["shift"] = f"P979.3 read (frame {frame})"
        chk.shift_known = True
    elif pnu == 925:
        _p925(chk, v, "read", frame)
    elif isinstance(pnu, int) and _LISTS[0] <= pnu <= _LISTS[1]:   # P980 and its continuations P981..P989
        chk.p980 = (chk.p980 or set()) | {x for x in vals if isinstance(x, int) and x}
    elif pnu == 971 and chk.p971_pending is not None:
        if v == 1:
            chk.p971_pending[1] += 1
        else:
            chk.p971_pending = None
    elif pnu == 65000 and isinstance(v, int):
        chk.p65000 = v


def _datatype(chk, ev, p, pnu, frame) -> None:
    """#89: a read response states the parameter's own data type (001_9461bb7bc8c2767b.txt:2029, 2081-2083)."""
    try:
        from ..records import param_info
        from ..records.profidrive import FORMATS
    except ImportError:
        return
    info = param_info(pnu, chk.cfg.profile) if pnu is not None else None
    want = info.get("type") if info else None
    got = p.get("format_name")
    names = {v[0] for v in FORMATS.values()}
    if want in names and got in names and want != got and p.get("attribute", 0x10) & 0xF0 == 0x10:
        if chk.cfg.profile == "generic" and any((param_info(pnu, q) or {}).get("type") == got for q in VENDOR_PROFILES):
            return   # no vendor known (a capture without the device's DCP): the type one vendor documents is no fault
        _v(chk, "BMP-DATATYPE", ev, f"P{pnu} read as {got}; its data type is {want}", frame=frame)


VENDOR_PROFILES = ("lika", "scancon", "hohner", "psm")


def p965_version(sub, v):
    """The profile version a P965 read answers: subindex 1, or byte 1 of the whole octet string 2 read at
    subindex 0 whose byte 0 is the encoder profile number 0x3D (records.md §4.3). "31"/"41" written as hex
    digits (0x31/0x41) count as 31/41: no manual says how they are coded (records.md §4.3)."""
    if sub == 1:
        x = _as_int(v)
    elif sub == 0 and isinstance(v, str) and len(v) == 4 and v[:2].lower() == "3d":   # byte 0: profile 0x3D
        x = _as_int(v[2:])
    else:
        return None
    return {0x31: 31, 0x41: 41}.get(x, x)


def _as_int(v):
    """Values arrive as ints, or as hex strings for octet-string types (records/profidrive.py)."""
    if isinstance(v, int):
        return v
    try:
        return int(str(v), 16)
    except ValueError:
        return None


def finish(chk) -> None:
    if chk.p971_pending is not None and chk.p971_pending[1] > 0:
        f, reads, ts = chk.p971_pending
        # 90: P971 returns to 0 once stored (000_37bf2397999f1108.txt:1977-1979)
        chk.emit("P971-NOT-CONFIRMED", f, ts, f"P971 still reads 1 in all {reads} reads after the store request")
        chk.p971_pending = None


def tg_length_problem(telegram: int, direction: str, length: int) -> str | None:
    """#64: words when a data object's length does not fit its telegram (behaviour.md §1.1)."""
    want = tg.length(telegram, direction)
    return None if want == length else f"telegram {telegram} {direction} is {want} bytes, the AR maps {length}"
