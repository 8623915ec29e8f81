//! The GPU pose pass's plain data (issue 18): per species a *program* — the steps the CPU pose
//! stage walks (`world::pose`), as matrices and indices — and per fish a record of its root and
//! driven yaws. The world builds them; the renderer uploads them and `shaders/pose.wgsl` runs
//! each fish's program into the palette buffer, in the layout the CPU stage writes.
//! [`run_program`] is the shader's arithmetic on the CPU, for tests without a GPU.

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec4};

/// Driven joints a fish record holds (the world's `MAX_DRIVEN_JOINTS`).
pub const GPU_POSE_MAX_YAWS: usize = 16;

/// Model matrices one species' program may make: the size of the pass's per-fish array in
/// `shaders/pose.wgsl` (`MAX_MODELS` there). A species needing more poses on the CPU.
pub const GPU_POSE_MAX_MODELS: usize = 32;

/// `GpuModelStep::yaw_slot` of a joint that is not driven.
pub const GPU_NOT_DRIVEN: u32 = u32::MAX;

/// One model step of a program: `model[k] = (parent < 0 ? placement : model[parent]) · local`,
/// `local = a + cos θ·b + sin θ·c` with θ the fish's yaw `yaw_slot` (`b` and `c` zero and θ
/// unused for a joint that is not driven).
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct GpuModelStep {
    /// The local transform's constant part (column-major): the rest matrix of a joint that is
    /// not driven, `R₀·a·aᵀ·S` with the rest translation of a driven one.
    pub a: [[f32; 4]; 4],
    /// The factor of cos θ (`R₀·S − R₀·a·aᵀ·S`; zero if not driven).
    pub b: [[f32; 4]; 4],
    /// The factor of sin θ (`R₀·[a]ₓ·S`; zero if not driven).
    pub c: [[f32; 4]; 4],
    /// Index of the parent's model step in the same program, −1 for the placement.
    pub parent: i32,
    /// Index into the fish's yaws, or [`GPU_NOT_DRIVEN`].
    pub yaw_slot: u32,
    /// Padding to 16 bytes (WGSL struct alignment).
    pub _pad: [u32; 2],
}

/// One palette slot of a program: `(left < 0 ? placement : model[left]) · rhs` if `product`,
/// else the placement itself.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct GpuSlotStep {
    /// The right factor (column-major): `inverse_bind`, or `rest_local · inverse_bind` for an
    /// entry made from the parent's model.
    pub rhs: [[f32; 4]; 4],
    /// Index of the left factor's model step in the same program, −1 for the placement.
    pub left: i32,
    /// 1 for a product, 0 for the placement itself.
    pub product: u32,
    /// Padding to 16 bytes (WGSL struct alignment).
    pub _pad: [u32; 2],
}

/// A species' program: its model steps and slots in [`GpuPosePrograms`]' arrays.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct GpuProgram {
    /// The rig's model → body transform (the placement's right factor).
    pub model_to_body: [[f32; 4]; 4],
    /// Its first step in [`GpuPosePrograms::models`].
    pub first_model: u32,
    /// Its number of model steps.
    pub num_models: u32,
    /// Its first slot in [`GpuPosePrograms::slots`].
    pub first_slot: u32,
    /// Its number of slots (palette entries per fish).
    pub num_slots: u32,
}

/// One fish as the pose pass reads it.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct GpuFishPose {
    /// Root position (xyz) and heading (w), radians.
    pub pos_heading: [f32; 4],
    /// Pitch, radians, positive nose-up.
    pub pitch: f32,
    /// Its species' program.
    pub program: u32,
    /// Where its slots start in the palette buffer.
    pub palette_offset: u32,
    /// Padding to 16 bytes (WGSL struct alignment).
    pub _pad: u32,
    /// Driven joints' yaws, radians (non-finite ones written as 0, the rest pose).
    pub yaw: [f32; GPU_POSE_MAX_YAWS],
}

/// Every species' program, in species order (`GpuFishPose::program` is the species index).
#[derive(Debug, Clone, Default, PartialEq)]
pub struct GpuPosePrograms {
    /// One per species.
    pub programs: Vec<GpuProgram>,
    /// Every program's model steps, program after program.
    pub models: Vec<GpuModelStep>,
    /// Every program's slots, program after program.
    pub slots: Vec<GpuSlotStep>,
}

/// The pose pass's record of one fish.
pub fn fish_pose(
    pos: glam::Vec3,
    heading: f32,
    pitch: f32,
    yaw: &[f32; GPU_POSE_MAX_YAWS],
    program: u32,
    palette_offset: u32,
) -> GpuFishPose {
    GpuFishPose {
        pos_heading: pos.extend(heading).to_array(),
        pitch,
        program,
        palette_offset,
        _pad: 0,
        yaw: yaw.map(|y| if y.is_finite() { y } else { 0.0 }),
    }
}

/// The placement's rotation as the pose pass writes it: heading about +y, then pitch about the
/// body's z, from full-angle sines and cosines (a level fish, pitch 0, needs no second pair).
pub fn placement_rotation(heading: f32, pitch: f32) -> glam::Mat3A {
    let (sh, ch) = heading.sin_cos();
    let (sp, cp) = if pitch == 0.0 {
        (0.0, 1.0)
    } else {
        pitch.sin_cos()
    };
    glam::Mat3A::from_cols(
        glam::Vec3A::new(cp * ch, sp, -cp * sh),
        glam::Vec3A::new(-sp * ch, cp, sp * sh),
        glam::Vec3A::new(sh, 0.0, ch),
    )
}

/// What `shaders/pose.wgsl` computes for one fish, on the CPU in f32 (the shader's formulas,
/// not the CPU stage's): for tests of the programs without a GPU.
pub fn run_program(programs: &GpuPosePrograms, fish: &GpuFishPose, out: &mut [Mat4]) {
    let Some(p) = programs.programs.get(fish.program as usize) else {
        return;
    };
    let [x, y, z, h] = fish.pos_heading;
    let r = placement_rotation(h, fish.pitch);
    let placement = Mat4::from_cols(
        r.x_axis.extend(0.0),
        r.y_axis.extend(0.0),
        r.z_axis.extend(0.0),
        Vec4::new(x, y, z, 1.0),
    ) * Mat4::from_cols_array_2d(&p.model_to_body);
    let steps = &programs.models[p.first_model as usize..][..p.num_models as usize];
    let mut models = [Mat4::IDENTITY; GPU_POSE_MAX_MODELS];
    for (k, s) in steps.iter().enumerate().take(GPU_POSE_MAX_MODELS) {
        let a = Mat4::from_cols_array_2d(&s.a);
        let local = match fish.yaw.get(s.yaw_slot as usize) {
            Some(&t) => {
                a + Mat4::from_cols_array_2d(&s.b) * t.cos()
                    + Mat4::from_cols_array_2d(&s.c) * t.sin()
            }
            None => a,
        };
        let parent = usize::try_from(s.parent).map_or(placement, |q| models[q]);
        models[k] = parent * local;
    }
    let slots = &programs.slots[p.first_slot as usize..][..p.num_slots as usize];
    for (entry, s) in out.iter_mut().zip(slots) {
        *entry = if s.product != 0 {
            usize::try_from(s.left).map_or(placement, |q| models[q])
                * Mat4::from_cols_array_2d(&s.rhs)
        } else {
            placement
        };
    }
}
