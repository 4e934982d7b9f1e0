"""``pndiss wireshark install [--dir D]`` / ``pndiss wireshark path``: the Lua plugin (lua/pndiss.lua,
its generated tables and the reference encoder's Lua port) in Wireshark's personal Lua plugin folder
(docs/wireshark.md)."""
from __future__ import annotations

import os
import shutil
import sys

PLUGIN_FILES = ("pndiss.lua", "pndiss_tables.lua", "pndiss_checker.lua")   # pndiss.lua loads the other two


def plugin_source() -> str:
    """Folder holding the plugin files: lua/ next to the package (source tree / editable install)."""
    here = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
    for cand in (os.path.join(os.path.dirname(here), "lua"), os.path.join(here, "lua")):
        if all(os.path.isfile(os.path.join(cand, f)) for f in PLUGIN_FILES):
            return cand
    from ..errors import UsageError
    raise UsageError("the Lua plugin files (lua/" + ", lua/".join(PLUGIN_FILES) + ") are not installed with this pndiss")


def personal_plugin_dir() -> str:
    """Wireshark >= 4.0 personal Lua plugin folder (`tshark -G folders`: "Personal Lua Plugins")."""
    if sys.platform.startswith("win"):
        return os.path.join(os.environ.get("APPDATA", os.path.expanduser("~")), "Wireshark", "plugins")
    # Linux and macOS both use ~/.local/lib/wireshark/plugins for Wireshark >= 4.0
    return os.path.join(os.path.expanduser("~"), ".local", "lib", "wireshark", "plugins")


def add_parser(sub) -> None:
    p = sub.add_parser("wireshark", help="install the Wireshark Lua plugin (docs/wireshark.md)")
    ws = p.add_subparsers(dest="ws_command", metavar="ACTION")
    ws.required = True
    i = ws.add_parser("install", help="copy the plugin into Wireshark's personal Lua plugin folder")
    i.add_argument("--dir", metavar="D", help="plugin folder (default: the personal Lua plugin folder)")
    i.set_defaults(func=run_install)
    q = ws.add_parser("path", help="print where the plugin files are and where they get installed")
    q.set_defaults(func=run_path)


def run_install(args) -> int:
    src = plugin_source()
    dest = args.dir or personal_plugin_dir()
    os.makedirs(dest, exist_ok=True)
    for f in PLUGIN_FILES:
        shutil.copyfile(os.path.join(src, f), os.path.join(dest, f))
    print(f"installed {', '.join(PLUGIN_FILES)} into {dest}")
    print("restart Wireshark (or run tshark) to load it; check with: tshark -G protocols | grep pndiss")
    return 0


def run_path(args) -> int:
    print(f"plugin files: {plugin_source()}")
    print(f"install folder: {personal_plugin_dir()}")
    return 0
