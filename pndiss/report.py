"""Terminal report (rich) and the progress bar.

The verdict comes first (pndiss/verdict.py: counts by severity and side, the first frame of each
rule, trust signals, what was not checked), the details after it, and the one-line verdict last.
The session and cyclic trackers contribute their own sections through ``report_sections()``.

Wire strings are data: the console never parses markup or emoji, and every table cell passes
through ``textsafe.visible`` (control characters and ANSI escapes shown, absurd lengths cut).
"""
from __future__ import annotations

import os
import sys
import time

from rich.console import Console
from rich.table import Table
from rich.text import Text

from . import verdict as vd
from .textsafe import visible

SEV_STYLE = {"error": "bold red", "warning": "yellow", "info": "cyan"}


def _ts(ns: int | None) -> str:
    if ns is None:
        return "-"
    try:
        return time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime(ns // 1_000_000_000)) + f".{ns % 1_000_000_000:09d}"[:7] + " UTC"
    except (OverflowError, OSError, ValueError):   # beyond the platform's dates: the number itself
        return f"{ns} ns since 1970"


class _Console(Console):
    def on_broken_pipe(self) -> None:
        """rich exits with 1 on a closed stdout; the CLI ends quietly with 0 instead (cli.py)."""
        raise BrokenPipeError


def make_console(file) -> Console:
    """A console that never interprets text (markup, emoji, highlighting); its width is the
    terminal's, or COLUMNS (else 120) when piped."""
    width = None
    if not (hasattr(file, "isatty") and file.isatty()):
        cols = os.environ.get("COLUMNS", "")
        width = int(cols) if cols.isdigit() and int(cols) >= 40 else 120
    return _Console(file=file, width=width, markup=False, emoji=False, highlight=False)


def row(t: Table, *cells) -> None:
    """Add a table row with every string cell made safe (wire strings are data)."""
    t.add_row(*(visible(c) if isinstance(c, str) else c for c in cells))


class ProgressReporter:
    """A rich progress bar on a TTY (with % and ETA when the input's size is known); a plain line
    every few seconds otherwise. ``what`` names the command's work ("analysing", "plotting")."""

    def __init__(self, path: str, to_stderr: bool = True, what: str = "analysing"):
        from . import inputs
        self.path = path
        self.total = inputs.size(path)
        self.what = what
        self.stream = sys.stderr
        self.tty = self.stream.isatty()
        self.last = time.monotonic()
        self.start = self.last
        self.bar = None
        if self.tty:
            from rich.progress import BarColumn, Progress, TaskProgressColumn, TextColumn, TimeRemainingColumn
            cols = [TextColumn("{task.description}")]
            if self.total:
                cols += [BarColumn(), TaskProgressColumn(), TextColumn("ETA"), TimeRemainingColumn()]
            self.bar = Progress(*cols, console=Console(file=self.stream), transient=True)
            self.task = self.bar.add_task(what, total=self.total or None)
            self.bar.start()

    def fraction(self) -> float | None:
        from . import inputs
        pos = inputs.position(self.path)
        if not self.total or pos is None:
            return None
        return min(pos / self.total, 1.0)

    def update(self, frames: int) -> None:
        now = time.monotonic()
        if self.bar is not None:
            frac = self.fraction()
            self.bar.update(self.task, completed=(frac or 0) * (self.total or 0) if frac is not None else None,
                            description=f"{self.what}: {frames:,} frames")
        elif now - self.last > 5:
            rate = frames / max(now - self.start, 1e-9)
            frac = self.fraction()
            extra = ""
            if frac:
                eta = (now - self.start) * (1 - frac) / frac
                extra = f", {frac:.0%}, ETA {eta:.0f} s"
            print(f"pndiss: {self.what}: {frames:,} frames ({rate:,.0f} frames/s{extra})", file=self.stream, flush=True)
            self.last = now

    def close(self) -> None:
        if self.bar is not None:
            self.bar.stop()


def render_violation(ev: dict, out=None) -> None:
    """One line per violation as it is decided (--follow)."""
    out = out or sys.stdout
    who = ev.get("station") or ev.get("device_mac") or ev.get("mac") or ""
    line = (f"frame {visible(ev.get('frame'))}: {visible(ev.get('severity', '?'), 20)} {visible(ev.get('side', '?'), 20)} "
            f"{visible(ev.get('rule'), 60)}" + (f" [{visible(who, 40)}]" if who else "")
            + f": {visible(ev.get('message', ''), 200)}")
    print(line, file=out, flush=True)


def render_verdict(con: Console, summary: dict, log) -> None:
    """The verdict block: headline, one line per rule (ID and side never cut), trust, not checked."""
    con.rule(Text("pndiss — ") + Text(visible(summary.get("capture", ""), 60)), style="bold")
    dur = ""
    if summary.get("first_ts_ns") is not None and summary.get("last_ts_ns") is not None:
        dur = f", {(summary['last_ts_ns'] - summary['first_ts_ns']) / 1e9:.3f} s from {_ts(summary['first_ts_ns'])}"
    acc = summary["accounting"]
    con.print(f"{summary['frames']:,} frames ({acc['decoded']:,} decoded, {acc['not_profinet']:,} not PROFINET, "
              f"{acc['malformed']:,} malformed){dur}")
    clamped = (summary.get("input") or {}).get("timestamps_clamped")
    if clamped:
        con.print(Text(f"{clamped:,} time stamps outside 1970..2262 (if_tsresol / if_tsoffset / 64-bit values) shown "
                       f"clamped, the first in frame {summary['input']['timestamps_clamped_first_frame']}"))
    for note in (summary.get("limits") or {}).get("notes", ()):
        con.print(Text(visible(note, 300)))
    if summary.get("scope"):
        sc = summary["scope"]
        con.print(Text("scope: " + visible(summary.get("scope_text") or ", ".join(f"{k} {v}" for k, v in sc.items()))
                       + " (verdict, JSONL and exit code; the tables below show the whole capture)"))
    if vd.no_profinet(summary):
        con.print(Text("VERDICT: no PROFINET frames found", style="bold yellow"))
        return
    head = vd.headline(log)
    style = "bold red" if log.by_sev.get("error") else "bold yellow" if log.total else "bold green"
    con.print(Text("VERDICT: " + visible(head, 300), style=style))
    for r in log.as_list()[:40]:
        line = Text("  ")
        line.append(f"{visible(r['severity'], 20):<7}", style=SEV_STYLE.get(r["severity"], ""))
        line.append(f" {visible(r['side'], 20):<10} {visible(r['rule'], 60)}  ×{r['events']:,} from frame {r['first_frame']}")
        if r["station"]:
            line.append(f"  {visible(r['station'], 40)}")
        con.print(line)
        con.print(Text("      " + visible(r["message"], 160), style="dim"))
    if len(log.rows) > 40 or log.overflow:
        con.print(f"  … {max(len(log.rows) - 40, 0) + log.overflow:,} more (rule, station) rows: see --jsonl")
    if log.rows:
        con.print(Text("  pndiss rules RULE-ID: what a rule checks, its manual sections, its settings",
                       style="dim"))
    for title, lines in (("Trust", vd.trust(summary)), ("Not checked", vd.not_checked(summary))):
        if lines:
            con.print(Text(title + ":", style="bold"))
            for ln in lines:
                con.print(Text("  - " + visible(ln, 300)))


def render_report(summary: dict, analyzer, to_stderr: bool = False) -> None:
    con = make_console(sys.stderr if to_stderr else sys.stdout)
    log = analyzer.violations
    render_verdict(con, summary, log)
    con.print()
    acc = summary["accounting"]
    if summary["frame_classes"]:
        t = Table(title="PN-RT frames by FrameID class")
        t.add_column("class")
        t.add_column("frames", justify="right")
        for k, v in sorted(summary["frame_classes"].items(), key=lambda kv: -kv[1]):
            row(t, k, f"{v:,}")
        con.print(t)
    if summary["events"]:
        t = Table(title="Events by kind")
        t.add_column("kind")
        t.add_column("events", justify="right")
        for k, v in sorted(summary["events"].items()):
            row(t, k, f"{v:,}")
        con.print(t)
    _stations(con, summary["stations"])
    for tracker in (analyzer.cyclic, analyzer.session, analyzer.activity, analyzer):  # encoders first
        for section in getattr(tracker, "report_sections", lambda: [])():
            con.print(section)
    if summary["malformed"]:
        t = Table(title=f"Malformed frames (first {min(20, len(summary['malformed']))} of {acc['malformed']})")
        t.add_column("frame", justify="right")
        t.add_column("layer")
        t.add_column("reason")
        for m in summary["malformed"][:20]:
            row(t, str(m["frame"]), m["layer"], m["reason"])
        con.print(t)
    con.rule()
    con.print(Text("pndiss " + visible(vd.one_line(summary, log, with_name=False), 300), style="bold"))


def _stations(con: Console, stations: list[dict]) -> None:
    if not stations:
        return
    ports = {s["mac"]: s["lldp_port_of"] for s in stations if s.get("lldp_port_of")}  # stations.as_list
    port_list: dict[str, list[str]] = {}
    for p, dev in ports.items():
        port_list.setdefault(dev, []).append(p)
    t = Table(title="Stations")
    t.add_column("MAC", no_wrap=True)
    for c in ("NameOfStation", "IP", "vendor/device", "role / type", "named by"):
        t.add_column(c)
    for s in stations:
        if s["mac"] in ports:
            continue
        vd_ = ""
        if s.get("vendor_id") is not None:
            vd_ = f"0x{s['vendor_id']:04x}/0x{s.get('device_id', 0):04x}"
            if s.get("vendor_name"):
                vd_ += f" ({s['vendor_name']})"
        role = " ".join(str(x) for x in (s.get("role"), s.get("type_of_station")) if x)
        # (the frames that told its name, role or address: DCP, LLDP, alarms -- not every frame it sent)
        seen = ", ".join(sorted(s.get("via", []))) if s.get("via") else f"{s['frames']} DCP/LLDP/alarm frames"
        if s["mac"] in port_list:
            seen += f"; LLDP ports {', '.join(sorted(port_list[s['mac']]))}"
        row(t, s["mac"], s.get("name", ""), s.get("ip", ""), vd_, role, seen)
    con.print(t)
