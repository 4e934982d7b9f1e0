"""Reading a dataset: which tables it has, and every table as a DuckDB view.

A view reads the files ``DATASET/<table>/<hash>.parquet`` of the captures that have their
``captures`` row (a capture whose writing was interrupted never shows), with the columns united by
name when the dataset holds files of several schema versions.
"""
from __future__ import annotations

import glob
import os
import re

from .schema import TABLES, arrow_schema

VERSIONS_DIR = "_versions"   # one empty file per schema version written (a name readers skip)


class DatasetError(Exception):
    """Not a dataset (no such directory, no captures table)."""


def files(dataset_dir: str, table: str) -> list[str]:
    return sorted(glob.glob(os.path.join(glob.escape(dataset_dir), table, "*.parquet")))


def referenced(sql: str) -> set[str]:
    """The dataset's tables a statement names (any word equal to a table name: binding a view costs
    a file read, a query over 1,000 captures should not pay it for tables it does not use)."""
    words = set(re.findall(r"[a-z_]+", sql.lower()))
    return {t for t in TABLES if t in words}


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


def versions(dataset_dir: str) -> set[int]:
    """Schema versions the dataset's files were written with (the writer leaves a mark per version)."""
    try:
        return {int(n) for n in os.listdir(os.path.join(dataset_dir, VERSIONS_DIR)) if n.isdigit()}
    except FileNotFoundError:
        return set()


def open(dataset_dir: str, con=None, tables=None):
    """A DuckDB connection (in memory, or ``con``) with one view per table of the dataset (or per
    name in ``tables``): a snapshot of the files of the captures complete at this moment."""
    import duckdb

    from .writer import done_hashes
    check(dataset_dir)
    con = con or duckdb.connect()
    done = done_hashes(dataset_dir)
    # files of one schema version have the same columns: DuckDB binds a view from the first file;
    # several versions need their columns united by name (which reads every file's footer)
    union = ", union_by_name=true" if len(versions(dataset_dir)) > 1 else ""
    for t in TABLES if tables is None else [t for t in TABLES if t in tables]:
        fs = [f for f in files(dataset_dir, t) if os.path.basename(f)[:-8] in done]
        if fs:
            src = f"read_parquet([{', '.join(_sql_str(f) for f in fs)}]{union})"
        else:   # no file yet: an empty relation of the declared columns
            con.register(f"_empty_{t}", arrow_schema(t).empty_table())
            src = f"_empty_{t}"
        con.execute(f"CREATE OR REPLACE VIEW {t} AS SELECT * FROM {src}")
    return con
