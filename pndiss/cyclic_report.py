"""Terminal report sections of the cyclic tracker: one block per encoder (rich renderables).

Built from ``CyclicTracker.summary()`` only, so the report shows exactly what the JSON summary says.
"""
from __future__ import annotations

from rich.table import Table

SEV_STYLE = {"error": "red", "warning": "yellow", "info": "cyan"}
SHOWN_SETTINGS = ("profile", "telegram", "compat", "class4", "preset_control", "xist1_preset_affected", "scaling",
                  "direction", "mupr", "tmr", "R", "shift", "iso", "SOLMON", "k", "l_max", "D_preset", "cycle_ns",
                  "max_master_sol_failures", "sol_threshold_ge", "sol_monitor_rt", "velocity_unit")


def sections(summary: dict) -> list:
    out = []
    encs = summary.get("encoders", [])
    if not encs:
        return out
    t = Table(title="Encoders (cyclic telegrams, reference encoder)")
    for col in ("station", "device", "slot/subslot", "telegram (source)", "profile (why)", "cycles", "not judged",
                "state changes", "violations"):
        t.add_column(col)
    for e in encs:
        nviol = sum(v["events"] for v in e["violations"].values())
        t.add_row(str(e.get("station") or "-"), str(e.get("device_mac") or "-"), f"{e['slot']}/{e['subslot']}",
                  f"{e['telegram']} ({e['telegram_source']})", f"{e['profile']} ({e['profile_reason']})",
                  str(e["cycles"]), str(e["gated_cycles"]), str(e["state_changes"]), str(nviol))
    out.append(t)
    for e in encs:
        name = f"{e.get('station') or e.get('device_mac')} slot {e['slot']}/{e['subslot']}"
        st = Table(title=f"Settings in force: {name}")
        st.add_column("setting")
        st.add_column("value")
        st.add_column("from")
        for k in SHOWN_SETTINGS:
            v = e["settings"].get(k)
            if v is not None:
                st.add_row(k, str(v["value"]), str(v["source"]))
        out.append(st)
        if e["timeline"]:
            tl = Table(title=f"State timeline (first {len(e['timeline'])} of {e['state_changes']} changes): {name}")
            for col in ("frame", "state", "value"):
                tl.add_column(col)
            for s in e["timeline"][:20]:
                tl.add_row(str(s["frame"]), s["state"], str(s["value"]))
            out.append(tl)
        if e["violations"]:
            vt = Table(title=f"Violations: {name}")
            for col in ("rule", "side", "severity", "events", "cycles", "first frame", "first message"):
                vt.add_column(col)
            for rule, v in sorted(e["violations"].items(), key=lambda kv: kv[1]["first_frame"]):
                vt.add_row(rule, v["side"], f"[{SEV_STYLE.get(v['severity'], '')}]{v['severity']}[/]", str(v["events"]),
                           str(v["cycles"]), str(v["first_frame"]), v["message"])
            out.append(vt)
    return out
