"""Position arithmetic of behaviour.md §4: raw -> scaled -> offset -> aligned, and the preset.

Plain integer functions shared by the checker (to predict what the encoder must show after a
preset) and by the device model (to produce it). ``R`` is the output modulus (§4.1).
"""
from __future__ import annotations

U32 = 1 << 32


def scaled(raw: int, *, direction: int = 0, class4: int = 1, scaling: int = 0, mupr: int | None = None,
           tmr: int | None = None, st_phys: int | None = None, mt_phys: int | None = None) -> int:
    """Output before the offset, s (§4.2 steps 1-3, [INFERENCE] formulas of the spec)."""
    tot = (st_phys or 0) * (mt_phys or 0)
    if class4 and direction and tot:  # step 2: code sequence reverses the count
        raw = (tot - raw) % tot
    if class4 and scaling and mupr and tmr and st_phys:  # step 3: software scaling
        return (raw * mupr // st_phys) % tmr
    return raw


def with_offset(s: int, offset: int, R: int | None) -> int:
    """pos = (s + offset) mod R (§4.2 step 4)."""
    return (s + offset) % R if R else (s + offset) % U32


def aligned_xist1(pos: int, shift: int = 0) -> int:
    """G1_XIST1 = pos << P979.3, 32 bits (§4.2 step 6; SCANCON 4.0 left alignment §1.6 R-X1-2)."""
    return (pos << shift) % U32


def preset_offset(mode: int, P: int, s_now: int, offset: int, R: int | None) -> int:
    """New offset: absolute (mode 0) makes pos = P; relative (mode 1) shifts by P (§4.3)."""
    m = R or U32
    return (P - s_now) % m if mode == 0 else (offset + P) % m


def expected_after_preset(mode: int, P: int, pos_before: int, R: int | None) -> int:
    """Position in the first frame with PDONE = 1 (§4.3, §9.3 #27): P, or pos_before + P."""
    m = R or U32
    return P % m if mode == 0 else (pos_before + P) % m


# [INFERENCE] The manuals' encoders count in binary: single-turn 13/14/16 bits, multi-turn 12-16 bits
# (network.md §1.11: "25 Bit", "27 Bit", ...; XAC77 16384 x 16384). Without scaling, and without
# --set st_phys/mt_phys, the output wraps at 2^k for an unknown k of at least this many bits.
MIN_RANGE_BITS = 12


def fits_binary_range(actual: int, exp: int, seen: tuple, tol: int) -> bool:
    """Does ``actual`` equal ``exp`` (+- tol) modulo 2^k for some hardware range 2^k above every position
    in ``seen``? (A relative preset across the unknown range end of an unscaled encoder.)"""
    lo = max(MIN_RANGE_BITS, max(seen).bit_length())
    for k in range(lo, 32):
        m = 1 << k
        if abs(delta(exp % m, actual, m)) <= tol:
            return True
    return False


def preset_860(PV: int, R: int | None) -> int:
    """Telegram 860 preset: absolute, clamped to R - 1 (SCANCON 001_9461bb7bc8c2767b.txt:931, §4.3)."""
    return min(PV, R - 1) if R else PV


def delta(a: int, b: int, m: int) -> int:
    """Signed shortest difference b - a modulo m (continuity across the TMR-1 <-> 0 wrap, §4.2)."""
    d = (b - a) % m
    return d - m if d > m // 2 else d
