//! The pose stage: palettes place each fish's model at its root, facing its heading, bend it
//! the way the motion layer says, and do not depend on the thread count.

use crate::world_common;

use glam::{Mat4, Vec3};
use shoal_core::motion::MotionRequest;
use shoal_core::world::sense::forward;
use shoal_core::world::{SpawnParams, TICK_HZ, World};
use world_common::{L, at, world};

const DT: f32 = (1.0 / TICK_HZ) as f32;

/// Model-space rest position of joint `j` of the fixture skeleton.
fn rest_joint(w: &World, j: usize) -> Vec3 {
    w.species(w.species_of(w.fish_ids().next().unwrap()).unwrap())
        .model
        .skeleton
        .rest_models()[j]
        .w_axis
        .truncate()
}

#[test]
fn rest_pose_palettes_place_the_bind_shape_at_the_root_facing_the_heading() {
    let (mut w, porgy, _) = world();
    let pos = Vec3::new(400.0, 200.0, 250.0);
    let (heading, pitch) = (std::f32::consts::FRAC_PI_2, 0.25);
    let id = w
        .spawn(SpawnParams {
            pitch,
            ..at(porgy, pos, heading)
        })
        .unwrap();
    w.update_pose();
    let mut palette = Vec::new();
    assert!(w.joint_palette(id, &mut palette));
    assert_eq!(palette.len(), 10);
    // At rest, every palette entry is the same rigid placement of the bind shape.
    let fwd = forward(heading, pitch);
    for (j, m) in palette.iter().enumerate() {
        assert!(
            m.abs_diff_eq(palette[0], 1e-4),
            "joint {j}: {m} vs {}",
            palette[0]
        );
        // The skinned position of joint j's bind position.
        let world_pos = m.transform_point3(rest_joint(&w, j));
        if j < 8 {
            // Joint j of the chain is j·L/7 behind the head along the fish's forward.
            let want = pos - fwd * (j as f32 * L / 7.0);
            assert!(
                world_pos.abs_diff_eq(want, 1e-3),
                "joint {j}: {world_pos} vs {want}"
            );
        }
    }
    // Heading π/2 faces −z: the tail lies towards +z (and, pitched nose-up, below the head).
    let tail = palette[7].transform_point3(rest_joint(&w, 7));
    assert!(
        tail.z > pos.z + 0.9 * L * pitch.cos() && tail.y < pos.y,
        "{tail}"
    );
}

#[test]
fn swimming_bends_the_body_to_the_side_the_motion_layer_says() {
    let (mut w, porgy, _) = world();
    let id = w
        .spawn(SpawnParams {
            speed: 50.0,
            ..at(porgy, Vec3::new(200.0, 200.0, 250.0), 0.0)
        })
        .unwrap();
    w.request(id, MotionRequest::Swim { speed: 50.0 }, false)
        .unwrap();
    let mut agreed = 0;
    let mut checked = 0;
    let mut palette = Vec::new();
    for _ in 0..240 {
        w.step_motion(DT);
        w.update_pose();
        let root = *w.root(id).unwrap();
        let tail_lateral = *w.lateral(id).unwrap().last().unwrap();
        assert!(w.joint_palette(id, &mut palette));
        // Bones keep their length: the pose is rigid per segment.
        let joints: Vec<Vec3> = (0..8)
            .map(|j| palette[j].transform_point3(rest_joint(&w, j)))
            .collect();
        for k in 1..8 {
            let bone = joints[k].distance(joints[k - 1]);
            assert!((bone - L / 7.0).abs() < 1e-3, "bone {k}: {bone}");
        }
        assert!(joints[0].abs_diff_eq(root.pos, 1e-3), "head at the root");
        // Left of a fish facing heading h is forward rotated +90° about y.
        let left = forward(root.heading + std::f32::consts::FRAC_PI_2, 0.0);
        let tail_side = (joints[7] - root.pos).dot(left);
        // The posed chain hangs off the root's heading while `lateral` is measured from the
        // travel line; near a zero crossing the head's recoil can flip the sign, so only clear
        // swings (> 8 % of a body length) count. A wrong bend axis gives 0 % agreement.
        if tail_lateral.abs() > 0.08 * L {
            checked += 1;
            if tail_side.signum() == tail_lateral.signum() {
                agreed += 1;
            }
        }
    }
    assert!(checked > 20, "the tail swings: {checked}");
    assert!(
        agreed as f32 >= 0.9 * checked as f32,
        "tail bends to the side of the midline: {agreed}/{checked}"
    );
}

fn scene() -> World {
    let (mut w, porgy, shark) = world();
    for i in 0..300 {
        let x = 30.0 + (i % 30) as f32 * 30.0;
        let z = 30.0 + (i / 30) as f32 * 40.0;
        w.spawn(SpawnParams {
            speed: 40.0 + (i % 7) as f32,
            seed: i,
            ..at(
                if i % 10 == 0 { shark } else { porgy },
                Vec3::new(x, 200.0, z),
                i as f32,
            )
        })
        .unwrap();
    }
    w
}

#[test]
fn palettes_do_not_depend_on_the_thread_count() {
    let run = |threads: usize| -> Vec<Mat4> {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let mut w = scene();
            let ids: Vec<_> = w.fish_ids().collect();
            for tick in 0..120 {
                if tick % 30 == 0 {
                    for (k, &id) in ids.iter().enumerate() {
                        w.steer_to(id, tick as f32 * 0.01 + k as f32, 150.0, 60.0)
                            .unwrap();
                    }
                }
                w.step_motion(DT);
                w.update_pose();
                w.rebuild_grid();
            }
            w.palettes().to_vec()
        })
    };
    let one = run(1);
    let two = run(2);
    // 300 fish of 7 slots (the fixture's 10 joints have 7 distinct palette entries).
    assert_eq!(one.len(), 2100);
    assert!(
        one == two,
        "bitwise identical palettes with 1 and 2 threads"
    );
}

#[test]
fn stage_counters_are_filled() {
    let mut w = scene();
    w.step_motion(DT);
    w.update_pose();
    w.rebuild_grid();
    let c = *w.counters();
    assert!(
        c.motion_ns > 0 && c.skeleton_ns > 0 && c.palette_ns > 0 && c.grid_ns > 0,
        "{c:?}"
    );
    assert_eq!(c.lua_ns, 0);
}

#[test]
fn the_shipped_porgy_at_rest_skins_to_its_bind_shape_head_at_the_root() {
    use shoal_core::skin::LinearBlendSkinningJob;
    use shoal_core::world::pose::root_matrix;
    use shoal_core::world::{Species, SpeciesDesc, Tank};

    let assets = shoal_core::source_root().join("assets");
    let species = Species::load(SpeciesDesc::black_porgy(), &assets).unwrap();
    let l = species.body_length();
    let mut w = World::new(
        Tank {
            min: Vec3::ZERO,
            max: Vec3::splat(20.0 * l),
        },
        1,
    );
    let sid = w.add_species(species);
    let pos = Vec3::new(300.0, 400.0, 500.0);
    let id = w
        .spawn(SpawnParams {
            pitch: -0.2,
            ..at(sid, pos, 2.0)
        })
        .unwrap();
    w.update_pose();
    let species = w.species(sid);
    let mesh = &species.model.mesh;
    let mut palette = Vec::new();
    assert!(w.joint_palette(id, &mut palette));
    assert_eq!(palette.len(), species.model.skeleton.num_joints());
    let n = mesh.num_vertices();
    let (mut positions, mut normals) = (vec![Vec3::ZERO; n], vec![Vec3::ZERO; n]);
    LinearBlendSkinningJob {
        palette: &palette,
        positions_in: &mesh.positions,
        normals_in: &mesh.normals,
        joints: &mesh.joints,
        weights: &mesh.weights,
        positions_out: &mut positions,
        normals_out: &mut normals,
    }
    .run()
    .unwrap();
    let placement = root_matrix(w.root(id).unwrap(), &species.rig.model_to_body);
    for (v, skinned) in mesh.positions.iter().zip(&positions) {
        let want = placement.transform_point3(*v);
        assert!(skinned.abs_diff_eq(want, 1e-3 * l), "{skinned} vs {want}");
    }
    // The snout is at the root and the body is l long along the heading.
    let fwd = forward(2.0, -0.2);
    let along: Vec<f32> = positions.iter().map(|p| (*p - pos).dot(fwd)).collect();
    let front = along.iter().copied().fold(f32::NEG_INFINITY, f32::max);
    let back = along.iter().copied().fold(f32::INFINITY, f32::min);
    assert!(front.abs() < 1e-3 * l, "snout at the root: {front}");
    assert!(
        (front - back - l).abs() < 1e-3 * l,
        "length {}",
        front - back
    );
}

/// An empty 1000 × 500 × 800 tank with the shipped porgy and eel (from `assets/`) as species.
fn shipped_species_world(
    seed: u64,
) -> (
    World,
    shoal_core::world::SpeciesId,
    shoal_core::world::SpeciesId,
) {
    use shoal_core::world::{Species, SpeciesDesc, Tank};

    let assets = shoal_core::source_root().join("assets");
    let mut w = World::new(
        Tank {
            min: Vec3::ZERO,
            max: Vec3::new(1000.0, 500.0, 800.0),
        },
        seed,
    );
    let porgy = w.add_species(Species::load(SpeciesDesc::black_porgy(), &assets).unwrap());
    let eel = w.add_species(Species::load(SpeciesDesc::eel(), &assets).unwrap());
    (w, porgy, eel)
}

#[test]
fn the_pose_plan_matches_the_layers_own_jobs_on_the_shipped_fish() {
    use shoal_core::world::pose::reference_palette;

    let (mut w, porgy, eel) = shipped_species_world(2);
    for i in 0..40 {
        w.spawn(SpawnParams {
            speed: 40.0,
            pitch: 0.1 * (i % 3) as f32,
            seed: i,
            ..at(
                if i % 2 == 0 { porgy } else { eel },
                Vec3::new(100.0 + 20.0 * i as f32, 250.0, 400.0),
                i as f32,
            )
        })
        .unwrap();
    }
    let ids: Vec<_> = w.fish_ids().collect();
    for (k, &id) in ids.iter().enumerate() {
        let side = if k % 2 == 0 { 0.5 } else { -0.7 };
        w.steer_to(id, side, 250.0, 60.0).unwrap();
    }
    let mut bent = 0;
    for _ in 0..50 {
        w.step_motion(DT);
    }
    w.update_pose();
    let mut got = Vec::new();
    for &id in &ids {
        let species = w.species(w.species_of(id).unwrap());
        let yaw = w.yaw(id).unwrap();
        if yaw.iter().any(|y| y.abs() > 0.02) {
            bent += 1;
        }
        assert!(w.joint_palette(id, &mut got));
        let mut want = vec![Mat4::IDENTITY; species.model.skeleton.num_joints()];
        reference_palette(species, w.root(id).unwrap(), &yaw, &mut want).unwrap();
        assert_eq!(got.len(), want.len());
        for (j, (got, want)) in got.iter().zip(&want).enumerate() {
            assert!(got.abs_diff_eq(*want, 1e-4), "joint {j}: {got} vs {want}");
        }
    }
    assert!(bent > 30, "most fish are bent mid-swim: {bent}");
}

/// Issue 18: a fish's palette holds its distinct entries only, fewer than its joints for the
/// shipped fish (their fins, eyes, jaw and tail copy the placement or a spine joint's entry),
/// and every fish's range is its species' slots.
#[test]
fn the_shipped_fish_palettes_hold_fewer_slots_than_joints() {
    let (mut w, porgy, eel) = shipped_species_world(3);
    for s in [porgy, eel] {
        let joints = w.species(s).model.skeleton.num_joints();
        let slots = w.num_palette_slots(s);
        println!(
            "{}: {slots} palette slots per fish for {joints} joints",
            w.species(s).desc.name
        );
        assert_eq!(w.slot_of_joint(s).len(), joints);
        assert!(slots < joints, "{slots} slots, {joints} joints");
        // Every slot is some joint's, and joint 0's is slot 0 (culling reads it).
        assert_eq!(w.slot_of_joint(s)[0], 0);
        for k in 0..slots as u16 {
            assert!(w.slot_of_joint(s).contains(&k), "slot {k} unused");
        }
    }
    assert!(w.num_palette_slots(porgy) < 30);
    for i in 0..10 {
        w.spawn(SpawnParams {
            speed: 40.0,
            seed: i,
            ..at(
                if i % 2 == 0 { porgy } else { eel },
                Vec3::new(100.0 + 50.0 * i as f32, 250.0, 400.0),
                i as f32,
            )
        })
        .unwrap();
    }
    w.update_pose();
    let slots = 5 * (w.num_palette_slots(porgy) + w.num_palette_slots(eel));
    assert_eq!(w.palettes().len(), slots);
    for id in w.fish_ids() {
        let s = w.species_of(id).unwrap();
        assert_eq!(w.palette_range(id).unwrap().len(), w.num_palette_slots(s));
    }
}
