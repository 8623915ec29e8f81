//! Criterion benchmark of `shoal export`'s document writer (issue 38): 1,000 black porgies,
//! 10 s at 30 keys/s (301 keys), from tracks to the packed `.glb` bytes. The other half of an
//! export, running the recording again, is the simulation's tick (`shoal bench sim`).
//!
//! Run with `cargo bench --bench school_export`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use glam::{Quat, Vec3};
use serde_json::json;
use shoal_core::asset::animation::{AnimSpecies, FishTrack, SchoolAnimation};
use shoal_core::world::{Species, SpeciesDesc};

const FISH: usize = 1_000;
const KEYS: usize = 301;

fn tracks(species: &Species) -> Vec<FishTrack> {
    let driven = species.rig.driven_joints.len();
    (0..FISH)
        .map(|f| {
            let mut t = FishTrack::new(format!("fish_{f}"), 0, json!({"id": f}), KEYS, driven);
            for k in 0..KEYS {
                let s = k as f32 / 30.0;
                t.present[k] = true;
                t.translation[k] = Vec3::new(f as f32 + 40.0 * s, 200.0, (f % 37) as f32);
                t.rotation[k] = Quat::from_rotation_y(0.3 * s + f as f32);
                for j in 0..driven {
                    let yaw = 0.2 * (6.0 * s + j as f32).sin();
                    t.joint_rotations[k * driven + j] =
                        species.rig.rest_locals[species.rig.driven_joints[j]].rotation
                            * Quat::from_axis_angle(species.rig.bend_axes[j], yaw);
                }
            }
            t.settle(driven);
            t
        })
        .collect()
}

fn bench(c: &mut Criterion) {
    let assets = shoal_core::source_root().join("assets");
    let species = Species::load(SpeciesDesc::black_porgy(), &assets).expect("default species");
    let fish = tracks(&species);
    let mut group = c.benchmark_group("school_export");
    group.sample_size(10);
    group.bench_function("1000_fish_301_keys_to_glb", |b| {
        b.iter(|| {
            let anim = SchoolAnimation {
                species: vec![AnimSpecies {
                    name: &species.desc.name,
                    model: &species.model,
                    rig: &species.rig,
                }],
                times: (0..KEYS).map(|k| k as f32 / 30.0).collect(),
                fish: fish.clone(),
                props: Vec::new(),
                extras: json!({}),
            };
            black_box(anim.write("bench", &mut |_, _| {}).to_glb().len())
        });
    });
    group.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
