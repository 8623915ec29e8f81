-- Crowding (paper section 3.1): keep a body length from neighbours (separation), swim the way
-- they swim (alignment) and stay with the group (cohesion). Hungry fish break off for food in
-- sight; a predator scatters the school; rocks and walls are avoided first.
local shoal = shoal
local common = require("behaviors.lib.common")

local M = {}

M.SEPARATION = 1.5
M.ALIGNMENT = 1.0
M.COHESION = 0.6

function M.perceive(fish)
  local p = fish.percepts or {}
  common.keep(p, "food", shoal.nearest("food"))
  common.keep(p, "predator", shoal.nearest("predator"))
  common.sense_collision(p)
  return p
end

function M.intend(fish, p)
  local dt = common.elapsed(fish)
  local hunger = common.hunger(fish, dt)
  local fear = common.fear(fish, p.predator_distance, dt)
  if p.predator_id and fear > 0.5 then return "flee" end
  if p.avoid_heading then return "avoid" end
  if hunger > 0.7 and p.food_id then return "eat" end
  return "school"
end

function M.behave(fish, intention, p)
  if intention == "flee" then
    common.escape(p)
  elseif intention == "avoid" then
    shoal.steer(p.avoid_heading, p.avoid_depth, p.avoid_speed)
  elseif intention == "eat" then
    common.feed(fish, p)
  else
    local hs, ds, ss = shoal.separation()
    local ha, da, sa = shoal.alignment()
    local hc, dc, sc = shoal.cohesion()
    local h, d, s = shoal.blend(hs, ds, ss, M.SEPARATION,
                                ha, da, sa, M.ALIGNMENT,
                                hc, dc, sc, M.COHESION)
    if h then
      shoal.steer(h, d, s)
    else
      common.wander()   -- alone: look for the others
    end
  end
end

return M
