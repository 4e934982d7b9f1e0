-- pndiss.lua: PROFINET rotary encoder (PROFIdrive Encoder Profile V4.x) telegrams, records and
-- violation rules for Wireshark/tshark >= 4.0 (Lua 5.2). Field names and values match the Python
-- core (pndiss): pndiss.<signal>, pndiss.<signal>.<bit>, pndiss.param.*, pndiss.bf00.*, pndiss.rule.
--
-- Tables (telegram layouts, bit maps, names, rule catalogue) are generated from the Python tables
-- into pndiss_tables.lua by tools/gen_lua.py; this file holds only logic.
--
-- Structure:
--   1. tables and fields           4. Connect learning (postdissector, field extractors)
--   2. preferences                 5. records: 0xB02E/0xB02F pairing, 0xBF00, I&M0
--   3. maps: Connect > map > none  6. cyclic heuristic on the pn_io list + rules (first pass only)

local bit = bit32 or bit  -- Lua 5.2 has bit32; some builds ship the BitOp 'bit' module only

-- 1. tables -------------------------------------------------------------------------------------
local function script_dir()
    local src = debug.getinfo(1, "S").source
    return (src:sub(1, 1) == "@" and src:sub(2):match("^(.*[/\\])")) or ""
end
-- Wireshark's dofile only searches its own folders: read the tables next to this file ourselves
local function load_tables()
    local path = script_dir() .. "pndiss_tables.lua"
    local fh = assert(io.open(path, "rb"), "pndiss: cannot open " .. path)
    local text = fh:read("*a")
    fh:close()
    return assert(load(text, "@" .. path, "t", {}))()
end
local T = load_tables()

local pndiss = Proto("pndiss", "PROFINET encoder (pndiss)")
local F = {}          -- abbrev -> ProtoField
local fields = pndiss.fields

local function field(abbrev, ctor, name, ...)
    local f = ctor(abbrev, name, ...)
    F[abbrev] = f
    fields[#fields + 1] = f
    return f
end

-- per-object header fields (telegram event keys)
field("pndiss.telegram", ProtoField.uint16, "Telegram")
field("pndiss.direction", ProtoField.string, "Direction")
field("pndiss.telegram_source", ProtoField.string, "Telegram from")
field("pndiss.api", ProtoField.uint32, "API", base.HEX)
field("pndiss.slot", ProtoField.uint16, "Slot")
field("pndiss.subslot", ProtoField.uint16, "Subslot", base.HEX)
field("pndiss.iops", ProtoField.uint8, "IOPS", base.HEX)
field("pndiss.judged", ProtoField.bool, "Judged (DataValid, RUN, IOPS good)")
field("pndiss.profile", ProtoField.string, "Device profile")
field("pndiss.station", ProtoField.string, "Station")

-- signals: size/sign from the table; control/status words in hex, values in decimal
local UCTOR = {[1] = ProtoField.uint8, [2] = ProtoField.uint16, [4] = ProtoField.uint32, [8] = ProtoField.uint64}
local SCTOR = {[1] = ProtoField.int8, [2] = ProtoField.int16, [4] = ProtoField.int32, [8] = ProtoField.int64}
local sig_names = {}
for name in pairs(T.signals) do sig_names[#sig_names + 1] = name end
table.sort(sig_names)
for _, name in ipairs(sig_names) do
    local s = T.signals[name]
    local word = T.bitmaps[name] ~= nil and s.size <= 4
    field("pndiss." .. name, (s.signed and SCTOR or UCTOR)[s.size], s.title, (word and not s.signed) and base.HEX or base.DEC)
end
-- bits: one field per (signal, bit name); profile variants share the name (positions may differ)
for _, sig in ipairs(sig_names) do
    for _, b in ipairs(T.bitmaps[sig] or {}) do
        local ab = "pndiss." .. sig .. "." .. b.name
        if not F[ab] then field(ab, ProtoField.uint8, b.title) end
    end
end
-- telegram event "xist2_error": G1_XIST2 holds an error code while g1_zsw.sensor_error = 1 (cyclic.md §9)
field("pndiss.xist2_error.code", ProtoField.uint32, "G1_XIST2 error code", base.HEX)
field("pndiss.xist2_error.text", ProtoField.string, "G1_XIST2 error")

-- records / parameters (record and param events)
field("pndiss.record.op", ProtoField.string, "Record access")
field("pndiss.record.index", ProtoField.uint16, "Record index", base.HEX)
field("pndiss.record.index_name", ProtoField.string, "Record index name")
field("pndiss.record.length", ProtoField.uint32, "Record data length")
field("pndiss.param.kind", ProtoField.string, "Parameter access")
field("pndiss.param.request_ref", ProtoField.uint8, "Request reference", base.HEX)
field("pndiss.param.request_id", ProtoField.string, "Request ID")
field("pndiss.param.response_id", ProtoField.uint8, "Response ID", base.HEX)
field("pndiss.param.axis", ProtoField.uint8, "Axis / DO-ID")
field("pndiss.param.request_frame", ProtoField.framenum, "Request in frame")
field("pndiss.param.ok", ProtoField.bool, "Positive response")
field("pndiss.param.pnu", ProtoField.uint16, "Parameter number")
field("pndiss.param.subindex", ProtoField.uint16, "Subindex")
field("pndiss.param.name", ProtoField.string, "Parameter name")
field("pndiss.param.format", ProtoField.uint8, "Format", base.HEX)
field("pndiss.param.value", ProtoField.string, "Value")
field("pndiss.param.value_text", ProtoField.string, "Value (text, octets or float)")
field("pndiss.param.error_code", ProtoField.uint16, "Error number", base.HEX)
field("pndiss.param.error", ProtoField.string, "Error")
field("pndiss.param.pairing", ProtoField.string, "Pairing problem")
local BF00_INT = {"flags", "code_sequence", "direction", "class4", "preset_control", "scaling",
                  "alarm_channel_control", "compat", "max_master_sol_failures", "velocity_unit"}
for _, n in ipairs(BF00_INT) do field("pndiss.bf00." .. n, ProtoField.uint8, n) end
field("pndiss.bf00.mupr", ProtoField.uint64, "Measuring units per revolution")
field("pndiss.bf00.tmr", ProtoField.uint64, "Total measuring range")
field("pndiss.bf00.velocity_unit_name", ProtoField.string, "Velocity unit")
field("pndiss.bf00.problem", ProtoField.string, "Problem")
field("pndiss.im0.profile_id", ProtoField.uint16, "I&M0 profile ID", base.HEX)
field("pndiss.im0.profile_name", ProtoField.string, "I&M0 profile")
field("pndiss.rule", ProtoField.string, "Violated rule")

-- expert infos: one per catalogue rule the plugin implements (filterable: pndiss.rule.<ID>)
local SEV = {error = expert.severity.ERROR, warning = expert.severity.WARN, info = expert.severity.NOTE}
local E = {}
for _, id in ipairs(T.plugin_rules) do
    local r = T.rules[id]
    E[id] = ProtoExpert.new("pndiss.rule." .. id, id .. " (" .. r.section .. ")", expert.group.PROTOCOL, SEV[r.severity])
end
E.malformed = ProtoExpert.new("pndiss.malformed", "pndiss: malformed", expert.group.MALFORMED, expert.severity.WARN)
local experts = {}
for _, e in pairs(E) do experts[#experts + 1] = e end
pndiss.experts = experts

-- 2. preferences ---------------------------------------------------------------------------------
pndiss.prefs.map = Pref.string("Manual map", "",
    "FrameID[:input|output]=telegram[@offset], comma separated (e.g. 0x8000:input=81,0x8001:output=81); "
    .. "used for frames no Connect describes (like pndiss --map)")
pndiss.prefs.profile = Pref.enum("Device profile", 1, "auto = from I&M0 / DCP vendor and order ID",
    {{1, "auto", 1}, {2, "lika", 2}, {3, "scancon", 3}, {4, "hohner", 4}, {5, "psm", 5}, {6, "generic", 6}}, false)
pndiss.prefs.telegram = Pref.uint("Telegram", 0, "telegram when neither Connect nor map tells it (0 = none: only a guess from both directions' lengths)")
local PROFILE_PREF = {"auto", "lika", "scancon", "hohner", "psm", "generic"}

-- 3. maps ----------------------------------------------------------------------------------------
-- Connect-derived maps: key "fid|src|dst" -> {direction, device, controller, station, ar, objects}
local maps, map_cache = {}, {}
local usermap = {}     -- fid -> {direction, telegram, offset}
local profiles = {}    -- device MAC -> profile (I&M0 / DCP)
local DRIVE_APIS = {[0x3A00] = true, [0x3D00] = true}   -- spec/network.md §1.7

local function tg_len(t, dir)
    local n = 0
    for _, s in ipairs(T.telegrams[t][dir]) do n = n + T.signals[s].size end
    return n
end

-- session.guess_telegram: both lengths must fit; 87 (4/4) and 86/860 (4/8) only on drive APIs
local function guess_telegram(out_len, in_len, api)
    if out_len == nil or in_len == nil then return nil end
    for _, row in ipairs(T.telegram_lengths) do
        if row[2] == out_len and row[3] == in_len then
            if not DRIVE_APIS[api] and ((out_len == 4 and in_len == 4) or (out_len == 4 and in_len == 8)) then
                return nil
            end
            return row[1]
        end
    end
end

local function parse_usermap(s)
    usermap = {}
    for item in tostring(s or ""):gmatch("[^,%s]+") do
        local fid, dir, t, off = item:match("^(%w+):?(%a*)=(%d+)@?(%d*)$")
        fid = fid and tonumber(fid)
        if fid and T.telegrams[tonumber(t)] then
            usermap[fid] = {direction = (dir == "output") and "output" or "input", telegram = tonumber(t),
                            offset = tonumber(off) or 0}
        end
    end
end

function pndiss.prefs_changed()
    parse_usermap(pndiss.prefs.map)
    map_cache = {}
end

-- session.profile_for: decided at its first use for a device from what is known then (I&M0 vendor
-- and order ID, else DCP vendor ID and DeviceVendorValue) and kept until an I&M0 read
local facts = {}    -- device MAC -> {dcp = {vendor, type}, im0 = {vendor, order}}
local select_profile   -- defined with the postdissector
local function profile_for(mac)
    local p = PROFILE_PREF[pndiss.prefs.profile] or "auto"
    if p ~= "auto" then return p end
    if profiles[mac] == nil then
        local f = facts[mac] or {}
        local src = f.im0 or f.dcp
        profiles[mac] = src and select_profile(src[1], src[2]) or "generic"
    end
    return profiles[mac]
end

-- compile one data object: telegram, layout rows {name, offset, size, signed}
local function compile_obj(o, direction)
    local dir = direction == "output" and "setpoint" or "actual"
    local t, src = o.telegram, o.telegram_source
    if t == nil and pndiss.prefs.telegram ~= 0 and T.telegrams[pndiss.prefs.telegram] then
        t, src = pndiss.prefs.telegram, "settings.telegram"
    end
    -- cyclic.py _frame: no telegram from the session (map, P922, both directions' lengths) and no
    -- preference: not an encoder submodule (a one-direction length guess would take any IO module)
    if t == nil or T.telegrams[t] == nil then return nil end
    local rows, off = {}, 0
    for _, name in ipairs(T.telegrams[t][dir]) do
        local s = T.signals[name]
        rows[#rows + 1] = {name = name, off = off, size = s.size, signed = s.signed}
        off = off + s.size
    end
    if o.length < off then return nil end     -- cyclic.py skips objects shorter than the telegram
    return {o = o, telegram = t, source = src, dir = dir, rows = rows, len = off}
end

-- like pndiss/cyclic.py CyclicTracker._frame/on_cyclic: a layout, once found, stays (with its objects)
-- until the maps change (map_generation: each Connect or P922 read), then every key is looked up
-- again; an unmapped key is also looked up again every RELOOKUP_EVERY frames of that key
local RELOOKUP_EVERY = 1024
local misses = {}
local map_generation, cache_generation = 0, 0
local function lookup(fid, src, dst)
    if cache_generation ~= map_generation then
        cache_generation = map_generation
        map_cache, misses = {}, {}
    end
    local key = fid .. "|" .. src .. "|" .. dst
    local c = map_cache[key]
    if c ~= nil then
        if c then return c end
        misses[key] = misses[key] + 1
        if misses[key] % RELOOKUP_EVERY ~= 0 then return nil end
    end
    local fm = maps[key]
    if fm == nil and usermap[fid] then
        local u = usermap[fid]
        local inp = u.direction == "input"
        local L = tg_len(u.telegram, inp and "actual" or "setpoint")
        fm = {direction = u.direction, device = inp and src or dst, controller = inp and dst or src,
              objects = {{api = 0, slot = 0, subslot = 0, offset = u.offset, length = L,
                          telegram = u.telegram, telegram_source = "map"}}}
    end
    local out = false
    if fm then
        local objs = {}
        for _, o in ipairs(fm.objects) do
            if o.length and o.length > 0 then
                local c2 = compile_obj(o, fm.direction)
                if c2 then objs[#objs + 1] = c2 end
            end
        end
        out = {fm = fm, objs = objs}
    end
    map_cache[key] = out
    if not out and misses[key] == nil then misses[key] = 0 end
    return out or nil
end

-- 4. Connect learning -----------------------------------------------------------------------------
local X = {}
for _, n in ipairs({"pn_io.opnum", "pn_io.block_type", "pn_io.ar_uuid", "pn_io.cminitiator_mac_add",
                    "pn_io.cmresponder_macadd", "pn_io.iocr_type", "pn_io.iocr_reference", "pn_io.frame_id",
                    "pn_io.data_length", "pn_io.api", "pn_io.slot_nr", "pn_io.subslot_nr",
                    "pn_io.io_data_object.frame_offset", "pn_io.iocs_frame_offset", "pn_io.data_description",
                    "pn_io.submodule_data_length", "pn_io.length_iops", "pn_io.length_iocs",
                    "pn_io.module_ident_number", "pn_io.submodule_ident_number", "pn_io.iocr_multicast_mac_add",
                    "pn_io.index", "pn_io.im_profile_id", "pn_io.vendor_id_high", "pn_io.vendor_id_low",
                    "pn_io.order_id", "dcerpc.pkt_type", "dcerpc.dg_act_id", "dcerpc.dg_seqnum",
                    "pn_rt.frame_id", "pn_rt.ds",
                    "pn_dcp.suboption_vendor_id", "pn_dcp.suboption_device_id", "pn_dcp.suboption_device_devicevendorvalue"}) do
    X[n] = Field.new(n)
end

-- all non-generated occurrences of a field, with offsets (wire order)
local function all(name)
    local out = {}
    for _, fi in ipairs({X[name]()}) do
        if not fi.generated then out[#out + 1] = fi end
    end
    return out
end

-- blocks of the PNIO stub: {type, s, e} from BlockType + BlockLength read in the source tvb
local function blocks()
    local out = {}
    for _, fi in ipairs(all("pn_io.block_type")) do
        local tvb = fi.source
        if tvb and fi.offset + 4 <= tvb:len() then
            local blen = tvb(fi.offset + 2, 2):uint()
            out[#out + 1] = {type = fi.value, s = fi.offset, e = fi.offset + 4 + blen, tvb = tvb}
        end
    end
    return out
end

local function inside(list, b)
    local out = {}
    for _, fi in ipairs(list) do
        if fi.offset >= b.s and fi.offset < b.e then out[#out + 1] = fi end
    end
    return out
end

-- value of the last field in list before offset off (the enclosing slot/subslot/api of an entry)
local function before(list, off)
    local v
    for _, fi in ipairs(list) do
        if fi.offset < off then v = fi.value else break end
    end
    return v
end

local pending_connects = {}   -- "act|seq" -> request summary

local function connect_request(key)
    local bl = blocks()
    local req = {iocrs = {}, expected = {}}
    local api, slot, sub = all("pn_io.api"), all("pn_io.slot_nr"), all("pn_io.subslot_nr")
    for _, b in ipairs(bl) do
        if b.type == 0x0101 then
            local u, m = inside(all("pn_io.ar_uuid"), b), inside(all("pn_io.cminitiator_mac_add"), b)
            req.ar = u[1] and tostring(u[1])
            req.controller = m[1] and tostring(m[1].value)
        elseif b.type == 0x0102 then
            local function first(n) local l = inside(all(n), b); return l[1] and l[1].value end
            local cr = {type = first("pn_io.iocr_type"), ref = first("pn_io.iocr_reference"),
                        frame_id = first("pn_io.frame_id"), data_length = first("pn_io.data_length"),
                        mcast = first("pn_io.iocr_multicast_mac_add"), objects = {}}
            local ba, bs, bss = inside(api, b), inside(slot, b), inside(sub, b)
            for _, fo in ipairs(inside(all("pn_io.io_data_object.frame_offset"), b)) do
                cr.objects[#cr.objects + 1] = {api = before(ba, fo.offset), slot = before(bs, fo.offset),
                                               subslot = before(bss, fo.offset), offset = fo.value}
            end
            req.iocrs[#req.iocrs + 1] = cr
        elseif b.type == 0x0104 then
            local ba, bs, bss = inside(api, b), inside(slot, b), inside(sub, b)
            local dd, iops = inside(all("pn_io.data_description"), b), inside(all("pn_io.length_iops"), b)
            for _, l in ipairs(inside(all("pn_io.submodule_data_length"), b)) do
                local k = table.concat({before(ba, l.offset) or 0, before(bs, l.offset) or 0,
                                        before(bss, l.offset) or 0}, "/")
                local e = req.expected[k] or {}
                local d = before(dd, l.offset)
                local io = nil
                for _, fi in ipairs(iops) do if fi.offset > l.offset then io = fi.value break end end
                if d == 1 then e.input = {l.value, io or 1} elseif d == 2 then e.output = {l.value, io or 1} end
                req.expected[k] = e
            end
        end
    end
    pending_connects[key] = req
end

local function connect_response(key, pinfo)
    local req = pending_connects[key]
    pending_connects[key] = nil
    if req == nil or req.controller == nil then return end
    local bl = blocks()
    local device = tostring(pinfo.dl_src)
    local res_fid = {}
    for _, b in ipairs(bl) do
        if b.type == 0x8101 then
            local m = inside(all("pn_io.cmresponder_macadd"), b)
            if m[1] then device = tostring(m[1].value) end
        elseif b.type == 0x8102 then
            local r, f = inside(all("pn_io.iocr_reference"), b), inside(all("pn_io.frame_id"), b)
            if r[1] and f[1] then res_fid[r[1].value] = f[1].value end
        end
    end
    for _, cr in ipairs(req.iocrs) do
        local direction = ({[1] = "input", [2] = "output", [3] = "input"})[cr.type]
        if direction then
            local fid = res_fid[cr.ref] or cr.frame_id
            local s, d = device, req.controller
            if direction == "output" then s, d = req.controller, device end
            if cr.type == 3 and cr.mcast then d = tostring(cr.mcast) end
            local fm = {direction = direction, device = device, controller = req.controller, ar = req.ar, objects = {}}
            for _, o in ipairs(cr.objects) do
                local e = req.expected[table.concat({o.api or 0, o.slot or 0, o.subslot or 0}, "/")] or {}
                local mine = e[direction] or {0, 1}
                local obj = {api = o.api, slot = o.slot, subslot = o.subslot, offset = o.offset, length = mine[1]}
                if e.input and e.output then
                    obj.telegram = guess_telegram(e.output[1], e.input[1], o.api)
                    if obj.telegram then obj.telegram_source = "length" end
                end
                fm.objects[#fm.objects + 1] = obj
            end
            maps[fid .. "|" .. s .. "|" .. d] = fm
            map_generation = map_generation + 1
        end
    end
end

-- 5. records --------------------------------------------------------------------------------------
local axes = {}      -- axis key -> rule state (section 6)
local devices = {}   -- device MAC -> {bf00 = decoded 0xBF00 written, p922 = first P922 value read}
local checker_p922   -- defined with the rules (section 6)
local apply_seq = 0  -- order in which 0xBF00/0xFFFF parameter sets were applied (latest wins)
local pairer = {}       -- param key -> {req, frame} of the request awaiting its response
local superseded = {}   -- param key -> frames of requests overwritten before a response
local frame_cache = {}   -- frame number -> list of {kind, ...} to show (computed on the first pass)

local function u8(t, o) return t(o, 1):uint() end
local function u16(t, o) return t(o, 2):uint() end

local function request_id_name(id)
    return T.request_ids[id] or ((id >= 0x40 and id <= 0x7F) and "manufacturer-specific" or "reserved")
end

local function param_name(pnu, profile)
    local v = T.vendor_params[profile]
    return (v and v[pnu]) or T.params[pnu] or ("P" .. pnu)
end

local INT_CODES = {B = true, H = true, I = true, b = true, h = true, i = true, q = true, Q = true}

-- a value block at off: returns block, next offset (nil + reason when it does not fit)
local function value_block(t, off, len)
    if off + 2 > len then return nil, "value block header truncated" end
    local fmt, n = u8(t, off), u8(t, off + 1)
    local spec = T.param_formats[fmt]
    if spec == nil then return nil, string.format("format 0x%02X unknown", fmt) end
    local size = spec.size
    local e = off + 2 + size * n
    if e > len then return nil, "values truncated" end
    local blk = {format = fmt, n = n, values = {}}
    for i = 0, n - 1 do
        local o = off + 2 + i * size
        local code = spec.code
        local v
        if code == "B" or code == "H" or code == "I" then v = tostring(t(o, size):uint())
        elseif code == "b" or code == "h" or code == "i" then v = tostring(t(o, size):int())
        elseif code == "q" then v = tostring(t(o, 8):int64())
        elseif code == "Q" then v = tostring(t(o, 8):uint64())
        elseif code == "f" then v = tostring(t(o, 4):float())
        elseif code == "d" then v = tostring(t(o, 8):float())
        elseif code == "str" then v = nil
        elseif code == "hex" then v = t(o, size):bytes():tohex():lower()
        end
        if v then blk.values[#blk.values + 1] = v end
        blk.int = INT_CODES[code] or false
    end
    if spec.code == "str" then blk.values[1] = t(off + 2, size * n):raw() end
    if fmt == 0x44 and n > 0 then
        local c = t(off + 2, 2):uint()
        blk.error = {code = c, text = T.param_errors[c] or
            ((c >= 0x65 and c <= 0xFF) and "manufacturer-specific error" or
             (c <= 0xFF and "reserved error number" or "error number above 0x00FF (high byte reserved)"))}
    end
    if (e - off) % 2 == 1 and e < len then e = e + 1 end   -- odd byte counts padded to a word
    return blk, e
end

local function decode_request(t, len, profile)
    if len < 4 then return nil, "parameter request header truncated" end
    local r = {ref = u8(t, 0), id = u8(t, 1), axis = u8(t, 2), n = u8(t, 3), params = {}}
    local off = 4
    for i = 1, r.n do
        if off + 6 > len then return nil, "parameter address truncated" end
        local pnu = u16(t, off + 2)
        r.params[i] = {attribute = u8(t, off), count = u8(t, off + 1), pnu = pnu, subindex = u16(t, off + 4),
                       name = param_name(pnu, profile)}
        off = off + 6
    end
    if r.id == 2 then
        for i = 1, r.n do
            local blk, e = value_block(t, off, len)
            if not blk then return nil, e end
            r.params[i].written = blk
            off = e
        end
    end
    return r
end

local function decode_response(t, len)
    if len < 4 then return nil, "parameter response header truncated" end
    local r = {ref = u8(t, 0), id = u8(t, 1), axis = u8(t, 2), n = u8(t, 3), blocks = {}}
    local off = 4
    if r.id ~= 2 then
        for i = 1, r.n do
            if off >= len and r.id == 0x80 then break end
            local blk, e = value_block(t, off, len)
            if not blk then return nil, e end
            r.blocks[i] = blk
            off = e
        end
    end
    r.ok = (r.id == 1 or r.id == 2)
    for _, b in ipairs(r.blocks) do if b.format == 0x44 then r.ok = false end end
    return r
end

local function decode_bf00(t, len, profile)
    local d = {problems = {}}
    if len ~= 31 then d.problems[#d.problems + 1] = "BF00-LENGTH" end
    if len >= 1 then
        local b0 = u8(t, 0)
        d.flags = b0
        for _, fb in ipairs(T.bf00_flags) do d[fb[1]] = bit.band(bit.rshift(b0, fb[2]), 1) end
        d.direction = d.code_sequence
    end
    if len >= 17 then d.mupr = t(1, 8):uint64(); d.tmr = t(9, 8):uint64() end
    if len >= 18 then d.max_master_sol_failures = u8(t, 17) end
    if len >= 17 then
        if d.mupr < UInt64(1) then d.problems[#d.problems + 1] = "BF00-VALUE-OUT-OF-RANGE" end
        if d.tmr < UInt64(2) then d.problems[#d.problems + 1] = "BF00-VALUE-OUT-OF-RANGE" end
    end
    if len >= 18 and d.max_master_sol_failures < (profile == "psm" and 0 or 1) then
        d.problems[#d.problems + 1] = "BF00-VALUE-OUT-OF-RANGE"
    end
    if len >= 19 and u8(t, 18) > (profile == "psm" and 4 or 3) then
        d.problems[#d.problems + 1] = "BF00-VALUE-OUT-OF-RANGE"
    end
    if profile == "lika" or profile == "generic" then   -- CHECK_RESERVED: bits 0.6-7, bytes 19-30
        local bad = len >= 1 and bit.rshift(u8(t, 0), 6) ~= 0
        for i = 19, math.min(len, 31) - 1 do if u8(t, i) ~= 0 then bad = true end end
        if bad then d.problems[#d.problems + 1] = "BF00-RESERVED-NONZERO" end
    end
    if len >= 19 then
        d.velocity_unit = u8(t, 18)
        local tbl = profile == "psm" and T.bf00_velocity_units_psm or T.bf00_velocity_units
        d.velocity_unit_name = tbl[d.velocity_unit] or ("undefined (" .. d.velocity_unit .. ")")
    end
    return d
end

-- the record events of this frame (write requests / read responses), from the header blocks
local function records_of_frame(pinfo)
    local out = {}
    local ok_pkt = all("dcerpc.pkt_type")
    local ptype = ok_pkt[1] and ok_pkt[1].value
    for _, b in ipairs(blocks()) do
        if (b.type == 0x0008 or b.type == 0x8009) and b.e - b.s >= 64 then
            local t = b.tvb
            local hs = b.s + 6 + 2   -- after block header and SeqNumber
            if hs + 16 + 4 + 2 + 2 + 2 + 2 + 4 <= t:len() then
                local ar = tostring(t(hs, 16):bytes())
                local api = t(hs + 16, 4):uint()
                local slot, subslot = t(hs + 20, 2):uint(), t(hs + 22, 2):uint()
                local index = t(hs + 26, 2):uint()
                local rlen = t(hs + 28, 4):uint()
                local ds = b.e
                if index ~= 0xE040 and ds + rlen <= t:len() then
                    out[#out + 1] = {op = b.type == 0x0008 and "write" or "read", index = index, api = api,
                                     slot = slot, subslot = subslot, ar = ar, tvb = t(ds, rlen):tvb(),
                                     len = rlen, at = {t, ds, rlen}}
                end
            end
        end
    end
    return out
end

local function record_items(pinfo, recs)
    local items = {}
    local src, dst = tostring(pinfo.dl_src), tostring(pinfo.dl_dst)
    for _, r in ipairs(recs) do
        local device = r.op == "write" and dst or src
        local controller = r.op == "write" and src or dst
        local profile = profile_for(device)
        local it = {rec = r, index_name = T.index_names[r.index] or
            (r.index < 0x8000 and string.format("user specific record 0x%04X", r.index) or string.format("record 0x%04X", r.index))}
        local nil_ar = r.ar == string.rep("00", 16)
        local key = table.concat({nil_ar and (controller .. "/" .. device) or r.ar, r.api, r.slot, r.subslot}, "|")
        local t, len = r.tvb, r.len
        if r.index == 0xB02E or r.index == 0xB02F then
            if r.op == "write" then
                local req = decode_request(t, len, profile)
                if req then
                    if pairer[key] then   -- ParamPairer.request: an unanswered request is overwritten
                        superseded[key] = superseded[key] or {}
                        table.insert(superseded[key], pairer[key].frame)
                    end
                    pairer[key] = {req = req, frame = pinfo.number}
                    it.request = req
                else
                    it.malformed = true
                end
            else
                local rsp = decode_response(t, len)
                if rsp then
                    local p = pairer[key]
                    pairer[key] = nil
                    local ev = {rsp = rsp, pairing = {}, params = {}}
                    local sup = superseded[key]
                    superseded[key] = nil
                    if sup then
                        local fr = {}
                        for j, f in ipairs(sup) do fr[j] = tostring(f) end
                        ev.pairing[#ev.pairing + 1] = "request(s) in frame(s) " .. table.concat(fr, ", ")
                            .. " overwritten before their response was read"
                    end
                    if p == nil then
                        ev.pairing[#ev.pairing + 1] = "no request"
                    else
                        local q = p.req
                        ev.request_frame, ev.req = p.frame, q
                        local w = ev.pairing
                        if rsp.ref ~= q.ref then
                            w[#w + 1] = string.format("request ref mismatch (request 0x%02X, response 0x%02X)", q.ref, rsp.ref)
                        end
                        if rsp.id ~= q.id and rsp.id ~= bit.bor(q.id, 0x80) then
                            w[#w + 1] = string.format("response id mismatch (request 0x%02X, response 0x%02X)", q.id, rsp.id)
                        end
                        if rsp.axis ~= q.axis then
                            w[#w + 1] = string.format("axis not mirrored (request %d, response %d)", q.axis, rsp.axis)
                        end
                        if rsp.n ~= q.n then
                            w[#w + 1] = string.format("number of parameters mismatch (request %d, response %d)", q.n, rsp.n)
                        end
                        if #rsp.blocks > 0 and #rsp.blocks ~= #q.params then
                            w[#w + 1] = string.format("%d value blocks for %d requested parameters", #rsp.blocks, #q.params)
                        end
                    end
                    local reqp = p and p.req.params or {}
                    for i = 1, math.max(#reqp, #rsp.blocks) do
                        local a, blk = reqp[i], rsp.blocks[i]
                        ev.params[i] = {pnu = a and a.pnu, subindex = a and a.subindex, name = a and a.name,
                                        format = blk and blk.format, values = blk and blk.values or {},
                                        int = blk and blk.int,
                                        error = blk and blk.error}
                        if a and a.pnu == 922 and blk and not blk.error and blk.values[1] and (a.subindex or 0) == 0 then
                            -- session.py _p922: a P922 read names the telegram of the device's submodules
                            -- with data, unless the user map says; a length guess is kept when P922's
                            -- telegram has another length in that direction (the checker then reports
                            -- TELEGRAM-SELECTION-MISMATCH); objects whose lengths fit none take it
                            local tnum = tonumber(blk.values[1])
                            if tnum then map_generation = map_generation + 1 end
                            if tnum and T.telegrams[tnum] then
                                -- one telegram per submodule: a length guess yields only if P922's
                                -- telegram fits the submodule's lengths in both directions
                                local misfit = {}
                                for _, fm in pairs(maps) do
                                    if fm.device == device then
                                        local dir = fm.direction == "input" and "actual" or "setpoint"
                                        for _, o in ipairs(fm.objects) do
                                            if (o.length or 0) > 0 and o.telegram_source == "length"
                                                    and tg_len(tnum, dir) ~= o.length then
                                                misfit[o.api .. ":" .. o.slot .. ":" .. o.subslot] = true
                                            end
                                        end
                                    end
                                end
                                for _, fm in pairs(maps) do
                                    if fm.device == device then
                                        for _, o in ipairs(fm.objects) do
                                            if o.telegram_source ~= "map" and (o.length or 0) > 0
                                                    and not (o.telegram_source == "length"
                                                             and misfit[o.api .. ":" .. o.slot .. ":" .. o.subslot])
                                                    and ((o.api == r.api and o.slot == r.slot and o.subslot == r.subslot)
                                                        or o.telegram == nil or o.telegram_source == "length"
                                                        or o.telegram_source == "gsdml") then
                                                o.telegram, o.telegram_source = tnum, "P922"
                                            end
                                        end
                                    end
                                end
                            end
                            if tnum then   -- acyclic.py _read, for every axis of the device (and replayed later)
                                local d = devices[device] or {}
                                devices[device] = d
                                d.p922s = d.p922s or {}
                                d.p922s[#d.p922s + 1] = tnum
                                for _, ax in pairs(axes) do
                                    if ax.device == device then checker_p922(ax, tnum) end
                                end
                            end
                        end
                    end
                    it.param = ev
                else
                    it.malformed = true
                end
            end
        end
        if r.index == 0xFFFF and r.op == "write" and len > 0 then
            local d = devices[device] or {}
            devices[device] = d
            d.ffff = ByteArray.new(t:raw(0, len), true)   -- bytes: a Tvb would expire with this frame
        end
        if r.index == 0xB02E or r.index == 0xB02F then
            -- handled above
        elseif r.index == 0xBF00 or (r.index == 0xFFFF and profile == "psm") then
            it.bf00 = decode_bf00(t, len, r.index == 0xFFFF and "psm" or profile)
            if r.op == "write" then   -- cyclic.py on_record: the written parameter set is in force
                local d = devices[device] or {}
                devices[device] = d
                apply_seq = apply_seq + 1
                d.bf00 = {seq = apply_seq, d = it.bf00}
            end
        end
        items[#items + 1] = it
    end
    return items
end

-- 6. cyclic --------------------------------------------------------------------------------------

local function sig_value(tvb, base, row)
    local r = tvb(base + row.off, row.size)
    if row.size == 8 then return row.signed and r:int64() or r:uint64() end
    return row.signed and r:int() or r:uint()
end

local function bits_of(sig, v, profile)
    local out = {}
    for _, b in ipairs(T.bitmaps[sig] or {}) do
        local ok = b.profiles == nil
        if not ok then for _, p in ipairs(b.profiles) do if p == profile then ok = true break end end end
        if ok then
            local mask = bit.lshift(1, b.width) - 1
            local x
            if type(v) == "number" then x = bit.band(bit.rshift(v, b.bit), mask)
            else x = v:rshift(b.bit):band(mask):tonumber() end
            out[#out + 1] = {b.name, x}
        end
    end
    return out
end

-- reserved masks per (signal, profile): bits no bitmap entry names (telegrams.reserved_mask)
local reserved_cache = {}
local function reserved_mask(sig, profile)
    local k = sig .. "|" .. profile
    local m = reserved_cache[k]
    if m then return m end
    local used = 0
    for _, b in ipairs(T.bitmaps[sig] or {}) do
        local ok = b.profiles == nil
        if not ok then for _, p in ipairs(b.profiles) do if p == profile then ok = true break end end end
        if ok then used = bit.bor(used, bit.lshift(bit.lshift(1, b.width) - 1, b.bit)) end
    end
    m = bit.band(bit.lshift(1, 8 * T.signals[sig].size) - 1, bit.bnot(used))
    reserved_cache[k] = m
    return m
end

-- rules.  Mirrors pndiss/encoder/_state.py (Checker._cycle_std, Checker._hit): one judged cycle per
-- input frame paired with the latest setpoint (pndiss/cyclic.py); a condition that holds over
-- consecutive judged cycles is ONE violation at its first frame; a gated cycle (DataValid 0,
-- provider STOP, IOPS bad) ends every run and forgets the history (Checker.gap).
-- Controller-side rules name the setpoint frame; tshark shows a frame only once, so the plugin
-- implements those that depend on the setpoint alone and decides them on the setpoint frame.
local L_MAX = 2          -- settings.l_max default (behaviour.md §0.1)

local function bitv(v, n) return bit.band(bit.rshift(v, n), 1) end

-- a new run starts unless the rule held in judged cycle `prev` (Checker._hit: o["n"] == n - 1)
local function run(ax, rule, prev, found)
    if ax.open[rule] ~= prev then found[#found + 1] = rule end
end

-- EncoderConfig.std: telegrams with STW2_ENC/ZSW2_ENC (81-84; PS/PSM 89)
local function is_std(t) return T.telegrams[t] ~= nil and (T.telegrams[t].standard or t == 89) end

-- compat in force: captured 0xBF00 > profile default (EncoderConfig.from_settings / acyclic.py)
local function compat_of(ax)
    local d = devices[ax.device]
    local w = d and d.bf00
    if ax.bf00 and (w == nil or ax.bf00.seq > w.seq) then w = ax.bf00 end
    if w and w.d.compat ~= nil then return w.d.compat end
    local pd = T.profile_defaults[ax.profile] or T.profile_defaults.generic
    return pd.compat
end

-- setpoint-only conditions (#60, #61), decided on the setpoint frame; cycle n+1 will judge them
local function sp_conditions(ax, sp)
    local p = ax.profile
    local c = {}
    c["RESERVED-BIT-SET-STW2"] = bit.band(sp.stw2_enc or 0, reserved_mask("stw2_enc", p)) ~= 0
    c["RESERVED-BIT-SET-G1STW"] = sp.g1_stw ~= nil and bit.band(sp.g1_stw, reserved_mask("g1_stw", p)) ~= 0
    return c
end

-- every cycle of the window W(n, -L_max, 0) has h[k] == v (no closures: this runs every cycle)
local function all_is(H, k, v)
    for i = 1, #H do if H[i][k] ~= v then return false end end
    return true
end

-- actual-side conditions of one judged cycle (frame = the input frame)
local function ac_conditions(ax, sp, ac)
    local p = ax.profile
    local c = {}
    local stw2, g1stw = sp.stw2_enc or 0, sp.g1_stw or 0
    local zsw2, g1zsw = ac.zsw2_enc or 0, ac.g1_zsw or 0
    local has_g1 = sp.g1_stw ~= nil and ac.g1_zsw ~= nil
    local CTRL = bitv(stw2, 10)
    local PREQ, AREQ, PARK, SACK = bitv(g1stw, 12), bitv(g1stw, 13), bitv(g1stw, 14), bitv(g1stw, 15)
    local CREQ = bitv(zsw2, p == "psm" and 10 or 9)   -- telegrams.bit_position control_requested
    local ACKIP, PDONE, ATX, PKA, SERR = bitv(g1zsw, 11), bitv(g1zsw, 12), bitv(g1zsw, 13), bitv(g1zsw, 14), bitv(g1zsw, 15)
    local compat = compat_of(ax)
    local VALID = compat == 0 or CTRL == 1
    local H = ax.hist
    H[#H + 1] = {CTRL = CTRL, PREQ = PREQ, AREQ = AREQ, PARK = PARK, SACK = SACK, VALID = VALID, PKA = PKA, SERR = SERR}
    if #H > L_MAX + 1 then table.remove(H, 1) end
    local full = #H == L_MAX + 1
    local pa = ax.prev_ac
    local first = pa == nil
    local pz = pa and (pa.g1_zsw or 0) or 0
    local pACKIP, pPDONE, pATX, pPKA, pSERR = bitv(pz, 11), bitv(pz, 12), bitv(pz, 13), bitv(pz, 14), bitv(pz, 15)
    -- 9.2 control by PLC (#13, #14, #16)
    if compat == 1 then
        c["CTRLREQ-MISMATCH"] = full and all_is(H, "CTRL", CTRL) and CREQ ~= CTRL
        c["CMD-EXECUTED-WITHOUT-CONTROL"] = full and all_is(H, "CTRL", 0) and not first
            and has_g1 and ((PDONE == 1 and pPDONE == 0) or (ATX == 1 and pATX == 0) or (PKA == 1 and pPKA == 0))
    else
        c["CTRLREQ-SET-IN-COMPAT"] = CREQ == 1
    end
    -- 9.8 reserved bits (#62, #63)
    c["RESERVED-BIT-SET-ZSW2"] = bit.band(zsw2, reserved_mask("zsw2_enc", p)) ~= 0
    if not has_g1 then return c end
    c["RESERVED-BIT-SET-G1ZSW"] = bit.band(g1zsw, reserved_mask("g1_zsw", p)) ~= 0
    local X1, X2 = ac.g1_xist1, ac.g1_xist2
    -- 9.3 preset handshake edges (#20, #21)
    c["PRESET-ACK-SPURIOUS"] = not first and PDONE == 1 and pPDONE == 0 and all_is(H, "PREQ", 0)
    c["PRESET-ACK-DROPPED"] = not first and PDONE == 0 and pPDONE == 1 and full and all_is(H, "PREQ", 1)
    -- 9.5 absolute value request (#36-39)
    c["ABSVAL-ACK-MISSING"] = full and ATX == 0 and all_is(H, "AREQ", 1) and all_is(H, "VALID", true) and all_is(H, "PKA", 0) and all_is(H, "SERR", 0)
    c["ABSVAL-ACK-STUCK"] = full and ATX == 1 and all_is(H, "AREQ", 0) and all_is(H, "VALID", true)
    c["ZSW-ATX-AND-SERR"] = ATX == 1 and SERR == 1
    c["XIST2-NOT-ZERO"] = p == "lika" and X2 ~= nil and ATX == 0 and SERR == 0 and PKA == 0 and X2 ~= 0
    -- 9.6 parking (#45-48)
    c["PARK-ACK-MISSING"] = full and PKA == 0 and all_is(H, "PARK", 1) and all_is(H, "VALID", true)
    c["PARK-ACK-NOT-CLEARED"] = full and PKA == 1 and all_is(H, "PARK", 0) and all_is(H, "VALID", true)
    c["PARK-OUTPUTS-NOT-CLEARED"] = p == "lika" and PKA == 1 and
        ((X1 or 0) ~= 0 or (X2 or 0) ~= 0 or PDONE == 1 or ATX == 1)
    c["PARK-ERROR-REPORTED"] = PKA == 1 and not first and pPKA == 1 and SERR == 1 and pSERR == 0
    -- 9.7 sensor error and acknowledgement (#51, #53, #54, #59)
    c["SERR-CODE-INVALID"] = SERR == 1 and X2 ~= nil and (X2 == 0 or (p == "lika" and T.xist2_errors[X2] == nil))
    c["ACKIP-SPURIOUS"] = not first and ACKIP == 1 and pACKIP == 0 and all_is(H, "SACK", 0)
    c["ACKIP-STUCK"] = full and ACKIP == 1 and all_is(H, "SACK", 0)
    c["FAULT-PRESENT-INCONSISTENT"] = p == "psm" and SERR == 1 and bitv(zsw2, 3) == 0
    return c
end

-- ax.telegram/ax.source: the cyclic view (pndiss/cyclic.py _Axis); ax.cfg_telegram/ax.cfg_source:
-- the checker's configuration (EncoderConfig.telegram and its source), which P922 may change first
local function new_axis(key, c, profile, device)
    return {key = key, telegram = c.telegram, source = c.source, cfg_telegram = c.telegram, cfg_source = c.source,
            profile = profile, device = device, n = 0, open = {}, hist = {}, sp = nil, sp_ok = false,
            sp_cond = nil, prev_ac = nil, io_len = {}, ambiguous = nil, p922_rejected = nil}
end

-- acyclic.py _read: P922 names the telegram when it was only guessed from the lengths and fits
-- the AR's data lengths; otherwise a guessed telegram keeps the AR's view (p922_rejected)
function checker_p922(ax, v)
    local guessed = tostring(ax.cfg_source):find("length", 1, true) ~= nil
    local fits = T.telegrams[v] ~= nil
    if fits then
        for dir, n in pairs(ax.io_len) do if tg_len(v, dir) ~= n then fits = false end end
    end
    if guessed and fits then
        ax.cfg_telegram, ax.cfg_source = v, "P922 read"
    elseif v ~= ax.cfg_telegram and guessed then
        ax.p922_rejected = v
    end
end

-- cyclic.py _ambiguous: a length guess is judged when both data lengths leave one candidate among
-- the profile's telegrams, or when the guess is a standard telegram (81 is mandatory in every class)
local function ambiguous(ax)
    if not tostring(ax.source):find("length", 1, true) then return false end
    local ia, is = ax.io_len.actual, ax.io_len.setpoint
    local n = 0
    for t, d in pairs(T.telegrams) do
        if (ia == nil or tg_len(t, "actual") == ia) and (is == nil or tg_len(t, "setpoint") == is) then
            local ok = ax.profile == "generic" and d.standard
            for _, p in ipairs(d.profiles) do if p == ax.profile then ok = true end end
            if ok then n = n + 1 end
        end
    end
    return n > 1 and not T.telegrams[ax.telegram].standard
end

-- cyclic.py _refine_profile: telegrams that exist only in PS/PSM make a 'generic' device PS/PSM
-- (a length guess proves it only when no other telegram fits both lengths); PS/PSM keeps its
-- parameters at 0xFFFF, so the last 0xFFFF written is applied again, decoded as PS/PSM
local function refine_profile(ax)
    local t = ax.telegram
    if tostring(ax.source):find("length", 1, true) then
        local ia, is = ax.io_len.actual, ax.io_len.setpoint
        local fits = {}
        for u in pairs(T.telegrams) do
            if (ia == nil or tg_len(u, "actual") == ia) and (is == nil or tg_len(u, "setpoint") == is) then
                fits[#fits + 1] = u
            end
        end
        if #fits ~= 1 or fits[1] ~= t then return end
    end
    local d = T.telegrams[t]
    if ax.profile == "generic" and d and #d.profiles == 1 and d.profiles[1] == "psm" then
        ax.profile = "psm"
        local dev = devices[ax.device]
        if dev and dev.ffff then
            apply_seq = apply_seq + 1
            ax.bf00 = {seq = apply_seq, d = decode_bf00(dev.ffff:tvb("0xFFFF record"), dev.ffff:len(), "psm")}
        end
    end
end

local function gap(ax)
    ax.open, ax.hist, ax.prev_ac, ax.prev_sp, ax.same = {}, {}, nil, nil, 0   -- Checker.gap: end runs, forget history
end

local function judge(ax, ac, found)
    -- Checker.cycle fast path: the same decoded words again (sig tables are reused while the bytes
    -- repeat), no run open and a saturated history cannot give a new result
    local same = ax.sp == ax.prev_sp and ac == ax.prev_ac
    ax.same = same and (ax.same or 0) + 1 or 0
    if same and ax.same > L_MAX + 1 and ax.last_hit ~= ax.n then
        ax.n = ax.n + 1
        return
    end
    ax.n = ax.n + 1
    ax.prev_sp = ax.sp
    if not is_std(ax.cfg_telegram) then return end
    for rule, cond in pairs(ax.sp_cond or {}) do
        if cond then ax.open[rule], ax.last_hit = ax.n, ax.n end   -- already reported on the setpoint frame
    end
    for rule, cond in pairs(ac_conditions(ax, ax.sp, ac)) do
        if cond and E[rule] then
            run(ax, rule, ax.n - 1, found)
            ax.open[rule] = ax.n
            ax.last_hit = ax.n
        end
    end
    ax.prev_ac = ac
end

-- cyclic frame: decode each mapped object, feed the axis state (first pass), cache the result
local function first_pass(pinfo, tvb, entry, ok_ds, fid)
    local out = {objs = {}, rules = {}}
    local fm = entry.fm
    for i, c in ipairs(entry.objs) do
        local o = c.o
        local key = c.key
        if key == nil then
            key = table.concat({fm.ar or (fm.controller .. "/" .. fm.device), o.api or 0, o.slot or 0, o.subslot or 0}, "|")
            c.key = key
        end
        if o.telegram ~= nil and o.telegram ~= c.telegram and o.telegram ~= c.rejected then
            -- cyclic.py _relabel: the session learnt the telegram (P922) after the first frame
            local ax = axes[key]
            local nc = T.telegrams[o.telegram] and not (ax and ax.p922_rejected == o.telegram) and compile_obj(o, fm.direction)
            if not nc then
                c.rejected = o.telegram
            else
                entry.objs[i], c = nc, nc   -- a new object: frames shown before keep the old layout
                if ax then
                    ax.telegram, ax.source, ax.ambiguous, ax.sp, ax.sp_cond = nc.telegram, nc.source, false, nil, nil
                    if ax.cfg_telegram ~= nc.telegram or tostring(ax.cfg_source):find("length", 1, true) then
                        ax.cfg_telegram, ax.cfg_source = nc.telegram, nc.source
                    end
                    refine_profile(ax)
                    gap(ax)
                end
            end
        end
        if o.offset + c.len > tvb:len() then
            out.malformed = string.format("data object %s/%s ends at byte %d of a %d-byte C_SDU",
                tostring(o.slot), tostring(o.subslot), o.offset + c.len, tvb:len())
            break
        end
        local iops = (o.offset + o.length < tvb:len()) and tvb(o.offset + o.length, 1):uint() or nil
        local ok = ok_ds and iops ~= nil and bit.band(iops, 0x80) ~= 0
        local ax = axes[key]
        if ax == nil then
            ax = new_axis(key, c, profile_for(fm.device), fm.device)
            refine_profile(ax)
            axes[key] = ax
            local d = devices[fm.device]
            for _, v in ipairs(d and d.p922s or {}) do checker_p922(ax, v) end   -- records seen before
        end
        if ax.io_len[c.dir] == nil then
            ax.io_len[c.dir] = o.length
            refine_profile(ax)
        end
        local raw = tvb:raw(o.offset, c.len)
        local sig = c.last_sig
        if raw ~= c.last_raw or sig == nil then   -- cyclic.py: an unchanged C_SDU reuses the decode
            sig = {}
            for _, row in ipairs(c.rows) do
                sig[row.name] = sig_value(tvb, o.offset, row)
            end
            c.last_raw, c.last_sig = raw, sig
        end
        out.objs[#out.objs + 1] = {c = c, iops = iops, ok = ok, profile = ax.profile}
        local found = {}
        if c.dir == "setpoint" then
            ax.sp, ax.sp_ok = sig, ok
            ax.sp_cond = nil
            if ok and is_std(ax.cfg_telegram) then
                ax.sp_cond = sp_conditions(ax, sig)
                for rule, cond in pairs(ax.sp_cond) do
                    if cond then run(ax, rule, ax.n, found) end   -- judged next as cycle n + 1
                end
            end
        else
            if ax.ambiguous == nil then ax.ambiguous = ambiguous(ax) end
            if ax.sp ~= nil then
                if not (ok and ax.sp_ok) or ax.ambiguous then gap(ax) else judge(ax, sig, found) end
            end
        end
        for _, r in ipairs(found) do out.rules[#out.rules + 1] = r end
    end
    return out
end

local function add_object(tree, tvb, c, cached, fm)
    local o = c.o
    local st = tree:add(pndiss, tvb(o.offset, c.len),
        string.format("PROFINET encoder: telegram %d %s, slot %s/%s", c.telegram, c.dir, tostring(o.slot), tostring(o.subslot)))
    st:add(F["pndiss.telegram"], c.telegram)
    st:add(F["pndiss.slot"], o.slot or 0)
    st:add(F["pndiss.subslot"], o.subslot or 0)
    if tree.visible then   -- shown, not needed for filtering: skipped in plain tshark runs (hot path)
        st:add(F["pndiss.direction"], c.dir)
        st:add(F["pndiss.telegram_source"], c.source or "")
        st:add(F["pndiss.api"], o.api or 0)
        if cached.iops then st:add(F["pndiss.iops"], tvb(o.offset + o.length, 1), cached.iops) end
        st:add(F["pndiss.judged"], cached.ok and true or false)
        st:add(F["pndiss.profile"], cached.profile)
    end
    local serr, x2
    for _, row in ipairs(c.rows) do
        local r = tvb(o.offset + row.off, row.size)
        local v = sig_value(tvb, o.offset, row)
        local it = st:add(F["pndiss." .. row.name], r, v)
        if T.bitmaps[row.name] then
            for _, b in ipairs(bits_of(row.name, v, cached.profile)) do
                it:add(F["pndiss." .. row.name .. "." .. b[1]], r, b[2])
                if row.name == "g1_zsw" and b[1] == "sensor_error" and b[2] ~= 0 then serr = true end
            end
        end
        if row.name == "g1_xist2" then x2 = {v, r} end
    end
    if serr and x2 then
        local code = x2[1]
        local es = st:add(F["pndiss.xist2_error.code"], x2[2], code)
        es:add(F["pndiss.xist2_error.text"], x2[2],
            T.xist2_errors[code] or string.format("device-specific error code 0x%04X", code))
    end
end

local function add_rules(tree, tvb, rules)
    if #rules == 0 then return end
    local st = tree:add(pndiss, tvb(0, 0), "pndiss violations")
    for _, rule in ipairs(rules) do
        local it = st:add(F["pndiss.rule"], rule)
        it:add_proto_expert_info(E[rule], rule .. ": " .. (T.rules[rule] and T.rules[rule].section or ""))
    end
end

local cyc_cache = {}   -- frame number -> first-pass result (entry + decoded flags + rules)

local cyclic_frame = nil   -- number of the frame the heuristic saw last: the postdissector skips it

local function heuristic(tvb, pinfo, tree)
    cyclic_frame = pinfo.number
    local fi = X["pn_rt.frame_id"]()
    if fi == nil then return false end
    local fid = fi.value
    local cached = cyc_cache[pinfo.number]
    if cached == nil then
        if pinfo.visited then return false end
        local entry = lookup(fid, tostring(pinfo.dl_src), tostring(pinfo.dl_dst))
        if entry == nil or #entry.objs == 0 then return false end
        -- DataStatus: DataValid (bit 2) and ProviderState RUN (bit 4), wire.md §2.3
        local ds = X["pn_rt.ds"]()
        local ok_ds = ds ~= nil and bit.band(ds.value, 0x14) == 0x14
        local res = first_pass(pinfo, tvb, entry, ok_ds, fid)
        cached = {entry = entry, res = res}
        cyc_cache[pinfo.number] = cached
    end
    if tree then
        for i, c in ipairs(cached.res.objs) do add_object(tree, tvb, c.c, c, cached.entry.fm) end
        add_rules(tree, tvb, cached.res.rules)
        if cached.res.malformed then tree:add_proto_expert_info(E.malformed, cached.res.malformed) end
    end
    return false   -- let pn_io go on with its own IODataObject dissection
end
pndiss:register_heuristic("pn_io", heuristic)

-- profile selection (pndiss/records/profiles.py): vendor ID 0x0239 = Lika, then order ID patterns
local ORDER_PATTERNS = {
    {{"LIKA", "ROTACOD", "XAC77"}, "lika"},
    {{"SCANCON", "SAG%-E"}, "scancon"},
    {{"^E%u?%u?%u?M?58", "ENA58IL"}, "hohner"},
    {{"%f[%w]PSM?%f[%W]", "ACURO"}, "psm"},
}
function select_profile(vendor, order)
    if vendor == 0x0239 then return "lika" end
    if order then
        local u = order:upper():gsub("^%s+", ""):gsub("%s+$", "")
        for _, row in ipairs(ORDER_PATTERNS) do
            for _, pat in ipairs(row[1]) do
                if u:find(pat) then return row[2] end
            end
        end
    end
    return "generic"
end
local im0_seen = {}

-- postdissector: Connect learning, DCP/I&M0 identity, records
local rec_cache = {}
function pndiss.dissector(tvb, pinfo, tree)
    if cyclic_frame == pinfo.number then return end   -- cyclic data: nothing for the postdissector
    local op = X["pn_io.opnum"]()
    if op == nil then
        if not pinfo.visited then
            local v = X["pn_dcp.suboption_vendor_id"]()
            if v and not im0_seen[tostring(pinfo.dl_src)] then
                local dv = X["pn_dcp.suboption_device_devicevendorvalue"]()
                local f = facts[tostring(pinfo.dl_src)] or {}
                facts[tostring(pinfo.dl_src)] = f
                f.dcp = {v.value, dv and dv.value}
            end
        end
        return
    end
    local items = rec_cache[pinfo.number]
    if items == nil then
        if pinfo.visited then return end
        local pt = X["dcerpc.pkt_type"]()
        local act, seq = X["dcerpc.dg_act_id"](), X["dcerpc.dg_seqnum"]()
        local key = act and seq and (tostring(act) .. "|" .. tostring(seq.value))
        local ok, err = pcall(function()
            if op.value == 0 and pt and key then
                if pt.value == 0 then connect_request(key) elseif pt.value == 2 then connect_response(key, pinfo) end
            end
            items = record_items(pinfo, records_of_frame(pinfo))
        end)
        if not ok then items = {{error = tostring(err)}} end
        -- I&M0 read response: vendor ID + order ID name the profile (session.profile_for)
        local im = X["pn_io.im_profile_id"]()
        local vh, vl, oid = X["pn_io.vendor_id_high"](), X["pn_io.vendor_id_low"](), X["pn_io.order_id"]()
        if im and vh and vl then
            local dev = tostring(pinfo.dl_src)
            local f = facts[dev] or {}
            facts[dev] = f
            f.im0 = {vh.value * 256 + vl.value, oid and oid.value}
            profiles[dev] = nil   -- decided again at the next use
            im0_seen[dev] = true
            items[#items + 1] = {im0 = im.value}
        end
        rec_cache[pinfo.number] = items
    end
    if not tree or #items == 0 then return end
    for _, it in ipairs(items) do
        if it.error then
            tree:add_proto_expert_info(E.malformed, "pndiss: " .. it.error)
        elseif it.im0 then
            local st = tree:add(pndiss, tvb(0, 0), "PROFINET encoder: I&M0")
            st:add(F["pndiss.im0.profile_id"], it.im0)
            st:add(F["pndiss.im0.profile_name"], T.im_profile_ids[it.im0] or string.format("profile 0x%04X", it.im0))
        else
            local r = it.rec
            local t, ds, len = r.at[1], r.at[2], r.at[3]
            local st = tree:add(pndiss, t(ds, len), string.format("PROFINET encoder: record %s 0x%04X %s",
                r.op, r.index, it.index_name))
            st:add(F["pndiss.record.op"], r.op)
            st:add(F["pndiss.record.index"], r.index)
            st:add(F["pndiss.record.index_name"], it.index_name)
            st:add(F["pndiss.record.length"], len)
            if it.malformed then st:add_proto_expert_info(E.malformed, "record data do not decode") end
            if it.request then
                local q = it.request
                st:add(F["pndiss.param.kind"], "parameter request")
                st:add(F["pndiss.param.request_ref"], q.ref)
                st:add(F["pndiss.param.request_id"], request_id_name(q.id))
                st:add(F["pndiss.param.axis"], q.axis)
                for _, a in ipairs(q.params) do
                    local pt2 = st:add(F["pndiss.param.pnu"], a.pnu)
                    pt2:add(F["pndiss.param.subindex"], a.subindex)
                    pt2:add(F["pndiss.param.name"], a.name)
                end
            elseif it.param then
                local ev = it.param
                st:add(F["pndiss.param.kind"], "parameter response")
                if ev.request_frame then st:add(F["pndiss.param.request_frame"], ev.request_frame) end
                if ev.req then
                    st:add(F["pndiss.param.request_ref"], ev.req.ref)
                    st:add(F["pndiss.param.request_id"], request_id_name(ev.req.id))
                    st:add(F["pndiss.param.axis"], ev.req.axis)
                end
                st:add(F["pndiss.param.response_id"], ev.rsp.id)
                st:add(F["pndiss.param.ok"], ev.rsp.ok)
                for _, w in ipairs(ev.pairing) do st:add(F["pndiss.param.pairing"], w) end
                for _, p in ipairs(ev.params) do
                    local pt2 = st:add(F["pndiss.param.pnu"], p.pnu or 0)
                    if p.subindex then pt2:add(F["pndiss.param.subindex"], p.subindex) end
                    if p.name then pt2:add(F["pndiss.param.name"], p.name) end
                    if p.format then pt2:add(F["pndiss.param.format"], p.format) end
                    if p.error then
                        pt2:add(F["pndiss.param.error_code"], p.error.code)
                        pt2:add(F["pndiss.param.error"], p.error.text)
                    else
                        local vf = p.int and F["pndiss.param.value"] or F["pndiss.param.value_text"]
                        for _, v in ipairs(p.values) do pt2:add(vf, v) end
                    end
                end
            elseif it.bf00 then
                local d = it.bf00
                for _, n in ipairs(BF00_INT) do
                    if d[n] ~= nil then st:add(F["pndiss.bf00." .. n], d[n]) end
                end
                if d.mupr then st:add(F["pndiss.bf00.mupr"], d.mupr); st:add(F["pndiss.bf00.tmr"], d.tmr) end
                if d.velocity_unit_name then st:add(F["pndiss.bf00.velocity_unit_name"], d.velocity_unit_name) end
                for _, pr in ipairs(d.problems) do st:add(F["pndiss.bf00.problem"], pr) end
            end
        end
    end
end
register_postdissector(pndiss)
parse_usermap(pndiss.prefs.map)
