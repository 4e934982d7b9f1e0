"""Frame numbering and block acceptance as tshark 4.0 (issue #18 item 4): one crafted pcapng per block
kind, read by pndiss and by the real tshark; the frame count and whether the file is refused must agree.
Time stamps that no sink can show (if_tsresol 0x00/0x80, huge raw values, if_tsoffset) are clamped
and counted (issue #17 item 2)."""
import struct
import subprocess

import pytest

from pndiss.analyzer import analyze_file
from pndiss.capture import TS_MAX, CaptureError, ReadInfo, open_capture
from test_capture import ETH, epb, idb, shb
from tsharkdiff import need_tshark


def raw(btype, body, blen=None, trail=None):
    """A block with chosen (possibly wrong) total lengths."""
    pad = (-len(body)) % 4
    n = 12 + len(body) + pad
    return struct.pack("<II", btype, blen or n) + body + bytes(pad) + struct.pack("<I", trail if trail is not None else (blen or n))


def idb_opts(opts: bytes, linktype=1):
    return raw(1, struct.pack("<HHI", linktype, 0, 0) + opts + struct.pack("<HH", 0, 0))


def opt(code, value: bytes):
    return struct.pack("<HH", code, len(value)) + value + bytes((-len(value)) % 4)


BASE = shb() + idb()
E1, E3 = epb(0, 1, ETH), epb(0, 3, ETH)
EPB_HDR = struct.pack("<IIIII", 0, 0, 2, len(ETH), len(ETH))

# name -> file; between two good packets one block of each kind, good or broken
CASES = {
    "custom-block-0x0bad": BASE + E1 + raw(0x0BAD, b"\x00\x00\x7e\x6f" + b"hello!!!") + E3,
    "custom-block-nocopy": BASE + E1 + raw(0x40000BAD, b"\x00\x00\x7e\x6f" + b"data") + E3,
    "custom-block-too-short": BASE + E1 + raw(0x0BAD, b"") + E3,
    "journal-block": BASE + E1 + raw(9, b"__REALTIME_TIMESTAMP=1\n\x00\x00") + E3,
    "journal-block-too-short": BASE + E1 + raw(9, b"") + E3,
    "unknown-block": BASE + E1 + raw(0x1234, b"abcd") + E3,
    "local-use-block": BASE + E1 + raw(0x80000001, b"abcd") + E3,
    "isb": BASE + E1 + raw(5, bytes(12)) + E3,
    "isb-too-short": BASE + E1 + raw(5, bytes(8)) + E3,
    "nrb": BASE + E1 + raw(4, bytes(4)) + E3,
    "nrb-too-short": BASE + E1 + raw(4, b"") + E3,
    "dsb": BASE + E1 + raw(10, struct.pack("<II", 0x544C534B, 4) + b"abcd") + E3,
    "epb-trailing-length-wrong": BASE + E1 + raw(6, EPB_HDR + ETH, trail=4) + E3,
    "epb-caplen-0": BASE + E1 + raw(6, struct.pack("<IIIII", 0, 0, 2, 0, 60)) + E3,
    "epb-too-short": BASE + E1 + raw(6, struct.pack("<IIII", 0, 0, 2, 0)) + E3,
    "epb-caplen-over-block": BASE + E1 + raw(6, struct.pack("<IIIII", 0, 0, 2, 100, 100) + ETH) + E3,
    "epb-caplen-262144": BASE + E1 + raw(6, struct.pack("<IIIII", 0, 0, 2, 262144, 262144) + bytes(262144)) + E3,
    "epb-caplen-262148": BASE + E1 + raw(6, struct.pack("<IIIII", 0, 0, 2, 262148, 262148) + bytes(262148)) + E3,
    "epb-caplen-over-origlen": BASE + E1 + raw(6, struct.pack("<IIIII", 0, 0, 2, len(ETH), 10) + ETH) + E3,
    "epb-bad-interface": BASE + E1 + raw(6, struct.pack("<IIIII", 5, 0, 2, len(ETH), len(ETH)) + ETH) + E3,
    "spb": BASE + E1 + raw(3, struct.pack("<I", len(ETH)) + ETH) + E3,
    "spb-origlen-2^31": BASE + E1 + raw(3, struct.pack("<I", 1 << 31) + ETH) + E3,
    "spb-origlen-short": BASE + E1 + raw(3, struct.pack("<I", 10) + ETH) + E3,
    "spb-too-short": BASE + E1 + raw(3, b"") + E3,
    "pb-obsolete": BASE + E1 + raw(2, struct.pack("<HHIIII", 0, 0, 0, 2, len(ETH), len(ETH)) + ETH) + E3,
    "idb-too-short": shb() + raw(1, struct.pack("<HH", 1, 0)) + E3,
    "block-length-8": BASE + E1 + struct.pack("<II", 0x1234, 8) + E3,
    "second-section": BASE + E1 + shb() + idb() + E3,
    "second-section-without-idb": BASE + E1 + shb() + E3,
}


def tshark_frames(path: str) -> tuple[int, bool]:
    """(frames tshark shows, whether it reported the file as damaged/cut short)."""
    r = subprocess.run([need_tshark(), "-n", "-r", path, "-T", "fields", "-e", "frame.number"],
                       capture_output=True, text=True)
    nums = [ln for ln in r.stdout.splitlines() if ln.strip()]
    return len(nums), "damaged or corrupt" in r.stderr or "cut short" in r.stderr


def pndiss_frames(path: str) -> tuple[int, bool]:
    n = 0
    try:
        for f in open_capture(path):
            n = f[0]
    except CaptureError as e:
        assert e.frames == n
        return n, True
    return n, False


@pytest.mark.parametrize("name", sorted(CASES))
def test_block_kind_as_tshark(tmp_path, name):
    p = tmp_path / f"{name}.pcapng"
    p.write_bytes(CASES[name])
    want = tshark_frames(str(p))
    assert pndiss_frames(str(p)) == want, name


def test_custom_block_frame_numbers(tmp_path):
    """The packet after a custom block is frame 3 in pndiss as in Wireshark, and the custom block
    itself is accounted (not PROFINET), so frames == decoded + not_profinet + malformed."""
    p = tmp_path / "cb.pcapng"
    p.write_bytes(CASES["custom-block-0x0bad"])
    got = [(f[0], f[2]) for f in open_capture(str(p))]
    assert got == [(1, 1), (2, -1), (3, 1)]
    a = analyze_file(str(p))
    s = a.summary()
    assert s["frames"] == 3 == sum(s["accounting"].values())
    assert s["accounting"]["not_profinet"] >= 1


@pytest.mark.parametrize("resol,raw_ts,want", [
    (0x00, 5, 5 * 10**9),                  # seconds
    (0x80, 5, 5 * 10**9),                  # 2^0: seconds too
    (0x7F, 5, 0),                          # 10^-127 s
    (0xFF, 5, 0),                          # 2^-127 s
    (0x00, 1_700_000_000_000_000, TS_MAX),  # a µs value read as seconds: beyond any sink, clamped
    (6, (1 << 64) - 1, TS_MAX),            # the largest 64-bit time stamp in µs
    (9, (1 << 63) + 5, TS_MAX),
])
def test_tsresol_clamped(tmp_path, resol, raw_ts, want):
    p = tmp_path / "ts.pcapng"
    p.write_bytes(shb() + idb(1, resol) + epb(0, raw_ts, ETH) + epb(0, raw_ts, ETH))
    info = ReadInfo()
    got = [f[1] for f in open_capture(str(p), info=info)]
    assert got == [want, want]
    assert info.ts_clamped == (2 if want == TS_MAX else 0)


def test_tsoffset_negative_clamped(tmp_path):
    p = tmp_path / "off.pcapng"
    p.write_bytes(shb() + idb_opts(opt(14, struct.pack("<q", -10))) + epb(0, 1, ETH)
                  + epb(0, 20_000_000, ETH))
    info = ReadInfo()
    got = [f[1] for f in open_capture(str(p), info=info)]
    assert got == [0, 10 * 10**9]
    assert info.ts_clamped == 1 and info.ts_clamped_first == 1


def test_hash_while_streaming(tmp_path):
    import hashlib
    from test_capture import pcap
    data = pcap([(i, 0, ETH) for i in range(50000)])
    p = tmp_path / "h.pcap"
    p.write_bytes(data)
    info = ReadInfo()
    assert sum(1 for _ in open_capture(str(p), info=info)) == 50000
    assert info.sha256() == hashlib.sha256(data).hexdigest()


def test_capture_tool_drop_counts_reported(tmp_path):
    """What the capture tool says it lost -- epb_dropcount on the packet after a loss, an old Packet Block's
    drops_count, an Interface Statistics Block's isb_ifdrop + isb_osdrop (cumulative: the last counts) -- is in the
    summary and the Trust section (an independent audit: ignored, and a lost parameter response became a
    controller's BMP-PIPELINED). tshark numbers the frames the same."""
    from pndiss.verdict import trust
    body = lambda ts, d, opts=b"": struct.pack("<IIIII", 0, 0, ts, len(d), len(d)) + d + bytes(-len(d) % 4) + opts
    drop = opt(4, struct.pack("<Q", 3)) + struct.pack("<HH", 0, 0)
    isb = lambda lost: raw(5, struct.pack("<III", 0, 0, 9) + opt(5, struct.pack("<Q", lost)) + opt(7, struct.pack("<Q", 2))
                          + struct.pack("<HH", 0, 0))
    pb = raw(2, struct.pack("<HHIIII", 0, 4, 0, 7, len(ETH), len(ETH)) + ETH)
    data = BASE + E1 + raw(6, body(5, ETH, drop)) + isb(5) + pb + E3 + isb(8)
    p = tmp_path / "drops.pcapng"
    p.write_bytes(data)
    s = analyze_file(str(p)).summary()
    assert s["input"]["tool_dropped"] == 3 + 4 and s["input"]["tool_dropped_first_frame"] == 2
    assert s["input"]["interface_dropped"] == 8 + 2
    assert any("the capture tool reports packets it dropped" in x for x in trust(s))
    need_tshark()
    assert tshark_frames(str(p))[0] == pndiss_frames(str(p))[0] == 4


def test_unknown_drop_counts_are_not_added():
    """dumpcap writes all ones into an ISB counter when pcap_stats() failed: unknown, not 2^64 - 1 drops."""
    import os
    import tempfile
    from pndiss.pcapng_read import UNKNOWN_COUNT, epb_options
    assert epb_options(struct.pack("<HHQ", 4, 8, UNKNOWN_COUNT) + struct.pack("<HH", 0, 0), 0, 16, "<") == (0, 0)
    isb = raw(5, struct.pack("<III", 0, 0, 9) + opt(5, struct.pack("<Q", UNKNOWN_COUNT)) + struct.pack("<HH", 0, 0))
    with tempfile.TemporaryDirectory() as d:
        p = os.path.join(d, "u.pcapng")
        with open(p, "wb") as f:
            f.write(BASE + E1 + isb + E3)
        s = analyze_file(p).summary()
    assert s["input"]["interface_dropped"] == 0
