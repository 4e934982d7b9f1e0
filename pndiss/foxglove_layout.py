"""A Foxglove layout for an exported MCAP (`pndiss export --layout FILE`, docs/mcap.md).

Built from the telegram channels the export made: per axis (station, slot.subslot) a position
plot, a speed plot (when the telegram has a speed signal) and a State Transitions panel of the
control and status bits; below them the violations in a Log panel. The file is Foxglove's
layout JSON (Layouts > Import from file): ``configById`` (panel type!id -> config) and a
``layout`` tree of row/column splits.

Foxglove's message paths take topic names of ``[a-zA-Z0-9_/-]`` and field names of
``[a-zA-Z0-9_-]`` as they are, anything else in double quotes (a backslash before ``"`` and
``\\``): our topics hold ``1.2`` and the bit keys a dot (``bits."g1_zsw.sensor_error"``).
"""
from __future__ import annotations

import json
import re

POSITION = ("g1_xist1", "g1_xist2")
SPEED = ("nist_b", "nist_a")
MULTI_BIT = ("sign_of_life",)   # counters, not on/off lanes (pndiss plot leaves them out too)


def quote(name: str, topic: bool = False) -> str:
    """A topic or field name as Foxglove's message path grammar reads it."""
    if re.fullmatch(r"[a-zA-Z0-9_/-]+" if topic else r"[a-zA-Z0-9_-]+", name):
        return name
    return '"' + re.sub(r'([\\"])', r"\\\1", name) + '"'


def _path(topic: str, part: str, field: str, label: str) -> dict:
    return {"value": f"{quote(topic, True)}.{part}.{quote(field)}", "enabled": True,
            "timestampMethod": "receiveTime", "label": label}


def _split(items: list, direction: str):
    """Equal splits of items along direction (Foxglove's binary mosaic tree)."""
    if len(items) == 1:
        return items[0]
    return {"first": items[0], "second": _split(items[1:], direction), "direction": direction,
            "splitPercentage": round(100 / len(items), 3)}


def build(telegram_channels: list[dict], violations_topic: str) -> dict:
    """telegram_channels: dicts with topic, station, slot, subslot, telegram, side ('setpoint' or
    'actual') and signals (names); violations_topic: the foxglove.Log topic."""
    axes: dict[tuple, dict] = {}
    for ch in telegram_channels:
        key = (str(ch.get("station")), ch.get("slot"), ch.get("subslot"))
        axes.setdefault(key, {})[ch["side"]] = ch
    config: dict[str, dict] = {}
    rows = []
    for n, ((station, slot, sub), sides) in enumerate(axes.items(), 1):
        name = f"{station} {slot}.{sub}"
        act, sp = sides.get("actual"), sides.get("setpoint")
        panels = []
        if act is not None:
            pos = [f for f in POSITION if f in act["signals"]][:1]
            if pos:
                pid = f"Plot!pos{n}"
                config[pid] = {"foxglovePanelTitle": f"{name}: position", "paths": [
                    _path(act["topic"], "signals", f, f) for f in pos], "showLegend": True, "isSynced": True,
                    "xAxisVal": "timestamp"}
                panels.append(pid)
            spd = [f for f in SPEED if f in act["signals"]]
            if spd:
                pid = f"Plot!speed{n}"
                config[pid] = {"foxglovePanelTitle": f"{name}: speed", "paths": [
                    _path(act["topic"], "signals", f, f) for f in spd], "showLegend": True, "isSynced": True,
                    "xAxisVal": "timestamp"}
                panels.append(pid)
        bits = [(ch, b) for ch in (sp, act) if ch is not None for b in ch.get("bits", ())
                if not b.endswith(MULTI_BIT)]
        if bits:
            pid = f"StateTransitions!bits{n}"
            config[pid] = {"foxglovePanelTitle": f"{name}: control (setpoint) / status (actual) bits",
                           "paths": [_path(ch["topic"], "bits", b, b) for ch, b in bits],
                           "isSynced": True}
            panels.append(pid)
        if panels:
            rows.append(_split(panels, "row"))
    config["RosOut!violations"] = {"foxglovePanelTitle": "pndiss violations", "topicToRender": violations_topic,
                                   "searchTerms": [], "minLogLevel": 1}
    rows.append("RosOut!violations")
    return {"configById": config, "globalVariables": {}, "userNodes": {}, "linkedGlobalVariables": [],
            "playbackConfig": {"speed": 1}, "layout": _split(rows, "column")}


def write(path: str, telegram_channels: list[dict], violations_topic: str) -> None:
    with open(path, "w", encoding="utf-8") as f:
        json.dump(build(telegram_channels, violations_topic), f, indent=1)
        f.write("\n")
