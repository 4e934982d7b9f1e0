"""Linux cooked captures (tcpdump -i any on a soft PLC or an edge box): SLL (linktype 113) and SLL2 (276)
carry the sender's address but no destination. The Connect still names both ends, so the AR's cyclic frames
are tied to it by frame ID and sender (session.lookup), in the Python core, the engine and the plugin."""
from __future__ import annotations

import shutil
import struct

import pytest

from pndiss.analyzer import analyze_file
from pndiss.settings import Settings
from test_multiaxis import multiaxis_capture


def _frames(path):
    data = open(path, "rb").read()
    off, out = 24, []
    while off < len(data):
        sec, usec, n, _orig = struct.unpack_from("<IIII", data, off)
        out.append((sec, usec, data[off + 16:off + 16 + n]))
        off += 16 + n
    return out


def _cooked(eth: bytes, linktype: int, outgoing: bool) -> bytes:
    src, etype, payload = eth[6:12], eth[12:14], eth[14:]
    ptype = 4 if outgoing else 0   # sent by this host / addressed to it
    if linktype == 113:
        return struct.pack(">HHH", ptype, 1, 6) + src + b"\0\0" + etype + payload
    return etype + b"\0\0" + struct.pack(">IHBB", 3, 1, ptype, 6) + src + b"\0\0" + payload


def _as_cooked(src_path, dst_path, linktype):
    plc = bytes.fromhex("020000000001")
    with open(dst_path, "wb") as f:
        f.write(struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, linktype))
        for sec, usec, fr in _frames(src_path):
            c = _cooked(fr, linktype, fr[6:12] == plc)
            f.write(struct.pack("<IIII", sec, usec, len(c), len(c)) + c)
    return dst_path


def _violations(path):
    evs = []
    a = analyze_file(path, Settings(), sink=lambda e: evs.append(e) if e["kind"] == "violation" else None)
    return [(e["rule"], e.get("slot"), e["frame"]) for e in evs], a.summary()


@pytest.mark.parametrize("linktype", [113, 276])
def test_cooked_capture_maps_the_ar_from_its_connect(tmp_path, linktype):
    from test_fastpath import _same_both_ways
    eth = multiaxis_capture(str(tmp_path / "eth.pcap"), fault_slot=2)
    cooked = _as_cooked(eth, str(tmp_path / f"ll{linktype}.pcap"), linktype)
    want, s_eth = _violations(eth)
    got, s = _violations(cooked)
    assert ("CTRLREQ-MISMATCH", 2, 306) in got and got == want
    assert s["cyclic"]["frames_mapped"] == s_eth["cyclic"]["frames_mapped"] == 600
    _same_both_ways(cooked)
    if shutil.which("tshark"):
        from test_lua_plugin import compare as plugin_compare
        n, bad, lua_viol, py_viol = plugin_compare(cooked)
        assert n and not bad and lua_viol == py_viol, bad[:5]


def _pcapng_as_pcap(src, dst):
    from pndiss.capture import open_capture
    with open(dst, "wb") as f:
        f.write(struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, 1))
        for _fn, ts, _lt, d in open_capture(src):
            d = bytes(d)
            f.write(struct.pack("<IIII", ts // 10**9, ts % 10**9 // 1000, len(d), len(d)) + d)
    return dst


@pytest.mark.parametrize("name", ["startup-t81-lika", "plant-restart-new-scaling"])
def test_cooked_simulated_sessions_as_their_ethernet_twin(tmp_path, name):
    """Whole sessions (DCP Set, the device providing before the Connect response, an AR restart) as a cooked
    capture: every cyclic frame is mapped as in the Ethernet original and the violations are the same -- a
    lookup that missed before the Connect is asked again, and a DCP Set, whose target the cooked header does not
    carry, claims no name for anybody (no false DCP-NAME-DUPLICATE / IP-ASSIGN-OCCUPIED)."""
    import os
    src = os.path.join(os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "captures", name + ".pcapng")
    if not os.path.exists(src):
        pytest.skip(f"captures/{name}.pcapng is missing")
    eth = _pcapng_as_pcap(src, str(tmp_path / "eth.pcap"))
    cooked = _as_cooked(eth, str(tmp_path / "sll.pcap"), 113)
    want, s_eth = _violations(eth)
    got, s = _violations(cooked)
    assert got == want
    assert s["cyclic"]["frames_mapped"] == s_eth["cyclic"]["frames_mapped"] > 0
    assert not s["cyclic"]["capture_gaps"]["stale"]
    if shutil.which("tshark"):
        from test_lua_plugin import compare as plugin_compare
        n, bad, lua_viol, py_viol = plugin_compare(cooked)
        assert n and not bad and lua_viol == py_viol, bad[:5]


def _pcapng(path, linktype, frames, tsresol=None, second=None):
    """A pcapng file: one interface of ``linktype`` (if_tsresol option when given), one EPB per frame; with
    ``second`` (a link type) a second interface, and every other frame (``frames`` as (frame, frame)) on it."""
    def block(bt, body):
        body += b"\0" * (-len(body) % 4)
        return struct.pack("<II", bt, len(body) + 12) + body + struct.pack("<I", len(body) + 12)
    opts = b"" if tsresol is None else struct.pack("<HHB3x", 9, 1, tsresol) + b"\0\0\0\0"
    with open(path, "wb") as f:
        f.write(block(0x0A0D0D0A, struct.pack("<IHHq", 0x1A2B3C4D, 1, 0, -1)))
        f.write(block(1, struct.pack("<HHI", linktype, 0, 65535) + opts))
        if second is not None:
            f.write(block(1, struct.pack("<HHI", second, 0, 65535)))
        for i, d in enumerate(frames):
            t = 1_700_000_000_000_000 + i * 1000
            ifid = i % 2 if second is not None else 0
            f.write(block(6, struct.pack("<IIIII", ifid, t >> 32, t & 0xFFFFFFFF, len(d), len(d)) + d))
    return path


@pytest.mark.parametrize("linktype,tsresol,second", [(113, None, None), (1, 0x80 | 30, None), (1, None, 113)])
def test_frames_the_engine_leaves_to_the_reader_are_taken_in_runs(tmp_path, monkeypatch, linktype, tsresol, second):
    """An interface the engine's window does not take (Linux cooked, dumpcap -i any; a binary if_tsresol): the
    reader takes its frames, a run at a time -- before, the window was indexed again for every frame
    (quadratic: 70 s for 40 k frames, found by an independent audit)."""
    from pndiss import frameindex
    eth = bytes.fromhex("020000000101 020000000001 8892") + bytes([0x80, 0x00]) + bytes(40) + bytes([0, 0, 0x35, 0])
    fr = _cooked(eth, 113, False) if linktype == 113 else eth
    frames = [fr, _cooked(eth, 113, False)] * 10000 if second else [fr] * 20000   # mixed: Ethernet and cooked NICs
    path = _pcapng(str(tmp_path / "c.pcapng"), linktype, frames, tsresol, second)
    calls = []
    orig = frameindex.pcapng
    monkeypatch.setattr(frameindex, "pcapng", lambda *a, **k: calls.append(1) or orig(*a, **k))
    from test_fastpath import _run_file
    s = _run_file(path, True)[0]   # the engine (the reference path reads frame by frame anyway)
    assert s["frames"] == 20000 and 0 < len(calls) < 50, len(calls)


def test_runs_between_frames_the_reader_takes_are_indexed_once(tmp_path, monkeypatch):
    """Runs of a dozen Ethernet frames between frames of a Linux cooked interface (an independent audit's TAP: an
    FCS port beside plain ones, 7 k frames/s): each run is indexed about once, not the whole 4 MiB window again
    for every run (quadratic) -- the bytes indexed stay a few times the file."""
    import os
    from pndiss import frameindex
    eth = bytes.fromhex("020000000101 020000000001 8892") + bytes([0x80, 0x00]) + bytes(40) + bytes([0, 0, 0x35, 0])
    ck = _cooked(eth, 113, False)
    frames = [ck if i % 13 == 12 else eth for i in range(60000)]
    path = str(tmp_path / "runs.pcapng")
    with open(path, "wb") as f:
        def block(bt, body):
            body += b"\0" * (-len(body) % 4)
            return struct.pack("<II", bt, len(body) + 12) + body + struct.pack("<I", len(body) + 12)
        f.write(block(0x0A0D0D0A, struct.pack("<IHHq", 0x1A2B3C4D, 1, 0, -1)))
        f.write(block(1, struct.pack("<HHI", 1, 0, 65535)) + block(1, struct.pack("<HHI", 113, 0, 65535)))
        for i, d in enumerate(frames):
            t = 1_700_000_000_000_000 + i * 1000
            f.write(block(6, struct.pack("<IIIII", int(d is ck), t >> 32, t & 0xFFFFFFFF, len(d), len(d)) + d))
    indexed = []
    orig = frameindex.pcapng
    monkeypatch.setattr(frameindex, "pcapng", lambda buf, pos, end, *a: indexed.append(end - pos) or orig(buf, pos, end, *a))
    from test_fastpath import _same_both_ways
    _same_both_ways(path)
    assert sum(indexed) < 8 * os.path.getsize(path), (sum(indexed), os.path.getsize(path))
