"""Capture reader: pcap (both byte orders, us/ns), pcapng (EPB/SPB/OPB, several interfaces,
tsresol), truncation, and frame numbers/timestamps equal to tshark's."""
import os
import struct
import subprocess

import pytest

from pndiss.capture import CaptureError, open_capture
from tsharkdiff import capture_files, need_tshark

ETH = bytes.fromhex("010ecf000000") + bytes.fromhex("0002030405aa") + b"\x88\x92\xfe\xfe" + bytes(42)


def pcap(frames, bo="<", ns=False, linktype=1):
    magic = 0xA1B23C4D if ns else 0xA1B2C3D4
    out = struct.pack(bo + "IHHiIII", magic, 2, 4, 0, 0, 65535, linktype)
    for sec, frac, data in frames:
        out += struct.pack(bo + "IIII", sec, frac, len(data), len(data)) + data
    return out


def block(btype, body, bo="<"):
    pad = (-len(body)) % 4
    n = 12 + len(body) + pad
    return struct.pack(bo + "II", btype, n) + body + bytes(pad) + struct.pack(bo + "I", n)


def shb(bo="<"):
    return block(0x0A0D0D0A, struct.pack(bo + "IHHq", 0x1A2B3C4D, 1, 0, -1), bo)


def idb(linktype=1, tsresol=None, bo="<"):
    opts = b""
    if tsresol is not None:
        opts = struct.pack(bo + "HH", 9, 1) + bytes([tsresol, 0, 0, 0]) + struct.pack(bo + "HH", 0, 0)
    return block(1, struct.pack(bo + "HHI", linktype, 0, 0) + opts, bo)


def epb(ifid, ts, data, bo="<"):
    return block(6, struct.pack(bo + "IIIII", ifid, ts >> 32, ts & 0xFFFFFFFF, len(data), len(data)) + data, bo)


def write(tmp_path, name, content):
    p = tmp_path / name
    p.write_bytes(content)
    return str(p)


@pytest.mark.parametrize("bo", ["<", ">"])
@pytest.mark.parametrize("ns", [False, True])
def test_pcap_byte_orders_and_resolution(tmp_path, bo, ns):
    p = write(tmp_path, "a.pcap", pcap([(10, 5, ETH), (11, 7, ETH[:20])], bo, ns))
    got = list(open_capture(p))
    mult = 1 if ns else 1000
    assert [(f[0], f[1], f[2], len(f[3])) for f in got] == [
        (1, 10 * 10**9 + 5 * mult, 1, len(ETH)), (2, 11 * 10**9 + 7 * mult, 1, 20)]


@pytest.mark.parametrize("bo", ["<", ">"])
def test_pcapng_interfaces_and_blocks(tmp_path, bo):
    data = (shb(bo) + idb(1, None, bo) + idb(1, 9, bo)
            + epb(0, 1_000_000, ETH, bo)        # us resolution: 1 s
            + epb(1, 2_000_000_000, ETH, bo)    # ns resolution: 2 s
            + block(3, struct.pack(bo + "I", len(ETH)) + ETH, bo)  # SPB: no time stamp, the one before it
            + block(2, struct.pack(bo + "HHIIII", 1, 0, 0, 5, len(ETH), len(ETH)) + ETH, bo)  # OPB
            + block(5, bytes(12), bo))  # ISB: no frame
    got = list(open_capture(write(tmp_path, "a.pcapng", data)))
    assert [(f[0], f[1]) for f in got] == [(1, 10**9), (2, 2 * 10**9), (3, 2 * 10**9), (4, 5)]
    assert all(f[3] == ETH for f in got)


def test_pcapng_binary_tsresol(tmp_path):
    data = shb() + idb(1, 0x80 | 10) + epb(0, 1024 * 3, ETH)
    assert list(open_capture(write(tmp_path, "b.pcapng", data)))[0][1] == 3 * 10**9


def test_truncated_mid_frame_reports_frames_read(tmp_path):
    raw = pcap([(1, 0, ETH), (2, 0, ETH)])
    p = write(tmp_path, "t.pcap", raw[:-10])
    frames = []
    with pytest.raises(CaptureError) as e:
        for f in open_capture(p):
            frames.append(f)
    assert len(frames) == 1 and e.value.frames == 1 and "truncated" in str(e.value)


@pytest.mark.parametrize("content,words", [(b"", "empty"), (b"hello world, not a capture", "not a pcap")])
def test_not_a_capture(tmp_path, content, words):
    with pytest.raises(CaptureError, match=words):
        list(open_capture(write(tmp_path, "x.pcap", content)))


@pytest.mark.parametrize("path", capture_files(), ids=os.path.basename)
def test_numbers_and_times_equal_tshark(path):
    tshark = need_tshark()
    out = subprocess.run([tshark, "-n", "-r", path, "-T", "fields", "-e", "frame.number", "-e", "frame.time_epoch",
                          "-e", "frame.cap_len"], capture_output=True, text=True, check=True).stdout.split("\n")
    theirs = [line.split("\t") for line in out if line]
    ours = list(open_capture(path))
    assert len(ours) == len(theirs)
    for (fn, ts, _lt, data), (tn, tt, tl) in zip(ours, theirs):
        sec, _, frac = tt.partition(".")
        assert (fn, ts, len(data)) == (int(tn), int(sec) * 10**9 + int(frac.ljust(9, "0")), int(tl))
