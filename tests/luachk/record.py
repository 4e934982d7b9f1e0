"""Record every call into pndiss.encoder.Checker (and every change made to it from outside) so
tests/luachk/replay.lua can replay the same calls through lua/pndiss_checker.lua.

``Recorder`` patches EncoderConfig.from_settings and the Checker methods the cyclic tracker calls
(constructor, cycle, gap, on_record, finish, _apply_cfg, _flush_all, _reset_history). Only
outermost calls are logged (the checker calls _apply_cfg itself, too). Before each logged call
the checker's externally writable state (every EncoderConfig field, io_len, prev_bf00) is diffed
against its state after the previous call: a difference was made from outside (cyclic_axes.py
_relabel / _refine_profile / _axis) and is logged as a ``set`` op, in order.
"""
from __future__ import annotations

import copy
import dataclasses
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
sys.path.insert(0, os.path.join(ROOT, "tools"))

from gen_lua import _s  # noqa: E402  (the generator's Lua string escaping)
from pndiss.encoder import _state, config  # noqa: E402

Checker = _state.Checker
EncoderConfig = config.EncoderConfig
CFG_FIELDS = [f.name for f in dataclasses.fields(EncoderConfig)]
SETTINGS_FIELDS = ("l_max", "preset_deadline_ms", "sol_threshold_ge", "sol_monitor_rt", "master_cycle_ratio", "st_phys",
                   "mt_phys", "xist1_shift", "max_position_step", "compat", "class4", "iso", "p65000")
EXTERNAL_RULES = {"TELEGRAM-LENGTH-MISMATCH", "STARTUP-NO-PARAM-RECORD"}  # counted by cyclic.py, not the checker
BIG = 1 << 53


# ------------------------------------------------------------------------------- Lua literals
def lua(v, hilo: bool = False) -> str:
    """A Lua literal; with hilo, integers >= 2^53 become {hi=, lo=} (the checker's 64-bit form)."""
    if v is None:
        return "nil"
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        if hilo and v >= BIG:
            return "{hi=%d,lo=%d}" % (v >> 32, v & 0xFFFFFFFF)
        return str(v)
    if isinstance(v, float):
        if v != v:
            return "(0/0)"
        if v in (float("inf"), float("-inf")):
            return "(1/0)" if v > 0 else "(-1/0)"
        return repr(v)
    if isinstance(v, str):
        return _s(v)
    if isinstance(v, (bytes, bytearray)):
        return _s(bytes(v).hex())
    if isinstance(v, (list, tuple, set, frozenset)):
        items = sorted(v) if isinstance(v, (set, frozenset)) else v
        return "{" + ",".join(lua(x, hilo) for x in items) + "}"
    if isinstance(v, dict):
        rows = []
        for k, x in v.items():
            if x is None:
                continue
            key = "[%d]" % k if isinstance(k, int) and not isinstance(k, bool) else "[%s]" % _s(str(k))
            rows.append(key + "=" + lua(x, hilo))
        return "{" + ",".join(rows) + "}"
    raise TypeError(f"cannot write {type(v).__name__} as Lua")


def num(v) -> str:
    """Numbers as the Lua driver prints them (%.17g), so both sides compare text."""
    if v is None:
        return "nil"
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, float)):
        return "%.17g" % v
    return str(v)


def violations(evs) -> list[tuple]:
    return [(e["rule"], e["frame"], e["last_frame"], e.get("cycles", 1), e["side"])
            for e in evs or () if e.get("kind") == "violation"]


# ------------------------------------------------------------------------------- the recorder
class Recorder:
    def __init__(self):
        self.ops: list[dict] = []
        self.expect: dict[int, list] = {}     # op index -> violations Python returned
        self.cfg_expect: dict[int, str] = {}  # op index of a 'new' -> the Python cfg, printed
        self.counts_expect: dict[int, str] = {}
        self.state_expect: dict[int, str] = {}  # op index of a record / finish -> fields the caller reads
        self._ids: dict[int, int] = {}         # id(checker) -> k
        self._keep: list = []                  # checkers and cfgs stay alive: ids are not reused
        self._snap: dict[int, dict] = {}
        self._last_in: dict[int, tuple] = {}
        self._fs: dict[int, tuple] = {}
        self._depth = 0
        self._saved = {}

    # -- state diffs -----------------------------------------------------------------------------
    @staticmethod
    def _state(chk) -> dict:
        st = {"cfg." + f: copy.deepcopy(getattr(chk.cfg, f)) for f in CFG_FIELDS}
        st["io_len"] = dict(chk.io_len)
        st["prev_bf00"] = chk.prev_bf00
        return st

    def _sync(self, chk, k: int) -> None:
        old, new = self._snap[k], self._state(chk)
        for key, v in new.items():
            if key == "prev_bf00" and v is old[key]:
                continue
            if v != old[key] or type(v) is not type(old[key]):
                self.ops.append({"op": "set", "k": k, "key": key, "value": v})

    def _after(self, chk, k: int) -> None:
        self._snap[k] = self._state(chk)

    # -- patching --------------------------------------------------------------------------------
    def install(self) -> "Recorder":
        rec = self
        orig_fs = EncoderConfig.__dict__["from_settings"].__func__
        orig_init = Checker.__init__

        def from_settings(cls, settings=None, **kw):
            cfg = orig_fs(cls, settings, **kw)
            s = None if settings is None else {n: getattr(settings, n, None) for n in SETTINGS_FIELDS}
            rec._fs[id(cfg)] = (s, dict(kw), copy.deepcopy(dataclasses.asdict(cfg)))
            rec._keep.append(cfg)
            return cfg

        def init(chk, cfg, info=None):
            rec._depth += 1
            try:
                orig_init(chk, cfg, info)
            finally:
                rec._depth -= 1
            k = len(rec._ids) + 1
            rec._ids[id(chk)] = k
            rec._keep.append(chk)
            op = {"op": "new", "k": k, "info": dict(info or {})}
            fs = rec._fs.get(id(cfg))
            if fs is not None and fs[2] == dataclasses.asdict(cfg):
                op["settings"], op["kw"] = fs[0], fs[1]
                op["from_settings"] = True
            else:  # built another way (or changed since): give the fields themselves
                op["cfg"] = dataclasses.asdict(cfg)
            rec.cfg_expect[len(rec.ops)] = cfg_text(cfg)
            rec.ops.append(op)
            rec._after(chk, k)

        self._saved = {"from_settings": EncoderConfig.__dict__["from_settings"], "__init__": Checker.__init__}
        EncoderConfig.from_settings = classmethod(from_settings)
        Checker.__init__ = init
        for name, opname in (("cycle", "cycle"), ("gap", "gap"), ("lost", "lost"), ("on_record", "rec"), ("finish", "finish"),
                             ("_apply_cfg", "apply"), ("_flush_all", "flush"), ("_reset_history", "reset"),
                             ("new_connection", "newconn"), ("write_refused", "refused"), ("on_alarm", "alarm")):
            self._saved[name] = Checker.__dict__[name]
            setattr(Checker, name, self._wrap(Checker.__dict__[name], opname))
        return self

    def uninstall(self) -> None:
        for name, f in self._saved.items():
            setattr(EncoderConfig if name == "from_settings" else Checker, name, f)
        self._saved = {}

    def __enter__(self):
        return self.install()

    def __exit__(self, *exc):
        self.uninstall()

    def _wrap(self, fn, opname):
        rec = self

        def wrapper(chk, *args, **kw):
            k = rec._ids.get(id(chk))
            if rec._depth or k is None:
                return fn(chk, *args, **kw)
            rec._sync(chk, k)
            op = {"op": opname, "k": k}
            if opname == "cycle":
                frame, ts, sp, ac = args[:4]
                sp_frame = args[4] if len(args) > 4 else kw.get("sp_frame")
                last = rec._last_in.get(k, (None, None))
                op.update(f=frame, ts=ts, spf=sp_frame)
                if sp is last[0]:
                    op["ssp"] = True
                else:
                    op["sp"] = dict(sp)
                if ac is last[1]:
                    op["sac"] = True
                else:
                    op["ac"] = dict(ac)
                rec._last_in[k] = (sp, ac)
            elif opname == "gap":
                op.update(f=args[0], ts=args[1])
            elif opname == "lost":
                op.update(f=args[0], ts=args[1], n=args[2])
            elif opname == "rec":
                op["ev"] = copy.deepcopy(args[0])
            elif opname == "newconn":
                op["prev"] = copy.deepcopy(args[0])
            elif opname == "refused":
                op["rf"] = args[0]
            elif opname == "alarm":
                op["ev"] = copy.deepcopy(args[0])
            before = len(chk.out)
            rec._depth += 1
            try:
                res = fn(chk, *args, **kw)
            finally:
                rec._depth -= 1
            idx = len(rec.ops)
            rec.ops.append(op)
            if opname == "flush":
                res = chk.out[before:]   # Python appends to the previous call's list
            if opname in ("cycle", "gap", "lost", "rec", "finish", "flush", "newconn", "refused", "alarm"):
                got = violations(res)
                if got:
                    rec.expect[idx] = got
            if opname == "finish":
                rec.counts_expect[idx] = counts_text(chk.counts)
            if opname in ("rec", "finish", "newconn", "refused"):
                rec.state_expect[idx] = state_text(chk)
            rec._after(chk, k)
            return res

        return wrapper

    # -- replay ----------------------------------------------------------------------------------
    def lines(self):
        for op in self.ops:
            o = dict(op)
            parts = []
            for key in ("sp", "ac"):
                if key in o:
                    parts.append(f"{key}={lua(o.pop(key), hilo=True)}")
            parts.extend(f"{key}={lua(v)}" for key, v in o.items() if v is not None)
            yield "{" + ",".join(parts) + "}\n"


def cfg_text(cfg) -> str:
    parts = []
    for f in CFG_FIELDS:
        v = getattr(cfg, f)
        if f == "sources":
            parts.append("sources=" + "|".join(f"{k}:{v[k]}" for k in sorted(v)))
        else:
            parts.append(f"{f}={num(v)}")
    return " ".join(parts)


def state_text(chk) -> str:
    """What cyclic.py (and lua/pndiss.lua) read back from a checker, plus what the records set."""
    return " ".join(f"{k}={num(v)}" for k, v in (
        ("p922_rejected", chk.p922_rejected), ("bf00_seen", chk.bf00_seen), ("telegram", chk.cfg.telegram),
        ("profile", chk.cfg.profile), ("shift", chk.cfg.shift), ("p65000", chk.p65000), ("n", chk.n)))


def counts_text(counts) -> str:
    return " ".join(f"{r}:{c['events']}:{c['cycles']}:{c['first_frame']}"
                    for r, c in sorted(counts.items()) if r not in EXTERNAL_RULES)


# ------------------------------------------------------------------------------- run + compare
LUA = os.environ.get("PNDISS_LUA", "lua5.2")
DRIVER = os.path.join(os.path.dirname(os.path.abspath(__file__)), "replay.lua")


def replay(rec: Recorder) -> dict:
    """Run the Lua port over the recorded calls; returns the comparison (see compare())."""
    with tempfile.NamedTemporaryFile("w", suffix=".luaops", delete=False, encoding="utf-8") as f:
        f.writelines(rec.lines())
        path = f.name
    try:
        p = subprocess.run([LUA, DRIVER, os.path.join(ROOT, "lua"), path], capture_output=True, text=True)
    finally:
        os.unlink(path)
    if p.returncode != 0:
        raise AssertionError(f"lua driver failed ({p.returncode}): {p.stderr[-3000:]}")
    return compare(rec, p.stdout)


def _parse_events(text: str) -> list[tuple]:
    out = []
    for item in text.split(";"):
        if item:
            rule, frame, last, cycles, side = item.split(",")
            out.append((rule, int(float(frame)), int(float(last)), int(float(cycles)), side))
    return out


def compare(rec: Recorder, stdout: str) -> dict:
    got: dict[int, list] = {}
    cfg_got: dict[int, str] = {}
    counts_got: dict[int, str] = {}
    state_got: dict[int, str] = {}
    problems = []
    done = False
    opens = 0
    for line in stdout.splitlines():
        tag, _, rest = line.partition("\t")
        if tag == "DONE":
            done = True
            continue
        if tag == "OPENS":
            opens = int(rest)
            continue
        if tag == "ERR":
            problems.append(rest)
            continue
        idx = int(tag)
        kind, _, rest = rest.partition("\t")
        if kind == "EV":
            got[idx] = _parse_events(rest)
        elif kind == "CFG":
            cfg_got[idx] = rest
        elif kind == "COUNTS":
            counts_got[idx] = rest
        elif kind == "ST":
            state_got[idx] = rest
    if not done:
        problems.append("driver did not finish")
    for idx in sorted(set(got) | set(rec.expect)):
        if got.get(idx, []) != rec.expect.get(idx, []):
            problems.append(f"op {idx} {rec.ops[idx]['op']} k={rec.ops[idx]['k']} frame={rec.ops[idx].get('f')}: "
                            f"python {rec.expect.get(idx, [])} lua {got.get(idx, [])}")
    for idx, text in rec.cfg_expect.items():
        if cfg_got.get(idx) != text:
            problems.append(f"op {idx} new: python cfg {text}\n   lua cfg {cfg_got.get(idx)}")
    for idx, text in rec.state_expect.items():
        if state_got.get(idx) != text:
            problems.append(f"op {idx} {rec.ops[idx]['op']} state: python {text} lua {state_got.get(idx)}")
    for idx, text in rec.counts_expect.items():
        if counts_got.get(idx) != text:
            problems.append(f"op {idx} finish counts: python {text} lua {counts_got.get(idx)}")
    n_calls = sum(1 for o in rec.ops if o["op"] != "set")
    n_viol = sum(len(v) for v in rec.expect.values())
    rules = {v[0] for evs in rec.expect.values() for v in evs}
    lua_rules = {v[0] for evs in got.values() for v in evs}
    return {"calls": n_calls, "violations": n_viol, "rules": rules, "lua_rules": lua_rules, "opens": opens,
            "problems": problems}


def lua_same(fn) -> set:
    """Run ``fn`` (Python checker calls) under a Recorder, replay the calls in the Lua checker and fail on any
    difference; the rules the Lua port emitted."""
    with Recorder() as rec:
        fn()
    res = replay(rec)
    assert not res["problems"], "\n".join(res["problems"][:20])
    return res["lua_rules"]
