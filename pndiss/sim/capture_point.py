"""What the capture point loses: frames dropped by a mirror port or a busy capture PC
(``--capture-loss RATE``) and a capture started in the middle of data exchange
(``--start-mid-session CYCLE``).

Both act on the finished, time-sorted frame list, so the session on the wire is the same with and
without them; the ground truth comes from what was dropped here, never from an analysis.
Frames that carry an injected fault's evidence (tags ``inj:*``), and the two frames either side
of them in their stream, are never dropped by the loss.
"""
from __future__ import annotations

import random


def _stream(data: bytes) -> tuple[int, str]:
    """(frame ID, source MAC) of a cyclic frame (802.1Q tagged, FrameID at 18)."""
    return int.from_bytes(data[18:20], "big"), ":".join(f"{b:02x}" for b in data[6:12])


def apply(sess, frames: list) -> tuple[list, dict]:
    """Return (frames as captured, ground-truth additions)."""
    cfg = sess.cfg
    extra: dict = {}
    needs = []
    if cfg.start_mid_session is not None:
        t0 = sess.cyc_ts(cfg.start_mid_session)
        frames = [f for f in frames if f.ts >= t0]
        needs.append("mid_session")
        extra["mid_session"] = mid_session_truth(sess, t0)
    if cfg.capture_loss > 0:
        # its own RNG: the same session with and without loss differs only in the dropped frames
        rng = random.Random(f"capture-loss:{cfg.seed}:{cfg.capture_loss}")
        keep = _near_faults(frames)
        kept, gaps = [], []
        last = {}       # stream -> frame number (in the written capture) of its last kept frame
        missing = {}    # stream -> frames dropped since
        n = 0
        for f in frames:
            cyclic = f.what.startswith("cyclic")
            key = _stream(f.data) if cyclic else None
            if cyclic and id(f) not in keep and rng.random() < cfg.capture_loss:
                missing[key] = missing.get(key, 0) + 1
                continue
            kept.append(f)
            n += 1
            if cyclic:
                if missing.get(key) and key in last:
                    gaps.append({"frame_id": key[0], "src": key[1], "prev_frame": last[key], "next_frame": n,
                                 "cycles_missing": missing[key]})
                missing[key] = 0
                last[key] = n
        frames = kept
        extra["capture_loss"] = {"rate": cfg.capture_loss,
                                 "frames_dropped": sum(g["cycles_missing"] for g in gaps)}
        extra["capture_gaps"] = gaps
        needs.append("capture_gap")
    else:
        extra["capture_gaps"] = []
    if needs:
        extra["needs"] = needs
    return frames, extra


def _near_faults(frames: list, margin: int = 2) -> set:
    """ids of the frames the loss must keep: every frame of an injected fault and, in its cyclic
    stream, the ``margin`` frames either side (the fault's context stays whole)."""
    by_stream: dict = {}
    keep = set()
    for f in frames:
        fault = any(t.startswith("inj:") for t in f.tags)
        if fault:
            keep.add(id(f))
        if f.what.startswith("cyclic"):
            by_stream.setdefault(_stream(f.data), []).append((f, fault))
    for lst in by_stream.values():
        hits = [j for j, (_f, fault) in enumerate(lst) if fault]
        for j in hits:
            for f, _ in lst[max(0, j - margin):j + margin + 1]:
                keep.add(id(f))
    return keep


def mid_session_truth(sess, t0: int) -> dict:
    """What an analyzer should infer from content alone: per station the telegram, where it sits in
    each cyclic frame (offsets from the first C_SDU byte) and its length."""
    from .. import telegrams as T
    from .stations import CTRL_MAC
    cfg = sess.cfg
    streams = []
    for st in sess.stations:
        streams.append({"station": st.name, "direction": "input", "frame_id": st.in_fid, "src": st.mac,
                        "telegram": cfg.telegram, "data_offset": st.in_data_off,
                        "data_length": T.length(cfg.telegram, "actual"), "c_sdu_length": st.in_csdu})
        streams.append({"station": st.name, "direction": "output", "frame_id": st.out_fid, "src": CTRL_MAC,
                        "telegram": cfg.telegram, "data_offset": st.out_data_off,
                        "data_length": T.length(cfg.telegram, "setpoint"), "c_sdu_length": st.out_csdu})
    return {"start_cycle": cfg.start_mid_session, "start_ns": t0,
            "assumed_settings": "profile defaults (no 0xBF00 in the capture)", "streams": streams}
