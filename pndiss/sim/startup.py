"""The AR start-up as a plant does it (issue #12 item 6): Connect, cyclic frames from the Connect on,
records (one S7-style MultipleWrite or plain writes), PrmEnd, ApplicationReady, then data exchange.

What the wire shows, per station (facts: an ET200S start-up from an S7 controller, issue #12):
* the device's provider sends input frames even before the Connect response: IOPS/IOCS BAD (0x00),
  DataStatus 0x35 (primary, valid, run, station ok);
* the controller's output frames start right after the Connect response: ProviderState STOP
  (DataStatus 0x25), IOPS/IOCS BAD;
* records, PrmEnd, ApplicationReady from the device; from cycle 0 on both sides run GOOD.
``good_before_prmend``: the device runs GOOD data (and the controller its outputs) from the first
frame, and the record write comes a few cycles after the Connect response, before PrmEnd.

``tidy`` is the simulator's old start-up (``--startup tidy``): Connect, 0xBF00, PrmEnd per station,
cyclic data only after the last PrmEnd and GOOD from its first frame.

Cycle numbers: cycle 0 is the first cycle of data exchange; start-up cycles are negative, so the
scenarios and injections (which count from 0) are the same in every start-up mode.
"""
from __future__ import annotations

from . import frames as F
from . import recdata

MS = 1_000_000
# a manufacturer-specific parameter record of the DAP written with 0xBF00 (index < 0x8000 is
# user-specific, wire.md §6.12); [sim choice]: 4 bytes, so the MultipleWrite holds two records
DAP_RECORD = (0, 0, 1, 0x0064, b"\x00\x01\x00\x00")
DATA_STATUS_STOP = 0x25   # primary, valid, ProviderState STOP, station ok (wire.md §2.3)


def records(sess, st, params, fresh=False) -> list:
    """[(api, slot, subslot, index, data, tags)] the controller writes before PrmEnd (``fresh``: as a
    conforming controller would, without the scenario's record faults)."""
    from .stations import API_ENC, SLOT_ENC, SUB_MAP
    sc = None if fresh else sess.scenario
    if hasattr(st, "connect_blocks"):     # an IO device: no parameter records
        return []
    out = [DAP_RECORD + ((),)]
    if not (sc and sc.skip_bf00):
        bf = sc.bf00_bytes if sc and sc.bf00_bytes else recdata.bf00(sess.cfg.profile, **params)
        out.insert(0, (API_ENC, SLOT_ENC, SUB_MAP, sess.ident["bf00_index"], bf, tuple(sc.bf00_tags) if sc else ()))
    return out


def write_records(sess, ts, st, recs) -> int:
    """One MultipleWrite (index 0xE040) or one plain write per record, 1 ms apart. Returns the end."""
    mw = sess.cfg.records == "multiplewrite"
    if not recs:
        return ts
    for api, slot, sub, index, data, _tags in recs:
        sess.facts["records"].append({"station": st.name, "op": "write", "index": index, "length": len(data),
                                      **({"via": "multiplewrite"} if mw else {})})
    if mw:
        tags = set().union(*(r[5] for r in recs))
        sess.seq_rw = getattr(sess, "seq_rw", 0) + 1
        outer = sess.seq_rw
        writes = []
        for api, slot, sub, index, data, _tags in recs:
            sess.seq_rw += 1
            writes.append((sess.seq_rw, api, slot, sub, index, data))
        sess.rpc_call(ts, st, 3, [F.multiple_write_req(outer, st.ar_uuid, writes)],
                      F.multiple_write_res(outer, st.ar_uuid, writes, [0] * len(writes)),
                      tags=tags, what="multiple_write")
        return ts + MS
    for j, (api, slot, sub, index, data, tags) in enumerate(recs):
        what = "bf00" if index == sess.ident["bf00_index"] else "write"
        sess.write_record(ts + j * MS, st, index, data, api=api, slot=slot, subslot=sub, tags=tags, what=what)
    return ts + len(recs) * MS


def realistic(sess, params, t_connect_ms: float) -> None:
    """Schedule Connect, records, PrmEnd and ApplicationReady of every station; set cycle 0
    (``sess.cyc_start_ns``) after the last ApplicationReady and each station's first cycles."""
    T = sess.cycle_ns
    gbp = sess.cfg.good_before_prmend
    plans = []
    t = sess.ms(t_connect_ms)
    for st in sess.all_stations():
        recs = records(sess, st, params)
        d_rec, d_prm, d_app = timing(sess, len(recs))
        plans.append((st, recs, t, t + d_rec, t + d_prm, t + d_app))
        t += 3 * MS
    # cycle 0 after every ApplicationReady; T of margin for moving each Connect onto the cycle grid
    sess.cyc_start_ns = max(p[5] for p in plans) + 2 * MS + T
    for st, recs, t_c, t_rec, t_prm, t_app in plans:
        st.first_in, st.first_out = schedule(sess, st, recs, t_c, t_rec - t_c, t_prm - t_c, t_app - t_c,
                                             station0_tags=True)
        st.good_from = min(st.first_in, st.first_out) if gbp and not hasattr(st, "connect_blocks") else 0


def tidy(sess, params, t: float) -> None:
    """The old tidy start-up: Connect, 0xBF00, PrmEnd per station; cyclic data from cycle 0 after
    the last PrmEnd, GOOD from the first frame; ApplicationReady once the IO data run."""
    sc = sess.scenario
    if sess.io_stations:
        raise ValueError("IO devices need the realistic start-up (not --startup tidy)")
    for st in sess.stations:
        sess.connect(sess.ms(t), st)
        if not (sc and sc.skip_bf00):
            bf = recdata.bf00(sess.cfg.profile, **params) if not (sc and sc.bf00_bytes) else sc.bf00_bytes
            sess.write_record(sess.ms(t + 3), st, sess.ident["bf00_index"], bf, what="bf00",
                              tags=sc.bf00_tags if sc else ())
            sess.facts["records"].append({"station": st.name, "op": "write", "index": sess.ident["bf00_index"],
                                          "length": len(bf)})
        sess.rpc_call(sess.ms(t + 6), st, 4, [F.control_req(st.ar_uuid, st.session_key, prm_end=True)],
                      [F.control_res(st.ar_uuid, st.session_key, block_type=0x8110)], what="prm_end")
        t += 10
    sess.cyc_start_ns = sess.ms(t)
    for st in sess.stations:
        sess.rpc_call(sess.cyc_ts(5 + 2 * st.i), st, 4,
                      [F.control_req(st.ar_uuid, st.session_key, app_ready=True)],
                      [F.control_res(st.ar_uuid, st.session_key, block_type=0x8112)],
                      from_device=True, what="app_ready")


def schedule(sess, st, recs, t_c, d_rec, d_prm, d_app, station0_tags=False) -> tuple[int, int]:
    """Connect, records, PrmEnd, ApplicationReady of one AR from about t_c on (relative times d_*),
    the Connect moved onto the cycle grid: it goes out 150 us before one of the device's input
    frames, so that frame lies between the request and its response (300 us later).
    Returns (first input cycle, first output cycle) of the AR."""
    sc = sess.scenario
    k = (t_c - sess.cyc_start_ns) // st.cycle_ns - 2
    while sess.in_ts(st, k) >= t_c:
        k -= 1
    while sess.in_ts(st, k) < t_c:
        k += 1
    t_c = sess.in_ts(st, k) - 150_000
    first_in = k
    while sess.out_ts(st, k) < t_c + 350_000:
        k += 1
    sess.connect(t_c, st)
    write_records(sess, t_c + d_rec, st, recs)
    prm_tags = tuple(sc.first_cyclic_tags) if sc and station0_tags and st.i == 0 and sc.skip_bf00 else ()
    sess.rpc_call(t_c + d_prm, st, 4, [F.control_req(st.ar_uuid, st.session_key, prm_end=True)],
                  [F.control_res(st.ar_uuid, st.session_key, block_type=0x8110)], what="prm_end", tags=prm_tags)
    sess.rpc_call(t_c + d_app, st, 4, [F.control_req(st.ar_uuid, st.session_key, app_ready=True)],
                  [F.control_res(st.ar_uuid, st.session_key, block_type=0x8112)],
                  from_device=True, what="app_ready")
    return first_in, k


def timing(sess, n_records: int) -> tuple[int, int, int]:
    """(records, PrmEnd, ApplicationReady) after the Connect request, in ns."""
    T = sess.cycle_ns
    n_rec = 1 if sess.cfg.records == "multiplewrite" else n_records
    d_rec = max(3 * T, 2 * MS)
    d_prm = d_rec + n_rec * MS + 2 * MS
    return d_rec, d_prm, d_prm + 2 * MS


def restart(sess, st, params) -> None:
    """AR restart of one station at cycle ``cfg.restart``: the controller releases the AR, a silence
    of ``cfg.restart_gap_ms``, then a new Connect (new AR UUID, next session key, same frame IDs)
    with the 0xBF00 values of ``cfg.restart_scaling``, PrmEnd, ApplicationReady, data exchange."""
    cfg = sess.cfg
    T = sess.cycle_ns
    R = cfg.restart
    if cfg.restart_mode == "abort":
        # the controller aborts the AR: ERR-RTA-PDU on the alarm CR, PNIOStatus RTA_ERR_CLS_PROTOCOL
        # 13 "abort.req" (wire.md §5, §7.1: byte pattern 14 01 ffff fffe 0004 cf 81 fd xx)
        sess.add(sess.out_ts(st, R - 1) + 300_000,
                 F.rta(_ctrl_mac(), st.mac, high=False, dst_ep=2, src_ep=1,
                       pdu_type=F.RTA_ERR, send_seq=0xFFFF, ack_seq=0xFFFE, sdu=bytes([0xCF, 0x81, 0xFD, 0x0D]),
                       add_flags=0x01), "abort")
    else:
        sess.rpc_call(sess.out_ts(st, R - 1) + 300_000, st, 1,
                      [F.control_req(st.ar_uuid, st.session_key, release=True)],
                      [F.control_res(st.ar_uuid, st.session_key, block_type=0x8114)], what="release")
    params2 = dict(params, **cfg.restart_scaling)
    st.ar_uuid = sess.uuid()
    st.session_key += 1
    recs = records(sess, st, params2, fresh=True)
    d_rec, d_prm, d_app = timing(sess, len(recs))
    t_c = sess.out_ts(st, R - 1) + int(cfg.restart_gap_ms * MS)
    first_in, first_out = schedule(sess, st, recs, t_c, d_rec, d_prm, d_app)
    good = max(first_in, first_out) + -(-(d_app + 2 * MS) // T) + 1
    if cfg.good_before_prmend:
        good = min(first_in, first_out)
    if good >= cfg.cycles - 1:
        raise ValueError(f"--restart {R}: the second AR would start data exchange at cycle {good}, "
                         f"after the last cycle ({cfg.cycles - 1}); restart earlier or run more cycles")
    tag = f"ar2:{st.i}"
    st.restart = {"end": R, "first": min(first_in, first_out), "first_in": first_in, "first_out": first_out,
                  "good_from": good, "params": params2, "sol0": 1 + sess.rng.randrange(15), "tag": tag}
    st.ars.append({"ar_uuid": str(st.ar_uuid), "session_key": st.session_key, "params": params2,
                   "first_cycle": min(first_in, first_out), "data_exchange_cycle": good, "tag": tag})
    st.ars[0]["last_cycle"] = R - 1
    st.ars[0]["ended_by"] = cfg.restart_mode
    if any(params2.get(k) != params.get(k) for k in ("direction", "mupr", "tmr")):
        # the controller changed code sequence / MUPR / TMR and does no preset before using the
        # position: behaviour.md §9 #31 (an info-level controller violation), on the first GOOD frame
        tag = "inj:PRESET-WITHOUT-NEW-PARAMS"
        st.restart["fault_tag"] = tag
        sess.injected.append({"rule": "PRESET-WITHOUT-NEW-PARAMS", "side": "controller", "cycle": good, "tag": tag,
                              "how": "the AR restart changes code sequence/MUPR/TMR in 0xBF00 and no preset follows",
                              "also_possible": [], "settings": {}})


def _ctrl_mac() -> str:
    from .stations import CTRL_MAC
    return CTRL_MAC
