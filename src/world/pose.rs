//! The pose stage: per fish, species rig → local joint transforms → skeleton forward kinematics →
//! skinning palette (paper sections 3.2–3.3), written into one flat palette array, fish after
//! fish (issue 4 uploads it as one storage buffer).
//!
//! Work splits by halving the fish range with `rayon::join` down to leaves of [`LEAF_FISH`]
//! fish; each leaf writes only its own sub-slice of the palette, so results do not depend on the
//! number of threads. Scratch (locals, model matrices) is per thread and grows only on warm-up.

use std::cell::RefCell;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use glam::{Mat4, Quat};

use super::{MAX_DRIVEN_JOINTS, Species, SpeciesId};
use crate::motion::RootState;
use crate::skeleton::JointTransform;
use crate::skin::palette;

/// Fish per leaf task: large enough that the per-leaf timing and scheduling are noise.
pub const LEAF_FISH: usize = 64;

/// World placement of a fish model: translation to the root (head) position, then heading about
/// +y, then pitch about the body's z axis, then the rig's model → body transform.
pub fn root_matrix(root: &RootState, model_to_body: &Mat4) -> Mat4 {
    Mat4::from_rotation_translation(
        Quat::from_rotation_y(root.heading) * Quat::from_rotation_z(root.pitch),
        root.pos,
    ) * *model_to_body
}

/// Inputs of the pose job, all indexed by dense fish position.
pub(crate) struct PoseInputs<'a> {
    pub species: &'a [Species],
    pub fish_species: &'a [SpeciesId],
    pub roots: &'a [RootState],
    pub yaw: &'a [[f32; MAX_DRIVEN_JOINTS]],
    /// `offsets[i]..offsets[i + 1]` is fish i's range in the palette; length = fish + 1.
    pub offsets: &'a [u32],
}

/// Nanoseconds spent in each half of the job, summed over threads.
#[derive(Default)]
pub(crate) struct PoseTiming {
    pub skeleton_ns: AtomicU64,
    pub palette_ns: AtomicU64,
    pub failures: AtomicU64,
}

#[derive(Default)]
struct Scratch {
    locals: Vec<JointTransform>,
    models: Vec<Mat4>,
}

thread_local! {
    static SCRATCH: RefCell<Scratch> = RefCell::new(Scratch::default());
}

/// Runs the job over fish `first..first + count`, whose palettes are `out`.
pub(crate) fn run(
    inputs: &PoseInputs<'_>,
    first: usize,
    count: usize,
    out: &mut [Mat4],
    timing: &PoseTiming,
) {
    if count <= LEAF_FISH {
        leaf(inputs, first, count, out, timing);
        return;
    }
    let half = count / 2;
    let split = (inputs.offsets[first + half] - inputs.offsets[first]) as usize;
    let (left, right) = out.split_at_mut(split);
    rayon::join(
        || run(inputs, first, half, left, timing),
        || run(inputs, first + half, count - half, right, timing),
    );
}

fn leaf(
    inputs: &PoseInputs<'_>,
    first: usize,
    count: usize,
    out: &mut [Mat4],
    timing: &PoseTiming,
) {
    SCRATCH.with_borrow_mut(|scratch| {
        let base = inputs.offsets[first] as usize;
        let total = inputs.offsets[first + count] as usize - base;
        if scratch.models.len() < total {
            scratch.models.resize(total, Mat4::IDENTITY);
        }
        let start = Instant::now();
        let mut failures = 0;
        for i in first..first + count {
            let species = &inputs.species[usize::from(inputs.fish_species[i].0)];
            let skeleton = &species.model.skeleton;
            let joints = skeleton.num_joints();
            if scratch.locals.len() < joints {
                scratch.locals.resize(joints, JointTransform::IDENTITY);
            }
            let locals = &mut scratch.locals[..joints];
            let driven = species.rig.body.power.len().min(MAX_DRIVEN_JOINTS);
            species.rig.pose(&inputs.yaw[i][..driven], locals);
            let lo = inputs.offsets[i] as usize - base;
            let models = &mut scratch.models[lo..lo + joints];
            let root = root_matrix(&inputs.roots[i], &species.rig.model_to_body);
            if skeleton.local_to_model(root, locals, models).run().is_err() {
                failures += 1;
            }
        }
        let mid = Instant::now();
        for i in first..first + count {
            let species = &inputs.species[usize::from(inputs.fish_species[i].0)];
            let lo = inputs.offsets[i] as usize - base;
            let hi = inputs.offsets[i + 1] as usize - base;
            if palette(
                &scratch.models[lo..hi],
                &species.model.inverse_bind_poses,
                &mut out[lo..hi],
            )
            .is_err()
            {
                failures += 1;
                out[lo..hi].fill(Mat4::IDENTITY);
            }
        }
        let end = Instant::now();
        timing
            .skeleton_ns
            .fetch_add((mid - start).as_nanos() as u64, Ordering::Relaxed);
        timing
            .palette_ns
            .fetch_add((end - mid).as_nanos() as u64, Ordering::Relaxed);
        if failures > 0 {
            timing.failures.fetch_add(failures, Ordering::Relaxed);
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::sense::forward;
    use glam::Vec3;

    #[test]
    fn root_matrix_faces_the_heading_and_sits_at_the_root() {
        let root = RootState {
            pos: Vec3::new(1.0, 2.0, 3.0),
            heading: 0.7,
            pitch: 0.2,
            speed: 0.0,
        };
        let m = root_matrix(&root, &Mat4::IDENTITY);
        assert!(m.transform_point3(Vec3::ZERO).abs_diff_eq(root.pos, 1e-6));
        // Body +x is the fish's forward.
        let f = m.transform_vector3(Vec3::X);
        assert!(f.abs_diff_eq(forward(0.7, 0.2), 1e-6), "{f}");
    }
}
