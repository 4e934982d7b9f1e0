"""``pndiss query DATASET "SQL"``: SQL over a Parquet dataset on embedded DuckDB (every table a view)."""
from __future__ import annotations

import csv
import datetime
import decimal
import json
import sys


def add_parser(sub) -> None:
    p = sub.add_parser("query", help="SQL over a dataset made by pndiss fleet (DuckDB; every table a view)",
                       description="Run one SQL statement on the dataset (docs/dataset.md lists the tables "
                                   "and columns), e.g. pndiss query ds \"SELECT station, rule, count(*) "
                                   "FROM violations GROUP BY ALL\"")
    p.add_argument("dataset", help="dataset directory")
    p.add_argument("sql", help="one SQL statement (DuckDB dialect)")
    p.add_argument("--format", choices=("table", "csv", "json"), default="table",
                   help="table (default, terminal), csv, or json (one JSON object per line)")
    p.set_defaults(func=run)


def execute(dataset: str, sql: str):
    """(column names, row iterator) of ``sql`` on the dataset; UsageError for a bad dataset or SQL."""
    import duckdb

    from ..dataset import DatasetError, open as open_dataset
    from ..dataset.reader import referenced
    from ..errors import UsageError
    try:
        con = open_dataset(dataset, tables=referenced(sql))
    except DatasetError as e:
        raise UsageError(str(e)) from None
    try:
        cur = con.execute(sql)
    except duckdb.Error as e:
        raise UsageError(f"query failed: {_first_line(e)}") from None
    if not cur.description:   # a statement without a result (SET, CREATE ...)
        return [], iter(())
    cols = [d[0] for d in cur.description]

    def rows():
        try:
            while batch := cur.fetchmany(4096):
                yield from batch
        except duckdb.Error as e:
            raise UsageError(f"query failed: {_first_line(e)}") from None
    return cols, rows()


def _first_line(e: Exception) -> str:
    return str(e).strip().splitlines()[0] if str(e).strip() else type(e).__name__


def plain(v):
    """A cell as JSON/CSV can carry it."""
    if isinstance(v, (datetime.datetime, datetime.date, datetime.time)):
        return v.isoformat()
    if isinstance(v, datetime.timedelta):
        return v.total_seconds()
    if isinstance(v, decimal.Decimal):
        return int(v) if v == v.to_integral_value() else float(v)
    if isinstance(v, (bytes, bytearray, memoryview)):
        return bytes(v).hex()
    if isinstance(v, (list, tuple)):
        return [plain(x) for x in v]
    if isinstance(v, dict):
        return {str(k): plain(x) for k, x in v.items()}
    return v


def run(args) -> int:
    cols, rows = execute(args.dataset, args.sql)
    out = sys.stdout
    if args.format == "csv":
        w = csv.writer(out, lineterminator="\n")
        w.writerow(cols)
        for r in rows:
            w.writerow([("" if v is None else json.dumps(plain(v)) if isinstance(v, (list, dict)) else plain(v))
                        for v in r])
    elif args.format == "json":
        for r in rows:
            out.write(json.dumps({c: plain(v) for c, v in zip(cols, r)}, default=str) + "\n")
    else:
        from rich.console import Console
        from rich.table import Table

        from ..textsafe import text
        t = Table(show_lines=False)
        for c in cols:
            t.add_column(text(c))
        n = 0
        for r in rows:
            # every cell through textsafe: station names and messages come from the wire
            t.add_row(*(text("" if v is None else json.dumps(plain(v), default=str)
                             if isinstance(v, (list, dict)) else plain(v)) for v in r))
            n += 1
        console = Console(file=out)
        if cols:
            console.print(t)
            console.print(f"{n} row{'s' if n != 1 else ''}")
    return 0
