"""Text from the wire is data: one place that makes it safe for each sink.

NameOfStation, LLDP chassis/port IDs and system names, I&M strings, DeviceVendorValue and map-file
text come from outside. A terminal must not interpret them as rich markup or ANSI escapes (a
NameOfStation with ``[/]`` crashed the report, one with ``ESC]0;...`` retitled the window), and
matplotlib must not read them as mathtext (``$\\qq$`` crashed the plot). JSONL keeps the full value:
JSON escapes control characters itself.
"""
from __future__ import annotations

import re

MAX_TERMINAL = 120  # characters of one wire string shown in the terminal; JSONL has all of it

# C0 controls, DEL, C1 controls (ESC [ ... is only the common case of these), line/paragraph
# separators and bidi overrides that would reorder the rest of the line
_UNSAFE = re.compile("[\x00-\x1f\x7f-\x9f\u2028\u2029\u202a-\u202e\u2066-\u2069]")


def _visible(m: re.Match) -> str:
    c = m.group()
    return {"\n": "\\n", "\r": "\\r", "\t": "\\t"}.get(c) or (f"\\x{ord(c):02x}" if ord(c) < 0x100 else f"\\u{ord(c):04x}")


def visible(s, cap: int | None = MAX_TERMINAL) -> str:
    """``s`` as plain text with every control character shown as an escape (``\\x1b[2J`` stays
    readable and inert), cut to ``cap`` characters with a note of the full length."""
    if s is None:
        return ""
    if not isinstance(s, str):
        s = str(s)
    if cap is not None and len(s) > cap:
        s = s[:cap] + f"… ({len(s)} chars)"
    if _UNSAFE.search(s):
        s = _UNSAFE.sub(_visible, s)
    return s


def term(s, cap: int | None = MAX_TERMINAL) -> str:
    """For a rich console: ``visible`` and then rich's markup escape (``[`` can open a tag)."""
    from rich.markup import escape
    return escape(visible(s, cap))


def text(s, cap: int | None = MAX_TERMINAL, style: str = ""):
    """A rich ``Text`` (never parsed as markup) of ``visible(s)``."""
    from rich.text import Text
    return Text(visible(s, cap), style=style)


def mathtext(s, cap: int | None = 200) -> str:
    """For matplotlib labels: every ``$`` escaped, so no mathtext ever starts (matplotlib counts
    ``$`` minus ``\\$``; a backslash outside mathtext is shown as it is)."""
    return visible(s, cap).replace("$", r"\$")
