//! A recording out of shoal (issue 38): [`export`] turns a `.shoalrun` into glTF skeletal
//! animation (the document is [`shoal_core::asset::animation`]'s), and [`inspect`] says what a
//! recording holds and, at a moment, where every fish and joint is — the same values export
//! writes — so scripts and tests outside shoal can read a recording without replaying it.
//!
//! A recording keeps the roots' poses; the joints' come from running it again with its own
//! scripts ([`super::replay_recorded`], checked frame by frame against the recording): at each
//! exported tick every fish's root, pitch and driven joints' yaws are read from the world and
//! posed by the species' rig ([`shoal_core::species::SpeciesRig::pose`]), which is the pose
//! the renderer draws.

use std::collections::{BTreeMap, HashMap};

use glam::{Quat, Vec3};
use serde_json::json;

use super::run_file::Run;
use super::{TimelineError, replay_recorded};
use shoal_core::asset::animation::{
    AnimSpecies, FishTrack, Prop, SchoolAnimation, SchoolDocument, joint_world_matrices, key_bytes,
};
use shoal_core::skeleton::JointTransform;
use shoal_core::world::{FishId, Species, SpeciesId, World};

/// Why an export or inspection could not be made.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// Replaying the recording (its file, its scripts, a species' model).
    #[error(transparent)]
    Timeline(#[from] TimelineError),
    /// The time range selects nothing.
    #[error("--from {from} --to {to}: {why} (the recording covers 0 to {seconds:.2} s)")]
    Range {
        /// Start asked for, seconds.
        from: f64,
        /// End asked for, seconds.
        to: f64,
        /// What is wrong.
        why: String,
        /// The recording's length.
        seconds: f64,
    },
    /// A moment outside the recording.
    #[error("--at {at}: {why} (the recording covers 0 to {seconds:.2} s)")]
    At {
        /// The moment asked for.
        at: f64,
        /// What is wrong.
        why: &'static str,
        /// The recording's length.
        seconds: f64,
    },
    /// `--fish` names fish the recording does not have.
    #[error("--fish: {unknown} {verb} not in the recording{span} (it has {known})")]
    UnknownFish {
        /// The unknown ids.
        unknown: String,
        /// "is" or "are".
        verb: &'static str,
        /// " between A and B s" when the fish exists elsewhere in the recording.
        span: String,
        /// The ids it has, as ranges.
        known: String,
    },
    /// `--fish` could not be parsed.
    #[error("--fish {given:?}: {why}")]
    FishSyntax {
        /// The argument.
        given: String,
        /// What is wrong.
        why: String,
    },
    /// `--rate` is not usable.
    #[error("--rate {rate}: {why}")]
    Rate {
        /// The rate asked for.
        rate: f64,
        /// What is wrong.
        why: String,
    },
    /// The export would not fit in the memory bound.
    #[error(
        "refused: exporting {fish} fish × {keys} keys needs about {estimate_mib} MiB, more than \
         the {limit_mib} MiB bound (--memory-limit); export fewer fish (--fish), a shorter span \
         (--from/--to) or a lower --rate"
    )]
    TooLarge {
        /// Fish exported.
        fish: usize,
        /// Keys per fish.
        keys: usize,
        /// Estimated peak memory, MiB.
        estimate_mib: u64,
        /// The bound, MiB.
        limit_mib: u64,
    },
}

/// A fish as a command line names it: `3`, `#3`, `3.1` / `#3.1` (slot 3, generation 1), or
/// `fish_3` / `fish_3_g1` (the exported node's name).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct FishSel {
    /// Slot index.
    pub index: u32,
    /// Generation; `None` matches every generation of the slot.
    pub generation: Option<u32>,
}

/// Parses `--fish` (comma-separated ids, see [`FishSel`]; `a-b` ranges of slots too).
pub fn parse_fish_ids(s: &str) -> Result<Vec<FishSel>, ExportError> {
    let bad = |why: String| ExportError::FishSyntax {
        given: s.to_owned(),
        why,
    };
    let mut out = Vec::new();
    for part in s.split(',').map(str::trim) {
        if part.is_empty() {
            return Err(bad("an empty id between commas".into()));
        }
        let p = part
            .strip_prefix("fish_")
            .or_else(|| part.strip_prefix('#'))
            .unwrap_or(part);
        let num = |t: &str| {
            t.parse::<u32>().map_err(|_| {
                bad(format!(
                    "`{part}` is not a fish id (3, #3, 3.1 for generation 1, fish_3, or a range 3-7)"
                ))
            })
        };
        if let Some((a, b)) = p.split_once('-') {
            let (a, b) = (num(a)?, num(b)?);
            if a > b {
                return Err(bad(format!("the range `{part}` runs backwards")));
            }
            out.extend((a..=b).map(|index| FishSel {
                index,
                generation: None,
            }));
        } else if let Some((i, g)) = p.split_once('.').or_else(|| p.split_once("_g")) {
            out.push(FishSel {
                index: num(i)?,
                generation: Some(num(g)?),
            });
        } else {
            out.push(FishSel {
                index: num(p)?,
                generation: None,
            });
        }
    }
    Ok(out)
}

/// The fish's id as shoal prints it: `#3`, `#3.1` after the slot's reuse.
pub fn fish_label(index: u32, generation: u32) -> String {
    if generation == 0 {
        format!("#{index}")
    } else {
        format!("#{index}.{generation}")
    }
}

/// The fish's node name in an export: `fish_3`, `fish_3_g1`.
pub fn fish_node_name(index: u32, generation: u32) -> String {
    if generation == 0 {
        format!("fish_{index}")
    } else {
        format!("fish_{index}_g{generation}")
    }
}

/// What to export.
#[derive(Debug, Clone)]
pub struct ExportSpec<'a> {
    /// The recording.
    pub run: &'a Run,
    /// Its name as given (for the document's extras).
    pub run_name: &'a str,
    /// The repository root (species assets).
    pub root: &'a std::path::Path,
    /// Start, seconds (default 0).
    pub from_s: Option<f64>,
    /// End, seconds (default the end of the recording).
    pub to_s: Option<f64>,
    /// Only these fish (default all).
    pub fish: Option<Vec<FishSel>>,
    /// Keys per second (default the recording's tick rate).
    pub rate_hz: Option<f64>,
    /// Rocks, food and the tank as static nodes.
    pub props: bool,
    /// Refuse an export whose estimated peak memory is above this, bytes.
    pub memory_limit: u64,
}

/// What went on, for progress reports.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Stage {
    /// Running the recording again: tick `done` of `total`.
    Replay,
    /// Writing fish `done` of `total`.
    Write,
}

/// A finished export: the document and what it holds.
pub struct Export {
    /// The document, to pack as `.glb` or `.gltf`.
    pub document: SchoolDocument,
    /// Fish written.
    pub fish: usize,
    /// Fish of them that are absent at some key (scaled to 0 there).
    pub appearing_or_leaving: usize,
    /// Keys per fish.
    pub keys: usize,
    /// Seconds the animation lasts.
    pub seconds: f64,
    /// Keys per second.
    pub rate_hz: f64,
    /// Species written (mesh names).
    pub species: Vec<String>,
    /// Below the tick rate: the largest distance, over every fish, joint and skipped tick,
    /// between shoal's pose and the one linear interpolation of the keys gives, in body
    /// lengths of the fish's species, and when (seconds into the recording) and which fish.
    pub rate_error: Option<(f32, f64, String)>,
    /// Props written.
    pub props: usize,
}

/// A fish's pose at one tick, as the document stores it.
#[derive(Debug, Clone)]
struct Sample {
    translation: Vec3,
    rotation: Quat,
    driven: Vec<Quat>,
}

/// Root and driven-joint rotations of `id` as the document stores them.
fn sample_of(
    world: &World,
    id: FishId,
    species: &Species,
    locals: &mut Vec<JointTransform>,
) -> Option<Sample> {
    let fish = world.fish(id)?;
    let root = fish.root();
    locals.resize(
        species.model.skeleton.num_joints(),
        JointTransform::IDENTITY,
    );
    species.rig.pose(&fish.yaw(), locals);
    Some(Sample {
        translation: root.pos,
        rotation: Quat::from_rotation_y(root.heading) * Quat::from_rotation_z(root.pitch),
        driven: species
            .rig
            .driven_joints
            .iter()
            .map(|&j| locals[j].rotation)
            .collect(),
    })
}

/// A fish of a recording: slot index and generation.
type FishKey = (u32, u32);

fn ticks_in(run: &Run, s: f64) -> usize {
    (s * run.header.tick_hz).round() as usize
}

/// Ranges of slot indices (`#0–#36, #40`) of the ids in `frames`.
fn known_ranges(ids: &std::collections::BTreeSet<(u32, u32)>) -> String {
    let mut slots: Vec<u32> = ids.iter().map(|&(i, _)| i).collect();
    slots.dedup();
    let mut parts = Vec::new();
    let mut k = 0;
    while k < slots.len() {
        let start = slots[k];
        while k + 1 < slots.len() && slots[k + 1] == slots[k] + 1 {
            k += 1;
        }
        parts.push(if slots[k] == start {
            format!("#{start}")
        } else {
            format!("#{start}–#{}", slots[k])
        });
        k += 1;
    }
    let reused: Vec<String> = ids
        .iter()
        .filter(|&&(_, g)| g > 0)
        .map(|&(i, g)| fish_label(i, g))
        .collect();
    let mut s = if parts.is_empty() {
        "no fish".to_owned()
    } else {
        parts.join(", ")
    };
    if !reused.is_empty() {
        s.push_str(&format!(", and reused slots {}", reused.join(", ")));
    }
    s
}

fn matches(sel: &[FishSel], index: u32, generation: u32) -> bool {
    sel.iter()
        .any(|s| s.index == index && s.generation.is_none_or(|g| g == generation))
}

/// Which ids of the recording `--fish` selects in ticks `a..=b`; errors name the unknown ones.
fn select_fish(
    run: &Run,
    sel: Option<&[FishSel]>,
    a: usize,
    b: usize,
) -> Result<Option<std::collections::BTreeSet<(u32, u32)>>, ExportError> {
    let Some(sel) = sel else {
        return Ok(None);
    };
    let all: std::collections::BTreeSet<(u32, u32)> = run
        .frames
        .iter()
        .flatten()
        .map(|p| (p.index, p.generation))
        .collect();
    let span: std::collections::BTreeSet<(u32, u32)> = run.frames[a..=b]
        .iter()
        .flatten()
        .map(|p| (p.index, p.generation))
        .collect();
    let mut unknown = Vec::new();
    let mut elsewhere = true;
    for s in sel {
        let hit = |set: &std::collections::BTreeSet<(u32, u32)>| {
            set.iter()
                .any(|&(i, g)| matches(std::slice::from_ref(s), i, g))
        };
        if !hit(&span) {
            elsewhere &= hit(&all);
            unknown.push(match s.generation {
                Some(g) => fish_label(s.index, g),
                None => fish_label(s.index, 0),
            });
        }
    }
    if !unknown.is_empty() {
        unknown.dedup();
        let whole = a == 0 && b + 1 == run.frames.len();
        return Err(ExportError::UnknownFish {
            verb: if unknown.len() == 1 { "is" } else { "are" },
            unknown: unknown.join(", "),
            span: if elsewhere && !whole {
                format!(" between {:.2} and {:.2} s", run.time_of(a), run.time_of(b))
            } else {
                String::new()
            },
            known: known_ranges(if whole || !elsewhere { &all } else { &span }),
        });
    }
    Ok(Some(
        span.into_iter()
            .filter(|&(i, g)| matches(sel, i, g))
            .collect(),
    ))
}

/// The ticks of the keys: `a`, then every `tick_hz / rate` ticks (rounded), and `b`.
fn key_ticks(a: usize, b: usize, tick_hz: f64, rate: f64) -> Vec<usize> {
    let step = tick_hz / rate;
    let mut out = Vec::new();
    let mut i = 0usize;
    loop {
        let k = a + (i as f64 * step).round() as usize;
        if k >= b {
            break;
        }
        if out.last() != Some(&k) {
            out.push(k);
        }
        i += 1;
    }
    out.push(b);
    out
}

/// Largest joint distance between `exact` and the pose interpolated between keys `p` and `q`
/// at fraction `s` (linear translation, spherical rotations, as glTF LINEAR does), in units.
fn interpolation_error(species: &Species, p: &Sample, q: &Sample, s: f32, exact: &Sample) -> f32 {
    let t = p.translation.lerp(q.translation, s);
    let r = p.rotation.slerp(q.rotation, s);
    let d: Vec<Quat> = p
        .driven
        .iter()
        .zip(&q.driven)
        .map(|(a, b)| a.slerp(*b, s))
        .collect();
    let (m, rig) = (&species.model, &species.rig);
    let got = joint_world_matrices(m, rig, t, r, &d);
    let want = joint_world_matrices(m, rig, exact.translation, exact.rotation, &exact.driven);
    got.iter()
        .zip(&want)
        .map(|(a, b)| a.w_axis.truncate().distance(b.w_axis.truncate()))
        .fold(0.0, f32::max)
}

/// Exports `spec.run` (see the module docs); `progress` hears of the replay and the writing.
pub fn export(
    spec: &ExportSpec<'_>,
    progress: &mut dyn FnMut(Stage, usize, usize),
) -> Result<Export, ExportError> {
    let run = spec.run;
    let hz = run.header.tick_hz;
    let seconds = run.seconds();
    let from = spec.from_s.unwrap_or(0.0);
    let to = spec.to_s.unwrap_or(seconds);
    let range = |why: &str| ExportError::Range {
        from,
        to,
        why: why.to_owned(),
        seconds,
    };
    if !(from.is_finite() && to.is_finite()) {
        return Err(range("times must be numbers"));
    }
    if from < 0.0 || to > seconds + 0.5 / hz {
        return Err(range("outside the recording"));
    }
    let (a, b) = (
        ticks_in(run, from),
        ticks_in(run, to).min(run.frames.len() - 1),
    );
    if b <= a {
        return Err(range(
            "an empty time range: --to must be later than --from by a tick or more",
        ));
    }
    let rate = spec.rate_hz.unwrap_or(hz);
    if !(rate.is_finite() && rate > 0.0) {
        return Err(ExportError::Rate {
            rate,
            why: "expected a positive number of keys per second".into(),
        });
    }
    if rate > hz * (1.0 + 1e-9) {
        return Err(ExportError::Rate {
            rate,
            why: format!(
                "higher than the recording's tick rate ({hz} Hz): there is nothing between ticks"
            ),
        });
    }
    let selected = select_fish(run, spec.fish.as_deref(), a, b)?;
    let wanted = |p: (u32, u32)| selected.as_ref().is_none_or(|s| s.contains(&p));
    let keys = key_ticks(a, b, hz, rate);
    let key_of: HashMap<usize, usize> = keys.iter().enumerate().map(|(i, &k)| (k, i)).collect();
    let lower_rate = keys.len() < b - a + 1;

    let n_fish = {
        let ids: std::collections::BTreeSet<(u32, u32)> = run.frames[a..=b]
            .iter()
            .flatten()
            .map(|p| (p.index, p.generation))
            .filter(|&p| wanted(p))
            .collect();
        ids.len()
    };

    let mut species: Vec<Species> = Vec::new();
    let mut species_of: HashMap<SpeciesId, usize> = HashMap::new();
    let mut tracks: Vec<FishTrack> = Vec::new();
    let mut track_of: HashMap<(u32, u32), usize> = HashMap::new();
    let mut first_last: Vec<(usize, usize)> = Vec::new();
    let mut samples_prev: HashMap<(u32, u32), Sample> = HashMap::new();
    let mut pending: Vec<(usize, Vec<(FishKey, Sample)>)> = Vec::new();
    let mut worst: Option<(f32, f64, String)> = None;
    let mut locals = Vec::new();
    let mut checked = false;
    let mut refused = None;
    let mut props = Vec::new();
    let total_ticks = b;
    replay_recorded(run, spec.root, b, |k, sim| {
        if k % 60 == 0 || k == b {
            progress(Stage::Replay, k, total_ticks);
        }
        if k < a {
            return Ok(());
        }
        let world = sim.world();
        if !checked {
            checked = true;
            let driven = (0..world.num_species())
                .map(|s| world.species(SpeciesId(s as u16)).rig.driven_joints.len())
                .max()
                .unwrap_or(0);
            let mesh_bytes: usize = (0..world.num_species())
                .map(|s| {
                    let m = &world.species(SpeciesId(s as u16)).model.mesh;
                    m.positions.len() * 80 + m.indices.len() * 4
                })
                .sum();
            let joints = (0..world.num_species())
                .map(|s| {
                    world
                        .species(SpeciesId(s as u16))
                        .model
                        .skeleton
                        .num_joints()
                })
                .max()
                .unwrap_or(0);
            // Three copies of the keys (the tracks, the binary buffer, the packed file), the
            // document's JSON tree (about 2 KiB per node of a fish, calibrated on 1,000
            // porgies), the meshes, and the running simulation (its state, plus a base for the
            // Lua lanes, palettes and code).
            let estimate = 3 * (keys.len() * n_fish * key_bytes(driven) + mesh_bytes) as u64
                + (n_fish * (joints + 4) * 2048) as u64
                + world.state().approx_bytes() as u64
                + (64 << 20);
            if estimate > spec.memory_limit {
                refused = Some(ExportError::TooLarge {
                    fish: n_fish,
                    keys: keys.len(),
                    estimate_mib: estimate.div_ceil(1 << 20),
                    limit_mib: spec.memory_limit >> 20,
                });
                return Err(TimelineError::Invalid("refused".into()));
            }
            if spec.props {
                props = props_of(world);
            }
        }
        let key = key_of.get(&k).copied();
        let mut skipped = Vec::new();
        for id in world.fish_ids() {
            let pid = (id.index, id.generation);
            if !wanted(pid) {
                continue;
            }
            let Some(sid) = world.species_of(id) else {
                continue;
            };
            let s_idx = *species_of.entry(sid).or_insert_with(|| {
                species.push(world.species(sid).clone());
                species.len() - 1
            });
            let sp = &species[s_idx];
            let Some(sample) = sample_of(world, id, sp, &mut locals) else {
                continue;
            };
            let Some(key) = key else {
                skipped.push((pid, sample));
                continue;
            };
            let t = *track_of.entry(pid).or_insert_with(|| {
                let extras = json!({
                    "id": fish_label(id.index, id.generation),
                    "index": id.index,
                    "generation": id.generation,
                    "species": sp.desc.name,
                    "behavior": world.behavior_of(id),
                    "body_length": sp.desc.motion.l,
                });
                tracks.push(FishTrack::new(
                    fish_node_name(id.index, id.generation),
                    s_idx,
                    extras,
                    keys.len(),
                    sp.rig.driven_joints.len(),
                ));
                first_last.push((key, key));
                tracks.len() - 1
            });
            let tr = &mut tracks[t];
            let nd = sp.rig.driven_joints.len();
            tr.present[key] = true;
            tr.translation[key] = sample.translation;
            tr.rotation[key] = sample.rotation;
            tr.joint_rotations[key * nd..(key + 1) * nd].copy_from_slice(&sample.driven);
            first_last[t].1 = key;
            if lower_rate {
                // The ticks since the previous key, against the keys' interpolation.
                for (tick, fishes) in &pending {
                    let Some(prev) = samples_prev.get(&pid) else {
                        continue;
                    };
                    let Some((_, exact)) = fishes.iter().find(|(p, _)| *p == pid) else {
                        continue;
                    };
                    let k0 = keys[key - 1];
                    let s = (*tick - k0) as f32 / (k - k0) as f32;
                    let l = sp.desc.motion.l;
                    let e = interpolation_error(sp, prev, &sample, s, exact) / l;
                    if worst.as_ref().is_none_or(|w| e > w.0) {
                        worst = Some((e, run.time_of(*tick), fish_label(pid.0, pid.1)));
                    }
                }
                samples_prev.insert(pid, sample);
            }
        }
        if lower_rate {
            if key.is_some() {
                pending.clear();
            } else {
                pending.push((k, skipped));
            }
        }
        Ok(())
    })
    .map_err(|e| refused.take().unwrap_or(ExportError::Timeline(e)))?;

    let t0 = run.time_of(keys[0]);
    let times: Vec<f32> = keys.iter().map(|&k| (run.time_of(k) - t0) as f32).collect();
    let mut appearing = 0;
    for (t, tr) in tracks.iter_mut().enumerate() {
        let nd = species[tr.species].rig.driven_joints.len();
        tr.settle(nd);
        let (f, l) = first_last[t];
        if tr.present.iter().any(|p| !p) {
            appearing += 1;
        }
        if let Some(x) = tr.extras.as_object_mut() {
            x.insert("present_from_s".into(), json!(times[f]));
            x.insert("present_to_s".into(), json!(times[l]));
        }
    }
    let anim = SchoolAnimation {
        species: species
            .iter()
            .map(|s| AnimSpecies {
                name: &s.desc.name,
                model: &s.model,
                rig: &s.rig,
            })
            .collect(),
        times,
        fish: tracks,
        props,
        extras: json!({
            "recording": spec.run_name,
            "scene": run.header.scene,
            "seed": run.header.seed,
            "from_s": t0,
            "to_s": run.time_of(b),
            "rate_hz": rate,
            "tick_hz": hz,
        }),
    };
    let total = anim.fish.len();
    let generator = format!("shoal {} (shoal export)", env!("CARGO_PKG_VERSION"));
    let document = anim.write(&generator, &mut |done, total| {
        progress(Stage::Write, done, total)
    });
    Ok(Export {
        document,
        fish: total,
        appearing_or_leaving: appearing,
        keys: keys.len(),
        seconds: run.time_of(b) - t0,
        rate_hz: rate,
        species: species.iter().map(|s| s.desc.name.clone()).collect(),
        rate_error: worst,
        props: anim.props.len(),
    })
}

/// The rocks, food (where it is now) and tank of `w`.
fn props_of(w: &World) -> Vec<Prop> {
    let tank = w.tank();
    let mut out = vec![Prop::Tank {
        min: tank.min,
        max: tank.max,
    }];
    out.extend(w.obstacles().iter().map(|o| Prop::Rock {
        centre: o.pos,
        radius: o.radius,
    }));
    out.extend(w.foods().map(|(_, f)| Prop::Food {
        pos: f.pos,
        radius: FOOD_RADIUS,
    }));
    out
}

/// Radius a food pellet is drawn with, world units (the renderer's).
const FOOD_RADIUS: f32 = 3.0;

/// What a recording holds.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Inspection {
    /// The scene file, relative to the scripts directory.
    pub scene: String,
    /// The seed.
    pub seed: u64,
    /// Script lanes.
    pub lanes: usize,
    /// The shoal that recorded it.
    pub shoal_version: String,
    /// Ticks per second.
    pub tick_hz: f64,
    /// Seconds it covers.
    pub seconds: f64,
    /// Frames (ticks + 1).
    pub frames: usize,
    /// The recorded script files.
    pub scripts: Vec<String>,
    /// What it is a replay of, if anything.
    pub replay_of: Option<super::run_file::ReplayOf>,
    /// Inputs from outside the scripts (a behaviour test's actions).
    pub inputs: usize,
    /// Every fish that is in it at some tick.
    pub fish: Vec<FishInfo>,
    /// The moment asked for.
    pub at: Option<Moment>,
}

/// A fish of a recording.
#[derive(Debug, Clone, serde::Serialize)]
pub struct FishInfo {
    /// `#3` (`#3.1`: generation 1 of slot 3).
    pub id: String,
    /// Its node's name in an export.
    pub node: String,
    /// Species.
    pub species: String,
    /// Behaviour script when first seen.
    pub behavior: Option<String>,
    /// Body length, world units.
    pub body_length: f32,
    /// First time it is in the world, seconds.
    pub from_s: f64,
    /// Last time it is in the world, seconds.
    pub to_s: f64,
}

/// Every fish at a moment.
#[derive(Debug, Clone, serde::Serialize)]
pub struct Moment {
    /// The moment, seconds (the tick's time).
    pub t_s: f64,
    /// The tick.
    pub tick: usize,
    /// Every fish in the world then.
    pub fish: Vec<FishPose>,
}

/// A fish at a moment: the values an export writes, in world units.
#[derive(Debug, Clone, serde::Serialize)]
pub struct FishPose {
    /// `#3`.
    pub id: String,
    /// Its node's name in an export.
    pub node: String,
    /// Species.
    pub species: String,
    /// Behaviour script.
    pub behavior: Option<String>,
    /// Body length, world units.
    pub body_length: f32,
    /// Root (head end of the spine).
    pub pos: [f32; 3],
    /// Heading, radians counter-clockwise seen from above, 0 = +x.
    pub heading: f32,
    /// Pitch, radians, nose up.
    pub pitch: f32,
    /// Every joint's world position, skeleton order.
    pub joints: Vec<JointPos>,
}

/// A joint's world position.
#[derive(Debug, Clone, serde::Serialize)]
pub struct JointPos {
    /// The joint's name in the species' model.
    pub name: String,
    /// Its node's name in an export.
    pub node: String,
    /// World position.
    pub pos: [f32; 3],
}

/// What `run` holds and, at `at_s`, where every fish and joint is (running the recording
/// again with its own scripts).
pub fn inspect(
    run: &Run,
    root: &std::path::Path,
    at_s: Option<f64>,
) -> Result<Inspection, ExportError> {
    let seconds = run.seconds();
    let at = match at_s {
        None => None,
        Some(t) if !t.is_finite() => {
            return Err(ExportError::At {
                at: t,
                why: "not a number",
                seconds,
            });
        }
        Some(t) if t < 0.0 || ticks_in(run, t) >= run.frames.len() => {
            return Err(ExportError::At {
                at: t,
                why: "outside the recording",
                seconds,
            });
        }
        Some(t) => Some(ticks_in(run, t)),
    };
    let last = run.frames.len() - 1;
    let mut fish: BTreeMap<(u32, u32), FishInfo> = BTreeMap::new();
    let mut moment = None;
    let mut locals = Vec::new();
    replay_recorded(run, root, last, |k, sim| {
        let w = sim.world();
        for id in w.fish_ids() {
            let Some(sid) = w.species_of(id) else {
                continue;
            };
            let sp = w.species(sid);
            let t = run.time_of(k);
            fish.entry((id.index, id.generation))
                .and_modify(|f| f.to_s = t)
                .or_insert_with(|| FishInfo {
                    id: fish_label(id.index, id.generation),
                    node: fish_node_name(id.index, id.generation),
                    species: sp.desc.name.clone(),
                    behavior: w.behavior_of(id).map(str::to_owned),
                    body_length: sp.desc.motion.l,
                    from_s: t,
                    to_s: t,
                });
        }
        if Some(k) == at {
            moment = Some(moment_of(w, k, run.time_of(k), &mut locals));
        }
        Ok(())
    })?;
    Ok(Inspection {
        scene: run.header.scene.clone(),
        seed: run.header.seed,
        lanes: run.header.lanes,
        shoal_version: run.header.shoal_version.clone(),
        tick_hz: run.header.tick_hz,
        seconds,
        frames: run.frames.len(),
        scripts: run.header.scripts.keys().cloned().collect(),
        replay_of: run.header.replay_of.clone(),
        inputs: run.header.inputs.len(),
        fish: fish.into_values().collect(),
        at: moment,
    })
}

fn moment_of(w: &World, tick: usize, t_s: f64, locals: &mut Vec<JointTransform>) -> Moment {
    let mut fish = Vec::new();
    for id in w.fish_ids() {
        let Some(sid) = w.species_of(id) else {
            continue;
        };
        let sp = w.species(sid);
        let Some(s) = sample_of(w, id, sp, locals) else {
            continue;
        };
        let Some(root) = w.root(id) else {
            continue;
        };
        let node = fish_node_name(id.index, id.generation);
        let joints = joint_world_matrices(&sp.model, &sp.rig, s.translation, s.rotation, &s.driven)
            .iter()
            .zip(sp.model.skeleton.names())
            .map(|(m, name)| JointPos {
                name: name.clone(),
                node: format!("{node}_{}", shoal_core::asset::sanitize_name(name)),
                pos: m.w_axis.truncate().to_array(),
            })
            .collect();
        fish.push(FishPose {
            id: fish_label(id.index, id.generation),
            node,
            species: sp.desc.name.clone(),
            behavior: w.behavior_of(id).map(str::to_owned),
            body_length: sp.desc.motion.l,
            pos: root.pos.to_array(),
            heading: root.heading,
            pitch: root.pitch,
            joints,
        });
    }
    Moment { t_s, tick, fish }
}
