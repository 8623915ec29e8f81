---@meta
-- LuaLS definitions of shoal's behaviour-test API (`shoal test`, files `tests/behavior/*_test.lua`;
-- see "Testing a behaviour" in scripts/README.md). Vectors are `{x, y, z}` arrays; times are
-- simulated seconds; angles in radians unless a name says degrees.

-- shoal.Vec3 ({x, y, z}) is defined in shoal.lua.

---A test's options for `t:world`.
---@class (exact) shoal.TestWorldOptions
---@field seed? integer            # the world's seed (default 1)
---@field scene? string            # a scene file (`scenes/default.lua`); default: the empty tank
---@field food? {sink_speed?: number, lifetime?: number}  # how pellets sink (units/s, default 0) and how long an uneaten one lasts (seconds, default for ever); default: the scene's
---@field tank? {min: shoal.Vec3, max: shoal.Vec3}  # the tank's corners
---@field scratch? boolean         # a private copy of scripts/ and assets/ (for `w:write_script`)
---@field allow_errors? boolean    # script errors are expected (check them with `w:errors()`)
---@field lod? boolean             # behaviour level of detail on or off in this world, whatever `shoal test --lod` says (default: `--lod`, else the scene's)
---@field focus? shoal.Vec3|shoal.Vec3[]  # level-of-detail focus point(s): fish near them decide at full rate (default: the scene's, else none)

---What `w:spawn` takes.
---@class (exact) shoal.TestSpawn
---@field species string           # a species of scripts/species/
---@field pos shoal.Vec3           # the head's position
---@field heading? number          # radians, 0 = +x, counter-clockwise seen from above
---@field pitch? number            # radians, + = nose up
---@field speed? number            # starting speed (default: the species' cruising speed)
---@field behavior? string         # a module of scripts/behaviors/ (none: only requested motions)

---The handle a test function receives.
---@class shoal.Test
local Test = {}

---A world for this test (several per test are allowed).
---@param options? shoal.TestWorldOptions
---@return shoal.TestWorld
function Test:world(options) end

---A check: fails the test (without stopping it) when `condition` is false or nil.
---@param condition any
---@param message? string
---@return boolean ok
function Test:expect(condition, message) end

---A check: `actual` within `tolerance` of `expected`.
---@param actual number
---@param expected number
---@param tolerance number
---@param message? string
---@return boolean ok
function Test:near(actual, expected, tolerance, message) end

---A check: `a < b`.
---@param a number
---@param b number
---@param message? string
---@return boolean ok
function Test:less(a, b, message) end

---A check: `a > b`.
---@param a number
---@param b number
---@param message? string
---@return boolean ok
function Test:greater(a, b, message) end

---A test's world.
---@class shoal.TestWorld
---@field time number  # simulated seconds
local TestWorld = {}

---Spawns a fish.
---@param spawn shoal.TestSpawn
---@return shoal.TestFish
function TestWorld:spawn(spawn) end

---Drops a food pellet.
---@param food {pos: shoal.Vec3}
---@return shoal.TestFood
function TestWorld:food(food) end

---Places a rock.
---@param rock {pos: shoal.Vec3, radius: number}
function TestWorld:obstacle(rock) end

---Runs `seconds` of simulated time.
---@param seconds number
function TestWorld:run(seconds) end

---Runs `n` ticks (default 1).
---@param n? integer
function TestWorld:step(n) end

---Runs until `condition(w)` holds, at most `max_seconds`.
---@param condition fun(w: shoal.TestWorld): boolean
---@param max_seconds number
---@return boolean met
---@return number time  # simulated seconds when it stopped
function TestWorld:run_until(condition, max_seconds) end

---|mean unit heading| of `fishes`: 1 = all aligned.
---@param fishes shoal.TestFish[]
---@return number
function TestWorld:polarization(fishes) end

---Mean distance from each of `fishes` to its nearest other one.
---@param fishes shoal.TestFish[]
---@return number
function TestWorld:nearest_distance(fishes) end

---Smallest distance between two of `fishes`.
---@param fishes shoal.TestFish[]
---@return number
function TestWorld:min_distance(fishes) end

---Mean position of `fishes`.
---@param fishes shoal.TestFish[]
---@return shoal.Vec3
function TestWorld:centroid(fishes) end

---The tank's corners.
---@return {min: shoal.Vec3, max: shoal.Vec3}
function TestWorld:tank() end

---The rocks.
---@return {pos: shoal.Vec3, radius: number}[]
function TestWorld:obstacles() end

---The script errors so far (`file:line: message`), for worlds made with `allow_errors = true`.
---@return string[]
function TestWorld:errors() end

---Fish in the tank.
---@return integer
function TestWorld:fish_count() end

---The mean so far of the scene's measure `name` (its `measures = { NAME = function(fish) … end }`),
---over every fish and once-a-second sample that gave a value. Raises an error for a name the
---scene does not declare, or before any sample has a value.
---@param name string
---@return number
function TestWorld:measure(name) end

---Writes `source` to `relative` inside a scratch world's scripts/ and reloads what it affects,
---as a save in the aquarium does. Returns the reload events, as text.
---@param relative string
---@param source string
---@return string
function TestWorld:write_script(relative, source) end

---A fish a test spawned.
---@class shoal.TestFish
---@field id integer
---@field alive boolean
---@field pos shoal.Vec3       # the head's position ({0, 0, 0} once the fish is gone)
---@field heading number       # radians; this and the fields below to `species` are nil once the fish is gone (check `alive`)
---@field pitch number
---@field speed number
---@field depth number         # below the surface
---@field params shoal.TestMotionParams  # the species' motion parameters
---@field species string
---@field motion string        # the motion playing ("idle" when none)
---@field behavior? string     # nil: no behaviour (only requested motions)
---@field memory? table        # its script's `fish.memory` (a copy)
---@field intention? any       # what its last decision intended
---@field percepts? table      # what its last decision perceived
local TestFish = {}

---@param speed number
function TestFish:swim(speed) end

---@param speed number
---@param duration number
function TestFish:accelerate(speed, duration) end

---@param duration? number  # seconds (default 1)
function TestFish:stop(duration) end

---@param kind "normal"|"quick"|"serial"
---@param degrees number
---@param side "left"|"right"
function TestFish:turn(kind, degrees, side) end

---@param height number
function TestFish:ascend(height) end

---@param depth number
function TestFish:descend(depth) end

---Switches its behaviour (nil: only requested motions). False when the fish is gone.
---@param name? string
---@return boolean
function TestFish:set_behavior(name) end

---A test fish's motion parameters (its species' `motion`, docs/motion.md; units as there).
---@class shoal.TestMotionParams
---@field p number            # pivot, fraction of body length from the head
---@field s number            # cruising speed, units/s
---@field l number            # body length, units
---@field max_amp number      # tail amplitude maxAmp, units
---@field lambda number       # body wavelength, units
---@field omega number        # wave frequency
---@field tt number           # turning time Tt, seconds
---@field f number            # turn amplitude weight
---@field turn_angle number   # default turn angle, radians
---@field turn_axis? number   # where the body turns about (nil: about the pivot p)
---@field front_amp number    # front wave amplitude, fraction of body length
---@field front_wave "recoil"|"travelling"|"anguilliform"

---A food pellet a test dropped.
---@class shoal.TestFood
---@field eaten boolean
---@field eaten_at? number  # simulated seconds
---@field pos shoal.Vec3     # where it is ({0, 0, 0} once eaten or dissolved)
---@field settled boolean    # resting on the floor or a rock (see t:world's `food`)
---@field dissolved boolean  # gone uneaten after its lifetime

---Declares a behaviour test.
---@param name string
---@param body fun(t: shoal.Test)
function test(name, body) end
