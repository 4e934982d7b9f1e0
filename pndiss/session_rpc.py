"""The transport layers of the PNIO-CM session tracker: IPv4 (fragments reassembled, bounded) -> UDP
-> RT_CLASS_UDP on 34962, or connectionless DCE/RPC with a PNIO interface UUID (fragments
reassembled, bounded), whose stub goes on to the PNIO-CM layer (SessionTracker._cm). Requests and
responses pair by activity UUID + sequence number.

A mixin of pndiss.session.SessionTracker: the tracker's own tables and counts.
"""
from __future__ import annotations

from .proto import dcerpc, ip, pnio_cm
from .proto.common import Malformed

PORT_RT_UDP = 0x8892    # 34962, RT_CLASS_UDP (spec/wire.md §1)
PORT_RPC = 0x8894       # 34964, PNIO-CM endpoint mapper / RPC server (spec/wire.md §1)

# PNIO interface UUIDs (spec/wire.md §5.2) and the endpoint mapper (DCE 1.1 RPC, tshark packet-epm.c)
INTERFACES = {
    "dea00001-6c97-11d1-8271-00a02442df7d": "PNIO Device",
    "dea00002-6c97-11d1-8271-00a02442df7d": "PNIO Controller",
    "dea00003-6c97-11d1-8271-00a02442df7d": "PNIO Supervisor",
    "dea00004-6c97-11d1-8271-00a02442df7d": "PNIO ParameterServer",
}
EPM_UUID = "e1af8308-5d1f-11c9-91a4-08002b14a0fa"


class RpcLayer:
    """SessionTracker mixin: IPv4 / UDP / DCE-RPC frames in, ``ip_fragment`` and ``rpc`` events out."""

    # ---------------------------------------------------------------- IPv4 / UDP
    def on_ipv4(self, fn, ts, data, off, src, dst) -> str:
        if len(data) - off >= 20 and data[off + 9] != ip.PROTO_UDP:
            return "not_profinet"  # TCP, ICMP, IGMP ...: no header work for traffic we do not decode
        if self._plain_udp(data, off):
            self._expire(ts)       # (as the full path below does for every whole datagram)
            return "not_profinet"
        try:
            h = ip.decode_ipv4(data, off)
        except Malformed:
            if self._pn_ports(data, off + 20):
                raise
            return "not_profinet"  # e.g. a snaplen-cut datagram of some other protocol
        self._expire(ts)
        if h["flags_mf"] or h["frag_offset"]:
            return self._ip_fragment(fn, ts, data, h, src, dst)
        if h["proto"] != ip.PROTO_UDP:
            return "not_profinet"
        return self._udp(fn, ts, data, h["payload_off"], h["payload_end"], h, src, dst)

    def _plain_udp(self, b: bytes, off: int) -> bool:
        """A whole, well-formed UDP datagram (the checks of decode_ipv4 and decode_udp) on no PNIO port whose
        payload cannot be connectionless DCE/RPC: what the path through _udp returns "not_profinet" for, without
        building its header dicts (an IT network's SNMP, mDNS, NetBIOS on the PROFINET segment)."""
        n = len(b) - off
        if n < 28:
            return False
        ihl = (b[off] & 0x0F) * 4
        total = (b[off + 2] << 8) | b[off + 3]
        if b[off] >> 4 != 4 or ihl < 20 or total < ihl or total > n or (b[off + 6] & 0x3F) or b[off + 7]:
            return False
        u, end = off + ihl, off + total
        if end - u < 8:
            return False
        length = (b[u + 4] << 8) | b[u + 5]
        if length < 8 or u + length > end:
            return False
        ports = self.rt_ports
        sp, dp = (b[u] << 8) | b[u + 1], (b[u + 2] << 8) | b[u + 3]
        if sp in ports or dp in ports or sp == PORT_RPC or dp == PORT_RPC:
            return False
        return length - 8 < dcerpc.HDR_LEN or b[u + 8] != 4

    def _ip_fragment(self, fn, ts, data, h, src, dst) -> str:
        if h["proto"] != ip.PROTO_UDP:
            return "not_profinet"
        key = (h["src"], h["dst"], h["proto"], h["id"])
        if h["frag_offset"] == 0:  # the first fragment shows the UDP ports and the RPC header
            p, e = h["payload_off"], h["payload_end"]
            ports = (data[p] << 8 | data[p + 1], data[p + 2] << 8 | data[p + 3]) if e - p >= 4 else ()
            pn = bool(set(ports) & (self.rt_ports | {PORT_RPC})) or self._looks_pnio(data, p + 8, e)
            self.ip_datagrams[key] = pn
            if len(self.ip_datagrams) > 4 * self.ipr.max_datagrams:
                self.ip_datagrams.pop(next(iter(self.ip_datagrams)))
            if not pn:
                return "not_profinet"
        elif self.ip_datagrams.get(key) is False:
            return "not_profinet"
        self.counts["ip_fragments"] += 1
        whole = self.ipr.add(fn, ts, h, data)
        self.a.emit({"frame": fn, "ts_ns": ts, "kind": "ip_fragment", "src": src, "dst": dst,
                     "ip": _ipf(h), "complete": whole is not None,
                     "frames": list(self.ipr.last_frames) if whole is not None else None})
        self._report_dropped(self.ipr.expire(ts), "ip")
        if whole is None:
            return "decoded"
        self.ip_datagrams.pop(key, None)
        hh = dict(h, payload_off=0, payload_end=len(whole), len=len(whole) + h["hdr_len"])
        st = self._udp(fn, ts, whole, 0, len(whole), hh, src, dst)
        return "decoded" if st == "not_profinet" else st

    def _pn_ports(self, b: bytes, p: int) -> bool:
        """UDP ports at b[p:] (an option-less IPv4 header assumed) are PNIO's."""
        if len(b) - p < 4:
            return False
        ports = {(b[p] << 8) | b[p + 1], (b[p + 2] << 8) | b[p + 3]}
        return bool(ports & (self.rt_ports | {PORT_RPC}))

    @staticmethod
    def _looks_pnio(b: bytes, p: int, e: int) -> bool:
        if e - p < dcerpc.HDR_LEN or b[p] != 4 or b[p + 1] > 10:
            return False
        try:
            return dcerpc.get_uuid(b, p + 24, "little" if b[p + 4] & 0x10 else "big") in INTERFACES
        except Exception:  # noqa: BLE001 - a guess on a partial datagram only
            return False

    def _udp(self, fn, ts, data, off, end, h, src, dst) -> str:
        u = ip.decode_udp(data, off, end)
        sp, dp = u["srcport"], u["dstport"]
        po, pe = u["payload_off"], u["payload_end"]
        if dp in self.rt_ports or sp in self.rt_ports:
            return self.a.pn_rt(fn, ts, data, po, src, dst, None, udp=True, end=pe)
        on_rpc_port = PORT_RPC in (sp, dp)
        if pe - po < dcerpc.HDR_LEN or data[po] != 4:
            if on_rpc_port and pe - po > 0:
                raise Malformed("dcerpc", f"UDP {sp}->{dp}: {pe - po} bytes are no connectionless DCE/RPC PDU")
            return "not_profinet"
        try:
            hdr = dcerpc.decode_header(data, po, pe)
        except Malformed:
            if on_rpc_port:
                raise
            return "not_profinet"
        iface = INTERFACES.get(hdr["dg_if_id"])
        if iface is None and not (on_rpc_port and hdr["dg_if_id"] == EPM_UUID):
            return "not_profinet"
        self._rpc(fn, ts, data, hdr, h, u, src, dst, iface or "EPM")
        return "decoded"

    # ---------------------------------------------------------------- DCE/RPC
    def _rpc(self, fn, ts, data, hdr, h, u, src, dst, iface) -> None:
        self.counts["rpc"] += 1
        ptype = hdr["pkt_type"]
        dc = {k: v for k, v in hdr.items() if k not in ("body_off", "body_end", "byte_order", "server_boot")}
        ev = {"frame": fn, "ts_ns": ts, "kind": "rpc", "src": src, "dst": dst,
              "src_ip": h["src"], "dst_ip": h["dst"], "ip": _ipf(h), "udp": _udpf(u),
              "dcerpc": dc, "interface": iface, "packet_type": hdr["pkt_type_name"],
              "opnum": hdr["opnum"], "operation": pnio_cm.OPNUMS.get(hdr["opnum"]) if iface != "EPM" else None}
        if ptype == dcerpc.FACK:
            dc.update(dcerpc.decode_fack(data, hdr["body_off"], hdr["body_end"], hdr["byte_order"]))
        key = (hdr["dg_act_id"], hdr["dg_seqnum"])
        conv = (h["src"], u["srcport"], h["dst"], u["dstport"])
        if ptype == dcerpc.RESPONSE:
            req = self.calls.get(key)
            if req is not None and req["opnum"] == hdr["opnum"]:
                ev["request_frame"] = req["frame"]
                ev["request_ts_ns"] = req["ts"]
                # tshark pairs only inside one UDP conversation (ports swapped): packet-dcerpc.c
                if req["conv"] == (conv[2], conv[3], conv[0], conv[1]):
                    dc["request_in"] = req["frame"]
                    dc["time"] = f"{(ts - req['ts']) / 1e9:.9f}"
        stub = None
        if hdr["dg_flags1"] & dcerpc.F1_FRAG:
            self.counts["rpc_fragments"] += 1
            copy = self.rpcr.completed(hdr, ts)   # a resend of a completed call's fragment (tshark: "reas: #N")
            got = None if copy else self.rpcr.add(fn, ts, hdr, data)
            ev["fragment"] = {"num": hdr["dg_frag_num"], "last": bool(hdr["dg_flags1"] & dcerpc.F1_LAST),
                              "complete": got is not None}
            if copy:
                ev["fragment"]["resent"] = True
                self.counts["rpc_fragments_resent"] = self.counts.get("rpc_fragments_resent", 0) + 1
            self._report_dropped(self.rpcr.expire(ts), "dcerpc")
            if got is not None:
                stub, frames = got
                ev["fragment"]["frames"] = frames
        else:
            stub = data[hdr["body_off"]:hdr["body_end"]]
        # a request counts from the frame that completes it (tshark's request_in does the same)
        if ptype == dcerpc.REQUEST and stub is not None and key not in self.calls:
            self.calls[key] = {"frame": fn, "ts": ts, "opnum": hdr["opnum"], "conv": conv, "pdu": None,
                               "src": src, "dst": dst, "obj_id": hdr.get("obj_id")}
        if stub is None or iface == "EPM" or ptype not in (dcerpc.REQUEST, dcerpc.RESPONSE) or not stub:
            self.a.emit(ev)
            return
        try:
            pdu = pnio_cm.decode_stub(stub, hdr["byte_order"], ptype == dcerpc.REQUEST, hdr["opnum"])
        except Malformed:
            self.a.emit(ev)  # the header was fine: keep it, then report the stub
            raise
        ev["pnio"] = pdu
        if "status" in pdu:
            ev["pnio_status"] = pdu["status"]
        self.a.emit(ev)
        self._cm(fn, ts, ev, pdu, key, src, dst)

    def _report_dropped(self, dropped, layer) -> None:
        """One malformed event per dropped reassembly; its frames, counted as decoded when they came,
        move to the malformed bucket, so the accounting agrees with the events (issue #18 item 5)."""
        counts = getattr(self.a, "counts", None)
        for frames, reason in dropped:
            total = getattr(frames, "total", len(frames))
            last = getattr(frames, "last", None) or frames[-1]
            if counts is not None:
                counts["decoded"] -= total
                counts["malformed"] += total
            self.counts["reassembly_dropped_frames"] = self.counts.get("reassembly_dropped_frames", 0) + total
            self.a.add_malformed(last, self.a.cur_ts, layer,
                              f"{reason}; frames ({total}): "
                              f"{', '.join(map(str, frames[:20]))}"
                              + (f" ... {last}" if total > 20 else ""))

    def _expire(self, ts) -> None:
        if self.ipr.pending:
            self._report_dropped(self.ipr.expire(ts), "ip")
        if self.rpcr.pending:
            self._report_dropped(self.rpcr.expire(ts), "dcerpc")


def _ipf(h: dict) -> dict:
    return {k: v for k, v in h.items() if k not in ("payload_off", "payload_end")}


def _udpf(u: dict) -> dict:
    return {k: v for k, v in u.items() if k not in ("payload_off", "payload_end")}
