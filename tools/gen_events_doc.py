"""Write docs/events.md: the JSONL event contract, with every kind's fields as observed on the
curated and public captures. Run: python3 tools/gen_events_doc.py"""
import glob
import os
import sys
from collections import defaultdict

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
sys.path.insert(0, ROOT)

from pndiss.analyzer import analyze_file  # noqa: E402

ABOUT = {
    "rt": "every PN-RT frame: FrameID, class, VLAN tags; cyclic frames add the APDU status "
          "(cycle_counter, ds and its bits as tshark names them, transfer_status, c_sdu_len)",
    "dcp": "a DCP PDU: service, xid, blocks (option/suboption and decoded values), `station_info` facts, "
           "`station` = the NameOfStation when the frame carries one",
    "dcp_name_invalid": "a device answers with a NameOfStation that breaks the naming rules (not a violation)",
    "lldp": "an LLDP frame: mandatory, optional, IEEE 802.1/802.3 and PROFINET TLVs (tshark names)",
    "mrp": "an MRP frame: version and TLVs",
    "ptcp": "a PTCP frame: header and TLV blocks",
    "alarm": "an RTA alarm PDU: header, DATA/ACK/NACK/ERR, AlarmNotification with diagnosis items",
    "ip_fragment": "an IPv4 fragment of a PNIO datagram (reassembled later)",
    "rpc": "one DCE/RPC PDU: header, operation, request/response pairing, PNIO-CM blocks, PNIO status",
    "ar": "an application relationship completed by a Connect response (`source` \"connect\"): IOCRs, data objects, telegrams and their "
          "source; `phase` (parameterisation, or refused) and `phases` (phase, frame) so far; in a capture without "
          "the Connect, one found from the cyclic content (`source` \"inferred from content\", `confidence`, "
          "`evidence`, `learnt_from` = first/last frame learnt from)",
    "ar_phase": "an AR moves on: parameterisation -> prm_end (PrmEnd) -> application_ready -> data_exchange (first "
                "judged cycle) -> released / aborted (ERR-RTA-PDU); cyclic data is judged from prm_end on",
    "record": "record data on the frame that carries it (write request / read response): index, name, decoded content",
    "record_result": "the response to a record write/read: PNIO status in words",
    "param": "a paired PROFIdrive parameter access (0xB02E/0xB02F): request + response, parameters named",
    "telegram": "one decoded data object of a mapped cyclic frame: signals, bits, IOPS, judged or gated",
    "state": "a state change of a reference encoder (control by PLC, preset, parking, sensor error, ...)",
    "violation": "a broken rule of the catalogue (contract below)",
    "malformed": "a frame (or reassembly) that could not be decoded: layer and reason",
    "capture_gap": "cycles of a cyclic stream the capture does not hold (its cycle counter skipped): capture loss, "
                   "not a protocol fault; `frame` is the first frame after the gap, the lost cycles are not judged",
}
# fields of events the shipped captures do not show (lossy or mid-session captures, issue #12)
EXTRA = {
    "capture_gap": {"station", "frame_id", "src", "dst", "direction", "cycles_missing", "prev_frame", "next_frame"},
    "ar": {"source", "telegram", "confidence", "evidence", "learnt_from"},
    "malformed": {"layer", "reason"},
}


def main() -> None:
    files = sorted(glob.glob(os.path.join(ROOT, "captures", "*.pcapng"))
                   + glob.glob(os.path.join(ROOT, "..", "shared", "captures", "public", "*.pcap*")))
    fields = defaultdict(set)
    counts = defaultdict(int)

    def sink(ev):
        counts[ev["kind"]] += 1
        fields[ev["kind"]].update(ev)

    for f in files:
        try:
            analyze_file(f, sink=sink)
        except Exception as e:  # a damaged file is reported, not fatal for the doc
            print(f"{f}: {e}", file=sys.stderr)
    lines = [
        "# Events (the JSONL contract)", "",
        "`pndiss analyze CAPTURE --jsonl PATH` writes one JSON object per line, in capture order. Every",
        "event has `frame` (1-based, equal to Wireshark's frame.number), `ts_ns` (capture time, integer",
        "nanoseconds since the epoch) and `kind`. Field names follow tshark's where tshark has the field",
        "(tests/tshark_map/*.json maps them one to one).", "",
        "## Types and schemas", "",
        "Every field name has one JSON type in every kind (or null where the value is unknown), so a",
        "query engine can type a column once: `station` is always the NameOfStation string (what a DCP",
        "or LLDP frame says about a station is the object `station_info`), `request_id` is a number like",
        "`response_id` (words in `request_id_name`), a state's `value`/`previous` are numbers (words in",
        "`value_name`/`previous_name`), the address IP-ASSIGN-OCCUPIED names is `ip_address` (`ip` is the",
        "IPv4 header object of `rpc` and `ip_fragment`). JSON Schemas ship in the package:",
        "`pndiss/data/event.schema.json` (one line) and `pndiss/data/summary.schema.json`",
        "(`--summary-json`); tests/test_analyst.py validates real output against both. Only one of",
        "`--jsonl -` and `--summary-json -` may use stdout.", "",
        "With `--station NAME|MAC` and/or `--time FROM..TO` only the events of that station / time range",
        "are written (and counted in the verdict and exit code).", "",
        "## The violation object", "",
        "```json",
        '{"frame": 1234, "ts_ns": 1767225601234000000, "kind": "violation", "rule": "SOL-MASTER-SKIP",',
        ' "side": "controller", "severity": "error", "last_frame": 1234,',
        ' "message": "controller sign-of-life 3 -> 5; expected 3 or 4", "source": "behaviour.md §9 #2; ..."}',
        "```", "",
        "`rule` is the stable catalogue ID (docs/rules.md), `side` is `controller` or `encoder`,",
        "`severity` is `error`, `warning` or `info`, `frame`/`last_frame` are the first and last frames",
        "involved, `ts_ns` is the time of `frame` (also for violations decided later), `source` cites",
        "the catalogue entry and the manuals (`pndiss rules RULE` names the manual sections). Extra keys (station, device_mac, slot,",
        "subslot, ...) may follow. `grep '\"kind\":\"violation\"'` finds them all.", "",
        "## Kinds", "",
        "Fields as observed on the curated and public captures (generated by tools/gen_events_doc.py).", "",
        "| kind | what | fields |", "|---|---|---|",
    ]
    for kind in sorted(set(fields) | set(ABOUT)):
        keys = sorted((fields.get(kind, set()) | EXTRA.get(kind, set())) - {"frame", "ts_ns", "kind"})
        lines.append(f"| `{kind}` | {ABOUT.get(kind, '')} | {', '.join(f'`{k}`' for k in keys) or '-'} |")
    with open(os.path.join(ROOT, "docs", "events.md"), "w", encoding="utf-8") as f:
        f.write("\n".join(lines) + "\n")
    print(f"{len(fields)} kinds from {len(files)} captures")


if __name__ == "__main__":
    main()
