-- A broken script hurts only the fish running it, and live edits keep what fish remember.

test("a script error in one fish does not stop the others", function(t)
  -- The error is the point of this test: allow it, then check it was reported.
  local w = t:world{ seed = 51, scratch = true, allow_errors = true }
  w:write_script("behaviors/broken.lua", [[
local M = {}
function M.behave(fish)
  error("this behaviour is broken on purpose")
end
return M
]])
  local bad = w:spawn{ species = "black_porgy", pos = {-200, 200, -100}, heading = 0, behavior = "broken" }
  w:spawn{ species = "black_porgy", pos = {-200, 200, 100}, heading = 0, behavior = "forage" }
  local food = w:food{ pos = {-50, 200, 120} }
  w:run(15)
  t:expect(food.eaten, "the healthy fish still forages")
  local errors = w:errors()
  t:expect(#errors >= 1, "the error is reported")
  local named = false
  for _, e in ipairs(errors) do
    if e:find("broken.lua:3", 1, true) then named = true end
  end
  t:expect(named, "the report names broken.lua line 3")
  t:greater(bad.speed, 0, "the broken fish keeps its last motion")
end)

test("reload keeps memory and picks up the new code", function(t)
  -- It counts the probe's decisions, which level of detail cuts far from a focus: the focus on
  -- the probe keeps it at full rate under `shoal test --lod on` too.
  local w = t:world{ seed = 52, scratch = true, focus = {0, 200, 0} }
  w:write_script("behaviors/counter.lua", [[
local M = {}
function M.behave(fish)
  fish.memory.count = (fish.memory.count or 0) + 1
  fish.memory.version = 1
end
return M
]])
  local fish = w:spawn{ species = "black_porgy", pos = {0, 200, 0}, heading = 0, behavior = "counter" }
  w:run(2)
  local before = assert(fish.memory).count
  t:greater(before, 5, "the counter ran for two seconds")
  w:write_script("behaviors/counter.lua", [[
local M = {}
function M.behave(fish)
  fish.memory.count = (fish.memory.count or 0) + 1
  fish.memory.version = 2
end
return M
]])
  w:run(1)
  t:greater(assert(fish.memory).count, before, "memory survived the reload and kept counting")
  t:expect(assert(fish.memory).version == 2, "the new code runs")
end)

test("a reload that fails keeps the last good version", function(t)
  local w = t:world{ seed = 53, scratch = true, allow_errors = true }
  w:write_script("behaviors/steady.lua", [[
local M = {}
function M.behave(fish) fish.memory.ticks = (fish.memory.ticks or 0) + 1 end
return M
]])
  local fish = w:spawn{ species = "black_porgy", pos = {0, 200, 0}, heading = 0, behavior = "steady" }
  w:run(1)
  local result = w:write_script("behaviors/steady.lua", "local M = {\nfunction M.behave(\nreturn M\n")
  t:expect(result:find("steady.lua", 1, true) ~= nil, "the failed reload names the file: " .. result)
  local before = assert(fish.memory).ticks
  w:run(1)
  t:greater(assert(fish.memory).ticks, before, "the old version keeps running")
  local errors = w:errors()
  t:expect(#errors == 1 and errors[1]:find("steady.lua", 1, true) ~= nil,
    "the failed reload is the one script error: " .. table.concat(errors, "; "))
end)
