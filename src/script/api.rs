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

use glam::Vec3;
use mlua::{Function, Lua, LuaString, Table, Value, Variadic};
use rand::Rng;

use crate::motion::{MotionRequest, Side, TurnKind};
use crate::world::steer::Steer;
use crate::world::{FishControls, FishId, FoodId, Percept, PerceptKind, SpeciesId, World};

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
    /// The fish `percepts` holds the vision of (one query per decision, shared by `see` and
    /// `nearest`); reset whenever `fish` changes.
    pub percepts_of: Option<FishId>,
    percepts: Vec<Percept>,
    motion_names: Vec<(&'static str, LuaString)>,
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
    rt(format!(
        "shoal.{name} can only be called while a fish's behaviour runs (from tick, perceive, intend or behave)"
    ))
}

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

fn world_err(name: &str, e: crate::world::WorldError) -> mlua::Error {
    rt(format!("shoal.{name}: {e}"))
}

fn species_name(lua: &Lua, ctx: &mut Ctx, world: &World, s: SpeciesId) -> mlua::Result<LuaString> {
    let i = usize::from(s.0);
    if ctx.species_names.len() <= i {
        ctx.species_names.resize(i + 1, None);
    }
    if let Some(n) = &ctx.species_names[i] {
        return Ok(n.clone());
    }
    let n = lua.create_string(&world.species(s).desc.name)?;
    ctx.species_names[i] = Some(n.clone());
    Ok(n)
}

fn kind_key(keys: &Keys, k: PerceptKind) -> &LuaString {
    match k {
        PerceptKind::Fish => &keys.kind_fish,
        PerceptKind::Food => &keys.kind_food,
        PerceptKind::Obstacle => &keys.kind_obstacle,
        PerceptKind::Predator => &keys.kind_predator,
    }
}

fn parse_kind(s: &[u8]) -> Option<PerceptKind> {
    Some(match s {
        b"fish" => PerceptKind::Fish,
        b"food" => PerceptKind::Food,
        b"obstacle" => PerceptKind::Obstacle,
        b"predator" => PerceptKind::Predator,
        _ => return None,
    })
}

fn fill_percept(
    lua: &Lua,
    ctx: &mut Ctx,
    world: &World,
    t: &Table,
    p: &Percept,
) -> mlua::Result<()> {
    let species = match p.species {
        Some(s) => Value::String(species_name(lua, ctx, world, s)?),
        None => Value::Nil,
    };
    let id = p
        .fish
        .map(|f| f.index)
        .or(p.food.map(|f| f.0))
        .or(p.obstacle.map(|o| o.0));
    let k = &ctx.keys;
    t.raw_set(&k.kind, kind_key(k, p.kind))?;
    t.raw_set(&k.species, species)?;
    t.raw_set(&k.id, id)?;
    t.raw_set(&k.distance, p.distance)?;
    t.raw_set(&k.bearing, p.bearing)?;
    t.raw_set(&k.elevation, p.elevation)?;
    t.raw_set(&k.x, p.pos.x)?;
    t.raw_set(&k.y, p.pos.y)?;
    t.raw_set(&k.z, p.pos.z)?;
    t.raw_set(&k.heading, p.heading)?;
    t.raw_set(&k.speed, p.speed)?;
    Ok(())
}

/// A percept as the values `shoal.nearest` returns: kind, species, id, distance, bearing,
/// elevation, x, y, z, heading, speed (all nil when nothing is seen).
type PerceptValues = (
    Option<LuaString>,
    Option<LuaString>,
    Option<u32>,
    Option<f32>,
    Option<f32>,
    Option<f32>,
    Option<f32>,
    Option<f32>,
    Option<f32>,
    Option<f32>,
    Option<f32>,
);

const NOTHING_SEEN: PerceptValues = (
    None, None, None, None, None, None, None, None, None, None, None,
);

fn percept_values(
    lua: &Lua,
    ctx: &mut Ctx,
    world: &World,
    p: &Percept,
) -> mlua::Result<PerceptValues> {
    let species = match p.species {
        Some(s) => Some(species_name(lua, ctx, world, s)?),
        None => None,
    };
    let id = p
        .fish
        .map(|f| f.index)
        .or(p.food.map(|f| f.0))
        .or(p.obstacle.map(|o| o.0));
    Ok((
        Some(kind_key(&ctx.keys, p.kind).clone()),
        species,
        id,
        Some(p.distance),
        Some(p.bearing),
        Some(p.elevation),
        Some(p.pos.x),
        Some(p.pos.y),
        Some(p.pos.z),
        Some(p.heading),
        Some(p.speed),
    ))
}

/// The motion layer's motion names, interned once.
fn motion_name(lua: &Lua, ctx: &mut Ctx, name: &'static str) -> mlua::Result<LuaString> {
    if let Some((_, s)) = ctx.motion_names.iter().find(|(n, _)| *n == name) {
        return Ok(s.clone());
    }
    let s = lua.create_string(name)?;
    ctx.motion_names.push((name, s.clone()));
    Ok(s)
}

fn parse_side(name: &str, s: &LuaString) -> mlua::Result<Side> {
    match s.as_bytes().as_ref() {
        b"left" => Ok(Side::Left),
        b"right" => Ok(Side::Right),
        other => Err(rt(format!(
            "shoal.{name}: side must be \"left\" or \"right\", got \"{}\"",
            String::from_utf8_lossy(other)
        ))),
    }
}

fn parse_turn(name: &str, s: &LuaString) -> mlua::Result<TurnKind> {
    match s.as_bytes().as_ref() {
        b"normal" => Ok(TurnKind::Normal),
        b"quick" => Ok(TurnKind::Quick),
        b"serial" => Ok(TurnKind::Serial),
        other => Err(rt(format!(
            "shoal.{name}: kind must be \"normal\", \"quick\" or \"serial\", got \"{}\"",
            String::from_utf8_lossy(other)
        ))),
    }
}

fn request(lua: &Lua, name: &str, r: MotionRequest, now: Option<bool>) -> mlua::Result<()> {
    with_controls(lua, name, |w, f, c| {
        w.request_with(f, c, r, now.unwrap_or(false))
            .map_err(|e| world_err(name, e))
    })
}

/// `heading, depth, speed`, or three nils.
type Triple = (Option<f32>, Option<f32>, Option<f32>);

fn triple(s: Option<Steer>) -> Triple {
    match s {
        Some(s) => (Some(s.heading), Some(s.depth), Some(s.speed)),
        None => (None, None, None),
    }
}

/// Cruise speed `s` and body length `l` of the fish's species.
fn cruise_and_length(w: &World, f: FishId) -> (f32, f32) {
    w.species_of(f)
        .map(|s| {
            let d = &w.species(s).desc;
            (d.motion.s, d.motion.l)
        })
        .unwrap_or((1.0, 1.0))
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

/// Runs a sensor query, adding its time to the stage's perception time.
fn timed<R>(ctx: &mut Ctx, f: impl FnOnce() -> R) -> R {
    let start = Instant::now();
    let r = f();
    ctx.perception_ns += start.elapsed().as_nanos() as u64;
    r
}

/// The weighted mix of steering wishes `shoal.blend` and `shoal.crowd` return: headings averaged
/// as unit vectors, depth and speed as numbers; wishes that are `None` and weights ≤ 0 (or NaN)
/// count for nothing; nothing when no weight remains.
fn blend(groups: impl Iterator<Item = (Option<(f64, f64, f64)>, f64)>) -> Triple64 {
    let (mut hx, mut hy, mut depth, mut speed, mut total) = (0.0, 0.0, 0.0, 0.0, 0.0);
    for (wish, wgt) in groups {
        let Some((h, d, s)) = wish else {
            continue;
        };
        let wgt = wgt.max(0.0);
        hx += wgt * h.cos();
        hy += wgt * h.sin();
        depth += wgt * d;
        speed += wgt * s;
        total += wgt;
    }
    if total <= 0.0 {
        return (None, None, None);
    }
    let heading = if hx * hx + hy * hy > 1e-12 {
        hy.atan2(hx)
    } else {
        0.0
    };
    (Some(heading), Some(depth / total), Some(speed / total))
}

/// `heading, depth, speed` in double precision, or three nils.
type Triple64 = (Option<f64>, Option<f64>, Option<f64>);

/// Creates the `shoal` global and the API context.
pub fn register(lua: &Lua) -> mlua::Result<()> {
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
        percepts_of: None,
        percepts: Vec::with_capacity(64),
        motion_names: Vec::new(),
        keys,
        species_names: Vec::new(),
        species_tables: Vec::new(),
        see_out,
        see_pool: Vec::new(),
        locked,
    });

    let shoal = lua.create_table()?;

    // ---- perception ---------------------------------------------------------------------
    shoal.set(
        "see",
        lua.create_function(|lua, (kind, max): (Option<LuaString>, Option<usize>)| {
            let kind = match &kind {
                Some(k) => Some(parse_kind(&k.as_bytes()).ok_or_else(|| {
                    rt("shoal.see: kind must be \"fish\", \"food\", \"obstacle\" or \"predator\"")
                })?),
                None => None,
            };
            let max = max.unwrap_or(DEFAULT_SEE_MAX);
            with_ctx(lua, "see", |w, f, ctx| {
                let start = Instant::now();
                if ctx.percepts_of != Some(f) {
                    w.vision(f, &mut ctx.percepts);
                    ctx.percepts_of = Some(f);
                }
                let out = ctx.see_out.clone();
                let mut n = 0usize;
                let percepts = std::mem::take(&mut ctx.percepts);
                for p in percepts
                    .iter()
                    .filter(|p| kind.is_none_or(|k| p.kind == k))
                    .take(max)
                {
                    if ctx.see_pool.len() <= n {
                        let t = lua.create_table_with_capacity(0, 11)?;
                        t.set_metatable(Some(ctx.locked.clone()))?;
                        ctx.see_pool.push(t);
                    }
                    let t = ctx.see_pool[n].clone();
                    fill_percept(lua, ctx, w, &t, p)?;
                    out.raw_set(n + 1, t)?;
                    n += 1;
                }
                ctx.percepts = percepts;
                let old = out.raw_len();
                for i in n + 1..=old {
                    out.raw_set(i, Value::Nil)?;
                }
                ctx.perception_ns += start.elapsed().as_nanos() as u64;
                Ok(out)
            })
        })?,
    )?;
    let nearest_raw =
        lua.create_function(|lua, (kind, species): (LuaString, Option<LuaString>)| {
            let kind = parse_kind(&kind.as_bytes()).ok_or_else(|| {
                rt("shoal.nearest: kind must be \"fish\", \"food\", \"obstacle\" or \"predator\"")
            })?;
            with_ctx(lua, "nearest", |w, f, ctx| {
                let start = Instant::now();
                let want = match &species {
                    Some(s) => match w.species_by_name(&s.to_str()?) {
                        Some(id) => Some(id),
                        None => return Ok(NOTHING_SEEN),
                    },
                    None => None,
                };
                let found = if ctx.percepts_of == Some(f) {
                    // The full vision list is at hand (shoal.see ran this decision).
                    ctx.percepts
                        .iter()
                        .find(|p| p.kind == kind && (want.is_none() || p.species == want))
                        .copied()
                } else {
                    w.nearest_in_view(f, kind, want)
                };
                let r = match found {
                    Some(p) => percept_values(lua, ctx, w, &p)?,
                    None => NOTHING_SEEN,
                };
                ctx.perception_ns += start.elapsed().as_nanos() as u64;
                Ok(r)
            })
        })?;
    let body_raw = lua.create_function(|lua, ()| {
        with_ctx(lua, "body", |w, f, ctx| {
            let (playing, queued) = (
                ctx.controls.player().current_name(),
                ctx.controls.player().queue_len(),
            );
            let motion = motion_name(lua, ctx, playing)?;
            let b = timed(ctx, || w.body_sense(f)).ok_or_else(|| outside("body"))?;
            let n = b.wall_normal;
            Ok((
                b.pos.x,
                b.pos.y,
                b.pos.z,
                b.depth,
                b.to_floor,
                b.to_surface,
                b.to_wall,
                n.x,
                n.y,
                n.z,
                b.contact,
                b.speed,
                b.heading,
                b.pitch,
                motion,
                queued,
            ))
        })
    })?;
    shoal.set(
        "species",
        lua.create_function(|lua, ()| {
            with_ctx(lua, "species", |w, f, ctx| {
                let s = w.species_of(f).ok_or_else(|| outside("species"))?;
                let i = usize::from(s.0);
                if ctx.species_tables.len() <= i {
                    ctx.species_tables.resize(i + 1, None);
                }
                if let Some(t) = &ctx.species_tables[i] {
                    return Ok(t.clone());
                }
                let d = &w.species(s).desc;
                let t = lua.create_table()?;
                t.raw_set("name", d.name.as_str())?;
                t.raw_set("length", d.motion.l)?;
                t.raw_set("cruise_speed", d.motion.s)?;
                t.raw_set("max_speed", d.max_speed)?;
                t.raw_set("view_range", d.view_range)?;
                t.raw_set("view_angle", d.view_angle_deg.to_radians())?;
                t.raw_set("turn_time", d.motion.tt)?;
                t.raw_set("predator", d.predator)?;
                t.raw_set("hunger_per_s", d.drives.hunger_per_s)?;
                t.raw_set("satiation_per_food", d.drives.satiation_per_food)?;
                t.raw_set("fear_decay_per_s", d.drives.fear_decay_per_s)?;
                t.raw_set("sociability", d.drives.sociability)?;
                // Shared by every fish of the species in the lane: read-only.
                let readonly: Function = lua.named_registry_value(READONLY_KEY)?;
                let t: Table = readonly.call((t, "shoal.species()"))?;
                ctx.species_tables[i] = Some(t.clone());
                Ok(t)
            })
        })?,
    )?;
    let outside_fn =
        lua.create_function(|_, name: String| -> mlua::Result<()> { Err(outside(&name)) })?;
    shoal.set(
        "motion",
        lua.create_function(|lua, ()| {
            with_controls(lua, "motion", |_, _, c| {
                Ok((c.player().current_name(), c.player().queue_len()))
            })
        })?,
    )?;
    shoal.set(
        "random",
        lua.create_function(|lua, (m, n): (Option<i64>, Option<i64>)| {
            with_controls(lua, "random", |_, _, c| {
                let rng = c.rng();
                Ok(match (m, n) {
                    (None, _) => Value::Number(rng.random::<f64>()),
                    (Some(m), None) if m >= 1 => Value::Integer(rng.random_range(1..=m)),
                    (Some(m), Some(n)) if m <= n => Value::Integer(rng.random_range(m..=n)),
                    _ => return Err(rt("shoal.random: empty interval")),
                })
            })
        })?,
    )?;

    // ---- motion requests ------------------------------------------------------------------
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
                    w.steer_to_with(f, c, h, d, speed)
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

    // ---- steering helpers -----------------------------------------------------------------
    shoal.set(
        "seek",
        lua.create_function(|lua, (x, y, z, speed): (f32, f32, f32, Option<f32>)| {
            with_world(lua, "seek", |w, f| {
                let speed = speed.unwrap_or_else(|| cruise_and_length(w, f).0);
                Ok(triple(w.steer_seek(f, Vec3::new(x, y, z), speed)))
            })
        })?,
    )?;
    shoal.set(
        "flee",
        lua.create_function(|lua, (x, y, z, speed): (f32, f32, f32, Option<f32>)| {
            with_world(lua, "flee", |w, f| {
                let speed = speed.unwrap_or_else(|| {
                    w.species_of(f)
                        .map(|s| w.species(s).desc.max_speed)
                        .unwrap_or(1.0)
                });
                Ok(triple(w.steer_flee(f, Vec3::new(x, y, z), speed)))
            })
        })?,
    )?;
    shoal.set(
        "arrive",
        lua.create_function(
            |lua, (x, y, z, slow_radius, speed): (f32, f32, f32, Option<f32>, Option<f32>)| {
                with_world(lua, "arrive", |w, f| {
                    let (s, l) = cruise_and_length(w, f);
                    let r = finite_arg("arrive", "slow_radius", slow_radius.unwrap_or(2.0 * l))?;
                    Ok(triple(w.steer_arrive(
                        f,
                        Vec3::new(x, y, z),
                        r,
                        speed.unwrap_or(s),
                    )))
                })
            },
        )?,
    )?;
    shoal.set(
        "wander",
        lua.create_function(
            |lua, (max_turn, max_depth_change, speed): (Option<f32>, Option<f32>, Option<f32>)| {
                with_controls(lua, "wander", |w, f, c| {
                    let (s, l) = cruise_and_length(w, f);
                    Ok(triple(w.steer_wander_with(
                        f,
                        c,
                        max_turn.unwrap_or(0.6),
                        max_depth_change.unwrap_or(0.5 * l),
                        speed.unwrap_or(s),
                    )))
                })
            },
        )?,
    )?;
    type Neighbourly = fn(&World, FishId, f32, f32) -> Option<Steer>;
    for (name, default_lengths, f) in [
        ("separation", 1.0f32, World::steer_separation as Neighbourly),
        ("alignment", 3.0, World::steer_alignment as Neighbourly),
        ("cohesion", 4.0, World::steer_cohesion as Neighbourly),
    ] {
        shoal.set(
            name,
            lua.create_function(move |lua, (radius, speed): (Option<f32>, Option<f32>)| {
                with_ctx(lua, name, |w, fish, ctx| {
                    let (s, l) = cruise_and_length(w, fish);
                    let r = finite_arg(name, "radius", radius.unwrap_or(default_lengths * l))?;
                    Ok(triple(timed(ctx, || f(w, fish, r, speed.unwrap_or(s)))))
                })
            })?,
        )?;
    }
    shoal.set(
        "avoid_obstacles",
        lua.create_function(
            |lua, (lookahead, clearance, speed): (Option<f32>, Option<f32>, Option<f32>)| {
                with_ctx(lua, "avoid_obstacles", |w, f, ctx| {
                    let (s, l) = cruise_and_length(w, f);
                    Ok(triple(timed(ctx, || {
                        w.steer_avoid_obstacles(
                            f,
                            lookahead.unwrap_or(3.0 * l),
                            clearance.unwrap_or(0.5 * l),
                            speed.unwrap_or(s),
                        )
                    })))
                })
            },
        )?,
    )?;
    shoal.set(
        "avoid_walls",
        lua.create_function(|lua, (margin, speed): (Option<f32>, Option<f32>)| {
            with_ctx(lua, "avoid_walls", |w, f, ctx| {
                let (s, l) = cruise_and_length(w, f);
                Ok(triple(timed(ctx, || {
                    w.steer_avoid_walls(f, margin.unwrap_or(2.0 * l), speed.unwrap_or(s))
                })))
            })
        })?,
    )?;
    shoal.set(
        "blend",
        lua.create_function(|_, args: Variadic<Value>| {
            let num = |v: &Value| v.as_number().or(v.as_integer().map(|i| i as f64));
            if !args.len().is_multiple_of(4) {
                return Err(rt(format!(
                    "shoal.blend: expects groups of heading, depth, speed, weight; got {} values",
                    args.len()
                )));
            }
            Ok(blend(args.chunks_exact(4).map(|g| {
                let wish = match (num(&g[0]), num(&g[1]), num(&g[2])) {
                    (Some(h), Some(d), Some(s)) => Some((h, d, s)),
                    _ => None,
                };
                (wish, num(&g[3]).unwrap_or(0.0))
            })))
        })?,
    )?;
    shoal.set(
        "crowd",
        lua.create_function(
            |lua, (rs, ws, ra, wa, rc, wc, speed): (f32, f64, f32, f64, f32, f64, Option<f32>)| {
                with_ctx(lua, "crowd", |w, fish, ctx| {
                    let s = speed.unwrap_or_else(|| cruise_and_length(w, fish).0);
                    let rs = finite_arg("crowd", "separation radius", rs)?;
                    let ra = finite_arg("crowd", "alignment radius", ra)?;
                    let rc = finite_arg("crowd", "cohesion radius", rc)?;
                    let crowd = timed(ctx, || w.steer_crowd(fish, rs, ra, rc, s));
                    let (sep, ali, coh) = crowd
                        .map(|c| (c.separation, c.alignment, c.cohesion))
                        .unwrap_or_default();
                    let wish = |st: Option<Steer>| {
                        st.map(|st| {
                            (
                                f64::from(st.heading),
                                f64::from(st.depth),
                                f64::from(st.speed),
                            )
                        })
                    };
                    Ok(blend(
                        [(wish(sep), ws), (wish(ali), wa), (wish(coh), wc)].into_iter(),
                    ))
                })
            },
        )?,
    )?;

    // Tables are filled on the Lua side: a field store there is a VM instruction, while one
    // made from Rust is a protected call under the memory limit.
    let (stage, readonly): (Function, Function) = lua
        .load(WRAPPERS)
        .set_name("=shoal api")
        .call((&shoal, body_raw, nearest_raw, outside_fn))?;
    lua.set_named_registry_value(STAGE_KEY, stage)?;
    lua.set_named_registry_value(READONLY_KEY, readonly)?;
    lua.globals().set("shoal", shoal)?;
    Ok(())
}

/// Registry key of the function that opens (`stage(time, tank…)`) and closes (`stage(nil)`) a
/// behaviour stage on the Lua side: `shoal.time` and `shoal.tank` answer from what it was given,
/// without a call into Rust per decision.
const STAGE_KEY: &str = "shoal.stage";

/// Registry key of `readonly(t, what)`: a read-only view of `t` (see [`WRAPPERS`]).
const READONLY_KEY: &str = "shoal.readonly";

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

/// `shoal.body`, `shoal.nearest` and `shoal.tank`: Rust returns plain values, these fill one
/// reused table each; `shoal.time` and `shoal.tank` answer from the stage's values. Returns the
/// stage function (see [`set_stage`]) and `readonly`. The reused tables are shared by every module
/// of the lane: their metatables are locked.
const WRAPPERS: &str = r#"
local shoal, body_raw, nearest_raw, outside = ...
local setmetatable, error, next = setmetatable, error, next
local locked = { __metatable = false }
local body = setmetatable({}, locked)
local near = setmetatable({}, locked)
local tank = setmetatable({}, locked)
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
end
function shoal.body()
  local b = body
  b.x, b.y, b.z, b.depth, b.to_floor, b.to_surface, b.to_wall,
    b.wall_x, b.wall_y, b.wall_z, b.contact, b.speed, b.heading, b.pitch, b.motion,
    b.queue = body_raw()
  return b
end
function shoal.nearest(kind, species)
  local k, sp, id, dist, bearing, elev, x, y, z, heading, speed = nearest_raw(kind, species)
  if k == nil then return nil end   -- nothing seen: no table to fill
  local n = near
  n.kind, n.species, n.id, n.distance, n.bearing, n.elevation = k, sp, id, dist, bearing, elev
  n.x, n.y, n.z, n.heading, n.speed = x, y, z, heading, speed
  return n
end
function shoal.tank()
  if now == nil then outside("tank") end
  local t = tank
  t.min_x, t.min_y, t.min_z, t.max_x, t.max_y, t.max_z = x0, y0, z0, x1, y1, z1
  return t
end
function shoal.time()
  if now == nil then outside("time") end
  return now
end
return stage, readonly
"#;

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
