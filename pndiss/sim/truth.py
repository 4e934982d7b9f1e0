"""The ground truth of a simulated session (the ``.expected.json`` sidecar): the stations with their
ARs and IOCRs, the injected faults and the frames that carry them, records, parameters, alarms."""
from __future__ import annotations

from .stations import CTRL_IP, CTRL_MAC, CTRL_NAME, SLOT_ENC, SUB_TEL, module_ident, submodule_ident


def tagged_span(sess, tag: str) -> dict:
    """Numbers (from 1) of the first and last frame tagged ``tag``, None where none is."""
    tagged = [n for n, f in enumerate(sess.frames, 1) if tag in f.tags]
    return {"first_frame": tagged[0] if tagged else None, "last_frame": tagged[-1] if tagged else None}


def ar_truth(sess, st) -> list:
    """Each AR of a station: UUID, session key, its 0xBF00 values, cycles and cyclic frames."""
    out = []
    for ar in st.ars:
        d = {k: v for k, v in ar.items() if k != "tag"}
        d["params"] = {k: v for k, v in ar["params"].items()
                       if k in ("mupr", "tmr", "direction", "velocity_unit", "class4", "compat")}
        d.update(tagged_span(sess, ar["tag"]))
        out.append(d)
    return out


def truth(sess) -> dict:
    """The sidecar's content (scenarios.write_capture dumps it)."""
    from . import iodevice
    cfg = sess.cfg
    faults = [dict({k: v for k, v in inj.items() if k != "tag"}, **tagged_span(sess, inj["tag"]))
              for inj in sess.injected]
    stations = []
    for st in sess.stations:
        def objs(lst, data_len):
            return [{"api": a, "slot": s, "subslot": ss, "offset": o,
                     "length": data_len if (s, ss) == (SLOT_ENC, SUB_TEL) else 0} for a, s, ss, o in lst]

        def iocs(lst):
            return [{"api": a, "slot": s, "subslot": ss, "offset": o} for a, s, ss, o in lst]
        stations.append({
            "name": st.name, "mac": st.mac, "ip": st.ip, "profile": cfg.profile,
            "vendor_id": sess.ident["vendor_id"], "device_id": sess.ident["device_id"],
            "ar_uuid": st.ars[0]["ar_uuid"], "telegram": cfg.telegram, "ars": ar_truth(sess, st),
            "telegram_slot": SLOT_ENC, "telegram_subslot": SUB_TEL,
            "module_ident": module_ident(cfg.telegram), "submodule_ident": submodule_ident(cfg.telegram),
            "iocrs": [
                {"direction": "input", "frame_id": st.in_fid, "src": st.mac, "dst": CTRL_MAC,
                 "data_length": st.in_csdu, "send_clock_factor": st.scf, "reduction_ratio": st.rr,
                 "objects": objs(st.in_objs, st.in_len), "iocs": iocs(st.in_iocs)},
                {"direction": "output", "frame_id": st.out_fid, "src": CTRL_MAC, "dst": st.mac,
                 "data_length": st.out_csdu, "send_clock_factor": st.scf, "reduction_ratio": st.rr,
                 "objects": objs(st.out_objs, st.out_len), "iocs": iocs(st.out_iocs)},
            ],
        })
    whats = {}
    for f in sess.frames:
        whats[f.what] = whats.get(f.what, 0) + 1
    return {
        "generator": "pndiss simulate",
        "config": {"scenario": cfg.scenario, "profile": cfg.profile, "telegram": cfg.telegram,
                   "cycle_ms": cfg.cycle_ms, "cycles": cfg.cycles, "encoders": cfg.encoders,
                   "seed": cfg.seed, "inject": [f"{r}@{c}" if c is not None else r for r, c in cfg.injects],
                   "startup": cfg.startup, "records": cfg.records, "good_before_prmend": cfg.good_before_prmend,
                   **({"restart": cfg.restart, "restart_scaling": cfg.restart_scaling,
                       "restart_mode": cfg.restart_mode}
                      if cfg.restart is not None else {}),
                   **({"capture_loss": cfg.capture_loss} if cfg.capture_loss else {}),
                   "drift_ppm": cfg.drift_ppm if not cfg.irt else 0, "jitter_us": cfg.jitter_us if not cfg.irt else 0,
                   **({"cycle_list": cfg.cycle_list} if cfg.cycle_list else {}),
                   **({"irt": True} if cfg.irt else {}), **({"io_devices": cfg.io_devices} if cfg.io_devices else {}),
                   **({"start_mid_session": cfg.start_mid_session} if cfg.start_mid_session is not None
                      else {})},
        "frames": len(sess.frames),
        "frame_kinds": dict(sorted(whats.items())),
        "controller": {"name": CTRL_NAME, "mac": CTRL_MAC, "ip": CTRL_IP},
        "stations": stations,
        "records": sess.facts["records"],
        "params": sess.facts["params"],
        "alarms": sess.facts["alarms"],
        "faults": faults,
        "clean": not faults,
        **getattr(sess, "capture_extra", {"capture_gaps": []}),
        **({"io_devices": [iodevice.truth(sess, st) for st in sess.io_stations]} if sess.io_stations else {}),
    }
