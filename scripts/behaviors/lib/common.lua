-- Shared pieces of the shipped behaviours: drives (after Tu & Terzopoulos, "Artificial Fishes",
-- 1994) and the reflexes every behaviour runs first (escape, collision avoidance).
--
-- Drives live in fish.memory so they persist across ticks and reloads:
--   hunger in [0, 1]: rises at HUNGER_RATE per second, falls by MEAL per pellet eaten.
--   fear   in [0, 1]: FEAR_RANGE / distance to the nearest predator seen, decaying when none is.

local shoal = shoal
local C = {}

C.HUNGER_RATE = 0.01   -- per second: from sated to starving in 100 s
C.MEAL = 0.4           -- hunger removed by one pellet
C.HUNGRY = 0.3         -- above this, food in sight wins over crowding/wandering
C.FEAR_LENGTHS = 6     -- a predator within this many body lengths is frightening
C.FEAR_DECAY = 0.5     -- per second, once no predator is seen

-- Seconds since this fish's previous decision (0 on its first).
function C.elapsed(fish)
  local m = fish.memory
  local now = shoal.time()
  local dt = m.last_time and (now - m.last_time) or 0
  m.last_time = now
  return dt
end

-- Updates hunger; returns it.
function C.hunger(fish, dt)
  local m = fish.memory
  local h = (m.hunger or 0.5) + C.HUNGER_RATE * dt
  if h > 1 then h = 1 end
  m.hunger = h
  return h
end

-- Updates fear from the distance to the nearest predator seen (nil: none); returns it.
function C.fear(fish, distance, dt)
  local m = fish.memory
  local f = (m.fear or 0) - C.FEAR_DECAY * dt
  if distance then
    local length = shoal.species().length
    local f_now = C.FEAR_LENGTHS * length / math.max(distance, 1e-3)
    if f_now > f then f = f_now end
  end
  if f < 0 then f = 0 elseif f > 1 then f = 1 end
  m.fear = f
  return f
end

-- Fills p.avoid_* with an avoidance manoeuvre when a rock or a wall is close; returns whether.
function C.sense_collision(p)
  local h, d, s = shoal.avoid_obstacles()
  if not h then h, d, s = shoal.avoid_walls() end
  p.avoid_heading, p.avoid_depth, p.avoid_speed = h, d, s
  return h ~= nil
end

-- Key names per prefix, built once (no string concatenation per decision).
local KEYS = setmetatable({}, { __index = function(t, prefix)
  local k = { id = prefix .. "_id", x = prefix .. "_x", y = prefix .. "_y", z = prefix .. "_z",
              distance = prefix .. "_distance", heading = prefix .. "_heading",
              speed = prefix .. "_speed" }
  t[prefix] = k
  return k
end })

-- Copies the fields of a (reused) percept table into p under a prefix, or clears them.
function C.keep(p, prefix, percept)
  local k = KEYS[prefix]
  if percept then
    p[k.id] = percept.id
    p[k.x], p[k.y], p[k.z] = percept.x, percept.y, percept.z
    p[k.distance] = percept.distance
    p[k.heading] = percept.heading
    p[k.speed] = percept.speed
  else
    p[k.id] = nil
    p[k.distance] = nil
  end
end

-- Escape: flat out away from the predator.
function C.escape(p)
  shoal.steer(shoal.flee(p.predator_x, p.predator_y, p.predator_z))
end

-- Go for the food in p; eat it when within reach. Returns true if it ate.
function C.feed(fish, p)
  local ate = false
  if p.food_distance < 0.5 * shoal.species().length then
    ate = shoal.eat(p.food_id)
    if ate then
      local m = fish.memory
      m.hunger = math.max(0, (m.hunger or 0) - C.MEAL)
      m.meals = (m.meals or 0) + 1
    end
  end
  if not ate then
    shoal.steer(shoal.arrive(p.food_x, p.food_y, p.food_z))
  end
  return ate
end

-- Wander, slowly changing heading and depth.
function C.wander(turn)
  shoal.steer(shoal.wander(turn))
end

return C
