"""Terminal report section for capture loss (pndiss/gaps.py): shown first, so a user knows the capture
was lossy before trusting the verdicts below it."""
from __future__ import annotations

from rich.table import Table

from .textsafe import visible

SHOWN = 20


def section(g: dict):
    """A rich Table of the capture gaps, or None when the capture holds every cycle it shows."""
    odd = [s for s in g.get("streams", []) if not s["uniform"]]
    if not g.get("count") and not odd:
        return None
    title = (f"Frames missing: {g['count']:,} gap(s), {g['cycles_missing']:,} cycle(s) "
             "(cycle counter: lost by the capture or on the network; not judged, not protocol faults)")
    t = Table(title=title)
    for col in ("stream (frame ID, src -> dst)", "station", "direction", "gaps", "cycles missing", "first gaps (frames)"):
        t.add_column(col)
    rows = g.get("gaps", [])
    for s in g.get("streams", []):
        key = (s["frame_id"], s["src"], s["dst"])
        mine = [r for r in rows if (r["frame_id"], r["src"], r["dst"]) == key]
        first = ", ".join(f"{r['prev_frame']}..{r['next_frame']} ({r['cycles_missing']})" for r in mine[:3])
        if not s["uniform"]:
            first = "cycle counter does not advance uniformly: gaps not detected"
        station = mine[0]["station"] if mine and mine[0]["station"] else "-"   # a NameOfStation: wire text
        t.add_row(visible(f"0x{s['frame_id']:04X} {s['src']} -> {s['dst']}"), visible(station),
                  visible(mine[0]["direction"] if mine else "-"), str(s["gaps"]), str(s["cycles_missing"]), first)
    return t
