-- Shared pieces of the shipped behaviours: drives (after Tu & Terzopoulos, "Artificial Fishes",
-- 1994), reflexes every behaviour runs first (collision avoidance, escape), and held wishes.
--
-- Drives live in fish.memory so they persist across ticks and reloads; their rates are species
-- data (scripts/species/*.lua, `drives = { ... }`):
--   hunger in [0, 1]: rises at hunger_per_s, falls by satiation_per_food per pellet eaten.
--   fear   in [0, 1]: FEAR_LENGTHS body lengths / distance to the nearest predator seen, decaying
--                     at fear_decay_per_s once none is seen (the fish remembers where it was).
--
-- Wishes that need a whole turn to carry out (avoiding a wall, a new wander direction) are held
-- for a moment in memory rather than recomputed every decision: recomputing them as the fish
-- turns would keep restarting the turn.

local shoal, math = shoal, math   -- locals: a global is looked up through the module's environment
local C = {}

-- What every layer of one decision needs, read once at its start by C.begin (decisions run one
-- after another, so one table serves them all): time, species data, body sensor.
---@class common.Decision
---@field now number          # simulated time, seconds
---@field me shoal.Species    # set by C.begin before any layer reads it
---@field body shoal.Body
local cur = { now = 0 }   -- me and body: C.begin sets them before any layer reads them
C.cur = cur

-- Starts a decision: refreshes `cur` and returns the fish's percept table (reused).
---@param fish shoal.Fish
---@return table percepts
function C.begin(fish)
  cur.now = shoal.time()
  cur.me = shoal.species()
  cur.body = shoal.body()
  return fish.percepts or {}
end

C.HUNGRY = 0.3         -- above this, food in sight wins over crowding/wandering
C.FEAR_LENGTHS = 6     -- a predator within this many body lengths is frightening
C.AFRAID = 0.5         -- fear above this: flee
C.AVOID_HOLD = 1.5     -- seconds an avoidance manoeuvre is held
C.AVOID_RETARGET = math.rad(60)  -- a new manoeuvre this different replaces a held one
C.WALL_LOOKAHEAD = 2.5 -- seconds ahead a side wall is looked for
C.SHARP_TURN = math.rad(100)  -- avoidance turns sharper than this are quick turns
C.SHARP_FOOD_TURN = math.rad(50)  -- food this far off the heading ...
C.NEAR_FOOD = 3                   -- ... and this close (body lengths): turn on the spot
C.WANDER_HOLD = { 2, 5 }  -- seconds a wander direction is held (random in this range)

-- Seconds since this fish's previous decision (0 on its first).
---@param fish shoal.Fish
---@return number seconds
function C.elapsed(fish)
  local m = fish.memory
  local now = cur.now
  local dt = m.last_time and (now - m.last_time) or 0
  m.last_time = now
  return dt
end

-- Updates hunger; returns it.
---@param fish shoal.Fish
---@param dt number  seconds since the previous decision
---@return number hunger
function C.hunger(fish, dt)
  local m = fish.memory
  local h = (m.hunger or 0.5) + cur.me.hunger_per_s * dt
  if h > 1 then h = 1 end
  m.hunger = h
  return h
end

-- Updates fear from the predator in p (if any) and remembers where it was; returns fear.
---@param fish shoal.Fish
---@param p table  percepts (predator_* from C.keep)
---@param dt number  seconds since the previous decision
---@return number fear
function C.fear(fish, p, dt)
  local m = fish.memory
  local f = (m.fear or 0) - cur.me.fear_decay_per_s * dt
  if p.predator_id then
    local length = cur.me.length
    local f_now = C.FEAR_LENGTHS * length / math.max(p.predator_distance, 1e-3)
    if f_now > f then f = f_now end
    m.threat_x, m.threat_y, m.threat_z = p.predator_x, p.predator_y, p.predator_z
  end
  if f < 0 then f = 0 elseif f > 1 then f = 1 end
  m.fear = f
  return f
end

-- Senses rocks and walls into p.rock_* / p.wall_* (heading, depth, speed or nil).
-- Side walls are seen early: where the fish will be in WALL_LOOKAHEAD seconds, a body length in
-- from the walls, must still be inside, else it turns for the middle of the tank (a steady wish,
-- so the motion layer carries out one whole turn). Floor and surface use shoal.avoid_walls.
---@param p table  percepts
function C.sense_collision(p)
  p.rock_heading, p.rock_depth, p.rock_speed = shoal.avoid_obstacles()
  local b, s, t = cur.body, cur.me, shoal.tank()
  local look = C.WALL_LOOKAHEAD * s.cruise_speed
  local x = b.x + math.cos(b.heading) * look
  local z = b.z - math.sin(b.heading) * look
  local inset = s.length
  if x < t.min_x + inset or x > t.max_x - inset or z < t.min_z + inset or z > t.max_z - inset then
    local cx, cz = 0.5 * (t.min_x + t.max_x), 0.5 * (t.min_z + t.max_z)
    p.wall_heading = math.atan(-(cz - b.z), cx - b.x)
    p.wall_depth, p.wall_speed = b.depth, s.cruise_speed
  else
    p.wall_heading, p.wall_depth, p.wall_speed = shoal.avoid_walls(s.length)
  end
end

local function angle_between(a, b)
  local d = (a - b) % (2 * math.pi)
  if d > math.pi then d = 2 * math.pi - d end
  return d
end

-- True while an avoidance manoeuvre of kind `which` ("rock" or "wall") is held, starting one if
-- p asks for it. A held manoeuvre is replaced only by one pointing somewhere else entirely (a
-- second wall), not by the slowly changing wish of the same one.
local AVOID_KEYS = {
  rock = { heading = "rock_heading", depth = "rock_depth", speed = "rock_speed" },
  wall = { heading = "wall_heading", depth = "wall_depth", speed = "wall_speed" },
}

---@param fish shoal.Fish
---@param p table  percepts (from C.sense_collision)
---@param which "rock"|"wall"
---@return boolean
function C.avoiding(fish, p, which)
  local m = fish.memory
  local now = cur.now
  local k = AVOID_KEYS[which]
  local h = p[k.heading]
  local held = m.avoid_kind == which and m.avoid_until and now < m.avoid_until
  if held and not (h and angle_between(h, m.avoid_heading) > C.AVOID_RETARGET) then
    return true
  end
  if h then
    m.avoid_kind = which
    m.avoid_heading, m.avoid_depth = h, p[k.depth]
    m.avoid_speed = p[k.speed]
    m.avoid_until = now + C.AVOID_HOLD
    return true
  end
  return false
end

-- Carries out the held avoidance: a sharp one as a quick turn (halting, small radius: the fish
-- spins away from the wall) unless `smooth`, anything else through shoal.steer.
---@param fish shoal.Fish
---@param smooth? boolean
function C.avoid(fish, smooth)
  local m = fish.memory
  local b = cur.body
  if b.motion == "quick_turn" then return end   -- let it finish
  local err = (m.avoid_heading - b.heading + math.pi) % (2 * math.pi) - math.pi
  if not smooth and math.abs(err) > C.SHARP_TURN then
    shoal.quick_turn(math.abs(err), err > 0 and "left" or "right", true)
  else
    shoal.steer(m.avoid_heading, m.avoid_depth, m.avoid_speed)
  end
end

-- Key names per prefix, built once (no string concatenation per decision).
---@class common.Keys
---@field id string
---@field x string
---@field y string
---@field z string
---@field distance string
---@field heading string
---@field speed string
---@field bearing string

---@type table<string, common.Keys>
local KEYS = setmetatable({}, { __index = function(t, prefix)
  local k = { id = prefix .. "_id", x = prefix .. "_x", y = prefix .. "_y", z = prefix .. "_z",
              distance = prefix .. "_distance", heading = prefix .. "_heading",
              speed = prefix .. "_speed", bearing = prefix .. "_bearing" }
  t[prefix] = k
  return k
end })

-- Copies the fields of a (reused) percept table into p under a prefix, or clears them.
---@param p table  percepts
---@param prefix string
---@param percept shoal.Percept?
function C.keep(p, prefix, percept)
  local k = KEYS[prefix]
  if percept then
    p[k.id] = percept.id
    p[k.x], p[k.y], p[k.z] = percept.x, percept.y, percept.z
    p[k.distance] = percept.distance
    p[k.bearing] = percept.bearing
    p[k.heading] = percept.heading
    p[k.speed] = percept.speed
  else
    p[k.id] = nil
    p[k.distance] = nil
  end
end

-- Escape: flat out away from where the predator was last seen.
---@param fish shoal.Fish
function C.escape(fish)
  local m = fish.memory
  shoal.steer(shoal.flee(m.threat_x, m.threat_y, m.threat_z))
end

-- Go for the food in p; eat it when within reach. Returns true if it ate.
---@param fish shoal.Fish
---@param p table  percepts (food_* from C.keep)
---@return boolean ate
function C.feed(fish, p)
  local ate = false
  if p.food_distance < 0.5 * cur.me.length then
    ate = shoal.eat(p.food_id)
    if ate then
      local m = fish.memory
      m.hunger = math.max(0, (m.hunger or 0) - cur.me.satiation_per_food)
      m.meals = (m.meals or 0) + 1
    end
  end
  if not ate then
    local b, body = p.food_bearing, cur.body
    local dx, dy, dz = p.food_x - body.x, p.food_y - body.y, p.food_z - body.z
    if body.motion == "quick_turn" then
      -- let the turn finish
    elseif dy * dy > dx * dx + dz * dz then
      -- More above or below than ahead (a pellet sinking past): its bearing says little, and
      -- turning towards it would only circle under it; rise or sink to it, heading held.
      local _, depth, speed = shoal.arrive(p.food_x, p.food_y, p.food_z)
      shoal.steer(body.heading, depth, speed)
    elseif math.abs(b) > C.SHARP_FOOD_TURN and p.food_distance < C.NEAR_FOOD * cur.me.length then
      -- Close and off to the side: a serial turn would circle it; turn on the spot.
      shoal.quick_turn(math.abs(b), b > 0 and "left" or "right", true)
    else
      shoal.steer(shoal.arrive(p.food_x, p.food_y, p.food_z))
    end
  end
  return ate
end

-- Wander: a new random direction every few seconds (up to `turn` radians from the current
-- heading, default 0.6), held in between.
---@param fish shoal.Fish
---@param turn? number  radians
function C.wander(fish, turn)
  local m = fish.memory
  local now = cur.now
  if not m.wander_until or now >= m.wander_until then
    m.wander_heading, m.wander_depth, m.wander_speed = shoal.wander(turn)
    local lo, hi = C.WANDER_HOLD[1], C.WANDER_HOLD[2]
    m.wander_until = now + lo + (hi - lo) * shoal.random()
  end
  shoal.steer(m.wander_heading, m.wander_depth, m.wander_speed)
end

return C
