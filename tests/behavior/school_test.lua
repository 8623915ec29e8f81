-- Crowding (paper 3.1): porgies that start facing every which way form an aligned school and keep
-- about a body length apart.

---@param w shoal.TestWorld
---@param n integer
---@return shoal.TestFish[]
local function spawn_school(w, n)
  local fishes = {} ---@type shoal.TestFish[]
  for i = 1, n do
    local row, col = (i - 1) // 4, (i - 1) % 4
    fishes[i] = w:spawn{
      species = "black_porgy",
      pos = {-150 + col * 90, 170 + (i % 3) * 30, -120 + row * 90},
      heading = (i * 2.4) % (2 * math.pi),   -- spread round the compass
      behavior = "school",
    }
  end
  return fishes
end

test("a school's polarization rises above 0.8", function(t)
  -- Open water (a tank 80 body lengths across), so the measure is of schooling, not of wheeling
  -- at the walls.
  local w = t:world{ seed = 11, tank = { min = {-2000, 0, -2000}, max = {2000, 400, 2000} } }
  local fishes = spawn_school(w, 12)
  t:less(w:polarization(fishes), 0.5, "headings start spread out")
  local aligned = w:run_until(function() return w:polarization(fishes) > 0.8 end, 30)
  t:expect(aligned, "polarization above 0.8 within 30 s")
  w:run(5)
  t:greater(w:polarization(fishes), 0.8, "and it stays aligned")
end)

test("schooling fish keep about a body length apart", function(t)
  local w = t:world{ seed = 12 }
  local fishes = spawn_school(w, 12)
  w:run(25)
  local l = fishes[1].params.l
  local mean = w:nearest_distance(fishes)
  t:greater(mean, 0.5 * l, "mean nearest-neighbour distance at least half a body length")
  t:less(mean, 2.5 * l, "mean nearest-neighbour distance at most 2.5 body lengths")
  t:greater(w:min_distance(fishes), 0.25 * l, "no two fish overlap")
end)

test("a schooling porgy chased towards the glass turns along it instead of ramming it", function(t)
  local w = t:world{ seed = 23 }
  local tank = w:tank()
  -- Near the +x wall, a barracuda behind and to one side: fleeing straight from it is fleeing
  -- into the glass.
  local prey = w:spawn{ species = "black_porgy", pos = {tank.max[1] - 220, 200, 0}, heading = 0,
                        behavior = "school" }
  local shark = w:spawn{ species = "barracuda", pos = {tank.max[1] - 350, 200, -100}, heading = 0.6 }
  shark:swim(40)
  local closest, fear = math.huge, 0
  w:run_until(function()
    closest = math.min(closest, tank.max[1] - prey.pos[1])
    fear = math.max(fear, prey.memory and prey.memory.fear or 0)
    return false
  end, 8)
  t:greater(fear, 0.5, "the prey was frightened")
  t:greater(closest, 0.25 * prey.params.l, "kept a quarter body length from the glass")
end)
