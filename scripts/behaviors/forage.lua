-- Feed-hunting (paper section 3.1): find food, approach it, eat it. Hunger rises over time and
-- falls with every pellet; a sated fish wanders, a hungry one searches with wider turns.
-- Priorities (intention layer): rocks > predator > walls > food > wandering. Walls rank below
-- food so pellets floating near the surface can be reached (the tank itself stops the fish).
local shoal = shoal
local common = require("behaviors.lib.common")

local M = {}

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
  if fear > common.AFRAID then return "flee" end
  if hunger > common.HUNGRY and p.food_id then return "eat" end
  if common.avoiding(fish, p, "wall") then return "avoid" end
  if hunger > common.HUNGRY then return "search" end
  return "wander"
end

function M.behave(fish, intention, p)
  if intention == "flee" then
    common.escape(fish)
  elseif intention == "avoid" then
    common.avoid(fish)
  elseif intention == "eat" then
    common.feed(fish, p)
  elseif intention == "search" then
    common.wander(fish, 1.2)
  else
    common.wander(fish)
  end
end

return M
