---@meta
-- LuaLS definitions of the shoal scripting API (https://luals.github.io/). The workspace configs
-- at the repository root (.luarc.json for LuaLS, .emmyrc.json for EmmyLua and `shoal check`) load
-- this directory, so editors complete and check behaviour, species and scene files with no setup;
-- `shoal check` runs the same checks (emmylua_check) from the command line and in CI.
--
-- Conventions: angles in radians (use math.rad(90)); heading is counter-clockwise seen from
-- above, 0 = +x; a bearing is relative to the fish's heading, positive to its left; depth is
-- world units below the surface (tank max.y); speeds in world units per second (a black porgy is
-- 50 units long and cruises at 50). Every function acts on the fish whose behaviour is running
-- and raises an error when called anywhere else (e.g. at a module's top level).
--
-- The tables returned by see, nearest and body are reused by the next call of the same
-- function: copy the fields you want to keep, or keep the id.

---A behaviour module: return either `tick` or the three layers of the paper's section 3.1.
---@class shoal.Behavior
---@field tick? fun(fish: shoal.Fish): string?        # one decision; the return value is the intention
---@field perceive? fun(fish: shoal.Fish): table?     # perception layer: summarise what the fish senses
---@field intend? fun(fish: shoal.Fish, percepts: table?): string?  # intention layer: pick a goal
---@field behave? fun(fish: shoal.Fish, intention: string?, percepts: table?)  # behaviour layer: issue motions
---@field min_decision_hz? number  # level of detail never lets this behaviour's fish decide less often (0, 60]

---The table a behaviour gets for its fish. It persists for the fish's life, across reloads.
---@class shoal.Fish
---@field id integer          # the fish's index (stable while it lives)
---@field generation integer  # together with id, the fish's handle
---@field species string      # species name
---@field behavior string     # behaviour module name
---@field memory table        # per-fish memory: persists across ticks and script reloads
---@field intention? string   # last intention (set by the host; shown in the inspector)
---@field percepts? table     # last value perceive returned (set by the host; shown in the inspector)
---@field params table        # the scene group's `params` (plain data, {} when none); read it, keep changes in memory

---One thing the fish sees.
---@class shoal.Percept
---@field kind "fish"|"food"|"obstacle"|"predator"
---@field species? string     # species name (fish and predators)
---@field id integer          # fish index, food id or obstacle id
---@field distance number     # from the fish's head (to an obstacle's surface), world units
---@field bearing number      # radians, relative to heading, + = left, in (-pi, pi]
---@field elevation number    # radians, + = above
---@field x number
---@field y number
---@field z number
---@field heading number      # of the seen fish, radians (0 otherwise)
---@field speed number        # of the seen fish, units/s (0 otherwise)

---The body sensor.
---@class shoal.Body
---@field x number
---@field y number
---@field z number
---@field depth number        # below the surface
---@field to_floor number
---@field to_surface number
---@field to_wall number      # to the nearest side wall
---@field wall_x number       # inward normal of that wall
---@field wall_y number
---@field wall_z number
---@field contact boolean     # touched a wall, floor, surface or rock in the last motion step
---@field speed number
---@field heading number
---@field pitch number
---@field motion string       # "swim", "accelerate", "stop", "normal_turn", "quick_turn", "serial_turn", "ascend", "descend", "idle"
---@field queue integer       # motion requests waiting behind the current one

---The tank's box, world units (y up; the water surface is max_y).
---@class shoal.Tank
---@field min_x number
---@field min_y number
---@field min_z number
---@field max_x number
---@field max_y number
---@field max_z number

---The fish's species data.
---@class shoal.Species
---@field name string
---@field length number       # body length l, world units
---@field cruise_speed number # s, units/s
---@field max_speed number
---@field view_range number   # world units
---@field view_angle number   # full opening of the view cone, radians
---@field turn_time number    # Tt, seconds
---@field predator boolean
---@field hunger_per_s number        # drives (species data): hunger rise per second
---@field satiation_per_food number  # hunger removed by one pellet
---@field fear_decay_per_s number    # fear decay per second once no predator is seen
---@field sociability number         # in [0, 1]: how strongly it keeps to its own species

-- Data files -----------------------------------------------------------------------------------
-- A scene file (scripts/scenes/*.lua) returns a shoal.Scene, a species file a shoal.SpeciesFile.
-- Annotate the returned table (`---@type shoal.Scene`) to have them checked in your editor.
-- Units: world units (a black porgy is 50 long; y up), seconds, radians.

---@alias shoal.Vec3 number[]  # {x, y, z}

---@class (exact) shoal.Box
---@field min shoal.Vec3        # lower corner, below max on every axis
---@field max shoal.Vec3        # upper corner

---@class (exact) shoal.FishGroup
---@field species string        # a file species/<name>.lua
---@field count? integer        # how many fish, 0 to 200000 (default 1)
---@field behavior? string      # a file behaviors/<name>.lua (none: the fish only swims)
---@field pos? shoal.Vec3       # exact start of the group's first fish
---@field region? shoal.Box     # box the fish start in (default: the middle half of the tank)
---@field heading? number       # start heading, radians (default random)
---@field speed? number         # start speed, units/s >= 0 (default the species' motion.s)
---@field params? table         # plain data each fish reads as fish.params

---@class (exact) shoal.FoodDrops
---@field every number          # seconds between drops, > 0
---@field count? integer        # pellets per drop (default 1)
---@field start? number         # time of the first drop, seconds (default `every`)
---@field region? shoal.Box     # where pellets appear (default a thin layer under the surface)

---@class (exact) shoal.LodBand
---@field radius? number        # outer radius from the nearest focus, units (left out: everywhere; last band only)
---@field every integer         # decide this many times less often than the species' decision_hz (1 to 600)
---@field cap? integer          # at most this many scripted fish hold the band: the nearest to a focus keep it, the rest drop to the next (not on the last band)

---@class (exact) shoal.Lod
---@field on? boolean           # level of detail on by default for this scene (`--lod on|off` overrides)
---@field focus? shoal.Vec3[]   # focus points for headless runs (the window uses its camera and selection)
---@field bands? shoal.LodBand[]  # nearest first; default {radius=600, every=1}, {radius=1500, every=2}, {every=3}
---@field wake? boolean         # events (contact, wall or rock ahead, predator or pellet in view) wake slow fish (default true)
---@field wall_lookahead? number  # seconds ahead (at cruising speed) a slow fish is woken for a wall, floor, surface or rock (0 to 60, default 2.5: the shipped behaviours' horizon)

---@class (exact) shoal.Obstacle
---@field pos shoal.Vec3
---@field radius number         # > 0

---@class (exact) shoal.Current
---@field pos shoal.Vec3
---@field radius number         # > 0
---@field velocity shoal.Vec3   # drift, units/s

---@class (exact) shoal.Scene
---@field tank shoal.Box
---@field assets? string        # models directory relative to the repository root (default "assets")
---@field species? string[]     # species to load although no group starts with them
---@field fish? shoal.FishGroup[]
---@field food? shoal.Vec3[]    # pellets present at the start
---@field food_drops? shoal.FoodDrops
---@field food_sink_speed? number  # how fast pellets sink, units/s (default 0: they stay where dropped)
---@field food_lifetime? number    # seconds an uneaten pellet lasts before it dissolves (default: for ever)
---@field obstacles? shoal.Obstacle[]
---@field currents? shoal.Current[]
---@field measures? table<string, fun(fish: shoal.Fish): number|boolean|nil>  # the scene's own measures, sampled once per simulated second for every fish (docs/measures.md)
---@field lod? shoal.Lod        # behaviour level of detail (docs/lod.md)

---@class (exact) shoal.MotionParams
---@field p? number             # pivot, fraction of body length from the head (> 0.1424)
---@field turn_axis? number     # where the body turns about, fraction of body length (default: p)
---@field front_amp? number     # front wave amplitude at the snout, fraction of body length
---@field front_wave? "recoil"|"travelling"|"anguilliform"  # carangiform recoil, a travelling front, or the whole-body anguilliform envelope (docs/motion.md)
---@field s? number             # cruising speed, units/s
---@field l? number             # body length, units (the model is scaled to it)
---@field max_amp? number       # maxAmp of A(x), units
---@field lambda? number        # body wavelength, units
---@field omega? number         # wave frequency (docs/motion.md)
---@field tt? number            # turning time Tt, seconds
---@field f? number             # turn amplitude weight, 1 to 2
---@field turn_angle? number    # default turn angle, radians

---@class (exact) shoal.Drives
---@field hunger_per_s? number
---@field satiation_per_food? number
---@field fear_decay_per_s? number
---@field sociability? number

---@class (exact) shoal.SpeciesFile
---@field base? "black_porgy"|"eel"  # start from this built-in description
---@field name? string
---@field asset? string         # skinned glTF model relative to assets/
---@field vertebral_joints? string[]  # joints the motion layer bends, head to tail
---@field motion? shoal.MotionParams
---@field view_range? number    # units
---@field view_angle_deg? number  # degrees
---@field max_speed? number     # units/s
---@field predator? boolean
---@field power_profile? "fig5"|"uniform"  # how the driven joints' bends are weighted
---@field color_tint? [number, number, number]  # {r, g, b} linear multiplier
---@field alpha_cutoff? number  # draw the model's alpha as a mask cut here, in (0, 1]
---@field drives? shoal.Drives
---@field decision_hz? number   # decisions per second, (0, 60]

---@class shoal
shoal = {}

-- Perception ---------------------------------------------------------------------------------

---Everything in the fish's view cone and range, nearest first.
---@param kind? "fish"|"food"|"obstacle"|"predator"  only this kind
---@param max? integer  at most this many (default 32)
---@return shoal.Percept[]
function shoal.see(kind, max) end

---The nearest thing of a kind in view (optionally of one species), or nil.
---@param kind "fish"|"food"|"obstacle"|"predator"
---@param species? string
---@return shoal.Percept?
function shoal.nearest(kind, species) end

---The body sensor.
---@return shoal.Body
function shoal.body() end

---The fish's species data.
---@return shoal.Species
function shoal.species() end

---The tank's box, world units (y up; the surface is max_y).
---@return shoal.Tank
function shoal.tank() end

---Simulated time, seconds.
---@return number
function shoal.time() end

---The motion now playing and how many requests wait behind it.
---@return string name
---@return integer queued
function shoal.motion() end

---The fish's own seeded random generator (runs are reproducible). Like math.random:
---no argument → float in [0, 1); (m) → integer in [1, m]; (m, n) → integer in [m, n].
---@overload fun(): number
---@overload fun(m: integer): integer
---@overload fun(m: integer, n: integer): integer
---@param m? integer
---@param n? integer
---@return number
function shoal.random(m, n) end

-- Motion requests (paper section 3.5). Each is queued behind the current motion unless `now` is
-- true, which interrupts it (blending from the current body shape).

---Swim steadily at `speed`.
---@param speed number
---@param now? boolean
function shoal.swim(speed, now) end

---Change speed to `speed` over `duration` seconds, then keep swimming.
---@param speed number
---@param duration number
---@param now? boolean
function shoal.accelerate(speed, duration, now) end

---Come to rest over `duration` seconds (default 1).
---@param duration? number
---@param now? boolean
function shoal.stop(duration, now) end

---Turn by `angle` radians (> 0) to a side.
---@param kind "normal"|"quick"|"serial"
---@param angle number
---@param side "left"|"right"
---@param now? boolean
function shoal.turn(kind, angle, side, now) end

---Normal turn: tail to one side only; the fish keeps swimming.
---@param angle number
---@param side "left"|"right"
---@param now? boolean
function shoal.normal_turn(angle, side, now) end

---Quick turn: turn while halting, small radius, in about Tt.
---@param angle number
---@param side "left"|"right"
---@param now? boolean
function shoal.quick_turn(angle, side, now) end

---Serial turn: turn while still swimming forward.
---@param angle number
---@param side "left"|"right"
---@param now? boolean
function shoal.serial_turn(angle, side, now) end

---Rise by `height` world units.
---@param height number
---@param now? boolean
function shoal.ascend(height, now) end

---Sink by `depth` world units.
---@param depth number
---@param now? boolean
function shoal.descend(depth, now) end

---Steer towards a heading, a depth and a speed (default: cruise speed): the host picks the turn
---kind, ascend/descend and accelerate. Calling it every decision with the same wish does not
---restart the motion. Takes a steering helper's results directly: shoal.steer(shoal.seek(x, y, z)).
---@param heading number
---@param depth number
---@param speed? number
function shoal.steer(heading, depth, speed) end

---Bite a food pellet: true if it is within reach of the mouth and was not eaten when this tick
---began. Fish decide in parallel, so the pellet is taken when the tick's decisions are done, by
---the first fish in decision order that bit it; every fish that bit it on that tick gets true.
---@param food integer  a food percept's id
---@return boolean ate
function shoal.eat(food) end

-- Steering helpers (computed in Rust). Each returns a desired heading, depth and speed. seek,
-- flee, arrive and wander always answer; the others return three nils when they have nothing to
-- say (no neighbours, nothing to avoid), so after `if heading then` the depth and speed are
-- numbers too (`---@return_overload`: emmylua narrows them; LuaLS ignores the tag).

---Towards a point.
---@param x number
---@param y number
---@param z number
---@param speed? number  default: cruise speed
---@return number heading, number depth, number speed
function shoal.seek(x, y, z, speed) end

---Away from a point.
---@param x number
---@param y number
---@param z number
---@param speed? number  default: max speed
---@return number heading, number depth, number speed
function shoal.flee(x, y, z, speed) end

---Towards a point, slowing down within `slow_radius` (default 2 body lengths).
---@param x number
---@param y number
---@param z number
---@param slow_radius? number
---@param speed? number
---@return number heading, number depth, number speed
function shoal.arrive(x, y, z, slow_radius, speed) end

---A small random change of heading (up to `max_turn` radians, default 0.6) and depth (up to
---`max_depth_change`, default half a body length), drawn from the fish's own generator.
---@param max_turn? number
---@param max_depth_change? number
---@param speed? number
---@return number heading, number depth, number speed
function shoal.wander(max_turn, max_depth_change, speed) end

---Away from fish closer than `radius` (default 1 body length).
---@param radius? number
---@param speed? number
---@return number? heading
---@return number? depth
---@return number? speed
---@return_overload number, number, number
---@return_overload nil, nil, nil
function shoal.separation(radius, speed) end

---The mean heading of same-species fish within `radius` (default 3 body lengths).
---@param radius? number
---@param speed? number
---@return number? heading
---@return number? depth
---@return number? speed
---@return_overload number, number, number
---@return_overload nil, nil, nil
function shoal.alignment(radius, speed) end

---Towards the centre of same-species fish within `radius` (default 4 body lengths).
---@param radius? number
---@param speed? number
---@return number? heading
---@return number? depth
---@return number? speed
---@return_overload number, number, number
---@return_overload nil, nil, nil
function shoal.cohesion(radius, speed) end

---Around the rock ahead within `lookahead` (default 3 body lengths), keeping `clearance`
---(default half a body length); nil when the way is clear.
---@param lookahead? number
---@param clearance? number
---@param speed? number
---@return number? heading
---@return number? depth
---@return number? speed
---@return_overload number, number, number
---@return_overload nil, nil, nil
function shoal.avoid_obstacles(lookahead, clearance, speed) end

---Back into the tank when within `margin` (default 2 body lengths) of a wall, the floor or the
---surface; nil otherwise.
---@param margin? number
---@param speed? number
---@return number? heading
---@return number? depth
---@return number? speed
---@return_overload number, number, number
---@return_overload nil, nil, nil
function shoal.avoid_walls(margin, speed) end

---The crowding rules of a school in one pass over the neighbours: separation from any fish within
---`sep_radius`, alignment with and cohesion towards fish of the same species within `ali_radius`
---and `coh_radius`, mixed with the given weights. nil `nearest`: every fish within the radii —
---the same as shoal.blend of shoal.separation, shoal.alignment and shoal.cohesion — except where
---the neighbourhood is packed (more than 2,048 fish in the grid cells within the widest radius):
---there alignment and cohesion take an even sample of at most 1,024 of them, so the cost stays
---bounded (separation always takes every fish). A whole number ≥ 1: only the nearest that many
---(any species, nearest first, ties by id; starlings follow six to seven). "all": every fish
---however many. nil when no neighbour is in range.
---@param sep_radius number
---@param sep_weight number
---@param ali_radius number
---@param ali_weight number
---@param coh_radius number
---@param coh_weight number
---@param speed? number
---@param nearest? integer|"all"
---@return number? heading
---@return number? depth
---@return number? speed
---@return_overload number, number, number
---@return_overload nil, nil, nil
function shoal.crowd(sep_radius, sep_weight, ali_radius, ali_weight, coh_radius, coh_weight, speed, nearest) end

---Weighted mix of steering wishes: groups of heading, depth, speed, weight. Groups whose heading
---is nil are skipped; nil when no group remains. Keep helper results in locals first (a call in
---the middle of an argument list gives only its first value).
---@param ... number?
---@return number? heading
---@return number? depth
---@return number? speed
---@return_overload number, number, number
---@return_overload nil, nil, nil
function shoal.blend(...) end
