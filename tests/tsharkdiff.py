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
    if len(s) == 3 and s[0] == s[2] == "'":  # FT_CHAR: ek prints 'V'
        return s[1]
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


@functools.lru_cache(maxsize=8)
def tshark_ek(path: str, extra: tuple = ()) -> dict[int, dict[str, list]]:
    """{frame number: {tshark field with '_' for '.': [values]}} from ``tshark -T ek``.

    Keys ek writes at the layer level (``pn_rt_pn_user_data``, ``dcerpc_dcerpc_fragments``: the
    "flat" keys of fields added outside a protocol subtree) are kept under their own name, so
    they are seen and compared like any other field.
    """
    out = subprocess.run([need_tshark(), "-n", "-r", path, "-T", "ek", *extra],
                         capture_output=True, text=True, check=True).stdout
    frames: dict[int, dict[str, list]] = {}
    layers_of: dict[int, dict[str, set]] = {}
    for line in out.splitlines():
        if not line.startswith('{"timestamp"'):
            continue
        layers = json.loads(line, object_pairs_hook=_keep_duplicates)["layers"]
        fn = int(layers["frame"]["frame_frame_number"])
        fields: dict[str, list] = defaultdict(list)
        owner: dict[str, set] = defaultdict(set)  # layer -> field names found in it
        for lname, body in layers.items():
            if not isinstance(body, (dict, list)) or (isinstance(body, list) and not any(
                    isinstance(d, dict) for d in body)):
                fields[lname].extend(body if isinstance(body, list) else [body])  # flat key
                owner[""].add(lname)
                continue
            for d in body if isinstance(body, list) else [body]:
                if not isinstance(d, dict):
                    continue
                for k, v in d.items():
                    name = k[len(lname) + 1:] if k.startswith(lname + "_") else k
                    fields[name].extend(v if isinstance(v, list) else [v])
                    owner[lname].add(name)
        frames[fn] = fields
        layers_of[fn] = owner
    _LAYERS[(path, extra)] = layers_of
    return frames


_LAYERS: dict[tuple, dict[int, dict[str, set]]] = {}

# tshark appends its AR summary ([ARUUID ... ContrMAC ... DevMAC ... InCR ... OutCR]) to the PNIO-CM
# layer as these last keys: values of its conversation state, not of the frame's bytes.
AR_SUMMARY = [f"pn_io_pn_io_{k}" for k in ("ar_uuid", "cminitiator_mac_add", "localalarmref",
                                            "cmresponder_macadd", "frame_id")]


# PNIO-CM and cyclic IO fields: one key per subtree (block), every group is data. Elsewhere (MRP, DCP)
# tshark adds some items twice in the same place; there the last group stands, as json.loads does.
DUPLICATES_KEPT = ("pn_io_",)


def _keep_duplicates(pairs: list) -> dict:
    """json object hook: ek writes a field found in several subtrees as repeated keys; keep every
    value of the PNIO fields (json.loads would keep the last group only). tshark's AR summary is
    dropped."""
    keys = [k for k, _ in pairs]
    for i in range(len(keys) - 5, -1, -1):  # the summary's five keys in a row (expert info may follow)
        if keys[i:i + 5] == AR_SUMMARY:
            pairs = pairs[:i] + pairs[i + 5:]
            break
    d: dict = {}
    for k, v in pairs:
        if k in d and k.startswith(DUPLICATES_KEPT):
            old = d[k]
            d[k] = (old if isinstance(old, list) else [old]) + (v if isinstance(v, list) else [v])
        else:
            d[k] = v
    return d


def ek_layers(path: str) -> dict[int, dict[str, set]]:
    """{frame: {layer (\"\" = flat keys): field names}} of the same ek run as tshark_ek(path)."""
    if (path, ()) not in _LAYERS:
        tshark_ek.cache_clear()
    tshark_ek(path)
    return _LAYERS[(path, ())]


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


def compare(path: str, maps: list[dict], compared_fields: set | None = None,
            skipped: dict | None = None) -> tuple[int, list[str]]:
    """(values compared, mismatch descriptions) for one capture; ``compared_fields`` collects the
    tshark fields (ek names) for which at least one frame was compared with values on tshark's side.

    A map with ``"requires": KEY`` compares only events that carry KEY (e.g. rt events with
    ``iodata``: cyclic frames of an AR pndiss has mapped); frames where tshark shows the field and
    no event qualifies are collected in ``skipped`` ({map file: {frame}}), never silently.
    """
    ts = tshark_ek(path)
    ours = pndiss_events(path)
    by_field: dict[str, list[tuple]] = defaultdict(list)  # tshark field -> [(kind, requires, path, map file)]
    for m in maps:
        for p, tf in m["fields"].items():
            by_field[tf].append((m["kind"], m.get("requires"), p, m["file"]))
    by_kind: dict[str, list[str]] = defaultdict(list)  # event kind -> tshark fields it may carry
    for tf, paths in by_field.items():
        for k in {k for k, _, _, _ in paths}:
            by_kind[k].append(tf)
    requires = {r for paths in by_field.values() for _, r, _, _ in paths if r is not None}
    compared = 0
    diffs: list[str] = []
    for fn, events in sorted(ours.items()):
        kinds = {e["kind"] for e in events}
        have = {(e["kind"], r) for e in events for r in requires if r in e}
        tframe = ts.get(fn, {})
        fields = {tf for k in kinds for tf in by_kind.get(k, ())}
        for tf in fields:
            paths = by_field[tf]
            usable = [(k, r, p) for k, r, p, _ in paths if k in kinds and (r is None or (k, r) in have)]
            key = tf.replace(".", "_")
            if not usable:
                if skipped is not None and any(v is not None for v in tframe.get(key, ())):
                    skipped.setdefault(paths[0][3], set()).add(fn)
                continue
            mine = Counter()
            for k, r, p in usable:
                for e in events:
                    if e["kind"] == k and (r is None or r in e):
                        for v in walk(e, p):
                            mine[norm(v)] += 1
            theirs = Counter(norm(v) for v in tframe.get(key, ()) if v is not None)
            compared += sum(theirs.values())
            if compared_fields is not None and (theirs or mine):
                compared_fields.add(key)
            if mine != theirs:
                diffs.append(f"{os.path.basename(path)} frame {fn} {tf}: pndiss {sorted(mine.elements(), key=str)[:8]} "
                             f"tshark {sorted(theirs.elements(), key=str)[:8]}")
    return compared, diffs


# --- coverage: which fields tshark emits on PROFINET frames, and which of them were compared -------
PN_LAYERS = frozenset({"pn_rt", "pn_dcp", "pn_io", "pn_io_device", "pn_io_controller", "pn_io_supervisor",
                       "pn_io_parameterserver", "pn_ptcp", "pn_mrp"})
PNIO_IF = ("dea00001", "dea00002", "dea00003", "dea00004")  # PNIO device/controller/supervisor/parameter server
COVERAGE_FILE = os.path.join(HERE, "tshark_coverage.json")


def load_coverage() -> dict:
    """{"excluded": {ek field: reason}, "open": {ek field: reason}} (tests/tshark_coverage.json)."""
    with open(COVERAGE_FILE) as f:
        return json.load(f)


def profinet_fields(path: str) -> tuple[set, set]:
    """(fields with a value, fields only ever without one) that tshark emits on the PROFINET frames
    of a capture: every field of the PN layers, the PROFINET TLVs of LLDP, DCE/RPC on the PNIO
    interfaces and the flat ek keys of those protocols. ek names (``.`` -> ``_``), as tshark_ek."""
    frames = tshark_ek(path)
    valued: set = set()
    named: set = set()
    for fn, owner in ek_layers(path).items():
        fields = frames[fn]
        pn = any(ln in PN_LAYERS for ln in owner)
        rpc = "dcerpc" in owner and any(str(v).lower().startswith(PNIO_IF)
                                        for v in fields.get("dcerpc_dg_if_id", ()))
        scope: set = set()
        for ln, names in owner.items():
            if ln in PN_LAYERS:
                scope |= names
            elif ln == "lldp":
                scope |= {n for n in names if "profinet" in n}
            elif ln == "dcerpc" and rpc:
                scope |= names
            elif ln == "" and (pn or rpc):
                scope |= {n for n in names if n.startswith(("pn_", "dcerpc_"))}
        for n in scope:
            named.add(n)
            if any(v is not None for v in fields.get(n, ())):
                valued.add(n)
    return valued, named - valued
