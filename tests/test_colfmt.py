"""Column sinks (pndiss/mcap_sink.py, pndiss/jsonl_sink.py): fed the engine's batches made from a
capture's reference events (tests/colfmt_producer.py), they write what the reference path writes:
the same MCAP messages per topic (and the same file when the driver says where each event was
emitted), the same JSONL lines; random column values format as json does; the bulk record writer
chunks and indexes as add_message does."""
from __future__ import annotations

import glob
import io
import json
import os
import random

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings as hsettings, strategies as st
from mcap.reader import make_reader

from colfmt_producer import Recorded, plan, play
from test_engine_sinks import _reference_lines
from pndiss import colrows
from pndiss import telegrams as tg
from pndiss.analyzer import analyze_file
from pndiss.jsonl_sink import JsonlSink
from pndiss.mcap_export import McapExporter
from pndiss.mcap_sink import McapSink
from pndiss.sinks import CycleBatch, StreamBatch

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
PUBLIC = os.path.join(ROOT, "..", "shared", "captures", "public")
OURS = sorted(glob.glob(os.path.join(ROOT, "captures", "*.pcap*")))
# a spread of scenarios: faults decided late, several encoders, PS/PSM bits, sensor errors, gaps
PICK = ("fault-absval-ack-missing", "fault-ackip-missing", "fault-cmd-executed-without-control",
        "fault-bf00-error-not-reported", "fault-dcp-name-duplicate", "startup-t89-psm", "sensor-error-t81-lika",
        "plant-3enc-cycles-io-devices", "plant-irt-loss-sol-skip", "plant-restart-abort", "plant-rt-loss-t81",
        "plant-mid-session-t83", "preset-t860-hohner", "parking-t81-scancon")
FEW = [c for c in OURS if os.path.basename(c).split(".")[0] in PICK]
PUBLIC_CAPS = sorted(glob.glob(os.path.join(PUBLIC, "*.pcap*")))
CI_KINDS = ("violation", "param", "record", "state", "capture_gap")

_dumps = json.JSONEncoder(separators=(",", ":"), default=str).encode


def _reference_jsonl(path: str, kinds=None) -> list[str]:
    """What ``pndiss analyze --jsonl`` writes on the reference path (the oracle of test_engine_sinks)."""
    lines = _reference_lines(path)
    return lines if kinds is None else [x for x in lines if json.loads(x)["kind"] in kinds]


def _messages(path: str) -> tuple[dict, dict]:
    """Messages per topic (log time, publish time, sequence, data) and channels per topic."""
    msgs = {}
    with open(path, "rb") as f:
        r = make_reader(f)
        for _sch, ch, m in r.iter_messages(log_time_order=False):
            msgs.setdefault(ch.topic, []).append((m.log_time, m.publish_time, m.sequence, m.data))
        s = r.get_summary()
    chans = {c.topic: (dict(c.metadata), s.schemas[c.schema_id].name, s.schemas[c.schema_id].data)
             for c in s.channels.values()}
    return msgs, chans


def _reference_mcap(path: str, out: str, **opts) -> None:
    e = McapExporter(out, path, None, **opts)
    analyze_file(path, None, e.on_event)
    e.close()


_RECORDED: dict = {}


def _recorded(path: str) -> Recorded:
    if path not in _RECORDED:
        _RECORDED[path] = Recorded(path)
    return _RECORDED[path]


# -- whole captures ---------------------------------------------------------------------------------
@pytest.mark.skipif(not FEW, reason="no captures in captures/")
@pytest.mark.parametrize("path", FEW, ids=os.path.basename)
def test_same_output_as_reference(path, tmp_path):
    rec = _recorded(path)
    ref_lines = _reference_jsonl(path)
    ref_mcap = str(tmp_path / "ref.mcap")
    _reference_mcap(path, ref_mcap)
    want_msgs, want_chans = _messages(ref_mcap)
    for every, positions in ((4096, True), (97, True), (4096, False), (13, False)):
        buf = io.StringIO()
        out = str(tmp_path / f"col{every}{positions}.mcap")
        sinks = [JsonlSink(buf), McapSink(out, path, None)]
        for s in sinks:   # small stretches: written at every flush point; else held until the end
            s.hold_rows = 0 if every < 1000 else s.hold_rows
        play(plan(rec, every), sinks, positions)
        got = buf.getvalue().splitlines()
        got_msgs, got_chans = _messages(out)
        assert got_chans == want_chans
        assert got_msgs == want_msgs, [t for t in want_msgs if got_msgs.get(t) != want_msgs[t]]
        if positions:   # the driver said where each event was emitted: the very same files
            assert got == ref_lines
            with open(out, "rb") as a, open(ref_mcap, "rb") as b:
                assert a.read() == b.read()
        else:           # placed by their frames: the same lines, each kind in the same order
            assert sorted(got) == sorted(ref_lines)
            for kind in {json.loads(x)["kind"] for x in ref_lines}:
                tag = f'"kind":"{kind}"'
                assert [x for x in got if tag in x] == [x for x in ref_lines if tag in x]


@pytest.mark.skipif(not PUBLIC_CAPS, reason="../shared/captures/public is missing")
def test_public_captures(tmp_path):
    for path in PUBLIC_CAPS:
        rec = Recorded(path)
        buf = io.StringIO()
        out = str(tmp_path / "col.mcap")
        play(plan(rec, 512), [JsonlSink(buf), McapSink(out, path, None)], True)
        assert buf.getvalue().splitlines() == _reference_jsonl(path), path
        ref = str(tmp_path / "ref.mcap")
        _reference_mcap(path, ref)
        assert _messages(out) == _messages(ref), path


@pytest.mark.skipif(not FEW, reason="no captures in captures/")
@pytest.mark.parametrize("opts", [{"on_change": True}, {"decimate": 3}, {"on_change": True, "decimate": 4},
                                  {"on_change": True, "keyframe_s": 0.002}, {"compression": "none"}],
                         ids=lambda o: ",".join(f"{k}={v}" for k, v in o.items()))
def test_volume_control(opts, tmp_path):
    for path in FEW[:4]:
        ref = str(tmp_path / "ref.mcap")
        _reference_mcap(path, ref, **opts)
        sink_opts = dict(opts)
        if "keyframe_s" in sink_opts:
            sink_opts["keyframe_ns"] = int(sink_opts.pop("keyframe_s") * 1e9)
        out = str(tmp_path / "col.mcap")
        s = McapSink(out, path, None, **sink_opts)
        s.hold_rows = 100
        play(plan(_recorded(path), 1000), [s], True)
        assert _messages(out) == _messages(ref), path
        e = McapExporter(str(tmp_path / "x.mcap"), path, None, **opts)
        analyze_file(path, None, e.on_event)
        e.close()
        assert s.summary()["dropped_samples"] == e.summary()["dropped_samples"]
        assert s.summary()["events_seen"] == e.summary()["events_seen"]


@pytest.mark.skipif(not FEW, reason="no captures in captures/")
def test_events_kinds_jsonl():
    """--events KINDS: the full JSONL's lines of those kinds (violation times set from frames it
    saw only as rows)."""
    for path in FEW[:6]:
        f = io.BytesIO()
        s = JsonlSink(f, CI_KINDS)
        s.hold_rows = 0
        assert not s.cycles and s.streams and s.kinds == frozenset(CI_KINDS)
        play(plan(_recorded(path), 300), [s])
        assert f.getvalue().decode().splitlines() == _reference_jsonl(path, CI_KINDS), path


# -- random columns ----------------------------------------------------------------------------------
I64 = st.integers(-(1 << 63), (1 << 63) - 1)


def _col(draw, name, n):
    s = tg.SIGNALS[name]
    bits = 8 * s["size"]
    lo, hi = (-(1 << (bits - 1)), (1 << (bits - 1)) - 1) if s["signed"] else (0, (1 << bits) - 1)
    vals = draw(st.lists(st.one_of(st.sampled_from([lo, hi, 0, 1]), st.integers(lo, hi)), min_size=n, max_size=n))
    return np.array(vals, np.uint64 if s["size"] == 8 and not s["signed"] else np.int64)


@st.composite
def cycle_batches(draw):
    t = draw(st.sampled_from(sorted(tg.TELEGRAMS)))
    d = draw(st.sampled_from(tg.DIRECTIONS))
    n = draw(st.integers(1, 6))
    names = tg.layout(t, d).names
    axis = {"station": draw(st.sampled_from(["enc-1", "ünï\"cöde", None])), "device_mac": "02:00:00:00:01:01",
            "api": draw(st.integers(0, 2**32 - 1)), "slot": draw(st.integers(0, 0xFFFF)),
            "subslot": draw(st.integers(0, 0xFFFF)), "telegram": t,
            "telegram_source": draw(st.sampled_from(["length", "P922", None])),
            "profile": draw(st.sampled_from(("generic", *tg.PROFILES)))}
    frames = np.array(sorted(draw(st.lists(st.integers(0, (1 << 63) - 1), min_size=n, max_size=n))), np.int64)
    return CycleBatch(axis=axis, direction=d, frame_id=draw(st.integers(0, 0xFFFF)), frame=frames,
                      ts_ns=np.array(draw(st.lists(I64, min_size=n, max_size=n)), np.int64),
                      iops=np.array(draw(st.lists(st.integers(-1, 255), min_size=n, max_size=n)), np.int16),
                      judged=np.array(draw(st.lists(st.booleans(), min_size=n, max_size=n)), bool),
                      signals={nm: _col(draw, nm, n) for nm in names})


@hsettings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(cycle_batches())
def test_random_telegram_rows_format_as_json(b):
    f = io.BytesIO()
    s = JsonlSink(f)
    s.cycle_batch(b)
    s.close()
    want = "".join(_dumps(colrows.telegram_event(b, i)) + "\n" for i in range(len(b)))
    assert f.getvalue().decode() == want
    for i in range(len(b)):   # the event itself is the reference's: signals as decoded, bits as telegrams.bits
        ev = colrows.telegram_event(b, i)
        assert ev["bits"] == tg.bits(ev["signals"], b.axis["profile"])


@st.composite
def stream_batches(draw):
    n = draw(st.integers(1, 5))
    tagged = draw(st.booleans())
    off = 18 if tagged else 14
    fid = draw(st.sampled_from([0x8000, 0x8001, 0xC000, 0x0100, 0xBC00, 0xF800]))
    length = draw(st.integers(off + 6, off + 60))
    rows = []
    for _ in range(n):
        head = bytes.fromhex("020000000101") + bytes.fromhex("020000000001")
        if tagged:
            head += draw(st.sampled_from([b"\x81\x00", b"\x88\xa8", b"\x91\x00"])) + draw(st.binary(min_size=2, max_size=2))
        head += b"\x88\x92" + fid.to_bytes(2, "big")
        rows.append(head + draw(st.binary(min_size=length - len(head), max_size=length - len(head))))
    frames = np.array(sorted(draw(st.lists(st.integers(0, (1 << 63) - 1), min_size=n, max_size=n))), np.int64)
    return StreamBatch(key=(fid, "02:00:00:00:00:01", "02:00:00:00:01:01"), frame=frames,
                       ts_ns=np.array(draw(st.lists(I64, min_size=n, max_size=n)), np.int64),
                       data=np.frombuffer(b"".join(rows), np.uint8).reshape(n, length), off=off)


@hsettings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(stream_batches())
def test_random_stream_rows_format_as_json(b):
    f = io.BytesIO()
    s = JsonlSink(f)
    s.stream_batch(b)
    s.close()
    want = "".join(_dumps(colrows.rt_event(b, i, True)) + "\n" for i in range(len(b)))
    assert f.getvalue().decode() == want


def test_bulk_records_chunk_and_index_as_add_message():
    """McapWriter.add_records (records laid out by coltext) gives the bytes add_message gives."""
    from pndiss.coltext import INT, Pool, Val
    from pndiss.mcap_writer import McapWriter

    for trial in range(60):
        rnd = random.Random(trial)
        size = rnd.choice([1, 60, 300, 4096, 1 << 20])
        comp = rnd.choice(["none", "zstd"])
        a, b = io.BytesIO(), io.BytesIO()
        wa, wb = McapWriter(a, chunk_size=size, compression=comp), McapWriter(b, chunk_size=size, compression=comp)
        for w in (wa, wb):
            w.start()
            sid = w.register_schema("s", "jsonschema", b"{}")
            for c in range(3):
                w.register_channel(f"/t{c}", "json", sid)
        pool = Pool()
        tmpl = pool.template({"frame": Val(INT, 0), "x": "y" * rnd.randint(0, 40)}, _dumps)
        for _ in range(rnd.randint(1, 5)):
            n = rnd.randint(1, 200)
            fr = np.array([rnd.randint(0, 10**12) for _ in range(n)], np.int64)
            cid = np.array([rnd.randint(1, 3) for _ in range(n)], np.int64)
            lt = np.array([rnd.randint(0, 2**62) for _ in range(n)], np.int64)
            pub = np.array([rnd.randint(0, 2**62) for _ in range(n)], np.int64)
            seq = fr & 0xFFFFFFFF
            for i in range(n):
                wa.add_message(int(cid[i]), int(lt[i]), pool_text(pool, tmpl, fr[i]), int(pub[i]), int(seq[i]))
            pool.render(np.full(n, tmpl), np.arange(n), fr,
                        lambda data, ends, lo, hi: wb.add_records(data, ends, cid[lo:hi], lt[lo:hi]),
                        hdr=(cid, seq, lt, pub), step=rnd.choice([1, 7, 8192]))
        for w in (wa, wb):
            w.finish()
        assert a.getvalue() == b.getvalue(), (trial, size)


def pool_text(pool, tmpl, frame) -> bytes:
    out = []
    pool.render(np.array([tmpl]), np.array([0]), np.array([frame], np.int64), lambda d, e, lo, hi: out.append(bytes(d)))
    return out[0]
