"""Mid-session captures: find the telegram in a cyclic frame from its content (issue #12).

A capture started after the Connect has no AR map. For cyclic streams the session cannot map, the
first SAMPLES C_SDUs of each stream are kept; once a stream and its partner (MACs reversed: the
controller's output stream and the device's input stream) both have them, every candidate telegram
(the table's telegrams with a sign-of-life word in both directions, pndiss/data/telegrams.json
"content_inference") at every offset of both C_SDUs is scored on what the table says a telegram
looks like:

- the IOPS byte right after the data object is GOOD (0x80) in every sample, and so is the byte before it
  unless it starts the C_SDU (gate: a data object starts there);
- the control/status words set no bit one profile reserves, for some one profile (gate; the profiles that
  fit are evidence too: words that fit only PS/PSM make the device PS/PSM, session.profile_for);
- the sign-of-life nibbles of STW2_ENC / ZSW2_ENC count 1..15 from frame to frame;
- ZSW2_ENC "control requested" mirrors STW2_ENC "control by PLC", and is set;
- the position (G1_XIST1 / G1_XIST3) moves continuously.

A layout passes only with positive evidence (the sign-of-life counting in both directions, or control
requested mirrored and set beside one counting side); all-zero IO data proves nothing. The best candidate becomes an AR map of source
"inferred from content" (the session's ``add_inferred``) with a confidence and the frames it was
learnt from; streams nothing fits are listed for a ready-to-edit --map template (docs/map.md).
Frames used for learning are counted, not judged.

Nothing fitting is not final: a capture may start while the PLC is in STOP (IOPS bad, no sign of
life), or in the AR's start-up, and the AR run later. A pair that fails is sampled again at once, then
after a pause in frames of twice the span its samples took, doubling (32 spans at most; RETRY_MAX_DOUBLINGS
samplings after the first)
(then never again: a stream of an ordinary IO device costs a few samplings per capture). The pause is counted in frame numbers, so the engine (which
hands a waiting stream over in bulk until then, pndiss/engine.py) and the frame loop sample the
same frames.
"""
from __future__ import annotations

from . import telegrams as tg
from .infer_facts import (CI as _CI, IOPS_GOOD, MAX_AXES, MAX_STREAMS, RETRY_MAX_DOUBLINGS, SAMPLES,  # noqa: F401
                          SOURCE, bit_of as _bit, candidates, continuous as _continuous, counting as _counting,
                          hold as _hold, lua_facts, offsets as _offsets, reserved_in as _reserved_in, word as _word)
from .proto.rt import DS_JUDGED

def _free(o: int, L: int, taken) -> bool:
    return all(o + L <= a or o >= b for a, b in taken)


def _pick(found: list, taken_s=(), taken_a=(), profiles=None) -> dict | None:
    """The best of the layouts (first of equal scores) clear of the byte ranges ``taken_s`` / ``taken_a`` (the
    layouts picked before) and fitting every one of ``profiles`` (when given), with its confidence: its evidence,
    less when another such layout over the same bytes scores close to it (one elsewhere in the frames is another
    axis). None: nothing left."""
    ok = [f for f in found if _free(f["os"], f["Ls"], taken_s) and _free(f["oa"], f["La"], taken_a)
          and (profiles is None or set(profiles) <= set(f["evidence"]["profiles"]))]
    if not ok:
        return None
    top = ok[0]
    for f in ok[1:]:
        if f["score"] > top["score"] + 1e-9:
            top = f
    mine_s, mine_a = [(top["os"], top["os"] + top["Ls"])], [(top["oa"], top["oa"] + top["La"])]
    rivals = [f["score"] for f in ok
              if f is not top and (not _free(f["os"], f["Ls"], mine_s) or not _free(f["oa"], f["La"], mine_a))]
    best = dict(top, evidence=dict(top["evidence"]), runner_up=max(rivals, default=0.0))
    margin = best["score"] - best["runner_up"]
    share = best["evidence"].pop("share")
    best["confidence"] = round(share * (1.0 if margin >= 0.5 else 0.5 + margin), 2)
    return best


class Stream:
    __slots__ = ("key", "samples", "frames", "done", "retry_at", "tries")

    def __init__(self, key):
        self.key = key            # (frame_id, src, dst)
        self.samples: list[bytes] = []
        self.frames: list[int] = []
        self.done = False         # decided for good: inferred, its Connect seen, or the capture ended
        self.retry_at = 0         # after a failed sampling: the frame number from which it samples again
        self.tries = 0


class Inference:
    def __init__(self, analyzer, enabled: bool = True):
        self.a = analyzer
        self.enabled = enabled
        self.streams: dict = {}
        self.results: list[dict] = []     # one per inferred AR (report, summary)
        self.failed: dict = {}            # key -> {frame_id, src, dst, c_sdu_len, frames}: nothing fits
        self.ts = None                    # time stamp of the frame that completed the samples

    def offer(self, key: tuple, fn: int, csdu: bytes, ts: int | None = None, ds: int | None = None) -> None:
        """A cyclic frame the session could not map (cyclic.py); decides once both directions have samples. A
        frame whose DataStatus is not valid + RUN (``ds``; a PLC in STOP, an AR starting up) is no sample: its
        IOPS are bad, and the IOCS bytes beside its data objects would fit a wrong layout (an independent audit)."""
        if ds is not None and ds & DS_JUDGED != DS_JUDGED:
            return
        st = self.streams.get(key)
        if st is None:
            if not self.enabled or len(self.streams) >= MAX_STREAMS:
                return
            st = self.streams[key] = Stream(key)
        if st.done or len(st.samples) >= SAMPLES or fn < st.retry_at:
            return
        st.samples.append(bytes(csdu))
        st.frames.append(fn)
        if len(st.samples) == SAMPLES:
            self.ts = ts
            self._try(st, fn)

    def wants(self, key: tuple, fn: int) -> bool:
        """Frames of this stream from frame ``fn`` on are needed now (the engine hands them over one by one)."""
        if not self.enabled:
            return False
        st = self.streams.get(key)
        return st is None and len(self.streams) < MAX_STREAMS or (st is not None and not st.done
                                                                   and len(st.samples) < SAMPLES
                                                                   and fn >= st.retry_at)

    def missing(self, key: tuple) -> int:
        """Samples a stream still needs before a decision (the engine offers fewer than that in bulk: the
        frame that completes them is handed over on its own, in capture order)."""
        st = self.streams.get(key)
        return SAMPLES - len(st.samples) if st is not None else SAMPLES

    def sampling(self, key: tuple, fn: int) -> bool:
        """Whether a stream known here is collecting samples from frame ``fn`` on (``wants``, and not new)."""
        return key in self.streams and self.wants(key, fn)

    def resumes_at(self, key: tuple) -> int | None:
        """The frame number from which a stream waiting after a failed sampling is needed again."""
        st = self.streams.get(key) if self.enabled else None
        # only while it waits (no samples yet): a stream with its samples, waiting for its partner, needs no frame
        return st.retry_at if st is not None and not st.done and st.retry_at and not st.samples else None

    def _try(self, st: Stream, fn: int) -> None:
        partners = [p for p in self.streams.values() if p is not st and not p.done and len(p.samples) == SAMPLES
                    and p.key[1] == st.key[2] and p.key[2] == st.key[1]]
        if not partners:
            return   # the partner may still come; finish() lists the stream if it never does
        sess = self.a.session
        if sess.has_connect(st.key[1], st.key[2]):
            for s in [st] + partners:   # the session knows (or is learning) this AR: its Connect decides
                s.done, s.samples = True, []
            return
        best = found = None
        for p in partners:
            for out_s, in_s in ((st, p), (p, st)):
                cands = self._layouts(out_s, in_s)
                got = _pick(cands)
                if got is not None and (best is None or got["score"] > best["score"]):
                    best, found = got, cands
        if best is None:
            for s in [st] + partners:
                self._retry(s, fn)
            return
        out_s, in_s = best["out"], best["in"]
        # a device with several encoder submodules (a multi-axis device, two encoder modules in one station): each
        # further layout that overlaps none found so far and has evidence of its own is one more axis -- and fits
        # every profile the first fits (a device has one profile: an IO module's heartbeat word beside an encoder,
        # fitting PS/PSM only, is no second axis of it)
        layouts = [best]
        while len(layouts) < MAX_AXES:
            more = _pick(found, [(b["os"], b["os"] + b["Ls"]) for b in layouts],
                         [(b["oa"], b["oa"] + b["La"]) for b in layouts], best["evidence"]["profiles"])
            if more is None:
                break
            layouts.append(more)
        for k, b in enumerate(layouts):
            res = {"frame": fn, "ts_ns": self.ts, "controller_mac": out_s.key[1], "device_mac": out_s.key[2],
                   "telegram": b["t"], "source": SOURCE, "confidence": b["confidence"], "evidence": b["evidence"],
                   "axis": k,
                   "learnt_from": [min(out_s.frames[0], in_s.frames[0]), max(out_s.frames[-1], in_s.frames[-1])],
                   "streams": [{"frame_id": s.key[0], "src": s.key[1], "dst": s.key[2], "direction": d,
                                "c_sdu_len": len(s.samples[0]), "offset": o, "length": tg.length(b["t"], tdir)}
                               for s, d, tdir, o in ((out_s, "output", "setpoint", b["os"]),
                                                     (in_s, "input", "actual", b["oa"]))]}
            self.results.append(res)
            sess.add_inferred(res)
        for s in (out_s, in_s):
            s.done = True
            s.samples = []

    def _retry(self, s: Stream, fn: int) -> None:
        """Nothing fits these samples: listed (for the --map template) and sampled again later."""
        self._list(s)
        if s.tries >= RETRY_MAX_DOUBLINGS:   # an ordinary IO device's streams: a few samplings, then never again
            s.done, s.samples = True, []
            return
        span = fn - s.frames[0] + 1 if s.frames else SAMPLES
        # the first failure samples again at once: a capture that starts in the AR's start-up has IOPS bad in
        # its first samples (no pause of cycles learnt from nothing); then pauses of 2, 4 ... 32 spans
        pause = 0 if s.tries == 0 else span << min(s.tries, RETRY_MAX_DOUBLINGS)
        s.tries += 1
        s.retry_at = fn + 1 + pause
        s.samples, s.frames = [], []

    def _fail(self, s: Stream) -> None:
        s.done = True
        self._list(s)
        s.samples = []

    def _list(self, s: Stream) -> None:
        if s.samples and self.a.session.lookup(*s.key) is None:
            self.failed[s.key] = {"frame_id": s.key[0], "src": s.key[1], "dst": s.key[2],
                                  "c_sdu_len": len(s.samples[0]), "frames": [s.frames[0], s.frames[-1]]}

    def finish(self) -> None:
        """End of capture: streams that never found a partner or never filled their samples are listed."""
        for s in self.streams.values():
            if not s.done:
                self._fail(s)

    def _layouts(self, out_s: Stream, in_s: Stream) -> list:
        """Every layout of the pair with evidence: dicts of telegram, offsets, lengths, score and evidence."""
        sp_sol, sp_sol_bits = _bit("setpoint", "sign_of_life")
        ac_sol, ac_sol_bits = _bit("actual", "sign_of_life")
        sp_m, sp_m_bits = _bit("setpoint", "mirror")
        ac_m, ac_m_bits = _bit("actual", "mirror")
        S, A = out_s.samples, in_s.samples
        ls, la = min(map(len, S)), min(map(len, A))
        # pair each actual sample with the latest setpoint before it (capture order)
        pairs = []
        j = -1
        for i, f in enumerate(in_s.frames):
            while j + 1 < len(out_s.frames) and out_s.frames[j + 1] < f:
                j += 1
            if j >= 0:
                pairs.append((j, i))
        found = []   # in the order tried
        for t in candidates():
            spo, aco = _offsets(t, "setpoint"), _offsets(t, "actual")
            Ls, La = tg.length(t, "setpoint"), tg.length(t, "actual")
            for os_ in self._placements(S, ls, Ls, spo):
                for oa in self._placements(A, la, La, aco):
                    r = self._evidence(t, S, A, pairs, os_, oa, spo, aco, sp_sol, ac_sol, sp_m, sp_m_bits, ac_m,
                                       ac_m_bits)
                    if r is not None:
                        found.append({"t": t, "os": os_, "oa": oa, "Ls": Ls, "La": La, "score": r[0], "evidence": r[1],
                                      "out": out_s, "in": in_s})
        return found

    @staticmethod
    def _placements(samples, n, L, offs):
        """Offsets where a data object of length L starts a data object and is followed by an IOPS GOOD in every
        sample. A data object starts the C_SDU or follows an IOxS byte (wire.md §2.3): the byte before it is GOOD
        too -- else the 'object' is the tail of a longer one (a PROFIdrive drive's telegram 3 holds STW2 / G1_STW
        and ZSW2 / G1_ZSW ... in the middle of its data; an independent audit found drives judged as encoders)."""
        for o in range(0, n - L):
            if all(c[o + L] == IOPS_GOOD and (o == 0 or c[o - 1] == IOPS_GOOD) for c in samples):
                yield o

    @staticmethod
    def _evidence(t, S, A, pairs, os_, oa, spo, aco, sp_sol, ac_sol, sp_m, sp_m_bits, ac_m, ac_m_bits):
        # gate: the words set no bit the profile they are judged with reserves -- some one profile for all four
        # words (a layout whose words need bits of two profiles is no encoder's); which ones fit is evidence of
        # the profile too (session.profile_for: a PS/PSM encoder found by its control-requested bit 10)
        used = {}
        for sig, samples, base, offs in (("stw2_enc", S, os_, spo), ("g1_stw", S, os_, spo),
                                         ("zsw2_enc", A, oa, aco), ("g1_zsw", A, oa, aco)):
            if sig in offs:
                size = tg.SIGNALS[sig]["size"]
                u = 0
                for c in samples:
                    u |= _word(c, base + offs[sig], size)
                used[sig] = u
        fits = [p for p in tg.PROFILES if not any(u & _reserved_in(sig, p) for sig, u in used.items())]
        if not fits:
            return None
        cls = [_word(c, os_ + spo[sp_sol], 2) >> 12 for c in S]
        dls = [_word(c, oa + aco[ac_sol], 2) >> 12 for c in A]
        sol_s, sol_a = _counting(cls), _counting(dls)
        mirror = 0.0
        if pairs:
            hits = 0
            for j, i in pairs:
                ctrl = any((_word(S[j], os_ + spo[sp_m], 2) >> b) & 1 for b in sp_m_bits)
                creq = [(_word(A[i], oa + aco[ac_m], 2) >> b) & 1 for b in ac_m_bits]
                hits += bool(ctrl and any(creq))
            mirror = hits / len(pairs)
        cont = None
        for name in _CI["positions"]:
            if name in aco:
                size = tg.SIGNALS[name]["size"]
                lo = oa + aco[name] + size - 4   # the low 32 bits (of a 64-bit G1_XIST3 too): same in the plugin
                c = _continuous([_word(x, lo, 4) for x in A], 32)
                if c is not None:
                    cont = max(cont or 0.0, c)
        if min(sol_s, sol_a) < 0.8 and (mirror < 0.9 or max(sol_s, sol_a) < 0.8):
            # no positive evidence from both sides: zeros and constants fit anything, one counting nibble is no
            # encoder's (a drive's STW2 / ZSW2 count alike; in an AR's start-up the IOxS bytes beside a data object
            # with its IOPS still bad make a wrong layout whose other side's words never count), and two steady
            # bits are no mirror (an IO module's outputs and inputs): a mirror counts beside a counting side
            return None
        parts = [sol_s, sol_a, mirror] + ([cont] if cont is not None else [])
        return sum(parts), {"sign_of_life_setpoint": round(sol_s, 2), "sign_of_life_actual": round(sol_a, 2),
                            "control_mirrored": round(mirror, 2),
                            "position_continuous": None if cont is None else round(cont, 2),
                            "profiles": fits, "sign_of_life_hold": _hold(cls), "share": sum(parts) / len(parts)}

    def summary(self) -> dict:
        lookup = self.a.session.lookup   # a Connect later in the capture may have mapped a stream since
        return {"inferred": self.results,
                "not_inferred": [f for k, f in self.failed.items() if lookup(*k) is None]}
