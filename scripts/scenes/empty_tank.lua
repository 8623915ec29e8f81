-- An empty tank for tests: 20 x 8 x 12 black porgy body lengths (l = 50), no fish, no food.
---@type shoal.Scene
local scene = {
  tank = { min = { -500, 0, -300 }, max = { 500, 400, 300 } },
}
return scene
