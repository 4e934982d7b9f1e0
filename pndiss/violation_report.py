"""Report section for violations that belong to no encoder axis (DCP naming/addressing, ...): they
count like every other (Analyzer.violations); the encoder tables show the rest."""
from __future__ import annotations

from rich.table import Table
from rich.text import Text

from .textsafe import visible

SEV_STYLE = {"error": "red", "warning": "yellow", "info": "cyan"}


def sections(violations: dict) -> list:
    rows = [(r, v) for r, v in violations.items() if v.get("not_axis")]
    if not rows:
        return []
    t = Table(title="Violations not tied to an encoder")
    for col in ("rule", "side", "severity", "events", "first frame", "first message"):
        t.add_column(col)
    for rule, v in sorted(rows, key=lambda kv: kv[1]["not_axis_first"][0]):
        frame, side, msg = v["not_axis_first"]
        t.add_row(visible(rule), visible(side or "-"), Text(visible(v["severity"]), style=SEV_STYLE.get(v["severity"], "")),
                  str(v["not_axis"]), str(frame), visible(msg or ""))  # message and side may carry wire text
    return [t]
