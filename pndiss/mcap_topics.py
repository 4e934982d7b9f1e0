"""Which MCAP channel an event goes to, and what its message holds (topics: docs/mcap.md).

Per event kind: the topic (per station, per data object and direction, or fixed), the channel's
metadata (fields constant per channel leave the message) and, for the cyclic topics, volume control
(``on_change`` / ``decimate``). Station labels are fixed at first use: NameOfStation when known, else
the MAC.

A mixin of pndiss.mcap_export.McapExporter: the exporter's channels, written through its _write.
"""
from __future__ import annotations

import json
import os
import re

from .mcap_schemas import SCHEMAS, type_of
from .telegrams import CHANGE_MASKS

# event kind -> (schema key, fixed topic) for the events that are not per-station
_FIXED = {"dcp": ("event", "/pn/dcp"), "lldp": ("event", "/pn/lldp"), "alarm": ("event", "/pn/alarms"),
          "malformed": ("malformed", "/pn/malformed")}
VIOLATIONS_TOPIC = "/pn/violations"
LEVELS = {"info": 2, "warning": 3, "error": 4}  # violation severity -> foxglove.LogLevel
_SETPOINT = {"setpoint", "output", "out", "o", "controller"}  # direction words meaning ctrl -> encoder

# fields that are constant per channel: they go to channel metadata, not into every message
_TG_CONST = frozenset(("kind", "ts_ns", "station", "device_mac", "controller_mac", "api", "slot",
                       "subslot", "telegram", "direction", "frame_id"))
_RT_CONST = frozenset(("kind", "ts_ns", "src", "dst", "frame_id", "frame_class", "iodata"))  # iodata: per-frame IOxS detail (pndiss/iodata.py), not on the timeline
TG_CONST, RT_CONST = _TG_CONST, _RT_CONST
_UNSAFE = re.compile(r"[^A-Za-z0-9._-]")


class Channel:
    """What one channel remembers: id, last time written (monotonic clamp), volume-control state."""
    __slots__ = ("id", "topic", "last_t", "n", "written", "last_key", "last_written_t", "prev_cc", "prev_t")

    def __init__(self, cid: int, topic: str):
        self.id, self.topic = cid, topic
        self.last_t = 0
        self.n = 0             # samples seen (for decimation)
        self.written = 0
        self.last_key = None   # what on_change compares
        self.last_written_t = None
        self.prev_cc = None    # apdu: previous cycle counter / time, for d_cycle and dt_ns
        self.prev_t = None


class Topics:
    """McapExporter mixin: event kinds -> channels and messages."""

    # -- events -----------------------------------------------------------------------------
    def on_event(self, ev: dict) -> None:
        kind = ev.get("kind")
        self.seen[kind] = self.seen.get(kind, 0) + 1
        h = self._kinds.get(kind)
        if h is not None:
            h(ev)
            return
        if kind == "dcp" or kind == "lldp" or kind == "ar":
            self._learn_station(kind, ev)
        skey, topic = _FIXED.get(kind) or ("event", f"/pn/{_UNSAFE.sub('_', str(kind))}")
        ckey = ("k", topic)
        ch = self._chans.get(ckey) or self._chan(ckey, topic, skey, {"kind": kind})
        self._write(ch, ev, ev)

    def _learn_station(self, kind: str, ev: dict) -> None:
        if kind == "ar":
            for k in ("controller_mac", "controller"):
                if isinstance(ev.get(k), str):
                    self._controllers.add(ev[k])
            self._learn(ev.get("device_mac"), ev.get("station"))
            return
        info = ev.get("station_info")
        if isinstance(info, dict):
            name = info.get("name") or info.get("name_of_station")
            # a DCP Set request names its target, every other DCP/LLDP frame its sender
            target = ev.get("dst") if ev.get("service") == "Set" and ev.get("service_type") == 0 else ev.get("src")
            self._learn(target, name)

    def _rt(self, ev: dict) -> None:
        cc = ev.get("cycle_counter")
        if cc is None:  # acyclic carrier (DCP, alarm, PTCP): its payload has its own topic
            return
        src, dst, fid = ev.get("src"), ev.get("dst"), ev.get("frame_id")
        ckey = ("rt", fid, src, dst)
        ch = self._chans.get(ckey)
        if ch is None:
            # Frame IDs are chosen per receiver, so both directions of an AR may use the same
            # one: with the roles known (Connect) the topic names the device and the direction.
            fids = f"0x{fid:04x}" if isinstance(fid, int) else _UNSAFE.sub("_", str(fid))
            if src in self._controllers or dst in self._controllers:
                dev, way = (dst, "output") if src in self._controllers else (src, "input")
                topic = f"/pn/{self._label(dev)}/apdu/{fids}/{way}"
            else:
                dev, way = src, None
                topic = f"/pn/{self._label(dev)}/apdu/{fids}"
            ch = self._chan(ckey, topic, "apdu", {
                "src": src, "dst": dst, "frame_id": fids, "frame_class": ev.get("frame_class"),
                "device_mac": dev, "direction": way})
        ts = ev.get("ts_ns") or 0
        d_cycle = None if ch.prev_cc is None else (cc - ch.prev_cc) & 0xFFFF
        dt = None if ch.prev_t is None else ts - ch.prev_t
        ch.prev_cc, ch.prev_t = cc, ts
        if (self.on_change or self.decimate > 1) and not self._keep(
                ch, (ev.get("ds"), ev.get("transfer_status"), d_cycle, ev.get("iops"), ev.get("iocs")), ts):
            return
        msg = {k: v for k, v in ev.items() if k not in _RT_CONST}
        if d_cycle is not None:
            msg["d_cycle"] = d_cycle
            msg["dt_ns"] = dt
        self._write(ch, ev, msg)

    def _telegram(self, ev: dict) -> None:
        mac = ev.get("device_mac")
        d = str(ev.get("direction", "")).lower()
        side = "setpoint" if d in _SETPOINT else "actual"
        api, slot, sub, tg = ev.get("api"), ev.get("slot"), ev.get("subslot"), ev.get("telegram")
        ckey = ("tg", mac, api, slot, sub, side)
        ch = self._chans.get(ckey)
        if ch is None:
            self._learn(mac, ev.get("station"))
            lab = self._label(mac, ev.get("station"))
            tgs = f"{tg:02d}" if isinstance(tg, int) else str(tg or "unknown")
            topic = f"/pn/{lab}/{slot}.{sub}/tg{tgs}/{side}"
            schema = json.loads(json.dumps(SCHEMAS["telegram"]))
            schema["title"] = f"pndiss.Telegram{tgs}{side.capitalize()}"
            for part in ("signals", "bits"):
                if isinstance(ev.get(part), dict):
                    props = schema["properties"][part]["properties"]
                    for k, v in ev[part].items():
                        t = type_of(v)
                        if t is not None:
                            props[str(k)] = t
            ch = self._chan(ckey, topic, "telegram", {
                "device_mac": mac, "station": ev.get("station"), "api": api, "slot": slot,
                "subslot": sub, "telegram": tg, "direction": side,
                "frame_id": f"0x{ev['frame_id']:04x}" if isinstance(ev.get("frame_id"), int) else ev.get("frame_id")},
                schema)
            self.telegram_channels.append({
                "topic": ch.topic, "station": ev.get("station") or mac, "slot": slot, "subslot": sub,
                "telegram": tg, "side": side,
                **{part: [str(k) for k in ev[part]] if isinstance(ev.get(part), dict) else []
                   for part in ("signals", "bits")}})
        if (self.on_change or self.decimate > 1) and not self._keep(ch, _change_key(ev), ev.get("ts_ns") or 0):
            return
        self._write(ch, ev, {k: v for k, v in ev.items() if k not in _TG_CONST})

    def _station_chan(self, ev: dict, what: str, skey: str) -> Channel:
        mac = ev.get("device_mac")
        self._learn(mac, ev.get("station"))
        lab = self._label(mac, ev.get("station"))
        ckey = (what, lab)
        return self._chans.get(ckey) or self._chan(ckey, f"/pn/{lab}/{what}", skey,
                                                   {"device_mac": mac, "station": ev.get("station")})

    def _state(self, ev: dict) -> None:
        self._write(self._station_chan(ev, "encoder_state", "state"), ev, ev)

    def _record(self, ev: dict) -> None:
        self._write(self._station_chan(ev, "records", "records"), ev, ev)

    def _violation(self, ev: dict) -> None:
        ckey = ("violations",)
        ch = self._chans.get(ckey) or self._chan(ckey, VIOLATIONS_TOPIC, "log", {})
        ts = ev.get("ts_ns") or 0
        fn, last = ev.get("frame"), ev.get("last_frame")
        where = f"frame {fn}" if last in (None, fn) else f"frames {fn}-{last}"
        rule = str(ev.get("rule", "?"))
        msg = {
            "timestamp": {"sec": ts // 1_000_000_000, "nsec": ts % 1_000_000_000},
            "level": LEVELS.get(ev.get("severity"), 0),
            "message": f"{rule} ({ev.get('side', '?')}, {where}): {ev.get('message', '')}",
            "name": rule,
            "file": os.path.basename(self.capture_path) if self.capture_path else "",
            "line": fn & 0xFFFFFFFF if isinstance(fn, int) and fn >= 0 else 0,
        }
        self._write(ch, ev, msg)

    # -- stations and volume control ---------------------------------------------------------------
    def _keep(self, ch: Channel, key, ts: int) -> bool:
        """Volume control for a cyclic sample (no options: every sample)."""
        ch.n += 1
        if not self.on_change:
            if self.decimate == 1 or (ch.n - 1) % self.decimate == 0:
                return True
            self.dropped += 1
            return False
        changed = key != ch.last_key
        ch.last_key = key
        if (changed or ch.last_written_t is None or ts - ch.last_written_t >= self.keyframe_ns
                or (self.decimate > 1 and (ch.n - 1) % self.decimate == 0)):
            return True
        self.dropped += 1
        return False

    def _label(self, mac: str | None, name: str | None = None) -> str:
        """Topic label of a station: NameOfStation when known at first use, else the MAC."""
        if not isinstance(name, str):
            name = None
        if not mac:
            return _UNSAFE.sub("_", name) if name else "unknown"
        mac = str(mac)
        lab = self._labels.get(mac)
        if lab is None:
            nm = name or self._names.get(mac)
            lab = _UNSAFE.sub("_", nm if nm else mac.replace(":", "-"))
            if lab in self._used_labels:  # two stations with one name (a DCP fault): add the MAC
                lab = f"{lab}_{mac.replace(':', '-')}"
            self._labels[mac] = lab
            self._used_labels.add(lab)
        return lab

    def _learn(self, mac, name) -> None:
        if isinstance(mac, str) and isinstance(name, str) and name and mac not in self._names:
            self._names[mac] = name


def _change_key(ev: dict):
    """What on_change compares of a telegram sample: its signals without the sign-of-life counters
    (telegrams.CHANGE_MASKS: they step every cycle), else its words and raw bytes."""
    sig = ev.get("signals")
    if isinstance(sig, dict):
        return (None, None, {k: v & CHANGE_MASKS[k] if k in CHANGE_MASKS and isinstance(v, int) else v
                             for k, v in sig.items()})
    return (ev.get("words"), ev.get("raw"), sig)
