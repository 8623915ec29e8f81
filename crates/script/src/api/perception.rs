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

/// A percept as the values the raw `nearest` gives `shoal.nearest`'s wrapper: species number
/// (its index + 1, 0 for none), id, distance, bearing, elevation, x, y, z, heading, speed (all
/// nil when nothing is seen; the wrapper knows the kind it asked for).
pub(super) type PerceptValues = (
    Option<u16>,
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

pub(super) const NOTHING_SEEN: PerceptValues =
    (None, None, None, None, None, None, None, None, None, None);

pub(super) fn percept_values(p: &Percept) -> PerceptValues {
    let id = p
        .fish
        .map(|f| f.index)
        .or(p.food.map(|f| f.0))
        .or(p.obstacle.map(|o| o.0));
    (
        Some(p.species.map_or(0, |s| s.0 + 1)),
        id,
        Some(p.distance),
        Some(p.bearing),
        Some(p.elevation),
        Some(p.pos.x),
        Some(p.pos.y),
        Some(p.pos.z),
        Some(p.heading),
        Some(p.speed),
    )
}

/// Perception: `see`, `motion`, `random` in `shoal`; the raw `body`, `nearest`, `species`,
/// `species_name` and `outside` (a message) that `wrappers.lua` builds `shoal.body`,
/// `shoal.nearest`, `shoal.species`, `shoal.tank` and `shoal.time` on, in the returned table.
pub(super) fn register_perception(lua: &Lua, shoal: &Table) -> mlua::Result<Table> {
    shoal.set(
        "see",
        lua.create_function(|lua, (kind, max): (Option<LuaString>, Option<usize>)| {
            let kind = match &kind {
                Some(k) => Some(PerceptKind::from_name(&k.as_bytes()).ok_or_else(|| {
                    rt("shoal.see: kind must be \"fish\", \"food\", \"obstacle\" or \"predator\"")
                })?),
                None => None,
            };
            let max = max.unwrap_or(DEFAULT_SEE_MAX);
            with_ctx(lua, "see", |w, f, ctx| {
                let start = sense_start(ctx);
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
                sense_end(ctx, start);
                Ok(out)
            })
        })?,
    )?;
    let nearest_raw = lua.create_function(|lua, (kind, species): (u8, Option<LuaString>)| {
        // Numbered as `KIND` in wrappers.lua passes them.
        let kind = PerceptKind::numbered(kind)
            .ok_or_else(|| rt(format!("shoal.nearest: kind must be {KINDS}")))?;
        with_ctx(lua, "nearest", |w, f, ctx| {
            let start = sense_start(ctx);
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
            sense_end(ctx, start);
            Ok(found.as_ref().map_or(NOTHING_SEEN, percept_values))
        })
    })?;
    let species_name_raw = lua.create_function(|lua, number: u16| {
        with_ctx(lua, "nearest", |w, _, ctx| {
            let s = number
                .checked_sub(1)
                .map(SpeciesId)
                .filter(|s| w.try_species(*s).is_some())
                .ok_or_else(|| rt(format!("shoal.nearest: no species numbered {number}")))?;
            species_name(lua, ctx, w, s)
        })
    })?;
    let body_raw = lua.create_function(|lua, ()| {
        with_ctx(lua, "body", |w, f, ctx| {
            let (playing, queued) = (
                ctx.controls.player().current_kind(),
                ctx.controls.player().queue_len(),
            );
            let motion = motion_number(playing);
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
    let species_raw = lua.create_function(|lua, ()| {
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
    })?;
    let outside_fn = lua.create_function(|_, name: String| Ok(outside_message(&name)))?;
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
    let raw = lua.create_table()?;
    raw.raw_set("body", body_raw)?;
    raw.raw_set("nearest", nearest_raw)?;
    raw.raw_set("species", species_raw)?;
    raw.raw_set("species_name", species_name_raw)?;
    raw.raw_set("outside", outside_fn)?;
    Ok(raw)
}
