"""CLI: accounting adds up, bad input gives one clear line and exit 2, JSONL contract."""
import json
import os
import shutil
import subprocess
import sys

import pytest

from tsharkdiff import PUBLIC, capture_files

MIXED = os.path.join(PUBLIC, "profinet_io_cm_mixed_1.pcap")
OWN = os.path.join(os.path.dirname(__file__), "..", "captures", "startup-t81-generic.pcapng")


def need_public(path: str) -> str:
    """The public capture, or one clear skip line on a plain clone (no ../shared)."""
    if not os.path.exists(path):
        pytest.skip(f"../shared/captures/public/ not present: {os.path.basename(path)} skipped")
    return path


def run(*args):
    return subprocess.run([sys.executable, "-m", "pndiss", *args], capture_output=True, text=True)


@pytest.mark.parametrize("path", capture_files(), ids=os.path.basename)
def test_accounting_adds_up(path, tmp_path):
    s = tmp_path / "s.json"
    r = run("analyze", path, "-q", "--summary-json", str(s))
    assert r.returncode == 0, r.stderr
    summ = json.loads(s.read_text())
    acc = summ["accounting"]
    assert acc["decoded"] + acc["not_profinet"] + acc["malformed"] == summ["frames"]
    assert summ["frames"] > 0


def test_mixed_accounts_for_1635():
    r = run("analyze", need_public(MIXED), "--no-progress")
    assert r.returncode == 0, r.stderr
    assert "1,635" in r.stdout and "MISMATCH" not in r.stdout


def test_jsonl_contract(tmp_path):
    out = tmp_path / "e.jsonl"
    r = run("analyze", OWN, "-q", "--jsonl", str(out))
    assert r.returncode == 0
    lines = [json.loads(x) for x in out.read_text().splitlines()]
    assert lines and all({"frame", "ts_ns", "kind"} <= set(e) for e in lines)
    assert {"rt", "lldp", "dcp"} <= {e["kind"] for e in lines}


def test_bad_inputs_one_line_exit_2(tmp_path):
    empty = tmp_path / "empty.pcap"
    empty.write_bytes(b"")
    text = tmp_path / "notes.txt"
    text.write_text("not a capture at all\n")
    with open(OWN, "rb") as f:
        raw = f.read()
    trunc = tmp_path / "trunc.pcapng"
    trunc.write_bytes(raw[:70])   # cut short in its first packet: nothing to report
    for p in (empty, text, trunc, tmp_path / "missing.pcap", tmp_path):
        r = run("analyze", str(p), "--no-progress")
        assert r.returncode == 2, (p, r.stderr)
        err = r.stderr.strip().splitlines()
        assert len(err) == 1 and err[0].startswith("pndiss: error:"), r.stderr
        assert "Traceback" not in r.stderr + r.stdout


def test_a_capture_cut_short_is_reported_then_exit_2(tmp_path):
    """A file that ends in the middle of a packet (dumpcap killed, a ring file copied while written): the report
    and the summary cover every whole frame before the cut, one error line says where it ends, exit 2 -- as
    tshark 4.0 shows the frames and exits 2 (an independent audit found no report at all)."""
    with open(OWN, "rb") as f:
        raw = f.read()
    trunc = tmp_path / "trunc.pcapng"
    trunc.write_bytes(raw[: len(raw) // 2 + 7])
    sj = tmp_path / "s.json"
    r = run("analyze", str(trunc), "--no-progress", "--summary-json", str(sj))
    assert r.returncode == 2, r.stderr
    err = r.stderr.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("pndiss: error:") and "truncated" in err[0], r.stderr
    assert "cut short in the middle of a packet" in r.stdout and "Traceback" not in r.stderr + r.stdout
    s = json.loads(sj.read_text())
    (d,) = s["input"]["damaged"]
    assert d["cut_short"] and d["after_frame"] == s["frames"] > 0 and d["file"] == str(trunc)
    assert sum(s["accounting"].values()) == s["frames"]
    tshark = shutil.which("tshark")
    if tshark:   # tshark shows the same whole frames, says "cut short" and exits 2 too
        t = subprocess.run([tshark, "-r", str(trunc), "-T", "fields", "-e", "frame.number"], capture_output=True,
                           text=True)
        assert t.returncode == 2 and "cut short" in t.stderr
        assert len(t.stdout.split()) == s["frames"]


def test_html_report_of_a_capture_cut_short(tmp_path):
    """pndiss report writes what was read of a cut capture, then exits 2 as analyze does."""
    pytest.importorskip("matplotlib")
    with open(OWN, "rb") as f:
        raw = f.read()
    trunc = tmp_path / "trunc.pcapng"
    trunc.write_bytes(raw[: len(raw) // 2 + 7])
    out = tmp_path / "r.html"
    r = run("report", str(trunc), "-o", str(out))
    assert r.returncode == 2 and out.stat().st_size > 1000 and "reporting what was read" in r.stderr


def test_bad_arguments_exit_2():
    assert run("analyze").returncode == 2
    assert run("analyze", OWN, "--set", "nonsense=1").returncode == 2


def test_every_event_kind_is_documented(tmp_path):
    """docs/events.md (tools/gen_events_doc.py) documents every kind a capture produces."""
    doc = open(os.path.join(os.path.dirname(__file__), "..", "docs", "events.md"), encoding="utf-8").read()
    kinds = set()
    for cap in (OWN, os.path.join(os.path.dirname(__file__), "..", "captures", "sensor-error-t81-lika.pcapng"),
                os.path.join(os.path.dirname(__file__), "..", "captures", "fault-preset-ack-missing.pcapng")):
        out = tmp_path / "e.jsonl"
        assert run("analyze", cap, "-q", "--jsonl", str(out)).returncode == 0
        kinds |= {json.loads(x)["kind"] for x in out.read_text().splitlines()}
    assert {"telegram", "violation", "state", "record", "param", "alarm"} <= kinds
    missing = [k for k in kinds if f"| `{k}` |" not in doc]
    assert not missing, f"undocumented event kinds: {missing} (run tools/gen_events_doc.py)"
