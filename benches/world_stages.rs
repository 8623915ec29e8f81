//! Criterion benchmarks of the world's Rust stages (issue 7), one group per stage, at 1,000 and
//! 10,000 fish of the default species in the constant-density bench scene:
//! grid rebuild, vision queries (one tick's worth: a tenth of the fish decide per tick at 10 Hz),
//! motion step, pose (skeleton + palette), and a whole tick with the built-in Rust driver.
//!
//! Run with `cargo bench --bench world_stages`.

use std::hint::black_box;
use std::path::Path;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use shoal::world::bench::bench_world;
use shoal::world::driver::WanderDriver;
use shoal::world::{Species, SpeciesDesc, TICK_HZ, World};

const COUNTS: [usize; 2] = [1_000, 10_000];

fn world(fish: usize) -> World {
    let assets = Path::new(env!("CARGO_MANIFEST_DIR")).join("assets");
    let species = Species::load(SpeciesDesc::black_porgy(), &assets).expect("default species");
    let mut world = bench_world(species, fish, 7).expect("bench scene");
    // One second of driven ticks so players, palettes and the grid are warm.
    let mut driver = WanderDriver::default();
    for _ in 0..TICK_HZ as usize {
        driver.tick(&mut world);
    }
    world
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
        let mut driver = WanderDriver::default();
        g.bench_function(BenchmarkId::from_parameter(fish), |b| {
            b.iter(|| driver.tick(&mut w))
        });
        g.finish();
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = stages
}
criterion_main!(benches);
