-- Whatever their scripts do, fish stay in the tank and never pass through a rock.

local function inside(tank, p, margin)
  return p[1] >= tank.min[1] - margin and p[1] <= tank.max[1] + margin
     and p[2] >= tank.min[2] - margin and p[2] <= tank.max[2] + margin
     and p[3] >= tank.min[3] - margin and p[3] <= tank.max[3] + margin
end

test("no fish leaves the tank", function(t)
  local w = t:world{ seed = 31 }
  local tank = w:tank()
  local fishes = {}
  local behaviors = {"wander", "school", "forage"}
  for i = 1, 15 do
    fishes[i] = w:spawn{
      species = "black_porgy",
      pos = {-400 + i * 50, 50 + (i % 5) * 70, -200 + (i % 4) * 120},
      heading = i * 1.3,
      behavior = behaviors[i % 3 + 1],
    }
  end
  -- And one with no mind at all, swimming flat out at a wall.
  local rammer = w:spawn{ species = "black_porgy", pos = {300, 200, 0}, heading = 0 }
  rammer:swim(150)
  fishes[#fishes + 1] = rammer
  local escaped = w:run_until(function()
    for _, f in ipairs(fishes) do
      if not inside(tank, f.pos, 1e-3) then return true end
    end
    return false
  end, 60)
  t:expect(not escaped, "every fish inside the tank for 60 s")
end)

test("no fish goes through an obstacle", function(t)
  local w = t:world{ seed = 32 }
  local rock = {0, 200, 0}
  local radius = 80
  w:obstacle{ pos = rock, radius = radius }
  local avoider = w:spawn{ species = "black_porgy", pos = {-350, 200, 10}, heading = 0, behavior = "wander" }
  local rammer = w:spawn{ species = "black_porgy", pos = {-350, 200, -10}, heading = 0 }
  rammer:swim(100)
  local function dist(f)
    local p = f.pos
    return math.sqrt((p[1] - rock[1])^2 + (p[2] - rock[2])^2 + (p[3] - rock[3])^2)
  end
  local closest = math.huge
  local crossed = w:run_until(function()
    for _, f in ipairs({avoider, rammer}) do
      local d = dist(f)
      if d < closest then closest = d end
      if d < radius - 1e-3 then return true end
    end
    return false
  end, 15)
  t:expect(not crossed, "no fish inside the rock")
  t:less(closest, radius + 20, "the rammer really did reach the rock")
end)
