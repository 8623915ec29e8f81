//! Assets the aquarium ships with, built by code: the procedural black porgy and eel
//! ([`FishPlan`]), and the auto-rigger that gives a static fish mesh a vertebral chain
//! ([`rig`]).
//!
//! Generated files are deterministic GLBs (same bytes every run) that pass the Khronos glTF
//! validator with no errors or warnings; `assets/black_porgy.glb` and `assets/eel.glb` are
//! committed, and a test regenerates them and compares bytes.

pub mod animation;
mod fish;
mod glb;
pub mod preview;
pub mod rig;
mod rigged;
pub mod species_file;

/// The generated fish's joint names live with the species that drive them; re-exported here
/// for the generator's callers.
pub use crate::species::{DRIVEN_JOINTS, JOINT_NAMES};
pub use fish::{FishPlan, MedianFin, Profile, chain_blend};
pub use glb::GlbBuilder;
pub use rigged::{Influences, MaterialSet, RiggedMesh};

/// The generated black porgy as GLB bytes (what `shoal asset porgy` writes).
pub fn black_porgy_glb() -> Vec<u8> {
    FishPlan::black_porgy().to_glb()
}

/// The generated eel as GLB bytes (what `shoal asset eel` writes).
pub fn eel_glb() -> Vec<u8> {
    FishPlan::eel().to_glb()
}

/// A node name part from a joint or bone name (rigging and export): letters, digits, `_` and `-` kept, anything else `_`
/// (three.js and Blender treat `.`, `:`, `/` and spaces in names specially).
pub fn sanitize_name(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() || c == '_' || c == '-' {
                c
            } else {
                '_'
            }
        })
        .collect()
}
