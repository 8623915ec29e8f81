-- Feed-hunting (paper section 3.1): find food, approach it, eat it. Hunger rises over time and
-- falls with every pellet; a sated fish wanders, a hungry one searches with wider turns.
-- Escape from a predator and collision avoidance come first.
local shoal = shoal
local common = require("behaviors.lib.common")

local M = {}

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
  if hunger > common.HUNGRY then
    if p.food_id then return "eat" end
    return "search"
  end
  return "wander"
end

function M.behave(fish, intention, p)
  if intention == "flee" then
    common.escape(p)
  elseif intention == "avoid" then
    shoal.steer(p.avoid_heading, p.avoid_depth, p.avoid_speed)
  elseif intention == "eat" then
    common.feed(fish, p)
  elseif intention == "search" then
    common.wander(1.2)
  else
    common.wander()
  end
end

return M
