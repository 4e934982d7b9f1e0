"""What `pndiss fleet-report` shows, as plain data from SQL over the dataset (reader.open).

Sections: the overview, violations per station and rule over time (by day; by ISO week or month
when the dataset spans more than MAX_PERIODS days), the worst axes, presets and restarts per day,
lossy captures (capture gaps) and failed captures. The renderers (terminal, HTML) only lay it out.
"""
from __future__ import annotations

MAX_PERIODS = 31
TABLES_USED = ("captures", "violations", "axes", "states", "ars", "ar_phases")
TOP = 15

OVERVIEW = """
SELECT count(*) AS captures, count(error) AS failed, coalesce(sum(frames), 0) AS frames,
       min(first_ts) AS first_ts, max(last_ts) AS last_ts, coalesce(sum(violations), 0) AS violations,
       coalesce(sum(errors), 0) AS errors, coalesce(sum(warnings), 0) AS warnings,
       coalesce(sum(infos), 0) AS infos, coalesce(sum(capture_gaps), 0) AS capture_gaps,
       coalesce(sum(cycles_missing), 0) AS cycles_missing,
       (SELECT count(DISTINCT coalesce(station, device_mac)) FROM axes) AS stations,
       (SELECT count(*) FROM (SELECT DISTINCT coalesce(station, device_mac), slot, subslot FROM axes)) AS axes
FROM captures"""

# the period of a time stamp, chosen by the dataset's span (a placeholder filled in per query)
PERIOD = {"day": "strftime({c}, '%Y-%m-%d')", "week": "strftime({c}, '%G-W%V')", "month": "strftime({c}, '%Y-%m')"}

VIOLATIONS_OVER_TIME = """
SELECT coalesce(station, device_mac, mac, '') AS station, rule, any_value(severity) AS severity,
       {period} AS period, count(*) AS n
FROM violations GROUP BY ALL ORDER BY station, rule, period"""

WORST_AXES = """
SELECT coalesce(station, device_mac) AS station, device_mac, slot, subslot,
       count(*) FILTER (WHERE severity = 'error') AS errors,
       count(*) FILTER (WHERE severity = 'warning') AS warnings,
       count(*) FILTER (WHERE severity = 'info') AS infos,
       count(DISTINCT rule) AS rules, count(DISTINCT capture_hash) AS captures,
       string_agg(DISTINCT rule, ', ' ORDER BY rule) AS which
FROM violations WHERE slot IS NOT NULL
GROUP BY ALL ORDER BY errors DESC, warnings DESC, infos DESC, station LIMIT {top}"""

# a preset: the reference encoder's preset state goes to "requested" (and "done" when acknowledged);
# a restart: a Connect beyond the first of a device in a capture, or an AR that ended by abort
PRESETS_RESTARTS = """
WITH p AS (
    SELECT strftime(ts, '%Y-%m-%d') AS day,
           count(*) FILTER (WHERE value_name = 'requested') AS presets_requested,
           count(*) FILTER (WHERE value_name = 'done') AS presets_done
    FROM states WHERE state = 'preset' GROUP BY ALL),
c AS (
    SELECT strftime(ts, '%Y-%m-%d') AS day, count(*) AS connects,
           count(*) - count(DISTINCT capture_hash || coalesce(device_mac, '')) AS restarts
    FROM ars WHERE source IS DISTINCT FROM 'inferred from content' GROUP BY ALL),   -- (no Connect: found from content)
a AS (
    SELECT strftime(ts, '%Y-%m-%d') AS day,
           count(*) FILTER (WHERE phase = 'aborted') AS aborts,
           count(*) FILTER (WHERE phase = 'released') AS releases
    FROM ar_phases GROUP BY ALL)
SELECT day, coalesce(presets_requested, 0) AS presets_requested, coalesce(presets_done, 0) AS presets_done,
       coalesce(connects, 0) AS connects, coalesce(restarts, 0) AS restarts, coalesce(aborts, 0) AS aborts,
       coalesce(releases, 0) AS releases
FROM p FULL JOIN c USING (day) FULL JOIN a USING (day) ORDER BY day"""

LOSSY = """
SELECT file, first_ts, frames, capture_gaps, cycles_missing,
       round(100.0 * cycles_missing / nullif(frames + cycles_missing, 0), 3) AS lost_pct
FROM captures WHERE capture_gaps > 0 ORDER BY lost_pct DESC, file LIMIT {top}"""

FAILED = "SELECT file, error FROM captures WHERE error IS NOT NULL ORDER BY file"


def _rows(con, sql: str) -> list[dict]:
    cur = con.execute(sql)
    cols = [d[0] for d in cur.description]
    return [dict(zip(cols, r)) for r in cur.fetchall()]


def collect(con) -> dict:
    """Every section as lists of row dicts (and the period the time table uses)."""
    ov = _rows(con, OVERVIEW)[0]
    days = con.execute("SELECT count(DISTINCT strftime(ts, '%Y-%m-%d')) FROM violations").fetchall()[0][0]
    weeks = con.execute("SELECT count(DISTINCT strftime(ts, '%G-W%V')) FROM violations").fetchall()[0][0]
    unit = "day" if days <= MAX_PERIODS else "week" if weeks <= MAX_PERIODS else "month"
    over = _rows(con, VIOLATIONS_OVER_TIME.format(period=PERIOD[unit].format(c="ts")))
    periods = sorted({r["period"] for r in over if r["period"] is not None})
    table: dict = {}
    for r in over:
        key = (r["station"], r["rule"])
        t = table.setdefault(key, {"station": r["station"], "rule": r["rule"], "severity": r["severity"],
                                   "total": 0, "by_period": {}})
        t["total"] += r["n"]
        t["by_period"][r["period"]] = r["n"]
    return {
        "overview": ov,
        "unit": unit,
        "periods": periods[-MAX_PERIODS:],
        "violations": sorted(table.values(), key=lambda t: (t["station"], -t["total"], t["rule"])),
        "worst_axes": _rows(con, WORST_AXES.format(top=TOP)),
        "days": _rows(con, PRESETS_RESTARTS),
        "lossy": _rows(con, LOSSY.format(top=TOP)),
        "failed": _rows(con, FAILED),
    }
