"""Regenerate pndiss/data/rules.json from the violation catalogue (spec/behaviour.md §9).

The catalogue is the source of truth for rule IDs, side, severity, condition and sources; this
script only transcribes it into data. Run: python3 tools/gen_rules.py [path/to/behaviour.md]
"""
import json
import os
import re
import sys

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SPEC = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "..", "shared", "spec", "behaviour.md")

text = open(SPEC, encoding="utf-8").read()
cat = text[text.index("## 9. Violation catalogue"):]
rules = []
section = None
item = re.compile(r"^(\d+)\. `([A-Z0-9-]+)` — \*\*([CE/]+)\*\*\s*(\(([^)]*)\))?\s*—\s*(.*)$")
lines = cat.splitlines()
i = 0
while i < len(lines):
    line = lines[i]
    if line.startswith("### 9."):
        section = line[4:].strip()
    m = item.match(line)
    if m:
        body = [m.group(6)]
        i += 1
        while i < len(lines) and lines[i].startswith("   "):
            body.append(lines[i].strip())
            i += 1
        full = " ".join(body)
        tags = [t.strip() for t in (m.group(5) or "").split(",") if t.strip()]
        sev = "error"
        for t in tags:
            if t in ("warning", "info"):
                sev = t
        srcs = re.findall(r"\(((?:\d{3}_[0-9a-f]+\.txt:[\d\-]+(?:,\s*)?)+)\)\s*$", full)
        cond = re.sub(r"\s*\((?:\d{3}_[0-9a-f]+\.txt:[\d\-]+(?:,\s*)?)+\)\s*$", "", full)
        cond = re.sub(r"\s*\(same\s+sources\)\s*$", "", cond)
        side = {"C": "controller", "E": "encoder", "C/E": "either"}[m.group(3)]
        rules.append({
            "n": int(m.group(1)), "id": m.group(2), "side": side, "severity": sev,
            "tags": [t for t in tags if t not in ("warning", "info")],
            "section": section, "condition": cond,
            "source": "behaviour.md §9 #%s; %s" % (m.group(1), srcs[0] if srcs else "same sources as the rule above"),
        })
        continue
    i += 1
assert len(rules) == 92, len(rules)
out = os.path.join(ROOT, "pndiss", "data", "rules.json")
with open(out, "w", encoding="utf-8") as f:
    json.dump(rules, f, indent=1, ensure_ascii=False)
    f.write("\n")
print(f"{len(rules)} rules -> {out}")
