//! Animation layer (paper section 3.1's last layer): draws the aquarium with wgpu.
//!
//! The renderer knows nothing of motion, skeletons or scripts. It takes plain data:
//! - once per species, a [`MeshUpload`] (positions, normals, per-vertex colours, joint indices and
//!   weights, triangle indices), which returns a [`MeshId`];
//! - once per frame, a [`FrameInput`]: one flat joint palette for *every* fish (each fish's joints
//!   contiguous, already in world space) — or, for the GPU pose pass, each species' pose program
//!   and one small record per fish ([`GpuPoseFrame`]) —, one [`FishInstance`] per fish naming its
//!   mesh and where its palette starts, the [`Camera`], the [`TankBounds`], the scene time and
//!   optional overlay line segments.
//!
//! On the GPU every palette of the frame lives in one storage buffer, uploaded once, or written
//! by the GPU pose pass from a few numbers per fish ([`GpuPoseFrame`]); the vertex
//! shader skins each vertex with `Σ w_n · M_n` (eq. 1, `shaders/skinning.wgsl`), and each species
//! is one instanced draw per material and level of detail in use, so draw calls do not grow with
//! the number of fish. Each frame, fish whose bounding sphere is outside the view are left out (their shadows
//! too, judged where the shadows lie), and each drawn fish gets the coarsest of its mesh's levels
//! of detail (index lists over the same vertices, made at upload) whose error stays under a pixel
//! on screen: see [`lod`]. The same skinning
//! function runs in a compute pass for [`Renderer::skin_positions`] so tests can compare GPU
//! skinning against a CPU reference.
//!
//! [`Renderer`] draws into any colour view: [`OffscreenTarget`] for headless rendering, tests and
//! benchmarks (read back as RGBA8), or a window surface (the window, and the adapter that turns
//! a simulation into frames, are in [`crate::app`]). [`testmesh`] holds a procedural skinned
//! fish for tests that need a mesh without asset files.
//!
//! This module is a leaf: it uses plain data types only (and the skin layer's mesh and
//! material types for [`MeshUpload::from_skinned_mesh`]), never the simulation.

#![warn(missing_docs)]

mod camera;
mod gpu;
pub mod lod;
pub mod material;
pub mod props;
mod renderer;
pub mod shaders;
mod target;
pub mod testmesh;

pub use camera::{Camera, Ray};
pub use gpu::{Gpu, GpuError};
pub use lod::{LodLevel, MAX_LODS, MeshBounds, MeshLods};
pub use renderer::{Culling, DEFAULT_LOD_TOLERANCE_PX, FramePart, RenderTimings, Renderer};
use shoal_core::skin::pose_program::{GpuFishPose, GpuPosePrograms};
pub use target::OffscreenTarget;

use glam::{Mat4, Vec3};

/// Errors of the render layer. Each says what failed and, where possible, what to do.
#[derive(Debug, thiserror::Error)]
pub enum RenderError {
    /// No GPU adapter (not even a software one) could be found or opened.
    #[error(transparent)]
    Gpu(#[from] GpuError),
    /// A mesh upload is inconsistent (attribute lengths differ, an index is out of range …).
    #[error("mesh `{label}`: {why}")]
    InvalidMesh {
        /// The mesh's label.
        label: String,
        /// What is wrong with it.
        why: String,
    },
    /// A frame refers to data that is not there.
    #[error("invalid frame: {0}")]
    InvalidFrame(String),
    /// A WGSL shader failed to parse or validate; the previous pipeline (if any) is kept.
    #[error("shader `{file}` failed to compile:\n{message}")]
    Shader {
        /// The shader file name (e.g. `fish.wgsl`).
        file: String,
        /// The compiler's message.
        message: String,
    },
    /// Reading the rendered image or skinned positions back from the GPU failed.
    #[error("GPU read-back failed: {0}")]
    Readback(String),
    /// Writing or encoding an output image failed.
    #[error("could not write `{path}`: {why}")]
    Output {
        /// The output path.
        path: String,
        /// Why.
        why: String,
    },
}

/// One species' mesh in its bind pose, uploaded once with [`Renderer::upload_mesh`].
///
/// All per-vertex slices must have the same length; `indices` is a triangle list (length a
/// multiple of 3) whose entries are below that length. Joint indices are relative to the fish's
/// palette offset ([`FishInstance::palette_offset`]); weights should sum to 1.
#[derive(Debug, Clone, Copy)]
pub struct MeshUpload<'a> {
    /// Debug label (shown in GPU tools and errors).
    pub label: &'a str,
    /// Bind-pose positions, model space, length units.
    pub positions: &'a [[f32; 3]],
    /// Bind-pose normals, model space (need not be normalised).
    pub normals: &'a [[f32; 3]],
    /// Per-vertex linear RGBA colour (a material base colour expanded per vertex).
    pub colors: &'a [[f32; 4]],
    /// Up to four joint indices per vertex.
    pub joints: &'a [[u16; 4]],
    /// Weights matching `joints`.
    pub weights: &'a [[f32; 4]],
    /// Triangle list, counter-clockwise front faces.
    pub indices: &'a [u32],
    /// Texture coordinates, one per vertex, or empty when no material has a texture.
    pub uvs: &'a [[f32; 2]],
    /// Tangents (xyz, w = bitangent sign), one per vertex, or empty when no material has a
    /// normal map (a normal map is then not drawn).
    pub tangents: &'a [[f32; 4]],
    /// The species' materials (textures, factors, alpha mode …); empty draws the vertex colours
    /// with [`shoal_core::skin::Material::default`].
    pub materials: &'a [shoal_core::skin::Material],
    /// Which triangles each material draws (index ranges of `indices`); empty: all with
    /// material 0. Each material costs one draw per level of detail in use, whatever the number
    /// of fish.
    pub parts: &'a [shoal_core::skin::MeshPart],
}

impl<'a> MeshUpload<'a> {
    /// Borrows a skin layer mesh (e.g. `FishModel::load("assets/black_porgy.glb")?.mesh`).
    pub fn from_skinned_mesh(label: &'a str, mesh: &'a shoal_core::skin::SkinnedMesh) -> Self {
        Self {
            label,
            positions: bytemuck::cast_slice(&mesh.positions),
            normals: bytemuck::cast_slice(&mesh.normals),
            colors: &mesh.colors,
            joints: &mesh.joints,
            weights: &mesh.weights,
            indices: &mesh.indices,
            uvs: &mesh.uvs,
            tangents: &mesh.tangents,
            materials: &mesh.materials,
            parts: &mesh.parts,
        }
    }
}

/// A mesh uploaded to a [`Renderer`]; index of the upload, in order.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct MeshId(pub u32);

/// One fish to draw this frame.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FishInstance {
    /// Its species' mesh.
    pub mesh: MeshId,
    /// Index into [`FrameInput::palettes`] of this fish's palette entry 0 (what its mesh's joint
    /// index 0 names; culling carries the mesh's bounds by it).
    pub palette_offset: u32,
    /// Linear RGB multiplier on the material colour (`[1, 1, 1]` leaves it unchanged).
    pub tint: [f32; 3],
    /// Drawn with a highlight when true.
    pub selected: bool,
}

/// The tank: an axis-aligned box, +y up; the sand floor is at `min.y`, the water surface at
/// `max.y`. Length units.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct TankBounds {
    /// Minimum corner.
    pub min: Vec3,
    /// Maximum corner.
    pub max: Vec3,
}

impl TankBounds {
    /// The tank's centre.
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }
    /// The tank's size along each axis.
    pub fn size(&self) -> Vec3 {
        self.max - self.min
    }
}

impl Default for TankBounds {
    /// A 600 × 240 × 360 tank (about 12 × 5 × 7 body lengths of a 50-unit porgy).
    fn default() -> Self {
        Self {
            min: Vec3::new(-300.0, 0.0, -180.0),
            max: Vec3::new(300.0, 240.0, 180.0),
        }
    }
}

/// A rigid object (a rock, a food pellet): a one-joint mesh placed by one matrix.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prop {
    /// Its mesh; every vertex must be on joint 0 only.
    pub mesh: MeshId,
    /// Model → world transform.
    pub transform: Mat4,
    /// Linear RGB multiplier on the material colour.
    pub tint: [f32; 3],
}

/// One coloured line segment in world space (overlays: skeletons, midlines, arrows, ranges).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OverlayLine {
    /// Start, world space.
    pub a: Vec3,
    /// End, world space.
    pub b: Vec3,
    /// Linear RGBA colour.
    pub color: [f32; 4],
}

impl OverlayLine {
    /// Appends a skeleton overlay: a bone from each joint to its parent (parents as stored by
    /// [`shoal_core::skeleton::Skeleton::parents`]; roots and out-of-range parents draw none) and a
    /// small cross of half-size `cross` at every joint. `joint(j)` is joint j's world position.
    pub fn push_skeleton(
        out: &mut Vec<OverlayLine>,
        parents: &[u16],
        joint: impl Fn(usize) -> Vec3,
        cross: f32,
    ) {
        for (j, &parent) in parents.iter().enumerate() {
            let a = joint(j);
            if usize::from(parent) < parents.len() {
                out.push(OverlayLine {
                    a: joint(usize::from(parent)),
                    b: a,
                    color: [1.0, 0.85, 0.2, 1.0],
                });
            }
            for d in [Vec3::X, Vec3::Y, Vec3::Z] {
                out.push(OverlayLine {
                    a: a - d * cross,
                    b: a + d * cross,
                    color: [1.0, 0.3, 0.2, 1.0],
                });
            }
        }
    }
}

/// Water, light and caustics settings.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Look {
    /// Linear RGB of deep water.
    pub water_deep: [f32; 3],
    /// Linear RGB of water near the surface.
    pub water_shallow: [f32; 3],
    /// Fog density per length unit (fraction of light lost ≈ 1 − e^(−density · distance)).
    pub fog_density_per_unit: f32,
    /// Strength of the floor/fish caustics; 0 turns them off.
    pub caustic_strength: f32,
    /// Direction towards the light (need not be normalised).
    pub light_dir: Vec3,
    /// Draw planar fish shadows on the sand (one extra instanced draw per species and material).
    pub shadows: bool,
}

impl Default for Look {
    fn default() -> Self {
        Self {
            water_deep: [0.005, 0.045, 0.09],
            water_shallow: [0.05, 0.32, 0.42],
            fog_density_per_unit: 0.0008,
            caustic_strength: 1.0,
            light_dir: Vec3::new(0.3, 1.0, 0.2),
            shadows: true,
        }
    }
}

/// A value for [`FrameInput::instances_revision`] no caller has had: one counter for the
/// process, so that two instance lists (two scenes, a restarted one) never share a value.
pub fn next_instances_revision() -> u64 {
    static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
    NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed)
}

/// Everything one frame needs. Borrowed: nothing is copied until the upload.
#[derive(Debug, Clone, Copy)]
pub struct FrameInput<'a> {
    /// Every fish's joint palette (world × model × inverse bind), each fish's entries contiguous
    /// (a world's fish has its distinct entries only, which its mesh's joint indices name).
    pub palettes: &'a [Mat4],
    /// The fish to draw.
    pub instances: &'a [FishInstance],
    /// Names the content of `instances` (and its length): the same value promises the same
    /// instances as the frame that last had it, so the renderer keeps what it built from them
    /// (the culling pass's per-fish records, the checks) instead of rebuilding and comparing
    /// them — a steady frame then costs the CPU nothing per fish there. Take a new value from
    /// [`next_instances_revision`] whenever any instance changes (a fish came or went, was
    /// tinted, selected, changed species or palette offset); moving fish do not change their
    /// instances. `None`: unknown, everything is rebuilt and compared (always correct).
    pub instances_revision: Option<u64>,
    /// The camera.
    pub camera: Camera,
    /// The tank.
    pub tank: TankBounds,
    /// Scene time, seconds (animates caustics and light shafts).
    pub time_s: f32,
    /// Rigid props (rocks, food), drawn lit and fogged like the fish.
    pub props: &'a [Prop],
    /// Debug overlay segments drawn on top of everything (empty for none).
    pub overlay: &'a [OverlayLine],
    /// Water and light settings.
    pub look: Look,
    /// Fish posed by the renderer's GPU pose pass instead of by the CPU: with it, `palettes`
    /// holds no fish entries (it should be empty) and the pass writes them.
    pub gpu_pose: Option<GpuPoseFrame<'a>>,
}

/// Fish for the GPU pose pass (`shaders/pose.wgsl`, [`shoal_core::skin::pose_program`]): each
/// record runs its species' program into the palette buffer from its palette offset, the same
/// layout a CPU-posed palette has.
#[derive(Debug, Clone, Copy)]
pub struct GpuPoseFrame<'a> {
    /// Every species' program.
    pub programs: &'a GpuPosePrograms,
    /// One record per fish.
    pub fish: &'a [GpuFishPose],
    /// Per instance of [`FrameInput::instances`] (same order): its palette's slot 0 (joint
    /// 0's entry), computed on the CPU, which culling and the choice of detail read.
    pub anchors: &'a [Mat4],
    /// Palette entries the fish take: the props' entries come after.
    pub palette_len: u32,
}
