//! Measuring the tick (issue 7): a scene that scales with the fish count, a timing loop, and the
//! figures `shoal bench sim` prints.
//!
//! The loop ticks a [`Pipeline`] of either [`Behavior`]: the built-in
//! [`super::driver::WanderDriver`] ([`WanderPipeline`]) or the Lua scripts with the shipped behaviours
//! (`script::Simulation`'s, in `cli::bench`).

use std::time::Instant;

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg32;

use super::{
    Behavior, Pipeline, SpawnParams, Species, StageCounters, Tank, WokenBy, World, WorldError,
};

/// Body lengths³ of water per fish in [`bench_world`]: the density stays the same at every fish
/// count, so cost per fish is comparable across counts.
pub const VOLUME_PER_FISH_LENGTHS3: f32 = 8.0;

/// A tank 2:1:1 (x:y:z) with [`VOLUME_PER_FISH_LENGTHS3`] per fish of body length `l` (at least
/// 12 × 6 × 6 body lengths), corner at the origin.
pub fn bench_tank(l: f32, fish: usize) -> Tank {
    let side = (VOLUME_PER_FISH_LENGTHS3 * fish.max(1) as f32 / 2.0).cbrt() * l;
    let side = side.max(6.0 * l);
    Tank {
        min: Vec3::ZERO,
        max: Vec3::new(2.0 * side, side, side),
    }
}

/// `count` seeded random positions inside `tank`, at least one body length `l` from its walls
/// (and the root one more length from the −x wall, so the body fits behind it).
pub fn bench_positions(tank: &Tank, l: f32, count: usize, seed: u64) -> Vec<Vec3> {
    let mut rng = Pcg32::seed_from_u64(seed);
    let inset = l.min(tank.extent().min_element() * 0.25);
    (0..count)
        .map(|_| {
            Vec3::new(
                rng.random_range(tank.min.x + inset + l..tank.max.x - inset),
                rng.random_range(tank.min.y + inset..tank.max.y - inset),
                rng.random_range(tank.min.z + inset..tank.max.z - inset),
            )
        })
        .collect()
}

/// [`bench_tank`] holding `fish` fish of `species` placed by [`bench_positions`] at cruising
/// speed, headings random (all seeded).
pub fn bench_world(species: Species, fish: usize, seed: u64) -> Result<World, WorldError> {
    let l = species.body_length();
    let cruise = species.desc.motion.s;
    let tank = bench_tank(l, fish);
    let mut world = World::new(tank, seed);
    let sid = world.add_species(species);
    let mut rng = Pcg32::seed_from_u64(seed ^ 1);
    for (i, pos) in bench_positions(&tank, l, fish, seed)
        .into_iter()
        .enumerate()
    {
        world.spawn(SpawnParams {
            species: sid,
            pos,
            heading: rng.random_range(-std::f32::consts::PI..std::f32::consts::PI),
            pitch: 0.0,
            speed: cruise,
            behavior: None,
            seed: seed
                .wrapping_mul(0x9E37_79B9_7F4A_7C15)
                .wrapping_add(i as u64),
        })?;
    }
    world.rebuild_grid();
    Ok(world)
}

/// Median per-stage milliseconds of the measured ticks.
#[derive(Clone, Copy, Debug, Default, PartialEq, serde::Serialize)]
pub struct StageMillis {
    /// Sensor queries.
    pub perception: f64,
    /// Behaviour decisions (Lua, or the Rust driver).
    pub behavior: f64,
    /// Choosing who decides this tick (level of detail) and handing them their controls.
    pub schedule: f64,
    /// Motion players, currents and contact.
    pub motion: f64,
    /// Rig pose and forward kinematics.
    pub skeleton: f64,
    /// Skinning palettes.
    pub palette: f64,
    /// Spatial grid rebuild.
    pub grid: f64,
}

/// What one run of [`measure`] found.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct SimBenchResult {
    /// Fish in the world.
    pub fish: usize,
    /// Ticks measured (after warm-up).
    pub ticks: usize,
    /// Median wall milliseconds per tick.
    pub median_ms: f64,
    /// 99th-percentile wall milliseconds per tick.
    pub p99_ms: f64,
    /// Mean wall milliseconds per tick.
    pub mean_ms: f64,
    /// Fish × ticks per wall second, from the mean.
    pub fish_ticks_per_s: f64,
    /// Median microseconds per fish per tick.
    pub us_per_fish: f64,
    /// Median of each stage, milliseconds.
    pub stages: StageMillis,
    /// Threads rayon used.
    pub threads: usize,
    /// Mean number of things in a fish's view at the end of the run (all fish sampled), which
    /// is what perception cost grows with.
    pub mean_in_view: f64,
    /// Mean distance from a fish to its nearest neighbour at the end, body lengths.
    pub mean_nearest_lengths: f64,
    /// Behaviour decisions per tick (mean).
    pub decisions_per_tick: f64,
    /// CPU microseconds of behaviour code per decision, sensor queries not included (all
    /// measured decisions' time over their number); `None` if nothing decided.
    pub decide_us_per_decision: Option<f64>,
    /// CPU microseconds of sensor queries per decision; `None` where not timed per decision
    /// (the Rust driver senses in one parallel batch).
    pub sense_us_per_decision: Option<f64>,
    /// Whether behaviour level of detail was on.
    pub lod: bool,
    /// Decisions per tick (mean) in each level-of-detail band, nearest first (one band when
    /// it is off; empty for a behaviour that does not schedule through the world).
    pub band_decisions_per_tick: Vec<f64>,
    /// Of the decisions per tick, how many an event woke (mean).
    pub woken_per_tick: f64,
    /// Those, by what woke them (means per tick).
    pub woken_by_per_tick: WokenBy<f64>,
}

fn percentile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    let rank = (q * (sorted.len() - 1) as f64).round() as usize;
    sorted[rank.min(sorted.len() - 1)]
}

fn median_of(mut values: Vec<f64>) -> f64 {
    values.sort_by(f64::total_cmp);
    percentile(&values, 0.5)
}

/// Runs `warmup` ticks, then times `ticks` ticks of `sim`.
pub fn measure<B: Behavior>(sim: &mut Pipeline<B>, warmup: usize, ticks: usize) -> SimBenchResult {
    for _ in 0..warmup {
        sim.tick();
    }
    let mut wall = Vec::with_capacity(ticks);
    let mut stages: Vec<StageCounters> = Vec::with_capacity(ticks);
    let mut bands = [0u64; super::lod::MAX_BANDS];
    let (mut woken, mut num_bands) = (0u64, 0usize);
    let mut woken_by = WokenBy::<u64>::default();
    for _ in 0..ticks {
        let start = Instant::now();
        sim.tick();
        wall.push(start.elapsed().as_secs_f64() * 1e3);
        stages.push(*sim.world().counters());
        let lod = sim.world().lod_counts();
        for (b, n) in bands.iter_mut().zip(lod.decisions) {
            *b += u64::from(n);
        }
        woken += u64::from(lod.woken);
        woken_by.add(lod.woken_by);
        num_bands = num_bands.max(usize::from(lod.bands));
    }
    let per_tick = |n: u64| n as f64 / ticks.max(1) as f64;
    let world = sim.world();
    let fish = world.num_fish();
    let (mut in_view, mut nearest, mut sampled) = (0usize, 0.0f64, 0usize);
    let mut seen = Vec::new();
    for id in world.fish_ids().step_by((fish / 500).max(1)) {
        world.vision(id, &mut seen);
        in_view += seen.len();
        let l = world
            .species(world.species_of(id).unwrap_or(super::SpeciesId(0)))
            .body_length();
        if let Some(p) = seen.iter().find(|p| p.fish.is_some()) {
            nearest += f64::from(p.distance / l);
        }
        sampled += 1;
    }
    let mean_ms = wall.iter().sum::<f64>() / wall.len().max(1) as f64;
    let mut sorted = wall.clone();
    sorted.sort_by(f64::total_cmp);
    let median_ms = percentile(&sorted, 0.5);
    let decisions: u64 = stages.iter().map(|s| s.decisions).sum();
    let decide_ns: u64 = stages.iter().map(|s| s.decide_cpu_ns).sum();
    let sense_ns: u64 = stages.iter().map(|s| s.sense_cpu_ns).sum();
    let per_decision = |ns: u64| (decisions > 0).then(|| ns as f64 / 1e3 / decisions as f64);
    let stage = |f: fn(&StageCounters) -> u64| {
        median_of(stages.iter().map(|s| f(s) as f64 / 1e6).collect())
    };
    SimBenchResult {
        fish,
        ticks,
        median_ms,
        p99_ms: percentile(&sorted, 0.99),
        mean_ms,
        fish_ticks_per_s: if mean_ms > 0.0 {
            fish as f64 / (mean_ms / 1e3)
        } else {
            0.0
        },
        us_per_fish: if fish > 0 {
            median_ms * 1e3 / fish as f64
        } else {
            0.0
        },
        stages: StageMillis {
            perception: stage(|s| s.perception_ns),
            behavior: stage(|s| s.lua_ns),
            schedule: stage(|s| s.schedule_ns),
            motion: stage(|s| s.motion_ns),
            skeleton: stage(|s| s.skeleton_ns),
            palette: stage(|s| s.palette_ns),
            grid: stage(|s| s.grid_ns),
        },
        threads: rayon::current_num_threads(),
        mean_in_view: in_view as f64 / sampled.max(1) as f64,
        mean_nearest_lengths: nearest / sampled.max(1) as f64,
        decisions_per_tick: decisions as f64 / stages.len().max(1) as f64,
        decide_us_per_decision: per_decision(decide_ns),
        sense_us_per_decision: if sense_ns > 0 {
            per_decision(sense_ns)
        } else {
            None
        },
        lod: world.lod().on,
        band_decisions_per_tick: bands[..num_bands].iter().map(|&n| per_tick(n)).collect(),
        woken_per_tick: per_tick(woken),
        woken_by_per_tick: woken_by.map(per_tick),
    }
}

/// Median and nearest-rank p99 of `samples` (sorted in place). Empty input gives zeros.
pub fn median_p99(samples: &mut [f64]) -> (f64, f64) {
    if samples.is_empty() {
        return (0.0, 0.0);
    }
    samples.sort_by(f64::total_cmp);
    let n = samples.len();
    let median = if n % 2 == 1 {
        samples[n / 2]
    } else {
        0.5 * (samples[n / 2 - 1] + samples[n / 2])
    };
    let rank = ((0.99 * n as f64).ceil() as usize).clamp(1, n);
    (median, samples[rank - 1])
}

#[cfg(test)]
mod tests {
    use super::median_p99;

    #[test]
    fn median_and_p99_by_hand() {
        let mut v: Vec<f64> = (1..=100).map(f64::from).rev().collect();
        assert_eq!(median_p99(&mut v), (50.5, 99.0));
        let mut odd = vec![3.0, 1.0, 2.0];
        assert_eq!(median_p99(&mut odd), (2.0, 3.0));
        assert_eq!(median_p99(&mut []), (0.0, 0.0));
    }
}
