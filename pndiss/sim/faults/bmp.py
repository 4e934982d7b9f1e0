"""Base mode parameter access faults (0xB02E / 0xB02F, records.md §3): one extra access by the first
encoder's controller at cycle k, the request or the device's answer broken."""
from __future__ import annotations

from ...records import build as B
from .. import recdata
from ..scenarios import Injection, injectable
from .base import register


class _Bmp(Injection):
    """One extra parameter access at cycle k (built by ``access(sess, st, ts, dev)``)."""

    def setup(self, sess, sc, params):
        sc.bmp_extra.append(self)

    def access(self, sess, st, ts, dev):
        raise NotImplementedError

    def exchange(self, sess, st, ts, req_id, items, res_id, blocks, tags=None):
        """A request (``items`` as recdata.param_request takes them) and the response (``blocks``) under
        a new request reference; both tagged with the fault unless ``tags`` is given."""
        ref = sess.next_ref()
        req = recdata.param_request(ref, req_id, items)
        sess.bmp(ts, st, req, recdata.param_response(ref, res_id, blocks), tags={self.tag} if tags is None else tags)


class _Exchange(_Bmp):
    """The fault is one exchange: ``message(dev)`` -> (request ID, items, response ID, blocks)."""

    def access(self, sess, st, ts, dev):
        self.exchange(sess, st, ts, *self.message(dev))


def _one(rule: str, why: str, message, **more) -> type:
    return register(_Exchange, rule, why=why, message=staticmethod(message), **more)


_one("P965-VERSION-MISMATCH",
     "a read of P965 subindex 1 (profile version) answers 31 while 0xBF00 selects V4.1 (compat = 1)",
     lambda dev: (1, [(965, 1, 0, None, 0x1F)], 1, [(0x1F, ["1f"])]))
_one("BMP-ILLEGAL-REQID-RESPONSE",
     "request ID 0x05 (illegal); the device answers 0x81 / error 0x16 instead of 0x80 / 0x21",
     lambda dev: (5, [(922, 0, 0, None, 0x06)], 0x81, [(0x44, [0x16])]),
     also=("BMP-BAD-REQUEST", "BMP-RESPID-MISMATCH"))
_one("BMP-NEG-FORMAT", "a negative response carries error number 0x0116 (the high byte is reserved, max 0x00FF)",
     lambda dev: (1, [(922, 0, 0, None, 0x06)], 0x81, [(0x44, [0x0116])]))
_one("BMP-WRITE-RO-ACCEPTED", "the device accepts a change of read-only P922",
     lambda dev: (2, [(922, 0, 0, [dev["telegram"]], 0x06)], 2, [(0x40, [])]),
     profile="lika")   # the read-only list is Lika's (000_37bf2397999f1108.txt:1953-2164)
_one("BMP-PRESET-LIMIT-ACCEPTED", "the device accepts P65000 = total measuring range + 1000",
     lambda dev: (2, [(65000, 0, 0, [dev["tmr"] + 1000], 0x43)], 2, [(0x40, [])]))
_one("BMP-DATATYPE", "the device answers a P922 read (Unsigned16) with format Unsigned32",
     lambda dev: (1, [(922, 0, 0, None, 0x06)], 1, [(0x07, [dev["telegram"]])]))
_one("BMP-PROFILE-PARAM-UNREADABLE", "a read of P979 after run-up is refused with error 0x11",
     lambda dev: (1, [(979, 0, 6, None, 0x07)], 0x81, [(0x44, [0x11])]))


@injectable("BMP-CLASS4-WRITE-ACCEPTED")
class BmpClass4WriteAccepted(_Exchange):
    why = "class 4 disabled in 0xBF00, the device accepts a P65000 change"
    also = ("PRESET-CLASS4-DISABLED",)
    message = staticmethod(lambda dev: (2, [(65000, 0, 0, [1000], 0x43)], 2, [(0x40, [])]))

    def setup(self, sess, sc, params):
        super().setup(sess, sc, params)
        params["class4"] = 0


@injectable("BMP-UNKNOWN-PNU")
class BmpUnknownPnu(_Bmp):
    why = "the device answers a read of P12345 (not in its P980 list) with a value"

    def access(self, sess, st, ts, dev):
        sess.read_param(ts - 10_000_000, st, 980, dev)
        self.exchange(sess, st, ts, 1, [(12345, 0, 0, None, 0x06)], 1, [(0x06, [7])])


@injectable("P971-NOT-CONFIRMED")
class P971NotConfirmed(_Bmp):
    why = "after P971 := 1 every later read of P971 still returns 1"
    profile = "lika"   # P971 store semantics are Lika's (000_37bf2397999f1108.txt:1975-1982)

    def access(self, sess, st, ts, dev):
        self.exchange(sess, st, ts, 2, [(971, 0, 0, [1], 0x06)], 2, [(0x40, [])], tags=())
        d = dict(dev, p971=1)
        sess.read_param(ts + 20_000_000, st, 971, d, tags={self.tag})
        sess.read_param(ts + 60_000_000, st, 971, d, tags={self.tag})


class BmpOrder(_Bmp):  # not injectable: see NOT_INJECTABLE["BMP-ORDER"]
    why = "a two-parameter read (P922, P979) is answered in reverse order"
    also = ("BMP-DATATYPE", "TELEGRAM-SELECTION-MISMATCH")   # blocks are paired by position

    def access(self, sess, st, ts, dev):
        f1, v1 = recdata.read_block(922, dev, sess.cfg.profile)
        f2, v2 = recdata.read_block(979, dev, sess.cfg.profile)
        self.exchange(sess, st, ts, 1, [(922, 0, 0, None, f1), (979, 0, len(v2), None, f2)],
                      1, [(f2, v2), (f1, v1)])


@injectable("BMP-BAD-REQUEST")
class BmpBadRequest(_Bmp):
    why = "the controller requests attribute 0x50 (reserved); the device answers error 0x16"

    def access(self, sess, st, ts, dev):
        ref = sess.next_ref()
        req = B.build_param_request(ref, 1, [{"pnu": 922, "attribute": 0x50}], axis=1)
        sess.bmp(ts, st, req, recdata.param_response(ref, 0x81, [(0x44, [0x16])]), tags={self.tag})


@injectable("BMP-PIPELINED")
class BmpPipelined(_Bmp):
    why = "the controller writes a second parameter request before reading the first response"
    also = ("BMP-NOT-MIRRORED", "BMP-DATATYPE")   # responses then pair with the wrong request

    def access(self, sess, st, ts, dev):
        r1, r2 = sess.next_ref(), sess.next_ref()
        q1 = recdata.param_request(r1, 1, [(922, 0, 0, None, 0x06)])
        q2 = recdata.param_request(r2, 1, [(965, 0, 0, None, 0x06)])
        f1, v1 = recdata.read_block(922, dev, sess.cfg.profile)
        f2, v2 = recdata.read_block(965, dev, sess.cfg.profile)
        sess.write_record(ts, st, 0xB02E, q1, what="bmp.write")
        sess.write_record(ts + 1_000_000, st, 0xB02E, q2, what="bmp.write", tags={self.tag})
        sess.read_record(ts + 2_000_000, st, 0xB02E, recdata.param_response(r1, 1, [(f1, v1)]), what="bmp.read")
        sess.read_record(ts + 3_000_000, st, 0xB02E, recdata.param_response(r2, 1, [(f2, v2)]), what="bmp.read")


# ------------------------------------------------------------------------ request references

@injectable("BMP-REQREF-ZERO")
class BmpReqrefZero(_Bmp):
    why = "the controller sends a parameter request with request reference 0"

    def access(self, sess, st, ts, dev):
        sess.read_param(ts, st, 922, dev, tags={self.tag}, ref=0)


@injectable("BMP-REQREF-NOT-CHANGED")
class BmpReqrefNotChanged(_Bmp):
    why = "the controller reuses the previous request reference"

    def access(self, sess, st, ts, dev):
        sess.read_param(ts, st, 922, dev)
        sess.read_param(ts + 5_000_000, st, 965, dev, tags={self.tag}, ref=sess.bmp_ref)


@injectable("BMP-NOT-MIRRORED")
class BmpNotMirrored(_Bmp):
    why = "the device answers with a different request reference"

    def access(self, sess, st, ts, dev):
        ref = sess.next_ref()
        f, v = recdata.read_block(922, dev, sess.cfg.profile)
        sess.read_param(ts, st, 922, dev, tags={self.tag}, ref=ref,
                        response=recdata.param_response((ref + 1) & 0xFF or 1, 1, [(f, v)]))


@injectable("BMP-RESPID-MISMATCH")
class BmpRespidMismatch(_Bmp):
    why = "the device answers a read request with response ID 0x02 (positive change, no values)"

    def access(self, sess, st, ts, dev):
        ref = sess.next_ref()
        sess.read_param(ts, st, 922, dev, tags={self.tag}, ref=ref, response=bytes([ref, 2, 1, 1]))
