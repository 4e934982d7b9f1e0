"""User parameter data, written by the controller at start-up: record 0xBF00 (Lika, SCANCON,
Hohner Exx58N, generic Encoder Profile V4.1) and the PS/PSM "Encoder Standard Parameter" record
0xFFFF, which has the same 31-byte layout (spec/records.md §5; behaviour.md §4.5, §9.9 #67-69).

Byte 0 holds six flag bits, bytes 1-8 MUPR and 9-16 TMR (8 bytes each, decoded big-endian: no
manual states the byte order, records.md §5.1), byte 17 max. master sign-of-life failures,
byte 18 velocity unit, bytes 19-30 reserved (Lika) or PSM's velocity reference.
Nothing here raises: a short record decodes as far as it goes and gets a BF00-LENGTH problem.
"""
from __future__ import annotations

import struct

RECORD_LEN = 31  # 000_37bf2397999f1108.txt:2171, 002_d69f444daf0f8af2.txt:1020
PROFILES = ("lika", "scancon", "hohner", "psm", "generic")

# Byte 0 bits (000_...:2174-2195, 001_9461bb7bc8c2767b.txt:666-676, 004_59bef5ae9f41db55.txt:641-651,
# 002_...:984-998). Bit 6 is PSM's encoder type (002_...:997-998), reserved for Lika.
FLAG_BITS = (("code_sequence", 0), ("class4", 1), ("preset_control", 2), ("scaling", 3),
             ("alarm_channel_control", 4), ("compat", 5))

# Velocity unit codes (000_...:2474-2480, 001_...:964-968, 004_...:800-804); PSM adds 4, printed
# garbled as "N"N4" (002_...:1004-1008), probably a normalised N2/N4 value.
VELOCITY_UNITS = {0: "steps/s", 1: "steps/100 ms", 2: "steps/10 ms", 3: "RPM"}
VELOCITY_UNITS_PSM = {**VELOCITY_UNITS, 4: "N2/N4 normalised to the velocity reference (garbled in the manual)"}

# What bit 0.2 means: Lika/SCANCON/PSM 0 = a preset affects G1_XIST1; the Hohner manual prints
# the inverse (004_...:720-722 vs 000_...:2272-2282, 001_...:794-796, 002_...:989-990).
PRESET_CONTROL_AFFECTS_AT_0 = {"lika": True, "scancon": True, "psm": True, "generic": True, "hohner": False}

# Alarm channel control meaning differs: Lika = encoder faults as channel diagnosis
# (000_...:2305-2317); SCANCON/Hohner = diagnostic telegram length (001_...:810-816, 004_...:742-746).
ALARM_CHANNEL_MEANING = {"lika": "encoder faults/warnings sent as channel diagnosis",
                         "generic": "encoder faults/warnings sent as channel diagnosis",
                         "scancon": "full diagnostic telegram (disabled: first 6 bytes only)",
                         "hohner": "full diagnostic telegram (disabled: first 6 bytes only)",
                         "psm": "not described"}

# Value ranges (behaviour.md §4.5; §9.9 #69): MUPR >= 1, TMR >= 2, SoL failures 1..255 (PSM 0..255),
# velocity unit 0..3 (PSM 0..4).
MIN_SOL = {"psm": 0}
MAX_VEL_UNIT = {"psm": 4}
# Profiles whose manual reserves bits 0.6-0.7 and bytes 19-30 as zero (000_...:2195, 2211);
# the SCANCON/Hohner manuals do not list them, PSM uses them.
CHECK_RESERVED = ("lika", "generic")


def _problem(rule: str, message: str) -> dict:
    return {"rule": rule, "message": message}


def decode_bf00(data: bytes, profile: str = "generic", *, st_phys: int | None = None,
                tot_phys: int | None = None) -> dict:
    """Decode user parameter data for ``profile``; ``st_phys``/``tot_phys`` (hardware counts per
    revolution / total), when known, tighten the MUPR/TMR range checks."""
    if profile not in PROFILES:
        profile = "generic"
    n = len(data)
    out: dict = {"profile": profile, "length": n, "problems": []}
    probs = out["problems"]
    if n != RECORD_LEN:
        probs.append(_problem("BF00-LENGTH", f"user parameter record is {n} bytes, expected {RECORD_LEN}"))
    if n >= 1:
        b0 = data[0]
        out["flags"] = b0
        for name, bit in FLAG_BITS:
            out[name] = b0 >> bit & 1
        out["direction"] = out["code_sequence"]
        out["direction_name"] = "CCW" if out["code_sequence"] else "CW"
        affects = (out["preset_control"] == 0) == PRESET_CONTROL_AFFECTS_AT_0[profile]
        out["preset_affects_xist1"] = affects
        out["compat_name"] = ("V4.1 (compatibility mode disabled)" if out["compat"]
                              else "V3.1 compatibility mode enabled")
        out["alarm_channel_meaning"] = ALARM_CHANNEL_MEANING[profile]
        if profile == "psm":
            out["encoder_type"] = b0 >> 6 & 1
            out["encoder_type_name"] = "linear" if out["encoder_type"] else "rotary"
        out["reserved_bits"] = b0 >> (7 if profile == "psm" else 6)
    if n >= 17:
        mh, ml, th, tl = struct.unpack_from(">IIII", data, 1)
        out["mupr"] = mh << 32 | ml
        out["tmr"] = th << 32 | tl
        if profile == "psm":  # PSM prints High/Low UINT32 halves (002_...:999-1002)
            out.update(mupr_high=mh, mupr_low=ml, tmr_high=th, tmr_low=tl)
        if out["mupr"]:
            q, r = divmod(out["tmr"], out["mupr"])
            out["revolutions"] = q if r == 0 else out["tmr"] / out["mupr"]
            # non-power-of-two revolutions: Lika "red zone", SCANCON/Hohner endless shaft
            # (000_...:2421-2433, 001_...:985-999); a warning, not an error
            out["revolutions_power_of_two"] = r == 0 and q > 0 and q & (q - 1) == 0
        if out["mupr"] < 1 or (st_phys is not None and out["mupr"] > st_phys):
            probs.append(_problem("BF00-VALUE-OUT-OF-RANGE",
                                  f"measuring units per revolution {out['mupr']} outside [1, "
                                  f"{st_phys if st_phys is not None else 'hardware resolution'}]"))
        if out["tmr"] < 2 or (tot_phys is not None and out["tmr"] > tot_phys):
            probs.append(_problem("BF00-VALUE-OUT-OF-RANGE",
                                  f"total measuring range {out['tmr']} outside [2, "
                                  f"{tot_phys if tot_phys is not None else 'total hardware resolution'}]"))
    if n >= 18:
        out["max_master_sol_failures"] = data[17]
        if data[17] < MIN_SOL.get(profile, 1):
            probs.append(_problem("BF00-VALUE-OUT-OF-RANGE",
                                  f"max. master sign-of-life failures {data[17]} outside [1, 255]"))
    if n >= 19:
        vu = data[18]
        table = VELOCITY_UNITS_PSM if profile == "psm" else VELOCITY_UNITS
        out["velocity_unit"] = vu
        out["velocity_unit_name"] = table.get(vu, f"undefined ({vu})")
        if vu > MAX_VEL_UNIT.get(profile, 3):
            probs.append(_problem("BF00-VALUE-OUT-OF-RANGE",
                                  f"velocity unit {vu} outside [0, {MAX_VEL_UNIT.get(profile, 3)}]"))
    if profile == "psm" and n >= 23:
        out["velocity_reference"] = struct.unpack_from(">f", data, 19)[0]  # Float32 (002_...:1009)
    if n > 19:
        out["reserved_bytes"] = data[19:].hex()
    if profile in CHECK_RESERVED:
        bad = []
        if out.get("reserved_bits"):
            bad.append(f"byte 0 bits 6-7 = {out['reserved_bits']:#x}")
        nz = [19 + i for i, b in enumerate(data[19:31]) if b]
        if nz:
            bad.append("bytes " + ", ".join(map(str, nz)) + " non-zero")
        if bad:
            probs.append(_problem("BF00-RESERVED-NONZERO", "reserved user parameter bits/bytes set: " + "; ".join(bad)))
    return out


# ---- vendor records 0x1000 / 0x1001 (records.md §5.5) -----------------------------------------
def decode_vendor_1000(data: bytes, profile: str) -> dict:
    """0x1000: SCANCON velocity filter (1 byte, codes unknown, 001_...:686, 970-983); Hohner lists
    "Preset value, 1 octet" (004_...:661, probably a copy error); PSM OEM sensor configuration
    (2 bytes: singleturn bits, multiturn bits; 33 = real configuration, 002_...:1049-1083)."""
    out: dict = {"length": len(data)}
    if profile == "psm" and len(data) >= 2:
        out["singleturn_bits"], out["multiturn_bits"] = data[0], data[1]
        out["uses_real_configuration"] = data[0] == 33 and data[1] == 33
    elif profile in ("scancon", "hohner") and len(data) >= 1:
        out["velocity_filter" if profile == "scancon" else "value"] = data[0]
    return out


# PSM 0x1001 byte 0 bit fields (002_...:1022-1047): (name, shift, width, value names)
PARAM_CONTROL = (("init_control", 0, 2, {0: "PRM", 1: "NV-RAM"}),
                 ("write_protect", 2, 2, {0: "write all", 1: "read only", 2: "write controller", 3: "write supervisor"}),
                 ("p65005_write_protect", 5, 1, {0: "write all", 1: "read only"}),
                 ("reset_control_write_protect", 6, 1, {0: "write all", 1: "read only"}))


def decode_param_control(data: bytes) -> dict:
    out: dict = {"length": len(data)}
    if data:
        for name, shift, width, names in PARAM_CONTROL:
            v = data[0] >> shift & ((1 << width) - 1)
            out[name] = v
            out[name + "_name"] = names.get(v, "not used")
    return out
