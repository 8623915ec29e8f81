-- Escape: when a predator comes within the fear range, swim away from it at top speed;
-- otherwise wander. Collision avoidance still wins over wandering.
local shoal = shoal
local common = require("behaviors.lib.common")

local M = {}

function M.perceive(fish)
  local p = fish.percepts or {}
  common.keep(p, "predator", shoal.nearest("predator"))
  common.sense_collision(p)
  return p
end

function M.intend(fish, p)
  local dt = common.elapsed(fish)
  local fear = common.fear(fish, p.predator_distance, dt)
  if p.predator_id and fear > 0.3 then return "flee" end
  if p.avoid_heading then return "avoid" end
  return "wander"
end

function M.behave(fish, intention, p)
  if intention == "flee" then
    common.escape(p)
  elseif intention == "avoid" then
    shoal.steer(p.avoid_heading, p.avoid_depth, p.avoid_speed)
  else
    common.wander()
  end
end

return M
