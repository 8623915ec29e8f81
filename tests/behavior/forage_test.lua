-- Feed-hunting (paper 3.1): a hungry porgy finds, approaches and eats food; hunger is a drive
-- that rises over time and falls with every meal.

-- A point `distance` ahead of the fish, kept a body length inside the tank.
---@param w shoal.TestWorld
---@param fish shoal.TestFish
---@param distance number
---@return shoal.Vec3
local function ahead(w, fish, distance)
  local p, h, tank, l = fish.pos, fish.heading, w:tank(), fish.params.l
  local q = {p[1] + math.cos(h) * distance, p[2], p[3] - math.sin(h) * distance}  ---@type shoal.Vec3
  for i = 1, 3 do
    q[i] = math.max(tank.min[i] + l, math.min(tank.max[i] - l, q[i]))
  end
  return q
end

test("hungry porgy finds food", function(t)
  local w = t:world{ seed = 7, scene = "scenes/empty_tank.lua" }
  w:spawn{ species = "black_porgy", pos = {0, 200, 0}, heading = 0, behavior = "forage" }
  local food = w:food{ pos = {150, 200, 50} }
  w:run(20)
  t:expect(food.eaten, "food eaten within 20 s")
  t:expect(food.eaten_at ~= nil and food.eaten_at < 20, "eaten_at is recorded")
end)

test("hunger rises without food and falls when eating", function(t)
  local w = t:world{ seed = 3 }
  local fish = w:spawn{ species = "black_porgy", pos = {-200, 200, 0}, heading = 0, behavior = "forage" }
  w:run(2)
  local h0 = assert(fish.memory).hunger
  t:expect(h0 ~= nil, "forage keeps hunger in memory")
  w:run(10)
  local h1 = assert(fish.memory).hunger
  t:near(h1 - h0, 0.10, 0.02, "hunger rises at 0.01 per second without food")
  local food = w:food{ pos = ahead(w, fish, 100) }
  local eaten = w:run_until(function() return food.eaten end, 15)
  t:expect(eaten, "the hungry porgy eats the pellet placed ahead of it")
  t:less(assert(fish.memory).hunger, h1 - 0.3, "a meal lowers hunger")
end)

test("a sated porgy ignores food", function(t)
  local w = t:world{ seed = 5 }
  local fish = w:spawn{ species = "black_porgy", pos = {-200, 200, 0}, heading = 0, behavior = "forage" }
  -- One meal takes hunger (0.5 at the start) below the hungry threshold; food then stays.
  local pellet = w:food{ pos = ahead(w, fish, 80) }
  t:expect(w:run_until(function() return pellet.eaten end, 10), "the first pellet is eaten")
  t:less(assert(fish.memory).hunger, 0.3, "a meal sates it")
  local ignored = w:food{ pos = ahead(w, fish, 120) }
  w:run(5)
  t:expect(not ignored.eaten, "a sated fish does not go for food")
end)

test("intention and percepts can be read", function(t)
  local w = t:world{ seed = 7 }
  local fish = w:spawn{ species = "black_porgy", pos = {0, 200, 0}, heading = 0, behavior = "forage" }
  t:expect(fish.intention == nil, "no intention before the first decision")
  w:food{ pos = {150, 200, 50} }
  w:run(1)
  t:expect(fish.intention == "eat", "a hungry porgy that sees food intends to eat, got "
    .. tostring(fish.intention))
  t:expect(fish.percepts ~= nil and fish.percepts.food_id ~= nil, "its percepts hold the food")
  t:near(assert(fish.percepts).food_x, 150, 1e-3, "the food it perceived is the one there is")
end)

test("a hungry porgy catches a pellet sinking past it", function(t)
  local w = t:world{ seed = 11, food = { sink_speed = 10 } }
  local fish = w:spawn{ species = "black_porgy", pos = {-150, 150, 0}, heading = 0, behavior = "forage" }
  -- Ahead and 150 units up: the porgy arrives under the pellet before it has sunk to its depth,
  -- and must rise to it rather than turn circles under it.
  local pellet = w:food{ pos = {0, 300, 0} }
  t:expect(w:run_until(function() return pellet.eaten end, 20), "the sinking pellet is eaten")
  t:greater(pellet.pos[2], 100, "caught in mid-water, not on the floor")
  t:expect(assert(fish.memory).meals == 1, "the porgy counts the meal")
end)

test("a pellet nobody eats settles and dissolves", function(t)
  local w = t:world{ seed = 12, food = { sink_speed = 40, lifetime = 15 } }
  local pellet = w:food{ pos = {0, 300, 0} }
  w:run(10)
  t:expect(pellet.settled, "on the floor after 10 s")
  t:near(pellet.pos[2], w:tank().min[2], 1e-3, "resting on the floor")
  w:run(6)
  t:expect(pellet.dissolved and not pellet.eaten, "dissolved uneaten after 15 s")
end)
