//! TEMPORARY STAND-INS — delete when `species` lands in main.
//!
//! Minimal copies of the contract's names (world-api.md) so the world compiles before the
//! species work is merged. Nothing here is the real thing.

use glam::Mat4;

use crate::motion::{Body, MotionParams};
use crate::skeleton::JointTransform;
use crate::skin::FishModel;

/// Stand-in for `species::SpeciesDesc`.
#[derive(Debug, Clone)]
pub struct SpeciesDesc {
    pub name: String,
    pub asset: String,
    pub motion: MotionParams,
    pub view_range: f32,
    pub view_angle_deg: f32,
    pub max_speed: f32,
    pub predator: bool,
}

impl SpeciesDesc {
    pub fn black_porgy() -> Self {
        Self {
            name: "black_porgy".into(),
            asset: "black_porgy.glb".into(),
            motion: MotionParams {
                p: 0.4,
                s: 50.0,
                l: 50.0,
                max_amp: 5.0,
                lambda: 50.0,
                omega: 1.0,
                tt: 0.5,
                f: 1.5,
                turn_angle: 1.57,
            },
            view_range: 200.0,
            view_angle_deg: 300.0,
            max_speed: 150.0,
            predator: false,
        }
    }
}

/// Stand-in for `species::SpeciesRig`.
#[derive(Debug, Clone)]
pub struct SpeciesRig {
    pub body: Body,
    pub model_to_body: Mat4,
}

impl SpeciesRig {
    pub fn bind(_desc: &SpeciesDesc, _model: &FishModel) -> Result<Self, String> {
        Err("stand-in".into())
    }
    pub fn pose(&self, _yaw: &[f32], _locals: &mut [JointTransform]) {}
}
