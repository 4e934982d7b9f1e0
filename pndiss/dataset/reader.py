"""Reading a dataset: which tables it has, and every table as a DuckDB view.

A view reads ``DATASET/<table>/*.parquet`` (columns united by name, so files of an older schema
version with fewer columns still read) and keeps only rows whose capture has its ``captures`` row:
rows of a capture whose writing was interrupted never show.
"""
from __future__ import annotations

import glob
import os

from .schema import TABLES, arrow_schema


class DatasetError(Exception):
    """Not a dataset (no such directory, no captures table)."""


def files(dataset_dir: str, table: str) -> list[str]:
    return sorted(glob.glob(os.path.join(glob.escape(dataset_dir), table, "*.parquet")))


def tables(dataset_dir: str) -> dict[str, int]:
    """Table name -> number of files, for every table of the schema (0: no rows yet)."""
    check(dataset_dir)
    return {t: len(files(dataset_dir, t)) for t in TABLES}


def check(dataset_dir: str) -> None:
    if not os.path.isdir(dataset_dir):
        raise DatasetError(f"{dataset_dir}: no such dataset directory")
    if not os.path.isdir(os.path.join(dataset_dir, "captures")):
        raise DatasetError(f"{dataset_dir}: not a pndiss dataset (no captures/ table; "
                           f"make one with pndiss fleet or pndiss.dataset.write_capture)")


def _sql_str(s: str) -> str:
    return "'" + s.replace("'", "''") + "'"


def open(dataset_dir: str, con=None):
    """A DuckDB connection (in memory, or ``con``) with one view per table of the dataset."""
    import duckdb

    check(dataset_dir)
    con = con or duckdb.connect()
    for t in TABLES:
        pattern = os.path.join(dataset_dir, t, "*.parquet")
        if files(dataset_dir, t):
            src = f"read_parquet({_sql_str(pattern)}, union_by_name=true)"
        else:   # no file yet: an empty relation of the declared columns
            empty = arrow_schema(t).empty_table()
            con.register(f"_empty_{t}", empty)
            src = f"_empty_{t}"
        if t == "captures":
            con.execute(f"CREATE OR REPLACE VIEW captures AS SELECT * FROM {src}")
        else:
            con.execute(f"CREATE OR REPLACE VIEW {t} AS SELECT * FROM {src} "
                        f"WHERE capture_hash IN (SELECT capture_hash FROM captures)")
    return con
