"""Session tracker placeholder: IPv4/UDP/DCE-RPC/PNIO-CM and the AR map land here."""
from __future__ import annotations


class SessionTracker:
    def __init__(self, analyzer):
        self.a = analyzer

    def on_ipv4(self, fn, ts, data, off, src, dst) -> str:
        return "not_profinet"

    def lookup(self, frame_id: int, src: str, dst: str):
        """FrameMap (pndiss.armap) for a cyclic frame, or None."""
        return None

    def finish(self) -> None:
        pass

    def summary(self) -> dict:
        return {}
