//! Skeletal layer (paper section 3.2): an immutable joint hierarchy and forward kinematics.
//!
//! The paper's joint record j_b^k(t) is {position, orientation} for the root, {NIL, orientation}
//! for inner joints and {NIL, NIL} for leaves; [`JointKind`] names those three roles. Bone length
//! l_b^k is the rest-pose distance between joint k and its parent.
//!
//! Layout follows ozz-animation's runtime skeleton: parents are stored so that a parent always
//! precedes its children ([`NO_PARENT`] for roots), names and rest poses live in separate arrays,
//! and the skeleton never changes after it is built. Forward kinematics is a job
//! ([`LocalToModelJob`]) over caller-owned slices that never allocates.
//!
//! The paper sets the vertebral joints' orientation with Euler angles about the vertebral
//! column's principal axes (section 3.5.3): [`EulerAngles`]. [`VertebralChain`] is the swimming
//! column of section 4 (7 segments, 6 driven joints by default) and [`VertebralPoseJob`] writes
//! the motion layer's joint yaws into its local transforms.

use glam::{Mat4, Quat, Vec3};

/// Parent index of a root joint.
pub const NO_PARENT: u16 = u16::MAX;

/// Most joints a skeleton may have (indices are `u16`, [`NO_PARENT`] is reserved).
pub const MAX_JOINTS: usize = u16::MAX as usize;

/// A joint's local transform relative to its parent (translation, rotation, scale).
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct JointTransform {
    /// Offset from the parent joint, in the parent's space.
    pub translation: Vec3,
    /// Orientation relative to the parent.
    pub rotation: Quat,
    /// Scale relative to the parent.
    pub scale: Vec3,
}

impl JointTransform {
    /// The identity transform.
    pub const IDENTITY: Self = Self {
        translation: Vec3::ZERO,
        rotation: Quat::IDENTITY,
        scale: Vec3::ONE,
    };

    /// The transform as a matrix: T · R · S.
    pub fn to_mat4(&self) -> Mat4 {
        Mat4::from_scale_rotation_translation(self.scale, self.rotation, self.translation)
    }

    /// Decomposes an affine matrix (as glTF `matrix` nodes store it).
    pub fn from_mat4(m: Mat4) -> Self {
        let (scale, rotation, translation) = m.to_scale_rotation_translation();
        Self {
            translation,
            rotation,
            scale,
        }
    }
}

impl Default for JointTransform {
    fn default() -> Self {
        Self::IDENTITY
    }
}

/// The role of a joint in the paper's hierarchy (section 3.2).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum JointKind {
    /// Carries position and orientation.
    Root,
    /// Carries orientation only.
    Inner,
    /// Carries nothing: the end of a chain.
    Leaf,
}

/// Why a skeleton or a job over it was rejected.
#[derive(Debug, thiserror::Error, PartialEq, Eq)]
pub enum SkeletonError {
    /// The per-joint arrays disagree in length.
    #[error(
        "skeleton arrays differ in length: {parents} parents, {names} names, {rests} rest poses"
    )]
    LengthMismatch {
        /// Number of parent indices.
        parents: usize,
        /// Number of names.
        names: usize,
        /// Number of rest poses.
        rests: usize,
    },
    /// More joints than indices can address.
    #[error("skeleton has {0} joints; at most {MAX_JOINTS} are supported")]
    TooManyJoints(usize),
    /// A joint's parent does not come before it (or does not exist).
    #[error("joint {joint} ({name:?}) has parent {parent}, which does not precede it")]
    ParentOrder {
        /// The joint's index.
        joint: usize,
        /// The joint's name.
        name: String,
        /// Its parent's index.
        parent: usize,
    },
    /// The parent links form a cycle, so no order puts parents first.
    #[error("joint hierarchy has a cycle through joint {joint} ({name:?})")]
    Cycle {
        /// A joint on the cycle.
        joint: usize,
        /// Its name.
        name: String,
    },
    /// A job's slice does not have one entry per joint.
    #[error("{what} has {len} entries, expected {expected} (one per joint)")]
    SliceLength {
        /// Which slice.
        what: &'static str,
        /// Its length.
        len: usize,
        /// The number of joints.
        expected: usize,
    },
    /// A number given to a job or builder is NaN, infinite or out of its range.
    #[error("{what}[{index}] = {value}: {why}")]
    InvalidValue {
        /// The input's name.
        what: &'static str,
        /// Index of the bad entry (0 for a single value).
        index: usize,
        /// The value as written (kept as text so the error stays `Eq`).
        value: String,
        /// What is accepted.
        why: &'static str,
    },
}

/// An immutable joint hierarchy with parents before children.
#[derive(Debug, Clone, PartialEq)]
pub struct Skeleton {
    parents: Vec<u16>,
    names: Vec<String>,
    rest_locals: Vec<JointTransform>,
    rest_models: Vec<Mat4>,
    bone_lengths: Vec<f32>,
    num_children: Vec<u16>,
}

impl Skeleton {
    /// Builds a skeleton from arrays already ordered parent-first.
    ///
    /// Fails if the arrays differ in length, if there are more than [`MAX_JOINTS`] joints, or if
    /// any joint's parent does not precede it.
    pub fn new(
        parents: Vec<u16>,
        names: Vec<String>,
        rest_locals: Vec<JointTransform>,
    ) -> Result<Self, SkeletonError> {
        if parents.len() != names.len() || parents.len() != rest_locals.len() {
            return Err(SkeletonError::LengthMismatch {
                parents: parents.len(),
                names: names.len(),
                rests: rest_locals.len(),
            });
        }
        if parents.len() > MAX_JOINTS {
            return Err(SkeletonError::TooManyJoints(parents.len()));
        }
        let mut num_children = vec![0u16; parents.len()];
        for (joint, &parent) in parents.iter().enumerate() {
            if parent != NO_PARENT {
                if usize::from(parent) >= joint {
                    return Err(SkeletonError::ParentOrder {
                        joint,
                        name: names[joint].clone(),
                        parent: usize::from(parent),
                    });
                }
                num_children[usize::from(parent)] += 1;
            }
        }
        let mut rest_models = vec![Mat4::IDENTITY; parents.len()];
        LocalToModelJob {
            skeleton_parents: &parents,
            root: Mat4::IDENTITY,
            locals: &rest_locals,
            models: &mut rest_models,
        }
        .run()?;
        let bone_lengths = parents
            .iter()
            .enumerate()
            .map(|(joint, &parent)| {
                if parent == NO_PARENT {
                    0.0
                } else {
                    let here = rest_models[joint].w_axis.truncate();
                    let there = rest_models[usize::from(parent)].w_axis.truncate();
                    here.distance(there)
                }
            })
            .collect();
        Ok(Self {
            parents,
            names,
            rest_locals,
            rest_models,
            bone_lengths,
            num_children,
        })
    }

    /// Builds a skeleton from joints in any order, where `parents[i]` is the index of joint i's
    /// parent in the same arrays. Returns the skeleton and, for each of its joints, the index the
    /// joint had in the input (new → old), so callers can remap per-joint data.
    pub fn from_unordered(
        parents: &[Option<usize>],
        names: &[String],
        rest_locals: &[JointTransform],
    ) -> Result<(Self, Vec<usize>), SkeletonError> {
        let n = parents.len();
        if names.len() != n || rest_locals.len() != n {
            return Err(SkeletonError::LengthMismatch {
                parents: n,
                names: names.len(),
                rests: rest_locals.len(),
            });
        }
        if n > MAX_JOINTS {
            return Err(SkeletonError::TooManyJoints(n));
        }
        // Depth-first from each root, children in input order, so the result is deterministic.
        let mut children: Vec<Vec<usize>> = vec![Vec::new(); n];
        let mut roots = Vec::new();
        for (joint, parent) in parents.iter().enumerate() {
            match parent {
                Some(p) if *p < n && *p != joint => children[*p].push(joint),
                _ => roots.push(joint),
            }
        }
        let mut order = Vec::with_capacity(n);
        let mut stack: Vec<usize> = roots.iter().rev().copied().collect();
        while let Some(joint) = stack.pop() {
            order.push(joint);
            stack.extend(children[joint].iter().rev());
        }
        if order.len() != n {
            let mut seen = vec![false; n];
            for &j in &order {
                seen[j] = true;
            }
            let joint = seen.iter().position(|s| !s).unwrap_or(0);
            return Err(SkeletonError::Cycle {
                joint,
                name: names[joint].clone(),
            });
        }
        let mut new_index = vec![0usize; n];
        for (new, &old) in order.iter().enumerate() {
            new_index[old] = new;
        }
        let new_parents = order
            .iter()
            .map(|&old| match parents[old] {
                Some(p) if p < n && p != old => new_index[p] as u16,
                _ => NO_PARENT,
            })
            .collect();
        let new_names = order.iter().map(|&old| names[old].clone()).collect();
        let new_rests = order.iter().map(|&old| rest_locals[old]).collect();
        Ok((Self::new(new_parents, new_names, new_rests)?, order))
    }

    /// Number of joints.
    pub fn num_joints(&self) -> usize {
        self.parents.len()
    }

    /// Parent of each joint ([`NO_PARENT`] for roots); parents precede children.
    pub fn parents(&self) -> &[u16] {
        &self.parents
    }

    /// Joint names, by joint index.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// Rest-pose local transforms, by joint index.
    pub fn rest_locals(&self) -> &[JointTransform] {
        &self.rest_locals
    }

    /// Rest-pose model-space matrices (root at the identity), by joint index.
    pub fn rest_models(&self) -> &[Mat4] {
        &self.rest_models
    }

    /// Rest-pose distance from each joint to its parent (l_b^k of the paper); 0 for roots.
    pub fn bone_lengths(&self) -> &[f32] {
        &self.bone_lengths
    }

    /// Index of the joint named `name`.
    pub fn find(&self, name: &str) -> Option<usize> {
        self.names.iter().position(|n| n == name)
    }

    /// The paper's role of joint `joint`: root, inner or leaf.
    pub fn kind(&self, joint: usize) -> JointKind {
        if self.parents[joint] == NO_PARENT {
            JointKind::Root
        } else if self.num_children[joint] == 0 {
            JointKind::Leaf
        } else {
            JointKind::Inner
        }
    }

    /// A forward-kinematics job over this skeleton.
    pub fn local_to_model<'a>(
        &'a self,
        root: Mat4,
        locals: &'a [JointTransform],
        models: &'a mut [Mat4],
    ) -> LocalToModelJob<'a> {
        LocalToModelJob {
            skeleton_parents: &self.parents,
            root,
            locals,
            models,
        }
    }
}

/// Forward kinematics: local joint transforms → model-space matrices.
///
/// `models[j] = models[parent(j)] · locals[j]`, and `root · locals[j]` for roots. Because
/// parents precede children, one pass in index order suffices. Never allocates.
#[derive(Debug)]
pub struct LocalToModelJob<'a> {
    /// Parent of each joint, parents first (from [`Skeleton::parents`]).
    pub skeleton_parents: &'a [u16],
    /// Transform applied above every root joint (the fish's placement in the world).
    pub root: Mat4,
    /// One local transform per joint.
    pub locals: &'a [JointTransform],
    /// Output: one model-space matrix per joint.
    pub models: &'a mut [Mat4],
}

impl LocalToModelJob<'_> {
    /// Checks slice lengths; the job's only failure conditions.
    pub fn validate(&self) -> Result<(), SkeletonError> {
        let expected = self.skeleton_parents.len();
        if self.locals.len() != expected {
            return Err(SkeletonError::SliceLength {
                what: "locals",
                len: self.locals.len(),
                expected,
            });
        }
        if self.models.len() != expected {
            return Err(SkeletonError::SliceLength {
                what: "models",
                len: self.models.len(),
                expected,
            });
        }
        Ok(())
    }

    /// Validates, then computes every model matrix.
    pub fn run(self) -> Result<(), SkeletonError> {
        self.validate()?;
        for (joint, (&parent, local)) in self
            .skeleton_parents
            .iter()
            .zip(self.locals.iter())
            .enumerate()
        {
            let parent_model = if parent == NO_PARENT {
                self.root
            } else {
                self.models[usize::from(parent)]
            };
            self.models[joint] = parent_model * local.to_mat4();
        }
        Ok(())
    }
}

/// Euler angles about a vertebral joint's principal axes (paper 3.5.3), radians.
///
/// A joint's local frame: +x along the vertebral column towards the head (the fish's forward),
/// +y dorsal (up), +z to the fish's right. The rotation is R = Ry(yaw)·Rz(pitch)·Rx(roll):
/// yaw about the dorsal axis (positive turns the joint's forward axis to the fish's left,
/// counter-clockwise seen from above, like `RootState::heading`), then pitch about the lateral
/// axis (positive nose-up), then roll about the column. Note the sign against the motion layer:
/// a positive motion `yaw` bends the part *behind* the joint to the left, which is a negative
/// Euler yaw of that joint ([`EulerAngles::from_bend_left`]).
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct EulerAngles {
    /// About +y (dorsal), radians, positive counter-clockwise seen from above.
    pub yaw: f32,
    /// About +z (the fish's right), radians, positive raises the forward axis.
    pub pitch: f32,
    /// About +x (the column), radians, positive rolls the dorsal axis towards the right.
    pub roll: f32,
}

impl EulerAngles {
    /// No rotation.
    pub const ZERO: Self = Self {
        yaw: 0.0,
        pitch: 0.0,
        roll: 0.0,
    };

    /// The angles that bend the body behind a joint by `bend_left` radians towards the fish's
    /// left (the motion layer's joint `yaw`): an Euler yaw of −bend_left.
    pub fn from_bend_left(bend_left: f32) -> Self {
        Self {
            yaw: -bend_left,
            ..Self::ZERO
        }
    }

    /// The rotation Ry(yaw)·Rz(pitch)·Rx(roll).
    pub fn to_quat(self) -> Quat {
        Quat::from_euler(glam::EulerRot::YZX, self.yaw, self.pitch, self.roll)
    }

    /// The angles of `rotation` (yaw in (−π, π], pitch in [−π/2, π/2], roll in (−π, π]).
    pub fn from_quat(rotation: Quat) -> Self {
        let (yaw, pitch, roll) = rotation.to_euler(glam::EulerRot::YZX);
        Self { yaw, pitch, roll }
    }
}

/// Name of the vertebral chain's root joint (at the head).
pub const HEAD_JOINT: &str = "head";
/// Name of the vertebral chain's leaf joint (at the tail tip).
pub const TAIL_TIP_JOINT: &str = "tail_tip";

/// The swimming vertebral column (paper sections 3.2 and 4): a root joint at the head, one
/// driven joint per entry of `joints_x` before the tail tip, and a leaf at the tail tip.
///
/// Joint 0 is the root ("head", position and orientation), joints 1 … n the driven joints
/// ("vertebra_1" … "vertebra_n", orientation only), joint n + 1 the leaf ("tail_tip"). In the
/// rest pose the fish faces +x and the column runs from the origin towards −x.
#[derive(Debug, Clone, PartialEq)]
pub struct VertebralChain {
    skeleton: Skeleton,
    body_length: f32,
    joints_x: Vec<f32>,
}

impl VertebralChain {
    /// The paper's black porgy column of `body_length`: 7 equal segments, 6 driven joints.
    pub fn black_porgy(body_length: f32) -> Result<Self, SkeletonError> {
        let joints_x: Vec<f32> = (1..=7).map(|k| k as f32 / 7.0).collect();
        Self::new(body_length, &joints_x)
    }

    /// A column of `body_length` length units whose driven joints sit at `joints_x` (fractions
    /// of the body length from the head, strictly increasing in (0, 1)), followed by the tail tip
    /// 1.0 — the same layout as the motion layer's `Body::joints_x`.
    ///
    /// Fails if the body length is not positive and finite, or `joints_x` is not strictly
    /// increasing inside (0, 1] or does not end at 1.0.
    pub fn new(body_length: f32, joints_x: &[f32]) -> Result<Self, SkeletonError> {
        if !(body_length.is_finite() && body_length > 0.0) {
            return Err(SkeletonError::InvalidValue {
                what: "body_length",
                index: 0,
                value: body_length.to_string(),
                why: "must be a positive length",
            });
        }
        let mut previous = 0.0;
        for (index, &x) in joints_x.iter().enumerate() {
            if !(x.is_finite() && x > previous && x <= 1.0) {
                return Err(SkeletonError::InvalidValue {
                    what: "joints_x",
                    index,
                    value: x.to_string(),
                    why: "joint positions must rise strictly inside (0, 1]",
                });
            }
            previous = x;
        }
        match joints_x.last() {
            Some(&last) if last == 1.0 && joints_x.len() >= 2 => {}
            _ => {
                return Err(SkeletonError::InvalidValue {
                    what: "joints_x",
                    index: joints_x.len().saturating_sub(1),
                    value: joints_x
                        .last()
                        .map_or_else(|| "nothing".to_owned(), |x| x.to_string()),
                    why: "needs at least one driven joint and must end with the tail tip 1.0",
                });
            }
        }
        let n = joints_x.len() - 1;
        let mut parents = Vec::with_capacity(n + 2);
        let mut names = Vec::with_capacity(n + 2);
        let mut rests = Vec::with_capacity(n + 2);
        parents.push(NO_PARENT);
        names.push(HEAD_JOINT.to_owned());
        rests.push(JointTransform::IDENTITY);
        let mut x_prev = 0.0;
        for (k, &x) in joints_x.iter().enumerate() {
            parents.push(k as u16);
            names.push(if k < n {
                format!("vertebra_{}", k + 1)
            } else {
                TAIL_TIP_JOINT.to_owned()
            });
            rests.push(JointTransform {
                translation: Vec3::new(-(x - x_prev) * body_length, 0.0, 0.0),
                ..JointTransform::IDENTITY
            });
            x_prev = x;
        }
        Ok(Self {
            skeleton: Skeleton::new(parents, names, rests)?,
            body_length,
            joints_x: joints_x.to_vec(),
        })
    }

    /// The joint hierarchy (head, driven joints, tail tip).
    pub fn skeleton(&self) -> &Skeleton {
        &self.skeleton
    }

    /// Body length, length units.
    pub fn body_length(&self) -> f32 {
        self.body_length
    }

    /// Driven joints' positions (fractions of body length), then the tail tip 1.0.
    pub fn joints_x(&self) -> &[f32] {
        &self.joints_x
    }

    /// Number of driven joints.
    pub fn num_driven(&self) -> usize {
        self.joints_x.len() - 1
    }

    /// A pose job writing `bend_left` (the motion layer's joint yaws) into `locals`.
    pub fn pose<'a>(
        &'a self,
        bend_left: &'a [f32],
        locals: &'a mut [JointTransform],
    ) -> VertebralPoseJob<'a> {
        VertebralPoseJob {
            rest_locals: self.skeleton.rest_locals(),
            head_lateral: 0.0,
            head_yaw: 0.0,
            bend_left,
            locals,
        }
    }
}

/// Motion yaws → local joint transforms of a [`VertebralChain`]. Never allocates.
///
/// Each driven joint k gets its rest translation and the rotation
/// [`EulerAngles::from_bend_left`]`(bend_left[k])`; the head joint gets `head_yaw` (radians,
/// counter-clockwise seen from above) and is moved `head_lateral` length units to the fish's
/// left (−z), as the motion player reports them; the tail tip keeps its rest transform.
#[derive(Debug)]
pub struct VertebralPoseJob<'a> {
    /// The chain's rest locals ([`Skeleton::rest_locals`]): head, driven joints, tail tip.
    pub rest_locals: &'a [JointTransform],
    /// Sideways offset of the head from the root's travel line, length units, positive left.
    pub head_lateral: f32,
    /// Yaw of the head segment relative to the heading, radians, counter-clockwise.
    pub head_yaw: f32,
    /// One bend per driven joint, radians, positive bends the body behind it to the left.
    pub bend_left: &'a [f32],
    /// Output: one local transform per joint of the chain.
    pub locals: &'a mut [JointTransform],
}

impl VertebralPoseJob<'_> {
    /// Checks sizes (a head, ≥ 1 driven joint and a tail tip; one bend per driven joint; one
    /// output per joint) and that every angle and offset is finite.
    pub fn validate(&self) -> Result<(), SkeletonError> {
        let num_joints = self.rest_locals.len();
        if num_joints < 3 {
            return Err(SkeletonError::SliceLength {
                what: "rest_locals",
                len: num_joints,
                expected: 3,
            });
        }
        if self.bend_left.len() + 2 != num_joints {
            return Err(SkeletonError::SliceLength {
                what: "bend_left",
                len: self.bend_left.len(),
                expected: num_joints - 2,
            });
        }
        if self.locals.len() != num_joints {
            return Err(SkeletonError::SliceLength {
                what: "locals",
                len: self.locals.len(),
                expected: num_joints,
            });
        }
        if let Some((index, &value)) = self
            .bend_left
            .iter()
            .enumerate()
            .find(|(_, v)| !v.is_finite())
        {
            return Err(SkeletonError::InvalidValue {
                what: "bend_left",
                index,
                value: value.to_string(),
                why: "joint angles must be finite",
            });
        }
        for (what, value) in [
            ("head_lateral", self.head_lateral),
            ("head_yaw", self.head_yaw),
        ] {
            if !value.is_finite() {
                return Err(SkeletonError::InvalidValue {
                    what,
                    index: 0,
                    value: value.to_string(),
                    why: "must be finite",
                });
            }
        }
        Ok(())
    }

    /// Validates, then writes every local transform.
    pub fn run(self) -> Result<(), SkeletonError> {
        self.validate()?;
        let n = self.rest_locals.len();
        let head = &self.rest_locals[0];
        self.locals[0] = JointTransform {
            translation: head.translation + Vec3::new(0.0, 0.0, -self.head_lateral),
            rotation: head.rotation
                * EulerAngles {
                    yaw: self.head_yaw,
                    ..EulerAngles::ZERO
                }
                .to_quat(),
            scale: head.scale,
        };
        for (k, &bend) in self.bend_left.iter().enumerate() {
            let rest = &self.rest_locals[k + 1];
            self.locals[k + 1] = JointTransform {
                rotation: rest.rotation * EulerAngles::from_bend_left(bend).to_quat(),
                ..*rest
            };
        }
        self.locals[n - 1] = self.rest_locals[n - 1];
        Ok(())
    }
}
