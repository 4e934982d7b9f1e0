"""One simulated PROFINET session: an IO controller and N encoders, frame by frame on a fixed clock.

``SimSession(cfg).build()`` returns the sorted frame list and the ground truth; the writer in
``scenarios.write_capture`` turns it into a pcapng + ``.expected.json``. Nothing here reads the
wall clock: timestamps are EPOCH_NS + seed seconds + scheduled offsets, UUIDs come from a seeded
RNG, so the same arguments give the same bytes.
"""
from __future__ import annotations

import random
import struct
import uuid
from dataclasses import dataclass, field

from .. import telegrams as T
from . import frames as F
from . import capture_point, recdata, startup
from .model import Encoder, Plc, Shaft, PROFILE_TELEGRAMS

EPOCH_NS = 1_767_225_600 * 10**9   # 2026-01-01T00:00:00Z, the simulator's fixed epoch
API_DAP = 0
API_ENC = 0x3D00                    # encoder object API (records.md §6, PS/PSM 002_d69f444daf0f8af2.txt:490-493)
SLOT_ENC = 1
SUB_MAP = 1                         # MAP/PAP at slot 1 subslot 1: records 0xBF00, 0xB02E (records.md §6)
SUB_TEL = 2                         # telegram submodule at slot 1 subslot 2 (000_37bf2397999f1108.txt:2756)
DAP_SUBSLOTS = (0x0001, 0x8000, 0x8001, 0x8002)   # DAP, interface, port 1, port 2

# Identification per profile. Only Lika's vendor ID 0x0239 is in the manuals (network.md §1.11);
# the other IDs, device IDs and all module/submodule idents are [sim choice] (network.md §1.8: none
# of the manuals gives them). vendor_text: network.md §1.11 "device type" candidates.
PROFILES = {
    "lika": dict(vendor_id=0x0239, device_id=0x0001, vendor_text="LIKA ROTACOD",
                 order_id="XAC7716/16384PT", bf00_index=0xBF00),
    "scancon": dict(vendor_id=0x0249, device_id=0x0001, vendor_text="SCANCON SAG",
                    order_id="SAG-EIXXB-1213-0000", bf00_index=0xBF00),
    "hohner": dict(vendor_id=0x0259, device_id=0x0001, vendor_text="ExM58 PN Encoder",
                   order_id="ExM58x-xxxPNxxxx1213", bf00_index=0xBF00),
    "psm": dict(vendor_id=0x0269, device_id=0x0001, vendor_text="PSM Encoder Standard",
                order_id="PSM-ENC-PN", bf00_index=0xFFFF),     # PS/PSM record 0xFFFF (records.md §5.1)
    "generic": dict(vendor_id=0x0279, device_id=0x0001, vendor_text="PNDISS SIM ENCODER",
                    order_id="PNDISS-SIM-ENC", bf00_index=0xBF00),
}
DAP_MODULE = 0x00000001            # [sim choice]
MAP_SUBMODULE = 0x0000FFFF         # SCANCON's MAP submodule ident 0xFFFF, low confidence (network.md §1.8)


def module_ident(telegram: int) -> int:
    return 0x00000100 + telegram   # [sim choice]: encoder module per telegram


def submodule_ident(telegram: int) -> int:
    return telegram                # [sim choice]: telegram submodule ident = telegram number


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


class Frame:
    __slots__ = ("ts", "order", "data", "tags", "what")

    def __init__(self, ts, order, data, what, tags=()):
        self.ts, self.order, self.data, self.what, self.tags = ts, order, data, what, set(tags)


def mac(n: int, dev: int) -> str:
    """Locally administered MACs: 02:00:00:00:<dev>:<n> (dev 0 = controller)."""
    return f"02:00:00:00:{dev:02x}:{n:02x}"


class Station:
    """Addresses and AR data of one encoder."""

    def __init__(self, i: int, cfg: Config, rng: random.Random, extra_in: int = 0):
        self.i = i
        self.mac = mac(1, i + 1)
        self.port_macs = (mac(2, i + 1), mac(3, i + 1))
        self.name = f"encoder-{i + 1}"
        self.ip = f"192.168.0.{10 + i}"
        self.ar_uuid = uuid.UUID(int=rng.getrandbits(128), version=4)
        self.session_key = 1
        # RT_CLASS_1 frame IDs 0x8000.. ; RT_CLASS_3 (IRT) 0x0100.. (wire.md §2.2)
        self.in_fid = (0x0100 if cfg.irt else 0x8000) + 2 * i
        self.out_fid = self.in_fid + 1
        self.scf, self.rr = station_clock(cfg, i)
        self.cycle_ns = self.scf * self.rr * 31_250
        self.step = (self.scf * self.rr) & 0xFFFF   # cycle counter unit 31.25 us (wire.md §2.3)
        # the same run time for every station, counted in its own cycles
        self.cycles = max(1, round(cfg.cycles * (cfg.cycle_list[0] if cfg.cycle_list else cfg.cycle_ms)
                                   * 1_000_000 / self.cycle_ns))
        self.ppb = self.phase = 0
        self.rpc_port = 0xC000 + i           # controller's RPC port for this AR
        self.dev_port = 0xC100 + i           # device's port for its own requests (ApplicationReady)
        sp, ac = T.length(cfg.telegram, "setpoint"), T.length(cfg.telegram, "actual") + extra_in
        self.out_len, self.in_len = sp, ac
        # Input CR: lone IOPS for DAP submodules and MAP, then the telegram data + IOPS, then the
        # IOCS of the telegram's output (wire.md §2.6); output CR: data + IOPS, then IOCS for all.
        n = len(DAP_SUBSLOTS)
        self.in_objs = [(API_DAP, 0, ss, o) for o, ss in enumerate(DAP_SUBSLOTS)] + \
            [(API_ENC, SLOT_ENC, SUB_MAP, n), (API_ENC, SLOT_ENC, SUB_TEL, n + 1)]
        self.in_data_off = n + 1
        self.in_iocs = [(API_ENC, SLOT_ENC, SUB_TEL, n + 2 + ac)]
        self.in_csdu = max(40, n + 3 + ac)
        self.out_data_off = 0
        self.out_objs = [(API_ENC, SLOT_ENC, SUB_TEL, 0)]
        self.out_iocs = [(API_DAP, 0, ss, sp + 1 + o) for o, ss in enumerate(DAP_SUBSLOTS)] + \
            [(API_ENC, SLOT_ENC, SUB_MAP, sp + 1 + n), (API_ENC, SLOT_ENC, SUB_TEL, sp + 2 + n)]
        self.out_csdu = max(40, sp + 3 + n)
        self.first_in = self.first_out = self.good_from = 0   # first cycles on the wire (startup.py)


CTRL_MAC = mac(1, 0)
CTRL_PORT_MAC = mac(2, 0)
CTRL_IP = "192.168.0.1"
CTRL_NAME = "plc"
CTRL_VENDOR, CTRL_DEVICE = 0x0289, 0x0001   # [sim choice]


def cyclic_header(src: str, dst: str, frame_id: int) -> bytes:
    """Ethernet + 802.1Q (PCP 6, VID 0) + FrameID: the fixed head of every cyclic frame (wire.md §1)."""
    return (bytes.fromhex(dst.replace(":", "")) + bytes.fromhex(src.replace(":", ""))
            + struct.pack(">HHHH", 0x8100, F.PCP_RT << 13, F.ETH_PNRT, frame_id))


# APDU status (wire.md §2.3): DataStatus 0x35 = primary, valid, run, station ok; transfer status 0
DATA_STATUS = 0x35
IOXS_GOOD = 0x80
IOXS_BAD = 0x00    # bad, detected by subslot (wire.md §2.5)


# start-up run: still, ramp to 60 rpm, constant, ramp down, still (fractions of the run)
DEFAULT_SHAFT = ((0.0, 0.0, 0.0), (0.1, 0.0, 60.0), (0.35, 60.0, 60.0), (0.6, 60.0, 0.0), (0.85, 0.0, 0.0))


class SimSession:
    """Builds every frame of one session; ``build()`` -> (frames sorted by time, ground truth)."""

    def __init__(self, cfg: Config, scenario=None):
        if cfg.telegram not in PROFILE_TELEGRAMS[cfg.profile]:
            raise ValueError(f"telegram {cfg.telegram} is not offered by profile {cfg.profile} "
                             f"(offered: {', '.join(map(str, PROFILE_TELEGRAMS[cfg.profile]))})")
        self.cfg = cfg
        self.rng = random.Random(cfg.seed)
        self.t0 = EPOCH_NS + cfg.seed * 10**9
        self.scf, self.rr = station_clock(cfg, 0)
        self.cycle_ns = self.scf * self.rr * 31_250
        self.ident = PROFILES[cfg.profile]
        self.stations = [Station(i, cfg, self.rng) for i in range(cfg.encoders)]
        self.frames: list[Frame] = []
        self.order = 0
        self.xid = self.rng.randrange(1, 1 << 24)
        self.ip_id = self.rng.randrange(1, 1 << 15)
        self.seq = 0
        self.bmp_ref = self.rng.randrange(1, 200)
        self.facts: dict = {"records": [], "params": [], "dcp": [], "alarms": []}
        self.injected: list[dict] = []
        self.scenario = scenario
        self.cyc_start_ns = 0
        self.with_cyclic = True
        self.params = None

    # ------------------------------------------------------------------ plumbing
    def add(self, ts: int, data: bytes, what: str, tags=()) -> Frame:
        self.order += 1
        fr = Frame(ts, self.order, data, what, tags)
        self.frames.append(fr)
        return fr

    def uuid(self) -> uuid.UUID:
        return uuid.UUID(int=self.rng.getrandbits(128), version=4)

    def next_ip_id(self) -> int:
        self.ip_id = (self.ip_id + 1) & 0xFFFF
        return self.ip_id

    def ms(self, x: float) -> int:
        return self.t0 + int(round(x * 1_000_000))

    def cyc_ts(self, k: int) -> int:
        return self.cyc_start_ns + k * self.cycle_ns

    def out_ts(self, st, k: int) -> int:
        """When the controller's output frame of cycle k for station st is on the wire: the
        controller's clock (drift), its cycle start jitters, the frames go out 20 us apart."""
        T = st.cycle_ns
        return (self.cyc_start_ns + k * T + (k * T * self.ctrl_ppb) // 10**9 + 20_000 * st.i
                + self.jitter(0, k, T))

    def in_ts(self, st, k: int) -> int:
        """When station st's input frame of cycle k is on the wire: the device's own clock and phase.
        The device answers the controller's frames it has received, so its frame of cycle k stays within
        one cycle of the controller's: the drift moves its phase, which wraps at a full cycle (from then on
        its frames come a cycle earlier or later relative to the controller's) instead of piling up a
        delay of many cycles over a long capture."""
        T = st.cycle_ns
        off = self._phase(st, k)
        jit = self.jitter(st.i + 1, k, T)
        if jit and (st.ppb or self.ctrl_ppb) and (self._phase(st, k - 1) > off or self._phase(st, k + 1) < off):
            jit = 0   # the phase wraps next to this frame: no jitter, so the stream keeps its order
        return self.cyc_start_ns + k * T + (k * T * self.ctrl_ppb) // 10**9 + off + jit

    def _phase(self, st, k: int) -> int:
        """The device frame's offset after the controller's cycle start, in [0, T)."""
        T = st.cycle_ns
        off = st.phase + (k * T * st.ppb) // 10**9 - (k * T * self.ctrl_ppb) // 10**9
        if 0 <= off < T or not (st.ppb or self.ctrl_ppb):
            return off   # one clock (IRT, tidy): the fixed phase, even past a cycle with many stations
        return off % T

    def set_clocks(self) -> None:
        """Drift (ppm) and phase of every clock from their own RNG, so the frame contents do not
        depend on them. IRT and --drift-ppm 0 --jitter-us 0: the old fixed order (inputs half a cycle
        after the outputs, 20 us apart)."""
        cfg = self.cfg
        rt = not cfg.irt and (cfg.drift_ppm or cfg.jitter_us)
        rng = random.Random(f"clocks:{cfg.seed}")
        d = cfg.drift_ppm if rt else 0.0
        self.ctrl_ppb = int(round(rng.uniform(-d, d) * 1000)) if d else 0
        self.jit_ns = int(cfg.jitter_us * 1000) if rt else 0
        self.jit_seed = rng.getrandbits(32)
        for st in self.all_stations():
            st.ppb = int(round(rng.uniform(-d, d) * 1000)) if d else 0
            st.phase = rng.randrange(st.cycle_ns) if rt else st.cycle_ns // 2 + 20_000 * st.i

    def jitter(self, clock: int, k: int, T: int) -> int:
        """Deterministic send jitter in [-J, J], J <= T/4 (a stream's frames keep their order)."""
        J = min(self.jit_ns, T // 4)
        if not J:
            return 0
        x = (k * 2654435761 + clock * 40503 + self.jit_seed) & 0xFFFFFFFF
        x = ((x ^ (x >> 16)) * 0x45D9F3B) & 0xFFFFFFFF
        x ^= x >> 16
        return x % (2 * J + 1) - J

    def all_stations(self) -> list:
        return self.stations + getattr(self, "io_stations", [])

    # ------------------------------------------------------------------ RPC
    def rpc_call(self, ts, st: Station, opnum: int, req_blocks, res_blocks, *, from_device=False,
                 status: int = 0, tags=(), what="rpc"):
        """A request and its response 300 us later, each one datagram."""
        act = self.uuid()
        if from_device:  # device -> controller (ApplicationReady), to the controller interface
            src, dst, sip, dip, sp, dp = st.mac, CTRL_MAC, st.ip, CTRL_IP, st.dev_port, F.RPC_PORT
            obj, iface = F.object_uuid(CTRL_VENDOR, CTRL_DEVICE), F.IF_CONTROLLER
        else:
            src, dst, sip, dip, sp, dp = CTRL_MAC, st.mac, CTRL_IP, st.ip, st.rpc_port, F.RPC_PORT
            ident = getattr(st, "ident", self.ident)
            obj, iface = F.object_uuid(ident["vendor_id"], ident["device_id"]), F.IF_DEVICE
        self.seq += 1
        req = F.rpc(src, dst, sip, dip, sp, dp, ptype=0, opnum=opnum, seq=self.seq, act=act, obj=obj,
                    iface=iface, blocks=req_blocks, ip_id=self.next_ip_id())
        res = F.rpc(dst, src, dip, sip, dp, sp, ptype=2, opnum=opnum, seq=self.seq, act=act, obj=obj,
                    iface=iface, blocks=res_blocks, status=status, ip_id=self.next_ip_id(), boot=1)
        a = self.add(ts, req, what + ".req", tags)
        b = self.add(ts + 300_000, res, what + ".res", tags)
        return a, b

    def write_record(self, ts, st, index, data, *, api=API_ENC, slot=SLOT_ENC, subslot=SUB_MAP,
                     status=0, tags=(), what="write"):
        self.seq_rw = getattr(self, "seq_rw", 0) + 1
        pn = 0 if status == 0 else status
        a, b = self.rpc_call(ts, st, 3, [F.write_req(self.seq_rw, st.ar_uuid, api, slot, subslot, index, data)],
                             [F.write_res(self.seq_rw, st.ar_uuid, api, slot, subslot, index, len(data), pn)],
                             status=pn, tags=tags, what=what)
        return a, b

    def read_record(self, ts, st, index, data, *, api=API_ENC, slot=SLOT_ENC, subslot=SUB_MAP, tags=(),
                    what="read"):
        self.seq_rw = getattr(self, "seq_rw", 0) + 1
        return self.rpc_call(ts, st, 2, [F.read_req(self.seq_rw, st.ar_uuid, api, slot, subslot, index, 4096)],
                             [F.read_res(self.seq_rw, st.ar_uuid, api, slot, subslot, index, data)],
                             tags=tags, what=what)

    def bmp(self, ts, st, req: bytes, res: bytes, tags=(), what="bmp"):
        """Base mode parameter access: write the request to 0xB02E, read the response (records.md §3.2)."""
        a, _ = self.write_record(ts, st, 0xB02E, req, tags=tags, what=what + ".write")
        _, d = self.read_record(ts + 1_000_000, st, 0xB02E, res, tags=tags, what=what + ".read")
        return a, d

    def next_ref(self) -> int:
        self.bmp_ref = self.bmp_ref % 255 + 1   # 1..255, changes with every request (records.md §3.5)
        return self.bmp_ref

    # ------------------------------------------------------------------ the session
    def device_params(self) -> dict:
        c = self.cfg
        # preset control: presets act on G1_XIST1; Hohner codes that as 1 (inverted, records.md §5.2)
        return dict(direction=0, class4=c.class4, preset_control=1 if c.profile == "hohner" else 0,
                    scaling=1, alarm_channel_control=0,
                    compat=c.compat, mupr=c.mupr, tmr=c.tmr, max_master_sol_failures=1,
                    velocity_unit=c.velocity_unit)

    def build(self):
        cfg, sc = self.cfg, self.scenario
        params = self.params = self.device_params()
        if sc is not None:
            sc.prepare(self, params)
        from .iodevice import IoStation
        self.io_stations = [IoStation(j, len(self.stations) + j, cfg, self.rng) for j in range(cfg.io_devices)]
        self.set_clocks()
        n = len(self.all_stations())
        # --- LLDP from the controller and both ports of every encoder (wire.md §6)
        self.lldp_round(0)
        # --- DCP: Identify All, responses; per station Identify by name, Set NameOfStation, Set IP
        xid = self.xid
        self.add(self.ms(5), F.dcp_identify_req(CTRL_MAC, xid), "dcp.identify_all")
        for st in self.all_stations():
            self.add(self.ms(5.5 + 0.2 * st.i), self.identify_res(st, xid), "dcp.identify_res")
        for st in self.all_stations():
            base = 10 + 10 * st.i
            x = self.xid = self.xid + 1
            self.add(self.ms(base), F.dcp_identify_req(CTRL_MAC, x, name=st.name), "dcp.identify_name")
            self.add(self.ms(base + 0.4), self.identify_res(st, x), "dcp.identify_res")
            self.dcp_set_name(self.ms(base + 2), st, st.name.encode())
            x = self.xid = self.xid + 1
            self.add(self.ms(base + 4), F.dcp_set_ip(CTRL_MAC, st.mac, x, st.ip, "255.255.255.0", "0.0.0.0"),
                     "dcp.set_ip")
            self.add(self.ms(base + 4.3), F.dcp_set_res(st.mac, CTRL_MAC, x, 1, 2), "dcp.set_res")
            self.facts["dcp"].append({"station": st.name, "ip": st.ip, "mac": st.mac})
        for j, (what, si, value, tags) in enumerate(sc.dcp_extra if sc else ()):
            st = self.stations[si]
            ts = self.ms(10 + 10 * n + 1 + 0.5 * j)
            x = self.xid = self.xid + 1
            if what == "name":   # the device refuses an invalid name: BlockError 3 "suboption not set"
                bad = not all(c.isalnum() or c in "-." for c in value.decode("latin-1"))
                self.add(ts, F.dcp_set_name(CTRL_MAC, st.mac, x, value), "dcp.set_name", tags)
                self.add(ts + 300_000, F.dcp_set_res(st.mac, CTRL_MAC, x, 2, 2, 3 if bad else 0), "dcp.set_res", tags)
            else:
                self.add(ts, F.dcp_set_ip(CTRL_MAC, st.mac, x, value, "255.255.255.0", "0.0.0.0"), "dcp.set_ip", tags)
                self.add(ts + 300_000, F.dcp_set_res(st.mac, CTRL_MAC, x, 1, 2), "dcp.set_res", tags)
                x = self.xid = self.xid + 1    # then the right address again
                self.add(ts + 400_000, F.dcp_set_ip(CTRL_MAC, st.mac, x, st.ip, "255.255.255.0", "0.0.0.0"),
                         "dcp.set_ip")
                self.add(ts + 450_000, F.dcp_set_res(st.mac, CTRL_MAC, x, 1, 2), "dcp.set_res")
        # --- Connect, records, PrmEnd, ApplicationReady per station
        t = 10 + 10 * n + 5
        if cfg.startup == "tidy":
            self.startup_tidy(params, t)
        else:
            startup.realistic(self, params, t)
        for st in self.all_stations():
            st.cc0 = (self.rng.randrange(1 << 16), self.rng.randrange(1 << 16))
            st.sol0 = 1 + self.rng.randrange(15)
            st.ars = [{"ar_uuid": str(st.ar_uuid), "session_key": st.session_key, "params": dict(params),
                       "first_cycle": min(st.first_in, st.first_out), "tag": f"ar1:{st.i}"}]
        if cfg.restart is not None:
            startup.restart(self, self.stations[0], params)
        # --- I&M0 and the profile parameters (P922, P964, P965, P979, P65001)
        encs = {}
        for st in self.stations:
            k = 20 + 3 * st.i
            # in units of max(cycle, 1 ms): one parameter access is over before the next (records.md §3.5)
            unit = max(self.cycle_ns, 1_000_000)
            self.read_record(self.cyc_start_ns + k * unit, st, 0xAFF0,
                             recdata.im0(self.ident["vendor_id"], self.ident["order_id"], f"SIM{cfg.seed:04d}{st.i:04d}"),
                             what="im0")
            self.facts["records"].append({"station": st.name, "op": "read", "index": 0xAFF0})
            dev = {"vendor_id": self.ident["vendor_id"], "telegram": cfg.telegram, "compat": params["compat"],
                   "mupr": params["mupr"], "tmr": params["tmr"], "preset_value": 0, "offset": 0,
                   "velocity_unit": params["velocity_unit"]}
            encs[st.i] = dev
            for j, pnu in enumerate((922, 964, 965, 979, 65001)):
                fn, tags = sc.param_override.get(pnu, (None, ())) if sc and st.i == 0 else (None, ())
                self.read_param(self.cyc_start_ns + (k + 10 + 5 * j) * unit, st, pnu, fn(dev) if fn else dev,
                                tags=tags)
            for inj in (sc.bmp_extra if sc and st.i == 0 else ()):
                inj.access(self, st, self.cyc_ts(inj.k), dev)
        # --- cyclic (the fast path writes it itself), LLDP again every 5 s (802.1AB msgTxInterval)
        if self.with_cyclic:
            self.run_cyclic(params, encs)
        else:   # the fast path writes cycles 0.. itself; the start-up cycles come from here
            self.run_startup_cycles()
        from .iodevice import run_cycles
        for st in self.io_stations:
            run_cycles(self, st, with_good=self.with_cyclic)
        t_lldp = 5000.0
        while self.ms(t_lldp) < self.cyc_ts(cfg.cycles):
            self.lldp_round(t_lldp + 0.2)
            t_lldp += 5000.0
        # --- Release at the end
        t_end = self.cyc_ts(cfg.cycles) + 2_000_000
        for st in self.all_stations():
            self.rpc_call(t_end + st.i * 1_000_000, st, 1,
                          [F.control_req(st.ar_uuid, st.session_key, release=True)],
                          [F.control_res(st.ar_uuid, st.session_key, block_type=0x8114)], what="release")
        if sc is not None:
            sc.finish(self)
        self.frames.sort(key=lambda f: (f.ts, f.order))
        self.frames, self.capture_extra = capture_point.apply(self, self.frames)
        return self.frames, self.truth()

    def startup_tidy(self, params, t: float) -> None:
        """The old tidy start-up: Connect, 0xBF00, PrmEnd per station; cyclic data from cycle 0 after
        the last PrmEnd, GOOD from the first frame; ApplicationReady once the IO data run."""
        sc = self.scenario
        if self.io_stations:
            raise ValueError("IO devices need the realistic start-up (not --startup tidy)")
        for st in self.stations:
            self.connect(self.ms(t), st)
            if not (sc and sc.skip_bf00):
                bf = recdata.bf00(self.cfg.profile, **params) if not (sc and sc.bf00_bytes) else sc.bf00_bytes
                self.write_record(self.ms(t + 3), st, self.ident["bf00_index"], bf, what="bf00",
                                  tags=sc.bf00_tags if sc else ())
                self.facts["records"].append({"station": st.name, "op": "write", "index": self.ident["bf00_index"],
                                              "length": len(bf)})
            self.rpc_call(self.ms(t + 6), st, 4, [F.control_req(st.ar_uuid, st.session_key, prm_end=True)],
                          [F.control_res(st.ar_uuid, st.session_key, block_type=0x8110)], what="prm_end")
            t += 10
        self.cyc_start_ns = self.ms(t)
        for st in self.stations:
            self.rpc_call(self.cyc_ts(5 + 2 * st.i), st, 4,
                          [F.control_req(st.ar_uuid, st.session_key, app_ready=True)],
                          [F.control_res(st.ar_uuid, st.session_key, block_type=0x8112)],
                          from_device=True, what="app_ready")

    def lldp_round(self, t_ms):
        self.add(self.ms(t_ms), F.lldp_frame(CTRL_PORT_MAC, chassis=CTRL_NAME, port_id=f"port-001.{CTRL_NAME}",
                                              mgmt_ip=CTRL_IP), "lldp")
        for st in self.all_stations():
            for p, pm in enumerate(st.port_macs):
                self.add(self.ms(t_ms + 0.1 + 0.05 * (2 * st.i + p)),
                         F.lldp_frame(pm, chassis=st.name, port_id=f"port-00{p + 1}.{st.name}", mgmt_ip=st.ip),
                         "lldp")

    def identify_res(self, st, xid):
        ident = getattr(st, "ident", self.ident)
        return F.dcp_identify_res(st.mac, CTRL_MAC, xid, name=st.name, vendor_text=ident["vendor_text"],
                                  vendor_id=ident["vendor_id"], device_id=ident["device_id"],
                                  ip=st.ip, mask="255.255.255.0", gw="0.0.0.0")

    def dcp_set_name(self, ts, st, name: bytes, tags=()):
        x = self.xid = self.xid + 1
        self.add(ts, F.dcp_set_name(CTRL_MAC, st.mac, x, name), "dcp.set_name", tags)
        self.add(ts + 300_000, F.dcp_set_res(st.mac, CTRL_MAC, x, 2, 2), "dcp.set_res", tags)

    def connect(self, ts, st: Station):
        cfg = self.cfg
        if hasattr(st, "connect_blocks"):    # an IO device (iodevice.py)
            req = [F.ar_block_req(st.ar_uuid, st.session_key, CTRL_MAC, F.object_uuid(CTRL_VENDOR, CTRL_DEVICE),
                                  CTRL_NAME)] + st.connect_blocks(cfg)
            res = [F.ar_block_res(st.ar_uuid, st.session_key, st.mac), F.iocr_block_res(1, 1, st.in_fid),
                   F.iocr_block_res(2, 2, st.out_fid), F.alarm_cr_block_res()]
            self.rpc_call(ts, st, 0, req, res, what="connect")
            return
        ctrl_obj = F.object_uuid(CTRL_VENDOR, CTRL_DEVICE)
        in_apis = [(API_DAP, [(s, ss, o) for a, s, ss, o in st.in_objs if a == API_DAP], []),
                   (API_ENC, [(s, ss, o) for a, s, ss, o in st.in_objs if a == API_ENC],
                    [(s, ss, o) for a, s, ss, o in st.in_iocs])]
        out_apis = [(API_DAP, [], [(s, ss, o) for a, s, ss, o in st.out_iocs if a == API_DAP]),
                    (API_ENC, [(s, ss, o) for a, s, ss, o in st.out_objs],
                     [(s, ss, o) for a, s, ss, o in st.out_iocs if a == API_ENC])]
        subs_dap = [(ss, ss, None, None) for ss in DAP_SUBSLOTS]
        subs_enc = [(SUB_MAP, MAP_SUBMODULE, None, None),
                    (SUB_TEL, submodule_ident(cfg.telegram), st.in_len, st.out_len)]
        req = [F.ar_block_req(st.ar_uuid, st.session_key, CTRL_MAC, ctrl_obj, CTRL_NAME),
               F.iocr_block_req(1, 1, st.in_csdu, st.in_fid, st.scf, st.rr, in_apis, rt_class=3 if cfg.irt else 2),
               F.iocr_block_req(2, 2, st.out_csdu, st.out_fid, st.scf, st.rr, out_apis, rt_class=3 if cfg.irt else 2),
               F.alarm_cr_block_req(),
               F.expected_submodules([(API_DAP, 0, DAP_MODULE, subs_dap),
                                      (API_ENC, SLOT_ENC, module_ident(cfg.telegram), subs_enc)])]
        res = [F.ar_block_res(st.ar_uuid, st.session_key, st.mac), F.iocr_block_res(1, 1, st.in_fid),
               F.iocr_block_res(2, 2, st.out_fid), F.alarm_cr_block_res()]
        self.rpc_call(ts, st, 0, req, res, what="connect",
                      tags=self.scenario.connect_tags if self.scenario and st.i == 0 else ())

    def read_param(self, ts, st, pnu, dev, tags=(), *, response=None, ref=None):
        fmt, vals = recdata.read_block(pnu, dev, self.cfg.profile)
        ref = self.next_ref() if ref is None else ref
        count = len(vals) if len(vals) > 1 else 0
        req = recdata.param_request(ref, 1, [(pnu, 0, count, None, fmt)])
        res = recdata.param_response(ref, 1, [(fmt, vals)]) if response is None else response
        self.bmp(ts, st, req, res, tags=tags, what=f"p{pnu}")
        self.facts["params"].append({"station": st.name, "pnu": pnu, "values": vals, "request_ref": ref})

    def write_param(self, ts, st, pnu, value, *, error: int | None = None, tags=()):
        ref = self.next_ref()
        req = recdata.param_request(ref, 2, [(pnu, 0, 0, [value & 0xFFFFFFFF], 0x43)])
        if error is None:
            res = recdata.param_response(ref, 2, [(0x40, [])])
        else:
            res = recdata.param_response(ref, 0x82, [(0x44, [error])])
        self.bmp(ts, st, req, res, tags=tags, what=f"p{pnu}.change")
        self.facts["params"].append({"station": st.name, "pnu": pnu, "write": value, "error": error,
                                     "request_ref": ref})

    # ------------------------------------------------------------------ alarms
    def alarm(self, ts, st, *, appears: bool, channel_error: int | None, tags=()):
        """Diagnosis appears/disappears from the device, the controller's AlarmAck, the device's
        transport ACK (low priority RTA, wire.md §7). Endpoints: controller 1, device 2 (AlarmCR)."""
        ds = getattr(st, "alarm_send", 0)
        cs = getattr(st, "alarm_ctrl_send", 0)
        st.alarm_seq = getattr(st, "alarm_seq", 0) + 1
        atype = 0x0001 if appears else 0x000C   # Diagnosis / Diagnosis disappears (wire.md §7.2)
        note = F.alarm_notification(high=False, alarm_type=atype, api=API_ENC, slot=SLOT_ENC, subslot=SUB_TEL,
                                    module_ident=module_ident(self.cfg.telegram),
                                    submodule_ident=submodule_ident(self.cfg.telegram), seq=st.alarm_seq,
                                    channel_error=channel_error, appears=appears)
        self.add(ts, F.rta(st.mac, CTRL_MAC, high=False, dst_ep=1, src_ep=2, pdu_type=F.RTA_DATA, send_seq=ds,
                           ack_seq=(cs - 1) & 0xFFFF, sdu=note), "alarm.notification", tags)
        ack = F.alarm_ack_block(high=False, alarm_type=atype, api=API_ENC, slot=SLOT_ENC, subslot=SUB_TEL,
                                seq=st.alarm_seq, appears=appears, channel=channel_error is not None)
        self.add(ts + 400_000, F.rta(CTRL_MAC, st.mac, high=False, dst_ep=2, src_ep=1, pdu_type=F.RTA_DATA,
                                     send_seq=cs, ack_seq=ds, sdu=ack), "alarm.ack", tags)
        self.add(ts + 700_000, F.rta(st.mac, CTRL_MAC, high=False, dst_ep=1, src_ep=2, pdu_type=F.RTA_ACK,
                                     send_seq=(ds + 1) & 0xFFFF, ack_seq=cs), "alarm.rta_ack", tags)
        st.alarm_send, st.alarm_ctrl_send = (ds + 1) & 0xFFFF, (cs + 1) & 0xFFFF
        self.facts["alarms"].append({"station": st.name, "alarm_type": atype, "appears": appears,
                                     "channel_error_type": channel_error})

    # ------------------------------------------------------------------ cyclic
    def run_startup_cycles(self) -> None:
        """Start-up cycles (k < 0) with IOxS BAD, zero data (realistic start-up, not GOOD before PrmEnd)."""
        if self.cfg.good_before_prmend or self.cfg.startup == "tidy":
            return
        for st in self.stations:
            step = st.step
            o_t, i_t = frame_templates(st, IOXS_BAD, startup.DATA_STATUS_STOP, DATA_STATUS)
            for k in range(min(st.first_in, st.first_out), 0):
                if k >= st.first_out:
                    o = bytearray(o_t)
                    struct.pack_into(">H", o, len(o) - 4, (st.cc0[0] + k * step) & 0xFFFF)
                    self.add(self.out_ts(st, k), bytes(o), "cyclic.out.startup", {st.ars[0]["tag"]})
                if k >= st.first_in:
                    i = bytearray(i_t)
                    struct.pack_into(">H", i, len(i) - 4, (st.cc0[1] + k * step) & 0xFFFF)
                    self.add(self.in_ts(st, k), bytes(i), "cyclic.in.startup", {st.ars[0]["tag"]})

    def run_cyclic(self, params, devs):
        cfg, sc = self.cfg, self.scenario
        cyc_s = self.cycle_ns / 1e9
        # shaft segments are given in fractions of the run (so short and long runs look alike)
        frac = sc.shaft if sc is not None and sc.shaft else DEFAULT_SHAFT
        run_s = cfg.cycles * cyc_s
        shaft_segs = tuple((f * run_s, r0, r1) for f, r0, r1 in frac)
        out_l, in_l = T.layout(cfg.telegram, "setpoint"), T.layout(cfg.telegram, "actual")
        self.run_startup_cycles()
        per = []
        for st in self.stations:
            enc = Encoder(cfg.profile, cfg.telegram, params=params, shaft=Shaft(shaft_segs), cycle_s=st.cycle_ns / 1e9)
            plc = Plc(cfg.telegram, sol_start=st.sol0)
            out_t, in_t = frame_templates(st, IOXS_GOOD, DATA_STATUS, DATA_STATUS)
            if sc is not None and sc.reject_bf00:
                # a conforming device refuses a bad 0xBF00: parameterisation error 0x1002 in G1_XIST2
                # and a 0x9011 channel diagnosis (cyclic.md §9; 000_37bf2397999f1108.txt:2605-2639)
                enc.error_code = 0x1002
                self.alarm(self.cyc_ts(2) + 300_000, st, appears=True, channel_error=0x9011,
                           tags=sc.bf00_tags)
            per.append([st, enc, plc, out_t, in_t, st.cc0, st.ars[0]["tag"]])
        last_in = {st.i: None for st in self.stations}
        # GOOD before PrmEnd: the model runs from the first start-up frame (hooks from cycle 0)
        k0 = min([0] + [min(st.good_from, st.first_in, st.first_out) for st in self.stations
                        if st.good_from < 0])
        for k in range(k0, max(st.cycles for st in self.stations)):
            for row in per:
                st, enc, plc, out_t, in_t, cc0, ar_tag = row
                if k >= st.cycles:
                    continue
                step = st.step
                rs = getattr(st, "restart", None)
                if rs is not None and k >= rs["end"]:
                    # Release, silence, the second AR's start-up, then its data exchange (a new model)
                    if k < rs["first"] or (k < rs["good_from"] and not self.restart_cycle(st, k, rs)):
                        continue
                    if k == rs["good_from"]:
                        enc = row[1] = Encoder(cfg.profile, cfg.telegram, params=rs["params"],
                                               shaft=Shaft(shaft_segs), cycle_s=st.cycle_ns / 1e9)
                        plc = row[2] = Plc(cfg.telegram, sol_start=rs["sol0"])
                        ar_tag = row[6] = rs["tag"]
                        last_in[st.i] = None
                tags_o, tags_i = {ar_tag}, {ar_tag}
                if rs is not None and k == rs["good_from"] and "fault_tag" in rs:
                    tags_i.add(rs["fault_tag"])
                hooks = sc is not None and k >= 0
                if hooks:
                    sc.before_cycle(self, k, st, plc, enc, last_in[st.i])
                out = plc.step(k, last_in[st.i])
                if hooks:
                    sc.after_plc(self, k, st, out, tags_o)
                actual = enc.step(k, out)
                if hooks:
                    sc.after_enc(self, k, st, actual, tags_i)
                last_in[st.i] = actual
                ob = out_l.encode(out)
                ib = in_l.encode(actual)
                o = bytearray(out_t)
                i = bytearray(in_t)
                o[20 + st.out_data_off:20 + st.out_data_off + len(ob)] = ob
                i[20 + st.in_data_off:20 + st.in_data_off + len(ib)] = ib
                struct.pack_into(">H", o, len(o) - 4, (cc0[0] + k * step) & 0xFFFF)
                struct.pack_into(">H", i, len(i) - 4, (cc0[1] + k * step) & 0xFFFF)
                if hooks:
                    sc.patch(self, k, st, o, i, tags_o, tags_i)
                    if k == 0 and st.i == 0:
                        tags_o |= set(sc.first_cyclic_tags)
                if k >= st.first_out and (rs is None or k < rs["end"] or k >= rs["first_out"]):
                    self.add(self.out_ts(st, k), bytes(o), "cyclic.out", tags_o)
                if k >= st.first_in and (rs is None or k < rs["end"] or k >= rs["first_in"]):
                    self.add(self.in_ts(st, k), bytes(i), "cyclic.in", tags_i)

    def restart_cycle(self, st, k, rs) -> bool:
        """A start-up cycle of the second AR: BAD frames (False), or GOOD already (True, model runs)."""
        if self.cfg.good_before_prmend:
            return True
        step = st.step
        o_t, i_t = rs.setdefault("bad", frame_templates(st, IOXS_BAD, startup.DATA_STATUS_STOP, DATA_STATUS))
        if k >= rs["first_out"]:
            o = bytearray(o_t)
            struct.pack_into(">H", o, len(o) - 4, (st.cc0[0] + k * step) & 0xFFFF)
            self.add(self.out_ts(st, k), bytes(o), "cyclic.out.startup", {rs["tag"]})
        if k >= rs["first_in"]:
            i = bytearray(i_t)
            struct.pack_into(">H", i, len(i) - 4, (st.cc0[1] + k * step) & 0xFFFF)
            self.add(self.in_ts(st, k), bytes(i), "cyclic.in.startup", {rs["tag"]})
        return False

    # ------------------------------------------------------------------ ground truth
    def ar_truth(self, st) -> list:
        """Each AR of a station: UUID, session key, its 0xBF00 values, cycles and cyclic frames."""
        out = []
        for ar in st.ars:
            tagged = [n for n, f in enumerate(self.frames, 1) if ar["tag"] in f.tags]
            d = {k: v for k, v in ar.items() if k != "tag"}
            d["params"] = {k: v for k, v in ar["params"].items()
                           if k in ("mupr", "tmr", "direction", "velocity_unit", "class4", "compat")}
            d["first_frame"] = tagged[0] if tagged else None
            d["last_frame"] = tagged[-1] if tagged else None
            out.append(d)
        return out

    def truth(self) -> dict:
        from . import iodevice
        cfg = self.cfg
        num = {id(f): n for n, f in enumerate(self.frames, 1)}
        faults = []
        for inj in self.injected:
            tagged = [n for n, f in enumerate(self.frames, 1) if inj["tag"] in f.tags]
            d = {k: v for k, v in inj.items() if k != "tag"}
            d["first_frame"] = tagged[0] if tagged else None
            d["last_frame"] = tagged[-1] if tagged else None
            faults.append(d)
        del num
        stations = []
        for st in self.stations:
            def objs(lst, data_len):
                return [{"api": a, "slot": s, "subslot": ss, "offset": o,
                         "length": data_len if (s, ss) == (SLOT_ENC, SUB_TEL) else 0} for a, s, ss, o in lst]

            def iocs(lst):
                return [{"api": a, "slot": s, "subslot": ss, "offset": o} for a, s, ss, o in lst]
            stations.append({
                "name": st.name, "mac": st.mac, "ip": st.ip, "profile": cfg.profile,
                "vendor_id": self.ident["vendor_id"], "device_id": self.ident["device_id"],
                "ar_uuid": st.ars[0]["ar_uuid"], "telegram": cfg.telegram, "ars": self.ar_truth(st),
                "telegram_slot": SLOT_ENC, "telegram_subslot": SUB_TEL,
                "module_ident": module_ident(cfg.telegram), "submodule_ident": submodule_ident(cfg.telegram),
                "iocrs": [
                    {"direction": "input", "frame_id": st.in_fid, "src": st.mac, "dst": CTRL_MAC,
                     "data_length": st.in_csdu, "send_clock_factor": st.scf, "reduction_ratio": st.rr,
                     "objects": objs(st.in_objs, st.in_len), "iocs": iocs(st.in_iocs)},
                    {"direction": "output", "frame_id": st.out_fid, "src": CTRL_MAC, "dst": st.mac,
                     "data_length": st.out_csdu, "send_clock_factor": st.scf, "reduction_ratio": st.rr,
                     "objects": objs(st.out_objs, st.out_len), "iocs": iocs(st.out_iocs)},
                ],
            })
        whats = {}
        for f in self.frames:
            whats[f.what] = whats.get(f.what, 0) + 1
        return {
            "generator": "pndiss simulate",
            "config": {"scenario": cfg.scenario, "profile": cfg.profile, "telegram": cfg.telegram,
                       "cycle_ms": cfg.cycle_ms, "cycles": cfg.cycles, "encoders": cfg.encoders,
                       "seed": cfg.seed, "inject": [f"{r}@{c}" if c is not None else r for r, c in cfg.injects],
                       "startup": cfg.startup, "records": cfg.records, "good_before_prmend": cfg.good_before_prmend,
                       **({"restart": cfg.restart, "restart_scaling": cfg.restart_scaling,
                           "restart_mode": cfg.restart_mode}
                          if cfg.restart is not None else {}),
                       **({"capture_loss": cfg.capture_loss} if cfg.capture_loss else {}),
                       "drift_ppm": cfg.drift_ppm if not cfg.irt else 0, "jitter_us": cfg.jitter_us if not cfg.irt else 0,
                       **({"cycle_list": cfg.cycle_list} if cfg.cycle_list else {}),
                       **({"irt": True} if cfg.irt else {}), **({"io_devices": cfg.io_devices} if cfg.io_devices else {}),
                       **({"start_mid_session": cfg.start_mid_session} if cfg.start_mid_session is not None
                          else {})},
            "frames": len(self.frames),
            "frame_kinds": dict(sorted(whats.items())),
            "controller": {"name": CTRL_NAME, "mac": CTRL_MAC, "ip": CTRL_IP},
            "stations": stations,
            "records": self.facts["records"],
            "params": self.facts["params"],
            "alarms": self.facts["alarms"],
            "faults": faults,
            "clean": not faults,
            **getattr(self, "capture_extra", {"capture_gaps": []}),
            **({"io_devices": [iodevice.truth(self, st) for st in self.io_stations]} if self.io_stations else {}),
        }


def frame_templates(st: Station, ioxs: int, ds_out: int, ds_in: int) -> tuple[bytes, bytes]:
    """(output, input) cyclic frames of a station with zero data, every IOPS/IOCS = ioxs, the
    DataStatus bytes given and cycle counter 0 (wire.md §2.3-2.6)."""
    out_t = bytearray(cyclic_header(CTRL_MAC, st.mac, st.out_fid) + bytes(st.out_csdu) + bytes(4))
    in_t = bytearray(cyclic_header(st.mac, CTRL_MAC, st.in_fid) + bytes(st.in_csdu) + bytes(4))
    h = 20  # dst, src, 802.1Q, type, FrameID
    for _a, _s, _ss, o in st.out_objs:
        out_t[h + o + st.out_len] = ioxs
    for _a, _s, _ss, o in st.out_iocs:
        out_t[h + o] = ioxs
    for _a, s, ss, o in st.in_objs:
        in_t[h + o + (st.in_len if (s, ss) == (SLOT_ENC, SUB_TEL) else 0)] = ioxs
    for _a, _s, _ss, o in st.in_iocs:
        in_t[h + o] = ioxs
    out_t[-2], in_t[-2] = ds_out, ds_in
    return bytes(out_t), bytes(in_t)


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
