"""Stations seen in a capture, keyed by MAC: name, IP, vendor/device ID, role, ports.

Filled from DCP Identify/Set/Hello (the device's own answers win over what a controller asked
for), LLDP (chassis/port IDs, management address) and PNIO-CM (ARs). Constant size per station.
"""
from __future__ import annotations


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

    def from_dcp(self, ev: dict, src: str, dst: str) -> None:
        """A DCP response or Hello describes its sender; a Set request describes its target."""
        self.seen(src)
        info = ev.get("station_info")  # the DCP module collects name/ip/vendor/device/role here
        if not info:
            return
        target = dst if ev.get("service") == "Set" and ev.get("service_type") == 0 else src
        self.update(target, **info)

    def from_lldp(self, ev: dict, src: str) -> None:
        self.seen(src)
        info = ev.get("station_info")
        if info:
            self.update(src, **info)

    def as_list(self) -> list[dict]:
        return sorted(self.by_mac.values(), key=lambda s: s["mac"])
