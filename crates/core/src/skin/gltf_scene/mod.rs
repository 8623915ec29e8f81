//! A general glTF 2.0 scene reader for skinning: nodes, skins and triangle meshes of a file,
//! read into plain arrays with every accessor bounds-checked, so a malformed file is an error and
//! never a panic.
//!
//! It follows the glTF specification where readers commonly go wrong:
//! - `JOINTS_n` values index into `skin.joints`, not into the node list;
//! - the skinned mesh node's own transform is ignored: a skinned vertex is
//!   Σ w · global(joint) · IBM · v in scene space;
//! - weights that do not sum to 1 are renormalized, with one warning per primitive;
//! - JOINTS_1/WEIGHTS_1 are merged with set 0 and the four strongest influences kept;
//! - inverse bind matrices default to the identity.
//!
//! Files: this one holds the scene's types and reads nodes and skins; `primitive` reads a mesh's
//! triangles and vertex attributes; `accessor` is the bounds-checked view of an accessor's bytes;
//! `pose` poses and skins the scene.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use glam::{Mat4, Quat, Vec3, Vec4};
use gltf::accessor::DataType;

use super::SkinError;
use super::lbs::transform_normal;
use super::material::{SceneMaterial, read_materials};
use crate::skeleton::JointTransform;

/// Required extensions shoal cannot read (geometry compression).
const COMPRESSION_EXTENSIONS: &[&str] = &["KHR_draco_mesh_compression", "EXT_meshopt_compression"];

/// One node of the file.
#[derive(Debug, Clone)]
pub struct SceneNode {
    /// The node's name, if it has one.
    pub name: Option<String>,
    /// Parent node index (none for roots).
    pub parent: Option<usize>,
    /// Child node indices, in file order.
    pub children: Vec<usize>,
    /// The node's local transform as stored (a `matrix` or T·R·S).
    pub local_matrix: Mat4,
    /// The same transform decomposed into translation / rotation / scale.
    pub local: JointTransform,
    /// Mesh index, if the node has a mesh.
    pub mesh: Option<usize>,
    /// Skin index, if the node's mesh is skinned.
    pub skin: Option<usize>,
}

/// One skin: its joints (node indices) and inverse bind matrices, paired by index.
#[derive(Debug, Clone)]
pub struct SceneSkin {
    /// The skin's name, if any.
    pub name: Option<String>,
    /// Node index of each joint; `JOINTS_n` attributes index into this list.
    pub joints: Vec<usize>,
    /// Inverse bind matrix of each joint (identity when the file has none).
    pub inverse_bind_matrices: Vec<Mat4>,
}

/// One triangle-list primitive with its attributes decoded to floats.
#[derive(Debug, Clone, Default)]
pub struct ScenePrimitive {
    /// Index of the primitive within its mesh.
    pub index: usize,
    /// POSITION, in the mesh's space.
    pub positions: Vec<Vec3>,
    /// NORMAL, if present.
    pub normals: Option<Vec<Vec3>>,
    /// Linear RGBA per vertex: material base colour × COLOR_0 (white when absent).
    pub colors: Vec<[f32; 4]>,
    /// COLOR_0 as stored (linear RGBA), if present.
    pub vertex_colors: Option<Vec<[f32; 4]>>,
    /// TEXCOORD_0, if present.
    pub uvs: Option<Vec<[f32; 2]>>,
    /// Every TEXCOORD_n set, n = 0, 1, … (empty when there is none).
    pub tex_coords: Vec<Vec<[f32; 2]>>,
    /// TANGENT (xyz and handedness w), if present.
    pub tangents: Option<Vec<[f32; 4]>>,
    /// Up to four influences per vertex, indices into the skin's joint list.
    pub joints: Option<Vec<[u16; 4]>>,
    /// The matching weights, summing to 1.
    pub weights: Option<Vec<[f32; 4]>>,
    /// Triangle list (non-indexed primitives get 0..n; strips and fans are converted).
    pub indices: Vec<u32>,
    /// The primitive has morph targets (ignored).
    pub has_morph_targets: bool,
    /// Index of the material, if any.
    pub material: Option<usize>,
}

/// One mesh: its name and triangle primitives.
#[derive(Debug, Clone, Default)]
pub struct SceneMesh {
    /// The mesh's name, if any.
    pub name: Option<String>,
    /// Its primitives that are triangles (points and lines are skipped with a warning).
    pub primitives: Vec<ScenePrimitive>,
}

/// A glTF file read for skinning.
#[derive(Debug, Clone)]
pub struct GltfScene {
    /// The file it was read from (for error messages).
    pub path: PathBuf,
    /// Every node, by node index.
    pub nodes: Vec<SceneNode>,
    /// Root nodes of the default scene (the first scene when none is marked default).
    pub scene_roots: Vec<usize>,
    /// Every skin, by skin index.
    pub skins: Vec<SceneSkin>,
    /// Every mesh, by mesh index.
    pub meshes: Vec<SceneMesh>,
    /// Every material, by material index (images not decoded yet).
    pub materials: Vec<SceneMaterial>,
    /// Things shoal could read past but a person should know about.
    pub warnings: Vec<String>,
}

/// One skinned (or rigidly placed) primitive in scene space, as `shoal skin` writes it.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct PosedPrimitive {
    /// Node index.
    pub node: usize,
    /// Node name, if any.
    pub node_name: Option<String>,
    /// Mesh index.
    pub mesh: usize,
    /// Primitive index within the mesh.
    pub primitive: usize,
    /// Scene-space positions, one per vertex of the primitive.
    pub positions: Vec<[f32; 3]>,
}

/// Local rotations that replace nodes' rest rotations (a pose file), by node name.
pub type PoseRotations = BTreeMap<String, Quat>;

impl GltfScene {
    /// Reads a `.gltf` (embedded or external buffers) or `.glb` file.
    pub fn load(path: &Path) -> Result<Self, SkinError> {
        let bytes = std::fs::read(path).map_err(|source| SkinError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::from_bytes(&bytes, path)
    }

    /// Reads a file already in memory; `path` names it in errors and resolves external URIs.
    pub fn from_bytes(bytes: &[u8], path: &Path) -> Result<Self, SkinError> {
        let gltf_err = |source: gltf::Error| SkinError::Gltf {
            path: path.to_path_buf(),
            source: Box::new(source),
        };
        super::validate::check_glb_length(bytes, path)?;
        let gltf = gltf::Gltf::from_slice_without_validation(bytes).map_err(gltf_err)?;
        // Indices the gltf crate's validation would index with unchecked (it panics).
        super::validate::check_indices(gltf.document.as_json(), path)?;
        for ext in gltf.document.extensions_required() {
            if COMPRESSION_EXTENSIONS.contains(&ext)
                || !gltf::json::extensions::ENABLED_EXTENSIONS.contains(&ext)
            {
                return Err(SkinError::UnsupportedExtension {
                    path: path.to_path_buf(),
                    extension: ext.to_string(),
                });
            }
        }
        // Parse again with validation (its check of required extensions comes after ours,
        // which names compression extensions clearly).
        let gltf = gltf::Gltf::from_slice(bytes).map_err(gltf_err)?;
        let base = path.parent().map(Path::to_path_buf);
        let buffers = gltf::import_buffers(&gltf.document, base.as_deref(), gltf.blob.clone())
            .map_err(gltf_err)?;
        let buffers: Vec<&[u8]> = buffers.iter().map(|b| b.0.as_slice()).collect();
        let mut scene = GltfScene {
            path: path.to_path_buf(),
            nodes: Vec::new(),
            scene_roots: Vec::new(),
            skins: Vec::new(),
            meshes: Vec::new(),
            materials: read_materials(&gltf.document, &buffers, path),
            warnings: Vec::new(),
        };
        scene.read_nodes(&gltf.document)?;
        scene.read_skins(&gltf.document, &buffers)?;
        scene.read_meshes(&gltf.document, &buffers)?;
        Ok(scene)
    }

    fn invalid(&self, problem: impl Into<String>) -> SkinError {
        SkinError::Invalid {
            path: self.path.clone(),
            problem: problem.into(),
        }
    }

    fn read_nodes(&mut self, doc: &gltf::Document) -> Result<(), SkinError> {
        let num_nodes = doc.nodes().len();
        for node in doc.nodes() {
            let local_matrix = Mat4::from_cols_array_2d(&node.transform().matrix());
            let (t, r, s) = node.transform().decomposed();
            let local = JointTransform {
                translation: Vec3::from(t),
                rotation: Quat::from_array(r).normalize(),
                scale: Vec3::from(s),
            };
            if !local_matrix.is_finite() || !local.rotation.is_finite() {
                return Err(
                    self.invalid(format!("node {} has a non-finite transform", node.index()))
                );
            }
            self.nodes.push(SceneNode {
                name: node.name().map(str::to_string),
                parent: None,
                children: node.children().map(|c| c.index()).collect(),
                local_matrix,
                local,
                mesh: node.mesh().map(|m| m.index()),
                skin: node.skin().map(|s| s.index()),
            });
        }
        for parent in 0..num_nodes {
            for child in self.nodes[parent].children.clone() {
                if let Some(other) = self.nodes[child].parent {
                    return Err(self.invalid(format!(
                        "node {child} has two parents ({other} and {parent})"
                    )));
                }
                self.nodes[child].parent = Some(parent);
            }
        }
        // Walking up from any node must end at a root within num_nodes steps.
        for start in 0..num_nodes {
            let mut at = start;
            let mut steps = 0;
            while let Some(p) = self.nodes[at].parent {
                at = p;
                steps += 1;
                if steps > num_nodes {
                    return Err(
                        self.invalid(format!("node hierarchy has a cycle through node {start}"))
                    );
                }
            }
        }
        let scene = doc.default_scene().or_else(|| doc.scenes().next());
        self.scene_roots = match scene {
            Some(scene) => scene.nodes().map(|n| n.index()).collect(),
            None => {
                self.warnings.push(format!(
                    "{}: the file has no scene; using every root node",
                    self.path.display()
                ));
                (0..num_nodes)
                    .filter(|&n| self.nodes[n].parent.is_none())
                    .collect()
            }
        };
        for &root in &self.scene_roots {
            if self.nodes[root].parent.is_some() {
                return Err(self.invalid(format!("scene root node {root} has a parent")));
            }
        }
        Ok(())
    }

    fn read_skins(&mut self, doc: &gltf::Document, buffers: &[&[u8]]) -> Result<(), SkinError> {
        for skin in doc.skins() {
            let joints: Vec<usize> = skin.joints().map(|j| j.index()).collect();
            if joints.is_empty() {
                return Err(self.invalid(format!("skin {} has no joints", skin.index())));
            }
            if joints.len() > usize::from(u16::MAX) {
                return Err(self.invalid(format!(
                    "skin {} has {} joints; at most 65535 are supported",
                    skin.index(),
                    joints.len()
                )));
            }
            let inverse_bind_matrices = match skin.inverse_bind_matrices() {
                None => vec![Mat4::IDENTITY; joints.len()],
                Some(acc) => {
                    let what = format!("skin {} inverseBindMatrices", skin.index());
                    let raw = RawAccessor::new(&acc, buffers, &self.path, &what)?;
                    if raw.dims != 16 || raw.data_type != DataType::F32 {
                        return Err(raw.error("must be MAT4 of FLOAT"));
                    }
                    if raw.count < joints.len() {
                        return Err(raw.error(&format!(
                            "has {} matrices for {} joints",
                            raw.count,
                            joints.len()
                        )));
                    }
                    let mut out = Vec::with_capacity(joints.len());
                    for i in 0..joints.len() {
                        let mut cols = [0.0f32; 16];
                        for (c, v) in cols.iter_mut().enumerate() {
                            *v = raw.float(i, c);
                        }
                        let m = Mat4::from_cols_array(&cols);
                        if !m.is_finite() {
                            return Err(raw.error(&format!("matrix {i} is not finite")));
                        }
                        out.push(m);
                    }
                    out
                }
            };
            self.skins.push(SceneSkin {
                name: skin.name().map(str::to_string),
                joints,
                inverse_bind_matrices,
            });
        }
        Ok(())
    }
}

mod accessor;
mod primitive;
mod scene_pose;

use accessor::RawAccessor;

/// Skins one vertex by a palette (helper for bake steps that are not per-frame).
pub(crate) fn skin_vertex(
    palette: &[Mat4],
    joints: [u16; 4],
    weights: [f32; 4],
    position: Vec3,
    normal: Vec3,
) -> Option<(Vec3, Vec3, Mat4)> {
    let mut m = Mat4::ZERO;
    for k in 0..4 {
        if weights[k] != 0.0 {
            m += *palette.get(usize::from(joints[k]))? * weights[k];
        }
    }
    let p = (m * Vec4::new(position.x, position.y, position.z, 1.0)).truncate();
    Some((p, transform_normal(&m, normal), m))
}
