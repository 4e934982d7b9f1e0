"""Rich report sections of the session tracker: ARs with their IOCR maps, record accesses,
the device profile chosen per station and why."""
from __future__ import annotations

import json
import os

from .textsafe import text

with open(os.path.join(os.path.dirname(__file__), "data", "labels.json"), encoding="utf-8") as _f:
    LABELS = json.load(_f)

MAX_RECORD_LINES = 200


def _hex(v, width=4) -> str:
    return "" if v is None else f"0x{v:0{width}x}"


def _short(dec) -> str:
    """One line of a decoded record for the table, in words where the data tables have them."""
    if not isinstance(dec, dict):
        return ""
    if dec.get("index") in (0xBF00, 0xFFFF) and ("flags" in dec or "mupr" in dec):
        return _words(dec, LABELS["bf00"])
    skip = {"index", "index_name", "data", "problems", "notes", "block_type", "block_length", "block_version_high",
            "block_version_low"}
    parts = []
    for k, v in dec.items():
        if k in skip or k.endswith("_name") or isinstance(v, (dict, list)) or v is None:
            continue
        name = dec.get(f"{k}_name")
        parts.append(f"{k.replace('_', ' ')} {name} ({v})" if name is not None else f"{k.replace('_', ' ')} {v}")
        if len(parts) == 6:
            break
    return " · ".join(parts)


def _words(dec: dict, labels) -> str:
    """Each field's meaning and value in words: 'Class 4 functionality enabled · velocity unit steps/s'."""
    words = LABELS["words"]
    parts = []
    for key, label, kind in labels:
        if key not in dec or dec[key] is None:
            continue
        v = dec[key]
        name = dec.get(f"{key}_name")
        if kind in words and v in (0, 1, True, False):
            parts.append(f"{label} {words[kind][int(v)]}")
        elif name is not None:
            parts.append(f"{label} {name}")
        else:
            parts.append(f"{label} {v}")
    for p in dec.get("problems") or ():
        parts.append(f"problem: {p.get('message', p)}")
    return " · ".join(parts)


def param_line(req: dict | None, rsp: dict | None) -> str:
    """A PROFIdrive parameter access in words: 'P922 Telegram selection · read · 81 (ok)'."""
    rq = (req or {}).get("params") or []
    rs = (rsp or {}).get("params") or []
    op = (req or {}).get("request_id_name") or ""
    verb = "write" if "change" in op else "read" if "request" in op else op or "?"
    out = []
    for i in range(max(len(rq), len(rs))):
        q = rq[i] if i < len(rq) else {}
        r = rs[i] if i < len(rs) else {}
        pnu = q.get("pnu")
        head = f"P{pnu}" + (f"[{q['subindex']}]" if q.get("subindex") else "") if pnu is not None else "P?"
        if q.get("name"):
            head += f" {q['name']}"
        vals = q.get("values") if verb == "write" else r.get("values")
        val = ", ".join(str(x) for x in (vals or [])[:8]) + (" …" if vals and len(vals) > 8 else "")
        if rsp is None:
            status = "no response"
        elif r.get("error") is not None:
            err = r["error"]
            status = f"error {err.get('text') or err.get('code')}" if isinstance(err, dict) else f"error {err}"
        else:
            status = "ok" if rsp.get("ok", True) else "refused"
        out.append(f"{head} · {verb}" + (f" · {val}" if val else "") + f" ({status})")
    return "; ".join(out)


def _param_rows(rows: list[dict]) -> dict[int, str]:
    """Frame -> words for the PROFIdrive parameter records (0xB02E/0xB02F): a response is read
    together with the request it answers (same device and request reference)."""
    last_req: dict[tuple, dict] = {}
    out = {}
    for r in rows:
        dec = r.get("decoded")
        if not isinstance(dec, dict) or dec.get("kind") not in ("parameter request", "parameter response"):
            continue
        key = (r.get("device_mac"), dec.get("request_ref"))
        if dec["kind"] == "parameter request":
            last_req[key] = dec
            out[r["frame"]] = "request: " + param_line(dec, None).replace(" (no response)", "")
        else:
            out[r["frame"]] = param_line(last_req.pop(key, None), dec)
    return out


def encoder_views(tracker) -> dict[tuple, dict]:
    """(device MAC, slot, subslot) -> the cyclic encoder's summary: one telegram source and one
    profile reason for every table (the checker's, which is what was judged)."""
    summary = getattr(getattr(tracker.a, "cyclic", None), "summary", None)
    if not callable(summary):  # a session tracker on its own (tests): its own view
        return {}
    return {(e.get("device_mac"), e.get("slot"), e.get("subslot")): e for e in summary().get("encoders", [])}


def telegram_source(e: dict) -> str:
    s = (e.get("settings") or {}).get("telegram")
    return str(s.get("source")) if isinstance(s, dict) and s.get("source") else str(e.get("telegram_source"))


def profile_reason(e: dict) -> str:
    s = (e.get("settings") or {}).get("profile")
    return str(s.get("source")) if isinstance(s, dict) and s.get("source") else str(e.get("profile_reason"))


def sections(tracker) -> list:
    from rich.table import Table   # the renderer only for a terminal report (-q prints one plain line)

    from .report import row
    out = []
    encs = encoder_views(tracker)
    refused = [ar for ar in tracker.ar_list if not ar["ok"]]
    for ar in tracker.ar_list:
        if not ar["ok"]:
            continue
        state = " -> ".join(f"{p['phase']} ({p['frame']}"
                            + (f": {ar['abort_cause']}" if p["phase"] == "aborted" and ar.get("abort_cause") else "") + ")"
                            for p in ar.get("phases", ())) or \
            ("released" if ar["released"] else "up")   # AR phases with their first frames (session.set_phase)
        t = Table(title=f"AR {ar['ar_uuid']} ({ar['ar_type_name']}) — {state}\n"
                        f"controller {ar['controller_mac']} {ar.get('controller_station') or ''} -> "
                        f"device {ar['device_mac']} {ar.get('station') or ''} "
                        f"(Connect frames {ar['request_frame']}/{ar['frame']})")
        for c in ("frame ID", "dir", "C_SDU", "cycle", "api", "slot/sub", "offset", "len", "IOPS",
                  "module / submodule ident", "telegram (source)"):
            t.add_column(c)
        objs = {(fm.frame_id, do.api, do.slot, do.subslot): do for fm in ar["maps"] for do in fm.objects}
        for cr in ar["iocrs"]:
            cyc = ""
            if cr["send_clock_factor"] and cr["reduction_ratio"]:
                cyc = f"{cr['send_clock_factor'] * cr['reduction_ratio'] * 31.25 / 1000:g} ms"
            first = True
            for o in cr["objects"] or [{}]:
                do = objs.get((cr["frame_id"], o.get("api"), o.get("slot"), o.get("subslot")))
                tel, src = (do.telegram, do.telegram_source) if do is not None else (o.get("telegram"),
                                                                                      o.get("telegram_source"))
                enc = encs.get((ar["device_mac"], o.get("slot"), o.get("subslot"))) if o else None
                if enc is not None and enc.get("telegram") == tel:
                    src = telegram_source(enc)
                row(t, _hex(cr["frame_id"]) if first else "", cr["direction"] if first else "",
                          str(cr["data_length"]) if first else "", cyc if first else "",
                          _hex(o.get("api"), 1) if o else "",
                          f"{o['slot']}/{_hex(o['subslot'])}" if o else "",
                          str(o.get("offset", "")), str(o.get("length", "")), str(o.get("iops_len", "")),
                          f"{_hex(o.get('module_ident'), 8)} / {_hex(o.get('submodule_ident'), 8)}" if o else "",
                          f"{tel} ({src})" if tel is not None else "")
                first = False
        out.append(t)
    if refused:
        t = Table(title=f"Refused Connects ({len(refused)})")
        for c in ("frames", "AR UUID", "controller", "device", "station", "PNIO status"):
            t.add_column(c)
        for ar in refused:
            row(t, f"{ar['request_frame']}/{ar['frame']}", ar["ar_uuid"],
                      f"{ar['controller_mac']} {ar.get('controller_station') or ''}", ar["device_mac"],
                      ar.get("station") or "", ar["status"]["text"])
        out.append(t)
    if tracker.record_rows:
        params = _param_rows(tracker.record_rows)
        t = Table(title=f"Record accesses ({min(len(tracker.record_rows), MAX_RECORD_LINES)} shown)")
        for c in ("frame", "op", "station", "slot/sub", "index"):
            t.add_column(c, no_wrap=c in ("frame", "op"))
        t.add_column("content", ratio=3)
        t.add_column("result", ratio=1)
        for r in tracker.record_rows[:MAX_RECORD_LINES]:
            content = params.get(r["frame"]) or _short(r.get("decoded")) or ", ".join(r.get("blocks", ()))
            row(t, str(r["frame"]), r["op"], r["station"] or r["device_mac"] or "",
                f"{r['slot']}/{_hex(r['subslot'])}", f"{_hex(r['index'])} {r['index_name']}",
                text(content, 600), r.get("result") or "")
        out.append(t)
    if tracker.profiles:
        t = Table(title="Device profile per station")
        for c in ("device", "station", "profile", "why"):
            t.add_column(c)
        by_dev = {mac: e for (mac, _s, _ss), e in encs.items()}
        for mac, (p, why) in sorted(tracker.profiles.items(), key=lambda kv: str(kv[0])):
            e = by_dev.get(mac)
            if e is not None:  # the profile the encoder was judged with, and its reason
                p, why = e.get("profile", p), profile_reason(e)
            row(t, str(mac), tracker.station_name(mac) or "", p, why)
        out.append(t)
    return out
