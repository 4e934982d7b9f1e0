"""Record index names: tshark's own names where it has one (pndiss/data/record_index.json,
generated from tshark 4.0.17 `-G values`, field pn_io.index), else the encoder manuals' names
(spec/records.md §1), else the index range (IEC 61158-6-10 ranges as tshark 4.0 groups them)."""
from __future__ import annotations

import json
import os

with open(os.path.join(os.path.dirname(__file__), "..", "data", "record_index.json"), encoding="utf-8") as _f:
    TSHARK_NAMES: dict[int, str] = {int(k, 16): v for k, v in json.load(_f)["names"].items()}

# encoder records tshark does not name (records.md §1: 0xBF00 000_...:2169, 001_...:667, 004_...:642;
# 0x1000 001_...:686, 004_...:661, 002_...:1049; 0x1001/0xFFFF 002_...:982-1047)
ENCODER_NAMES = {0xBF00: "Encoder user parameter data", 0x1000: "Encoder vendor record 0x1000",
                 0x1001: "Encoder parameter control (P65005, PS/PSM)",
                 0xFFFF: "Encoder standard parameter (PS/PSM user parameter data)"}


def index_name(index: int) -> str:
    n = TSHARK_NAMES.get(index) or ENCODER_NAMES.get(index)
    if n:
        return n
    if index < 0x8000:
        return f"user specific record 0x{index:04X}"
    return f"record 0x{index:04X}"
