"""A tiny table-driven harness for the sans-IO reference encoder (no pcap needed).

A scenario is a list of rows; each row is one cycle written as
``"<setpoint signals> | <actual signals>"`` in the telegram's signal order (int(x, 0), so
``0x1400`` or ``5000``), optionally as ``(row, repeat)``. A row may also be a dict event
(``record`` / ``param``) fed to on_record at that point. ``run`` returns the violation events.
"""
from __future__ import annotations

from pndiss import telegrams as tg
from pndiss.encoder import Checker, EncoderConfig
from pndiss.settings import Settings

BASE = dict(profile="lika", telegram=81, compat=1, class4=1, st_phys=8192, mt_phys=4096, l_max=2, shift=0,
            p65000=0, preset_control=None)   # the tables state the preset value (the factory 0); tests/
# test_encoder_rules.py: unknown; preset_control None = the vendor's coding, given as a captured 0xBF00 would


def make_cfg(**kw) -> EncoderConfig:
    d = dict(BASE)
    d.update(kw)
    if d["compat"] is None:   # left open, as without a captured 0xBF00: the checker learns it from the words
        del d["compat"]
    prof = d.pop("profile")
    tel = d.pop("telegram")
    c = EncoderConfig.from_settings(Settings(), profile=prof, telegram=tel)
    for k, v in d.items():
        setattr(c, k, v)
        c.sources[k] = "settings.test table"   # given, as --set would (compat given: #13-#16 judged from the first cycle)
    return c


def parse(row: str, telegram: int) -> tuple[dict, dict]:
    left, right = row.split("|")
    sp_names = tg.layout(telegram, "setpoint").names
    ac_names = tg.layout(telegram, "actual").names
    sp = dict(zip(sp_names, (int(x, 0) for x in left.split())))
    ac = dict(zip(ac_names, (int(x, 0) for x in right.split())))
    return sp, ac


def expand(rows):
    for r in rows:
        if isinstance(r, tuple):
            for _ in range(r[1]):
                yield r[0]
        else:
            yield r


def run(rows, prev_bf00=None, **cfg_kw) -> list[dict]:
    cfg = make_cfg(**cfg_kw)
    chk = Checker(cfg)
    chk.prev_bf00 = prev_bf00
    out = []
    cache = {}
    for i, r in enumerate(expand(rows)):
        if isinstance(r, dict):
            out += chk.on_record(dict(r, frame=i, ts_ns=i))
            continue
        if r not in cache:  # identical rows give identical dicts, like the tracker's decode cache
            cache[r] = parse(r, cfg.telegram)
        sp, ac = cache[r]
        out += chk.cycle(i, i * 1000, sp, ac)
    out += chk.finish()
    return [e for e in out if e["kind"] == "violation"]


def rule_ids(rows, **kw) -> set[str]:
    return {e["rule"] for e in run(rows, **kw)}


def sol_rows(cls, dls, g1stw="0x2000", g1zsw="0x2000", x="5 5", ctrl=True, zextra=0x0200):
    """Rows for sign-of-life tests: one cycle per (C-LS, DO-LS) pair."""
    rows = []
    for c, d in zip(cls, dls):
        stw2 = (c << 12) | (0x0400 if ctrl else 0)
        zsw2 = (d << 12) | zextra
        rows.append(f"{stw2:#x} {g1stw} | {zsw2:#x} {g1zsw} {x}")
    return rows
