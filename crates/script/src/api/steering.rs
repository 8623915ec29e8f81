//! The steering half of the `shoal` API: helpers that return a desired `heading, depth, speed`
//! (`seek`, `flee`, `arrive`, `wander`, the crowding rules, `avoid_*`), `blend` and `crowd`.

use glam::Vec3;
use mlua::{Lua, Table, Value, Variadic};
use shoal_core::world::{CROWD_DENSE, CROWD_NEAREST};

use super::*;

/// `heading, depth, speed`, or three nils.
pub(super) type Triple = (Option<f32>, Option<f32>, Option<f32>);

pub(super) fn triple(s: Option<Steer>) -> Triple {
    match s {
        Some(s) => (Some(s.heading), Some(s.depth), Some(s.speed)),
        None => (None, None, None),
    }
}

/// Cruise speed `s` and body length `l` of the fish's species.
pub(super) fn cruise_and_length(w: &World, f: FishId) -> (f32, f32) {
    w.species_of(f)
        .map(|s| {
            let d = &w.species(s).desc;
            (d.motion.s, d.motion.l)
        })
        .unwrap_or((1.0, 1.0))
}

/// The weighted mix of steering wishes `shoal.blend` and `shoal.crowd` return: headings averaged
/// as unit vectors, depth and speed as numbers; wishes that are `None` and weights ≤ 0 (or NaN)
/// count for nothing; nothing when no weight remains.
pub(super) fn blend(groups: impl Iterator<Item = (Option<(f64, f64, f64)>, f64)>) -> Triple64 {
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
pub(super) type Triple64 = (Option<f64>, Option<f64>, Option<f64>);

/// Steering helpers of one fish: `seek`, `flee`, `arrive`, `wander`.
pub(super) fn register_steering(lua: &Lua, shoal: &Table) -> mlua::Result<()> {
    shoal.set(
        "seek",
        lua.create_function(|lua, (x, y, z, speed): (f32, f32, f32, Option<f32>)| {
            with_world(lua, "seek", |w, f| {
                let speed = speed.unwrap_or_else(|| cruise_and_length(w, f).0);
                Ok(triple(Some(
                    fish_ref(w, f, "seek")?.seek(Vec3::new(x, y, z), speed),
                )))
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
                Ok(triple(Some(
                    fish_ref(w, f, "flee")?.flee(Vec3::new(x, y, z), speed),
                )))
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
                    let fish = fish_ref(w, f, "arrive")?;
                    Ok(triple(Some(fish.arrive(
                        Vec3::new(x, y, z),
                        r,
                        speed.unwrap_or(s),
                    ))))
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
                    Ok(triple(Some(fish_ref(w, f, "wander")?.wander(
                        c,
                        max_turn.unwrap_or(0.6),
                        max_depth_change.unwrap_or(0.5 * l),
                        speed.unwrap_or(s),
                    ))))
                })
            },
        )?,
    )?;
    Ok(())
}

/// Which neighbours `shoal.crowd` takes (its `nearest` argument).
#[derive(Clone, Copy)]
enum CrowdOf {
    /// nil: every fish within the radii, sampled for alignment and cohesion where the
    /// neighbourhood is dense ([`World::steer_crowd_bounded`]).
    Bounded,
    /// `"all"`: every fish within the radii, however many ([`World::steer_crowd`]).
    All,
    /// A whole number ≥ 1: the nearest that many ([`World::steer_crowd_nearest`]).
    Nearest(usize),
}

/// `shoal.crowd`'s `nearest` argument: nil, a whole number ≥ 1 or the string `"all"`.
fn crowd_of(v: &Value) -> mlua::Result<CrowdOf> {
    let bad = |shown: String| {
        rt(format!(
            "shoal.crowd: nearest is {shown}: must be a whole number of neighbours (1 or more, \
             e.g. {CROWD_NEAREST}), \"all\", or nil for every fish within the radii (sampled \
             where more than {CROWD_DENSE} are near)"
        ))
    };
    match v {
        Value::Nil => Ok(CrowdOf::Bounded),
        Value::Integer(n) if *n >= 1 => {
            Ok(CrowdOf::Nearest(usize::try_from(*n).unwrap_or(usize::MAX)))
        }
        Value::Number(x) if x.fract() == 0.0 && *x >= 1.0 && x.is_finite() => {
            Ok(CrowdOf::Nearest(*x as usize))
        }
        Value::String(s) if s.as_bytes().as_ref() == b"all" => Ok(CrowdOf::All),
        Value::Integer(n) => Err(bad(n.to_string())),
        Value::Number(x) => Err(bad(x.to_string())),
        Value::String(s) => Err(bad(format!("{:?}", s.to_string_lossy()))),
        other => Err(bad(format!("a {}", other.type_name()))),
    }
}

/// Steering against neighbours and surroundings: `separation`, `alignment`, `cohesion`,
/// `avoid_obstacles`, `avoid_walls`, `blend`, `crowd`.
pub(super) fn register_crowding(lua: &Lua, shoal: &Table) -> mlua::Result<()> {
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
                    let fish = fish_ref(w, f, "avoid_obstacles")?;
                    Ok(triple(timed(ctx, || {
                        fish.avoid_obstacles(
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
                let fish = fish_ref(w, f, "avoid_walls")?;
                Ok(triple(timed(ctx, || {
                    fish.avoid_walls(margin.unwrap_or(2.0 * l), speed.unwrap_or(s))
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
            |lua,
             (rs, ws, ra, wa, rc, wc, speed, nearest): (
                f32,
                f64,
                f32,
                f64,
                f32,
                f64,
                Option<f32>,
                Value,
            )| {
                let of = crowd_of(&nearest)?;
                with_ctx(lua, "crowd", |w, fish, ctx| {
                    let s = speed.unwrap_or_else(|| cruise_and_length(w, fish).0);
                    let rs = finite_arg("crowd", "separation radius", rs)?;
                    let ra = finite_arg("crowd", "alignment radius", ra)?;
                    let rc = finite_arg("crowd", "cohesion radius", rc)?;
                    let radii = [rs, ra, rc];
                    let crowd = timed(ctx, || match of {
                        CrowdOf::Bounded => w.steer_crowd_bounded(fish, radii, s),
                        CrowdOf::All => w.steer_crowd(fish, rs, ra, rc, s),
                        CrowdOf::Nearest(k) => w.steer_crowd_nearest(fish, radii, s, Some(k)),
                    });
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
    Ok(())
}
