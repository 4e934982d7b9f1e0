"""Start-up faults in the records and the telegram: no 0xBF00, a faulty 0xBF00, a Connect whose
input length fits no telegram, a P922 answer that names another telegram."""
from __future__ import annotations

from ..scenarios import Injection, injectable
from .base import register


@injectable("TELEGRAM-LENGTH-MISMATCH")
class TelegramLengthMismatch(Injection):
    why = "the Connect configures 3 more input bytes than the telegram has (15, no telegram has that; P922 says 81)"
    side = "encoder"

    def setup(self, sess, sc, params):
        from ..stations import Station
        sess.stations = [Station(i, sess.cfg, sess.rng, extra_in=3) for i in range(sess.cfg.encoders)]
        sc.connect_tags = {self.tag}


@injectable("TELEGRAM-SELECTION-MISMATCH")
class TelegramSelectionMismatch(Injection):
    why = "a P922 read answers telegram 82 while 81 is configured"

    def setup(self, sess, sc, params):
        sc.param_override[922] = (lambda d: dict(d, telegram=d["telegram"] + 1), {self.tag})


@injectable("STARTUP-NO-PARAM-RECORD")
class StartupNoParamRecord(Injection):
    why = "the controller starts cyclic data exchange without writing 0xBF00"

    def setup(self, sess, sc, params):
        sc.skip_bf00 = True
        sc.first_cyclic_tags = {self.tag}


class _Bf00Fault(Injection):
    """A faulty 0xBF00 record; the conforming encoder reports parameterisation error 0x1002 in
    G1_XIST2 and a 0x9011 channel diagnosis (cyclic.md §9, 000_37bf2397999f1108.txt:2605-2639)."""

    reject = True
    bad = {}

    def setup(self, sess, sc, params):
        vals = dict(params)
        vals.update(self.bad)
        from .. import recdata
        sc.bf00_bytes = recdata.bf00(sess.cfg.profile, **vals)
        sc.bf00_tags = {self.tag}
        sc.reject_bf00 = self.reject


# (rule, how, the 0xBF00 values changed, further attributes)
for _rule, _why, _bad, _more in (
    ("BF00-LENGTH", "the controller writes a 30-byte 0xBF00 (31 expected)", {"length": 30}, {}),
    ("BF00-RESERVED-NONZERO", "the controller writes 0xBF00 with reserved byte 25 = 0x55",
     {"reserved_bytes": bytes(6) + b"\x55"}, {}),
    ("BF00-VALUE-OUT-OF-RANGE", "the controller writes 0xBF00 with velocity unit 9 (0..3 allowed)",
     {"velocity_unit": 9}, {}),
    ("BF00-ERROR-NOT-REPORTED",
     "an invalid 0xBF00 (velocity unit 9) is followed by normal data exchange without an error",
     {"velocity_unit": 9}, dict(reject=False, also=("BF00-VALUE-OUT-OF-RANGE",))),
    ("BF00-VALID-REJECTED", "a valid 0xBF00 is answered with parameterisation error 0x1002 and a 0x9011 diagnosis",
     {}, {}),
):
    register(_Bf00Fault, _rule, why=_why, bad=_bad, **_more)
