"""Fast path for large benchmark captures (``pndiss simulate --cycles 10000000``).

The start-up (DCP, LLDP, Connect, records, parameter reads, Release) comes from the normal
session builder; the cyclic part is written in chunks without scapy or a per-frame Python loop:
every cyclic frame of these sessions has the same length (C_SDU padded to 40 bytes, wire.md §2.4),
so a chunk is one frame-pair template repeated, and the fields that change per cycle (timestamps,
cycle counters, sign-of-life nibbles, positions) are written with extended-slice assignment into
the bytearray (C speed). The device model is the steady state of a conforming encoder: control by
PLC, absolute value requested and acknowledged, shaft turning at a constant ``STEPS`` per cycle.
"""
from __future__ import annotations

import dataclasses
import json
import random
import struct
import sys
from array import array

from .. import telegrams as T
from . import pcapng
from .config import Config
from .cyclic import DATA_STATUS, IOXS_GOOD, cyclic_header
from .session import SimSession
from .stations import CTRL_MAC, SLOT_ENC, SUB_TEL

FAST_THRESHOLD = 100_000   # cycles; below this the normal (model-driven) path is used
STEPS = 8                  # position steps per cycle (8192 steps/rev at 1 ms: ~58.6 rpm)
CHUNK = 1 << 15            # cycles per chunk (a multiple of 2048 keeps cycle counters aligned)
_LITTLE = sys.byteorder == "little"


def _be32(values: array) -> bytes:
    """Big-endian bytes of an array('I')."""
    if _LITTLE:
        values.byteswap()
    return values.tobytes()


def _le32(values: array) -> bytes:
    """Little-endian bytes of an array('I') (pcapng here is little-endian)."""
    if not _LITTLE:
        values.byteswap()
    return values.tobytes()


class _Stream:
    """Per station: frame templates and where the changing fields sit (byte offsets in the EPB)."""

    def __init__(self, sess: SimSession, st, n_st: int):
        cfg = sess.cfg
        self.st = st
        tel = cfg.telegram
        self.out_l, self.in_l = T.layout(tel, "setpoint"), T.layout(tel, "actual")
        ctrl_bit = T.bit_position("zsw2_enc", "control_requested", cfg.profile) if "zsw2_enc" in self.in_l.names else 0
        out_t = bytearray(cyclic_header(CTRL_MAC, st.mac, st.out_fid) + bytes(st.out_csdu) + bytes(4))
        in_t = bytearray(cyclic_header(st.mac, CTRL_MAC, st.in_fid) + bytes(st.in_csdu) + bytes(4))
        for _a, _s, _ss, o in st.out_objs:
            out_t[20 + o + st.out_len] = IOXS_GOOD
        for _a, _s, _ss, o in st.out_iocs:
            out_t[20 + o] = IOXS_GOOD
        for _a, s, ss, o in st.in_objs:
            in_t[20 + o + (st.in_len if (s, ss) == (SLOT_ENC, SUB_TEL) else 0)] = IOXS_GOOD
        for _a, _s, _ss, o in st.in_iocs:
            in_t[20 + o] = IOXS_GOOD
        out_t[-2] = in_t[-2] = DATA_STATUS
        # constant words: control by PLC + absolute value request; control requested + ATX; speed
        speed = STEPS * 1_000_000_000 // sess.cycle_ns          # steps/s (velocity unit 0)
        ob = self.out_l.encode({"stw2_enc": 0x0400, "g1_stw": 0x2000})
        ib = self.in_l.encode({"zsw2_enc": 1 << ctrl_bit if ctrl_bit else 0, "g1_zsw": 0x2000,
                               "nist_a": speed, "nist_b": speed})
        out_t[20 + st.out_data_off:20 + st.out_data_off + len(ob)] = ob
        in_t[20 + st.in_data_off:20 + st.in_data_off + len(ib)] = ib
        if len(out_t) != len(in_t):
            raise ValueError("fast path needs equal frame lengths")
        self.out_t, self.in_t = bytes(out_t), bytes(in_t)
        # byte offsets inside the frames (the EPB adds 28 bytes in front)
        names_o, names_i = self.out_l.names, self.in_l.names
        self.sol_out = 20 + st.out_data_off + self._off(self.out_l, "stw2_enc") if "stw2_enc" in names_o else None
        self.sol_in = 20 + st.in_data_off + self._off(self.in_l, "zsw2_enc") if "zsw2_enc" in names_i else None
        self.pos = [20 + st.in_data_off + self._off(self.in_l, n) + (4 if n == "g1_xist3" else 0)
                    for n in ("g1_xist1", "g1_xist2", "g1_xist3") if n in names_i]
        self.cc_out = len(out_t) - 4
        self.cc_in = len(in_t) - 4
        self.cc0 = st.cc0                                     # the start-up cycles' counters go on
        self.sol0 = st.sol0
        self.ctrl_hi = 0x04                                   # STW2_ENC high byte: bit 10
        self.creq_hi = (1 << ctrl_bit) >> 8 if ctrl_bit else 0
        self.tmr = sess.params["tmr"]

    @staticmethod
    def _off(layout, name):
        off = 0
        for n in layout.names:
            if n == name:
                return off
            off += T.SIGNALS[n]["size"]
        raise KeyError(name)


def write_fast(cfg: Config, path: str, expected: bool = True) -> dict:
    """Start-up scenario with ``cfg.cycles`` cycles, cyclic part in bulk. Returns the ground truth."""
    loss = cfg.capture_loss
    # the start-up part comes whole; frames are lost only from the bulk cyclic part (below)
    sess = SimSession(dataclasses.replace(cfg, capture_loss=0.0), None)
    sess.with_cyclic = False
    acyclic, truth = sess.build()
    streams = [_Stream(sess, st, len(sess.stations)) for st in sess.stations]
    flen = len(streams[0].out_t)
    epb = 32 + flen + (-flen & 3)
    n_st = len(streams)
    per_cycle = 2 * n_st
    stride = epb * per_cycle
    step_cc = (sess.scf * sess.rr) & 0xFFFF
    T_ns = sess.cycle_ns
    # EPB templates for one cycle: outs at t + 20 us * i, ins at t + T/2 + 20 us * i
    head = struct.Struct("<IIIIIII")
    pair = bytearray()
    slots = []       # (kind, stream, ts offset)
    for i, s in enumerate(streams):
        slots.append(("out", s, 20_000 * i))
    for i, s in enumerate(streams):
        slots.append(("in", s, T_ns // 2 + 20_000 * i))
    for kind, s, _ in slots:
        fr = s.out_t if kind == "out" else s.in_t
        pair += head.pack(6, epb, 0, 0, 0, flen, flen) + fr + bytes(-flen & 3) + struct.pack("<I", epb)
    pair = bytes(pair)
    # cycle-counter and sign-of-life patterns (periods 65536/step and 15)
    cc_period = 65536 // step_cc if 65536 % step_cc == 0 else 65536
    frames_cyc = cfg.cycles * per_cycle
    # acyclic frames: sorted by time; each goes before the first cyclic frame with a later time
    acyc = [(f.ts, f.data) for f in acyclic]
    t_start = sess.cyc_start_ns

    drift = any(st.phase != st.cycle_ns // 2 + 20_000 * st.i or st.ppb for st in sess.stations) \
        or sess.ctrl_ppb or sess.jit_ns
    gaps = []
    if drift or loss:
        with open(path, "wb") as f:
            w = pcapng.Writer(f)
            _write_sorted(w, acyc, sess, slots, pair, stride, epb, streams, step_cc, cc_period, loss, gaps)
    else:
        _write_fixed(path, acyc, cfg, sess, slots, pair, stride, epb, streams, step_cc, cc_period, t_start, T_ns)
    if loss:
        dropped = sum(g["cycles_missing"] for g in gaps)
        frames_cyc -= dropped
        truth["config"]["capture_loss"] = loss
        truth["capture_loss"] = {"rate": loss, "frames_dropped": dropped,
                                 "note": "bulk path: only data-exchange frames are lost"}
        truth["capture_gaps"] = gaps
        truth["needs"] = ["capture_gap"]
    truth["frames"] = len(acyc) + frames_cyc
    truth["frame_kinds"]["cyclic.in"] = truth["frame_kinds"]["cyclic.out"] = cfg.cycles * n_st
    truth["fast_path"] = {"steps_per_cycle": STEPS, "note": "constant-speed steady state, no handshakes"}
    if expected:
        from .scenarios import expected_path
        with open(expected_path(path), "w", encoding="utf-8") as f:
            json.dump(truth, f, indent=1, sort_keys=True)
            f.write("\n")
    return truth


def _write_sorted(w, acyc, sess, slots, pair, stride, epb, streams, step_cc, cc_period, loss=0.0,
                  gaps=None) -> None:
    """Drifting clocks and jitter: per chunk every frame's own timestamp (the session's out_ts /
    in_ts), then the chunk's frames and the acyclic frames in time order. A frame is written once
    no later frame can be earlier: before the first frame of the next chunk (each stream's frames
    are in order, so that is the earliest of the streams' next frames)."""
    cycles = sess.cfg.cycles
    n_slots = len(slots)
    ts_of = [(sess.out_ts if kind == "out" else sess.in_ts, s.st) for kind, s, _ in slots]
    pending = []     # (ts, order, bytes) not yet written
    ai = order = 0
    # capture loss (capture_point.py does the same for the normal path): own RNG, gaps per stream
    rng = random.Random(f"capture-loss:{sess.cfg.seed}:{loss}")
    keys = [(st.out_fid if kind == "out" else st.in_fid, CTRL_MAC if kind == "out" else st.mac)
            for kind, s, _ in slots for st in (s.st,)]
    last, missing = [None] * n_slots, [0] * n_slots
    k = 0
    while k < cycles:
        k1 = min(cycles, k + CHUNK)
        n = k1 - k
        mv = _emit_into(slots, pair, stride, epb, k, k1, sess.cyc_start_ns, sess.cycle_ns, streams, step_cc,
                        cc_period)
        view = memoryview(mv)
        for j, (fn, st) in enumerate(ts_of):
            ts = [fn(st, c) for c in range(k, k1)]
            hi = _le32(array("I", [t >> 32 for t in ts]))
            lo = _le32(array("I", [t & 0xFFFFFFFF for t in ts]))
            e = j * epb
            for b in range(4):
                mv[e + 12 + b::stride] = hi[b::4]
                mv[e + 16 + b::stride] = lo[b::4]
            for c, t in enumerate(ts):
                i = c * n_slots + j
                pending.append((t, order + i, view[i * epb:(i + 1) * epb]))
        order += n * n_slots
        bound = min(fn(st, k1) for fn, st in ts_of) if k1 < cycles else None
        while ai < len(acyc) and (bound is None or acyc[ai][0] < bound):
            pending.append((acyc[ai][0], -1, pcapng.epb(*acyc[ai])))
            ai += 1
        pending.sort(key=lambda r: (r[0], r[1]))
        cut = len(pending) if bound is None else next((x for x, r in enumerate(pending) if r[0] >= bound),
                                                      len(pending))
        out = pending[:cut]
        if loss:
            kept = []
            for r in out:
                if r[1] < 0:
                    kept.append(r)
                    continue
                j = r[1] % n_slots
                if rng.random() < loss:
                    missing[j] += 1
                    continue
                kept.append(r)
                num = w.frames + len(kept)
                if missing[j] and last[j] is not None:
                    gaps.append({"frame_id": keys[j][0], "src": keys[j][1], "prev_frame": last[j],
                                 "next_frame": num, "cycles_missing": missing[j]})
                missing[j] = 0
                last[j] = num
            out = kept
        w.write_raw(b"".join(bytes(r[2]) if isinstance(r[2], memoryview) else r[2] for r in out), len(out))
        pending = pending[cut:]
        k = k1
    while ai < len(acyc):
        w.write(*acyc[ai])
        ai += 1


def _write_fixed(path, acyc, cfg, sess, slots, pair, stride, epb, streams, step_cc, cc_period, t_start, T_ns):
    """One synchronised clock without jitter: every cycle's frames in one fixed slot order."""
    with open(path, "wb") as f:
        w = pcapng.Writer(f)
        ai = 0
        # acyclic frames before the first cycle
        while ai < len(acyc) and acyc[ai][0] < t_start:
            w.write(*acyc[ai])
            ai += 1
        k = 0
        while k < cfg.cycles:
            # the next acyclic frame bounds this chunk: whole cycles that end before it
            k_end = min(cfg.cycles, k + CHUNK)
            if ai < len(acyc):
                ta = acyc[ai][0]
                k_lim = max(k, (ta - t_start) // T_ns)      # cycles entirely <= ta start before k_lim
                k_end = min(k_end, k_lim)
            if k_end > k:
                _emit(w, slots, pair, stride, epb, k, k_end, t_start, T_ns, streams, step_cc, cc_period, sess)
                k = k_end
                continue
            # cycle k straddles the acyclic frame: write its frames one by one around it
            t_k = t_start + k * T_ns
            one = _emit_into(slots, pair, stride, epb, k, k + 1, t_start, T_ns, streams, step_cc, cc_period)
            t_k = t_start + k * T_ns
            for j, (_kind, _s, toff) in enumerate(slots):
                while ai < len(acyc) and acyc[ai][0] <= t_k + toff:
                    w.write(*acyc[ai])
                    ai += 1
                w.write_raw(one[j * epb:(j + 1) * epb], 1)
            k += 1
        while ai < len(acyc):
            w.write(*acyc[ai])
            ai += 1


def _emit(w, slots, pair, stride, epb, k0, k1, t_start, T_ns, streams, step_cc, cc_period, sess):
    buf = _emit_into(slots, pair, stride, epb, k0, k1, t_start, T_ns, streams, step_cc, cc_period)
    w.write_raw(buf, (k1 - k0) * len(slots))


def _tile(pattern: bytes, period: int, width: int, start: int, n: int) -> bytes:
    """n items of ``width`` bytes from a periodic pattern (``period`` items), starting at item start."""
    start %= period
    reps = (start + n) // period + 1
    return (pattern * reps)[start * width:(start + n) * width]


def _emit_into(slots, pair, stride, epb, k0, k1, t_start, T_ns, streams, step_cc, cc_period) -> bytearray:
    """Frames of cycles k0..k1-1; bytearray extended-slice assignment is a tight C loop."""
    n = k1 - k0
    mv = bytearray(pair * n)
    for j, (kind, s, toff) in enumerate(slots):
        e = j * epb
        t0 = t_start + k0 * T_ns + toff
        t1 = t0 + n * T_ns
        # timestamps: EPB words 3 (high) and 4 (low), little-endian
        if t0 >> 32 == (t1 - T_ns) >> 32:
            hi = struct.pack("<I", t0 >> 32)
            for b in range(4):
                mv[e + 12 + b::stride] = hi[b:b + 1] * n
            lo = _le32(array("I", range(t0 & 0xFFFFFFFF, (t0 & 0xFFFFFFFF) + n * T_ns, T_ns)))
            for b in range(4):
                mv[e + 16 + b::stride] = lo[b::4]
        else:  # the 2^32 ns boundary falls inside: per frame (rare, every ~4.3 s of capture time)
            for c in range(n):
                struct.pack_into("<II", mv, e + c * stride + 12, (t0 + c * T_ns) >> 32, (t0 + c * T_ns) & 0xFFFFFFFF)
        fo = e + 28   # frame start inside the EPB
        # cycle counter (BE u16), period 65536/step
        cc0 = s.cc0[0] if kind == "out" else s.cc0[1]
        key = ("cc", kind, id(s))
        pat = _PAT.get(key)
        if pat is None:
            pat = _PAT[key] = b"".join(struct.pack(">H", (cc0 + i * step_cc) & 0xFFFF) for i in range(cc_period))
        seq = _tile(pat, cc_period, 2, k0, n)
        off = fo + (s.cc_out if kind == "out" else s.cc_in)
        mv[off::stride] = seq[0::2]
        mv[off + 1::stride] = seq[1::2]
        # sign-of-life nibble in the high byte of STW2_ENC / ZSW2_ENC (next(v) = v mod 15 + 1)
        if kind == "out" and s.sol_out is not None:
            key = ("so", id(s))
            pat = _PAT.get(key) or _PAT.setdefault(key, bytes(((((s.sol0 - 1 + i) % 15) + 1) << 4) | s.ctrl_hi
                                                               for i in range(15)))
            mv[fo + s.sol_out::stride] = _tile(pat, 15, 1, k0, n)
        if kind == "in" and s.sol_in is not None:
            # the encoder starts at cycle 1, once the controller's value has changed (cyclic.md §6)
            key = ("si", id(s))
            pat = _PAT.get(key) or _PAT.setdefault(key, bytes((((i % 15) + 1) << 4) | s.creq_hi for i in range(15)))
            if k0 == 0:
                seq = bytes([s.creq_hi]) + _tile(pat, 15, 1, 0, n - 1)
            else:
                seq = _tile(pat, 15, 1, k0 - 1, n)
            mv[fo + s.sol_in::stride] = seq
        if kind == "in" and s.pos:
            tmr = s.tmr
            p0 = (k0 * STEPS) % tmr
            vals = _positions(p0, n, tmr)
            for po in s.pos:
                for b in range(4):
                    mv[fo + po + b::stride] = vals[b::4]
    return mv


_PAT: dict = {}


def _positions(p0: int, n: int, tmr: int) -> bytes:
    """Big-endian u32 positions p0, p0+STEPS, ... modulo tmr."""
    out = []
    p, left = p0, n
    while left:
        m = min(left, (tmr - p + STEPS - 1) // STEPS)
        out.append(array("I", range(p, p + m * STEPS, STEPS)))
        left -= m
        p = (p + m * STEPS) % tmr
    a = array("I")
    for x in out:
        a.extend(x)
    return _be32(a)
