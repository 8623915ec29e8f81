-- A predator that hunts porgies: patrols at cruise speed; when hungry and a porgy is in sight it
-- chases it flat out (aiming where the prey will be), "catches" it when within half a body
-- length (the prey is not removed: shoal's fish are scenery), then rests until hungry again.
local shoal = shoal
local common = require("behaviors.lib.common")

local M = {}

M.PREY = "black_porgy"
M.REST_SECONDS = 8
M.LEAD_SECONDS = 0.5

function M.perceive(fish)
  local p = common.begin(fish)
  common.keep(p, "prey", shoal.nearest("fish", M.PREY))
  common.sense_collision(p)
  return p
end

function M.intend(fish, p)
  local m = fish.memory
  local dt = common.elapsed(fish)
  common.hunger(fish, dt)
  if common.avoiding(fish, p, "rock") or common.avoiding(fish, p, "wall") then
    return "avoid"
  end
  if m.rest_until and common.cur.now < m.rest_until then return "rest" end
  if p.prey_id and m.hunger > 0.2 then return "hunt" end
  return "patrol"
end

function M.behave(fish, intention, p)
  local m = fish.memory
  if intention == "avoid" then
    common.avoid(fish)
  elseif intention == "hunt" then
    local me = common.cur.me
    if p.prey_distance < 0.5 * me.length then
      m.catches = (m.catches or 0) + 1
      m.hunger = 0
      m.rest_until = common.cur.now + M.REST_SECONDS
      common.wander(fish, 1.5)
      return
    end
    -- lead the target: where it will be in LEAD_SECONDS
    local lead = M.LEAD_SECONDS * (p.prey_speed or 0)
    local x = p.prey_x + math.cos(p.prey_heading or 0) * lead
    local z = p.prey_z - math.sin(p.prey_heading or 0) * lead
    shoal.steer(shoal.seek(x, p.prey_y, z, me.max_speed))
  elseif intention == "rest" then
    common.wander(fish, 0.3)
  else
    common.wander(fish, 0.5)
  end
end

return M
