"""Rich report sections of the session tracker: ARs with their IOCR maps, record accesses,
the device profile chosen per station and why."""
from __future__ import annotations

from rich.table import Table

MAX_RECORD_LINES = 200


def _hex(v, width=4) -> str:
    return "" if v is None else f"0x{v:0{width}x}"


def _short(dec) -> str:
    """One line of a decoded record for the table."""
    if not isinstance(dec, dict):
        return ""
    skip = {"index", "index_name", "data", "problems"}
    parts = []
    for k, v in dec.items():
        if k in skip or isinstance(v, (dict, list)) or v is None:
            continue
        parts.append(f"{k}={v}")
        if len(parts) == 5:
            break
    if dec.get("params"):
        ps = dec["params"]
        parts.append("params " + ", ".join(f"P{p.get('pnu')}" for p in ps[:4]) + (" ..." if len(ps) > 4 else ""))
    return " ".join(parts)


def sections(tracker) -> list:
    out = []
    refused = [ar for ar in tracker.ar_list if not ar["ok"]]
    for ar in tracker.ar_list:
        if not ar["ok"]:
            continue
        state = " -> ".join(f"{p['phase']} ({p['frame']})" for p in ar.get("phases", ())) or \
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
                t.add_row(_hex(cr["frame_id"]) if first else "", cr["direction"] if first else "",
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
            t.add_row(f"{ar['request_frame']}/{ar['frame']}", ar["ar_uuid"],
                      f"{ar['controller_mac']} {ar.get('controller_station') or ''}", ar["device_mac"],
                      ar.get("station") or "", ar["status"]["text"])
        out.append(t)
    if tracker.record_rows:
        t = Table(title=f"Record accesses ({len(tracker.record_rows)} shown)")
        for c in ("frame", "time", "op", "station / device", "slot/sub", "index", "content", "result"):
            t.add_column(c)
        t0 = tracker.a.first_ts or 0
        for r in tracker.record_rows[:MAX_RECORD_LINES]:
            t.add_row(str(r["frame"]), f"{(r['ts_ns'] - t0) / 1e9:.6f}", r["op"],
                      r["station"] or r["device_mac"] or "", f"{r['slot']}/{_hex(r['subslot'])}",
                      f"{_hex(r['index'])} {r['index_name']}",
                      (_short(r.get("decoded")) or ", ".join(r.get("blocks", ())))[:80],
                      r.get("result") or "")
        out.append(t)
    if tracker.profiles:
        t = Table(title="Device profile per station")
        for c in ("device", "station", "profile", "why"):
            t.add_column(c)
        for mac, (p, why) in sorted(tracker.profiles.items(), key=lambda kv: str(kv[0])):
            t.add_row(str(mac), tracker._station(mac) or "", p, why)
        out.append(t)
    return out
