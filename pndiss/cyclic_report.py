"""Terminal report sections of the cyclic tracker: one block per encoder (rich renderables).

Built from ``CyclicTracker.summary()`` only, so the report shows exactly what the JSON summary says.
"""
from __future__ import annotations

from .session_report import profile_reason, telegram_source
from .textsafe import visible

SEV_STYLE = {"error": "red", "warning": "yellow", "info": "cyan"}
SHOWN_SETTINGS = ("profile", "telegram", "compat", "class4", "preset_control", "xist1_preset_affected", "scaling",
                  "direction", "mupr", "tmr", "R", "shift", "iso", "SOLMON", "k", "l_max", "D_preset", "cycle_ns",
                  "max_master_sol_failures", "sol_threshold_ge", "sol_monitor_rt", "velocity_unit")


def connection(e: dict, encs: list) -> str:
    """' (AR of the Connect in frame N, aborted at frame M)' when the device reconnected: one axis per AR, else ''."""
    same = [x for x in encs if (x.get("device_mac"), x.get("slot"), x.get("subslot"))
            == (e.get("device_mac"), e.get("slot"), e.get("subslot"))]
    if len(same) < 2:
        return ""
    end = e.get("ar_ended") or {}
    return (f" (AR {same.index(e) + 1} of {len(same)}" + (f", Connect frame {e['ar_frame']}" if e.get("ar_frame") else "")
            + (f", {end['phase']} at frame {end['frame']}" if end else "") + ")")


def sections(summary: dict) -> list:
    from rich.table import Table   # the renderer only for a terminal report (-q prints one plain line)
    from rich.text import Text

    from .report import row
    out = []
    encs = summary.get("encoders", [])
    if not encs:
        return out
    # one paragraph per encoder, not a 9-column table: readable at 80 columns
    t = Text("Encoders (cyclic telegrams, reference encoder)\n", style="bold")
    for e in encs:
        nviol = sum(v["events"] for v in e["violations"].values())
        t.append(visible(f"{e.get('station') or '-'} ({e.get('device_mac') or '-'}) slot {e['slot']}/{e['subslot']}"
                         + connection(e, encs)), style="bold")
        t.append(visible(f": telegram {e['telegram']} ({telegram_source(e)}); profile {e['profile']} "
                         f"({profile_reason(e)}); {e['cycles']:,} cycles, {e['gated_cycles']:,} not judged, "
                         f"{e['state_changes']:,} state changes, {nviol:,} violations", 400))
        t.append("\n")
    out.append(t)
    for e in encs:
        name = f"{e.get('station') or e.get('device_mac')} slot {e['slot']}/{e['subslot']}" + connection(e, encs)
        name = visible(name, 80)
        st = Table(title=f"Settings in force: {name}")
        st.add_column("setting")
        st.add_column("value")
        st.add_column("from")
        for k in SHOWN_SETTINGS:
            v = e["settings"].get(k)
            if v is not None:
                row(st, k, str(v["value"]), str(v["source"]))
        out.append(st)
        if e["timeline"]:
            tl = Table(title=f"State timeline (first {len(e['timeline'])} of {e['state_changes']} changes): {name}")
            for col in ("frame", "state", "value"):
                tl.add_column(col)
            for s in e["timeline"][:20]:
                row(tl, str(s["frame"]), s["state"], str(s.get("value_name", s["value"])))
            out.append(tl)
        if e["violations"]:
            vt = Table(title=f"Violations: {name}")
            for col in ("rule", "side", "severity", "events", "cycles", "first frame", "first message"):
                vt.add_column(col, no_wrap=col in ("rule", "side", "severity"))
            for rule, v in sorted(e["violations"].items(), key=lambda kv: kv[1]["first_frame"]):
                row(vt, rule, v["side"], Text(v["severity"], style=SEV_STYLE.get(v["severity"], "")), str(v["events"]),
                    str(v["cycles"]), str(v["first_frame"]), v["message"])
            out.append(vt)
    return out
