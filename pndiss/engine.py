"""The engine: a window of the capture demultiplexed into streams, steady cyclic data judged per axis.

Real traffic has no repeating frame order (devices at 1/2/4 ms, drifting clocks, jitter, IO devices,
capture loss), so nothing here looks for one. For each window the reader offers (pndiss/capture.py,
``batch=``):

1. pndiss/frameindex.py finds every record (offset, length, time stamp) with NumPy;
2. each frame's 16/20-byte prefix (MACs, VLAN tag, EtherType, FrameID) is hashed; the distinct
   prefixes are looked up once in the fast path's stream table, so every frame gets a stream id
   (-1: no known cyclic stream);
3. frames that are no known cyclic stream -- RPC, DCP, LLDP, alarms, PTCP, a stream's first frame,
   an unmapped stream's periodic re-lookup, streams still sampled by content inference -- are
   *global*: they go through the analyzer one by one, in capture order, exactly as pndiss/fast.py
   does. They split the window into segments;
4. within a segment the cyclic streams are independent groups (an encoder axis: its setpoint and
   actual streams; an IO device's or an unmapped stream: alone). pndiss/pairing.py walks each
   group: stretches where the reference encoder provably does nothing but advance are applied at
   once, every other frame goes through ``CyclicTracker.on_cyclic`` -- the reference code, so no
   rule is written twice. Events of those frames are held and released in processing order at the
   segment's end, so the event stream is the reference path's.

Order, drift, jitter, the number of devices, cycle times and capture gaps change which frames go
one by one (few), not the speed. tests/test_engine.py compares it with the reference path.
"""
from __future__ import annotations

import numpy as np

from . import frameindex
from .cyclic import RELOOKUP_EVERY
from .pairing import Group, walker
from .proto.common import Malformed
from .proto.rt import judgeable
from .readinfo import JUMP_NS
from .session_rpc import PORT_RPC

ETH_PNRT = 0x8892
K2 = np.uint64(0x9E3779B97F4A7C15)
K3 = np.uint64(0xC2B2AE3D27D4EB4F)
SMALL = 48          # fewer frames between two global ones go one by one
MAX_NEW = 512       # cyclic prefixes of no known stream in one window beyond which the engine declines it
MIN_FRAMES = 8          # a window with fewer indexed frames is left to the reader
_MISSING = object()


class Engine:
    def __init__(self, a, streams: dict, feed_one, progress=None, collector=None):
        self.a = a
        self.t = a.cyclic
        self.streams = streams      # fast.run's prefix -> _Stream
        self.feed_one = feed_one    # fast.run's per-frame step: (fn, ts, lt, data) -> None
        self.progress = progress
        self.col = collector        # pndiss/batches.py: column batches for sinks of cycles / frames (or None)
        self.last_fn = 0
        self.last_ts = None
        self.hashes = np.empty(0, dtype=np.uint64)   # sorted prefix hashes of earlier windows (Window._sid)
        self.frames_bulk = 0        # diagnostics (bench/NOTES.md)
        self.frames_single = 0
        self.frames_global = 0
        self.frames_inert = 0       # counted in bulk (Window._segment)

    # -- reader interface (pndiss/capture.py) ------------------------------------------------------
    def pcapng(self, bo: str, ifaces: list):
        nif = len(ifaces)
        BIG = 1 << 62

        def fits(i) -> bool:
            """Ethernet (an FCS the engine cuts as the reader does: capture.record_converter), and time stamps the plain
            multiply keeps in int64 (else the reader takes them)."""
            return i[0] == 1 and 0 < i[3] < BIG and -BIG < i[2] < BIG and i[5] >= 0

        ok = [fits(i) for i in ifaces]
        fcs = np.array([i[7] if k else 0 for i, k in zip(ifaces, ok)], dtype=np.int64)   # (Ethernet's conversion)
        cut_fcs = bool(fcs.any())
        lts = np.array([1 if k else 0 for k in ok], dtype=np.int64)
        mult = np.array([i[3] if k else 0 for i, k in zip(ifaces, ok)], dtype=np.int64)
        off = np.array([i[2] if k else 0 for i, k in zip(ifaces, ok)], dtype=np.int64)
        lim = np.array([min(i[5], (1 << 63) - 1) if k else -1 for i, k in zip(ifaces, ok)], dtype=np.int64)

        span = [1 << 62]   # bytes indexed per call: smaller while windows end early (frames the reader takes)

        def take(buf, pos, end, n):
            stop = min(end, pos + span[0])
            ix = frameindex.pcapng(buf, pos, stop, bo, nif)
            m = len(ix)
            if m < MIN_FRAMES:
                if stop < end:   # the span held too few frames: the whole window next time
                    span[0] = 1 << 62
                    return take(buf, pos, end, n)
                return 1
            # frames the reader must take itself: not Ethernet, a time stamp it would clamp (and count), or cut by
            # the snap length (a cyclic frame's APDU status is its last 4 bytes on the wire: analyzer._pn_rt)
            raw = ix.raw_ts
            li = lim[ix.ifid]   # -1: every time stamp of the interface is checked (clamped) by the reader
            good = (lts[ix.ifid] == 1) & (li >= 0) & (raw <= np.maximum(li, 0).astype(np.uint64)) \
                & (ix.cap == ix.orig)
            if not good.all():
                m = int(np.argmin(good))
                # runs of frames the window takes between frames the reader must take (a cooked interface beside
                # Ethernet ones): index about what is taken, not the whole window again each time (quadratic)
                span[0] = max(1 << 12, 2 * int(ix.block[m]) - 2 * pos) if m < len(ix) else 1 << 62
                if m < MIN_FRAMES:   # the reader takes every frame up to the next run the window can take
                    return _to_next_run(good)   # at once: not one re-index per frame (cooked, FCS, mixed NICs)
            else:
                span[0] = 1 << 62
            ifid = ix.ifid[:m]
            ts = raw[:m].astype(np.int64) * mult[ifid] + off[ifid]
            cap, orig = ix.cap[:m], ix.orig[:m]
            pf = ix.fcs[:m] if ix.fcs is not None else None
            if cut_fcs or (pf is not None and pf.any()):
                # an FCS interface (a TAP's port beside plain NICs), or a packet's own FCS length (epb_flags, over the
                # interface's): the frame without its FCS, as read (pcapng_read.epb_options)
                f = fcs[ifid] if pf is None else np.where(pf > 0, pf, fcs[ifid])
                f = np.where(cap > f, f, 0)
                cap, orig = cap - f, orig - f
            return self._window(buf, n, ix.data[:m], cap, ts, ix.end if m == len(ix) else int(ix.block[m]), orig)
        return take

    def pcap(self, bo: str, linktype: int, mult: int, conv=None):
        def take(buf, pos, end, n):
            if linktype != 1 or conv:
                return 1 << 20
            ix = frameindex.pcap(buf, pos, end, bo)
            if len(ix) < MIN_FRAMES:
                return 1
            m = len(ix)
            whole = ix.cap == ix.orig   # a frame the snap length cut: the reader takes it (as pcapng above)
            if not whole.all():
                m = int(np.argmin(whole))
                if m < MIN_FRAMES:
                    return _to_next_run(whole)
            raw = ix.raw_ts[:m]
            ts = (raw >> np.uint64(32)).astype(np.int64) * 1_000_000_000 + \
                (raw & np.uint64(0xFFFFFFFF)).astype(np.int64) * mult
            return self._window(buf, n, ix.data[:m], ix.cap[:m], ts, ix.end if m == len(ix) else int(ix.block[m]),
                                ix.orig[:m])
        return take

    # -- one window --------------------------------------------------------------------------------
    def _window(self, buf, n: int, data, cap, ts, stop: int, orig):
        w = Window(self, buf, n, data, cap, ts)
        if w.unknown > MAX_NEW:
            # thousands of prefixes no stream has yet (a flood of random MACs, not a plant): learning them
            # window by window would cost O(frames) per new stream; the frame-by-frame path takes them
            return len(data)
        ro = self.a.reader   # time order, as fast.run keeps it frame by frame
        for i in np.flatnonzero(cap < orig).tolist():   # frames the capture cut (snap length), as the readers count
            ro.cut(n + 1 + i, int(cap[i]), int(orig[i]))
        back = np.empty_like(ts)
        back[0] = ro.last_ts - ts[0]
        np.subtract(ts[:-1], ts[1:], out=back[1:])
        if back.max() > 0:
            hit = np.flatnonzero(back > 0)
            ro.backwards(n + int(hit[0]) + 1, len(hit), int(back.max()))
        if back.min() <= -JUMP_NS:   # forward jumps of the capture's time (ReadInfo.order does the same per frame)
            for i in np.flatnonzero(back <= -JUMP_NS).tolist():
                before = ro.last_ts if i == 0 else int(ts[i - 1])
                if before:
                    ro.jumps.append((before, int(ts[i])))
        w.run()
        m = len(data)
        if self.col is not None:
            self.col.flush(n + m)
        self.last_fn = n + m
        self.last_ts = ro.last_ts = int(ts[-1])
        if self.progress is not None and (self.last_fn >> 12) != (n >> 12):
            self.progress(self.last_fn & ~0xFFF)
        return stop, n + m


def _to_next_run(good) -> int:
    """Frames before the first run of MIN_FRAMES frames the engine can take (all of them when there is none)."""
    if len(good) < MIN_FRAMES:
        return len(good)
    full = np.convolve(good.astype(np.int32), np.ones(MIN_FRAMES, dtype=np.int32), "valid") == MIN_FRAMES
    hit = np.flatnonzero(full)
    return max(1, int(hit[0])) if hit.size else len(good)


HASHES_MAX = 4096   # prefix hashes remembered across windows (a plant's streams; a flood starts afresh)


def _uniq(a):
    """np.unique(a) without its np.ma.is_masked check, which imports numpy.ma (~30 ms of every run's start)."""
    a = np.sort(a, axis=None)
    if len(a) < 2:
        return a
    keep = np.empty(len(a), dtype=bool)
    keep[0] = True
    np.not_equal(a[1:], a[:-1], out=keep[1:])
    return a[keep]


def _distinct(h, eng):
    """np.unique(h, return_index=True, return_inverse=True), except that ``first`` names any frame of each
    value (a representative: every use only needs one). When every value is one an earlier window had -- a
    capture's streams go on -- it is a lookup in the engine's sorted table, not a sort of the window."""
    kh = eng.hashes
    if len(kh):
        pos = np.searchsorted(kh, h)
        np.minimum(pos, len(kh) - 1, out=pos)
        if (kh[pos] == h).all():
            rep = np.empty(len(kh), dtype=np.int64)
            rep[pos] = np.arange(len(h))
            present = np.zeros(len(kh), dtype=bool)
            present[pos] = True
            idx = np.flatnonzero(present)
            remap = np.empty(len(kh), dtype=np.int64)
            remap[idx] = np.arange(len(idx))
            return kh[idx], rep[idx], remap[pos]
    uh, first, inv = np.unique(h, return_index=True, return_inverse=True)
    merged = _uniq(np.concatenate((kh, uh)))
    eng.hashes = merged if len(merged) <= HASHES_MAX else uh
    return uh, first, inv


class Window:
    """The frames of one window: stream ids, and the walk over segments and global frames."""

    def __init__(self, eng: Engine, buf, n: int, data, cap, ts):
        self.e = eng
        self.buf = buf
        self.u8 = np.frombuffer(buf, dtype=np.uint8)
        self.n = n                  # frame number before the window's first frame
        self.data = data
        self.cap = cap
        self.ts = ts
        self.m = len(data)
        self._sid()

    def _sid(self) -> None:
        """Per frame the index of its known cyclic stream in self.ss (-1: a global frame): the 16-byte
        prefix (20 with an 802.1Q tag) hashed per frame, each distinct one looked up once."""
        d, cap = self.data, self.cap
        m = self.m
        big = cap >= 24
        dd = np.where(big, d, 0)
        if not (dd & 3).any():   # pcapng: packet data is 4-byte aligned, the prefix is 5 words
            W = np.frombuffer(self.buf, dtype="<u4", count=len(self.buf) >> 2)
            dw = dd >> 2
            w = [W[dw + k] for k in range(5)]
        else:
            P = self.u8[dd[:, None] + np.arange(20)]
            w = [P[:, 4 * k:4 * k + 4].copy().view("<u4").reshape(m) for k in range(5)]
        w3 = w[3] & 0xFFFF                    # bytes 12, 13 (little-endian view)
        tagged = w3 == 0x0081                 # 802.1Q TPID 0x8100
        cand = big & ((w3 == 0x9288) | (tagged & ((w[4] & 0xFFFF) == 0x9288)))   # EtherType 0x8892
        w4 = np.where(tagged, w[4], 0)
        # frames no cyclic stream's judgement depends on (pndiss.engine: they do not end a segment): PTCP and
        # DCP FrameIDs, LLDP, MRP, non-PROFINET EtherTypes other than IPv4 (RPC), IPv4 that cannot be PNIO
        # (_ip_kinds); 2 = DCP / LLDP, which name stations (a capture gap of an unmapped stream is named from
        # them: then they end a segment)
        et = np.where(tagged, w[4] & 0xFFFF, w3)                      # byte-swapped EtherType (inside one tag)
        fid_w = np.where(tagged, w[4] >> 16, w[3] >> 16)              # byte-swapped FrameID
        fid = ((fid_w & 0xFF) << 8) | (fid_w >> 8)
        pn = et == 0x9288
        ptcp = pn & ((fid < 0x0100) | ((fid >= 0xFF00) & (fid < 0xFF80)))
        dcp = pn & (fid >= 0xFEFC) & (fid <= 0xFEFF)
        lldp = et == 0xCC88
        # (a second 802.1Q tag, or an outer QinQ TPID 0x88A8 / 0x9100 the decoder peels: looked at one by one)
        other = ~pn & ~lldp & (et != 0x0008) & (et != 0x0081) & (w3 != 0xA888) & (w3 != 0x0091)
        self._ip = big & (et == 0x0008)
        self._rt_ports = set(self.e.a.session.rt_ports)
        alarm = pn & ((fid == 0xFC01) | (fid == 0xFE01))
        # 4 = inert: Analyzer.feed only counts it as not PROFINET (no decoder, no state): counted in bulk (_segment)
        inert = other & (et != 0xE388) & (et != 0xA888) & (et != 0x0091)   # (an inner QinQ TPID is peeled too)
        self._kind0 = np.where(big & inert, 4, np.where(big & (ptcp | other | (et == 0xE388)), 1,
                               np.where(big & (dcp | lldp), 2, np.where(big & alarm, 3, 0)))).astype(np.int8)
        self.tagged = tagged
        self.nkind = self._kinds()
        h = (w[0].astype(np.uint64) | (w[1].astype(np.uint64) << np.uint64(32))) * K2
        h ^= (w[2].astype(np.uint64) | (w[3].astype(np.uint64) << np.uint64(32))) * K3
        h ^= w4.astype(np.uint64)
        h = np.where(cand, h, np.uint64(0))
        uh, first, inv = _distinct(h, self.e)
        same = (w[0] == w[0][first][inv]) & (w[1] == w[1][first][inv]) & (w[2] == w[2][first][inv]) \
            & (w[3] == w[3][first][inv]) & (w4 == w4[first][inv])
        if not (same | ~cand).all():
            cand = np.zeros(m, dtype=bool)   # a hash collision: every frame the careful way
        self.ss = []
        self.uid_sid = np.full(len(uh), -1, dtype=np.int64)
        self.first, self.inv, self.cand, self.tagged = first, inv, cand, tagged
        self.known = -1
        self._resolve()
        self.unknown = int(np.count_nonzero(cand[first] & (self.uid_sid < 0)))

    def _kinds(self):
        """nkind with the IPv4 frames that cannot be PNIO made neutral, DCE/RPC ones local (_ip_kinds, with the RT_CLASS_UDP ports the
        session knows now: a Connect may add one, then run() asks again)."""
        kind = self._kind0.copy()
        ii = np.flatnonzero(self._ip)
        if len(ii):
            neutral, local, inert = self._ip_kinds(ii)
            kind[ii[neutral]] = 1
            kind[ii[inert]] = 4
            kind[ii[local]] = 3
        return kind

    def _ip_kinds(self, ii):
        """Of the IPv4 frames ``ii``: those no PNIO layer takes (session_rpc: TCP, ICMP, UDP that is neither
        RT_CLASS_UDP nor connectionless DCE/RPC, version 4), so no cyclic judgement depends on them. An IT
        network's SNMP polls, OPC UA or HTTP on the PROFINET segment then no longer end a segment (an independent
        audit: 0.8 % IPv4 frames made the engine slower than the reference path). Fragments stay global.
        Returns (neutral, local, inert): local = a whole UDP datagram that may be connectionless DCE/RPC; inert =
        not UDP (session_rpc.on_ipv4 counts it and looks no further, fragments too)."""
        u8 = self.u8
        d = self.data[ii].astype(np.int64)
        end = d + self.cap[ii]
        b = d + np.where(self.tagged[ii], 18, 14)
        fits = b + 20 <= end
        b = np.where(fits, b, 0)
        vihl = u8[b]
        ihl = (vihl & 0xF).astype(np.int64) * 4
        frag = ((u8[b + 6] & 0x3F) != 0) | (u8[b + 7] != 0)          # MF or a fragment offset
        udp = u8[b + 9] == 17
        l4 = b + ihl
        ok = fits & ((vihl >> 4) == 4) & (ihl >= 20) & ~frag
        uok = ok & udp & (l4 + 9 <= end)
        l4 = np.where(uok, l4, 0)
        sp = (u8[l4].astype(np.int64) << 8) | u8[l4 + 1]
        dp = (u8[l4 + 2].astype(np.int64) << 8) | u8[l4 + 3]
        ports = np.array(sorted(self._rt_ports | {PORT_RPC}), dtype=np.int64)
        rt = np.isin(sp, ports[ports != PORT_RPC]) | np.isin(dp, ports[ports != PORT_RPC])
        maybe = (u8[l4 + 8] == 4) | np.isin(sp, ports) | np.isin(dp, ports)
        # connectionless DCE/RPC other than Connect / Release (opnum 0 / 1, they change the AR maps every walk
        # reads): one device's records, parameters and controls -- local (_segment). The opnum is header bytes
        # 68-69, in the byte order drep byte 0 says (wire.md §5.1)
        hdr = uok & (l4 + 8 + 70 <= end)
        h = np.where(hdr, l4 + 8, 0)
        little = (u8[h + 4] & 0x10) != 0
        opnum = np.where(little, u8[h + 68].astype(np.int64) | (u8[h + 69].astype(np.int64) << 8),
                         (u8[h + 68].astype(np.int64) << 8) | u8[h + 69])
        rpc = hdr & (u8[h] == 4) & ~rt & (opnum > 1)
        return ok & np.where(udp, uok & ~maybe, True), rpc, fits & ~udp

    def _resolve(self) -> bool:
        """Look the window's distinct prefixes up in the stream table (again after it learnt streams)."""
        streams = self.e.streams
        if len(streams) == self.known:
            return False
        self.known = len(streams)
        get = streams.get
        changed = False
        for u in np.flatnonzero(self.uid_sid < 0).tolist():
            f = self.first[u]
            if not self.cand[f]:
                continue
            p = int(self.data[f])
            s = get(self.buf[p:p + (20 if self.tagged[f] else 16)], False)
            if s:
                self.uid_sid[u] = len(self.ss)
                self.ss.append(s)
                changed = True
        if changed or not hasattr(self, "sid"):
            self.sid = self.uid_sid[self.inv]
            self._split()
        return changed

    def _split(self) -> None:
        sid = self.sid
        # small integers: NumPy's stable sort is a radix sort (linear) for 16-bit keys
        order = np.argsort(sid.astype(np.int16) if len(self.ss) < 32000 else sid, kind="stable")
        counts = np.bincount(sid + 1, minlength=len(self.ss) + 1)
        bounds = np.concatenate(([0], np.cumsum(counts)))
        g = order[:counts[0]]                            # frames of no known stream, in order
        nk = self.nkind[g]
        self.glob = g[nk == 0]                           # ... that end a segment
        self.neutral = g[(nk == 1) | (nk == 2) | (nk == 4)]   # ... that do not (processed inside it, events held)
        self.local = g[nk == 3]                          # ... one device's (RPC, alarms): inside it, in order
        self.pos = [order[bounds[k + 1]:bounds[k + 2]] for k in range(len(self.ss))]

    def frame(self, i: int):
        p = int(self.data[i])
        return self.buf[p:p + int(self.cap[i])]

    def fn(self, i: int) -> int:
        return self.n + 1 + i

    # -- the walk --------------------------------------------------------------------------------
    def run(self) -> None:
        m = self.m
        i = 0
        one = self.e.feed_one
        while i < m:
            glob = self.glob
            gi = int(np.searchsorted(glob, i))
            j = int(glob[gi]) if gi < len(glob) else m
            if j - i < SMALL:
                # a few frames between two global ones (start-up): cheaper one by one than set up as columns
                for k in range(i, min(j + 1, m)):
                    one(self.fn(k), int(self.ts[k]), 1, self.frame(k))
                self.e.frames_global += min(j + 1, m) - i
                if len(self.e.streams) != self.known:
                    self._resolve()
                i = j + 1
                continue
            present = self._present(i, j)
            cats = self._categories(present, self.fn(i))
            stop = self._stream_stop(i, j, cats)
            if stop - i < SMALL:
                # the next frames must go on their own (streams not looked up since an AR's maps changed, at a
                # start-up): a stretch one by one, cheaper than a segment's set-up for each of them
                stop = min(j, i + SMALL)
                for k in range(i, stop):
                    one(self.fn(k), int(self.ts[k]), 1, self.frame(k))
                self.e.frames_global += stop - i
                if len(self.e.streams) != self.known:
                    self._resolve()
                i = stop
                continue
            j = stop
            a, b = np.searchsorted(self.neutral, (i, j))
            neutral = self.neutral[a:b]
            if len(neutral) and any(c is not None and (c[1] is None or c[1].fm.station is None) for c in cats.values()):
                # the capture gaps of a stream whose map names no station (unmapped, or inferred from the content)
                # are named from DCP / LLDP: those end the segment here
                named = neutral[self.nkind[neutral] == 2]
                if len(named):
                    j = int(named[0])
                    neutral = neutral[neutral < j]
            if j > i:
                a, b = np.searchsorted(self.local, (i, j))
                end = self._segment(i, j, cats, neutral, self.local[a:b])
                if end < j:   # a local frame relabelled a telegram: on from there (with fresh categories)
                    i = end
                    if len(self.e.streams) != self.known:
                        self._resolve()
                    continue
            if j < m:
                self._global(j)
                j += 1
                if len(self.e.a.session.rt_ports) != len(self._rt_ports):
                    # a Connect named an RT_CLASS_UDP port: IPv4 frames to it are cyclic data, no longer neutral
                    self._rt_ports = set(self.e.a.session.rt_ports)
                    self.nkind = self._kinds()
                    self._split()
                if len(self.e.streams) != self.known:
                    self._resolve()   # the frame taught the fast path a stream: its later frames are no longer global
            i = j

    def _categories(self, present, fn: int) -> dict:
        """Per stream present: None when its frames must go one by one in capture order (not looked up yet,
        the maps changed), ("sample", None) while content inference samples it (its frames in bulk, the one that
        completes the samples on its own), else ("ok", its _Frame or None: unmapped)
        -- decided on the tracker's state, which changes only at global frames."""
        t = self.e.t
        gen_ok = t.map_generation == self.e.a.session.map_generation
        out = {}
        for k in present:
            key = self.ss[k].key
            fr = t.frames.get(key, _MISSING) if gen_ok else _MISSING
            if fr is None and t.infer.sampling(key, fn):
                out[k] = ("sample", None)   # its frames are offered to content inference in bulk (_stream_stop)
            elif fr is _MISSING or (fr is None and t.infer.wants(key, fn)) or key in t.trim_to \
                    or key not in t.trailer_checked:
                # (a trailer after the APDU status: read where the Connect puts it, one by one; a stream whose frames
                # have not told yet whether they carry one -- no valid status at either place -- too)
                out[k] = None
            else:
                out[k] = ("ok", fr)
        return out

    def _present(self, i: int, j: int) -> list:
        """The known streams with a frame in [i, j), in stream order. From each stream's sorted frame
        indices, not np.unique over the range: a segment cut short (a stream waiting for content inference
        stops it at its resume frame) would otherwise pay for the whole rest of the window again -- unless the
        range is short against the number of streams (a plant's parameter reads every few dozen frames: one
        unique of those frames, not a search per stream)."""
        if j - i < 8 * len(self.pos):
            u = _uniq(self.sid[i:j])
            return u[u >= 0].tolist()
        out = []
        for k, p in enumerate(self.pos):
            a = int(np.searchsorted(p, i))
            if a < len(p) and p[a] < j:
                out.append(k)
        return out

    def _stream_stop(self, i: int, j: int, cats: dict) -> int:
        """The first frame in [i, j) that must be global: a stream of category None, an unmapped stream's
        periodic re-lookup when the session would now find its map, or the frame from which content
        inference samples an unmapped stream again (pndiss/infer.py)."""
        t = self.e.t
        for k, c in cats.items():
            if c is not None and c[0] == "sample":
                # the frame that completes its samples decides (an AR may be inferred): it goes on its own
                p = self.pos[k]
                a = int(np.searchsorted(p, i)) + t.infer.missing(self.ss[k].key) - 1
                if a < len(p) and p[a] < j:
                    j = int(p[a])
            elif c is not None and c[1] is None:
                again = t.infer.resumes_at(self.ss[k].key)
                if again is not None:
                    p = self.pos[k]
                    a = int(np.searchsorted(p, max(i, again - self.n - 1)))
                    if a < len(p) and p[a] < j:
                        j = int(p[a])
            if c is not None and (c[1] is not None or t.a.session.lookup(*self.ss[k].key) is None):
                continue
            p = self.pos[k]
            a = int(np.searchsorted(p, i))
            if c is None:
                j = min(j, int(p[a]))
                continue
            left = RELOOKUP_EVERY - t.misses.get(self.ss[k].key, 0) % RELOOKUP_EVERY
            if a + left - 1 < len(p) and p[a + left - 1] < j:
                j = int(p[a + left - 1])
        return j

    def _global(self, i: int) -> None:
        self.e.frames_global += 1
        self.e.feed_one(self.fn(i), int(self.ts[i]), 1, self.frame(i))

    def _segment(self, i: int, j: int, cats, neutral, local) -> int:
        """Frames [i, j): known streams, each in a settled category, frames no judgement depends on, and
        ``local`` frames (a DCE/RPC datagram other than Connect / Release, an alarm: one device's records,
        parameters, AR control). Each group is walked on its own; the groups of the device a local frame names
        are walked up to it, then it goes on its own, then their walks go on with fresh columns (its AR phase may
        have moved); every other group runs through it, as nothing of theirs depends on that device's frame.
        Events are held and released in frame order. Returns where the segment ended: before j when a local
        frame relabels a telegram (P922): its device's categories are stale, the segment ends after it. Connect
        and Release, which change the maps every walk reads, are global frames."""
        a = self.e.a
        groups = Group.build(self, i, j, cats)
        walks = [walker(self, g) for g in groups]
        end = j
        held = a.hold()
        one = self.e.feed_one
        todo, nxt = neutral.tolist(), [0]
        fed = np.flatnonzero(self.nkind[neutral] != 4).tolist()   # positions in todo of the frames fed one by one
        nfed = [0]

        def neutral_before(stop: int) -> None:
            """The neutral frames before ``stop`` not taken yet (only those before the segment's end: their
            events are released with its other events, in frame order); the inert ones between two others
            counted at once, the last of them becoming the analyzer's current frame as if fed."""
            k = nxt[0]
            f = nfed[0]
            while k < len(todo) and todo[k] < stop:
                p = fed[f] if f < len(fed) else len(todo)
                q = p if p < len(todo) and todo[p] < stop else int(np.searchsorted(neutral, stop))
                if q > k:   # inert frames k .. q-1
                    last = todo[q - 1]
                    a.count_inert(q - k, self.fn(last), int(self.ts[last]), int(self.ts[todo[k]]))
                    self.e.frames_inert += q - k
                    k = q
                    continue
                a.hold_at(self.fn(todo[k]))
                one(self.fn(todo[k]), int(self.ts[todo[k]]), 1, self.frame(todo[k]))
                self.e.frames_global += 1
                k += 1
                f += 1
            nxt[0], nfed[0] = k, f
        try:
            by_dev: dict = {}   # device MAC -> its groups
            for n, g in enumerate(groups):
                by_dev.setdefault(g.device(), []).append(n)
            by_dev.pop(None, None)   # unmapped streams: counted, offered to content inference, which a local frame
            #                          does not touch (a Connect, which it asks about, is a global frame)
            for L in local.tolist():
                neutral_before(L)
                macs = self._macs(L)
                touched = [n for mac in macs for n in by_dev.get(mac, ())]
                phases = []
                for n in touched:
                    walks[n].run(L)
                    phases.append([fr.fm.phase for fr in groups[n].fr if fr is not None])
                gen = a.session.map_generation
                a.hold_at(self.fn(L))
                self._global(L)
                if a.session.map_generation != gen:
                    # the device's maps changed (a P922 read relabels its telegram): its streams' categories are
                    # stale -- every group up to the frame, and the segment ends there (the next looks them up).
                    # (The other groups' frames before it now meet the new generation: the tracker compiles their
                    # unchanged layouts again -- caches only, #64 is once per data object; the review of 2026-11-25
                    # found no difference on 120 targeted and random sessions)
                    for wk in walks:
                        wk.run(L)
                    end = L + 1
                    break
                for n, ph in zip(touched, phases):
                    if [fr.fm.phase for fr in groups[n].fr if fr is not None] != ph:
                        # the device's AR moved (PrmEnd, ApplicationReady): its walk gates on the phase, afresh
                        groups[n] = groups[n].part(L + 1, j)
                        walks[n] = walker(self, groups[n])
            else:
                neutral_before(j)
                for wk in walks:
                    wk.run(None)
        finally:
            a.release(held)
        if self.e.col is not None:
            self.e.col.flush(self.fn(end - 1))
        return end

    def _macs(self, i: int) -> set:
        p = int(self.data[i])
        b = self.buf
        return {bytes(b[p + 6:p + 12]).hex(":"), bytes(b[p:p + 6]).hex(":")}

    def single(self, i: int, s) -> None:
        """Frame i of known stream s the frame-by-frame way (pndiss/fast.py)."""
        a = self.e.a
        self.e.frames_single += 1
        fn, ts = self.fn(i), int(self.ts[i])
        a.hold_at(fn)
        data = self.frame(i)
        s.n += 1
        try:
            off = 18 if data[12] == 0x81 else 14
            self.e.t.on_cyclic(s.key, fn, ts, judgeable(data[-2], data[-1]), data, off + 2)
        except Malformed as e:
            s.bad += 1
            a.add_malformed(fn, ts, e.layer, e.reason)
