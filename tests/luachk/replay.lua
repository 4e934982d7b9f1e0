-- Replay the calls recorded by tests/luachk/record.py through lua/pndiss_checker.lua.
--   lua5.2 replay.lua <dir of pndiss_checker.lua and pndiss_tables.lua> <ops file>
-- One op per line (a Lua table). Prints, per op index (0-based, as in Python):
--   <i>\tEV\trule,frame,last_frame,cycles,side;...   the violations a call returned (none: no line)
--   <i>\tCFG\t...                                    the configuration a 'new' built
--   <i>\tCOUNTS\t...                                 chk.counts after 'finish'
-- and checks itself that every run announced with open=true is later reported with the same
-- first frame ("ERR" lines otherwise), then "DONE".
local dir, path = arg[1], arg[2]
local T = dofile(dir .. "/pndiss_tables.lua")
local C = dofile(dir .. "/pndiss_checker.lua")
C.init(T)

local CFG_FIELDS = {"profile", "telegram", "compat", "class4", "preset_control", "scaling", "direction", "mupr", "tmr",
  "st_phys", "mt_phys", "max_master_sol_failures", "velocity_unit", "shift", "iso", "k", "l_max", "preset_deadline_ms",
  "cycle_ns", "sol_threshold_ge", "sol_monitor_rt", "max_position_step", "p65000", "p925", "sources"}

local function num(v)
  if v == nil then return "nil" end
  if type(v) == "number" then return string.format("%.17g", v) end
  return tostring(v)
end

local function cfg_text(c)
  local parts = {}
  for _, f in ipairs(CFG_FIELDS) do
    if f == "sources" then
      local keys = {}
      for k in pairs(c.sources) do keys[#keys + 1] = k end
      table.sort(keys)
      local s = {}
      for _, k in ipairs(keys) do s[#s + 1] = k .. ":" .. tostring(c.sources[k]) end
      parts[#parts + 1] = "sources=" .. table.concat(s, "|")
    else
      parts[#parts + 1] = f .. "=" .. num(c[f])
    end
  end
  return table.concat(parts, " ")
end

local chks, last_sp, last_ac = {}, {}, {}
local opened = {}     -- k .. rule .. frame -> announced runs not yet reported
local out = io.stdout
local n_open = 0

local function state(i, chk)
  out:write(i, "\tST\t", string.format("p922_rejected=%s bf00_seen=%s telegram=%s profile=%s shift=%s p65000=%s n=%s",
    num(chk.p922_rejected), tostring(chk.bf00_seen), num(chk.cfg.telegram), tostring(chk.cfg.profile), num(chk.cfg.shift),
    num(chk.p65000), num(chk.n)), "\n")
end

local function report(i, k, evs)
  local parts = {}
  for _, e in ipairs(evs) do
    if e.open then
      n_open = n_open + 1
      local key = k .. "|" .. e.rule .. "|" .. e.frame
      opened[key] = (opened[key] or 0) + 1
    else
      local key = k .. "|" .. e.rule .. "|" .. e.frame
      if (opened[key] or 0) > 0 then opened[key] = opened[key] - 1 end
      parts[#parts + 1] = string.format("%s,%s,%s,%s,%s", e.rule, num(e.frame), num(e.last_frame), num(e.cycles), e.side)
    end
  end
  if #parts > 0 then out:write(i, "\tEV\t", table.concat(parts, ";"), "\n") end
end

local i = -1
for line in io.lines(path) do
  i = i + 1
  local op = assert(load("return " .. line))()
  local k, chk = op.k, chks[op.k]
  local kind = op.op
  if kind == "new" then
    local cfg
    if op.from_settings then
      cfg = C.config_from_settings(op.settings, op.kw or {})
    else
      cfg = C.new_config(op.cfg.profile, op.cfg.telegram)
      for key, v in pairs(op.cfg) do cfg[key] = v end
      cfg.sources = op.cfg.sources or {}
    end
    chks[k] = C.new(cfg, op.info)
    last_sp[k], last_ac[k] = nil, nil
    out:write(i, "\tCFG\t", cfg_text(chks[k].cfg), "\n")
  elseif kind == "set" then
    local key = op.key
    if key:sub(1, 4) == "cfg." then
      local v = op.value
      if key == "cfg.sources" then v = v or {} end
      chk.cfg[key:sub(5)] = v
    elseif key == "io_len" then
      chk.io_len = op.value or {}
    elseif key == "prev_bf00" then
      chk.prev_bf00 = op.value
    else
      out:write("ERR\tunknown set ", key, "\n")
    end
  elseif kind == "cycle" then
    local sp = op.ssp and last_sp[k] or op.sp
    local ac = op.sac and last_ac[k] or op.ac
    last_sp[k], last_ac[k] = sp, ac
    report(i, k, chk:cycle(op.f, op.ts, sp, ac, op.spf))
  elseif kind == "gap" then
    report(i, k, chk:gap(op.f, op.ts, "not valid"))
  elseif kind == "lost" then
    report(i, k, chk:lost(op.f, op.ts, op.n))
  elseif kind == "rec" then
    report(i, k, chk:on_record(op.ev))
    state(i, chk)
  elseif kind == "finish" then
    report(i, k, chk:finish())
    state(i, chk)
    local rules = {}
    for r in pairs(chk.counts) do rules[#rules + 1] = r end
    table.sort(rules)
    local s = {}
    for _, r in ipairs(rules) do
      local c = chk.counts[r]
      s[#s + 1] = string.format("%s:%s:%s:%s", r, num(c.events), num(c.cycles), num(c.first_frame))
    end
    out:write(i, "\tCOUNTS\t", table.concat(s, " "), "\n")
  elseif kind == "apply" then
    chk:apply_cfg()
  elseif kind == "flush" then
    report(i, k, chk:flush_all())
  elseif kind == "reset" then
    chk:reset_history()
  elseif kind == "alarm" then
    report(i, k, chk:on_alarm(op.ev))
  elseif kind == "refused" then
    report(i, k, chk:write_refused(op.rf))
    state(i, chk)
  elseif kind == "newconn" then
    report(i, k, chk:new_connection(op.prev))
    state(i, chk)
  else
    out:write("ERR\tunknown op ", tostring(kind), "\n")
  end
end
for key, n in pairs(opened) do
  if n > 0 then out:write("ERR\trun announced open but never reported: ", key, "\n") end
end
out:write("OPENS\t", n_open, "\n")
out:write("DONE\t", i + 1, "\n")
