"""The Parquet dataset of many captures (docs/dataset.md): one table per kind of fact, one file per
table per capture, named by the capture's content hash.

- ``write_capture(path, dataset_dir, settings=None, cycles="on_change") -> dict``: analyse one capture
  and add it (its ``captures`` row is returned; a failed file is recorded with ``error``);
- ``open(dataset_dir)``: a DuckDB connection with every table as a view;
- ``tables(dataset_dir)``, ``done_hashes(dataset_dir)``, ``content_hash(path)``.
"""
from __future__ import annotations

from .reader import DatasetError, files, open, tables  # noqa: F401  (open: the dataset, as in the docs)
from .schema import SCHEMA_VERSION, TABLES  # noqa: F401
from .writer import content_hash, done_hashes, table_path, write_capture  # noqa: F401
