"""PDev record blocks: port and interface data (real, check, adjust), MRP interface data, PTCP sync
data and the IRT blocks (PDIRData, PDIRSubframeData).

Field names are tshark 4.0's (``pn_io.<name>``, packet-dcerpc-pn-io.c; masks and value strings as
``tshark -G fields`` / ``-G values`` list them), so tests/tshark_map/pnio_cm.json maps them one to
one. Every body gets a Cursor over its block (header excluded) and fills the block dict; padding to
4 bytes counts from the block header, as the blocks are 4-byte aligned in every record.
"""
from __future__ import annotations

from .cmblock import Cursor, bits

# --- value tables (tshark -G values) ---------------------------------------------------------------
MAU_TYPES = {0x00: "Unknown", 0x05: "10BASET", 0x0A: "10BASETXHD", 0x0B: "10BASETXFD", 0x0C: "10BASEFLHD",
             0x0D: "10BASEFLFD", 0x0F: "100BASETXHD", 0x10: "100BASETXFD", 0x11: "100BASEFXHD",
             0x12: "100BASEFXFD", 0x15: "1000BASEXHD", 0x16: "1000BASEXFD", 0x17: "1000BASELXHD",
             0x18: "1000BASELXFD", 0x19: "1000BASESXHD", 0x1A: "1000BASESXFD", 0x1D: "1000BASETHD",
             0x1E: "1000BASETFD", 0x1F: "10GigBASEFX", 0x2E: "100BASELX10", 0x36: "100BASEPXFD",
             0x8D: "10BASET1L"}
LINK_STATE_PORT = {0: "unknown", 1: "disabled/discarding", 2: "blocking", 3: "listening", 4: "learning",
                   5: "forwarding", 6: "broken"}
LINK_STATE_LINK = {1: "up", 2: "down", 3: "testing", 4: "unknown", 5: "dormant", 6: "notpresent",
                   7: "lowerlayerdown"}
MEDIA_TYPES = {0: "Unknown", 1: "Copper cable", 2: "Fiber optic cable", 3: "Radio communication"}
MRP_ROLES = {0: "Media Redundancy disabled", 1: "Media Redundancy Client", 2: "Media Redundancy Manager",
             3: "Media Redundancy Manager (auto)"}
PREAMBLE_LENGTH = {0: "Seven octets Preamble shall be used", 1: "One octet Preamble shall be used"}

LINE_DELAY = (("line_delay_value", 0x7FFFFFFF), ("line_delay_format_indicator", 0x80000000))
MULTIPLE_INTERFACE_MODE = (("MultipleInterfaceMode_NameOfDevice", 0x1), ("MultipleInterfaceMode_reserved_1", 0xFFFE),
                           ("MultipleInterfaceMode_reserved_2", 0xFFFF0000))
MRP_CHECK = (("mrp_check_mrm", 0x1), ("mrp_check_domainUUID", 0x2), ("mrp_check_reserved_1", 0xFFFFFC),
             ("mrp_check_reserved_2", 0xFF000000))
CHECK_SYNC_MODE = (("check_sync_mode_reserved", 0xFFFC), ("check_sync_mode_sync_master", 0x2),
                   ("check_sync_mode_cable_delay", 0x1))
FRAME_DATA_PROPERTIES = (("frame_data_properties_forwardingMode", 0x1),
                         ("frame_data_properties_MulticastMACAdd", 0x6),
                         ("frame_data_properties_FragMode", 0x18),
                         ("frame_data_reserved_1", 0xE0), ("frame_data_reserved_2", 0xFFFFFF00))
FRAME_DETAILS = (("frame_details_sync_frame", 0x3), ("frame_details_meaning_frame_send_offset", 0xC),
                 ("frame_details_reserved", 0xF0))
TX_PORT_PROPERTIES = tuple((f"tx_port_properties_bit_{i}", 1 << i) for i in range(8))
TX_PHASE = (("tx_phase_assignment_begin_value", 0xF), ("tx_phase_assignment_orange_begin", 0xF0),
            ("tx_phase_assignment_end_reserved", 0xF00), ("tx_phase_assignment_reserved", 0xF000))
SFIOCR_PROPERTIES = (("SFIOCRProperties_DistributedWatchDogFactor", 0xFF),
                     ("SFIOCRProperties_RestartFactorForDistributedWD", 0xFF00),
                     ("SFIOCRProperties_DFPmode", 0xFF0000), ("SFIOCRProperties_reserved_1", 0xF000000),
                     ("SFIOCRProperties_reserved_2", 0x10000000), ("SFIOCRProperties_DFPType", 0x20000000),
                     ("SFIOCRProperties_DFPRedundantPathLayout", 0x40000000),
                     ("SFIOCRProperties_SFCRC16", 0x80000000))
SUBFRAME_DATA = (("subframe_data_position", 0x7F), ("subframe_data_reserved1", 0x80),
                 ("subframe_data_data_length", 0xFF00), ("subframe_data_reserved2", 0xFFFF0000))


def _line_delay(c: Cursor, d: dict) -> None:
    v = d["line_delay"] = c.u32()
    d.update(bits(v, LINE_DELAY))


def _peer(c: Cursor) -> dict:
    p = {"length_peer_port_id": c.u8()}
    p["peer_port_id"] = c.text(p["length_peer_port_id"])
    p["length_peer_chassis_id"] = c.u8()
    p["peer_chassis_id"] = c.text(p["length_peer_chassis_id"])
    return p


def _link_state(c: Cursor, d: dict) -> None:
    port, link = c.u8(), c.u8()
    d.update(link_state_port=port, link_state_port_name=LINK_STATE_PORT.get(port, "reserved"),
             link_state_link=link, link_state_link_name=LINK_STATE_LINK.get(link, "reserved"))


def _mau(c: Cursor, d: dict) -> None:
    m = d["mau_type"] = c.u16()
    d["mau_type_name"] = MAU_TYPES.get(m, "reserved")


def pd_port_data_real(c: Cursor, d: dict) -> None:
    """PDPortDataReal 0x020F: own port, peers (name, port, line delay, MAC), MAU type, boundaries,
    link state, media type."""
    c.u16()
    d["slot_nr"], d["subslot_nr"] = c.u16(), c.u16()
    d["length_own_port_id"] = c.u8()
    d["own_port_id"] = c.text(d["length_own_port_id"])
    d["number_of_peers"] = c.u8()
    c.align4()
    d["peers"] = []
    for _ in range(d["number_of_peers"]):
        p = _peer(c)
        c.align4()
        _line_delay(c, p)
        p["peer_macadd"] = c.mac()
        c.align4()
        d["peers"].append(p)
    _mau(c, d)
    c.align4()
    d["domain_boundary"] = c.u32()
    d["multicast_boundary"] = c.u32()
    _link_state(c, d)
    c.align4()
    mt = d["media_type"] = c.u32()
    d["media_type_name"] = MEDIA_TYPES.get(mt, "reserved")


def pd_interface_data_real(c: Cursor, d: dict) -> None:
    """PDInterfaceDataReal 0x0240: chassis ID (NameOfStation), MAC and IP suite of the interface."""
    d["length_own_chassis_id"] = c.u8()
    d["own_chassis_id"] = c.text(d["length_own_chassis_id"])
    c.align4()
    d["macadd"] = c.mac()
    c.align4()
    for k in ("ip_address", "subnetmask", "standard_gateway"):
        o = c.take(4)
        d[k] = ".".join(str(x) for x in c.b[o:o + 4])


def pd_interface_adjust(c: Cursor, d: dict) -> None:
    """PDInterfaceAdjust 0x0250: MultipleInterfaceMode."""
    c.u16()
    v = d["multiple_interface_mode"] = c.u32()
    d.update(bits(v, MULTIPLE_INTERFACE_MODE))


def check_peers(c: Cursor, d: dict) -> None:
    d["number_of_peers"] = c.u8()
    d["peers"] = [_peer(c) for _ in range(d["number_of_peers"])]


def check_line_delay(c: Cursor, d: dict) -> None:
    c.u16()
    _line_delay(c, d)


def check_mau_type(c: Cursor, d: dict) -> None:
    _mau(c, d)


def check_link_state(c: Cursor, d: dict) -> None:
    _link_state(c, d)


def check_sync_difference(c: Cursor, d: dict) -> None:
    v = d["check_sync_mode"] = c.u16()
    d.update(bits(v, CHECK_SYNC_MODE))


def check_mau_type_difference(c: Cursor, d: dict) -> None:
    d["mau_type_mode"] = c.u16()


def _adjust_props(c: Cursor, d: dict) -> None:
    d["adjust_properties"] = c.u16()


def adjust_domain_boundary(c: Cursor, d: dict) -> None:
    c.u16()
    if d["block_version_low"] == 0:
        d["domain_boundary"] = c.u32()
    else:
        d["domain_boundary_ingress"], d["domain_boundary_egress"] = c.u32(), c.u32()
    _adjust_props(c, d)


def adjust_multicast_boundary(c: Cursor, d: dict) -> None:
    c.u16()
    d["multicast_boundary"] = c.u32()
    _adjust_props(c, d)


def adjust_mau_type(c: Cursor, d: dict) -> None:
    c.u16()
    _mau(c, d)
    _adjust_props(c, d)


def adjust_link_state(c: Cursor, d: dict) -> None:
    c.u16()
    _link_state(c, d)
    _adjust_props(c, d)


def adjust_preamble_length(c: Cursor, d: dict) -> None:
    c.u16()
    v = d["preamble_length"] = c.u16()
    d["preamble_length_name"] = PREAMBLE_LENGTH.get(v, "reserved")
    _adjust_props(c, d)


def _mrp_domain(c: Cursor, d: dict) -> None:
    d["mrp_domain_uuid"] = c.uuid()
    r = d["mrp_role"] = c.u16()
    d["mrp_role_name"] = MRP_ROLES.get(r, "reserved")
    c.u16()
    d["mrp_length_domain_name"] = c.u8()
    d["mrp_domain_name"] = c.text(d["mrp_length_domain_name"])
    c.align4()


def mrp_interface_adjust_real(c: Cursor, d: dict) -> None:
    """PDInterfaceMrpDataAdjust 0x0211 / Real 0x0212, version 1.0: domain, role, name (the MRP
    manager/client parameter blocks follow as nested blocks)."""
    c.u16()
    _mrp_domain(c, d)


def mrp_interface_check(c: Cursor, d: dict) -> None:
    """PDInterfaceMrpDataCheck 0x0213, version 1.0."""
    c.u16()
    d["mrp_domain_uuid"] = c.uuid()
    v = d["mrp_check"] = c.u32()
    d.update(bits(v, MRP_CHECK))


def _mrp_instance(c: Cursor, d: dict) -> None:
    c.u8()
    d["mrp_MrpInstance"] = c.u8()


def mrp_instance_check(c: Cursor, d: dict) -> None:
    """MrpInstanceDataCheck 0x0233 (inside PDInterfaceMrpDataCheck version 1.1)."""
    _mrp_instance(c, d)
    d["mrp_domain_uuid"] = c.uuid()
    v = d["mrp_check"] = c.u32()
    d.update(bits(v, MRP_CHECK))


def mrp_instance_adjust_real(c: Cursor, d: dict) -> None:
    """MrpInstanceDataAdjust/Real 0x0231/0x0232: instance, then as the version 1.0 interface block."""
    _mrp_instance(c, d)
    _mrp_domain(c, d)


def pd_sync_data(c: Cursor, d: dict) -> None:
    """PDSyncData 0x0203 version 1.2: PTCP subdomain, intervals, PLL window, factors, master priorities."""
    if d["block_version_low"] != 2:
        return
    c.u16()
    d["ptcp_subdomain_id"] = c.uuid()
    for k in ("reserved_interval_begin", "reserved_interval_end", "pllwindow", "sync_send_factor"):
        d[k] = c.u32()
    for k in ("send_clock_factor", "ptcp_timeout_factor", "ptcp_takeover_timeout_factor",
              "ptcp_master_startup_time", "sync_properties"):
        d[k] = c.u16()
    d["ptcp_master_priority_1"], d["ptcp_master_priority_2"] = c.u8(), c.u8()
    d["ptcp_length_subdomain_name"] = c.u8()
    d["ptcp_subdomain_name"] = c.text(d["ptcp_length_subdomain_name"])


def pdir_global_data(c: Cursor, d: dict) -> None:
    """PDIRGlobalData 0x0206 (versions 1.1 and 1.2): IRDataID, bridge and port delays."""
    c.u16()
    d["ir_data_id"] = c.uuid()
    d["max_bridge_delay"] = c.u32()
    d["number_of_ports"] = c.u32()
    d["ports"] = []
    for _ in range(d["number_of_ports"]):
        p = {"max_port_tx_delay": c.u32(), "max_port_rx_delay": c.u32()}
        if d["block_version_low"] >= 2:
            p["max_line_rx_delay"], p["yellowtime"] = c.u32(), c.u32()
        d["ports"].append(p)


def pdir_frame_data(c: Cursor, d: dict) -> None:
    """PDIRFrameData 0x0207: per frame send offset, length, ratio, phase, FrameID, ports."""
    c.u16()
    if d["block_version_low"] >= 1:
        v = d["frame_data_properties"] = c.u32()
        d.update(bits(v, FRAME_DATA_PROPERTIES))
    frames = d["ir_frames"] = []
    while c.left() >= 17:
        f = {"frame_send_offset": c.u32(), "data_length": c.u16(), "reduction_ratio": c.u16(),
             "phase": c.u16(), "frame_id": c.u16(), "ethertype": c.u16(), "rx_port": c.u8()}
        f["frame_details"] = c.u8()
        f.update(bits(f["frame_details"], FRAME_DETAILS))
        f["nr_of_tx_port_groups"] = c.u8()
        f["tx_port_groups"] = []
        for _ in range(f["nr_of_tx_port_groups"]):
            g = {"tx_port_properties": c.u8()}
            g.update(bits(g["tx_port_properties"], TX_PORT_PROPERTIES))
            f["tx_port_groups"].append(g)
        c.align4()
        frames.append(f)


def _phase(v: int) -> dict:
    return {"value": v, **bits(v, TX_PHASE)}


def pdir_begin_end_data(c: Cursor, d: dict) -> None:
    """PDIRBeginEndData 0x0208: red period per port, its assignments and phases."""
    c.u16()
    d["start_of_red_frame_id"], d["end_of_red_frame_id"] = c.u16(), c.u16()
    d["number_of_ports"] = c.u32()
    d["ports"] = []
    for _ in range(d["number_of_ports"]):
        p = {"number_of_assignments": c.u32(), "assignments": []}
        for _ in range(p["number_of_assignments"]):
            a = {}
            for k in ("red_orange_period_begin_tx", "orange_period_begin_tx", "green_period_begin_tx",
                      "red_orange_period_begin_rx", "orange_period_begin_rx", "green_period_begin_rx"):
                a[k] = c.u32()
            p["assignments"].append(a)
        p["number_of_phases"] = c.u32()
        p["phases"] = [{"tx": _phase(c.u16()), "rx": _phase(c.u16())} for _ in range(p["number_of_phases"])]
        d["ports"].append(p)


def subframe_block(c: Cursor, d: dict) -> None:
    """SubframeBlock 0x022B: FrameID, SFIOCRProperties, then one SubframeData word per subframe."""
    d["frame_id"] = c.u16()
    v = d["SFIOCRProperties"] = c.u32()
    d.update(bits(v, SFIOCR_PROPERTIES))
    d["subframes"] = []
    while c.left() >= 4:
        w = c.u32()
        d["subframes"].append({"subframe_data": w, **bits(w, SUBFRAME_DATA)})


BODIES = {
    0x020F: pd_port_data_real, 0x0240: pd_interface_data_real, 0x0250: pd_interface_adjust,
    0x020A: check_peers, 0x020B: check_line_delay, 0x020C: check_mau_type, 0x021C: check_link_state,
    0x021E: check_sync_difference, 0x021F: check_mau_type_difference,
    0x0209: adjust_domain_boundary, 0x0210: adjust_multicast_boundary, 0x020E: adjust_mau_type,
    0x021B: adjust_link_state, 0x0226: adjust_preamble_length,
    0x0233: mrp_instance_check, 0x0203: pd_sync_data,
    0x0206: pdir_global_data, 0x0207: pdir_frame_data, 0x0208: pdir_begin_end_data, 0x022B: subframe_block,
}
# Bodies followed by nested blocks (version 1.0 of the MRP interface blocks: manager/client params)
# (version 1.1 of 0x0211/0x0213 is a container of MrpInstanceData blocks: pnio_cm.CONTAINERS)
PREFIX_BODIES = {(0x0211, 0): mrp_interface_adjust_real, (0x0212, 0): mrp_interface_adjust_real,
                 (0x0213, 0): mrp_interface_check,
                 (0x0231, 0): mrp_instance_adjust_real, (0x0232, 0): mrp_instance_adjust_real}
