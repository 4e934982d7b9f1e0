"""`pndiss fleet-report DATASET --html FILE`: the fleet report as one self-contained HTML file.

Same sections as the terminal (pndiss/dataset/report.py collects them). No scripts, no network:
the chart is inline SVG, the heat map table cells. Station names, rules, files and errors come from
the wire or the file system: every one goes through ``esc`` (html.escape, quotes included).
"""
from __future__ import annotations

import html

from . import __version__

SECTIONS = ("overview", "over-time", "worst-axes", "presets-restarts", "lossy", "failed")
TITLES = {"overview": "Overview", "over-time": "Violations per station and rule over time",
          "worst-axes": "Worst axes", "presets-restarts": "Presets and restarts per day",
          "lossy": "Lossy captures", "failed": "Failed captures"}
SEV = {"error": "#d62728", "warning": "#ff7f0e", "info": "#1f77b4"}
CSS = ("body{font-family:sans-serif;max-width:1250px;margin:1em auto;color:#222}"
       "table{border-collapse:collapse;margin:.4em 0;font-size:13px}td,th{border:1px solid #ccc;padding:2px 6px;"
       "text-align:left;vertical-align:top}th{background:#eee}.none{color:#777}.num{text-align:right}"
       ".verdict{font-size:20px;font-weight:bold;padding:.4em;border-radius:4px}.bad{background:#fde4e4}"
       ".good{background:#e4f7e4}.error{color:#c00}.warning{color:#c60}.info{color:#06c}nav a{margin-right:1em}"
       "td.heat{text-align:center;min-width:1.6em}td.k{white-space:nowrap}.legend span{margin-right:1em}")


def esc(v) -> str:
    return html.escape("" if v is None else str(v), quote=True)


def _table(head: list[str], rows: list[list], num: set[int] = frozenset()) -> str:
    if not rows:
        return "<p class='none'>none</p>"
    h = "".join(f"<th>{esc(c)}</th>" for c in head)
    body = "".join("<tr>" + "".join(f"<td{' class=num' if i in num else ''}>{esc(c)}</td>" for i, c in enumerate(r))
                   + "</tr>" for r in rows)
    return f"<table><thead><tr>{h}</tr></thead><tbody>{body}</tbody></table>"


def _chart(d: dict) -> str:
    """Bars of violations per period, stacked by severity (inline SVG)."""
    periods = d["periods"]
    if not periods:
        return ""
    tot = {p: {s: 0 for s in SEV} for p in periods}
    for v in d["violations"]:
        for p, n in v["by_period"].items():
            if p in tot:
                tot[p][v["severity"] if v["severity"] in SEV else "error"] += n
    top = max(sum(x.values()) for x in tot.values()) or 1
    w, h, bw = 1000, 180, max(4, min(40, 900 // len(periods)))
    parts = []
    for i, p in enumerate(periods):
        y = h - 20
        x = 50 + i * (bw + 4)
        for s, colour in SEV.items():
            bh = round(tot[p][s] / top * (h - 40))
            if bh:
                y -= bh
                parts.append(f"<rect x='{x}' y='{y}' width='{bw}' height='{bh}' fill='{colour}'>"
                             f"<title>{esc(p)}: {tot[p][s]} {esc(s)}</title></rect>")
        parts.append(f"<text x='{x}' y='{h - 5}' font-size='9'>{esc(p[-5:])}</text>")
    parts.append(f"<text x='0' y='14' font-size='11'>{top}</text><text x='0' y='{h - 22}' font-size='11'>0</text>")
    legend = "".join(f"<span style='color:{c}'>&#9632; {s}</span>" for s, c in SEV.items())
    return (f"<svg width='{w}' height='{h}' role='img' aria-label='violations per {esc(d['unit'])}'>{''.join(parts)}"
            f"</svg><p class='legend'>{legend}</p>")


def _heat(d: dict) -> str:
    if not d["violations"]:
        return "<p class='none'>none</p>"
    periods = d["periods"]
    top = max((n for v in d["violations"] for n in v["by_period"].values()), default=1)
    short = [p[5:] if d["unit"] == "day" else p for p in periods]   # the year is in the overview
    head = "".join(f"<th>{esc(x)}</th>" for x in ["station", "rule", "total"]) + "".join(
        f"<th title='{esc(p)}'>{esc(x)}</th>" for p, x in zip(periods, short))
    rows = []
    for v in d["violations"]:
        cells = []
        for p in periods:
            n = v["by_period"].get(p, 0)
            a = 0 if not n else 0.15 + 0.85 * n / top
            cells.append(f"<td class='heat' style='background:rgba(214,39,40,{a:.2f})'>{n or ''}</td>")
        rows.append(f"<tr><td class='k'>{esc(v['station'])}</td><td class='k {esc(v['severity'])}'>{esc(v['rule'])}</td>"
                    f"<td class='num'>{v['total']}</td>{''.join(cells)}</tr>")
    return f"<table><thead><tr>{head}</tr></thead><tbody>{''.join(rows)}</tbody></table>"


def render(d: dict, dataset: str) -> str:
    ov = d["overview"]
    bad = ov["errors"] or ov["failed"]
    verdict = (f"{ov['captures']} captures, {ov['violations']} violations ({ov['errors']} errors, "
               f"{ov['warnings']} warnings, {ov['infos']} info), {ov['failed']} failed")
    body = {
        "overview": f"<p class='verdict {'bad' if bad else 'good'}'>{esc(verdict)}</p>" + _table(
            ["captures", "frames", "from", "to", "stations", "axes", "capture gaps", "cycles lost"],
            [[ov["captures"], f"{ov['frames']:,}", ov["first_ts"], ov["last_ts"], ov["stations"], ov["axes"],
              ov["capture_gaps"], ov["cycles_missing"]]]),
        "over-time": f"<p>per {esc(d['unit'])}</p>" + _chart(d) + _heat(d),
        "worst-axes": _table(["station", "device MAC", "slot/subslot", "errors", "warnings", "info", "rules",
                              "captures", "which"],
                             [[a["station"], a["device_mac"], f"{a['slot']}/{a['subslot']}", a["errors"], a["warnings"],
                               a["infos"], a["rules"], a["captures"], a["which"]] for a in d["worst_axes"]],
                             {3, 4, 5, 6, 7}),
        "presets-restarts": _table(["day", "presets requested", "presets done", "connects", "restarts", "aborts",
                                    "releases"],
                                   [[r["day"], r["presets_requested"], r["presets_done"], r["connects"], r["restarts"],
                                     r["aborts"], r["releases"]] for r in d["days"]], {1, 2, 3, 4, 5, 6}),
        "lossy": _table(["file", "from", "frames", "capture gaps", "cycles lost", "lost %"],
                        [[r["file"], r["first_ts"], r["frames"], r["capture_gaps"], r["cycles_missing"], r["lost_pct"]]
                         for r in d["lossy"]], {2, 3, 4, 5}),
        "failed": _table(["file", "error"], [[r["file"], r["error"]] for r in d["failed"]]),
    }
    nav = "".join(f"<a href='#{s}'>{TITLES[s]}</a>" for s in SECTIONS)
    secs = "".join(f"<section id='{s}'><h2>{TITLES[s]}</h2>{body[s]}</section>" for s in SECTIONS)
    return (f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>pndiss fleet report: "
            f"{esc(dataset)}</title><style>{CSS}</style></head><body><h1>pndiss fleet report: {esc(dataset)}</h1>"
            f"<p>pndiss {esc(__version__)}</p><nav>{nav}</nav>{secs}</body></html>\n")
