//! The GPU pose pass's plain data (issue 18): per species a *program* — the body wave's
//! per-sample constants and the steps the CPU pose stage walks (`world::pose`), as matrices and
//! indices — and per fish a record of its root and of the motion player's shape terms (phase,
//! speed gain, blend, turn terms). The world builds them; the renderer uploads them and
//! `shaders/pose.wgsl` samples each fish's body shape, turns it into the driven joints' yaws
//! (as the motion player's shape step does) and runs the program into the palette buffer, in the
//! layout the CPU stage writes. [`run_program`] is the shader's arithmetic on the CPU, for tests
//! without a GPU.

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec4};

/// Driven joints a fish record holds (the world's `MAX_DRIVEN_JOINTS`).
pub const GPU_POSE_MAX_YAWS: usize = 16;

/// Model matrices one species' program may make: the size of the pass's per-fish array in
/// `shaders/pose.wgsl` (`MAX_MODELS` there). A species needing more poses on the CPU.
pub const GPU_POSE_MAX_MODELS: usize = 32;

/// Midline samples a program's shape step reads: the head and up to
/// [`GPU_POSE_MAX_YAWS`] + 1 `joints_x` entries.
pub const GPU_POSE_MAX_SAMPLES: usize = GPU_POSE_MAX_YAWS + 2;

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

/// One midline sample of a species' body (the motion player's wave table, head first, then
/// each `joints_x` entry): what the shape step reads of it.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Pod, Zeroable)]
pub struct GpuShapeSample {
    /// x' = x·l − p·l, length units.
    pub xp: f32,
    /// A(x) (the front wave's amplitude in front of the pivot), length units.
    pub amp: f32,
    /// sin and cos of the swim wave's spatial argument (2π·x'/λ' in front of the pivot, 2π·x'/λ
    /// behind it).
    pub swim_sin: f32,
    /// See `swim_sin`.
    pub swim_cos: f32,
    /// x·l: the sample's distance from the snout, length units.
    pub xl: f32,
    /// The power weight of the driven joint at this sample (0 for the head and the tail tip).
    pub power: f32,
    /// Padding to 32 bytes.
    pub _pad: [f32; 2],
}

/// A species' program: its shape samples, model steps and slots in [`GpuPosePrograms`]' arrays.
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
    /// Its first sample in [`GpuPosePrograms::samples`].
    pub first_sample: u32,
    /// Its number of samples: the head, then one per `joints_x` entry (driven joints + 2).
    pub num_samples: u32,
    /// The species' f, eq. (5) and (6).
    pub f: f32,
    /// Padding to 16 bytes (WGSL struct alignment).
    pub _pad: u32,
}

/// One motion's turn terms at the step, as the shape step reads them: the motion player's
/// [`MotionTerms`](crate::motion::player::MotionTerms) (kind 0: no turn term; 1: a normal turn,
/// eq. (5); 2: a quick or serial turn, eq. (6)).
pub type GpuMotionShape = crate::motion::player::MotionTerms;

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
    /// The swim wave's phase φ (radians), its speed gain, the current motion's weight in the
    /// shape's cross-fade (1: no previous motion), and 0.
    pub wave: [f32; 4],
    /// The current motion's turn terms.
    pub current: GpuMotionShape,
    /// The previous motion's, while the shape cross-fades from it.
    pub previous: GpuMotionShape,
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
    /// Every program's shape samples, program after program.
    pub samples: Vec<GpuShapeSample>,
}

/// Whether `x` is finite, tested on its bits (as the shader must: a GPU may assume no NaNs).
fn finite_bits(x: f32) -> bool {
    x.to_bits() & 0x7f80_0000 != 0x7f80_0000
}

/// The paper's F (positive to the fish's right) of `motion` at sample `s`, with `travelling`
/// the sample's sin(2π·x'/λ − φ): `shaders/pose.wgsl`'s `motion_shape`.
fn motion_shape(m: &GpuMotionShape, f: f32, gain: f32, s: &GpuShapeSample, travelling: f32) -> f32 {
    let swim = s.amp * gain * travelling;
    if m.kind == 0 || m.ip == 0.0 || s.xp <= 0.0 {
        return swim;
    }
    let t = if m.kind == 1 {
        s.amp * (travelling + m.d) * f
    } else {
        let theta = m.omega_t - std::f32::consts::TAU * s.xp / m.wavelength;
        if theta < 0.0 || theta > m.stroke_end {
            0.0
        } else {
            s.amp * m.bend * f * m.d * theta.sin().abs()
        }
    };
    swim * (1.0 - m.ip) + t * m.ip
}

/// The driven joints' yaws of `fish` under `program`, as `shaders/pose.wgsl` derives them:
/// the shape sampled at the head and each `joints_x` entry (cross-faded between the two
/// motions), each segment's angle atan2(rise, run), and yaw k = power·(θ_{k+1} − θ_k); non-finite
/// values as 0.
pub fn shape_yaws(
    program: &GpuProgram,
    samples: &[GpuShapeSample],
    fish: &GpuFishPose,
) -> [f32; GPU_POSE_MAX_YAWS] {
    let mut yaw = [0.0f32; GPU_POSE_MAX_YAWS];
    let [phase, gain, w, _] = fish.wave;
    let (sin_phi, cos_phi) = phase.sin_cos();
    let first = program.first_sample as usize;
    let n = (program.num_samples as usize).min(GPU_POSE_MAX_SAMPLES);
    let Some(samples) = samples.get(first..first + n) else {
        return yaw;
    };
    let (mut prev_lat, mut prev_xl, mut prev_theta) = (0.0f32, 0.0f32, 0.0f32);
    for (i, s) in samples.iter().enumerate() {
        let travelling = s.swim_sin * cos_phi - s.swim_cos * sin_phi;
        let mut shape = motion_shape(&fish.current, program.f, gain, s, travelling);
        if w < 1.0 {
            shape = shape * w
                + motion_shape(&fish.previous, program.f, gain, s, travelling) * (1.0 - w);
        }
        let lat = if finite_bits(-shape) { -shape } else { 0.0 };
        if i > 0 {
            let theta = (lat - prev_lat).atan2(s.xl - prev_xl);
            if i >= 2 {
                let y = samples[i - 1].power * (theta - prev_theta);
                yaw[i - 2] = if finite_bits(y) { y } else { 0.0 };
            }
            prev_theta = theta;
        }
        prev_lat = lat;
        prev_xl = s.xl;
    }
    yaw
}

/// The placement's rotation as the pose pass writes it: heading about +y, then pitch about the
/// body's z, from full-angle sines and cosines (a level fish, pitch 0, needs no second pair).
pub fn placement_rotation(heading: f32, pitch: f32) -> glam::Mat3A {
    placement_rotation_of(heading.sin_cos(), pitch)
}

/// [`placement_rotation`] from the heading's sine and cosine, `(sh, ch)` (`heading.sin_cos()`),
/// for a caller that has them already.
pub fn placement_rotation_of((sh, ch): (f32, f32), pitch: f32) -> glam::Mat3A {
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
    let yaws = shape_yaws(p, &programs.samples, fish);
    let steps = &programs.models[p.first_model as usize..][..p.num_models as usize];
    let mut models = [Mat4::IDENTITY; GPU_POSE_MAX_MODELS];
    for (k, s) in steps.iter().enumerate().take(GPU_POSE_MAX_MODELS) {
        let a = Mat4::from_cols_array_2d(&s.a);
        let local = match yaws.get(s.yaw_slot as usize) {
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
