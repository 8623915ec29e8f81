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
        parents: usize,
        names: usize,
        rests: usize,
    },
    /// More joints than indices can address.
    #[error("skeleton has {0} joints; at most {MAX_JOINTS} are supported")]
    TooManyJoints(usize),
    /// A joint's parent does not come before it (or does not exist).
    #[error("joint {joint} ({name:?}) has parent {parent}, which does not precede it")]
    ParentOrder {
        joint: usize,
        name: String,
        parent: usize,
    },
    /// The parent links form a cycle, so no order puts parents first.
    #[error("joint hierarchy has a cycle through joint {joint} ({name:?})")]
    Cycle { joint: usize, name: String },
    /// A job's slice does not have one entry per joint.
    #[error("{what} has {len} entries, expected {expected} (one per joint)")]
    SliceLength {
        what: &'static str,
        len: usize,
        expected: usize,
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
