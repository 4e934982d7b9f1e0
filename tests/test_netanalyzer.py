"""Captures of a Hilscher netANALYZER TAP (LINKTYPE_NETANALYZER, 240), common on PROFINET commissioning:
each record is a 4-byte little-endian header and the Ethernet frame with its FCS (Wireshark's
packet-netanalyzer.c). The same session written that way must give the same analysis as plain Ethernet,
and tshark with the plugin the same violations; GPIO events are frames with no packet."""
from __future__ import annotations

import os
import shutil
import struct
import subprocess
import zlib

import pytest

import capedit
from pndiss.analyzer import analyze_file
from pndiss.capture import open_capture
from pndiss.settings import Settings


def _record(frame: bytes) -> bytes:
    wire = frame + struct.pack("<I", zlib.crc32(frame))   # the FCS the TAP keeps
    return struct.pack("<I", (len(wire) << 16) | (1 << 10)) + wire   # status 0, header version 1, port 0


def _gpio() -> bytes:
    return struct.pack("<I", (1 << 10) | (1 << 8)) + bytes(30)          # a GPIO event: no Ethernet frame


def _write_pcap(path: str, recs) -> None:
    with open(path, "wb") as f:
        f.write(struct.pack("<IHHiIII", 0xA1B23C4D, 2, 4, 0, 0, 65535, 240))   # ns time stamps
        for ts, rec in recs:
            f.write(struct.pack("<IIII", ts // 1_000_000_000, ts % 1_000_000_000, len(rec), len(rec)) + rec)


@pytest.fixture(scope="module")
def caps(tmp_path_factory):
    tmp = str(tmp_path_factory.mktemp("netana"))
    src = capedit.simulate(os.path.join(tmp, "eth.pcapng"), "--scenario", "preset", "--cycles", "400",
                           "--inject", "PRESET-ACK-MISSING")
    frames = [(ts, bytes(d)) for _fn, ts, _lt, d in open_capture(src)]
    dst = os.path.join(tmp, "netana.pcap")
    recs = [(ts, _record(d)) for ts, d in frames]
    recs.insert(50, (frames[49][0], _gpio()))   # one GPIO event among the frames (frame 51)
    _write_pcap(dst, recs)
    return src, dst


def _run(path, fast):
    evs = []
    a = analyze_file(path, Settings(fast_path=fast), sink=lambda e: evs.append(e) if e["kind"] == "violation" else None)
    return a.summary(), [(e["rule"], e["frame"]) for e in evs]


def test_same_analysis_as_ethernet(caps):
    src, dst = caps
    _s0, want = _run(src, False)
    assert [r for r, _f in want] == ["PRESET-ACK-MISSING"]
    renum = [(r, f + (f > 50)) for r, f in want]   # the GPIO event is frame 51
    for fast in (False, True):
        s, got = _run(dst, fast)
        assert got == renum
        acc = s["accounting"]
        assert acc["malformed"] == 0 and acc["not_profinet"] == _s0["accounting"]["not_profinet"] + 1


@pytest.mark.skipif(shutil.which("tshark") is None, reason="tshark not installed")
def test_tshark_and_plugin_same(caps):
    from test_lua_plugin import rule_rows
    src, dst = caps
    n = subprocess.run(["tshark", "-r", dst, "-Y", "pn_rt", "-T", "fields", "-e", "frame.number"],
                       capture_output=True, text=True, check=True).stdout.split()
    m = subprocess.run(["tshark", "-r", src, "-Y", "pn_rt", "-T", "fields", "-e", "frame.number"],
                       capture_output=True, text=True, check=True).stdout.split()
    assert len(n) == len(m) > 0
    _s, want = _run(dst, True)
    assert {(f, r) for f, r, _d in rule_rows(dst)} == {(f, r) for r, f in want}


# -- Ethernet frames that keep their FCS: pcapng if_fcslen, pcap FCS length bits ---------------------

def _blk(t: int, body: bytes) -> bytes:
    body += b"\0" * (-len(body) % 4)
    return struct.pack("<II", t, 12 + len(body)) + body + struct.pack("<I", 12 + len(body))


def _write_fcs(path: str, frames, kind: str) -> None:
    fcs = [(ts, d + struct.pack("<I", zlib.crc32(d))) for ts, d in frames]
    with open(path, "wb") as f:
        if kind == "pcapng":
            f.write(_blk(0x0A0D0D0A, struct.pack("<IHHq", 0x1A2B3C4D, 1, 0, -1)))
            opts = struct.pack("<HHB3x", 9, 1, 9) + struct.pack("<HHB3x", 13, 1, 4) + struct.pack("<HH", 0, 0)
            f.write(_blk(1, struct.pack("<HHI", 1, 0, 0) + opts))   # if_tsresol 9, if_fcslen 4
            for ts, w in fcs:
                f.write(_blk(6, struct.pack("<IIIII", 0, ts >> 32, ts & 0xFFFFFFFF, len(w), len(w)) + w))
        elif kind == "pcapng-epb-flags":   # a TAP's way: no if_fcslen, the FCS length in each packet's epb_flags
            f.write(_blk(0x0A0D0D0A, struct.pack("<IHHq", 0x1A2B3C4D, 1, 0, -1)))
            f.write(_blk(1, struct.pack("<HHI", 1, 0, 0) + struct.pack("<HHB3x", 9, 1, 9) + struct.pack("<HH", 0, 0)))
            for k, (ts, w) in enumerate(fcs):
                flags = struct.pack("<HHI", 2, 4, (4 << 5) | (1 + k % 2))   # FCS length 4, inbound / outbound
                drops = struct.pack("<HHQ", 4, 8, 0) if k % 3 == 0 else b""   # epb_dropcount first in some
                body = struct.pack("<IIIII", 0, ts >> 32, ts & 0xFFFFFFFF, len(w), len(w)) + w + b"\0" * (-len(w) % 4)
                f.write(_blk(6, body + drops + flags + struct.pack("<HH", 0, 0)))
        else:   # link type 1 with the FCS-present bit and 2 x 16 bits of FCS (bits 26, 28-31)
            f.write(struct.pack("<IHHiIII", 0xA1B23C4D, 2, 4, 0, 0, 65535, 1 | 0x04000000 | (2 << 28)))
            for ts, w in fcs:
                f.write(struct.pack("<IIII", ts // 1_000_000_000, ts % 1_000_000_000, len(w), len(w)) + w)


@pytest.fixture(scope="module")
def fcs_caps(caps, tmp_path_factory):
    src = caps[0]
    tmp = str(tmp_path_factory.mktemp("fcs"))
    frames = [(ts, bytes(d)) for _fn, ts, _lt, d in open_capture(src)]
    out = {}
    for kind in ("pcapng", "pcap", "pcapng-epb-flags"):
        out[kind] = os.path.join(tmp, "fcs." + kind.split("-")[0])
        if kind != "pcapng" and kind.startswith("pcapng"):
            out[kind] = os.path.join(tmp, "fcs-flags.pcapng")
        _write_fcs(out[kind], frames, kind)
    return src, out


@pytest.mark.parametrize("kind", ("pcapng", "pcap", "pcapng-epb-flags"))
def test_fcs_is_cut_like_tshark(fcs_caps, kind):
    """Without cutting the FCS the APDU status (DataStatus, IOPS) was read from it: cycles not judged,
    the fault unseen, and with no word of it. The FCS length comes from the interface (if_fcslen, pcap's
    FCS bits) or, as a TAP writes it, from each packet's epb_flags (an independent audit: ignored, every
    encoder cycle unjudged, a real fault missed)."""
    src, out = fcs_caps
    s0, want = _run(src, False)
    for fast in (False, True):
        s, got = _run(out[kind], fast)
        assert got == want and s["cyclic"]["cycles_gated"] == s0["cyclic"]["cycles_gated"]
    if shutil.which("tshark"):
        ds = [subprocess.run(["tshark", "-r", p, "-Y", "pn_rt.ds", "-T", "fields", "-e", "pn_rt.ds"],
                             capture_output=True, text=True, check=True).stdout for p in (src, out[kind])]
        assert ds[0] == ds[1] != ""
