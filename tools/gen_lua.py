#!/usr/bin/env python3
"""Generate lua/pndiss_tables.lua from the Python tables, so the Wireshark plugin and the Python
core share one source of truth: telegram layouts and bit maps (pndiss/data/telegrams.json via
pndiss.telegrams), G1_XIST2 error codes, velocity units, the rule catalogue
(pndiss/data/rules.json), record index names and PROFIdrive parameter names/formats/errors
(pndiss.records), the 0xBF00 flag bits and the list of rules the plugin implements or cannot do.

    python3 tools/gen_lua.py            # rewrite lua/pndiss_tables.lua
    python3 tools/gen_lua.py --check    # exit 1 when the checked-in file is stale

tests/test_lua_tables.py regenerates in memory and compares with the checked-in file.
"""
from __future__ import annotations

import os
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

OUT = os.path.join(ROOT, "lua", "pndiss_tables.lua")

# Rules the plugin computes itself (lua/pndiss.lua, section "rules"); every other catalogue rule
# is listed in UNSUPPORTED with the reason (docs/wireshark.md repeats these reasons).
PLUGIN_RULES = (
    "RESERVED-BIT-SET-STW2", "RESERVED-BIT-SET-G1STW", "RESERVED-BIT-SET-ZSW2", "RESERVED-BIT-SET-G1ZSW",
    "ZSW-ATX-AND-SERR", "XIST2-NOT-ZERO", "PARK-OUTPUTS-NOT-CLEARED", "SERR-CODE-INVALID",
)

# Reason groups for the rules the plugin leaves to the Python core.
WHY_NOT_PORTED = ("not ported yet: needs the reference encoder's cycle pairing, window history and "
                  "deadline state (pndiss/encoder/_state.py); run `pndiss analyze` for it")
WHY_RECORD = ("not ported yet: record/BMP rule of pndiss/encoder/acyclic.py; the plugin shows the "
              "decoded record and parameter fields, `pndiss analyze` judges them")
WHY_SETTINGS = ("needs settings the plugin does not have (hardware resolution, isochronous mode, "
                "latency tolerance) or an end-of-capture verdict; run `pndiss analyze`")


def _why(rule: dict) -> str:
    sec = rule.get("section", "")
    if sec.startswith(("9.9", "9.10")):
        return WHY_RECORD
    if "end of capture" in rule.get("condition", "").lower():
        return WHY_SETTINGS
    return WHY_NOT_PORTED


# ---------------------------------------------------------------------------------- Lua writer
def _s(v: str) -> str:
    out = ['"']
    for ch in v:
        o = ord(ch)
        if ch == '"':
            out.append('\\"')
        elif ch == "\\":
            out.append("\\\\")
        elif o < 32 or o == 127:
            out.append(f"\\{o:03d}")
        elif o > 127:  # Lua 5.2 strings are bytes: write UTF-8 as decimal escapes
            out.extend(f"\\{b:03d}" for b in ch.encode("utf-8"))
        else:
            out.append(ch)
    out.append('"')
    return "".join(out)


def lua(v, ind: str = "") -> str:
    """A Lua literal for a JSON-like value; dict keys sorted so the output is stable."""
    if v is None:
        return "nil"
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, int):
        return str(v)
    if isinstance(v, float):
        return repr(v)
    if isinstance(v, str):
        return _s(v)
    nxt = ind + "  "
    if isinstance(v, (list, tuple)):
        if not v:
            return "{}"
        items = [lua(x, nxt) for x in v]
        if sum(len(x) for x in items) < 100 and all("\n" not in x for x in items):
            return "{" + ", ".join(items) + "}"
        return "{\n" + "".join(f"{nxt}{x},\n" for x in items) + ind + "}"
    if isinstance(v, dict):
        if not v:
            return "{}"
        keys = sorted(v, key=lambda k: (isinstance(k, str), k))
        rows = []
        for k in keys:
            if v[k] is None:
                continue
            key = f"[{k}]" if isinstance(k, int) else (k if k.isidentifier() and k not in _LUA_KW else f"[{_s(k)}]")
            rows.append(f"{nxt}{key} = {lua(v[k], nxt)},\n")
        return "{\n" + "".join(rows) + ind + "}"
    raise TypeError(type(v))


_LUA_KW = {"and", "break", "do", "else", "elseif", "end", "false", "for", "function", "goto", "if", "in",
           "local", "nil", "not", "or", "repeat", "return", "then", "true", "until", "while"}


# ---------------------------------------------------------------------------------- the tables
def tables() -> dict:
    from pndiss import rules, telegrams as tg
    from pndiss.records import im, names, profidrive, userparams

    signals = {n: {"size": s["size"], "signed": s["signed"], "direction": s["direction"], "title": s["title"]}
               for n, s in tg.SIGNALS.items()}
    telegrams = {t: {"setpoint": [r[0] for r in sorted(d["setpoint"], key=lambda r: r[1])],
                     "actual": [r[0] for r in sorted(d["actual"], key=lambda r: r[1])],
                     "standard": bool(d["standard"])}
                 for t, d in tg.TELEGRAMS.items()}
    bitmaps = {sig: [{"name": b["name"], "bit": b["bit"], "width": b["width"], "title": b.get("title", b["name"]),
                      "profiles": list(b["profiles"]) if "profiles" in b else None} for b in rows]
               for sig, rows in tg.BITMAPS.items()}
    # telegram preference for the length guess: standard first, then 860, then OEM (session.py)
    order = sorted(tg.TELEGRAMS, key=lambda t: (0 if t < 100 else 1 if t == 860 else 2, t))
    lengths = [[t, tg.length(t, "setpoint"), tg.length(t, "actual")] for t in order]
    idx_names = dict(names.TSHARK_NAMES)
    for k, v in names.ENCODER_NAMES.items():
        idx_names.setdefault(k, v)
    params = {p: e["name"] for p, e in profidrive.PARAMS.items()}
    vparams = {prof: {p: e["name"] for p, e in t.items()} for prof, t in profidrive.VENDOR_PARAMS.items()}
    formats = {c: {"name": n, "size": s, "code": code} for c, (n, s, code) in profidrive.FORMATS.items()}
    cat = {r["id"]: {"n": r["n"], "severity": r["severity"], "side": r["side"], "section": r["section"]}
           for r in rules.RULES.values()}
    missing = [r for r in PLUGIN_RULES if r not in rules.RULES]
    if missing:
        raise SystemExit(f"PLUGIN_RULES names unknown rules: {missing}")
    unsupported = {rid: _why(r) for rid, r in rules.RULES.items() if rid not in PLUGIN_RULES}
    return {
        "signals": signals, "telegrams": telegrams, "bitmaps": bitmaps, "profiles": list(tg.PROFILES),
        "xist2_errors": {c: e["text"] for c, e in tg.XIST2_ERRORS.items()},
        "velocity_units": {v: u["text"] for v, u in tg.VELOCITY_UNITS.items()},
        "telegram_lengths": lengths,
        "profile_defaults": {p: {k: v for k, v in d.items() if k != "source"} for p, d in tg.PROFILE_DEFAULTS.items()},
        "index_names": idx_names,
        "params": params, "vendor_params": vparams, "param_formats": formats,
        "param_errors": dict(profidrive.ERRORS),
        "request_ids": dict(profidrive.REQUEST_IDS), "response_ids": dict(profidrive.RESPONSE_IDS),
        "attributes": dict(profidrive.ATTRIBUTES),
        "bf00_flags": [[n, b] for n, b in userparams.FLAG_BITS],
        "bf00_velocity_units": dict(userparams.VELOCITY_UNITS),
        "bf00_velocity_units_psm": dict(userparams.VELOCITY_UNITS_PSM),
        "im_profile_ids": dict(im.IM_PROFILE_IDS), "vendors": dict(im.VENDORS),
        "rules": cat, "plugin_rules": list(PLUGIN_RULES), "unsupported_rules": unsupported,
    }


def render() -> str:
    t = tables()
    out = ["-- GENERATED by tools/gen_lua.py from the Python tables (pndiss/data/*.json, pndiss.telegrams,\n"
           "-- pndiss.records, pndiss.rules). Do not edit: run `python3 tools/gen_lua.py`.\n",
           "local T = {}\n"]
    for k in t:
        out.append(f"T.{k} = {lua(t[k])}\n")
    out.append("return T\n")
    return "".join(out)


def main(argv: list[str]) -> int:
    text = render()
    if "--check" in argv:
        try:
            with open(OUT, encoding="utf-8") as f:
                cur = f.read()
        except FileNotFoundError:
            cur = None
        if cur != text:
            print(f"{OUT} is stale: run python3 tools/gen_lua.py", file=sys.stderr)
            return 1
        return 0
    os.makedirs(os.path.dirname(OUT), exist_ok=True)
    with open(OUT, "w", encoding="utf-8") as f:
        f.write(text)
    print(f"wrote {OUT} ({len(text)} bytes)")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
