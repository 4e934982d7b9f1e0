"""Ordinary IO devices on the encoders' wire (``--io-devices N``): non-encoder ARs with their own DCP,
LLDP, Connect, PrmEnd/ApplicationReady and cyclic frames (8 digital inputs, 8 digital outputs).

Real plants have them next to the encoders: their frames interleave with the encoders' and their
ARs must not be taken for axes. Idents and the vendor ID are [sim choice].
"""
from __future__ import annotations

import random
import struct
import uuid

from . import frames as F
from .config import station_clock
from .cyclic import DATA_STATUS, IOXS_BAD, IOXS_GOOD, cyclic_header
from .stations import CTRL_MAC, DAP_MODULE, DAP_SUBSLOTS, mac
from .truth import ar_truth

IDENT = dict(vendor_id=0x0299, device_id=0x0002, vendor_text="PNDISS SIM IO DEVICE", order_id="PNDISS-SIM-IO")
SLOT_DI, SLOT_DO = 1, 2
DI_MODULE, DO_MODULE = 0x00000020, 0x00000021          # [sim choice]
DI_SUBMODULE, DO_SUBMODULE = 0x00010001, 0x00010002     # not a telegram number


class IoStation:
    """Addresses and AR data of one IO device (global station index i after the encoders)."""

    in_key = (SLOT_DI, 1)
    out_key = (SLOT_DO, 1)

    def __init__(self, j: int, i: int, cfg, rng: random.Random):
        self.j, self.i = j, i
        self.mac = mac(1, 0x41 + j)
        self.port_macs = (mac(2, 0x41 + j), mac(3, 0x41 + j))
        self.name = f"io-device-{j + 1}"
        self.ip = f"192.168.0.{100 + j}"
        self.ident = IDENT
        self.ar_uuid = uuid.UUID(int=rng.getrandbits(128), version=4)
        self.session_key = 1
        self.in_fid = (0x0180 if cfg.irt else 0x8100) + 2 * j
        self.out_fid = self.in_fid + 1
        self.rpc_port = 0xC080 + j
        self.dev_port = 0xC180 + j
        self.scf, self.rr = station_clock(cfg, 0)
        self.cycle_ns = self.scf * self.rr * 31_250
        self.step = (self.scf * self.rr) & 0xFFFF
        self.cycles = cfg.cycles
        self.ppb = self.phase = 0
        self.in_len = self.out_len = 1
        n = len(DAP_SUBSLOTS)
        # input CR: lone IOPS of the DAP submodules, DI byte + IOPS, IOCS of the DO (wire.md §2.6)
        self.in_objs = [(0, 0, ss, o) for o, ss in enumerate(DAP_SUBSLOTS)] + [(0, SLOT_DI, 1, n)]
        self.in_iocs = [(0, SLOT_DO, 1, n + 2)]
        self.in_data_off = n
        self.in_csdu = 40
        # output CR: DO byte + IOPS, IOCS of the DAP submodules and the DI
        self.out_objs = [(0, SLOT_DO, 1, 0)]
        self.out_iocs = [(0, 0, ss, 2 + o) for o, ss in enumerate(DAP_SUBSLOTS)] + [(0, SLOT_DI, 1, 2 + n)]
        self.out_data_off = 0
        self.out_csdu = 40
        self.first_in = self.first_out = self.good_from = 0
        self.ars = []

    def connect_blocks(self, cfg):
        rt = 3 if cfg.irt else 2
        in_apis = [(0, [(s, ss, o) for _a, s, ss, o in self.in_objs], [(s, ss, o) for _a, s, ss, o in self.in_iocs])]
        out_apis = [(0, [(s, ss, o) for _a, s, ss, o in self.out_objs],
                     [(s, ss, o) for _a, s, ss, o in self.out_iocs])]
        return [F.iocr_block_req(1, 1, self.in_csdu, self.in_fid, self.scf, self.rr, in_apis, rt_class=rt),
                F.iocr_block_req(2, 2, self.out_csdu, self.out_fid, self.scf, self.rr, out_apis, rt_class=rt),
                F.alarm_cr_block_req(),
                F.expected_submodules([(0, 0, DAP_MODULE, [(ss, ss, None, None) for ss in DAP_SUBSLOTS]),
                                       (0, SLOT_DI, DI_MODULE, [(1, DI_SUBMODULE, 1, None)]),
                                       (0, SLOT_DO, DO_MODULE, [(1, DO_SUBMODULE, None, 1)])])]


def templates(st, ioxs: int, ds_out: int, ds_in: int) -> tuple[bytes, bytes]:
    out_t = bytearray(cyclic_header(CTRL_MAC, st.mac, st.out_fid) + bytes(st.out_csdu) + bytes(4))
    in_t = bytearray(cyclic_header(st.mac, CTRL_MAC, st.in_fid) + bytes(st.in_csdu) + bytes(4))
    for _a, s, ss, o in st.out_objs:
        out_t[20 + o + st.out_len] = ioxs
    for _a, _s, _ss, o in st.out_iocs:
        out_t[20 + o] = ioxs
    for _a, s, ss, o in st.in_objs:
        in_t[20 + o + (st.in_len if (s, ss) == st.in_key else 0)] = ioxs
    for _a, _s, _ss, o in st.in_iocs:
        in_t[20 + o] = ioxs
    out_t[-2], in_t[-2] = ds_out, ds_in
    return bytes(out_t), bytes(in_t)


def run_cycles(sess, st, with_good: bool = True) -> None:
    """Start-up cycles (IOxS BAD, ProviderState STOP from the controller), then data exchange: the
    inputs change now and then, the controller's outputs follow a slow pattern."""
    from .startup import DATA_STATUS_STOP
    bad = templates(st, IOXS_BAD, DATA_STATUS_STOP, DATA_STATUS)
    good = templates(st, IOXS_GOOD, DATA_STATUS, DATA_STATUS)
    cc0 = st.cc0
    rng = random.Random(f"io:{sess.cfg.seed}:{st.j}")
    di, next_change = rng.randrange(256), 0
    for k in range(min(st.first_in, st.first_out), st.cycles if with_good else 0):
        o_t, i_t = bad if k < st.good_from else good
        o, i = bytearray(o_t), bytearray(i_t)
        if k >= st.good_from:
            if k >= next_change:
                di ^= 1 << rng.randrange(8)
                next_change = k + rng.randrange(20, 400)
            o[20 + st.out_data_off] = (k // 250) & 0xFF
            i[20 + st.in_data_off] = di
        struct.pack_into(">H", o, len(o) - 4, (cc0[0] + k * st.step) & 0xFFFF)
        struct.pack_into(">H", i, len(i) - 4, (cc0[1] + k * st.step) & 0xFFFF)
        what = "io.startup" if k < st.good_from else "io"
        if k >= st.first_out:
            sess.add(sess.out_ts(st, k), bytes(o), "cyclic.out." + what, {st.ars[0]["tag"]})
        if k >= st.first_in:
            sess.add(sess.in_ts(st, k), bytes(i), "cyclic.in." + what, {st.ars[0]["tag"]})


def truth(sess, st) -> dict:
    return {"name": st.name, "mac": st.mac, "ip": st.ip, "vendor_id": IDENT["vendor_id"],
            "device_id": IDENT["device_id"], "ar_uuid": str(st.ar_uuid), "ars": ar_truth(sess, st),
            "modules": [{"slot": SLOT_DI, "subslot": 1, "module_ident": DI_MODULE, "submodule_ident": DI_SUBMODULE,
                         "input_length": 1},
                        {"slot": SLOT_DO, "subslot": 1, "module_ident": DO_MODULE, "submodule_ident": DO_SUBMODULE,
                         "output_length": 1}],
            "iocrs": [{"direction": "input", "frame_id": st.in_fid, "src": st.mac, "dst": CTRL_MAC,
                       "data_length": st.in_csdu, "send_clock_factor": st.scf, "reduction_ratio": st.rr},
                      {"direction": "output", "frame_id": st.out_fid, "src": CTRL_MAC, "dst": st.mac,
                       "data_length": st.out_csdu, "send_clock_factor": st.scf, "reduction_ratio": st.rr}]}
