"""One simulated PROFINET session: an IO controller and N encoders, frame by frame on a fixed clock.

``SimSession(cfg).build()`` returns the sorted frame list and the ground truth; the writer in
``scenarios.write_capture`` turns it into a pcapng + ``.expected.json``. Nothing here reads the
wall clock: timestamps are EPOCH_NS + seed seconds + scheduled offsets, UUIDs come from a seeded
RNG, so the same arguments give the same bytes.

This module holds the session's clock and its acyclic traffic (LLDP, DCP, RPC: Connect, records,
parameters, alarms); config.py the options, stations.py who is on the wire, startup.py the AR
start-up, cyclic.py the data exchange, truth.py the sidecar.
"""
from __future__ import annotations

import random
import uuid

from . import frames as F
from . import capture_point, cyclic, recdata, startup, truth
from .config import Config, station_clock
from .model import PROFILE_TELEGRAMS
from .stations import (API_DAP, API_ENC, CTRL_DEVICE, CTRL_IP, CTRL_MAC, CTRL_NAME, CTRL_PORT_MAC, CTRL_VENDOR,
                       DAP_MODULE, DAP_SUBSLOTS, MAP_SUBMODULE, PROFILES, SLOT_ENC, SUB_MAP, SUB_TEL, Station,
                       module_ident, submodule_ident)

EPOCH_NS = 1_767_225_600 * 10**9   # 2026-01-01T00:00:00Z, the simulator's fixed epoch


class Frame:
    __slots__ = ("ts", "order", "data", "tags", "what")

    def __init__(self, ts, order, data, what, tags=()):
        self.ts, self.order, self.data, self.what, self.tags = ts, order, data, what, set(tags)


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
            startup.tidy(self, params, t)
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
            cyclic.run(self, params, encs)
        else:   # the fast path writes cycles 0.. itself; the start-up cycles come from here
            cyclic.run_startup_cycles(self)
        from .iodevice import run_cycles
        for st in self.io_stations:
            run_cycles(self, st, with_good=self.with_cyclic)
        t_lldp = 5000.0
        while self.ms(t_lldp) < self.cyc_ts(cfg.cycles):
            self.lldp_round(t_lldp + 0.2)
            t_lldp += 5000.0
        if cfg.param_polls_ms or cfg.it_fps:   # a plant's parameter polls and IT network (sim/plant.py)
            from . import plant
            if cfg.param_polls_ms:
                plant.parameter_polls(self, encs, cfg.param_polls_ms)
            if cfg.it_fps:
                plant.it_traffic(self, cfg.it_fps)
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
        return self.frames, truth.truth(self)

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

