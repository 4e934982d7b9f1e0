"""MCAP export: every capture written, read back two ways (mcap-python, @mcap/core in Node),
counts per topic against the analyzer's own events, schemas, time order, volume control."""
from __future__ import annotations

import glob
import hashlib
import json
import os
import shutil
import subprocess
from collections import Counter

import jsonschema
import pytest
from hypothesis import HealthCheck, given, settings as hsettings, strategies as st
from mcap.reader import make_reader

from pndiss.analyzer import analyze_file
from pndiss.cli import main as cli_main
from pndiss.mcap_export import McapExporter
from pndiss.settings import Settings

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
NODE_DIR = os.path.join(ROOT, "tests", "node")
PUBLIC = os.path.join(ROOT, "..", "shared", "captures", "public")
CAPTURES = sorted(glob.glob(os.path.join(ROOT, "captures", "*.pcap*"))
                  + glob.glob(os.path.join(PUBLIC, "*.pcap*")))


# -- helpers ---------------------------------------------------------------------------------
def foxglove_problems(schema, path="$"):
    """What Foxglove's jsonschema reader would refuse (facts from foxglove/studio
    packages/mcap-support/src/parseJsonSchema.ts): an object needs "properties"; a property is a
    oneOf of numeric consts, or one type of boolean/string/number/integer, an object (same rules)
    or an array whose items are one of those."""
    if schema.get("type") != "object" or not isinstance(schema.get("properties"), dict):
        return [f"{path}: not an object with properties"]
    out = []
    for name, p in schema["properties"].items():
        where = f"{path}.{name}"
        if isinstance(p.get("oneOf"), list):
            if not all(isinstance(a.get("const"), (int, float)) for a in p["oneOf"]):
                out.append(f"{where}: oneOf alternatives must be numbers")
            continue
        t = p.get("type")
        if t == "object":
            out += foxglove_problems(p, where)
        elif t == "array":
            it = p.get("items")
            if not isinstance(it, dict) or it.get("type") not in ("boolean", "string", "number", "integer", "object"):
                out.append(f"{where}: array items need one type")
            elif it["type"] == "object":
                out += foxglove_problems(it, where + "[]")
        elif t not in ("boolean", "string", "number", "integer"):
            out.append(f"{where}: type {t!r} is not supported")
    return out


def _shape(v):
    """Structure and value types of a message (what a schema can reject), values aside."""
    if isinstance(v, dict):
        return tuple((k, _shape(x)) for k, x in v.items())
    if isinstance(v, list):
        return ("list", tuple(sorted({_shape(x) for x in v}, key=repr)))
    return type(v).__name__


def read_back(path, strict=True, every=1):
    """(per-topic counts, channels by topic, metadata, problems) reading the file in file order.
    strict: also validate messages against their schemas and sequence against the frame; with
    every=N only each new message shape per channel and every Nth message are validated
    (cyclic channels repeat one shape thousands of times; jsonschema costs ~0.3 ms a message)."""
    counts, chans, problems = Counter(), {}, []
    last_t = {}
    validators = {}
    shapes, fox_checked = set(), set()
    with open(path, "rb") as f:
        r = make_reader(f)
        for schema, ch, m in r.iter_messages(log_time_order=False):
            counts[ch.topic] += 1
            chans[ch.topic] = ch
            if m.log_time < last_t.get(ch.id, 0):
                problems.append(f"{ch.topic}: log time steps back at sequence {m.sequence}")
            last_t[ch.id] = m.log_time
            assert schema is not None and schema.encoding == "jsonschema" and ch.message_encoding == "json"
            msg = json.loads(m.data)
            if schema.id not in fox_checked:
                fox_checked.add(schema.id)
                if not strict:
                    problems += foxglove_problems(json.loads(schema.data), schema.name)
            if not strict:
                continue
            frame = msg.get("line") if schema.name == "foxglove.Log" else msg.get("frame")
            if frame is not None and frame != m.sequence:
                problems.append(f"{ch.topic}: sequence {m.sequence} != frame {frame}")
            if every > 1 and counts[ch.topic] % every:
                sh = (ch.id, _shape(msg))
                if sh in shapes:
                    continue
                shapes.add(sh)
            v = validators.get(schema.id)
            if v is None:
                v = validators[schema.id] = jsonschema.Draft202012Validator(json.loads(schema.data))
                problems += foxglove_problems(json.loads(schema.data), schema.name)
            for e in v.iter_errors(msg):
                problems.append(f"{ch.topic} frame {m.sequence}: {e.message}")
        summary = r.get_summary()
        meta = {md.name: md.metadata for md in r.iter_metadata()}
    # Foxglove keys datatypes by schema name: two different schemas must not share one
    by_name = Counter(sc.name for sc in summary.schemas.values())
    problems += [f"schema name {n} names {c} schemas" for n, c in by_name.items() if c > 1]
    stats = summary.statistics.channel_message_counts
    for cid, ch in summary.channels.items():
        if stats.get(cid, 0) != counts[ch.topic]:
            problems.append(f"{ch.topic}: statistics say {stats.get(cid, 0)}, read {counts[ch.topic]}")
    return counts, chans, meta, problems


def family(topic):
    parts = topic.split("~")[0].split("/")
    if topic == "/pn/violations":
        return "violation"
    if len(parts) == 3:  # /pn/<kind>
        return {"alarms": "alarm"}.get(parts[2], parts[2])
    if len(parts) > 4 and parts[3] == "apdu":
        return "apdu"
    if parts[-1] in ("setpoint", "actual"):
        return "telegram"
    return {"encoder_state": "state", "records": "records"}[parts[3]]


_node_ready = None


def node_reader(paths):
    """Per-file results of the Node reader, or None when Node is missing (outside CI)."""
    global _node_ready
    if shutil.which("node") is None:
        if os.environ.get("CI") == "true":
            pytest.fail("node is needed for the independent MCAP reader (scripts/test installs it)")
        return None
    if _node_ready is None:
        if not os.path.isdir(os.path.join(NODE_DIR, "node_modules", "@mcap", "core")):
            subprocess.run(["npm", "install", "--silent", "--no-audit", "--no-fund"], cwd=NODE_DIR,
                           check=True, timeout=300, capture_output=True)
        _node_ready = True
    p = subprocess.run(["node", os.path.join(NODE_DIR, "read_mcap.mjs"), *paths], capture_output=True,
                       text=True, timeout=300)
    assert p.returncode == 0, p.stderr
    return json.loads(p.stdout)


# -- real captures ---------------------------------------------------------------------------
def _export_one(cap, out):
    """Analyse + export one capture; keep only what the checks need (never the event list)."""
    fam, rt_groups, tg_groups = Counter(), Counter(), Counter()
    settings = Settings()
    exp = McapExporter(out, cap, settings)

    def sink(ev):
        k = ev["kind"]
        if k == "rt":
            if "cycle_counter" in ev:
                fam["apdu"] += 1
                rt_groups[(ev["src"], ev["dst"], ev["frame_id"])] += 1
        elif k == "telegram":
            fam["telegram"] += 1
            tg_groups[(ev.get("device_mac"), str(ev.get("slot")), str(ev.get("subslot")))] += 1
        elif k in ("record", "param", "record_result"):
            fam["records"] += 1
        else:
            fam[k] += 1
        exp.on_event(ev)
    try:
        a = analyze_file(cap, settings, sink)
    finally:
        exp.close()
    return {"out": out, "fam": fam, "rt": rt_groups, "tg": tg_groups, "violations": a.kinds["violation"],
            "settings": settings.as_dict()}


@pytest.fixture(scope="session")
def exports(tmp_path_factory):
    """Every capture exported once; the Node reader run once over all the files."""
    d = tmp_path_factory.mktemp("mcap")
    res = {cap: _export_one(cap, str(d / f"{i}.mcap")) for i, cap in enumerate(CAPTURES)}
    node = node_reader([r["out"] for r in res.values()]) if res else None
    for r in res.values():
        r["node"] = None if node is None else node[r["out"]]
    return res


@pytest.mark.skipif(not CAPTURES, reason="no captures")
@pytest.mark.parametrize("cap", CAPTURES, ids=os.path.basename)
def test_capture_roundtrip(cap, exports):
    r = exports[cap]
    counts, chans, meta, problems = read_back(r["out"], every=25)
    assert problems == []
    # counts per topic family equal the analyzer's own event counts
    fam = Counter()
    for t, n in counts.items():
        fam[family(t)] += n
    assert +fam == +r["fam"]
    assert fam["violation"] == r["violations"]
    # finer: one channel per (src, dst, frame ID) of cyclic frames and per telegram submodule,
    # matched through the channel metadata rather than the topic text
    got = Counter()
    for t, ch in chans.items():
        if family(t) == "apdu":
            got[(ch.metadata["src"], ch.metadata["dst"], int(ch.metadata["frame_id"], 16))] += counts[t]
    assert got == r["rt"]
    got = Counter()
    for t, ch in chans.items():
        if family(t) == "telegram":
            got[(ch.metadata.get("device_mac"), ch.metadata["slot"], ch.metadata["subslot"])] += counts[t]
    assert got == r["tg"]
    # the metadata record names the capture and the settings in force
    md = meta["pndiss"]
    with open(cap, "rb") as f:
        assert md["capture_sha256"] == hashlib.sha256(f.read()).hexdigest()
    assert json.loads(md["settings"]) == json.loads(json.dumps(r["settings"]))
    # the independent reader (indexed, CRCs validated) agrees
    node = r["node"]
    if node is not None:
        assert "error" not in node, node
        assert node["badJson"] == 0
        assert node["topics"] == {t: counts.get(t, 0) for t in node["topics"]}
        assert set(node["topics"]) >= set(counts)
        assert node["metadata"]["pndiss"]["capture_sha256"] == md["capture_sha256"]


def test_input_digest_only_for_a_sink_that_shows_it(tmp_path):
    """The SHA-256 of the input (~0.8 s of CPU per GB) is taken while reading only when a sink declares it needs
    it (the MCAP file's metadata): a plain analysis does not pay for it."""
    from pndiss.driver import analyze
    from pndiss.mcap_sink import McapSink
    cap = CAPTURES[0]
    assert analyze(cap).reader.sha256() is None
    sink = McapSink(str(tmp_path / "d.mcap"), cap, None)
    a = analyze(cap, None, [sink])
    sink.close()
    with open(cap, "rb") as f:
        assert a.reader.sha256() == hashlib.sha256(f.read()).hexdigest()


# -- synthetic streams -----------------------------------------------------------------------
DEV, CTRL = "00:0e:cf:00:00:01", "00:1b:1b:00:00:02"


def tg(frame, ts, direction, words, **kw):
    ev = {"frame": frame, "ts_ns": ts, "kind": "telegram", "direction": direction, "telegram": 81,
          "station": "enc-1", "device_mac": DEV, "api": 0x3D00, "slot": 1, "subslot": 2,
          "frame_id": 0x8001 if direction == "actual" else 0x8000,
          "signals": {"G1_XIST1": words[0], "G1_ZSW": words[1]},
          "bits": {"G1_ZSW.15": words[1] >> 15 & 1}}
    ev.update(kw)
    return ev


def rt(frame, ts, cc, src=DEV, dst=CTRL, fid=0x8001, ds=0x35):
    return {"frame": frame, "ts_ns": ts, "kind": "rt", "src": src, "dst": dst, "frame_id": fid,
            "frame_class": "RTC1", "cycle_counter": cc, "ds": ds, "transfer_status": 0, "c_sdu_len": 40}


def export(tmp_path, events, **kw):
    out = str(tmp_path / "s.mcap")
    exp = McapExporter(out, None, Settings(), **kw)
    for ev in events:
        exp.on_event(ev)
    exp.close()
    return out, exp


def test_synthetic_topics_and_log(tmp_path):
    evs = [
        {"frame": 1, "ts_ns": 10, "kind": "ar", "station": "enc-1", "device_mac": DEV, "controller_mac": CTRL},
        rt(2, 1_000, 7, src=CTRL, dst=DEV, fid=0x8000),
        tg(2, 1_000, "setpoint", (0, 0x0400)),
        rt(3, 2_000, 7),
        tg(3, 2_000, "actual", (123, 0x8000)),
        {"frame": 3, "ts_ns": 2_000, "kind": "state", "station": "enc-1", "device_mac": DEV, "state": "OPERATE"},
        {"frame": 4, "ts_ns": 3_000, "kind": "record", "station": "enc-1", "device_mac": DEV, "op": "write",
         "index": 0xBF00, "data": b"\x01\x02"},
        {"frame": 5, "ts_ns": 4_000, "kind": "violation", "rule": "R-X", "side": "encoder", "severity": "warning",
         "last_frame": 6, "message": "late ack"},
        {"frame": 6, "ts_ns": 5_000, "kind": "dcp", "src": DEV, "dst": CTRL},
        {"frame": 7, "ts_ns": 6_000, "kind": "malformed", "layer": "pn_rt", "reason": "short"},
        {"frame": 8, "ts_ns": 7_000, "kind": "mystery", "x": float("nan")},
    ]
    out, exp = export(tmp_path, evs)
    counts, chans, meta, problems = read_back(out)
    assert problems == []
    assert dict(counts) == {
        "/pn/enc-1/apdu/0x8000/output": 1, "/pn/enc-1/1.2/tg81/setpoint": 1, "/pn/enc-1/apdu/0x8001/input": 1,
        "/pn/enc-1/1.2/tg81/actual": 1, "/pn/enc-1/encoder_state": 1, "/pn/enc-1/records": 1,
        "/pn/violations": 1, "/pn/dcp": 1, "/pn/malformed": 1, "/pn/ar": 1, "/pn/mystery": 1}
    assert chans["/pn/enc-1/1.2/tg81/actual"].metadata["telegram"] == "81"
    assert chans["/pn/enc-1/apdu/0x8000/output"].metadata["device_mac"] == DEV  # named after the device, not the sender
    with open(out, "rb") as f:
        msgs = {ch.topic: (s, json.loads(m.data)) for s, ch, m in make_reader(f).iter_messages()}
    s, log = msgs["/pn/violations"]
    assert s.name == "foxglove.Log"
    assert log["level"] == 3 and log["name"] == "R-X" and log["line"] == 5
    assert log["timestamp"] == {"sec": 0, "nsec": 4000}
    assert "frames 5-6" in log["message"] and "late ack" in log["message"]
    assert msgs["/pn/mystery"][1]["x"] is None  # NaN cannot go into JSON
    assert msgs["/pn/enc-1/records"][1]["data"] == "0102"
    tgs = json.loads(msgs["/pn/enc-1/1.2/tg81/actual"][0].data)
    assert set(tgs["properties"]["signals"]["properties"]) == {"G1_XIST1", "G1_ZSW"}


def test_declared_schemas_foxglove_readable():
    from pndiss.mcap_schemas import SCHEMAS
    for name, sch in SCHEMAS.items():
        assert foxglove_problems(sch, name) == []
    assert foxglove_problems({"type": "object", "properties": {"a": {"type": ["string", "null"]}}})  # the checker bites


def test_duplicate_station_names(tmp_path):
    other = "00:0e:cf:00:00:09"
    evs = [tg(1, 1, "actual", (1, 0)), tg(2, 2, "actual", (1, 0), device_mac=other)]
    out, _ = export(tmp_path, evs)
    assert sorted(read_back(out)[0]) == ["/pn/enc-1/1.2/tg81/actual", "/pn/enc-1_00-0e-cf-00-00-09/1.2/tg81/actual"]


def test_station_label_without_name(tmp_path):
    out, _ = export(tmp_path, [rt(1, 5, 1, src="aa:bb:cc:dd:ee:ff", dst="11:22:33:44:55:66")])
    counts, *_ = read_back(out)
    assert list(counts) == ["/pn/aa-bb-cc-dd-ee-ff/apdu/0x8001"]


def test_same_frame_id_both_ways(tmp_path):
    # frame IDs are chosen by the receiver: both directions of one AR may carry 0x8000
    evs = [{"frame": 1, "ts_ns": 1, "kind": "ar", "station": "enc-1", "device_mac": DEV, "controller_mac": CTRL},
           rt(2, 2, 1, src=CTRL, dst=DEV, fid=0x8000), rt(3, 3, 1, src=DEV, dst=CTRL, fid=0x8000),
           rt(4, 4, 2, src=CTRL, dst=DEV, fid=0x8000)]
    out, _ = export(tmp_path, evs)
    counts, _, _, problems = read_back(out)
    assert problems == []
    assert dict(counts) == {"/pn/ar": 1, "/pn/enc-1/apdu/0x8000/output": 2, "/pn/enc-1/apdu/0x8000/input": 1}
    # and when nothing tells the roles, the topic names stay unique anyway
    out, _ = export(tmp_path, [rt(1, 1, 1, fid=0x8000, src="a"), rt(1, 1, 1, fid=0x8000, src="a", dst="c")])
    assert sorted(read_back(out)[0]) == ["/pn/a/apdu/0x8000", "/pn/a/apdu/0x8000~2"]


def test_time_clamped_per_channel(tmp_path):
    # a capture whose clock steps back, and a violation reported late for an earlier frame
    evs = [rt(1, 5_000, 1), rt(2, 4_000, 2), rt(3, 6_000, 3),
           {"frame": 3, "ts_ns": 6_000, "kind": "violation", "rule": "R-A", "side": "encoder", "severity": "error", "message": "m"},
           {"frame": 1, "ts_ns": 5_000, "kind": "violation", "rule": "R-B", "side": "encoder", "severity": "info", "message": "m"}]
    out, _ = export(tmp_path, evs)
    counts, _, _, problems = read_back(out)
    assert problems == [] and counts["/pn/violations"] == 2
    with open(out, "rb") as f:
        pub = [(m.log_time, m.publish_time) for _, ch, m in make_reader(f).iter_messages(log_time_order=False)
               if ch.topic.endswith("0x8001")]
    assert pub == [(5_000, 5_000), (5_000, 4_000), (6_000, 6_000)]


def test_apdu_deltas(tmp_path):
    evs = [rt(i + 1, 1_000_000 * i, (0xFFF0 + 32 * i) & 0xFFFF) for i in range(4)]
    out, _ = export(tmp_path, evs)
    with open(out, "rb") as f:
        msgs = [json.loads(m.data) for _, _, m in make_reader(f).iter_messages()]
    assert "d_cycle" not in msgs[0]
    assert [m["d_cycle"] for m in msgs[1:]] == [32, 32, 32]
    assert [m["dt_ns"] for m in msgs[1:]] == [1_000_000] * 3


def _model(words, times, on_change, decimate, keyframe_ns):
    """Which samples volume control keeps, written out plainly."""
    kept, last_w, last_t = [], object(), None
    for i, (w, t) in enumerate(zip(words, times)):
        if not on_change:
            keep = i % decimate == 0
        else:
            keep = w != last_w or last_t is None or t - last_t >= keyframe_ns or (decimate > 1 and i % decimate == 0)
            last_w = w
        if keep:
            kept.append(i)
            last_t = t
    return kept


@pytest.mark.parametrize("on_change,decimate", [(False, 1), (False, 5), (True, 1), (True, 7)])
def test_volume_control(tmp_path, on_change, decimate):
    n = 400
    period = 4_000_000  # 4 ms cycle: a keyframe every 250 samples
    words = [(i // 60) * 10 for i in range(n)]  # position steps every 60 cycles
    times = [i * period for i in range(n)]
    evs = [tg(i + 1, times[i], "actual", (words[i], 0)) for i in range(n)]
    out, exp = export(tmp_path, evs, on_change=on_change, decimate=decimate)
    with open(out, "rb") as f:
        frames = [m.sequence for _, _, m in make_reader(f).iter_messages()]
    want = [i + 1 for i in _model(words, times, on_change, decimate, 1_000_000_000)]
    assert frames == want
    assert exp.dropped == n - len(want)
    if on_change:
        assert len(want) < n


@pytest.mark.parametrize("comp", ["none", "lz4", "zstd"])
def test_compression(tmp_path, comp):
    pytest.importorskip("lz4") if comp == "lz4" else None
    evs = [rt(i + 1, i * 1000, i) for i in range(300)]
    out, _ = export(tmp_path, evs, compression=comp, chunk_size=2000)
    counts, _, _, problems = read_back(out)
    assert problems == [] and counts["/pn/00-0e-cf-00-00-01/apdu/0x8001"] == 300
    with open(out, "rb") as f:
        chunks = make_reader(f).get_summary().chunk_indexes
    assert len(chunks) > 1
    assert {c.compression for c in chunks} == {"" if comp == "none" else comp}
    node = node_reader([out])
    if node is not None:
        assert node[out]["topics"] == dict(counts)


# -- arbitrary events: a file or a clear error, never a broken MCAP --------------------------
_scalar = st.one_of(st.none(), st.booleans(), st.integers(-2**70, 2**70), st.floats(), st.text(max_size=8),
                    st.binary(max_size=8))
_value = st.recursive(_scalar, lambda c: st.lists(c, max_size=3) | st.dictionaries(st.text(max_size=5), c, max_size=3),
                      max_leaves=6)
_event = st.fixed_dictionaries(
    {"frame": st.integers(0, 2**33), "ts_ns": st.integers(-5, 2**63), "kind": st.sampled_from(
        ["rt", "telegram", "state", "record", "param", "violation", "dcp", "lldp", "alarm", "malformed", "rpc", "x/y"])},
    optional={"cycle_counter": st.integers(0, 0xFFFF), "frame_id": st.one_of(st.integers(0, 0xFFFF), _scalar),
              "src": _scalar, "dst": _scalar, "device_mac": _scalar, "station": _value, "slot": _scalar,
              "subslot": _scalar, "telegram": _scalar, "direction": _scalar, "signals": _value, "bits": _value,
              "severity": _scalar, "rule": _scalar, "last_frame": _scalar, "message": _scalar, "extra": _value})


@hsettings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.lists(_event, max_size=12), st.booleans(), st.integers(1, 4))
def test_arbitrary_events(tmp_path, evs, on_change, decimate):
    out, exp = export(tmp_path, evs, on_change=on_change, decimate=decimate)
    counts, _, _, problems = read_back(out, strict=False)
    assert problems == []
    assert sum(counts.values()) + exp.dropped == sum(
        1 for e in evs if e["kind"] != "rt" or "cycle_counter" in e)


# -- fast path (issue #8): the same file as the reference path --------------------------------
def _messages(path):
    """Everything a reader sees, in file order: channels, schemas, messages, metadata."""
    with open(path, "rb") as f:
        r = make_reader(f)
        msgs = [(ch.topic, m.log_time, m.publish_time, m.sequence, m.data)
                for _, ch, m in r.iter_messages(log_time_order=False)]
        summ = r.get_summary()
        chans = [(c.id, c.topic, c.schema_id, c.metadata) for c in summ.channels.values()]
        schemas = [(x.id, x.name, x.data) for x in summ.schemas.values()]
        meta = [(md.name, md.metadata) for md in r.iter_metadata()]
    return chans, schemas, msgs, meta


def _assert_same_export(ref, new):
    with open(ref, "rb") as f:
        a = f.read()
    with open(new, "rb") as f:
        b = f.read()
    if a == b:
        return
    ca, sa, ma, xa = _messages(ref)
    cb, sb, mb, xb = _messages(new)
    assert cb == ca and sb == sa and xb == xa
    for i, (x, y) in enumerate(zip(ma, mb)):
        assert y == x, f"message {i}"
    assert len(mb) == len(ma)
    pytest.fail("same records, different bytes")  # e.g. chunking: still a change to explain


def _fast_and_reference(cap, d, **kw):
    ref, new = str(d / "ref.mcap"), str(d / "new.mcap")
    for path, reference in ((ref, True), (new, False)):
        settings = Settings()
        exp = McapExporter(path, cap, settings, _reference=reference, **kw)
        try:
            a = exp.run(cap, settings)
        finally:
            exp.close()
        res = (a.summary(), {k: v for k, v in exp.summary().items() if k != "path"})
        if reference:
            want = res
        else:
            got = res
    return ref, new, want, got


@pytest.mark.skipif(not CAPTURES, reason="no captures")
@pytest.mark.parametrize("cap", CAPTURES, ids=os.path.basename)
def test_fast_path_same_file(cap, tmp_path):
    """The exporter's fast path (no rt / telegram event dicts, own writer) writes the file the
    reference path (event dicts through on_event, mcap-python's Writer) writes: same bytes, so
    the same channels, schemas, messages, times and order; and the analyzer ends in the same state
    (summary, event counts) as with the event sink."""
    ref, new, want, got = _fast_and_reference(cap, tmp_path, chunk_size=64 * 1024)
    _assert_same_export(ref, new)
    assert json.dumps(got, default=str, sort_keys=True) == json.dumps(want, default=str, sort_keys=True)


FEW = [c for c in CAPTURES if any(k in os.path.basename(c) for k in ("motion", "preset", "sensor-error", "3enc"))][:6]


@pytest.mark.skipif(not FEW, reason="no captures")
@pytest.mark.parametrize("opts", [{"on_change": True}, {"decimate": 3}, {"on_change": True, "decimate": 4,
                                                                         "keyframe_s": 0.01},
                                  {"compression": "none"}])
@pytest.mark.parametrize("cap", FEW, ids=os.path.basename)
def test_fast_path_same_file_options(cap, opts, tmp_path):
    ref, new, want, got = _fast_and_reference(cap, tmp_path, **opts)
    _assert_same_export(ref, new)
    assert got[1] == want[1]


def _write_pcap(path, frames):
    """frames ((ts_ns, data)) as a nanosecond pcap, Ethernet."""
    import struct
    with open(path, "wb") as f:
        f.write(struct.pack("<IHHiIII", 0xA1B23C4D, 2, 4, 0, 0, 65535, 1))
        for ts, data in frames:
            f.write(struct.pack("<IIII", ts // 1_000_000_000, ts % 1_000_000_000, len(data), len(data)) + data)


def test_fast_path_changes_midstream(tmp_path):
    """Known streams whose DataStatus, TransferStatus, frame length and VLAN priority change, whose
    clock steps back, with a sensor error (G1_XIST2 error code) on the way: each change takes a new
    template or the reference way, and the file stays the reference path's."""
    from pndiss.capture import open_capture
    sim = str(tmp_path / "s.pcapng")
    assert cli_main(["simulate", "--scenario", "sensor-error", "--cycles", "800", "--no-expected", "-o", sim]) == 0
    out, k = [], 0
    for fn, ts, lt, data in open_capture(sim):
        data = bytearray(data)
        off = 16 if data[12:14] == b"\x81\x00" else 12
        if data[off:off + 2] == b"\x88\x92" and data[off + 2] >= 0x80:  # cyclic RTC1
            k += 1
            if 300 <= k < 340:
                data[-2] ^= 0x04              # DataValid off: a new DataStatus text, cycles not judged
            elif 400 <= k < 420:
                data[-1] = 3                  # TransferStatus
            elif 500 <= k < 510:
                data[-4:-4] = b"\x00\x00"     # two more bytes in the C_SDU: c_sdu_len changes
            elif 600 <= k < 620 and off == 16:
                data[14] = (data[14] & 0x1F) | 0x80   # VLAN priority 4: a new stream key
            if k in (700, 701):
                ts -= 5_000_000               # the clock steps back: log_time is held per channel
        out.append((ts, bytes(data)))
    cap = str(tmp_path / "m.pcap")
    _write_pcap(cap, out)
    ref, new, want, got = _fast_and_reference(cap, tmp_path)
    _assert_same_export(ref, new)
    assert json.dumps(got, default=str, sort_keys=True) == json.dumps(want, default=str, sort_keys=True)
    with open(new, "rb") as f:
        topics = {ch.topic for _, ch, _ in make_reader(f).iter_messages()}
    assert any(t.endswith("/actual") for t in topics) and any("/apdu/" in t for t in topics)


_SESSION = {}


def _session(scenario, cycles):
    """(ts, data) of a simulated session, made once per test run."""
    key = (scenario, cycles)
    if key not in _SESSION:
        import tempfile
        from pndiss.capture import open_capture
        with tempfile.TemporaryDirectory() as d:
            sim = os.path.join(d, "s.pcapng")
            assert cli_main(["simulate", "--scenario", scenario, "--cycles", str(cycles), "--no-expected",
                             "-o", sim]) == 0
            _SESSION[key] = [(ts, bytes(data)) for _, ts, _, data in open_capture(sim)]
    return _SESSION[key]


_mutation = st.tuples(st.integers(0, 10**6), st.sampled_from(["ds", "transfer", "csdu", "cc", "repeat", "drop",
                                                                 "back"]),
                      st.integers(0, 255), st.integers(0, 63))


@hsettings(max_examples=25, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(st.sampled_from(["motion", "preset", "parking"]), st.lists(_mutation, max_size=12),
       st.sampled_from([{}, {"on_change": True, "keyframe_s": 0.005}, {"decimate": 3},
                        {"on_change": True, "decimate": 7, "keyframe_s": 0.002}]), st.booleans())
def test_fast_path_mutated_sessions(tmp_path, scenario, muts, opts, exact_clock):
    """Random damage in the steady runs (DataStatus, TransferStatus, any C_SDU byte: words, IOPS;
    cycle counter; a frame repeated or dropped; the clock stepping back), with and without volume
    control: whatever the batch engine and the fast path make of it, the file is the reference
    path's."""
    frames = list(_session(scenario, 700))
    if exact_clock:  # no jitter: keyframe intervals end exactly on a frame
        frames = [(frames[0][0] + 250_000 * i, d) for i, (_, d) in enumerate(frames)]
    cyc = [i for i, (_, d) in enumerate(frames) if d[12:14] in (b"\x81\x00", b"\x88\x92") and len(d) > 40
           and d[16 if d[12] == 0x81 else 12:(16 if d[12] == 0x81 else 12) + 2] == b"\x88\x92"]
    for where, kind, val, at in sorted(muts, key=lambda m: -m[0]):
        i = cyc[where % len(cyc)]
        ts, d = frames[i]
        d = bytearray(d)
        off = 18 if d[12] == 0x81 else 14
        if kind == "ds":
            d[-2] = val
        elif kind == "transfer":
            d[-1] = val
        elif kind == "csdu":
            d[off + 2 + at % (len(d) - off - 6)] = val
        elif kind == "cc":
            d[-4] = val
        elif kind == "repeat":
            frames.insert(i + 1, (ts, bytes(d)))
        elif kind == "drop":
            del frames[i]
            continue
        elif kind == "back":
            ts -= val * 20_000   # up to 5 ms: behind earlier frames of its channel
        frames[i] = (ts, bytes(d))
    cap = str(tmp_path / "m.pcap")
    _write_pcap(cap, frames)
    ref, new, want, got = _fast_and_reference(cap, tmp_path, **opts)
    _assert_same_export(ref, new)
    assert json.dumps(got, default=str, sort_keys=True) == json.dumps(want, default=str, sort_keys=True)


def _write_pcapng(path, frames, resol=9, tsoffset_s=0):
    """frames ((ts_ns, data)) as a pcapng with one Ethernet interface; if_tsresol ``resol`` (a power
    of ten, or 0x80 | n for 2^-n), if_tsoffset ``tsoffset_s`` seconds (subtracted from every time)."""
    import struct

    def block(btype, body):
        body += b"\0" * (-len(body) % 4)
        n = len(body) + 12
        return struct.pack("<II", btype, n) + body + struct.pack("<I", n)
    per_s = 10 ** resol if resol < 0x80 else 1 << (resol & 0x7F)
    opts = struct.pack("<HHB3x", 9, 1, resol) + struct.pack("<HHq", 14, 8, tsoffset_s) + b"\0\0\0\0"
    with open(path, "wb") as f:
        f.write(block(0x0A0D0D0A, struct.pack("<IHHq", 0x1A2B3C4D, 1, 0, -1)))
        f.write(block(1, struct.pack("<HHI", 1, 0, 65535) + opts))
        for ts, data in frames:
            t = (ts - tsoffset_s * 1_000_000_000) * per_s // 1_000_000_000
            f.write(block(6, struct.pack("<IIIII", 0, t >> 32, t & 0xFFFFFFFF, len(data), len(data)) + data))


@pytest.mark.parametrize("resol,shift", [(9, 0), (9, 1), (0x94, 0)], ids=["ns", "negative-times", "binary-resolution"])
def test_fast_path_timestamps(tmp_path, resol, shift):
    """Capture times the batch path cannot take as whole columns (a binary if_tsresol) or that the
    reference writes as 0 (before the epoch, through a negative if_tsoffset): still the reference file."""
    from pndiss.capture import open_capture
    sim = str(tmp_path / "s.pcapng")
    assert cli_main(["simulate", "--scenario", "startup", "--cycles", "600", "--no-expected", "-o", sim]) == 0
    frames = list((ts, data) for _, ts, _, data in open_capture(sim))
    if shift:  # the epoch falls half-way through the cyclic run
        mid = frames[len(frames) // 2][0]
        frames = [(ts - mid, data) for ts, data in frames]
    if resol >= 0x80:  # times the file can hold exactly
        per = 1 << (resol & 0x7F)
        frames = [(ts * per // 1_000_000_000 * 1_000_000_000 // per, data) for ts, data in frames]
    cap = str(tmp_path / "t.pcapng")
    _write_pcapng(cap, frames, resol, tsoffset_s=-10**6 if shift else 0)
    ref, new, want, got = _fast_and_reference(cap, tmp_path)
    _assert_same_export(ref, new)
    assert json.dumps(got, default=str, sort_keys=True) == json.dumps(want, default=str, sort_keys=True)


def test_writer_same_bytes_as_mcap_python():
    """pndiss.mcap_writer lays out a file record for record as mcap-python does (chunks, message
    indexes, summary, CRCs) for an arbitrary sequence of calls."""
    import io
    import random
    from mcap.writer import CompressionType, Writer
    from pndiss.mcap_writer import McapWriter

    comps = {"none": CompressionType.NONE, "zstd": CompressionType.ZSTD}
    try:
        import lz4.frame  # noqa: F401
        comps["lz4"] = CompressionType.LZ4
    except ImportError:
        pass
    for trial in range(150):
        rnd = random.Random(trial)
        comp = rnd.choice(sorted(comps))
        size = rnd.choice([1, 60, 300, 4096])
        a, b = io.BytesIO(), io.BytesIO()
        wa, wb = Writer(a, chunk_size=size, compression=comps[comp]), McapWriter(b, chunk_size=size, compression=comp)
        for w in (wa, wb):
            w.start(profile="p", library="lib")
        channels = 0
        for i in range(rnd.randint(0, 80)):
            r = rnd.random()
            if r < 0.1 or not channels:
                data = rnd.randbytes(rnd.randint(0, 30))
                meta = {f"k{j}": rnd.choice(["", "v", "µ"]) for j in range(rnd.randint(0, 3))}
                sids = [w.register_schema(f"s{i}", "jsonschema", data) for w in (wa, wb)]
                cids = [w.register_channel(f"/t{i}", "json", sids[0], meta) for w in (wa, wb)]
                assert sids[0] == sids[1] and cids[0] == cids[1]
                channels += 1
            elif r < 0.15:
                for w in (wa, wb):
                    w.add_metadata(f"m{i}", {"a": str(i)})
            else:
                cid, t, pub = rnd.randint(1, channels), rnd.randint(0, 2**63), rnd.randint(0, 2**64 - 1)
                data, seq = rnd.randbytes(rnd.randint(0, 50)), rnd.randint(0, 2**32 - 1)
                for w in (wa, wb):
                    w.add_message(cid, t, data, pub, seq)
        for w in (wa, wb):
            w.finish()
        assert b.getvalue() == a.getvalue(), (trial, comp, size)


# -- command line ----------------------------------------------------------------------------
SMALL = [c for c in CAPTURES if os.path.getsize(c) < 2_000_000]


@pytest.mark.skipif(not SMALL, reason="no captures")
def test_cli_export_and_analyze(tmp_path):
    cap = max(SMALL, key=os.path.getsize)
    a, b = str(tmp_path / "a.mcap"), str(tmp_path / "b.mcap")
    assert cli_main(["export", cap, "-o", a, "-q"]) == 0
    assert cli_main(["analyze", cap, "--mcap", b, "-q", "--no-progress"]) == 0
    ca, cb = read_back(a)[0], read_back(b)[0]
    assert ca == cb and sum(ca.values()) > 0
    c = str(tmp_path / "c.mcap")
    assert cli_main(["export", cap, "-o", c, "-q", "--on-change", "--compression", "none"]) == 0
    cc = read_back(c)[0]
    assert set(cc) == set(ca) and sum(cc.values()) <= sum(ca.values())


def test_cli_errors(tmp_path, capsys, monkeypatch):
    assert cli_main(["export", str(tmp_path / "missing.pcap"), "-o", str(tmp_path / "x.mcap")]) == 2
    if SMALL:
        assert cli_main(["export", SMALL[0], "-o", str(tmp_path / "x.mcap"), "--decimate", "0"]) == 2
        assert cli_main(["export", SMALL[0], "-o", str(tmp_path / "nodir" / "x.mcap")]) == 2
        assert cli_main(["analyze", SMALL[0], "-q", "--mcap", str(tmp_path / "nodir" / "x.mcap")]) == 2
        import sys
        monkeypatch.setitem(sys.modules, "lz4.frame", None)  # as if lz4 were not installed
        assert cli_main(["export", SMALL[0], "-o", str(tmp_path / "l.mcap"), "--compression", "lz4"]) == 2
        assert not (tmp_path / "l.mcap").exists()
    err = capsys.readouterr().err
    assert "error" in err and "internal error" not in err


def test_on_change_leaves_out_the_sign_of_life(tmp_path, monkeypatch):
    """A standing shaft under sign-of-life monitoring: STW2/ZSW2 step every cycle, nothing else changes.
    --on-change writes keyframes (and what does change), not every sample; the dataset's on_change cycles the
    same (an independent audit: 99.5 % of the samples kept, the option useless on the topics that are most of
    the volume). Engine and reference path write the same file."""
    import sys
    sys.path.insert(0, os.path.join(ROOT, "tests"))
    import capedit
    from pndiss.dataset import write_capture
    import pyarrow.parquet as pq
    src = capedit.simulate(str(tmp_path / "sol.pcapng"), "--scenario", "parking", "--irt", "--cycles", "8000")
    outs = []
    for fast in ("1", "0"):
        monkeypatch.setenv("PNDISS_FAST_PATH", fast)
        out = str(tmp_path / f"o{fast}.mcap")
        assert cli_main(["export", src, "-o", out, "--on-change", "-q"]) == 0
        outs.append(open(out, "rb").read())
        counts = read_back(out)[0]
        tg_actual = [n for t, n in counts.items() if "/tg" in t and t.endswith("/actual")]
        assert tg_actual and max(tg_actual) < 200, counts   # 8,000 cycles at 250 us: 2 s, keyframes each second
    assert outs[0] == outs[1]
    ds = str(tmp_path / "ds")
    row = write_capture(src, ds, cycles="on_change")
    assert 0 < row["cycle_rows"] < 400, row["cycle_rows"]
    assert pq.read_table(os.path.join(ds, "cycles")).num_rows == row["cycle_rows"]
