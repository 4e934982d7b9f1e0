"""Property tests: every records decoder returns a dict or raises Malformed on random, truncated
and mutated bytes; builders and decoders round-trip."""
import math

from hypothesis import given, settings, strategies as st

from pndiss.proto.common import Malformed
from pndiss.records import ParamPairer, decode_record
from pndiss.records.build import build_bf00, build_im0, build_param_request, build_param_response
from pndiss.records.profidrive import FORMATS
from pndiss.records.userparams import decode_bf00

PROFILES = st.sampled_from(["lika", "scancon", "hohner", "psm", "generic"])
INDICES = st.sampled_from([0xAFF0, 0xAFF1, 0xAFF2, 0xAFF3, 0xAFF4, 0xB02E, 0xB02F, 0xBF00, 0xFFFF, 0x1000,
                           0x1001, 0x8028, 0xE040])
SEEDS = [build_im0(0x0239, "XAC7716", "1"), bytes.fromhex("00020001" "1000FDE80000" "430100000064"),
         bytes.fromhex("00820002" "44020002" "0000" "4000"), build_bf00("psm", velocity_reference=1.0),
         build_param_response(1, 1, [{"format": 0x09, "values": ["abc"]}, {"format": 0x0F, "values": [1.0]}])]


def _check(index, data, write, profile):
    try:
        d = decode_record(index, data, write=write, profile=profile)
    except Malformed as e:
        assert e.layer and e.reason
        return None
    assert isinstance(d, dict) and isinstance(d["index_name"], str)
    return d


@settings(max_examples=300, deadline=None)
@given(INDICES, st.binary(max_size=80), st.booleans(), PROFILES)
def test_random_bytes(index, data, write, profile):
    _check(index, data, write, profile)


@settings(max_examples=300, deadline=None)
@given(st.sampled_from(SEEDS), st.sampled_from([0xAFF0, 0xB02E, 0xB02F, 0xBF00, 0xFFFF]), st.booleans(), PROFILES,
       st.data())
def test_truncated_and_mutated(seed, index, write, profile, data):
    cut = data.draw(st.integers(0, len(seed)))
    _check(index, seed[:cut], write, profile)
    buf = bytearray(seed)
    for _ in range(data.draw(st.integers(1, 4))):
        buf[data.draw(st.integers(0, len(buf) - 1))] = data.draw(st.integers(0, 255))
    _check(index, bytes(buf), write, profile)


@settings(max_examples=200, deadline=None)
@given(st.lists(st.tuples(st.binary(max_size=40), st.booleans(), st.sampled_from(["a", "b"])), max_size=8))
def test_pairer_never_raises(seq):
    pp = ParamPairer()
    for i, (raw, is_req, key) in enumerate(seq):
        try:
            d = decode_record(0xB02E, raw, write=is_req)
        except Malformed:
            continue
        if is_req:
            pp.request(key, d, i, i)
        else:
            ev = pp.response(key, d, i, i)
            assert isinstance(ev["pairing"], list) and isinstance(ev["params"], list)


_INT_FORMATS = [f for f, (_, size, code) in FORMATS.items() if code in ("b", "B", "h", "H", "i", "I", "q", "Q")
                and f != 0x44]


@settings(max_examples=250, deadline=None)
@given(st.integers(0, 255), st.integers(0, 255), st.lists(st.tuples(st.sampled_from(_INT_FORMATS),
                                                                     st.integers(1, 5), st.integers(1, 65535),
                                                                     st.integers(0, 65534), st.randoms()),
                                                           min_size=1, max_size=5))
def test_request_response_round_trip(ref, axis, specs):
    params, blocks = [], []
    for fmt, n, pnu, sub, rnd in specs:
        size, code = FORMATS[fmt][1], FORMATS[fmt][2]
        bits = 8 * size
        vals = [rnd.randrange(-(1 << (bits - 1)), 1 << (bits - 1)) if code.islower() else rnd.randrange(0, 1 << bits)
                for _ in range(n)]
        params.append({"pnu": pnu, "subindex": sub, "count": n, "format": fmt, "values": vals})
        blocks.append({"format": fmt, "values": vals})
    req = decode_record(0xB02E, build_param_request(ref, 2, params, axis=axis), write=True)
    rsp = decode_record(0xB02E, build_param_response(ref, 1, blocks, axis=axis), write=False)
    assert "trailing_bytes" not in req and "trailing_bytes" not in rsp
    assert [(p["pnu"], p["subindex"], p["count"], p["values"]) for p in req["params"]] == \
        [(p["pnu"], p["subindex"], p["count"], p["values"]) for p in params]
    assert [b["values"] for b in rsp["params"]] == [b["values"] for b in blocks]


@settings(max_examples=250, deadline=None)
@given(PROFILES, st.integers(0, 1), st.integers(0, 1), st.integers(0, 1), st.integers(1, 1 << 40),
       st.integers(2, 1 << 50), st.integers(1, 255), st.integers(0, 3),
       st.floats(allow_nan=False, allow_infinity=False, width=32))
def test_bf00_round_trip(profile, cs, c4, comp, mupr, tmr, sol, vu, vref):
    extra = {"velocity_reference": vref} if profile == "psm" else {}
    raw = build_bf00(profile, code_sequence=cs, class4=c4, compat=comp, mupr=mupr, tmr=tmr,
                     max_master_sol_failures=sol, velocity_unit=vu, **extra)
    d = decode_bf00(raw, profile)
    assert (d["code_sequence"], d["class4"], d["compat"], d["mupr"], d["tmr"], d["max_master_sol_failures"],
            d["velocity_unit"]) == (cs, c4, comp, mupr, tmr, sol, vu)
    assert d["problems"] == []
    if profile == "psm":
        assert math.isclose(d["velocity_reference"], vref, rel_tol=1e-6, abs_tol=1e-30)


@settings(max_examples=200, deadline=None)
@given(st.integers(0, 0xFFFF), st.text(alphabet="ABCXYZ0123456789-/ ", max_size=20),
       st.text(alphabet="0123456789", max_size=16), st.integers(0, 0xFFFF), st.integers(0, 0xFFFF))
def test_im0_round_trip(vendor, order, serial, profile_id, supported):
    d = decode_record(0xAFF0, build_im0(vendor, order, serial, profile_id=profile_id, im_supported=supported),
                      write=False)
    assert (d["vendor_id"], d["order_id"], d["serial_number"], d["profile_id"], d["im_supported"]) == \
        (vendor, order.rstrip(), serial, profile_id, supported)
    assert d["notes"] == []
