"""Capture loss: cycles a cyclic stream sent that the capture does not hold (issue #12).

A mirror port or a busy capture PC drops frames; the protocol did not. Each cyclic PN-RT frame
carries the provider's CycleCounter (u16, unit 31.25 us) that advances by SendClockFactor x
ReductionRatio per frame (wire.md §2.3), so between two captured frames of one (FrameID, src, dst)
stream round(delta / step) - 1 cycles are missing. The step comes from the Connect's IOCR when the
stream is mapped, else it is learnt from the stream itself (the smallest advance seen). A stream
whose counter does not advance in multiples of its step (a provider with a free-running counter)
is marked non-uniform and judged without gap detection. The two directions of an AR have their own
counters (RT: independent clocks), so each stream is followed on its own.

The opposite of loss: a mirror port that sees a frame on two ports captures it twice, sometimes a
cycle or more late (its queue holds the copy behind other traffic). A consumer takes a frame only when
its CycleCounter is newer than the last one it took: (now - last) mod 2^16 in 1..61440 (PROFINET IO
2.4 §4.7.2.1.2, as the p-net device stack checks it); a frame with the same or an up to 4,095 units
older counter is discarded. So is it here (``duplicate``): no cycle, only counted -- as a copy when
it repeats the stream's previous frame (same CycleCounter, DataStatus and C_SDU), else as stale.
"""
from __future__ import annotations

from math import gcd

from .proto.eth import NO_DST
from .readinfo import JUMP_NS

WRAP = 0x10000
UNIT_NS = 31250              # CycleCounter unit, 31.25 us (wire.md §2.3)
HALF_WRAP_NS = WRAP * UNIT_NS // 2
LEARN = 4            # advances seen before a learnt step is trusted
IRREGULAR_MAX = 3    # advances off the step before the stream counts as non-uniform
MAX_EVENTS = 1000    # gaps kept for the summary/report (events carry all of them)
NEWER_MAX = 61440    # the consumer's cycle-counter check: (now - last) mod 2^16 in 1..61440 is a newer frame


class Stream:
    __slots__ = ("cc", "frame", "ts", "last", "step", "known", "seen", "irregular", "uniform", "gaps", "missing", "said")

    def __init__(self):
        self.cc = None
        self.frame = None
        self.ts = None
        self.last = None      # (DataStatus, C_SDU) of the last captured frame (what a copy repeats)
        self.step = 0         # counter units per cycle; 0 = not known yet
        self.known = False    # step from the Connect (not learnt)
        self.seen = 0         # advances of exactly one step since the step last changed
        self.irregular = 0
        self.uniform = True
        self.gaps = 0
        self.missing = 0
        self.said = None      # (step, from the Connect) the latest gap was counted in (the summary's, after a restart)


TS_ERROR_NS = 20_000_000   # how far a time stamp may be off: coarse capture clocks (15.6 ms), a TAP's port batches


def with_counter(k: int, d: int, step: int) -> int | None:
    """The cycles lost in a pause the time stamps say is ``k`` cycles, made to agree with the counter's advance ``d``
    (k + 1 steps are d modulo a wrap): the nearest such count within 200 ppm (two clocks' drift) or TS_ERROR_NS
    (time stamps that are off), else None -- the counter contradicts the time stamps. Past some minutes of pause the
    window holds a whole wrap and a step cannot be told from a loss: counted as a loss."""
    tol = max(2, k // 5000, TS_ERROR_NS // (step * UNIT_NS))
    for delta in range(tol + 1):
        for kk in (k - delta, k + delta):
            if kk >= 0 and ((kk + 1) * step - d) % WRAP == 0:
                return kk
    return None


class GapTracker:
    """Per cyclic stream: the counter of its last captured frame; says how many cycles a new frame skipped."""

    def __init__(self, enabled: bool = True, table: dict | None = None):
        self.enabled = enabled
        # key -> Stream; the analyzer passes a bounded table (a flood of random source MACs, issue #18)
        self.streams: dict = {} if table is None else table
        self.rows: list[dict] = []
        self.count = 0
        self.missing = 0
        self.prev = None      # the stream's previous captured frame, set by advance()
        self.duplicates = 0   # copies of frames (``duplicate``)
        self.first_duplicate = None   # (frame, the frame it copies)
        self.stale = 0        # other frames whose counter is not newer (``duplicate``)
        # per MAC of a stream with a gap, the time of the frame that ended its latest gap (what else the capture
        # may have lost): a device's parameter request asks about its own streams (the engine walks those up to
        # the request; every other stream may be ahead or behind)
        self.last_by_mac: dict = {}
        self.first_stale = None       # (frame, the frame it is not newer than)
        # pauses of half a counter wrap or more that the counter contradicts (it went on by what no whole number of
        # wraps fits): the capture's clock stepped (NTP on the capture PC), no frame was lost there
        self.clock_steps = 0
        self.clock_step_first = None  # (frame, the stream's frame before it, ns the time jumped)
        # () -> the capture reader's ReadInfo (CyclicTracker sets it): its forward time jumps and the capture tool's
        # own loss reports are losses the streams' counters cannot show
        self.reader_of = lambda: None

    def step_from(self, key, step: int | None) -> None:
        """The stream's cycle step from its IOCR (SendClockFactor x ReductionRatio), when the Connect says it."""
        st = self.streams.get(key)
        if st is None:
            st = self.streams[key] = Stream()
        if step and 0 < step < WRAP and (st.step == 0 or not (st.known or st.irregular)):
            # the Connect says it (a step learnt from a clean counter gives way; one the counter contradicted
            # stays: a free-running counter is not made uniform again by every map change). An earlier AR's
            # step on the same frame ID was forgotten when it ended (restart): a project downloaded with another
            # cycle time reconnects on the same IDs
            if st.step != step:
                st.seen = 0
            st.step, st.known = step, True

    def restart(self, key) -> None:
        """The stream's AR ended (Release / abort, or connects again): its counter starts afresh with the next AR,
        the pause between them is not capture loss, and its step is the next Connect's (or learnt again)."""
        st = self.streams.get(key)
        if st is not None:
            st.cc = st.frame = st.ts = st.last = None
            st.step, st.known, st.seen, st.irregular, st.uniform = 0, False, 0, 0, True

    def duplicate(self, key, fn: int, ts: int, cc: int, last: tuple) -> bool:
        """Frame ``fn`` is one a consumer discards: its counter is not newer than the stream's previous captured
        frame's (the cycle-counter check, NEWER_MAX), which came less than half a counter wrap (1.024 s)
        before. A copy when it repeats that frame's ``last`` (DataStatus, C_SDU) and counter, else stale
        (a late copy of an earlier frame, or a provider repeating its counter). Counted here."""
        st = self.streams.get(key)
        if st is None or st.cc is None or st.ts is None or ts - st.ts >= HALF_WRAP_NS:
            return False
        d = (cc - st.cc) % WRAP
        if 1 <= d <= NEWER_MAX or (d and key[2] == NO_DST):
            return False   # (a cooked capture's stream key has no destination: two ARs' streams may share it)
        if d == 0 and st.last == last:
            self.duplicates += 1
            if self.first_duplicate is None or fn < self.first_duplicate[0]:  # the engine visits streams in bulk
                self.first_duplicate = (fn, st.frame)
        else:
            self.stale += 1
            if self.first_stale is None or fn < self.first_stale[0]:
                self.first_stale = (fn, st.frame)
        return True

    def advance(self, key, fn: int, ts: int, cc: int, last: tuple | None = None) -> int:
        """Cycles missing between the stream's previous captured frame (then in ``self.prev``) and this one:
        0 when none, or when it cannot be told (step not confirmed yet, counter not uniform). ``last``:
        the frame's (DataStatus, C_SDU), which a copy of it would repeat."""
        st = self.streams.get(key)
        if st is None:
            st = self.streams[key] = Stream()
        prev, pts = st.cc, st.ts
        self.prev = st.frame
        st.cc, st.frame, st.ts, st.last = cc, fn, ts, last
        if prev is None or not self.enabled:
            return 0
        d = (cc - prev) % WRAP
        if pts is not None and ts - pts >= HALF_WRAP_NS and st.uniform and (st.known or st.seen >= LEARN):
            # the counter may have wrapped during the gap (every 2.048 s): the time stamps tell the cycles --
            # also for an advance of exactly one step (a loss of k x 2.048 s): no provider pauses a second
            # without its consumer's watchdog ending the AR (the engine asks the same, pndiss/streamcols.py)
            period = st.step * UNIT_NS
            k0 = (ts - pts + period // 2) // period - 1
            k = with_counter(k0, d, st.step)
            # an advance of exactly one step across a jump of the whole capture's time that the time stamps miss by
            # more than their error: a clock step too, however long (an hour's step fits some count within the drift
            # allowed; a real loss lands a counter exactly one step on once in 2,048, and then the times agree)
            if (k is None or (d == st.step and abs(k - k0) > max(2, TS_ERROR_NS // period))) \
                    and self._clock_jump(pts, ts, period):
                # the time stamps jumped by what the counter's advance contradicts, and so did the whole capture's
                # time between two frames: the capture's clock stepped; the counter says what was lost (usually
                # nothing) -- not "seen in the cycle counter" cycles
                self._clock_step(fn, ts - pts)
            else:
                k = k0 if k is None else k   # (a counter restarted in the pause, a device rebooting: the time)
                if k > 0:
                    self._lost_at(key, ts)
                    return self._count(st, k)
        elif pts is not None and ts - pts >= JUMP_NS and st.step and st.uniform and (st.known or st.seen >= LEARN) \
                and d % st.step == 0 and ts - pts - (d // st.step) * st.step * UNIT_NS > TS_ERROR_NS + 2 * st.step * UNIT_NS \
                and self._clock_jump(pts, ts, st.step * UNIT_NS):
            # a shorter step (under half a wrap, so the counter's advance is unambiguous): the time stamps say far
            # longer than the counter, and the whole capture's time jumped there -- named too (an independent audit:
            # a 1 s step left every later time 1 s off without a word); the counter says what was lost, as below.
            # Only a counter on its own step: an irregular advance across a real outage says nothing (a review)
            self._clock_step(fn, ts - pts)
        if d == 0:
            return 0              # a repeated counter: no new cycle, nothing to say
        if st.step == 0:
            st.step = d
            return 0
        if d % st.step:
            # off the step: a smaller true step (the first advance already skipped cycles) or a counter
            # that does not advance uniformly; a step is trusted only once seen LEARN times exactly
            st.irregular += 1
            st.step = gcd(st.step, d)
            st.seen = 0
            st.known = False
            if st.irregular >= IRREGULAR_MAX:
                st.uniform = False
            return 0
        if d == st.step:
            st.seen += 1
            if st.seen >= LEARN:
                st.irregular = 0   # confirmed: an AR restart now and then does not make it non-uniform
            return 0
        if not st.uniform or (not st.known and st.seen < LEARN):
            if st.irregular and not st.known:
                st.irregular += 1  # a step shrunk by an odd advance and never seen exactly: a free-running counter
                if st.irregular >= IRREGULAR_MAX:
                    st.uniform = False
            return 0
        self._lost_at(key, ts)
        return self._count(st, d // st.step - 1)

    def _lost_at(self, key, ts: int) -> None:
        for mac in key[1:]:
            old = self.last_by_mac.get(mac)
            if old is None or ts > old:
                self.last_by_mac[mac] = ts

    def _clock_jump(self, pts: int, ts: int, period: int) -> bool:
        """The capture's time itself jumped inside this stream's pause (no frame of any stream there): a clock step,
        not a silent device (others' frames go on through a reboot)."""
        need = ts - pts - TS_ERROR_NS - 2 * period
        return any(pts <= a and b <= ts and b - a >= need for a, b in getattr(self.reader_of(), "jumps", ()))

    def last_gap(self, mac: str):
        """When a stream to or from ``mac`` last showed capture loss, or the capture tool last said it lost packets
        (pcapng epb_dropcount: ReadInfo.last_drop_ts) -- None: never."""
        own, tool = self.last_by_mac.get(mac), getattr(self.reader_of(), "last_drop_ts", None)
        return own if tool is None else tool if own is None else max(own, tool)

    def _clock_step(self, fn: int, jump_ns: int) -> None:
        self.clock_steps += 1
        if self.clock_step_first is None or fn < self.clock_step_first[0]:
            self.clock_step_first = (fn, self.prev, jump_ns)

    def _count(self, st: Stream, k: int) -> int:
        st.said = (st.step, st.known)
        st.gaps += 1
        st.missing += k
        self.count += 1
        self.missing += k
        return k

    def keep(self, row: dict) -> None:
        """A gap for the summary: the first MAX_EVENTS in frame order are kept (the engine may find them
        stream by stream within a stretch of the capture, not in frame order)."""
        self.rows.append(row)
        if len(self.rows) >= 2 * MAX_EVENTS:
            self.rows.sort(key=lambda r: r["next_frame"])
            del self.rows[MAX_EVENTS:]

    def kept(self) -> list[dict]:
        return sorted(self.rows, key=lambda r: r["next_frame"])[:MAX_EVENTS]

    def period_ns(self, key) -> int | None:
        """The stream's cycle in ns (its counter step), when known and uniform."""
        st = self.streams.get(key)
        return st.step * UNIT_NS if st is not None and st.step and st.uniform else None

    def confirmed_period_ns(self, key) -> int | None:
        """The stream's cycle in ns once its step is the Connect's or was seen LEARN times (uniform counter)."""
        st = self.streams.get(key)
        if st is None or not st.step or not st.uniform or not (st.known or st.seen >= LEARN):
            return None
        return st.step * UNIT_NS

    def same_step(self, a, b) -> bool:
        """Both streams advance by one confirmed step per cycle (a setpoint and an actual stream of one
        AR at one reduction ratio): each actual value then has its own setpoint."""
        sa, sb = self.streams.get(a), self.streams.get(b)
        return (sa is not None and sb is not None and sa.step == sb.step and sa.uniform and sb.uniform
                and (sa.known or sa.seen >= LEARN) and (sb.known or sb.seen >= LEARN))

    def faster(self, a, b) -> bool:
        """Stream a runs at a confirmed smaller step than stream b (an output CR at a smaller reduction ratio
        than the input CR): several setpoints per actual value, the device acting on the latest."""
        sa, sb = self.streams.get(a), self.streams.get(b)
        return (sa is not None and sb is not None and 0 < sa.step < sb.step and sa.uniform and sb.uniform
                and (sa.known or sa.seen >= LEARN) and (sb.known or sb.seen >= LEARN))

    def summary(self) -> dict:
        streams = []
        for key, st in self.streams.items():
            if st.gaps or not st.uniform:
                # the step its gaps were counted in (an AR's end starts the next one afresh at 0: an audit)
                step, known = st.said or (st.step, st.known)
                streams.append({"frame_id": key[0], "src": key[1], "dst": key[2], "gaps": st.gaps,
                                "cycles_missing": st.missing, "step": step,
                                "step_source": "connect" if known else "learnt",
                                "uniform": st.uniform})
        return {"count": self.count, "cycles_missing": self.missing, "streams": streams,
                "checked": self.enabled, "gaps": self.kept(), "duplicates": self.duplicates,
                "first_duplicate": list(self.first_duplicate) if self.first_duplicate else None,
                "stale": self.stale, "first_stale": list(self.first_stale) if self.first_stale else None,
                "clock_steps": self.clock_steps,
                "first_clock_step": list(self.clock_step_first) if self.clock_step_first else None}
