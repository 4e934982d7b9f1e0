"""docs/dataset.md: its tables section is the schema (tools/gen_dataset_doc.py), and its pandas and
Polars snippets run on a real dataset and agree with DuckDB."""
from __future__ import annotations

import os
import re
import sys

import pytest

pytest.importorskip("pyarrow")
pytest.importorskip("duckdb")

from pndiss import dataset  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DOC = os.path.join(ROOT, "docs", "dataset.md")
sys.path.insert(0, os.path.join(ROOT, "tools"))


def snippet(lang: str) -> str:
    blocks = re.findall(r"```python\n(.*?)```", open(DOC, encoding="utf-8").read(), re.S)
    found = [b for b in blocks if b.startswith(f"# {lang}")]
    assert len(found) == 1, lang
    return found[0]


def test_doc_tables_are_current():
    import gen_dataset_doc
    text = open(DOC, encoding="utf-8").read()
    assert gen_dataset_doc.render(text) == text, "docs/dataset.md is stale: run python3 tools/gen_dataset_doc.py"


@pytest.fixture(scope="module")
def ds(tmp_path_factory):
    d = str(tmp_path_factory.mktemp("doc") / "ds")
    for name in ("fault-preset-ack-missing", "sensor-error-t81-lika", "fault-dcp-name-duplicate"):
        dataset.write_capture(os.path.join(ROOT, "captures", name + ".pcapng"), d)
    # a write in progress (temporary name) must not be read by any of them
    open(os.path.join(d, "violations", ".deadbeef.1.tmp"), "wb").write(b"PAR1 half written")
    return d


def duck_counts(d):
    rows = dataset.open(d).execute("SELECT station, rule, count(*) FROM violations GROUP BY ALL").fetchall()
    return {(s, r): n for s, r, n in rows}


@pytest.mark.parametrize("lang", ["pandas", "polars"])
def test_snippet_runs(ds, lang):
    pytest.importorskip(lang)
    ns = {"DATASET": ds}
    exec(compile(snippet(lang), f"docs/dataset.md ({lang})", "exec"), ns)
    got = ns["by_station_rule"]
    if lang == "polars":
        got = got.to_pandas()
    # a violation without a station (DCP-NAME-DUPLICATE names MACs) is counted too: NaN/None alike
    got = {(r.station if isinstance(r.station, str) else None, r.rule): r.n for r in got.itertuples()}
    assert got == duck_counts(ds) and (None, "DCP-NAME-DUPLICATE") in got
    if lang == "pandas":
        assert ns["sensor_errors"]["g1_zsw.sensor_error"].max() == 1
    else:
        assert set(ns["firmware"]["bug_fix"].to_list()) == {"0"}
