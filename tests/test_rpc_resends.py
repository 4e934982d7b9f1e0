"""Plant RPC traffic the simulator does not make: a request the controller sends again after its
response (it missed the response; the device answers again from its cache, wire.md §5.1), and a
record write the device refuses (a 0xBF00 rewritten during operation, answered with an error).
The first runs once; the second writes nothing, so the parameters in force stay (helper audit,
round 4: BMP-PIPELINED, PRESET-CLASS4-DISABLED and PRESET-EXECUTED-WHEN-NOT-ALLOWED were false)."""
from __future__ import annotations

import collections
import os
import shutil
import struct

import pytest

import capedit
from pndiss.analyzer import analyze_file
from pndiss.capture import open_capture
from pndiss.settings import Settings
from pndiss.sim.pcapng import Writer

STUB = 14 + 20 + 8 + 80      # Ethernet, IPv4, UDP, connectionless DCE/RPC header: the NDR stub
BLOCKS = STUB + 20           # after the NDR header: the IOD read/write header block
KINDS = ("record", "record_result", "param", "ar", "ar_phase")


def _rpc(d: bytes):
    """(ptype, act|seq) of a connectionless DCE/RPC PDU over UDP, else None."""
    if len(d) < STUB or d[12:14] != b"\x08\x00" or d[23] != 17 or d[14 + 20 + 8] != 4:
        return None
    h = d[42:]
    little = bool(h[4] & 0x10)
    seq = struct.unpack("<I" if little else ">I", h[64:68])[0]
    return h[1], (h[40:56], seq, little)


def _events(path):
    evs, kinds = [], collections.Counter()

    def sink(e):
        if e["kind"] == "violation":
            evs.append((e["rule"], e["frame"]))
        elif e["kind"] in KINDS:
            kinds[e["kind"]] += 1
    a = analyze_file(path, Settings(fast_path=False), sink=sink)
    return evs, kinds, a.summary()["session"]["counts"]["rpc_retransmissions"]


@pytest.fixture(scope="module")
def caps(tmp_path_factory):
    tmp = str(tmp_path_factory.mktemp("rpc"))
    src = capedit.simulate(os.path.join(tmp, "full.pcapng"), "--scenario", "preset", "--cycles", "600",
                           "--records", "plain")
    frames = list(open_capture(src))
    out = {"src": src}
    # 1. every request sent again 1 ms after its response, and the response again after it
    ren, reqs, n = {}, {}, 0
    dst = os.path.join(tmp, "resent.pcapng")
    with open(dst, "wb") as f:
        w = Writer(f)
        for fn, ts, _lt, d in frames:
            d = bytes(d)
            ren[fn] = w.write(ts, d)
            r = _rpc(d)
            if r is None:
                continue
            if r[0] == 0:
                reqs[r[1][:2]] = d
            elif r[0] == 2 and r[1][:2] in reqs:
                w.write(ts + 1_000_000, reqs.pop(r[1][:2]))
                w.write(ts + 1_100_000, d)
                n += 1
    out["resent"] = (dst, ren, n)
    # 2. the start-up 0xBF00 written again before the first preset with class 4 off, and refused
    bf00 = next((fn, d) for fn, _ts, _lt, d in frames if (r := _rpc(bytes(d))) and r[0] == 0
                and struct.unpack(">H", bytes(d)[BLOCKS:BLOCKS + 2])[0] == 0x0008
                and struct.unpack(">H", bytes(d)[BLOCKS + 34:BLOCKS + 36])[0] == 0xBF00)
    req = bytearray(bf00[1])
    key = _rpc(bytes(req))[1]
    res = next(bytearray(d) for _fn, _ts, _lt, d in frames if (r := _rpc(bytes(d))) and r[0] == 2 and r[1] == key)
    for p in (req, res):   # a new call: another sequence number
        p[42 + 64:42 + 68] = struct.pack("<I" if key[2] else ">I", 0x7000)
    req[BLOCKS + 64] &= ~0x02               # 0xBF00 byte 0 bit 1: class 4 functionality off
    # PNIOStatus write error / state conflict: the call's an NDR u32 (the stub's byte order), the header's bytes
    res[STUB:STUB + 4] = struct.pack("<I" if key[2] else ">I", 0xDF80B500)
    res[BLOCKS + 8 + 36:BLOCKS + 8 + 40] = b"\xdf\x80\xb5\x00"
    at = _first_preset_frame(src) - 40

    def with_write(name, answer) -> str:
        """The capture with the write and its answer just before frame ``at``."""
        path = os.path.join(tmp, name + ".pcapng")
        with open(path, "wb") as f:
            w = Writer(f)
            for fn, ts, _lt, d in frames:
                if fn == at:
                    w.write(ts - 2_000, bytes(req))
                    w.write(ts - 1_000, bytes(answer))
                w.write(ts, bytes(d))
        return path
    out["refused"] = with_write("refused", res)
    # 2b. the same refusal as an error of the call alone (no IODWriteResHeader): the NDR header ends the PDU
    bare = bytearray(res[:BLOCKS])
    little = key[2]
    u16, u32 = ("<H", "<I") if little else (">H", ">I")
    bare[STUB + 4:STUB + 8] = bare[STUB + 16:STUB + 20] = struct.pack(u32, 0)   # ArgsLength, ActualCount
    bare[42 + 74:42 + 76] = struct.pack(u16, 20)                                   # DCE/RPC fragment length
    bare[16:18] = struct.pack(">H", len(bare) - 14)                                # IPv4 total length
    bare[24:26] = b"\0\0"
    csum = sum(struct.unpack(">10H", bytes(bare[14:34])))
    while csum >> 16:
        csum = (csum & 0xFFFF) + (csum >> 16)
    bare[24:26] = struct.pack(">H", ~csum & 0xFFFF)
    bare[38:40] = struct.pack(">H", len(bare) - 34)                                # UDP length
    bare[40:42] = b"\0\0"                                                          # UDP checksum: none
    out["refused_bare"] = with_write("refused-bare", bare)
    ok = bytearray(res)   # the same write answered OK: class 4 is off
    ok[STUB:STUB + 4] = ok[BLOCKS + 8 + 36:BLOCKS + 8 + 40] = b"\0\0\0\0"
    out["accepted"] = with_write("accepted", ok)
    return out


def _first_preset_frame(path) -> int:
    evs = []
    analyze_file(path, Settings(fast_path=False),
                 sink=lambda e: evs.append(e["frame"]) if e["kind"] == "state" and e.get("state") == "preset"
                 and e.get("value") not in (0, "idle") else None)
    assert evs
    return evs[0]


def test_a_request_sent_again_after_its_response_runs_once(caps):
    dst, ren, n = caps["resent"]
    want, kinds, retrans = _events(caps["src"])
    got, got_kinds, got_retrans = _events(dst)
    assert n >= 5 and "param" in kinds
    assert got == [(r, ren[f]) for r, f in want] and got_kinds == kinds
    assert got_retrans == retrans + 2 * n


def test_a_refused_0xbf00_writes_nothing(caps):
    base, _k, _r = _events(caps["src"])
    got, _k, _r = _events(caps["refused"])
    assert {r for r, _f in got} == {r for r, _f in base}
    got, _k, _r = _events(caps["refused_bare"])   # refused by the call's status alone
    assert {r for r, _f in got} == {r for r, _f in base}
    accepted, _k, _r = _events(caps["accepted"])   # the negative: accepted, class 4 is off for the preset
    assert "PRESET-CLASS4-DISABLED" in {r for r, _f in accepted}


@pytest.mark.skipif(shutil.which("tshark") is None, reason="tshark not installed")
@pytest.mark.parametrize("name", ("resent", "refused", "refused_bare", "accepted"))
def test_plugin_same(caps, name):
    from test_lua_plugin import compare
    path = caps[name][0] if name == "resent" else caps[name]
    n, bad, lua_viol, viol = compare(path)
    assert n and not bad, bad[:5]
    assert lua_viol == viol


# -- an engineering tool's Device Access AR writes P65000 ----------------------------------------------

def test_p65000_written_through_another_ar_is_the_encoders(caps, tmp_path):
    """The preset value is the encoder's one P65000, whichever AR wrote it (behaviour.md §9.3 #27): the
    write and read-back of P65000 moved to another AR UUID (a Device Access AR of a commissioning tool)
    still set it, and that AR's parameter channel is judged too (its own request references, #78)."""
    import uuid
    evs = []
    analyze_file(caps["src"], Settings(fast_path=False), sink=lambda e: evs.append(e) if e["kind"] == "param" else None)
    p = next(e for e in evs if any(x.get("pnu") == 65000 for x in e["params"]))
    ar = uuid.UUID(p["ar_uuid"])
    other = uuid.UUID(int=ar.int ^ 0xFFFF)
    lo, hi = p["request_frame"] - 1, p["frame"] + 20
    dst = str(tmp_path / "da-ar.pcapng")
    with open(dst, "wb") as f:
        w = Writer(f)
        for fn, ts, _lt, d in open_capture(caps["src"]):
            d = bytes(d)
            if lo <= fn <= hi and _rpc(d):
                d = d.replace(ar.bytes, other.bytes).replace(ar.bytes_le, other.bytes_le)
            w.write(ts, d)

    def enc(path):
        got = []
        a = analyze_file(path, Settings(fast_path=False), sink=lambda e: got.append(e) if e["kind"] == "param" else None)
        assert any(e["ar_uuid"] == str(other) for e in got) == (path == dst)
        e, = a.summary()["cyclic"]["encoders"]
        return e["p65000"], e["presets_unjudged"], sorted(e["violations"])
    want = enc(caps["src"])
    assert want[0] == 1000 and want[1] == 0
    assert enc(dst) == want
    if shutil.which("tshark"):   # the plugin routes the other AR's parameter access the same way
        from test_lua_plugin import compare
        n, bad, lua_viol, viol = compare(dst)
        assert n and not bad and lua_viol == viol
