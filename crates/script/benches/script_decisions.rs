//! Criterion benchmarks of the behaviour stage (issue 5): the cost of one fish decision — the
//! Lua call through perceive → intend → behave with the sensor queries and steering helpers it
//! makes — for the shipped `school` and `forage` behaviours at 1,000 and 10,000 fish.
//!
//! Each iteration runs one tick's behaviour stage, in which a sixth of the fish decide (10 Hz
//! decisions staggered over the 60 Hz tick); throughput is reported per decision. The target is
//! under 5 µs per decision at 10,000 fish.
//!
//! Run with `cargo bench --bench script_decisions`.

use std::path::Path;

use criterion::{BenchmarkId, Criterion, Throughput, criterion_group, criterion_main};
use glam::Vec3;
use shoal_script::Simulation;

const COUNTS: [usize; 2] = [1_000, 10_000];

/// `fish` porgies running `behavior` at constant density (one per 80³ units), warmed up for a
/// second so memories, percept tables and motion players are in their steady state.
fn sim(fish: usize, behavior: &str) -> Simulation {
    let root = shoal_core::source_root();
    let mut sim = Simulation::from_scene(root, Path::new("scenes/empty_tank.lua"), 7).unwrap();
    let side = (fish as f32).cbrt().ceil() as usize;
    let spacing = 80.0;
    let extent = side as f32 * spacing;
    sim.set_tank(
        Vec3::splat(-0.5 * extent - 200.0),
        Vec3::splat(0.5 * extent + 200.0),
    )
    .unwrap();
    for i in 0..fish {
        let (x, y, z) = (i % side, (i / side) % side, i / (side * side));
        let pos = (Vec3::new(x as f32, y as f32, z as f32) + 0.5) * spacing - 0.5 * extent;
        sim.spawn(
            "black_porgy",
            pos,
            i as f32 * 0.7,
            0.0,
            None,
            Some(behavior),
        )
        .unwrap();
    }
    for i in 0..fish / 20 {
        let f = i as f32;
        sim.world_mut()
            .add_food(Vec3::new(f.sin(), (f * 0.7).cos(), (f * 1.3).sin()) * 0.45 * extent);
    }
    sim.run(1.0);
    assert!(
        sim.error_messages().is_empty(),
        "{:?}",
        sim.error_messages()
    );
    sim
}

fn decisions(c: &mut Criterion) {
    for behavior in ["school", "forage"] {
        let mut g = c.benchmark_group(format!("decision_{behavior}"));
        for fish in COUNTS {
            let mut s = sim(fish, behavior);
            g.throughput(Throughput::Elements((fish / 6) as u64));
            g.bench_function(BenchmarkId::from_parameter(fish), |b| {
                b.iter(|| s.run_behaviors())
            });
        }
        g.finish();
    }
}

criterion_group! {
    name = benches;
    config = Criterion::default().sample_size(20);
    targets = decisions
}
criterion_main!(benches);
