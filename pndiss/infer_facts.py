"""What an encoder telegram looks like in a cyclic frame's content (pndiss/infer.py decides with these): the bit
maps of the inference table (telegrams.json ``content_inference``), the sign-of-life counters and their hold, the
position's continuity -- pure functions of the sampled values, and the facts the plugin's port reads (lua_facts)."""
from __future__ import annotations

from . import telegrams as tg
from .encoder.config import next_ls

SAMPLES = 48          # C_SDUs per stream before a decision
MAX_AXES = 4          # encoder layouts one device's pair of streams may hold (a multi-axis device)
MAX_STREAMS = 256     # streams sampled at once (bounded memory)
SOURCE = "inferred from content"
RETRY_MAX_DOUBLINGS = 6   # samplings after the first: at once, then pauses of span x 2, 4, ... 32

CI = tg.TABLE["content_inference"]
IOPS_GOOD = CI["iops_good"]


def bit_of(direction: str, what: str) -> tuple[str, tuple[int, ...]]:
    """(signal, bit positions over every profile) of a named field of the inference table."""
    sig, name = CI[what][direction]
    pos = set()
    for p in tg.PROFILES:
        for n, shift, _mask in tg.bit_fields(sig, p):
            if n == name:
                pos.add(shift)
    return sig, tuple(sorted(pos))


def reserved(sig: str) -> int:
    """Bits no profile gives a meaning to."""
    m = (1 << (8 * tg.SIGNALS[sig]["size"])) - 1
    for p in tg.PROFILES:
        m &= tg.reserved_mask(sig, p)
    return m


def reserved_in(sig: str, profile: str) -> int:
    """Bits profile ``profile`` gives no meaning to."""
    return tg.reserved_mask(sig, profile)


def candidates() -> list[int]:
    """Telegrams with the sign-of-life words in both directions, standard ones first (table order)."""
    sp_sig, ac_sig = CI["sign_of_life"]["setpoint"][0], CI["sign_of_life"]["actual"][0]
    out = [t for t in sorted(tg.TELEGRAMS, key=lambda t: (t not in tg.STANDARD, t))
           if any(n == sp_sig for n, _ in tg.TELEGRAMS[t]["setpoint"])
           and any(n == ac_sig for n, _ in tg.TELEGRAMS[t]["actual"])]
    return out


def offsets(t: int, direction: str) -> dict:
    return {n: o for n, o in tg.TELEGRAMS[t][direction]}


def word(c: bytes, off: int, size: int) -> int:
    return int.from_bytes(c[off:off + size], "big")


def counting(vals: list[int]) -> float:
    """Share of consecutive sign-of-life values that step 1..15 (or hold: k > 1 controller cycles)."""
    if len(vals) < 2:
        return 0.0
    good = moves = through_zero = 0
    for a, b in zip(vals, vals[1:]):
        through_zero += a == 15 and b == 0
        if a == 0 or b == 0:
            continue
        if b != a:
            moves += 1
        if b == next_ls(a) or b == a:
            good += 1
    if through_zero >= 2:
        return 0.0   # 15 -> 0 -> 1 again and again: a 4-bit counter (an IO module's heartbeat), no sign-of-life
    return good / (len(vals) - 1) if moves >= (len(vals) - 1) // 4 else 0.0


def hold(vals: list[int]) -> int:
    """k: how many consecutive frames the controller holds each sign-of-life value (a controller application cycle
    of k bus cycles, behaviour.md §0.1, R-CLS-4 001_9461bb7bc8c2767b.txt:1671, 1677) -- the longest run between the
    first and the last, 2..14, when at least 40 % of them are that long (capture loss shortens some); else 1. Without it a mid-session capture (the 0x8030
    record that says k is written at start-up) blamed the controller for every hold (an independent audit)."""
    runs, cur, n = [], None, 0
    for v in vals:
        if v == cur:
            n += 1
        else:
            if cur is not None:
                runs.append((cur, n))
            cur, n = v, 1
    inner = [m for v, m in runs[1:] if v != 0]   # (the last run is still open: not in runs)
    if len(inner) < 3:
        return 1
    # a lost frame shortens a run, never lengthens one: k is the longest run, when 40 % of them are that long
    r = max(inner)
    return r if 2 <= r <= 14 and inner.count(r) >= 0.4 * len(inner) else 1


def continuous(vals: list[int], bits: int) -> float | None:
    """Share of small steps; None when the value never changes (a standstill proves nothing)."""
    m = 1 << bits
    if len(vals) < 2 or len(set(vals)) < 2:
        return None
    ok = 0
    for a, b in zip(vals, vals[1:]):
        d = (b - a) % m
        d = d - m if d > m // 2 else d
        ok += abs(d) < (m >> 8)
    return ok / (len(vals) - 1)


def lua_facts() -> dict:
    """What the plugin's port of this module reads (tools/gen_lua.py): the same numbers, computed once."""
    words = ("stw2_enc", "g1_stw", "zsw2_enc", "g1_zsw")
    cands = []
    for t in candidates():
        cands.append({"telegram": t, "setpoint": offsets(t, "setpoint"), "actual": offsets(t, "actual"),
                      "len_setpoint": tg.length(t, "setpoint"), "len_actual": tg.length(t, "actual")})
    return {"samples": SAMPLES, "max_streams": MAX_STREAMS, "max_axes": MAX_AXES, "retry_max_doublings": RETRY_MAX_DOUBLINGS, "source": SOURCE, "iops_good": IOPS_GOOD,
            "reserved": {w: reserved(w) for w in words}, "sizes": {w: tg.SIGNALS[w]["size"] for w in words},
            "profiles": list(tg.PROFILES),
            "reserved_by_profile": {p: {w: reserved_in(w, p) for w in words} for p in tg.PROFILES},
            "sol": {d: bit_of(d, "sign_of_life")[0] for d in tg.DIRECTIONS},
            "mirror": {d: {"signal": bit_of(d, "mirror")[0], "bits": list(bit_of(d, "mirror")[1])} for d in tg.DIRECTIONS},
            "positions": [{"name": n, "size": tg.SIGNALS[n]["size"]} for n in CI["positions"]],
            "candidates": cands}
