//! Criterion benchmarks of the world's Rust stages (issue 7), one group per stage, at 1,000 and
//! 10,000 fish of the default species in the constant-density bench scene:
//! grid rebuild, vision queries (one tick's worth: a tenth of the fish decide per tick at 10 Hz),
//! the school behaviour's crowd queries and the nearest predator (a sixth of the fish, as the
//! Lua host's 10 Hz decisions at 60 Hz ticks; the scene with one predator per 100 fish),
//! motion step, pose (skeleton + palette), and a whole tick with the built-in Rust driver.
//!
//! Run with `cargo bench --bench world_stages`.

use std::hint::black_box;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use shoal_core::world::bench::{bench_positions, bench_world};
use shoal_core::world::driver::{WanderDriver, WanderPipeline};
use shoal_core::world::sense::{forward, in_view_cone};
use shoal_core::world::{FishId, PerceptKind, SpawnParams, Species, SpeciesDesc, TICK_HZ, World};

const COUNTS: [usize; 2] = [1_000, 10_000];

fn world(fish: usize) -> World {
    let assets = shoal_core::source_root().join("assets");
    let species = Species::load(SpeciesDesc::black_porgy(), &assets).expect("default species");
    let world = bench_world(species, fish, 7).expect("bench scene");
    // One second of driven ticks so players, palettes and the grid are warm.
    let mut sim = WanderPipeline::new(world, WanderDriver::default());
    for _ in 0..TICK_HZ as usize {
        sim.tick();
    }
    sim.into_world()
}

/// The bench world plus one predator (the porgy marked a predator) per 100 fish, grid rebuilt.
fn with_predators(mut world: World) -> World {
    let mut shark = world
        .species(world.species_of(world.fish_ids().next().unwrap()).unwrap())
        .clone();
    shark.desc.name = "shark".into();
    shark.desc.predator = true;
    let l = shark.body_length();
    let sid = world.add_species(shark);
    let count = world.num_fish() / 100;
    for (i, pos) in bench_positions(world.tank(), l, count, 99)
        .into_iter()
        .enumerate()
    {
        world
            .spawn(SpawnParams {
                species: sid,
                pos,
                heading: i as f32,
                pitch: 0.0,
                speed: 0.0,
                behavior: None,
                seed: i as u64,
            })
            .expect("predator");
    }
    world.rebuild_grid();
    world
}

/// The nearest predator in view as `shoal.nearest("predator")` found it before
/// `World::nearest_in_view`: every fish within view range, filtered.
fn nearest_predator_by_neighbours(w: &World, f: FishId, ids: &mut Vec<FishId>) -> Option<FishId> {
    let me = *w.root(f)?;
    let mine = w.species_of(f)?;
    let desc = &w.species(mine).desc;
    let fwd = forward(me.heading, me.pitch);
    w.neighbors(me.pos, desc.view_range, ids);
    let mut best: Option<(f32, FishId)> = None;
    for &o in ids.iter() {
        let (Some(sp), Some(r)) = (w.species_of(o), w.root(o)) else {
            continue;
        };
        if o == f || sp == mine || !w.species(sp).desc.predator {
            continue;
        }
        let d = r.pos.distance(me.pos);
        if best.is_none_or(|(bd, b)| d < bd || (d == bd && o < b))
            && d <= desc.view_range
            && in_view_cone(me.pos, fwd, desc.view_angle_deg, r.pos)
        {
            best = Some((d, o));
        }
    }
    best.map(|(_, o)| o)
}

fn queries(c: &mut Criterion) {
    for fish in COUNTS {
        let mut w = with_predators(world(fish));
        let sixth: Vec<_> = w.fish_ids().step_by(6).collect();
        let l = w.species(w.species_of(sixth[0]).unwrap()).body_length();
        let (sep, ali, coh) = (1.0 * l, 4.0 * l, 6.0 * l);
        // The first crowd query asks the next rebuild for the headings in cell order.
        black_box(w.steer_crowd(sixth[0], sep, ali, coh, 60.0));
        w.rebuild_grid();

        let mut g = c.benchmark_group("school_crowd_sixth_of_fish");
        g.throughput(Throughput::Elements(sixth.len() as u64));
        g.bench_function(BenchmarkId::new("three_calls", fish), |b| {
            b.iter(|| {
                for &id in &sixth {
                    black_box(w.steer_separation(id, sep, 60.0));
                    black_box(w.steer_alignment(id, ali, 60.0));
                    black_box(w.steer_cohesion(id, coh, 60.0));
                }
            })
        });
        g.bench_function(BenchmarkId::new("one_pass", fish), |b| {
            b.iter(|| {
                for &id in &sixth {
                    black_box(w.steer_crowd(id, sep, ali, coh, 60.0));
                }
            })
        });
        g.finish();

        let mut g = c.benchmark_group("nearest_predator_sixth_of_fish");
        g.throughput(Throughput::Elements(sixth.len() as u64));
        let mut ids = Vec::new();
        g.bench_function(BenchmarkId::new("neighbours", fish), |b| {
            b.iter(|| {
                for &id in &sixth {
                    black_box(nearest_predator_by_neighbours(&w, id, &mut ids));
                }
            })
        });
        g.bench_function(BenchmarkId::new("nearest_in_view", fish), |b| {
            b.iter(|| {
                for &id in &sixth {
                    black_box(w.nearest_in_view(id, PerceptKind::Predator, None));
                }
            })
        });
        g.finish();
    }
}

fn stages(c: &mut Criterion) {
    for fish in COUNTS {
        let mut w = world(fish);
        let ids: Vec<_> = w.fish_ids().collect();

        let mut g = c.benchmark_group("grid_rebuild");
        g.throughput(Throughput::Elements(fish as u64));
        g.bench_function(BenchmarkId::from_parameter(fish), |b| {
            b.iter(|| w.rebuild_grid())
        });
        g.finish();

        let mut g = c.benchmark_group("vision_tenth_of_fish");
        let queries: Vec<_> = ids.iter().step_by(10).copied().collect();
        g.throughput(Throughput::Elements(queries.len() as u64));
        let mut out = Vec::new();
        g.bench_function(BenchmarkId::from_parameter(fish), |b| {
            b.iter(|| {
                let mut seen = 0;
                for &id in &queries {
                    w.vision(id, &mut out);
                    seen += out.len();
                }
                black_box(seen)
            })
        });
        g.finish();

        let mut g = c.benchmark_group("step_motion");
        g.throughput(Throughput::Elements(fish as u64));
        g.bench_function(BenchmarkId::from_parameter(fish), |b| {
            b.iter(|| w.step_motion((1.0 / TICK_HZ) as f32))
        });
        g.finish();

        let mut g = c.benchmark_group("update_pose");
        g.throughput(Throughput::Elements(fish as u64));
        g.bench_function(BenchmarkId::from_parameter(fish), |b| {
            b.iter(|| {
                w.update_pose();
                black_box(w.palettes().len())
            })
        });
        g.finish();

        let mut g = c.benchmark_group("tick_rust_driver");
        g.throughput(Throughput::Elements(fish as u64));
        let mut sim = WanderPipeline::new(w, WanderDriver::default());
        g.bench_function(BenchmarkId::from_parameter(fish), |b| b.iter(|| sim.tick()));
        g.finish();
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = stages, queries
}
criterion_main!(benches);
