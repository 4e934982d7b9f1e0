"""Several controllers' ARs around one encoder device (a shared device): only the AR that owns an encoder
module judges it. Another AR may read its inputs as Shared Input (SubmoduleProperties bit 2, wire.md §6.6) or get
it "locked by IO controller" (ModuleDiffBlock, §6.7); one Encoder Object per module (network.md §1.7): a P65000
written to another controller's module, or an alarm sent to another controller, is not this AR's encoder's. Also
parameter-channel pairing through the whole pipeline (records.md §3). Each capture is checked by the reference
path, the engine and the Lua plugin in real tshark."""
from __future__ import annotations

import shutil
import struct

import pytest

import rpc_frames as R
from pndiss.analyzer import analyze_file
from pndiss.records.build import build_param_request, build_param_response
from pndiss.settings import Settings
from synframes import channel_item, notification, rta
from test_multiaxis import _bf00

T81, MAP, DIO = 0x1051, 0xFFFF, 0x0321
SHARED, REDUCE_OUT = 0x04, 0x10             # SubmoduleProperties bits (wire.md §6.6)
BF00 = _bf00(0x0A, 4096, 32768)             # valid: class 4, scaling
STATE_CONFLICT = bytes.fromhex("df80b500")  # IODWrite refused: the parameter manager is busy
PLC_A = R.PLC
PLC_B = ("02:00:00:00:00:02", "192.168.0.2", "22222222-9abc-def0-1234-56789abcdef0",
         "00000008-0000-1010-8000-000000000008")


def encoder(slot):
    """An encoder module's submodules: the MAP (subslot 1) and the telegram 81 submodule (subslot 2)."""
    return [(slot, 1, MAP, 0, 0, 0), (slot, 2, T81, 3, 12, 4)]


class Ar:
    """One controller's AR with the device: its Connect and calls (``frames``), then its cyclic frames."""

    def __init__(self, plc, subs, fids, diff=b"", locked=()):
        self.plc, self.subs, self.fids, self.locked, self.seq = plc, subs, fids, set(locked), 1
        self.frames = list(R.connect_pair(subs, in_fid=fids[0], out_fid=fids[1], rr=(1, 1), plc=plc, diff=diff))

    def call(self, fn, *a, **kw) -> list:
        """The frames of one more call (the next sequence number of the AR's activity)."""
        self.seq += 1
        return list(fn(*a, seq=self.seq, plc=self.plc, **kw))

    def param(self, slot, req, rsp, refused_req=None) -> list:
        """Parameter request written to 0xB02E of the module, then the response read (records.md §3);
        ``refused_req``: a second request written before the read and refused (the device is busy)."""
        out = self.call(R.write_pair, 0xB02E, req, slot=slot)
        if refused_req is not None:
            out += self.call(R.write_pair, 0xB02E, refused_req, slot=slot, status=STATE_CONFLICT)
        return out + self.call(R.read_pair, 0xB02E, rsp, slot=slot)

    def cycle(self, i, enc) -> list:
        """Output and input frame of cycle i, laid out as connect_pair's offsets; enc(slot, i) -> (setpoints,
        actual values) of that encoder. A shared input gets a copy of the inputs and sends zeros or no data; a
        locked submodule carries no valid data (IOPS bad)."""
        ins, outs, n_in, n_out = b"", b"", 0, 0
        for slot, ss, ident, typ, in_len, out_len in self.subs:
            sp, act = enc(slot, i) if ident == T81 else (bytes(out_len), bytes(in_len))
            if typ & SHARED or (slot, ss) in self.locked:
                sp = bytes(out_len)
            if (slot, ss) in self.locked:
                act = bytes(in_len)
            iops = b"\0" if (slot, ss) in self.locked else b"\x80"
            if (typ & 3) in (0, 1, 3):
                ins, n_in = ins + (act if typ & 3 else b"") + iops, n_in + 1
            if (typ & 3) in (2, 3):
                outs, n_out = outs + (b"" if typ & REDUCE_OUT else sp) + iops, n_out + 1
        dev, plc = R.DEVICE_MAC, self.plc[0]
        return [R.eth(src, dst, struct.pack(">H", fid) + sdu.ljust(40, b"\0") + struct.pack(">HBB", i * 32 % 65536,
                                                                                           0x35, 0), 0x8892)
                for src, dst, fid, sdu in ((plc, dev, self.fids[1], outs + b"\x80" * n_in),
                                           (dev, plc, self.fids[0], ins + b"\x80" * n_out))]


def still(slot, i, preset=None):
    """A correct V4.1 encoder at standstill under control by PLC; ``preset``: (first, end, value): G1_STW.12
    from cycle first to end - 1, answered one cycle later by G1_ZSW.12 and the position at the value."""
    sol = i % 15 + 1
    req = preset is not None and preset[0] <= i < preset[1]
    done = preset is not None and preset[0] < i <= preset[1]
    pos = preset[2] if preset is not None and i > preset[0] else 1000 * slot
    return (struct.pack(">HH", 0x0400 | sol << 12, req << 12),
            struct.pack(">HHII", 0x0200 | sol << 12, done << 12, pos, pos))


def cycles(ars, first, end, enc=still, at=None) -> list:
    """Cycles first..end-1 of the ARs (1 ms each, frames 100 us apart); at: cycle -> frames before it."""
    items = []
    for i in range(first, end):
        items += (at or {}).get(i, [])
        fr = [f for ar in ars for f in ar.cycle(i, enc)]
        items += fr + [1000 - 100 * len(fr)]
    return items


def write(path, items) -> str:
    """A pcap of frames 100 us apart; an int in ``items`` is that many us of silence."""
    with open(path, "wb") as f:
        f.write(struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, 1))
        t = 1_700_000_000_000_000
        for it in items:
            if isinstance(it, int):
                t += it
                continue
            f.write(struct.pack("<IIII", t // 1_000_000, t % 1_000_000, len(it), len(it)) + it)
            t += 100
    return str(path)


def alarm(plc, slot, seq=0):
    """A diagnosis alarm (ChannelDiagnosis 0x9011, a user parameter assignment error) of the encoder's telegram
    submodule, from the device to ``plc``'s AlarmCR (the device's alarm reference is the same in every AR)."""
    pdu = rta(0x11, 0x11, seq, 0xFFFE, notification(0x0001, 0xA801, channel_item(0x8000, 0x0800, 0x9011),
                                                    slot=slot, subslot=2))
    return R.eth(R.DEVICE_MAC, plc[0], struct.pack(">H", 0xFE01) + pdu, 0x8892)


def p65000(ref, value):
    """Change request of P65000 (U32) and its positive response."""
    return (build_param_request(ref, 2, [{"pnu": 65000, "format": 0x43, "values": [value]}]),
            build_param_response(ref, 2, no_of_parameters=1))


def judge(path):
    """(sorted (rule, slot) violations, summary, ar events) of the capture; the engine agrees with the reference
    path and the plugin in tshark with the core."""
    from test_fastpath import _same_both_ways
    evs = []
    a = analyze_file(path, Settings(), sink=lambda e: evs.append(e) if e["kind"] in ("violation", "ar") else None)
    _same_both_ways(path)
    if shutil.which("tshark"):
        from test_lua_plugin import compare
        n, bad, lua_viol, py_viol = compare(path)
        assert n and not bad and lua_viol == py_viol, (bad[:5], lua_viol ^ py_viol)
    viol = sorted((e["rule"], e.get("slot")) for e in evs if e["kind"] == "violation")
    return viol, a.summary(), [e for e in evs if e["kind"] == "ar"]


def ar_objects(ars, plc):
    """[IO data object rows of (slot, subslot 2)] in both CRs of the controller's AR (summary or ar events)."""
    ar, = [x for x in ars if x["controller_mac"] == plc[0]]
    return [o for cr in ar["iocrs"] for o in cr["objects"] if (o["slot"], o["subslot"]) == (1, 2)]


# -- 1, 2: another controller reads the encoder as Shared Input, or gets it locked -------------------------

def owner_a():
    """A owns the encoder in slot 1: it writes its 0xBF00 before PrmEnd."""
    a = Ar(PLC_A, encoder(1), (0x8000, 0x8001))
    a.frames += a.call(R.write_pair, 0xBF00, BF00) + a.call(R.prm_end_pair)
    return a


@pytest.mark.parametrize("props", [3 | SHARED, 3 | SHARED | REDUCE_OUT])
def test_shared_input_ar_is_not_judged(tmp_path, props):
    """B lists A's encoder as Shared Input beside its own IO module: its inputs are a copy of the encoder's
    (control requested while A controls it), its outputs zeros or, reduced, no bytes; it writes no 0xBF00 (the
    owner parameterises the module). Nothing is judged in B's AR: no false CTRLREQ-MISMATCH /
    STARTUP-NO-PARAM-RECORD; A's axis is judged as usual."""
    a = owner_a()
    b = Ar(PLC_B, [(1, 2, T81, props, 12, 4), (2, 1, DIO, 1, 2, 0)], (0x8010, 0x8011))
    b.frames += b.call(R.prm_end_pair)
    path = write(tmp_path / "shared-input.pcap", a.frames + cycles([a], 0, 50) + b.frames + cycles([a, b], 50, 400))
    viol, s, ars = judge(path)
    assert viol == []
    for o in ar_objects(s["session"]["ars"], PLC_B) + ar_objects(ars, PLC_B):   # input and output CR
        assert o["telegram"] is None and o["telegram_source"] == "not owned"
    for o in ar_objects(ars, PLC_B) + ar_objects(s["session"]["ars"], PLC_B):   # the ar event and the summary
        assert o["telegram_note"].startswith("not judged in this AR: shared input")
    from pndiss.verdict import not_checked   # the report says why
    assert [x for x in not_checked(s) if "1/2 in the AR of" in x and "shared input" in x]
    assert [o["telegram"] for o in ar_objects(s["session"]["ars"], PLC_A)] == [81, 81]
    enc, = s["cyclic"]["encoders"]
    assert (enc["slot"], enc["cycles"]) == (1, 400)


def test_locked_submodule_needs_no_user_parameters(tmp_path):
    """B lists the encoder module too, but the device answers it "locked by IO controller" (SubmoduleState
    0x8180, ARInfo 3) in a ModuleDiffBlock: B does not parameterise it (no 0xBF00), and that is no
    STARTUP-NO-PARAM-RECORD -- there is no data exchange with it in B's AR."""
    a = owner_a()
    subs = [struct.pack(">HIH", ss, ident, 0x8180) for ss, ident in ((1, MAP), (2, T81))]
    diff = R.block(0x8104, struct.pack(">HIHHIHH", 1, 0x3D00, 1, 1, 0x100, 2, 2) + b"".join(subs))
    b = Ar(PLC_B, encoder(1) + [(2, 1, DIO, 1, 2, 0)], (0x8010, 0x8011), diff=diff, locked={(1, 1), (1, 2)})
    b.frames += b.call(R.prm_end_pair)
    path = write(tmp_path / "locked.pcap", a.frames + cycles([a], 0, 50) + b.frames + cycles([a, b], 50, 300))
    viol, s, ars = judge(path)
    assert viol == []
    # the locked module keeps its telegram (a hand-over -- p-net's plug alarm and plug-PrmEnd -- makes it B's):
    # while locked its IOPS are bad, so none of B's cycles is judged
    assert [o["telegram"] for o in ar_objects(ars, PLC_B)] == [81, 81]
    judged = {(e["device_mac"], e["slot"], e["subslot"], e["cycles"] > 0) for e in s["cyclic"]["encoders"]}
    assert len(s["cyclic"]["encoders"]) == 2 and sum(e["cycles"] for e in s["cyclic"]["encoders"]) == 300, judged


@pytest.mark.parametrize("module_state,sub_state,words", [(1, 0x9000, "a wrong module"), (0, 0x9800, "no module")])
def test_wrong_or_missing_module_needs_no_user_parameters(tmp_path, module_state, sub_state, words):
    """The device answers the Connect with a ModuleDiffBlock: the encoder module in slot 1 is the wrong one
    (IdentInfo 2) or missing (IdentInfo 3); the controller rightly writes it no 0xBF00 and its IOPS stay bad. No
    STARTUP-NO-PARAM-RECORD, and the Trust section says what the device reported (an independent audit: the PLC
    was blamed, the mismatch not mentioned)."""
    subs = [struct.pack(">HIH", ss, ident, sub_state) for ss, ident in ((1, MAP), (2, T81))]
    diff = R.block(0x8104, struct.pack(">HIHHIHH", 1, 0x3D00, 1, 1, 0x100, module_state, 2) + b"".join(subs))
    a = Ar(PLC_A, encoder(1), (0x8000, 0x8001), diff=diff, locked={(1, 1), (1, 2)})
    a.frames += a.call(R.prm_end_pair)
    path = write(tmp_path / f"diff{module_state}.pcap", a.frames + cycles([a], 0, 100))
    viol, s, _ars = judge(path)
    assert viol == []
    from pndiss.verdict import trust
    assert any(f"reports {words} in slot 1" in line for line in trust(s)), trust(s)


@pytest.mark.parametrize("consumed", [False, True])
def test_outputs_the_device_does_not_consume_are_not_judged(tmp_path, consumed):
    """A Codesys-style controller sends GOOD outputs from the start; the device says with its IOCS of them (in its
    input frame) that it does not consume them until its ApplicationReady, and does not react to them until then:
    those cycles are not judged (an independent audit: CTRLREQ-MISMATCH and ABSVAL-ACK-MISSING against a correct
    encoder). The same reaction while its IOCS says GOOD is the encoder's fault."""
    a = owner_a()

    def enc(slot, i):   # control requested (ZSW2_ENC.9) only from cycle 60 on
        sp, act = still(slot, i)
        return sp, (act[:2] if i >= 60 else struct.pack(">H", struct.unpack(">H", act[:2])[0] & ~0x0200)) + act[2:]
    items = list(a.frames)
    for i in range(200):
        fr = a.cycle(i, enc)
        if i < 60 and not consumed:   # C_SDU byte 14 of the input frame: IOCS of slot 1/2's outputs (connect_pair)
            fr[1] = fr[1][:16 + 14] + b"\0" + fr[1][16 + 15:]
        items += fr + [800]
    viol, s, _ars = judge(write(tmp_path / f"iocs{int(consumed)}.pcap", items))
    assert viol == ([("CTRLREQ-MISMATCH", 1)] if consumed else [])
    if not consumed:
        (e,) = s["cyclic"]["encoders"]
        assert e["gated_cycles"] >= 59


# -- 3, 4: a device with two encoder modules, each owned by another controller -----------------------------

def two_owners():
    """A owns the encoder in slot 1, B the one in slot 3 and the IO module in slot 2; both parameterise theirs."""
    a = owner_a()
    b = Ar(PLC_B, encoder(3) + [(2, 1, DIO, 1, 2, 0)], (0x8010, 0x8011))
    b.frames += b.call(R.write_pair, 0xBF00, BF00, slot=3) + b.call(R.prm_end_pair)
    return a, b


def test_p65000_of_another_controllers_module_is_not_this_axis(tmp_path):
    """A writes P65000 = 0 to its module, B P65000 = 777 to its own (slot 3); A's absolute preset then goes to
    0, correctly: B's value is slot 3's Encoder Object's, not A's (no PRESET-VALUE-WRONG on slot 1)."""
    a, b = two_owners()
    at = {10: a.param(1, *p65000(1, 0)), 60: b.param(3, *p65000(1, 777))}
    path = write(tmp_path / "two-presets.pcap", a.frames + cycles([a], 0, 30, at=at) + b.frames
                 + cycles([a, b], 30, 300, enc=lambda s, i: still(s, i, (100, 104, 0) if s == 1 else None), at=at))
    viol, s, _ars = judge(path)
    assert viol == []
    enc = {e["slot"]: e for e in s["cyclic"]["encoders"]}
    assert (enc[1]["p65000"], enc[1]["presets_unjudged"], enc[3]["p65000"]) == (0, 0, 777)


def test_alarm_to_the_next_controller_is_not_the_vanished_ars(tmp_path):
    """A's AR ends without a Release in the capture; 3 s later B connects with the same frame IDs and writes a
    valid 0xBF00; a diagnosis alarm to B rejects it: one BF00-VALID-REJECTED, B's, not A's dead AR's too."""
    a = owner_a()
    b = Ar(PLC_B, encoder(1), (0x8000, 0x8001))
    b.frames += b.call(R.write_pair, 0xBF00, BF00) + b.call(R.prm_end_pair)
    path = write(tmp_path / "takeover-alarm.pcap", a.frames + cycles([a], 0, 200) + [3_000_000] + b.frames
                 + cycles([b], 200, 400, at={300: [alarm(PLC_B, 1)]}))
    viol, s, _ars = judge(path)
    assert viol == [("BF00-VALID-REJECTED", 1)]
    # B's accepted Connect owning the same encoder module means A's AR ended unseen (session_ar._taken_over)
    phase = {a["controller_mac"]: a["phase"] for a in s["session"]["ars"]}
    assert phase == {PLC_A[0]: "aborted", PLC_B[0]: "data_exchange"}, phase


def test_same_alarm_reference_towards_two_controllers(tmp_path):
    """The device numbers each AR's alarms from 0 with one alarm reference: two alarms 1 ms apart with send
    sequence number 0, to A for slot 1 and to B for slot 3, are two alarms (not an RTA resend): both judged."""
    a, b = two_owners()
    path = write(tmp_path / "alarm-each.pcap", a.frames + b.frames
                 + cycles([a, b], 0, 300, at={150: [alarm(PLC_A, 1)], 151: [alarm(PLC_B, 3)]}))
    viol, _s, _ars = judge(path)
    assert viol == [("BF00-VALID-REJECTED", 1), ("BF00-VALID-REJECTED", 3)]


# -- 5: parameter access pairing through the pipeline (one AR) ------------------------------------------------

DESCRIPTION = bytes([0x00, 0x06]) + bytes(range(2, 46))   # P922's complete description: 46 octets (records.md §3.7)
P922 = [{"pnu": 922}]


def param_case(case):
    """The parameter accesses of one case, as (request, response[, refused second request])."""
    if case == "description":   # attribute 0x20: the description, not P922's value
        return (build_param_request(1, 1, [{"pnu": 922, "attribute": 0x20}]),
                build_param_response(1, 1, [{"format": 0x0A, "values": list(DESCRIPTION)}]))
    if case == "refused-early":   # request 2 written while 1 is pending, refused; response 1: P922 = 83
        return (build_param_request(1, 1, P922), build_param_response(1, 1, [{"format": 0x06, "values": [83]}]),
                build_param_request(2, 1, [{"pnu": 65000}]))
    # an illegal request ID, answered as the profile says: response ID 0x80, error 0x21
    return build_param_request(3, 0x03, P922), build_param_response(3, 0x80, [{"error": 0x21}])


@pytest.mark.parametrize("case, want", [
    ("description", []),
    ("refused-early", ["BMP-PIPELINED", "TELEGRAM-SELECTION-MISMATCH"]),
    ("illegal-id", ["BMP-BAD-REQUEST"]),
])
def test_parameter_access_pairing(tmp_path, case, want):
    """A description read neither relabels the telegram nor reads as P922 = 0; a write the busy device refuses
    keeps request 1 pending (its response still judged: P922 = 83 in an AR running 81) and is still the
    controller's pipelining; response ID 0x80 is the right answer to an illegal request ID."""
    a = owner_a()
    path = write(tmp_path / f"{case}.pcap", a.frames + cycles([a], 0, 200, at={80: a.param(1, *param_case(case))}))
    viol, s, _ars = judge(path)
    assert [r for r, _slot in viol] == want
    enc, = s["cyclic"]["encoders"]
    assert enc["telegram"] == 81 and [o["telegram"] for o in ar_objects(s["session"]["ars"], PLC_A)] == [81, 81]
