"""Connect and record blocks beyond the AR core: DiagnosisData (channel, extended channel and
qualified diagnosis), Expected/RealIdentificationData, the PROFIsafe FSParameterBlock, SRInfoBlock
and ARVendorBlock.

Field names are tshark 4.0's (``pn_io.<name>``; value strings from ``tshark -G values``), mapped in
tests/tshark_map/pnio_cm.json. Diagnosis entries share their decoder with the alarm items
(pndiss/proto/alarm.py: one table of channel error types for both).
"""
from __future__ import annotations

from .cmblock import Cursor, bits

FS_PARAMETER_MODE = {0: "OFF", 1: "ON", 2: "Reserved", 3: "Reserved"}
SR_PROPERTIES = (("sr_properties_InputValidOnBackupAR", 0x1), ("sr_properties_Reserved_1", 0x2),
                 ("sr_properties_Mode", 0x4), ("sr_properties_Reserved_2", 0xFFF8),
                 ("sr_properties_Reserved_3", 0xFFFF0000))


def diagnosis_data(c: Cursor, d: dict) -> None:
    """DiagnosisData 0x0010 (records 0x800A/0x800C/0xC00C/0xE00C/0xF00C ...): [API,] slot, subslot,
    ChannelNumber, ChannelProperties, UserStructureIdentifier, then the entries of that USI until
    the block ends (tshark dissect_DiagnosisData_block)."""
    from . import alarm  # here: alarm imports pnio_cm, which imports this module
    if d["block_version_low"] >= 1:
        d["api"] = c.u32()
    d["slot_nr"] = c.u16()
    d["subslot_nr"] = c.u16()
    d["channel_number"] = c.u16()
    props = c.u16()
    p = d["channel_properties"] = {"value": props, **{k: (props & m) >> s for k, m, s in alarm.CHANNEL_PROPERTY_BITS}}
    p["specifier_name"] = alarm.CHANNEL_SPECIFIER[p["specifier"]]
    p["maintenance_name"] = alarm.CHANNEL_MAINTENANCE[p["maintenance"]]
    usi = d["user_structure_identifier"] = c.u16()
    d["usi_name"] = alarm.usi_name(usi)
    size = alarm.USI_ITEM_SIZES.get(usi) if usi in (0x8000, 0x8002, 0x8003) else None
    if size is None:  # manufacturer specific (USI < 0x8000) or an item tshark does not split: bytes
        o = c.take(c.left())
        d["data"] = c.b[o:c.end].hex()
        return
    d["items"] = []
    while c.left() >= size:
        o = c.take(size)
        d["items"].append(alarm.channel_item(c.b, o, usi))
    if c.left():
        o = c.take(c.left())
        d["trailing"] = c.b[o:c.end].hex()


def identification_data(c: Cursor, d: dict) -> None:
    """Expected/RealIdentificationData 0x0012/0x0013: version 1.0 lists the slots of API 0, 1.1
    lists APIs, each with slots (module ident) and subslots (submodule ident)."""
    if d["block_version_low"] >= 1:
        d["number_of_apis"] = c.u16()
        n_api = d["number_of_apis"]
    else:
        n_api = 1
    d["apis"] = []
    for _ in range(n_api):
        a = {"api": c.u32()} if d["block_version_low"] >= 1 else {}
        a["number_of_slots"] = c.u16()
        a["slots"] = []
        for _ in range(a["number_of_slots"]):
            s = {"slot_nr": c.u16(), "module_ident_number": c.u32(), "number_of_subslots": c.u16()}
            s["subslots"] = [{"subslot_nr": c.u16(), "submodule_ident_number": c.u32()}
                             for _ in range(s["number_of_subslots"])]
            a["slots"].append(s)
        d["apis"].append(a)


def fs_parameter(c: Cursor, d: dict) -> None:
    """FSParameterBlock 0x0601 (inside ARFSUBlock of a Connect, or record 0xE050): fast start-up mode
    and the UUID of the parameter set."""
    c.u16()
    m = d["fs_parameter_mode"] = c.u32()
    d["fs_parameter_mode_name"] = FS_PARAMETER_MODE.get(m & 0x3, "Reserved")
    d["fs_parameter_uuid"] = c.uuid()


def sr_info(c: Cursor, d: dict) -> None:
    """SRInfoBlock 0x010A (system redundancy Connect)."""
    d["RedundancyDataHoldFactor"] = c.u16()
    v = d["sr_properties"] = c.u32()
    d.update(bits(v, SR_PROPERTIES))


def ar_vendor(c: Cursor, d: dict) -> None:
    """ARVendorBlockReq/Res 0x0108/0x8108: APStructureIdentifier, API, vendor data (kept as hex)."""
    d["ap_structure_identifier"] = c.u16()
    d["api"] = c.u32()
    o = c.take(c.left())
    d["data"] = c.b[o:c.end].hex()


BODIES = {0x0010: diagnosis_data, 0x0012: identification_data, 0x0013: identification_data,
          0x0601: fs_parameter, 0x010A: sr_info, 0x0108: ar_vendor, 0x8108: ar_vendor}
