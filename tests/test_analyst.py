"""The analyst's experience (issue #16 items 1-5, 8) and exit codes that mean one thing (#18 item 3).

Each test names the numbered problem it covers; all run on the captures in captures/ only.
"""
from __future__ import annotations

import gzip
import json
import lzma
import os
import re
import select
import shutil
import struct
import subprocess
import sys
import time

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CAP = os.path.join(ROOT, "captures")
T81 = os.path.join(CAP, "startup-t81-generic.pcapng")
T81x3 = os.path.join(CAP, "startup-t81-generic-3enc.pcapng")
FAULT = os.path.join(CAP, "fault-preset-ack-missing.pcapng")
DUP = os.path.join(CAP, "fault-dcp-name-duplicate.pcapng")


def run(*args, columns=80, stdin=None, env=None):
    e = dict(os.environ, COLUMNS=str(columns), PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    e.update(env or {})
    return subprocess.run([sys.executable, "-m", "pndiss", *args], capture_output=True, text=stdin is None,
                          input=stdin, env=e)


def out_of(r) -> str:
    return r.stdout if isinstance(r.stdout, str) else r.stdout.decode()


# -- 1. the verdict ------------------------------------------------------------------------------
def test_1_verdict_first_and_last_at_80_columns():
    r = run("analyze", FAULT, "--no-progress")
    assert r.returncode == 0, r.stderr
    lines = r.stdout.splitlines()
    assert len(max(lines, key=len)) <= 80
    head = "\n".join(lines[:8])
    fault = json.load(open(FAULT.replace(".pcapng", ".expected.json")))["faults"][0]
    m = re.search(r"VERDICT: 1 error \(1 encoder\) — first at frame (\d+) \(PRESET-ACK-MISSING\)", head)
    assert m and fault["first_frame"] <= int(m.group(1)) <= fault["last_frame"], head
    rule_line = next(x for x in lines[:10] if "PRESET-ACK-MISSING" in x and "×" in x)
    assert "error" in rule_line and "encoder" in rule_line and "…" not in rule_line
    tail = " ".join(lines[-2:])
    assert lines[-2].startswith("pndiss verdict: 1 error (1 encoder)") and "PRESET-ACK-MISSING" in tail


def test_1_verdict_with_three_encoders_comes_first():
    r = run("analyze", T81x3, "--no-progress")
    assert r.returncode == 0, r.stderr
    assert any(x.startswith("VERDICT: no violations") for x in r.stdout.splitlines()[:6])


def test_1_quiet_prints_the_one_line_verdict():
    r = run("analyze", DUP, "-q")
    assert r.returncode == 0
    assert r.stdout.count("\n") == 1 and "1 error (1 controller)" in r.stdout and "DCP-NAME-DUPLICATE" in r.stdout


def test_1_unchecked_sign_of_life_is_said_with_its_setting():
    r = run("analyze", T81, "--no-progress", columns=200)
    assert "sign-of-life: not checked" in r.stdout and "--set sol_monitor_rt=1" in r.stdout
    r = run("analyze", T81, "--no-progress", "--set", "sol_monitor_rt=1", columns=200)
    assert "sign-of-life: not checked" not in r.stdout


def test_1_width_from_columns_when_piped():
    r = run("analyze", T81, "--no-progress", columns=170)
    assert max(len(x) for x in r.stdout.splitlines()) <= 170
    assert any(len(x) > 125 for x in r.stdout.splitlines())


# -- 2. words instead of dumps ---------------------------------------------------------------------
def test_2_parameter_access_in_words():
    r = run("analyze", T81, "--no-progress", columns=200)
    text = re.sub(r"\s*│\s*", " ", r.stdout)
    assert "P922 Telegram selection · read · 81 (ok)" in text
    assert "request_id_name=" not in r.stdout and "kind=parameter" not in r.stdout


def test_2_bf00_fields_in_words():
    r = run("analyze", T81, "--no-progress", columns=200)
    assert "Class 4 functionality enabled" in r.stdout and "velocity unit steps/s" in r.stdout
    assert "flags=" not in r.stdout and "flags: " not in r.stdout


def test_2_one_telegram_source_and_one_profile_reason():
    r = run("analyze", T81x3, "--no-progress", columns=250)
    sources = set(re.findall(r"\b81 \((P922[^)]*\)|length[^)]*|[^)]*)\)", r.stdout))
    assert sources and not any(s.startswith("length") for s in sources), sources
    assert not ("from I&M0" in r.stdout and "from DCP" in r.stdout)


def test_2_lldp_port_macs_are_not_stations():
    r = run("analyze", T81, "--no-progress", columns=200)
    table = r.stdout[r.stdout.index("Stations"):]
    table = table[:table.index("└")]
    rows = [x for x in table.splitlines() if x.startswith("│ 02:")]
    assert not any(x.startswith("│ 02:00:00:00:01:02") or x.startswith("│ 02:00:00:00:01:03") for x in rows)
    assert "02:00:00:00:01:02" in table  # named as a port of encoder-1
    stations = {s["mac"]: s for s in _summary(T81)["stations"]}   # the summary says so too
    enc = stations["02:00:00:00:01:02"]["lldp_port_of"]
    assert stations[enc]["name"] == stations["02:00:00:00:01:02"]["name"] and "lldp_port_of" not in stations[enc]


# -- 3. inputs -------------------------------------------------------------------------------------
def _summary(*args, stdin=None) -> dict:
    r = run("analyze", *args, "-q", "--summary-json", "-", stdin=stdin)
    assert r.returncode == 0, r.stderr
    return json.loads(out_of(r))


def test_3_stdin_and_compressed_inputs(tmp_path):
    raw = open(T81, "rb").read()
    ref = _summary(T81)
    assert _summary("-", stdin=raw)["frames"] == ref["frames"]
    for name, data in (("c.pcapng.gz", gzip.compress(raw)), ("c.pcapng.xz", lzma.compress(raw))):
        p = tmp_path / name
        p.write_bytes(data)
        s = _summary(str(p))
        assert s["frames"] == ref["frames"] and s["accounting"] == ref["accounting"]
    import zstandard
    p = tmp_path / "c.pcapng.zst"
    p.write_bytes(zstandard.ZstdCompressor().compress(raw))
    assert _summary(str(p))["accounting"] == ref["accounting"]


def test_3_follow_prints_violations_while_the_pipe_is_open():
    raw = open(FAULT, "rb").read()
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    p = subprocess.Popen([sys.executable, "-m", "pndiss", "analyze", "-", "--follow", "-q"], stdin=subprocess.PIPE,
                         stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
    try:
        p.stdin.write(raw[: len(raw) * 9 // 10])  # the violation (frame 367 of 668) and its deadline are in
        p.stdin.flush()
        deadline = time.monotonic() + 60
        line = b""
        while time.monotonic() < deadline and b"\n" not in line:
            if select.select([p.stdout], [], [], 1)[0]:
                line += os.read(p.stdout.fileno(), 4096)
        assert b"PRESET-ACK-MISSING" in line, "no violation printed while the input was still open"
        assert p.poll() is None
        p.stdin.write(raw[len(raw) * 9 // 10:])
        p.stdin.close()
        assert p.wait(60) == 0
    finally:
        if p.poll() is None:
            p.kill()


def test_3_station_and_time_filters():
    s = _summary(DUP, "--station", "02:00:00:00:02:01")
    assert s["verdict"]["total"] == 1
    assert _summary(DUP, "--station", "02:00:00:00:00:01")["verdict"]["total"] == 0   # the PLC: in the capture
    assert _summary(DUP, "--time", "..0.0001")["verdict"]["total"] == 0
    assert _summary(DUP, "--time", "0..")["verdict"]["total"] == 1
    r = run("analyze", FAULT, "-q", "--station", "encoder-1", "--fail-on", "error")
    assert r.returncode == 1 and "(in scope: station encoder-1)" in r.stdout + r.stderr
    assert run("analyze", FAULT, "-q", "--station", "ENCODER-1", "--fail-on", "error").returncode == 1   # DNS names
    # a station or range the capture does not hold is a usage error, not "no violations": a typo in a CI gate
    # (--station encoder-l --fail-on error) must not pass (an independent audit)
    for bad, said in ((("--station", "nobody"), "no station of that name or MAC in the capture (stations: "),
                      (("--station", "02:00:00:00:03:01"), "no station of that name or MAC"),
                      (("--time", "1000.."), "the range holds no frame"), (("--time", "5..2"), "FROM is after TO")):
        r = run("analyze", FAULT, "-q", *bad, "--fail-on", "error")
        assert r.returncode == 2 and said in r.stderr and "Traceback" not in r.stderr, (bad, r.stderr)
    assert run("analyze", FAULT, "--time", "abc").returncode == 2


def test_3_no_profinet_frames_found(tmp_path):
    tcp = (b"\x00\x11\x22\x33\x44\x55\x66\x77\x88\x99\xaa\xbb\x08\x00" + bytes.fromhex(
        "45000028000140004006000c0a0000010a000002") + bytes.fromhex("00501f900000000100000000500220000000000000000000"))
    p = tmp_path / "http.pcap"
    with open(p, "wb") as f:
        f.write(struct.pack("<IHHiIII", 0xA1B2C3D4, 2, 4, 0, 0, 65535, 1))
        for i in range(3):
            f.write(struct.pack("<IIII", 1_700_000_000 + i, 0, len(tcp), len(tcp)) + tcp)
    r = run("analyze", str(p), "-q")
    assert r.returncode == 0 and "no PROFINET frames found" in r.stdout
    assert "no PROFINET frames found" in run("analyze", str(p), "--no-progress").stdout


# -- 4. machine output -------------------------------------------------------------------------------
def _jsonl(path, *extra) -> list[dict]:
    r = run("analyze", path, "-q", "--jsonl", "-", *extra)
    assert r.returncode == 0, r.stderr
    return [json.loads(x) for x in r.stdout.splitlines()]


def test_4_one_type_per_field_and_schema():
    import jsonschema
    schema = json.load(open(os.path.join(ROOT, "pndiss", "data", "event.schema.json")))
    v = jsonschema.Draft202012Validator(schema)
    types: dict[str, set] = {}
    for cap in (T81, DUP, FAULT, os.path.join(CAP, "sensor-error-t81-lika.pcapng"),
                os.path.join(CAP, "preset-t860-hohner.pcapng")):
        for ev in _jsonl(cap):
            errs = list(v.iter_errors(ev))
            assert not errs, (ev["kind"], errs[0].message)
            for k, val in ev.items():
                if val is not None:
                    types.setdefault(k, set()).add("number" if type(val) in (int, float) else type(val).__name__)
    mixed = {k: t for k, t in types.items() if len(t) > 1}
    assert not mixed, mixed
    assert types["station"] == {"str"} and types["request_id"] == {"number"}


def test_4_summary_schema(tmp_path):
    import jsonschema
    schema = json.load(open(os.path.join(ROOT, "pndiss", "data", "summary.schema.json")))
    for cap in (T81x3, DUP, FAULT):
        jsonschema.validate(_summary(cap), schema)


@pytest.mark.parametrize("name", ["fault-cmd-without-control.pcapng", "fault-bmp-reqref-zero.pcapng",
                                  "fault-park-while-running.pcapng", "fault-preset-ack-missing.pcapng"])
def test_4_violation_time_is_its_frames_time(name):
    """Violations decided frames later (controller-side rules, record rules) carry their frame's time."""
    evs = _jsonl(os.path.join(CAP, name))
    times = {}
    for e in evs:
        if e["kind"] != "violation":
            times.setdefault(e["frame"], e["ts_ns"])
    viol = [e for e in evs if e["kind"] == "violation"]
    assert viol
    for e in viol:
        assert e["ts_ns"] == times[e["frame"]], e


def test_4_one_format_on_stdout():
    r = run("analyze", T81, "--jsonl", "-", "--summary-json", "-")
    assert r.returncode == 2 and "one of them" in r.stderr and r.stdout == ""


# -- 5. errors and help --------------------------------------------------------------------------------
def test_5_missing_map_is_exit_2_one_line():
    r = run("analyze", T81, "--map", "/missing.toml")
    assert r.returncode == 2
    assert r.stderr.strip().splitlines() == ["pndiss: error: --map /missing.toml: no such file"]


@pytest.mark.parametrize("args,hint", [
    (("analyze", T81, "--jsnl", "x"), "did you mean --jsonl"),
    (("analyze", T81, "--set", "l_mx=3"), "did you mean l_max"),
    (("analyze", T81, "--profile", "lkia"), "did you mean lika"),
    (("analyse", T81), "did you mean analyze"),
    (("rules", "PRESET-ACK-MISING"), "did you mean PRESET-ACK-MISSING"),
])
def test_5_did_you_mean(args, hint):
    r = run(*args)
    assert r.returncode == 2 and hint in r.stderr, r.stderr


def test_5_rules_explains_a_rule_with_manual_sections():
    r = run("rules", "sol-master-zero")
    assert r.returncode == 0
    assert "SOL-MASTER-ZERO" in r.stdout and "controller" in r.stdout
    assert "SCANCON EXAG" in r.stdout and "section 3.4.2" in r.stdout
    assert "--set sol_monitor_rt=" in r.stdout and "CLS = STW2_ENC bits 15..12" in r.stdout
    assert not re.search(r"\d{3}_[0-9a-f]{16}\.txt", r.stdout)
    listing = run("rules")
    assert listing.returncode == 0 and len(listing.stdout.splitlines()) == 92


@pytest.mark.parametrize("shell", ["bash", "zsh", "fish"])
def test_5_completion_scripts(shell, tmp_path):
    r = run("completion", shell)
    assert r.returncode == 0 and "analyze" in r.stdout and "summary-json" in r.stdout
    if shell == "bash":
        f = tmp_path / "c.bash"
        f.write_text(r.stdout)
        got = subprocess.run(["bash", "-c", f"source {f}; COMP_WORDS=(pndiss analyze --prof); COMP_CWORD=2; "
                                            "_pndiss; echo ${COMPREPLY[@]}"], capture_output=True, text=True)
        assert got.stdout.strip() == "--profile"
    elif shutil.which(shell):
        f = tmp_path / "c"
        f.write_text(r.stdout)
        assert subprocess.run([shell, "-n", str(f)]).returncode == 0


def test_5_progress_has_percent_and_eta(monkeypatch, capsys):
    from pndiss import inputs, report
    clock = [100.0]
    monkeypatch.setattr(report.time, "monotonic", lambda: clock[0])
    pr = report.ProgressReporter(T81, True, "plotting")
    f = inputs.open_input(T81)
    f.read(os.path.getsize(T81) // 2)
    clock[0] += 6
    pr.update(5000)
    pr.close()
    f.close()
    err = capsys.readouterr().err
    assert "plotting: 5,000 frames" in err and "50%" in err and "ETA 6 s" in err


def test_5_plot_reports_progress():
    import pndiss.commands.plot as plot_cmd
    src = open(plot_cmd.__file__, encoding="utf-8").read()
    assert "ProgressReporter" in src and "progress.update" in src


# -- 8. tests and the test command on a plain clone ----------------------------------------------------
def test_8_test_command_keeps_the_install():
    script = open(os.path.join(ROOT, "scripts", "test"), encoding="utf-8").read()
    assert "install -q --disable-pip-version-check -e" not in script and " -e '.[test]'" not in script
    assert 'export PYTHONPATH="$PWD' in script


def test_8_cli_tests_skip_without_shared(tmp_path):
    """A copy of the checkout without ../shared: the CLI tests pass or skip with one line."""
    clone = tmp_path / "clone"
    (clone / "tests").mkdir(parents=True)
    for name in os.listdir(os.path.join(ROOT, "tests")):
        src = os.path.join(ROOT, "tests", name)
        if name.endswith(".py"):
            shutil.copy(src, clone / "tests" / name)
    for d in ("pndiss", "captures", "docs"):
        os.symlink(os.path.join(ROOT, d), clone / d)
    assert not (tmp_path / "shared").exists()
    env = dict(os.environ, PYTHONPATH=str(clone))
    r = subprocess.run([sys.executable, "-m", "pytest", "-q", "-p", "no:cacheprovider", "-rs", "tests/test_cli.py",
                        "-k", "mixed or jsonl or bad_ or documented"], cwd=clone, capture_output=True, text=True, env=env)
    assert r.returncode == 0, r.stdout[-2000:]
    assert "../shared/captures/public/ not present" in r.stdout


# -- exit codes (#18 item 3) -------------------------------------------------------------------------
def test_exit_codes_0_1_2():
    assert run("analyze", T81, "-q").returncode == 0
    assert run("analyze", FAULT, "-q", "--fail-on", "error").returncode == 1
    assert run("analyze", FAULT, "-q", "--fail-on", "error", "--station", "nobody").returncode == 2   # not in it
    assert run("analyze", "/nonexistent.pcapng").returncode == 2


@pytest.mark.skipif(not os.path.exists("/dev/full"), reason="no /dev/full")
@pytest.mark.parametrize("opt", ["--jsonl", "--summary-json"])
def test_exit_2_on_a_full_disk(opt):
    r = run("analyze", T81, "-q", opt, "/dev/full")
    assert r.returncode == 2, r.stderr
    assert r.stderr.strip().splitlines() == ["pndiss: error: cannot write /dev/full: No space left on device"]


def test_exit_2_on_an_unwritable_path(tmp_path):
    r = run("analyze", T81, "-q", "--jsonl", str(tmp_path / "no" / "such" / "dir.jsonl"))
    assert r.returncode == 2 and r.stderr.startswith("pndiss: error: cannot write")


def test_closed_stdout_ends_quietly_with_0():
    env = dict(os.environ, PYTHONPATH=ROOT + os.pathsep + os.environ.get("PYTHONPATH", ""))
    for args in (["--jsonl", "-", "-q"], ["--no-progress"]):
        p = subprocess.Popen([sys.executable, "-m", "pndiss", "analyze", T81, *args], stdout=subprocess.PIPE,
                             stderr=subprocess.PIPE, env=env)
        p.stdout.readline()
        p.stdout.close()  # what `| head -1` does
        err = p.stderr.read().decode()
        assert p.wait(60) == 0, err
        assert err == "", err


def test_exit_3_only_for_internal_errors(monkeypatch, capsys):
    from pndiss import cli
    import pndiss.commands.analyze as an

    def boom(args):
        raise RuntimeError("a bug")
    monkeypatch.setattr(an, "run", boom)
    assert cli.main(["analyze", T81]) == 3
    assert "internal error" in capsys.readouterr().err


def test_trust_names_an_assumed_v41_mode_and_unjudged_presets():
    """Rules that depend on the V3.1/V4.1 mode fired while the mode is only the profile's default (no
    0xBF00 seen): the Trust section says so and how to change it; presets whose P65000 was never seen
    are listed as not judged."""
    from pndiss import verdict
    e = {"station": "enc", "slot": 1, "subslot": 2, "violations": {"CMD-WITHOUT-CONTROL": {"events": 1}},
         "settings": {"compat": {"value": 1, "source": "lika default (telegrams.json profile_defaults)"}},
         "presets_unjudged": 2}
    s = {"cyclic": {"encoders": [e]}, "accounting": {}}
    assert any("V4.1 mode" in t and "--set compat=0" in t for t in verdict.trust(s))
    assert any("2 preset(s)" in t and "--set p65000=N" in t for t in verdict.not_checked(s))
    e["settings"]["compat"]["source"] = "captured 0xBF00"
    assert not any("V4.1 mode" in t for t in verdict.trust(s))


def test_3_station_mac_known_only_from_cyclic_frames(tmp_path):
    """--station MAC for a device that sent no DCP, LLDP or alarm frame (a mid-session capture): its MAC is in the
    capture by its cyclic streams and ARs, so it is a scope, not a usage error (the review of 2026-11-25), in any
    letter case."""
    sys.path.insert(0, os.path.join(ROOT, "tests"))
    import capedit
    def named(fn, d):   # DCP (FrameID 0xFEFC..0xFEFF) and LLDP frames dropped
        o = 16 if d[12:14] == b"\x81\x00" else 12
        et = d[o:o + 2]
        return et != b"\x88\xcc" and not (et == b"\x88\x92" and 0xFEFC <= int.from_bytes(d[o + 2:o + 4], "big") <= 0xFEFF)
    path = str(tmp_path / "nodcp.pcapng")
    capedit.rewrite(FAULT, path, named)
    from pndiss.analyzer import analyze_file
    assert "02:00:00:00:01:01" not in analyze_file(path).stations.by_mac   # (no DCP / LLDP / alarm named it)
    for mac in ("02:00:00:00:01:01", "02-00-00-00-01-01".upper()):
        r = run("analyze", path, "-q", "--station", mac, "--fail-on", "error")
        assert r.returncode == 1, (mac, r.stderr)
    assert run("analyze", path, "-q", "--station", "02:00:00:00:09:09").returncode == 2
    # the controller's name only from its Connect (no DCP of it): no station the scope could keep events of
    r = run("analyze", path, "-q", "--station", "plc", "--fail-on", "error")
    assert r.returncode == 2 and "no station of that name" in r.stderr
    r = run("analyze", path, "-q", "--station", "192.168.0.10")
    assert r.returncode == 2 and "not an IP address" in r.stderr


def test_3_station_of_the_plc_keeps_its_violations():
    """--station with the PLC's MAC keeps the controller-side violations of its ARs (they name the device's axis,
    not the controller's MAC); the encoder's own violations stay out (review of 2026-11-25)."""
    ctrl = os.path.join(CAP, "fault-preset-req-stuck.pcapng")
    r = run("analyze", ctrl, "-q", "--station", "02:00:00:00:00:01", "--fail-on", "warning")
    assert r.returncode == 1 and "PRESET-REQ-STUCK" in r.stdout + r.stderr, r.stderr
    enc = run("analyze", FAULT, "-q", "--station", "02:00:00:00:00:01", "--fail-on", "error")   # an encoder's fault
    assert enc.returncode == 0, enc.stdout + enc.stderr
