"""Cyclic tracker placeholder: telegram decoding and the reference encoder land here."""
from __future__ import annotations


class CyclicTracker:
    def __init__(self, analyzer):
        self.a = analyzer

    def on_frame(self, rt_event: dict, pdu: bytes, csdu_off: int) -> None:
        """Called for every cyclic PN-RT frame after its ``rt`` event was emitted.
        C_SDU = pdu[csdu_off:len(pdu)-4]."""

    def finish(self) -> None:
        pass

    def summary(self) -> dict:
        return {}
