"""Terminal report (rich) and the progress bar.

The report is built from ``Analyzer.summary()``; the session and cyclic trackers contribute
their own sections through ``report_sections()`` so each part renders what it knows.
"""
from __future__ import annotations

import os
import sys
import time

from rich.console import Console
from rich.table import Table



def _ts(ns: int | None) -> str:
    if ns is None:
        return "-"
    return time.strftime("%Y-%m-%d %H:%M:%S", time.gmtime(ns // 1_000_000_000)) + f".{ns % 1_000_000_000:09d}"[:7] + " UTC"


class ProgressReporter:
    """A rich progress bar on a TTY; a plain line every few seconds otherwise."""

    def __init__(self, path: str, to_stderr: bool):
        self.total = os.path.getsize(path)
        self.stream = sys.stderr
        self.tty = self.stream.isatty()
        self.last = time.monotonic()
        self.start = self.last
        self.bar = None
        if self.tty:
            from rich.progress import Progress
            self.bar = Progress(console=Console(file=self.stream), transient=True)
            self.task = self.bar.add_task("analysing", total=None)
            self.bar.start()

    def update(self, frames: int) -> None:
        now = time.monotonic()
        if self.bar is not None:
            self.bar.update(self.task, completed=frames, description=f"analysing: {frames:,} frames")
        elif now - self.last > 5:
            rate = frames / max(now - self.start, 1e-9)
            print(f"pndiss: {frames:,} frames analysed ({rate:,.0f} frames/s)", file=self.stream, flush=True)
            self.last = now

    def close(self) -> None:
        if self.bar is not None:
            self.bar.stop()


def render_report(summary: dict, analyzer, to_stderr: bool = False) -> None:
    con = Console(file=sys.stderr if to_stderr else sys.stdout, width=None if sys.stdout.isatty() else 120)
    acc = summary["accounting"]
    con.rule(f"[bold]pndiss[/bold] — {summary.get('capture', '')}")
    dur = None
    if summary["first_ts_ns"] is not None and summary["last_ts_ns"] is not None:
        dur = (summary["last_ts_ns"] - summary["first_ts_ns"]) / 1e9
    con.print(f"{summary['frames']:,} frames, {_ts(summary['first_ts_ns'])} … "
              f"{_ts(summary['last_ts_ns'])}" + (f" ({dur:.3f} s)" if dur is not None else ""))
    t = Table(title="Frame accounting", show_header=True)
    t.add_column("decoded", justify="right")
    t.add_column("not PROFINET", justify="right")
    t.add_column("malformed", justify="right")
    t.add_column("total", justify="right")
    total = acc["decoded"] + acc["not_profinet"] + acc["malformed"]
    t.add_row(f"{acc['decoded']:,}", f"{acc['not_profinet']:,}", f"{acc['malformed']:,}",
              f"{total:,}" + ("" if total == summary["frames"] else " (MISMATCH)"))
    con.print(t)
    if summary["frame_classes"]:
        t = Table(title="PN-RT frames by FrameID class")
        t.add_column("class")
        t.add_column("frames", justify="right")
        for k, v in sorted(summary["frame_classes"].items(), key=lambda kv: -kv[1]):
            t.add_row(k, f"{v:,}")
        con.print(t)
    if summary["events"]:
        t = Table(title="Events by kind")
        t.add_column("kind")
        t.add_column("events", justify="right")
        for k, v in sorted(summary["events"].items()):
            t.add_row(k, f"{v:,}")
        con.print(t)
    _stations(con, summary["stations"])
    for tracker in (analyzer.activity, analyzer.session, analyzer.cyclic, analyzer):
        for section in getattr(tracker, "report_sections", lambda: [])():
            con.print(section)
    if summary["malformed"]:
        t = Table(title=f"Malformed frames (first {min(20, len(summary['malformed']))} of {acc['malformed']})")
        t.add_column("frame", justify="right")
        t.add_column("layer")
        t.add_column("reason")
        for m in summary["malformed"][:20]:
            t.add_row(str(m["frame"]), m["layer"], m["reason"])
        con.print(t)


def _stations(con: Console, stations: list[dict]) -> None:
    if not stations:
        return
    t = Table(title="Stations")
    for c in ("MAC", "NameOfStation", "IP", "vendor/device", "role / type", "seen in"):
        t.add_column(c)
    for s in stations:
        vd = ""
        if s.get("vendor_id") is not None:
            vd = f"0x{s['vendor_id']:04x}/0x{s.get('device_id', 0):04x}"
            if s.get("vendor_name"):
                vd += f" ({s['vendor_name']})"
        role = " ".join(str(x) for x in (s.get("role"), s.get("type_of_station")) if x)
        seen = ", ".join(sorted(s.get("via", []))) if s.get("via") else f"{s['frames']} frames"
        t.add_row(s["mac"], s.get("name", ""), s.get("ip", ""), vd, role, seen)
    con.print(t)
