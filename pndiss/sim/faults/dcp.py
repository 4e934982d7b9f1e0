"""DCP faults: the controller sends one more DCP Set after the start-up's own (session.py
``dcp_extra``): an invalid NameOfStation, or a name / IP address another encoder holds."""
from __future__ import annotations

from ..scenarios import Injection
from .base import register


class _DcpSet(Injection):
    """Set ``what`` ("name" or "ip") of station ``station`` to ``value``; None: encoder-1's own."""

    what = "name"
    station = 0
    value = None

    def setup(self, sess, sc, params):
        if len(sess.stations) < self.encoders:
            raise ValueError(f"{self.rule} needs --encoders 2 or more")
        value = self.value
        if value is None:
            first = sess.stations[0]
            value = first.name.encode() if self.what == "name" else first.ip
        sc.dcp_extra.append((self.what, self.station, value, {self.tag}))


register(_DcpSet, "DCP-NAME-INVALID", value=b"Encoder_1!",
         why="the controller sends DCP Set NameOfStation 'Encoder_1!' (invalid characters); the device refuses")
register(_DcpSet, "DCP-NAME-DUPLICATE", station=1, encoders=2,
         why="the controller assigns encoder-1's name to encoder-2 as well (needs --encoders 2)")
register(_DcpSet, "IP-ASSIGN-OCCUPIED", what="ip", station=1, encoders=2,
         why="the controller assigns encoder-1's IP address to encoder-2 (needs --encoders 2)")
