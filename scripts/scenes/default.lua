-- The default aquarium: a school of black porgies crowding in mid-water, food dropped in at the
-- surface every few seconds that sinks slowly through the school (hungry porgies break off to eat
-- it; what nobody eats settles on the floor and dissolves), two eels wandering near the floor,
-- and a barracuda patrolling that hunts porgies and scatters the school as it passes.
-- Edit and save: the panel offers to restart the scene.
---@type shoal.Scene
local scene = {
  -- 20 x 8 x 12 porgy body lengths; y is up, the surface is max.y.
  tank = { min = { -500, 0, -300 }, max = { 500, 400, 300 } },

  fish = {
    { species = "black_porgy", count = 30, behavior = "school",
      region = { min = { -200, 150, -120 }, max = { 200, 260, 120 } } },
    { species = "black_porgy", count = 4, behavior = "forage",
      region = { min = { -350, 100, -200 }, max = { 350, 300, 200 } } },
    { species = "eel", count = 2, behavior = "wander",
      region = { min = { -400, 30, -200 }, max = { 400, 80, 200 } } },
    { species = "barracuda", count = 1, behavior = "predator",
      pos = { -420, 200, 0 }, heading = 0 },
  },

  food = { { 0, 380, 0 } },
  food_sink_speed = 12,   -- units/s: about half a minute from the surface to the floor
  food_lifetime = 90,     -- seconds before an uneaten pellet dissolves
  food_drops = { every = 5, count = 3, start = 3,
                 region = { min = { -300, 370, -200 }, max = { 300, 385, 200 } } },

  obstacles = {
    { pos = { 250, 60, -120 }, radius = 60 },
    { pos = { -280, 40, 150 }, radius = 45 },
  },

  currents = {
    { pos = { 0, 200, 0 }, radius = 150, velocity = { 8, 0, 0 } },
  },

  -- The scene's own measures (docs/measures.md): each is called once per simulated second for
  -- every fish, with the fish's table and the shoal sensors answering for it; `shoal compare` and
  -- a test's `w:measure(NAME)` report the mean over fish and samples. Return nil to leave a fish
  -- out; true and false count as 1 and 0.
  measures = {
    -- How far the nearest predator a porgy sees is, in porgy body lengths (porgies seeing one).
    predator_distance_l = function(fish)
      if fish.species ~= "black_porgy" then return nil end
      local p = shoal.nearest("predator")
      if p == nil then return nil end
      return p.distance / shoal.species().length
    end,
    -- The share of porgies whose last decision was to flee.
    fleeing = function(fish)
      if fish.species ~= "black_porgy" then return nil end
      return fish.intention == "flee"
    end,
  },
}
return scene
