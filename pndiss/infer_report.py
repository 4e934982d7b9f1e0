"""Terminal report sections for mid-session captures (pndiss/infer.py): telegrams found from the content,
the settings assumed for them, and a ready-to-edit --map template (docs/map.md, TOML) for the cyclic
streams nothing fitted."""
from __future__ import annotations

from rich.table import Table
from rich.text import Text

from . import telegrams as tg


def _controllers(streams: list[dict], known=()) -> set:
    """MACs that are IO controllers: those the capture's ARs name, and a sender of streams to two or more devices
    (a controller's outputs go to each of its devices; a device answers one controller)."""
    dsts: dict = {}
    for s in streams:
        dsts.setdefault(s["src"], set()).add(s["dst"])
    return {m for m in known if m} | {m for m, d in dsts.items() if len(d) >= 2}


def map_template(streams: list[dict], controllers=()) -> str:
    """A --map file (TOML) listing the streams; the user fills in direction, slot/subslot and telegram. The
    direction is filled in where the controller is known (``controllers``, else guessed by _controllers)."""
    out = ["# pndiss --map template (docs/map.md): one [[frames]] entry per cyclic stream pndiss could not place.",
           "# Set direction (input = device -> controller), the data object's slot/subslot, offset and telegram;",
           "# delete the entries of streams that are not encoders."]
    ctl = _controllers(streams, controllers)
    for s in streams:
        direction = ('direction = "output"     # from the controller ' + s["src"] if s["src"] in ctl else
                     'direction = "input"      # to the controller ' + s["dst"] if s["dst"] in ctl else
                     'direction = "input"      # or "output": which MAC is the controller is not known')
        out += ["", "[[frames]]", f'frame_id = "0x{s["frame_id"]:04X}"', f'src = "{s["src"]}"', f'dst = "{s["dst"]}"',
                direction,
                f'# C_SDU length {s["c_sdu_len"]} bytes; sampled in frames {s["frames"][0]}..{s["frames"][1]}',
                "[[frames.objects]]", "api = 0x3D00", "slot = 1", "subslot = 1", "offset = 0",
                "telegram = 81            # 81..84, 86..89, 100, 101, 860"]
    return "\n".join(out) + "\n"


def sections(summary: dict) -> list:
    ci = summary.get("content_inference") or {}
    out = []
    inferred = ci.get("inferred", [])
    if inferred:
        t = Table(title="Telegrams inferred from content (no Connect in the capture for these devices)")
        for col in ("device", "controller", "telegram", "confidence", "learnt from frames", "streams (frame ID @ offset)",
                    "evidence"):
            t.add_column(col)
        for r in inferred:
            streams = ", ".join(f"0x{s['frame_id']:04X} {s['direction']} @{s['offset']}" for s in r["streams"])
            ev = ", ".join(f"{k} {v}" for k, v in r["evidence"].items())
            t.add_row(r["device_mac"], r["controller_mac"], str(r["telegram"]), f"{r['confidence']:.2f}",
                      f"{r['learnt_from'][0]}..{r['learnt_from'][1]}", streams, ev)
        out.append(t)
        profiles = {e.get("profile", "generic") for e in summary.get("encoders", [])
                    if e.get("telegram_source") == "inferred from content"} or {"generic"}
        for p in sorted(profiles):
            d = {k: v for k, v in tg.PROFILE_DEFAULTS.get(p, {}).items() if k not in ("source", "_doc")}
            out.append(Text(f"No 0xBF00 write in the capture for these devices: rules that need the user parameters "
                            f"run with the {p} profile defaults ({', '.join(f'{k}={v}' for k, v in d.items() if k != 'compat')}); "
                            f"the compatibility mode is learnt from the control and status words (see each "
                            f"encoder's settings); slot/subslot are unknown (shown as 0/0)."))
    failed = ci.get("not_inferred", [])
    if failed:
        out.append(Text(f"{len(failed)} cyclic stream(s) have no AR map (no Connect in the capture) and pndiss could "
                        "not find a telegram in their content. Tell pndiss with --map FILE; a template to edit:",
                        style="yellow"))
        known = {r.get("controller_mac") for r in inferred} | {e.get("controller_mac") for e in summary.get("encoders", [])}
        out.append(Text(map_template(failed, known)))
    return out
