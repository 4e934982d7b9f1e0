"""Network activity for the report: DCP services, LLDP neighbours with their PROFINET TLVs,
alarms, PTCP. Fed every event by the analyzer; keeps bounded tables (constant memory)."""
from __future__ import annotations

from collections import Counter


MAX_ROWS = 50


class Activity:
    def __init__(self):
        self.dcp: Counter = Counter()        # "Identify Request" -> frames
        self.dcp_sets: list[tuple] = []      # (frame, target MAC, what)
        self.lldp: dict[tuple, dict] = {}    # (src MAC, chassis, port) -> neighbour row
        self.alarms: list[tuple] = []
        self.alarm_count = 0
        self.ptcp: Counter = Counter()

    def on_event(self, ev: dict) -> None:
        kind = ev["kind"]
        if kind == "dcp":
            self.dcp[f"{ev.get('service', ev.get('service_id'))} {ev.get('service_type_name', ev.get('service_type'))}"] += 1
            if ev.get("service") == "Set" and ev.get("service_type") == 0 and len(self.dcp_sets) < MAX_ROWS:
                self.dcp_sets.append((ev["frame"], ev["dst"], _set_what(ev)))
        elif kind == "lldp":
            key = (ev["src"], (ev.get("chassis") or {}).get("text") or (ev.get("chassis") or {}).get("id"),
                   (ev.get("port") or {}).get("id"))
            row = self.lldp.get(key)
            if row is None:
                if len(self.lldp) >= MAX_ROWS:
                    return
                row = self.lldp[key] = {"frames": 0, "first": ev["frame"], "ttl": ev.get("ttl"), "pn": set()}
            row["frames"] += 1
            for t in ev.get("profinet") or ():
                row["pn"].add(t.get("name") or f"subtype {t.get('subtype')}")
        elif kind == "alarm":
            self.alarm_count += 1
            if len(self.alarms) < MAX_ROWS:
                self.alarms.append(_alarm_row(ev))
        elif kind == "ptcp":
            self.ptcp[ev.get("frame_class") or f"0x{ev.get('frame_id', 0):04x}"] += 1

    def summary(self) -> dict:
        return {
            "dcp": dict(self.dcp),
            "dcp_sets": [{"frame": f, "target": t, "what": w} for f, t, w in self.dcp_sets],
            "lldp_neighbours": [{"src": k[0], "chassis": k[1], "port": k[2], "frames": v["frames"],
                                 "first_frame": v["first"], "ttl": v["ttl"], "profinet_tlvs": sorted(v["pn"])}
                                for k, v in self.lldp.items()],
            "alarms": self.alarm_count,
            "ptcp": sum(self.ptcp.values()),
        }

    def report_sections(self) -> list:
        from rich.table import Table   # the renderer only for a terminal report (-q prints one plain line)

        from .report import row
        out = []
        if self.dcp:
            t = Table(title="DCP activity")
            t.add_column("service")
            t.add_column("frames", justify="right")
            for k, v in sorted(self.dcp.items()):
                row(t, k, str(v))
            out.append(t)
        if self.dcp_sets:
            t = Table(title="DCP Set requests")
            for c in ("frame", "target", "sets"):
                t.add_column(c)
            for f, tgt, what in self.dcp_sets:
                row(t, str(f), tgt, what)
            out.append(t)
        if self.lldp:
            t = Table(title="LLDP neighbours")
            for c in ("source MAC", "chassis ID", "port ID", "TTL", "frames", "PROFINET TLVs"):
                t.add_column(c)
            for (src, chassis, port), r in self.lldp.items():
                row(t, src, str(chassis or ""), str(port or ""), str(r["ttl"]), str(r["frames"]),
                          ", ".join(sorted(r["pn"])) or "-")
            out.append(t)
        if self.alarms:
            t = Table(title=f"Alarms ({self.alarm_count})")
            for c in ("frame", "from", "priority", "PDU", "alarm", "slot/sub", "details"):
                t.add_column(c)
            for r in self.alarms:
                row(t, *r)
            out.append(t)
        return out


def _set_what(ev: dict) -> str:
    parts = []
    for b in ev.get("blocks") or ():
        if "nameofstation" in b:
            parts.append(f"NameOfStation={b['nameofstation']!r}")
        elif "ip" in b:
            parts.append(f"IP={b['ip']}")
        else:
            parts.append(b.get("suboption_name") or f"{b.get('option')}/{b.get('suboption')}")
    return ", ".join(parts)


def _alarm_row(ev: dict) -> tuple:
    slot, sub = ev.get("slot_nr"), ev.get("subslot_nr")
    where = f"{slot}/0x{sub:04x}" if isinstance(slot, int) and isinstance(sub, int) else ""
    details = ev["status"].get("text", "") if isinstance(ev.get("status"), dict) else ""
    diags = []
    for i in ev.get("items") or ():
        if isinstance(i, dict) and isinstance(i.get("channel_error_type"), int):
            how = (i.get("channel_properties") or {}).get("specifier_name", "")
            text = i.get("encoder_error") or i.get("channel_error_type_name", "")
            diags.append(f"{how} 0x{i['channel_error_type']:04x} {text}".strip())
    details = "; ".join(diags[:3]) or details
    return (str(ev["frame"]), ev.get("src", ""), str(ev.get("priority", "")), str(ev.get("pdu_type_name", "")),
            str(ev.get("alarm_type_name", "")), where, details)
