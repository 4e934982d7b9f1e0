-- pndiss.lua: PROFINET rotary encoder (PROFIdrive Encoder Profile V4.x) telegrams, records and
-- violation rules for Wireshark/tshark >= 4.0 (Lua 5.2). Field names and values match the Python
-- core (pndiss): pndiss.<signal>, pndiss.<signal>.<bit>, pndiss.param.*, pndiss.bf00.*, pndiss.rule.
--
-- Tables (telegram layouts, bit maps, names, rule catalogue) are generated from the Python tables
-- into pndiss_tables.lua by tools/gen_lua.py; the reference encoder (pndiss/encoder/*.py) is ported
-- to pndiss_checker.lua; this file decodes and drives the checker as pndiss/cyclic.py does.
--
-- Structure:
--   1. tables and fields           5. records: Python-shaped record/param events, 0xBF00, I&M0
--   2. preferences                 6. DCP: NameOfStation rules, duplicate names, occupied IPs
--   3. maps: Connect > map > none  7. cyclic driver (pndiss/cyclic.py CyclicTracker), violations
--   4. Connect learning            8. heuristic on the pn_io list, postdissector, init
--
-- Violations are decided on the first pass (pinfo.visited false) and cached per frame, also for
-- an earlier frame (deadline rules, controller-side rules naming the setpoint frame). The first
-- frame dissected again (visited true: tshark -2's second pass, Wireshark's redissection) runs
-- every checker's finish() before its tree is built, so the second pass shows every violation
-- on the frame the Python core names.

local bit = bit32 or bit  -- Lua 5.2 has bit32; some builds ship the BitOp 'bit' module only

-- 1. tables -------------------------------------------------------------------------------------
local function script_dir()
    local src = debug.getinfo(1, "S").source
    return (src:sub(1, 1) == "@" and src:sub(2):match("^(.*[/\\])")) or ""
end
-- Wireshark's dofile only searches its own folders: read the files next to this one ourselves
local function load_module(file, env)
    local path = script_dir() .. file
    local fh = assert(io.open(path, "rb"), "pndiss: cannot open " .. path)
    local text = fh:read("*a")
    fh:close()
    return assert(load(text, "@" .. path, "t", env))()
end
local T = load_module("pndiss_tables.lua", {})
-- the checker uses the standard library; globals it might set stay in its own environment
local C = load_module("pndiss_checker.lua", setmetatable({}, {__index = _G}))
C.init(T)

local pndiss = Proto("pndiss", "PROFINET encoder (pndiss)")
local F = {}          -- abbrev -> ProtoField
local CONST = {}      -- constant tables (the main chunk may hold at most 200 locals: room for ports)
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
field("pndiss.judged", ProtoField.bool, "Judged (AR in data exchange, DataValid, RUN, TransferStatus 0, IOPS and the device's IOCS good)")
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
-- bits: one field per (signal, bit name); profile variants share the name. Where every variant puts
-- the bit at the same place (and the word is unsigned and at most 32 bits) the field has the word's
-- type and the bit mask, so Wireshark shows "..1. ...." and filters on the field's own value; the tree
-- then adds the whole word (MASKED[abbrev]). Otherwise a plain field wide enough for the value.
local MASKED = {}
local function width_ctor(w)
    return w <= 8 and ProtoField.uint8 or w <= 16 and ProtoField.uint16 or w <= 32 and ProtoField.uint32
        or ProtoField.uint64
end
for _, sig in ipairs(sig_names) do
    local s = T.signals[sig]
    local where = {}
    for _, b in ipairs(T.bitmaps[sig] or {}) do
        local k = b.bit .. ":" .. b.width
        if where[b.name] == nil then where[b.name] = k elseif where[b.name] ~= k then where[b.name] = false end
    end
    for _, b in ipairs(T.bitmaps[sig] or {}) do
        local ab = "pndiss." .. sig .. "." .. b.name
        if not F[ab] then
            if where[b.name] and s.size <= 4 and not s.signed then
                local ones = b.width >= 32 and 0xFFFFFFFF or bit.lshift(1, b.width) - 1
                field(ab, UCTOR[s.size], b.title, base.DEC, nil, bit.lshift(ones, b.bit))
                MASKED[ab] = true
            else
                field(ab, width_ctor(b.width), b.title)
            end
        end
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
field("pndiss.param.request_id", ProtoField.uint8, "Request ID", base.HEX)
field("pndiss.param.request_id_name", ProtoField.string, "Request")
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
for _, n in ipairs(BF00_INT) do   -- labelled as the manuals name them; the flags byte in hex
    field("pndiss.bf00." .. n, ProtoField.uint8, ({flags = "Flags (byte 0)", code_sequence = "Code sequence",
        direction = "Direction", class4 = "Class 4 functionality", preset_control = "Preset control (G1_XIST1)",
        scaling = "Scaling function control", alarm_channel_control = "Alarm channel control",
        compat = "Compatibility mode (0: V3.1, 1: V4.1)", max_master_sol_failures = "Maximum master sign-of-life failures",
        velocity_unit = "Velocity measuring unit"})[n] or n, n == "flags" and base.HEX or base.DEC)
end
field("pndiss.bf00.mupr", ProtoField.uint64, "Measuring units per revolution")
field("pndiss.bf00.tmr", ProtoField.uint64, "Total measuring range")
field("pndiss.bf00.velocity_unit_name", ProtoField.string, "Velocity unit")
field("pndiss.bf00.problem", ProtoField.string, "Problem")
field("pndiss.im0.profile_id", ProtoField.uint16, "I&M0 profile ID", base.HEX)
field("pndiss.im0.profile_name", ProtoField.string, "I&M0 profile")
field("pndiss.rule", ProtoField.string, "Violated rule")
-- the frame whose dissection decided the violation (0 = at the end of the capture, finish()): a
-- violation decided on a later frame than the one it names is shown only in a second pass
field("pndiss.rule.decided_at", ProtoField.uint32, "Decided at frame (0: end of capture)")
-- who broke the protocol (the core's "side"): filter pndiss.rule.side == "controller"
field("pndiss.rule.side", ProtoField.string, "Side (controller or encoder)")
-- on the deciding frame: a violation this frame decided for an earlier frame (what a single pass,
-- which has printed that frame already, can still show); not pndiss.rule, so -Y pndiss.rule is unchanged
field("pndiss.late_rule", ProtoField.string, "Violation decided here for an earlier frame")
field("pndiss.late_rule.frame", ProtoField.framenum, "Violation in frame")

-- expert infos: one per catalogue rule (filterable: pndiss.rule.<ID>)
local SEV = {error = expert.severity.ERROR, warning = expert.severity.WARN, info = expert.severity.NOTE}
local E = {}
local rule_ids = {}
for id in pairs(T.rules) do rule_ids[#rule_ids + 1] = id end
table.sort(rule_ids)
for _, id in ipairs(rule_ids) do
    local r = T.rules[id]
    E[id] = ProtoExpert.new("pndiss.rule." .. id, id .. " (" .. r.section .. ")", expert.group.PROTOCOL, SEV[r.severity])
end
E.malformed = ProtoExpert.new("pndiss.malformed", "pndiss: malformed", expert.group.MALFORMED, expert.severity.WARN)
E.blind = ProtoExpert.new("pndiss.no_first_pass_tree", "pndiss: no protocol tree on the first pass",
    expert.group.DEBUG, expert.severity.WARN)
local experts = {}
for _, id in ipairs(rule_ids) do experts[#experts + 1] = E[id] end
experts[#experts + 1] = E.malformed
experts[#experts + 1] = E.blind
pndiss.experts = experts

-- 2. preferences ---------------------------------------------------------------------------------
pndiss.prefs.map = Pref.string("Manual map", "",
    "FrameID[:input|output]=telegram[@offset], comma separated (e.g. 0x8000:input=81,0x8001:output=81); "
    .. "used for frames no Connect describes (like pndiss --map)")
pndiss.prefs.profile = Pref.enum("Device profile", 1, "auto = from I&M0 / DCP vendor and order ID",
    {{1, "auto", 1}, {2, "lika", 2}, {3, "scancon", 3}, {4, "hohner", 4}, {5, "psm", 5}, {6, "generic", 6}}, false)
pndiss.prefs.telegram = Pref.uint("Telegram", 0, "telegram when neither Connect nor map tells it (0 = none: only a guess from both directions' lengths)")
pndiss.prefs.settings = Pref.string("Settings", "",
    "reference encoder settings like pndiss --set, comma separated (e.g. l_max=3,sol_monitor_rt=1,st_phys=8192); "
    .. "keys: " .. "l_max preset_deadline_ms sol_threshold_ge sol_monitor_rt iso master_cycle_ratio compat class4 "
    .. "st_phys mt_phys xist1_shift max_position_step p65000")
local PROFILE_PREF = {"auto", "lika", "scancon", "hohner", "psm", "generic"}

-- pndiss.settings.Settings defaults of the keys EncoderConfig.from_settings reads
local SETTING_DEFAULTS = {l_max = 2, preset_deadline_ms = 10.0, sol_threshold_ge = false, sol_monitor_rt = false}
local SETTING_BOOLS = {sol_threshold_ge = true, sol_monitor_rt = true, iso = true}
local SETTING_KEYS = {l_max = true, preset_deadline_ms = true, sol_threshold_ge = true, sol_monitor_rt = true,
                      iso = true, master_cycle_ratio = true, compat = true, class4 = true, st_phys = true,
                      mt_phys = true, xist1_shift = true, max_position_step = true, p65000 = true}
local settings = {}
local function parse_settings(s)
    settings = {}
    for k, v in pairs(SETTING_DEFAULTS) do settings[k] = v end
    local bad = {}   -- what pndiss --set refuses (a usage error there): said, not silently dropped
    for item in tostring(s or ""):gmatch("[^,%s]+") do
        local k, v = item:match("^([%w_]+)=(.+)$")
        local lv = v and v:lower()
        if k and SETTING_KEYS[k] and (lv == "none" or lv == "null") then
            settings[k] = nil   -- as --set KEY=none: from the capture / the default (settings._coerce)
        elseif k and SETTING_KEYS[k] and SETTING_BOOLS[k] then
            local b = ({["1"] = true, ["true"] = true, ["yes"] = true, ["on"] = true,
                        ["0"] = false, ["false"] = false, ["no"] = false, ["off"] = false})[lv]
            if b == nil then bad[#bad + 1] = item else settings[k] = b end
        elseif k and SETTING_KEYS[k] and tonumber(v) then
            settings[k] = tonumber(v)
        else
            bad[#bad + 1] = item   -- an unknown key (byte_order: pndiss analyze --set only), or a bad value
        end
    end
    settings.ignored = #bad > 0 and table.concat(bad, ", ") or nil
    if settings.ignored then
        io.stderr:write("pndiss: Settings preference: ignored " .. settings.ignored .. " (keys: l_max "
            .. "preset_deadline_ms sol_threshold_ge sol_monitor_rt iso master_cycle_ratio compat class4 st_phys "
            .. "mt_phys xist1_shift max_position_step p65000; none = from the capture)\n")
    end
end

-- 3. maps ----------------------------------------------------------------------------------------
-- Per-capture state is (re)created by reset_state() (section 8) from the protocol's init routine,
-- which Wireshark calls before every (re)dissection of the file.
-- Connect-derived maps: key "fid|src|dst" -> {direction, device, controller, station, ar, frame_id,
-- cycle_ns, source, objects}
local maps, map_cache
local open_req         -- DCE/RPC "act|seq" -> frame of its request, until the response (retransmissions run once)
local alarm_seq        -- device MAC .. "|" .. alarm endpoint .. "|" .. priority -> {sequence number, time} (resends)
local dcp_state        -- DcpTracker state (section 6); station = MAC -> last NameOfStation (stations.py)
local usermap = {}     -- fid -> {direction, telegram, offset} (preference, not capture state)
local profiles         -- device MAC -> profile (I&M0 / DCP)
local ar_devs          -- AR UUID -> {device, controller} (session.ars: records name their AR)
local p922_of          -- "device|api|slot|subslot" -> telegram read from P922 (session.telegram_p922)
local ar_keys          -- AR UUID -> {{fid, src, dst}, ...} of its frame maps (session.frame_keys)
local ar_phase         -- AR UUID -> phase (session.set_phase; only what changes the verdict is tracked)
local ar_order         -- AR UUIDs in the order of their Connects (session.ars, for an abort)
local DRIVE_APIS = {[0x3A00] = true, [0x3D00] = true}   -- spec/network.md §1.7

local function tg_len(t, dir)
    local n = 0
    for _, s in ipairs(T.telegrams[t][dir]) do n = n + T.signals[s].size end
    return n
end

-- telegrams.telegrams_for_length: every telegram whose lengths fit (nil = any), in number order
local tg_sorted = {}
for t in pairs(T.telegrams) do tg_sorted[#tg_sorted + 1] = t end
table.sort(tg_sorted)
local function telegrams_for_length(actual, setpoint)
    local out = {}
    for _, t in ipairs(tg_sorted) do
        if (actual == nil or tg_len(t, "actual") == actual) and (setpoint == nil or tg_len(t, "setpoint") == setpoint) then
            out[#out + 1] = t
        end
    end
    return out
end

-- session.guess_telegram: both lengths must fit; 87 (4/4) and 86/860 (4/8) only on the encoder API 0x3D00, any
-- telegram in subslot 1 only on drive APIs, or on a device known as an encoder of a profile that has them (its own
-- telegrams first)
local function guess_telegram(out_len, in_len, api, profile, subslot)
    if out_len == nil or in_len == nil then return nil end
    local first, mine = nil, nil
    for _, row in ipairs(T.telegram_lengths) do
        if row[2] == out_len and row[3] == in_len then
            first = first or row[1]
            if mine == nil and profile ~= nil and profile ~= "generic" then
                for _, p in ipairs(T.telegrams[row[1]].profiles) do
                    if p == profile then mine = row[1] end
                end
            end
        end
    end
    if first == nil then return nil end
    if (api ~= 0x3D00 and ((out_len == 4 and in_len == 4) or (out_len == 4 and in_len == 8)))
            or (not DRIVE_APIS[api] and subslot == 1) then
        return mine
    end
    return mine or first
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
    parse_settings(pndiss.prefs.settings)
    map_cache = {}
end

-- session.profile_for: decided at its first use for a device from what is known then (I&M0 vendor
-- and order ID, else DCP vendor ID and DeviceVendorValue) and kept until an I&M0 read
local facts            -- device MAC -> {dcp = {vendor, type}, im0 = {vendor, order}}
local select_profile   -- defined with the postdissector
local function profile_for(mac)
    local p = PROFILE_PREF[pndiss.prefs.profile] or "auto"
    if p ~= "auto" then return p, "set by the Device profile preference" end
    if profiles[mac] == nil then
        local f = facts[mac] or {}
        local src = f.im0 or f.dcp or f.connect   -- (the Connect's object UUID: session_ar._connect_identity)
        profiles[mac] = {src and select_profile(src[1], src[2]) or "generic",
                         f.im0 and "I&M0" or (f.dcp and "DCP") or (f.connect and "Connect") or "no identity seen"}
        if profiles[mac][1] == "generic" and f.ffff then   -- only PS/PSM keeps its parameters at 0xFFFF
            profiles[mac] = {"psm", "record 0xFFFF written in frame " .. f.ffff .. ": PS/PSM's encoder parameter record"}
        elseif profiles[mac][1] == "generic" and f.words then   -- an inferred layout's words fit one profile only
            profiles[mac] = {f.words, "the control/status words of its inferred telegram set bits only profile "
                             .. f.words .. " defines"}
        end
    end
    return profiles[mac][1], profiles[mac][2]
end

-- telegram layouts (telegrams.layout): rows {name, off, size, signed} and the length, per direction
local layouts = {}
local function layout(t, dir)
    local k = t .. dir
    local L = layouts[k]
    if L == nil then
        local rows, off = {}, 0
        for _, name in ipairs(T.telegrams[t][dir]) do
            local s = T.signals[name]
            rows[#rows + 1] = {name = name, off = off, size = s.size, signed = s.signed}
            off = off + s.size
        end
        L = {rows = rows, len = off}
        layouts[k] = L
    end
    return L
end

-- cyclic.py _Obj: one data object of a mapped frame (d = the map's DataObject, shared with the map
-- so that a P922 relabel is seen on the next frame)
local function new_obj(d, telegram, source, dir, key, iocs_at)
    local L = layout(telegram, dir)
    return {d = d, telegram = telegram, source = source, rows = L.rows, len = L.len, key = key,
            stop = d.offset + d.length, sig = nil, length_checked = false, rejected = nil, ax = nil,
            iocs_at = iocs_at}   -- (an actual value's frame: the device's IOCS of the setpoints, cyclic.py _Obj)
end

-- like pndiss/cyclic.py CyclicTracker._frame/on_cyclic: a layout, once found, stays (with its objects)
-- until the maps change (map_generation: each Connect or P922 read), then every key is looked up
-- again; an unmapped key is also looked up again every RELOOKUP_EVERY frames of that key
local RELOOKUP_EVERY = 1024
local gen   -- per map generation: misses (key -> lookups that found nothing), checked (keys whose trailer
            -- was looked at); trim (key -> C_SDU length by the Connect, for frames with a trailer) lives on

-- capture loss, as pndiss/gaps.py: per (frame ID, src, dst) stream the CycleCounter of its last frame;
-- round(advance / step) - 1 cycles are missing, once the step is known (Connect) or seen LEARN times
local gap_streams
local gap_last_ts      -- MAC -> time of the latest capture gap of a stream to or from it (gaps.GapTracker.last_by_mac)
local GAP_LEARN, GAP_IRREGULAR_MAX = 4, 3
-- restart: gaps.restart -- the stream's AR ended or connects again: a new counter, its step the next Connect's
local function gap_stream(key, restart)
    local st = gap_streams[key]
    if st == nil or restart then
        st = {step = 0, known = false, seen = 0, irregular = 0, uniform = true}
        gap_streams[key] = st
    end
    return st
end
local function gap_step_from(key, cycle_ns)
    local st = gap_stream(key)
    local step = cycle_ns and math.floor(cycle_ns / 31250) or 0
    if step > 0 and step < 0x10000 and (st.step == 0 or not (st.known or st.irregular > 0)) then
        -- the Connect says it; a step the counter contradicted stays (gaps.py step_from)
        if st.step ~= step then st.seen = 0 end
        st.step, st.known = step, true
    end
end
local function gcd(a, b)
    while b ~= 0 do a, b = b, a % b end
    return a
end
local GAP_UNIT_NS, GAP_HALF_WRAP_NS = 31250, 0x10000 * 31250 / 2
local GAP_NEWER_MAX = 61440
local NOT_OWNED = "not owned"   -- armap.NOT_OWNED: a shared-input submodule (another AR controls it)
local NO_DST = "NONE"   -- proto/eth.NO_DST: tshark's destination of a Linux cooked frame (its header carries none)
-- pndiss/gaps.py duplicate: a frame whose counter is not newer than the stream's previous frame's (the consumer's
-- cycle-counter check: (now - last) mod 2^16 in 1..61440), less than half a wrap later, is discarded: returns
-- (that frame, true) for a copy of it (same counter, DataStatus and C_SDU), (that frame, false) for a stale one
local function gap_duplicate(key, cc, ts, last)
    local st = gap_streams[key]
    if st == nil or st.cc == nil or st.ts == nil or ts - st.ts >= GAP_HALF_WRAP_NS then return nil end
    local d = (cc - st.cc) % 0x10000
    if d >= 1 and d <= GAP_NEWER_MAX then return nil end
    if d ~= 0 and key:sub(-#NO_DST - 1) == "|" .. NO_DST then return nil end   -- a cooked capture: two ARs' streams may share a key
    return st.fn, d == 0 and st.last == last
end
local function gap_advance(key, cc, ts, last, fn)
    local st = gap_stream(key)
    local prev, pts = st.cc, st.ts
    st.cc, st.ts, st.last, st.fn = cc, ts, last, fn
    if prev == nil then return 0 end
    local d = (cc - prev) % 0x10000
    if pts ~= nil and ts - pts >= GAP_HALF_WRAP_NS and st.uniform   -- (also one step on: a loss of k x 2.048 s)
            and (st.known or st.seen >= GAP_LEARN) then
        -- the counter may have wrapped during the gap: the time stamps tell the cycles (pndiss/gaps.py)
        local period = st.step * GAP_UNIT_NS
        local k0 = math.floor((ts - pts + math.floor(period / 2)) / period) - 1
        local k = nil   -- gaps.with_counter: the nearest count the counter's advance agrees with (drift, 20 ms)
        for delta = 0, math.max(2, math.floor(k0 / 5000), math.floor(20000000 / period)) do
            for _, kk in ipairs({k0 - delta, k0 + delta}) do
                if k == nil and kk >= 0 and ((kk + 1) * st.step - d) % 0x10000 == 0 then k = kk end
            end
            if k ~= nil then break end
        end
        if k == nil or (d == st.step and math.abs(k - k0) > math.max(2, math.floor(20000000 / period))) then
            -- (exactly one step on across a jump of the capture's time the time stamps miss: a clock step too)
            -- gaps._clock_jump: the whole capture's time jumped inside the pause (the postdissector notes the jumps
            -- of every frame in "*jumps"; the one up to this frame is still pending): a clock step, the counter
            -- says what was lost; else a stream that alone went quiet (a device restarting): the time stamps say it
            local need = ts - pts - 20000000 - 2 * period
            local last = gap_last_ts["*last"]
            local clock = last ~= nil and pts <= last and ts - last >= math.max(need, 500000000)
            for _, j in ipairs(gap_last_ts["*jumps"] or {}) do
                if pts <= j[1] and j[2] <= ts and j[2] - j[1] >= need then clock = true end
            end
            if clock then k = nil elseif k == nil then k = k0 end
        end
        if k ~= nil and k > 0 then
            for mac in key:gmatch("|([^|]*)") do   -- gaps.GapTracker._lost_at: per MAC of the stream
                if gap_last_ts[mac] == nil or ts > gap_last_ts[mac] then gap_last_ts[mac] = ts end
            end
            return k
        end
    end
    if d == 0 then return 0 end
    if st.step == 0 then st.step = d; return 0 end
    if d % st.step ~= 0 then
        st.irregular = st.irregular + 1
        st.step = gcd(st.step, d)
        st.seen, st.known = 0, false
        if st.irregular >= GAP_IRREGULAR_MAX then st.uniform = false end
        return 0
    end
    if d == st.step then
        st.seen = st.seen + 1
        if st.seen >= GAP_LEARN then st.irregular = 0 end
        return 0
    end
    if not st.uniform or (not st.known and st.seen < GAP_LEARN) then
        if st.irregular > 0 and not st.known then
            st.irregular = st.irregular + 1
            if st.irregular >= GAP_IRREGULAR_MAX then st.uniform = false end
        end
        return 0
    end
    for mac in key:gmatch("|([^|]*)") do   -- gaps.GapTracker._lost_at
        if gap_last_ts[mac] == nil or ts > gap_last_ts[mac] then gap_last_ts[mac] = ts end
    end
    return math.floor(d / st.step) - 1
end
-- both streams advance by one confirmed step per cycle: each actual value has its own setpoint
local function gap_same_step(a, b)
    local sa, sb = gap_streams[a or ""], gap_streams[b or ""]
    return sa ~= nil and sb ~= nil and sa.step == sb.step and sa.uniform and sb.uniform
        and (sa.known or sa.seen >= GAP_LEARN) and (sb.known or sb.seen >= GAP_LEARN)
end
-- gaps.faster: stream a at a confirmed smaller step than stream b (an output CR faster than the input CR)
local function gap_faster(a, b)
    local sa, sb = gap_streams[a or ""], gap_streams[b or ""]
    return sa ~= nil and sb ~= nil and sa.step > 0 and sa.step < sb.step and sa.uniform and sb.uniform
        and (sa.known or sa.seen >= GAP_LEARN) and (sb.known or sb.seen >= GAP_LEARN)
end
local map_generation, cache_generation
-- peek: the stream's map only (session.lookup), nothing cached or counted
local function lookup(fid, src, dst, peek)
    if cache_generation ~= map_generation then
        cache_generation = map_generation
        map_cache, gen = {}, {misses = {}, checked = {}, trim = gen.trim}
    end
    local key = fid .. "|" .. src .. "|" .. dst
    local c = map_cache[key]
    if c ~= nil and not peek then
        if c then return c end
        gen.misses[key] = gen.misses[key] + 1
        if gen.misses[key] % RELOOKUP_EVERY ~= 0 then return nil end
    end
    local fm = maps[key]
    if fm == nil and dst == NO_DST then
        -- session.lookup: a Linux cooked capture has no destination address; the frame ID and the sender name
        -- the stream when exactly one map has them
        local pre, found, n = fid .. "|" .. src .. "|", nil, 0
        for k, m in pairs(maps) do
            if k:sub(1, #pre) == pre then found, n = m, n + 1 end
        end
        if n == 1 then fm = found end
    end
    if fm == nil and usermap[fid] then
        local u = usermap[fid]
        local inp = u.direction == "input"
        local L = tg_len(u.telegram, inp and "actual" or "setpoint")
        fm = {direction = u.direction, device = inp and src or dst, controller = inp and dst or src,
              frame_id = fid, source = "map",
              objects = {{api = 0, slot = 0, subslot = 0, offset = u.offset, length = L,
                          telegram = u.telegram, telegram_source = "map"}}}
    end
    if peek then return fm end
    local out = false
    if fm then
        local dir = fm.direction == "output" and "setpoint" or "actual"
        gap_step_from(key, fm.cycle_ns)
        local objs = {}
        for _, d in ipairs(fm.objects) do
            if d.length and d.length > 0 then
                local t, source = d.telegram, d.telegram_source
                local pt = pndiss.prefs.telegram
                if pt ~= 0 and d.telegram_source ~= NOT_OWNED and (t == nil or (tostring(source):sub(1, 6) == "length" and T.telegrams[pt] ~= nil
                        and T.telegrams[t] ~= nil and layout(pt, "setpoint").len == layout(t, "setpoint").len
                        and layout(pt, "actual").len == layout(t, "actual").len)) then   -- the guess's lengths only
                    t, source = pndiss.prefs.telegram, "settings.telegram"
                end
                -- no telegram from the session (map, P922, both directions' lengths) and no preference:
                -- not an encoder submodule (a one-direction length guess would take any IO module)
                if t ~= nil and T.telegrams[t] then
                    local axkey = table.concat({fm.ar or (fm.controller .. "/" .. fm.device), d.api or 0,
                                                d.slot or 0, d.subslot or 0}, "|")
                    local iocs_at = nil
                    if dir == "actual" then
                        for _, c in ipairs(fm.iocs or {}) do
                            if c.api == d.api and c.slot == d.slot and c.subslot == d.subslot then iocs_at = c.offset end
                        end
                    end
                    objs[#objs + 1] = new_obj(d, t, source, dir, axkey, iocs_at)
                end
            end
        end
        out = {fm = fm, dir = dir, objs = objs, last_csdu = nil}
    end
    map_cache[key] = out
    if not out and gen.misses[key] == nil then gen.misses[key] = 0 end
    return out or nil
end
-- 4. Connect learning -----------------------------------------------------------------------------
local X = {}
for _, n in ipairs({"pn_io.opnum", "pn_io.block_type", "pn_io.ar_uuid", "pn_io.cminitiator_mac_add",
                    "pn_io.cmresponder_macadd", "pn_io.iocr_type", "pn_io.iocr_reference", "pn_io.frame_id",
                    "pn_io.data_length", "pn_io.api", "pn_io.slot_nr", "pn_io.subslot_nr",
                    "pn_io.io_data_object.frame_offset", "pn_io.iocs_frame_offset", "pn_io.data_description",
                    "pn_io.submodule_data_length", "pn_io.length_iops", "pn_io.length_iocs",
                    "pn_io.submodule_properties", "pn_io.submodule_state",
                    "pn_io.module_ident_number", "pn_io.submodule_ident_number", "pn_io.iocr_multicast_mac_add",
                    "pn_io.index", "pn_io.im_profile_id", "pn_io.vendor_id_high", "pn_io.vendor_id_low",
                    "pn_io.order_id", "dcerpc.pkt_type", "dcerpc.dg_act_id", "dcerpc.dg_seqnum", "dcerpc.dg_frag_len", "dcerpc.obj_id",
                    "pn_rt.frame_id", "pn_rt.ds", "pn_rt.transfer_status", "pn_rt.cycle_counter", "pn_io.send_clock_factor", "pn_io.reduction_ratio",
                    "pn_io.error_code", "pn_io.error_decode", "pn_io.error_code1", "pn_io.error_code2",
                    "pn_io.control_command", "pn_io.pdu_type.type", "pn_io.alarm_type", "pn_io.send_seq_num",
                    "pn_io.alarm_src_endpoint", "pn_io.alarm_dst_endpoint", "pn_io.localalarmref",
                    "pn_io.channel_error_type", "pn_io.channel_properties.specifier", "pn_io.artype_req",
                    "pn_dcp.service_id", "lldp.chassis.subtype", "lldp.chassis.id", "lldp.port.subtype", "lldp.port.id",
                    "lldp.profinet.subtype",
                    "pn_dcp.suboption_vendor_id", "pn_dcp.suboption_device_id", "pn_dcp.suboption_device_devicevendorvalue",
                    "frame.drop_count"}) do
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

-- latin-1 bytes as UTF-8 text (cmblock.text: bytes.decode("latin-1"))
local function latin1(raw)
    return (raw:gsub("[\128-\255]", function(c)
        local b = c:byte()
        return string.char(0xC0 + math.floor(b / 64), 0x80 + b % 64)
    end))
end

-- session.station_name: a MAC's NameOfStation from the station table (DCP, Connects), nil when unknown or empty
local function station_of(mac)
    local n = dcp_state.station[mac]
    if n == nil or n == "" then return nil end
    return n
end

local pending_connects   -- "act|seq" -> request summary

-- session_ar._replaces: a Connect that takes over the cyclic data of the AR the controller holds with the device
-- (an AR with IOCRs that is no supervisor AR; a supervisor / Device Access AR from the same MAC runs beside it)
-- session_ar._held: the ARs other than ar this controller holds with this device (up: not ended)
local function held(controller, device, ar)
    local out = {}
    for _, a in ipairs(ar_order) do
        local d = ar_devs[a]
        if a ~= ar and d ~= nil and d[1] == device and d[2] == controller and ar_phase[a] ~= nil
                and ar_phase[a] ~= "released" and ar_phase[a] ~= "aborted" and d[5] then   -- (an IO AR: d[5])
            out[#out + 1] = a
        end
    end
    return out
end

-- gaps.restart of an AR's streams its maps still hold: the next frame starts a new cycle counter. With MACs a, b:
-- session_ar.end_inferred -- the AR between them known only from its content (no Connect, no UUID) ended (its
-- Release, an ERR-RTA-PDU, its controller's new Connect): its maps end with it, its streams' counters start afresh
local function restart_gaps(ar, a, b, phase)
    if a ~= nil then
        for sk, fm in pairs(maps) do
            if fm.source == "content" and fm.phase ~= "released" and fm.phase ~= "aborted"
                    and ((fm.controller == a and fm.device == b) or (fm.controller == b and fm.device == a)) then
                fm.phase = phase
                if gap_streams[sk] ~= nil then gap_stream(sk, true) end
            end
        end
        map_generation = map_generation + 1
        return
    end
    for _, k in ipairs(ar_keys[ar]) do
        local sk = k[1] .. "|" .. k[2] .. "|" .. k[3]
        if gap_streams[sk] ~= nil and maps[sk] == k[4] then gap_stream(sk, true) end
    end
end

local function replaces(req)
    return req.ar_type ~= 0x0006 and #req.iocrs > 0
end

local function connect_request(key, pinfo)
    local bl = blocks()
    local req = {iocrs = {}, expected = {}, src = tostring(pinfo.dl_src), dst = tostring(pinfo.dl_dst)}
    local api, slot, sub = all("pn_io.api"), all("pn_io.slot_nr"), all("pn_io.subslot_nr")
    for _, b in ipairs(bl) do
        if b.type == 0x0101 then
            local u, m = inside(all("pn_io.ar_uuid"), b), inside(all("pn_io.cminitiator_mac_add"), b)
            req.ar = u[1] and tostring(u[1])
            req.controller = m[1] and tostring(m[1].value)
            local at = inside(all("pn_io.artype_req"), b)[1]   -- a label in tshark 4.0: its two bytes are the ARType
            req.ar_type = at and at.range:len() == 2 and at.range:uint() or nil
        elseif b.type == 0x0103 then   -- AlarmCRBlockReq: the controller's local alarm reference
            local r = inside(all("pn_io.localalarmref"), b)[1]
            req.cref = r and r.value
        elseif b.type == 0x0102 then
            local function first(n) local l = inside(all(n), b); return l[1] and l[1].value end
            local cr = {type = first("pn_io.iocr_type"), ref = first("pn_io.iocr_reference"),
                        frame_id = first("pn_io.frame_id"), data_length = first("pn_io.data_length"),
                        mcast = first("pn_io.iocr_multicast_mac_add"), scf = first("pn_io.send_clock_factor"),
                        rr = first("pn_io.reduction_ratio"), objects = {}, iocs = {}}
            local ba, bs, bss = inside(api, b), inside(slot, b), inside(sub, b)
            for _, fo in ipairs(inside(all("pn_io.io_data_object.frame_offset"), b)) do
                cr.objects[#cr.objects + 1] = {api = before(ba, fo.offset), slot = before(bs, fo.offset),
                                               subslot = before(bss, fo.offset), offset = fo.value}
            end
            for _, fo in ipairs(inside(all("pn_io.iocs_frame_offset"), b)) do   -- armap.IocsEntry
                cr.iocs[#cr.iocs + 1] = {api = before(ba, fo.offset), slot = before(bs, fo.offset),
                                         subslot = before(bss, fo.offset), offset = fo.value}
            end
            req.iocrs[#req.iocrs + 1] = cr
        elseif b.type == 0x0104 then
            local ba, bs, bss = inside(api, b), inside(slot, b), inside(sub, b)
            local dd, iops = inside(all("pn_io.data_description"), b), inside(all("pn_io.length_iops"), b)
            local props = inside(all("pn_io.submodule_properties"), b)
            for _, l in ipairs(inside(all("pn_io.submodule_data_length"), b)) do
                local k = table.concat({before(ba, l.offset) or 0, before(bs, l.offset) or 0,
                                        before(bss, l.offset) or 0}, "/")
                local e = req.expected[k] or {}
                local d = before(dd, l.offset)
                local io = nil
                for _, fi in ipairs(iops) do if fi.offset > l.offset then io = fi.value break end end
                -- SubmoduleProperties (wire.md §6.6): bit 2 SharedInput, bits 3/4 reduce this AR's input/output to 0 bytes
                local pr = before(props, l.offset) or 0
                e.shared_input = bit.band(pr, 0x4) ~= 0
                local n = l.value
                if (d == 1 and bit.band(pr, 0x8) ~= 0) or (d == 2 and bit.band(pr, 0x10) ~= 0) then n = 0 end
                if d == 1 then e.input = {n, io or 1} elseif d == 2 then e.output = {n, io or 1} end
                req.expected[k] = e
            end
        end
    end
    pending_connects[key] = req
    -- session_ar._connect_identity: the object UUID DEA00000-6C97-11D1-8271-{instance}{device ID}{vendor ID}
    local oid = X["dcerpc.obj_id"]()
    oid = oid and tostring(oid):lower() or ""   -- (a GUID field has no .value in Wireshark 4.0's Lua: its text)
    if oid:sub(1, 24) == "dea00000-6c97-11d1-8271-" and #oid == 36 and tonumber(oid:sub(33, 36), 16) then
        local f = facts[req.dst] or {}
        if f.connect == nil then
            f.connect, facts[req.dst], profiles[req.dst] = {tonumber(oid:sub(33, 36), 16), nil}, f, nil
        end
    end
    if not replaces(req) then return end
    -- session_ar._connect_requested: the device may provide the new AR's frames before the response, so the
    -- streams of the AR the controller holds with it start their capture-loss tracking afresh
    restart_gaps(nil, req.controller, req.dst, "aborted")
    for _, a in ipairs(held(req.controller, req.dst, req.ar)) do restart_gaps(a) end
    -- cyclic_axes.restart_between: and any stream between the two, of an AR the capture never knew
    for sk, _ in pairs(gap_streams) do
        local _, src, dst = sk:match("^([^|]*)|([^|]*)|([^|]*)$")
        if (src == req.controller and dst == req.dst) or (src == req.dst and dst == req.controller) then
            gap_stream(sk, true)
        end
    end
end

local on_reconnect     -- CyclicTracker.on_reconnect (section 7): an AR UUID connected again
local ar_moves         -- SessionTracker.set_phase (section 7): an AR moves to a later phase
-- res: a response read before its request (session.orphans), applied when the request comes
local function connect_response(key, pinfo, res)
    if res == nil then
        -- session._connect: a refused Connect (PNIOStatus not 0) maps no frames
        res = {number = pinfo.number, ok = true, device = tostring(pinfo.dl_src), res_fid = {},
               locked = {}}   -- locked: "api/slot/subslot" -> another AR owns it (session_ar.diff_state, ModuleDiffBlock)
        for _, n in ipairs({"pn_io.error_code", "pn_io.error_decode", "pn_io.error_code1", "pn_io.error_code2"}) do
            local st = all(n)[1]
            if st and st.value ~= 0 then res.ok = false end
        end
        local bl = blocks()
        local res_fid, locked = res.res_fid, res.locked
        for _, b in ipairs(bl) do
            if b.type == 0x8104 then
                local ba, bs, bss = inside(all("pn_io.api"), b), inside(all("pn_io.slot_nr"), b), inside(all("pn_io.subslot_nr"), b)
                for _, st in ipairs(inside(all("pn_io.submodule_state"), b)) do
                    local v = st.value
                    local why
                    if bit.band(v, 0x8000) ~= 0 then   -- (or the submodule plugged is wrong / none: no parameters either)
                        why = ({[2] = "superordinated locked", [3] = "locked by IO controller",
                                [4] = "locked by IO supervisor"})[bit.band(bit.rshift(v, 7), 0xF)]
                              or ({[2] = "wrong submodule", [3] = "no submodule"})[bit.band(bit.rshift(v, 11), 0xF)]
                    else
                        why = ({[2] = "locked by IO controller", [0] = "no submodule",
                                [1] = "wrong submodule"})[bit.band(v, 0x7FFF)]
                    end
                    if why then
                        locked[table.concat({before(ba, st.offset) or 0, before(bs, st.offset) or 0,
                                             before(bss, st.offset) or 0}, "/")] = why
                    end
                end
            elseif b.type == 0x8101 then
                local m = inside(all("pn_io.cmresponder_macadd"), b)
                if m[1] then res.device = tostring(m[1].value) end
            elseif b.type == 0x8103 then   -- AlarmCRBlockRes: the device's local alarm reference
                local r = inside(all("pn_io.localalarmref"), b)[1]
                res.dref = r and r.value
            elseif b.type == 0x8102 then
                local r, f = inside(all("pn_io.iocr_reference"), b), inside(all("pn_io.frame_id"), b)
                if r[1] and f[1] then res_fid[r[1].value] = f[1].value end
            elseif b.type == 0x8106 and res.server_name == nil then
                -- cm_connect._ar_server: u16 StationNameLength + the device's NameOfStation (latin-1), first block
                local o, t = b.s + 6, b.tvb
                if o + 2 <= b.e and o + 2 <= t:len() then
                    local n = t(o, 2):uint()
                    if o + 2 + n <= b.e and o + 2 + n <= t:len() then
                        res.server_name = n > 0 and latin1(t(o + 2, n):raw()) or ""
                    end
                end
            end
        end
        if pending_connects[key] == nil then
            -- session.orphans: the capture holds the response before its request (a device's NIC or a TAP port stamping
            -- early, the file sorted by time): kept until the request comes (the caller hands it back then)
            pending_connects["orphan|" .. key] = res
            return
        end
    end
    local req = pending_connects[key]
    pending_connects[key] = nil
    if req == nil or req.controller == nil then return end
    map_generation = map_generation + 1
    req.dref = res.dref
    local ok, device, res_fid, server_name, locked, fn = res.ok, res.device, res.res_fid, res.server_name, res.locked,
        res.number
    if req.ar and (ok or ar_devs[req.ar] == nil) then   -- device, controller, alarm refs, an IO AR (replaces)
        ar_devs[req.ar] = {device, req.controller, req.cref, req.dref, replaces(req)}
    end
    -- session._connect: dev_station = the station table's name (DCP, an earlier Connect) or the ARServerBlock's;
    -- it goes into the station table, a refused Connect's too
    local station = station_of(device)
    if station == nil then station = server_name ~= "" and server_name or nil end
    if station ~= nil then dcp_state.station[device] = station end
    if not ok then return end
    if replaces(req) then   -- cyclic_axes.on_new_ar: the new AR's alarms number afresh (not a supervisor's beside it)
        for k in pairs(alarm_seq) do
            if k:sub(1, #device + 1) == device .. "|" then alarm_seq[k] = nil end
        end
    end
    -- session_ar._superseded: the controller's new Connect ends the AR it held with this device (power lost,
    -- link down, an abort not captured), before the new maps take its streams
    if replaces(req) then
        for _, a in ipairs(held(req.controller, device, req.ar)) do ar_moves(a, "aborted", fn) end
    end
    local keys = {}
    local again = req.ar ~= nil and ar_phase[req.ar] ~= nil   -- session_ar: controllers may reuse an AR UUID
    if req.ar then
        if ar_phase[req.ar] == nil then ar_order[#ar_order + 1] = req.ar end
        ar_keys[req.ar], ar_phase[req.ar] = keys, "parameterisation"
    end
    for _, cr in ipairs(req.iocrs) do
        local direction = ({[1] = "input", [2] = "output", [3] = "input"})[cr.type]
        if direction then
            local fid = res_fid[cr.ref] or cr.frame_id
            local s, d = device, req.controller
            if direction == "output" then s, d = req.controller, device end
            if cr.type == 3 and cr.mcast then d = tostring(cr.mcast) end
            local fm = {direction = direction, device = device, controller = req.controller, ar = req.ar, frame_id = fid,
                        station = station, source = "connect", objects = {}, phase = "parameterisation",
                        data_length = cr.data_length,   -- the C_SDU's length (a trailer: bytes beyond it)
                        primary_only = req.ar_type == 0x0020,   -- armap.FrameMap.primary_only: system redundancy
                        -- armap.FrameMap.cycle_time_ns: SendClockFactor x ReductionRatio x 31.25 us
                        cycle_ns = (cr.scf and cr.scf > 0 and cr.rr and cr.rr > 0) and cr.scf * cr.rr * 31250 or nil,
                        iocs = cr.iocs}
            for _, o in ipairs(cr.objects) do
                local ek = table.concat({o.api or 0, o.slot or 0, o.subslot or 0}, "/")
                local e = req.expected[ek] or {}
                local mine = e[direction] or {0, 1}
                local obj = {api = o.api, slot = o.slot, subslot = o.subslot, offset = o.offset, length = mine[1]}
                -- session._assign_telegram: P922 read before > both directions' lengths
                local pk = table.concat({device, o.api or 0, o.slot or 0, o.subslot or 0}, "|")
                local pt = p922_of[pk]
                if pt ~= nil and T.telegrams[pt] and ((e.output and tg_len(pt, "setpoint") ~= e.output[1])
                                                     or (e.input and tg_len(pt, "actual") ~= e.input[1])) then
                    p922_of[pk], pt = nil, nil   -- an earlier connection's P922 these lengths contradict: stale
                end
                obj.locked = not e.shared_input and locked[ek] or nil   -- for now (judged when GOOD, no #66)
                if e.shared_input then
                    obj.telegram_source = NOT_OWNED   -- another AR controls the encoder
                elseif pt ~= nil then
                    obj.telegram, obj.telegram_source = pt, "P922"
                elseif e.input and e.output then
                    -- the device's identity, not the Device profile preference (any plain 4/8-byte IO module)
                    local prof, why = profile_for(device)
                    if tostring(why):sub(1, 6) == "set by" then prof = "generic" end
                    obj.telegram = guess_telegram(e.output[1], e.input[1], o.api, prof, o.subslot)
                    if obj.telegram then obj.telegram_source = "length" end
                end
                fm.objects[#fm.objects + 1] = obj
            end
            -- session_ar._connect: another controller's AR known only from its content on this frame ID of the
            -- device ended unseen (the PLC replaced)
            for _, om in pairs(maps) do
                if om.source == "content" and om.frame_id == fid and s == device and om.device == device
                        and om.controller ~= d and om.phase ~= "released" and om.phase ~= "aborted" then
                    restart_gaps(nil, device, om.controller, "aborted")
                end
            end
            maps[fid .. "|" .. s .. "|" .. d] = fm
            keys[#keys + 1] = {fid, s, d, fm}
        end
    end
    -- session_ar._taken_over: another controller's AR owning an encoder module this AR owns too ended unseen
    -- (not with system redundancy, whose two ARs own the same modules)
    if req.ar_type ~= 0x0020 and req.ar_type ~= 0x0006 then   -- (a supervisor gives the module back)
        local mine, any_ = {}, false
        for _, k in ipairs(keys) do
            for _, o in ipairs(k[4].objects) do
                if o.telegram ~= nil and not o.locked then mine[(o.api or 0) .. "/" .. (o.slot or 0) .. "/" .. (o.subslot or 0)] = true; any_ = true end
            end
        end
        for _, a in ipairs(any_ and ar_order or {}) do
            local dv, ph = ar_devs[a], ar_phase[a]
            if a ~= req.ar and dv ~= nil and dv[1] == device and dv[2] ~= req.controller and ph ~= nil
                    and ph ~= "released" and ph ~= "aborted" and ar_keys[a] ~= nil then
                local hit = false
                for _, k in ipairs(ar_keys[a]) do
                    if not k[4].primary_only then
                        for _, o in ipairs(k[4].objects) do
                            if o.telegram ~= nil and mine[(o.api or 0) .. "/" .. (o.slot or 0) .. "/" .. (o.subslot or 0)] then hit = true end
                        end
                    end
                end
                if hit then ar_moves(a, "aborted", fn) end
            end
        end
    end
    if again then on_reconnect(req.ar, device, keys, fn) end
end

-- mid-session captures: pndiss/infer.py, step for step. The first SAMPLES C_SDUs of each cyclic stream
-- nothing maps are kept; once a stream and its partner (MACs reversed) have them, every candidate
-- telegram at every offset is scored (IOPS GOOD after the data, reserved bits clear, sign-of-life
-- counting, control requested mirrored, positions continuous: T.content_inference); the best becomes
-- a map of source "inferred from content"
local CI = T.content_inference
local infer_streams, infer_list   -- key -> stream; streams in first-seen order (Python's dict order)

local function has_connect(controller, device)
    for _, d in pairs(ar_devs) do
        if (d[1] == controller and d[2] == device) or (d[1] == device and d[2] == controller) then return true end
    end
    for _, r in pairs(pending_connects) do
        if (r.src == controller and r.dst == device) or (r.src == device and r.dst == controller) then return true end
    end
    return false
end

local function word(c, off, size)
    local v = 0
    for i = 1, size do v = v * 256 + c:byte(off + i) end
    return v
end

local function next_ls(v) return (v % 15) + 1 end

local function counting(vals)
    local n = #vals
    if n < 2 then return 0.0 end
    local good, moves, through_zero = 0, 0, 0
    for i = 1, n - 1 do
        local a, b = vals[i], vals[i + 1]
        if a == 15 and b == 0 then through_zero = through_zero + 1 end
        if a ~= 0 and b ~= 0 then
            if b ~= a then moves = moves + 1 end
            if b == next_ls(a) or b == a then good = good + 1 end
        end
    end
    if through_zero >= 2 then return 0.0 end   -- a 4-bit counter through 0 (infer.py _counting)
    if moves >= math.floor((n - 1) / 4) then return good / (n - 1) end
    return 0.0
end

local function continuous(vals)
    local n = #vals
    if n < 2 then return nil end
    local differ = false
    for i = 2, n do if vals[i] ~= vals[1] then differ = true break end end
    if not differ then return nil end
    local m = 4294967296
    local ok = 0
    for i = 1, n - 1 do
        local d = (vals[i + 1] - vals[i]) % m
        if d > m / 2 then d = d - m end
        if math.abs(d) < 16777216 then ok = ok + 1 end
    end
    return ok / (n - 1)
end

local function placements(samples, n, L)
    local out = {}
    for o = 0, n - L - 1 do
        local all_good = true
        for _, c in ipairs(samples) do
            -- (a data object starts the C_SDU or follows an IOxS byte: infer.py _placements)
            if c:byte(o + L + 1) ~= CI.iops_good or (o > 0 and c:byte(o) ~= CI.iops_good) then all_good = false break end
        end
        if all_good then out[#out + 1] = o end
    end
    return out
end

local function evidence(S, A, pairs_, os_, oa, spo, aco)
    -- infer.py _hold: frames each controller sign-of-life value is held (k), when 80 % of the inner runs agree
    local function hold_of(vals)
        local runs, cur, n = {}, nil, 0
        for _, v in ipairs(vals) do
            if v == cur then n = n + 1 else
                if cur ~= nil then runs[#runs + 1] = {cur, n} end
                cur, n = v, 1
            end
        end
        local inner, count = {}, {}
        for i = 2, #runs do
            if runs[i][1] ~= 0 then
                inner[#inner + 1] = runs[i][2]
                count[runs[i][2]] = (count[runs[i][2]] or 0) + 1
            end
        end
        if #inner < 3 then return 1 end
        local r = 0   -- infer.py _hold: the longest run, when 40 % of them are that long
        for _, m in ipairs(inner) do if m > r then r = m end end
        if r >= 2 and r <= 14 and (count[r] or 0) >= 0.4 * #inner then return r end
        return 1
    end
    -- gate: some one profile reserves none of the bits the four words set (infer.py _evidence); which fit
    local used = {}
    for _, w in ipairs({{"stw2_enc", S, os_, spo}, {"g1_stw", S, os_, spo}, {"zsw2_enc", A, oa, aco},
                        {"g1_zsw", A, oa, aco}}) do
        local sig, samples, base, offs = w[1], w[2], w[3], w[4]
        if offs[sig] ~= nil then
            local u = 0
            for _, c in ipairs(samples) do u = bit.bor(u, word(c, base + offs[sig], CI.sizes[sig])) end
            used[sig] = u
        end
    end
    local fits = {}
    for _, p in ipairs(CI.profiles) do
        local ok = true
        for sig, u in pairs(used) do
            if bit.band(u, CI.reserved_by_profile[p][sig]) ~= 0 then ok = false break end
        end
        if ok then fits[#fits + 1] = p end
    end
    if #fits == 0 then return nil end
    local cls, dls = {}, {}
    for i, c in ipairs(S) do cls[i] = bit.rshift(word(c, os_ + spo[CI.sol.setpoint], 2), 12) end
    for i, c in ipairs(A) do dls[i] = bit.rshift(word(c, oa + aco[CI.sol.actual], 2), 12) end
    local sol_s, sol_a = counting(cls), counting(dls)
    local mirror = 0.0
    if #pairs_ > 0 then
        local hits = 0
        local ms, ma = CI.mirror.setpoint, CI.mirror.actual
        for _, pr in ipairs(pairs_) do
            local ws, wa = word(S[pr[1]], os_ + spo[ms.signal], 2), word(A[pr[2]], oa + aco[ma.signal], 2)
            local ctrl, creq = false, false
            for _, b in ipairs(ms.bits) do if bit.band(bit.rshift(ws, b), 1) == 1 then ctrl = true end end
            for _, b in ipairs(ma.bits) do if bit.band(bit.rshift(wa, b), 1) == 1 then creq = true end end
            if ctrl and creq then hits = hits + 1 end
        end
        mirror = hits / #pairs_
    end
    local cont = nil
    for _, p in ipairs(CI.positions) do
        if aco[p.name] ~= nil then
            local lo = oa + aco[p.name] + p.size - 4
            local vals = {}
            for i, c in ipairs(A) do vals[i] = word(c, lo, 4) end
            local cv = continuous(vals)
            if cv ~= nil then cont = math.max(cont or 0.0, cv) end
        end
    end
    if math.min(sol_s, sol_a) < 0.8 and (mirror < 0.9 or math.max(sol_s, sol_a) < 0.8) then return nil end
    local sum, n = sol_s + sol_a + mirror, 3
    if cont ~= nil then sum, n = sum + cont, 4 end
    return sum, {sol_s = sol_s, sol_a = sol_a, mirror = mirror, cont = cont, share = sum / n, profiles = fits,
                 hold = hold_of(cls)}
end

local function infer_score(out_s, in_s, taken_s, taken_a, need)
    local S, A = out_s.samples, in_s.samples
    local ls, la = math.huge, math.huge
    for _, c in ipairs(S) do ls = math.min(ls, #c) end
    for _, c in ipairs(A) do la = math.min(la, #c) end
    local pairs_ = {}
    local j = 0
    for i, f in ipairs(in_s.frames) do
        while j + 1 <= #out_s.frames and out_s.frames[j + 1] < f do j = j + 1 end
        if j >= 1 then pairs_[#pairs_ + 1] = {j, i} end
    end
    -- infer.py _score: layouts clear of the ones found before (taken_*), fitting every profile of ``need``
    local function free(o, L, taken)
        for _, r in ipairs(taken or {}) do if not (o + L <= r[1] or o >= r[2]) then return false end end
        return true
    end
    local function fits_all(ev)
        if need == nil then return true end
        for _, p in ipairs(need) do
            local ok = false
            for _, q in ipairs(ev.profiles) do if q == p then ok = true end end
            if not ok then return false end
        end
        return true
    end
    local found, best = {}, nil
    for _, cand in ipairs(CI.candidates) do
        local spo, aco = cand.setpoint, cand.actual
        for _, os_ in ipairs(placements(S, ls, cand.len_setpoint)) do
            if free(os_, cand.len_setpoint, taken_s) then
                for _, oa in ipairs(placements(A, la, cand.len_actual)) do
                    if free(oa, cand.len_actual, taken_a) then
                        local score, ev = evidence(S, A, pairs_, os_, oa, spo, aco)
                        if score ~= nil and fits_all(ev) then
                            local f = {t = cand.telegram, cand = cand, os = os_, oa = oa, score = score, ev = ev,
                                       out = out_s, ["in"] = in_s}
                            found[#found + 1] = f
                            if best == nil or score > best.score + 1e-9 then best = f end
                        end
                    end
                end
            end
        end
    end
    if best == nil then return nil end
    best.runner_up = 0.0   -- the best other layout over some of the same bytes
    for _, f in ipairs(found) do
        if f ~= best and (not free(f.os, f.cand.len_setpoint, {{best.os, best.os + best.cand.len_setpoint}})
                or not free(f.oa, f.cand.len_actual, {{best.oa, best.oa + best.cand.len_actual}})) then
            best.runner_up = math.max(best.runner_up, f.score)
        end
    end
    local margin = best.score - best.runner_up
    local f = margin >= 0.5 and 1.0 or 0.5 + margin
    best.confidence = math.floor(best.ev.share * f * 100 + 0.5) / 100
    return best
end

local function infer_fail(st)
    st.done = true
    st.samples = {}
end

-- nothing fits: sampled again from a frame number after a pause (infer.py _retry, RETRY_MAX_DOUBLINGS)
local function infer_retry(st, fn)
    if st.tries >= CI.retry_max_doublings then infer_fail(st); return end
    local span = #st.frames > 0 and (fn - st.frames[1] + 1) or CI.samples
    -- the first failure samples again at once (a capture started in the AR's start-up: IOPS bad at first)
    local pause = st.tries == 0 and 0 or math.floor(span * 2 ^ math.min(st.tries, CI.retry_max_doublings))
    st.tries = st.tries + 1
    st.retry_at = fn + 1 + pause
    st.samples, st.frames = {}, {}
end

local function infer_try(st, fn)
    local partners = {}
    for _, p in ipairs(infer_list) do
        if p ~= st and not p.done and #p.samples == CI.samples and p.src == st.dst and p.dst == st.src then
            partners[#partners + 1] = p
        end
    end
    if #partners == 0 then return end
    if has_connect(st.src, st.dst) then   -- the Connect of this AR decides
        infer_fail(st)
        for _, p in ipairs(partners) do infer_fail(p) end
        return
    end
    local best = nil
    for _, p in ipairs(partners) do
        for _, io in ipairs({{st, p}, {p, st}}) do
            local got = infer_score(io[1], io[2])
            if got ~= nil and (best == nil or got.score > best.score) then best = got end
        end
    end
    if best == nil then
        infer_retry(st, fn)
        for _, p in ipairs(partners) do infer_retry(p, fn) end
        return
    end
    local out_s, in_s = best.out, best["in"]
    local controller, device = out_s.src, out_s.dst
    local station = station_of(device)   -- session.add_inferred: the station table's name of the device
    -- the cycle the encoder reports in: its input stream's counter step (else the output's), once confirmed
    -- (gaps.py confirmed_period_ns: the Connect's step, or one seen GAP_LEARN times on a uniform counter)
    local cycle = nil
    for _, k in ipairs({in_s.key, out_s.key}) do
        local g = gap_streams[k]
        if cycle == nil and g ~= nil and g.step ~= 0 and g.uniform and (g.known or g.seen >= GAP_LEARN) then
            cycle = g.step * GAP_UNIT_NS
        end
    end
    -- infer.py _try: further layouts clear of the ones found are further axes (slot/subslot 0/k)
    local layouts, taken_s, taken_a = {best}, {{best.os, best.os + best.cand.len_setpoint}}, {{best.oa, best.oa + best.cand.len_actual}}
    while #layouts < CI.max_axes do
        local more = infer_score(out_s, in_s, taken_s, taken_a, best.ev.profiles)
        if more == nil then break end
        layouts[#layouts + 1] = more
        taken_s[#taken_s + 1] = {more.os, more.os + more.cand.len_setpoint}
        taken_a[#taken_a + 1] = {more.oa, more.oa + more.cand.len_actual}
    end
    for k, b in ipairs(layouts) do
        for _, x in ipairs({{out_s, "output", b.os, b.cand.len_setpoint}, {in_s, "input", b.oa, b.cand.len_actual}}) do
            local s = x[1]
            local o = {api = 0, slot = 0, subslot = k - 1, offset = x[3], length = x[4], telegram = b.t,
                       telegram_source = CI.source}
            if k > 1 and maps[s.key] ~= nil and maps[s.key].source == "content" then
                local objs = maps[s.key].objects
                objs[#objs + 1] = o
            else
                maps[s.key] = {direction = x[2], device = device, controller = controller, frame_id = s.fid,
                               source = "content", station = station, learnt_cycle_ns = cycle,
                               learnt_k = best.ev.hold > 1 and best.ev.hold or nil, objects = {o},
                               inferred = {confidence = best.confidence, first = math.min(out_s.frames[1], in_s.frames[1]),
                                           last = math.max(out_s.frames[#out_s.frames], in_s.frames[#in_s.frames])}}
            end
        end
    end
    for _, s in ipairs({out_s, in_s}) do
        s.done = true
        s.samples = {}
    end
    local fits = best.ev.profiles
    local generic = false
    for _, p in ipairs(fits) do if p == "generic" then generic = true end end
    if #fits == 1 and not generic then   -- session.add_inferred: profile_for takes the words' profile
        facts[device] = facts[device] or {}
        facts[device].words = fits[1]
        if profiles[device] ~= nil and profiles[device][1] == "generic" then profiles[device] = nil end
    end
    map_generation = map_generation + 1
end

-- cyclic.py: a cyclic frame nothing maps (key "fid|src|dst", tvb = its C_SDU)
local function infer_offer(key, fid, src, dst, fn, tvb)
    local st = infer_streams[key]
    if st == nil then
        if #infer_list >= CI.max_streams then return end
        st = {key = key, fid = fid, src = src, dst = dst, samples = {}, frames = {}, done = false, retry_at = 0, tries = 0}
        infer_streams[key] = st
        infer_list[#infer_list + 1] = st
    end
    if st.done or #st.samples >= CI.samples or fn < st.retry_at then return end
    st.samples[#st.samples + 1] = tvb:raw()
    st.frames[#st.frames + 1] = fn
    if #st.samples == CI.samples then infer_try(st, fn) end
end


-- 5. records --------------------------------------------------------------------------------------
-- Each IODWriteReq / IODReadRes record becomes a 'record' event shaped like pndiss/session.py's
-- (kind, op, index, ar_uuid, device_mac, frame, ts_ns, length, data, decoded, profile), each
-- 0xB02E/0xB02F response a 'param' event shaped like records.ParamPairer.response's; both go to
-- the cyclic driver (section 7) like SessionTracker -> CyclicTracker.on_record.
local pairer           -- param key -> {req = Python-shaped request, frame, ts} awaiting its response
local superseded       -- param key -> frames of requests overwritten before a response
local refused_early    -- param key -> frames of new requests refused while one was open (ParamPairer.refused_early)
local on_record        -- the cyclic driver's CyclicTracker.on_record (section 7)

local function u8(t, o) return t(o, 1):uint() end
local function u16(t, o) return t(o, 2):uint() end

local function request_id_name(id)
    return T.request_ids[id] or ((id >= 0x40 and id <= 0x7F) and "manufacturer-specific" or "reserved")
end

local function response_id_name(id)
    return T.response_ids[id] or (((id >= 0x40 and id <= 0x7F) or id >= 0xC0) and "manufacturer-specific" or "reserved")
end

local function param_name(pnu, profile)
    local v = T.vendor_params[profile]
    return (v and v[pnu]) or T.params[pnu] or ("P" .. pnu)
end

local function error_text(c)
    return T.param_errors[c] or ((c >= 0x65 and c <= 0xFF) and "manufacturer-specific error" or
        (c <= 0xFF and "reserved error number" or "error number above 0x00FF (high byte reserved)"))
end

CONST.INT_CODES = {B = true, H = true, I = true, b = true, h = true, i = true, q = true, Q = true}
local TWO53 = 2 ^ 53

-- an 8-byte integer at t(o) as a Lua number (exact below 2^53 in magnitude, rounded above: the
-- checker compares record values as doubles); exact = a signal above 2^53 as {hi, lo} (uint32
-- halves of the two's complement), the checker's convention for cyclic values
local function int64_at(t, o, signed, exact)
    local hi, lo = t(o, 4):uint(), t(o + 4, 4):uint()
    local v = hi * 4294967296 + lo
    if signed and hi >= 0x80000000 then v = (hi - 4294967296) * 4294967296 + lo end
    if exact and (v >= TWO53 or v <= -TWO53) then return {hi = hi, lo = lo} end
    return v
end

-- a value block at off (records/profidrive.py _block): returns block, next offset (nil + reason
-- when it does not fit). shown = strings for the tree; values = Python's typed values
local function value_block(t, off, len)
    if off + 2 > len then return nil, "value block header truncated" end
    local fmt, n = u8(t, off), u8(t, off + 1)
    local spec = T.param_formats[fmt]
    if spec == nil then return nil, string.format("format 0x%02X unknown", fmt) end
    local size, code = spec.size, spec.code
    local e = off + 2 + size * n
    local function fits(s, x)   -- profidrive._fits: values end the record or meet a block of a known format
        if (x - s) % 2 == 1 and x < len then x = x + 1 end
        return x == len or (x + 2 <= len and T.param_formats[u8(t, x)] ~= nil)
    end
    if code == "hex" and n == size and size > 1 and not fits(off + 2, e) and fits(off + 2, off + 2 + size) then
        n, e = 1, off + 2 + size   -- profidrive._values: a fixed-size octet string counted in octets, one element
    end
    if e > len then return nil, "values truncated" end
    local blk = {format = fmt, format_name = spec.name, no_of_values = u8(t, off + 1), shown = {}, values = {},
                 int = CONST.INT_CODES[code] or false}
    for i = 0, n - 1 do
        local o = off + 2 + i * size
        local v, s
        if code == "B" or code == "H" or code == "I" then v = t(o, size):uint(); s = tostring(v)
        elseif code == "b" or code == "h" or code == "i" then v = t(o, size):int(); s = tostring(v)
        elseif code == "q" then v = int64_at(t, o, true); s = tostring(t(o, 8):int64())
        elseif code == "Q" then v = int64_at(t, o, false); s = tostring(t(o, 8):uint64())
        elseif code == "f" then v = t(o, 4):float(); s = tostring(v)
        elseif code == "d" then v = t(o, 8):float(); s = tostring(v)
        elseif code == "hex" then v = t(o, size):bytes():tohex():lower(); s = v
        end
        if v ~= nil then blk.values[#blk.values + 1] = v end
        if s ~= nil then blk.shown[#blk.shown + 1] = s end
    end
    if code == "str" then   -- profidrive.py: raw.decode("latin-1"), as UTF-8 text (tshark prints it as is)
        local text = t(off + 2, size * n):raw():gsub("[\128-\255]", function(c)
            local b = c:byte()
            return string.char(0xC0 + math.floor(b / 64), 0x80 + b % 64)
        end)
        blk.values[1], blk.shown[1] = text, text
    end
    if fmt == 0x44 and n > 0 then
        blk.error = {code = blk.values[1], text = error_text(blk.values[1])}
        if n > 1 then blk.error_subindex = blk.values[2] end
    end
    if (e - off) % 2 == 1 and e < len then e = e + 1 end   -- odd byte counts padded to a word
    return blk, e
end

-- records/profidrive.decode_request
local function decode_request(t, len, profile)
    if len < 4 then return nil, "parameter request header truncated" end
    local rid = u8(t, 1)
    local r = {kind = "parameter request", request_ref = u8(t, 0), request_id = rid, request_id_name = request_id_name(rid),
               axis = u8(t, 2), no_of_parameters = u8(t, 3), params = {}, length = len}
    local off = 4
    for i = 1, r.no_of_parameters do
        if off + 6 > len then return nil, "parameter address truncated" end
        local pnu = u16(t, off + 2)
        r.params[i] = {attribute = u8(t, off), count = u8(t, off + 1), pnu = pnu, subindex = u16(t, off + 4),
                       name = param_name(pnu, profile)}
        off = off + 6
    end
    if rid == 2 then   -- value blocks only in a change request
        for i = 1, r.no_of_parameters do
            local blk, e = value_block(t, off, len)
            if not blk then return nil, e end
            local p = r.params[i]
            p.format, p.format_name, p.no_of_values = blk.format, blk.format_name, blk.no_of_values
            p.values, p.error, p.block = blk.values, blk.error, blk
            off = e
        end
    end
    if off < len then r.trailing_bytes = len - off end
    return r
end

-- records/profidrive.decode_response
local function decode_response(t, len)
    if len < 4 then return nil, "parameter response header truncated" end
    local rid = u8(t, 1)
    local r = {kind = "parameter response", request_ref = u8(t, 0), response_id = rid,
               response_id_name = response_id_name(rid), axis = u8(t, 2), no_of_parameters = u8(t, 3),
               params = {}, length = len}
    local off = 4
    if rid ~= 2 then
        for i = 1, r.no_of_parameters do
            if off >= len and rid == 0x80 then break end   -- illegal-request-ID answer: a bare header
            local blk, e = value_block(t, off, len)
            if not blk then return nil, e end
            r.params[i] = blk
            off = e
        end
    end
    r.ok = (rid == 1 or rid == 2)
    for _, b in ipairs(r.params) do if b.format == 0x44 then r.ok = false end end
    return r
end

-- records/userparams.decode_bf00 (0xBF00; PS/PSM 0xFFFF): problems are {rule, message}; mupr/tmr
-- as numbers for the checker, mupr64/tmr64 (UInt64) for the tree
CONST.CHECK_RESERVED = {lika = true, generic = true}
local function decode_bf00(t, len, profile)
    if not T.profile_defaults[profile] then profile = "generic" end
    local d = {profile = profile, length = len, problems = {}}
    local P = d.problems
    local function problem(rule, msg) P[#P + 1] = {rule = rule, message = msg} end
    if len ~= 31 then problem("BF00-LENGTH", string.format("user parameter record is %d bytes, expected 31", len)) end
    if len >= 1 then
        local b0 = u8(t, 0)
        d.flags = b0
        for _, fb in ipairs(T.bf00_flags) do d[fb[1]] = bit.band(bit.rshift(b0, fb[2]), 1) end
        d.direction = d.code_sequence
        d.reserved_bits = bit.rshift(b0, profile == "psm" and 7 or 6)
    end
    if len >= 17 then
        d.mupr64, d.tmr64 = t(1, 8):uint64(), t(9, 8):uint64()
        d.mupr, d.tmr = int64_at(t, 1, false), int64_at(t, 9, false)
        if d.mupr64 < UInt64(1) then
            problem("BF00-VALUE-OUT-OF-RANGE", "measuring units per revolution " .. tostring(d.mupr64)
                .. " outside [1, hardware resolution]")
        end
        if d.tmr64 < UInt64(2) then
            problem("BF00-VALUE-OUT-OF-RANGE", "total measuring range " .. tostring(d.tmr64)
                .. " outside [2, total hardware resolution]")
        end
    end
    if len >= 18 then
        d.max_master_sol_failures = u8(t, 17)
        if d.max_master_sol_failures < (profile == "psm" and 0 or 1) then
            problem("BF00-VALUE-OUT-OF-RANGE", string.format("max. master sign-of-life failures %d outside [1, 255]",
                d.max_master_sol_failures))
        end
    end
    if len >= 19 then
        d.velocity_unit = u8(t, 18)
        local tbl = profile == "psm" and T.bf00_velocity_units_psm or T.bf00_velocity_units
        d.velocity_unit_name = tbl[d.velocity_unit] or ("undefined (" .. d.velocity_unit .. ")")
        local maxv = profile == "psm" and 4 or 3
        if d.velocity_unit > maxv then
            problem("BF00-VALUE-OUT-OF-RANGE", string.format("velocity unit %d outside [0, %d]", d.velocity_unit, maxv))
        end
    end
    if CONST.CHECK_RESERVED[profile] then   -- bits 0.6-7, bytes 19-30
        local bad = (d.reserved_bits or 0) ~= 0
        for i = 19, math.min(len, 31) - 1 do if u8(t, i) ~= 0 then bad = true end end
        if bad then problem("BF00-RESERVED-NONZERO", "reserved user parameter bits/bytes set") end
    end
    return d
end

local function ts_ns(pinfo) return pinfo.abs_ts * 1e9 end

-- the records of this frame (write requests / read responses), from the header blocks
local function records_of_frame()
    local out = {}
    local arus = all("pn_io.ar_uuid")
    for _, b in ipairs(blocks()) do
        if (b.type == 0x0008 or b.type == 0x8009) and b.e - b.s >= 64 then
            local t = b.tvb
            local hs = b.s + 6 + 2   -- after block header and SeqNumber
            if hs + 16 + 4 + 2 + 2 + 2 + 2 + 4 <= t:len() then
                local au = inside(arus, b)[1]
                local ar = au and tostring(au) or tostring(t(hs, 16):bytes())
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

local NIL_UUID = "00000000-0000-0000-0000-000000000000"

local function index_name(index)
    return T.index_names[index] or (index < 0x8000 and string.format("user specific record 0x%04X", index)
        or string.format("record 0x%04X", index))
end

-- session._p922: a P922 read names the telegram of the device's submodules with data, unless the
-- user map says; a length guess yields only if P922's telegram fits its lengths in both directions
local function p922_relabel(device, api, slot, subslot, value)
    local tnum
    if type(value) == "number" then tnum = value >= 0 and math.floor(value) or math.ceil(value)
    elseif type(value) == "string" then tnum = tonumber(value, 10)
    end
    if tnum == nil then return end
    p922_of[table.concat({device, api, slot, subslot}, "|")] = tnum
    map_generation = map_generation + 1
    if not T.telegrams[tnum] then return end
    local misfit = {}
    for _, fm in pairs(maps) do
        if fm.device == device then
            local dir = fm.direction == "input" and "actual" or "setpoint"
            for _, o in ipairs(fm.objects) do
                if (o.length or 0) > 0 and o.telegram_source == "length" and tg_len(tnum, dir) ~= o.length then
                    misfit[o.api .. ":" .. o.slot .. ":" .. o.subslot] = true
                end
            end
        end
    end
    for _, fm in pairs(maps) do
        if fm.device == device then
            for _, o in ipairs(fm.objects) do
                if o.telegram_source ~= "map" and o.telegram_source ~= NOT_OWNED and (o.length or 0) > 0
                        and not (o.telegram_source == "length" and misfit[o.api .. ":" .. o.slot .. ":" .. o.subslot])
                        and ((o.api == api and o.slot == slot and o.subslot == subslot)
                            or o.telegram == nil or o.telegram_source == "length" or o.telegram_source == "gsdml") then
                    o.telegram, o.telegram_source = tnum, "P922"
                end
            end
        end
    end
end

-- two decoded requests equal field by field (ParamPairer.request: a retry of the same request)
local function deep_eq(a, b)
    if type(a) ~= "table" or type(b) ~= "table" then return a == b end
    for k, v in pairs(a) do if not deep_eq(v, b[k]) then return false end end
    for k in pairs(b) do if a[k] == nil then return false end end
    return true
end

-- ParamPairer.request: a new request overwrites an unanswered one (kept, in case its write is refused)
local function pair_request(key, dec, fn, ts, device)
    local old = pairer[key]
    -- pending from before the capture lost frames (in the device's streams): its response may have been read there
    -- (forgotten, not overwritten)
    local lost = gap_last_ts[device or ""]
    local dropped = gap_last_ts["*drop"]   -- the capture tool's own loss report (capture.epb_options)
    if dropped ~= nil and (lost == nil or dropped > lost) then lost = dropped end
    if old and lost ~= nil and lost > old.ts then old = nil end
    if old and deep_eq(old.req, dec) then return end   -- the same request again: the first stays pending
    if old then
        superseded[key] = superseded[key] or {}
        table.insert(superseded[key], old.frame)
    end
    pairer[key] = {req = dec, frame = fn, ts = ts, overwrote = old}
end

-- ParamPairer.response: the response paired with the request written before it on the same key
local function pair_response(key, rsp, frame, ts, profile)
    local p = pairer[key]
    local o = p and p.overwrote
    if o and o.ts <= ts and ts < p.ts and rsp.request_ref == o.req.request_ref and rsp.request_ref ~= p.req.request_ref then
        -- ParamPairer.response: the answer to the request the pending one replaced, before that write in time (a
        -- TAP's port batches put it later in the file): no overwrite; the pending request stays
        local sup = superseded[key]
        if sup and sup[#sup] == o.frame then
            table.remove(sup)
            if #sup == 0 then superseded[key] = nil end
        end
        pairer[key] = {req = o.req, frame = o.frame, ts = o.ts}
        local out = pair_response(key, rsp, frame, ts, profile)
        pairer[key] = {req = p.req, frame = p.frame, ts = p.ts}
        return out
    end
    pairer[key] = nil
    local sup = superseded[key]
    superseded[key] = nil
    local early = refused_early[key]
    refused_early[key] = nil
    local ev = {request_frame = nil, response_frame = frame, response_ref = rsp.request_ref, response_id = rsp.response_id,
                response_id_name = rsp.response_id_name, response_axis = rsp.axis,
                response_no_of_parameters = rsp.no_of_parameters, ok = rsp.ok, params = {}, pairing = {}}
    local w = ev.pairing
    if sup then
        local fr = {}
        for j, f in ipairs(sup) do fr[j] = tostring(f) end
        ev.superseded_request_frames = sup
        w[#w + 1] = "request(s) in frame(s) " .. table.concat(fr, ", ") .. " overwritten before their response was read"
    end
    if early then
        local fr = {}
        for j, f in ipairs(early) do fr[j] = tostring(f) end
        w[#w + 1] = "request(s) in frame(s) " .. table.concat(fr, ", ") .. " pipelined before this response was read (refused by the device)"
    end
    local blocks_ = rsp.params
    local q = p and p.req
    if rsp.decode_error then
        ev.decode_error = true
        w[#w + 1] = "value blocks do not decode: values not judged"
    end
    if q == nil then
        w[#w + 1] = "no request"
    else
        ev.request_frame, ev.request_ts_ns, ev.request_ref = p.frame, p.ts, q.request_ref
        ev.request_id, ev.request_id_name, ev.axis, ev.no_of_parameters = q.request_id, q.request_id_name, q.axis,
            q.no_of_parameters
        ev.request_id_code = q.request_id  -- alias kept for older readers
        if rsp.request_ref ~= q.request_ref then
            w[#w + 1] = string.format("request ref mismatch (request 0x%02X, response 0x%02X)", q.request_ref, rsp.request_ref)
        end
        local qid = q.request_id
        local legal = qid == 1 or qid == 2 or (qid >= 0x40 and qid <= 0x7F)
        -- an illegal request ID is answered with 0x80 (001_9461bb7bc8c2767b.txt:2073; rule #80 judges the rest)
        -- (and a manufacturer-specific one the device does not offer: 0x80 / error 0x21, the documented refusal)
        if rsp.response_id ~= qid and rsp.response_id ~= bit.bor(qid, 0x80)
                and not (rsp.response_id == 0x80 and (not legal or qid >= 0x40)) then
            w[#w + 1] = string.format("response id mismatch (request 0x%02X, response 0x%02X)", q.request_id, rsp.response_id)
        end
        if rsp.axis ~= q.axis then
            w[#w + 1] = string.format("axis not mirrored (request %d, response %d)", q.axis, rsp.axis)
        end
        if rsp.no_of_parameters ~= q.no_of_parameters then
            w[#w + 1] = string.format("number of parameters mismatch (request %d, response %d)", q.no_of_parameters,
                rsp.no_of_parameters)
        end
        if #blocks_ > 0 and #blocks_ ~= #q.params then
            if rsp.no_of_parameters == q.no_of_parameters then   -- (else said above: one fault, one note)
                w[#w + 1] = string.format("%d value blocks for %d requested parameters", #blocks_, #q.params)
            end
        elseif q.request_id == 0x01 and #q.params >= 2 and #blocks_ == #q.params then
            -- profidrive.order_broken (#84): the blocks that hold values (an error or zero block keeps its place)
            -- hold the requested element counts in another order; or (types_swapped) two of them each hold the
            -- other parameter's declared data type in its number of elements
            local want, got, sw, sg, same, pos = {}, {}, {}, {}, true, {}
            local types = T.checker.param_types[profile] or T.checker.param_types.generic
            local decl = {}
            for i, a in ipairs(q.params) do
                want[i] = math.max(1, a.count or 0)
                got[i] = blocks_[i].no_of_values or -1
                local f = blocks_[i].format
                if bit.band(a.attribute or 0x10, 0xF0) == 0x10 then decl[i] = types[a.pnu] end
                if f ~= 0x44 and f ~= 0x40 then
                    pos[#pos + 1] = i
                    if want[i] ~= got[i] then same = false end
                    sw[#sw + 1], sg[#sg + 1] = want[i], got[i]
                end
            end
            table.sort(sw)
            table.sort(sg)
            local perm = #pos >= 2
            for i = 1, #sw do if sw[i] ~= sg[i] then perm = false end end
            local swapped = false
            for _, x in ipairs(pos) do
                for _, y in ipairs(pos) do
                    if x < y and decl[x] and decl[y] and decl[x] ~= decl[y] and blocks_[x].format_name == decl[y]
                            and blocks_[y].format_name == decl[x] and got[x] == want[y] and got[y] == want[x] then
                        swapped = true
                    end
                end
            end
            if not same and perm then
                w[#w + 1] = "value blocks not in request order (elements requested [" .. table.concat(want, ", ")
                    .. "], values answered [" .. table.concat(got, ", ") .. "])"
            elseif swapped then
                local dn, an = {}, {}
                for i = 1, #q.params do dn[i], an[i] = decl[i] or "?", tostring(blocks_[i].format_name) end
                w[#w + 1] = "value blocks not in request order (data types requested [" .. table.concat(dn, ", ")
                    .. "], answered [" .. table.concat(an, ", ") .. "])"
            end
        end
    end
    local reqp = q and q.params or {}
    for i = 1, math.max(#reqp, #blocks_) do   -- profidrive._param
        local a, blk = reqp[i], blocks_[i]
        local prm = {values = {}}
        if a then
            prm.pnu, prm.subindex, prm.count, prm.name, prm.attribute = a.pnu, a.subindex, a.count, a.name, a.attribute
            if a.values then prm.written = {format = a.format, values = a.values} end
        end
        if blk then
            prm.format, prm.format_name, prm.no_of_values = blk.format, blk.format_name, blk.no_of_values
            prm.values, prm.error, prm.error_subindex = blk.values, blk.error, blk.error_subindex
            prm.block = blk
        end
        ev.params[i] = prm
    end
    return ev
end

-- the record and param events of one frame, in wire order, each handed to the cyclic driver
local function record_items(pinfo, recs)
    local items = {}
    local src, dst = tostring(pinfo.dl_src), tostring(pinfo.dl_dst)
    local fn, ts = pinfo.number, ts_ns(pinfo)
    for _, r in ipairs(recs) do
        local device = r.op == "write" and dst or src
        local controller = r.op == "write" and src or dst
        local known = ar_devs[r.ar]   -- session._rec_event: the AR names device and controller
        if known then device, controller = known[1], known[2] end
        local f = facts[device] or {}
        if r.index == 0xFFFF and r.op == "write" and f.ffff == nil then
            facts[device], f.ffff, profiles[device] = f, fn, nil   -- PS/PSM evidence (profile_for)
        end
        local profile = profile_for(device)
        local it = {rec = r, index_name = index_name(r.index)}
        local t, len = r.tvb, r.len
        local ev = {frame = fn, ts_ns = ts, kind = "record", op = r.op, index = r.index, index_name = it.index_name,
                    api = r.api, slot = r.slot, subslot = r.subslot, device_mac = device, controller_mac = controller,
                    ar_uuid = r.ar, length = len, profile = profile}
        local dec
        if r.index == 0xB02E or r.index == 0xB02F then
            if r.op == "write" then dec = decode_request(t, len, profile) else dec = decode_response(t, len) end
            if dec then it.decoded = dec else it.malformed = true end
        elseif r.index == 0xBF00 or (r.index == 0xFFFF and profile == "psm") then
            dec = decode_bf00(t, len, r.index == 0xFFFF and "psm" or profile)
            it.bf00 = dec
        end
        if r.index == 0xBF00 or r.index == 0xFFFF or r.index == 0x8030 then
            ev.data = len > 0 and t:bytes(0, len):tohex():lower() or ""   -- acyclic._own_bf00_checks reads the bytes
        end
        ev.decoded = dec or (not it.malformed and {index = r.index, index_name = it.index_name}) or nil
        on_record(ev, fn)
        if not dec and (r.index == 0xB02E or r.index == 0xB02F) and r.op == "read" and len >= 4 then
            -- profidrive.undecodable_response: the header still answers the request (paired, judged on it)
            local rid = u8(t, 1)
            dec = {kind = "parameter response", request_ref = u8(t, 0), response_id = rid, axis = u8(t, 2),
                   response_id_name = response_id_name(rid), no_of_parameters = u8(t, 3), params = {},
                   length = len, ok = false, decode_error = true}
        end
        local nil_ar = r.ar == NIL_UUID
        local key = table.concat({nil_ar and (controller .. "/" .. device) or r.ar, r.api, r.slot, r.subslot}, "|")
        if (r.index == 0xB02E or r.index == 0xB02F) and dec then
            if r.op == "write" then
                pair_request(key, dec, fn, ts, device)
            else
                local pev = pair_response(key, dec, fn, ts, profile)
                pev.frame, pev.ts_ns, pev.kind, pev.index = fn, ts, "param", r.index
                pev.api, pev.slot, pev.subslot, pev.device_mac = r.api, r.slot, r.subslot, device
                pev.controller_mac, pev.ar_uuid, pev.profile = controller, r.ar, profile
                it.param = pev
                on_record(pev, fn)
                for _, prm in ipairs(pev.several_encoders and {} or pev.params) do
                    if prm.pnu == 922 and not prm.error and prm.values[1] ~= nil and (prm.subindex or 0) == 0
                            and bit.band(prm.attribute or 0x10, 0xF0) == 0x10 then   -- the value, not its description
                        p922_relabel(device, r.api, r.slot, r.subslot, prm.values[1])
                    end
                end
            end
        end
        items[#items + 1] = it
    end
    return items
end

-- 6. DCP ------------------------------------------------------------------------------------------
-- pndiss/proto/dcp.py (+ dcp_blocks.py, dcp_rules.py): the blocks of a DCP PDU (read from the bytes, so a PDU the Python decoder
-- calls malformed gives no event here either), NameOfStation rules (name_problems) and DcpTracker
-- (which MAC holds which name / IP). A violation is noted on the frame being dissected.
local note_violation   -- section 7

local GET, SET, IDENTIFY, HELLO = 3, 4, 5, 6
CONST.DCP_SERVICE_TYPES = {[0] = true, [1] = true, [5] = true}
CONST.DCP_PREFIXED = {[2] = true, [3] = true, [6] = true, [7] = true}
-- smallest value (after BlockInfo/BlockQualifier) each value decoder accepts (dcp_blocks.py _fixed)
CONST.DCP_MIN = {["1|1"] = 6, ["1|2"] = 12, ["1|3"] = 28, ["2|3"] = 4, ["2|4"] = 2, ["2|7"] = 2, ["2|8"] = 4,
                 ["2|10"] = 2, ["3|61"] = 2, ["3|255"] = 3, ["5|1"] = 2, ["5|2"] = 2, ["5|3"] = 4, ["5|4"] = 3,
                 ["5|5"] = 2, ["5|6"] = 2, ["7|1"] = 16, ["7|2"] = 2, ["7|3"] = 16, ["7|4"] = 16, ["7|5"] = 6}

-- dcp_blocks._string: tshark's ENC_ASCII view (ends at a NUL; each non-ASCII byte becomes U+FFFD)
local function dcp_string(t, o, n)
    local s = n > 0 and t(o, n):raw() or ""
    s = s:match("^[^%z]*")
    return (s:gsub("[\128-\255]", "\239\191\189"))
end

local function ipv4(t, o)
    return string.format("%d.%d.%d.%d", u8(t, o), u8(t, o + 1), u8(t, o + 2), u8(t, o + 3))
end

-- dcp.decode: {sid, stype, blocks = {{opt, sub, name?, ip?, erroneous?}}} or nil (malformed)
local function dcp_decode(t, off)
    local len = t:len()
    if len - off < 10 then return nil end
    local sid, stype, dlen = u8(t, off), u8(t, off + 1), u16(t, off + 8)
    local start = off + 10
    local e = start + dlen
    -- a frame the snap length cut: its whole blocks stand (dcp.decode cut=True), a partial one ends them
    local cut = e > len and t:reported_len() > len
    if e > len and not cut then return nil end
    if cut then e = len end
    local d = {sid = sid, stype = stype, xid = t(off + 2, 4):uint(), blocks = {}}
    if sid < GET or sid > HELLO or not CONST.DCP_SERVICE_TYPES[stype] then return d end
    local response = stype ~= 0
    if sid == GET and not response then
        if dlen % 2 == 1 then return nil end
        return d
    end
    local prefix = ((sid == IDENTIFY and response) or (sid == HELLO and not response) or (sid == GET and response))
        or (sid == SET and not response)
    local o = start
    while o < e do
        if o + 4 > e then return cut and d or nil end
        local opt, sub, blen = u8(t, o), u8(t, o + 1), u16(t, o + 2)
        local vend = o + 4 + blen
        if vend > e then return cut and d or nil end
        local b = {opt = opt, sub = sub}
        local vs, vl = o + 4, blen
        if prefix and (CONST.DCP_PREFIXED[opt] or (opt == 1 and sub >= 1 and sub <= 3)) then
            if blen < 2 then return cut and d or nil end
            vs, vl = vs + 2, vl - 2
        end
        if opt == 5 and sid == SET and blen == 0 then
            b.erroneous = true
        elseif opt == 6 then
            if vl < 2 then return cut and d or nil end
        elseif not (opt == 0xFF and sub == 0xFF) then
            local k = opt .. "|" .. sub
            if CONST.DCP_MIN[k] and vl < CONST.DCP_MIN[k] then return cut and d or nil end
            if k == "2|5" and vl % 2 == 1 then return cut and d or nil end
            if k == "3|61" then
                local n = u8(t, vs + 1)
                if n > 0 and vl < 2 + n then return cut and d or nil end
            end
            if k == "2|2" then b.name = dcp_string(t, vs, vl) end
            if k == "1|2" or k == "1|3" then b.ip = ipv4(t, vs) end
        end
        d.blocks[#d.blocks + 1] = b
        o = vend + blen % 2   -- odd blocks are followed by one pad byte
    end
    return d
end

-- dcp_rules.name_problems: does the NameOfStation break the rules? (an empty name is a reset)
local function name_bad(name)
    if name == "" then return false end
    if #name > 127 or name:find("[^A-Za-z0-9%.%-]") then return true end
    if name:sub(1, 1) == "-" or name:sub(-1) == "-" then return true end
    local labels = {}
    for l in (name .. "."):gmatch("([^%.]*)%.") do labels[#labels + 1] = l end
    for i, l in ipairs(labels) do
        if l == "" or #l > 63 then return true end
        if (i > 1 and l:sub(1, 1) == "-") or (i < #labels and l:sub(-1) == "-") then return true end
    end
    local first = labels[1]:lower()
    if first:match("^port%-%d%d%d$") or first:match("^port%-%d%d%d%-%d%d%d%d%d$") then return true end
    return name:match("^%d+%.%d+%.%d+%.%d+$") ~= nil
end

-- DcpTracker
-- dcp_state (declared with the maps, section 3): {name_at, ip_at, mac_name, mac_ip, reported, station,
-- identifies}
local function dcp_release(at, by_mac, mac)
    local old = by_mac[mac]
    by_mac[mac] = nil
    if old ~= nil and at[old] and at[old][1] == mac then at[old] = nil end
end

-- DcpTracker._gone: an Identify after the holder's claim (for all, or for its name / IP), other than the
-- one a response answers, that the holder left unanswered: a replaced device, its name / IP is free
local function dcp_gone(mac, seen, xid)
    local S_ = dcp_state
    local heard = {}   -- askers one of whose Identifies shows an answer: responses to them reach the capture
    for _, idf in ipairs(S_.identifies) do
        if next(idf.answered) ~= nil then heard[idf.asker] = true end
    end
    for _, idf in ipairs(S_.identifies) do
        if idf.frame > seen and idf.xid ~= xid and (next(idf.answered) ~= nil or heard[idf.asker])
                and not idf.answered[mac]
                and (idf.all or (idf.name ~= nil and idf.name == S_.mac_name[mac])
                     or (idf.ip ~= nil and idf.ip == S_.mac_ip[mac])) then
            return true
        end
    end
    return false
end

local function dcp_identify(d, src, fn)
    local S_ = dcp_state
    if d.stype == 0 then
        local idf = {xid = d.xid, frame = fn, answered = {}, asker = src}
        for _, b in ipairs(d.blocks) do
            if b.opt == 0xFF and b.sub == 0xFF then idf.all = true
            elseif b.name ~= nil then idf.name = b.name
            elseif b.opt == 1 and b.sub == 2 and b.ip ~= nil then idf.ip = b.ip end
        end
        S_.identifies[#S_.identifies + 1] = idf
        if #S_.identifies > 16 then table.remove(S_.identifies, 1) end
    else
        for _, idf in ipairs(S_.identifies) do
            if idf.xid == d.xid then idf.answered[src] = true end
        end
    end
end

local function dcp_claim(what, value, mac, assign, fn, xid)
    local S_ = dcp_state
    local at, by_mac = S_[what .. "_at"], S_["mac_" .. what]
    local holder = at[value]
    if holder ~= nil and holder[1] ~= mac and by_mac[holder[1]] == value and dcp_gone(holder[1], holder[2], xid) then
        dcp_release(S_.name_at, S_.mac_name, holder[1])   -- a replaced device: its name and IP are free
        dcp_release(S_.ip_at, S_.mac_ip, holder[1])
        holder = nil
    end
    if holder ~= nil and holder[1] ~= mac and by_mac[holder[1]] == value then
        local rule = what == "name" and "DCP-NAME-DUPLICATE" or "IP-ASSIGN-OCCUPIED"
        local a, b = mac, holder[1]
        if b < a then a, b = b, a end
        local key = rule .. "|" .. value .. "|" .. a .. "|" .. b
        if (what == "name" or assign) and not S_.reported[key] then
            S_.reported[key] = true
            note_violation(fn, rule, fn, false, what == "name"
                and string.format("NameOfStation '%s' %s for %s, but %s holds it (frame %d)", value,
                    assign and "assigned" or "reported", mac, holder[1], holder[2])
                or string.format("Set assigns IP %s to %s, but %s uses it (frame %d)", value, mac, holder[1], holder[2]))
        end
    end
    local old = by_mac[mac]
    if old ~= nil and old ~= value and at[old] and at[old][1] == mac then at[old] = nil end
    by_mac[mac] = value
    if holder == nil or holder[1] == mac or by_mac[holder[1]] ~= value or assign then at[value] = {mac, fn} end
end

local function on_dcp(pinfo)
    local fi = X["pn_dcp.service_id"]()
    if fi == nil or fi.source == nil then return end
    local d = dcp_decode(fi.source, fi.offset)
    if d == nil then return end
    local fn = pinfo.number
    local response = d.stype ~= 0
    if d.sid == IDENTIFY then dcp_identify(d, tostring(pinfo.dl_src), fn) end
    local xid = d.sid == IDENTIFY and d.xid or nil
    local st_name, st_ip
    local facts_ok = (response and d.stype == 1 and (d.sid == IDENTIFY or d.sid == GET))
        or (not response and (d.sid == HELLO or d.sid == SET))
    for _, b in ipairs(d.blocks) do
        if b.name ~= nil and d.sid == SET and not response and name_bad(b.name) then
            note_violation(fn, "DCP-NAME-INVALID", fn, false, "Set NameOfStation '" .. b.name .. "' breaks the naming rules")
        end
        if facts_ok and not b.erroneous then
            if b.name ~= nil then st_name = b.name end
            if b.ip ~= nil then st_ip = b.ip end
        end
    end
    if st_name == nil and st_ip == nil then return end
    local assign = d.sid == SET and d.stype == 0
    local target = assign and tostring(pinfo.dl_dst) or tostring(pinfo.dl_src)
    if assign and target == NO_DST then return end   -- dcp_rules: a cooked capture names no Set target
    local S_ = dcp_state
    if st_name ~= nil then S_.station[target] = st_name end
    if st_name ~= nil and st_name ~= "" then
        dcp_claim("name", st_name, target, assign, fn, xid)
    elseif st_name == "" then
        dcp_release(S_.name_at, S_.mac_name, target)
    end
    if st_ip ~= nil and st_ip ~= "0.0.0.0" then
        dcp_claim("ip", st_ip, target, assign, fn, xid)
    elseif st_ip == "0.0.0.0" then
        dcp_release(S_.ip_at, S_.mac_ip, target)
    end
end

-- 7. cyclic driver --------------------------------------------------------------------------------
-- pndiss/cyclic.py CyclicTracker, step for step: one checker (pndiss_checker.lua, the port of
-- pndiss/encoder) per axis (AR/submodule), fed every judged cycle (an input frame paired with the
-- latest setpoint), every gap, every record/param event of its device; plus the two rules the
-- driver itself emits (STARTUP-NO-PARAM-RECORD, TELEGRAM-LENGTH-MISMATCH).
local axes             -- axis key -> axis (cyclic.py _Axis)
local axis_list        -- axes in creation order (Python's dict order)
local dev_records      -- device -> record/param events, replayed into a new axis (cap 256)
local bf00_last        -- device -> {ar, decoded} of the latest 0xBF00/0xFFFF write
local bf00_resp        -- AR UUID -> frame of a successful 0xBF00/0xFFFF write response (its request may be lost)
local answered         -- DCE/RPC "act|seq" -> frame of its response (its copies run once)
local req_body, answered_body   -- "act|seq" -> the open / the answered request's body (a resend of it runs once)
local answered_at        -- "act|seq" -> time (s) of its response
local bf00_before        -- device MAC .. "|" .. frame of a 0xBF00 write -> bf00_last before it (false: none)

-- The body of a connectionless DCE/RPC PDU (the 80-byte header, then dg_frag_len bytes), from the Tvb the
-- header was read from; nil when it is not all there
local function rpc_body(seq)
    local len = X["dcerpc.dg_frag_len"]()
    if seq == nil or len == nil then return nil end
    local src, at = seq.source, seq.offset - 64 + 80   -- the sequence number sits at header byte 64
    if src == nil or at < 0 or at + len.value > src:len() then return nil end
    return src(at, len.value):raw()
end
local wrote            -- DCE/RPC "act|seq" of the write requests seen (a response without one: _unseen_writes)
local prev_bf00        -- device -> decoded 0xBF00 of an earlier connection (#31)
local viol             -- frame -> list of {rule, decided} (decided: frame whose dissection decided it; 0 = finish)
local viol_seen        -- "frame|rule" -> that entry
local late             -- deciding frame -> list of entries that name an earlier frame
local finished         -- every checker's finish() has run (first frame dissected again)

local function is_std(t) return T.checker.control_words[t] == true end  -- STW2_ENC/ZSW2_ENC (telegram table)

-- a violation on `frame`, decided while dissecting frame `decided`; `open` = a per-cycle run just
-- opened (its first frame is final; the flush later repeats it), so it is shown at once
function note_violation(frame, rule, decided, open, message, side)
    local k = frame .. "|" .. rule
    local v = viol_seen[k]
    if v == nil then
        v = {rule = rule, frame = frame, decided = decided, message = message, side = side}
        viol_seen[k] = v
        local l = viol[frame]
        if l == nil then l = {}; viol[frame] = l end
        l[#l + 1] = v
        if decided ~= 0 and decided ~= frame then
            local d = late[decided]
            if d == nil then d = {}; late[decided] = d end
            d[#d + 1] = v
        end
    elseif not open and message ~= nil then
        v.message = message   -- the run's final message replaces what it said when it opened
    end
end

local function note(evs, decided)
    if evs == nil then return end
    for _, ev in ipairs(evs) do
        if ev.rule ~= nil then
            -- an open run's message as its checker formatted it when it opened (one pass shows it; the close
            -- gives the final one, with its cycles)
            local m = ev.message
            if m == nil and ev.open and ev.run and ev.run.msg ~= ev.rule then m = ev.run.msg end
            note_violation(ev.frame, ev.rule, decided, ev.open, m, ev.side)
        end
    end
end

-- cyclic.py _refine_profile: telegrams 86-89/100/101 exist only in PS/PSM: a 'generic' device using
-- one is PS/PSM (a length guess proves it only when no other telegram fits), and so is one the session
-- saw written at record 0xFFFF (profile_for); PS/PSM keeps its
-- parameters at 0xFFFF, so the device's 0xFFFF records are given to the checker again
-- cyclic_axes.addressed_to: a record or parameter access addressed to another encoder module of the device is that
-- module's (one Encoder Object per module and slot); one addressed elsewhere is every axis' of the device
-- (also when another controller's AR owns that module: a shared device; session_records.encoder_slots)
local function addressed_to(ax, ev)
    local slot = ev.slot
    if slot == nil or slot == ax.info.slot or ax.fm == nil then return true end
    for _, d in ipairs(ax.fm.objects or {}) do
        if d.slot == slot and d.telegram ~= nil then return false end
    end
    for _, fm in pairs(maps) do
        if fm.device == ax.info.device_mac then
            for _, d in ipairs(fm.objects) do
                if d.slot == slot and d.telegram ~= nil then return false end
            end
        end
    end
    return true
end

local function refine_profile(ax, fn)
    local t = ax.telegram
    local chk = ax.checker
    local guess_fits_other = false   -- a length guess proves the vendor only when no other telegram fits
    if tostring(ax.source):find("length", 1, true) then
        local fits = telegrams_for_length(chk.io_len.actual, chk.io_len.setpoint)
        guess_fits_other = #fits ~= 1 or fits[1] ~= t
    end
    if ax.profile ~= "generic" then return end
    local d = T.telegrams[t]
    local reason
    if d and #d.profiles == 1 and d.profiles[1] == "psm" and not guess_fits_other then
        reason = "telegram " .. t .. " exists only in PS/PSM (cyclic.md §2); " .. tostring(ax.reason)
    else
        local p, why = profile_for(ax.info.device_mac)   -- the session learnt it later (a 0xFFFF write)
        if p ~= "psm" then return end
        reason = why
    end
    do
        ax.profile = "psm"
        ax.reason = reason
        ax.ambiguous = nil   -- PS/PSM has OEM telegrams of the standard lengths: the guess is weighed again
        chk.cfg.profile = "psm"
        chk.cfg.sources.profile = ax.reason
        chk:apply_cfg()
        for _, ev in ipairs(dev_records[ax.info.device_mac or ""] or {}) do
            if ev.kind == "record" and ev.index == 0xFFFF and addressed_to(ax, ev) then note(chk:on_record(ev), fn) end
        end
    end
end

-- cyclic.py _ambiguous: a length guess is judged when both data lengths leave one candidate among
-- the profile's telegrams, or when the guess is a standard telegram of a profile without OEM telegrams of its lengths
local function ambiguous(ax, o)
    if not tostring(o.source):find("length", 1, true) then return false end
    local io = ax.checker.io_len
    local n, seen = 0, {}
    for _, t in ipairs(telegrams_for_length(io.actual, io.setpoint)) do
        local d = T.telegrams[t]
        local ok = ax.profile == "generic" and d.standard
        for _, p in ipairs(d.profiles) do if p == ax.profile then ok = true end end
        -- telegrams of the same layout are one candidate (PS/PSM 86 = 860)
        local sig = table.concat(d.setpoint, ",") .. "|" .. table.concat(d.actual, ",")
        if ok and not seen[sig] then n = n + 1; seen[sig] = true end
    end
    -- PS/PSM's OEM 100/101 have the lengths of 81/83: mandatory 81 is supported, not necessarily run
    return n > 1 and (not T.telegrams[ax.telegram].standard or ax.profile == "psm")
end

-- cyclic.py _axis: a checker configured like EncoderConfig.from_settings (iso from the frame ID
-- class, cycle time from the Connect), the records seen before replayed in order
local function new_axis(o, fr, fn)
    local fm, d = fr.fm, o.d
    local info = {station = fm.station, device_mac = fm.device, api = d.api, slot = d.slot, subslot = d.subslot}
    local ax = {key = o.key, info = info, sp = nil, sp_frame = nil, sp_ok = false, telegram = o.telegram,
                source = o.source, fm = fm, ambiguous = nil}
    ax.profile, ax.reason = profile_for(fm.device)
    local iso = nil
    if fm.frame_id ~= nil then iso = fm.frame_id >= 0x0100 and fm.frame_id < 0x1000 end   -- RT_CLASS_3 = IRT
    local cycle, cycle_source = fm.cycle_ns, nil   -- (nil: the Connect's)
    if cycle == nil and fm.learnt_cycle_ns then   -- a map found from the content: config.COUNTER_CYCLE
        cycle = fm.learnt_cycle_ns
        cycle_source = "learnt from the cycle counter step of the encoder's input frames (no Connect in the capture)"
    end
    local cfg = C.config_from_settings(settings, {profile = ax.profile, telegram = o.telegram, cycle_ns = cycle,
                                                  cycle_source = cycle_source, iso = iso, profile_reason = ax.reason,
                                                  telegram_source = o.source})
    if fm.learnt_k and not (cfg.sources.k or ""):find("^settings%.") then   -- cyclic_axes._axis (as record 0x8030)
        cfg.k = fm.learnt_k
        cfg.sources.k = "the controller holds each sign-of-life value " .. fm.learnt_k
            .. " cycles in the frames the telegram was inferred from"
    end
    ax.checker = C.new(cfg, info)
    ax.checker.io_len[fr.dir] = d.length
    refine_profile(ax, fn)
    ax.checker.prev_bf00 = prev_bf00[fm.device or ""]
    axes[o.key] = ax
    axis_list[#axis_list + 1] = ax
    for _, ev in ipairs(dev_records[fm.device or ""] or {}) do
        if (ev.ar_uuid == nil or fm.ar == nil or ev.ar_uuid == fm.ar) and addressed_to(ax, ev) then
            note(ax.checker:on_record(ev), fn)
        end
    end
    return ax
end

-- CyclicTracker.on_record: record/param events in capture order
-- cyclic_axes.on_reconnect: the AR's axes go on with the new frame maps, each checker starts a new
-- connection (Checker.new_connection); the ended connection's 0xBF00 is the previous one (#31)
function on_reconnect(ar, dev, keys, fn)
    -- cyclic_axes._reconnect_config: the new Connect's telegram and cycle for the axis' submodule (a project
    -- downloaded with another telegram or cycle time reconnects with the same AR UUID); the lengths come again
    local function reconnect_config(ax, keys, fn)
        local chk = ax.checker
        local c = chk.cfg
        chk.io_len = {}
        local changed = false
        for _, k in ipairs(keys) do
            for _, d in ipairs(k[4].objects) do
                if d.api == ax.info.api and d.slot == ax.info.slot and d.subslot == ax.info.subslot
                        and T.telegrams[d.telegram] and d.telegram ~= c.telegram then
                    c.telegram = d.telegram
                    c.sources.telegram = d.telegram_source or "Connect"
                    ax.telegram, ax.source = d.telegram, d.telegram_source
                    changed = true
                end
            end
        end
        local cyc = ax.fm and ax.fm.cycle_ns
        if cyc and cyc ~= c.cycle_ns then
            c.cycle_ns = cyc
            c.sources.cycle_ns = "Connect (SendClockFactor x ReductionRatio)"
            changed = true
        end
        if changed then
            refine_profile(ax, fn)
            chk:apply_cfg()
        end
    end
    local old = bf00_last[dev]
    if old ~= nil and old.ar == ar then
        prev_bf00[dev] = old.decoded
        bf00_last[dev] = nil
    end
    bf00_resp[ar] = nil
    for _, k in ipairs(keys) do gap_stream(k[1] .. "|" .. k[2] .. "|" .. k[3], true) end   -- new counters (gaps.restart)
    for _, ax in ipairs(axis_list) do
        if ax.fm ~= nil and ax.fm.ar == ar then
            local pick
            for _, k in ipairs(keys) do
                if pick == nil and k[4].direction == ax.fm.direction then pick = k[4] end
            end
            ax.fm = pick or (keys[1] and keys[1][4]) or ax.fm
            ax.sp, ax.sp_frame, ax.sp_before, ax.pend, ax.ac_key, ax.held = nil, nil, nil, nil, nil, nil   -- the pairing starts afresh
            ax.sp_ok, ax.sp_new, ax.sp_break = false, false, false
            note(ax.checker:new_connection(prev_bf00[dev]), fn)
            reconnect_config(ax, keys, fn)
        end
    end
end

function on_record(ev, fn)
    local dev = ev.device_mac or ""
    if ev.kind == "record" and (ev.index == 0xBF00 or ev.index == 0xFFFF) and ev.op == "write" then
        local old = bf00_last[dev]
        if old ~= nil and old.ar ~= ev.ar_uuid then prev_bf00[dev] = old.decoded end
        bf00_before[dev .. "|" .. tostring(ev.frame)] = old or false   -- a refused write puts it back
        bf00_last[dev] = {ar = ev.ar_uuid, decoded = ev.decoded or {}}
    end
    local lst = dev_records[dev]
    if lst == nil then lst = {}; dev_records[dev] = lst end
    local kept = #lst < 256
    if kept then lst[#lst + 1] = ev end
    if ev.kind == "param" and ev.index == 0xB02F then
        -- cyclic_axes.on_record: a global access's DO-ID may name any encoder module of the device: not applied to one
        local slots, n = {}, 0
        for _, fm in pairs(maps) do
            if fm.device == dev and fm.source == "connect" then
                for _, d in ipairs(fm.objects) do
                    if d.telegram ~= nil and not slots[d.slot or 0] then slots[d.slot or 0], n = true, n + 1 end
                end
            end
        end
        if n > 1 then
            ev.several_encoders = true   -- (no P922 relabel from it: record_items)
            local copy = {}
            for k, v in pairs(ev) do copy[k] = v end
            copy.do_unknown, ev = true, copy
        end
    end
    for _, ax in ipairs(axis_list) do
        if (ax.info.device_mac or "") == dev and (ev.ar_uuid == nil or ax.fm.ar == nil or ev.ar_uuid == ax.fm.ar
                or (ev.kind == "param" and ax.fm.phase ~= "released" and ax.fm.phase ~= "aborted"))
                and addressed_to(ax, ev) then
            -- any AR's parameter access while the axis' AR is up
            -- an axis of a restarted AR seen before its own 0xBF00 (#31)
            if ax.checker.prev_bf00 == nil then ax.checker.prev_bf00 = prev_bf00[dev] end
            local refined = ax.profile == "generic" and ev.index == 0xFFFF and ev.profile == "psm"
            if refined then refine_profile(ax, fn) end   -- replays the device's 0xFFFF records, this one if kept
            if not (refined and kept) then note(ax.checker:on_record(ev), fn) end
        end
    end
end

-- cyclic.py _relabel: the session learnt the telegram (P922) after the first frame
local function relabel(o, fr, fn)
    local t = o.d.telegram
    local ax = axes[o.key]
    if not T.telegrams[t] or (ax ~= nil and ax.checker.p922_rejected == t) then
        o.rejected = t   -- P922 contradicts the AR's lengths: the checker reported it, keep the AR's view
        return
    end
    local L = layout(t, fr.dir)
    o.telegram, o.source, o.rows, o.len = t, o.d.telegram_source, L.rows, L.len
    o.sig = nil
    o.length_checked = false
    if ax == nil then return end
    ax.telegram, ax.source, ax.ambiguous = t, o.source, false
    ax.sp, ax.sp_before = nil, nil   -- decoded with the old layout, as a held setpoint and a waiting actual value are
    ax.held, ax.pend = nil, nil
    local chk = ax.checker
    local c = chk.cfg
    if c.telegram ~= t or tostring(c.sources.telegram):find("length", 1, true) then
        c.telegram = t
        c.sources.telegram = o.source or "session"
    end
    refine_profile(ax, fn)
    chk:apply_cfg()
    note(chk:flush_all(), fn)   -- the open runs end with the old layout (cyclic.py _relabel)
    chk:reset_history()
end

-- cyclic.py _length_check: #64, the data object's length fits its telegram
local function length_check(o, fr, fn)
    if o.source == "length (guess)" or o.d.length_checked_for == o.telegram then return end
    o.d.length_checked_for = o.telegram   -- once per data object and telegram (cyclic.py _length_check)
    if tg_len(o.telegram, fr.dir) ~= o.d.length then
        note_violation(fn, "TELEGRAM-LENGTH-MISMATCH", fn, false, string.format(
            "telegram %d %s is %d bytes, the AR maps %d (telegram from %s)", o.telegram, fr.dir,
            tg_len(o.telegram, fr.dir), o.d.length, tostring(o.source)),
            fr.dir == "setpoint" and "controller" or "encoder")   -- (cyclic.py: the side by direction)
    end
end

-- cyclic.py _startup: #66, 0xBF00 (PS/PSM 0xFFFF) is written since the Connect, decided at PrmEnd
-- (an ambiguous length guess of an unknown vendor is not judged: cyclic_axes._startup)
local function startup(ax, fn)
    for _, d in ipairs(ax.fm.objects or {}) do   -- another AR owns the module (ModuleDiffBlock): no 0xBF00 of this AR
        if d.locked and d.slot == ax.info.slot and d.subslot == ax.info.subslot then return end
    end
    if ax.fm.source == "connect" and is_std(ax.checker.cfg.telegram) and not ax.checker.bf00_seen
            and not bf00_resp[ax.fm.ar or ""] and not (ambiguous(ax, {source = ax.source}) and ax.profile == "generic") then
        note_violation(fn, "STARTUP-NO-PARAM-RECORD", fn, false,
            "PrmEnd without a write of 0xBF00" .. (ax.profile == "psm" and " / 0xFFFF" or "")
            .. " since the Connect of this AR")
    end
end

-- session.set_phase + cyclic.on_phase, as far as they change a verdict: PrmEnd or ApplicationReady
-- ends the AR's parameterisation (its cycles are judged from then on), Release / abort ends the AR
-- (cyclic.py NOT_JUDGED_PHASES); at PrmEnd #66 is decided for every encoder axis of the AR
-- (cyclic.py _ar_axes creates them). Phases only move forward.
CONST.PHASE_RANK = {parameterisation = 0, judged = 1, released = 2, aborted = 3}
function ar_moves(ar, phase, fn)
    local cur = ar ~= nil and ar_phase[ar] or nil
    local to = (phase == "prm_end" or phase == "application_ready") and "judged" or phase
    if cur == nil or CONST.PHASE_RANK[to] <= CONST.PHASE_RANK[cur] then return end
    ar_phase[ar] = to
    for _, k in ipairs(ar_keys[ar]) do k[4].phase = to end
    if to == "released" or to == "aborted" then restart_gaps(ar) end   -- a later AR on these streams: no capture loss
    if phase ~= "prm_end" then return end
    local list, seen = {}, {}
    for _, k in ipairs(ar_keys[ar]) do
        if maps[k[1] .. "|" .. k[2] .. "|" .. k[3]] == k[4] then
            local fr = lookup(k[1], k[2], k[3])
            if fr ~= nil and fr.fm == k[4] then
                for _, o in ipairs(fr.objs) do
                    local ax = o.ax or axes[o.key]
                    if ax == nil then ax = new_axis(o, fr, fn) end
                    o.ax = ax
                    if ax.checker.io_len[fr.dir] == nil then
                        ax.checker.io_len[fr.dir] = o.d.length
                        refine_profile(ax, fn)
                    end
                    if not seen[ax] then seen[ax] = true; list[#list + 1] = ax end
                end
            end
        end
    end
    for _, ax in ipairs(list) do startup(ax, fn) end
end

-- PNIO-CM Control / Release of an AR (session._control, session._release)
local function control(op, pt, fn)
    local want = (op == 4 and pt == 0) and "control" or ((op == 1 and pt == 2) and "release" or nil)
    if want == nil then return end
    for _, b in ipairs(blocks()) do
        local u = inside(all("pn_io.ar_uuid"), b)[1]
        local ar = u and tostring(u)
        if want == "release" and b.type == 0x8114 then
            ar_moves(ar, "released", fn)
        elseif want == "control" and b.type >= 0x0110 and b.type <= 0x0117 and b.type ~= 0x0115 then
            local c = inside(all("pn_io.control_command"), b)[1]
            if c and bit.band(c.value, 1) ~= 0 then ar_moves(ar, "prm_end", fn) end
            if c and bit.band(c.value, 2) ~= 0 then ar_moves(ar, "application_ready", fn) end
        end
    end
end

-- session.on_rta_error: an ERR-RTA-PDU between an AR's controller and device aborts the latest such AR
local function rta_error(pinfo)
    local t = X["pn_io.pdu_type.type"]()
    if t == nil then return end
    local src, dst = tostring(pinfo.dl_src), tostring(pinfo.dl_dst)
    local se, de = X["pn_io.alarm_src_endpoint"](), X["pn_io.alarm_dst_endpoint"]()
    local refs_key = "*refs|" .. (src < dst and (src .. "|" .. dst) or (dst .. "|" .. src))   -- (in alarm_seq)
    if t.value ~= 4 then
        -- session_ar.on_alarm_endpoints: alarms no known AR numbers so, between the MACs of an AR known only from
        -- its content, are its: its alarm references (each side's own is its source endpoint)
        if se == nil or de == nil then return end
        local inferred = false
        for _, fm in pairs(maps) do
            if fm.source == "content" and ((fm.controller == src and fm.device == dst)
                                           or (fm.controller == dst and fm.device == src)) then inferred = true end
        end
        if not inferred then return end
        for _, ar in ipairs(ar_order) do
            local d = ar_devs[ar]
            if d and ((d[1] == src and d[2] == dst) or (d[1] == dst and d[2] == src)) then
                local mine, theirs = d[4], d[3]
                if d[2] == src then mine, theirs = d[3], d[4] end
                if mine ~= nil and theirs ~= nil and mine == se.value and theirs == de.value then return end
            end
        end
        local r = alarm_seq[refs_key] or {}
        r[src], r[dst] = se.value, de.value
        alarm_seq[refs_key] = r
        return
    end
    -- session_ar._names_endpoints: of several ARs between the two, the one whose alarm references the PDU's
    -- endpoints name; one whose references are unknown when none does; none: an AR known only from its content
    local pick, unknown
    for i = #ar_order, 1, -1 do
        local ar = ar_order[i]
        local d = ar_devs[ar]
        local ph = ar_phase[ar]
        if pick == nil and d and ((d[1] == src and d[2] == dst) or (d[1] == dst and d[2] == src))
                and ph ~= "released" and ph ~= "aborted" then
            local mine, theirs = d[4], d[3]    -- the device sent it; the controller: the other way round
            if d[2] == src then mine, theirs = d[3], d[4] end
            if mine == nil or theirs == nil or se == nil or de == nil then
                unknown = unknown or ar
            elseif mine == se.value and theirs == de.value then
                pick = ar
            end
        end
    end
    pick = pick or unknown
    if pick ~= nil then
        ar_moves(pick, "aborted", pinfo.number)
        return
    end
    local r = alarm_seq[refs_key]   -- the inferred AR numbers its alarms otherwise: another unseen AR ended
    if r ~= nil and se ~= nil and de ~= nil and (r[src] ~= se.value or r[dst] ~= de.value) then return end
    restart_gaps(nil, src, dst, "aborted")
end

-- CyclicTracker.on_alarm: a DATA-RTA alarm notification reaches the encoder axes of its submodule (#48, #70); the
-- RTA resends it with the same sequence number until it is acknowledged: judged once
local function rta_alarm(pinfo)
    local at, pt = X["pn_io.alarm_type"](), X["pn_io.pdu_type.type"]()
    if at == nil or pt == nil or pt.value ~= 1 then return end
    local src = tostring(pinfo.dl_src)
    local ep, seq, fid = X["pn_io.alarm_src_endpoint"](), X["pn_io.send_seq_num"](), X["pn_rt.frame_id"]()
    local dst = tostring(pinfo.dl_dst)   -- per AR: one alarm reference towards two controllers (a shared device)
    local key = src .. "|" .. dst .. "|" .. tostring(ep and ep.value) .. "|" .. ((fid and fid.value == 0xFC01) and "high" or "low")
    local sq, now = seq and seq.value, tonumber(pinfo.abs_ts)
    local last = alarm_seq[key]
    alarm_seq[key] = {sq, now}   -- the window slides with each resend
    if last ~= nil and last[1] == sq and now - last[2] <= 10 then return end   -- cyclic_axes.ALARM_RESEND_NS
    local slot, sub = all("pn_io.slot_nr"), all("pn_io.subslot_nr")
    local items, spec = {}, all("pn_io.channel_properties.specifier")
    for i, c in ipairs(all("pn_io.channel_error_type")) do
        items[i] = {channel_error_type = c.value, channel_properties = {specifier = spec[i] and spec[i].value}}
    end
    local ev = {kind = "alarm", frame = pinfo.number, ts_ns = ts_ns(pinfo), src = src, alarm_type = at.value,
                slot_nr = slot[1] and slot[1].value, subslot_nr = sub[1] and sub[1].value, items = items}
    for _, ax in ipairs(axis_list) do
        if (ax.info.device_mac or "") == src and ax.info.slot == ev.slot_nr and ax.info.subslot == ev.subslot_nr
                and ax.fm.phase ~= "released" and ax.fm.phase ~= "aborted"   -- an ended AR's axis: not its alarm
                and (ax.fm.controller == nil or ax.fm.controller == dst or dst == NO_DST) then   -- nor another controller's AR's
            note(ax.checker:on_alarm(ev), pinfo.number)
        end
    end
end

-- signal values for the checker: numbers (8-byte ones above 2^53 as {hi, lo})
local function decode_sig(tvb, base, rows)
    local sig = {}
    for _, row in ipairs(rows) do
        local r = tvb(base + row.off, row.size)
        if row.size == 8 then sig[row.name] = int64_at(tvb, base + row.off, row.signed, true)
        else sig[row.name] = row.signed and r:int() or r:uint() end
    end
    return sig
end

-- cyclic.py _judge: one cycle, the actual value `sig` (frame fn) with the axis' setpoint; decided = the
-- frame being dissected (a value that waited for its setpoint is judged on the setpoint's frame)
local function judge(ax, sig, fn, ts, ok, decided)
    local chk = ax.checker
    if not (ok and ax.sp_ok) or ax.ambiguous then
        note(chk:gap(fn, ts, "not valid"), decided)
    else
        note(chk:cycle(fn, ts, ax.sp, sig, ax.sp_frame, ax.sp_before), decided)
    end
end

-- CyclicTracker.on_cyclic for one mapped frame (first pass); returns what the tree shows
-- cyclic.py _own_setpoint: a setpoint followed by a newer one before any actual value (ax.held) is this value's
-- when the value lies from it as the last pair's did (ax.phase): two frames swapped by time-stamp jitter
local function own_setpoint(ax, miss, rts, sig, fn, ts, ok)
    local h = ax.held
    ax.held = nil
    local st = gap_streams[ax.sp_key or ""]
    local T = (st ~= nil and st.step > 0 and st.uniform) and st.step * GAP_UNIT_NS or nil
    local d0, d1 = math.abs(rts - h.rts - ax.phase), math.abs(rts - ax.sp_rts - ax.phase)
    if miss > 0 or T == nil or d0 >= d1 or 2 * d0 >= T then   -- within half a cycle of the phase (gaps.period_ns)
        ax.sp_break = true
        return false
    end
    local sp, sp_frame, sp_ok, sp_before = ax.sp, ax.sp_frame, ax.sp_ok, ax.sp_before
    ax.sp, ax.sp_frame, ax.sp_ok, ax.sp_before = h.sig, h.fn, h.ok, h.before
    ax.phase = rts - h.rts
    ax.held_paired = (ax.held_paired or 0) + 1   -- cyclic.HELD_MAX in a row: more is clock drift
    judge(ax, sig, fn, ts, ok, fn)
    ax.sp, ax.sp_frame, ax.sp_ok, ax.sp_before = sp, sp_frame, sp_ok, sp_before
    return true
end

local function on_cyclic(pinfo, tvb, fr, ds_ok, miss, key)
    local fn, ts = pinfo.number, ts_ns(pinfo)
    local rts = pinfo.rel_ts * 1e9   -- time differences for the pairing (abs_ts as a double rounds to ~0.2 us)
    local out = {objs = {}}
    local csdu = tvb:raw()
    local same = csdu == fr.last_csdu
    fr.last_csdu = csdu
    local n_csdu = tvb:len()
    local dir = fr.dir
    for _, o in ipairs(fr.objs) do
        local d = o.d
        local t = d.telegram
        if t ~= nil and t ~= o.telegram and t ~= o.rejected and not (o.source == "settings.telegram"
                and tostring(d.telegram_source):sub(1, 6) == "length") then relabel(o, fr, fn) end
        local skip = false
        if not same or o.sig == nil then
            if o.stop > n_csdu then   -- Python raises Malformed: the rest of the frame is not looked at
                out.malformed = string.format("data object %s/%s ends at byte %d of a %d-byte C_SDU",
                    tostring(d.slot), tostring(d.subslot), o.stop, n_csdu)
                break
            end
            if not o.length_checked then
                o.length_checked = true
                length_check(o, fr, fn)
            end
            if d.length < o.len then
                skip = true
            else
                o.sig = decode_sig(tvb, d.offset, o.rows)   -- a new table only when the bytes changed
            end
        end
        if not skip then
            local iops = (o.stop < n_csdu) and tvb(o.stop, 1):uint() or nil
            local ok = ds_ok and iops ~= nil and bit.band(iops, 0x80) ~= 0
            if ok and o.iocs_at ~= nil then   -- the device consumes the setpoints: its IOCS of them is GOOD
                ok = o.iocs_at < n_csdu and bit.band(tvb(o.iocs_at, 1):uint(), 0x80) ~= 0
            end
            local ax = o.ax
            if ax == nil then
                ax = axes[o.key]
                if ax == nil then
                    ax = new_axis(o, fr, fn)
                elseif ax.telegram ~= o.telegram or ax.source ~= o.source then   -- (or P922 confirmed a guess)
                    ax.telegram, ax.source, ax.ambiguous = o.telegram, o.source, nil   -- layouts rebuilt after a P922 relabel
                end
                o.ax = ax
            end
            local chk = ax.checker
            if chk.io_len[dir] == nil then
                chk.io_len[dir] = d.length
                refine_profile(ax, fn)
            end
            -- what the tree shows of this object; the same table while nothing changes (memory per frame)
            local v = o.view
            local shown = ok and not ax.ambiguous   -- judged: not while the telegram is only guessed (cyclic.py)
            if v == nil or v.iops ~= iops or v.ok ~= shown or v.profile ~= ax.profile or v.telegram ~= o.telegram
                    or v.rows ~= o.rows or v.source ~= o.source or v.station ~= fr.fm.station then
                v = {telegram = o.telegram, source = o.source, rows = o.rows, len = o.len, d = d, dir = dir,
                     iops = iops, ok = shown, profile = ax.profile, station = fr.fm.station}
                o.view = v
            end
            out.objs[#out.objs + 1] = v
            if dir == "setpoint" then
                local before = ax.sp_before
                if ax.sp_ok then ax.sp_before = ax.sp else ax.sp_before = nil end
                -- setpoint cycles lost, or one never paired: no edge across (cyclic.py)
                -- (an output CR faster than the input CR leaves setpoints unpaired by design: the device acts on the latest)
                -- -- unless the next actual value turns out to be the unpaired one's, captured late (own_setpoint)
                if miss > 0 or (ax.sp_new and not gap_faster(key, ax.ac_key)) then
                    if miss == 0 and ax.held == nil and ax.phase ~= nil and (ax.held_paired or 0) < 3 then   -- cyclic.HELD_MAX
                        ax.held = {sig = ax.sp, fn = ax.sp_frame, ok = ax.sp_ok, before = before, rts = ax.sp_rts}
                    else
                        ax.sp_break, ax.held = true, nil
                    end
                end
                ax.sp, ax.sp_frame, ax.sp_ok, ax.sp_rts = o.sig, fn, ok, rts
                ax.sp_new, ax.sp_key = true, key
                local pend = ax.pend
                if pend ~= nil then   -- an actual value came before its setpoint (RT clocks drift): pair them now
                    ax.pend = nil
                    if miss > 0 then  -- ... unless its setpoint is among the lost ones: not judged
                        ax.sp_break = false
                        note(chk:lost(pend.fn, pend.ts, 1), fn)
                    else
                        ax.sp_new, ax.held_paired = false, 0
                        ax.phase = pend.rts - rts
                        judge(ax, pend.sig, pend.fn, pend.ts, pend.ok, fn)
                    end
                end
            else
                ax.ac_key = key
                if ax.ambiguous == nil then ax.ambiguous = ambiguous(ax, o) end
                if ax.sp ~= nil and not (ax.held ~= nil and own_setpoint(ax, miss, rts, o.sig, fn, ts, ok)) then
                    if ax.pend ~= nil then   -- two actual values, no setpoint between: the first one's is lost
                        local pend = ax.pend
                        ax.pend = nil
                        note(chk:lost(pend.fn, pend.ts, 1), fn)
                    end
                    local stale = false
                    if miss > 0 or ax.sp_break or not ax.sp_new then
                        -- cyclic.py _unpaired: lost cycles elapse unjudged; a value waits for its own setpoint
                        stale = not ax.sp_new and gap_same_step(ax.sp_key, key)
                        local brk = ax.sp_break
                        ax.sp_break = false
                        if miss > 0 or brk then note(chk:lost(fn, ts, miss), fn) end
                        if stale then ax.pend = {sig = o.sig, fn = fn, ts = ts, ok = ok, rts = rts} end
                    end
                    if not stale then
                        ax.sp_new, ax.held_paired = false, 0
                        ax.phase = rts - ax.sp_rts
                        judge(ax, o.sig, fn, ts, ok, fn)
                    end
                end
            end
        end
    end
    -- frames that show the same objects share one cached result
    local last = fr.last_out
    if last ~= nil and out.malformed == nil and last.malformed == nil and #last.objs == #out.objs then
        local same_view = true
        for i, v in ipairs(out.objs) do if last.objs[i] ~= v then same_view = false break end end
        if same_view then return last end
    end
    fr.last_out = out
    return out
end

-- CyclicTracker.finish: the end of the capture for every checker (deadlines, P971, open runs)
local function finish_all()
    finished = true
    for _, ax in ipairs(axis_list) do note(ax.checker:finish(), 0) end
end

-- 8. tree, heuristic, postdissector, init -----------------------------------------------------------

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
            out[#out + 1] = {b.name, x, b}
        end
    end
    return out
end

-- one decoded data object (a 'telegram' event): values read again from the frame's bytes
local function add_object(tree, tvb, c)
    local d = c.d
    if d.offset + c.len > tvb:len() then
        -- a frame whose C_SDU equals the previous (malformed) one was judged with the object's last values
        -- (cyclic.py does the same); its bytes are not in this frame: shown, not read (fuzz seed5051-m12)
        tree:add(pndiss, string.format("PROFINET encoder: telegram %d %s, slot %s/%s: the data object ends at byte %d "
            .. "of a %d-byte C_SDU", c.telegram, c.dir, tostring(d.slot), tostring(d.subslot), d.offset + c.len, tvb:len()))
        return
    end
    local st = tree:add(pndiss, tvb(d.offset, c.len),
        string.format("PROFINET encoder: telegram %d %s, slot %s/%s", c.telegram, c.dir, tostring(d.slot), tostring(d.subslot)))
    st:add(F["pndiss.telegram"], c.telegram)
    st:add(F["pndiss.slot"], d.slot or 0)
    st:add(F["pndiss.subslot"], d.subslot or 0)
    if c.station then st:add(F["pndiss.station"], c.station) end
    -- (always: a display filter dissects with an invisible tree too -- pndiss.judged == 0 is a natural question)
    st:add(F["pndiss.direction"], c.dir)
    st:add(F["pndiss.telegram_source"], c.source or "")
    st:add(F["pndiss.api"], d.api or 0)
    if c.iops then st:add(F["pndiss.iops"], tvb(d.offset + d.length, 1), c.iops) end
    st:add(F["pndiss.judged"], c.ok and true or false)
    st:add(F["pndiss.profile"], c.profile)
    local serr, x2
    for _, row in ipairs(c.rows) do
        local r = tvb(d.offset + row.off, row.size)
        local v = sig_value(tvb, d.offset, row)
        local it = st:add(F["pndiss." .. row.name], r, v)
        if T.bitmaps[row.name] then
            for _, b in ipairs(bits_of(row.name, v, c.profile)) do
                local ab = "pndiss." .. row.name .. "." .. b[1]
                local x = b[2]
                if MASKED[ab] then x = v
                elseif b[3].width > 32 then x = v:rshift(b[3].bit):band(UInt64.max():rshift(64 - b[3].width)) end
                it:add(F[ab], r, x)
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

-- the Info column names the frame's violations (and those decided here for earlier frames), so
-- the packet list shows them in a single pass (tshark without -2, the GUI's first look)
local function info_rules(pinfo)
    local parts = {}
    for _, v in ipairs(viol[pinfo.number] or {}) do parts[#parts + 1] = v.rule end
    for _, v in ipairs(late[pinfo.number] or {}) do parts[#parts + 1] = v.rule .. " (frame " .. v.frame .. ")" end
    if #parts > 0 then pinfo.cols.info:append(" [pndiss: " .. table.concat(parts, ", ") .. "]") end
end

-- the violations cached for this frame: pndiss.rule + expert info pndiss.rule.<ID> each
local function add_rules(tree, tvb, pinfo)
    local d = late[pinfo.number]
    if d ~= nil and #d > 0 then
        local st = tree:add(pndiss, tvb(0, 0), "pndiss violations decided here for earlier frames")
        for _, v in ipairs(d) do
            st:add(F["pndiss.late_rule"], v.rule):add(F["pndiss.late_rule.frame"], v.frame)
        end
    end
    local l = viol[pinfo.number]
    if l == nil or #l == 0 then return end
    local st = tree:add(pndiss, tvb(0, 0), "pndiss violations")
    for _, v in ipairs(l) do
        local r = T.rules[v.rule]
        local it = st:add(F["pndiss.rule"], v.rule)
        local side = v.side or (r and r.side) or ""
        it:add_proto_expert_info(E[v.rule], v.rule .. " (" .. side .. "): " .. (v.message or (r and r.section) or ""))
        it:add(F["pndiss.rule.side"], side)
        it:add(F["pndiss.rule.decided_at"], v.decided):set_generated()
    end
end

local cyc_cache        -- frame number -> first-pass result of a mapped cyclic frame
local cyclic_frame     -- number of the frame the heuristic saw last: the postdissector skips it
local blind            -- a frame had no fields on the first pass (tshark -2 without -Y or -R)

local function heuristic(tvb, pinfo, tree)
    local whole = tvb   -- (the first pass cuts tvb before a trailer; the tree shows the frame's own bytes)
    -- pn_io may offer other frames too (a DCP Identify after an AR was seen): those are the postdissector's
    local fid = X["pn_rt.frame_id"]()
    if fid ~= nil and not ((fid.value >= 0x0100 and fid.value < 0x1000) or (fid.value >= 0x8000 and fid.value < 0xFC00)) then
        return false   -- not cyclic data (rt.py _RANGES)
    end
    cyclic_frame = pinfo.number
    if pinfo.visited and not finished then finish_all() end
    local cached = cyc_cache[pinfo.number]
    if cached == nil then
        if pinfo.visited then return false end
        local fi = X["pn_rt.frame_id"]()
        if fi == nil then blind = true; return false end   -- no protocol tree: nothing extracted
        -- analyzer._pn_rt: a frame the snap length cut has no APDU status (its last 4 bytes): malformed, no cycle
        if pinfo.caplen < pinfo.len then return false end
        local src, dst = tostring(pinfo.dl_src), tostring(pinfo.dl_dst)
        local key = fi.value .. "|" .. src .. "|" .. dst
        local cc, ds, xs = X["pn_rt.cycle_counter"](), X["pn_rt.ds"](), X["pn_rt.transfer_status"]()
        cc, ds, xs = cc and cc.value, ds and ds.value, xs and xs.value
        -- a trailer (a TAP's, an FCS kept): bytes after the C_SDU the Connect gives, and tshark's counter and
        -- status are the trailer's. Decided once per stream and map generation (cyclic.py _trailer_check): the
        -- status where the Connect puts it and none at the frame's end -> read counter and status there
        if cache_generation ~= map_generation then lookup(fi.value, src, dst, true) end   -- (a new generation: decide again)
        local trim, n = gen.trim[key], tvb:len()
        local byte   -- the C_SDU and, after it, the 4 bytes tshark reads as the APDU status (only where looked at)
        if trim or not gen.checked[key] then
            byte = function(i)
                if i < n then return tvb(i, 1):uint() end
                return ({cc and bit.rshift(cc, 8), cc and bit.band(cc, 0xFF), ds, xs})[i - n + 1] or 0
            end
        end
        if not gen.checked[key] then
            local fm = lookup(fi.value, src, dst, true)
            local at = fm and fm.data_length and math.max(40, fm.data_length)
            local longer = at ~= nil and n > at
            local here = longer and bit.band(byte(at + 2), 0x04) ~= 0 and byte(at + 3) == 0
            local at_end = ds ~= nil and bit.band(ds, 0x04) ~= 0 and xs == 0
            if fm == nil then
                gen.checked[key] = true
            elseif not longer or here or at_end then
                gen.checked[key] = true
                trim = (here and not at_end) and {at = at, extra = n - at} or nil
                gen.trim[key] = trim
            end
        end
        if trim and n > trim.at then
            local at = trim.at
            cc, ds, xs = bit.bor(bit.lshift(byte(at), 8), byte(at + 1)), byte(at + 2), byte(at + 3)
            tvb = tvb(0, at):tvb()
        else
            trim = nil
        end
        local last = tostring(ds) .. "|" .. tvb:raw()
        local copy_of, is_copy = nil, false
        trim = trim and {at = trim.at, extra = n - trim.at, cc = cc}   -- (what the tree says of this frame)
        if cc then copy_of, is_copy = gap_duplicate(key, cc, ts_ns(pinfo), last) end
        if copy_of then
            cyc_cache[pinfo.number] = {objs = {}, copy_of = copy_of, stale = not is_copy, trim = trim}
            return false
        end
        local miss = cc and gap_advance(key, cc, ts_ns(pinfo), last, pinfo.number) or 0
        local fr = lookup(fi.value, src, dst)
        if fr == nil and ds ~= nil and bit.band(ds, 0x14) == 0x14 then   -- mid-session capture: frames of
            infer_offer(key, fi.value, src, dst, pinfo.number, tvb)       -- a provider in RUN (infer.offer)
        end
        if fr == nil or #fr.objs == 0 then return false end
        -- rt.judgeable: DataValid (bit 2), ProviderState RUN (bit 4) and TransferStatus 0, wire.md §2.3
        local ok_ds = ds ~= nil and bit.band(ds, 0x14) == 0x14 and (xs == nil or xs == 0)
        local ph = fr.fm.phase   -- before PrmEnd or after the AR's end: not judged (cyclic.py NOT_JUDGED_PHASES)
        if ph == "parameterisation" or ph == "released" or ph == "aborted" then ok_ds = false end
        -- a system redundancy AR's frame that says Backup (DataStatus.State, bit 0): the device acts on the primary
        if fr.fm.primary_only and ds ~= nil and ds % 2 == 0 then ok_ds = false end
        if ph == "released" or ph == "aborted" then   -- gaps.restart: a later AR here is no capture loss
            if gap_streams[key] ~= nil then gap_stream(key, true) end
        end
        cached = on_cyclic(pinfo, tvb, fr, ok_ds, miss, key)
        cached.trim = trim
        cyc_cache[pinfo.number] = cached
    end
    if tree then
        local t = cached.trim
        if t then
            tree:add(pndiss, whole(t.at, math.min(4, whole:len() - t.at)), string.format("PROFINET encoder: %d bytes after the "
                .. "%d-byte C_SDU the Connect gives (a trailer: a TAP's, or an FCS kept): cycle counter %d and status "
                .. "read here, not at the frame's end", t.extra, t.at, t.cc or 0))
        end
        if cached.copy_of and cached.stale then
            tree:add(pndiss, tvb(0, 0), "PROFINET encoder: cycle counter not newer than frame " .. cached.copy_of
                     .. "'s (a late copy, or a repeated counter): a consumer discards it, not a cycle")
        elseif cached.copy_of then
            tree:add(pndiss, tvb(0, 0), "PROFINET encoder: copy of frame " .. cached.copy_of
                     .. " (same cycle counter, status and data: a mirror port saw it twice), not a cycle")
        end
        for _, c in ipairs(cached.objs) do add_object(tree, tvb, c) end
        if cached.malformed then
            tree:add(pndiss, tvb(0, 0), "PROFINET encoder: malformed"):add_proto_expert_info(E.malformed, cached.malformed)
        end
    end
    return false   -- let pn_io go on with its own IODataObject dissection
end
pndiss:register_heuristic("pn_io", heuristic)

-- profile selection (pndiss/records/profiles.py): vendor ID 0x0239 = Lika, then order ID patterns
CONST.ORDER_PATTERNS = {
    {{"LIKA", "ROTACOD", "XAC77"}, "lika"},
    {{"SCANCON", "SAG%-E"}, "scancon"},
    {{"^E%u?%u?%u?M?58", "ENA58IL"}, "hohner"},
    {{"%f[%w]PSM?%f[%W]", "ACURO"}, "psm"},
}
function select_profile(vendor, order)
    if vendor == 0x0239 then return "lika" end
    if order then
        local u = order:upper():gsub("^%s+", ""):gsub("%s+$", "")
        for _, row in ipairs(CONST.ORDER_PATTERNS) do
            for _, pat in ipairs(row[1]) do
                if u:find(pat) then return row[2] end
            end
        end
    end
    return "generic"
end
local im0_seen

local function show_records(tree, tvb, items)
    -- the first pass's Tvbs have expired: find the record bytes again in this dissection (same order)
    local cur, k = records_of_frame(), 0
    for _, it in ipairs(items) do
        if it.error then
            tree:add(pndiss, tvb(0, 0), "PROFINET encoder: record error"):add_proto_expert_info(E.malformed,
                "pndiss: " .. it.error)
        elseif it.im0 then
            local st = tree:add(pndiss, tvb(0, 0), "PROFINET encoder: I&M0")
            st:add(F["pndiss.im0.profile_id"], it.im0)
            st:add(F["pndiss.im0.profile_name"], T.im_profile_ids[it.im0] or string.format("profile 0x%04X", it.im0))
        else
            local r = it.rec
            k = k + 1
            local len = r.len
            local at = cur[k] and cur[k].index == r.index and cur[k].len == len and cur[k].at
            local st = tree:add(pndiss, at and at[1](at[2], len) or tvb(0, 0), string.format("PROFINET encoder: record %s 0x%04X %s",
                r.op, r.index, it.index_name))
            st:add(F["pndiss.record.op"], r.op)
            st:add(F["pndiss.record.index"], r.index)
            st:add(F["pndiss.record.index_name"], it.index_name)
            st:add(F["pndiss.record.length"], len)
            if it.malformed then st:add_proto_expert_info(E.malformed, "record data do not decode") end
            local q = r.op == "write" and it.decoded
            if q and q.kind == "parameter request" then
                st:add(F["pndiss.param.kind"], "parameter request")
                st:add(F["pndiss.param.request_ref"], q.request_ref)
                st:add(F["pndiss.param.request_id"], q.request_id)
                st:add(F["pndiss.param.request_id_name"], q.request_id_name)
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
                if ev.request_ref ~= nil then
                    st:add(F["pndiss.param.request_ref"], ev.request_ref)
                    st:add(F["pndiss.param.request_id"], ev.request_id)
                    st:add(F["pndiss.param.request_id_name"], ev.request_id_name)
                    st:add(F["pndiss.param.axis"], ev.axis)
                end
                st:add(F["pndiss.param.response_id"], ev.response_id)
                st:add(F["pndiss.param.ok"], ev.ok)
                for _, w in ipairs(ev.pairing) do st:add(F["pndiss.param.pairing"], w) end
                for _, p in ipairs(ev.params) do
                    local pt2 = st:add(F["pndiss.param.pnu"], p.pnu or 0)
                    if p.subindex then pt2:add(F["pndiss.param.subindex"], p.subindex) end
                    if p.name then pt2:add(F["pndiss.param.name"], p.name) end
                    if p.format then pt2:add(F["pndiss.param.format"], p.format) end
                    if p.error then
                        pt2:add(F["pndiss.param.error_code"], p.error.code)
                        pt2:add(F["pndiss.param.error"], p.error.text)
                    elseif p.block then
                        local vf = p.block.int and F["pndiss.param.value"] or F["pndiss.param.value_text"]
                        for _, v in ipairs(p.block.shown) do pt2:add(vf, v) end
                    end
                end
            elseif it.bf00 then
                local d = it.bf00
                for _, n in ipairs(BF00_INT) do
                    if d[n] ~= nil then st:add(F["pndiss.bf00." .. n], d[n]) end
                end
                if d.mupr64 then st:add(F["pndiss.bf00.mupr"], d.mupr64); st:add(F["pndiss.bf00.tmr"], d.tmr64) end
                if d.velocity_unit_name then st:add(F["pndiss.bf00.velocity_unit_name"], d.velocity_unit_name) end
                for _, pr in ipairs(d.problems) do st:add(F["pndiss.bf00.problem"], pr.rule) end
            end
        end
    end
end

-- session_records._unseen_writes: a successful write response of the user parameter record proves the
-- write #66 asks for even when the capture lost its request; one of 0xFFFF names PS/PSM (profile_for)
local function write_responses(pinfo)
    local arus = all("pn_io.ar_uuid")
    for _, b in ipairs(blocks()) do
        if b.type == 0x8008 and b.e - b.s >= 64 then
            local t, hs = b.tvb, b.s + 8   -- after block header and SeqNumber
            local index = t(hs + 26, 2):uint()
            if (index == 0xBF00 or index == 0xFFFF) and t(hs + 36, 4):uint() == 0 then   -- PNIOStatus OK
                local au = inside(arus, b)[1]
                local ar = au and tostring(au) or tostring(t(hs, 16):bytes())
                local dev = (ar_devs[ar] or {})[1] or tostring(pinfo.dl_src)
                local f = facts[dev] or {}
                if index == 0xFFFF and f.ffff == nil then
                    facts[dev], f.ffff, profiles[dev] = f, pinfo.number, nil
                    for _, ax in ipairs(axis_list) do
                        if (ax.info.device_mac or "") == dev then refine_profile(ax, pinfo.number) end
                    end
                end
                if index == 0xBF00 or profile_for(dev) == "psm" then   -- 0xFFFF is the user record of PS/PSM only
                    bf00_resp[ar] = bf00_resp[ar] or pinfo.number
                end
            end
        end
    end
end

-- session_records._write_results / cyclic_axes.on_write_refused: a write the device answered with an error
-- wrote nothing: a 0xBF00 / 0xFFFF applied at its request is taken back, a parameter request is not pending
local function write_refusals(pinfo, req_frame)
    local dev = tostring(pinfo.dl_src)
    local function refuse(index)
        if index == nil or index == 0xBF00 or index == 0xFFFF then
            local bk = dev .. "|" .. tostring(req_frame)
            local old = bf00_before[bk]
            if old ~= nil then bf00_last[dev] = old or nil; bf00_before[bk] = nil end
            for _, ax in ipairs(axis_list) do
                if (ax.info.device_mac or "") == dev then note(ax.checker:write_refused(req_frame), pinfo.number) end
            end
        end
        if index == nil or index == 0xB02E or index == 0xB02F then
            for k, v in pairs(pairer) do
                if v.frame == req_frame then   -- ParamPairer.refused: a request it overwrote is pending again
                    pairer[k] = v.overwrote
                    if v.overwrote then   -- the controller still wrote before reading the response (#76)
                        refused_early[k] = refused_early[k] or {}
                        table.insert(refused_early[k], req_frame)
                        local sup = superseded[k]
                        if sup and sup[#sup] == v.overwrote.frame then
                            sup[#sup] = nil
                            if #sup == 0 then superseded[k] = nil end
                        end
                    end
                end
            end
        end
    end
    local inner = false
    for _, b in ipairs(blocks()) do
        if b.type == 0x8008 and b.e - b.s >= 64 then
            local t, hs = b.tvb, b.s + 8   -- after block header and SeqNumber
            local index = t(hs + 26, 2):uint()
            if index ~= 0xE040 then
                inner = true
                if t(hs + 36, 4):uint() ~= 0 then refuse(index) end   -- PNIOStatus not OK
            end
        end
    end
    -- no result of its own (a MultipleWrite refused as a whole, an error without headers): the call's PNIOStatus
    local st = X["pn_io.error_code"]()
    if not inner and st ~= nil and st.value ~= 0 then refuse(nil) end
end

-- first pass of a non-cyclic frame: DCP identity and rules, Connects, records
-- stations.from_lldp with lldp._station: an LLDPDU with a PROFINET TLV names its sender, from a locally
-- assigned port ID "port-xxx.<NameOfStation>" (the older style) or else a locally assigned chassis ID
local function on_lldp(pinfo)
    local cs = X["lldp.chassis.subtype"]()
    if cs == nil or X["lldp.profinet.subtype"]() == nil then return end
    local ps, pid, cid = X["lldp.port.subtype"](), X["lldp.port.id"](), X["lldp.chassis.id"]()
    local name
    if ps and ps.value == 7 and pid then
        local id = pid.range:raw()   -- the wire bytes: tshark 4.0 shows a chassis ID as bytes, a port ID as text
        local dot = id:find(".", 1, true)
        if dot then name = id:sub(dot + 1) end
    end
    if name == nil and cs.value == 7 and cid and cid.len > 0 then name = cid.range:raw() end
    if name ~= nil then dcp_state.station[tostring(pinfo.dl_src)] = name end
end

local function first_pass(pinfo)
    local op = X["pn_io.opnum"]()
    if op == nil then
        local dev = tostring(pinfo.dl_src)
        local v = X["pn_dcp.suboption_vendor_id"]()
        local dv = X["pn_dcp.suboption_device_devicevendorvalue"]()
        if (v or dv) and not im0_seen[dev] then   -- (stations.update: each field kept until a frame brings it again)
            local f = facts[dev] or {}
            facts[dev] = f
            local old = f.dcp or {}
            f.dcp = {v and v.value or old[1], dv and dv.value or old[2]}
            -- session_records.identity_changed: a profile decided before this identity is decided again
            if f.dcp[1] ~= old[1] or f.dcp[2] ~= old[2] then profiles[dev] = nil end
        end
        on_dcp(pinfo)
        on_lldp(pinfo)
        rta_error(pinfo)
        rta_alarm(pinfo)
        return nil
    end
    local items
    local pt = X["dcerpc.pkt_type"]()
    local act, seq = X["dcerpc.dg_act_id"](), X["dcerpc.dg_seqnum"]()
    local key = act and seq and (tostring(act) .. "|" .. tostring(seq.value))
    local req_frame   -- a response's request, when the capture holds it
    if pt and key then   -- a request or response again: a retransmission or a copy, run once (session.py _cm)
        local done = answered[key]
        -- a response with no request open, its key answered before: a copy (an act|seq reused later is no copy)
        if pt.value == 2 and open_req[key] == nil and done ~= nil and done ~= pinfo.number then return {} end
        local body = pt.value == 0 and rpc_body(seq) or nil
        -- session._cm: the same request again after its response (the client resends, the server answers
        -- from its cache): the call runs once; a new request reusing the act|seq differs and runs
        if body ~= nil and done ~= nil and open_req[key] == nil and answered_body[key] == body
            and tonumber(pinfo.abs_ts) - answered_at[key] <= 10 then return {} end   -- session.RESEND_WINDOW_NS
        if pt.value == 0 and op.value == 3 then wrote[key] = true end   -- session_records: pending_writes
        if pt.value == 0 then
            local first = open_req[key]
            if first ~= nil and first ~= pinfo.number then return {} end
            open_req[key] = pinfo.number
            req_body[key] = body
        elseif pt.value == 2 then
            req_frame = open_req[key]
            answered_body[key] = open_req[key] ~= nil and req_body[key] or nil
            open_req[key], req_body[key] = nil, nil
            answered[key] = pinfo.number
            answered_at[key] = tonumber(pinfo.abs_ts)
        end
    end
    local ok, err = pcall(function()
        if op.value == 0 and pt and key then
            if pt.value == 0 then
                connect_request(key, pinfo)
                local early = pending_connects["orphan|" .. key]   -- its response came first (session.orphans)
                if early ~= nil then
                    pending_connects["orphan|" .. key], open_req[key] = nil, nil
                    connect_response(key, pinfo, early)
                end
            elseif pt.value == 2 then
                connect_response(key, pinfo)
            end
        end
        if pt then control(op.value, pt.value, pinfo.number) end
        items = record_items(pinfo, records_of_frame())
        if pt and pt.value == 2 and op.value == 3 and key and not wrote[key] then write_responses(pinfo) end
        if pt and pt.value == 2 and op.value == 3 and req_frame ~= nil then write_refusals(pinfo, req_frame) end
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
    return items
end

-- postdissector: every frame; the violations of the frame are added last
local rec_cache
function pndiss.dissector(tvb, pinfo, tree)
    if pinfo.visited and not finished then finish_all() end
    if not pinfo.visited then
        -- ReadInfo.order: the capture's forward time jumps (gaps._clock_jump), kept in the gap table
        local now, last = ts_ns(pinfo), gap_last_ts["*last"]
        if last ~= nil and now - last >= 500000000 then
            local j = gap_last_ts["*jumps"] or {}
            j[#j + 1] = {last, now}
            if #j > 256 then table.remove(j, 1) end
            gap_last_ts["*jumps"] = j
        end
        gap_last_ts["*last"] = now
        local dc = X["frame.drop_count"]()   -- epb_dropcount: the tool lost packets before this one (all ones: unknown)
        local nd = dc and dc.value
        if type(nd) == "userdata" then nd = nd:tonumber() end
        if nd and nd > 0 and nd < 1.8e19 then gap_last_ts["*drop"] = ts_ns(pinfo) end
    end
    if cyclic_frame ~= pinfo.number then   -- the heuristic handled cyclic data
        local items = rec_cache[pinfo.number]
        if items == nil and not pinfo.visited then
            -- a PROFINET frame (EtherType 0x8892, after one tag too) without a FrameID field: tshark -2's first
            -- pass builds no tree, so nothing is extracted -- say so (the heuristic says it for cyclic frames)
            if not blind and tvb:len() >= 20 then
                local et = tvb(12, 2):uint()
                if et == 0x8100 then et = tvb(16, 2):uint() end
                if et == 0x8892 and X["pn_rt.frame_id"]() == nil then blind = true end
            end
            items = first_pass(pinfo) or false
            rec_cache[pinfo.number] = items
        end
        if tree and items and #items > 0 then show_records(tree, tvb, items) end
    end
    info_rules(pinfo)
    if tree then
        add_rules(tree, tvb, pinfo)
        if blind and pinfo.visited then   -- an expert info needs an item to hang on
            tree:add(pndiss, tvb(0, 0), "PROFINET encoder: nothing decoded"):add_proto_expert_info(E.blind,
                "pndiss: the first pass had no protocol tree, so nothing was learnt "
                .. "(tshark -2 needs a display filter or field output: add -Y frame)")
        end
    end
end
register_postdissector(pndiss)

-- all per-capture state, new: Wireshark calls init before every (re)dissection of a file
local function reset_state()
    maps, map_cache, gen = {}, {}, {misses = {}, checked = {}, trim = {}}
    open_req = {}
    map_generation, cache_generation = 0, 0
    profiles, facts, ar_devs, p922_of, im0_seen = {}, {}, {}, {}, {}
    ar_keys, ar_phase, ar_order = {}, {}, {}
    pending_connects, pairer, superseded, refused_early = {}, {}, {}, {}
    axes, axis_list, dev_records, bf00_last, prev_bf00 = {}, {}, {}, {}, {}
    bf00_resp, answered, wrote = {}, {}, {}
    req_body, answered_body, bf00_before, answered_at, alarm_seq = {}, {}, {}, {}, {}
    gap_streams = {}
    gap_last_ts = {}
    infer_streams, infer_list = {}, {}
    viol, viol_seen, late, finished = {}, {}, {}, false
    dcp_state = {name_at = {}, ip_at = {}, mac_name = {}, mac_ip = {}, reported = {}, station = {}, identifies = {}}
    cyc_cache, rec_cache, cyclic_frame, blind = {}, {}, nil, false
end
function pndiss.init() reset_state() end

-- 9. the list of every violation: tshark -z pndiss,violations, Statistics > pndiss violations -------
-- A single pass cannot show on an earlier frame what a later one decided; this list is made at the
-- end of the pass (finish() run first), so it holds every violation pndiss analyze reports.
-- a message can quote the wire (a NameOfStation): control characters are shown, never obeyed
local function visible(s)
    return (tostring(s):gsub("%c", function(c) return string.format("\\x%02x", c:byte()) end))
end

local function violation_lines()
    if not finished then finish_all() end
    local rows = {}
    for _, l in pairs(viol) do for _, v in ipairs(l) do rows[#rows + 1] = v end end
    table.sort(rows, function(a, b)
        if a.frame ~= b.frame then return a.frame < b.frame end
        return a.rule < b.rule
    end)
    local out = {string.format("%-7s %-29s %-8s %-10s %-7s %s", "frame", "rule", "severity", "side",
        "decided", "message")}
    for _, v in ipairs(rows) do
        local r = T.rules[v.rule] or {}
        local at = v.decided == 0 and "end" or tostring(v.decided)
        out[#out + 1] = string.format("%-7d %-29s %-8s %-10s %-7s %s", v.frame, v.rule, r.severity or "",
            v.side or r.side or "", at, visible(v.message or r.section or ""))
    end
    return out, #rows
end

local function violations_text()
    local lines, n = violation_lines()
    local bar = string.rep("=", 72)
    local head = "pndiss violations: " .. n
    if settings.ignored then head = head .. "\nWARNING: Settings preference: ignored " .. settings.ignored end
    if blind then   -- tshark -2 builds no protocol tree for a tap on its first pass: nothing was decoded
        head = head .. "\nWARNING: the first pass had no protocol tree, so pndiss decoded nothing: add -Y frame"
            .. " (tshark -2 -q -z pndiss,violations -Y frame), or run without -2"
    end
    return table.concat({bar, head, bar, table.concat(lines, "\n"), bar}, "\n") .. "\n"
end

-- tshark -z pndiss,violations: a tap with a filter makes tshark build the protocol tree the field
-- extractors need; draw runs once at the end of the file
register_stat_cmd_arg("pndiss,violations", function()
    local tap = Listener.new(nil, "frame")
    function tap.draw() io.write(violations_text()) end
end)

-- Wireshark: Statistics > pndiss violations (the "unsorted" group: Wireshark 4.0 shows no Lua item
-- of the generic one); retapping redissects every frame after the load, so finish() sees the file
if gui_enabled() then
    register_menu("pndiss violations", function()
        local tw = TextWindow.new("pndiss violations")
        local tap = Listener.new(nil, "frame")
        tw:set_atclose(function() tap:remove() end)
        function tap.draw() tw:set(violations_text()) end
        retap_packets()
    end, MENU_STAT_UNSORTED)
end

reset_state()
parse_usermap(pndiss.prefs.map)
parse_settings(pndiss.prefs.settings)
