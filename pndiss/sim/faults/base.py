"""The kinds of injection the fault families build on, and ``register``, which makes a fault of a
known kind from one table row (the families declare their same-shape faults as tables)."""
from __future__ import annotations

from ..scenarios import Injection, injectable

SOL_SETTINGS = {"sol_monitor_rt": True}   # SOLMON outside isochronous mode (behaviour.md §3.1 R-CLS-5)


def register(kind: type, rule: str, **attrs) -> type:
    """The injection for ``rule``: a ``kind`` with these class attributes (``why``, ``word``, ...)."""
    return injectable(rule)(type("".join(p.capitalize() for p in rule.split("-")), (kind,), attrs))


def alter(words: dict, word: str, keep: int, set_: int) -> None:
    """``words[word] & keep | set_``; keep 0 replaces the word, which then need not be there yet."""
    words[word] = set_ if keep == 0 else words[word] & keep | set_


class ScenarioFault(Injection):
    """A fault that shapes its scenario: ``knobs`` (scenario attribute -> value) are set before the run."""

    knobs: dict = {}

    def setup(self, sess, sc, params):
        for name, value in self.knobs.items():
            setattr(sc, name, value)


class Cyclic(Injection):
    """A fault in the words of one side during cycles k .. k+n-1 (first encoder)."""

    n = 1
    where = "enc"      # "enc": the encoder's actual values; "plc": the controller's setpoint

    def active(self, k, st):
        return st.i == 0 and self.k <= k < self.k + self.n

    def after_plc(self, sess, k, st, out, tags):
        if self.where == "plc" and self.active(k, st):
            if self.change(out, k) is not False:
                tags.add(self.tag)

    def after_enc(self, sess, k, st, actual, tags):
        if self.where == "enc" and self.active(k, st):
            if self.change(actual, k) is not False:
                tags.add(self.tag)

    def change(self, words, k):
        raise NotImplementedError


class Bits(Cyclic):
    """Cycles k .. k+n-1: one word changed, ``word & keep | set_``."""

    word = ""
    keep = -1
    set_ = 0

    def change(self, words, k):
        alter(words, self.word, self.keep, self.set_)


class WhileZsw(Injection):
    """While G1_ZSW of the first encoder has a bit of ``when`` set: one word changed
    (``word & keep | set_``; no ``word``: the frame is only tagged)."""

    when = 0
    word = None
    keep = -1
    set_ = 0

    def after_enc(self, sess, k, st, actual, tags):
        if st.i == 0 and actual["g1_zsw"] & self.when:
            if self.word:
                alter(actual, self.word, self.keep, self.set_)
            tags.add(self.tag)


class AckKept(Injection):
    """The encoder keeps G1_ZSW bit ``ack`` for 20 cycles after the PLC's G1_STW bit ``request``
    falls (first encoder)."""

    request = ack = 0

    def setup(self, sess, sc, params):
        self.seen, self.fall = False, None

    def after_plc(self, sess, k, st, out, tags):
        if st.i == 0:
            if out["g1_stw"] & self.request:
                self.seen = True
            elif self.seen and self.fall is None:
                self.fall = k

    def after_enc(self, sess, k, st, actual, tags):
        if st.i == 0 and self.fall is not None and k < self.fall + 20:
            actual["g1_zsw"] |= self.ack
            tags.add(self.tag)


class Knob(Injection):
    """A fault switched on in the PLC or encoder model at cycle k; tags frames while ``flagged``."""

    where = "enc"

    def before_cycle(self, sess, k, st, plc, enc, last_in):
        if st.i == 0 and k == self.k:
            self.turn_on(sess, plc, enc)

    def turn_on(self, sess, plc, enc):
        raise NotImplementedError

    def flagged(self, k, words) -> bool:
        return False

    def after_plc(self, sess, k, st, out, tags):
        if self.where == "plc" and st.i == 0 and k >= self.k and self.flagged(k, out):
            tags.add(self.tag)

    def after_enc(self, sess, k, st, actual, tags):
        if self.where == "enc" and st.i == 0 and k >= self.k and self.flagged(k, actual):
            tags.add(self.tag)
