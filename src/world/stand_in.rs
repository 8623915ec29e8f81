//! TEMPORARY STAND-INS — delete when `species` and `skin` land in main.
//!
//! Minimal copies of the contract's names (world-api.md) so the world compiles before the
//! species/skin work is merged. Nothing here is the real thing.

use std::path::Path;

use glam::Mat4;

use crate::motion::{Body, MotionParams};
use crate::skeleton::{JointTransform, Skeleton};

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

/// Stand-in for `skin::FishModel`.
#[derive(Debug, Clone)]
pub struct FishModel {
    pub skeleton: Skeleton,
    pub inverse_bind_poses: Vec<Mat4>,
}

impl FishModel {
    pub fn load(_path: &Path) -> Result<Self, String> {
        Err("stand-in".into())
    }
}

/// Stand-in for `skin::palette`.
pub fn palette(models: &[Mat4], ibms: &[Mat4], out: &mut [Mat4]) -> Result<(), String> {
    for ((o, m), i) in out.iter_mut().zip(models).zip(ibms) {
        *o = *m * *i;
    }
    Ok(())
}
