"""PNIO-CM Connect, Control and Release blocks: AR, IOCR, AlarmCR, ExpectedSubmodule, ModuleDiff,
ARServer, IRInfo, the control blocks, and the I&M0FilterData blocks of record 0xF840.

Field names are tshark 4.0's (packet-dcerpc-pn-io.c; spec/wire.md §6.3-§6.8), mapped one to one in
tests/tshark_map/pnio_cm.json. Split out of pnio_cm.py (which keeps the NDR header, the PNIO status,
the read/write headers and the block walker) by block family, as pdrecords.py and cmblocks.py.
"""
from __future__ import annotations

from .cmblock import Cursor as _Cur, bits as _bits


# bit tables, spec/wire.md §6.3-§6.8 (tshark field names)
AR_PROPERTIES = (("ar_properties_state", 0x7), ("ar_properties_supervisor_takeover_allowed", 0x8),
                 ("ar_properties_parameterization_server", 0x10), ("ar_properties_reserved_1", 0xE0),
                 ("ar_properties_device_access", 0x100), ("ar_properties_companion_ar", 0x600),
                 ("ar_properties_acknowledge_companion_ar", 0x800), ("ar_properties_reserved", 0x0FFFF000),
                 ("ar_properties_time_aware_system", 0x10000000),
                 ("ar_properties_combined_object_container", 0x20000000),
                 ("ar_properties_StartupMode", 0x40000000),
                 ("ar_properties_pull_module_alarm_allowed", 0x80000000))
IOCR_PROPERTIES = (("iocr_properties_rtclass", 0xF), ("iocr_properties_reserved1", 0x7F0),
                   ("iocr_properties_media_redundancy", 0x800), ("iocr_properties_reserved2", 0xFFF000),
                   ("iocr_properties_reserved3", 0xF000000),
                   ("iocr_properties_fast_forwarding_mac_adr", 0x20000000),
                   ("iocr_properties_distributed_subframe_watchdog", 0x40000000),
                   ("iocr_properties_full_subframe_structure", 0x80000000))
ALARMCR_PROPERTIES = (("alarmcr_properties_priority", 0x1), ("alarmcr_properties_transport", 0x2),
                      ("alarmcr_properties_reserved", 0xFFFFFFFC))
SUBMODULE_PROPERTIES = (("submodule_properties_type", 0x3), ("submodule_properties_shared_input", 0x4),
                        ("submodule_properties_reduce_input_submodule_data_length", 0x8),
                        ("submodule_properties_reduce_output_submodule_data_length", 0x10),
                        ("submodule_properties_discard_ioxs", 0x20), ("submodule_properties_reserved", 0xFFC0))
SUBMODULE_STATE = (("submodule_state_format_indicator", 0x8000), ("submodule_state_ident_info", 0x7800),
                   ("submodule_state_ar_info", 0x0780), ("submodule_state_fault", 0x40),
                   ("submodule_state_maintenance_demanded", 0x20),
                   ("submodule_state_maintenance_required", 0x10), ("submodule_state_advice", 0x8),
                   ("submodule_state_add_info", 0x7))
CONTROL_COMMAND = (("control_command_prmend", 0x1), ("control_command_applready", 0x2),
                   ("control_command_release", 0x4), ("control_command_done", 0x8),
                   ("control_command_ready_for_companion", 0x10),
                   ("control_command_ready_for_rt_class3", 0x20), ("control_command_prmbegin", 0x40))
APPL_READY = (("control_block_properties_appl_ready_bit0", 0x1),
              ("control_block_properties_appl_ready_bit1", 0x2),
              ("control_block_properties_appl_ready_otherbits", 0xFFFC))
IOCR_TYPES = {1: "input", 2: "output", 3: "multicast provider", 4: "multicast consumer"}
AR_TYPES = {0x0001: "IO Controller AR", 0x0003: "IOCARCIR", 0x0006: "IO Supervisor AR",
            0x0010: "IO Controller AR (RT_CLASS_3)", 0x0020: "IO Controller AR (sysred/CiR)"}
DATA_DESCRIPTION = {1: "input", 2: "output"}


# --- block bodies ---------------------------------------------------------------------------
def _ar_req(c: _Cur, d: dict) -> None:
    d["artype_req"] = c.u16()  # tshark's pn_io.artype_req is a label without the value (quirk)
    d["ar_type_name"] = AR_TYPES.get(d["artype_req"], "reserved")
    d["ar_uuid"] = c.uuid()
    if d["artype_req"] == 0x0020:
        # ARType 0x0020 (sysred/CiR): tshark shows the ARUUID again as Discriminator/ConfigID/Selector
        b = c.b[c.o - 16:c.o]
        d["ar_uuid_sysred"] = d["ar_uuid"]
        d["ar_discriminator"] = b[:6].hex()
        d["ar_configid"] = b[6:14].hex()
        sel = (b[14] << 8) | b[15]
        d["ar_selector"] = sel
        d["ar_arnumber"], d["ar_arresource"], d["ar_arreserved"] = sel & 0x7, (sel >> 3) & 0x3, sel >> 5
    d["session_key"] = c.u16()
    d["cminitiator_mac_add"] = c.mac()
    d["cminitiator_uuid"] = c.uuid()
    d["ar_properties"] = c.u32()
    d.update(_bits(d["ar_properties"], AR_PROPERTIES))
    d["cminitiator_activitytimeoutfactor"] = c.u16()
    d["cminitiator_udprtport"] = c.u16()
    n = d["station_name_length"] = c.u16()
    d["cminitiator_station_name"] = c.text(n)


def _ar_res(c: _Cur, d: dict) -> None:
    d["ar_type"] = c.u16()
    d["ar_type_name"] = AR_TYPES.get(d["ar_type"], "reserved")
    d["ar_uuid"] = c.uuid()
    d["session_key"] = c.u16()
    d["cmresponder_macadd"] = c.mac()
    d["cmresponder_udprtport"] = c.u16()


def _iocr_req(c: _Cur, d: dict) -> None:
    d["iocr_type"] = c.u16()
    d["direction"] = IOCR_TYPES.get(d["iocr_type"], "reserved")
    d["iocr_reference"] = c.u16()
    d["lt"] = c.u16()
    d["iocr_properties"] = c.u32()
    d.update(_bits(d["iocr_properties"], IOCR_PROPERTIES))
    for k in ("data_length", "frame_id", "send_clock_factor", "reduction_ratio", "phase", "sequence"):
        d[k] = c.u16()
    d["frame_send_offset"] = c.u32()
    for k in ("watchdog_factor", "data_hold_factor", "iocr_tag_header"):
        d[k] = c.u16()
    d["iocr_multicast_mac_add"] = c.mac()
    d["number_of_apis"] = c.u16()
    apis = d["apis"] = []
    for _ in range(d["number_of_apis"]):
        a = {"api": c.u32(), "number_of_io_data_objects": c.u16()}
        a["io_data_objects"] = [{"slot_nr": c.u16(), "subslot_nr": c.u16(),
                                 "io_data_object_frame_offset": c.u16()}
                                for _ in range(a["number_of_io_data_objects"])]
        a["number_of_iocs"] = c.u16()
        a["iocs"] = [{"slot_nr": c.u16(), "subslot_nr": c.u16(), "iocs_frame_offset": c.u16()}
                     for _ in range(a["number_of_iocs"])]
        apis.append(a)


def _iocr_res(c: _Cur, d: dict) -> None:
    d["iocr_type"] = c.u16()
    d["direction"] = IOCR_TYPES.get(d["iocr_type"], "reserved")
    d["iocr_reference"] = c.u16()
    d["frame_id"] = c.u16()


def _alarmcr_req(c: _Cur, d: dict) -> None:
    d["alarmcr_type"] = c.u16()
    d["lt"] = c.u16()
    d["alarmcr_properties"] = c.u32()
    d.update(_bits(d["alarmcr_properties"], ALARMCR_PROPERTIES))
    for k in ("rta_timeoutfactor", "rta_retries", "localalarmref", "maxalarmdatalength",
              "alarmcr_tagheaderhigh", "alarmcr_tagheaderlow"):
        d[k] = c.u16()


def _alarmcr_res(c: _Cur, d: dict) -> None:
    d["alarmcr_type"] = c.u16()
    d["localalarmref"] = c.u16()
    d["maxalarmdatalength"] = c.u16()


def _expected_sub(c: _Cur, d: dict) -> None:
    d["number_of_apis"] = c.u16()
    apis = d["apis"] = []
    for _ in range(d["number_of_apis"]):
        a = {"api": c.u32(), "slot_nr": c.u16(), "module_ident_number": c.u32(),
             "module_properties": c.u16(), "number_of_submodules": c.u16(), "submodules": []}
        for _ in range(a["number_of_submodules"]):
            s = {"subslot_nr": c.u16(), "submodule_ident_number": c.u32(), "submodule_properties": c.u16()}
            s.update(_bits(s["submodule_properties"], SUBMODULE_PROPERTIES))
            # one Input description for types 0 and 1, Output for 2, both for 3 (spec/wire.md §6.6)
            kinds = {0: (1,), 1: (1,), 2: (2,), 3: (1, 2)}[s["submodule_properties_type"]]
            s["data_descriptions"] = []
            for _k in kinds:
                dd = c.u16()
                s["data_descriptions"].append({"data_description": dd, "direction": DATA_DESCRIPTION.get(dd),
                                               "submodule_data_length": c.u16(),
                                               "length_iocs": c.u8(), "length_iops": c.u8()})
            a["submodules"].append(s)
        apis.append(a)


def _module_diff(c: _Cur, d: dict) -> None:
    d["number_of_apis"] = c.u16()
    apis = d["apis"] = []
    for _ in range(d["number_of_apis"]):
        a = {"api": c.u32(), "number_of_modules": c.u16(), "modules": []}
        for _ in range(a["number_of_modules"]):
            m = {"slot_nr": c.u16(), "module_ident_number": c.u32(), "module_state": c.u16(),
                 "number_of_submodules": c.u16(), "submodules": []}
            for _ in range(m["number_of_submodules"]):
                s = {"subslot_nr": c.u16(), "submodule_ident_number": c.u32(), "submodule_state": c.u16()}
                s.update(_bits(s["submodule_state"], SUBMODULE_STATE))
                m["submodules"].append(s)
            a["modules"].append(m)
        apis.append(a)


def _ar_server(c: _Cur, d: dict) -> None:
    n = d["station_name_length"] = c.u16()
    d["cminitiator_station_name"] = c.text(n)  # tshark labels the device's name so (quirk)


def _control(c: _Cur, d: dict) -> None:
    d["reserved16"] = [c.u16()]
    d["ar_uuid"] = c.uuid()
    d["session_key"] = c.u16()
    d["reserved16"].append(c.u16())
    cmd = d["control_command"] = c.u16()
    d.update(_bits(cmd, CONTROL_COMMAND))
    props = c.u16()
    d["command"] = [n[len("control_command_"):] for n, m in CONTROL_COMMAND if cmd & m]
    if cmd & 0x2:  # tshark shows the properties as ApplicationReady bits then
        d["control_block_properties_appl_ready"] = props
        d.update(_bits(props, APPL_READY))
    else:
        d["control_block_properties"] = props


def _im_filter(c: _Cur, d: dict) -> None:
    # I&M0FilterData (records 0xF840), tshark dissect_IandM0FilterData_block
    d["number_of_apis"] = c.u16()
    apis = d["apis"] = []
    for _ in range(d["number_of_apis"]):
        a = {"api": c.u32(), "number_of_modules": c.u16(), "modules": []}
        for _ in range(a["number_of_modules"]):
            m = {"slot_nr": c.u16(), "module_ident_number": c.u32(), "number_of_submodules": c.u16(),
                 "submodules": []}
            for _ in range(m["number_of_submodules"]):
                m["submodules"].append({"subslot_nr": c.u16(), "submodule_ident_number": c.u32()})
            a["modules"].append(m)
        apis.append(a)


def _ir_info(c: _Cur, d: dict) -> None:
    # IRInfoBlock (RT_CLASS_3 Connect), tshark dissect_IRInfo_block: which IOCR sits where in DFP frames
    c.u16()
    d["IRData_uuid"] = c.uuid()
    c.u16()
    d["number_of_iocrs"] = c.u16()
    d["iocrs"] = [{"iocr_reference": c.u16(), "subframe_offset": c.u16(), "subframe_data": c.u32()}
                  for _ in range(d["number_of_iocrs"])]


BODIES = {
    0x0101: _ar_req, 0x8101: _ar_res, 0x0102: _iocr_req, 0x8102: _iocr_res,
    0x0103: _alarmcr_req, 0x8103: _alarmcr_res, 0x0104: _expected_sub, 0x8104: _module_diff,
    0x8106: _ar_server, 0x0109: _ir_info, 0x0030: _im_filter, 0x0031: _im_filter, 0x0032: _im_filter,
    **{t: _control for t in (0x0110, 0x0111, 0x0112, 0x0113, 0x0114, 0x0116, 0x0117,
                             0x8110, 0x8111, 0x8112, 0x8113, 0x8114, 0x8116, 0x8117)},
}
