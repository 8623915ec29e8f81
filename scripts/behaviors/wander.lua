-- Wander: cruise about the tank, avoiding rocks and walls.
local shoal = shoal
local common = require("behaviors.lib.common")

local M = {}

function M.perceive(fish)
  local p = fish.percepts or {}
  common.sense_collision(p)
  return p
end

function M.intend(fish, p)
  if p.avoid_heading then return "avoid" end
  return "wander"
end

function M.behave(fish, intention, p)
  if intention == "avoid" then
    shoal.steer(p.avoid_heading, p.avoid_depth, p.avoid_speed)
  else
    common.wander()
  end
end

return M
