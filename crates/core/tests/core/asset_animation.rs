//! The glTF animation writer behind `shoal export` (issue 38): the joints it animates pose a
//! fish exactly as the world's pose stage does, a fish that appears and leaves mid-animation is
//! scaled to zero while absent, and the Khronos validator passes the document.

use crate::common;

use glam::{Quat, Vec3};
use serde_json::json;
use shoal_core::asset::animation::{
    AnimSpecies, FishTrack, Prop, SchoolAnimation, joint_world_matrices,
};
use shoal_core::motion::{MotionRequest, Side, TurnKind};
use shoal_core::skeleton::JointTransform;
use shoal_core::world::{TICK_HZ, World};

fn tick(w: &mut World, t: usize) {
    let ids: Vec<_> = w.fish_ids().collect();
    for (k, id) in ids.iter().enumerate() {
        if (t + 11 * k).is_multiple_of(40) {
            let turn = MotionRequest::Turn {
                kind: [TurnKind::Quick, TurnKind::Normal][k % 2],
                angle: 0.8,
                side: if k % 2 == 0 { Side::Left } else { Side::Right },
            };
            w.request(*id, turn, true).unwrap();
        }
    }
    w.step_motion((1.0 / TICK_HZ) as f32);
    w.update_pose();
}

/// What the document stores for a fish: root rotation Ry(heading)·Rz(pitch) and the rig's
/// driven-joint rotations; through the document's hierarchy these must give the world's joints.
#[test]
fn the_animated_hierarchy_poses_every_joint_where_the_pose_stage_puts_it() {
    let mut w = common::porgy_and_eel_world();
    let mut palette = Vec::new();
    let mut compared = 0;
    for t in 0..150 {
        tick(&mut w, t);
        if t % 10 != 9 {
            continue;
        }
        for id in w.fish_ids().collect::<Vec<_>>() {
            let fish = w.fish(id).unwrap();
            let sp = fish.species();
            let root = *fish.root();
            let mut locals = vec![JointTransform::IDENTITY; sp.model.skeleton.num_joints()];
            sp.rig.pose(&fish.yaw(), &mut locals);
            let driven: Vec<Quat> = sp
                .rig
                .driven_joints
                .iter()
                .map(|&j| locals[j].rotation)
                .collect();
            let r = Quat::from_rotation_y(root.heading) * Quat::from_rotation_z(root.pitch);
            let ours = joint_world_matrices(&sp.model, &sp.rig, root.pos, r, &driven);
            assert!(w.joint_palette(id, &mut palette));
            let l = sp.desc.motion.l;
            for (j, (m, p)) in ours.iter().zip(&palette).enumerate() {
                // palette = model · inverse(rest model): the joint's world matrix is
                // palette · rest model.
                let world = *p * sp.model.skeleton.rest_models()[j];
                let d = m.w_axis.truncate().distance(world.w_axis.truncate());
                assert!(
                    d < 1e-5 * l,
                    "fish {id:?} joint {j}: {d} units apart at tick {t}"
                );
                compared += 1;
            }
        }
    }
    assert!(compared > 1000, "{compared}");
}

fn gltf_of(glb: &[u8]) -> serde_json::Value {
    let len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    serde_json::from_slice(&glb[20..20 + len]).unwrap()
}

#[test]
fn a_fish_present_for_part_of_the_span_is_scaled_to_zero_while_absent_and_the_validator_passes() {
    let porgy = common::PosedPorgy::load();
    let driven = porgy.rig.driven_joints.len();
    let keys = 6;
    let times: Vec<f32> = (0..keys).map(|k| k as f32 * 0.5).collect();
    let mut tracks = Vec::new();
    for (f, present) in [[true; 6], [false, false, true, true, false, false]]
        .into_iter()
        .enumerate()
    {
        let mut tr = FishTrack::new(format!("fish_{f}"), 0, json!({"id": f}), keys, driven);
        for (k, &p) in present.iter().enumerate() {
            if !p {
                continue;
            }
            tr.present[k] = true;
            tr.translation[k] = Vec3::new(10.0 * k as f32, 100.0 + f as f32 * 50.0, 0.0);
            // Headings around the ±π seam: the stored quaternions must stay in one hemisphere.
            tr.rotation[k] = Quat::from_rotation_y(3.0 + 0.1 * k as f32);
            for j in 0..driven {
                tr.joint_rotations[k * driven + j] =
                    porgy.rig.rest_locals[porgy.rig.driven_joints[j]].rotation
                        * Quat::from_rotation_y(0.1 * (k + j) as f32);
            }
        }
        tr.settle(driven);
        tracks.push(tr);
    }
    // Absent keys hold the nearest present one.
    assert_eq!(tracks[1].translation[0], tracks[1].translation[2]);
    assert_eq!(tracks[1].translation[5], tracks[1].translation[3]);
    for k in 1..keys {
        assert!(tracks[0].rotation[k].dot(tracks[0].rotation[k - 1]) >= 0.0);
    }
    let anim = SchoolAnimation {
        species: vec![AnimSpecies {
            name: "black_porgy",
            model: &porgy.model,
            rig: &porgy.rig,
        }],
        times,
        fish: tracks,
        props: vec![
            Prop::Tank {
                min: Vec3::ZERO,
                max: Vec3::splat(400.0),
            },
            Prop::Rock {
                centre: Vec3::splat(50.0),
                radius: 20.0,
            },
        ],
        extras: json!({"test": true}),
    };
    let mut calls = 0;
    let glb = anim.write("shoal test", &mut |_, _| calls += 1).to_glb();
    assert_eq!(calls, 2);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("school.glb");
    std::fs::write(&path, &glb).unwrap();
    common::validate(&[&path]);

    let doc = gltf_of(&glb);
    let nodes = doc["nodes"].as_array().unwrap();
    let named = |n: &str| nodes.iter().position(|x| x["name"] == n).unwrap();
    let (f0, f1) = (named("fish_0"), named("fish_1"));
    // One mesh for the species (instanced), one skin per fish.
    assert_eq!(doc["skins"].as_array().unwrap().len(), 2);
    let porgy_meshes = doc["meshes"]
        .as_array()
        .unwrap()
        .iter()
        .filter(|m| m["name"] == "black_porgy")
        .count();
    assert_eq!(porgy_meshes, 1);
    let channels = doc["animations"][0]["channels"].as_array().unwrap();
    let on = |node: usize, path: &str| {
        channels
            .iter()
            .filter(|c| c["target"]["node"] == node && c["target"]["path"] == path)
            .count()
    };
    assert_eq!(
        (on(f0, "translation"), on(f0, "rotation"), on(f0, "scale")),
        (1, 1, 0)
    );
    assert_eq!(
        (on(f1, "translation"), on(f1, "rotation"), on(f1, "scale")),
        (1, 1, 1)
    );
    // Root translation and rotation per fish, plus a rotation per driven joint, plus fish 1's scale.
    assert_eq!(channels.len(), 2 * (2 + driven) + 1);
    // The scale channel's values, read back from the buffer: 0 0 1 1 0 0.
    let scale = channels
        .iter()
        .find(|c| c["target"]["path"] == "scale")
        .unwrap();
    let sampler = &doc["animations"][0]["samplers"][scale["sampler"].as_u64().unwrap() as usize];
    assert_eq!(sampler["interpolation"], "STEP");
    let acc = &doc["accessors"][sampler["output"].as_u64().unwrap() as usize];
    let view = &doc["bufferViews"][acc["bufferView"].as_u64().unwrap() as usize];
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let bin = &glb[20 + json_len + 8..];
    let off = view["byteOffset"].as_u64().unwrap() as usize;
    let xs: Vec<f32> = (0..keys)
        .map(|k| f32::from_le_bytes(bin[off + 12 * k..off + 12 * k + 4].try_into().unwrap()))
        .collect();
    assert_eq!(xs, [0.0, 0.0, 1.0, 1.0, 0.0, 0.0]);
    assert!(
        nodes.iter().any(|n| n["name"] == "tank") && nodes.iter().any(|n| n["name"] == "rock_0")
    );
    // The skinned mesh nodes are scene roots (glTF ignores their parents' transforms).
    let roots = doc["scenes"][0]["nodes"].as_array().unwrap();
    assert!(roots.contains(&json!(named("fish_1_mesh"))));
}
