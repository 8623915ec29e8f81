//! [`RiggedMesh`]: a skinned triangle mesh with a joint hierarchy, written as a GLB that the
//! Khronos validator accepts with no warnings. Shared by the fish generator and the auto-rigger.

use glam::{Mat4, Vec3};
use serde_json::{Value, json};

use super::glb::GlbBuilder;

/// Up to four (joint, weight) pairs per vertex: joint indices into [`RiggedMesh::joint_names`].
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Influences {
    /// Joint indices; unused slots are 0 with weight 0.
    pub joints: [u16; 4],
    /// Weights, strongest first, summing to 1.
    pub weights: [f32; 4],
}

impl Influences {
    /// Normalizes a list of (joint, weight) pairs: merges duplicate joints, drops non-positive
    /// weights, keeps the four strongest (ties: lower joint first), renormalizes so the f32 sum
    /// is exactly 1. Falls back to `fallback` with weight 1 when nothing is left.
    pub fn from_pairs(pairs: &[(u16, f32)], fallback: u16) -> Self {
        let mut merged: [(u16, f32); 12] = [(0, 0.0); 12];
        let mut n = 0;
        for &(j, w) in pairs {
            if w.is_nan() || w <= 0.0 {
                continue;
            }
            if let Some(m) = merged[..n].iter_mut().find(|m| m.0 == j) {
                m.1 += w;
            } else if n < merged.len() {
                merged[n] = (j, w);
                n += 1;
            }
        }
        let list = &mut merged[..n];
        list.sort_by(|a, b| b.1.total_cmp(&a.1).then(a.0.cmp(&b.0)));
        let kept = &list[..n.min(4)];
        let total: f32 = kept.iter().map(|k| k.1).sum();
        if kept.is_empty() || total.is_nan() || total <= 0.0 {
            return Self {
                joints: [fallback, 0, 0, 0],
                weights: [1.0, 0.0, 0.0, 0.0],
            };
        }
        let mut out = Self::default();
        let mut sum = 0.0f32;
        for (k, &(j, w)) in kept.iter().enumerate() {
            out.joints[k] = j;
            out.weights[k] = w / total;
        }
        // Drop influences too small to matter, then make the sum exactly 1 in f32.
        let mut last = 0;
        for k in 0..4 {
            if out.weights[k] < 1e-3 {
                out.weights[k] = 0.0;
                out.joints[k] = 0;
            } else {
                last = k;
            }
        }
        for k in 0..4 {
            if k != last {
                sum += out.weights[k];
            }
        }
        out.weights[last] = 1.0 - sum;
        out
    }
}

/// A skinned mesh with its skeleton, in asset space (glTF: +Y up, +Z forward).
#[derive(Debug, Clone, Default)]
pub struct RiggedMesh {
    /// Node name of the mesh node.
    pub name: String,
    /// Joint names, parent-first.
    pub joint_names: Vec<String>,
    /// Parent of each joint (index into the same list), none for the root.
    pub joint_parents: Vec<Option<usize>>,
    /// Rest position of each joint in asset space (joints are unrotated at rest).
    pub joint_positions: Vec<Vec3>,
    /// Vertex positions.
    pub positions: Vec<Vec3>,
    /// Unit vertex normals.
    pub normals: Vec<Vec3>,
    /// Linear RGBA vertex colours (multiplied with the material's base colour).
    pub colors: Vec<[f32; 4]>,
    /// Optional texture coordinates (set 0).
    pub uvs: Option<Vec<[f32; 2]>>,
    /// Optional tangents (xyz unit, w = ±1 handedness), written when a normal map needs them.
    pub tangents: Option<Vec<[f32; 4]>>,
    /// Skin influences per vertex.
    pub influences: Vec<Influences>,
    /// Triangle list.
    pub indices: Vec<u32>,
    /// Consecutive triangle ranges drawn with their own material: (number of indices, index
    /// into the [`MaterialSet`]'s materials), in index order, written as one primitive each
    /// (sharing the vertex attributes). Empty: one primitive with [`MaterialSet::material`].
    pub parts: Vec<(usize, usize)>,
}

/// What the file's `materials`, `textures`, `images` and `samplers` are; `material` is the index
/// the primitive uses (when the mesh has no [`RiggedMesh::parts`]). Images are embedded as buffer views (`bytes`, MIME type).
#[derive(Debug, Clone)]
pub struct MaterialSet {
    /// glTF `materials` array.
    pub materials: Value,
    /// glTF `textures` array (may be empty).
    pub textures: Value,
    /// glTF `samplers` array (may be empty).
    pub samplers: Value,
    /// Embedded images: bytes and MIME type.
    pub images: Vec<(Vec<u8>, String)>,
    /// Material used by the mesh's primitive.
    pub material: usize,
}

impl MaterialSet {
    /// One PBR material with a base colour factor, metallic and roughness.
    pub fn pbr(name: &str, base_color: [f32; 4], metallic: f32, roughness: f32) -> Self {
        Self {
            materials: json!([{
                "name": name,
                "pbrMetallicRoughness": {
                    "baseColorFactor": base_color,
                    "metallicFactor": metallic,
                    "roughnessFactor": roughness
                }
            }]),
            textures: json!([]),
            samplers: json!([]),
            images: Vec::new(),
            material: 0,
        }
    }
}

impl RiggedMesh {
    /// Writes the mesh as a GLB: node 0 is the mesh node (a scene root, identity transform),
    /// nodes 1.. are the joints in order; one skin whose IBMs are the inverse rest poses.
    pub fn to_glb(&self, materials: &MaterialSet, generator: &str) -> Vec<u8> {
        let mut b = GlbBuilder::new();
        let pos = b.positions(&self.positions);
        let nor = b.vec3s(&self.normals);
        let col = b.colors_u8(&self.colors);
        let joints: Vec<[u16; 4]> = self.influences.iter().map(|i| i.joints).collect();
        let weights: Vec<[f32; 4]> = self.influences.iter().map(|i| i.weights).collect();
        let jnt = b.joints(&joints);
        let wgt = b.vec4s(&weights);
        let uv = self.uvs.as_ref().map(|uv| b.vec2s(uv));
        let mut ranges: Vec<(std::ops::Range<usize>, usize)> = Vec::new();
        let mut at = 0;
        for &(count, material) in &self.parts {
            let end = (at + count).min(self.indices.len());
            ranges.push((at..end, material));
            at = end;
        }
        if ranges.is_empty() {
            ranges.push((0..self.indices.len(), materials.material));
        }
        let idx: Vec<(usize, usize)> = ranges
            .iter()
            .map(|(r, m)| (b.indices(&self.indices[r.clone()]), *m))
            .collect();
        let ibms: Vec<Mat4> = self
            .joint_positions
            .iter()
            .map(|p| Mat4::from_translation(-*p))
            .collect();
        let ibm = b.mat4s(&ibms);

        let mut attributes = json!({
            "POSITION": pos, "NORMAL": nor, "COLOR_0": col, "JOINTS_0": jnt, "WEIGHTS_0": wgt
        });
        if let Some(uv) = uv {
            attributes["TEXCOORD_0"] = json!(uv);
        }
        if let Some(t) = &self.tangents {
            attributes["TANGENT"] = json!(b.vec4s(t));
        }
        let mut nodes = vec![json!({"name": self.name, "mesh": 0, "skin": 0})];
        for (j, name) in self.joint_names.iter().enumerate() {
            let local = match self.joint_parents[j] {
                Some(p) => self.joint_positions[j] - self.joint_positions[p],
                None => self.joint_positions[j],
            };
            let mut node = json!({"name": name, "translation": local.to_array()});
            let children: Vec<usize> = (0..self.joint_names.len())
                .filter(|&c| self.joint_parents[c] == Some(j))
                .map(|c| c + 1)
                .collect();
            if !children.is_empty() {
                node["children"] = json!(children);
            }
            nodes.push(node);
        }
        let roots: Vec<usize> = std::iter::once(0)
            .chain(
                (0..self.joint_names.len())
                    .filter(|&j| self.joint_parents[j].is_none())
                    .map(|j| j + 1),
            )
            .collect();
        let mut images = Vec::new();
        for (bytes, mime) in &materials.images {
            let view = b.image_view(bytes);
            images.push(json!({"bufferView": view, "mimeType": mime}));
        }
        let mut root = json!({
            "asset": {"version": "2.0", "generator": generator},
            "scene": 0,
            "scenes": [{"name": self.name, "nodes": roots}],
            "nodes": nodes,
            "meshes": [{"name": self.name, "primitives": idx.iter().map(|&(indices, material)| json!({
                "attributes": attributes, "indices": indices, "material": material, "mode": 4
            })).collect::<Vec<_>>()}],
            "materials": materials.materials,
            "skins": [{
                "name": format!("{}_skin", self.name),
                "inverseBindMatrices": ibm,
                "joints": (1..=self.joint_names.len()).collect::<Vec<_>>(),
                "skeleton": roots.get(1).copied().unwrap_or(1)
            }]
        });
        if !images.is_empty() {
            root["images"] = Value::Array(images);
        }
        // Material extensions (KHR_texture_transform, KHR_materials_unlit …) must be declared.
        let mut used = std::collections::BTreeSet::new();
        extension_names(&materials.materials, &mut used);
        if !used.is_empty() {
            root["extensionsUsed"] = json!(used);
        }
        if materials.textures.as_array().is_some_and(|t| !t.is_empty()) {
            root["textures"] = materials.textures.clone();
        }
        if materials.samplers.as_array().is_some_and(|t| !t.is_empty()) {
            root["samplers"] = materials.samplers.clone();
        }
        b.finish(root)
    }
}

/// Collects the keys of every `extensions` object inside `v`.
fn extension_names(v: &Value, out: &mut std::collections::BTreeSet<String>) {
    match v {
        Value::Object(map) => {
            for (k, child) in map {
                if k == "extensions"
                    && let Value::Object(exts) = child
                {
                    out.extend(exts.keys().cloned());
                }
                extension_names(child, out);
            }
        }
        Value::Array(items) => items.iter().for_each(|c| extension_names(c, out)),
        _ => {}
    }
}
