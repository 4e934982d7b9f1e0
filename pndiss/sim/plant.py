"""What a plant adds on the wire beside the encoders' start-up and cyclic data (``pndiss simulate
--param-polls MS --it-traffic FPS``): the benchmark's realistic set (bench/run, set (d)).

- **Parameter polls.** An HMI or the PLC program reads encoder parameters over PROFIdrive base-mode
  parameter access while the shaft turns: per encoder every MS ms a 0xB02E write and read (four
  DCE/RPC datagrams, records.md §3.2), staggered between the encoders, the parameters in turn. Only
  parameters whose value does not move (P964 device identification, P965 profile number, P979
  sensor format) are read, so the truth needs no model of the device's state.
- **IT traffic.** A PROFINET segment is rarely PROFINET only: OPC UA over TCP between an HMI and the
  PLC, SNMP polls of every device, ARP, mDNS over IPv6, ICMP echo. FPS frames per second, Poisson
  arrivals, seeded. None of it is PROFINET: the analyzer counts it as "not PROFINET".
"""
from __future__ import annotations

import random
import struct

from .stations import CTRL_IP, CTRL_MAC

POLL_PNUS = (964, 965, 979)
HMI_MAC, HMI_IP = "02:00:00:00:f0:01", "192.168.0.200"
SNMP_MAC, SNMP_IP = "02:00:00:00:f0:02", "192.168.0.201"
# the share of each kind of IT frame (OPC UA request/response pairs dominate an HMI's traffic)
IT_MIX = (("opcua", 0.60), ("snmp", 0.16), ("arp", 0.10), ("mdns", 0.09), ("icmp", 0.05))


def parameter_polls(sess, encs: dict, every_ms: float) -> int:
    """Base-mode reads of each encoder every ``every_ms`` ms from after its start-up reads to the end of
    the cyclic run; returns how many."""
    period = int(every_ms * 1_000_000)
    unit = max(sess.cycle_ns, 1_000_000)
    t_end = sess.cyc_ts(sess.cfg.cycles) - 3_000_000   # the last one answered before the Release
    n = max(1, len(sess.stations))
    count = 0
    for st in sess.stations:
        t = sess.cyc_start_ns + 200 * unit + st.i * period // n   # after the start-up reads (session.build)
        k = 0
        while t < t_end:
            sess.read_param(t, st, POLL_PNUS[k % len(POLL_PNUS)], encs[st.i])
            t += period
            k += 1
            count += 1
    return count


def _mac(s: str) -> bytes:
    return bytes(int(x, 16) for x in s.split(":"))


def _ip(s: str) -> bytes:
    return bytes(int(x) for x in s.split("."))


def _eth(src: str, dst: str, etype: int, payload: bytes) -> bytes:
    b = _mac(dst) + _mac(src) + struct.pack(">H", etype) + payload
    return b + bytes(max(0, 60 - len(b)))


def _ipv4(src: str, dst: str, proto: int, payload: bytes, ident: int) -> bytes:
    hdr = struct.pack(">BBHHHBBH4s4s", 0x45, 0, 20 + len(payload), ident & 0xFFFF, 0x4000, 64, proto, 0,
                      _ip(src), _ip(dst))
    return hdr[:10] + struct.pack(">H", _checksum(hdr)) + hdr[12:] + payload


def _tlv(tag: int, value: bytes) -> bytes:
    """A BER tag-length-value (short length form: every SNMP message here is under 128 bytes)."""
    return bytes([tag, len(value)]) + value


def _checksum(b: bytes) -> int:
    """The Internet checksum (RFC 1071) of b."""
    if len(b) & 1:
        b += b"\x00"
    s = sum(struct.unpack(f">{len(b) // 2}H", b))
    while s >> 16:
        s = (s & 0xFFFF) + (s >> 16)
    return ~s & 0xFFFF


class _It:
    def __init__(self, sess, rng):
        self.sess, self.rng = sess, rng
        self.ip_id = rng.randrange(1 << 16)
        self.tcp_seq = [rng.randrange(1 << 32), rng.randrange(1 << 32)]
        self.snmp_id = rng.randrange(1 << 20)
        self.devices = [(st.mac, st.ip) for st in sess.all_stations()]

    def frames(self, kind: str) -> list:
        """The frame(s) of one IT exchange: (delay ns, frame bytes)."""
        self.ip_id += 1
        r = self.rng
        if kind == "opcua":   # an OPC UA MSG chunk from the HMI and the PLC's answer
            n = 60 + r.randrange(200)
            body = b"MSGF" + struct.pack("<I", n) + bytes(n - 8)   # the chunk's size field: its whole length
            req = self._tcp(HMI_MAC, CTRL_MAC, HMI_IP, CTRL_IP, 51000, 4840, 0, body)
            res = self._tcp(CTRL_MAC, HMI_MAC, CTRL_IP, HMI_IP, 4840, 51000, 1, body[:8] + bytes(len(body) - 8))
            return [(0, req), (150_000 + r.randrange(400_000), res)]
        if kind == "snmp":    # an SNMPv1 GetRequest of sysUpTime.0 and its answer (BER)
            mac, ip = self.devices[r.randrange(len(self.devices))]
            self.snmp_id += 1
            oid = _tlv(6, bytes([0x2B, 6, 1, 2, 1, 1, 3, 0]))
            rid = _tlv(2, self.snmp_id.to_bytes(3, "big")) + _tlv(2, b"\x00") + _tlv(2, b"\x00")

            def msg(pdu_tag, value):
                return _tlv(0x30, _tlv(2, b"\x00") + _tlv(4, b"public")
                            + _tlv(pdu_tag, rid + _tlv(0x30, _tlv(0x30, oid + value))))
            up = _tlv(0x43, (r.randrange(1 << 31)).to_bytes(4, "big"))
            q = self._udp(SNMP_MAC, mac, SNMP_IP, ip, 50161, 161, msg(0xA0, _tlv(5, b"")))
            a = self._udp(mac, SNMP_MAC, ip, SNMP_IP, 161, 50161, msg(0xA2, up))
            return [(0, q), (400_000 + r.randrange(600_000), a)]
        if kind == "arp":     # who-has from the HMI
            mac, ip = self.devices[r.randrange(len(self.devices))]
            arp = struct.pack(">HHBBH6s4s6s4s", 1, 0x0800, 6, 4, 1, _mac(HMI_MAC), _ip(HMI_IP), bytes(6), _ip(ip))
            return [(0, _eth(HMI_MAC, "ff:ff:ff:ff:ff:ff", 0x0806, arp))]
        if kind == "mdns":    # an IPv6 mDNS query of the engineering PC
            name = (b"\x05_http", b"\x04_ipp", b"\x04_ssh", b"\x05_opcua")[self.ip_id % 4]
            q = struct.pack(">HHHHHH", 0, 0, 1, 0, 0, 0) + name + b"\x04_tcp\x05local\x00\x00\x0c\x00\x01"
            src, dst = bytes.fromhex("fe800000000000000000f0fffe000001"), bytes.fromhex("ff0200000000000000000000000000fb")
            udp = struct.pack(">HHHH", 5353, 5353, 8 + len(q), 0) + q
            ck = _checksum(src + dst + struct.pack(">IxxxB", len(udp), 17) + udp) or 0xFFFF   # RFC 8200 §8.1
            udp = udp[:6] + struct.pack(">H", ck) + udp[8:]
            ip6 = struct.pack(">IHBB", 6 << 28, len(udp), 17, 255) + src + dst
            return [(0, _eth(HMI_MAC, "33:33:00:00:00:fb", 0x86DD, ip6 + udp))]
        mac, ip = self.devices[r.randrange(len(self.devices))]   # icmp: a ping of a device and its reply
        req, rep = (struct.pack(">BBHHH", t, 0, 0, 1, self.ip_id & 0xFFFF) + bytes(32) for t in (8, 0))
        req, rep = (m[:2] + struct.pack(">H", _checksum(m)) + m[4:] for m in (req, rep))
        return [(0, _eth(HMI_MAC, mac, 0x0800, _ipv4(HMI_IP, ip, 1, req, self.ip_id))),
                (200_000, _eth(mac, HMI_MAC, 0x0800, _ipv4(ip, HMI_IP, 1, rep, self.ip_id)))]

    def _tcp(self, sm, dm, si, di, sp, dp, side, body) -> bytes:
        seq = self.tcp_seq[side]
        self.tcp_seq[side] = (seq + len(body)) & 0xFFFFFFFF
        ack = self.tcp_seq[1 - side]
        tcp = struct.pack(">HHIIBBHHH", sp, dp, seq, ack, 0x50, 0x18, 8192, 0, 0) + body
        return _eth(sm, dm, 0x0800, _ipv4(si, di, 6, tcp, self.ip_id))

    def _udp(self, sm, dm, si, di, sp, dp, body) -> bytes:
        udp = struct.pack(">HHHH", sp, dp, 8 + len(body), 0) + body
        return _eth(sm, dm, 0x0800, _ipv4(si, di, 17, udp, self.ip_id))


def it_traffic(sess, fps: float) -> int:
    """About ``fps`` IT frames per second from the first cycle to the end of the cyclic run (Poisson
    arrivals of exchanges, IT_MIX); returns how many frames."""
    rng = random.Random(f"it-traffic:{sess.cfg.seed}:{fps}")
    it = _It(sess, rng)
    kinds, weights = zip(*IT_MIX)
    per_exchange = sum(w * (1 if k in ("arp", "mdns") else 2) for k, w in IT_MIX)
    rate = fps / per_exchange / 1e9                     # exchanges per ns
    t, t_end = sess.cyc_start_ns, sess.cyc_ts(sess.cfg.cycles)
    count = 0
    while True:
        t += int(rng.expovariate(rate)) + 1
        if t >= t_end:
            return count
        for delay, data in it.frames(rng.choices(kinds, weights)[0]):
            sess.add(t + delay, data, "it")
            count += 1
