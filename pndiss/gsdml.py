"""Read module/submodule identifiers and their telegram from GSDML files (``--gsdml FILE``).

GSDML (ISO 15745 profile, PI GSDML spec; structure as summarised in shared/gsdml/README.md §3):
``ModuleItem``/``DeviceAccessPointItem`` carry ``ModuleIdentNumber``; their
``VirtualSubmoduleItem``s and the ``SubmoduleList/SubmoduleItem``s carry ``SubmoduleIdentNumber``,
``API`` and ``IOData`` (``Input``/``Output`` ``DataItem``s whose ``DataType`` gives the size).
The telegram number is taken from the submodule's (else module's) name text, e.g. "Standard
telegram 81" (no GSDML attribute names it; the Siemens files name it only in the text).
"""
from __future__ import annotations

import re
import xml.etree.ElementTree as ET

# DataItem sizes in bytes (GSDML DataType names)
DATA_TYPE_SIZE = {"Integer8": 1, "Unsigned8": 1, "Integer16": 2, "Unsigned16": 2, "Integer32": 4,
                  "Unsigned32": 4, "Integer64": 8, "Unsigned64": 8, "Float32": 4, "Float64": 8,
                  "Unsigned8+Unsigned8": 2, "Float32+Unsigned8": 5, "Float32+Status8": 5,
                  "OctetString_S": 1, "N2": 2, "N4": 4, "V2": 2, "E2": 2, "C4": 4, "X2": 2, "X4": 4}
_TELEGRAM = re.compile(r"telegra(?:m|mm)\s*(\d{1,4})", re.I)


class GsdmlError(ValueError):
    pass


def _local(tag: str) -> str:
    return tag.rsplit("}", 1)[-1]


def _num(v: str | None) -> int | None:
    if v is None:
        return None
    try:
        return int(v, 0)
    except ValueError:
        return None


def _children(el, name):
    return [c for c in el if _local(c.tag) == name]


def _find_all(el, name):
    return [c for c in el.iter() if _local(c.tag) == name]


def _io_len(sub, direction: str) -> int | None:
    for io in _find_all(sub, "IOData"):
        for part in _children(io, direction):
            total = 0
            for di in _children(part, "DataItem"):
                dt = di.get("DataType", "")
                if dt == "OctetString" or dt.startswith("VisibleString"):
                    total += _num(di.get("Length")) or 0
                else:
                    total += DATA_TYPE_SIZE.get(dt, 0)
            return total
        return 0
    return None


def parse(path: str) -> dict:
    """{"vendor_id", "device_id", "modules": [{ident, id, name, telegram}], "submodules": [{ident,
    id, api, name, telegram, input_length, output_length, module_ident}]}."""
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as e:
        raise GsdmlError(f"{path}: {e}") from None
    texts = {}
    for t in _find_all(root, "Text"):
        if t.get("TextId") is not None and t.get("TextId") not in texts:
            texts[t.get("TextId")] = t.get("Value", "")

    def name_of(el) -> str | None:
        for mi in _children(el, "ModuleInfo"):
            for n in _children(mi, "Name"):
                return texts.get(n.get("TextId"), n.get("TextId"))
        return None

    def telegram(*names) -> int | None:
        for n in names:
            m = _TELEGRAM.search(n or "")
            if m:
                return int(m.group(1))
        return None

    ident = next(iter(_find_all(root, "DeviceIdentity")), None)
    out = {"path": path, "vendor_id": _num(ident.get("VendorID")) if ident is not None else None,
           "device_id": _num(ident.get("DeviceID")) if ident is not None else None,
           "modules": [], "submodules": []}
    seen = set()

    def add_sub(sub, mod_ident, mod_name):
        key = (mod_ident, sub.get("ID"), sub.get("SubmoduleIdentNumber"))
        if key in seen:
            return
        seen.add(key)
        n = name_of(sub)
        out["submodules"].append({
            "id": sub.get("ID"), "ident": _num(sub.get("SubmoduleIdentNumber")),
            "api": _num(sub.get("API", "0")) or 0, "name": n, "module_ident": mod_ident,
            "telegram": telegram(n, mod_name),
            "input_length": _io_len(sub, "Input"), "output_length": _io_len(sub, "Output")})

    for tag in ("DeviceAccessPointItem", "ModuleItem"):
        for m in _find_all(root, tag):
            mi, mn = _num(m.get("ModuleIdentNumber")), name_of(m)
            out["modules"].append({"id": m.get("ID"), "ident": mi, "name": mn, "telegram": telegram(mn)})
            for vs in _find_all(m, "VirtualSubmoduleItem"):
                add_sub(vs, mi, mn)
    for s in _find_all(root, "SubmoduleItem"):
        add_sub(s, None, None)
    return out


class GsdmlIndex:
    """(module ident, submodule ident) -> telegram over one or more GSDML files."""

    def __init__(self, paths: list[str]):
        self.files = [parse(p) for p in paths]
        self.by_pair: dict[tuple, int] = {}
        self.by_sub: dict[int, set] = {}
        for f in self.files:
            for s in f["submodules"]:
                if s["telegram"] is None or s["ident"] is None:
                    continue
                if s["module_ident"] is not None:
                    self.by_pair[(s["module_ident"], s["ident"])] = s["telegram"]
                self.by_sub.setdefault(s["ident"], set()).add(s["telegram"])

    def telegram_for(self, module_ident: int | None, submodule_ident: int) -> int | None:
        t = self.by_pair.get((module_ident, submodule_ident))
        if t is not None:
            return t
        ts = self.by_sub.get(submodule_ident)
        return next(iter(ts)) if ts and len(ts) == 1 else None  # ambiguous across files: no answer
