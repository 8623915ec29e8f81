-- The Lua side of the `shoal` API (loaded by crates/script/src/api/mod.rs, `register`): Rust
-- returns plain values (numbers, indices) and these wrappers fill one reused table each, since a
-- field store here is a VM instruction while one made from Rust is a protected call under the
-- memory limit. Arguments, from Rust: the `shoal` table; the raw functions; the per-lane
-- `decision` table; MOTION, motion names by number; KIND, percept kind numbers by name (both
-- numbered in Rust, the one place they are written); BAD_KIND, the error for an unknown kind.
-- Returns the stage function, `readonly` and `forget_species`.
local shoal, raw, decision, MOTION, KIND, BAD_KIND = ...
local body_raw, nearest_raw, species_raw, species_name_raw, outside =
  raw.body, raw.nearest, raw.species, raw.species_name, raw.outside
local setmetatable, error, next = setmetatable, error, next
local locked = { __metatable = false }
local body = setmetatable({}, locked)
local near = setmetatable({}, locked)
local tank = setmetatable({}, locked)
-- Per lane: each species' `shoal.species()` table by species number, and its name.
---@type table<integer|false, table|nil>
local species_tables = {}
---@type table<integer, string|nil>
local species_names = {}
local function readonly(t, what)
  return setmetatable({}, {
    __index = t,
    __newindex = function() error(what .. " is read-only", 2) end,
    __pairs = function() return next, t, nil end,
    __len = function() return #t end,
    __metatable = false,
  })
end
local now, x0, y0, z0, x1, y1, z1
local function stage(time, ...)
  now = time
  x0, y0, z0, x1, y1, z1 = ...
  decision.species = nil
end
local function forget_species()
  species_tables, species_names = {}, {}
end
function shoal.body()
  local b = body
  local motion, queue
  b.x, b.y, b.z, b.depth, b.to_floor, b.to_surface, b.to_wall,
    b.wall_x, b.wall_y, b.wall_z, b.contact, b.speed, b.heading, b.pitch, motion,
    queue = body_raw()
  b.motion, b.queue = MOTION[motion], queue
  return b
end
function shoal.nearest(kind, species)
  local k = KIND[kind]
  if k == nil then error(BAD_KIND, 2) end
  local sp, id, dist, bearing, elev, x, y, z, heading, speed = nearest_raw(k, species)
  if sp == nil then return nil end   -- nothing seen: no table to fill
  ---@type string|false|nil
  local name = false
  if sp > 0 then
    name = species_names[sp]
    if name == nil then
      name = species_name_raw(sp)
      species_names[sp] = name
    end
  end
  local n = near
  n.kind, n.species, n.id, n.distance, n.bearing, n.elevation = kind, name or nil, id, dist,
    bearing, elev
  n.x, n.y, n.z, n.heading, n.speed = x, y, z, heading, speed
  return n
end
function shoal.species()
  local sp = decision.species
  local t = species_tables[sp or false]
  if t then return t end
  t = species_raw()   -- raises outside a decision
  if sp then species_tables[sp] = t end
  return t
end
function shoal.tank()
  if now == nil then error(outside("tank"), 2) end
  local t = tank
  t.min_x, t.min_y, t.min_z, t.max_x, t.max_y, t.max_z = x0, y0, z0, x1, y1, z1
  return t
end
function shoal.time()
  if now == nil then error(outside("time"), 2) end
  return now
end
return stage, readonly, forget_species
