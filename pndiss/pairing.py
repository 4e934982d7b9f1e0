"""One group of cyclic streams within a segment (pndiss/engine.py): counted, or paired and judged.

A group is what the reference path's state ties together: an encoder axis' setpoint and actual
streams (cyclic.py pairs them), the two streams of a device with several encoders (every axis has a
data object in both: its frames go one by one, in capture order), or a stream alone (an IO device's,
an unmapped one). Groups share no state inside a segment, so each is walked on its own.

An axis walk works on *pairs*. From a clean state (the last setpoint paired, nothing pending) the
reference pairs the next two frames of the axis whenever one is a setpoint and one an actual value,
in either order: setpoint first (judged at the actual), or -- RT clocks drift -- actual first (it
waits, cyclic.py ``pend``, and is judged when its setpoint comes). A run of such pairs is applied at
once when the arrays prove the reference would only advance: the cycle counters moved by one step
(no capture loss), DataStatus / IOPS / AR phase gate every pair the same way, the control/status
key stayed, the inputs changed (no identical-input shortcut), and no value rule can fire
(``Checker.vector_unsafe``, the rules' vectorised twins). Everything else -- the pair where any of
that fails, two setpoints or two actual values in a row, sign-of-life monitoring, telegrams that
carry a preset -- goes frame by frame through ``CyclicTracker.on_cyclic``.
"""
from __future__ import annotations

import numpy as np

from .axiswalk import AxisWalk
from .streamcols import BLOCK, RETRY_MAX, Cols


class Group:
    __slots__ = ("kind", "streams", "pos", "fr", "ax")

    def __init__(self, kind, streams, pos, fr=None, ax=None):
        self.kind = kind        # "count" (unmapped / no telegram), "sample" (unmapped, content inference samples
        #                         it: counted, and its C_SDUs offered), "axis" (one setpoint + one actual), "single"
        self.streams = streams  # fast._Stream per member
        self.pos = pos          # window frame indexes per member (sorted)
        self.fr = fr            # _Frame per member (None: unmapped)
        self.ax = ax

    @staticmethod
    def build(w, i: int, j: int, cats) -> list:
        """The groups of segment [i, j) of window w. Streams whose data objects share an axis are one group:
        a device with several encoders sends all their setpoints in one frame and all their actual values
        in another, and the reference pairs them in capture order across both streams."""
        out = []
        of_axis: dict = {}    # axis key (_Obj.key) -> its group
        keys: dict = {}       # id(group) -> the axis keys in it
        for k, c in cats.items():
            p = w.pos[k]
            a, b = np.searchsorted(p, (i, j))
            if a == b:
                continue
            p = p[a:b]
            s = w.ss[k]
            fr = c[1]
            if fr is None or not fr.objs:
                out.append(Group("sample" if c[0] == "sample" else "count", [s], [p], [fr]))
                continue
            mine = {o.key for o in fr.objs}
            met = {id(of_axis[x]): of_axis[x] for x in mine if x in of_axis}
            if met:
                g, *others = met.values()
                for h in others:   # this stream joins groups so far apart: one group
                    g.streams += h.streams
                    g.pos += h.pos
                    g.fr += h.fr
                    mine |= keys.pop(id(h))
                    out.remove(h)
                mine |= keys[id(g)]
            else:
                g = Group("axis", [], [], [])
                out.append(g)
            keys[id(g)] = mine
            for x in mine:
                of_axis[x] = g
            g.streams.append(s)
            g.pos.append(p)
            g.fr.append(fr)
        for g in out:
            if g.kind != "axis":
                continue
            axes = {id(o.ax): o.ax for fr in g.fr for o in fr.objs}
            one = len(g.fr) == 2 and g.fr[0].direction != g.fr[1].direction and len(axes) == 1 \
                and all(len(fr.objs) == 1 for fr in g.fr)
            g.ax = next(iter(axes.values())) if one else None
            if g.ax is None:   # several data objects, an axis not created yet, or one direction only: one by one
                g.kind = "single"
        return out


    def part(self, i: int, j: int) -> "Group":
        """The same group with its members' frames in window range [i, j) only (members without any dropped, as
        build() does: an axis with one direction left goes one by one)."""
        keep = [(s, p[np.searchsorted(p, i):np.searchsorted(p, j)], fr)
                for s, p, fr in zip(self.streams, self.pos, self.fr)]
        keep = [m for m in keep if len(m[1])]
        kind = "single" if self.kind == "axis" and len(keep) < len(self.streams) else self.kind
        return Group(kind, [m[0] for m in keep], [m[1] for m in keep], [m[2] for m in keep], self.ax)

    def device(self):
        """The device MAC of a mapped group (its frame maps'); None for an unmapped stream."""
        for fr in self.fr:
            if fr is not None and fr.fm.device_mac:
                return fr.fm.device_mac
        return None


def walker(w, g: Group):
    """The walk of one group: ``run(stop)`` takes its frames before window index ``stop`` (None: all of them),
    and may be called again for the next stretch (a device's record exchange between, pndiss/engine.py)."""
    if not g.streams:
        return SinglesWalk(w, g)
    if g.kind in ("count", "sample"):
        return CountWalk(w, g)
    if g.kind == "axis":
        return AxisWalk(w, g)
    return SinglesWalk(w, g)


class SinglesWalk:
    """Members' frames one by one in capture order (merged)."""

    def __init__(self, w, g: Group):
        self.w = w
        if not g.pos:
            self.idx, self.who = np.zeros(0, dtype=np.int64), None
        elif len(g.pos) == 1:
            self.idx, self.who = g.pos[0], None
        else:
            idx = np.concatenate(g.pos)
            who = np.concatenate([np.full(len(p), k) for k, p in enumerate(g.pos)])
            o = np.argsort(idx, kind="stable")
            self.idx, self.who = idx[o], who[o]
        self.streams = g.streams
        self.q = 0

    def run(self, stop) -> None:
        end = len(self.idx) if stop is None else int(np.searchsorted(self.idx, stop))
        single, streams = self.w.single, self.streams
        for q in range(self.q, end):
            single(int(self.idx[q]), streams[0 if self.who is None else int(self.who[q])])
        self.q = max(self.q, end)


def _offer(w, s, idx) -> None:
    """C_SDUs of an unmapped stream's frames to content inference, as CyclicTracker.on_cyclic offers each
    (the engine's segment ends before the frame that would complete the samples: none does here)."""
    offer = w.e.t.infer.offer
    for i in idx.tolist():
        data = w.frame(i)
        off = 18 if data[12] == 0x81 else 14
        offer(s.key, w.fn(i), data[off + 2:len(data) - 4], int(w.ts[i]), data[-2])


class CountWalk:
    """A stream without encoder data: frame counts and the gap tracker; a frame the tracker must look at
    (a counter that is not one step on, a length change) goes the reference way."""

    def __init__(self, w, g: Group):
        self.w, self.g = w, g
        self.c = Cols(w, g.streams[0], g.pos[0])
        self.r = self.fails = 0

    def run(self, stop) -> None:
        p = self.g.pos[0]
        n = len(p) if stop is None else int(np.searchsorted(p, stop))
        if self.r < n:
            self.r, self.fails = _walk_count(self.w, self.g, self.c, self.r, n, self.fails)


def _walk_count(w, g: Group, c, r: int, n: int, fails: int) -> tuple[int, int]:
    """Rows [r, n) of the stream's columns ``c``; returns (the row reached, the backoff's failures)."""
    t = w.e.t
    s, p, fr = g.streams[0], g.pos[0], g.fr[0]
    while r < n:
        e = min(n, r + BLOCK)
        bad = c.gaps_bad(t.gaps, r, e) | c.capbad[r:e]
        if bad.any():
            e = r + int(np.argmax(bad))
        if e > r:
            cnt = e - r
            s.n += cnt
            c.bulk_gaps(t.gaps, r, e)
            if w.e.col is not None and w.e.col.str:
                c.bulk_frames(w.e.col, r, e)
            if g.kind == "sample":
                _offer(w, s, p[r:e])
            if fr is None:
                t.count_unmapped(s.key, cnt)
                t.misses[s.key] = t.misses.get(s.key, 0) + cnt
            else:
                t.no_telegram += cnt
            w.e.frames_bulk += cnt
            r = e
            fails = 0
            continue
        # one by one for a while (backoff): a stream whose counter the tracker cannot follow costs no mask per frame
        fails += 1
        k = min(n, r + min(RETRY_MAX, 1 << min(fails - 1, 6)))
        for i in p[r:k]:
            w.single(int(i), s)
        r = k
    return r, fails
