"""A controller reconnects the same encoder after a project download (an independent audit's PLC start-up styles):
the Release, then a Connect with the same AR UUID (controllers reuse it) or a new one, and another telegram or
cycle time on the same frame IDs. The second connection is judged with its own configuration: no capture loss
from the old cycle step, no stale telegram from the first connection's P922 read or data lengths."""
from __future__ import annotations

import struct

import pytest

import rpc_frames as R
from pndiss.records.build import build_param_request, build_param_response
from test_shared_device import BF00, MAP, PLC_A, T81, Ar, judge, write

T83 = 0x1053
NEW_AR = (PLC_A[0], PLC_A[1], "33333333-9abc-def0-1234-56789abcdef0", PLC_A[3])


def encoder(ident, in_len):
    return [(1, 1, MAP, 0, 0, 0), (1, 2, ident, 3, in_len, 4)]


def enc83(slot, i):
    """telegram 81 or 83 by the caller's length: a correct V4.1 encoder at standstill under control by PLC."""
    sol = i % 15 + 1
    return (struct.pack(">HH", 0x0400 | sol << 12, 0),
            struct.pack(">HHIIi", 0x0200 | sol << 12, 0, 1000, 1000, 0))


def enc81(slot, i):
    sp, act = enc83(slot, i)
    return sp, act[:12]


def p922(ar, value, ref):
    req = build_param_request(ref, 1, [{"pnu": 922, "subindex": 0}])
    rsp = build_param_response(ref, 1, [{"format": 6, "values": [value]}])   # Unsigned16
    return ar.param(1, req, rsp)


def run_cycles(ar, enc, first, end, step, cycle_us):
    items = []
    for i in range(first, end):
        fr = ar.cycle(i, enc)
        # the counter advances by SendClockFactor x ReductionRatio per frame (wire.md §6.4)
        fr = [f[:-4] + struct.pack(">H", i * step % 65536) + f[-2:] for f in fr]
        items += fr + [cycle_us - 100 * len(fr)]
    return items


@pytest.mark.parametrize("uuid", ["same", "new"])
def test_download_with_another_telegram_and_cycle(tmp_path, uuid):
    """1 ms telegram 81, P922 read 81; Release; 2 ms telegram 83 on the same frame IDs, P922 read 83: no violation,
    no capture gap, and the second connection runs telegram 83 at 2 ms (the audit: every 2 ms frame was one lost
    cycle, the encoder's real faults went unjudged; with the AR UUID reused, a false TELEGRAM-SELECTION-MISMATCH)."""
    a = Ar(PLC_A, encoder(T81, 12), (0x8000, 0x8001))
    a.frames = list(R.connect_pair(a.subs, in_fid=0x8000, out_fid=0x8001, rr=(1, 1), plc=PLC_A))
    items = a.frames + a.call(R.write_pair, 0xBF00, BF00) + a.call(R.prm_end_pair)
    items += run_cycles(a, enc81, 0, 150, 32, 1000) + p922(a, 81, 1) + run_cycles(a, enc81, 150, 300, 32, 1000)
    items += a.call(R.release_pair) + [50_000]
    plc = PLC_A if uuid == "same" else NEW_AR
    b = Ar(plc, encoder(T83, 16), (0x8000, 0x8001))
    b.frames = list(R.connect_pair(b.subs, in_fid=0x8000, out_fid=0x8001, rr=(2, 2), plc=plc))
    b.seq = a.seq + 1 if uuid == "same" else 1
    items += b.frames + b.call(R.write_pair, 0xBF00, BF00) + b.call(R.prm_end_pair)
    items += run_cycles(b, enc83, 0, 150, 64, 2000) + p922(b, 83, 2) + run_cycles(b, enc83, 150, 300, 64, 2000)
    viol, summary, _ars = judge(write(tmp_path / f"reconnect-{uuid}.pcap", items))
    assert viol == []
    assert summary["cyclic"]["capture_gaps"]["count"] == 0
    last = summary["cyclic"]["encoders"][-1]
    assert last["telegram"] == 83 and last["settings"]["telegram"]["value"] == 83
    assert last["settings"]["cycle_ns"]["value"] == 2_000_000
