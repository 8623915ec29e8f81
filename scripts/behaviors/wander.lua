-- Wander: cruise about the tank, avoiding rocks and walls.
local common = require("behaviors.lib.common")

local M = {}

function M.perceive(fish)
  local p = common.begin(fish)
  common.sense_collision(p)
  return p
end

function M.intend(fish, p)
  if common.avoiding(fish, p, "rock") or common.avoiding(fish, p, "wall") then
    return "avoid"
  end
  return "wander"
end

function M.behave(fish, intention)
  if intention == "avoid" then
    common.avoid(fish)
  else
    common.wander(fish)
  end
end

return M
