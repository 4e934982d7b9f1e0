"""Differential testing against tshark: run ``tshark -T ek`` and pndiss on one capture and
compare every mapped field of every frame (mapping files: tests/tshark_map/*.json).

A map file is ``{"kind": K, "fields": {PATH: TSHARK_FIELD}}``. PATH walks a pndiss event of kind
K: ``a.b`` for nested dicts, ``a[]`` iterates a list. For each frame and each tshark field, the
multiset of pndiss values (over all events of the mapped kinds, all paths that map to that field)
must equal the multiset of tshark's values. Frames where pndiss emitted no event of a kind that
maps to the field are not compared for it (they are counted by the accounting tests instead).
"""
from __future__ import annotations

import functools
import glob
import json
import os
import re
import shutil
import subprocess
from collections import Counter, defaultdict

HERE = os.path.dirname(__file__)
ROOT = os.path.dirname(HERE)
PUBLIC = os.path.join(ROOT, "..", "shared", "captures", "public")
OWN = os.path.join(ROOT, "captures")


def capture_files() -> list[str]:
    files = []
    for d in (PUBLIC, OWN):
        for ext in ("*.pcap", "*.pcapng"):
            files.extend(glob.glob(os.path.join(d, ext)))
    return sorted(files)


def load_maps() -> list[dict]:
    maps = []
    for p in sorted(glob.glob(os.path.join(HERE, "tshark_map", "*.json"))):
        with open(p) as f:
            m = json.load(f)
        m["file"] = os.path.basename(p)
        maps.append(m)
    return maps


_HEXCOLON = re.compile(r"(?:[0-9a-f]{2}:)+[0-9a-f]{2}")


def norm(v):
    """Canonical form shared by both sides: ints for numbers/booleans, plain strings else."""
    if isinstance(v, bool):
        return int(v)
    if isinstance(v, int):
        return v
    if isinstance(v, float):
        return v
    if v is None:
        return None
    s = str(v).strip()
    if s in ("true", "false", "True", "False"):
        return int(s.lower() == "true")
    try:
        return int(s, 0)
    except ValueError:
        pass
    if re.fullmatch(r"[0-9]+", s):  # leading zeros: int(.., 0) refuses them
        return int(s, 10)
    low = s.lower()
    if _HEXCOLON.fullmatch(low):
        return low.replace(":", "")
    return s


def need_tshark() -> str:
    t = shutil.which("tshark")
    if t is None:
        import pytest
        if os.environ.get("CI"):
            pytest.fail("tshark is required in CI (install it: apt-get install -y tshark)")
        pytest.skip("tshark not installed")
    return t


@functools.lru_cache(maxsize=64)
def tshark_ek(path: str, extra: tuple = ()) -> dict[int, dict[str, list]]:
    """{frame number: {tshark field with '_' for '.': [values]}} from ``tshark -T ek``."""
    out = subprocess.run([need_tshark(), "-n", "-r", path, "-T", "ek", *extra],
                         capture_output=True, text=True, check=True).stdout
    frames: dict[int, dict[str, list]] = {}
    for line in out.splitlines():
        if not line.startswith('{"timestamp"'):
            continue
        layers = json.loads(line)["layers"]
        fn = int(layers["frame"]["frame_frame_number"])
        fields: dict[str, list] = defaultdict(list)
        for lname, body in layers.items():
            for d in body if isinstance(body, list) else [body]:
                if not isinstance(d, dict):
                    continue
                for k, v in d.items():
                    name = k[len(lname) + 1:] if k.startswith(lname + "_") else k
                    fields[name].extend(v if isinstance(v, list) else [v])
        frames[fn] = fields
    return frames


def walk(ev, path: str) -> list:
    vals = [ev]
    for part in path.split("."):
        nxt = []
        many = part.endswith("[]")
        key = part[:-2] if many else part
        for v in vals:
            if not isinstance(v, dict) or key not in v or v[key] is None:
                continue
            x = v[key]
            if many:
                nxt.extend(x if isinstance(x, list) else [x])
            else:
                nxt.append(x)
        vals = nxt
    out = []
    for v in vals:
        out.extend(v if isinstance(v, list) else [v])
    return out


def pndiss_events(path: str) -> dict[int, list[dict]]:
    from pndiss.analyzer import analyze_file

    per_frame: dict[int, list[dict]] = defaultdict(list)
    analyze_file(path, sink=lambda ev: per_frame[ev["frame"]].append(ev))
    return per_frame


def compare(path: str, maps: list[dict]) -> tuple[int, list[str]]:
    """(values compared, mismatch descriptions) for one capture."""
    ts = tshark_ek(path)
    ours = pndiss_events(path)
    by_field: dict[str, list[tuple[str, str]]] = defaultdict(list)  # tshark field -> [(kind, path)]
    for m in maps:
        for p, tf in m["fields"].items():
            by_field[tf].append((m["kind"], p))
    compared = 0
    diffs: list[str] = []
    for fn, events in sorted(ours.items()):
        kinds = {e["kind"] for e in events}
        tframe = ts.get(fn, {})
        for tf, paths in by_field.items():
            if not any(k in kinds for k, _ in paths):
                continue
            mine = Counter()
            for k, p in paths:
                for e in events:
                    if e["kind"] == k:
                        for v in walk(e, p):
                            mine[norm(v)] += 1
            theirs = Counter(norm(v) for v in tframe.get(tf.replace(".", "_"), []) if v is not None)
            compared += sum(theirs.values())
            if mine != theirs:
                diffs.append(f"{os.path.basename(path)} frame {fn} {tf}: pndiss {sorted(mine.elements(), key=str)[:8]} "
                             f"tshark {sorted(theirs.elements(), key=str)[:8]}")
    return compared, diffs
