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

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use glam::{Mat4, Quat, Vec3, Vec4};
use gltf::accessor::{DataType, Dimensions};
use gltf::mesh::Mode;

use super::SkinError;
use super::lbs::{LinearBlendSkinningJob, transform_normal};
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

    fn read_meshes(&mut self, doc: &gltf::Document, buffers: &[&[u8]]) -> Result<(), SkinError> {
        for mesh in doc.meshes() {
            let mut out = SceneMesh {
                name: mesh.name().map(str::to_string),
                primitives: Vec::new(),
            };
            for prim in mesh.primitives() {
                if let Some(p) = self.read_primitive(&mesh, &prim, buffers)? {
                    out.primitives.push(p);
                }
            }
            self.meshes.push(out);
        }
        Ok(())
    }

    fn read_primitive(
        &mut self,
        mesh: &gltf::Mesh,
        prim: &gltf::Primitive,
        buffers: &[&[u8]],
    ) -> Result<Option<ScenePrimitive>, SkinError> {
        let label = format!("mesh {} primitive {}", mesh.index(), prim.index());
        let mode = prim.mode();
        if !matches!(
            mode,
            Mode::Triangles | Mode::TriangleStrip | Mode::TriangleFan
        ) {
            self.warnings.push(format!(
                "{}: {label} is {mode:?}, not triangles; skipped",
                self.path.display()
            ));
            return Ok(None);
        }
        let Some(pos_acc) = prim.get(&gltf::Semantic::Positions) else {
            return Err(self.invalid(format!("{label} has no POSITION")));
        };
        let raw = RawAccessor::new(&pos_acc, buffers, &self.path, &format!("{label} POSITION"))?;
        let positions = raw.vec3s()?;
        let n = positions.len();
        let same_count = |raw: &RawAccessor, name: &str| -> Result<(), SkinError> {
            if raw.count != n {
                return Err(raw.error(&format!(
                    "{name} has {} entries for {n} vertices",
                    raw.count
                )));
            }
            Ok(())
        };
        let normals = match prim.get(&gltf::Semantic::Normals) {
            None => None,
            Some(acc) => {
                let raw = RawAccessor::new(&acc, buffers, &self.path, &format!("{label} NORMAL"))?;
                same_count(&raw, "NORMAL")?;
                Some(raw.vec3s()?)
            }
        };
        let base = prim.material().pbr_metallic_roughness().base_color_factor();
        let mut colors = vec![base; n];
        let mut vertex_colors = None;
        if let Some(acc) = prim.get(&gltf::Semantic::Colors(0)) {
            let raw = RawAccessor::new(&acc, buffers, &self.path, &format!("{label} COLOR_0"))?;
            same_count(&raw, "COLOR_0")?;
            if raw.dims != 3 && raw.dims != 4 {
                return Err(raw.error("must be VEC3 or VEC4"));
            }
            let mut vc = vec![[1.0f32; 4]; n];
            for (i, (c, v)) in colors.iter_mut().zip(vc.iter_mut()).enumerate() {
                for k in 0..raw.dims {
                    v[k] = raw.float(i, k);
                    c[k] *= v[k];
                }
            }
            vertex_colors = Some(vc);
        }
        // Every TEXCOORD_n set present from 0 up (a material may use any of them).
        let mut tex_coords: Vec<Vec<[f32; 2]>> = Vec::new();
        while let Some(acc) = prim.get(&gltf::Semantic::TexCoords(tex_coords.len() as u32)) {
            let name = format!("TEXCOORD_{}", tex_coords.len());
            let raw = RawAccessor::new(&acc, buffers, &self.path, &format!("{label} {name}"))?;
            same_count(&raw, &name)?;
            if raw.dims != 2 {
                return Err(raw.error("must be VEC2"));
            }
            tex_coords.push((0..n).map(|i| [raw.float(i, 0), raw.float(i, 1)]).collect());
        }
        let uvs = tex_coords.first().cloned();
        let tangents = match prim.get(&gltf::Semantic::Tangents) {
            None => None,
            Some(acc) => {
                let raw = RawAccessor::new(&acc, buffers, &self.path, &format!("{label} TANGENT"))?;
                same_count(&raw, "TANGENT")?;
                if raw.dims != 4 {
                    return Err(raw.error("must be VEC4"));
                }
                Some(
                    (0..n)
                        .map(|i| std::array::from_fn(|k| raw.float(i, k)))
                        .collect(),
                )
            }
        };
        // Skinning attributes: every set, merged, four strongest kept.
        let mut sets = Vec::new();
        for set in 0.. {
            let j = prim.get(&gltf::Semantic::Joints(set));
            let w = prim.get(&gltf::Semantic::Weights(set));
            match (j, w) {
                (None, None) => break,
                (Some(j), Some(w)) => {
                    let rj = RawAccessor::new(
                        &j,
                        buffers,
                        &self.path,
                        &format!("{label} JOINTS_{set}"),
                    )?;
                    let rw = RawAccessor::new(
                        &w,
                        buffers,
                        &self.path,
                        &format!("{label} WEIGHTS_{set}"),
                    )?;
                    same_count(&rj, "JOINTS")?;
                    same_count(&rw, "WEIGHTS")?;
                    if rj.dims != 4 || !matches!(rj.data_type, DataType::U8 | DataType::U16) {
                        return Err(rj.error("must be VEC4 of UNSIGNED_BYTE or UNSIGNED_SHORT"));
                    }
                    if rw.dims != 4 {
                        return Err(rw.error("must be VEC4"));
                    }
                    sets.push((rj, rw));
                }
                _ => {
                    return Err(self.invalid(format!(
                        "{label} has JOINTS_{set} without WEIGHTS_{set} or the reverse"
                    )));
                }
            }
        }
        let (joints, weights) = if sets.is_empty() {
            (None, None)
        } else {
            let (j, w) = self.merge_influences(&label, &sets, n)?;
            (Some(j), Some(w))
        };
        let mut indices = match prim.indices() {
            None => (0..n as u32).collect::<Vec<u32>>(),
            Some(acc) => {
                let raw = RawAccessor::new(&acc, buffers, &self.path, &format!("{label} indices"))?;
                if raw.dims != 1
                    || !matches!(raw.data_type, DataType::U8 | DataType::U16 | DataType::U32)
                {
                    return Err(raw.error("must be SCALAR unsigned integers"));
                }
                let mut out = Vec::with_capacity(raw.count);
                for i in 0..raw.count {
                    let v = raw.uint(i, 0);
                    if v as usize >= n {
                        return Err(raw.error(&format!("index {i} is {v}, past the {n} vertices")));
                    }
                    out.push(v);
                }
                out
            }
        };
        indices = match mode {
            Mode::TriangleStrip => strip_to_list(&indices),
            Mode::TriangleFan => fan_to_list(&indices),
            _ => {
                if indices.len() % 3 != 0 {
                    self.warnings.push(format!(
                        "{}: {label} has {} indices, not a multiple of 3; the last are dropped",
                        self.path.display(),
                        indices.len()
                    ));
                    indices.truncate(indices.len() / 3 * 3);
                }
                indices
            }
        };
        let has_morph_targets = prim.morph_targets().len() > 0;
        Ok(Some(ScenePrimitive {
            index: prim.index(),
            positions,
            normals,
            colors,
            vertex_colors,
            uvs,
            tex_coords,
            tangents,
            joints,
            weights,
            indices,
            has_morph_targets,
            material: prim.material().index(),
        }))
    }

    /// Merges JOINTS_n/WEIGHTS_n sets: per vertex, the four strongest influences, renormalized.
    fn merge_influences(
        &mut self,
        label: &str,
        sets: &[(RawAccessor, RawAccessor)],
        n: usize,
    ) -> Result<Influences, SkinError> {
        let mut joints = Vec::with_capacity(n);
        let mut weights = Vec::with_capacity(n);
        let mut num_off = 0usize;
        let mut num_dropped = 0usize;
        let mut num_zero = 0usize;
        let mut worst_sum = 1.0f32;
        for v in 0..n {
            let mut best = [(0u16, 0.0f32); 4];
            let mut sum = 0.0f32;
            for (rj, rw) in sets {
                for k in 0..4 {
                    let w = rw.float(v, k);
                    if !w.is_finite() || w < 0.0 {
                        return Err(rw.error(&format!("vertex {v} has weight {w}")));
                    }
                    sum += w;
                    if w == 0.0 {
                        continue;
                    }
                    let j = rj.uint(v, k);
                    let j = u16::try_from(j)
                        .map_err(|_| rj.error(&format!("vertex {v} joint {j} is too large")))?;
                    // Insert into the four strongest (ties keep the earlier influence).
                    if w > best[3].1 {
                        if best[3].1 > 0.0 {
                            num_dropped += 1;
                        }
                        let mut at = 3;
                        while at > 0 && w > best[at - 1].1 {
                            best[at] = best[at - 1];
                            at -= 1;
                        }
                        best[at] = (j, w);
                    } else {
                        num_dropped += 1;
                    }
                }
            }
            let tolerance = if sets[0].1.data_type == DataType::F32 {
                2e-3
            } else {
                8e-3
            };
            if (sum - 1.0).abs() > tolerance {
                num_off += 1;
                if (sum - 1.0).abs() > (worst_sum - 1.0).abs() {
                    worst_sum = sum;
                }
            }
            let kept: f32 = best.iter().map(|b| b.1).sum();
            if kept <= 0.0 {
                num_zero += 1;
                joints.push([0; 4]);
                weights.push([1.0, 0.0, 0.0, 0.0]);
                continue;
            }
            joints.push([best[0].0, best[1].0, best[2].0, best[3].0]);
            weights.push([
                best[0].1 / kept,
                best[1].1 / kept,
                best[2].1 / kept,
                best[3].1 / kept,
            ]);
        }
        let file = self.path.display().to_string();
        if num_off > 0 {
            self.warnings.push(format!(
                "{file}: {label}: the weights of {num_off} of {n} vertices do not sum to 1 (worst sum {worst_sum}); renormalized"
            ));
        }
        if num_dropped > 0 {
            self.warnings.push(format!(
                "{file}: {label}: {num_dropped} influences beyond the 4 strongest per vertex were dropped; renormalized"
            ));
        }
        if num_zero > 0 {
            self.warnings.push(format!(
                "{file}: {label}: {num_zero} vertices have no weight; bound to the skin's first joint"
            ));
        }
        Ok((joints, weights))
    }

    /// Scene-space (global) matrix of every node from the given local matrices; nodes outside
    /// the hierarchy reachable from a root still get their chain product.
    pub fn globals_from(&self, locals: &[Mat4]) -> Vec<Mat4> {
        let mut globals = vec![Mat4::IDENTITY; self.nodes.len()];
        let mut done = vec![false; self.nodes.len()];
        let mut chain = Vec::new();
        for start in 0..self.nodes.len() {
            chain.clear();
            let mut at = Some(start);
            while let Some(n) = at {
                if done[n] {
                    break;
                }
                chain.push(n);
                at = self.nodes[n].parent;
            }
            let mut m = at.map_or(Mat4::IDENTITY, |n| globals[n]);
            for &n in chain.iter().rev() {
                m *= locals[n];
                globals[n] = m;
                done[n] = true;
            }
        }
        globals
    }

    /// The rest (file) local matrices of all nodes.
    pub fn rest_locals(&self) -> Vec<Mat4> {
        self.nodes.iter().map(|n| n.local_matrix).collect()
    }

    /// Local matrices with the pose's rotations replacing those nodes' rest rotations. Fails if
    /// a pose entry names no node, or its quaternion is not finite or zero.
    pub fn posed_locals(&self, pose: &PoseRotations) -> Result<Vec<Mat4>, SkinError> {
        let mut locals = self.rest_locals();
        for (name, rotation) in pose {
            let len = rotation.length();
            if !len.is_finite() || len < 1e-6 {
                return Err(SkinError::Pose {
                    path: self.path.clone(),
                    problem: format!(
                        "rotation of {name:?} is {rotation:?}, not a usable quaternion"
                    ),
                });
            }
            let mut found = false;
            for (i, node) in self.nodes.iter().enumerate() {
                if node.name.as_deref() == Some(name.as_str()) {
                    let t = JointTransform {
                        rotation: *rotation / len,
                        ..node.local
                    };
                    locals[i] = t.to_mat4();
                    found = true;
                }
            }
            if !found {
                let mut names: Vec<String> = self
                    .skins
                    .iter()
                    .flat_map(|s| s.joints.iter())
                    .filter_map(|&j| self.nodes[j].name.clone())
                    .collect();
                names.sort();
                names.dedup();
                return Err(SkinError::Pose {
                    path: self.path.clone(),
                    problem: format!(
                        "no node is named {name:?}; joint names are: {}",
                        names.join(", ")
                    ),
                });
            }
        }
        Ok(locals)
    }

    /// Mesh nodes of the default scene, depth-first in file order.
    pub fn scene_mesh_nodes(&self) -> Vec<usize> {
        let mut out = Vec::new();
        let mut stack: Vec<usize> = self.scene_roots.iter().rev().copied().collect();
        let mut seen = vec![false; self.nodes.len()];
        while let Some(n) = stack.pop() {
            if std::mem::replace(&mut seen[n], true) {
                continue;
            }
            if self.nodes[n].mesh.is_some() {
                out.push(n);
            }
            stack.extend(self.nodes[n].children.iter().rev());
        }
        out
    }

    /// Skins every primitive of every mesh node of the default scene with the given local node
    /// matrices (see [`Self::posed_locals`]): skinned nodes by equation (1) with palette =
    /// global(joint) · IBM (the node's own transform ignored), others by their global transform.
    pub fn pose_scene(&self, locals: &[Mat4]) -> Result<Vec<PosedPrimitive>, SkinError> {
        let globals = self.globals_from(locals);
        let mut out = Vec::new();
        for node_index in self.scene_mesh_nodes() {
            let node = &self.nodes[node_index];
            let Some(mesh_index) = node.mesh else {
                continue;
            };
            let mesh = self.meshes.get(mesh_index).ok_or_else(|| {
                self.invalid(format!("node {node_index} names missing mesh {mesh_index}"))
            })?;
            let palette: Option<Vec<Mat4>> = match node.skin {
                None => None,
                Some(s) => {
                    let skin = self.skins.get(s).ok_or_else(|| {
                        self.invalid(format!("node {node_index} names missing skin {s}"))
                    })?;
                    Some(
                        skin.joints
                            .iter()
                            .zip(&skin.inverse_bind_matrices)
                            .map(|(&j, ibm)| globals[j] * *ibm)
                            .collect(),
                    )
                }
            };
            for prim in &mesh.primitives {
                let positions: Vec<Vec3> = match (&palette, &prim.joints, &prim.weights) {
                    (Some(palette), Some(joints), Some(weights)) => {
                        let mut pos = vec![Vec3::ZERO; prim.positions.len()];
                        LinearBlendSkinningJob {
                            palette,
                            positions_in: &prim.positions,
                            normals_in: &[],
                            joints,
                            weights,
                            positions_out: &mut pos,
                            normals_out: &mut [],
                        }
                        .run()
                        .map_err(|e| {
                            self.invalid(format!(
                                "node {node_index}, mesh {mesh_index} primitive {}: {e}",
                                prim.index
                            ))
                        })?;
                        pos
                    }
                    (Some(_), _, _) => {
                        return Err(self.invalid(format!(
                            "node {node_index} is skinned but mesh {mesh_index} primitive {} has no JOINTS_0/WEIGHTS_0",
                            prim.index
                        )));
                    }
                    (None, _, _) => prim
                        .positions
                        .iter()
                        .map(|&p| globals[node_index].transform_point3(p))
                        .collect(),
                };
                out.push(PosedPrimitive {
                    node: node_index,
                    node_name: node.name.clone(),
                    mesh: mesh_index,
                    primitive: prim.index,
                    positions: positions.iter().map(|p| p.to_array()).collect(),
                });
            }
        }
        Ok(out)
    }
}

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

fn strip_to_list(strip: &[u32]) -> Vec<u32> {
    let mut out = Vec::new();
    for i in 2..strip.len() {
        if i % 2 == 0 {
            out.extend([strip[i - 2], strip[i - 1], strip[i]]);
        } else {
            out.extend([strip[i - 1], strip[i - 2], strip[i]]);
        }
    }
    out
}

fn fan_to_list(fan: &[u32]) -> Vec<u32> {
    let mut out = Vec::new();
    for i in 2..fan.len() {
        out.extend([fan[i - 1], fan[i], fan[0]]);
    }
    out
}

/// Per-vertex joint indices and weights.
type Influences = (Vec<[u16; 4]>, Vec<[f32; 4]>);

/// A bounds-checked view of one accessor's bytes.
struct RawAccessor<'b> {
    bytes: &'b [u8],
    stride: usize,
    count: usize,
    dims: usize,
    data_type: DataType,
    normalized: bool,
    path: PathBuf,
    what: String,
    index: usize,
}

impl<'b> RawAccessor<'b> {
    fn new(
        acc: &gltf::Accessor,
        buffers: &[&'b [u8]],
        path: &Path,
        what: &str,
    ) -> Result<Self, SkinError> {
        let err = |problem: String| SkinError::Accessor {
            path: path.to_path_buf(),
            accessor: acc.index(),
            what: what.to_string(),
            problem,
        };
        if acc.sparse().is_some() {
            return Err(err("sparse accessors are not supported".into()));
        }
        let dims = match acc.dimensions() {
            Dimensions::Scalar => 1,
            Dimensions::Vec2 => 2,
            Dimensions::Vec3 => 3,
            Dimensions::Vec4 => 4,
            Dimensions::Mat2 => 4,
            Dimensions::Mat3 => 9,
            Dimensions::Mat4 => 16,
        };
        let data_type = acc.data_type();
        let elem = dims * data_type.size();
        let count = acc.count();
        let Some(view) = acc.view() else {
            // No buffer view and no sparse data: all zeros per the specification.
            return Ok(Self {
                bytes: &[],
                stride: 0,
                count,
                dims,
                data_type,
                normalized: acc.normalized(),
                path: path.to_path_buf(),
                what: what.to_string(),
                index: acc.index(),
            });
        };
        if matches!(acc.dimensions(), Dimensions::Mat2 | Dimensions::Mat3) && data_type.size() < 4 {
            return Err(err(
                "padded MAT2/MAT3 of bytes or shorts are not supported".into()
            ));
        }
        let buffer = buffers
            .get(view.buffer().index())
            .ok_or_else(|| err(format!("buffer {} does not exist", view.buffer().index())))?;
        let view_end = view
            .offset()
            .checked_add(view.length())
            .filter(|&e| e <= buffer.len())
            .ok_or_else(|| {
                err(format!(
                    "buffer view {} (offset {}, length {}) runs past its buffer of {} bytes",
                    view.index(),
                    view.offset(),
                    view.length(),
                    buffer.len()
                ))
            })?;
        let view_bytes = &buffer[view.offset()..view_end];
        let stride = view.stride().unwrap_or(elem);
        if stride < elem {
            return Err(err(format!(
                "byteStride {stride} is less than the element size {elem}"
            )));
        }
        let needed = if count == 0 {
            Some(0)
        } else {
            (count - 1)
                .checked_mul(stride)
                .and_then(|x| x.checked_add(elem))
                .and_then(|x| x.checked_add(acc.offset()))
        };
        match needed {
            Some(end) if end <= view_bytes.len() => {}
            _ => {
                return Err(err(format!(
                    "{count} elements of {elem} bytes (stride {stride}, offset {}) run past buffer view {} of {} bytes",
                    acc.offset(),
                    view.index(),
                    view_bytes.len()
                )));
            }
        }
        Ok(Self {
            bytes: &view_bytes[acc.offset().min(view_bytes.len())..],
            stride,
            count,
            dims,
            data_type,
            normalized: acc.normalized(),
            path: path.to_path_buf(),
            what: what.to_string(),
            index: acc.index(),
        })
    }

    fn error(&self, problem: &str) -> SkinError {
        SkinError::Accessor {
            path: self.path.clone(),
            accessor: self.index,
            what: self.what.clone(),
            problem: problem.to_string(),
        }
    }

    /// Component `c` of element `i` as stored (bounds were checked in `new`); 0 when there
    /// is no buffer view.
    fn component_bits(&self, i: usize, c: usize) -> u32 {
        if self.bytes.is_empty() {
            return 0;
        }
        let size = self.data_type.size();
        let at = i * self.stride + c * size;
        let b = &self.bytes[at..at + size];
        match size {
            1 => u32::from(b[0]),
            2 => u32::from(u16::from_le_bytes([b[0], b[1]])),
            _ => u32::from_le_bytes([b[0], b[1], b[2], b[3]]),
        }
    }

    /// Component as a float: normalized integers map to [0, 1] or [−1, 1].
    fn float(&self, i: usize, c: usize) -> f32 {
        let bits = self.component_bits(i, c);
        match self.data_type {
            DataType::F32 => f32::from_bits(bits),
            DataType::U8 if self.normalized => bits as f32 / 255.0,
            DataType::U16 if self.normalized => bits as f32 / 65535.0,
            DataType::I8 if self.normalized => (f32::from(bits as u8 as i8) / 127.0).max(-1.0),
            DataType::I16 if self.normalized => (f32::from(bits as u16 as i16) / 32767.0).max(-1.0),
            DataType::I8 => f32::from(bits as u8 as i8),
            DataType::I16 => f32::from(bits as u16 as i16),
            DataType::U8 | DataType::U16 | DataType::U32 => bits as f32,
        }
    }

    fn uint(&self, i: usize, c: usize) -> u32 {
        self.component_bits(i, c)
    }

    fn vec3s(&self) -> Result<Vec<Vec3>, SkinError> {
        if self.dims != 3 {
            return Err(self.error("must be VEC3"));
        }
        let mut out = Vec::with_capacity(self.count);
        for i in 0..self.count {
            let v = Vec3::new(self.float(i, 0), self.float(i, 1), self.float(i, 2));
            if !v.is_finite() {
                return Err(self.error(&format!("element {i} is not finite: {v}")));
            }
            out.push(v);
        }
        Ok(out)
    }
}
