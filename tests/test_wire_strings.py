"""Wire strings are data (issues #17 item 1, #18 item 7): text from the network never restyles,
crashes or escapes into the terminal, the plot, JSONL or MCAP.

Two property tests: (1) hostile bytes as NameOfStation, DeviceVendorValue, LLDP chassis/port IDs
and system name, and map-file text, in a real capture run through the CLI (terminal at 80 and 200
columns, JSONL, MCAP, PNG and HTML plots); (2) every string field of every event kind of real
captures replaced by a hostile string and fed to every sink this module owns.
"""
from __future__ import annotations

import html.parser
import io
import json
import os
import struct
import sys

import pytest
from hypothesis import HealthCheck, example, given, settings as hsettings, strategies as st
from rich.cells import cell_len

from pndiss import textsafe
from pndiss.capture import open_capture
from pndiss.cli import main
from synframes import lldpdu, tlv

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
BASE = os.path.join(ROOT, "captures", "startup-t81-generic.pcapng")
NASTY = ["[/]", "[bold red]x[/bold red]", "[link=http://x]y[/link]", "$\\qq$", "$x^$_", "\x1b]0;pwned\x07",
         "\x1b[2J\x1b[H", "\x1b[31mred", "a\rb\nc\td", "\u202eevil", "\x00\x01\x7f\x9b", ":smile:", "<script>x</script>",
         "x" * 5000, "%s%n%x", "{0}{1}"]
hostile_text = st.one_of(st.sampled_from(NASTY), st.text(min_size=1, max_size=200),
                         st.lists(st.sampled_from(NASTY), min_size=2, max_size=4).map("".join))
hostile_bytes = st.one_of(hostile_text.map(lambda s: s.encode("utf-8", "surrogatepass")[:240] or b"x"),
                          st.binary(min_size=1, max_size=240))

CTRL = bytes.fromhex("020000000001")
DEV = bytes.fromhex("0200000000aa")


def _blk(opt: int, sub: int, val: bytes) -> bytes:
    b = bytes([opt, sub]) + struct.pack(">H", len(val)) + val
    return b + (b"\0" if len(val) & 1 else b"")


def _dcp(fid: int, sid: int, stype: int, blocks, dst: bytes, src: bytes) -> bytes:
    body = b"".join(blocks)
    f = dst + src + b"\x88\x92" + struct.pack(">H", fid) + struct.pack(">BBIHH", sid, stype, 7, 0, len(body)) + body
    return f + bytes(max(0, 60 - len(f)))


def hostile_frames(h: bytes) -> list[bytes]:
    name = h[:240]
    ident = _dcp(0xFEFF, 5, 1, [_blk(2, 2, b"\0\0" + name), _blk(2, 1, b"\0\0" + name),
                                _blk(2, 3, b"\0\0\x01\x2a\x00\x11"), _blk(2, 4, b"\0\0\x02\x00")], CTRL, DEV)
    set_req = _dcp(0xFEFD, 4, 0, [_blk(2, 2, b"\0\1" + name)], DEV, CTRL)
    lldp = DEV[:5] + b"\xbb" + DEV + b"\x88\xcc" + lldpdu(name or b"x", name or b"x", extra=tlv(5, name[:200]))
    lldp2 = bytes.fromhex("0180c200000e") + DEV + b"\x88\xcc" + lldpdu(b"port." + name[:100], name[:100] or b"p",
                                                                        chassis_subtype=4 if len(name) == 6 else 7)
    return [ident, set_req, lldp, lldp2]


def write_pcap(path: str, frames: list[tuple[int, bytes]]) -> None:
    with open(path, "wb") as f:
        f.write(struct.pack("<IHHiIII", 0xA1B23C4D, 2, 4, 0, 0, 65535, 1))
        for ts, fr in frames:
            f.write(struct.pack("<IIII", ts // 1_000_000_000, ts % 1_000_000_000, len(fr), len(fr)) + fr)


_BASE_FRAMES = None


def capture_with(path: str, h: bytes) -> None:
    """The base capture's frames with the hostile ones in front (same link type: Ethernet)."""
    global _BASE_FRAMES
    if _BASE_FRAMES is None:
        _BASE_FRAMES = [(ts, bytes(d)) for _fn, ts, _lt, d in open_capture(BASE)]
    t0 = _BASE_FRAMES[0][0]
    write_pcap(path, [(t0, f) for f in hostile_frames(h)] + _BASE_FRAMES)


def assert_inert(text: str) -> None:
    """No escape or other control character reaches the terminal, besides newlines."""
    bad = [c for c in text if (ord(c) < 0x20 and c != "\n") or 0x7F <= ord(c) <= 0x9F or c in "\u202e\u2028"]
    assert not bad, f"control characters reached the output: {bad[:5]!r}"


def run_cli(capsys, monkeypatch, *args, columns=80) -> tuple[int, str, str]:
    monkeypatch.setenv("COLUMNS", str(columns))
    code = main(list(args))
    out, err = capsys.readouterr()
    return code, out, err


@pytest.fixture(scope="module")
def work(tmp_path_factory):
    return tmp_path_factory.mktemp("wire")


@hsettings(max_examples=12, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(h=hostile_bytes, name=hostile_text)
@example(h="पन्ह त्र र्च कृकृ ड्ड न्हृे إلا بسم الله".encode(), name="\x00\x01\x7f\x9b$\\qq$[link=http://x]y[/link]")
def test_capture_with_hostile_strings_every_sink(work, capsys, monkeypatch, h, name):
    cap = str(work / "hostile.pcap")
    capture_with(cap, h)
    mp = work / "map.json"  # map-file text: a station name from the user's file
    mp.write_text(json.dumps({"about": name, "submodules": [{"device_mac": "02:00:00:00:01:01", "station": name,
                                                             "slot": 1, "subslot": 2, "telegram": 81}]}))
    jsonl, mcap = work / "e.jsonl", work / "e.mcap"
    for cols in (80, 200):
        code, out, err = run_cli(capsys, monkeypatch, "analyze", cap, "--no-progress", "--map", str(mp),
                                 "--jsonl", str(jsonl), "--mcap", str(mcap), columns=cols)
        assert code == 0, err
        assert "VERDICT" in out and "internal error" not in err
        assert_inert(out)
        assert_inert(err)
        assert max(cell_len(x) for x in out.splitlines()) <= cols  # terminal cells, not code points
    events = [json.loads(x) for x in jsonl.read_text(encoding="utf-8").splitlines()]
    assert any(e["kind"] == "dcp" for e in events)
    _read_mcap(str(mcap))
    code, out, err = run_cli(capsys, monkeypatch, "analyze", cap, "-q", "--follow")
    assert code == 0 and "internal error" not in err
    assert_inert(out)
    for ext in (".html", ".png"):
        out_path = str(work / f"p{ext}")
        code, _out, err = run_cli(capsys, monkeypatch, "plot", cap, "-o", out_path, "--no-progress", "--map", str(mp))
        assert code == 0, err
        _check_picture(out_path)


def _read_mcap(path: str) -> int:
    from mcap.reader import make_reader
    n = 0
    with open(path, "rb") as f:
        for _schema, _ch, m in make_reader(f).iter_messages():
            json.loads(m.data)
            n += 1
    return n


def _check_picture(path: str) -> None:
    if path.endswith(".png"):
        with open(path, "rb") as f:
            assert f.read(8) == b"\x89PNG\r\n\x1a\n"
        return
    doc = open(path, encoding="utf-8").read()
    assert "<script>x" not in doc
    p = html.parser.HTMLParser()
    p.feed(doc)
    p.close()


# -- every string field of every event kind ------------------------------------------------------
def _events() -> list[dict]:
    from pndiss.analyzer import analyze_file
    evs = []
    kinds = {}
    for name in ("fault-preset-ack-missing.pcapng", "sensor-error-t81-lika.pcapng", "fault-dcp-name-duplicate.pcapng"):
        def keep(ev):
            # a few of each kind keep the test fast; every kind and field shape is in
            if kinds.get(ev["kind"], 0) < 25:
                kinds[ev["kind"]] = kinds.get(ev["kind"], 0) + 1
                evs.append(ev)
        analyze_file(os.path.join(ROOT, "captures", name), None, keep)
    return evs


EVENTS = None


def _poison(v, s: str):
    if isinstance(v, str):
        return s
    if isinstance(v, dict):
        return {k: (v[k] if k == "kind" else _poison(v[k], s)) for k in v}
    if isinstance(v, list):
        return [_poison(x, s) for x in v]
    return v


@hsettings(max_examples=10, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(s=hostile_text)
def test_every_string_field_of_every_event_kind(tmp_path_factory, monkeypatch, s):
    from pndiss.mcap_export import McapExporter
    from pndiss.plot import Timeline, render_html, render_png
    from pndiss.report import render_violation
    from pndiss.settings import Settings
    global EVENTS
    if EVENTS is None:
        EVENTS = _events()
    assert {"dcp", "lldp", "record", "param", "telegram", "state", "violation", "alarm", "ar"} <= {e["kind"] for e in EVENTS}
    evs = [_poison(e, s) for e in EVENTS]
    d = tmp_path_factory.mktemp("ev")
    for e in evs:  # JSONL keeps the full value
        back = json.loads(json.dumps(e))
        assert back == e
    exp = McapExporter(str(d / "x.mcap"), None, Settings())
    for e in evs:
        exp.on_event(e)
    exp.close()
    _read_mcap(str(d / "x.mcap"))
    tl = Timeline(200)
    for e in evs:
        tl.on_event(e)
    render_html(tl, str(d / "x.html"), s)
    _check_picture(str(d / "x.html"))
    render_png(tl, str(d / "x.png"), s)
    _check_picture(str(d / "x.png"))
    buf = io.StringIO()
    for e in evs:
        if e["kind"] == "violation":
            render_violation(e, buf)
    assert_inert(buf.getvalue())
    _terminal_with(evs, s, monkeypatch)


def _terminal_with(evs: list[dict], s: str, monkeypatch) -> None:
    """The terminal report of a real run whose violations, activity (DCP/LLDP/alarms), stations and
    record rows carry the hostile string."""
    from pndiss.analyzer import analyze_file
    from pndiss.report import render_report
    a = analyze_file(BASE)
    for e in evs:
        if e["kind"] == "violation":
            a.violations.add(e)
        elif e["kind"] in ("dcp", "lldp", "alarm"):
            a.activity.on_event(e)
    a.session.record_rows[:] = [_poison(r, s) if isinstance(r, dict) else r for r in a.session.record_rows]
    summary = _poison(a.summary(), s)
    for key in ("frames", "accounting", "first_ts_ns", "last_ts_ns"):  # numbers stay numbers
        summary[key] = a.summary()[key]
    summary["capture"] = s
    for cols in (80, 200):
        monkeypatch.setenv("COLUMNS", str(cols))
        out = io.StringIO()
        monkeypatch.setattr(sys, "stdout", out)
        render_report(summary, a)
        monkeypatch.setattr(sys, "stdout", sys.__stdout__)
        text = out.getvalue()
        assert "VERDICT" in text
        assert_inert(text)


def test_textsafe_units():
    assert textsafe.visible("\x1b[2Jx") == "\\x1b[2Jx"
    assert textsafe.term("[/]") == "\\[/]"
    assert textsafe.mathtext("$\\qq$") == "\\$\\qq\\$"
    long = "y" * 10_000
    assert len(textsafe.visible(long)) < 200 and "10000 chars" in textsafe.visible(long)
    assert textsafe.visible(long, None) == long
