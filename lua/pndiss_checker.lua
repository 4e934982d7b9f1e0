-- pndiss_checker.lua: the reference encoder's checker (pndiss/encoder: config.py, position.py,
-- _state.py, acyclic.py) ported line by line to plain Lua 5.2, sans-IO. No Wireshark API: it runs
-- in lua5.2 (tests/test_lua_checker.py replays the Python checker's calls through it and demands
-- the same violations) and inside Wireshark, where lua/pndiss.lua feeds it.
--
-- Loading this file has no side effect: it only builds and returns the module table (Wireshark
-- runs every .lua of its plugin folder; that run defines nothing global).
--
-- API (the names of pndiss/encoder; Python attributes are plain fields here):
--   local C = dofile(dir .. "pndiss_checker.lua"); C.init(T)      -- T = pndiss_tables.lua (needs T.checker)
--   local cfg = C.config_from_settings(settings, {profile=, telegram=, bf00=, cycle_ns=, iso=,
--                                                 profile_reason=, telegram_source=})
--       EncoderConfig.from_settings; settings = a table of the Settings fields it reads (l_max,
--       preset_deadline_ms, sol_threshold_ge, sol_monitor_rt, master_cycle_ratio, st_phys, mt_phys,
--       xist1_shift, max_position_step, compat, class4, iso, p65000; nil = unset). cfg is a plain table with
--       the EncoderConfig fields (cfg.profile, cfg.telegram, cfg.sources, ...); C.new_config(profile,
--       telegram) gives the dataclass defaults. Properties are functions of cfg: C.std (= C.is_std),
--       C.xist1_preset_affected, C.xist1_counter, C.solmon, C.modulus, C.n_sol, C.d_preset,
--       C.store_cycles, C.defaults.
--   local chk = C.new(cfg, info)                  -- info = {station=, device_mac=, api=, slot=, subslot=}
--   chk:cycle(frame, ts, sp, ac, sp_frame)        -- sp / ac: signal name -> number (signed signals negative)
--   chk:gap(frame, ts, reason)
--   chk:lost(frame, ts, cycles)
--   chk:on_record(ev)                             -- ev shaped like the Python record/param event dict:
--                                                    same keys, lists 1-based, None = nil, record data
--                                                    as a hex string (as in the Python event)
--   chk:finish()
--   chk:apply_cfg(), chk:flush_all(), chk:reset_history()   (also as _apply_cfg, _flush_all, _reset_history)
--   fields: chk.cfg, chk.io_len (direction -> length), chk.prev_bf00, chk.p922_rejected, chk.bf00_seen,
--           chk.counts (rule -> {events=, cycles=, first_frame=, severity=, side=, message=}), chk.n
--
-- Every call returns a list of events {rule=, frame=, last_frame=, cycles=, message=, side=,
-- severity=, ts_ns=, + the info fields}, like pndiss.rules.violation. Treat it as read-only: calls
-- without events share one empty list. When a per-cycle rule OPENS a run, {rule=, frame=, open=true}
-- is pushed at once (the run's first frame is final then); the run's normal event follows when it
-- ends, with the same frame. flush_all() returns the events of the runs it closes; Python's
-- _flush_all appends them to the previous call's list, which nobody reads, so a caller that must
-- report exactly what Python reports drops them (their counts stay, as in Python).
-- The identical-input fast path (_state.py Checker.cycle: same sp and ac objects as the last cycle) needs the
-- caller to pass the same tables when the data did not change; fresh tables are always correct.
-- Timeline 'state' events of the Python checker are not produced (no rule reads them).
--
-- Numbers: Lua 5.2 has doubles only. Every value below 2^53 is exact, as in Python. 64-bit signals
-- (g1_xist3, g1_xist_preset_c) above 2^53 arrive as {hi=, lo=}: the preset trigger bit 63 is read
-- exactly from hi; the position/preset VALUE is then hi * 2^32 + lo rounded to a double (to a
-- multiple of 2^(e-52)). Modulo arithmetic reduces each operand first (fmod is exact), so results
-- equal Python's whenever the values themselves are doubles, e.g. positions above 2^53 that are
-- multiples of their ulp (the tests use 2^60 + k * 256) and any modulus R < 2^53. Inexact, where
-- Python is exact: positions/preset values >= 2^53 that a double cannot hold (rounded on arrival),
-- a difference of two such positions modulo 2^64 (#44 NIST sign, #33 with no R), and 0xBF00
-- MUPR/TMR >= 2^53. No encoder in the spec or the captures gets near 2^53.
local C = {}

local bit = bit32 or bit
local band, bor, rshift, lshift = bit.band, bit.bor, bit.rshift, bit.lshift
if not bit32 then
  -- LuaBitOp returns signed 32-bit results: fold them back to 0..2^32-1 like bit32.
  local b0, s0, l0 = band, rshift, lshift
  local function u(x) if x < 0 then return x + 4294967296 end return x end
  band = function(a, b) return u(b0(a, b)) end
  rshift = function(a, n) return u(s0(a, n)) end
  lshift = function(a, n) return u(l0(a, n)) end
end
local floor, ceil, abs, fmod = math.floor, math.ceil, math.abs, math.fmod
local fmt, find, lower = string.format, string.find, string.lower

local U32 = 4294967296
local U64 = 18446744073709551616
local T, K                        -- generated tables (C.init), T.checker
local EMPTY = setmetatable({}, {__newindex = function() error("pndiss_checker: returned event lists are read-only") end})
local NONE = false                -- None inside the position history

-- ------------------------------------------------------------------------------ small helpers
-- Python truthiness for values that may be nil, booleans, numbers, strings or tables.
local function truthy(v)
  if v == nil or v == false or v == 0 or v == "" then return false end
  if type(v) == "table" then return next(v) ~= nil end
  return true
end

local function isint(v) return type(v) == "number" and v == floor(v) and v == v end

-- Python int(v): settings may arrive as strings (--set), booleans or numbers.
local function toint(v)
  if v == true then return 1 elseif v == false then return 0 end
  local n = tonumber(v)
  if n == nil then error("pndiss_checker: not an integer: " .. tostring(v)) end
  if n >= 0 then return floor(n) end
  return ceil(n)
end

-- a 64-bit value: a number, or {hi=, lo=} above 2^53 (see the header)
local function num(v)
  if type(v) == "table" then return v.hi * U32 + v.lo end
  return v
end

-- Python's a % m (result in [0, m)): fmod is exact for every double, so this is exact whenever
-- a is (any size) and m < 2^53.
local function mod(a, m)
  local r = fmod(a, m)
  if r < 0 then r = r + m end
  return r
end

-- position.delta: signed shortest difference b - a modulo m. Each operand is reduced first (exact),
-- so b - a is never formed from two large numbers, and m + small numbers never from m = 2^64.
local function delta(a, b, m)
  local r
  if a >= 0 and b >= 0 and a < m and b < m then
    r = b - a                                   -- the usual case: both already reduced
  else
    r = fmod(fmod(b, m) - fmod(a, m), m)        -- in (-m, m), congruent to b - a
  end
  local half = (m - m % 2) / 2      -- m // 2 (m is an integer, or 2^64)
  if r < 0 then
    -- Python: d = r + m, then d - m (= r) when d > m // 2, else d
    if r > half - m then return r end
    return r + m
  end
  if r > half then return r - m end
  return r
end

local function next_ls(v) return (v % 15) + 1 end

local function expected_after_preset(mode, P, pos_before, R)
  local m = R or U32
  if mode == 0 then return mod(P, m) end
  return mod(mod(pos_before, m) + mod(P, m), m)   -- (pos_before + P) % m without a large sum
end

-- position.fits_binary_range: an unscaled encoder of unknown range wraps at 2^k, k >= MIN_RANGE_BITS
-- bits and above every position seen ([INFERENCE] binary single-/multi-turn counts)
local MIN_RANGE_BITS = 12
local function fits_binary_range(actual, exp, a, b, tol)
  local top, lo = math.max(a, b), 0
  while top >= 1 do top = math.floor(top / 2); lo = lo + 1 end
  for k = math.max(MIN_RANGE_BITS, lo), 31 do
    local m = 2 ^ k
    if math.abs(delta(mod(exp, m), actual, m)) <= tol then return true end
  end
  return false
end

local function preset_860(PV, R)
  if R then return math.min(PV, R - 1) end
  return PV
end

local function b2i(v) if v then return 1 end return 0 end

C.delta, C.mod, C.next_ls = delta, mod, next_ls

-- ------------------------------------------------------------------------------ configuration
function C.init(tables)
  T = tables
  K = tables.checker
  assert(K, "pndiss_tables.lua has no 'checker' table: regenerate it with tools/gen_lua.py")
  return C
end

local function defaults(c)
  return T.profile_defaults[c.profile] or T.profile_defaults.generic
end
C.defaults = defaults

-- STD: telegram with STW2_ENC/ZSW2_ENC (81-84; PS/PSM 89) (behaviour.md §9 preamble)
function C.std(c) return K.control_words[c.telegram] == true end  -- STW2_ENC/ZSW2_ENC present (telegram table)
C.is_std = C.std

-- Does a preset move G1_XIST1? Class 4 on and the vendor's 'enabled' coding (§7 D14)
function C.xist1_preset_affected(c)
  local d = defaults(c)
  local pc = c.preset_control
  if pc == nil then pc = d.preset_control end
  return truthy(c.class4) and pc == d.preset_control_affects_xist1
end

-- SCANCON/HOHNER profile 4.1: XIST1 is a wrapping 32-bit counter (behaviour.md §1.6 R-X1-3)
function C.xist1_counter(c) return defaults(c).xist1_counter and not truthy(c.shift) end

-- SOLMON = STD and iso and (not SCANCON or compat = 1); settings.sol_monitor_rt drops iso (§9)
function C.solmon(c)
  return C.std(c) and (truthy(c.iso) or truthy(c.sol_monitor_rt)) and (c.profile ~= "scancon" or c.compat == 1)
end

-- R: TMR with class 4 and scaling on, else ST_phys x MT_phys (behaviour.md §4.1 [INFERENCE])
function C.modulus(c)
  if truthy(c.class4) and truthy(c.scaling) and truthy(c.tmr) then return c.tmr end
  if truthy(c.st_phys) and truthy(c.mt_phys) then return c.st_phys * c.mt_phys end
  return nil
end

-- N tolerated master sign-of-life failures: byte 17 in V3.1 mode, 1 in V4.1 (§3.3 R-SOLC-3)
function C.n_sol(c)
  if c.compat == 0 then return c.max_master_sol_failures end
  if truthy(c.p925) then return c.p925 end   -- P925 seen (written or read): V4.1's optional control
  return 1
end

-- D_preset = ceil(10 ms / T_cycle) + L_max; T_cycle 1 ms when unknown (behaviour.md §0.1)
function C.d_preset(c)
  local t = c.cycle_ns
  if not truthy(t) then t = 1000000 end
  return ceil(c.preset_deadline_ms * 1e6 / t) + c.l_max
end

-- Cycles in 10 ms: the longest allowed position gap after a preset (§9.5 #43)
function C.store_cycles(c)
  local t = c.cycle_ns
  if not truthy(t) then t = 1000000 end
  return math.max(1, ceil(10e6 / t))
end

-- EncoderConfig.velocity_lag_cycles: two velocity intervals + L_max; 0 when NIST is computed every cycle (#44)
function C.velocity_lag_cycles(c)
  local u = defaults(c).velocity_update_ms or 0
  local f = defaults(c).velocity_filter_cycles or 0   -- a default filter's lag (SCANCON/Hohner 'Fine' 7:3)
  if u == 0 then return f end   -- (NIST and the position travel in one frame: no controller latency)
  local t = c.cycle_ns
  if not truthy(t) then t = 1000000 end
  return ceil(2 * u * 1e6 / t) + c.l_max + f
end

local DEFAULT_SOURCE = "default (telegrams.json profile_defaults)"   -- a profile default, nothing captured or given

-- EncoderConfig.compat_open: the compatibility mode neither captured (0xBF00) nor given (--set compat)
function C.compat_open(c)
  local s = c.sources and c.sources.compat or ""
  return s:sub(-#DEFAULT_SOURCE) == DEFAULT_SOURCE
end

-- EncoderConfig.class4_open / preset_control_open: a vendor default only (no 0xBF00, no --set): not judged on
function C.class4_open(c)
  local s = c.sources and c.sources.class4 or ""
  return s:sub(-#DEFAULT_SOURCE) == DEFAULT_SOURCE
end
function C.preset_control_open(c)
  local s = c.sources and c.sources.preset_control or ""
  return s:sub(-#DEFAULT_SOURCE) == DEFAULT_SOURCE
end

-- EncoderConfig field defaults (config.py); nil = None
local function new_config(profile, telegram)
  return {profile = profile, telegram = telegram, compat = 1, class4 = 1, preset_control = nil, scaling = 0,
          direction = 0, mupr = nil, tmr = nil, st_phys = nil, mt_phys = nil, max_master_sol_failures = 1,
          velocity_unit = 0, shift = nil, iso = false, k = 1, l_max = 2, preset_deadline_ms = 10.0,
          cycle_ns = nil, sol_threshold_ge = false, sol_monitor_rt = false, max_position_step = nil, p65000 = nil,
          p925 = nil, sources = {}}
end
C.new_config = new_config

local SETTINGS_MAP = {{"l_max", "l_max"}, {"preset_deadline_ms", "preset_deadline_ms"},
  {"sol_threshold_ge", "sol_threshold_ge"}, {"sol_monitor_rt", "sol_monitor_rt"}, {"master_cycle_ratio", "k"},
  {"st_phys", "st_phys"}, {"mt_phys", "mt_phys"}, {"xist1_shift", "shift"}, {"max_position_step", "max_position_step"},
  {"compat", "compat"}, {"class4", "class4"}, {"p65000", "p65000"}}
local NOT_INT = {sol_threshold_ge = true, sol_monitor_rt = true, preset_deadline_ms = true}
local BF00_MAP = {{"compat", "compat"}, {"class4", "class4"}, {"preset_control", "preset_control"},
  {"scaling", "scaling"}, {"direction", "direction"}, {"code_sequence", "direction"}, {"mupr", "mupr"},
  {"tmr", "tmr"}, {"max_master_sol_failures", "max_master_sol_failures"}, {"velocity_unit", "velocity_unit"}}

-- EncoderConfig.from_settings: kw = {profile=, telegram=, bf00=, cycle_ns=, iso=, profile_reason=, telegram_source=}
function C.config_from_settings(s, kw)
  kw = kw or {}
  local profile = kw.profile or "generic"
  local c = new_config(T.profile_defaults[profile] and profile or "generic", kw.telegram or 81)
  local src = c.sources
  src.profile = kw.profile_reason or "given"
  src.telegram = kw.telegram_source or "given"
  local d = defaults(c)
  for _, name in ipairs({"class4", "preset_control", "scaling", "compat"}) do
    c[name] = d[name]
    src[name] = c.profile .. " " .. DEFAULT_SOURCE
  end
  if s ~= nil then
    for _, m in ipairs(SETTINGS_MAP) do
      local v = s[m[1]]
      if v ~= nil then
        if not NOT_INT[m[2]] then v = toint(v) end  -- --set delivers strings for fields whose default is None
        c[m[2]] = v
        src[m[2]] = "settings." .. m[1]
      end
    end
  end
  local bf00 = kw.bf00
  if truthy(bf00) then  -- the captured 0xBF00 wins over settings and defaults (behaviour.md §0.3)
    for _, m in ipairs(BF00_MAP) do
      if bf00[m[1]] ~= nil then
        c[m[2]] = toint(bf00[m[1]])
        src[m[2]] = "captured 0xBF00"
      end
    end
  end
  if kw.iso ~= nil then
    c.iso = truthy(kw.iso)
    src.iso = "capture (IOCR RT class)"
  end
  if s ~= nil and s.iso ~= nil then
    c.iso = truthy(s.iso)
    src.iso = "settings.iso"
  end
  if truthy(kw.cycle_ns) then
    c.cycle_ns = kw.cycle_ns
    src.cycle_ns = kw.cycle_source or "Connect (SendClockFactor x ReductionRatio)"
  end
  return c
end

-- ------------------------------------------------------------------------------ the checker
local Checker = {}
Checker.__index = Checker
local flush_all                   -- close every open run (defined with the violations below)
C.Checker = Checker

function C.new(cfg, info)
  local self = setmetatable({}, Checker)
  self.cfg = cfg
  self.info = info or {}
  self.n = 0                      -- judged cycles so far
  self.f, self.fc = 0, 0          -- frame of the actual value / of the setpoint
  self.last_fc = nil              -- setpoint frame of the previous judged cycle
  self.sp_new = true              -- this cycle's setpoint frame was not judged before
  self.sp_before = nil            -- the controller's setpoint frame before this one (RT drift)
  self.ts = 0
  self.out = nil                  -- events of the current call (created on the first one)
  self.open = {}                  -- coalescing runs of per-cycle conditions: rule -> run
  self.open_order = {}            -- their rules in opening order (Python dict order)
  self.counts = {}                -- rule -> {events=, cycles=, first_frame=, severity=, side=, message=}
  self.gated = 0
  self.lost_cycles = 0            -- cycles missing from the capture (not judged)
  self.sol_known_at = 0           -- cycle from which the failure counter C is known again after a loss (#10)
  self:reset_history()
  -- acyclic knowledge (behaviour.md §2.0: state carried from cycle to cycle)
  -- last written preset value; until a write is seen, settings.p65000 (nil = unknown, _state.py)
  self.p65000 = self.cfg.p65000
  self.presets_unjudged = 0       -- presets acknowledged while P65000 was unknown (not judged)
  self.velocity_filter = nil      -- frame of a SCANCON velocity filter write (0x1000): NIST-SIGN not judged
  self.bf00_seen = false
  self.bf00_invalid = nil         -- why the last 0xBF00 was invalid (#67-69)
  self.bf00_valid_frame = nil
  self.params_changed = false     -- dir/MUPR/TMR differ from the previous connection (#31)
  self.preset_done = false
  self.first_frame = nil
  self.shift_known = cfg.shift ~= nil
  self.bf00_due = nil             -- {cycle, why}: an invalid 0xBF00 must show 0x1002 (#70)
  self.prev_bf00 = nil            -- the device's 0xBF00 of the previous connection (#31)
  self.p971_pending = nil         -- {frame, reads that still returned 1, ts} after P971 := 1 (#90)
  self.p980 = nil                 -- set of PNUs the device lists in P980 (#88)
  self.last_req_ref = {}   -- AR UUID -> its last request reference (#78)
  self.io_len = {}                -- data object length per direction, for P922 plausibility (#65)
  self.p922_rejected = nil
  self:apply_cfg()
  return self
end

function Checker:apply_cfg()
  local c = self.cfg
  self.std = C.std(c)
  self.solmon = C.solmon(c)
  self.R = C.modulus(c)
  self.L = c.l_max
  self.D = C.d_preset(c)
  -- a run of NIST-SIGN must outlast a correct device's velocity lag (value_rules.active_value_rules)
  self.nist_run = math.max(K.registry["NIST-SIGN"].min_run, C.velocity_lag_cycles(c) + 1)
  self.lika = c.profile == "lika"
  self.psm = c.profile == "psm"
  local creq = K.creq_bit[self.psm and "psm" or "generic"]
  if self.creq_bit ~= nil and self.creq_bit ~= creq and c.sources.compat ~= nil
      and c.sources.compat:sub(1, 21) == "learnt from the words" then
    -- learnt at the other bit (a PS/PSM device judged generic until its 0xFFFF showed it): learn again
    c.compat = defaults(c).compat
    c.sources.compat = c.profile .. " " .. DEFAULT_SOURCE
  end
  self.creq_bit = creq
  self.compat_open = C.compat_open(c)   -- the mode is learnt from the words (learn_compat)
  local rm = K.reserved_masks
  self.res_stw2 = rm.stw2_enc[c.profile] or rm.stw2_enc.generic
  self.res_g1stw = rm.g1_stw[c.profile] or rm.g1_stw.generic
  self.res_zsw2 = rm.zsw2_enc[c.profile] or rm.zsw2_enc.generic
  self.res_g1zsw = rm.g1_zsw[c.profile] or rm.g1_zsw.generic
  self.sol_limit = 10 * C.n_sol(c)  -- fault at C > 10N (or >= with sol_threshold_ge), §3.3 R-SOLC-3
end
Checker._apply_cfg = Checker.apply_cfg

-- Forget the previous cycle (after a gap in judged data): no edges across a gap.
function Checker:reset_history()
  self.prev_sp, self.prev_ac = nil, nil
  local cap = self.cfg.l_max + 1
  -- W(n,-L_max,0): ring buffers of (CTRL, PREQ, AREQ, PARK, SACK, VALID, PKA, SERR) per cycle
  self.h_cap, self.h_n, self.h_head = cap, 0, 0
  self.hCTRL, self.hPREQ, self.hAREQ, self.hPARK, self.hSACK, self.hVALID, self.hPKA, self.hSERR = {}, {}, {}, {}, {}, {}, {}, {}
  self.ph_n, self.ph1, self.ph2, self.ph3 = 0, NONE, NONE, NONE   -- X1 / position of W(n,-2,0), oldest first
  self.cls_run = 0
  self.cls_runs_done = 0
  self.C = 0                      -- master sign-of-life failure counter (§3.3)
  self.Ch, self.Ch_n, self.Ch_head = {}, 0, 0
  self.started_C, self.started_D = false, false
  self.pre = nil                  -- pending preset handshake (§2.4)
  self.pdone_since = nil          -- cycle PDONE rose (for #24)
  self.pdone_clear_due = nil
  self.p860 = nil
  self.p89 = nil
  self.sack_edge = nil            -- {n, frame, ts} of rise(SACK) with SERR = 1 (#52)
  self.sack_since_serr = false
  self.fack_since_serr = false
  self.serr_code = nil
  self.ackip_since = nil
  self.restore_due = nil
  self.park_rise_due = nil
  self.solf_due = nil
  self.sol_fault_seen = false
  self.nist_bad = 0
  self.store = nil                -- store window after a preset trigger (#43)
  self.same = 0
  self.key_ok = false             -- control/status words without the sign-of-life nibbles
  self.k1, self.k2, self.k3, self.k4 = 0, 0, 0, 0
  self.steady_n = 0
end
Checker._reset_history = Checker.reset_history

-- A cycle that is reported, not judged (provider STOP, DataValid = 0, IOPS bad).
-- No judged cycle joins the next one: open runs end, the edge history starts afresh (_state.py _break).
local function break_history(self)
  self.out = nil
  if self.prev_ac ~= nil or self.open_order[1] ~= nil then
    flush_all(self)
    self:reset_history()
  end
  return self.out or EMPTY
end

function Checker:gap(frame, ts, reason)
  self.gated = self.gated + 1
  return break_history(self)
end

-- `cycles` cycles missing from the capture before `frame` (capture loss, pndiss/gaps.py): they count
-- as elapsed (n moves on) but are not judged; no edge, window or pending handshake reaches across them.
function Checker:lost(frame, ts, cycles)
  self.lost_cycles = self.lost_cycles + cycles
  self.n = self.n + cycles
  local out = break_history(self)
  -- C started afresh is a lower bound until a counter at the threshold would have counted down (#10)
  self.sol_known_at = self.n + self.sol_limit + 10
  return out
end

-- ------------------------------------------------------------------------------ violations
local function push(self, ev)
  local out = self.out
  if out == nil then out = {}; self.out = out end
  out[#out + 1] = ev
end

function Checker:emit(rule, frame, ts, msg, last, side, cycles)
  cycles = cycles or 1
  local r = T.rules[rule]
  local s = side or r.side
  local ev = {rule = rule, frame = frame, ts_ns = ts, last_frame = last or frame, cycles = cycles, message = msg,
              side = s, severity = r.severity}
  for k, v in pairs(self.info) do if ev[k] == nil then ev[k] = v end end
  local c = self.counts[rule]
  if c == nil then
    self.counts[rule] = {events = 1, cycles = cycles, first_frame = frame, severity = r.severity, side = s, message = msg}
  else
    c.events = c.events + 1
    c.cycles = c.cycles + cycles
  end
  push(self, ev)
end

function Checker:flush(rule)
  local o = self.open[rule]
  self.open[rule] = nil
  local order = self.open_order
  for i = 1, #order do
    if order[i] == rule then table.remove(order, i); break end
  end
  self:emit(rule, o.first, o.ts, o.msg, o.last, o.side, o.cycles)
end

flush_all = function(self)
  while self.open_order[1] ~= nil do self:flush(self.open_order[1]) end
end

-- From outside (cyclic.py _relabel): close every open run; returns their events. (Python's
-- _flush_all appends them to the list of the previous call, which nobody reads any more.)
function Checker:flush_all()
  self.out = nil
  flush_all(self)
  return self.out or EMPTY
end
Checker._flush_all = Checker.flush_all

-- The condition of a per-cycle rule holds in this cycle: open or extend its run. Returns the new
-- run when it opened (the caller sets .msg: messages are formatted once per run, not per cycle).
function Checker:hit(rule, controller, side)
  local o = self.open[rule]
  local f = controller and self.fc or self.f
  if o ~= nil then
    if o.n == self.n - 1 then
      o.n = self.n
      o.last = f
      o.cycles = o.cycles + 1
      return nil
    end
    self:flush(rule)
  end
  o = {n = self.n, first = f, ts = self.ts, last = f, cycles = 1, msg = rule, side = side}
  self.open[rule] = o
  self.open_order[#self.open_order + 1] = rule
  push(self, {rule = rule, frame = f, open = true, run = o})   -- (run: its message, once the caller set it)
  return o
end

-- ------------------------------------------------------------------------------ histories
local function hist_push(self, CTRL, PREQ, AREQ, PARK, SACK, VALID, PKA, SERR)
  local i = self.h_head % self.h_cap + 1
  self.h_head = i
  self.hCTRL[i], self.hPREQ[i], self.hAREQ[i], self.hPARK[i] = CTRL, PREQ, AREQ, PARK
  self.hSACK[i], self.hVALID[i], self.hPKA[i], self.hSERR[i] = SACK, VALID, PKA, SERR
  if self.h_n < self.h_cap then self.h_n = self.h_n + 1 end
end

-- all(h[field] == v for h in H)
local function h_all(self, arr, v)
  for i = 1, self.h_n do if arr[i] ~= v then return false end end
  return true
end

-- Checker._learn_compat (words.py): the compatibility mode from the words while nothing captured or given says it
function Checker:learn_compat(full, CTRL, CREQ, executed)
  local mode, why
  if CREQ == 1 then
    mode, why = 1, "control requested set"
  elseif full and h_all(self, self.hCTRL, 1) then
    mode, why = 0, fmt("control requested held 0 while control by PLC was 1 for %d cycles", self.L + 1)
  elseif full and executed and h_all(self, self.hCTRL, 0) then
    mode, why = 0, "a command acknowledged while control by PLC was 0"
  else
    return
  end
  self.cfg.compat = mode
  self.cfg.sources.compat = fmt("learnt from the words (frame %s: %s)", tostring(self.f), why)
  self:apply_cfg()
end

-- The "status bit follows control bit within L_max" rows of one group (registry.py FOLLOWS, generated into
-- K.follows): the status bit still shows row.is although every cycle of the full window met row.window.
local function follows(self, group, status, value)
  local rows = K.follows[group]
  for r = 1, #rows do
    local row = rows[r]
    if row.status == status and value == row.is then
      local ok = true
      for field, want in pairs(row.window) do
        local h = self["h" .. field]
        for i = 1, self.h_n do
          local x = h[i]
          if (x == true or x == 1) ~= (want == 1) then ok = false; break end
        end
        if not ok then break end
      end
      if ok then
        local o = self:hit(row.rule)
        if o then o.msg = (row.message:gsub("{n}", tostring(self.L + 1))) end
      end
    end
  end
end

local function pos_push(self, v)
  if v == nil then v = NONE end
  self.ph1, self.ph2, self.ph3 = self.ph2, self.ph3, v
  if self.ph_n < 3 then self.ph_n = self.ph_n + 1 end
  -- with fewer than 3 entries the oldest slots hold NONE and are skipped by ph_n
end

-- len(set(pos_hist)) <= 1
local function pos_still(self)
  local n = self.ph_n
  if n <= 1 then return true end
  if n == 2 then return self.ph2 == self.ph3 end
  return self.ph1 == self.ph2 and self.ph2 == self.ph3
end

local function pos_list(self)
  local out, n = {}, self.ph_n
  local all = {self.ph1, self.ph2, self.ph3}
  for i = 4 - n, 3 do
    local v = all[i]
    out[#out + 1] = v == NONE and "None" or tostring(v)
  end
  return "[" .. table.concat(out, ", ") .. "]"
end

-- Largest position step of W(n-3, n-1): the motion tolerance per cycle (§4.3 [INFERENCE]).
function Checker:speed()
  local m = self.R or U32
  local best, prev = 0, nil
  local n = self.ph_n
  for i = 4 - n, 3 do
    local v
    if i == 1 then v = self.ph1 elseif i == 2 then v = self.ph2 else v = self.ph3 end
    if v ~= NONE then
      if prev ~= nil then
        local d = abs(delta(prev, v, m))
        if d > best then best = d end
      end
      prev = v
    end
  end
  return best
end

local function ch_push(self, v)
  local cap = self.h_cap
  local i = self.Ch_head % cap + 1
  self.Ch_head = i
  self.Ch[i] = v
  if self.Ch_n < cap then self.Ch_n = self.Ch_n + 1 end
end

-- ------------------------------------------------------------------------------ one cycle
-- A deadline rule is running (the registry's deadlines, pndiss/encoder/registry.py DEADLINES via the
-- generated tables): a state that is set, or for open_when entries set with one of those keys true
-- (a preset request already reported as unanswered (#19) and still held is inert in steady cycles).
function Checker:pending_steady()
  local dl = K.deadlines
  for i = 1, #dl do
    local d = dl[i]
    local v = self[d.state]
    if v ~= nil then
      local keys = d.open_when
      if keys == nil then return true end
      for j = 1, #keys do
        if v[keys[j]] then return true end
      end
    end
  end
  return false
end

function Checker:pending()
  return self.solmon or self:pending_steady()
end

-- Judge one cycle: setpoint sp and actual value ac (signal tables) of the same cycle.
function Checker:cycle(frame, ts, sp, ac, sp_frame, sp_before)
  self.out = nil
  self.f, self.ts = frame, ts
  self.fc = sp_frame == nil and frame or sp_frame
  -- RT: the controller's sign-of-life is judged on its own stream (Checker.cycle in _state.py)
  self.sp_new = self.fc ~= self.last_fc
  self.last_fc = self.fc
  self.sp_before = sp_before
  if self.first_frame == nil then self.first_frame = frame end
  local same_in = sp == self.prev_sp and ac == self.prev_ac
  -- Fast path: identical inputs, nothing pending, history saturated -> nothing can change.
  if same_in and self.open_order[1] == nil and self.same > self.L + 1 and not self:pending() then
    self.n = self.n + 1
    return EMPTY
  end
  self.same = same_in and self.same + 1 or 0
  self.n = self.n + 1
  if self.std then
    local k1, k2 = (sp.stw2_enc or 0) % 4096, sp.g1_stw or 0
    local k3, k4 = (ac.zsw2_enc or 0) % 4096, ac.g1_zsw or 0
    local same_key = self.key_ok and k1 == self.k1 and k2 == self.k2 and k3 == self.k3 and k4 == self.k4
    if same_key and self.steady_n > self.L + 1 and self.open_order[1] == nil and not self:pending_steady() then
      self:cycle_steady(sp, ac)
    else
      self.steady_n = same_key and self.steady_n + 1 or 0
      self:cycle_std(sp, ac)
    end
    self.key_ok, self.k1, self.k2, self.k3, self.k4 = true, k1, k2, k3, k4
  elseif K.preset_words[self.cfg.telegram] then
    self:cycle_preset_telegram(sp, ac)
  end
  if self.open_order[1] ~= nil then
    local n, order, open = self.n, self.open_order, self.open
    local i = 1
    while order[i] ~= nil do
      local rule = order[i]
      if open[rule].n < n then self:flush(rule) else i = i + 1 end
    end
  end
  self.prev_sp, self.prev_ac = sp, ac
  return self.out or EMPTY
end

-- rise(cur, prev) / fall(cur, prev) of _state.py are written out below as
-- (cur == 1 and prev == 0) / (cur == 0 and prev == 1): no call per edge test
-- bit b of a non-negative integer word as plain arithmetic (VM operations, no library calls:
-- these run several times per frame); w >> 12 of a 16-bit word is written (w - w % 4096) / 4096
local P2 = {}
for b = 0, 31 do P2[b] = 2 ^ b end
local function bitof(w, b)
  local p = P2[b]
  if w % (p + p) >= p then return 1 end
  return 0
end

function Checker:cycle_std(sp, ac)
  local c, n, L = self.cfg, self.n, self.L
  local stw2 = sp.stw2_enc or 0
  local g1stw = sp.g1_stw or 0
  local zsw2 = ac.zsw2_enc or 0
  local g1zsw = ac.g1_zsw or 0
  local has_g1 = sp.g1_stw ~= nil and ac.g1_zsw ~= nil
  -- bits 10-15 of the 16-bit words written out as arithmetic (this runs for every non-steady frame)
  local CLS, CTRL = (stw2 - stw2 % 4096) / 4096, stw2 % 2048 >= 1024 and 1 or 0
  local HMODE, PREQ = g1stw % 4096 >= 2048 and 1 or 0, g1stw % 8192 >= 4096 and 1 or 0
  local AREQ, PARK = g1stw % 16384 >= 8192 and 1 or 0, g1stw % 32768 >= 16384 and 1 or 0
  local SACK = g1stw % 65536 >= 32768 and 1 or 0
  local FACK = self.psm and bitof(stw2, 7) or 0
  local DLS, CREQ = (zsw2 - zsw2 % 4096) / 4096, bitof(zsw2, self.creq_bit)
  local ACKIP, PDONE = g1zsw % 4096 >= 2048 and 1 or 0, g1zsw % 8192 >= 4096 and 1 or 0
  local ATX, PKA = g1zsw % 16384 >= 8192 and 1 or 0, g1zsw % 32768 >= 16384 and 1 or 0
  local SERR = g1zsw % 65536 >= 32768 and 1 or 0
  local X1, X2, X3 = ac.g1_xist1, ac.g1_xist2, num(ac.g1_xist3)
  local NIST = ac.nist_b
  if NIST == nil then NIST = ac.nist_a end
  local VALID = c.compat == 0 or CTRL == 1                  -- §9 VALID[n]
  local ps, pa = self.prev_sp, self.prev_ac
  local first = ps == nil
  local pCLS, pCTRL, pHMODE, pPREQ, pAREQ, pPARK, pSACK
  local pDLS, pACKIP, pPDONE, pATX, pPKA, pSERR, pX1, pX2
  if not first then
    local s2, g = ps.stw2_enc or 0, ps.g1_stw or 0
    pCLS, pCTRL = (s2 - s2 % 4096) / 4096, s2 % 2048 >= 1024 and 1 or 0
    pHMODE, pPREQ = g % 4096 >= 2048 and 1 or 0, g % 8192 >= 4096 and 1 or 0
    pAREQ, pPARK, pSACK = g % 16384 >= 8192 and 1 or 0, g % 32768 >= 16384 and 1 or 0, g % 65536 >= 32768 and 1 or 0
    local z2, gz = pa.zsw2_enc or 0, pa.g1_zsw or 0
    pDLS = (z2 - z2 % 4096) / 4096
    pACKIP, pPDONE = gz % 4096 >= 2048 and 1 or 0, gz % 8192 >= 4096 and 1 or 0
    pATX, pPKA, pSERR = gz % 16384 >= 8192 and 1 or 0, gz % 32768 >= 16384 and 1 or 0, gz % 65536 >= 32768 and 1 or 0
    pX1, pX2 = pa.g1_xist1, pa.g1_xist2
  end
  hist_push(self, CTRL, PREQ, AREQ, PARK, SACK, VALID, PKA, SERR)
  local full = self.h_n == L + 1   -- a window W(n,-L_max,0) is only judged once fully observed

  -- position used by the preset arithmetic: X3 in telegram 84, else X2 while ATX (§1.6, §4.3)
  local pos2
  if X3 ~= nil then pos2 = X3 elseif ATX == 1 and SERR == 0 then pos2 = X2 end
  local ppos2
  if pa ~= nil then
    local pz = pa.g1_zsw or 0
    if pa.g1_xist3 ~= nil then ppos2 = num(pa.g1_xist3)
    elseif bitof(pz, 13) == 1 and bitof(pz, 15) == 0 then ppos2 = pX2 end
  end
  local motion_ref = X1
  if motion_ref == nil then motion_ref = X3 end
  -- standstill judged on the cycles before this one (this one may already show the reaction), by the position:
  -- the velocity lags a stop (filtered by SCANCON/Hohner, Lika's every 100 ms: words.py)
  local standstill = pos_still(self)
  local v_before = self:speed()
  pos_push(self, motion_ref)

  local pmotion
  if pa ~= nil then
    if X1 ~= nil then pmotion = pa.g1_xist1 else pmotion = num(pa.g1_xist3) end
  end
  self:value_rules(CLS, pCLS, DLS, pDLS, SERR, ATX, PKA, PDONE, X1, X2, X3, NIST, pos2, ppos2, self.pre, motion_ref,
                   pmotion, zsw2, g1zsw, first, has_g1)
  local shift = c.shift or 0
  local o

  -- ---- 9.2 control by PLC -----------------------------------------------------------------
  if self.compat_open then
    self:learn_compat(full, CTRL, CREQ, not first and has_g1 and (
      (PDONE == 1 and pPDONE == 0) or (ATX == 1 and pATX == 0) or (PKA == 1 and pPKA == 0)))
  elseif c.compat == 1 then
    if full and h_all(self, self.hCTRL, CTRL) and CREQ ~= CTRL then
      -- #13: CREQ follows CTRL within L_max (000_37bf2397999f1108.txt:3100-3106)
      o = self:hit("CTRLREQ-MISMATCH")
      if o then o.msg = fmt("control requested (ZSW2_ENC.%d)=%d while control by PLC (STW2_ENC.10)=%d for %d cycles; expected %d",
                            self.creq_bit, CREQ, CTRL, L + 1, CTRL) end
    end
    if CTRL == 0 and not first and has_g1 and ((PREQ == 1 and pPREQ == 0) or (AREQ == 1 and pAREQ == 0) or (PARK == 1 and pPARK == 0)
                                               or (SACK == 1 and pSACK == 0)) then
      -- #15: commands without control are ignored (000_37bf2397999f1108.txt:1689-1691)
      o = self:hit("CMD-WITHOUT-CONTROL", true)
      if o then o.msg = fmt("G1_STW=0x%04X command edge while STW2_ENC.10=0 (V4.1 mode ignores it)", g1stw) end
    end
    if full and h_all(self, self.hCTRL, 0) and not first and has_g1 and (
        (PDONE == 1 and pPDONE == 0) or (ATX == 1 and pATX == 0) or (PKA == 1 and pPKA == 0)) then
      -- #16: nothing may execute without control (000_37bf2397999f1108.txt:3108-3114)
      o = self:hit("CMD-EXECUTED-WITHOUT-CONTROL")
      if o then o.msg = fmt("G1_ZSW=0x%04X acknowledged a command while control by PLC was 0 for %d cycles; expected no reaction",
                            g1zsw, L + 1) end
    end
  elseif CREQ ~= 0 then
    -- #14: V3.1 mode holds control requested at 0 (000_37bf2397999f1108.txt:2338-2346)
    o = self:hit("CTRLREQ-SET-IN-COMPAT")
    if o then o.msg = fmt("ZSW2_ENC.%d=1 in V3.1 compatibility mode; expected 0", self.creq_bit) end
  end

  -- ---- 9.8 reserved bits ------------------------------------------------------------------
  if band(stw2, self.res_stw2) ~= 0 then  -- #60: reserved STW2_ENC bits (behaviour.md §9.8)
    o = self:hit("RESERVED-BIT-SET-STW2", true)
    if o then o.msg = fmt("STW2_ENC=0x%04X sets reserved bits 0x%04X (%s)", stw2, band(stw2, self.res_stw2), c.profile) end
  end
  if band(zsw2, self.res_zsw2) ~= 0 then  -- #62: reserved ZSW2_ENC bits (behaviour.md §9.8)
    o = self:hit("RESERVED-BIT-SET-ZSW2")
    if o then o.msg = fmt("ZSW2_ENC=0x%04X sets reserved bits 0x%04X (%s)", zsw2, band(zsw2, self.res_zsw2), c.profile) end
  end
  if has_g1 then
    if band(g1stw, self.res_g1stw) ~= 0 then  -- #61: reserved G1_STW bits (behaviour.md §9.8)
      o = self:hit("RESERVED-BIT-SET-G1STW", true)
      if o then o.msg = fmt("G1_STW=0x%04X sets reserved bits 0x%04X (%s)", g1stw, band(g1stw, self.res_g1stw), c.profile) end
    end
    if band(g1zsw, self.res_g1zsw) ~= 0 then  -- #63: reserved G1_ZSW bits (behaviour.md §9.8)
      o = self:hit("RESERVED-BIT-SET-G1ZSW")
      if o then o.msg = fmt("G1_ZSW=0x%04X sets reserved bits 0x%04X (%s)", g1zsw, band(g1zsw, self.res_g1zsw), c.profile) end
    end
  end
  local hs = self.psm and K.preset_handshake[c.telegram]   -- telegram 89: control/status bit pair (cyclic.md §3.9)
  if hs and sp.stw2_enc ~= nil then
    local tb, ab = hs.trigger, hs.ack
    self:preset89(band(rshift(stw2, tb), 1), first and 0 or band(rshift(ps.stw2_enc or 0, tb), 1), band(rshift(zsw2, ab), 1))
  end
  if not has_g1 then return end

  -- ---- 9.3 preset (G1_STW.12 / G1_ZSW.12) -------------------------------------------------
  if not first and (PREQ == 1 and pPREQ == 0) then
    if not truthy(c.class4) and not C.class4_open(c) then
      -- #17: preset needs class 4 functionality (001_9461bb7bc8c2767b.txt:846)
      o = self:hit("PRESET-CLASS4-DISABLED", true)
      if o then o.msg = "preset requested (G1_STW.12 rise) with class 4 functionality off" end
    end
    local moving = not standstill
    if moving then
      -- #26: presets only at standstill (001_9461bb7bc8c2767b.txt:844, 004_59bef5ae9f41db55.txt:772)
      o = self:hit("PRESET-NOT-STANDSTILL", true)
      if o then o.msg = fmt("preset requested while moving (positions %s, NIST=%s)", pos_list(self), NIST == nil and "None" or tostring(NIST)) end
    end
    local allowed = VALID and (truthy(c.class4) or C.class4_open(c)) and PKA == 0 and SERR == 0
    self.pre = {n = n, f = self.f, fc = self.fc, ts = self.ts, mode = HMODE, P = self.p65000, pos2 = ppos2, x1 = pX1,
                allowed = allowed, moving = moving, done = false, v = v_before}
    if allowed and (HMODE == 1 or truthy(self.p65000)) then
      self.store = {n = n, f = self.f, ts = self.ts, zero = 0}
    end
  end
  local pre = self.pre
  if pre ~= nil and PREQ == 1 and PDONE == 0 and not first and HMODE ~= pHMODE and pPREQ == 1 then
    -- #25: the mode is latched at the edge [INFERENCE] (000_37bf2397999f1108.txt:1790-1793)
    o = self:hit("PRESET-MODE-CHANGED", true)
    if o then o.msg = fmt("G1_STW.11 changed %d->%d while the preset request was pending", pHMODE, HMODE) end
  end
  if not first and (PDONE == 1 and pPDONE == 0) then
    local off = not truthy(c.class4) and not C.class4_open(c)
    if off or pPKA ~= 0 then
      -- #18: no preset without class 4 or while parked (000_37bf2397999f1108.txt:2245-2265, 3140-3162)
      o = self:hit("PRESET-EXECUTED-WHEN-NOT-ALLOWED")
      if o then o.msg = "preset acknowledged (G1_ZSW.12 rise) while "
                        .. (off and "class 4 functionality is off" or "parked") end
    end
    if h_all(self, self.hPREQ, 0) then
      -- #20: PDONE only in answer to PREQ (000_37bf2397999f1108.txt:3123-3139)
      o = self:hit("PRESET-ACK-SPURIOUS")
      if o then o.msg = fmt("G1_ZSW.12 rose with G1_STW.12=0 in the last %d cycles", self.h_n) end
    end
    self.pdone_since = n
    self.preset_done = true
    if pre ~= nil and not pre.done then
      pre.done = true
      pre.done_n = n
      self:check_preset_value(pre, pos2, X1, shift)
    end
  end
  if not first and (PDONE == 0 and pPDONE == 1) then
    self.pdone_since = nil
    if full and h_all(self, self.hPREQ, 1) then
      -- #21: PDONE holds while PREQ = 1 (000_37bf2397999f1108.txt:1806-1812)
      o = self:hit("PRESET-ACK-DROPPED")
      if o then o.msg = "G1_ZSW.12 fell while G1_STW.12 stayed 1" end
    end
  end
  if pre ~= nil and not first and (PREQ == 0 and pPREQ == 1) then
    if not pre.done and PDONE == 0 and pre.allowed then
      -- #23: the controller must hold PREQ until PDONE (000_37bf2397999f1108.txt:780-781)
      self:emit("PRESET-REQ-EARLY-RELEASE", self.fc, self.ts,
                fmt("G1_STW.12 released %d cycles after the request (frame %d) before G1_ZSW.12 rose", n - pre.n, pre.fc),
                nil, nil, n - pre.n)
    end
    if PDONE == 1 or pre.done then
      self.pdone_clear_due = {n + L, self.f, self.ts}
    end
    self.pre = nil
    pre = nil
  end
  if pre ~= nil and not pre.done and pre.allowed and n - pre.n >= self.D then
    -- #19: PDONE within D_preset (000_37bf2397999f1108.txt:774-778, 001_9461bb7bc8c2767b.txt:541)
    self:emit("PRESET-ACK-MISSING", pre.f, pre.ts,
              fmt("no G1_ZSW.12 within D_preset=%d cycles after the preset request", self.D), self.f, nil, self.D)
    pre.allowed = false  -- reported once
  end
  local pcd = self.pdone_clear_due
  if pcd ~= nil then
    if PREQ == 1 then
      self.pdone_clear_due = nil
    elseif PDONE == 0 then
      self.pdone_clear_due = nil
    elseif n >= pcd[1] then
      -- #22: PDONE clears within L_max after PREQ falls (000_37bf2397999f1108.txt:1810-1812)
      self:emit("PRESET-ACK-NOT-CLEARED", pcd[2], pcd[3], fmt("G1_ZSW.12 still 1 %d cycles after G1_STW.12 fell", L),
                self.f, nil, L)
      self.pdone_clear_due = nil
    end
  end
  if self.pdone_since ~= nil and PREQ == 1 and n - self.pdone_since == self.D then
    -- #24: the controller closes the handshake (000_37bf2397999f1108.txt:1832-1834)
    self:emit("PRESET-REQ-STUCK", self.fc, self.ts, fmt("G1_STW.12 still 1 %d cycles after G1_ZSW.12 rose", self.D),
              nil, nil, self.D)
  end
  if pre ~= nil and pre.done and PREQ == 1 and PDONE == 1 and pre.after ~= nil and pos2 ~= nil
      and ppos2 ~= nil and pre.mode == 1 and abs(pre.P) > 2 * pre.v and self.n > pre.done_n then
    -- #30: holding PREQ must not re-execute (relative shift applied twice) [INFERENCE] §2.4 R-PRE-1
    local d = delta(ppos2, pos2, self.R or U32)
    if abs(d - pre.P) <= pre.v then
      o = self:hit("PRESET-REEXECUTED")
      if o then o.msg = fmt("position moved by the preset value %s again (%s -> %s) while G1_STW.12 was held",
                            tostring(pre.P), tostring(ppos2), tostring(pos2)) end
    end
  end
  local st = self.store
  if st ~= nil and n > st.n then
    -- #43: position zero for longer than 10 ms after the trigger (001_9461bb7bc8c2767b.txt:525)
    if pos2 == 0 or X1 == 0 then
      st.zero = st.zero + 1
      if st.zero == C.store_cycles(c) + 1 then
        self:emit("XIST-DURING-STORE", st.f, st.ts,
                  fmt("position 0 for more than %d cycles (10 ms) after the preset request", C.store_cycles(c)), self.f)
        self.store = nil
      end
    elseif st.zero ~= 0 or n - st.n > self.D then
      self.store = nil  -- the store window is over
    end
  end

  -- ---- 9.5 absolute value request and XIST contents ---------------------------------------
  if full then follows(self, "absval", "ATX", ATX) end  -- #36, #37: ATX follows AREQ (registry FOLLOWS)

  -- ---- 9.6 parking ------------------------------------------------------------------------
  if full then follows(self, "park", "PKA", PKA) end  -- #45, #46: PKA follows PARK (registry FOLLOWS)
  if PKA == 1 and not first and pPKA == 1 and (SERR == 1 and pSERR == 0) then
    -- #48: no new errors while parked (000_37bf2397999f1108.txt:1775-1777)
    o = self:hit("PARK-ERROR-REPORTED")
    if o then o.msg = fmt("sensor error raised while parked (G1_XIST2=0x%X)", X2 or 0) end
  end
  if not first and (PKA == 1 and pPKA == 0) and self.lika then
    self.park_rise_due = {n + L, self.f, self.ts}
  end
  local prd = self.park_rise_due
  if prd ~= nil and n >= prd[1] then
    self.park_rise_due = nil
    if SERR == 1 and PKA == 1 then
      -- #49: parking clears errors (000_37bf2397999f1108.txt:1874-1875)
      self:emit("PARK-ERRORS-NOT-CLEARED", prd[2], prd[3], fmt("sensor error still set %d cycles after parking started", L), self.f)
    end
  end
  if not first and (PARK == 1 and pPARK == 0) and not standstill then
    -- #50: parking while running is not allowed (000_37bf2397999f1108.txt:1876-1879)
    o = self:hit("PARK-WHILE-RUNNING", true)
    if o then o.msg = fmt("parking requested while moving (positions %s, NIST=%s)", pos_list(self), NIST == nil and "None" or tostring(NIST)) end
  end

  -- ---- 9.7 sensor error and acknowledgement -----------------------------------------------
  if SERR == 1 and (first or pSERR == 0) then
    -- an error on in the first cycle after a break began unseen: its acknowledgement is not known (#11/#55)
    self.sack_since_serr = SACK == 1 or first
    self.fack_since_serr = FACK == 1
  end
  if SERR == 1 then
    self.serr_code = X2
    self.sack_since_serr = self.sack_since_serr or SACK == 1
    self.fack_since_serr = self.fack_since_serr or FACK == 1
  end
  if not first and (SACK == 1 and pSACK == 0) then
    if SERR == 0 and pSERR == 0 then
      -- #57: acknowledging nothing (000_37bf2397999f1108.txt:1887-1891)
      o = self:hit("SACK-WITHOUT-ERROR", true)
      if o then o.msg = "G1_STW.15 raised with no sensor error" end
    else
      self.sack_edge = {n, self.f, self.ts}
    end
  end
  local se = self.sack_edge
  if se ~= nil then
    local n0 = se[1]
    local lika_flow = defaults(c).ackip_every_ack
    if ACKIP == 1 or SERR == 0 then
      if ACKIP == 1 or not lika_flow then self.sack_edge = nil end
    end
    if self.sack_edge ~= nil then
      if (lika_flow and n - n0 >= L) or (not lika_flow and n - n0 >= L + 1 and SACK == 1 and SERR == 1) then
        -- #52: ACKIP answers SACK (LIKA always; others if the reset takes > 1 cycle) (000_37bf2397999f1108.txt:3193-3199)
        self:emit("ACKIP-MISSING", se[2], se[3],
                  fmt("no G1_ZSW.11 within %d cycles after G1_STW.15 rose with a sensor error", n - n0), self.f, nil, n - n0)
        self.sack_edge = nil
      elseif not lika_flow and SACK == 0 then
        self.sack_edge = nil
      end
    end
  end
  if not first and (ACKIP == 1 and pACKIP == 0) and h_all(self, self.hSACK, 0) then
    -- #53: ACKIP only after SACK (000_37bf2397999f1108.txt:3193-3199)
    o = self:hit("ACKIP-SPURIOUS")
    if o then o.msg = fmt("G1_ZSW.11 rose with G1_STW.15=0 in the last %d cycles", self.h_n) end
  end
  if full then follows(self, "ackip", "ACKIP", ACKIP) end  -- #54: ACKIP ends with the acknowledgement (FOLLOWS)
  if ACKIP == 1 and SACK == 1 then
    if self.ackip_since == nil then
      self.ackip_since = n
    elseif n - self.ackip_since == self.D then
      -- #58: the controller releases SACK after ACKIP (000_37bf2397999f1108.txt:3201-3202)
      self:emit("SACK-HELD", self.fc, self.ts, fmt("G1_STW.15 held %d cycles after G1_ZSW.11 rose", self.D), nil, nil, self.D)
    end
  elseif SACK == 0 then
    self.ackip_since = nil
  end
  if not first and (SERR == 0 and pSERR == 1) then
    local code = self.serr_code
    -- (the acknowledgement of this very cycle counts: a reset within one bus cycle, words.py)
    local acked = self.sack_since_serr or SACK == 1 or (self.psm and (self.fack_since_serr or FACK == 1))
    if PKA == 0 and not acked then
      if code == K.e_master_sol then
        -- #11: a sign-of-life fault clears only after acknowledgement (001_9461bb7bc8c2767b.txt:1697)
        o = self:hit("SOL-FAULT-CLEARED-WITHOUT-ACK")
        if o then o.msg = "0x0F02 sign-of-life fault cleared without G1_STW.15" .. (self.psm and " / STW2_ENC.7" or "") end
      else
        -- #55: errors clear after acknowledgement [AMBIGUOUS] (000_37bf2397999f1108.txt:3182-3213)
        o = self:hit("SERR-CLEARED-WITHOUT-ACK")
        if o then o.msg = fmt("sensor error 0x%X cleared without G1_STW.15", code or 0) end
      end
    end
    if AREQ == 1 and VALID and PKA == 0 then   -- (parking cleared it: parked, the position stays out, R-ABS-4)
      self.restore_due = {n + L, self.f, self.ts}
    end
  end
  local rd = self.restore_due
  if rd ~= nil and n >= rd[1] then
    self.restore_due = nil
    if ATX == 0 and AREQ == 1 and SERR == 0 and PKA == 0 then
      -- #56: the position comes back into XIST2 (000_37bf2397999f1108.txt:3204-3209)
      self:emit("SERR-XIST2-NOT-RESTORED", rd[2], rd[3], fmt("G1_ZSW.13 still 0 %d cycles after the sensor error cleared", L),
                self.f)
    end
  end
  if self.psm and SERR == 1 and bitof(zsw2, 3) == 0 then
    -- #59: PS/PSM fault present follows the sensor error [INFERENCE] (002_d69f444daf0f8af2.txt:576-582)
    o = self:hit("FAULT-PRESENT-INCONSISTENT")
    if o then o.msg = "G1_ZSW.15=1 but ZSW2_ENC.3 (fault present)=0" end
  end

  -- ---- 9.9 0xBF00 reaction (#70, #71) -----------------------------------------------------
  local bd = self.bf00_due
  if bd ~= nil then
    if SERR == 1 and X2 == K.e_param then
      self.bf00_due = nil
    elseif n >= bd[1] then
      -- #70: an invalid parameter set must be reported (000_37bf2397999f1108.txt:2636-2639)
      self:emit("BF00-ERROR-NOT-REPORTED", bd[3] or self.f, bd[4] or self.ts,   -- from the write to the deciding frame
                fmt("0xBF00 was invalid (%s) but data exchange runs with no 0x1002 sensor error", bd[2]), self.f)
      self.bf00_due = nil
    end
  end
end

local function xist2_inconsistent(self, X1, X2, shift)
  local exp1 = lshift(X2, shift)
  if X1 ~= exp1 then
    -- #40: X1 == X2 << P979.3 (001_9461bb7bc8c2767b.txt:2223-2224)
    local o = self:hit("XIST2-INCONSISTENT")
    if o then o.msg = fmt("G1_XIST1=0x%08X, expected G1_XIST2 << %d = 0x%08X", X1, shift, exp1) end
  end
end

-- Rules on the counters and position values: they must run every cycle, also in steady state.
function Checker:value_rules(CLS, pCLS, DLS, pDLS, SERR, ATX, PKA, PDONE, X1, X2, X3, NIST, pos2, ppos2, pre,
                             motion_ref, pmotion, zsw2, g1zsw, first, has_g1)
  local c = self.cfg
  local o
  -- learn the XIST1 shift (P979.3) from the first cycle with both positions (§1.6 R-X1-4)
  if not self.shift_known and has_g1 and ATX == 1 and SERR == 0 and X1 ~= nil and truthy(X2) then
    for s = 0, 31 do
      if lshift(X2, s) == X1 then
        c.shift = s
        c.sources.shift = fmt("inferred from frame %d (X1 = X2 << %d)", self.f, s)
        break
      end
    end
    self.shift_known = true
  end
  local shift = c.shift or 0

  -- ---- 9.1 sign-of-life -------------------------------------------------------------------
  if CLS ~= 0 then self.started_C = true end
  if self.solmon then
    self:sign_of_life(CLS, pCLS, DLS, pDLS, SERR, X2, first)
  elseif DLS ~= 0 then
    self.started_D = true
  end
  local iso = c.iso
  iso = iso ~= nil and iso ~= false and iso ~= 0   -- truthy(c.iso), inline: this runs every cycle
  if not iso and DLS == 0 and self.started_D then
    -- #8: RT mode, DLS back to 0 once running (RT examples show DLS != 0, 001_9461bb7bc8c2767b.txt:2221)
    o = self:hit("SOL-DEVICE-ZERO-RT")
    if o then o.msg = fmt("encoder sign-of-life 0 in RT data exchange (ZSW2_ENC=0x%04X); expected 1..15", zsw2) end
  end
  if iso and SERR == 1 and X2 == K.e_sync and DLS ~= 0 then
    -- #12: sync fault 0x0F04 must come with DLS = 0 (001_9461bb7bc8c2767b.txt:1802-1804)
    o = self:hit("SYNC-FAULT-DLS-NONZERO")
    if o then o.msg = fmt("G1_XIST2=0x0F04 with encoder sign-of-life %d; expected 0", DLS) end
  end

  if ATX == 1 and SERR == 1 then
    -- #38: never both (000_37bf2397999f1108.txt:1911-1914)
    o = self:hit("ZSW-ATX-AND-SERR")
    if o then o.msg = fmt("G1_ZSW=0x%04X has transmit-absolute-value and sensor-error together", g1zsw) end
  end
  if self.lika and X2 ~= nil and ATX == 0 and SERR == 0 and PKA == 0 and X2 ~= 0 then
    -- #39: LIKA sends 0 in XIST2 without request (000_37bf2397999f1108.txt:1626-1629)
    o = self:hit("XIST2-NOT-ZERO")
    if o then o.msg = fmt("G1_XIST2=%d with G1_ZSW.13=0 and no error; expected 0", X2) end
  end
  if ATX == 1 and SERR == 0 and X1 ~= nil and X2 ~= nil and X3 == nil then
    -- (not class4 or xist1_preset_affected) and not xist1_counter, inline (config.py properties)
    local c4, d, sh = c.class4, T.profile_defaults[c.profile] or T.profile_defaults.generic, c.shift
    local pc = c.preset_control
    if pc == nil then pc = d.preset_control end
    local on = c4 ~= nil and c4 ~= 0 and c4 ~= false
    local src = tostring(c.sources.shift or "")
    -- a vendor not known: its X1 may be a profile 4.1 counter, unless the shift was read (P979) or given
    local known = (c.profile ~= "generic" or src:sub(1, 4) == "P979" or src:sub(1, 9) == "settings.")
                  and not ((self.preset_done or PDONE == 1) and C.preset_control_open(c))
    if known and (not on or pc == d.preset_control_affects_xist1) and not (d.xist1_counter and (sh == nil or sh == 0)) then
      xist2_inconsistent(self, X1, X2, shift)
    end
  end
  local R = self.R
  if R and ATX == 1 and SERR == 0 and ((X2 ~= nil and X2 >= R) or (self.lika and X1 ~= nil and X1 >= R)) then
    -- #41: position inside [0, R) (000_37bf2397999f1108.txt:2394-2434)
    o = self:hit("POSITION-OUT-OF-RANGE")
    if o then o.msg = fmt("position G1_XIST2=%s G1_XIST1=%s >= R=%s", tostring(X2), tostring(X1), tostring(R)) end
  end
  self:continuity(pos2, ppos2, pre, PKA, PDONE)
  local pa = self.prev_ac
  if pos2 == nil and ppos2 == nil and self.lika and X3 == nil and X1 ~= nil and pmotion ~= nil and SERR == 0
      and pa ~= nil and X1 ~= 0 and pmotion ~= 0 then   -- (0: parked or in error, a cycle apart from its bit)
    -- value_rules._positions: LIKA's G1_XIST1 is the absolute position too, where no X2 carries it (no sensor error,
    -- no parking in either cycle)
    local pz = pa.g1_zsw or 0
    local pss = bitof(pz, 15) == 1 and (pa.g1_xist2 or 1) or 0
    if pss == 0 and bitof(pz, 14) == 0 then self:continuity(rshift(X1, shift), rshift(pmotion, shift), pre, PKA, PDONE) end
  end
  if self.velocity_filter == nil then self:nist_sign(motion_ref, pmotion, NIST) end   -- not with a SCANCON filter written

  if self.lika and PKA == 1 and ((X1 or 0) ~= 0 or (SERR == 0 and (X2 or 0) ~= 0) or PDONE ~= 0 or ATX ~= 0) then
    -- #47: LIKA clears outputs while parked (000_37bf2397999f1108.txt:3149-3159); a sensor error keeps its code in
    -- G1_XIST2 until parking clears it (#49, #51)
    o = self:hit("PARK-OUTPUTS-NOT-CLEARED")
    if o then o.msg = fmt("parked with G1_XIST1=%s G1_XIST2=%s G1_ZSW=0x%04X; expected 0s", tostring(X1), tostring(X2), g1zsw) end
  end
  if SERR == 1 and X2 ~= nil and (X2 == 0 or (self.lika and not K.lika_codes[X2])) then
    -- #51: SERR needs an error code in XIST2 (000_37bf2397999f1108.txt:2617-2639)
    o = self:hit("SERR-CODE-INVALID")
    if o then o.msg = fmt("sensor error with G1_XIST2=0x%X; expected %s", X2,
                          self.lika and "one of the LIKA error codes" or "a non-zero code") end
  end
  if SERR == 1 and X2 == K.e_param and self.bf00_valid_frame ~= nil and self.bf00_invalid == nil then
    -- #71: a valid parameter set must be accepted (same sources)
    o = self:hit("BF00-VALID-REJECTED")
    if o then o.msg = fmt("0x1002 parametrization error after a valid 0xBF00 (frame %s)", tostring(self.bf00_valid_frame)) end
  end
end

-- Control and status words (sign-of-life aside) as in the last L_max+1 cycles, nothing pending and
-- no rule running: window, edge and deadline rules cannot change, so only the value rules run.
function Checker:cycle_steady(sp, ac)
  -- the bit arithmetic is written out (no helper calls): this is the common per-frame path
  local stw2, zsw2, g1zsw = sp.stw2_enc or 0, ac.zsw2_enc or 0, ac.g1_zsw or 0
  local ps, pa = self.prev_sp, self.prev_ac
  local X1, X2, X3 = ac.g1_xist1, ac.g1_xist2, ac.g1_xist3
  if type(X3) == "table" then X3 = num(X3) end
  local SERR = g1zsw >= 32768 and 1 or 0                    -- g1zsw >> 15
  local ATX = g1zsw % 16384 >= 8192 and 1 or 0              -- bit 13
  local pos2
  if X3 ~= nil then pos2 = X3 elseif ATX == 1 and SERR == 0 then pos2 = X2 end
  local pz = pa.g1_zsw or 0
  local ppos2
  if X3 ~= nil then ppos2 = num(pa.g1_xist3)
  elseif pz % 16384 >= 8192 and pz < 32768 then ppos2 = pa.g1_xist2 end
  local motion_ref = X1
  if motion_ref == nil then motion_ref = X3 end
  pos_push(self, motion_ref)
  local NIST = ac.nist_b
  if NIST == nil then NIST = ac.nist_a end
  local pmotion
  if X1 ~= nil then pmotion = pa.g1_xist1 else pmotion = num(pa.g1_xist3) end
  local ps2, pz2 = ps.stw2_enc or 0, pa.zsw2_enc or 0
  self:value_rules((stw2 - stw2 % 4096) / 4096, (ps2 - ps2 % 4096) / 4096, (zsw2 - zsw2 % 4096) / 4096,
                   (pz2 - pz2 % 4096) / 4096, SERR, ATX,
                   g1zsw % 32768 >= 16384 and 1 or 0, g1zsw % 8192 >= 4096 and 1 or 0, X1, X2, X3, NIST, pos2, ppos2,
                   self.pre, motion_ref, pmotion, zsw2, g1zsw, false, ac.g1_zsw ~= nil)
end

-- ------------------------------------------------------------------------------ sign-of-life (§3)
function Checker:sign_of_life(CLS, pCLS, DLS, pDLS, SERR, X2, first)
  local c, k = self.cfg, self.cfg.k
  local o
  if self.started_C and self.sp_new then   -- one judgement per controller frame (RT drift)
    if not first and self.sp_before ~= nil then
      local s2 = self.sp_before.stw2_enc or 0
      pCLS = (s2 - s2 % 4096) / 4096
    end
    if CLS == 0 then
      -- #1: C-LS 0 is never sent once started (001_9461bb7bc8c2767b.txt:484)
      o = self:hit("SOL-MASTER-ZERO", true)
      if o then o.msg = "controller sign-of-life 0 after start; expected 1..15" end
    elseif not first and truthy(pCLS) and CLS ~= pCLS and CLS ~= next_ls(pCLS) then
      -- #2: +1 per TMAPC, never a double step (001_9461bb7bc8c2767b.txt:482, 1693)
      o = self:hit("SOL-MASTER-SKIP", true)
      if o then o.msg = fmt("controller sign-of-life %d -> %d; expected %d or %d", pCLS, CLS, pCLS, next_ls(pCLS)) end
    end
    -- failure counter of the DO (§3.3 R-SOLC-1/2): +10 per deviation, -1 per good TMAPC
    if first or pCLS == nil then
      self.cls_run = 1
    elseif CLS == pCLS then
      self.cls_run = self.cls_run + 1
      if self.cls_run > k then
        -- #3: frozen controller (001_9461bb7bc8c2767b.txt:1693, 1708-1712)
        o = self:hit("SOL-MASTER-STALL", true)
        if o then o.msg = fmt("controller sign-of-life stuck at %d for more than k=%d cycles", CLS, k) end
        if (self.cls_run - 1) % k == 0 then
          self.C = self.C + 10
        end
      end
    else
      if k > 1 and self.cls_runs_done > 0 and self.cls_run < k then
        -- #4: each value is held k cycles (001_9461bb7bc8c2767b.txt:1671, 1677)
        o = self:hit("SOL-MASTER-WINDOW", true)
        if o then o.msg = fmt("controller sign-of-life %d held %d cycles; expected k=%d", pCLS, self.cls_run, k) end
      end
      self.cls_runs_done = self.cls_runs_done + 1
      self.cls_run = 1
      if CLS == 0 or (truthy(pCLS) and CLS ~= next_ls(pCLS)) then
        self.C = self.C + 10
      else
        self.C = math.max(0, self.C - 1)
      end
    end
    ch_push(self, self.C)
    local over
    if truthy(c.sol_threshold_ge) then over = self.C >= self.sol_limit else over = self.C > self.sol_limit end
    if over and self.solf_due == nil and not self.sol_fault_seen then
      self.solf_due = {self.n + self.L, self.f, self.ts}
    end
  end
  if SERR == 1 and X2 == K.e_master_sol then
    self.sol_fault_seen = true
    self.solf_due = nil
  elseif self.solf_due ~= nil and self.n >= self.solf_due[1] then
    local sd = self.solf_due
    -- #9: the encoder reports 0x0F02 once the counter passes 10N (000_37bf2397999f1108.txt:2624-2626)
    self:emit("SOL-FAULT-MISSING", sd[2], sd[3], fmt("failure counter C=%d > 10*N=%d but no G1_ZSW.15 with "
              .. "G1_XIST2=0x0F02 within %d cycles", self.C, self.sol_limit, self.L), self.f)
    self.solf_due = nil
    self.sol_fault_seen = true
  end
  if self.C <= self.sol_limit and SERR == 0 then
    self.sol_fault_seen = false  -- re-armed once the counter is back under the threshold
  end
  if SERR == 1 and X2 == K.e_master_sol and self.prev_ac ~= nil and bitof(self.prev_ac.g1_zsw or 0, 15) == 0 then
    local all_below = self.n >= self.sol_known_at
    for i = 1, self.Ch_n do if not (self.Ch[i] < self.sol_limit) then all_below = false; break end end
    if all_below then
      -- #10: no 0x0F02 without enough failures (001_9461bb7bc8c2767b.txt:1777-1781)
      o = self:hit("SOL-FAULT-SPURIOUS")
      if o then o.msg = fmt("0x0F02 raised while the failure counter stayed below 10*N=%d (C=%d)", self.sol_limit, self.C) end
    end
  end
  if DLS ~= 0 then
    if not self.started_D and not first and pDLS == 0 and pCLS ~= nil and CLS == pCLS
        and not (self.started_C and self.cls_run <= self.L + 1) then
      -- #7: the DO starts on a C-LS change (001_9461bb7bc8c2767b.txt:1734-1736), within L_max cycles of it
      o = self:hit("SOL-DEVICE-EARLY-START")
      if o then o.msg = fmt("encoder sign-of-life started (%d) without a controller sign-of-life change", DLS) end
    end
    self.started_D = true
    if not first and truthy(pDLS) and DLS ~= next_ls(pDLS) then
      -- #6: +1 every DP cycle (001_9461bb7bc8c2767b.txt:504-506, 1730)
      o = self:hit("SOL-DEVICE-SKIP")
      if o then o.msg = fmt("encoder sign-of-life %d -> %d; expected %d", pDLS, DLS, next_ls(pDLS)) end
    end
  elseif self.started_D and not (SERR == 1 and X2 == K.e_sync) then
    -- #5: DLS 0 only with sync fault 0x0F04 (001_9461bb7bc8c2767b.txt:1802-1804)
    o = self:hit("SOL-DEVICE-ZERO")
    if o then o.msg = "encoder sign-of-life 0 after start without sync fault 0x0F04" end
  end
end

-- ------------------------------------------------------------------------------ preset arithmetic (§4.3, #27-29)
-- #27-29 at the first frame with PDONE = 1: |observed - expected| <= v x cycles (§4.3).
function Checker:check_preset_value(pre, pos2, X1, shift)
  local c = self.cfg
  if not pre.allowed then return end
  local P_, mode = pre.P, pre.mode
  if P_ == nil then  -- no P65000 write seen and none given: the expected position is unknown
    self.presets_unjudged = self.presets_unjudged + 1
    return
  end
  local tol = pre.v * (self.n - pre.n + 1)
  local m2 = self.R or U32
  local function near(a, b, m) return abs(delta(b, a, m)) <= tol end
  local words = mode == 0 and "absolute" or "relative"
  local x2_ok = nil
  if pos2 ~= nil and (mode == 0 or pre.pos2 ~= nil) then
    local exp2 = expected_after_preset(mode, P_, pre.pos2 or 0, self.R)
    -- the range unknown (no scaling, no st_phys/mt_phys): the result may have wrapped at it
    x2_ok = near(pos2, exp2, m2) or (self.R == nil and mode ~= 0 and fits_binary_range(pos2, exp2, pre.pos2 or 0, pos2, tol))
    pre.after = pos2
    if not x2_ok then
      -- #27: position after the preset (000_37bf2397999f1108.txt:1799-1807, 1818-1829)
      self:emit("PRESET-VALUE-WRONG", self.f, self.ts,
                fmt("%s preset P65000=%s: position %s in the first frame with G1_ZSW.12, expected %s", words,
                    tostring(P_), tostring(pos2), tostring(exp2)) .. (tol ~= 0 and (" +- " .. tostring(tol)) or ""))
    end
  end
  if X1 == nil or pre.x1 == nil or C.preset_control_open(c) then return end   -- (no 0xBF00: X1's setting unknown)
  local x1_before = pre.x1
  local counter = C.xist1_counter(c)
  local m1 = counter and U32 or m2
  local sh = counter and 0 or shift
  local base = counter and x1_before or rshift(x1_before, shift)
  local moved_like_x2 = false
  if x2_ok then
    if pre.pos2 ~= nil then
      moved_like_x2 = not near(pos2, pre.pos2, m2)
    else  -- near(pos2, pos2 + tol + 1, m2), without the sum (inexact for positions >= 2^53)
      moved_like_x2 = not (abs(delta(tol + 1, 0, m2)) <= tol)
    end
  end
  local x1_kept = near(rshift(X1, sh), base, m1)
  if C.xist1_preset_affected(c) then
    local exp1 = expected_after_preset(mode, P_, base, m1)
    if x1_kept and moved_like_x2 and not near(exp1, base, m1) then
      -- #29: preset control enabled, XIST1 must follow (000_37bf2397999f1108.txt:2245-2249)
      self:emit("PRESET-XIST1-NOT-AFFECTED-WHEN-ENABLED", self.f, self.ts,
                fmt("G1_XIST2 took the preset but G1_XIST1 stayed %d; expected %d", X1, lshift(mod(exp1, U32), sh)))
    elseif not ((near(rshift(X1, sh), exp1, m1) and band(X1, lshift(1, sh) - 1) == 0)
                or self:x1_other_reading(rshift(X1, sh), exp1, base, pos2, x2_ok, tol, mode, pre.pos2)) then
      self:emit("PRESET-VALUE-WRONG", self.f, self.ts,
                fmt("%s preset P65000=%s: G1_XIST1=0x%08X in the first frame with G1_ZSW.12, expected 0x%08X", words,
                    tostring(P_), X1, lshift(mod(exp1, U32), sh)))
    end
  elseif not x1_kept and moved_like_x2 then
    -- #28: preset control disabled, XIST1 must not move (§7 D14 per-vendor coding)
    self:emit("PRESET-XIST1-AFFECTED-WHEN-DISABLED", self.f, self.ts,
              fmt("G1_XIST1 changed %d -> %d at the preset although G1_XIST1 preset control is disabled", x1_before, X1))
  end
end

-- presets._x1_other_reading: a 32-bit counter may start again from the new absolute position (G1_XIST2's);
-- a position of unknown range may have wrapped at it
function Checker:x1_other_reading(x1, exp1, base, pos2, x2_ok, tol, mode, pos_before)
  if C.xist1_counter(self.cfg) then
    if pos2 == nil and mode == 0 and truthy(self.R) then
      -- no G1_XIST2 to read it by: a counter started at the absolute position holds it modulo R (presets.py)
      return math.abs(delta(mod(base + exp1 - mod(base, self.R), U32), x1, U32)) <= tol
    end
    if x2_ok ~= true or pos2 == nil then return false end
    if math.abs(delta(pos2, x1, U32)) <= tol then return true end
    -- ... or moved by the position's jump (a counter that ran past the measuring range)
    return pos_before ~= nil and math.abs(delta(mod(base + pos2 - pos_before, U32), x1, U32)) <= tol
  end
  return self.R == nil and mode ~= 0 and fits_binary_range(x1, exp1, base, x1, tol)
end

-- ------------------------------------------------------------------------------ continuity and velocity (§4.2, #42, #44)
local function is_pow2(v)
  local x = v
  while x > 1 and x % 2 == 0 do x = x / 2 end
  return x == 1
end

function Checker:continuity(pos, ppos, pre, PKA, PDONE)
  local c = self.cfg
  local R = self.R
  -- (a jump in a cycle with G1_ZSW.12 is a preset's, also one whose request a capture gap hid)
  if pos == nil or ppos == nil or R == nil or PKA ~= 0 or PDONE ~= 0 or pre ~= nil or self.pdone_since ~= nil then return end
  if c.profile ~= "scancon" and c.profile ~= "hohner" and c.profile ~= "lika" and not (self.psm and truthy(c.scaling)) then
    return  -- generic: unknown
  end
  local step = c.max_position_step
  if not truthy(step) then step = math.max(1, floor(R / 8)) end
  local d = delta(ppos, pos, R)
  -- value_rules._red_zone: LIKA with a range R that is no power of two jumps where the physical range wraps (to 0 or
  -- from 0)
  local red = c.profile == "lika" and not is_pow2(R) and (pos <= step or ppos <= step)
  if abs(d) > step and not red then
    -- #42: endless shaft is continuous modulo R (001_9461bb7bc8c2767b.txt:993-995)
    local o = self:hit("POSITION-DISCONTINUITY")
    if o then o.msg = fmt("position %s -> %s (step %s) exceeds the plausible %s per cycle (R=%s)", tostring(ppos),
                          tostring(pos), tostring(d), tostring(step), tostring(R)) end
  end
end

-- v = 2^k - 1 (a binary hardware range's last position); v a number below 2^53
local function is_pow2_minus1(v)
  local x = v + 1
  while x > 1 and x % 2 == 0 do x = x / 2 end
  return x == 1
end

function Checker:nist_sign(pos, ppos, nist)
  if pos == nil or ppos == nil or nist == nil or nist == 0 then
    self.nist_bad = 0
    return
  end
  local m = (pos > U32 or ppos > U32) and U64 or U32
  local d = delta(ppos, pos, m)
  if d ~= 0 and (d > 0) ~= (nist > 0) then
    self.nist_bad = self.nist_bad + 1
    if self.nist_bad >= self.nist_run then  -- in a row: not a filter lag at reversal
      -- #44: NIST sign follows the motion [INFERENCE] (001_9461bb7bc8c2767b.txt:962)
      local o = self:hit("NIST-SIGN")
      if o then o.msg = fmt("NIST=%s while the position moves by %s per cycle", tostring(nist), tostring(d)) end
    end
  else
    self.nist_bad = 0
  end
end

-- ------------------------------------------------------------------------------ preset telegrams 86/87/88/100/101/860 (§2.5, #32-34)
-- trigger bit and value of a preset word (bit 31 of _b, bit 63 of _c); {hi=, lo=} above 2^53
local function preset_word(word, top)
  if type(word) == "table" then
    if top == 63 then
      return rshift(word.hi, 31), band(word.hi, 0x7FFFFFFF) * U32 + word.lo
    end
    word = word.hi * U32 + word.lo  -- not expected for 32-bit words
  end
  if top == 63 then return 0, word end  -- a number < 2^53 has bit 63 clear
  local hi = floor(word / U32)
  local lo = word - hi * U32
  return rshift(lo, 31), band(lo, 0x7FFFFFFF) + hi * U32
end

C.preset_word = preset_word

function Checker:cycle_preset_telegram(sp, ac)
  local pw = K.preset_words[self.cfg.telegram]   -- the word and its trigger bit (cyclic.md §10)
  local sig, top = pw.signal, pw.bit
  local PT, PV = preset_word(sp[sig] or 0, top)
  local pos = ac.g1_xist1
  if pos == nil then pos = num(ac.g1_xist3) end
  local NIST = ac.nist_b
  local standstill = pos_still(self)   -- by the position: the velocity lags a stop (words.py)
  local v_before = self:speed()
  pos_push(self, pos)
  local ps = self.prev_sp
  local pPT = nil
  if ps ~= nil then pPT = preset_word(ps[sig] or 0, top) end
  local n = self.n
  local o
  if pPT == 0 and PT == 1 then
    local exp = preset_860(PV, self.R)
    if self.R ~= nil and PV >= self.R then
      -- #32: preset value below the total resolution (001_9461bb7bc8c2767b.txt:599, 612)
      o = self:hit("PRESET860-VALUE-OUT-OF-RANGE", true)
      if o then o.msg = fmt("preset value %s >= R=%s", tostring(PV), tostring(self.R)) end
    end
    if not standstill then
      -- #26: presets only at standstill (001_9461bb7bc8c2767b.txt:844)
      o = self:hit("PRESET-NOT-STANDSTILL", true)
      if o then o.msg = fmt("preset triggered while moving (positions %s, NIST=%s)", pos_list(self), NIST == nil and "None" or tostring(NIST)) end
    end
    self.p860 = {n = n, f = self.f, fc = self.fc, ts = self.ts, exp = exp, seen = false, v = v_before, last = pos}
    self.preset_done = true
  end
  local p = self.p860
  if p ~= nil then
    local m = self.R or (top == 63 and U64 or U32)
    if n > p.n and pos ~= nil and (abs(delta(p.exp, pos, m)) <= p.v * (n - p.n + 1) or (self.R == nil
        and num(pos) >= 4095 and num(pos) < num(p.exp) and is_pow2_minus1(num(pos)))) then
      -- within the motion since the trigger (§4.3 tolerance); or, the range unknown, clamped to 2^k - 1 < PV
      p.seen = true
    end
    p.last = pos
    if n - p.n >= self.D and not p.judged then
      p.judged = true
      if not p.seen then
        -- #33: absolute preset to min(PV, R-1) (001_9461bb7bc8c2767b.txt:924, 931)
        self:emit("PRESET860-WRONG", p.f, p.ts, fmt("position never showed the preset %s within D_preset=%d cycles (last %s)",
                  tostring(p.exp), self.D, tostring(pos)), self.f)
      end
    end
    if PT == 1 and n - p.n == self.D + 1 then
      -- #34: the controller resets bit 31 (001_9461bb7bc8c2767b.txt:924)
      self:emit("PRESET860-TRIGGER-HELD", p.fc, p.ts, fmt("preset trigger (bit %d) held more than %d cycles", top, self.D),
                self.fc)
    end
    if PT == 0 and p.judged then
      self.p860 = nil
    end
  end
end

function Checker:preset89(PTRIG, pPTRIG, PACK)
  local n = self.n
  if pPTRIG == 0 and PTRIG == 1 and self.prev_sp ~= nil then
    self.p89 = {n, self.f, self.ts}
  end
  local p = self.p89
  if p ~= nil then
    if PACK ~= 0 and n > p[1] then
      self.p89 = nil
    elseif n - p[1] >= self.D then
      -- #35: PS/PSM telegram 89 acknowledges in ZSW2_ENC.0 [INFERENCE] (002_d69f444daf0f8af2.txt:831, 850)
      self:emit("PRESET89-ACK-MISSING", p[2], p[3], fmt("no XIST_PRESET_ACK (ZSW2_ENC.0) within %d cycles", self.D), self.f)
      self.p89 = nil
    end
  end
end

-- ------------------------------------------------------------------------------ acyclic input (acyclic.py, §5, §9.9, §9.10)
local function v_(chk, rule, ev, msg, frame, side, last)
  if frame == nil then frame = ev.frame or 0 end
  chk:emit(rule, frame, ev.ts_ns or 0, msg, last, side)
end

local function hexbytes(s)
  -- ev.data: the record's bytes as a hex string (as in the Python event); a byte string is
  -- accepted too when it is not valid hex of even length
  local out = {}
  if type(s) ~= "string" then return out end
  if #s % 2 == 0 and not find(s, "[^0-9a-fA-F]") then
    for i = 1, #s, 2 do out[#out + 1] = tonumber(s:sub(i, i + 1), 16) end
  else
    for i = 1, #s do out[i] = s:byte(i) end
  end
  return out
end

-- #67-69 from the raw bytes, when no records decoder judged them.
local function own_bf00_checks(chk, ev, idx, d, problems)
  local c = chk.cfg
  local data = hexbytes(ev.data)
  local n = ev.length
  if n == nil then n = #data end
  if n ~= K.bf00_len then
    problems[#problems + 1] = "length " .. tostring(n)
    -- #67: 31 bytes (000_37bf2397999f1108.txt:2171)
    v_(chk, "BF00-LENGTH", ev, fmt("0x%04X written with %s bytes; expected %d", idx, tostring(n), K.bf00_len))
  end
  if c.profile == "lika" and #data >= 1 then
    local res = band(data[1], 0xC0) ~= 0
    for i = 20, math.min(31, #data) do if data[i] ~= 0 then res = true end end
    if res then
      problems[#problems + 1] = "reserved bits"
      -- #68: LIKA byte 0 bits 6-7 and bytes 19-30 are reserved (000_37bf2397999f1108.txt:2195, 2211)
      v_(chk, "BF00-RESERVED-NONZERO", ev, fmt("0xBF00 reserved content set (byte 0 = 0x%02X)", data[1]))
    end
  end
  local rng = {}
  local mupr, tmr = d.mupr, d.tmr
  if mupr ~= nil and (mupr < 1 or (truthy(c.st_phys) and mupr > c.st_phys)) then
    rng[#rng + 1] = fmt("MUPR=%s outside [1, %s]", tostring(mupr), truthy(c.st_phys) and tostring(c.st_phys) or "?")
  end
  if tmr ~= nil and (tmr < 2 or (truthy(c.st_phys) and truthy(c.mt_phys) and tmr > c.st_phys * c.mt_phys)) then
    rng[#rng + 1] = fmt("TMR=%s outside [2, %s]", tostring(tmr),
                        ((c.st_phys or 0) * (c.mt_phys or 0) ~= 0) and tostring(c.st_phys * c.mt_phys) or "?")
  end
  if d.max_master_sol_failures == 0 and c.profile ~= "psm" then
    rng[#rng + 1] = "max master sign-of-life failures = 0"
  end
  local vu = d.velocity_unit
  if vu ~= nil and vu > (c.profile == "psm" and 4 or 3) then
    rng[#rng + 1] = "velocity unit " .. tostring(vu)
  end
  if #rng > 0 then
    for _, r in ipairs(rng) do problems[#problems + 1] = r end
    -- #69: value ranges of the parameter set (000_37bf2397999f1108.txt:2395-2480)
    v_(chk, "BF00-VALUE-OUT-OF-RANGE", ev, "0xBF00 " .. table.concat(rng, "; "))
  end
end

-- #79: a request written to the PAP must be well formed (001_9461bb7bc8c2767b.txt:2013-2030)
local function bmp_request(chk, ev)
  local d = ev.decoded or {}
  if d.kind ~= "parameter request" then return end
  local bad = {}
  local rid = d.request_id
  if not (rid == 1 or rid == 2 or (isint(rid) and 0x40 <= rid and rid <= 0x7F)) then
    bad[#bad + 1] = isint(rid) and fmt("request ID 0x%02X", rid) or "request ID"
  end
  local n = d.no_of_parameters
  if isint(n) and not (1 <= n and n <= 39) then bad[#bad + 1] = fmt("%d parameters", n) end
  if (d.length or 0) > 240 then bad[#bad + 1] = fmt("length %s > 240", tostring(d.length)) end
  for _, p in ipairs(d.params or {}) do
    local a, cnt, pnu, sub = p.attribute, p.count, p.pnu, p.subindex
    if isint(a) then
      local hi = band(a, 0xF0)
      if band(a, 0x0F) ~= 0 or (hi ~= 0x10 and hi ~= 0x20 and hi ~= 0x30) then bad[#bad + 1] = fmt("attribute 0x%02X", a) end
    end
    if isint(cnt) and cnt > 234 then bad[#bad + 1] = fmt("%d elements", cnt) end
    if pnu == 0 then bad[#bad + 1] = "PNU 0" end
    if sub == 0xFFFF then bad[#bad + 1] = "subindex 0xFFFF" end
    local nv = p.no_of_values
    if rid == 2 and isint(nv) and isint(cnt) and cnt ~= 0 and nv ~= cnt then
      bad[#bad + 1] = fmt("PNU %s: %d values for %d elements", tostring(pnu), nv, cnt)
    end
  end
  if #bad > 0 then
    v_(chk, "BMP-BAD-REQUEST", ev, "parameter request: " .. table.concat(bad, "; "))
  end
end

local function record(chk, ev)
  local idx = ev.index
  if (idx == 0xB02E or idx == 0xB02F) and ev.op == "write" then
    bmp_request(chk, ev)
    return
  end
  if idx == 0x8030 and ev.op == "write" then
    -- acyclic._iso_mode_data: IsochronousModeData's ControllerApplicationCycleFactor is k (it replaces k = 1)
    local data = hexbytes(ev.data)
    if #data >= 14 and data[1] == 0x02 and data[2] == 0x04 then   -- hexbytes: a list of byte values
      local f = data[13] * 256 + data[14]
      local c = chk.cfg
      if f > 1 and not (c.sources.k or ""):find("^settings%.") then
        c.k = f
        c.sources.k = fmt("record 0x8030 ControllerApplicationCycleFactor (frame %s)", tostring(ev.frame))
        chk:apply_cfg()
      end
    end
    return
  end
  if idx == 0x1000 and ev.op == "write" and chk.cfg.profile == "scancon" and chk.velocity_filter == nil then
    chk.velocity_filter = ev.frame or 0   -- its lag is unknown: NIST-SIGN is not judged (value_rules.py)
    chk:apply_cfg()
    return
  end
  if not K.bf00_indexes[idx] or ev.op ~= "write" then return end
  if idx == 0xFFFF and chk.cfg.profile ~= "psm" then return end
  local c = chk.cfg
  local was_seen = chk.bf00_seen
  chk.bf00_seen = true
  local problems = {}
  local d = ev.decoded or {}
  if d.problems ~= nil then  -- pndiss.records already judged #67-69 (records/userparams.py)
    for _, p in ipairs(d.problems) do
      local rule = type(p) == "table" and p.rule or nil
      if rule ~= nil and K.record_rules[rule] then
        problems[#problems + 1] = p.message or rule
        v_(chk, rule, ev, fmt("0x%04X: %s", idx, tostring(p.message or rule)))
      end
    end
  else
    own_bf00_checks(chk, ev, idx, d, problems)
  end
  -- the captured parameter set is now in force (behaviour.md §2.0: re-read whenever written); what it
  -- replaces is kept until the response: a refused write wrote nothing (Checker:write_refused)
  local saved = {}
  for _, m in ipairs(BF00_MAP) do saved[#saved + 1] = {m[2], c[m[2]], c.sources[m[2]]} end
  chk.bf00_undo = {frame = ev.frame, cfg = saved, state = {chk.bf00_invalid, chk.bf00_due, chk.bf00_valid_frame,
                                                         chk.params_changed, was_seen}}
  for _, m in ipairs(#problems == 0 and BF00_MAP or {}) do   -- an invalid set is not the configuration
    if d[m[1]] ~= nil then
      c[m[2]] = toint(d[m[1]])
      c.sources[m[2]] = "captured 0xBF00 (frame " .. tostring(ev.frame) .. ")"
    end
  end
  chk:apply_cfg()
  if #problems > 0 then
    chk.bf00_invalid = table.concat(problems, "; ")
    chk.bf00_due = {chk.n + chk.D, chk.bf00_invalid, ev.frame, ev.ts_ns}   -- (+ the write: #70's trigger)
    chk.bf00_valid_frame = nil
  else
    chk.bf00_invalid = nil
    chk.bf00_due = nil
    chk.bf00_valid_frame = ev.frame
  end
  local prev = chk.prev_bf00
  if prev ~= nil and next(d) ~= nil then
    for _, k in ipairs({"direction", "code_sequence", "mupr", "tmr"}) do
      if prev[k] ~= d[k] then chk.params_changed = true; break end
    end
  end
end

-- Values arrive as ints, or as hex strings for octet-string types (records/profidrive.py).
local function as_int(v)
  if isint(v) then return v end
  if type(v) ~= "string" then return nil end
  local s = v:match("^%s*(.-)%s*$"):gsub("_", "")
  local sign = 1
  if s:sub(1, 1) == "-" then sign, s = -1, s:sub(2) elseif s:sub(1, 1) == "+" then s = s:sub(2) end
  if s:sub(1, 2):lower() == "0x" then s = s:sub(3) end
  if s == "" or find(s, "[^0-9a-fA-F]") then return nil end
  return sign * tonumber(s, 16)
end

-- acyclic.p965_version: subindex 1, or byte 1 of the whole octet string 2 at subindex 0; 0x31/0x41 count as 31/41
local function p965_version(sub, v)
  local x
  if sub == 1 then
    x = as_int(v)
  elseif sub == 0 and type(v) == "string" and #v == 4 and v:sub(1, 2):lower() == "3d" then
    x = as_int(v:sub(3))
  else
    return nil
  end
  if x == 0x31 then return 31 elseif x == 0x41 then return 41 end
  return x
end

-- #89: a read response states the parameter's own data type (001_9461bb7bc8c2767b.txt:2029, 2081-2083)
local function datatype(chk, ev, p, pnu, frame)
  if pnu == nil then return end
  local types = K.param_types[chk.cfg.profile] or K.param_types.generic
  local want = types[pnu]
  local got = p.format_name
  local names = K.format_names
  if want ~= nil and names[want] and got ~= nil and names[got] and want ~= got
      and band(p.attribute or 0x10, 0xF0) == 0x10 then
    if chk.cfg.profile == "generic" then
      for prof, t in pairs(K.param_types) do   -- acyclic._datatype: no vendor known, a vendor's own type is no fault
        if prof ~= "generic" and t[pnu] == got then return end
      end
    end
    v_(chk, "BMP-DATATYPE", ev, fmt("P%d read as %s; its data type is %s", pnu, got, want), frame)
  end
end

local function telegram_fits(chk, v, vfloat)
  if vfloat or not isint(v) or K.telegram_length[v] == nil then return false end
  for d, n in pairs(chk.io_len) do
    if K.telegram_length[v][d] ~= n then return false end
  end
  return true
end

-- vfloat: the values are floats in Python (Float32/Float64 format), never isinstance(v, int)
-- acyclic._p925: P925 tolerated master sign-of-life failures (V4.1 mode, behaviour.md §3.3 R-SOLC-3)
local function p925(chk, v, how, frame)
  if isint(v) and v > 0 and v < 0x10000 and v ~= chk.cfg.p925 then
    chk.cfg.p925 = v
    chk.cfg.sources.p925 = fmt("P925 %s (frame %s)", how, tostring(frame))
    chk:apply_cfg()
  end
end

local function read(chk, ev, p, pnu, sub, vals, frame, vfloat)
  local c = chk.cfg
  local v = vals[1]
  datatype(chk, ev, p, pnu, frame)
  if ev.do_unknown then return end   -- acyclic._read: the value may be another encoder's of the device
  local guessed = find(tostring(c.sources.telegram or ""), "length", 1, true) ~= nil
  local fits = telegram_fits(chk, v, vfloat)
  local vint = not vfloat and isint(v)
  if pnu == 922 and guessed and fits then
    -- the AR's telegram was only guessed from the lengths: P922 names it (the session relabels the map)
    c.telegram = v
    c.sources.telegram = "P922 read (frame " .. tostring(frame) .. ")"
    chk:apply_cfg()
  elseif pnu == 922 and vint and truthy(c.telegram) and v ~= c.telegram then
    if guessed then
      chk.p922_rejected = v  -- the AR's data lengths are the configuration; keep them
    end
    local lens = {}
    for d, n in pairs(chk.io_len) do lens[#lens + 1] = d .. " " .. tostring(n) .. " bytes" end
    table.sort(lens, function(a, b) return a > b end)   -- setpoint, then actual (acyclic._read)
    -- #65: P922 names the configured telegram (000_37bf2397999f1108.txt:1953-1956)
    v_(chk, "TELEGRAM-SELECTION-MISMATCH", ev, fmt("P922 reads %d; the AR runs telegram %d", v, c.telegram)
       .. (#lens > 0 and (" (data lengths: " .. table.concat(lens, ", ") .. ")") or ""), frame)
  elseif pnu == 965 and c.profile ~= "psm" and not vfloat and p965_version(sub, v) ~= nil then
    v = p965_version(sub, v)
    local exp = c.compat == 0 and 31 or 41
    if chk.compat_open and (v == 31 or v == 41) then  -- the profile version tells the mode (behaviour.md §2.2)
      c.compat = v == 31 and 0 or 1
      c.sources.compat = fmt("learnt from P965.1 = %d (frame %s)", v, tostring(frame))
      chk:apply_cfg()
    elseif v ~= exp then
      -- #75: P965.1 = 31 in V3.1 mode, 41 in V4.1 (000_37bf2397999f1108.txt:2369-2372)
      v_(chk, "P965-VERSION-MISMATCH", ev, fmt("P965.1 = %d with compatibility mode %s; expected %d", v,
         tostring(c.compat), exp), frame)
    end
  elseif pnu == 979 and sub == 3 and vint and 0 <= v and v < 32 then
    c.shift = v
    c.sources.shift = "P979.3 read (frame " .. tostring(frame) .. ")"
    chk.shift_known = true
  elseif pnu == 925 and vint then
    p925(chk, v, "read", frame)
  elseif isint(pnu) and pnu >= 980 and pnu <= 989 then   -- P980 and its continuations P981..P989
    chk.p980 = chk.p980 or {}
    for i = 1, #vals do
      local x = vals[i]
      if not vfloat and isint(x) and x ~= 0 then chk.p980[x] = true end
    end
  elseif pnu == 971 and chk.p971_pending ~= nil then
    if v == 1 then
      chk.p971_pending[2] = chk.p971_pending[2] + 1
    else
      chk.p971_pending = nil
    end
  elseif pnu == 65000 and vint then
    chk.p65000 = v
  end
end

-- #86: read-only parameters refuse changes with 0x01 (001_9461bb7bc8c2767b.txt:2041)
local function read_only(chk, ev, pnu, err, frame)
  local ro = K.read_only[chk.cfg.profile]
  if ro and pnu ~= nil and ro[pnu] and err == nil then
    v_(chk, "BMP-WRITE-RO-ACCEPTED", ev, fmt("change of read-only P%d answered positively; expected error 0x01", pnu), frame)
  end
end

local function change(chk, ev, p, pnu, sub, err, vals, frame, vfloat)
  local c = chk.cfg
  local w = p.written
  if w ~= nil and w.values ~= nil and #w.values > 0 then  -- a positive change answer has no values
    vals = w.values
    vfloat = K.float_formats[w.format] == true
  end
  if ev.do_unknown then   -- acyclic._change: a global access whose DO-ID may name another encoder of the device
    if pnu == 65000 and err == nil then chk.p65000 = nil end
    read_only(chk, ev, pnu, err, frame)
    return
  end
  if pnu == 925 and err == nil and #vals > 0 and not vfloat then p925(chk, vals[1], "written", frame) end
  if pnu == 65000 then
    local v = vals[1]
    local vint = not vfloat and isint(v)
    if not truthy(c.class4) and not C.class4_open(c) then
      -- #17: P65000 needs class 4 functionality (001_9461bb7bc8c2767b.txt:846)
      v_(chk, "PRESET-CLASS4-DISABLED", ev, "P65000 change request while class 4 functionality is off",
         ev.request_frame or frame)
      if err == nil then
        -- #91: refusal expected [AMBIGUOUS] (001_9461bb7bc8c2767b.txt:2389-2391)
        v_(chk, "BMP-CLASS4-WRITE-ACCEPTED", ev, "P65000 change accepted with class 4 functionality off", frame)
      end
    end
    local R = C.modulus(c)
    if err == nil and vint and R ~= nil and v > R then
      -- #87: P65000 greater than the range -> error 0x02 (001_9461bb7bc8c2767b.txt:847)
      v_(chk, "BMP-PRESET-LIMIT-ACCEPTED", ev, fmt("P65000=%s > R=%s accepted; expected error 0x02", tostring(v), tostring(R)), frame)
    end
    if err == nil and vint then
      chk.p65000 = v  -- R-PAR-1: stored only, no preset (001_9461bb7bc8c2767b.txt:845)
    end
  end
  read_only(chk, ev, pnu, err, frame)
  if pnu == 971 and err == nil and vals[1] ~= nil and vals[1] == 1 and c.profile == "lika" then
    chk.p971_pending = {frame, 0, ev.ts_ns or 0}
  end
end

local function param(chk, ev)
  local c = chk.cfg
  local is_change   -- request_id is the code (0x02 = change parameter); hand-made events may give the name
  if isint(ev.request_id) then is_change = ev.request_id == 2
  else is_change = find(tostring(ev.request_id_name or ev.request_id or "None"), "change", 1, true) ~= nil end
  local frame = ev.response_frame or ev.frame or 0
  if ev.request_id == nil and ev.response_id == 2 then
    chk.p65000 = nil   -- a change by a request the capture lost: P65000 may have changed (acyclic._param)
  end
  for _, prob in ipairs(ev.pairing or {}) do
    local words = lower(tostring(prob))
    for _, pr in ipairs(K.pairing_rules) do
      if find(words, pr[1], 1, true) then
        -- #76 / #81: one request at a time, mirrored header (001_9461bb7bc8c2767b.txt:1822, 1908, 1921); an
        -- overwritten request is the fault of the write that overwrote it (decided at this response)
        local at = frame
        if pr[1] == "overwritten" and ev.request_frame then at = ev.request_frame end
        v_(chk, pr[2], ev, "parameter access: " .. tostring(prob), at, nil, frame)
        break
      end
    end
  end
  local ref = ev.request_ref
  if isint(ref) then
    if ref == 0 then
      -- #77: request reference 0 is reserved (001_9461bb7bc8c2767b.txt:2013)
      v_(chk, "BMP-REQREF-ZERO", ev, "request reference 0x00 (reserved)", ev.request_frame or frame)
    elseif ref == chk.last_req_ref[ev.ar_uuid or ""] then
      -- #78: a new reference per request (001_9461bb7bc8c2767b.txt:1908) -- of the same AR
      v_(chk, "BMP-REQREF-NOT-CHANGED", ev, fmt("request reference %d repeated", ref), ev.request_frame or frame)
    end
    chk.last_req_ref[ev.ar_uuid or ""] = ref
  end
  local params = ev.params or {}
  local rid = ev.response_id
  local qid = ev.request_id_code
  if isint(qid) and not (qid == 1 or qid == 2 or (0x40 <= qid and qid <= 0x7F)) and isint(rid) then
    local has_code, code0 = false, nil
    for _, p in ipairs(params) do
      if type(p.error) == "table" then has_code, code0 = true, p.error.code; break end
    end
    if rid ~= 0x80 or (has_code and code0 ~= 0x21) then
      -- #80: an illegal request ID is answered 0x80 / error 0x21 (001_9461bb7bc8c2767b.txt:2073)
      v_(chk, "BMP-ILLEGAL-REQID-RESPONSE", ev, fmt("request ID 0x%02X answered with response ID 0x%02X", qid, rid)
         .. (has_code and (", error " .. (isint(code0) and fmt("0x%02X", code0) or tostring(code0))) or "") .. "; expected 0x80 with error 0x21", frame)
    end
  end
  if ev.decode_error then
    -- acyclic._param: its value blocks did not decode; the header is judged above, no parameter's result is known
    if is_change then
      for _, p in ipairs(params) do if p.pnu == 65000 then chk.p65000 = nil end end
    end
    return
  end
  if isint(rid) and band(rid, 0x80) == 0 then
    local any_err = false
    for _, p in ipairs(params) do if truthy(p.error) then any_err = true; break end end
    if any_err then
      -- #82: a positive response cannot carry errors (001_9461bb7bc8c2767b.txt:1914-1920)
      v_(chk, "BMP-RESPID-MISMATCH", ev, fmt("positive response ID 0x%02X with a parameter error", rid), frame)
    end
  end
  local aborted = false
  local nparams = #params
  for _, prob in ipairs(ev.pairing or {}) do   -- #84: paired by position, a block would be another parameter's
    if find(tostring(prob), "not in request order", 1, true) then return end
  end
  local neg = isint(rid) and band(rid, 0x80) ~= 0
  if neg and nparams == 1 and isint(params[1].format) and params[1].format ~= 0x44 then
    -- #83: the one block of a negative single-parameter response is the error (format 0x44, 001_...:1970-1978)
    v_(chk, "BMP-NEG-FORMAT", ev, fmt("PNU %s: negative response whose block has format 0x%02X; an error entry "
       .. "has format 0x44", tostring(params[1].pnu), params[1].format), frame)
  end
  for _, p in ipairs(params) do
    local pnu, err = p.pnu, p.error
    local sub = p.subindex
    if sub == nil then sub = 0 end
    local code = type(err) == "table" and err.code or nil
    local vals = p.values or {}
    if code ~= nil and code > 0xFF then
      -- #83: error numbers are one byte (001_9461bb7bc8c2767b.txt:2031)
      v_(chk, "BMP-NEG-FORMAT", ev, fmt("PNU %s: error number 0x%X > 0xFF", tostring(pnu), code), frame)
    elseif neg and p.format == 0x44 and p.no_of_values ~= 1 and p.no_of_values ~= 2 then
      -- #83: an error entry holds the error number and at most one more value (001_...:1970-1978)
      v_(chk, "BMP-NEG-FORMAT", ev, fmt("PNU %s: error entry with %s values; expected 1 or 2", tostring(pnu),
         tostring(p.no_of_values)), frame)
    end
    if is_change and nparams > 1 then
      if aborted and err == nil then
        -- #85: errors 0x05/0x16/0x17/0x18 abort the rest (001_9461bb7bc8c2767b.txt:2089, 2099)
        v_(chk, "BMP-MULTI-NOT-ABORTED", ev, fmt("PNU %s reported changed after an aborting error", tostring(pnu)), frame)
      end
      if code ~= nil and K.aborting_errors[code] then aborted = true end
    end
    if chk.p980 ~= nil and truthy(pnu) and not chk.p980[pnu] and not (pnu >= 980 and pnu <= 989)
        and (err == nil or code ~= 0x00) and not ev.do_unknown then
      -- #88: unknown PNU -> error 0x00 (001_9461bb7bc8c2767b.txt:2040); P980..P989 never list themselves,
      -- PNU 0 is the controller's bad request (#79)
      v_(chk, "BMP-UNKNOWN-PNU", ev, fmt("PNU %s is not in P980 but was answered ", tostring(pnu))
         .. (err == nil and "positively" or ("with error " .. (isint(code) and fmt("0x%02X", code) or tostring(code)))), frame)
    end
    local vfloat = K.float_formats[p.format] == true
    if p.attribute ~= nil and band(p.attribute, 0xF0) ~= 0x10 then
      -- a description or text (attribute 0x20 / 0x30): not the parameter's value (acyclic._value_attribute)
    elseif is_change then
      change(chk, ev, p, pnu, sub, err, vals, frame, vfloat)
    elseif err == nil and #vals > 0 then
      read(chk, ev, p, pnu, sub, vals, frame, vfloat)
    elseif code == 0x11 and pnu ~= nil and K.profile_pnus[pnu] then
      -- #92: profile parameters readable in every state (001_9461bb7bc8c2767b.txt:1830)
      v_(chk, "BMP-PROFILE-PARAM-UNREADABLE", ev, fmt("read of P%s refused with 0x11 after run-up", tostring(pnu)), frame)
    end
  end
end

-- acyclic.check_alarm: a diagnosis alarm whose channel diagnosis appears: 0x9011 reports an invalid 0xBF00 (#70)
-- or rejects a valid one (#71), and none may come while parked (#48)
function Checker:on_alarm(ev)
  self.out = nil
  if ev.alarm_type == 1 then
    local codes, n, commissioning = {}, 0, false
    for _, it in ipairs(ev.items or {}) do
      if it.channel_properties ~= nil and it.channel_properties.specifier == 1 then
        n = n + 1
        codes[#codes + 1] = fmt("0x%04X", it.channel_error_type or 0)
        if it.channel_error_type == 0x9011 then commissioning = true end
      end
    end
    if n > 0 then
      local pa = self.prev_ac   -- the last cycle's actual values: G1_ZSW.14 parked, SERR and G1_XIST2
      if commissioning then
        if self.bf00_due ~= nil then
          self.bf00_due = nil
        elseif self.bf00_valid_frame ~= nil and self.bf00_invalid == nil then
          -- #71: a valid 0xBF00 rejected; once: the cyclic rule reports it when the data already shows it
          local in_data = pa ~= nil and (pa.g1_zsw or 0) % 65536 >= 32768 and pa.g1_xist2 == K.e_param
          if not in_data then
            v_(self, "BF00-VALID-REJECTED", ev, fmt("commissioning diagnostic 0x9011 after a valid 0xBF00 (frame %s)",
                                                    tostring(self.bf00_valid_frame)))
            self.bf00_valid_frame = nil
          end
        end
      end
      if pa ~= nil and (pa.g1_zsw or 0) % 32768 >= 16384 then
        -- #48: no error reports while parked (000_37bf2397999f1108.txt:1775-1777)
        v_(self, "PARK-ERROR-REPORTED", ev, "diagnosis alarm (channel error type " .. table.concat(codes, ", ") .. ") while parked")
      end
    end
  end
  return self.out or EMPTY
end

-- acyclic.write_refused: the device refused the 0xBF00 / 0xFFFF write of request_frame; what was in force is again
function Checker:write_refused(request_frame)
  self.out = nil
  local undo = self.bf00_undo
  self.bf00_undo = nil
  if undo ~= nil and undo.frame == request_frame then
    local c = self.cfg
    for i = #undo.cfg, 1, -1 do   -- last first: code_sequence and direction share an attribute
      local a = undo.cfg[i]
      c[a[1]] = a[2]
      c.sources[a[1]] = a[3]
    end
    local st = undo.state
    self.bf00_invalid, self.bf00_due, self.bf00_valid_frame, self.params_changed = st[1], st[2], st[3], st[4]
    self:apply_cfg()
  end
  return self.out or EMPTY
end

-- A record or param event of this encoder's device, in capture order (Python event shape).
function Checker:on_record(ev)
  self.out = nil
  local kind = ev.kind
  if kind == "record" then
    record(self, ev)
  elseif kind == "param" then
    param(self, ev)
  end
  return self.out or EMPTY
end

local function end_connection(self)
  if self.params_changed and not self.preset_done and self.first_frame ~= nil then
    -- #31: new dir/MUPR/TMR need a new preset (000_37bf2397999f1108.txt:2237-2240)
    self:emit("PRESET-WITHOUT-NEW-PARAMS", self.first_frame, 0,
              "0xBF00 changed code sequence/MUPR/TMR against the previous connection and no preset followed")
  end
  local pp = self.p971_pending
  if pp ~= nil and pp[2] > 0 then
    -- #90: P971 returns to 0 once stored (000_37bf2397999f1108.txt:1977-1979)
    self:emit("P971-NOT-CONFIRMED", pp[1], pp[3], fmt("P971 still reads 1 in all %d reads after the store request", pp[2]))
    self.p971_pending = nil
  end
end

function Checker:finish()
  self.out = nil
  local pre = self.pre
  if pre ~= nil and not pre.done and pre.allowed and self.n - pre.n >= self.D then   -- else #19's window is not over
    self:emit("PRESET-ACK-MISSING", pre.f, pre.ts,
              fmt("no G1_ZSW.12 in the %d cycles after the preset request (capture ended)", self.n - pre.n), self.f)
  end
  end_connection(self)
  flush_all(self)
  return self.out or EMPTY
end

-- _state.new_connection: the same AR connected again; the ending connection's #31 and #90 are judged as at
-- the end of a capture, the next starts with what a new checker knows; counts, timeline and P65000 go on
function Checker:new_connection(prev_bf00)
  self.out = nil
  end_connection(self)
  flush_all(self)
  self:reset_history()
  self.bf00_seen = false
  self.bf00_invalid, self.bf00_valid_frame, self.bf00_due = nil, nil, nil
  self.params_changed, self.preset_done = false, false
  self.first_frame = nil
  self.prev_bf00 = prev_bf00
  self.last_req_ref = {}
  return self.out or EMPTY
end

return C
