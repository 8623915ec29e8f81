//! TEMPORARY STAND-INS — delete when `species` lands in main.
//!
//! Copies of the shape of `species::SpeciesDesc` / `SpeciesRig` (as written on the skin branch)
//! so the world compiles and its tests run before the species work is merged. Nothing here is
//! the real thing: `bind` is not provided.

use glam::{Mat4, Quat, Vec3};

use crate::motion::{Body, MotionParams};
use crate::skeleton::JointTransform;

/// Stand-in for `species::SpeciesDesc`.
#[derive(Debug, Clone)]
pub struct SpeciesDesc {
    pub name: String,
    pub asset: String,
    pub vertebral_joints: Vec<String>,
    pub motion: MotionParams,
    pub view_range: f32,
    pub view_angle_deg: f32,
    pub max_speed: f32,
    /// Not on the species branch yet: the world helper adds it there after the merge.
    pub predator: bool,
}

impl SpeciesDesc {
    pub fn black_porgy() -> Self {
        Self {
            name: "black_porgy".into(),
            asset: "black_porgy.glb".into(),
            vertebral_joints: (1..=6).map(|i| format!("spine_{i}")).collect(),
            motion: MotionParams {
                p: 0.4,
                s: 50.0,
                l: 50.0,
                max_amp: 50.0 / 6.0,
                lambda: 50.0,
                omega: 3.75,
                tt: 2.0,
                f: 1.0,
                turn_angle: std::f32::consts::FRAC_PI_2,
            },
            view_range: 250.0,
            view_angle_deg: 300.0,
            max_speed: 120.0,
            predator: false,
        }
    }
}

/// Stand-in for `species::SpeciesRig`.
#[derive(Debug, Clone)]
pub struct SpeciesRig {
    pub body: Body,
    pub driven_joints: Vec<usize>,
    pub bend_axes: Vec<Vec3>,
    pub model_to_body: Mat4,
    pub model_body_length: f32,
    pub model_forward: Vec3,
    pub model_up: Vec3,
    pub rest_locals: Vec<JointTransform>,
}

impl SpeciesRig {
    pub fn bind(
        _desc: &SpeciesDesc,
        _model: &crate::skin::FishModel,
    ) -> Result<Self, &'static str> {
        Err("species binding is not merged yet")
    }

    pub fn pose(&self, yaw: &[f32], locals: &mut [JointTransform]) {
        let n = locals.len().min(self.rest_locals.len());
        locals[..n].copy_from_slice(&self.rest_locals[..n]);
        for ((&j, axis), &angle) in self.driven_joints.iter().zip(&self.bend_axes).zip(yaw) {
            if j >= n || !angle.is_finite() {
                continue;
            }
            let rest = self.rest_locals[j].rotation;
            locals[j].rotation = (rest * Quat::from_axis_angle(*axis, angle)).normalize();
        }
    }
}
