-- Crowding (paper section 3.1): keep a body length from neighbours (separation), swim the way
-- they swim (alignment) and stay with the group (cohesion). Hungry fish break off for food in
-- sight; a predator scatters the school (a wall ahead of a fleeing fish comes first); rocks are
-- avoided before anything else.
local shoal = shoal
local common = require("behaviors.lib.common")

local M = {}

-- weights of the three crowding rules, and their radii in body lengths
M.SEPARATION, M.SEPARATION_RADIUS = 1.0, 1.0
M.ALIGNMENT, M.ALIGNMENT_RADIUS = 2.0, 4.0
M.COHESION, M.COHESION_RADIUS = 1.0, 6.0

function M.perceive(fish)
  local p = common.begin(fish)
  common.keep(p, "food", shoal.nearest("food"))
  common.keep(p, "predator", shoal.nearest("predator"))
  common.sense_collision(p)
  return p
end

function M.intend(fish, p)
  local dt = common.elapsed(fish)
  local hunger = common.hunger(fish, dt)
  local fear = common.fear(fish, p, dt)
  if common.avoiding(fish, p, "rock") then return "avoid" end
  if fear > common.AFRAID then
    -- Fleeing straight from a predator runs a fish into the glass: a wall ahead comes first.
    if common.avoiding(fish, p, "wall") then return "avoid" end
    return "flee"
  end
  if hunger > 0.7 and p.food_id then return "eat" end
  if common.avoiding(fish, p, "wall") then return "avoid" end
  return "school"
end

function M.behave(fish, intention, p)
  if intention == "flee" then
    common.escape(fish)
  elseif intention == "avoid" then
    common.avoid(fish, true)   -- smooth turns: the school wheels together
  elseif intention == "eat" then
    common.feed(fish, p)
  else
    -- The three rules in one pass over the neighbours (the same as shoal.blend of
    -- shoal.separation, shoal.alignment and shoal.cohesion, each with its own radius).
    local l = common.cur.me.length
    local h, d, s = shoal.crowd(M.SEPARATION_RADIUS * l, M.SEPARATION,
                                M.ALIGNMENT_RADIUS * l, M.ALIGNMENT,
                                M.COHESION_RADIUS * l, M.COHESION)
    if h then
      shoal.steer(h, d, s)
    else
      common.wander(fish)   -- alone: look for the others
    end
  end
end

return M
