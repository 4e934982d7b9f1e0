"""`pndiss report CAPTURE -o report.html`: one self-contained HTML file to send to a colleague.

Sections: verdict (counts by severity and side, the first frame of each rule, what the capture
lets us trust), stations and ARs, one position/speed plot per axis, every violation (the first ones
of each rule with a plot of their axis around them, all with the frames to open in Wireshark),
parameter accesses, records, settings. Plots are PNG data URIs drawn by pndiss/plot.py
(matplotlib); no scripts, no network, no external files.

Every value that comes from the capture (station names, I&M strings, LLDP IDs, messages) is text
from the wire: it goes through ``esc`` (html.escape, quotes included) and nowhere else.
"""
from __future__ import annotations

import base64
import html
import os
import tempfile

from . import __version__
from .plot import SEV_COLOURS, Timeline, render_png
from .cyclic_report import connection
from .report_data import ReportCollector, axis_key

SEVERITIES = ("error", "warning", "info")
SECTIONS = ("verdict", "stations", "axes", "violations", "parameters", "records", "settings")


def esc(v) -> str:
    """Any value as HTML text (wire strings are data, never markup)."""
    return html.escape("" if v is None else str(v), quote=True)


def _table(head: list[str], rows: list[list], cls: str = "") -> str:
    if not rows:
        return "<p class='none'>none</p>"
    h = "".join(f"<th>{esc(c)}</th>" for c in head)
    body = "".join("<tr>" + "".join(f"<td>{esc(c)}</td>" for c in r) + "</tr>" for r in rows)
    return f"<table class='{esc(cls)}'><thead><tr>{h}</tr></thead><tbody>{body}</tbody></table>"


def _png_uri(tl: Timeline, title: str) -> str | None:
    """The timeline as a PNG data URI; None when it cannot be drawn (e.g. a label matplotlib refuses)."""
    fd, path = tempfile.mkstemp(suffix=".png")
    os.close(fd)
    try:
        render_png(tl, path, title)
        with open(path, "rb") as f:
            return "data:image/png;base64," + base64.b64encode(f.read()).decode("ascii")
    except (ValueError, RuntimeError, OverflowError):
        return None
    finally:
        os.remove(path)


def _img(uri: str | None, alt: str) -> str:
    if uri is None:
        return f"<p class='none'>{esc(alt)}: no plot could be drawn</p>"
    return f"<img src='{uri}' alt='{esc(alt)}'>"


def _axis_timeline(full: Timeline, key: tuple, marks: list) -> Timeline:
    """A Timeline of one axis of the whole capture, with that axis' violation markers."""
    t = Timeline(full.max_points)
    t.encoders = {key: full.encoders[key]}
    t.first_ts, t.last_ts, t.t0 = full.first_ts, full.last_ts, full.t0
    t.violations = marks[:300]
    t.violation_count = len(marks)
    return t


def _context_timeline(ctx) -> Timeline:
    t = Timeline(100_000)
    for ev in ctx.events:
        t.on_event(ev)
    t.on_event(ctx.violation)
    return t


def _where(v: dict) -> tuple[int | None, int | None]:
    fn = v.get("frame") if isinstance(v.get("frame"), int) else None
    last = v.get("last_frame") if isinstance(v.get("last_frame"), int) else fn
    return fn, last


def _wireshark(capture: str, v: dict) -> str:
    fn, last = _where(v)
    if fn is None:
        return ""
    frames = f"frame.number == {fn}" if last in (None, fn) else f"frame.number in {{{fn} {last}}}"
    return (f"<p class='ws'>Wireshark: Go to packet {fn} (Ctrl+G)"
            + (f", then {last}" if last not in (None, fn) else "")
            + f"; display filter <code>{esc(frames)}</code> · "
            f"<code>tshark -r {esc(os.path.basename(capture))} -Y \"{esc(frames)}\" -V</code></p>")


def _verdict(summary: dict, col: ReportCollector) -> str:
    vs = col.violations
    by = {s: {} for s in SEVERITIES}
    first: dict[str, dict] = {}
    for v in vs:
        sev = v.get("severity") if v.get("severity") in by else "error"
        side = str(v.get("side") or "?")
        by[sev][side] = by[sev].get(side, 0) + 1
        r = str(v.get("rule"))
        if r not in first or (v.get("frame") or 0) < (first[r].get("frame") or 0):
            first[r] = v
    parts = []
    for s in SEVERITIES:
        n = sum(by[s].values())
        sides = ", ".join(f"{c} {esc(k)}" for k, c in sorted(by[s].items()))
        parts.append(f"<span class='{s}'>{n} {s}{'s' if n != 1 else ''}</span>" + (f" ({sides})" if n else ""))
    if vs:
        f0 = min((v.get("frame") or 0) for v in vs)
        head = f"<p class='verdict bad'>{' · '.join(parts)} — first at frame {f0}</p>"
    else:
        head = "<p class='verdict good'>No violations.</p>"
    cyc = summary.get("cyclic", {})
    unjudged = [f"{n} {what}" for n, what in ((cyc.get("frames_unmapped", 0), "cyclic frames not mapped to a telegram"),
                                              (cyc.get("frames_no_telegram", 0),
                                               "cyclic frames of ARs without an encoder telegram (IO devices)"),
                                              (cyc.get("cycles_gated", 0), "cycles not judged")) if n]
    if unjudged:
        head += f"<p class='warn'>Not checked: {esc(', '.join(unjudged))} (see below).</p>"
    if col.n_violations > len(vs):
        head += f"<p>{col.n_violations} violations in all; the first {len(vs)} are counted and listed.</p>"
    counts = {}
    for v in vs:
        counts[str(v.get("rule"))] = counts.get(str(v.get("rule")), 0) + 1
    rows = [[r, v.get("severity"), v.get("side"), counts[r], v.get("frame"), v.get("message")]
            for r, v in sorted(first.items(), key=lambda kv: kv[1].get("frame") or 0)]
    acc = summary.get("accounting", {})
    trust = [
        ["frames", summary.get("frames")],
        ["decoded / not PROFINET / malformed",
         f"{acc.get('decoded', 0)} / {acc.get('not_profinet', 0)} / {acc.get('malformed', 0)}"],
        ["cyclic frames mapped / not mapped to a telegram", f"{cyc.get('frames_mapped', 0)} / {cyc.get('frames_unmapped', 0)}"],
        ["cycles not judged (DataValid 0, STOP, IOPS bad, ambiguous telegram)", cyc.get("cycles_gated", 0)],
    ]
    for e in cyc.get("encoders", []):
        trust.append([f"telegram of {e.get('station') or e.get('device_mac')} {e.get('slot')}.{e.get('subslot')}",
                      f"{e.get('telegram')} (from {e.get('telegram_source')}); profile {e.get('profile')}"])
    if not summary.get("settings", {}).get("sol_monitor_rt"):
        trust.append(["not checked", "sign-of-life in RT (non-isochronous) ARs: --set sol_monitor_rt=1 checks it"])
    return (head + "<h3>Rules, first frame each</h3>"
            + _table(["rule", "severity", "side", "count", "first frame", "message"], rows)
            + "<h3>What the capture lets us trust</h3>" + _table(["item", "value"], trust, "kv"))


def _stations(summary: dict) -> str:
    st = [[s.get("name"), s.get("mac"), s.get("ip"), s.get("type_of_station"),
           f"0x{s['vendor_id']:04x}/0x{s['device_id']:04x}" if isinstance(s.get("vendor_id"), int)
           and isinstance(s.get("device_id"), int) else "", s.get("chassis_id"), s.get("port_id"), s.get("frames")]
          for s in summary.get("stations", []) if not s.get("lldp_port_of")]   # a station's LLDP port is no station
    ars = [[a.get("ar_uuid"), f"{a.get('controller_station') or a.get('controller_mac')} → "
            f"{a.get('station') or a.get('device_mac')}", a.get("ar_type_name"),
            (a.get("status") or {}).get("text") if isinstance(a.get("status"), dict) else a.get("status"),
            ", ".join(str(c) for c in a.get("control") or []), a.get("frame"), _end(a)]
           for a in summary.get("session", {}).get("ars", [])]
    return ("<h3>Stations</h3>" + _table(["name", "MAC", "IP", "type", "vendor/device", "LLDP chassis",
                                          "LLDP port", "DCP/LLDP/alarm frames"], st)
            + "<h3>Application relations</h3>" + _table(["AR UUID", "controller → device", "type", "status",
                                                          "control", "connect frame", "ended"], ars))


def _end(a: dict) -> str:
    """How and where the AR ended: 'released at frame N', 'aborted at frame N: cause', or ''."""
    ph = a.get("phase")
    if ph not in ("released", "aborted"):
        return ""
    at = next((p.get("frame") for p in reversed(a.get("phases") or []) if p.get("phase") == ph), a.get("release_frame"))
    return f"{ph} at frame {at}" + (f": {a['abort_cause']}" if a.get("abort_cause") else "")


def _axes(summary: dict, col: ReportCollector) -> str:
    tl = col.timeline
    out = []
    all_encs = summary.get("cyclic", {}).get("encoders", [])
    encs: dict = {}
    for e in all_encs:   # a device that reconnected: one entry per AR, one timeline for the axis
        encs.setdefault((str(e.get("device_mac")), str(e.get("slot")), str(e.get("subslot"))), []).append(e)
    for key, enc in tl.encoders.items():
        marks = [(v.get("ts_ns"), str(v.get("rule")), str(v.get("severity"))) for v in col.violations
                 if axis_key(v) == key and isinstance(v.get("ts_ns"), int)]
        out.append(f"<h3>{esc(enc.label)}</h3>")
        for e in encs.get(key) or [{}]:
            out.append(f"<p>telegram {esc(e.get('telegram'))} (from "
                       f"{esc(e.get('telegram_source'))}), profile {esc(e.get('profile'))} — "
                       f"{esc(e.get('profile_reason'))}; {esc(e.get('cycles'))} cycles{esc(connection(e, all_encs))}</p>")
        out.append(_img(_png_uri(_axis_timeline(tl, key, marks), ""), f"{enc.label} position and speed"))
    return "".join(out) or "<p class='none'>no telegram samples in this capture</p>"


def _violations(capture: str, col: ReportCollector) -> str:
    plotted = {id(c.violation): c for c in col.contexts}
    out = []
    for i, v in enumerate(col.violations):
        sev = v.get("severity") if v.get("severity") in SEV_COLOURS else "error"
        fn, last = _where(v)
        frames = f"frame {fn}" if last in (None, fn) else f"frames {fn}–{last}"
        who = " ".join(str(x) for x in (v.get("station") or v.get("device_mac") or "",
                                         f"{v.get('slot')}.{v.get('subslot')}" if v.get("slot") is not None else "") if x)
        out.append(f"<div class='viol {sev}' id='v{i}'><h4>{esc(v.get('rule'))} <small>{esc(sev)}, "
                   f"{esc(v.get('side'))} side, {esc(frames)}{', ' + esc(who) if who else ''}</small></h4>"
                   f"<p>{esc(v.get('message'))}</p>" + _wireshark(capture, v))
        c = plotted.get(id(v))
        if c is not None and c.events:
            out.append(_img(_png_uri(_context_timeline(c), ""), f"{v.get('rule')} around frame {fn}"))
        if v.get("source"):
            out.append(f"<p class='src'>source: {esc(v.get('source'))}</p>")
        out.append("</div>")
    return "".join(out) or "<p class='none'>none</p>"


def _values(p: dict) -> str:
    parts = []
    for x in p.get("params") or []:
        if not isinstance(x, dict):
            continue
        vals = x.get("values") or (x.get("written") or {}).get("values")   # (a change: the values written)
        val = x.get("error") or (", ".join(str(v) for v in vals[:8]) + (" …" if len(vals) > 8 else "")
                                 + (" (written)" if not x.get("values") else "") if isinstance(vals, list) else "")
        parts.append(f"P{x.get('pnu')} {x.get('name') or ''}: {val}")
    return "; ".join(parts)


def _parameters(col: ReportCollector) -> str:
    rows = [[p.get("request_frame"), p.get("frame"), p.get("station") or p.get("device_mac"),
             p.get("request_id"), _values(p), "ok" if p.get("ok") else "error"] for p in col.params]
    more = f"<p>{col.n_params} in all, the first {len(rows)} shown.</p>" if col.n_params > len(rows) else ""
    return _table(["request frame", "response frame", "station", "request", "parameters", "result"], rows) + more


def _result(r: dict):
    st = r.get("status")
    return r.get("result") or (st.get("text") if isinstance(st, dict) else st)


def _records(col: ReportCollector, names: dict) -> str:
    rows = [[r.get("frame"), r.get("kind"), r.get("op"), f"0x{r['index']:04X}" if isinstance(r.get("index"), int)
             else r.get("index"), r.get("index_name"), r.get("station") or names.get(r.get("device_mac"))
             or r.get("device_mac"),   # (a record_result names only the MAC: the station's name as the rows above)
             f"{r.get('slot')}.{r.get('subslot')}", r.get("length"), _result(r)]
            for r in col.records]
    more = f"<p>{col.n_records} in all, the first {len(rows)} shown.</p>" if col.n_records > len(rows) else ""
    return _table(["frame", "kind", "op", "index", "name", "station", "slot.subslot", "length", "result"], rows) + more


CSS = ("body{font-family:sans-serif;max-width:1250px;margin:1em auto;color:#222}"
       "table{border-collapse:collapse;margin:.4em 0;font-size:13px}td,th{border:1px solid #ccc;padding:2px 6px;"
       "text-align:left;vertical-align:top}.warn{color:#a60;font-weight:bold}th{background:#eee}img{max-width:100%}.none{color:#777}"
       ".verdict{font-size:20px;font-weight:bold;padding:.4em;border-radius:4px}.bad{background:#fde4e4}"
       ".good{background:#e4f7e4}.error{color:#c00}.warning{color:#c60}.info{color:#06c}"
       ".viol{border-left:5px solid #ccc;padding:.2em .8em;margin:.8em 0}.viol.error{border-color:#d62728}"
       ".viol.warning{border-color:#ff7f0e}.viol.info{border-color:#1f77b4}.viol p,.viol h4{color:#222}"
       ".src{font-size:11px;color:#777}code{background:#f4f4f4;padding:0 3px}nav a{margin-right:1em}")


def render(summary: dict, col: ReportCollector, capture: str) -> str:
    name = os.path.basename(capture)
    body = {
        "verdict": _verdict(summary, col),
        "stations": _stations(summary),
        "axes": _axes(summary, col),
        "violations": _violations(capture, col),
        "parameters": _parameters(col),
        "records": _records(col, {st.get("mac"): st.get("name") for st in summary.get("stations", []) if st.get("name")}),
        "settings": _table(["setting", "value"], [[k, v] for k, v in summary.get("settings", {}).items()], "kv"),
    }
    titles = {"verdict": "Verdict", "stations": "Stations and ARs", "axes": "Axes", "violations": "Violations",
              "parameters": "Parameter accesses", "records": "Records", "settings": "Settings"}
    nav = "".join(f"<a href='#{s}'>{titles[s]}</a>" for s in SECTIONS)
    secs = "".join(f"<section id='{s}'><h2>{titles[s]}</h2>{body[s]}</section>" for s in SECTIONS)
    return (f"<!DOCTYPE html><html lang='en'><head><meta charset='utf-8'><title>pndiss report: {esc(name)}</title>"
            f"<style>{CSS}</style></head><body><h1>pndiss report: {esc(name)}</h1>"
            f"<p>{esc(summary.get('frames'))} frames · pndiss {esc(__version__)}</p><nav>{nav}</nav>{secs}"
            "</body></html>\n")
