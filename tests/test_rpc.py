"""IPv4/UDP, connectionless DCE/RPC and PNIO-CM decoders: known values, bounded reassembly,
property tests (nothing but a dict or Malformed escapes), and the tshark fields the ek parse
drops (duplicate JSON keys) compared against ek with every duplicate kept."""
from __future__ import annotations

import collections
import glob
import json
import os
import shutil
import struct
import subprocess

import pytest
from hypothesis import HealthCheck, given, settings, strategies as st

import rpc_frames as rf
from pndiss.proto import dcerpc, ip, pnio_cm
from pndiss.proto.common import Malformed
from pndiss.proto.eth import decode_link
from pndiss.settings import Settings
from pndiss.stations import Stations

PUBLIC = os.path.join(os.path.dirname(__file__), "..", "..", "shared", "captures", "public")
FAST = settings(max_examples=250, deadline=None, suppress_health_check=[HealthCheck.too_slow])


class FakeAnalyzer:
    """The parts of pndiss.analyzer.Analyzer the session tracker uses (keeps these tests
    independent of the cyclic decoder)."""

    def __init__(self, settings_=None):
        from pndiss.session import SessionTracker

        self.settings = settings_ or Settings()
        self.stations = Stations()
        self.events: list[dict] = []
        self.malformed: list[dict] = []
        self.cur_frame = self.cur_ts = 0
        self.first_ts = None
        self.rt: list[tuple] = []
        self.records: list[dict] = []
        self.cyclic = type("C", (), {"on_record": lambda _s, ev: self.records.append(ev),
                                     "on_phase": lambda _s, *args: None,
                                     "on_write_result": lambda _s, ev: None,
                                     "on_reconnect": lambda _s, *args: None,
                                     "on_write_refused": lambda _s, ev: None,
                                     "restart_gaps": lambda _s, keys: None,
                                     "restart_between": lambda _s, a, b: None,
                                     "on_new_ar": lambda _s, dev: None})()
        self.session = SessionTracker(self)

    def emit(self, ev):
        self.events.append(ev)

    def event(self, kind, **f):
        ev = {"frame": self.cur_frame, "ts_ns": self.cur_ts, "kind": kind, **f}
        self.emit(ev)
        return ev

    def add_malformed(self, fn, ts, layer, reason):
        ev = {"frame": fn, "ts_ns": ts, "kind": "malformed", "layer": layer, "reason": reason}
        self.malformed.append(ev)
        self.emit(ev)

    _malformed = add_malformed

    def pn_rt(self, fn, ts, data, off, src, dst, tags, udp, end=None):
        self.rt.append((fn, off, end, udp))
        return "decoded"

    def feed(self, fn, ts, data, linktype=1) -> str:
        self.cur_frame, self.cur_ts = fn, ts
        if self.first_ts is None:
            self.first_ts = ts
        try:
            d, s, et, off, _tags = decode_link(linktype, data)
            if et != 0x0800:
                return "not_profinet"
            from pndiss.proto.common import mac
            return self.session.on_ipv4(fn, ts, data, off, mac(s), mac(d))
        except Malformed as e:
            self._malformed(fn, ts, e.layer, e.reason)
            return "malformed"


def run_capture(path: str) -> FakeAnalyzer:
    from pndiss.capture import open_capture

    a = FakeAnalyzer()
    for fn, ts, lt, data in open_capture(path):
        a.feed(fn, ts, data, lt)
    a.session.finish()
    return a


def public(name: str) -> str:
    p = os.path.join(PUBLIC, name)
    if not os.path.exists(p):
        pytest.skip(f"{name} not present")
    return p


# ---------------------------------------------------------------- known values
def test_uuid_little_endian_drep():
    # spec/wire.md §5.1: 00 00 a0 de 97 6c d1 11 82 71 ... = dea00000-6c97-11d1-8271-...
    b = bytes.fromhex("0000a0de976cd1118271000100010279")
    assert dcerpc.get_uuid(b, 0, "little") == "dea00000-6c97-11d1-8271-000100010279"
    assert dcerpc.get_uuid(rf.uuid_bytes(rf.DEVICE_IF), 0, "big") == rf.DEVICE_IF


@given(st.binary(min_size=16, max_size=24), st.integers(0, 8), st.sampled_from(["big", "little"]))
def test_uuid_text_is_the_uuid_modules(b, off, order):
    """get_uuid writes the text itself (three in every header): the uuid module's text, both byte orders."""
    import struct as _s
    import uuid as _u
    if off + 16 > len(b):
        with pytest.raises(_s.error):
            dcerpc.get_uuid(b, off, order)
        return
    a, m, c = _s.unpack_from(">IHH" if order == "big" else "<IHH", b, off)
    want = str(_u.UUID(int=(a << 96) | (m << 80) | (c << 64) | int.from_bytes(b[off + 8:off + 16], "big")))
    assert dcerpc.get_uuid(b, off, order) == want == dcerpc.get_uuid(memoryview(b), off, order)


@pytest.mark.parametrize("little", [False, True])
def test_header_both_byte_orders(little):
    pdu = rf.dcerpc(0, 3, b"\x01\x02", seq=0x01020304, little=little, frag_num=7)
    h = dcerpc.decode_header(pdu, 0, len(pdu))
    assert h["dg_seqnum"] == 0x01020304 and h["opnum"] == 3 and h["dg_frag_num"] == 7
    assert h["dg_if_id"] == rf.DEVICE_IF and h["dg_frag_len"] == 2
    assert h["byte_order"] == ("little" if little else "big")
    assert h["drep"] == ("10:00:00" if little else "00:00:00")


def test_pnio_status_words():
    # observed Connect refusal (spec/wire.md §5.4): db 81 40 04
    s = pnio_cm.status(0xDB, 0x81, 0x40, 0x04)
    assert not s["ok"] and "Out of AR Resources" in s["text"] and "IODConnectRes" in s["text"]
    s = pnio_cm.status(0xDF, 0x80, 0xB0, 0)
    assert "invalid index" in s["text"] and "PNIORW" in s["text"]
    assert pnio_cm.status(0, 0, 0, 0)["text"] == "OK"


def test_ndr_response_status_little_endian():
    stub = rf.ndr_response(b"", little=True, status=bytes([0xDB, 0x81, 0x40, 0x04]))
    d = pnio_cm.decode_stub(stub, "little", False, 0)
    assert (d["status"]["error_code"], d["status"]["error_code2"]) == (0xDB, 4)


def test_connect_blocks_decoded():
    req, res = rf.connect_pair([(1, 0x51, 3, 12, 4)])
    a = FakeAnalyzer()
    assert a.feed(1, 1000, req) == "decoded"
    assert a.feed(2, 2000, res) == "decoded"
    rpc = [e for e in a.events if e["kind"] == "rpc"]
    names = [b["block_name"] for b in rpc[0]["pnio"]["blocks"]]
    assert names == ["ARBlockReq", "IOCRBlockReq", "IOCRBlockReq", "AlarmCRBlockReq", "ExpectedSubmoduleBlockReq"]
    exp = rpc[0]["pnio"]["blocks"][4]["apis"][0]["submodules"][0]
    assert [dd["submodule_data_length"] for dd in exp["data_descriptions"]] == [12, 4]
    assert rpc[1]["request_frame"] == 1
    # the response comes from another port than 34964: tshark (and dcerpc.request_in) does not pair it
    assert "request_in" not in rpc[1]["dcerpc"]
    assert [b["frame_id"] for b in rpc[1]["pnio"]["blocks"] if b["block_type"] == 0x8102] == [0x8000, 0x8001]


def test_multiple_write_inner_records():
    # 0xE040: inner headers + data, each padded to 4 bytes from the stub start (spec/wire.md §6.10)
    d1, d2 = b"\x01\x02\x03", b"\xAA" * 8
    inner = rf.rw_header(0x0008, 0xBF00, len(d1)) + d1 + b"\0"  # 20 + 64 + 3 -> pad 1
    inner += rf.rw_header(0x0008, 0xB02E, len(d2)) + d2
    outer = rf.rw_header(0x0008, 0xE040, len(inner), api=0, slot=0, subslot=0) + inner
    d = pnio_cm.decode_stub(rf.ndr_request(outer), "big", True, 3)
    recs = [b for b in pnio_cm.records(d) if "data" in b]
    assert [(b["index"], b["data"]) for b in recs] == [(0xBF00, d1.hex()), (0xB02E, d2.hex())]


def test_block_overrun_is_malformed():
    bad = struct.pack(">HHBB", 0x0101, 200, 1, 0) + b"\0" * 10
    with pytest.raises(Malformed):
        pnio_cm.decode_stub(rf.ndr_request(bad), "big", True, 0)


def test_ip_fragments_reassembled():
    payload = rf.udp(49153, 34964, rf.dcerpc(0, 5, rf.ndr_request(b""), seq=9))
    first, second = payload[:40], payload[40:]
    f1 = rf.eth(rf.CONTROLLER_MAC, rf.DEVICE_MAC, rf.ipv4(rf.CONTROLLER_IP, rf.DEVICE_IP, first, ident=77,
                                                          flags_frag=0x2000))
    f2 = rf.eth(rf.CONTROLLER_MAC, rf.DEVICE_MAC, rf.ipv4(rf.CONTROLLER_IP, rf.DEVICE_IP, second, ident=77,
                                                          flags_frag=40 // 8))
    a = FakeAnalyzer()
    assert a.feed(1, 0, f1) == "decoded" and a.feed(2, 1, f2) == "decoded"
    frags = [e for e in a.events if e["kind"] == "ip_fragment"]
    assert [e["complete"] for e in frags] == [False, True] and frags[1]["frames"] == [1, 2]
    rpc = [e for e in a.events if e["kind"] == "rpc"]
    assert len(rpc) == 1 and rpc[0]["frame"] == 2 and rpc[0]["pnio"]["operation"] == "Read Implicit"


def test_dcerpc_fragments_reassembled_and_records_named():
    blob = rf.rw_header(0x0008, 0xBF00, 40) + bytes(range(40))
    stub = rf.ndr_request(blob)
    parts = [stub[:50], stub[50:90], stub[90:]]
    a = FakeAnalyzer()
    for i, p in enumerate(parts):
        flags = 0x24 | (0x02 if i == 2 else 0)
        fr = rf.frame(rf.CONTROLLER_MAC, rf.DEVICE_MAC, rf.CONTROLLER_IP, rf.DEVICE_IP, 49153, 34964,
                      rf.dcerpc(0, 3, p, seq=4, flags1=flags, frag_num=i))
        assert a.feed(i + 1, i, fr) == "decoded"
    rec = [e for e in a.events if e["kind"] == "record"]
    assert len(rec) == 1 and rec[0]["frame"] == 3 and rec[0]["index"] == 0xBF00 and rec[0]["length"] == 40
    assert rec[0]["index_name"] and a.records == rec


def test_a_resent_fragment_of_a_completed_call_is_a_copy():
    """A CL client resends the last request fragment the slow server did not acknowledge yet (an independent
    audit's S7 capture; tshark: "[DCE/RPC fragment, reas: #N]"): a copy of the completed call's fragment, decoded
    and counted as resent -- not a new call that never completes (it was reported malformed at the end)."""
    stub = rf.ndr_request(rf.rw_header(0x0008, 0xBF00, 40) + bytes(range(40)))
    parts = [stub[:50], stub[50:]]
    a = FakeAnalyzer()
    frames = [rf.frame(rf.CONTROLLER_MAC, rf.DEVICE_MAC, rf.CONTROLLER_IP, rf.DEVICE_IP, 49153, 34964,
                       rf.dcerpc(0, 3, p, seq=4, flags1=0x24 | (0x02 if i else 0), frag_num=i))
              for i, p in enumerate(parts)]
    for fn, fr in enumerate(frames + frames[1:], 1):
        assert a.feed(fn, fn * 1000, fr) == "decoded"
    a.session.finish()
    assert not a.malformed and a.session.counts["rpc_fragments_resent"] == 1
    assert len([e for e in a.events if e["kind"] == "record"]) == 1


def test_udp_rt_class_goes_to_pn_rt():
    fr = rf.frame(rf.DEVICE_MAC, rf.CONTROLLER_MAC, rf.DEVICE_IP, rf.CONTROLLER_IP, 0x8892, 0x8892,
                  b"\x80\x00" + b"\0" * 44)
    a = FakeAnalyzer()
    assert a.feed(1, 0, fr) == "decoded"
    assert a.rt and a.rt[0][3] is True and a.rt[0][1] == 14 + 20 + 8


def test_rt_class_udp_port_from_connect():
    a = FakeAnalyzer()
    req, res = rf.connect_pair([(1, 0x51, 3, 12, 4)], rt_class=4, udp_port=40000)
    a.feed(1, 0, req)
    a.feed(2, 1, res)
    fr = rf.frame(rf.DEVICE_MAC, rf.CONTROLLER_MAC, rf.DEVICE_IP, rf.CONTROLLER_IP, 40001, 40000,
                  b"\x80\x00" + b"\0" * 44)
    assert a.feed(3, 2, fr) == "decoded" and a.rt and a.rt[0][0] == 3


def test_other_ip_is_not_profinet():
    a = FakeAnalyzer()
    tcp = rf.eth(rf.CONTROLLER_MAC, rf.DEVICE_MAC, rf.ipv4(rf.CONTROLLER_IP, rf.DEVICE_IP, b"\0" * 20, proto=6))
    dns = rf.frame(rf.CONTROLLER_MAC, rf.DEVICE_MAC, rf.CONTROLLER_IP, rf.DEVICE_IP, 5353, 53, b"\x12" * 30)
    other_rpc = rf.frame(rf.CONTROLLER_MAC, rf.DEVICE_MAC, rf.CONTROLLER_IP, rf.DEVICE_IP, 1000, 2000,
                         rf.dcerpc(0, 0, b"", if_id="12345678-1234-1234-1234-123456789abc"))
    assert [a.feed(i, 0, f) for i, f in enumerate((tcp, dns, other_rpc))] == ["not_profinet"] * 3


def test_truncated_datagram_malformed_only_on_pnio_ports():
    # a snaplen-cut datagram (IP total length > captured bytes)
    pn = rf.frame(rf.CONTROLLER_MAC, rf.DEVICE_MAC, rf.CONTROLLER_IP, rf.DEVICE_IP, 49153, 34964, b"\0" * 200)
    other = rf.frame(rf.CONTROLLER_MAC, rf.DEVICE_MAC, rf.CONTROLLER_IP, rf.DEVICE_IP, 5000, 5001, b"\0" * 200)
    a = FakeAnalyzer()
    assert a.feed(1, 0, pn[:100]) == "malformed" and a.malformed[0]["layer"] == "ip"
    assert a.feed(2, 0, other[:100]) == "not_profinet"


# ---------------------------------------------------------------- bounded memory
def test_ip_reassembly_bounded():
    r = ip.IpReassembler(max_datagrams=64, max_bytes=1 << 16)
    dropped = 0
    for i in range(100_000):
        pkt = rf.ipv4("10.0.0.1", "10.0.0.2", b"\0" * 64, ident=i & 0xFFFF, flags_frag=0x2000)
        h = ip.decode_ipv4(pkt, 0)
        assert r.add(i, i, h, pkt) is None
        assert len(r.pending) <= 64 and r.bytes <= 1 << 16
        if i % 1000 == 0:
            dropped += len(r.expire(i))
    dropped += len(r.expire(None))
    assert dropped == 100_000 and not r.pending and r.bytes == 0


def test_dcerpc_reassembly_bounded_through_the_tracker():
    a = FakeAnalyzer()
    n = 20_000
    for i in range(n):
        body = b"\x55" * 100
        fr = rf.frame(rf.CONTROLLER_MAC, rf.DEVICE_MAC, rf.CONTROLLER_IP, rf.DEVICE_IP, 49153, 34964,
                      rf.dcerpc(0, 3, body, act=f"00000000-0000-1010-8000-{i:012x}", flags1=0x24))
        assert a.feed(i + 1, i * 1000, fr) == "decoded"
        assert len(a.session.rpcr.pending) <= a.session.rpcr.max_calls
        assert a.session.rpcr.bytes <= a.session.rpcr.max_bytes
    a.session.finish()
    assert len(a.malformed) == n  # every incomplete call reported once, naming its frame
    assert all(m["layer"] == "dcerpc" and "frames" in m["reason"] for m in a.malformed)
    assert not a.session.rpcr.pending


def test_reassembly_times_out():
    r = dcerpc.FragmentReassembler(timeout_ns=10)
    pdu = rf.dcerpc(0, 3, b"abc", flags1=0x24)
    h = dcerpc.decode_header(pdu, 0, len(pdu))
    r.add(1, 0, h, pdu)
    assert r.expire(5) == [] and r.expire(100) == [([1], "DCE/RPC reassembly timed out")]


# ---------------------------------------------------------------- property tests
def _sample_request_stub() -> bytes:
    req, _ = rf.connect_pair([(1, 0x51, 3, 12, 4), (2, 1, 0, 0, 0)])
    return req[14 + 20 + 8 + 80:]


def _sample_write_stub() -> bytes:
    inner = rf.rw_header(0x0008, 0xBF00, 3) + b"\1\2\3\0" + rf.rw_header(0x0008, 0x8071, 8) + b"\0" * 8
    return rf.ndr_request(rf.rw_header(0x0008, 0xE040, len(inner)) + inner)


SAMPLES = [_sample_request_stub(), _sample_write_stub(),
           rf.ndr_response(rf.ar_block_res() + rf.iocr_res(1, 1, 0x8000) + rf.alarmcr_res())]


def _mutate(data: bytes, edits) -> bytes:
    b = bytearray(data)
    for pos, val in edits:
        if b:
            b[pos % len(b)] = val
    return bytes(b)


@FAST
@given(st.binary(max_size=120), st.integers(0, 40))
def test_ipv4_udp_random(data, off):
    try:
        h = ip.decode_ipv4(data, off)
        assert isinstance(h, dict)
        ip.decode_udp(data, h["payload_off"], h["payload_end"])
    except Malformed:
        pass


@FAST
@given(st.binary(max_size=200), st.sampled_from([0, 4, 0x10]))
def test_dcerpc_header_random(data, drep):
    data = b"\x04\x00\x20\x00" + bytes([drep]) + data if len(data) % 2 else data
    try:
        h = dcerpc.decode_header(data, 0, len(data))
        assert h["ver"] == 4
        dcerpc.decode_fack(data, h["body_off"], h["body_end"], h["byte_order"])
    except Malformed:
        pass


@FAST
@given(st.sampled_from(range(len(SAMPLES))), st.lists(st.tuples(st.integers(0, 10_000), st.integers(0, 255)),
                                                      max_size=6), st.integers(0, 400), st.booleans())
def test_pnio_stub_mutated(i, edits, cut, request):
    stub = _mutate(SAMPLES[i], edits)[:cut]
    for order in ("big", "little"):
        try:
            d = pnio_cm.decode_stub(stub, order, request, 0)
            assert isinstance(d, dict) and isinstance(d["blocks"], list)
        except Malformed:
            pass


@FAST
@given(st.binary(max_size=300))
def test_pnio_blocks_random(data):
    try:
        out: list = []
        pnio_cm.decode_blocks(data, 0, len(data), out)
    except Malformed:
        pass


def _write_pair():
    act = "00000003-0000-1010-8000-000000000003"
    w = rf.rw_header(0x0008, 0xB02E, 4) + b"\1\1\0\1"
    req = rf.frame(rf.CONTROLLER_MAC, rf.DEVICE_MAC, rf.CONTROLLER_IP, rf.DEVICE_IP, 49153, 34964,
                   rf.dcerpc(0, 3, rf.ndr_request(w), act=act))
    res = rf.frame(rf.DEVICE_MAC, rf.CONTROLLER_MAC, rf.DEVICE_IP, rf.CONTROLLER_IP, 34964, 49153,
                   rf.dcerpc(2, 3, rf.ndr_response(rf.rw_header(0x8008, 0xB02E, 4)), act=act))
    return req, res


@FAST
@given(st.sampled_from([0, 1]), st.lists(st.tuples(st.integers(0, 400), st.integers(0, 255)), max_size=5),
       st.integers(0, 1600), st.booleans())
def test_whole_frames_mutated(which, edits, cut, mutate_request):
    # request + response pairs, one of them mutated: the tracker's pairing code sees odd blocks too
    req, res = rf.connect_pair([(1, 0x51, 3, 12, 4)]) if which == 0 else _write_pair()
    if mutate_request:
        req = _mutate(req, edits)[:max(cut, 14)]
    else:
        res = _mutate(res, edits)[:max(cut, 14)]
    a = FakeAnalyzer()
    for i, fr in enumerate((req, res)):
        assert a.feed(i + 1, i, fr) in ("decoded", "not_profinet", "malformed")
    a.session.finish()


# ---------------------------------------------------------------- tshark, duplicate ek keys
# ek repeats a key for a field that occurs in several subtrees and json.loads keeps only the
# last group; tshark also appends its AR summary (ar_uuid, cminitiator_mac_add, localalarmref,
# cmresponder_macadd, frame_id) as the last keys of the layer. Parse ek keeping every key,
# drop that trailing summary group, compare the rest (tests/tshark_map/pnio_cm.json "quirks").
DUP_FIELDS = {
    "ar_uuid": ["pnio.blocks[].ar_uuid", "pnio.blocks[].ar_uuid_sysred"],
    "cminitiator_mac_add": ["pnio.blocks[].cminitiator_mac_add"],
    "cmresponder_macadd": ["pnio.blocks[].cmresponder_macadd"],
    "localalarmref": ["pnio.blocks[].localalarmref"],
    "frame_id": ["pnio.blocks[].frame_id", "pnio.blocks[].ir_frames[].frame_id"],
    "slot_nr": ["pnio.blocks[].slot_nr", "pnio.blocks[].apis[].slot_nr", "pnio.blocks[].apis[].io_data_objects[].slot_nr",
                "pnio.blocks[].apis[].iocs[].slot_nr", "pnio.blocks[].apis[].modules[].slot_nr"],
    "subslot_nr": ["pnio.blocks[].subslot_nr", "pnio.blocks[].apis[].submodules[].subslot_nr",
                   "pnio.blocks[].apis[].io_data_objects[].subslot_nr", "pnio.blocks[].apis[].iocs[].subslot_nr",
                   "pnio.blocks[].apis[].modules[].submodules[].subslot_nr"],
}
SUMMARY = ["ar_uuid", "cminitiator_mac_add", "localalarmref", "cmresponder_macadd", "frame_id"]
PREFIX = "pn_io_pn_io_"


def _ek_all_keys(path: str) -> dict[int, dict[str, list]]:
    out = subprocess.run([shutil.which("tshark"), "-n", "-r", path, "-T", "ek"], capture_output=True, text=True,
                         check=True).stdout
    frames = {}
    for line in out.splitlines():
        if not line.startswith('{"timestamp"'):
            continue
        acc = collections.defaultdict(list)

        def hook(pairs, acc=acc):
            items = [(k[len(PREFIX):], v) for k, v in pairs if k.startswith(PREFIX)]
            if [k for k, _ in items[-5:]] == SUMMARY:
                items = items[:-5]
            for k, v in items:
                acc[k].extend(v if isinstance(v, list) else [v])
            return dict(pairs)

        d = json.loads(line, object_pairs_hook=hook)
        frames[int(d["layers"]["frame"]["frame_frame_number"])] = acc
    return frames


RPC_CAPTURES = sorted(glob.glob(os.path.join(PUBLIC, "profinet_io_cm_*"))
                      + glob.glob(os.path.join(PUBLIC, "*pnio-cm*"))
                      + glob.glob(os.path.join(PUBLIC, "python-profinet_connectrequest.pcap")))


@pytest.mark.skipif(shutil.which("tshark") is None, reason="tshark not installed")
@pytest.mark.parametrize("path", RPC_CAPTURES, ids=[os.path.basename(p) for p in RPC_CAPTURES])
def test_ek_duplicate_key_fields_equal_tshark(path):
    from tsharkdiff import norm, walk

    theirs_all = _ek_all_keys(path)
    a = run_capture(path)
    per_frame = collections.defaultdict(list)
    for e in a.events:
        if e["kind"] == "rpc" and "pnio" in e:
            per_frame[e["frame"]].append(e)
    compared, diffs = 0, []
    for fn, evs in sorted(per_frame.items()):
        for fld, paths in DUP_FIELDS.items():
            mine = collections.Counter(norm(v) for e in evs for p in paths for v in walk(e, p))
            theirs = collections.Counter(norm(v) for v in theirs_all.get(fn, {}).get(fld, []) if v is not None)
            compared += sum(theirs.values())
            if mine != theirs:
                diffs.append(f"frame {fn} {fld}: only pndiss {dict(mine - theirs)} only tshark {dict(theirs - mine)}")
    print(f"\n{os.path.basename(path)}: {compared} duplicate-key values compared")
    assert compared > 0 and not diffs, "\n".join(diffs[:20])


def test_write_capture_fragments_and_record_names():
    a = run_capture(public("profinet_io_cm_write.pcapng"))
    frag = [e for e in a.events if e["kind"] == "rpc" and e.get("fragment")]
    done = [e for e in frag if e["fragment"]["complete"]]
    assert done and all(len(e["fragment"]["frames"]) >= 2 for e in done)
    assert any("pnio" in e for e in done)
    recs = [e for e in a.events if e["kind"] == "record"]
    assert not a.malformed and len(recs) > 300
    assert all(e["index_name"] for e in recs)
    assert {e["index"] for e in recs} >= {0x8071, 0x802F}  # PDInterfaceAdjust, PDPortDataAdjust written
    frag_frames = {e["frame"] for e in done}
    assert any(e["frame"] in frag_frames for e in recs)  # records written by a reassembled request
