"""Robustness: random, truncated and mutated frames through the whole pipeline. Nothing but a
``malformed`` event may come of bad bytes: no exception escapes Analyzer.feed, and every frame
is counted exactly once."""
import os

from hypothesis import HealthCheck, given, settings, strategies as st

from pndiss.analyzer import Analyzer
from pndiss.capture import open_capture
from pndiss.proto import rt
from pndiss.proto.common import Malformed
from pndiss.proto.eth import decode_link
from tsharkdiff import capture_files

ETHERTYPES = [0x8892, 0x88CC, 0x0800, 0x88E3, 0x8100, 0x88A8, 0x0806]


def _seed_frames(limit=400):
    """Real frames from every capture, a few of each (by EtherType/FrameID) to mutate."""
    seen, frames = {}, []
    for p in capture_files():
        for _fn, _ts, lt, data in open_capture(p):
            key = (os.path.basename(p), data[12:16])
            if seen.get(key, 0) < 3 and lt == 1:
                seen[key] = seen.get(key, 0) + 1
                frames.append(data)
            if len(frames) >= limit:
                return frames
    return frames


SEEDS = _seed_frames()


def _feed(frames):
    events = []
    a = Analyzer(sink=events.append)
    for i, f in enumerate(frames, 1):
        a.feed(i, i * 1000, 1, bytes(f))
    a.finish()
    assert sum(a.counts.values()) == len(frames)
    return a, events


@settings(max_examples=300, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.sampled_from(ETHERTYPES), st.integers(0, 0xFFFF), st.binary(max_size=200))
def test_random_payloads(et, frame_id, payload):
    frame = bytes(12) + et.to_bytes(2, "big") + frame_id.to_bytes(2, "big") + payload
    _feed([frame])


@settings(max_examples=400, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(st.data())
def test_mutated_and_truncated_real_frames(data):
    base = bytearray(data.draw(st.sampled_from(SEEDS)))
    cut = data.draw(st.integers(0, len(base)))
    flips = data.draw(st.lists(st.tuples(st.integers(0, max(len(base) - 1, 0)), st.integers(0, 255)), max_size=6))
    for pos, val in flips:
        if pos < len(base):
            base[pos] = val
    _feed([bytes(base), bytes(base[:cut])])


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=80), st.sampled_from([1, 113, 276, 147]))
def test_link_layer(data, lt):
    try:
        dst, src, et, off, tags = decode_link(lt, data)
        assert off <= len(data)
    except Malformed:
        pass


@settings(max_examples=300, deadline=None)
@given(st.binary(max_size=64))
def test_apdu_status(pdu):
    try:
        ev = rt.decode_apdu_status(pdu, 0)
        assert ev["c_sdu_len"] == len(pdu) - 6
    except Malformed:
        assert len(pdu) < 6


def test_frame_id_classes_cover_every_id():
    names = {rt.classify(i)[0] for i in range(0x10000)}
    assert {"RTC1", "RTC3", "Alarm high", "Alarm low", "DCP Hello", "PTCP Delay", "FRAG"} <= names
