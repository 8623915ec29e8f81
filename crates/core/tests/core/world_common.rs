//! Shared fixtures of the world tests: a small synthetic species and scenes.
#![allow(dead_code)]

use std::sync::Arc;

use glam::{Mat4, Quat, Vec3};
use shoal_core::motion::Body;
use shoal_core::skeleton::{JointTransform, NO_PARENT, Skeleton};
use shoal_core::skin::SkinnedMesh;
use shoal_core::world::{
    FishId, FishModel, SpawnParams, Species, SpeciesDesc, SpeciesId, SpeciesRig, Tank, World,
};

/// Body length of the test species, world units.
pub const L: f32 = 50.0;

/// A fish skeleton drawn head to tail along −x from the model origin (the head):
///
/// ```text
///   fin(8)  fin(9)
///     |      |
///   j0 ── j1 ── j2 ── j3 ── j4 ── j5 ── j6 ── j7
///  head                                      tail
/// ```
/// j0…j7 are 7 equal segments of L/7; fin 8 hangs below j1, fin 9 below j3.
pub fn skeleton() -> Skeleton {
    let mut parents: Vec<u16> = (0..8u16)
        .map(|i| if i == 0 { NO_PARENT } else { i - 1 })
        .collect();
    parents.extend([1, 3]);
    let names = (0..10).map(|i| format!("j{i}")).collect();
    let seg = L / 7.0;
    let mut locals: Vec<JointTransform> = (0..8)
        .map(|i| JointTransform {
            translation: if i == 0 {
                Vec3::ZERO
            } else {
                Vec3::new(-seg, 0.0, 0.0)
            },
            rotation: Quat::IDENTITY,
            scale: Vec3::ONE,
        })
        .collect();
    for _ in 0..2 {
        locals.push(JointTransform {
            translation: Vec3::new(0.0, -3.0, 0.0),
            rotation: Quat::from_rotation_z(0.3),
            scale: Vec3::ONE,
        });
    }
    Skeleton::new(parents, names, locals).expect("test skeleton")
}

/// The test species: the skeleton above, the paper's 6 driven joints.
pub fn species(name: &str, predator: bool) -> Species {
    let skeleton = skeleton();
    let inverse_bind_poses = skeleton.rest_models().iter().map(|m| m.inverse()).collect();
    let mut desc = SpeciesDesc::black_porgy();
    desc.name = name.to_string();
    desc.predator = predator;
    desc.motion.l = L;
    desc.view_range = 4.0 * L;
    desc.view_angle_deg = 300.0;
    Species {
        desc,
        rig: SpeciesRig {
            body: Body::evenly_spaced(7),
            driven_joints: (1..7).collect(),
            // Joints' local frames are the body frame (+y up): bend about −y (ventral) so a
            // positive yaw swings the part behind to the left (−z).
            bend_axes: vec![Vec3::NEG_Y; 6],
            model_to_body: Mat4::IDENTITY,
            model_body_length: L,
            model_forward: Vec3::X,
            model_up: Vec3::Y,
            rest_locals: skeleton.rest_locals().to_vec(),
        },
        model: Arc::new(FishModel {
            skeleton,
            inverse_bind_poses,
            mesh: SkinnedMesh::default(),
            warnings: Vec::new(),
        }),
    }
}

/// A 20 × 8 × 10 body-length tank with its corner at the origin.
pub fn tank() -> Tank {
    Tank {
        min: Vec3::ZERO,
        max: Vec3::new(20.0 * L, 8.0 * L, 10.0 * L),
    }
}

/// An empty world in [`tank`] with the test species (and a predator species).
pub fn world() -> (World, SpeciesId, SpeciesId) {
    let mut w = World::new(tank(), 1);
    let fish = w.add_species(species("porgy", false));
    let shark = w.add_species(species("shark", true));
    (w, fish, shark)
}

/// Spawn parameters for a still fish.
pub fn at(species: SpeciesId, pos: Vec3, heading: f32) -> SpawnParams {
    SpawnParams {
        species,
        pos,
        heading,
        pitch: 0.0,
        speed: 0.0,
        behavior: None,
        seed: 3,
    }
}

/// Spawns and returns the id (panics on error: fixtures are valid).
pub fn spawn(w: &mut World, species: SpeciesId, pos: Vec3, heading: f32) -> FishId {
    w.spawn(at(species, pos, heading)).expect("spawn")
}
