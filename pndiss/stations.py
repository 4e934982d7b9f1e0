"""Stations seen in a capture, keyed by MAC: name, IP, vendor/device ID, role, ports.

Filled from DCP Identify/Set/Hello (the device's own answers win over what a controller asked
for), LLDP (chassis/port IDs, management address) and PNIO-CM (ARs). Constant size per station.
"""
from __future__ import annotations

from .proto.eth import NO_DST


IDENTITY = ("vendor_id", "device_id", "type_of_station")   # what a device's profile is decided from (DCP)


class Stations:
    def __init__(self, by_mac: dict | None = None):
        self.by_mac: dict[str, dict] = {} if by_mac is None else by_mac   # a limits.BoundedDict in the analyzer

    def get(self, mac: str) -> dict:
        s = self.by_mac.get(mac)
        if s is None:
            s = self.by_mac[mac] = {"mac": mac, "frames": 0}
        return s

    def seen(self, mac: str) -> dict:
        s = self.get(mac)
        s["frames"] += 1
        return s

    def update(self, mac: str, **fields) -> None:
        s = self.get(mac)
        for k, v in fields.items():
            if v is not None:
                s[k] = v

    def from_dcp(self, ev: dict, src: str, dst: str) -> str | None:
        """A DCP response or Hello describes its sender; a Set request describes its target. Returns the MAC whose
        identity (vendor ID, device ID, type of station) this changed, else None."""
        self.seen(src)
        info = ev.get("station_info")  # the DCP module collects name/ip/vendor/device/role here
        if not info:
            return None
        target = dst if ev.get("service") == "Set" and ev.get("service_type") == 0 else src
        if target == NO_DST:   # a Set in a Linux cooked capture: the target's address is not there
            return None
        s = self.get(target)
        before = tuple(s.get(k) for k in IDENTITY)
        self.update(target, **info)
        return target if tuple(s.get(k) for k in IDENTITY) != before else None

    def from_lldp(self, ev: dict, src: str) -> None:
        self.seen(src)
        info = ev.get("station_info")
        if info:
            self.update(src, **info)

    def as_list(self) -> list[dict]:
        """Every station by MAC; an LLDP port MAC of a known station carries ``lldp_port_of`` (that
        station's MAC) so readers do not take a device's ports for devices of their own."""
        out = sorted(self.by_mac.values(), key=lambda s: s["mac"])
        ports = lldp_ports(out)
        return [dict(s, lldp_port_of=ports[s["mac"]]) if s["mac"] in ports else s for s in out]


def lldp_ports(stations: list[dict]) -> dict[str, str]:
    """MAC -> device MAC for LLDP port MACs: a source known only from LLDP whose system name is a
    station that DCP or an AR knows under another MAC is that station's port, not a station."""
    by_name = {}
    for s in stations:
        if s.get("name") and (s.get("vendor_id") is not None or s.get("ip") or s.get("role") is not None):
            by_name.setdefault(s["name"], s["mac"])
    out = {}
    for s in stations:
        if s.get("port_id") is not None and s.get("vendor_id") is None and s.get("name") in by_name \
                and by_name[s["name"]] != s["mac"]:
            out[s["mac"]] = by_name[s["name"]]
    return out
