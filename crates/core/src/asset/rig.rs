//! Auto-rigging a static fish mesh (`shoal asset rig`): find the body's long axis, decide which
//! end is the head, lay a vertebral chain along it and compute smooth skin weights.
//!
//! - **Long axis** (`--axis auto`): the principal axis of the vertex cloud (largest eigenvector
//!   of its covariance, by power iteration), snapped to an asset axis when within 15° of one;
//!   or a named asset axis.
//! - **Head end** (`--head auto`): the end whose last 20% of length has the larger cross-section
//!   (product of the two perpendicular standard deviations). A fish's tail end is a thin
//!   peduncle plus a tall but flat caudal fin, so its cross-section is small; the head is thick
//!   in both directions. Override with `--head +` / `--head -` (towards +axis / −axis).
//! - **Chain**: `root` at 12% of the length from the snout, then `spine_1` … `spine_{n−1}`
//!   evenly from 30% to 85%, and a leaf `tail_end` at the tail tip (so `--joints 7` gives the
//!   paper's seven segments and six driven joints). Each joint sits on the midline of its
//!   cross-section slab.
//! - **Weights**: by position along the axis, each vertex belongs to the chain joint whose
//!   segment holds it, handed over to the next by a smoothstep within ±35% of the shorter
//!   neighbouring segment around each joint (at most two influences, summing to 1).
//! - **Materials**: the first material is kept whole (every factor, alpha mode,
//!   double-sidedness, extensions) with every texture it uses (base colour, metallic-roughness,
//!   normal, occlusion, emissive) embedded in the GLB with its sampler, and TEXCOORD_0. A
//!   texture on another coordinate set, or whose image cannot be read, is dropped with a warning.
//!
//! The mesh is baked into scene space (every mesh node's global transform applied), so the rig's
//! model space is the source file's scene space.

use std::path::{Path, PathBuf};

use glam::{Mat3, Vec3};
use serde_json::{Value, json};

use super::fish::chain_blend;
use super::rigged::{Influences, MaterialSet, RiggedMesh};
use crate::skin::{GltfScene, SkinError};

/// Why rigging failed.
#[derive(Debug, thiserror::Error)]
pub enum RigError {
    /// The input could not be read as glTF.
    #[error(transparent)]
    Load(#[from] SkinError),
    /// An option is out of range.
    #[error("{0}")]
    Option(String),
    /// The mesh cannot be rigged.
    #[error("{}: {problem}", path.display())]
    Mesh {
        /// The input file.
        path: PathBuf,
        /// What is wrong.
        problem: String,
    },
}

/// Why a texture of the input was not copied into the rigged file. Not fatal: the rig goes on
/// with a warning naming the texture, and the material keeps its factors.
#[derive(Debug, thiserror::Error)]
enum TextureCopyError {
    /// The material names a texture the file does not have.
    #[error("texture {0} does not exist")]
    NoTexture(usize),
    /// The image is of a kind shoal does not copy (see `image_problem`).
    #[error("image {image}: {problem}")]
    Unsupported {
        /// The image's index.
        image: usize,
        /// What is wrong with it.
        problem: &'static str,
    },
    /// The image's bytes could not be read.
    #[error("image {image}: {source}")]
    Image {
        /// The image's index.
        image: usize,
        /// Why.
        source: ImageReadError,
    },
}

/// Why an image's bytes could not be read for copying.
#[derive(Debug, thiserror::Error)]
enum ImageReadError {
    /// Images embedded as data URIs are left out.
    #[error("data-URI images are not copied")]
    DataUri,
    /// The image file beside the glTF could not be read.
    #[error("{}: {source}", path.display())]
    Read {
        /// The image file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// Neither the file nor its name says PNG or JPEG.
    #[error("{uri}: unknown image type")]
    UnknownType {
        /// The image's URI.
        uri: String,
    },
    /// The glTF's buffers could not be loaded.
    #[error(transparent)]
    Buffers(#[from] gltf::Error),
    /// The image's buffer view points at a buffer the file does not have.
    #[error("image buffer missing")]
    NoBuffer,
    /// The buffer view's offset and length overflow.
    #[error("bad view")]
    BadView,
    /// The buffer view reaches past its buffer.
    #[error("image view out of bounds")]
    OutOfBounds,
}

/// Which axis the body lies along.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Axis {
    /// The principal axis of the vertices.
    Auto,
    /// Asset X.
    X,
    /// Asset Y.
    Y,
    /// Asset Z.
    Z,
}

impl Axis {
    /// Parses `auto`, `x`, `y` or `z`.
    pub fn parse(s: &str) -> Result<Self, RigError> {
        match s.to_ascii_lowercase().as_str() {
            "auto" => Ok(Self::Auto),
            "x" => Ok(Self::X),
            "y" => Ok(Self::Y),
            "z" => Ok(Self::Z),
            _ => Err(RigError::Option(format!(
                "--axis {s:?}: expected auto, x, y or z"
            ))),
        }
    }
}

/// Which end of the long axis is the head.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum HeadEnd {
    /// The thicker end.
    Auto,
    /// Towards +axis.
    Positive,
    /// Towards −axis.
    Negative,
}

impl HeadEnd {
    /// Parses `auto`, `+` or `-`.
    pub fn parse(s: &str) -> Result<Self, RigError> {
        match s {
            "auto" => Ok(Self::Auto),
            "+" => Ok(Self::Positive),
            "-" => Ok(Self::Negative),
            _ => Err(RigError::Option(format!(
                "--head {s:?}: expected auto, + or -"
            ))),
        }
    }
}

/// Rigging options.
#[derive(Debug, Clone, Copy)]
pub struct RigOptions {
    /// Vertebral chain joints, root included (≥ 2); a leaf `tail_end` is added.
    pub num_joints: usize,
    /// Long-axis choice.
    pub axis: Axis,
    /// Head-end choice.
    pub head: HeadEnd,
}

impl Default for RigOptions {
    fn default() -> Self {
        Self {
            num_joints: 7,
            axis: Axis::Auto,
            head: HeadEnd::Auto,
        }
    }
}

/// A rigged fish.
#[derive(Debug, Clone)]
pub struct Rigged {
    /// The GLB file.
    pub glb: Vec<u8>,
    /// The mesh and skeleton written.
    pub mesh: RiggedMesh,
    /// Chain joint names, head to tail (root, spine_1 …, tail_end).
    pub joint_names: Vec<String>,
    /// The driven joints (spine_1 …), head to tail: a species' `vertebral_joints`.
    pub driven_joints: Vec<String>,
    /// Unit long axis, pointing from tail to head.
    pub axis: Vec3,
    /// Whether the head is at the +axis end of the chosen axis before orienting.
    pub head_positive: bool,
    /// Things a person should know.
    pub warnings: Vec<String>,
}

/// Rigs a `.gltf` / `.glb` file.
pub fn rig_file(path: &Path, opts: &RigOptions) -> Result<Rigged, RigError> {
    let scene = GltfScene::load(path)?;
    rig_scene(&scene, opts)
}

/// Rigs a scene already read: bakes its meshes into scene space (`bake_scene`), finds the
/// long axis and the head end (`body_frame`), places the chain along the midline
/// (`chain_joints`) and weights every vertex to it, then writes the GLB with the first
/// material.
pub fn rig_scene(scene: &GltfScene, opts: &RigOptions) -> Result<Rigged, RigError> {
    if opts.num_joints < 2 || opts.num_joints > 64 {
        return Err(RigError::Option(format!(
            "--joints {}: expected 2 to 64 chain joints",
            opts.num_joints
        )));
    }
    let mut warnings = scene.warnings.clone();
    let baked = bake_scene(scene, &mut warnings)?;
    let frame = body_frame(scene, &baked.positions, opts)?;
    let (names, chain_f, joint_positions) = chain_joints(opts, &baked.positions, &frame);
    let parents: Vec<Option<usize>> = (0..names.len())
        .map(|j| if j == 0 { None } else { Some(j - 1) })
        .collect();
    let chain: Vec<(u16, f32)> = chain_f
        .iter()
        .enumerate()
        .map(|(j, &f)| (j as u16, f))
        .collect();
    let mut pairs = Vec::new();
    let influences: Vec<Influences> = frame
        .fractions
        .iter()
        .map(|&f| {
            pairs.clear();
            chain_blend(&chain, f, 0.35, |j, w| pairs.push((j, w)));
            Influences::from_pairs(&pairs, 0)
        })
        .collect();

    let name = scene
        .nodes
        .iter()
        .find_map(|n| n.mesh.and(n.name.clone()))
        .unwrap_or_else(|| "fish".into());
    let Baked {
        positions,
        normals,
        colors,
        uvs,
        all_uvs,
        tangents,
        all_tangents,
        indices,
        parts,
    } = baked;
    let rigged = RiggedMesh {
        name: super::sanitize_name(&name),
        joint_names: names.clone(),
        joint_parents: parents,
        joint_positions,
        positions,
        normals,
        colors,
        uvs: if all_uvs && !uvs.is_empty() {
            Some(uvs)
        } else {
            None
        },
        tangents: None,
        influences,
        indices,
        parts: Vec::new(),
    };
    let have_tangents = all_tangents && tangents.len() == rigged.positions.len();
    // The distinct materials in order of first use; each part points at its slot.
    let mut used: Vec<Option<usize>> = Vec::new();
    let mut part_slots = Vec::with_capacity(parts.len());
    for &(count, m) in &parts {
        let slot = used.iter().position(|&u| u == m).unwrap_or_else(|| {
            used.push(m);
            used.len() - 1
        });
        part_slots.push((count, slot));
    }
    let materials = copy_materials(scene, &used, rigged.uvs.is_some(), &mut warnings)?;
    let mut rigged = rigged;
    if used.len() > 1 {
        rigged.parts = part_slots;
    }
    let normal_maps = materials
        .materials
        .as_array()
        .is_some_and(|ms| ms.iter().any(|m| m.get("normalTexture").is_some()));
    if normal_maps && have_tangents {
        rigged.tangents = Some(tangents);
    }
    let glb = rigged.to_glb(&materials, "shoal asset rig");
    Ok(Rigged {
        glb,
        joint_names: names.clone(),
        driven_joints: names[1..names.len() - 1].to_vec(),
        mesh: rigged,
        axis: frame.axis,
        head_positive: frame.head_positive,
        warnings,
    })
}

/// Every mesh node of the default scene, baked into scene space as one triangle list.
struct Baked {
    positions: Vec<Vec3>,
    normals: Vec<Vec3>,
    colors: Vec<[f32; 4]>,
    uvs: Vec<[f32; 2]>,
    /// Every primitive had TEXCOORD_0.
    all_uvs: bool,
    tangents: Vec<[f32; 4]>,
    /// Every primitive had TANGENT.
    all_tangents: bool,
    indices: Vec<u32>,
    /// Consecutive triangle ranges and their material: (number of indices, material index in
    /// the file), in index order.
    parts: Vec<(usize, Option<usize>)>,
}

/// Bakes every mesh node of the default scene into scene space: positions, normals, tangents
/// (handedness flipped under a mirroring transform), colours, TEXCOORD_0 and indices. Errors
/// when there is no triangle mesh; warns about skinned nodes and extra materials.
fn bake_scene(scene: &GltfScene, warnings: &mut Vec<String>) -> Result<Baked, RigError> {
    let path = &scene.path;
    let mesh_err = |problem: String| RigError::Mesh {
        path: path.clone(),
        problem,
    };
    let globals = scene.globals_from(&scene.rest_locals());
    let mut positions = Vec::new();
    let mut normals = Vec::new();
    let mut colors = Vec::new();
    let mut uvs: Vec<[f32; 2]> = Vec::new();
    let mut all_uvs = true;
    let mut tangents: Vec<[f32; 4]> = Vec::new();
    let mut all_tangents = true;
    let mut indices = Vec::new();
    let mut parts: Vec<(usize, Option<usize>)> = Vec::new();
    for node in scene.scene_mesh_nodes() {
        let Some(mesh) = scene.nodes[node].mesh.and_then(|m| scene.meshes.get(m)) else {
            continue;
        };
        if scene.nodes[node].skin.is_some() {
            warnings.push(format!(
                "{}: node {node} is already skinned; its bind shape is rigged afresh",
                path.display()
            ));
        }
        let g = globals[node];
        let normal_m = Mat3::from_mat4(g).inverse().transpose();
        for prim in &mesh.primitives {
            match parts.last_mut() {
                Some(last) if last.1 == prim.material => last.0 += prim.indices.len(),
                _ => parts.push((prim.indices.len(), prim.material)),
            }
            let base = positions.len() as u32;
            let local_normals = match &prim.normals {
                Some(n) => n.clone(),
                None => crate::skin::vertex_normals(&prim.positions, &prim.indices),
            };
            for (v, p) in prim.positions.iter().enumerate() {
                positions.push(g.transform_point3(*p));
                normals.push((normal_m * local_normals[v]).normalize_or(Vec3::Y));
                colors.push(prim.vertex_colors.as_ref().map_or([1.0; 4], |c| c[v]));
            }
            match &prim.uvs {
                Some(u) => uvs.extend(u),
                None => all_uvs = false,
            }
            // Tangents follow the surface: the linear part of the transform, handedness
            // flipped with a mirroring one.
            let flip = if g.determinant() < 0.0 { -1.0 } else { 1.0 };
            match &prim.tangents {
                Some(ts) => tangents.extend(ts.iter().map(|t| {
                    let v = Mat3::from_mat4(g) * Vec3::new(t[0], t[1], t[2]);
                    let v = v.normalize_or(Vec3::X);
                    [v.x, v.y, v.z, if t[3] < 0.0 { -flip } else { flip }]
                })),
                None => all_tangents = false,
            }
            if g.determinant() < 0.0 {
                for t in prim.indices.chunks_exact(3) {
                    indices.extend([t[0] + base, t[2] + base, t[1] + base]);
                }
            } else {
                indices.extend(prim.indices.iter().map(|i| i + base));
            }
        }
    }
    if positions.len() < 4 || indices.is_empty() {
        return Err(mesh_err(
            "the default scene has no triangle mesh to rig".into(),
        ));
    }
    if positions.len() > u32::MAX as usize / 2 {
        return Err(mesh_err("mesh too large".into()));
    }
    Ok(Baked {
        positions,
        normals,
        colors,
        uvs,
        all_uvs,
        tangents,
        all_tangents,
        indices,
        parts,
    })
}

/// Where the body lies: its long axis (unit, tail to head), the head end, and each vertex's
/// position along the body.
struct BodyFrame {
    centroid: Vec3,
    /// Unit long axis, pointing from tail to head.
    axis: Vec3,
    /// Whether the head is at the +axis end of the chosen axis before orienting.
    head_positive: bool,
    /// The head's coordinate along `axis` from the centroid.
    head_t: f32,
    /// Snout to tail, length units.
    length: f32,
    /// Per vertex: fraction of the length from the snout, in [0, 1].
    fractions: Vec<f32>,
}

/// The long axis (the option's, or the principal axis snapped to a coordinate axis) and the
/// head end (the option's, or the end whose last fifth has the larger cross-section).
fn body_frame(
    scene: &GltfScene,
    positions: &[Vec3],
    opts: &RigOptions,
) -> Result<BodyFrame, RigError> {
    let n = positions.len() as f32;
    let centroid = positions.iter().copied().sum::<Vec3>() / n;
    let mut axis = match opts.axis {
        Axis::X => Vec3::X,
        Axis::Y => Vec3::Y,
        Axis::Z => Vec3::Z,
        Axis::Auto => {
            crate::species::snap_to_asset_axis(crate::math::principal_axis(positions, centroid))
        }
    };
    let along: Vec<f32> = positions
        .iter()
        .map(|p| (*p - centroid).dot(axis))
        .collect();
    let (tmin, tmax) = along
        .iter()
        .fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), &t| {
            (a.min(t), b.max(t))
        });
    let length = tmax - tmin;
    if length.is_nan() || length <= 1e-9 {
        return Err(RigError::Mesh {
            path: scene.path.clone(),
            problem: "the mesh has no extent along its long axis".into(),
        });
    }
    // Perpendicular frame for the cross-section measure.
    let (u, w) = perpendicular_frame(axis);
    let section = |lo: f32, hi: f32| -> f32 {
        let mut s = [0.0f64; 5];
        for (p, &t) in positions.iter().zip(&along) {
            if t >= lo && t <= hi {
                let d = *p - centroid;
                let (a, b) = (f64::from(d.dot(u)), f64::from(d.dot(w)));
                s[0] += 1.0;
                s[1] += a;
                s[2] += a * a;
                s[3] += b;
                s[4] += b * b;
            }
        }
        if s[0] < 2.0 {
            return 0.0;
        }
        let va = s[2] / s[0] - (s[1] / s[0]).powi(2);
        let vb = s[4] / s[0] - (s[3] / s[0]).powi(2);
        (va.max(0.0).sqrt() * vb.max(0.0).sqrt()) as f32
    };
    let head_positive = match opts.head {
        HeadEnd::Positive => true,
        HeadEnd::Negative => false,
        HeadEnd::Auto => {
            let plus = section(tmax - 0.2 * length, tmax);
            let minus = section(tmin, tmin + 0.2 * length);
            plus >= minus
        }
    };
    if !head_positive {
        axis = -axis;
    }
    // Now `axis` points from tail to head; f = fraction of length from the snout.
    let head_t = if head_positive { tmax } else { -tmin };
    let fractions: Vec<f32> = positions
        .iter()
        .map(|p| ((head_t - (*p - centroid).dot(axis)) / length).clamp(0.0, 1.0))
        .collect();
    Ok(BodyFrame {
        centroid,
        axis,
        head_positive,
        head_t,
        length,
        fractions,
    })
}

/// The chain's joints, root, `spine_1` … and `tail_end`: their names, their fractions of the
/// length from the snout (the tail tip's 1.0 not included) and their positions on the midline
/// (the mean of the vertices in a slab around each).
fn chain_joints(
    opts: &RigOptions,
    positions: &[Vec3],
    frame: &BodyFrame,
) -> (Vec<String>, Vec<f32>, Vec<Vec3>) {
    let BodyFrame {
        centroid,
        axis,
        head_t,
        length,
        ..
    } = *frame;
    let fractions = frame.fractions.as_slice();
    // Chain: root, spine_1.., tail_end.
    let driven = opts.num_joints - 1;
    let mut chain_f = vec![0.12f32];
    for k in 0..driven {
        let t = if driven == 1 {
            0.5
        } else {
            k as f32 / (driven - 1) as f32
        };
        chain_f.push(0.30 + 0.55 * t);
    }
    let mut names = vec!["root".to_string()];
    names.extend(crate::species::spine_names(driven));
    names.push("tail_end".into());
    let mut joint_positions = Vec::new();
    for &f in chain_f.iter().chain(std::iter::once(&1.0f32)) {
        // Midline: mean perpendicular offset of the vertices in a slab around f.
        let half = 0.04;
        let mut sum = Vec3::ZERO;
        let mut count = 0.0f32;
        for (p, &pf) in positions.iter().zip(fractions) {
            if (pf - f).abs() <= half {
                let d = *p - centroid;
                sum += d - axis * d.dot(axis);
                count += 1.0;
            }
        }
        let offset = if count > 0.0 { sum / count } else { Vec3::ZERO };
        let t = head_t - f * length;
        joint_positions.push(centroid + axis * t + offset);
    }
    (names, chain_f, joint_positions)
}

/// Two unit vectors perpendicular to `axis` and each other.
fn perpendicular_frame(axis: Vec3) -> (Vec3, Vec3) {
    let helper = if axis.y.abs() < 0.9 { Vec3::Y } else { Vec3::X };
    let u = (helper - axis * helper.dot(axis)).normalize();
    (u, axis.cross(u))
}

/// Copies every material the mesh uses (`used`, in order; `None` is a primitive without one,
/// which gets a plain default) whole: its JSON as written (factors, alpha mode,
/// double-sidedness, normal scale, occlusion strength, emissive factor and every extension),
/// with every texture it refers to (base colour, metallic-roughness, normal, occlusion,
/// emissive, and textures of material extensions) re-pointed at images embedded in the GLB,
/// with their samplers; an image several materials share is embedded once. A texture whose
/// image cannot be read, or that needs a coordinate set the rig does not keep (only TEXCOORD_0
/// is kept), is dropped with a warning naming it. A normal map is kept without the file's
/// tangents: glTF then asks for MikkTSpace tangents, which shoal makes when it loads the fish.
fn copy_materials(
    scene: &GltfScene,
    used: &[Option<usize>],
    have_uvs: bool,
    warnings: &mut Vec<String>,
) -> Result<MaterialSet, RigError> {
    let default = || MaterialSet::pbr("rigged", [1.0, 1.0, 1.0, 1.0], 0.0, 0.6);
    let plain = || default().materials[0].clone();
    if used.iter().all(Option::is_none) {
        let mut set = default();
        set.materials = Value::Array(vec![plain(); used.len().max(1)]);
        return Ok(set);
    }
    let bytes = std::fs::read(&scene.path).map_err(|source| SkinError::Io {
        path: scene.path.clone(),
        source,
    })?;
    let Ok(gltf) = gltf::Gltf::from_slice(&bytes) else {
        return Ok(default());
    };
    // The file's own JSON, so nothing the gltf crate does not model is lost.
    let raw: Option<Value> = if bytes.starts_with(b"glTF") {
        gltf::Glb::from_slice(&bytes)
            .ok()
            .and_then(|glb| serde_json::from_slice(&glb.json).ok())
    } else {
        serde_json::from_slice(&bytes).ok()
    };
    let Some(raw) = raw else {
        return Ok(default());
    };
    let file = scene.path.display().to_string();
    let mut copier = TextureCopier {
        scene,
        gltf: &gltf,
        have_uvs,
        file: &file,
        textures: Vec::new(),
        samplers: Vec::new(),
        images: Vec::new(),
        image_of: std::collections::BTreeMap::new(),
        texture_of: std::collections::BTreeMap::new(),
        warnings,
    };
    let mut materials = Vec::with_capacity(used.len());
    for &index in used {
        let Some(mut m) = index.and_then(|i| raw["materials"].get(i).cloned()) else {
            materials.push(plain());
            continue;
        };
        let at = match used.len() {
            1 => "material".to_string(),
            _ => format!("material {}", index.unwrap_or(0)),
        };
        copier.remap(&mut m, &at);
        if m.get("name").is_none() {
            m["name"] = json!("rigged");
        }
        materials.push(m);
    }
    Ok(MaterialSet {
        materials: Value::Array(materials),
        textures: Value::Array(copier.textures),
        samplers: Value::Array(copier.samplers),
        images: copier.images,
        material: 0,
    })
}

/// Re-points a material's texture references at the rigged GLB's own textures.
struct TextureCopier<'a> {
    scene: &'a GltfScene,
    gltf: &'a gltf::Gltf,
    have_uvs: bool,
    file: &'a str,
    textures: Vec<Value>,
    samplers: Vec<Value>,
    images: Vec<(Vec<u8>, String)>,
    /// Source image index → embedded image index.
    image_of: std::collections::BTreeMap<usize, usize>,
    /// Source texture index → new texture index (`None`: dropped).
    texture_of: std::collections::BTreeMap<usize, Option<usize>>,
    warnings: &'a mut Vec<String>,
}

impl TextureCopier<'_> {
    /// Walks `v`; every `…Texture` object with an `index` is a textureInfo to re-point (or to
    /// remove when its texture cannot be copied).
    fn remap(&mut self, v: &mut Value, at: &str) {
        let Value::Object(map) = v else {
            return;
        };
        let keys: Vec<String> = map.keys().cloned().collect();
        for key in keys {
            let is_info = key.ends_with("Texture")
                && map[&key].get("index").and_then(Value::as_u64).is_some();
            if is_info {
                let info = &map[&key];
                let old = info["index"].as_u64().unwrap_or(0) as usize;
                let set = info.get("texCoord").and_then(Value::as_u64).unwrap_or(0);
                let what = format!("{at}.{key} (texture {old})");
                let new = if set != 0 || !self.have_uvs {
                    self.warnings.push(format!(
                        "{}: {what} dropped: it needs TEXCOORD_{set}, and the rig keeps TEXCOORD_0 only{}",
                        self.file,
                        if self.have_uvs { "" } else { " (which not every primitive has)" }
                    ));
                    None
                } else {
                    self.texture(old, &what)
                };
                match new {
                    Some(n) => map[&key]["index"] = json!(n),
                    None => {
                        map.remove(&key);
                    }
                }
            } else if let Some(child) = map.get_mut(&key) {
                self.remap(child, &format!("{at}.{key}"));
            }
        }
    }

    fn texture(&mut self, old: usize, what: &str) -> Option<usize> {
        if let Some(&done) = self.texture_of.get(&old) {
            return done;
        }
        let result = self.copy_texture(old);
        let new = match result {
            Ok(n) => Some(n),
            Err(why) => {
                self.warnings
                    .push(format!("{}: {what} dropped: {why}", self.file));
                None
            }
        };
        self.texture_of.insert(old, new);
        new
    }

    fn copy_texture(&mut self, old: usize) -> Result<usize, TextureCopyError> {
        let tex = self
            .gltf
            .document
            .textures()
            .nth(old)
            .ok_or(TextureCopyError::NoTexture(old))?;
        let image = tex.source();
        if let Some(problem) =
            crate::skin::material::image_problem(self.gltf.document.as_json(), image.index())
        {
            return Err(TextureCopyError::Unsupported {
                image: image.index(),
                problem,
            });
        }
        let source = match self.image_of.get(&image.index()) {
            Some(&i) => i,
            None => {
                let (data, mime) = read_image(self.scene, self.gltf, &image).map_err(|source| {
                    TextureCopyError::Image {
                        image: image.index(),
                        source,
                    }
                })?;
                self.images.push((data, mime));
                self.image_of.insert(image.index(), self.images.len() - 1);
                self.images.len() - 1
            }
        };
        let s = tex.sampler();
        let mut sampler = json!({});
        if let Some(f) = s.mag_filter() {
            sampler["magFilter"] = json!(f.as_gl_enum());
        }
        if let Some(f) = s.min_filter() {
            sampler["minFilter"] = json!(f.as_gl_enum());
        }
        sampler["wrapS"] = json!(s.wrap_s().as_gl_enum());
        sampler["wrapT"] = json!(s.wrap_t().as_gl_enum());
        let sampler_index = match self.samplers.iter().position(|x| *x == sampler) {
            Some(i) => i,
            None => {
                self.samplers.push(sampler);
                self.samplers.len() - 1
            }
        };
        self.textures
            .push(json!({"sampler": sampler_index, "source": source}));
        Ok(self.textures.len() - 1)
    }
}

fn read_image(
    scene: &GltfScene,
    gltf: &gltf::Gltf,
    image: &gltf::Image,
) -> Result<(Vec<u8>, String), ImageReadError> {
    match image.source() {
        gltf::image::Source::Uri { uri, mime_type } => {
            if uri.starts_with("data:") {
                return Err(ImageReadError::DataUri);
            }
            let decoded = crate::skin::material::percent_decode(uri);
            let base = scene.path.parent().unwrap_or(Path::new("."));
            let file = base.join(&decoded);
            let data = std::fs::read(&file).map_err(|source| ImageReadError::Read {
                path: file.clone(),
                source,
            })?;
            let mime = mime_type.map(str::to_string).or_else(|| mime_of(&decoded));
            let mime = mime.ok_or_else(|| ImageReadError::UnknownType {
                uri: uri.to_owned(),
            })?;
            Ok((data, mime))
        }
        gltf::image::Source::View { view, mime_type } => {
            let base = scene.path.parent();
            let buffers = gltf::import_buffers(&gltf.document, base, gltf.blob.clone())?;
            let buf = buffers
                .get(view.buffer().index())
                .ok_or(ImageReadError::NoBuffer)?;
            let end = view
                .offset()
                .checked_add(view.length())
                .ok_or(ImageReadError::BadView)?;
            let data = buf
                .0
                .get(view.offset()..end)
                .ok_or(ImageReadError::OutOfBounds)?;
            Ok((data.to_vec(), mime_type.to_string()))
        }
    }
}

fn mime_of(name: &str) -> Option<String> {
    let lower = name.to_ascii_lowercase();
    if lower.ends_with(".png") {
        Some("image/png".into())
    } else if lower.ends_with(".jpg") || lower.ends_with(".jpeg") {
        Some("image/jpeg".into())
    } else {
        None
    }
}
