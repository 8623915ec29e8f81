//! Skin mesh layer (paper section 3.3, equation (1)): skinned glTF loading and linear blend
//! skinning.
//!
//! - [`GltfScene`] reads any glTF 2.0 file's nodes, skins and triangle meshes with every
//!   accessor bounds-checked (`shoal skin` poses whole scenes with it).
//! - [`FishModel`] flattens the first skinned mesh of a file for the runtime: a
//!   [`Skeleton`](crate::skeleton::Skeleton) of the skin's joints, inverse bind poses and one
//!   merged vertex list.
//! - [`palette`] and [`LinearBlendSkinningJob`] are equation (1) as allocation-free jobs.

use std::path::PathBuf;

mod gltf_scene;
mod lbs;
pub mod material;
mod model;
pub mod pose_program;
mod validate;

pub use gltf_scene::{
    GltfScene, PoseRotations, PosedPrimitive, SceneMesh, SceneNode, ScenePrimitive, SceneSkin,
};
pub use lbs::{LinearBlendSkinningJob, palette, transform_normal};
pub use material::{AlphaMode, Material, TextureImage};
pub use model::{FishModel, MeshPart, SkinnedMesh, generate_tangents, vertex_normals};

use crate::skeleton::SkeletonError;

/// Why a skinned model could not be loaded or skinned. File errors name the file.
#[derive(Debug, thiserror::Error)]
pub enum SkinError {
    /// The file could not be read.
    #[error("{}: cannot read: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The OS error.
        source: std::io::Error,
    },
    /// The glTF/GLB container, JSON or buffers are malformed (as reported by the `gltf` crate).
    #[error("{}: not a valid glTF file: {source}", path.display())]
    Gltf {
        /// The file.
        path: PathBuf,
        /// What the parser said.
        source: Box<gltf::Error>,
    },
    /// The file requires an extension shoal cannot read (e.g. Draco compression).
    #[error("{}: requires glTF extension {extension}, which shoal does not support; re-export without it", path.display())]
    UnsupportedExtension {
        /// The file.
        path: PathBuf,
        /// The extension's name.
        extension: String,
    },
    /// An accessor is out of bounds or of the wrong type.
    #[error("{}: accessor {accessor} ({what}): {problem}", path.display())]
    Accessor {
        /// The file.
        path: PathBuf,
        /// Accessor index.
        accessor: usize,
        /// What it was read as (e.g. `mesh 0 primitive 0 POSITION`).
        what: String,
        /// What is wrong.
        problem: String,
    },
    /// The file's structure is unusable (missing node, cycle, …).
    #[error("{}: {problem}", path.display())]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },
    /// The default scene has no skinned mesh.
    #[error("{}: no skinned mesh: {detail}", path.display())]
    NoSkin {
        /// The file.
        path: PathBuf,
        /// What was found instead.
        detail: String,
    },
    /// The skin's joints do not form a valid skeleton.
    #[error("{}: bad joint hierarchy: {source}", path.display())]
    Skeleton {
        /// The file.
        path: PathBuf,
        /// The skeleton's complaint.
        source: SkeletonError,
    },
    /// A pose names an unknown joint or gives an unusable rotation.
    #[error("{}: bad pose: {problem}", path.display())]
    Pose {
        /// The model file.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },
    /// A skinning job's slice has the wrong length.
    #[error("{what} has {len} entries, expected {expected} ({detail})")]
    JobSlice {
        /// Which slice.
        what: &'static str,
        /// Its length.
        len: usize,
        /// The length expected.
        expected: usize,
        /// More context.
        detail: String,
    },
    /// A vertex names a joint outside the palette.
    #[error("vertex {vertex} uses joint {joint}, but the palette has {num_joints} joints")]
    JointOutOfRange {
        /// Vertex index.
        vertex: usize,
        /// The joint index it uses.
        joint: usize,
        /// Palette length.
        num_joints: usize,
    },
}
