"""The AR map: which submodule's bytes sit where in which cyclic frame.

Built by the session tracker (``pndiss.session``) from Connect requests/responses, from a
user map (``--map``), a GSDML file or, last, data lengths; read by the cyclic decoder
(``pndiss.cyclic``). This module is only the shared data model, so both sides agree on it.
"""
from __future__ import annotations

from dataclasses import dataclass, field


NOT_OWNED = "not owned"   # DataObject.telegram_source of a shared-input submodule: another AR controls it


@dataclass
class DataObject:
    """One submodule's IO data in one cyclic frame (offsets relative to the first C_SDU byte)."""

    api: int
    slot: int
    subslot: int
    offset: int                 # first data byte; IOPS follows the data directly
    length: int                 # data bytes (0 for submodules without data in this direction)
    iops_len: int = 1
    module_ident: int | None = None
    submodule_ident: int | None = None
    telegram: int | None = None          # PROFIdrive telegram number, when known
    telegram_source: str | None = None   # 'P922' | 'gsdml' | 'map' | 'length' (a guess) | ...
    # the Connect response's ModuleDiffBlock: not this AR's working submodule (for now): another AR owns it, or the
    # submodule plugged is wrong / none (session_ar.diff_state); judged only while its IOPS are GOOD, no #66
    locked: str | None = None
    length_checked_for: int | None = None  # the telegram its length was checked against (cyclic.py, #64 once)


@dataclass
class IocsEntry:
    """An IOCS byte in a cyclic frame: the consumer status of a submodule of the other direction."""

    api: int
    slot: int
    subslot: int
    offset: int
    length: int = 1


@dataclass
class FrameMap:
    """Layout of one cyclic frame ID between one MAC pair (one IOCR of one AR)."""

    frame_id: int
    direction: str              # 'input' (device -> controller) or 'output' (controller -> device)
    controller_mac: str | None = None
    device_mac: str | None = None
    station: str | None = None  # NameOfStation of the device, when known
    ar_uuid: str | None = None
    data_length: int | None = None       # C_SDU length from the IOCR block
    send_clock_factor: int | None = None
    reduction_ratio: int | None = None
    watchdog_factor: int | None = None
    objects: list[DataObject] = field(default_factory=list)
    iocs: list[IocsEntry] = field(default_factory=list)
    source: str = "connect"     # 'connect' | 'map' | 'length'
    released: bool = False      # the AR was released; the map stays for late frames
    # the AR's phase (pndiss.session_ar PHASES); None = no Connect seen (map, mid-session): judged as data
    # exchange. Cycles of an AR still in 'parameterisation' (Connect seen, no PrmEnd yet) are not judged.
    phase: str | None = None
    # a system redundancy AR (ARType 0x0020, S2/R1): the device acts on the AR its controller holds as primary;
    # a frame of it whose DataStatus.State says Backup (bit 0 clear, wire.md §2.3) carries no cycle it acts on
    primary_only: bool = False
    # no Connect (a map found from the content): the stream's cycle from its cycle counter step, when confirmed
    learnt_cycle_ns: int | None = None
    # ... and k, the cycles the controller holds each sign-of-life value (infer.py _hold), when more than 1
    learnt_k: tuple[int, str] | None = None

    @property
    def cycle_time_ns(self) -> int | None:
        """SendClockFactor x ReductionRatio x 31.25 us, when known."""
        if self.send_clock_factor and self.reduction_ratio:
            return self.send_clock_factor * self.reduction_ratio * 31250
        return None
