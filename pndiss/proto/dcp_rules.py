"""PN-DCP rules: NameOfStation naming (DCP-NAME-INVALID, spec/network.md §2.1) on one frame, and
``DcpTracker``, the cross-frame state for DCP-NAME-DUPLICATE and IP-ASSIGN-OCCUPIED.
"""
from __future__ import annotations

import re
from collections import deque

from .. import rules
from .dcp_tables import HELLO, IDENTIFY, SET
from .eth import NO_DST


MAX_NAME = 127   # Lika manual (000_37bf2397999f1108.txt:956-968); IEC allows 240 octets [AMBIGUOUS]
MAX_LABEL = 63
_LABEL_OK = re.compile(r"[A-Za-z0-9-]*")
_PORT_NAME = re.compile(r"port-\d{3}(-\d{5})?")
_IPV4_LIKE = re.compile(r"\d+\.\d+\.\d+\.\d+")


def name_problems(name: str) -> list[str]:
    """Why ``name`` breaks the NameOfStation rules (empty list = fine). An empty name is a
    reset, not an error. Letters of either case are accepted (the manuals say "letters";
    the IEC lower-case rule is [UNVERIFIED] in spec/wire.md §3.6)."""
    if name == "":
        return []
    probs = []
    if len(name) > MAX_NAME:
        probs.append(f"{len(name)} characters (more than {MAX_NAME})")
    bad = sorted({c for c in name if not (c == "." or _LABEL_OK.fullmatch(c))})
    if bad:
        probs.append("characters other than letters, digits, '-' and '.': " + " ".join(repr(c) for c in bad))
    if name.startswith("-") or name.endswith("-"):
        probs.append("starts or ends with '-'")
    labels = name.split(".")
    last = len(labels) - 1
    for i, label in enumerate(labels):
        if label == "":
            probs.append("empty label (leading, trailing or double '.')")
            continue
        if len(label) > MAX_LABEL:
            probs.append(f"label of {len(label)} characters (more than {MAX_LABEL})")
        # DNS labels: no '-' at either end (the name's own ends are reported above)
        if (i > 0 and label[0] == "-") or (i < last and label[-1] == "-"):
            probs.append(f"label {label!r} starts or ends with '-'")
    # IEC 61158-6-10 extras quoted in spec/wire.md §3.6 [UNVERIFIED there]: not "port-xyz",
    # not an IPv4 literal
    if _PORT_NAME.fullmatch(name.split(".")[0].lower()):
        probs.append("has the form of a port name (port-xyz)")
    if _IPV4_LIKE.fullmatch(name):
        probs.append("has the form of an IPv4 address")
    return probs


def violation_event(rule: str, message: str, **extra) -> dict:
    """A violation for the ``events`` list of a decoded frame: the analyzer stamps frame and
    time (Analyzer.event), so this one drops the placeholders."""
    ev = rules.violation(rule, 0, 0, message, **extra)
    for k in ("frame", "ts_ns", "last_frame"):
        del ev[k]
    return ev


def name_events(d: dict, sid: int, response: bool) -> list[dict]:
    out = []
    for b in d["blocks"]:
        name = b.get("nameofstation")
        if name is None:
            continue
        probs = name_problems(name)
        if not probs:
            continue
        if sid == SET and not response:
            out.append(violation_event("DCP-NAME-INVALID",
                                       f"Set NameOfStation {name!r}: " + "; ".join(probs), name=name))
        elif response or sid == HELLO:
            # a device reports a name that breaks the rules (not the controller's Set)
            out.append({"kind": "dcp_name_invalid", "name": name, "problems": probs,
                        "service": d["service"]})
    return out


class DcpTracker:
    """Cross-frame DCP state: which MAC holds which NameOfStation and IP, learned from Identify /
    Get responses and Hellos (the device's own word) and from Set requests (assignments).

    ``on_dcp(ev, src, dst)`` returns violation events (frame/time from ``ev``):
    DCP-NAME-DUPLICATE when a Set gives a name that another MAC holds, or two MACs report the
    same name; IP-ASSIGN-OCCUPIED when a Set assigns an IP that another MAC holds.
    Each (rule, value, MAC pair) is reported once.

    A holder that left an Identify unanswered (one for all devices, or for that name / IP, sent after
    the holder last claimed the value) is gone: the value passes to the new MAC without a violation.
    That is how a failed device is replaced: the controller's Identify finds only the new device, which
    then gets the old one's name and IP (000_37bf2397999f1108.txt:1052-1069).
    """

    def __init__(self, table=dict):
        # ``table()`` makes each per-key table (the analyzer passes bounded ones: pndiss/limits.py)
        self.name_at: dict[str, tuple[str, int]] = table()   # name -> (mac, frame seen)
        self.ip_at: dict[str, tuple[str, int]] = table()     # ip -> (mac, frame seen)
        self.mac_name: dict[str, str] = table()
        self.mac_ip: dict[str, str] = table()
        self.reported: set = set()
        # the latest Identify requests: [xid, frame, filter {"all"/"name"/"ip": value}, MACs that answered, asker]
        self.identifies: deque = deque(maxlen=16)

    def on_dcp(self, ev: dict, src: str, dst: str) -> list[dict]:
        if ev.get("service_id") == IDENTIFY:
            self._identify(ev, src)
        st = ev.get("station_info")
        if not st:
            return []
        assign = ev.get("service_id") == SET and ev.get("service_type") == 0
        target = dst if assign else src
        if assign and target == NO_DST:
            return []   # a Linux cooked capture has no destination address: whom the Set names is not known
        fn, ts = ev.get("frame", 0), ev.get("ts_ns", 0)
        out = []
        name = st.get("name")
        xid = ev.get("xid") if ev.get("service_id") == IDENTIFY else None
        if name:
            out += self._claim("name", name, target, assign, fn, ts, xid)
        elif name == "":
            self._release(self.name_at, self.mac_name, target)  # name reset: the name is free
        ip = st.get("ip")
        if ip and ip != "0.0.0.0":
            out += self._claim("ip", ip, target, assign, fn, ts, xid)
        elif ip == "0.0.0.0":
            self._release(self.ip_at, self.mac_ip, target)
        return out

    def _identify(self, ev: dict, src: str) -> None:
        if ev.get("service_type") == 0:
            flt = {}
            for b in ev.get("blocks", ()):
                if b.get("option") == 0xFF and b.get("suboption") == 0xFF:
                    flt["all"] = True
                elif "nameofstation" in b:
                    flt["name"] = b["nameofstation"]
                elif b.get("option") == 1 and b.get("suboption") == 2 and b.get("ip"):
                    flt["ip"] = b["ip"]
            self.identifies.append([ev.get("xid"), ev.get("frame", 0), flt, set(), src])
        else:
            for idf in self.identifies:
                if idf[0] == ev.get("xid"):
                    idf[3].add(src)

    def _gone(self, mac_: str, seen: int, xid) -> bool:
        """Did an Identify after frame ``seen`` that the holder ``mac_`` had to answer (for all, for its name
        or its IP) go unanswered? (The Identify a response answers is still open: not judged with it.) Responses
        go to the asker only: they reach the capture when one of that asker's Identifies shows an answer -- an
        Identify for the name nobody answered, then one by AliasName (the neighbour's port, LLDP) the new device
        answers, is how a controller finds the replacement of a failed device (behaviour.md §5.4 item 6)."""
        heard = {idf[4] for idf in self.identifies if idf[3]}
        for idf_xid, frame, flt, answered, asker in self.identifies:
            if frame > seen and idf_xid != xid and (answered or asker in heard) and mac_ not in answered and (
                    flt.get("all") or flt.get("name", False) == self.mac_name.get(mac_)
                    or flt.get("ip", False) == self.mac_ip.get(mac_)):
                return True
        return False

    @staticmethod
    def _release(at: dict, by_mac: dict, mac_: str) -> None:
        old = by_mac.pop(mac_, None)
        if old is not None and at.get(old, ("",))[0] == mac_:
            del at[old]

    def _claim(self, what: str, value: str, mac_: str, assign: bool, fn: int, ts: int, xid=None) -> list[dict]:
        at, by_mac = (self.name_at, self.mac_name) if what == "name" else (self.ip_at, self.mac_ip)
        out = []
        holder = at.get(value)
        if holder is not None and holder[0] != mac_ and by_mac.get(holder[0]) == value \
                and self._gone(holder[0], holder[1], xid):
            self._release(self.name_at, self.mac_name, holder[0])  # a replaced device: its name and IP are free
            self._release(self.ip_at, self.mac_ip, holder[0])
            holder = None
        if holder is not None and holder[0] != mac_ and by_mac.get(holder[0]) == value:
            other, seen = holder
            if what == "name":
                rule = "DCP-NAME-DUPLICATE"
                msg = (f"NameOfStation {value!r} {'assigned' if assign else 'reported'} for {mac_}, "
                       f"but {other} holds it (frame {seen})")
            else:
                rule = "IP-ASSIGN-OCCUPIED"
                msg = f"Set assigns IP {value} to {mac_}, but {other} uses it (frame {seen})"
            key = (rule, value, frozenset((mac_, other)))
            if (what == "name" or assign) and key not in self.reported:
                self.reported.add(key)
                # 'ip' is the IPv4 header object in rpc events: the address claimed is 'ip_address'
                out.append(rules.violation(rule, fn, ts, msg, **{"ip_address" if what == "ip" else what: value, "mac": mac_,
                                                                 "other_mac": other, "other_frame": seen}))
        old = by_mac.get(mac_)
        if old is not None and old != value and at.get(old, ("",))[0] == mac_:
            del at[old]
        by_mac[mac_] = value
        if holder is None or holder[0] == mac_ or by_mac.get(holder[0]) != value or assign:
            at[value] = (mac_, fn)
        return out
