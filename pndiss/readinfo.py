"""What the capture reader learns besides the frames (pndiss/capture.py): the input's digest, time stamps
it had to clamp, and frames earlier than the frame before them (counted by the drivers and the engine)."""
from __future__ import annotations

import hashlib
from collections import deque

JUMP_NS = 500_000_000   # a forward step of the capture's time worth remembering (gaps.py: half a wrap is 1.024 s)
CUT_KEPT = 1 << 16   # cut frames remembered for their malformed reasons: more than one engine window holds
TS_MAX = (1 << 63) - 1  # time stamps are clamped to [0, TS_MAX] ns: every sink (MCAP u64, datetime) shows them


class ReadInfo:
    """What the reader learnt besides the frames: the input's SHA-256 (hashed while streaming, so a
    FIFO is read once and a big file not twice; only when asked: ``digest``, ~0.8 s of CPU per GB), whether it
    was read to its end, and how many time stamps were out of the range every sink can show (clamped to
    [0, TS_MAX] ns)."""

    __slots__ = ("_h", "_known", "complete", "ts_clamped", "ts_clamped_first", "last_ts", "ts_back", "ts_back_max",
                 "ts_back_first", "cut_n", "cut_first", "cut_to", "_cut_at", "damaged", "tool_drops", "tool_drops_first",
                 "last_drop_ts", "_isb", "jumps")

    def __init__(self, known_sha256: str | None = None, digest: bool = True):
        # a digest the caller took already (pndiss fleet hashes every input to plan): not taken twice
        self._known = known_sha256
        self._h = hashlib.sha256() if digest and not known_sha256 else None
        self.complete = False
        self.ts_clamped = 0
        self.ts_clamped_first = None
        # frames earlier than the frame before them (the drivers and the engine keep last_ts): several
        # interfaces or files merged without sorting pair setpoints with the wrong actual values
        self.last_ts = 0
        self.ts_back = 0
        self.ts_back_max = 0
        self.ts_back_first = None
        # frames the capture cut (captured length < length on the wire: the snap length): what was cut off is
        # not there to decode; tshark 4.0 says "Packet size limited during capture"
        self.cut_n = 0
        self.cut_first = None
        self.cut_to = 0
        self._cut_at: dict = {}   # frame -> (captured, on the wire), the latest ones (malformed reasons)
        # files whose read ended early (pndiss/driver.py): cut short in the middle of a packet, or corrupt
        self.damaged: list[dict] = []
        # what the capture tool says it lost: per packet (pcapng epb_dropcount, a Packet Block's drops_count) and
        # per interface (Interface Statistics Blocks: isb_ifdrop + isb_osdrop, cumulative: the last one counts)
        self.tool_drops = 0
        self.tool_drops_first = None
        self.last_drop_ts = None   # time of the packet after the latest reported loss (parameter pairing forgets)
        self._isb: dict = {}
        # forward jumps of the capture's time between two frames in file order (t before, t after), at least
        # JUMP_NS: a stream's pause its cycle counter contradicts is a clock step only inside one (gaps.py)
        self.jumps = deque(maxlen=256)

    def sha256(self) -> str | None:
        """The digest of the whole input, '' when it was not read to its end, None when nobody asked for it."""
        if self._known:
            return self._known if self.complete else ""
        if self._h is None:
            return None
        return self._h.hexdigest() if self.complete else ""

    def feed(self, data) -> None:
        """The input's next bytes, in order (hashed unless the caller gave the digest)."""
        if self._h is not None:
            self._h.update(data)

    def clamp(self, fn: int, ts: int) -> int:
        self.ts_clamped += 1
        if self.ts_clamped_first is None:
            self.ts_clamped_first = fn
        return 0 if ts < 0 else TS_MAX

    def order(self, fn: int, ts: int) -> None:
        """A frame taken one by one, in file order (the engine counts its windows with backwards())."""
        if ts < self.last_ts:
            self.backwards(fn, 1, self.last_ts - ts)
        elif ts - self.last_ts >= JUMP_NS and self.last_ts:
            self.jumps.append((self.last_ts, ts))
        self.last_ts = ts

    def tool_dropped(self, fn: int, n: int, ts: int) -> None:
        """The capture tool lost ``n`` packets between frame ``fn`` and the one before it (it says so)."""
        self.tool_drops += n
        if self.tool_drops_first is None:
            self.tool_drops_first = fn
        self.last_drop_ts = ts

    def interface_dropped(self, key, n: int) -> None:
        """An Interface Statistics Block: ``n`` packets the interface and the OS dropped so far."""
        self._isb[key] = max(self._isb.get(key, 0), n)

    def backwards(self, fn: int, n: int, most: int) -> None:
        """``n`` frames from frame ``fn`` on went back in time, by at most ``most`` ns."""
        self.ts_back += n
        self.ts_back_max = max(self.ts_back_max, most)
        if self.ts_back_first is None or fn < self.ts_back_first:
            self.ts_back_first = fn

    def cut(self, fn: int, cap: int, orig: int) -> None:
        """Frame ``fn`` was captured with ``cap`` of its ``orig`` bytes (the readers, frame by frame: the engine
        leaves such frames to them, pndiss/frameindex.py)."""
        self.cut_n += 1
        if self.cut_first is None:
            self.cut_first = fn
        self.cut_to = max(self.cut_to, cap)
        self._cut_at[fn] = (cap, orig)
        if len(self._cut_at) > CUT_KEPT:
            self._cut_at.pop(next(iter(self._cut_at)))

    def damage(self, path: str, e, frames: int) -> None:
        """The read of ``path`` ended with CaptureError ``e``; every whole frame before it, up to frame ``frames``
        (a decompressor's error does not know the frame), was read."""
        self.damaged.append({"file": str(path), "after_frame": e.frames or frames,
                             "cut_short": bool(getattr(e, "cut_short", False)), "message": str(e)})

    def cut_of(self, fn: int):
        """(captured, on the wire) of a recent frame the capture cut, else None."""
        return self._cut_at.get(fn)

    def as_dict(self) -> dict:
        return {"timestamps_clamped": self.ts_clamped, "timestamps_clamped_first_frame": self.ts_clamped_first,
                "timestamps_backwards": self.ts_back, "timestamps_backwards_max_ns": self.ts_back_max,
                "timestamps_backwards_first_frame": self.ts_back_first,
                "frames_cut": self.cut_n, "frames_cut_first_frame": self.cut_first, "frames_cut_to_bytes": self.cut_to,
                "damaged": list(self.damaged), "tool_dropped": self.tool_drops,
                "tool_dropped_first_frame": self.tool_drops_first, "interface_dropped": sum(self._isb.values())}
