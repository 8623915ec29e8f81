//! [`FishModel`]: one skinned mesh flattened for the runtime (skeleton, inverse bind poses and a
//! single merged vertex/index list).

use std::path::Path;

use glam::{Mat4, Vec3};

use super::SkinError;
use super::gltf_scene::{GltfScene, SceneMesh, ScenePrimitive, SceneSkin, skin_vertex};
use super::material::{Material, transform_uvs};
use crate::skeleton::{JointTransform, Skeleton};

/// Vertex data of a skinned mesh in the skeleton's bind (rest) pose, all primitives merged.
#[derive(Debug, Clone, Default, PartialEq)]
pub struct SkinnedMesh {
    /// Bind-shape positions (V_d of equation (1)), in the skeleton's model space.
    pub positions: Vec<Vec3>,
    /// Bind-shape unit normals, one per vertex (computed from the triangles when the file has none).
    pub normals: Vec<Vec3>,
    /// Linear RGBA per vertex: material base colour × vertex colour.
    pub colors: Vec<[f32; 4]>,
    /// Up to four joint indices per vertex, into the skeleton.
    pub joints: Vec<[u16; 4]>,
    /// The matching weights, summing to 1.
    pub weights: Vec<[f32; 4]>,
    /// Triangle list over all primitives.
    pub indices: Vec<u32>,
    /// Texture coordinates, one per vertex: each primitive's material's set
    /// (`KHR_texture_transform` applied; zeros for a primitive whose material has no texture);
    /// empty when no material has a usable texture.
    pub uvs: Vec<[f32; 2]>,
    /// Tangents (xyz unit, w = ±1 bitangent sign), one per vertex, in the bind shape: the
    /// file's TANGENT, or MikkTSpace tangents made from the texture coordinates when a normal
    /// map needs them and the file has none; empty when no material has a normal map.
    pub tangents: Vec<[f32; 4]>,
    /// The materials the primitives use, in order of first use (at least one in a loaded
    /// model; empty means [`Material::default`], see [`SkinnedMesh::material`]).
    pub materials: Vec<Material>,
    /// The triangle ranges of the primitives and the material each is drawn with, in index
    /// order, covering `indices`.
    pub parts: Vec<MeshPart>,
}

/// A range of a [`SkinnedMesh`]'s triangles drawn with one of its materials.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct MeshPart {
    /// First index (a multiple of 3) into the mesh's index list.
    pub first_index: u32,
    /// Number of indices.
    pub num_indices: u32,
    /// Index into the mesh's materials.
    pub material: u16,
}

impl SkinnedMesh {
    /// Number of vertices.
    pub fn num_vertices(&self) -> usize {
        self.positions.len()
    }

    /// Number of triangles.
    pub fn num_triangles(&self) -> usize {
        self.indices.len() / 3
    }

    /// The first material (the only one of most fish); [`Material::default`] when the mesh
    /// has none.
    pub fn material(&self) -> &Material {
        static PLAIN: std::sync::LazyLock<Material> = std::sync::LazyLock::new(Material::default);
        self.materials.first().unwrap_or(&PLAIN)
    }
}

/// The first skinned mesh node of a glTF file's default scene, ready for the runtime.
///
/// The skeleton holds the skin's joints only, parent-first; a root joint's rest transform
/// includes every non-joint ancestor node, so the skeleton's model space is the file's scene
/// space. The file's bind pose is *flattened*: `mesh.positions` / `normals` are the rest-pose
/// skinned shape (Σ w · global(joint) · IBM · v, the glTF definition, the mesh node's own
/// transform ignored) and `inverse_bind_poses[j]` is the inverse of joint j's rest model matrix.
/// So skinning with `palette = rest_models × inverse_bind_poses` reproduces `mesh.positions`,
/// and any pose gives what the file's own bind data would give wherever the file's
/// global(joint) · IBM agree across a vertex's joints (true for every well-formed export; a
/// warning counts the vertices where it does not).
#[derive(Debug, Clone)]
pub struct FishModel {
    /// The skin's joints, parent-first; names are the joint node names (or `joint_<i>`, i the
    /// index in `skin.joints`).
    pub skeleton: Skeleton,
    /// Inverse bind pose (M_{n,d}⁻¹) by skeleton joint.
    pub inverse_bind_poses: Vec<Mat4>,
    /// The merged mesh in bind pose.
    pub mesh: SkinnedMesh,
    /// Things a person should know about the file (renormalized weights, dropped influences…).
    pub warnings: Vec<String>,
}

impl FishModel {
    /// Loads the first skinned mesh node (depth-first in the default scene) of a `.gltf`/`.glb`.
    pub fn load(path: &Path) -> Result<FishModel, SkinError> {
        let scene = GltfScene::load(path)?;
        Self::from_scene(&scene)
    }

    /// Builds the model from a scene already read: the first skinned mesh node
    /// (`skinned_node`), its skin's joints as a skeleton (`skin_joints`), and its primitives
    /// skinned into the bind shape (`bind_shape`), with warnings about what was dropped.
    pub fn from_scene(scene: &GltfScene) -> Result<FishModel, SkinError> {
        let path = &scene.path;
        let mut warnings = scene.warnings.clone();
        let node_index = skinned_node(scene)?;
        let node = &scene.nodes[node_index];
        let invalid = |problem: String| SkinError::Invalid {
            path: path.clone(),
            problem,
        };
        let (Some(mesh_index), Some(skin_index)) = (node.mesh, node.skin) else {
            return Err(invalid(format!("node {node_index} lost its mesh or skin")));
        };
        let skin = scene
            .skins
            .get(skin_index)
            .ok_or_else(|| invalid(format!("node {node_index} names missing skin {skin_index}")))?;
        let mesh = scene
            .meshes
            .get(mesh_index)
            .ok_or_else(|| invalid(format!("node {node_index} names missing mesh {mesh_index}")))?;
        let globals = scene.globals_from(&scene.rest_locals());
        if !globals[node_index].abs_diff_eq(Mat4::IDENTITY, 1e-6) {
            warnings.push(format!(
                "{}: the skinned mesh node {node_index}'s own transform is ignored (glTF skinning rule)",
                path.display()
            ));
        }

        let num = skin.joints.len();
        let (parents, names, rests) = skin_joints(scene, skin, skin_index)?;
        let (skeleton, order) =
            Skeleton::from_unordered(&parents, &names, &rests).map_err(|source| {
                SkinError::Skeleton {
                    path: path.clone(),
                    source,
                }
            })?;
        let mut new_of_old = vec![0u16; num];
        for (new, &old) in order.iter().enumerate() {
            new_of_old[old] = new as u16;
        }

        // The file's rest palette, global(joint) · IBM, by file joint index.
        let bind_palette: Vec<Mat4> = skin
            .joints
            .iter()
            .zip(&skin.inverse_bind_matrices)
            .map(|(&n, ibm)| globals[n] * *ibm)
            .collect();
        let mut model_mismatch = 0.0f32;
        for (new, &old) in order.iter().enumerate() {
            let g = globals[skin.joints[old]];
            let r = skeleton.rest_models()[new];
            model_mismatch = model_mismatch.max(
                (g - r)
                    .abs()
                    .to_cols_array()
                    .into_iter()
                    .fold(0.0, f32::max),
            );
        }

        let BindShape {
            mut out,
            inconsistent,
            computed_normals,
            morph,
            tangents,
            extent,
        } = bind_shape(
            path,
            mesh,
            (node_index, mesh_index, skin_index),
            &bind_palette,
            &new_of_old,
        )?;
        resolve_materials(scene, &mesh.primitives, &mut out, &mut warnings);
        if out.materials.iter().any(|m| m.normal_texture.is_some()) {
            out.tangents = match tangents {
                Some(t) => t,
                None => generate_tangents(&out.positions, &out.normals, &out.uvs, &out.indices),
            };
        }
        let file = path.display();
        if inconsistent > 0 {
            warnings.push(format!(
                "{file}: at {inconsistent} vertices the joints' global·IBM disagree at rest; \
                 the bind shape is their weighted blend"
            ));
        }
        if computed_normals {
            warnings.push(format!(
                "{file}: mesh {mesh_index} has no normals; computed from faces"
            ));
        }
        if morph {
            warnings.push(format!(
                "{file}: mesh {mesh_index} morph targets are ignored"
            ));
        }
        if model_mismatch > 1e-4 * (1.0 + extent) {
            warnings.push(format!(
                "{file}: some joint rest transforms have shear, which the skeleton's T·R·S drops (max error {model_mismatch})"
            ));
        }
        let inverse_bind_poses = skeleton.rest_models().iter().map(|m| m.inverse()).collect();
        Ok(FishModel {
            skeleton,
            inverse_bind_poses,
            mesh: out,
            warnings,
        })
    }
}

/// The first mesh node of the default scene (depth first) that has a skin; when there is none,
/// an error saying why (no mesh, only morph targets, or no skin).
fn skinned_node(scene: &GltfScene) -> Result<usize, SkinError> {
    let path = &scene.path;
    let mesh_nodes = scene.scene_mesh_nodes();
    let Some(&node_index) = mesh_nodes.iter().find(|&&n| scene.nodes[n].skin.is_some()) else {
        let morph_only = mesh_nodes.iter().any(|&n| {
            scene.nodes[n]
                .mesh
                .and_then(|m| scene.meshes.get(m))
                .is_some_and(|m| m.primitives.iter().any(|p| p.has_morph_targets))
        });
        let detail = if mesh_nodes.is_empty() {
            "the default scene has no mesh".to_string()
        } else if morph_only {
            "its meshes are deformed by morph targets only, which shoal does not play; \
             rig it with `shoal asset rig`"
                .to_string()
        } else {
            format!(
                "none of its {} mesh nodes has a skin; rig it with `shoal asset rig`",
                mesh_nodes.len()
            )
        };
        return Err(SkinError::NoSkin {
            path: path.clone(),
            detail,
        });
    };
    Ok(node_index)
}

/// Each joint's parent, name and rest local transform, in the skin's joint order. A joint's
/// parent is its nearest ancestor that is a joint of this skin; its rest local is the product of
/// the node transforms in between.
#[allow(clippy::type_complexity)]
fn skin_joints(
    scene: &GltfScene,
    skin: &SceneSkin,
    skin_index: usize,
) -> Result<(Vec<Option<usize>>, Vec<String>, Vec<JointTransform>), SkinError> {
    let invalid = |problem: String| SkinError::Invalid {
        path: scene.path.clone(),
        problem,
    };
    let num = skin.joints.len();
    let mut joint_of_node = vec![None; scene.nodes.len()];
    for (i, &n) in skin.joints.iter().enumerate() {
        if n >= scene.nodes.len() {
            return Err(invalid(format!(
                "skin {skin_index} joint {i} is missing node {n}"
            )));
        }
        if joint_of_node[n].is_some() {
            return Err(invalid(format!("skin {skin_index} lists node {n} twice")));
        }
        joint_of_node[n] = Some(i);
    }
    let mut parents = Vec::with_capacity(num);
    let mut names = Vec::with_capacity(num);
    let mut rests = Vec::with_capacity(num);
    for (i, &n) in skin.joints.iter().enumerate() {
        names.push(
            scene.nodes[n]
                .name
                .clone()
                .unwrap_or_else(|| format!("joint_{i}")),
        );
        let mut chain = scene.nodes[n].local_matrix;
        let mut direct = true;
        let mut at = scene.nodes[n].parent;
        let mut parent = None;
        while let Some(a) = at {
            if let Some(j) = joint_of_node[a] {
                parent = Some(j);
                break;
            }
            chain = scene.nodes[a].local_matrix * chain;
            direct = false;
            at = scene.nodes[a].parent;
        }
        parents.push(parent);
        rests.push(if direct {
            scene.nodes[n].local
        } else {
            JointTransform::from_mat4(chain)
        });
    }
    Ok((parents, names, rests))
}

/// A skinned mesh's primitives merged and skinned into the bind shape, with what the warnings
/// need.
struct BindShape {
    out: SkinnedMesh,
    /// Vertices whose joints' global·IBM disagree at rest.
    inconsistent: usize,
    /// A primitive had no normals.
    computed_normals: bool,
    /// A primitive has morph targets (ignored).
    morph: bool,
    /// Bind-shape tangents when every primitive has TANGENT.
    tangents: Option<Vec<[f32; 4]>>,
    /// Largest |coordinate| of the bind shape.
    extent: f32,
}

/// Skins every primitive of `mesh` into the bind shape with the file's rest palette
/// (`bind_palette`, by file joint index) and renumbers its joints into skeleton order
/// (`new_of_old`). `ids` is (node, mesh, skin) for error messages.
fn bind_shape(
    path: &Path,
    mesh: &SceneMesh,
    ids: (usize, usize, usize),
    bind_palette: &[Mat4],
    new_of_old: &[u16],
) -> Result<BindShape, SkinError> {
    let (node_index, mesh_index, skin_index) = ids;
    let invalid = |problem: String| SkinError::Invalid {
        path: path.to_path_buf(),
        problem,
    };
    let num = new_of_old.len();
    let mut extent = 0.0f32;
    let mut out = SkinnedMesh::default();
    let mut inconsistent = 0usize;
    let mut computed_normals = false;
    let mut morph = false;
    let mut tangents = Some(Vec::new());
    for prim in &mesh.primitives {
        if prim.tangents.is_none() {
            tangents = None;
        }
        let (Some(joints), Some(weights)) = (&prim.joints, &prim.weights) else {
            return Err(invalid(format!(
                "node {node_index} is skinned but mesh {mesh_index} primitive {} has no JOINTS_0/WEIGHTS_0",
                prim.index
            )));
        };
        morph |= prim.has_morph_targets;
        let base = out.positions.len() as u32;
        let normals_in = match &prim.normals {
            Some(n) => n.clone(),
            None => {
                computed_normals = true;
                vertex_normals(&prim.positions, &prim.indices)
            }
        };
        for v in 0..prim.positions.len() {
            let Some((p, n, m)) = skin_vertex(
                bind_palette,
                joints[v],
                weights[v],
                prim.positions[v],
                normals_in[v],
            ) else {
                return Err(SkinError::Accessor {
                    path: path.to_path_buf(),
                    accessor: 0,
                    what: format!("mesh {mesh_index} primitive {} JOINTS", prim.index),
                    problem: format!(
                        "vertex {v} uses joint {:?} but skin {skin_index} has {num} joints",
                        joints[v]
                    ),
                });
            };
            // Do the influencing joints agree where this vertex sits at rest?
            for k in 0..4 {
                if weights[v][k] > 0.0 {
                    let q =
                        bind_palette[usize::from(joints[v][k])].transform_point3(prim.positions[v]);
                    if q.distance(p) > 1e-4 * (1.0 + p.length()) {
                        inconsistent += 1;
                        break;
                    }
                }
            }
            extent = extent.max(p.abs().max_element());
            out.positions.push(p);
            out.normals.push(n);
            if let (Some(ts), Some(file)) = (tangents.as_mut(), prim.tangents.as_ref()) {
                // Tangents follow the surface like edges: the skinning matrix's linear part,
                // handedness flipped where it mirrors.
                let t = file[v];
                let d = m.transform_vector3(Vec3::new(t[0], t[1], t[2]));
                let d = (d - n * d.dot(n)).normalize_or(Vec3::X);
                let flip = if m.determinant() < 0.0 { -1.0 } else { 1.0 };
                ts.push([d.x, d.y, d.z, if t[3] < 0.0 { -flip } else { flip }]);
            }
            out.colors.push(prim.colors[v]);
            let j = joints[v];
            out.joints.push([
                new_of_old[usize::from(j[0])],
                new_of_old[usize::from(j[1])],
                new_of_old[usize::from(j[2])],
                new_of_old[usize::from(j[3])],
            ]);
            out.weights.push(weights[v]);
        }
        out.indices.extend(prim.indices.iter().map(|i| i + base));
    }
    Ok(BindShape {
        out,
        inconsistent,
        computed_normals,
        morph,
        tangents,
        extent,
    })
}

/// Area-weighted vertex normals of a triangle list (zero where a vertex has no area).
pub fn vertex_normals(positions: &[Vec3], indices: &[u32]) -> Vec<Vec3> {
    let mut normals = vec![Vec3::ZERO; positions.len()];
    for tri in indices.chunks_exact(3) {
        let [a, b, c] = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
        if a >= positions.len() || b >= positions.len() || c >= positions.len() {
            continue;
        }
        let n = (positions[b] - positions[a]).cross(positions[c] - positions[a]);
        normals[a] += n;
        normals[b] += n;
        normals[c] += n;
    }
    normals.iter().map(|n| n.normalize_or_zero()).collect()
}

/// Gives `out` its materials (one per distinct primitive material, in order of first use; a
/// primitive without one gets [`Material::default`]), each with its textures decoded, the
/// primitives' triangle ranges, and the texture coordinates each material is drawn with
/// (transformed) as `out.uvs`. Problems are warnings: the fish then keeps its factors.
fn resolve_materials(
    scene: &GltfScene,
    primitives: &[ScenePrimitive],
    out: &mut SkinnedMesh,
    warnings: &mut Vec<String>,
) {
    // Distinct scene materials in order of first use, and each primitive's slot.
    let mut used: Vec<Option<usize>> = Vec::new();
    let mut slot_of = Vec::with_capacity(primitives.len());
    for p in primitives {
        let m = p.material.filter(|&m| m < scene.materials.len());
        let slot = match used.iter().position(|&u| u == m) {
            Some(s) => s,
            None => {
                used.push(m);
                used.len() - 1
            }
        };
        slot_of.push(slot);
    }
    if used.is_empty() {
        used.push(None);
    }
    let mut first_index = 0u32;
    out.parts = primitives
        .iter()
        .zip(&slot_of)
        .map(|(p, &slot)| {
            let part = MeshPart {
                first_index,
                num_indices: p.indices.len() as u32,
                material: slot as u16,
            };
            first_index += part.num_indices;
            part
        })
        .collect();
    out.materials = used
        .iter()
        .map(|&m| {
            let Some(scene_material) = m.map(|m| &scene.materials[m]) else {
                return Material::default();
            };
            let set = scene_material.uv_source().map_or(0, |s| s.0 as usize);
            let has_uvs = primitives.iter().all(|p| {
                p.material != m
                    || p.tex_coords
                        .get(set)
                        .is_some_and(|t| t.len() == p.positions.len())
            });
            scene_material.resolve(&scene.path, has_uvs, warnings)
        })
        .collect();
    if !out.materials.iter().any(Material::has_textures) {
        return;
    }
    let mut uvs = Vec::with_capacity(out.positions.len());
    for (p, &slot) in primitives.iter().zip(&slot_of) {
        let source = used[slot]
            .and_then(|m| scene.materials[m].uv_source())
            .filter(|_| out.materials[slot].has_textures());
        match source.and_then(|(set, t)| Some((p.tex_coords.get(set as usize)?, t))) {
            Some((coords, transform)) if coords.len() == p.positions.len() => {
                let mut coords = coords.clone();
                transform_uvs(&mut coords, &transform);
                uvs.extend(coords);
            }
            _ => uvs.extend(std::iter::repeat_n([0.0; 2], p.positions.len())),
        }
    }
    out.uvs = uvs;
}

/// MikkTSpace tangents (what glTF asks for when a file has none), one per vertex: the
/// per-corner tangents MikkTSpace makes (bevy_mikktspace) averaged over each vertex's corners
/// and made perpendicular to its normal, the handedness of the majority. Vertices of no
/// triangle, or whose coordinates give no direction, get +x.
pub fn generate_tangents(
    positions: &[Vec3],
    normals: &[Vec3],
    uvs: &[[f32; 2]],
    indices: &[u32],
) -> Vec<[f32; 4]> {
    struct Corners<'a> {
        positions: &'a [Vec3],
        normals: &'a [Vec3],
        uvs: &'a [[f32; 2]],
        indices: &'a [u32],
        sum: Vec<(Vec3, f32)>,
    }
    impl Corners<'_> {
        fn vertex(&self, face: usize, vert: usize) -> usize {
            self.indices[face * 3 + vert] as usize
        }
    }
    impl bevy_mikktspace::Geometry for Corners<'_> {
        fn num_faces(&self) -> usize {
            self.indices.len() / 3
        }
        fn num_vertices_of_face(&self, _face: usize) -> usize {
            3
        }
        fn position(&self, face: usize, vert: usize) -> [f32; 3] {
            self.positions[self.vertex(face, vert)].to_array()
        }
        fn normal(&self, face: usize, vert: usize) -> [f32; 3] {
            self.normals[self.vertex(face, vert)].to_array()
        }
        fn tex_coord(&self, face: usize, vert: usize) -> [f32; 2] {
            self.uvs[self.vertex(face, vert)]
        }
        fn set_tangent(
            &mut self,
            tangent_space: Option<bevy_mikktspace::TangentSpace>,
            face: usize,
            vert: usize,
        ) {
            if let Some(t) = tangent_space {
                let v = self.vertex(face, vert);
                let e = t.tangent_encoded();
                self.sum[v].0 += Vec3::new(e[0], e[1], e[2]);
                self.sum[v].1 += e[3];
            }
        }
    }
    let n = positions.len();
    let valid = normals.len() == n && uvs.len() == n && indices.iter().all(|&i| (i as usize) < n);
    let mut corners = Corners {
        positions,
        normals,
        uvs,
        indices: if valid { indices } else { &[] },
        sum: vec![(Vec3::ZERO, 0.0); n],
    };
    // The generator reports no error kinds (its error enum is empty).
    let _ = bevy_mikktspace::generate_tangents(&mut corners);
    corners
        .sum
        .iter()
        .enumerate()
        .map(|(v, &(t, w))| {
            let nrm = normals.get(v).copied().unwrap_or(Vec3::Z);
            let t = (t - nrm * t.dot(nrm)).normalize_or(Vec3::X);
            [t.x, t.y, t.z, if w < 0.0 { -1.0 } else { 1.0 }]
        })
        .collect()
}
