"""The ``--map FILE`` user map: which telegram sits where, when the capture has no Connect (or
to override what the Connect, P922, GSDML or the length guess say). Format: docs/map.md.

Two kinds of entries:
- ``frames``: a cyclic frame ID (optionally with source/destination MAC) and its data objects
  (slot, subslot, offset, length, telegram) -> a FrameMap for captures that start mid-session;
- ``submodules``: (device MAC or station, api, slot, subslot) -> telegram, applied to
  Connect-derived maps too.
JSON, TOML (same structure) or CSV (one row per data object / submodule) are accepted.
"""
from __future__ import annotations

import csv
import json
import tomllib

from .armap import DataObject, FrameMap

DIRECTIONS = ("input", "output")


class MapError(ValueError):
    """The map file is unusable; the message names the file and the entry."""


def _int(v, what: str, path: str) -> int:
    if isinstance(v, bool):
        raise MapError(f"{path}: {what} must be a number, got {v!r}")
    if isinstance(v, int):
        return v
    try:
        return int(str(v).strip(), 0)
    except ValueError:
        raise MapError(f"{path}: {what} must be a number (decimal or 0x...), got {v!r}") from None


def _mac(v, path: str) -> str | None:
    if v in (None, ""):
        return None
    m = str(v).strip().lower().replace("-", ":")
    parts = m.split(":")
    if len(parts) != 6 or not all(len(p) == 2 and all(c in "0123456789abcdef" for c in p) for p in parts):
        raise MapError(f"{path}: {v!r} is not a MAC address (aa:bb:cc:dd:ee:ff)")
    return m


def _telegram_lengths(t: int) -> tuple[int, int] | None:
    """(setpoint, actual) bytes of telegram ``t`` from pndiss/data/telegrams.json, if known."""
    from . import telegrams as tg
    d = tg.TELEGRAMS.get(t)
    if d is None:
        return None
    return tuple(sum(tg.SIGNALS[n]["size"] for n, _ in d[k]) for k in ("setpoint", "actual"))


class UserMap:
    def __init__(self, frames: list[dict], submodules: list[dict], path: str = "<map>"):
        self.path = path
        self.frames: list[dict] = []
        for i, f in enumerate(frames):
            self.frames.append(self._frame(f, f"{path}: frames[{i}]"))
        self.submodules = [self._sub(s, f"{path}: submodules[{i}]") for i, s in enumerate(submodules)]

    def _frame(self, f: dict, where: str) -> dict:
        if "frame_id" not in f:
            raise MapError(f"{where}: frame_id missing")
        direction = str(f.get("direction", "input")).lower()
        if direction not in DIRECTIONS:
            raise MapError(f"{where}: direction must be input or output, got {direction!r}")
        objs = []
        for j, o in enumerate(f.get("objects", [])):
            w = f"{where}.objects[{j}]"
            tel = _int(o["telegram"], "telegram", w) if o.get("telegram") not in (None, "") else None
            if o.get("length") not in (None, ""):
                length = _int(o["length"], "length", w)
            elif tel is not None and _telegram_lengths(tel):
                length = _telegram_lengths(tel)[1 if direction == "input" else 0]
            else:
                raise MapError(f"{w}: give a length or a known telegram")
            for k in ("slot", "subslot"):
                if k not in o:
                    raise MapError(f"{w}: {k} missing")
            objs.append({"api": _int(o.get("api", 0), "api", w), "slot": _int(o["slot"], "slot", w),
                         "subslot": _int(o["subslot"], "subslot", w),
                         "offset": _int(o.get("offset", 0), "offset", w), "length": length,
                         "iops_len": _int(o.get("iops_len", 1), "iops_len", w), "telegram": tel})
        return {"frame_id": _int(f["frame_id"], "frame_id", where), "src": _mac(f.get("src"), where),
                "dst": _mac(f.get("dst"), where), "direction": direction, "station": f.get("station"),
                "objects": objs}

    def _sub(self, s: dict, where: str) -> dict:
        for k in ("slot", "subslot", "telegram"):
            if s.get(k) in (None, ""):
                raise MapError(f"{where}: {k} missing")
        return {"device_mac": _mac(s.get("device_mac"), where), "station": s.get("station") or None,
                "api": _int(s["api"], "api", where) if s.get("api") not in (None, "") else None,
                "slot": _int(s["slot"], "slot", where), "subslot": _int(s["subslot"], "subslot", where),
                "telegram": _int(s["telegram"], "telegram", where)}

    # -- queries ---------------------------------------------------------------------------
    def telegram_for(self, device_mac, station, api, slot, subslot) -> int | None:
        for s in self.submodules:
            if (s["slot"], s["subslot"]) != (slot, subslot) or s["api"] not in (None, api):
                continue
            if s["device_mac"] not in (None, device_mac) or s["station"] not in (None, station):
                continue
            return s["telegram"]
        for f in self.frames:  # a frame entry names telegrams too
            dev = f["src"] if f["direction"] == "input" else f["dst"]
            if f["station"] not in (None, station) or dev not in (None, device_mac):
                continue
            for o in f["objects"]:
                if (o["api"], o["slot"], o["subslot"]) == (api, slot, subslot) and o["telegram"] is not None:
                    return o["telegram"]
        return None

    def frame_map(self, frame_id: int, src: str, dst: str) -> FrameMap | None:
        """A FrameMap for a frame the Connect did not describe (most specific entry wins)."""
        best = None
        for f in self.frames:
            if f["frame_id"] != frame_id or f["src"] not in (None, src) or f["dst"] not in (None, dst):
                continue
            score = (f["src"] is not None) + (f["dst"] is not None)
            if best is None or score > best[0]:
                best = (score, f)
        if best is None:
            return None
        f = best[1]
        inp = f["direction"] == "input"
        fm = FrameMap(frame_id=frame_id, direction=f["direction"], controller_mac=dst if inp else src,
                      device_mac=src if inp else dst, station=f["station"], source="map")
        for o in f["objects"]:
            fm.objects.append(DataObject(api=o["api"], slot=o["slot"], subslot=o["subslot"], offset=o["offset"],
                                         length=o["length"], iops_len=o["iops_len"], telegram=o["telegram"],
                                         telegram_source="map" if o["telegram"] is not None else None))
        return fm


CSV_COLUMNS = ("frame_id", "src", "dst", "direction", "station", "device_mac", "api", "slot", "subslot",
               "offset", "length", "iops_len", "telegram")


def _from_csv(text: str, path: str) -> UserMap:
    rows = list(csv.DictReader(line for line in text.splitlines() if not line.lstrip().startswith("#")))
    frames: dict[tuple, dict] = {}
    subs = []
    for i, r in enumerate(rows):
        r = {k.strip(): (v or "").strip() for k, v in r.items() if k}
        unknown = set(r) - set(CSV_COLUMNS)
        if unknown:
            raise MapError(f"{path}: row {i + 2}: unknown column(s) {', '.join(sorted(unknown))}")
        if r.get("frame_id"):
            k = (r["frame_id"], r.get("src", ""), r.get("dst", ""), r.get("direction") or "input")
            f = frames.setdefault(k, {"frame_id": r["frame_id"], "src": r.get("src"), "dst": r.get("dst"),
                                      "direction": r.get("direction") or "input",
                                      "station": r.get("station") or None, "objects": []})
            f["objects"].append({c: r[c] for c in ("api", "slot", "subslot", "offset", "length", "iops_len",
                                                   "telegram") if r.get(c)})
        else:
            subs.append({c: r.get(c) for c in ("device_mac", "station", "api", "slot", "subslot", "telegram")})
    return UserMap(list(frames.values()), subs, path)


def load_map(path: str) -> UserMap:
    """Read a map file; the format follows the extension (.json, .toml, .csv)."""
    with open(path, "rb") as f:
        raw = f.read()
    try:
        if path.endswith(".csv"):
            return _from_csv(raw.decode("utf-8"), path)
        data = tomllib.loads(raw.decode("utf-8")) if path.endswith(".toml") else json.loads(raw)
    except (ValueError, UnicodeDecodeError) as e:
        if isinstance(e, MapError):
            raise
        raise MapError(f"{path}: {e}") from None
    if not isinstance(data, dict):
        raise MapError(f"{path}: the top level must be an object with 'frames' and/or 'submodules'")
    unknown = set(data) - {"frames", "submodules", "about"}
    if unknown:
        raise MapError(f"{path}: unknown key(s) {', '.join(sorted(unknown))}")
    return UserMap(data.get("frames", []), data.get("submodules", []), path)
