"""Who is on the simulated wire: the controller and each encoder, with their addresses, identities
(PROFILES, [sim choice] where no manual gives them) and the AR layout: slots, subslots, IO data
objects and IOCS offsets of both IOCRs (wire.md §2.6)."""
from __future__ import annotations

import random
import uuid

from .. import telegrams as T
from .config import Config, station_clock

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
