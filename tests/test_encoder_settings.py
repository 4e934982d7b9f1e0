"""Settings in force: docs/settings.md lists every setting; resolution order capture > settings > default."""
import dataclasses
import os

from pndiss import telegrams as tg
from pndiss.encoder import EncoderConfig
from pndiss.settings import Settings

DOC = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "docs", "settings.md")


def test_every_setting_is_documented():
    text = open(DOC, encoding="utf-8").read()
    missing = [f.name for f in dataclasses.fields(Settings) if f"`{f.name}`" not in text]
    assert missing == []


def test_resolution_order_and_sources():
    s = Settings(l_max=4, class4=0, st_phys="8192", mt_phys=4096)  # --set delivers strings for None-default fields
    c = EncoderConfig.from_settings(s, profile="lika", telegram=83, bf00={"compat": 0, "class4": 1})
    assert c.l_max == 4 and c.sources["l_max"] == "settings.l_max"
    assert c.class4 == 1 and c.sources["class4"] == "captured 0xBF00"          # capture beats settings
    assert c.compat == 0 and c.st_phys == 8192 and c.modulus == 8192 * 4096
    c2 = EncoderConfig.from_settings(None, profile="hohner", telegram=81)
    assert c2.class4 == tg.PROFILE_DEFAULTS["hohner"]["class4"] == 0 and "default" in c2.sources["class4"]
    shown = c.in_force()
    assert shown["D_preset"]["value"] == 10 + 4 and shown["SOLMON"]["value"] is False


def test_solmon_and_threshold_choices():
    c = EncoderConfig(profile="scancon", telegram=81, iso=True, compat=0)
    assert not c.solmon                    # SCANCON monitors only with compat = 1 (§3.1 R-CLS-5)
    c.compat = 1
    assert c.solmon and c.n_sol == 1
    c = EncoderConfig(profile="lika", telegram=860, iso=True)
    assert not c.solmon                    # no sign-of-life in telegram 860 (§2.5 R-P860-3)
    c = EncoderConfig(profile="lika", telegram=81, compat=0, max_master_sol_failures=3, cycle_ns=250_000)
    assert c.n_sol == 3 and c.d_preset == 40 + 2
