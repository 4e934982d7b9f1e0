"""Cyclic data exchange on the model-driven path: frame templates, the start-up cycles (IOxS BAD),
the run cycle by cycle (PLC and encoder models, scenario hooks) and the second AR of a restart.
fastpath.py writes long clean runs without the models from the same templates."""
from __future__ import annotations

import struct

from .. import telegrams as T
from . import frames as F
from . import startup
from .model import Encoder, Plc, Shaft
from .stations import CTRL_MAC, SLOT_ENC, SUB_TEL, Station


def cyclic_header(src: str, dst: str, frame_id: int) -> bytes:
    """Ethernet + 802.1Q (PCP 6, VID 0) + FrameID: the fixed head of every cyclic frame (wire.md §1)."""
    return (bytes.fromhex(dst.replace(":", "")) + bytes.fromhex(src.replace(":", ""))
            + struct.pack(">HHHH", 0x8100, F.PCP_RT << 13, F.ETH_PNRT, frame_id))


# APDU status (wire.md §2.3): DataStatus 0x35 = primary, valid, run, station ok; transfer status 0
DATA_STATUS = 0x35
IOXS_GOOD = 0x80
IOXS_BAD = 0x00    # bad, detected by subslot (wire.md §2.5)


# start-up run: still, ramp to 60 rpm, constant, ramp down, still (fractions of the run)
DEFAULT_SHAFT = ((0.0, 0.0, 0.0), (0.1, 0.0, 60.0), (0.35, 60.0, 60.0), (0.6, 60.0, 0.0), (0.85, 0.0, 0.0))


def frame_templates(st: Station, ioxs: int, ds_out: int, ds_in: int) -> tuple[bytes, bytes]:
    """(output, input) cyclic frames of a station with zero data, every IOPS/IOCS = ioxs, the
    DataStatus bytes given and cycle counter 0 (wire.md §2.3-2.6)."""
    out_t = bytearray(cyclic_header(CTRL_MAC, st.mac, st.out_fid) + bytes(st.out_csdu) + bytes(4))
    in_t = bytearray(cyclic_header(st.mac, CTRL_MAC, st.in_fid) + bytes(st.in_csdu) + bytes(4))
    h = 20  # dst, src, 802.1Q, type, FrameID
    for _a, _s, _ss, o in st.out_objs:
        out_t[h + o + st.out_len] = ioxs
    for _a, _s, _ss, o in st.out_iocs:
        out_t[h + o] = ioxs
    for _a, s, ss, o in st.in_objs:
        in_t[h + o + (st.in_len if (s, ss) == (SLOT_ENC, SUB_TEL) else 0)] = ioxs
    for _a, _s, _ss, o in st.in_iocs:
        in_t[h + o] = ioxs
    out_t[-2], in_t[-2] = ds_out, ds_in
    return bytes(out_t), bytes(in_t)


def _bad_cycle(sess, st, k, templates, first_out, first_in, tag) -> None:
    """Start-up cycle k (IOxS BAD, zero data): the output frame from ``first_out`` on, the input
    frame from ``first_in`` on, each with its cycle counter."""
    for t, first, cc, ts_of, what in ((templates[0], first_out, st.cc0[0], sess.out_ts, "cyclic.out.startup"),
                                      (templates[1], first_in, st.cc0[1], sess.in_ts, "cyclic.in.startup")):
        if k >= first:
            f = bytearray(t)
            struct.pack_into(">H", f, len(f) - 4, (cc + k * st.step) & 0xFFFF)
            sess.add(ts_of(st, k), bytes(f), what, {tag})


def run_startup_cycles(sess) -> None:
    """Start-up cycles (k < 0) with IOxS BAD, zero data (realistic start-up, not GOOD before PrmEnd)."""
    if sess.cfg.good_before_prmend or sess.cfg.startup == "tidy":
        return
    for st in sess.stations:
        bad = frame_templates(st, IOXS_BAD, startup.DATA_STATUS_STOP, DATA_STATUS)
        for k in range(min(st.first_in, st.first_out), 0):
            _bad_cycle(sess, st, k, bad, st.first_out, st.first_in, st.ars[0]["tag"])


def run(sess, params, devs):
    """Every station's data exchange from cycle 0 (from its first frame with GOOD before PrmEnd):
    the PLC and encoder models step, the scenario's hooks change their words, frames are added."""
    cfg, sc = sess.cfg, sess.scenario
    cyc_s = sess.cycle_ns / 1e9
    # shaft segments are given in fractions of the run (so short and long runs look alike)
    frac = sc.shaft if sc is not None and sc.shaft else DEFAULT_SHAFT
    run_s = cfg.cycles * cyc_s
    shaft_segs = tuple((f * run_s, r0, r1) for f, r0, r1 in frac)
    out_l, in_l = T.layout(cfg.telegram, "setpoint"), T.layout(cfg.telegram, "actual")
    run_startup_cycles(sess)
    per = []
    for st in sess.stations:
        enc = Encoder(cfg.profile, cfg.telegram, params=params, shaft=Shaft(shaft_segs), cycle_s=st.cycle_ns / 1e9)
        plc = Plc(cfg.telegram, sol_start=st.sol0)
        out_t, in_t = frame_templates(st, IOXS_GOOD, DATA_STATUS, DATA_STATUS)
        if sc is not None and sc.reject_bf00:
            # a conforming device refuses a bad 0xBF00: parameterisation error 0x1002 in G1_XIST2
            # and a 0x9011 channel diagnosis (cyclic.md §9; 000_37bf2397999f1108.txt:2605-2639)
            enc.error_code = 0x1002
            sess.alarm(sess.cyc_ts(2) + 300_000, st, appears=True, channel_error=0x9011,
                       tags=sc.bf00_tags)
        per.append([st, enc, plc, out_t, in_t, st.cc0, st.ars[0]["tag"]])
    last_in = {st.i: None for st in sess.stations}
    # GOOD before PrmEnd: the model runs from the first start-up frame (hooks from cycle 0)
    k0 = min([0] + [min(st.good_from, st.first_in, st.first_out) for st in sess.stations
                    if st.good_from < 0])
    for k in range(k0, max(st.cycles for st in sess.stations)):
        for row in per:
            st, enc, plc, out_t, in_t, cc0, ar_tag = row
            if k >= st.cycles:
                continue
            step = st.step
            rs = getattr(st, "restart", None)
            if rs is not None and k >= rs["end"]:
                # Release, silence, the second AR's start-up, then its data exchange (a new model)
                if k < rs["first"] or (k < rs["good_from"] and not restart_cycle(sess, st, k, rs)):
                    continue
                if k == rs["good_from"]:
                    enc = row[1] = Encoder(cfg.profile, cfg.telegram, params=rs["params"],
                                           shaft=Shaft(shaft_segs), cycle_s=st.cycle_ns / 1e9)
                    plc = row[2] = Plc(cfg.telegram, sol_start=rs["sol0"])
                    ar_tag = row[6] = rs["tag"]
                    last_in[st.i] = None
            tags_o, tags_i = {ar_tag}, {ar_tag}
            if rs is not None and k == rs["good_from"] and "fault_tag" in rs:
                tags_i.add(rs["fault_tag"])
            hooks = sc is not None and k >= 0
            if hooks:
                sc.before_cycle(sess, k, st, plc, enc, last_in[st.i])
            out = plc.step(k, last_in[st.i])
            if hooks:
                sc.after_plc(sess, k, st, out, tags_o)
            actual = enc.step(k, out)
            if hooks:
                sc.after_enc(sess, k, st, actual, tags_i)
            last_in[st.i] = actual
            ob = out_l.encode(out)
            ib = in_l.encode(actual)
            o = bytearray(out_t)
            i = bytearray(in_t)
            o[20 + st.out_data_off:20 + st.out_data_off + len(ob)] = ob
            i[20 + st.in_data_off:20 + st.in_data_off + len(ib)] = ib
            struct.pack_into(">H", o, len(o) - 4, (cc0[0] + k * step) & 0xFFFF)
            struct.pack_into(">H", i, len(i) - 4, (cc0[1] + k * step) & 0xFFFF)
            if hooks:
                sc.patch(sess, k, st, o, i, tags_o, tags_i)
                if k == 0 and st.i == 0:
                    tags_o |= set(sc.first_cyclic_tags)
            if k >= st.first_out and (rs is None or k < rs["end"] or k >= rs["first_out"]):
                sess.add(sess.out_ts(st, k), bytes(o), "cyclic.out", tags_o)
            if k >= st.first_in and (rs is None or k < rs["end"] or k >= rs["first_in"]):
                sess.add(sess.in_ts(st, k), bytes(i), "cyclic.in", tags_i)


def restart_cycle(sess, st, k, rs) -> bool:
    """A start-up cycle of the second AR: BAD frames (False), or GOOD already (True, model runs)."""
    if sess.cfg.good_before_prmend:
        return True
    bad = rs.setdefault("bad", frame_templates(st, IOXS_BAD, startup.DATA_STATUS_STOP, DATA_STATUS))
    _bad_cycle(sess, st, k, bad, rs["first_out"], rs["first_in"], rs["tag"])
    return False
