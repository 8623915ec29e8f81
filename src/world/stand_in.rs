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
