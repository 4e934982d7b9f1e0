"""Frame builders for the simulator: DCP, LLDP, PNIO-CM (DCE/RPC over UDP), alarms, cyclic RTC1.

Each builder returns the Ethernet frame as bytes (no FCS). Scapy builds the layers it gets right
(DCP, LLDP, DCE/RPC + PNIO-CM blocks); our own bytes are used for the cyclic frames (templates,
see fastpath.py), record payloads and the alarm PDU. Every frame type was checked with
``tshark -V`` 4.0.17 (tests/test_simulate.py keeps checking it).
"""
from __future__ import annotations

import struct
import uuid
from functools import lru_cache

from scapy.layers.inet import IP, UDP
from scapy.layers.l2 import Dot1Q, Ether
from scapy.contrib import lldp as L
from scapy.contrib import pnio_dcp as D  # noqa: F401  (registers the DCP layers with scapy)
from scapy.contrib import pnio_rpc as R
from scapy.packet import Raw

DCP_MCAST = "01:0e:cf:00:00:00"        # DCP Identify multicast (wire.md §1 destination MACs)
LLDP_MCAST = "01:80:c2:00:00:0e"       # LLDP nearest bridge (wire.md §1)
ETH_PNRT = 0x8892
RPC_PORT = 34964                        # PNIO-CM connectionless RPC (wire.md §1, UDP 34964)
PCP_RT = 6                              # cyclic + alarm high priority tag, VID 0 (wire.md §1, 802.1Q)

# PNIO interface UUIDs (IEC 61158-6-10; scapy pnio_rpc RPC_INTERFACE_UUID)
IF_DEVICE = R.RPC_INTERFACE_UUID["UUID_IO_DeviceInterface"]
IF_CONTROLLER = R.RPC_INTERFACE_UUID["UUID_IO_ControllerInterface"]


def object_uuid(vendor_id: int, device_id: int, instance: int = 1) -> uuid.UUID:
    """PNIO object UUID dea00000-6c97-11d1-8271-<instance><device id><vendor id> (IEC 61158-6-10)."""
    return uuid.UUID(f"dea00000-6c97-11d1-8271-{instance:04x}{device_id:04x}{vendor_id:04x}")


def _eth(src: str, dst: str, payload, vlan: int | None = None, etype: int | None = None) -> bytes:
    e = Ether(src=src, dst=dst)
    if vlan is not None:
        e = e / Dot1Q(prio=vlan, vlan=0)
    if etype is not None:
        if vlan is not None:
            e[Dot1Q].type = etype
        else:
            e.type = etype
    b = bytes(e / payload)
    return b if len(b) >= 60 else b + bytes(60 - len(b))  # Ethernet minimum frame, FCS not captured


# ---------------------------------------------------------------------------------------- DCP
# FrameIDs: wire.md §2.2 (0xFEFE identify request, 0xFEFF identify response, 0xFEFD get/set)

def _dcp(src, dst, frame_id, service_id, service_type, xid, blocks, delay=None) -> bytes:
    body = b"".join(bytes(b) for b in blocks)
    # scapy's ProfinetDCP pads identify requests oddly; the header is 10 bytes (wire.md §3)
    hdr = struct.pack(">HBBIHH", frame_id, service_id, service_type, xid,
                      delay if delay is not None else 0, len(body))
    return _eth(src, dst, Raw(hdr + body), etype=ETH_PNRT)


def _pad_even(b: bytes) -> bytes:
    return b + b"\0" * (len(b) & 1)


def dcp_block(option: int, sub: int, value: bytes, block_info: int | None = None) -> bytes:
    """One DCP block: option, suboption, length, [BlockInfo/Qualifier], value, pad to even."""
    v = value if block_info is None else struct.pack(">H", block_info) + value
    return _pad_even(struct.pack(">BBH", option, sub, len(v)) + v)


def dcp_identify_req(src, xid, name: str | None = None, dst=DCP_MCAST) -> bytes:
    # Identify All = option 0xFF/0xFF without value; by name = NameOfStation (2/2) filter
    blk = dcp_block(0xFF, 0xFF, b"") if name is None else dcp_block(2, 2, name.encode())
    return _dcp(src, dst, 0xFEFE, 5, 0, xid, [blk], delay=1)


def dcp_identify_res(src, dst, xid, *, name: str, vendor_text: str, vendor_id: int, device_id: int,
                     ip: str, mask: str, gw: str) -> bytes:
    ipb = bytes(map(int, ip.split("."))) + bytes(map(int, mask.split("."))) + bytes(map(int, gw.split(".")))
    blocks = [
        dcp_block(2, 1, vendor_text.encode(), 0),             # DeviceVendorValue
        dcp_block(2, 2, name.encode(), 0),                    # NameOfStation
        dcp_block(2, 3, struct.pack(">HH", vendor_id, device_id), 0),
        dcp_block(2, 4, b"\x01\x00", 0),                      # device role: IO device
        dcp_block(2, 5, bytes([2, 1, 2, 2, 2, 3, 2, 4, 1, 2]), 0),  # device options list
        dcp_block(2, 7, struct.pack(">H", 1), 0),             # device instance 0.1
        dcp_block(1, 2, ipb, 1),                              # IP, BlockInfo "IP set"
    ]
    return _dcp(src, dst, 0xFEFF, 5, 1, xid, blocks)


def dcp_set_name(src, dst, xid, name: bytes, permanent=True) -> bytes:
    blocks = [dcp_block(2, 2, name, 1 if permanent else 0), dcp_block(5, 2, b"", 1)]  # + Control Stop
    return _dcp(src, dst, 0xFEFD, 4, 0, xid, blocks)


def dcp_set_ip(src, dst, xid, ip, mask, gw, permanent=True) -> bytes:
    ipb = b"".join(bytes(map(int, a.split("."))) for a in (ip, mask, gw))
    return _dcp(src, dst, 0xFEFD, 4, 0, xid, [dcp_block(1, 2, ipb, 1 if permanent else 0)])


def dcp_set_res(src, dst, xid, option: int, sub: int, error: int = 0) -> bytes:
    # Control/Response block (5/4): the answered option/suboption + BlockError
    return _dcp(src, dst, 0xFEFD, 4, 1, xid, [dcp_block(5, 4, bytes([option, sub, error]))])


# --------------------------------------------------------------------------------------- LLDP

@lru_cache(maxsize=256)   # identical every 5 s; scapy is slow
def lldp_frame(src, *, chassis: str, port_id: str, ttl: int = 20, port_desc: str | None = None,
               sysname: str | None = None, mgmt_ip: str | None = None, delay_ns=(0, 0)) -> bytes:
    """LLDP with the TLVs PROFINET devices send (wire.md §6): chassis = NameOfStation (locally
    assigned), port "port-001.<name>", TTL, PROFINET port status + chassis MAC, 802.3 MAC/PHY."""
    tlvs = [
        L.LLDPDUChassisID(subtype=7, id=chassis.encode()),
        L.LLDPDUPortID(subtype=7, id=port_id.encode()),
        L.LLDPDUTimeToLive(ttl=ttl),
    ]
    if port_desc:
        tlvs.append(L.LLDPDUPortDescription(description=port_desc.encode()))
    if sysname:
        tlvs.append(L.LLDPDUSystemName(system_name=sysname.encode()))
    if mgmt_ip:
        tlvs.append(L.LLDPDUManagementAddress(management_address_subtype=1,
                                              management_address=bytes(map(int, mgmt_ip.split("."))),
                                              interface_numbering_subtype=2, interface_number=1))
    # PROFINET OUI 00:0E:CF: subtype 1 = Measured delay values, 2 = Port status (RTC2 + RTC3 state),
    # 5 = chassis MAC (wire.md §6 / tshark packet-lldp.c profinet_subtypes)
    tlvs.append(L.LLDPDUGenericOrganisationSpecific(org_code=0x000ECF, subtype=2, data=b"\x00\x00\x00\x00"))
    tlvs.append(L.LLDPDUGenericOrganisationSpecific(org_code=0x000ECF, subtype=5,
                                                   data=bytes.fromhex(src.replace(":", ""))))
    # IEEE 802.3 MAC/PHY config: autoneg supported+enabled, 100BASE-TX FD advertised, MAU 16 (100BASE-TXFD)
    tlvs.append(L.LLDPDUGenericOrganisationSpecific(org_code=0x00120F, subtype=1,
                                                   data=b"\x03\x04\x00\x00\x10"))
    tlvs.append(L.LLDPDUEndOfLLDPDU())
    p = tlvs[0]
    for t in tlvs[1:]:
        p = p / t
    return _eth(src, LLDP_MCAST, p)


# ------------------------------------------------------------------------------- PNIO-CM / RPC

def rpc(src_mac, dst_mac, src_ip, dst_ip, sport, dport, *, ptype: int, opnum: int, seq: int,
        act: uuid.UUID, obj: uuid.UUID, iface: uuid.UUID, blocks: list, status: int = 0,
        ip_id: int = 0, args_max: int = 16696, boot: int = 0) -> bytes:
    """One unfragmented DCE/RPC datagram (ptype 0 request, 2 response) carrying PNIO blocks."""
    hdr = R.DceRpc4(ptype=ptype, flags1=0x20 if ptype == 0 else 0x0A, object=obj, if_id=iface,
                    act_id=act, server_boot=boot, seqnum=seq, opnum=opnum)
    if ptype == 0:
        body = R.PNIOServiceReqPDU(args_max=args_max, blocks=blocks)
    else:
        body = R.PNIOServiceResPDU(status=status, blocks=blocks)
    return _eth(src_mac, dst_mac, IP(src=src_ip, dst=dst_ip, id=ip_id, ttl=64, flags="DF")
                / UDP(sport=sport, dport=dport) / hdr / body)


def ar_block_req(ar_uuid, session_key, ctrl_mac, ctrl_obj, station: str):
    return R.ARBlockReq(ARType=1, ARUUID=ar_uuid, SessionKey=session_key, CMInitiatorMacAdd=ctrl_mac,
                        CMInitiatorObjectUUID=ctrl_obj, ARProperties_State=1,
                        ARProperties_ParametrizationServer=1, ARProperties_StartupMode=1,
                        CMInitiatorActivityTimeoutFactor=600, CMInitiatorUDPRTPort=0x8892,
                        CMInitiatorStationName=station.encode())


def iocr_block_req(iocr_type, ref, data_length, frame_id, scf, rr, apis, watchdog=3, rt_class=2):
    """apis: [(api, [(slot, subslot, offset)] data objects, [(slot, subslot, offset)] iocs)]."""
    return R.IOCRBlockReq(
        IOCRType=iocr_type, IOCRReference=ref, LT=0x8892, IOCRProperties_RTClass=rt_class,
        DataLength=data_length, FrameID=frame_id, SendClockFactor=scf, ReductionRatio=rr,
        Phase=1, Sequence=0, FrameSendOffset=0xFFFFFFFF, WatchdogFactor=watchdog,
        DataHoldFactor=watchdog, IOCRTagHeader_IOUserPriority=PCP_RT, IOCRTagHeader_IOCRVLANID=0,
        IOCRMulticastMACAdd="01:0e:cf:00:00:00",
        APIs=[R.IOCRAPI(API=api,
                        IODataObjects=[R.IOCRAPIObject(SlotNumber=s, SubslotNumber=ss, FrameOffset=o)
                                       for s, ss, o in objs],
                        IOCSs=[R.IOCRAPIObject(SlotNumber=s, SubslotNumber=ss, FrameOffset=o)
                               for s, ss, o in iocs])
              for api, objs, iocs in apis])


def alarm_cr_block_req():
    # AlarmCRTagHeaderHigh 0xC000 (PCP 6) / Low 0xA000 (PCP 5) as observed (wire.md §1)
    return R.AlarmCRBlockReq(AlarmCRType=1, LT=0x8892, RTATimeoutFactor=100, RTARetries=3,
                             LocalAlarmReference=1, MaxAlarmDataLength=200,
                             AlarmCRTagHeaderHigh=0xC000, AlarmCRTagHeaderLow=0xA000)


# DataDescription: 1 = input, 2 = output (IEC 61158-6-10 ExpectedSubmoduleDataDescription)
def expected_submodules(slots):
    """slots: [(api, slot, module_ident, [(subslot, submodule_ident, in_len|None, out_len|None)])]."""
    apis = []
    for api, slot, mod_ident, subs in slots:
        sms = []
        for subslot, sub_ident, in_len, out_len in subs:
            dds, typ = [], 0
            if in_len is not None and out_len is None or (in_len is None and out_len is None):
                dds.append(R.ExpectedSubmoduleDataDescription(DataDescription=1,
                                                              SubmoduleDataLength=in_len or 0,
                                                              LengthIOCS=1, LengthIOPS=1))
                typ = 1 if in_len else 0
            elif in_len is not None and out_len is not None:
                dds.append(R.ExpectedSubmoduleDataDescription(DataDescription=1, SubmoduleDataLength=in_len,
                                                              LengthIOCS=1, LengthIOPS=1))
                dds.append(R.ExpectedSubmoduleDataDescription(DataDescription=2, SubmoduleDataLength=out_len,
                                                              LengthIOCS=1, LengthIOPS=1))
                typ = 3
            else:
                dds.append(R.ExpectedSubmoduleDataDescription(DataDescription=2, SubmoduleDataLength=out_len,
                                                              LengthIOCS=1, LengthIOPS=1))
                typ = 2
            if typ == 0:  # no IO data: one input description with length 0 (IEC 61158-6-10)
                dds = [R.ExpectedSubmoduleDataDescription(DataDescription=1, SubmoduleDataLength=0,
                                                          LengthIOCS=1, LengthIOPS=1)]
            sms.append(R.ExpectedSubmodule(SubslotNumber=subslot, SubmoduleIdentNumber=sub_ident,
                                           SubmoduleProperties_Type=typ, DataDescription=dds))
        apis.append(R.ExpectedSubmoduleAPI(API=api, SlotNumber=slot, ModuleIdentNumber=mod_ident,
                                           Submodules=sms))
    return R.ExpectedSubmoduleBlockReq(APIs=apis)


def ar_block_res(ar_uuid, session_key, dev_mac):
    return R.ARBlockRes(ARType=1, ARUUID=ar_uuid, SessionKey=session_key, CMResponderMacAdd=dev_mac,
                        CMResponderUDPRTPort=0x8892)


def iocr_block_res(iocr_type, ref, frame_id):
    return R.IOCRBlockRes(IOCRType=iocr_type, IOCRReference=ref, FrameID=frame_id)


def alarm_cr_block_res(local_ref=2, max_len=200):
    return R.AlarmCRBlockRes(AlarmCRType=1, LocalAlarmReference=local_ref, MaxAlarmDataLength=max_len)


def control_req(ar_uuid, session_key, *, prm_end=False, app_ready=False, done=False, release=False):
    # Block types: 0x0110 PrmEnd/Done req, 0x0112 ApplicationReady req, 0x0114 Release req
    bt = 0x0112 if app_ready else 0x0114 if release else 0x0110
    return R.IODControlReq(block_type=bt, padding=b"\0\0", ARUUID=ar_uuid, SessionKey=session_key,
                           ControlCommand_PrmEnd=int(prm_end), ControlCommand_ApplicationReady=int(app_ready),
                           ControlCommand_Release=int(release))


def control_res(ar_uuid, session_key, *, block_type: int):
    # responses: 0x8110, 0x8112, 0x8114 with ControlCommand Done
    return R.IODControlRes(block_type=block_type, padding=b"\0\0", ARUUID=ar_uuid, SessionKey=session_key,
                           ControlCommand_Done=1)


def write_req(seq, ar_uuid, api, slot, subslot, index, data: bytes):
    return R.IODWriteReq(seqNum=seq, ARUUID=ar_uuid, API=api, slotNumber=slot, subslotNumber=subslot,
                         padding=b"\0\0", index=index, recordDataLength=len(data), RWPadding=b"\0" * 24) / Raw(data)


def write_res(seq, ar_uuid, api, slot, subslot, index, length, status=0):
    return R.IODWriteRes(seqNum=seq, ARUUID=ar_uuid, API=api, slotNumber=slot, subslotNumber=subslot,
                         padding=b"\0\0", index=index, recordDataLength=length, status=status,
                         RWPadding=b"\0" * 16)


def multiple_write_req(seq, ar_uuid, writes: list):
    """Index 0xE040 (wire.md §6.10): writes = [(seq, api, slot, subslot, index, data)]. Outer header
    API/slot/subslot 0xFFFFFFFF/0xFFFF/0xFFFF as an S7-1500 sends it; each inner IODWriteReqHeader +
    data, padded to 4 bytes from the stub start (the body starts at stub offset 20 + 64, aligned), the
    last record not padded."""
    body = b""
    for j, (sq, api, slot, subslot, index, data) in enumerate(writes):
        body += bytes(R.IODWriteReq(seqNum=sq, ARUUID=ar_uuid, API=api, slotNumber=slot, subslotNumber=subslot,
                                    padding=b"\0\0", index=index, recordDataLength=len(data),
                                    RWPadding=b"\0" * 24)) + data
        if j < len(writes) - 1:
            body += bytes(-len(body) % 4)
    return R.IODWriteReq(seqNum=seq, ARUUID=ar_uuid, API=0xFFFFFFFF, slotNumber=0xFFFF, subslotNumber=0xFFFF,
                         padding=b"\0\0", index=0xE040, recordDataLength=len(body), RWPadding=b"\0" * 24) / Raw(body)


def multiple_write_res(seq, ar_uuid, writes: list, statuses: list):
    """Outer IODWriteResHeader (index 0xE040, RecordDataLength n x 64), then one per inner write."""
    out = [R.IODWriteRes(seqNum=seq, ARUUID=ar_uuid, API=0xFFFFFFFF, slotNumber=0xFFFF, subslotNumber=0xFFFF,
                         padding=b"\0\0", index=0xE040, recordDataLength=64 * len(writes),
                         status=max(statuses, default=0), RWPadding=b"\0" * 16)]
    for (sq, api, slot, subslot, index, data), stat in zip(writes, statuses):
        out.append(write_res(sq, ar_uuid, api, slot, subslot, index, len(data), stat))
    return out


def read_req(seq, ar_uuid, api, slot, subslot, index, max_len):
    return R.IODReadReq(seqNum=seq, ARUUID=ar_uuid, API=api, slotNumber=slot, subslotNumber=subslot,
                        padding=b"\0\0", index=index, recordDataLength=max_len, RWPadding=b"\0" * 24)


def read_res(seq, ar_uuid, api, slot, subslot, index, data: bytes):
    return R.IODReadRes(seqNum=seq, ARUUID=ar_uuid, API=api, slotNumber=slot, subslotNumber=subslot,
                        padding=b"\0\0", index=index, recordDataLength=len(data),
                        RWPadding=b"\0" * 20) / Raw(data)


# ------------------------------------------------------------------------------------- alarms
# RTA header and AlarmNotification / AlarmAck blocks: wire.md §7.1-7.3 (tshark packet-dcerpc-pn-io.c
# dissect_PNIO_RTA, dissect_AlarmNotification_block, dissect_Alarm_ack_block). Own bytes: scapy's
# PNIORealTimeAcyclicPDUHeader puts the PDU type in the wrong nibble (wire.md §7.1).
RTA_DATA, RTA_ACK = 1, 3


RTA_ERR = 4


def rta(src, dst, *, high: bool, dst_ep: int, src_ep: int, pdu_type: int, send_seq: int, ack_seq: int,
        sdu: bytes = b"", add_flags: int = 0x11) -> bytes:
    hdr = struct.pack(">HHBBHHH", dst_ep, src_ep, 0x10 | pdu_type, add_flags, send_seq, ack_seq, len(sdu))
    fid = 0xFC01 if high else 0xFE01
    return _eth(src, dst, Raw(struct.pack(">H", fid) + hdr + sdu), vlan=6 if high else 5, etype=ETH_PNRT)


def alarm_notification(*, high: bool, alarm_type: int, api: int, slot: int, subslot: int, module_ident: int,
                       submodule_ident: int, seq: int, channel_error: int | None, appears: bool) -> bytes:
    # AlarmSpecifier: seq bits 0-10, ChannelDiagnosis bit 11, SubmoduleDiagnosisState bit 13,
    # ARDiagnosisState bit 15 (wire.md §7.2)
    spec = (seq & 0x7FF) | ((1 << 11) if channel_error is not None else 0) | ((0xA000) if appears else 0)
    body = struct.pack(">HIHHIIH", alarm_type, api, slot, subslot, module_ident, submodule_ident, spec)
    if channel_error is not None:
        # USI 0x8000 ChannelDiagnosis: ChannelNumber 0x8000 (whole submodule), ChannelProperties
        # specifier 1 appears / 2 disappears in bits 11-12, ChannelErrorType (wire.md §7.3)
        props = (1 if appears else 2) << 11
        body += struct.pack(">HHHH", 0x8000, 0x8000, props, channel_error)
    bt = 0x0001 if high else 0x0002
    return struct.pack(">HHBB", bt, len(body) + 2, 1, 0) + body


def alarm_ack_block(*, high: bool, alarm_type: int, api: int, slot: int, subslot: int, seq: int,
                    appears: bool, channel: bool = True) -> bytes:
    spec = (seq & 0x7FF) | ((1 << 11) if channel else 0) | (0xA000 if appears else 0)
    body = struct.pack(">HIHHHI", alarm_type, api, slot, subslot, spec, 0)
    bt = 0x8001 if high else 0x8002
    return struct.pack(">HHBB", bt, len(body) + 2, 1, 0) + body
