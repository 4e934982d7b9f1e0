"""Foxglove (issue #16 item 7): one topic root, unique schema names, a layout file per export.

The layout's every message path must name a topic of the exported file and a signal its channel's
schema declares; every telegram axis gets its panels; the Log panel shows the violations topic.
"""
from __future__ import annotations

import json
import os
import re

from hypothesis import HealthCheck, given, settings as hsettings, strategies as st
from mcap.reader import make_reader

from pndiss.cli import main as cli_main
from pndiss.foxglove_layout import build
from pndiss.mcap_export import McapExporter
from pndiss.mcap_topics import VIOLATIONS_TOPIC
from pndiss.settings import Settings
from test_mcap import DEV, _event, read_back, rt, tg

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CAPS = [os.path.join(ROOT, "captures", n) for n in (
    "motion-t83-generic.pcapng", "startup-t81-generic-3enc.pcapng", "fault-preset-ack-missing.pcapng")]
# Foxglove's message path: a topic of [a-zA-Z0-9_/-] or quoted, then .field parts ([a-zA-Z0-9_-] or quoted)
_Q = r'"(?:[^"\\]|\\.)*"'
PATH = re.compile(rf'^({_Q}|[a-zA-Z0-9_/-]+)\.(signals|bits)\.({_Q}|[a-zA-Z0-9_-]+)$')


def unquote(s):
    return re.sub(r"\\(.)", r"\1", s[1:-1]) if s.startswith('"') else s


def _summary(path):
    with open(path, "rb") as f:
        s = make_reader(f).get_summary()
    chans = {c.topic: c for c in s.channels.values()}
    return chans, s.schemas


def test_layout_names_exported_topics(tmp_path):
    for cap in CAPS:
        out, lay = str(tmp_path / "x.mcap"), str(tmp_path / "x.json")
        assert cli_main(["export", cap, "-o", out, "--layout", lay, "-q"]) == 0
        layout = json.load(open(lay, encoding="utf-8"))
        chans, schemas = _summary(out)
        cfg = layout["configById"]
        # the tree holds exactly the configured panels
        ids = []

        def walk(node):
            if isinstance(node, str):
                ids.append(node)
            else:
                assert node["direction"] in ("row", "column") and 0 < node["splitPercentage"] < 100
                walk(node["first"])
                walk(node["second"])
        walk(layout["layout"])
        assert sorted(ids) == sorted(cfg)
        seen_topics = set()
        for pid, c in cfg.items():
            for p in c.get("paths", []):
                m = PATH.match(p["value"])
                assert m, p["value"]
                topic, part, field = unquote(m.group(1)), m.group(2), unquote(m.group(3))
                assert topic in chans, (cap, topic)
                sch = json.loads(schemas[chans[topic].schema_id].data)
                assert field in sch["properties"][part]["properties"], (topic, field)
                seen_topics.add(topic)
        actual = {t for t, c in chans.items() if t.endswith("/actual")}
        assert actual and actual <= seen_topics          # every axis has its panels
        assert cfg["RosOut!violations"]["topicToRender"] == VIOLATIONS_TOPIC
        if VIOLATIONS_TOPIC in chans:
            assert schemas[chans[VIOLATIONS_TOPIC].schema_id].name == "foxglove.Log"
        if "motion" in cap:
            assert any(pid.startswith("Plot!speed") for pid in cfg)
        bits = [p["value"] for pid, c in cfg.items() if pid.startswith("StateTransitions") for p in c["paths"]]
        assert any('.bits."g1_zsw.' in b for b in bits) and any('.bits."g1_stw.' in b for b in bits)
        # one topic root
        assert all(t.startswith("/pn/") for t in chans), sorted(chans)


def test_layout_unwritable(tmp_path, capsys):
    cap = CAPS[0]
    assert cli_main(["export", cap, "-o", str(tmp_path / "x.mcap"), "--layout",
                     str(tmp_path / "no" / "dir.json"), "-q"]) == 2
    assert "cannot write" in capsys.readouterr().err


def test_schema_names_unique(tmp_path):
    """Two telegram 81 actual channels whose first messages carry different signals get two
    schemas: they have two names (the second with a suffix); equal schemas are shared."""
    out = str(tmp_path / "s.mcap")
    exp = McapExporter(out, None, Settings())
    exp.on_event(rt(1, 1_000, 1))
    exp.on_event(tg(1, 1_000, "actual", (1, 2)))
    exp.on_event(tg(2, 2_000, "actual", (1, 2), subslot=3))                       # same schema
    exp.on_event(tg(3, 3_000, "actual", (1, 2), subslot=4, signals={"G1_XIST1": 1}))  # another one
    exp.on_event({"frame": 4, "ts_ns": 4_000, "kind": "violation", "rule": "R", "side": "encoder",
                  "severity": "error", "message": "m", "device_mac": DEV})
    exp.close()
    counts, chans, _, problems = read_back(out)
    assert problems == []
    _, schemas = _summary(out)
    names = sorted(s.name for s in schemas.values())
    assert names.count("pndiss.Telegram81Actual") == 1 and "pndiss.Telegram81Actual_2" in names
    assert len(names) == len(set(names))
    for s in schemas.values():
        assert json.loads(s.data)["title"] == s.name
    assert VIOLATIONS_TOPIC in counts


@hsettings(max_examples=100, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(_event, max_size=12))
def test_layout_arbitrary_events(tmp_path, evs):
    """Whatever the events hold, the layout is built and every path parses as a message path."""
    out = str(tmp_path / "a.mcap")
    exp = McapExporter(out, None, Settings())
    for ev in evs:
        exp.on_event(ev)
    exp.close()
    layout = json.loads(json.dumps(build(exp.telegram_channels, VIOLATIONS_TOPIC)))
    for c in layout["configById"].values():
        for p in c.get("paths", []):
            m = PATH.match(p["value"])
            assert m and unquote(m.group(1)) in {ch["topic"] for ch in exp.telegram_channels}, p["value"]
