"""``pndiss fleet-report DATASET [--html FILE]``: what a dataset of many captures says, at a glance."""
from __future__ import annotations

import os


def add_parser(sub) -> None:
    p = sub.add_parser("fleet-report", help="violations per station and rule over time, worst axes, presets "
                                            "and restarts, lossy captures of a dataset (terminal or HTML)")
    p.add_argument("dataset", help="dataset directory (pndiss fleet, docs/dataset.md)")
    p.add_argument("--html", metavar="FILE", help="also write the report as one self-contained HTML file")
    p.set_defaults(func=run)


def run(args) -> int:
    from ..dataset import DatasetError, open as open_dataset
    from ..dataset.report import TABLES_USED, collect
    from ..errors import UsageError
    try:
        con = open_dataset(args.dataset, tables=TABLES_USED)
    except DatasetError as e:
        raise UsageError(str(e)) from None
    data = collect(con)
    if args.html:
        from ..fleet_html import render
        page = render(data, os.path.basename(os.path.normpath(args.dataset)))
        try:
            with open(args.html, "w", encoding="utf-8") as f:
                f.write(page)
        except OSError as e:
            raise UsageError(f"cannot write {args.html}: {e.strerror}") from None
    render_terminal(data)
    return 0


def render_terminal(d: dict, console=None) -> None:
    from rich.console import Console
    from rich.table import Table

    from ..textsafe import text
    c = console or Console()
    ov = d["overview"]
    c.print(f"[bold]{ov['captures']:,} captures[/bold] ({ov['failed']} failed), {ov['frames']:,} frames, "
            f"{str(ov['first_ts'] or '-')[:19]} .. {str(ov['last_ts'] or '-')[:19]} UTC; {ov['stations']} stations, {ov['axes']} axes")
    style = "bold red" if ov["errors"] else "bold green"
    c.print(f"[{style}]{ov['violations']:,} violations[/{style}] ({ov['errors']} errors, {ov['warnings']} warnings, "
            f"{ov['infos']} info); {ov['capture_gaps']} capture gaps, {ov['cycles_missing']} cycles lost")

    def table(title, head, rows, right=(), wide=(0, 1)):
        t = Table(title=title, title_justify="left")
        for i, h in enumerate(head):
            longest = max((len(r[i]) for r in rows), default=len(h))
            # names up to 24 characters in full (a longer one is cut: the HTML has all of it), rule IDs whole
            t.add_column(h, justify="right" if i in right else "left", no_wrap=i in wide,
                         min_width=min(longest, 24 if i == 0 else 40) if i in wide else min(longest, 20),
                         max_width=max(24, len(h)) if i == 0 and i in wide else None)
        for r in rows:
            t.add_row(*(text(x) for x in r))   # station names, files, errors: wire/file text, shown inert
        if rows:
            c.print(t)
        else:
            c.print(f"{title}: none")

    # as many of the last periods as the terminal has room for (the HTML shows them all)
    fixed = sum(min(max((len(str(v[k])) for v in d["violations"]), default=8), w) + 3
                for k, w in (("station", 24), ("rule", 40)))
    room = max(1, (c.width - fixed - 12) // 8)
    periods = d["periods"][-room:]
    short = [p[5:] if d["unit"] == "day" else p for p in periods]   # the year is in the overview line
    table(f"Violations per station and rule (per {d['unit']}, last {len(periods)})",
          ["station", "rule", "total", *short],
          [[v["station"], v["rule"], str(v["total"]), *(str(v["by_period"].get(p, "")) for p in periods)]
           for v in d["violations"]], right=set(range(2, 3 + len(periods))))
    table("Worst axes", ["station", "device MAC", "slot/sub", "errors", "warnings", "info", "rules", "captures"],
          [[a["station"], a["device_mac"], f"{a['slot']}/{a['subslot']}", str(a["errors"]), str(a["warnings"]),
            str(a["infos"]), str(a["rules"]), str(a["captures"])] for a in d["worst_axes"]], right={3, 4, 5, 6, 7})
    table("Presets and restarts per day", ["day", "presets req.", "presets done", "connects", "restarts", "aborts",
                                           "releases"],
          [[r["day"], *(str(r[k]) for k in ("presets_requested", "presets_done", "connects", "restarts", "aborts",
                                            "releases"))] for r in d["days"][-31:]], right={1, 2, 3, 4, 5, 6})
    table("Lossy captures", ["file", "from", "frames", "gaps", "cycles lost", "lost %"],
          [[os.path.basename(r["file"] or ""), str(r["first_ts"])[:19], str(r["frames"]), str(r["capture_gaps"]), str(r["cycles_missing"]),
            str(r["lost_pct"])] for r in d["lossy"]], right={2, 3, 4, 5})
    if d["failed"]:
        table("Failed captures", ["file", "error"], [[os.path.basename(r["file"] or ""), r["error"]]
                                                     for r in d["failed"]], wide=(0,))
