"""The options of one simulated session (``Config``, set by ``pndiss simulate``) and what a cycle
time means on the wire: send clock factor x reduction ratio (network.md §1.3)."""
from __future__ import annotations

from dataclasses import dataclass, field


@dataclass
class Config:
    scenario: str = "startup"
    profile: str = "generic"
    telegram: int = 81
    cycle_ms: float = 1.0
    cycles: int = 2000
    encoders: int = 1
    injects: list = field(default_factory=list)   # [(rule_id, cycle or None)]
    seed: int = 1
    mupr: int = 8192
    tmr: int = 8192 * 4096
    compat: int = 1
    class4: int = 1
    velocity_unit: int = 0
    startup: str = "realistic"        # "realistic" (plant-like, sim/startup.py) or "tidy" (cyclic after PrmEnd)
    records: str = "multiplewrite"    # start-up records: one 0xE040 MultipleWrite or "plain" writes
    good_before_prmend: bool = False  # device GOOD from its first frame, records a few cycles later
    restart: int | None = None        # cycle at which encoder 1's AR is released and set up again
    restart_scaling: dict = field(default_factory=dict)   # 0xBF00 values of the second AR (mupr, tmr, direction, ...)
    restart_gap_ms: float = 200.0     # silence between Release and the new Connect
    restart_mode: str = "release"     # how the first AR ends: "release" (IODReleaseReq) or "abort" (ERR-RTA)
    capture_loss: float = 0.0         # share of cyclic frames the capture point drops (seeded)
    start_mid_session: int | None = None   # the capture starts at this data-exchange cycle
    cycle_list: list | None = None    # one cycle time (ms) per encoder; None: cycle_ms for all
    drift_ppm: float = 50.0           # each clock (controller, every device) runs off by up to +-this
    jitter_us: float = 20.0           # send-time jitter of each cyclic frame, +-us (at most a quarter cycle)
    irt: bool = False                 # isochronous RT_CLASS_3 (frame IDs 0x0100..), no drift or jitter
    io_devices: int = 0               # ordinary IO devices (DI/DO module) on the same wire
    param_polls_ms: float = 0.0       # per encoder a base-mode parameter read every this many ms (sim/plant.py)
    it_fps: float = 0.0               # IT frames per second on the segment: OPC UA, SNMP, ARP, mDNS, ICMP


def station_clock(cfg: Config, i: int) -> tuple[int, int]:
    """(SCF, RR) of encoder i: one send clock for the controller (that of the shortest cycle, or the
    cycle's own below 1 ms), the reduction ratio gives each encoder its cycle time."""
    cycles = cfg.cycle_list or [cfg.cycle_ms]
    mine = cycles[i] if i < len(cycles) else cycles[0]
    scf = send_clock(min(cycles))[0]
    send_clock(mine)                        # refuses a cycle time that is not SCF x RR
    rr = int(round(mine * 32 / scf))
    if rr * scf != mine * 32 or rr & (rr - 1) or rr > 512:
        raise ValueError(f"cycle time {mine} ms is not a power-of-two multiple of the send clock "
                         f"{scf * 31.25:g} us")
    return scf, rr


def send_clock(cycle_ms: float) -> tuple[int, int]:
    """(SendClockFactor, ReductionRatio) for a cycle time: SCF x RR x 31.25 us (network.md §1.3).
    Send clock 1 ms (SCF 32) with RR = cycle/1 ms for slower cycles; SCF < 32 below 1 ms."""
    units = cycle_ms * 32
    if units != int(units) or units < 8:
        raise ValueError(f"cycle time {cycle_ms} ms is not a multiple of 31.25 us x 8 (min 0.25 ms)")
    units = int(units)
    if units <= 32:
        if units & (units - 1):
            raise ValueError(f"cycle time {cycle_ms} ms: below 1 ms the send clock must be 0.25, 0.5 or 1 ms")
        return units, 1
    rr = units // 32
    if units % 32 or rr & (rr - 1) or rr > 512:
        raise ValueError(f"cycle time {cycle_ms} ms: must be 1 ms x a power of two up to 512")
    return 32, rr
