"""``pndiss rules [ID]``: the rule catalogue, and one rule explained.

From pndiss/data/rules.json (behaviour.md §9) and pndiss/data/rule_help.json (the manual sections the
rule comes from, the notation, the settings that change it; tools/gen_rule_help.py).
"""
from __future__ import annotations

import json
import os
import re
import sys


def add_parser(sub) -> None:
    p = sub.add_parser("rules", help="list the violation rules, or explain one: pndiss rules PRESET-ACK-MISSING")
    p.add_argument("rule", nargs="?", metavar="ID", help="rule ID (case-insensitive); without it: the list")
    p.add_argument("--side", choices=("controller", "encoder"), help="list only this side's rules")
    p.set_defaults(func=run)


def _help() -> dict:
    path = os.path.join(os.path.dirname(os.path.dirname(__file__)), "data", "rule_help.json")
    with open(path, encoding="utf-8") as f:
        return json.load(f)


def explain(rule_id: str) -> str:
    """The text `pndiss rules ID` prints (raises UsageError with a did-you-mean for unknown IDs)."""
    from ..errors import UsageError, did_you_mean
    from ..rules import RULES
    rid = rule_id.strip().upper()
    r = RULES.get(rid)
    if r is None:
        raise UsageError(f"no rule {rule_id!r}" + did_you_mean(rid, list(RULES), 3)
                         + " (pndiss rules lists them)")
    h = _help()
    extra = h["rules"].get(rid, {})
    cond = r["condition"]
    names = sorted({n for n in re.findall(r"\b([A-Z][A-Z0-9]+)\b", cond) if n in h["glossary"]})
    side = {"controller": "the controller (PLC)", "encoder": "the encoder"}.get(r["side"], r["side"])
    lines = [f"{rid} — {r['severity']}, blamed on {side}",
             f"Section: {r['section']} (catalogue entry #{r['n']})",
             "",
             "What it checks (in cycle n; the message of each violation says what was seen and what was expected):",
             f"  {cond}"]
    if r.get("tags"):
        lines.append(f"  Marked {', '.join(r['tags'])}: a derivation or an ambiguity of the manuals, not a manual statement.")
    if names:
        lines += ["", "Where:"] + [f"  {n} = {h['glossary'][n]}" for n in names]
    srcs = extra.get("sources") or []
    if srcs:
        lines += ["", "From the manuals (section and line of the plain-text manual):"]
        for s in srcs:
            lines.append(f"  - {s['manual']}: section {s['section'] or '?'} (line {s['line']})")
    sets = extra.get("settings") or []
    if sets:
        lines += ["", "Tune it with (docs/settings.md):"]
        lines += [f"  --set {k}=..." for k in sets]
    lines += ["", "Find it in a capture: pndiss analyze CAPTURE --jsonl - | grep '\"rule\":\"" + rid + "\"'"]
    return "\n".join(lines)


def run(args) -> int:
    from ..rules import RULES
    if args.rule:
        print(explain(args.rule))
        return 0
    for rid, r in sorted(RULES.items(), key=lambda kv: kv[1]["n"]):
        if args.side and r["side"] != args.side:
            continue
        print(f"{rid:<42} {r['side']:<10} {r['severity']:<7} {r['section']}")
    print(f"\n{len(RULES)} rules; pndiss rules ID explains one", file=sys.stderr)
    return 0
