"""Which device profile (Lika, SCANCON, Hohner Exx58N, Hohner PS/PSM, generic V4.1) a device uses,
from what identification we see: vendor ID / device ID (DCP or I&M0) and any order ID or DCP
device-vendor string (spec/network.md §1.11, records.md §2.4).

Only Lika's vendor ID is printed in the manuals (0x0239, 000_37bf2397999f1108.txt:846, 1962);
no manual gives a device ID. The other vendors are recognised by their order-number / type
strings, each cited below.
"""
from __future__ import annotations

import re

from .im import VENDORS

# vendor ID -> profile (000_...:846, 1962, 1993)
VENDOR_PROFILES = {0x0239: "lika"}

# (pattern on order ID / DCP type-of-station string, profile, source)
ORDER_PATTERNS = (
    (re.compile(r"LIKA|ROTACOD|XAC77", re.I), "lika",
     "000_37bf2397999f1108.txt:41-42, 1132 (XAC77.., 'LIKA ROTACOD')"),
    (re.compile(r"SCANCON|SAG-E", re.I), "scancon",
     "001_9461bb7bc8c2767b.txt:705, 1110, 1148 ('SAG-EIXXB..', 'SCANCON SAG')"),
    (re.compile(r"^E[A-Z]{0,3}M?58|ENA58IL", re.I), "hohner",
     "004_59bef5ae9f41db55.txt:172-173, 1010 ('Exx58N-...PN...', 'ExM58x-xxxPNxxxx1213', 'ENA58IL')"),
    (re.compile(r"\bPSM?\b|ACURO", re.I), "psm",
     "002_d69f444daf0f8af2.txt:5, 1334 ('PS/PSM Type 0', 'ACURO')"),
)


def select_profile(vendor_id: int | None, device_id: int | None = None, order_id: str | None = None,
                   *, source: str | None = None) -> tuple[str, str]:
    """(profile, reason in words). ``source`` names where the IDs came from (e.g. "DCP", "I&M0")."""
    frm = f" from {source}" if source else ""
    if vendor_id in VENDOR_PROFILES:
        prof = VENDOR_PROFILES[vendor_id]
        return prof, f"vendor ID 0x{vendor_id:04X} ({VENDORS.get(vendor_id, prof)}){frm}"
    if order_id:
        for pat, prof, src in ORDER_PATTERNS:
            if pat.search(order_id.strip()):
                return prof, f"order ID / type '{order_id.strip()}'{frm} matches {prof} ({src})"
    if vendor_id is None:
        return "generic", "no vendor ID seen: generic Encoder Profile V4.1"
    dev = f", device 0x{device_id:04X}" if device_id is not None else ""
    return "generic", (f"vendor 0x{vendor_id:04X}{dev}{frm} not a known encoder vendor: "
                       "generic Encoder Profile V4.1")
