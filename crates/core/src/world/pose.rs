//! The pose stage: per fish, species rig → local joint transforms → skeleton forward kinematics →
//! skinning palette (paper sections 3.2–3.3), written into one flat palette array, fish after
//! fish (issue 4 uploads it as one storage buffer).
//!
//! The array holds each fish's *distinct* palette entries only (issue 18): many joints' entries
//! are exact copies of another's (see [`PosePlan`]), so a species maps each joint to a *slot*
//! ([`PosePlan::slot_of_joint`]) and a fish's palette is its slots. Expanding the slots through
//! the map gives the per-joint palette bit for bit ([`expand_palette`]); the renderer instead
//! remaps the mesh's joint indices to slots once, at upload ([`remap_joints`]).
//!
//! Work splits by halving the fish range with `rayon::join` down to leaves of [`LEAF_FISH`]
//! fish; each leaf writes only its own sub-slice of the palette, so results do not depend on the
//! number of threads. Scratch (model matrices) is per thread and grows only on warm-up. The
//! per-fish work is [`PosePlan`] (which multiplies only what differs between joints), checked
//! against the layers' own jobs ([`reference_palette`]).

pub(crate) mod buffers;
pub mod gpu;

use std::cell::RefCell;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use std::ops::Mul;

use glam::{Affine3A, DMat3, DVec3, Mat3A, Mat4, Quat, Vec3, Vec3A};

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

/// The matrix type a plan multiplies in. [`Affine3A`] when every matrix the plan multiplies is
/// exactly affine (bottom row 0 0 0 1): glam multiplies both column by column in the same order,
/// so the products are the same numbers (up to the sign of zeros) with a quarter fewer
/// operations. [`Mat4`] otherwise.
trait Transform: Copy + Mul<Output = Self> {
    const IDENTITY: Self;
    /// The transform `x ↦ linear · x + translation`.
    fn from_linear_translation(linear: Mat3A, translation: Vec3A) -> Self;
    /// `m`, which the plan has checked to be representable.
    fn from_mat4(m: Mat4) -> Self;
    fn to_mat4(self) -> Mat4;
    /// [`root_matrix`] in this type: the same quaternions and the same products, so the same
    /// numbers. (Writing Ry(h)·Rz(p) out from full-angle `sin_cos` is cheaper but rounds
    /// differently, by 2 ulp of an 800-unit position at times: more than the world's tests
    /// allow against the reference.)
    fn placement(root: &RootState, model_to_body: Self) -> Self {
        let rotation = Quat::from_rotation_y(root.heading) * Quat::from_rotation_z(root.pitch);
        Self::from_linear_translation(Mat3A::from_quat(rotation), root.pos.into()) * model_to_body
    }
}

impl Transform for Mat4 {
    const IDENTITY: Self = Mat4::IDENTITY;
    fn from_linear_translation(linear: Mat3A, translation: Vec3A) -> Self {
        Mat4::from_cols(
            linear.x_axis.extend(0.0),
            linear.y_axis.extend(0.0),
            linear.z_axis.extend(0.0),
            translation.extend(1.0),
        )
    }
    fn from_mat4(m: Mat4) -> Self {
        m
    }
    fn to_mat4(self) -> Mat4 {
        self
    }
}

impl Transform for Affine3A {
    const IDENTITY: Self = Affine3A::IDENTITY;
    fn from_linear_translation(linear: Mat3A, translation: Vec3A) -> Self {
        Affine3A {
            matrix3: linear,
            translation,
        }
    }
    fn from_mat4(m: Mat4) -> Self {
        Affine3A::from_mat4(m)
    }
    fn to_mat4(self) -> Mat4 {
        Mat4::from(self)
    }
}

/// A driven joint's local transform as a function of its yaw θ, prepared once per species.
///
/// The rig poses the joint as T · R₀ · R(a, θ) · S (rest translation, rest rotation, the bend
/// about the unit axis a, rest scale). By Rodrigues' formula R(a, θ) = cos θ·I + sin θ·[a]ₓ +
/// (1 − cos θ)·a·aᵀ, so its linear part is exactly `outer + cos θ·(rest − outer) + sin θ·cross`
/// with the three constant matrices below (computed in f64 and rounded once): one `sin_cos`
/// and three multiply-adds per column per fish, where the quaternion form needs a half-angle
/// `sin_cos`, a quaternion product, a normalisation (square root and division) and the
/// conversion to a matrix. The rest rotation is normalised here, once, which is what
/// normalising the product did (`normalize(r·q) = normalize(r)·q` for a unit `q`).
#[derive(Debug, Clone, Copy)]
struct Bend {
    /// R₀·a·aᵀ·S.
    outer: Mat3A,
    /// R₀·S − R₀·a·aᵀ·S.
    rest_minus_outer: Mat3A,
    /// R₀·[a]ₓ·S.
    cross: Mat3A,
    /// The rest translation T.
    translation: Vec3A,
}

impl Bend {
    fn new(rest: &JointTransform, axis: Vec3) -> Self {
        let r0 = DMat3::from_quat(rest.rotation.as_dquat().normalize());
        let s = DMat3::from_diagonal(rest.scale.as_dvec3());
        let a = axis.as_dvec3().try_normalize().unwrap_or(DVec3::Y);
        let cross = DMat3::from_cols(
            DVec3::new(0.0, a.z, -a.y),
            DVec3::new(-a.z, 0.0, a.x),
            DVec3::new(a.y, -a.x, 0.0),
        );
        let outer = DMat3::from_cols(a * a.x, a * a.y, a * a.z);
        let f32s = |m: DMat3| Mat3A::from(m.as_mat3());
        Self {
            outer: f32s(r0 * outer * s),
            rest_minus_outer: f32s(r0 * s - r0 * outer * s),
            cross: f32s(r0 * cross * s),
            translation: rest.translation.into(),
        }
    }

    /// The joint's local transform at yaw `angle` (radians, finite).
    #[inline]
    fn local<T: Transform>(&self, angle: f32) -> T {
        let (sin, cos) = angle.sin_cos();
        let column = |outer: Vec3A, rest: Vec3A, cross: Vec3A| outer + rest * cos + cross * sin;
        let (o, r, c) = (&self.outer, &self.rest_minus_outer, &self.cross);
        T::from_linear_translation(
            Mat3A::from_cols(
                column(o.x_axis, r.x_axis, c.x_axis),
                column(o.y_axis, r.y_axis, c.y_axis),
                column(o.z_axis, r.z_axis, c.z_axis),
            ),
            self.translation,
        )
    }
}

/// Whether `m`'s bottom row is exactly 0 0 0 1.
fn exactly_affine(m: &Mat4) -> bool {
    m.row(3) == glam::Vec4::W
}

/// How a joint's palette entry is made (see [`PosePlan`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum PaletteOp {
    /// Its own model matrix × inverse bind pose.
    OwnModel,
    /// Its parent's model matrix (the placement, for a root) × `rest_local · inverse_bind`.
    ParentModel,
    /// Its parent's palette entry, which equals it (see [`PosePlan`]).
    CopyParent,
    /// The placement itself, which equals it (a root whose rest pose is its bind pose).
    CopyRoot,
}

/// A plan's matrices in the type it multiplies in.
#[derive(Debug, Clone, Default)]
struct Matrices<T> {
    /// Rest local transform of each joint.
    rest: Vec<T>,
    /// Right factor of each joint's palette entry: `inverse_bind` for [`PaletteOp::OwnModel`],
    /// `rest_local · inverse_bind` for [`PaletteOp::ParentModel`] (unused for copies).
    palette_rhs: Vec<T>,
    /// The rig's model → body transform.
    model_to_body: T,
}

impl<T: Transform> Matrices<T> {
    fn new(rest: &[Mat4], rhs: &[Mat4], model_to_body: Mat4) -> Self {
        Self {
            rest: rest.iter().map(|&m| T::from_mat4(m)).collect(),
            palette_rhs: rhs.iter().map(|&m| T::from_mat4(m)).collect(),
            model_to_body: T::from_mat4(model_to_body),
        }
    }
}

#[derive(Debug, Clone)]
enum PlanMatrices {
    Affine(Matrices<Affine3A>),
    General(Matrices<Mat4>),
}

impl Default for PlanMatrices {
    fn default() -> Self {
        PlanMatrices::General(Matrices::default())
    }
}

/// Largest relative difference, over the elements, at which a non-driven joint's palette entry
/// counts as equal to its parent's ([`PaletteOp::CopyParent`]).
const SAME_PALETTE_TOLERANCE: f32 = 1e-6;

/// Whether `a` equals `b` within [`SAME_PALETTE_TOLERANCE`] of `b`'s largest element (or 1).
fn same_matrix(a: &Mat4, b: &Mat4) -> bool {
    within(a, b, SAME_PALETTE_TOLERANCE)
}

/// Whether every element of `a` is within `tolerance` × `b`'s largest element (or 1) of `b`'s.
fn within(a: &Mat4, b: &Mat4, tolerance: f32) -> bool {
    let scale = b.abs().to_cols_array().into_iter().fold(1.0f32, f32::max);
    (*a - *b)
        .abs()
        .to_cols_array()
        .into_iter()
        .all(|d| d <= tolerance * scale)
}

/// A species' skeleton prepared for posing many fish (built once per species, see
/// [`PosePlan::new`]): the same result as [`reference_palette`] — `SpeciesRig::pose`, then
/// `Skeleton::local_to_model`, then `skin::palette` — with the constant work done up front:
///
/// - rest local matrices are precomputed, so only driven joints build a matrix per fish;
/// - a joint that is not driven and whose rest pose is its bind pose relative to its parent
///   (`rest_local · inverse_bind = inverse_bind(parent)`, checked to 1e-6 relative) has the
///   same palette entry as its parent, `parent_model · rest_local · inverse_bind`
///   = `parent_model · inverse_bind(parent)`: it is copied, not multiplied (likewise a root
///   whose rest pose is its bind pose gets the fish's placement). Fins, jaw, eyes and the tail
///   of the shipped fish are such joints; only the root and the six driven spine joints are
///   multiplied. A copy differs from the product only by its rounding;
/// - model matrices are made only for joints whose palette entry or whose descendants need
///   them; another not-driven joint without such descendants gets its palette entry from its
///   parent's model matrix, `parent · (rest_local · inverse_bind)`, one product;
/// - when every matrix it multiplies is exactly affine, it multiplies [`Affine3A`]s (the same
///   products as [`Mat4`]s, fewer operations).
///
/// Per fish it then walks only what works: a schedule lists the model matrices to make and the
/// palette's distinct entries, its *slots*: one per joint whose entry is a product, plus one for
/// the placement if a joint copies it, numbered in the order their first joint comes (so joint
/// 0's entry is slot 0, which culling reads). A copy is not written at all: the joint maps to
/// the slot it copies ([`PosePlan::slot_of_joint`]), bit-identical to the per-joint palette's
/// copy. Joints without a model matrix cost nothing there; a driven joint's local transform
/// comes from its `Bend` (Rodrigues' formula, one `sin_cos`).
#[derive(Debug, Clone, Default)]
pub struct PosePlan {
    parents: Vec<u16>,
    /// Index into the fish's yaw array for driven joints, [`NOT_DRIVEN`] otherwise.
    yaw_slot: Vec<u8>,
    /// The bend of each joint (used for driven joints only).
    bends: Vec<Bend>,
    /// Whether the joint's model matrix is needed (for its palette entry or a descendant's).
    needs_model: Vec<bool>,
    palette_op: Vec<PaletteOp>,
    /// `needs_model` and `palette_op` as lists of steps (see [`Schedule`]).
    schedule: Schedule,
    matrices: PlanMatrices,
}

const NOT_DRIVEN: u8 = u8::MAX;

/// What a plan does per fish, in order, built from its `needs_model` and `palette_op`.
#[derive(Debug, Clone, Default)]
struct Schedule {
    /// The joints whose model matrix is made (parents before children).
    models: Vec<ModelStep>,
    /// Every slot of the palette, in slot order (so the palette is written front to back).
    palette: Vec<PaletteStep>,
    /// Each joint's slot: its own for a product, else the slot of the entry it copies.
    slot_of_joint: Vec<u16>,
}

/// One model matrix: `model[joint] = model[parent] · local` ([`NO_PARENT`]: the placement).
#[derive(Debug, Clone, Copy)]
struct ModelStep {
    joint: u16,
    parent: u16,
    /// Index into the fish's yaw array, or [`NOT_DRIVEN`] (the rest matrix).
    yaw_slot: u8,
}

/// One slot of the palette: if `product`, `joint`'s entry `model[left] · palette_rhs[joint]`
/// (`left` a joint, or [`NO_PARENT`] for the placement); otherwise the placement itself (the
/// entry of the joints that copy it).
#[derive(Debug, Clone, Copy)]
struct PaletteStep {
    joint: u16,
    left: u16,
    product: bool,
}

impl Schedule {
    fn new(parents: &[u16], yaw_slot: &[u8], needs_model: &[bool], ops: &[PaletteOp]) -> Self {
        let mut schedule = Self::default();
        for (j, &parent) in parents.iter().enumerate() {
            if needs_model[j] {
                schedule.models.push(ModelStep {
                    joint: j as u16,
                    parent,
                    yaw_slot: yaw_slot[j],
                });
            }
        }
        // Each joint's slot: a product gets the next one; a copy takes the slot of what it
        // copies (its parent's, whose own slot is known as parents come first, or the
        // placement's, made when the first joint copies it).
        let mut placement_slot = None;
        for (j, op) in ops.iter().enumerate() {
            let joint = j as u16;
            let next = schedule.palette.len() as u16;
            let slot = match op {
                PaletteOp::OwnModel | PaletteOp::ParentModel => {
                    let left = if *op == PaletteOp::OwnModel {
                        joint
                    } else {
                        parents[j]
                    };
                    schedule.palette.push(PaletteStep {
                        joint,
                        left,
                        product: true,
                    });
                    next
                }
                PaletteOp::CopyParent => schedule.slot_of_joint[usize::from(parents[j])],
                PaletteOp::CopyRoot => *placement_slot.get_or_insert_with(|| {
                    schedule.palette.push(PaletteStep {
                        joint,
                        left: NO_PARENT,
                        product: false,
                    });
                    next
                }),
            };
            schedule.slot_of_joint.push(slot);
        }
        schedule
    }
}

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
        let ibm: Vec<Mat4> = (0..n)
            .map(|j| {
                model
                    .inverse_bind_poses
                    .get(j)
                    .copied()
                    .unwrap_or(Mat4::IDENTITY)
            })
            .collect();
        let mut yaw_slot = vec![NOT_DRIVEN; n];
        let mut axis = vec![Vec3::Y; n];
        for (k, (&j, &a)) in rig.driven_joints.iter().zip(&rig.bend_axes).enumerate() {
            if j < n && k < MAX_DRIVEN_JOINTS && yaw_slot[j] == NOT_DRIVEN {
                yaw_slot[j] = k as u8;
                axis[j] = a;
            }
        }
        let bends = rest
            .iter()
            .zip(&axis)
            .map(|(r, &a)| Bend::new(r, a))
            .collect();
        let parent = |j: usize| (parents[j] != NO_PARENT).then(|| usize::from(parents[j]));
        // Palette entries equal to the parent's (or the placement's).
        let mut palette_op: Vec<PaletteOp> = (0..n)
            .map(|j| {
                if yaw_slot[j] != NOT_DRIVEN {
                    return PaletteOp::OwnModel;
                }
                let local_bind = rest_matrix[j] * ibm[j];
                match parent(j) {
                    None if same_matrix(&local_bind, &Mat4::IDENTITY) => PaletteOp::CopyRoot,
                    Some(p) if same_matrix(&local_bind, &ibm[p]) => PaletteOp::CopyParent,
                    _ => PaletteOp::ParentModel,
                }
            })
            .collect();
        // Model matrices: a joint's is needed if it is driven, or a child's model or palette
        // entry is made from it. Children come after their parents, so walk backwards.
        let mut needs_model: Vec<bool> = (0..n).map(|j| yaw_slot[j] != NOT_DRIVEN).collect();
        for j in (0..n).rev() {
            if let Some(p) = parent(j)
                && (needs_model[j] || palette_op[j] == PaletteOp::ParentModel)
            {
                needs_model[p] = true;
            }
        }
        // A joint with a model of its own makes its palette entry from it.
        for j in 0..n {
            if needs_model[j] && palette_op[j] == PaletteOp::ParentModel {
                palette_op[j] = PaletteOp::OwnModel;
            }
        }
        let palette_rhs: Vec<Mat4> = (0..n)
            .map(|j| match palette_op[j] {
                PaletteOp::ParentModel => rest_matrix[j] * ibm[j],
                _ => ibm[j],
            })
            .collect();
        let affine = rest_matrix
            .iter()
            .chain(&palette_rhs)
            .chain([&rig.model_to_body])
            .all(exactly_affine);
        let matrices = if affine {
            PlanMatrices::Affine(Matrices::new(&rest_matrix, &palette_rhs, rig.model_to_body))
        } else {
            PlanMatrices::General(Matrices::new(&rest_matrix, &palette_rhs, rig.model_to_body))
        };
        let schedule = Schedule::new(&parents, &yaw_slot, &needs_model, &palette_op);
        Self {
            parents,
            yaw_slot,
            bends,
            needs_model,
            palette_op,
            schedule,
            matrices,
        }
    }

    /// Number of joints.
    pub fn num_joints(&self) -> usize {
        self.parents.len()
    }

    /// Number of slots (palette entries per fish): the distinct entries of the per-joint
    /// palette.
    pub fn num_slots(&self) -> usize {
        self.schedule.palette.len()
    }

    /// Each joint's slot: joint j's palette entry is slot `slot_of_joint()[j]` of the fish's
    /// palette. Joint 0's is slot 0.
    pub fn slot_of_joint(&self) -> &[u16] {
        &self.schedule.slot_of_joint
    }

    /// Whether the plan multiplies [`Affine3A`]s (every matrix it multiplies is exactly affine).
    pub fn is_affine(&self) -> bool {
        matches!(self.matrices, PlanMatrices::Affine(_))
    }

    /// Matrix products per fish: model matrices made plus palette entries not copied.
    pub fn products_per_fish(&self) -> usize {
        let models = self.needs_model.iter().filter(|&&m| m).count();
        let palettes = self
            .palette_op
            .iter()
            .filter(|op| matches!(op, PaletteOp::OwnModel | PaletteOp::ParentModel))
            .count();
        models + palettes
    }

    /// The model matrices of the joints `schedule` makes, from the fish's placement `root` and
    /// its driven joints' `yaw` (radians; a missing or non-finite yaw counts as rest, as in
    /// `SpeciesRig::pose`). Entries of other joints are left alone.
    fn models<T: Transform>(
        &self,
        schedule: &Schedule,
        m: &Matrices<T>,
        root: T,
        yaw: &[f32],
        models: &mut [T],
    ) {
        for step in &schedule.models {
            let j = usize::from(step.joint);
            let local = self.local(m, j, step.yaw_slot, yaw);
            let parent = match step.parent {
                NO_PARENT => root,
                p => models[usize::from(p)],
            };
            models[j] = parent * local;
        }
    }

    /// Joint `j`'s local transform, bent by the yaw at `yaw_slot` of `yaw` if it is driven
    /// (a missing or non-finite yaw counts as rest).
    #[inline]
    fn local<T: Transform>(&self, m: &Matrices<T>, j: usize, yaw_slot: u8, yaw: &[f32]) -> T {
        match yaw_slot {
            NOT_DRIVEN => m.rest[j],
            slot => match yaw.get(usize::from(slot)) {
                Some(&angle) if angle.is_finite() => self.bends[j].local(angle),
                _ => m.rest[j],
            },
        }
    }

    /// The palette's slots from [`PosePlan::models`]' output: every slot of `out` that the plan
    /// has (slots past `out`'s end are not made).
    fn palette<T: Transform>(
        &self,
        schedule: &Schedule,
        m: &Matrices<T>,
        root: T,
        models: &[T],
        out: &mut [Mat4],
    ) {
        let placement = root.to_mat4();
        for (slot, step) in out.iter_mut().zip(&schedule.palette) {
            let j = usize::from(step.joint);
            *slot = match (step.product, step.left) {
                (true, NO_PARENT) => (root * m.palette_rhs[j]).to_mat4(),
                (true, p) => (models[usize::from(p)] * m.palette_rhs[j]).to_mat4(),
                (false, _) => placement,
            };
        }
    }

    /// The skinning palette of one fish at `root` with its driven joints' `yaw`, into `out`
    /// (one entry per joint: the slots expanded), as [`reference_palette`] computes it.
    /// Allocates scratch; the pose stage uses per-thread scratch and writes slots only.
    pub fn palette_of(&self, root: &RootState, yaw: &[f32], out: &mut [Mat4]) {
        fn run<T: Transform>(
            plan: &PosePlan,
            m: &Matrices<T>,
            root: &RootState,
            yaw: &[f32],
            out: &mut [Mat4],
        ) {
            // The schedule the tick walks.
            let schedule = &plan.schedule;
            let mut models = vec![T::IDENTITY; plan.num_joints()];
            let root = T::placement(root, m.model_to_body);
            plan.models(schedule, m, root, yaw, &mut models);
            let mut slots = vec![Mat4::IDENTITY; schedule.palette.len()];
            plan.palette(schedule, m, root, &models, &mut slots);
            for (entry, &slot) in out.iter_mut().zip(&schedule.slot_of_joint) {
                *entry = slots[usize::from(slot)];
            }
        }
        match &self.matrices {
            PlanMatrices::Affine(m) => run(self, m, root, yaw, out),
            PlanMatrices::General(m) => run(self, m, root, yaw, out),
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
) -> Result<(), ReferencePoseError> {
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
        .run()?;
    crate::skin::palette(&models, &species.model.inverse_bind_poses, out)?;
    Ok(())
}

/// Why [`reference_palette`] could not pose a fish: the layer that refused, with its own error.
#[derive(Debug, thiserror::Error)]
pub enum ReferencePoseError {
    /// Forward kinematics refused the skeleton or its local transforms.
    #[error(transparent)]
    Skeleton(#[from] crate::skeleton::SkeletonError),
    /// Skinning refused the models or the inverse bind poses.
    #[error(transparent)]
    Skin(#[from] crate::skin::SkinError),
}

/// A fish's per-joint palette from its slots: `out[j] = slots[slot_of_joint[j]]` for every
/// joint (`out` is cleared first; a slot missing from `slots` leaves the joints from there on
/// out). The same matrices, bit for bit, as the per-joint palette the slots stand for.
pub fn expand_palette(slots: &[Mat4], slot_of_joint: &[u16], out: &mut Vec<Mat4>) {
    out.clear();
    out.extend(
        slot_of_joint
            .iter()
            .map_while(|&s| slots.get(usize::from(s)).copied()),
    );
}

/// A skinned mesh's per-vertex joint indices rewritten as slot indices (`slot_of_joint` of the
/// species whose palette it is drawn with): an exact rewrite, a joint's slot holding the very
/// matrix its per-joint entry would. An index outside the skeleton stays outside the palette
/// (`num_slots` + how far it was past the last joint), so a renderer still refuses it.
pub fn remap_joints(joints: &[[u16; 4]], slot_of_joint: &[u16], num_slots: usize) -> Vec<[u16; 4]> {
    let n = slot_of_joint.len();
    joints
        .iter()
        .map(|v| {
            v.map(|j| match slot_of_joint.get(usize::from(j)) {
                Some(&s) => s,
                None => u16::try_from(num_slots + (usize::from(j) - n)).unwrap_or(u16::MAX),
            })
        })
        .collect()
}

/// Inputs of the pose job, all indexed by dense fish position.
pub(crate) struct PoseInputs<'a> {
    pub plans: &'a [PosePlan],
    pub fish_species: &'a [SpeciesId],
    pub roots: &'a [RootState],
    pub yaw: &'a [[f32; MAX_DRIVEN_JOINTS]],
    /// `offsets[i]..offsets[i + 1]` is fish i's slots in the palette; length = fish + 1.
    pub offsets: &'a [u32],
}

/// Nanoseconds spent in each half of the job, summed over threads.
#[derive(Default)]
pub(crate) struct PoseTiming {
    pub skeleton_ns: AtomicU64,
    pub palette_ns: AtomicU64,
}

/// Per-thread scratch of the pose job: model matrices and placements of a leaf's fish, in each
/// matrix type (a leaf may hold fish of affine and general plans).
#[derive(Default)]
struct Scratch {
    affine: TypedScratch<Affine3A>,
    general: TypedScratch<Mat4>,
}

#[derive(Default)]
struct TypedScratch<T> {
    models: Vec<T>,
    roots: Vec<T>,
}

impl<T: Transform> TypedScratch<T> {
    /// Room for `joints` model matrices and `fish` placements (grows only on warm-up).
    fn prepare(&mut self, joints: usize, fish: usize) {
        if self.models.len() < joints {
            self.models.resize(joints, T::IDENTITY);
        }
        if self.roots.len() < fish {
            self.roots.resize(fish, T::IDENTITY);
        }
    }
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
        let slots =
            |i: usize| inputs.offsets[i] as usize - base..inputs.offsets[i + 1] as usize - base;
        let plan = |i: usize| &inputs.plans[usize::from(inputs.fish_species[i].0)];
        // Model matrices: each fish's joints, one fish after the other.
        let joints: usize = (first..first + count).map(|i| plan(i).num_joints()).sum();
        let start = Instant::now();
        let mut at = 0;
        for (k, i) in (first..first + count).enumerate() {
            let plan = plan(i);
            let models = at..at + plan.num_joints();
            at = models.end;
            let (root, yaw) = (&inputs.roots[i], &inputs.yaw[i]);
            match &plan.matrices {
                PlanMatrices::Affine(m) => {
                    let s = &mut scratch.affine;
                    s.prepare(joints, count);
                    s.roots[k] = Affine3A::placement(root, m.model_to_body);
                    plan.models(&plan.schedule, m, s.roots[k], yaw, &mut s.models[models]);
                }
                PlanMatrices::General(m) => {
                    let s = &mut scratch.general;
                    s.prepare(joints, count);
                    s.roots[k] = Mat4::placement(root, m.model_to_body);
                    plan.models(&plan.schedule, m, s.roots[k], yaw, &mut s.models[models]);
                }
            }
        }
        let mid = Instant::now();
        let mut at = 0;
        for (k, i) in (first..first + count).enumerate() {
            let plan = plan(i);
            let models = at..at + plan.num_joints();
            at = models.end;
            let out = &mut out[slots(i)];
            match &plan.matrices {
                PlanMatrices::Affine(m) => {
                    let s = &scratch.affine;
                    plan.palette(&plan.schedule, m, s.roots[k], &s.models[models], out);
                }
                PlanMatrices::General(m) => {
                    let s = &scratch.general;
                    plan.palette(&plan.schedule, m, s.roots[k], &s.models[models], out);
                }
            }
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

    use crate::world::{Species, SpeciesDesc};
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg32;
    use std::sync::Arc;

    fn shipped(desc: SpeciesDesc) -> Species {
        let assets = crate::source_root().join("assets");
        Species::load(desc, &assets).expect("shipped species")
    }

    /// Largest difference between two palettes, relative to each entry's largest element (or 1).
    fn relative_error(got: &[Mat4], want: &[Mat4]) -> f32 {
        got.iter()
            .zip(want)
            .map(|(g, w)| {
                let scale = w.abs().to_cols_array().into_iter().fold(1.0f32, f32::max);
                (*g - *w)
                    .abs()
                    .to_cols_array()
                    .into_iter()
                    .fold(0.0f32, f32::max)
                    / scale
            })
            .fold(0.0, f32::max)
    }

    /// Random placements (across a large tank) and bends, some yaws not finite.
    fn poses(seed: u64, n: usize) -> Vec<(RootState, [f32; MAX_DRIVEN_JOINTS])> {
        let mut rng = Pcg32::seed_from_u64(seed);
        (0..n)
            .map(|k| {
                let root = RootState {
                    pos: Vec3::new(
                        rng.random_range(-3000.0..3000.0),
                        rng.random_range(0.0..1500.0),
                        rng.random_range(-3000.0..3000.0),
                    ),
                    heading: rng.random_range(-3.2..3.2),
                    pitch: rng.random_range(-0.5..0.5),
                    speed: 0.0,
                };
                let mut yaw = [0.0; MAX_DRIVEN_JOINTS];
                for y in &mut yaw {
                    *y = rng.random_range(-0.6..0.6);
                }
                if k % 7 == 3 {
                    yaw[2] = f32::NAN;
                }
                (root, yaw)
            })
            .collect()
    }

    /// The plan's palette against the layers' own jobs; returns the largest relative error.
    fn check_against_reference(species: &Species, plan: &PosePlan) -> f32 {
        let n = plan.num_joints();
        let (mut got, mut want) = (vec![Mat4::IDENTITY; n], vec![Mat4::IDENTITY; n]);
        let mut worst = 0.0f32;
        for (root, yaw) in poses(3, 200) {
            let driven = species.rig.driven_joints.len();
            plan.palette_of(&root, &yaw[..driven], &mut got);
            reference_palette(species, &root, &yaw[..driven], &mut want).unwrap();
            worst = worst.max(relative_error(&got, &want));
        }
        worst
    }

    /// The per-joint palette as the pose stage wrote it before slots (issue 18), straight from
    /// the plan's ops: each product made, each copy copied from its parent's entry or the
    /// placement.
    fn per_joint_palette(plan: &PosePlan, root: &RootState, yaw: &[f32]) -> Vec<Mat4> {
        fn run<T: Transform>(
            plan: &PosePlan,
            m: &Matrices<T>,
            root: &RootState,
            yaw: &[f32],
        ) -> Vec<Mat4> {
            let mut models = vec![T::IDENTITY; plan.num_joints()];
            let root = T::placement(root, m.model_to_body);
            plan.models(&plan.schedule, m, root, yaw, &mut models);
            let mut out: Vec<Mat4> = Vec::with_capacity(plan.num_joints());
            for (j, op) in plan.palette_op.iter().enumerate() {
                let parent = plan.parents[j];
                let left = |p: u16| {
                    if p == NO_PARENT {
                        root
                    } else {
                        models[usize::from(p)]
                    }
                };
                let entry = match op {
                    PaletteOp::OwnModel => (models[j] * m.palette_rhs[j]).to_mat4(),
                    PaletteOp::ParentModel => (left(parent) * m.palette_rhs[j]).to_mat4(),
                    PaletteOp::CopyParent => out[usize::from(parent)],
                    PaletteOp::CopyRoot => root.to_mat4(),
                };
                out.push(entry);
            }
            out
        }
        match &plan.matrices {
            PlanMatrices::Affine(m) => run(plan, m, root, yaw),
            PlanMatrices::General(m) => run(plan, m, root, yaw),
        }
    }

    /// The slots, expanded through the plan's joint → slot map, are that per-joint palette bit
    /// for bit, over many poses; and fewer slots than joints only if some entry is a copy.
    fn assert_slots_expand_to_the_per_joint_palette(plan: &PosePlan) {
        let n = plan.num_joints();
        let copies = plan
            .palette_op
            .iter()
            .filter(|op| matches!(op, PaletteOp::CopyParent | PaletteOp::CopyRoot))
            .count();
        let places = usize::from(plan.palette_op.contains(&PaletteOp::CopyRoot));
        assert_eq!(plan.num_slots(), n - copies + places);
        let bits = |v: &[Mat4]| -> Vec<u32> {
            v.iter()
                .flat_map(|m| m.to_cols_array().map(f32::to_bits))
                .collect()
        };
        let mut got = vec![Mat4::IDENTITY; n];
        for (root, yaw) in poses(5, 100) {
            let want = per_joint_palette(plan, &root, &yaw);
            plan.palette_of(&root, &yaw, &mut got);
            assert_eq!(bits(&got), bits(&want));
        }
    }

    #[test]
    fn the_shipped_fish_multiply_only_root_and_spine_and_match_the_reference() {
        for desc in [SpeciesDesc::black_porgy(), SpeciesDesc::eel()] {
            let species = shipped(desc);
            let plan = PosePlan::new(&species.rig, &species.model);
            assert!(plan.is_affine());
            // n driven joints (the porgy's 6, the eel's 12). Models: root + the n spine joints;
            // palette products: the n spine joints.
            let n = species.rig.num_driven();
            assert_eq!(plan.products_per_fish(), 1 + 2 * n, "{}", species.desc.name);
            // Slots: the placement (the root's entry, slot 0) and the n products.
            assert_eq!(plan.num_slots(), 1 + n, "{}", species.desc.name);
            assert_eq!(plan.slot_of_joint()[0], 0);
            assert_slots_expand_to_the_per_joint_palette(&plan);
            let worst = check_against_reference(&species, &plan);
            // Measured: 1.8e-7 (the copies' and the products' rounding).
            assert!(
                worst <= 1e-5,
                "{}: relative error {worst}",
                species.desc.name
            );
        }
    }

    #[test]
    fn a_rest_pose_off_its_bind_pose_and_a_projective_bind_matrix_take_the_general_path() {
        let porgy = shipped(SpeciesDesc::black_porgy());
        let joint = |name: &str| porgy.model.skeleton.find(name).unwrap();
        let mut species = porgy.clone();
        // A fin and the head (which has children) posed off their bind pose: their palette
        // entries differ from their parents'.
        for name in ["pectoral_L_1", "head"] {
            let j = joint(name);
            species.rig.rest_locals[j].rotation *= Quat::from_rotation_x(0.3);
        }
        let plan = PosePlan::new(&species.rig, &species.model);
        assert!(plan.is_affine());
        assert!(plan.products_per_fish() > 13);
        assert!(plan.num_slots() > 7);
        assert_slots_expand_to_the_per_joint_palette(&plan);
        let worst = check_against_reference(&species, &plan);
        assert!(worst <= 1e-5, "relative error {worst}");
        // A bind matrix whose bottom row is not 0 0 0 1: Mat4 products throughout.
        let mut model = (*species.model).clone();
        model.inverse_bind_poses[joint("jaw")].w_axis.w = 1.001;
        species.model = Arc::new(model);
        let plan = PosePlan::new(&species.rig, &species.model);
        assert!(!plan.is_affine());
        assert_slots_expand_to_the_per_joint_palette(&plan);
        let worst = check_against_reference(&species, &plan);
        assert!(worst <= 1e-5, "relative error {worst}");
    }

    #[test]
    fn a_bend_is_the_rigs_quaternion_rotation() {
        // Rodrigues' form against T·normalize(R₀·q(a, θ))·S, for rest rotations that are not
        // quite unit (as files store them) and any axis, scale and angle.
        let mut rng = Pcg32::seed_from_u64(11);
        let mut v = |lo: f32, hi: f32| {
            Vec3::new(
                rng.random_range(lo..hi),
                rng.random_range(lo..hi),
                rng.random_range(lo..hi),
            )
        };
        for _ in 0..500 {
            let (axis, r, scale, translation) = (
                v(-1.0, 1.0).normalize(),
                v(-1.0, 1.0),
                v(0.5, 2.0),
                v(-9.0, 9.0),
            );
            let rest = JointTransform {
                translation,
                rotation: Quat::from_scaled_axis(r) * 1.0001,
                scale,
            };
            let bend = Bend::new(&rest, axis);
            for angle in [-2.5f32, -0.6, -1e-4, 0.0, 3e-3, 0.4, 1.2, 3.1] {
                let rotation = (rest.rotation * Quat::from_axis_angle(axis, angle)).normalize();
                let want = Mat4::from_scale_rotation_translation(scale, rotation, translation);
                let got: Mat4 = bend.local(angle);
                // Entries up to 2 (the scale): a few of their ulps. The translation is copied.
                assert!(got.abs_diff_eq(want, 2e-6), "{angle}: {got} vs {want}");
            }
        }
    }

    #[test]
    fn affine_products_are_the_mat4_products() {
        let species = shipped(SpeciesDesc::black_porgy());
        let mut affine = PosePlan::new(&species.rig, &species.model);
        let mut general = affine.clone();
        let PlanMatrices::Affine(m) = &affine.matrices else {
            panic!("the shipped porgy is affine");
        };
        let to_mat4 = |v: &[Affine3A]| v.iter().map(|&a| Mat4::from(a)).collect::<Vec<_>>();
        general.matrices = PlanMatrices::General(Matrices::new(
            &to_mat4(&m.rest),
            &to_mat4(&m.palette_rhs),
            Mat4::from(m.model_to_body),
        ));
        // Every entry a product, none copied, so the comparison covers every joint.
        for plan in [&mut affine, &mut general] {
            plan.palette_op.fill(PaletteOp::OwnModel);
            plan.needs_model.fill(true);
        }
        let n = affine.num_joints();
        let (mut a, mut g) = (vec![Mat4::IDENTITY; n], vec![Mat4::IDENTITY; n]);
        for (root, yaw) in poses(8, 100) {
            affine.palette_of(&root, &yaw[..6], &mut a);
            general.palette_of(&root, &yaw[..6], &mut g);
            // Equal numbers (== treats −0 and +0 alike, the only difference).
            assert_eq!(a, g);
        }
    }
}
