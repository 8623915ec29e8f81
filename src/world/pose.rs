//! The pose stage: per fish, species rig → local joint transforms → skeleton forward kinematics →
//! skinning palette (paper sections 3.2–3.3), written into one flat palette array, fish after
//! fish (issue 4 uploads it as one storage buffer).
//!
//! Work splits by halving the fish range with `rayon::join` down to leaves of [`LEAF_FISH`]
//! fish; each leaf writes only its own sub-slice of the palette, so results do not depend on the
//! number of threads. Scratch (model matrices) is per thread and grows only on warm-up. The
//! per-fish work is [`PosePlan`], checked against the layers' own jobs ([`reference_palette`]).

use std::cell::RefCell;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use glam::{Mat4, Quat, Vec3};

use super::{FishModel, MAX_DRIVEN_JOINTS, Species, SpeciesId, SpeciesRig};
use crate::motion::RootState;
use crate::skeleton::{JointTransform, NO_PARENT};

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

/// A species' skeleton prepared for posing many fish (built once per species, see
/// [`PosePlan::new`]): the same result as [`reference_palette`] — `SpeciesRig::pose`, then
/// `Skeleton::local_to_model`, then `skin::palette` — with the constant work done up front:
/// rest local matrices are precomputed (only driven joints build a matrix per fish), and a joint
/// that is not driven and has no children (fins, jaw, tail tip) gets its palette entry straight
/// from its parent's model matrix, `parent · (rest_local · inverse_bind)`, one product instead of
/// three steps.
#[derive(Debug, Clone, Default)]
pub struct PosePlan {
    parents: Vec<u16>,
    /// Rest local transform of each joint, as given and as a matrix.
    rest: Vec<JointTransform>,
    rest_matrix: Vec<Mat4>,
    /// Index into the fish's yaw array for driven joints, [`NOT_DRIVEN`] otherwise.
    yaw_slot: Vec<u8>,
    /// Bend axis of driven joints (joint-local).
    axis: Vec<Vec3>,
    /// Whether the joint's model matrix is needed (it has children, or is driven).
    needs_model: Vec<bool>,
    /// Right factor of the palette entry: `inverse_bind` for joints with a model matrix,
    /// `rest_local · inverse_bind` for the others (applied to the parent's model matrix).
    palette_rhs: Vec<Mat4>,
}

const NOT_DRIVEN: u8 = u8::MAX;

impl PosePlan {
    /// Prepares `rig` on `model`. Joints are taken from the model's skeleton; the rig's driven
    /// joints beyond [`MAX_DRIVEN_JOINTS`] or outside the skeleton are ignored (as
    /// `SpeciesRig::pose` ignores them), and a missing inverse bind pose counts as identity
    /// (`Species::validate` refuses such species for spawning anyway).
    pub fn new(rig: &SpeciesRig, model: &FishModel) -> Self {
        let skeleton = &model.skeleton;
        let n = skeleton.num_joints();
        let parents = skeleton.parents().to_vec();
        let rest: Vec<JointTransform> = (0..n)
            .map(|j| {
                rig.rest_locals
                    .get(j)
                    .copied()
                    .unwrap_or(skeleton.rest_locals()[j])
            })
            .collect();
        let rest_matrix: Vec<Mat4> = rest.iter().map(JointTransform::to_mat4).collect();
        let mut yaw_slot = vec![NOT_DRIVEN; n];
        let mut axis = vec![Vec3::ZERO; n];
        for (k, (&j, &a)) in rig.driven_joints.iter().zip(&rig.bend_axes).enumerate() {
            if j < n && k < MAX_DRIVEN_JOINTS && yaw_slot[j] == NOT_DRIVEN {
                yaw_slot[j] = k as u8;
                axis[j] = a;
            }
        }
        let mut has_children = vec![false; n];
        for &p in &parents {
            if p != NO_PARENT {
                has_children[usize::from(p)] = true;
            }
        }
        let needs_model: Vec<bool> = (0..n)
            .map(|j| has_children[j] || yaw_slot[j] != NOT_DRIVEN)
            .collect();
        let palette_rhs = (0..n)
            .map(|j| {
                let ibm = model
                    .inverse_bind_poses
                    .get(j)
                    .copied()
                    .unwrap_or(Mat4::IDENTITY);
                if needs_model[j] {
                    ibm
                } else {
                    rest_matrix[j] * ibm
                }
            })
            .collect();
        Self {
            parents,
            rest,
            rest_matrix,
            yaw_slot,
            axis,
            needs_model,
            palette_rhs,
        }
    }

    /// Number of joints (palette entries per fish).
    pub fn num_joints(&self) -> usize {
        self.parents.len()
    }

    /// Model matrices of the joints that need one, from the fish's placement `root` and its
    /// driven joints' `yaw` (radians; a non-finite yaw counts as rest, as in
    /// `SpeciesRig::pose`). Entries of other joints are left alone.
    pub fn models(&self, root: Mat4, yaw: &[f32], models: &mut [Mat4]) {
        for j in 0..self.parents.len() {
            if !self.needs_model[j] {
                continue;
            }
            let local = match self.yaw_slot[j] {
                NOT_DRIVEN => self.rest_matrix[j],
                slot => match yaw.get(usize::from(slot)) {
                    Some(&angle) if angle.is_finite() => {
                        let r = &self.rest[j];
                        let rotation =
                            (r.rotation * Quat::from_axis_angle(self.axis[j], angle)).normalize();
                        Mat4::from_scale_rotation_translation(r.scale, rotation, r.translation)
                    }
                    _ => self.rest_matrix[j],
                },
            };
            let parent = match self.parents[j] {
                NO_PARENT => root,
                p => models[usize::from(p)],
            };
            models[j] = parent * local;
        }
    }

    /// The skinning palette from [`PosePlan::models`]' output.
    pub fn palette(&self, root: Mat4, models: &[Mat4], out: &mut [Mat4]) {
        for (j, o) in out.iter_mut().enumerate().take(self.parents.len()) {
            let left = if self.needs_model[j] {
                models[j]
            } else {
                match self.parents[j] {
                    NO_PARENT => root,
                    p => models[usize::from(p)],
                }
            };
            *o = left * self.palette_rhs[j];
        }
    }
}

/// The pose stage spelled out with the layers' own jobs, for one fish: `SpeciesRig::pose` →
/// `Skeleton::local_to_model` from [`root_matrix`] → `skin::palette`. [`PosePlan`] computes the
/// same (tests compare them); this allocates and is for checking, not for the tick.
pub fn reference_palette(
    species: &Species,
    root: &RootState,
    yaw: &[f32],
    out: &mut [Mat4],
) -> Result<(), String> {
    let skeleton = &species.model.skeleton;
    let mut locals = vec![JointTransform::IDENTITY; skeleton.num_joints()];
    species.rig.pose(yaw, &mut locals);
    let mut models = vec![Mat4::IDENTITY; skeleton.num_joints()];
    skeleton
        .local_to_model(
            root_matrix(root, &species.rig.model_to_body),
            &locals,
            &mut models,
        )
        .run()
        .map_err(|e| e.to_string())?;
    crate::skin::palette(&models, &species.model.inverse_bind_poses, out).map_err(|e| e.to_string())
}

/// Inputs of the pose job, all indexed by dense fish position.
pub(crate) struct PoseInputs<'a> {
    pub species: &'a [Species],
    pub plans: &'a [PosePlan],
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
}

#[derive(Default)]
struct Scratch {
    models: Vec<Mat4>,
    roots: Vec<Mat4>,
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
        scratch.roots.clear();
        let start = Instant::now();
        for i in first..first + count {
            let sid = usize::from(inputs.fish_species[i].0);
            let plan = &inputs.plans[sid];
            let root = root_matrix(&inputs.roots[i], &inputs.species[sid].rig.model_to_body);
            scratch.roots.push(root);
            let lo = inputs.offsets[i] as usize - base;
            let hi = inputs.offsets[i + 1] as usize - base;
            plan.models(root, &inputs.yaw[i], &mut scratch.models[lo..hi]);
        }
        let mid = Instant::now();
        for (k, i) in (first..first + count).enumerate() {
            let plan = &inputs.plans[usize::from(inputs.fish_species[i].0)];
            let lo = inputs.offsets[i] as usize - base;
            let hi = inputs.offsets[i + 1] as usize - base;
            plan.palette(scratch.roots[k], &scratch.models[lo..hi], &mut out[lo..hi]);
        }
        let end = Instant::now();
        timing
            .skeleton_ns
            .fetch_add((mid - start).as_nanos() as u64, Ordering::Relaxed);
        timing
            .palette_ns
            .fetch_add((end - mid).as_nanos() as u64, Ordering::Relaxed);
    });
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::world::sense::forward;

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
