-- Every motion of the paper's motion layer, driven directly (no behaviour) and measured.

local function wrap(a)
  return (a + math.pi) % (2 * math.pi) - math.pi
end

-- Runs until `fish` has started the motion `name` and then finished it (bounded by `max` s).
---@param w shoal.TestWorld
---@param fish shoal.TestFish
---@param name string
---@param max? number
---@return boolean finished, number time
local function play(w, fish, name, max)
  w:run_until(function() return fish.motion == name end, 1)
  return w:run_until(function() return fish.motion ~= name end, max or 15)
end

---@param w shoal.TestWorld
---@param heading? number
---@return shoal.TestFish
local function swimmer(w, heading)
  local fish = w:spawn{ species = "black_porgy", pos = {-300, 200, 0}, heading = heading or 0 }
  fish:swim(fish.params.s)
  w:run(1)
  return fish
end

test("a quick turn reverses heading within its turn time", function(t)
  local w = t:world{ seed = 41 }
  local fish = swimmer(w)
  local h0 = fish.heading
  local tt = fish.params.tt
  fish:turn("quick", 180, "left")
  w:run(tt * 1.25)
  t:near(math.abs(wrap(fish.heading - h0)), math.pi, 0.1 * math.pi, "heading reversed")
end)

test("a quick turn halts while turning", function(t)
  local w = t:world{ seed = 42 }
  local fish = swimmer(w)
  local s = fish.params.s
  fish:turn("quick", 120, "right")
  local slowest = math.huge
  w:run_until(function()
    if fish.speed < slowest then slowest = fish.speed end
    return false
  end, fish.params.tt)
  t:less(slowest, 0.5 * s, "speed drops below half the cruise speed during a quick turn")
end)

test("a serial turn keeps moving forward", function(t)
  local w = t:world{ seed = 43 }
  local fish = swimmer(w)
  local h0 = fish.heading
  local s = fish.params.s
  fish:turn("serial", 90, "right")
  local slowest = math.huge
  local p0 = fish.pos
  w:run_until(function() return fish.motion == "serial_turn" end, 1)
  local t0 = w.time
  w:run_until(function()
    if fish.speed < slowest then slowest = fish.speed end
    return fish.motion ~= "serial_turn"
  end, 15)
  local took = w.time - t0
  t:greater(slowest, 0.5 * s, "speed stays above half the cruise speed")
  local p1 = fish.pos
  local moved = math.sqrt((p1[1] - p0[1])^2 + (p1[3] - p0[3])^2)
  t:greater(moved, 0.5 * s * took, "the fish travels on while turning")
  t:near(wrap(fish.heading - h0), -math.pi / 2, 0.1 * math.pi / 2, "heading changed by 90° to the right")
end)

test("a normal turn lands on its angle on both sides", function(t)
  for _, case in ipairs({ {"left", 1}, {"right", -1} }) do
    local w = t:world{ seed = 44 }
    local fish = swimmer(w)
    local h0 = fish.heading
    fish:turn("normal", 60, case[1])
    t:expect(play(w, fish, "normal_turn"), "the normal turn completes")
    t:near(wrap(fish.heading - h0), case[2] * math.rad(60), 0.1 * math.rad(60),
      "normal turn of 60° to the " .. case[1])
  end
end)

test("ascent and descent reach the asked depth", function(t)
  local w = t:world{ seed = 45 }
  local fish = swimmer(w)
  local d0 = fish.depth
  fish:ascend(100)
  t:expect(play(w, fish, "ascend"), "the ascent completes")
  t:near(d0 - fish.depth, 100, 5, "ascended 100 units")
  local d1 = fish.depth
  fish:descend(80)
  t:expect(play(w, fish, "descend"), "the descent completes")
  t:near(fish.depth - d1, 80, 4, "descended 80 units")
  t:near(fish.pitch, 0, 0.05, "levelled out afterwards")
end)

test("stop halts and accelerate reaches the new speed", function(t)
  local w = t:world{ seed = 46 }
  local fish = swimmer(w)
  fish:stop(1)
  w:run(2)
  t:less(fish.speed, 0.05 * fish.params.s, "stopped")
  fish:accelerate(80, 1.5)
  w:run(2.5)
  t:near(fish.speed, 80, 4, "accelerated to 80 units/s")
end)
