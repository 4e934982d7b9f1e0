"""lua/pndiss_tables.lua is generated from the Python tables: stale file = failing test; every
catalogue rule is either implemented by the plugin or listed with a reason; the Lua parses."""
from __future__ import annotations

import os
import shutil
import subprocess
import sys

import pytest

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, os.path.join(ROOT, "tools"))

import gen_lua  # noqa: E402
from pndiss import rules, telegrams as tg  # noqa: E402


def test_generated_tables_are_current():
    with open(gen_lua.OUT, encoding="utf-8") as f:
        assert f.read() == gen_lua.render(), "lua/pndiss_tables.lua is stale: run python3 tools/gen_lua.py"


def test_every_rule_implemented_or_explained():
    t = gen_lua.tables()
    impl, why = set(t["plugin_rules"]), t["unsupported_rules"]
    assert impl.isdisjoint(why)
    assert impl | set(why) == set(rules.RULES)
    assert all(len(w) > 20 for w in why.values())
    doc = open(gen_lua.DOC, encoding="utf-8").read()
    assert gen_lua.render_doc(doc) == doc, "docs/wireshark.md rule lists are stale: run python3 tools/gen_lua.py"
    for r in impl:
        assert f"`{r}`" in doc


def test_plugin_rules_have_lua_conditions():
    # the driver and DCP rules live in pndiss.lua, the reference encoder's in its port pndiss_checker.lua
    src = "".join(open(os.path.join(ROOT, "lua", f), encoding="utf-8").read()
                  for f in ("pndiss.lua", "pndiss_checker.lua"))
    # the pairing problems' rules come from a generated table (acyclic.PAIRING_RULES), which the checker reads
    src += "".join(f'"{rule}"' for _, rule in gen_lua.tables()["checker"]["pairing_rules"])
    # so do the "status bit follows control bit" rows of the rule registry (encoder/registry.py FOLLOWS)
    src += "".join(f'"{row["rule"]}"' for rows in gen_lua.tables()["checker"]["follows"].values() for row in rows)
    for r in gen_lua.PLUGIN_RULES:
        assert f'"{r}"' in src, f"{r} is declared implemented but the Lua plugin never names it"


def test_tables_carry_every_signal_and_bit():
    text = open(gen_lua.OUT, encoding="utf-8").read()
    for name in tg.field_names():
        last = name.split(".")[-1]
        assert last in text, name


@pytest.mark.skipif(shutil.which("luac") is None and shutil.which("luac5.2") is None, reason="no luac")
def test_lua_syntax():
    luac = shutil.which("luac5.2") or shutil.which("luac")
    for f in ("pndiss.lua", "pndiss_tables.lua", "pndiss_checker.lua"):
        p = subprocess.run([luac, "-p", os.path.join(ROOT, "lua", f)], capture_output=True, text=True)
        assert p.returncode == 0, p.stderr


@pytest.mark.parametrize("value", ["a\"b\\c", "\u00a7 9.1 \u2227", "x\ny", ""])
def test_lua_string_literal_round_trip(value):
    lua = shutil.which("lua5.2") or shutil.which("lua")
    if lua is None:
        pytest.skip("no lua interpreter")
    lit = gen_lua.lua(value)
    p = subprocess.run([lua, "-e", f"io.write({lit})"], capture_output=True)
    assert p.returncode == 0 and p.stdout.decode("utf-8") == value


try:
    from hypothesis import given, settings, strategies as st
except ImportError:  # pragma: no cover
    given = None

if given is not None:
    @settings(max_examples=60, deadline=None)
    @given(st.text(max_size=40))
    def test_lua_string_literal_property(value):
        """Any text survives the generator's Lua string escaping (checked by the real interpreter)."""
        lua = shutil.which("lua5.2") or shutil.which("lua")
        if lua is None:
            pytest.skip("no lua interpreter")
        value = value.replace("\x00", "")
        p = subprocess.run([lua, "-e", f"io.write({gen_lua.lua(value)})"], capture_output=True)
        assert p.returncode == 0
        assert p.stdout.decode("utf-8", "surrogatepass") == value.encode("utf-8", "surrogatepass").decode("utf-8", "surrogatepass")


def test_wireshark_command_install_and_path(tmp_path):
    """`pndiss wireshark install --dir D` copies the three files unchanged and prints D; `path` names both folders."""
    dest = tmp_path / "plugins"
    p = subprocess.run([sys.executable, "-m", "pndiss", "wireshark", "install", "--dir", str(dest)],
                       capture_output=True, text=True, cwd=ROOT)
    assert p.returncode == 0, p.stderr
    assert str(dest) in p.stdout
    for f in ("pndiss.lua", "pndiss_tables.lua", "pndiss_checker.lua"):
        assert (dest / f).read_bytes() == open(os.path.join(ROOT, "lua", f), "rb").read()
    p = subprocess.run([sys.executable, "-m", "pndiss", "wireshark", "path"], capture_output=True, text=True,
                       cwd=ROOT, env=dict(os.environ, HOME=str(tmp_path)))
    assert p.returncode == 0
    assert os.path.join(ROOT, "lua") in p.stdout
    assert os.path.join(str(tmp_path), ".local", "lib", "wireshark", "plugins") in p.stdout
