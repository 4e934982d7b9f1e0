"""PN-DCP value tables (spec/wire.md §3; tshark 4.0 ``packet-pn-dcp.c`` value strings), declared
once for the header (dcp.py), the block decoders (dcp_blocks.py) and the naming rules (dcp_rules.py).
"""
from __future__ import annotations

LAYER = "pn_dcp"

# ServiceID / ServiceType (spec/wire.md §3.1; tshark pn_dcp.service_id / service_type)
SERVICES = {0: "reserved", 1: "Manufacturer specific", 2: "Manufacturer specific",
            3: "Get", 4: "Set", 5: "Identify", 6: "Hello"}
GET, SET, IDENTIFY, HELLO = 3, 4, 5, 6
SERVICE_TYPES = {0: "Request", 1: "Response Success", 5: "Response - Request not supported"}

# Options (spec/wire.md §3.3; tshark pn_dcp.option). 0x80-0xFE: manufacturer specific.
OPTIONS = {0: "Reserved", 1: "IP", 2: "Device properties", 3: "DHCP", 4: "Reserved",
           5: "Control", 6: "Device Initiative", 7: "TSN Domain", 0xFF: "All Selector"}

# tshark gives every option's suboption byte its own field (pn_dcp.suboption_ip, ..._device,
# ...); options it has no table for use pn_dcp.suboption_manuf (tshark 4.0 dissect_PNDCP_Option).
SUBOPTION_FIELD = {1: "suboption_ip", 2: "suboption_device", 3: "suboption_dhcp",
                   5: "suboption_control", 6: "suboption_deviceinitiative", 7: "suboption_tsn",
                   0xFF: "suboption_all"}

# Suboption names per option (spec/wire.md §3.3-3.4; tshark value tables)
SUBOPTIONS = {
    1: {1: "MAC address", 2: "IP parameter", 3: "Full IP suite"},
    2: {1: "Manufacturer specific (Type of Station)", 2: "Name of Station", 3: "Device ID",
        4: "Device Role", 5: "Device Options", 6: "Alias Name", 7: "Device Instance",
        8: "OEM Device ID", 10: "RSI Properties"},
    3: {12: "Host name", 43: "Vendor specific", 54: "Server identifier",
        55: "Parameter request list", 60: "Class identifier", 61: "DHCP client identifier",
        81: "FQDN, Fully Qualified Domain Name", 97: "UUID/GUID-based Client",
        255: "Control DHCP for address resolution"},
    5: {1: "Start Transaction", 2: "End Transaction", 3: "Signal", 4: "Response",
        5: "Reset Factory Settings", 6: "Reset to Factory"},
    6: {1: "Device Initiative"},
    7: {1: "TSN Domain Name", 2: "NME Manager", 3: "NME Parameter UUID", 4: "NME Agent",
        5: "CIM Interface"},
    0xFF: {0xFF: "ALL Selector"},
}

# Options whose blocks carry BlockInfo/BlockQualifier (tshark 4.0: IP only for its three known
# suboptions, Device/DHCP/DeviceInitiative/TSN always; Control, All, manufacturer never).
PREFIXED = {2, 3, 6, 7}

# IP-parameter BlockInfo (spec/wire.md §3.2; bit 7 = address conflict detected)
IP_BLOCK_INFO = {0: "IP not set", 1: "IP set", 2: "IP set by DHCP",
                 0x80: "IP not set (address conflict detected)",
                 0x81: "IP set (address conflict detected)",
                 0x82: "IP set by DHCP (address conflict detected)"}
BLOCK_QUALIFIER = {0: "Use the value temporary", 1: "Save the value permanent"}
# Reset to Factory qualifier (spec/wire.md §3.4, tshark pn_dcp.block_qualifier_reset)
RESET_QUALIFIER = {2: "Reset application data", 3: "Reset application data",
                   4: "Reset communication parameter", 5: "Reset communication parameter",
                   6: "Reset engineering parameter", 7: "Reset engineering parameter",
                   8: "Resets all stored data", 9: "Resets all stored data",
                   0x0A: "Reset engineering parameter", 0x0B: "Reset engineering parameter",
                   0x10: "Resets all stored data in the IOD or IOC to its factory values",
                   0x11: "Resets all stored data in the IOD or IOC to its factory values",
                   0x12: "Reset and restore data", 0x13: "Reset and restore data"}
BLOCK_ERRORS = {0: "Ok", 1: "Option unsupported", 2: "Suboption unsupported or no DataSet available",
                3: "Suboption not set", 4: "Resource error", 5: "SET not possible by local reasons",
                6: "In operation, SET not possible"}
SIGNAL_VALUES = {0x0100: "Flash once"}
# DeviceRoleDetails bits (spec/wire.md §3.7)
ROLE_BITS = ((0x01, "IO-Device"), (0x02, "IO-Controller"), (0x04, "IO-Multidevice"),
             (0x08, "PN-Supervisor"))
# RSI properties bits (spec/wire.md §3.3; tshark ..._rsi_properties_value.bit0-5)
RSI_BITS = ("ip_stack", "clrpc_interface", "rsi_ar_interface", "rsi_ar_read_implicit",
            "rsi_cim_interface", "rsi_cim_read_implicit")
DHCP_CONTROL = {0: "Don't use DHCP", 1: "Don't use DHCP, DHCP options reset to factory values",
                2: "Use DHCP with the given set of DHCP options"}
DEVICE_INITIATIVE = {0: "No Hello after power on", 1: "Hello after power on"}
