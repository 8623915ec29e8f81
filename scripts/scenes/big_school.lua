-- The big school: 10,000 black porgies in a tank sized for them (8 body lengths³ of water per
-- fish, the density `shoal bench sim` measures at), with foragers, eels near the floor, a few
-- barracuda hunting through the school, and food dropped at the surface. Open it to see what a
-- school of this size does, or compare behaviour changes at scale:
--   shoal run --scene big_school
--   shoal compare --scene big_school --seeds 8 --seconds 20 ...
---@type shoal.Scene
local scene = {
  -- 72 x 32 x 36 porgy body lengths (a porgy is 50 units long); y is up, the surface is max.y.
  tank = { min = { -1800, 0, -900 }, max = { 1800, 1600, 900 } },

  fish = {
    { species = "black_porgy", count = 9000, behavior = "school",
      region = { min = { -1500, 300, -700 }, max = { 1500, 1300, 700 } } },
    { species = "black_porgy", count = 960, behavior = "forage",
      region = { min = { -1600, 200, -800 }, max = { 1600, 1400, 800 } } },
    { species = "eel", count = 32, behavior = "wander",
      region = { min = { -1600, 30, -800 }, max = { 1600, 90, 800 } } },
    { species = "barracuda", count = 8, behavior = "predator",
      region = { min = { -1700, 400, -800 }, max = { -1400, 1200, 800 } } },
  },

  food_sink_speed = 12,
  food_lifetime = 90,
  food_drops = { every = 4, count = 40, start = 2,
                 region = { min = { -1500, 1560, -700 }, max = { 1500, 1590, 700 } } },

  obstacles = {
    { pos = { 900, 120, -400 }, radius = 150 },
    { pos = { -1000, 100, 450 }, radius = 120 },
    { pos = { 0, 80, 0 }, radius = 100 },
  },

  currents = {
    { pos = { 0, 800, 0 }, radius = 500, velocity = { 10, 0, 0 } },
  },
}
return scene
