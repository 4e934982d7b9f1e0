"""Timeline picture of a capture: position and speed per encoder, status bits as lanes,
violation markers with rule IDs (docs/mcap.md, "Timeline").

``Timeline`` is an event sink with bounded memory: each numeric series keeps at most
``max_points`` samples (when full it drops every other one and halves its sampling rate), bit
lanes keep only their transitions. ``render_png`` needs matplotlib (``pip install pndiss[plot]``);
``render_html`` writes a self-contained page with an inline SVG and needs nothing.
"""
from __future__ import annotations

import html

from .textsafe import mathtext, visible

# Signal names that carry position / speed, first match wins (telegram tables, cyclic.md §2:
# G1_XIST1 = position; NIST_A 16-bit / NIST_B 32-bit speed).
# Matched without regard to case (the telegram decoder names them in lower case).
POSITION_SIGNALS = ("g1_xist1", "xist1", "g1_xist2", "position")
SPEED_SIGNALS = ("nist_b", "nist_a", "speed", "velocity")
MAX_LANES = 16
MAX_TRANSITIONS = 5000
MAX_MARKERS = 300
SEV_COLOURS = {"error": "#d62728", "warning": "#ff7f0e", "info": "#1f77b4"}


class Series:
    """Bounded (t, value) samples: every ``stride``-th sample, stride doubling when full."""
    __slots__ = ("t", "v", "stride", "n", "max")

    def __init__(self, max_points: int):
        self.t: list[int] = []
        self.v: list[float] = []
        self.stride, self.n, self.max = 1, 0, max_points

    def add(self, t: int, v) -> None:
        self.n += 1
        if (self.n - 1) % self.stride:
            return
        self.t.append(t)
        self.v.append(v)
        if len(self.t) >= self.max:
            del self.t[1::2], self.v[1::2]
            self.stride *= 2


class Lane:
    """One bit over time, as its transitions: [(t, value)], first entry = first sample."""
    __slots__ = ("changes", "last", "truncated")

    def __init__(self):
        self.changes: list[tuple[int, int]] = []
        self.last = None
        self.truncated = False

    def add(self, t: int, v: int) -> None:
        if v != self.last:
            self.last = v
            if len(self.changes) < MAX_TRANSITIONS:
                self.changes.append((t, v))
            else:
                self.truncated = True


class Encoder:
    def __init__(self, label: str, max_points: int):
        self.label = label
        self.position = Series(max_points)
        self.speed = Series(max_points)
        self.position_name = self.speed_name = None
        self.lanes: dict[str, Lane] = {}


def _flat_bits(bits: dict, prefix: str = ""):
    """(name, 0/1) pairs of a bits dict, nested dicts flattened with '.'."""
    for k, v in bits.items():
        name = f"{prefix}{k}"
        if isinstance(v, dict):
            yield from _flat_bits(v, name + ".")
        elif isinstance(v, (bool, int)):
            yield name, v


def _pick(sig: dict, wanted) -> str | None:
    """Key of ``sig`` that is the first of ``wanted`` (any case) with a numeric value."""
    low = {str(k).lower(): k for k in sig}
    for n in wanted:
        k = low.get(n)
        if k is not None and _num(sig[k]) is not None:
            return k
    return None


def _num(v):
    return v if isinstance(v, (int, float)) and not isinstance(v, bool) and v == v else None


class Timeline:
    def __init__(self, max_points: int = 4000):
        self.max_points = max_points
        self.encoders: dict[tuple, Encoder] = {}
        self.violations: list[tuple[int, str, str]] = []  # (t, rule, severity), first MAX_MARKERS
        self.violation_count = 0
        self.first_ts: int | None = None   # earliest event
        self.last_ts: int | None = None
        self.t0: int | None = None         # first telegram sample
        self.start: int | None = None      # the capture's first frame (the caller sets it): the time axis starts there
        self._multi: set[str] = set()      # multi-bit fields (sign-of-life): no lane

    def on_event(self, ev: dict) -> None:
        ts = ev.get("ts_ns")
        if not isinstance(ts, int):
            return
        if self.first_ts is None or ts < self.first_ts:
            self.first_ts = ts
        if self.last_ts is None or ts > self.last_ts:
            self.last_ts = ts
        kind = ev.get("kind")
        if kind == "telegram":
            self._telegram(ev, ts)
        elif kind == "violation":
            self.violation_count += 1
            if len(self.violations) < MAX_MARKERS:
                self.violations.append((ts, str(ev.get("rule", "?")), str(ev.get("severity", "error"))))

    def _telegram(self, ev: dict, ts: int) -> None:
        if self.t0 is None:
            self.t0 = ts
        key = (str(ev.get("device_mac")), str(ev.get("slot")), str(ev.get("subslot")))
        enc = self.encoders.get(key)
        if enc is None:
            st = ev.get("station") if isinstance(ev.get("station"), str) else None
            tg = ev.get("telegram")
            enc = self.encoders[key] = Encoder(
                f"{st or key[0]} {key[1]}.{key[2]}" + (f" tg{tg}" if tg is not None else ""), self.max_points)
        setpoint = str(ev.get("direction", "")).lower() in ("setpoint", "output", "out", "o", "controller")
        sig = ev.get("signals")
        if isinstance(sig, dict) and not setpoint:
            if enc.position_name is None:
                enc.position_name = _pick(sig, POSITION_SIGNALS)
            if enc.speed_name is None:
                enc.speed_name = _pick(sig, SPEED_SIGNALS)
            if enc.position_name is not None and _num(sig.get(enc.position_name)) is not None:
                enc.position.add(ts, sig[enc.position_name])
            if enc.speed_name is not None and _num(sig.get(enc.speed_name)) is not None:
                enc.speed.add(ts, sig[enc.speed_name])
        bits = ev.get("bits")
        if isinstance(bits, dict):
            side = "ctrl" if setpoint else "enc"
            for name, v in _flat_bits(bits):
                name = f"{side} {name}"
                if v is not True and v is not False and v != 0 and v != 1:
                    if name not in self._multi:   # a multi-bit field (the sign-of-life): no lane on any axis
                        self._multi.add(name)
                        for other in self.encoders.values():
                            other.lanes.pop(name, None)
                    continue
                lane = enc.lanes.get(name)
                if lane is None:
                    if name in self._multi:
                        continue
                    lane = enc.lanes[name] = Lane()
                lane.add(ts, 1 if v else 0)

    def shown_lanes(self, enc: Encoder) -> list[tuple[str, Lane]]:
        """Lanes worth a row: the bits that ever changed (else the first few), at most MAX_LANES."""
        moving = [(n, l) for n, l in enc.lanes.items() if len(l.changes) > 1]
        return (moving or list(enc.lanes.items())[:4])[:MAX_LANES]

    def origin(self) -> int:
        """Time 0 of the axis: the capture's first frame (the time `--time` and `--window` count from), else the first
        telegram sample (an independent audit: a time read off the plot was 4.7 ms off the --time value)."""
        if self.start is not None:
            return self.start
        return self.t0 if self.t0 is not None else (self.first_ts or 0)

    def sec(self, t: int) -> float:
        return (t - self.origin()) / 1e9


def _window_ns(tl: Timeline, window) -> tuple[int, int]:
    """(first, last) ns shown: ``window`` = (start s, end s) on the plot's axis, or everything."""
    if window is None:
        lo = min([tl.origin()] + [t for t, _, _ in tl.violations])
        return lo, max(tl.last_ts or lo, lo + 1)
    lo, hi = (tl.origin() + int(w * 1e9) for w in window)
    return lo, max(hi, lo + 1)


def _series_in(s: Series, lo: int, hi: int) -> tuple[list, list]:
    ts, vs = [], []
    for t, v in zip(s.t, s.v):
        if lo <= t <= hi:
            ts.append(t)
            vs.append(v)
    return ts, vs


def _lane_in(lane: Lane, lo: int, hi: int) -> list[tuple[int, int]]:
    """Transitions inside [lo, hi], starting with the value the lane has at ``lo``."""
    out, cur = [], None
    for t, v in lane.changes:
        if t <= lo:
            cur = v
        elif t <= hi:
            out.append((t, v))
    if cur is not None:
        out.insert(0, (lo, cur))
    return out


# -- PNG (matplotlib) ---------------------------------------------------------------------------
class PlotUnavailable(Exception):
    pass


def render_png(tl: Timeline, path: str, title: str = "", window=None) -> None:
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
    except ImportError:
        raise PlotUnavailable("PNG output needs matplotlib: pip install 'pndiss[plot]' "
                              "(or write .html, which needs nothing)") from None
    encs = list(tl.encoders.values())
    rows = []  # (kind, encoder)
    for e in encs:
        rows.append(("motion", e))
        if tl.shown_lanes(e):
            rows.append(("lanes", e))
    if not rows:
        rows.append(("empty", None))
    heights = [1.0 if k != "lanes" else max(0.6, 0.28 * len(tl.shown_lanes(e))) for k, e in rows]
    fig, axes = plt.subplots(len(rows), 1, sharex=True, squeeze=False,
                             figsize=(11, 1.2 + 2.2 * sum(heights)), gridspec_kw={"height_ratios": heights})
    axes = [a[0] for a in axes]
    lo_t, hi_t = _window_ns(tl, window)
    end = tl.sec(hi_t)
    for ax, (kind, e) in zip(axes, rows):
        if kind == "motion":
            ts, vs = _series_in(e.position, lo_t, hi_t)
            if ts:
                ax.plot([tl.sec(t) for t in ts], vs, color="#1f77b4", lw=1.2,
                        drawstyle="steps-post", label=e.position_name)
            ax.set_ylabel(mathtext(e.position_name or "position"), color="#1f77b4", fontsize=8)
            ax.text(0.005, 0.97, mathtext(e.label), transform=ax.transAxes, fontsize=9, va="top", weight="bold",
                    bbox={"facecolor": "white", "alpha": 0.8, "edgecolor": "none"})
            ts, vs = _series_in(e.speed, lo_t, hi_t)
            if ts:
                ax2 = ax.twinx()
                ax2.plot([tl.sec(t) for t in ts], vs, color="#2ca02c", lw=1.0, label=e.speed_name)
                ax2.set_ylabel(mathtext(e.speed_name), color="#2ca02c", fontsize=8)
                ax2.tick_params(labelsize=7)
        elif kind == "lanes":
            lanes = tl.shown_lanes(e)
            for i, (name, lane) in enumerate(lanes):
                y0 = len(lanes) - 1 - i
                ch = _lane_in(lane, lo_t, hi_t) or [(lo_t, lane.changes[0][1])]
                xs = [tl.sec(t) for t, _ in ch] + [end]
                ys = [y0 + 0.7 * v for _, v in ch]
                ys.append(ys[-1])
                ax.step(xs, ys, where="post", lw=1.1, color="#444")
                ax.fill_between(xs, y0, ys, step="post", alpha=0.25, color="#9467bd")
            ax.set_yticks([len(lanes) - 1 - i + 0.35 for i in range(len(lanes))])
            ax.set_yticklabels([mathtext(n) for n, _ in lanes], fontsize=7)
            ax.set_ylim(-0.2, len(lanes))
        else:
            ax.text(0.5, 0.5, "no telegram samples in this capture", ha="center", va="center",
                    transform=ax.transAxes, color="#666")
            ax.set_yticks([])
        ax.tick_params(labelsize=7)
        ax.grid(True, axis="x", alpha=0.3)
        for t, rule, sev in tl.violations:
            if lo_t <= t <= hi_t:
                ax.axvline(tl.sec(t), color=SEV_COLOURS.get(sev, "#d62728"), lw=0.9, alpha=0.8)
        if window is not None:
            ax.set_xlim(tl.sec(lo_t), end)
    # one label per cluster of markers (its distinct rule IDs), at most 60 labels: legible
    gap = (end - tl.sec(lo_t)) / 60
    clusters: list[list] = []
    for t, rule, sev in sorted(v for v in tl.violations if lo_t <= v[0] <= hi_t):
        xs = tl.sec(t)
        if clusters and xs - clusters[-1][0] < gap:
            if rule not in clusters[-1][1]:
                clusters[-1][1].append(rule)
        else:
            clusters.append([xs, [rule], sev])
    for xs, rules, sev in clusters[:60]:
        text = ", ".join(rules[:3]) + (f" +{len(rules) - 3}" if len(rules) > 3 else "")
        axes[0].annotate(mathtext(text), (xs, 1.0), xycoords=("data", "axes fraction"), rotation=60,
                         fontsize=6, color=SEV_COLOURS.get(sev, "#d62728"), va="bottom")
    axes[-1].set_xlabel("time since the first frame [s]" if tl.start is not None or tl.t0 is None
                        else "time since the first cyclic sample [s]")
    v = f"{tl.violation_count} violation(s)" if tl.violation_count else "no violations"
    fig.suptitle(f"{mathtext(title)}  —  {v}" if title else v, fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


# -- HTML (inline SVG, no dependencies, no network) ------------------------------------------------
def render_html(tl: Timeline, path: str, title: str = "", window=None) -> None:
    W, LEFT, RIGHT = 1100, 170, 20
    lo_t, hi_t = _window_ns(tl, window)
    span = hi_t - lo_t
    x = lambda t: LEFT + (t - lo_t) * (W - LEFT - RIGHT) / span  # noqa: E731
    parts, y = [], 30
    esc = lambda s: html.escape(visible(s, None))  # noqa: E731  wire strings: inert and visible

    def line(s: Series, y0, h, colour):
        ts, vs = _series_in(s, lo_t, hi_t)
        if not ts:
            return
        lo, hi = min(vs), max(vs)
        sc = h / (hi - lo) if hi > lo else 0
        pts = []
        for t, v in zip(ts, vs):
            pts.append(f"{x(t):.1f},{y0 + h - (v - lo) * sc:.1f}")
        parts.append(f'<polyline fill="none" stroke="{colour}" stroke-width="1.2" points="{" ".join(pts)}"/>')
        parts.append(f'<text x="{LEFT - 6}" y="{y0 + 8}" class="ax" fill="{colour}">{hi:g}</text>'
                     f'<text x="{LEFT - 6}" y="{y0 + h}" class="ax" fill="{colour}">{lo:g}</text>')

    for e in tl.encoders.values():
        parts.append(f'<text x="4" y="{y}" class="h">{esc(e.label)}</text>')
        y += 8
        if e.position.t:
            line(e.position, y, 90, "#1f77b4")
            parts.append(f'<text x="4" y="{y + 40}" fill="#1f77b4">{esc(e.position_name)}</text>')
        if e.speed.t:
            line(e.speed, y + 100, 60, "#2ca02c")
            parts.append(f'<text x="4" y="{y + 130}" fill="#2ca02c">{esc(e.speed_name)}</text>')
        y += 170
        for name, lane in tl.shown_lanes(e):
            pts, prev = [], None
            for t, v in _lane_in(lane, lo_t, hi_t) or [(lo_t, lane.changes[0][1])]:
                yy = y + 14 - 12 * v
                if prev is not None:
                    pts.append(f"{x(t):.1f},{prev:.1f}")
                pts.append(f"{x(t):.1f},{yy:.1f}")
                prev = yy
            pts.append(f"{W - RIGHT},{prev:.1f}")
            parts.append(f'<text x="4" y="{y + 12}">{esc(name)}</text>'
                         f'<polyline fill="none" stroke="#444" points="{" ".join(pts)}"/>')
            y += 20
        y += 20
    if not tl.encoders:
        parts.append(f'<text x="{LEFT}" y="{y + 20}">no telegram samples in this capture</text>')
        y += 40
    for t, rule, sev in tl.violations:
        if not lo_t <= t <= hi_t:
            continue
        c = SEV_COLOURS.get(sev, "#d62728")
        parts.append(f'<line x1="{x(t):.1f}" y1="14" x2="{x(t):.1f}" y2="{y}" stroke="{c}">'
                     f'<title>{esc(rule)} ({esc(sev)}) at {tl.sec(t):.6f} s</title></line>'
                     f'<text x="{x(t) + 2:.1f}" y="12" fill="{c}" style="font-size:9px">{esc(rule)}</text>')
    parts.append(f'<text x="{LEFT}" y="{y + 14}" class="ax">{tl.sec(lo_t):.3f} s</text>'
                 f'<text x="{W - RIGHT}" y="{y + 14}" class="ax" text-anchor="end">{tl.sec(lo_t + span):.3f} s</text>')
    v = f"{tl.violation_count} violation(s)" if tl.violation_count else "no violations"
    doc = (f"<!DOCTYPE html><html><head><meta charset='utf-8'><title>{esc(title)} timeline</title>"
           "<style>body{font-family:sans-serif}svg text{font-size:11px}.h{font-weight:bold}"
           ".ax{font-size:9px;text-anchor:end}</style></head><body>"
           f"<h3>{esc(title)} — {v}</h3>"
           f'<svg xmlns="http://www.w3.org/2000/svg" width="{W}" height="{y + 24}">{"".join(parts)}</svg>'
           "</body></html>\n")
    with open(path, "w", encoding="utf-8") as f:
        f.write(doc)
