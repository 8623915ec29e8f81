-- Escape: when a predator comes within the fear range, swim away from where it was last seen at
-- top speed until the fear wears off; otherwise wander. Rocks are avoided first; walls give way
-- to fear (the tank itself stops a fish fleeing into one).
local shoal = shoal
local common = require("behaviors.lib.common")

local M = {}

function M.perceive(fish)
  local p = common.begin(fish)
  common.keep(p, "predator", shoal.nearest("predator"))
  common.sense_collision(p)
  return p
end

function M.intend(fish, p)
  local dt = common.elapsed(fish)
  local fear = common.fear(fish, p, dt)
  if common.avoiding(fish, p, "rock") then return "avoid" end
  if fear > common.AFRAID then return "flee" end
  if common.avoiding(fish, p, "wall") then return "avoid" end
  return "wander"
end

function M.behave(fish, intention)
  if intention == "flee" then
    common.escape(fish)
  elseif intention == "avoid" then
    common.avoid(fish)
  else
    common.wander(fish)
  end
end

return M
