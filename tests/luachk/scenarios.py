"""Random encoder sessions for the Python/Lua checker comparison (tests/test_lua_checker.py).

``run(rnd)`` builds a Checker from random settings and feeds it a random but plausible session:
a controller that toggles its command bits, an encoder that answers them (on time, late, wrong
or not at all), sign-of-life counters that mostly count, positions that move and jump, sensor
errors, gaps, 0xBF00 writes, parameter accesses and the outside changes cyclic.py makes
(profile/telegram relabel, _apply_cfg, _flush_all, _reset_history). Run it inside a Recorder.
``rnd`` is a random.Random (hypothesis passes st.randoms()).
"""
from __future__ import annotations

from pndiss import telegrams as tg
from pndiss.encoder import Checker, EncoderConfig
from pndiss.settings import Settings

STD_TELEGRAMS = (81, 82, 83, 84)
PRESET_TELEGRAMS = (86, 87, 88, 100, 101, 860)
ERROR_CODES = (0x0F02, 0x0F04, 0x1002, 0x0003, 0x1001, 0, 0x1234)
PNUS = (922, 925, 964, 965, 971, 975, 979, 980, 61001, 65000, 65001, 12345, 100)
PAIRING = ("request(s) in frame(s) 3 overwritten before their response was read", "no request",
           "response id mismatch (request 0x01, response 0x02)", "request ref mismatch (request 0x01, response 0x02)",
           "axis not mirrored (request 1, response 2)", "number of parameters mismatch (request 1, response 2)",
           "2 value blocks for 1 requested parameters")
FORMAT_NAMES = ("Unsigned16", "Unsigned32", "Integer32", "OctetString", "VisibleString", "Float32", "Word")


def _same_lengths(chk) -> int:
    """Another telegram with the data lengths the checker knows (81 and 100, 86 and 860 ...), else 81."""
    for t in sorted(tg.TELEGRAMS):
        if t != chk.cfg.telegram and all(tg.length(t, d) == n for d, n in chk.io_len.items()):
            return t
    return 81


def settings(rnd) -> Settings:
    s = Settings()
    s.l_max = rnd.choice((1, 2, 2, 3))
    s.preset_deadline_ms = rnd.choice((10.0, 10.0, 3.0, 2.5))
    s.sol_threshold_ge = rnd.random() < 0.3
    s.sol_monitor_rt = rnd.random() < 0.4
    s.iso = rnd.choice((None, None, True, False))
    s.master_cycle_ratio = rnd.choice((1, 1, 2, 3))
    s.compat = rnd.choice((None, None, 0, 1))
    s.class4 = rnd.choice((None, None, 0, 1))
    s.st_phys = rnd.choice((None, 8192, 4096, 360))
    s.mt_phys = rnd.choice((None, 4096, 16, 1))
    s.xist1_shift = rnd.choice((None, None, 0, 1, 3))
    s.max_position_step = rnd.choice((None, None, 100, 5000))
    s.p65000 = rnd.choice((None, None, 0, 1000))
    return s


def bf00(rnd) -> dict:
    d = {}
    for key, values in (("compat", (0, 1)), ("class4", (0, 1)), ("preset_control", (0, 1)), ("scaling", (0, 1)),
                        ("direction", (0, 1)), ("mupr", (0, 1, 360, 8192, 8193, 100000)),
                        ("tmr", (1, 2, 1000, 33554432, 33554433, 1 << 40)), ("max_master_sol_failures", (0, 1, 2, 5)),
                        ("velocity_unit", (0, 1, 3, 4, 5))):
        if rnd.random() < 0.7:
            d[key] = rnd.choice(values)
    if rnd.random() < 0.2:
        d["code_sequence"] = d.get("direction", rnd.choice((0, 1)))
    return d


def record_event(rnd, frame: int, ts: int, chk) -> dict:
    """A record or param event for ``chk``'s device (P922 answers know its telegram and data lengths)."""
    r = rnd.random()
    if r < 0.45:  # a user parameter write (0xBF00, PS/PSM 0xFFFF)
        idx = rnd.choice((0xBF00, 0xBF00, 0xFFFF))
        n = rnd.choice((31, 31, 31, 30, 32))
        data = bytes(rnd.randrange(256) if rnd.random() < 0.15 else 0 for _ in range(n))
        d = bf00(rnd)
        if rnd.random() < 0.5:
            probs = []
            for rule in ("BF00-LENGTH", "BF00-RESERVED-NONZERO", "BF00-VALUE-OUT-OF-RANGE", "NOT-A-RECORD-RULE"):
                if rnd.random() < 0.2:
                    probs.append({"rule": rule, "message": f"{rule.lower()} problem"})
            d["problems"] = probs
        ev = {"frame": frame, "ts_ns": ts, "kind": "record", "op": rnd.choice(("write", "write", "read")),
              "index": idx, "length": n, "data": data.hex(), "decoded": d}
        if rnd.random() < 0.1:
            ev["decoded"] = {}
        return ev
    if r < 0.55:  # a parameter request written to the PAP: valid values, now and then one off (or at a limit)
        def pick(good, bad):
            return rnd.choice(bad) if rnd.random() < 0.12 else rnd.choice(good)
        rid = pick((1, 2, 0x40, 0x7F), (0, 3, 0x3F, 0x80, 0x90))
        params = []
        for _ in range(rnd.choice((1, 1, 2))):
            cnt = pick((0, 1, 2, 234), (235, 300))
            params.append({"attribute": pick((0x10, 0x20, 0x30), (0x11, 0x40, 0x00)), "count": cnt,
                           "pnu": pick((922, 65000), (0,)), "subindex": pick((0, 1, 0xFFFE), (0xFFFF,)),
                           "no_of_values": pick((None, cnt), (cnt + 1,))})
        return {"frame": frame, "ts_ns": ts, "kind": "record", "op": "write", "index": rnd.choice((0xB02E, 0xB02F)),
                "decoded": {"kind": pick(("parameter request",), ("parameter response",)),
                            "request_id": rid, "no_of_parameters": pick((len(params), 1, 39), (0, 40)),
                            "length": pick((10, 240), (241, 250)), "params": params}}
    # a paired parameter access (records.ParamPairer shape)
    change = rnd.random() < 0.4
    qid = rnd.choice((2,) if change else (1, 1, 1, 5, 0x41))
    params = []
    for _ in range(rnd.choice((1, 1, 2, 3))):
        pnu = rnd.choice(PNUS)
        sub = {965: (1, 1, 0), 979: (3, 3, 0)}.get(pnu, (0, 0, 1, 3))
        p = {"pnu": pnu, "subindex": rnd.choice(sub), "attribute": rnd.choice((0x10, 0x10, 0x20)),
             "format_name": rnd.choice(FORMAT_NAMES)}
        if rnd.random() < 0.3:
            p["error"] = {"code": rnd.choice((0x00, 0x01, 0x02, 0x05, 0x11, 0x16, 0x21, 0xFF, 0x100, 0x1FF))}
        else:
            v = {922: rnd.choice((chk.cfg.telegram, _same_lengths(chk), 81, 83, 84, 86, 100, 5)),
                 965: rnd.choice((31, 41, "29", "1F", 7)),
                 979: rnd.choice((0, 2, 40)), 980: rnd.choice((922, 0, 65000)), 971: rnd.choice((0, 1, 1)),
                 65000: rnd.choice((0, 10, 5000, 999, 1000, 1 << 30, -5))}.get(pnu, rnd.choice((0, 1, 7)))
            vals = [v] + ([rnd.choice((922, 965, 979, 0))] if pnu == 980 and rnd.random() < 0.5 else [])
            if change and rnd.random() < 0.6:
                p["written"] = {"format": 7, "values": vals}
                if rnd.random() < 0.5:
                    vals = []
            p["values"] = vals
            p["format"] = 6
            if rnd.random() < 0.15:  # a device answering in Float32: Python then has floats, not ints
                p["format"], p["format_name"] = 8, "Float32"
                p["values"] = [float(x) for x in vals if isinstance(x, int)]
                if "written" in p and rnd.random() < 0.5:
                    p["written"] = {"format": 8, "values": [float(x) for x in p["written"]["values"]
                                                            if isinstance(x, int)]}
        params.append(p)
    ok_rid = (0x02 if change else 0x01) | (0x80 if any("error" in p for p in params) else 0)
    ev = {"frame": frame, "ts_ns": ts, "kind": "param", "response_frame": frame, "request_frame": frame - 1,
          "request_id": ("change parameter" if change else "request parameter") if qid in (1, 2) else None,
          "request_id_code": qid, "response_id": rnd.choice((ok_rid, ok_rid, ok_rid, 0x80, 0x01)),
          "request_ref": rnd.choice((0, 1, 2, 3, 3, None)), "ok": True, "params": params,
          "pairing": [rnd.choice(PAIRING)] if rnd.random() < 0.1 else []}
    return ev


class Encoder:
    """A semi-conforming device plus controller: most reactions right, some late or missing."""

    def __init__(self, rnd, telegram: int, profile: str, lag: int):
        self.rnd, self.t, self.profile, self.lag = rnd, telegram, profile, lag
        self.cls = rnd.choice((0, 1))
        self.dls = 0
        self.ctrl = 1 if rnd.random() < 0.9 else 0
        self.g1stw = 0
        self.stw2_extra = 0
        self.serr = 0
        self.code = 0
        self.pos = rnd.choice((0, 100, 4000, 1 << 20))
        self.speed = rnd.choice((0, 0, 1, 5, -3, 400))
        self.queue = []          # (due cycle, status bit, value) answers of the encoder
        self.g1zsw = 0
        self.zsw2_extra = 0
        self.n = 0
        self.shift = rnd.choice((0, 0, 1, 2))
        self.preset_word = 0
        self.p65000 = rnd.choice((0, 10, 5000))
        self.sp = self.ac = None
        self.x1_hold = None      # (value, cycles): a device whose XIST1 ignores the preset for a while
        self.nist_neg = False
        self.far = telegram == 84 and rnd.random() < 0.3
        self.drill = rnd.random() < 0.15
        self.areq_late = rnd.random() < 0.4
        self.zero_for = 0
        if self.drill:
            self.speed = 0

    def step(self):
        rnd, n = self.rnd, self.n
        self.n += 1
        changed = rnd.random() < 0.5 or self.sp is None or self.drill
        # controller
        if self.drill:  # preset drill: absolute value requested, PREQ held until PDONE, then released
            if not self.areq_late:
                self.g1stw |= 1 << 13
            if not (self.g1stw >> 12) & 1 and n % 12 == 0:
                self.g1stw |= (1 << 12) | (1 << 13)   # late: XIST2 shows no position before the request
                if rnd.random() < 0.3:  # a device that shows 0 while it stores the preset (#43)
                    self.zero_for = rnd.randrange(3, 13)
                self.g1stw = (self.g1stw & ~(1 << 11)) | (rnd.choice((0, 1)) << 11)
            elif (self.g1stw >> 12) & 1 and (self.g1zsw >> 12) & 1 and rnd.random() < 0.25:
                self.g1stw &= ~(1 << 12)
                if self.areq_late:
                    self.g1stw &= ~(1 << 13)
        elif rnd.random() < 0.06:
            b = rnd.choice((11, 12, 12, 13, 13, 14, 15))
            self.g1stw ^= 1 << b
        if rnd.random() < 0.01:
            self.ctrl ^= 1
        if rnd.random() < 0.01:
            self.stw2_extra ^= 1 << rnd.choice((0, 7, 3, 11))
        if rnd.random() < 0.01:
            self.g1stw ^= 1 << rnd.choice((0, 5))
        r = rnd.random()
        if r < 0.85:
            self.cls = (self.cls % 15) + 1 if self.cls else (1 if rnd.random() < 0.3 else 0)
        elif r < 0.9:
            self.cls = rnd.randrange(16)
        # encoder: answers
        for b, src in ((12, 12), (13, 13), (14, 14)):
            want = (self.g1stw >> src) & 1
            have = (self.g1zsw >> b) & 1
            if want != have and not any(q[1] == b for q in self.queue):
                if rnd.random() < 0.9:
                    self.queue.append((n + rnd.choice((0, 1, 1, 2, self.lag, self.lag + 3)), b, want))
        if (self.g1stw >> 15) & 1 and self.serr and rnd.random() < 0.5:
            self.queue.append((n + rnd.choice((0, 1, 2, 4)), 11, 1))
            self.queue.append((n + rnd.choice((1, 2, 3, 5)), 15, 0))
        if not (self.g1stw >> 15) & 1 and (self.g1zsw >> 11) & 1 and rnd.random() < 0.7:
            self.queue.append((n + rnd.choice((0, 1, 3)), 11, 0))
        if self.drill and (self.g1stw >> 12) & 1 and (self.g1zsw >> 12) & 1 and (self.g1stw >> 11) & 1 \
                and rnd.random() < 0.2:
            self.pos += self.p65000  # a faulty device: the held relative preset runs again
        due = [q for q in self.queue if q[0] <= n]
        self.queue = [q for q in self.queue if q[0] > n]
        for _, b, v in due:
            if b == 12 and v == 1 and rnd.random() < 0.7:  # the preset moves the position
                mode = (self.g1stw >> 11) & 1
                if rnd.random() < 0.4:
                    self.x1_hold = ((self.pos << self.shift) % (1 << 32), rnd.choice((1, 3, 10)))
                self.pos = self.pos + self.p65000 if mode else self.p65000
            self.g1zsw = (self.g1zsw & ~(1 << b)) | (v << b)
            if b == 15:
                self.serr = v
        if rnd.random() < 0.02 and not self.drill:
            self.serr = 1
            self.code = rnd.choice(ERROR_CODES)
            self.g1zsw |= 1 << 15
        if rnd.random() < 0.01 and not self.drill:
            self.g1zsw ^= 1 << rnd.choice((11, 12, 13, 14, 15, 0, 3))
            self.serr = (self.g1zsw >> 15) & 1
        if rnd.random() < 0.01:
            self.zsw2_extra ^= 1 << rnd.choice((0, 3, 9, 10, 11))
        r = rnd.random()
        if r < 0.8:
            self.dls = (self.dls % 15) + 1 if (self.dls or self.cls) else 0
        elif r < 0.85:
            self.dls = rnd.randrange(16)
        # motion
        if rnd.random() < 0.05 and not self.drill:
            self.speed = rnd.choice((0, 0, 0, 2, -7, 300, 70000))
        self.pos = (self.pos + self.speed) % (1 << 32)
        if rnd.random() < 0.03:
            self.nist_neg = not self.nist_neg   # a device reporting the velocity with the wrong sign
        if rnd.random() < 0.01:
            self.pos = rnd.randrange(1 << 32)
        if not changed:
            return self.sp, self.ac
        t = self.t
        if t in STD_TELEGRAMS or t == 89:
            creq = self.ctrl if rnd.random() < 0.97 else 1 - self.ctrl
            creq_bit = 10 if self.profile == "psm" else 9
            sp = {"stw2_enc": (self.cls << 12) | (self.ctrl << 10) | self.stw2_extra}
            zsw2 = (self.dls << 12) | (creq << creq_bit) | self.zsw2_extra
            if self.serr and self.profile == "psm" and rnd.random() < 0.8:
                zsw2 |= 1 << 3
            ac = {"zsw2_enc": zsw2 & 0xFFFF}
            atx, serr = (self.g1zsw >> 13) & 1, (self.g1zsw >> 15) & 1
            pk = (self.g1zsw >> 14) & 1
            x2 = self.code if serr else (self.pos if atx else (0 if rnd.random() < 0.9 else 7))
            x1 = 0 if pk and self.profile == "lika" and rnd.random() < 0.8 else (self.pos << self.shift) % (1 << 32)
            if self.x1_hold is not None:
                x1, left = self.x1_hold
                self.x1_hold = (x1, left - 1) if left > 1 else None
            if self.zero_for:
                self.zero_for -= 1
                x1 = 0
                x2 = 0 if atx and not serr else x2
            if t == 89:
                sp["g1_xist_preset_b1"] = rnd.randrange(1 << 31)
                if rnd.random() < 0.05:
                    sp["stw2_enc"] ^= 1
                ac["g1_xist1"] = x1
                ac["nist_b"] = -self.speed if self.nist_neg else self.speed
                if rnd.random() < 0.5:
                    ac["zsw2_enc"] |= sp["stw2_enc"] & 1
            else:
                sp["g1_stw"] = self.g1stw & 0xFFFF
                ac["g1_zsw"] = self.g1zsw & 0xFFFF
                if t == 84:
                    ac["g1_xist3"] = self.pos if rnd.random() < 0.98 else rnd.randrange(1 << 52)
                    if self.far:  # above 2^53 ({hi=, lo=} in Lua), on multiples of 256: exact as doubles
                        ac["g1_xist3"] = (1 << 60) + ac["g1_xist3"] * 256
                else:
                    ac["g1_xist1"] = x1
                ac["g1_xist2"] = x2 % (1 << 32)
                if t == 82:
                    ac["nist_a"] = max(-32768, min(32767, self.speed if rnd.random() < 0.95 else -self.speed))
                elif t in (83, 84):
                    ac["nist_b"] = -self.speed if self.nist_neg else self.speed
        else:
            c = t in (88, 101)
            top = 63 if c else 31
            if rnd.random() < 0.05:
                self.preset_word ^= 1 << top
            if rnd.random() < 0.05:
                big = ((1 << 53) - 5, 1 << 40, (1 << 60) + 256 * rnd.randrange(1 << 20))  # the last: a double
                v = rnd.choice((0, 100, 5000, 1 << 20, (1 << 31) - 1) + (big if c else ()))
                self.preset_word = (self.preset_word & (1 << top)) | v
            sp = {"g1_xist_preset_c" if c else "g1_xist_preset_b": self.preset_word}
            if (self.preset_word >> top) & 1 and rnd.random() < 0.3:
                self.pos = self.preset_word & ((1 << top) - 1)
            ac = {"g1_xist3" if c else "g1_xist1": self.pos}
            if t != 87:
                ac["nist_b"] = self.speed
        self.sp, self.ac = sp, ac
        return sp, ac


def _p971(frame: int, ts: int, rid: str, value: int) -> dict:
    change = rid.startswith("change")
    p = {"pnu": 971, "subindex": 0, "attribute": 0x10, "format": 6, "format_name": "Unsigned16", "error": None,
         "values": [] if change else [value]}
    if change:
        p["written"] = {"format": 6, "values": [value]}
    return {"frame": frame, "ts_ns": ts, "kind": "param", "response_frame": frame, "request_frame": frame - 1,
            "request_id": rid, "request_id_code": 2 if change else 1, "response_id": 2 if change else 1,
            "request_ref": frame % 200 + 1, "ok": True, "pairing": [], "params": [p]}


def run(rnd) -> Checker:
    """One random session through a Checker (the Recorder around it logs everything)."""
    profile = rnd.choice(tg.PROFILES)
    telegram = rnd.choice(STD_TELEGRAMS + STD_TELEGRAMS + PRESET_TELEGRAMS + (89,))
    if telegram in PRESET_TELEGRAMS + (89,) and rnd.random() < 0.7:
        profile = "psm"
    s = settings(rnd)
    cfg = EncoderConfig.from_settings(
        s, profile=profile, telegram=telegram, bf00=bf00(rnd) if rnd.random() < 0.5 else None,
        cycle_ns=rnd.choice((None, 1_000_000, 500_000, 2_000_000, 3_000_000)), iso=rnd.choice((None, True, False)),
        profile_reason="random", telegram_source=rnd.choice(("given", "length", "connect")))
    if rnd.random() < 0.1:  # a configuration changed after from_settings: the replay rebuilds it field by field
        cfg.max_master_sol_failures = rnd.choice((1, 2, 3))
        cfg.shift = rnd.choice((None, 0, 2))
    info = {"station": "enc", "device_mac": "02:00:00:00:00:01", "api": 0x3D00, "slot": 1, "subslot": 2}
    chk = Checker(cfg, info)
    chk.io_len["setpoint"] = tg.length(telegram, "setpoint")
    if rnd.random() < 0.8:
        chk.io_len["actual"] = tg.length(telegram, "actual")
    if rnd.random() < 0.3:
        chk.prev_bf00 = bf00(rnd)
    enc = Encoder(rnd, telegram, profile, lag=rnd.choice((1, 3, 12)))
    frame, ts = 10, 1_000_000_000
    if enc.drill:  # a preset drill: class 4 on and a P65000 written first
        chk.cfg.class4 = 1
        chk._apply_cfg()
        p65000 = {"pnu": 65000, "subindex": 0, "attribute": 0x10, "values": [], "error": None,
                  "written": {"format": 7, "values": [rnd.choice((77, 5000, 123456))]}}
        chk.on_record({"frame": 5, "ts_ns": ts, "kind": "param", "response_frame": 5, "request_frame": 4,
                       "request_id": "change parameter", "request_id_code": 2, "response_id": 2, "request_ref": 9,
                       "ok": True, "pairing": [], "params": [p65000]})
    p971 = profile == "lika" and rnd.random() < 0.4
    if p971:
        chk.on_record(_p971(6, ts, "change parameter", 1))
    for _ in range(rnd.randrange(20, 260)):
        frame += rnd.choice((2, 2, 3))
        ts += 1_000_000
        r = rnd.random()
        if r < 0.02:
            chk.gap(frame, ts, "not valid")
        elif r < 0.025:  # capture loss (pndiss/gaps.py): cycles elapse unjudged
            chk.lost(frame, ts, rnd.randrange(1, 4))
        elif r < 0.06:
            chk.on_record(record_event(rnd, frame, ts, chk))
        elif r < 0.065:  # cyclic_axes.py _refine_profile / _relabel from outside
            if rnd.random() < 0.5:
                chk.cfg.profile = "psm"
                chk.cfg.sources["profile"] = "telegram exists only in PS/PSM"
                chk._apply_cfg()
            else:
                chk.cfg.telegram = rnd.choice(STD_TELEGRAMS)
                chk.cfg.sources["telegram"] = "P922"
                chk._apply_cfg()
                chk._flush_all()
                chk._reset_history()
                enc.t = chk.cfg.telegram
                enc.sp = enc.ac = None
        elif r < 0.075 and p971:  # LIKA: P971 read back after the store request
            chk.on_record(_p971(frame, ts, "request parameter", rnd.choice((1, 1, 0))))
        else:
            enc.p65000 = chk.p65000 or 0  # the device presets to what the controller wrote (P65000; unknown to the checker: 0)
            sp, ac = enc.step()
            sp_frame = frame - 1 if rnd.random() < 0.9 else None
            chk.cycle(frame, ts, sp, ac, sp_frame)
    chk.finish()
    return chk


def held_xist1_session() -> Checker:
    """Hand-made: an absolute preset requested while XIST2 shows no position yet (so the position
    before the preset is unknown) on a device whose XIST1 ignores it: #29, decided by the
    'no position before' branch of _check_preset_value."""
    # the preset control bit as a captured 0xBF00 says it (without one, #28/#29 are not judged)
    cfg = EncoderConfig.from_settings(Settings(), profile="generic", telegram=81, cycle_ns=1_000_000,
                                      bf00={"class4": 1, "preset_control": 0})
    chk = Checker(cfg, {"station": "enc"})
    chk.on_record({"frame": 2, "ts_ns": 0, "kind": "param", "response_frame": 2, "request_frame": 1,
                   "request_id": "change parameter", "request_id_code": 2, "response_id": 2, "request_ref": 1,
                   "ok": True, "pairing": [], "params": [{"pnu": 65000, "subindex": 0, "attribute": 0x10,
                                                           "written": {"format": 7, "values": [5000]},
                                                           "values": [], "error": None}]})
    zsw2 = 1 << 9  # control requested, as STW2_ENC.10 asks
    rows = [(0x0000, 0x0000, 100, 0)] * 5 + [(0x3000, 0x0000, 100, 0), (0x3000, 0x3000, 100, 5000),
                                             (0x0000, 0x2000, 100, 5000), (0x0000, 0x0000, 100, 0)]
    for i, (g1stw, g1zsw, x1, x2) in enumerate(rows):
        chk.cycle(10 + 2 * i, i, {"stw2_enc": 0x0400, "g1_stw": g1stw},
                  {"zsw2_enc": zsw2, "g1_zsw": g1zsw, "g1_xist1": x1, "g1_xist2": x2}, 9 + 2 * i)
    chk.finish()
    return chk
