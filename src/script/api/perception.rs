//! The perception half of the `shoal` API: `see`, `nearest`, `body`, `species`, `motion`,
//! `random`, and how percepts become Lua values.

use mlua::{Function, Lua, LuaString, Table, Value};
use rand::Rng;

use super::*;

pub(super) fn species_name(
    lua: &Lua,
    ctx: &mut Ctx,
    world: &World,
    s: SpeciesId,
) -> mlua::Result<LuaString> {
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

pub(super) fn kind_key(keys: &Keys, k: PerceptKind) -> &LuaString {
    match k {
        PerceptKind::Fish => &keys.kind_fish,
        PerceptKind::Food => &keys.kind_food,
        PerceptKind::Obstacle => &keys.kind_obstacle,
        PerceptKind::Predator => &keys.kind_predator,
    }
}

pub(super) fn parse_kind(s: &[u8]) -> Option<PerceptKind> {
    Some(match s {
        b"fish" => PerceptKind::Fish,
        b"food" => PerceptKind::Food,
        b"obstacle" => PerceptKind::Obstacle,
        b"predator" => PerceptKind::Predator,
        _ => return None,
    })
}

pub(super) fn fill_percept(
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
pub(super) type PerceptValues = (
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

pub(super) const NOTHING_SEEN: PerceptValues = (
    None, None, None, None, None, None, None, None, None, None, None,
);

pub(super) fn percept_values(
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
pub(super) fn motion_name(lua: &Lua, ctx: &mut Ctx, name: &'static str) -> mlua::Result<LuaString> {
    if let Some((_, s)) = ctx.motion_names.iter().find(|(n, _)| *n == name) {
        return Ok(s.clone());
    }
    let s = lua.create_string(name)?;
    ctx.motion_names.push((name, s.clone()));
    Ok(s)
}

/// The functions a raw perception query goes through on the Lua side (see [`WRAPPERS`]).
pub(super) struct RawSenses {
    pub(super) body: Function,
    pub(super) nearest: Function,
    pub(super) outside: Function,
}

/// Perception: `see`, `nearest`, `body`, `species`, `motion`, `random`.
pub(super) fn register_perception(lua: &Lua, shoal: &Table) -> mlua::Result<RawSenses> {
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
    Ok(RawSenses {
        body: body_raw,
        nearest: nearest_raw,
        outside: outside_fn,
    })
}
