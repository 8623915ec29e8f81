//! The `shoal` table: everything a behaviour script can ask of the world.
//!
//! Perception (`see`, `nearest`, `body`) is answered by the world's sensors over its spatial grid;
//! motion requests (`swim`, `turn`, `steer`, …) go to the fish's motion player; the steering
//! helpers (`seek`, `separation`, …) are computed in Rust and return a desired
//! `heading, depth, speed` triple (or nothing). Every function acts on the fish whose behaviour is
//! running; called at any other time (say, at a module's top level) it raises an error.
//!
//! Conventions (see `scripts/types/shoal.lua`, the LuaLS definitions, for every signature):
//! angles in radians (`math.rad(90)`), heading counter-clockwise seen from above with 0 = +x,
//! bearings positive to the fish's left; depth in world units below the surface; speeds in world
//! units per second; `side` is `"left"` or `"right"`.
//!
//! To keep a decision cheap the tables returned by `see`, `nearest` and `body` are reused on the
//! next call of the same function: copy what you want to keep (or keep the `id`).

use std::sync::Arc;
use std::time::Instant;

use mlua::{Function, Lua, LuaString, Table, Value};

use shoal_core::motion::{MotionKind, MotionRequest, Side, TurnKind};
use shoal_core::world::steer::Steer;
use shoal_core::world::{
    FishControls, FishId, FishRef, FoodId, Percept, PerceptKind, SpeciesId, World,
};

mod perception;
mod steering;

use perception::register_perception;
use steering::{cruise_and_length, register_crowding, register_steering};

/// A script lane with many decisions due on a tick (64 or more) times the sensor queries of
/// one decision in this many, counting each timed one this many times (see
/// [`Ctx::sense_weight`]): an unbiased estimate of the sensing time that reads the clock a
/// quarter as often. Smaller lanes time every query.
pub const SENSE_SAMPLE: u32 = 4;

/// Default number of percepts `shoal.see` returns.
pub const DEFAULT_SEE_MAX: usize = 32;

/// Field names, interned once so filling a table does not hash strings.
struct Keys {
    kind: LuaString,
    species: LuaString,
    id: LuaString,
    distance: LuaString,
    bearing: LuaString,
    elevation: LuaString,
    x: LuaString,
    y: LuaString,
    z: LuaString,
    heading: LuaString,
    speed: LuaString,
    kind_fish: LuaString,
    kind_food: LuaString,
    kind_obstacle: LuaString,
    kind_predator: LuaString,
}

/// Per-call context of the API, kept as Lua app data.
pub struct Ctx {
    /// The fish whose behaviour is running, if any.
    pub fish: Option<FishId>,
    /// The world, shared read-only by every lane while behaviours run (`None` otherwise).
    pub world: Option<Arc<World>>,
    /// The running fish's controls (motion player, steering memo, random generator), checked
    /// out of the world for its decision (see [`World::check_out`]).
    pub controls: FishControls,
    /// Pellets the fish of this lane bit during the stage, in decision order; the host applies
    /// them to the world after every lane has run (see `shoal.eat`).
    pub claims: Vec<(FishId, FoodId)>,
    /// Sensor time spent in this stage, nanoseconds (taken out of the Lua time).
    pub perception_ns: u64,
    /// How many times the sensor queries of the running decision count their time in
    /// `perception_ns`: 1 (the default) times every query; a lane sets [`SENSE_SAMPLE`] on one
    /// decision in that many and 0 on the others, because reading the clock twice per query
    /// (~60 ns on the reference VM) costs more than the body sensor it would time.
    pub sense_weight: u32,
    /// The fish `percepts` holds the vision of (one query per decision, shared by `see` and
    /// `nearest`); reset whenever `fish` changes.
    pub percepts_of: Option<FishId>,
    percepts: Vec<Percept>,
    keys: Keys,
    species_names: Vec<Option<LuaString>>,
    species_tables: Vec<Option<Table>>,
    see_out: Table,
    see_pool: Vec<Table>,
    /// `{ __metatable = false }`: the metatable of the tables the API reuses for every caller
    /// of the lane, so no script can hang metamethods on them.
    locked: Table,
}

impl Ctx {
    /// Forgets cached species names and tables (after a species changed).
    pub fn invalidate_species(&mut self) {
        self.species_names.clear();
        self.species_tables.clear();
    }
}

fn rt(msg: impl Into<String>) -> mlua::Error {
    mlua::Error::RuntimeError(msg.into())
}

fn outside(name: &str) -> mlua::Error {
    rt(outside_message(name))
}

fn outside_message(name: &str) -> String {
    format!(
        "shoal.{name} can only be called while a fish's behaviour runs (from tick, perceive, intend or behave)"
    )
}

/// The percept kinds scripts name, as the error of a bad one lists them.
const KINDS: &str = "\"fish\", \"food\", \"obstacle\" or \"predator\"";

/// Runs `f` with the world (read-only: decisions of different lanes share it), the current fish
/// and the rest of the API context. The context stays borrowed while `f` runs, so `f` must not
/// borrow it again (pass `ctx` on instead).
fn with_ctx<R>(
    lua: &Lua,
    name: &str,
    f: impl FnOnce(&World, FishId, &mut Ctx) -> mlua::Result<R>,
) -> mlua::Result<R> {
    let mut ctx = lua
        .try_app_data_mut::<Ctx>()
        .ok()
        .flatten()
        .ok_or_else(|| outside(name))?;
    let Some(fish) = ctx.fish else {
        return Err(outside(name));
    };
    let Some(world) = ctx.world.take() else {
        return Err(outside(name));
    };
    // The world is moved out of the context for the call (no reference count changes) and back.
    let r = f(&world, fish, &mut ctx);
    ctx.world = Some(world);
    r
}

/// Runs `f` with the world and the current fish.
fn with_world<R>(
    lua: &Lua,
    name: &str,
    f: impl FnOnce(&World, FishId) -> mlua::Result<R>,
) -> mlua::Result<R> {
    with_ctx(lua, name, |w, fish, _| f(w, fish))
}

/// Runs `f` with the world, the current fish and its checked-out controls (for motion requests
/// and random numbers).
fn with_controls<R>(
    lua: &Lua,
    name: &str,
    f: impl FnOnce(&World, FishId, &mut FishControls) -> mlua::Result<R>,
) -> mlua::Result<R> {
    with_ctx(lua, name, |w, fish, ctx| f(w, fish, &mut ctx.controls))
}

/// The current fish as the world hands it out (an error naming `name` if it is gone).
fn fish_ref<'w>(w: &'w World, f: FishId, name: &str) -> mlua::Result<FishRef<'w>> {
    w.fish(f)
        .ok_or_else(|| world_err(name, shoal_core::world::WorldError::StaleFish(f)))
}

fn world_err(name: &str, e: shoal_core::world::WorldError) -> mlua::Error {
    rt(format!("shoal.{name}: {e}"))
}

/// `s` parsed by the motion layer's one parser (`FromStr` of [`Side`] or [`TurnKind`]); the error,
/// which lists the accepted names, is prefixed `shoal.{name}: `.
fn parse_name<T: std::str::FromStr<Err = shoal_core::motion::UnknownName>>(
    name: &str,
    s: &LuaString,
) -> mlua::Result<T> {
    String::from_utf8_lossy(s.as_bytes().as_ref())
        .parse()
        .map_err(|e| rt(format!("shoal.{name}: {e}")))
}

fn parse_side(name: &str, s: &LuaString) -> mlua::Result<Side> {
    parse_name(name, s)
}

fn parse_turn(name: &str, s: &LuaString) -> mlua::Result<TurnKind> {
    parse_name(name, s)
}

fn request(lua: &Lua, name: &str, r: MotionRequest, now: Option<bool>) -> mlua::Result<()> {
    with_controls(lua, name, |w, f, c| {
        fish_ref(w, f, name)?
            .request(c, r, now.unwrap_or(false))
            .map_err(|e| world_err(name, e))
    })
}

fn finite_arg(name: &str, what: &str, v: f32) -> mlua::Result<f32> {
    if v.is_finite() {
        Ok(v)
    } else {
        Err(rt(format!(
            "shoal.{name}: {what} is {v}: must be a finite number"
        )))
    }
}

/// Runs a sensor query, adding its time to the stage's perception time when this decision's
/// queries are timed (see [`Ctx::sense_weight`]).
fn timed<R>(ctx: &mut Ctx, f: impl FnOnce() -> R) -> R {
    let start = sense_start(ctx);
    let r = f();
    sense_end(ctx, start);
    r
}

/// The clock at the start of a sensor query, if this decision's queries are timed.
fn sense_start(ctx: &Ctx) -> Option<Instant> {
    (ctx.sense_weight > 0).then(Instant::now)
}

/// Adds the time since `start` (weighted) to the perception time.
fn sense_end(ctx: &mut Ctx, start: Option<Instant>) {
    if let Some(start) = start {
        ctx.perception_ns += start.elapsed().as_nanos() as u64 * u64::from(ctx.sense_weight);
    }
}

/// Creates the `shoal` global and the API context: the context, then each group of functions
/// (perception, motion requests, steering helpers, crowding), then the Lua-side wrappers.
pub fn register(lua: &Lua) -> mlua::Result<()> {
    install_context(lua)?;
    let shoal = lua.create_table()?;
    let raw = register_perception(lua, &shoal)?;
    register_motion(lua, &shoal)?;
    register_steering(lua, &shoal)?;
    register_crowding(lua, &shoal)?;
    // The host's driver stores the deciding fish's species here (a host without one: nobody
    // does, and `shoal.species()` always asks Rust).
    let decision: Table = match lua.named_registry_value::<Option<Table>>(DECISION_KEY)? {
        Some(t) => t,
        None => {
            let t = lua.create_table()?;
            lua.set_named_registry_value(DECISION_KEY, &t)?;
            t
        }
    };
    let motion_names = lua.create_sequence_from(MOTION_KINDS.map(MotionKind::name))?;
    let kind_numbers = lua.create_table_from(
        PerceptKind::ALL
            .iter()
            .enumerate()
            .map(|(i, k)| (k.name(), i + 1)),
    )?;
    // Tables are filled on the Lua side: a field store there is a VM instruction, while one
    // made from Rust is a protected call under the memory limit.
    let (stage, readonly, forget_species): (Function, Function, Function) =
        lua.load(WRAPPERS).set_name("=shoal api").call((
            &shoal,
            raw,
            decision,
            motion_names,
            kind_numbers,
            format!("shoal.nearest: kind must be {KINDS}"),
        ))?;
    lua.set_named_registry_value(STAGE_KEY, stage)?;
    lua.set_named_registry_value(READONLY_KEY, readonly)?;
    lua.set_named_registry_value(FORGET_SPECIES_KEY, forget_species)?;
    lua.globals().set("shoal", shoal)?;
    Ok(())
}

/// Forgets the species names and tables the API cached in `lua` (after a species changed).
pub fn invalidate_species(lua: &Lua) -> mlua::Result<()> {
    if let Some(mut c) = lua.app_data_mut::<Ctx>() {
        c.invalidate_species();
    }
    match lua.named_registry_value::<Option<Function>>(FORGET_SPECIES_KEY)? {
        Some(f) => f.call(()),
        None => Ok(()),
    }
}

/// Every [`MotionKind`], in the order `shoal.body()` numbers them (1-based on the Lua side).
const MOTION_KINDS: [MotionKind; 9] = [
    MotionKind::Idle,
    MotionKind::Swim,
    MotionKind::Accelerate,
    MotionKind::Stop,
    MotionKind::NormalTurn,
    MotionKind::QuickTurn,
    MotionKind::SerialTurn,
    MotionKind::Ascend,
    MotionKind::Descend,
];

/// The number `shoal.body()` passes for `k`: its 1-based place in [`MOTION_KINDS`] (a match, so
/// a new kind does not compile until it has one).
fn motion_number(k: MotionKind) -> u8 {
    match k {
        MotionKind::Idle => 1,
        MotionKind::Swim => 2,
        MotionKind::Accelerate => 3,
        MotionKind::Stop => 4,
        MotionKind::NormalTurn => 5,
        MotionKind::QuickTurn => 6,
        MotionKind::SerialTurn => 7,
        MotionKind::Ascend => 8,
        MotionKind::Descend => 9,
    }
}

/// The API context ([`Ctx`]) in the Lua state's app data, with its interned keys and tables.
fn install_context(lua: &Lua) -> mlua::Result<()> {
    let key = |s: &str| lua.create_string(s);
    let keys = Keys {
        kind: key("kind")?,
        species: key("species")?,
        id: key("id")?,
        distance: key("distance")?,
        bearing: key("bearing")?,
        elevation: key("elevation")?,
        x: key("x")?,
        y: key("y")?,
        z: key("z")?,
        heading: key("heading")?,
        speed: key("speed")?,
        kind_fish: key("fish")?,
        kind_food: key("food")?,
        kind_obstacle: key("obstacle")?,
        kind_predator: key("predator")?,
    };
    let locked = lua.create_table()?;
    locked.raw_set("__metatable", false)?;
    let see_out = lua.create_table()?;
    see_out.set_metatable(Some(locked.clone()))?;
    lua.set_app_data(Ctx {
        fish: None,
        world: None,
        controls: FishControls::default(),
        claims: Vec::new(),
        perception_ns: 0,
        sense_weight: 1,
        percepts_of: None,
        percepts: Vec::with_capacity(64),
        keys,
        species_names: Vec::new(),
        species_tables: Vec::new(),
        see_out,
        see_pool: Vec::new(),
        locked,
    });
    Ok(())
}

/// Motion requests: `swim`, `accelerate`, `stop`, the turns, `ascend`, `descend`, `steer`,
/// `eat`.
fn register_motion(lua: &Lua, shoal: &Table) -> mlua::Result<()> {
    shoal.set(
        "swim",
        lua.create_function(|lua, (speed, now): (f32, Option<bool>)| {
            request(lua, "swim", MotionRequest::Swim { speed }, now)
        })?,
    )?;
    shoal.set(
        "accelerate",
        lua.create_function(|lua, (speed, duration, now): (f32, f32, Option<bool>)| {
            request(
                lua,
                "accelerate",
                MotionRequest::Accelerate { speed, duration },
                now,
            )
        })?,
    )?;
    shoal.set(
        "stop",
        lua.create_function(|lua, (duration, now): (Option<f32>, Option<bool>)| {
            let duration = duration.unwrap_or(1.0);
            request(lua, "stop", MotionRequest::Stop { duration }, now)
        })?,
    )?;
    shoal.set(
        "turn",
        lua.create_function(
            |lua, (kind, angle, side, now): (LuaString, f32, LuaString, Option<bool>)| {
                let kind = parse_turn("turn", &kind)?;
                let side = parse_side("turn", &side)?;
                request(lua, "turn", MotionRequest::Turn { kind, angle, side }, now)
            },
        )?,
    )?;
    for (name, kind) in [
        ("normal_turn", TurnKind::Normal),
        ("quick_turn", TurnKind::Quick),
        ("serial_turn", TurnKind::Serial),
    ] {
        shoal.set(
            name,
            lua.create_function(
                move |lua, (angle, side, now): (f32, LuaString, Option<bool>)| {
                    let side = parse_side(name, &side)?;
                    request(lua, name, MotionRequest::Turn { kind, angle, side }, now)
                },
            )?,
        )?;
    }
    shoal.set(
        "ascend",
        lua.create_function(|lua, (height, now): (f32, Option<bool>)| {
            request(lua, "ascend", MotionRequest::Ascend { height }, now)
        })?,
    )?;
    shoal.set(
        "descend",
        lua.create_function(|lua, (depth, now): (f32, Option<bool>)| {
            request(lua, "descend", MotionRequest::Descend { depth }, now)
        })?,
    )?;
    shoal.set(
        "steer",
        lua.create_function(
            |lua, (heading, depth, speed): (Option<f32>, Option<f32>, Option<f32>)| {
                let (Some(h), Some(d)) = (heading, depth) else {
                    return Err(rt(
                        "shoal.steer: heading and depth are required (a steering helper returned nothing?)",
                    ));
                };
                with_controls(lua, "steer", |w, f, c| {
                    let speed = speed.unwrap_or_else(|| cruise_and_length(w, f).0);
                    fish_ref(w, f, "steer")?
                        .steer_to(c, h, d, speed)
                        .map_err(|e| world_err("steer", e))
                })
            },
        )?,
    )?;
    shoal.set(
        "eat",
        lua.create_function(|lua, food: u32| {
            // A bite is a claim: the pellet is eaten when the stage ends (lanes decide in
            // parallel), by the first fish in decision order that bit it this tick.
            let food = FoodId(food);
            with_ctx(lua, "eat", |w, f, ctx| {
                let ok = w.can_eat(f, food);
                if ok {
                    ctx.claims.push((f, food));
                }
                Ok(ok)
            })
        })?,
    )?;
    Ok(())
}

/// Registry key of the function that opens (`stage(time, tank…)`) and closes (`stage(nil)`) a
/// behaviour stage on the Lua side: `shoal.time` and `shoal.tank` answer from what it was given,
/// without a call into Rust per decision.
const STAGE_KEY: &str = "shoal.stage";

/// Registry key of `readonly(t, what)`: a read-only view of `t` (see `wrappers.lua`).
const READONLY_KEY: &str = "shoal.readonly";

/// Registry key of `forget_species()`, which empties the Lua side's species caches.
const FORGET_SPECIES_KEY: &str = "shoal.forget_species";

/// Registry key of the table the host's driver writes the deciding fish's species into
/// (`decision.species`, the species index + 1) before each decision.
/// Registry key of the table the driver writes what it knows of the deciding fish into before
/// each decision: `species`, its species index + 1 (nil when the caller did not say). The
/// `shoal` API answers `shoal.species()` from it without a call into Rust.
pub const DECISION_KEY: &str = "shoal.decision";

/// Tells the Lua side of the API that a behaviour stage starts at `time` in `world`'s tank
/// (`Some`) or has ended (`None`).
pub fn set_stage(lua: &Lua, stage: Option<(f64, &World)>) -> mlua::Result<()> {
    let f: Function = lua.named_registry_value(STAGE_KEY)?;
    match stage {
        Some((time, w)) => {
            let t = w.tank();
            f.call((time, t.min.x, t.min.y, t.min.z, t.max.x, t.max.y, t.max.z))
        }
        None => f.call(()),
    }
}

/// `shoal.body`, `shoal.nearest`, `shoal.species` and `shoal.tank`: Rust returns plain values
/// (numbers, indices), these fill one reused table each; `shoal.time` and `shoal.tank` answer
/// from the stage's values. Names cross as small integers and are looked up here: the percept
/// kind (`KIND`), the species (`species_name`, interned once per lane) and the motion
/// (`MOTION`), so no string handle is made per call. `shoal.species()` answers from a per-lane
/// cache by the deciding fish's species index, which the host's driver stores in `decision`
/// (see [`DECISION_KEY`]) before each decision, so it costs no call into Rust once warm.
/// Returns the stage function (see [`set_stage`]), `readonly` and `forget_species`. The reused
/// tables are shared by every module of the lane: their metatables are locked.
const WRAPPERS: &str = include_str!("wrappers.lua");

/// Names of the functions in the `shoal` table, sorted (for the LuaLS definitions test).
pub fn registered_names(lua: &Lua) -> mlua::Result<Vec<String>> {
    let shoal: Table = lua.globals().get("shoal")?;
    let mut names: Vec<String> = shoal
        .pairs::<String, Value>()
        .filter_map(|kv| kv.ok())
        .filter(|(_, v)| v.is_function())
        .map(|(k, _)| k)
        .collect();
    names.sort();
    Ok(names)
}
