"""Record / parameter rules (behaviour.md §9.9 #65-71, 75; §9.10 BMP-*): record and param events
as the session helper emits them, fed to the checker with a few cycles around them."""
import pytest

from encoder_table import rule_ids, run

G = "0x1400 0x2000 | 0x1200 0x2000 5 5"
BAD_CODE = "0x1400 0x2000 | 0x1200 0x8000 5 0x1002"


def param(pnu, values=(), *, change=False, error=None, sub=0, ref=1, rid=None, qid=None, pairing=(), fmt=None, more=()):
    p = {"pnu": pnu, "subindex": sub, "values": [] if change else list(values), "error": error,
         "format_name": fmt, "attribute": 0x10}
    if change:
        p["written"] = {"values": list(values)}
    ev = {"kind": "param", "request_id": "change parameter" if change else "request parameter",
          "request_id_code": qid if qid is not None else (2 if change else 1), "request_ref": ref,
          "response_id": rid if rid is not None else ((0x82 if change else 0x81) if error else (2 if change else 1)),
          "ok": error is None, "params": [p, *more], "pairing": list(pairing)}
    return ev


def bf00(decoded=None, data="00" * 31, length=31):
    return {"kind": "record", "op": "write", "index": 0xBF00, "length": length, "data": data,
            "decoded": decoded if decoded is not None else {"compat": 1, "class4": 1, "mupr": 8192, "tmr": 8192 * 4096,
                                                             "problems": []}}


ERR = lambda code: {"code": code, "text": "x"}  # noqa: E731


def neg(pnu, fmt, n):
    """A negative response to a read of ``pnu`` whose one block has format ``fmt`` and ``n`` values."""
    ev = param(pnu, error=ERR(0x00) if fmt == 0x44 and n else None, rid=0x81)
    ev["params"][0].update(format=fmt, no_of_values=n)
    return ev

CASES = [
    ("TELEGRAM-SELECTION-MISMATCH", {}, [param(922, [83]), G], [param(922, [81]), G]),
    ("P965-VERSION-MISMATCH", {}, [param(965, ["001f"], sub=1), G], [param(965, ["0029"], sub=1), G]),
    ("P965-VERSION-MISMATCH", dict(compat=0), [param(965, [41], sub=1), G], [param(965, [31], sub=1), G]),
    # the whole octet string 2 at subindex 0: byte 1 is the version (records.md §4.3), as 0x1F/0x29 or as hex digits
    ("P965-VERSION-MISMATCH", {}, [param(965, ["3d1f"], sub=0), G], [param(965, ["3d29"], sub=0), G]),
    ("P965-VERSION-MISMATCH", {}, [param(965, ["3d31"], sub=0), G], [param(965, ["3d41"], sub=0), G]),
    ("P965-VERSION-MISMATCH", {}, [param(965, ["3d1f"], sub=0), G], [param(965, ["003d"], sub=0), G]),  # byte 0 only
    ("BF00-LENGTH", {}, [bf00({"problems": [{"rule": "BF00-LENGTH", "message": "30 bytes"}]}, length=30), G], [bf00(), G]),
    ("BF00-LENGTH", {}, [bf00({}, data="00" * 30, length=30), G], [bf00({}), G]),             # own check
    ("BF00-RESERVED-NONZERO", {}, [bf00({}, data="c0" + "00" * 30), G], [bf00({}), G]),
    ("BF00-VALUE-OUT-OF-RANGE", {}, [bf00({"mupr": 0, "tmr": 100}), G], [bf00({"mupr": 100, "tmr": 100}), G]),
    ("BF00-ERROR-NOT-REPORTED", {}, [bf00({"mupr": 0}), (G, 15)], [bf00({"mupr": 0}), G, (BAD_CODE, 3)]),
    ("BF00-VALID-REJECTED", {}, [bf00(), G, BAD_CODE], [bf00(), G, G]),
    ("PRESET-CLASS4-DISABLED", dict(class4=0), [param(65000, [10], change=True, error=ERR(0x11)), G],
     [param(65001, [1]), G]),
    ("PRESET-WITHOUT-NEW-PARAMS", dict(prev_bf00={"mupr": 4096, "tmr": 4096 * 4096, "direction": 0}),
     [bf00(), (G, 3)], [bf00(), G, "0x1400 0x3000 | 0x1200 0x2000 5 5", "0x1400 0x3000 | 0x1200 0x3000 0 0"]),
    ("BMP-PIPELINED", {}, [param(922, [81], pairing=["request(s) in frame(s) 3 overwritten before their response was read"])],
     [param(922, [81])]),
    ("BMP-REQREF-ZERO", {}, [param(922, [81], ref=0)], [param(922, [81], ref=7)]),
    ("BMP-REQREF-NOT-CHANGED", {}, [param(922, [81], ref=5), param(922, [81], ref=5)],
     [param(922, [81], ref=5), param(922, [81], ref=6)]),
    ("BMP-ILLEGAL-REQID-RESPONSE", {}, [param(922, qid=5, rid=0x81, error=ERR(0x21))],
     [param(922, qid=5, rid=0x80, error=ERR(0x21))]),
    ("BMP-NOT-MIRRORED", {}, [param(922, [81], pairing=["request ref mismatch (request 0x01, response 0x02)"])],
     [param(922, [81])]),
    ("BMP-RESPID-MISMATCH", {}, [param(922, error=ERR(0x00), rid=0x01)], [param(922, error=ERR(0x00))]),
    # 84: the pairer's note that the blocks are out of request order; P922's "value" is then not judged
    ("BMP-ORDER", {}, [param(922, [20753], pairing=["value blocks not in request order (elements requested [1, 6], "
                                                     "values answered [6, 1])"])], [param(922, [81])]),
    ("BMP-NEG-FORMAT", {}, [param(922, error=ERR(0x123))], [param(922, error=ERR(0x23))]),
    # an error entry is format 0x44 with 1 or 2 values (001_9461bb7bc8c2767b.txt:1970-1978)
    ("BMP-NEG-FORMAT", {}, [neg(1234, 0x44, 3)], [neg(1234, 0x44, 2)]),
    ("BMP-NEG-FORMAT", {}, [neg(1234, 0x44, 0)], [neg(1234, 0x44, 1)]),
    ("BMP-NEG-FORMAT", {}, [neg(1234, 0x42, 1)], [neg(1234, 0x44, 1)]),
    ("BMP-MULTI-NOT-ABORTED", {},
     [param(65000, [1], change=True, error=ERR(0x05), more=[{"pnu": 971, "subindex": 0, "values": [], "error": None}])],
     [param(65000, [1], change=True, error=ERR(0x05), more=[{"pnu": 971, "subindex": 0, "values": [], "error": ERR(0x05)}])]),
    ("BMP-WRITE-RO-ACCEPTED", {}, [param(922, [81], change=True)], [param(922, [81], change=True, error=ERR(0x01))]),
    # "greater than the total measuring range" (001_9461bb7bc8c2767b.txt:847): R itself is accepted silently
    ("BMP-PRESET-LIMIT-ACCEPTED", {}, [param(65000, [(1 << 25) + 1], change=True)], [param(65000, [1 << 25], change=True)]),
    ("BMP-UNKNOWN-PNU", {}, [param(980, [922, 65000]), param(1234, [1])], [param(980, [922, 65000]), param(1234, error=ERR(0x00))]),
    ("BMP-DATATYPE", {}, [param(65000, [1], fmt="Integer32")], [param(65000, [1], fmt="Unsigned32")]),
    ("P971-NOT-CONFIRMED", {}, [param(971, [1], change=True), param(971, [1]), param(971, [1])],
     [param(971, [1], change=True), param(971, [1]), param(971, [0])]),
    ("BMP-CLASS4-WRITE-ACCEPTED", dict(class4=0), [param(65000, [1], change=True)],
     [param(65000, [1], change=True, error=ERR(0x11))]),
    ("BMP-PROFILE-PARAM-UNREADABLE", {}, [param(922, error=ERR(0x11))], [param(922, [81])]),
]


@pytest.mark.parametrize("rule,cfg,bad,good", CASES, ids=[f"{c[0]}-{i}" for i, c in enumerate(CASES)])
def test_record_rule(rule, cfg, bad, good):
    assert rule in rule_ids(bad, **cfg)
    assert rule not in rule_ids(good, **cfg)


def test_bmp_bad_request_from_record():
    rec = {"kind": "record", "op": "write", "index": 0xB02E,
           "decoded": {"kind": "parameter request", "request_id": 0x05, "no_of_parameters": 1, "length": 10,
                       "params": [{"attribute": 0x11, "count": 0, "pnu": 0, "subindex": 0}]}}
    ok = {"kind": "record", "op": "write", "index": 0xB02E,
          "decoded": {"kind": "parameter request", "request_id": 0x01, "no_of_parameters": 1, "length": 10,
                      "params": [{"attribute": 0x10, "count": 0, "pnu": 922, "subindex": 0}]}}
    ev = run([rec])
    assert [e["rule"] for e in ev] == ["BMP-BAD-REQUEST"]
    assert "request ID 0x05" in ev[0]["message"] and "PNU 0" in ev[0]["message"] and "attribute 0x11" in ev[0]["message"]
    assert run([ok]) == []


def test_p65000_write_sets_preset_value_for_the_arithmetic():
    # LIKA worked example (behaviour.md §4.4 #1): pos 5000, P65000 = 1000, relative -> 6000
    pre = [param(65000, [1000], change=True), "0x1400 0x2000 | 0x1200 0x2000 5000 5000",
           "0x1400 0x2000 | 0x1200 0x2000 5000 5000", "0x1400 0x3800 | 0x1200 0x2000 5000 5000"]
    assert "PRESET-VALUE-WRONG" not in rule_ids(pre + ["0x1400 0x3800 | 0x1200 0x3000 6000 6000"])
    assert "PRESET-VALUE-WRONG" in rule_ids(pre + ["0x1400 0x3800 | 0x1200 0x3000 1000 1000"])


def test_global_access_of_another_encoder_is_not_applied():
    """A global access (0xB02F) on a device with several encoder modules (the session marks it do_unknown): its
    DO-ID may name another encoder, so its P65000 / P922 values are not this axis' -- no preset judged on 5000, no
    P922 mismatch -- while what holds for every axis of the profile still is (an independent audit: false
    PRESET-VALUE-WRONG and TELEGRAM-SELECTION-MISMATCH on slot 1 from DO 2's parameters)."""
    other = lambda ev: dict(ev, do_unknown=True)   # noqa: E731
    pre = [other(param(65000, [5000], change=True)), "0x1400 0x2000 | 0x1200 0x2000 5000 5000",
           "0x1400 0x2000 | 0x1200 0x2000 5000 5000", "0x1400 0x3800 | 0x1200 0x2000 5000 5000"]
    assert "PRESET-VALUE-WRONG" not in rule_ids(pre + ["0x1400 0x3800 | 0x1200 0x3000 0 0"])
    assert "TELEGRAM-SELECTION-MISMATCH" not in rule_ids([G, other(param(922, [83])), G])
    assert "TELEGRAM-SELECTION-MISMATCH" in rule_ids([G, param(922, [83]), G])
    assert "BMP-WRITE-RO-ACCEPTED" in rule_ids([G, other(param(922, [81], change=True)), G], profile="lika")


def test_undecodable_response_judges_no_parameter():
    """A response whose value blocks did not decode (profidrive.undecodable_response: paired, its parameters have no
    block): no parameter's result is known -- a negative change of read-only P979 or of P65000 beyond the range is
    no "answered positively", an error 0x00 no unknown PNU answered otherwise; a P65000 change leaves P65000 unknown
    (a review: false BMP-WRITE-RO-ACCEPTED / BMP-PRESET-LIMIT-ACCEPTED / BMP-UNKNOWN-PNU)."""
    def undecodable(ev):
        ev = dict(ev, decode_error="profidrive: values truncated", ok=False)
        ev["params"] = [dict(p, values=[], error=None, format_name=None) for p in ev["params"]]
        return ev
    for ev in (param(979, [5], change=True, rid=0x82), param(65000, [1 << 26], change=True, rid=0x82),
               param(1234, rid=0x81)):
        assert not rule_ids([G, undecodable(ev), G], profile="lika")
    pre = [param(65000, [1000], change=True), undecodable(param(65000, [5000], change=True)),
           "0x1400 0x2000 | 0x1200 0x2000 5000 5000", "0x1400 0x2000 | 0x1200 0x2000 5000 5000",
           "0x1400 0x3800 | 0x1200 0x2000 5000 5000"]
    assert "PRESET-VALUE-WRONG" not in rule_ids(pre + ["0x1400 0x3800 | 0x1200 0x3000 6000 6000"])
    assert "PRESET-VALUE-WRONG" not in rule_ids(pre + ["0x1400 0x3800 | 0x1200 0x3000 10000 10000"])


def test_bf00_in_force_reconfigures_the_checker():
    # a captured 0xBF00 with compat = 0 switches CREQ to 'held at 0' (behaviour.md §2.2)
    rows = [bf00({"compat": 0, "problems": []}), "0x1400 0x2000 | 0x1200 0x2000 5 5"]
    assert "CTRLREQ-SET-IN-COMPAT" in rule_ids(rows)
    assert "CTRLREQ-SET-IN-COMPAT" not in rule_ids(rows[1:])


def _attr(ev, attribute):
    for p in ev["params"]:
        p["attribute"] = attribute
    return ev


PRESET_REL = ["0x1400 0x2000 | 0x1200 0x2000 5000 5000", "0x1400 0x2000 | 0x1200 0x2000 5000 5000",
              "0x1400 0x3800 | 0x1200 0x2000 5000 5000", "0x1400 0x3800 | 0x1200 0x3000 6000 6000"]


def test_description_read_is_not_the_value():
    """A description (attribute 0x20) or text (0x30) read answers with other octets than the value (records.md
    §3.4): its first octet is not P922 nor P65000."""
    assert "TELEGRAM-SELECTION-MISMATCH" not in rule_ids([_attr(param(922, [10, 46]), 0x20), G])
    assert "TELEGRAM-SELECTION-MISMATCH" in rule_ids([_attr(param(922, [10, 46]), 0x10), G])
    written = [param(65000, [1000], change=True)]
    assert "PRESET-VALUE-WRONG" not in rule_ids(written + [_attr(param(65000, [0]), 0x20)] + PRESET_REL)
    assert "PRESET-VALUE-WRONG" in rule_ids(written + [_attr(param(65000, [0]), 0x10)] + PRESET_REL)


def test_parameter_lists_and_pnu_zero_are_no_unknown_pnu():
    """P980..P989 never list themselves, and a list continues in P981 (records.md §4.6); PNU 0 is the controller's
    bad request (#79), whatever error answers it."""
    lst = param(980, [922, 65000, 981])
    assert "BMP-UNKNOWN-PNU" not in rule_ids([lst, param(980, [922, 65000, 981]), param(981, [65001])])
    assert "BMP-UNKNOWN-PNU" not in rule_ids([lst, param(981, [65001]), param(65001, [1, 2])])
    assert "BMP-UNKNOWN-PNU" in rule_ids([lst, param(65001, [1, 2])])
    assert "BMP-UNKNOWN-PNU" not in rule_ids([lst, param(0, error=ERR(0x16))])


def test_invalid_bf00_is_not_the_configuration():
    """A 0xBF00 judged invalid (TMR 1) is answered with 0x1002, not taken as the encoder's scaling: no second,
    derived POSITION-OUT-OF-RANGE against the encoder (behaviour.md §4.5)."""
    bad = bf00({"compat": 1, "class4": 1, "scaling": 1, "mupr": 8192, "tmr": 1,
                "problems": [{"rule": "BF00-VALUE-OUT-OF-RANGE", "message": "TMR 1"}]})
    got = rule_ids([bad, G])
    assert "BF00-VALUE-OUT-OF-RANGE" in got and "POSITION-OUT-OF-RANGE" not in got
    ok = bf00({"compat": 1, "class4": 1, "scaling": 1, "mupr": 2, "tmr": 4, "problems": []})
    assert "POSITION-OUT-OF-RANGE" in rule_ids([ok, G])


@pytest.mark.skipif(__import__("shutil").which("lua5.2") is None, reason="lua5.2 not installed")
def test_record_rules_lua_same():
    """Every row of the record / parameter table through the Lua checker (luachk replay): the same violations."""
    from luachk.record import lua_same

    def table():
        for _rule, cfg, bad, good in CASES:
            run(bad, **cfg)
            run(good, **cfg)
        test_description_read_is_not_the_value()
        test_parameter_lists_and_pnu_zero_are_no_unknown_pnu()
        test_invalid_bf00_is_not_the_configuration()
        test_global_access_of_another_encoder_is_not_applied()
        test_undecodable_response_judges_no_parameter()
    assert "P965-VERSION-MISMATCH" in lua_same(table)


def test_bf00_error_not_reported_names_the_write_and_the_deciding_cycle():
    """#70 is a deadline rule: its frame is the trigger (the invalid write), its last frame the cycle that decides,
    as PRESET-ACK-MISSING's (an independent audit: it named the deciding cycle twice)."""
    (v,) = [e for e in run([bf00({"mupr": 0}), (G, 15)]) if e["rule"] == "BF00-ERROR-NOT-REPORTED"]
    assert v["frame"] == 0 and v["last_frame"] > 1
