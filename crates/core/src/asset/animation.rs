//! A school as glTF 2.0 skeletal animation (issue 38): what `shoal export` writes, for
//! Blender, Unreal, Unity, Godot and three.js.
//!
//! Layout of the document, per fish (`fish_3`, or `fish_3_g1` for generation 1 of slot 3):
//!
//! ```text
//! fish_3            translation, rotation (and scale) animated: the root (head end of the
//!  │                spine) and Ry(heading)·Rz(pitch), exactly shoal's `root_matrix`;
//!  │                `extras.shoal`: id, species, behaviour, body length, when it is present
//!  └ fish_3_body    static: the species' model → body transform (scale, axes, head at 0)
//!     └ fish_3_<joint> …  the skeleton's joints, at their rest translation and scale; the
//!                         driven (vertebral) joints' rotations are animated
//! fish_3_mesh       a scene root (glTF skins ignore a skinned node's own transform and the
//!                   validator warns when it has a parent): the species' mesh, skinned by the
//!                   fish's own skin (its joints, the species' inverse bind matrices)
//! ```
//!
//! Each species' mesh, materials and inverse bind matrices are written once and shared by its
//! fish (instancing); each fish has its own skin, since a skin names its joint nodes.
//!
//! One animation (`school`) holds every channel, all on one set of key times: per fish the
//! root's translation and rotation (LINEAR; rotations kept in one hemisphere key to key, so
//! interpolation takes the short way) and each driven joint's rotation. Joints that are not
//! driven hold their rest rotation in shoal's pose ([`crate::species::SpeciesRig::pose`]
//! copies it), which is the node's own rotation, so they get no channel.
//!
//! A fish that is not in the world at every key (spawned or despawned during the exported
//! span) gets a STEP `scale` channel, 0 while absent and 1 while present: scale 0 collapses its
//! joints, and the skinned mesh with them, onto the root. While absent its other channels hold
//! the nearest present key, so nothing flies across the tank as it appears.

use glam::{Mat4, Quat, Vec3};
use serde_json::{Value, json};

use super::GlbBuilder;
use crate::skeleton::NO_PARENT;
use crate::skin::{AlphaMode, FishModel, TextureImage};
use crate::species::SpeciesRig;

/// A species as the document instances it.
#[derive(Debug, Clone, Copy)]
pub struct AnimSpecies<'a> {
    /// Its name (the mesh's name).
    pub name: &'a str,
    /// Its model: skeleton, inverse bind poses, mesh, materials.
    pub model: &'a FishModel,
    /// Its rig: model → body transform and the driven joints.
    pub rig: &'a SpeciesRig,
}

/// One fish's animation, sampled at the document's key times.
#[derive(Debug, Clone, PartialEq)]
pub struct FishTrack {
    /// Node name stem: `fish_<index>` (`fish_<index>_g<generation>` after the slot's reuse).
    pub name: String,
    /// Index into [`SchoolAnimation::species`].
    pub species: usize,
    /// `extras.shoal` of the fish's node.
    pub extras: Value,
    /// Whether the fish is in the world at each key.
    pub present: Vec<bool>,
    /// Root translation at each key (world units).
    pub translation: Vec<Vec3>,
    /// Root rotation at each key.
    pub rotation: Vec<Quat>,
    /// Driven joints' local rotations, key after key: `keys × rig.driven_joints.len()`.
    pub joint_rotations: Vec<Quat>,
}

impl FishTrack {
    /// An empty track of `keys` keys with `driven` driven joints, absent everywhere.
    pub fn new(name: String, species: usize, extras: Value, keys: usize, driven: usize) -> Self {
        Self {
            name,
            species,
            extras,
            present: vec![false; keys],
            translation: vec![Vec3::ZERO; keys],
            rotation: vec![Quat::IDENTITY; keys],
            joint_rotations: vec![Quat::IDENTITY; keys * driven],
        }
    }

    /// Fills the keys where the fish is absent with the nearest present key (earlier ones
    /// from the first present key, later ones from the last before them), and keeps each
    /// rotation in the hemisphere of the key before it.
    pub fn settle(&mut self, driven: usize) {
        let keys = self.present.len();
        let Some(first) = self.present.iter().position(|&p| p) else {
            return;
        };
        let mut last = first;
        for k in 0..keys {
            if self.present[k] {
                last = k;
                continue;
            }
            let from = if k < first { first } else { last };
            self.translation[k] = self.translation[from];
            self.rotation[k] = self.rotation[from];
            let (src, dst) = (from * driven, k * driven);
            for j in 0..driven {
                self.joint_rotations[dst + j] = self.joint_rotations[src + j];
            }
        }
        for k in 1..keys {
            if self.rotation[k].dot(self.rotation[k - 1]) < 0.0 {
                self.rotation[k] = -self.rotation[k];
            }
            for j in 0..driven {
                let (a, b) = ((k - 1) * driven + j, k * driven + j);
                if self.joint_rotations[b].dot(self.joint_rotations[a]) < 0.0 {
                    self.joint_rotations[b] = -self.joint_rotations[b];
                }
            }
        }
    }
}

/// A static prop: a mesh of its own at a place.
#[derive(Debug, Clone, PartialEq)]
pub enum Prop {
    /// A rock (the world's obstacle sphere).
    Rock {
        /// Centre, world units.
        centre: Vec3,
        /// Radius, world units.
        radius: f32,
    },
    /// A food pellet where it is at the first key.
    Food {
        /// Position, world units.
        pos: Vec3,
        /// Radius drawn, world units.
        radius: f32,
    },
    /// The tank's edges (lines).
    Tank {
        /// Lower corner.
        min: Vec3,
        /// Upper corner.
        max: Vec3,
    },
}

/// What the document is of.
#[derive(Debug, Clone)]
pub struct SchoolAnimation<'a> {
    /// The species, instanced by index.
    pub species: Vec<AnimSpecies<'a>>,
    /// Key times, seconds from the start of the animation, increasing.
    pub times: Vec<f32>,
    /// The fish.
    pub fish: Vec<FishTrack>,
    /// Static props.
    pub props: Vec<Prop>,
    /// `extras.shoal` of the scene (where it came from).
    pub extras: Value,
}

/// A written document: JSON plus binary buffer, still to be packed.
pub struct SchoolDocument {
    builder: GlbBuilder,
    root: Value,
}

impl SchoolDocument {
    /// As one binary glTF (`.glb`).
    pub fn to_glb(self) -> Vec<u8> {
        self.builder.finish(self.root)
    }

    /// As a `.gltf` JSON text and the binary buffer it names `bin_uri`.
    pub fn to_gltf(self, bin_uri: &str) -> (Vec<u8>, Vec<u8>) {
        self.builder.finish_gltf(self.root, bin_uri)
    }

    /// Bytes of binary data.
    pub fn bin_len(&self) -> usize {
        self.builder.bin_len()
    }
}

/// Bytes one key of one fish takes in the animation data: translation, rotation and scale,
/// and a rotation per driven joint.
pub fn key_bytes(driven: usize) -> usize {
    (3 + 4 + 1 + 4 * driven) * 4
}

fn quat_array(q: Quat) -> [f32; 4] {
    q.to_array()
}

/// The species' mesh and materials: returns the mesh index.
fn write_species(
    b: &mut GlbBuilder,
    s: &AnimSpecies<'_>,
    materials: &mut Vec<Value>,
    textures: &mut Vec<Value>,
    images: &mut Vec<Value>,
    samplers: &mut Vec<Value>,
    meshes: &mut Vec<Value>,
) -> usize {
    let m = &s.model.mesh;
    let pos = b.positions(&m.positions);
    let nor = b.vec3s(&m.normals);
    let col = b.vec4s(&m.colors);
    let jnt = b.joints(&m.joints);
    let wgt = b.vec4s(&m.weights);
    let mut attributes = json!({
        "POSITION": pos, "NORMAL": nor, "COLOR_0": col, "JOINTS_0": jnt, "WEIGHTS_0": wgt
    });
    if !m.uvs.is_empty() && m.uvs.len() == m.positions.len() {
        attributes["TEXCOORD_0"] = json!(b.vec2s(&m.uvs));
    }
    let first_material = materials.len();
    for mat in &m.materials {
        // The vertex colours already hold baseColorFactor (see `SkinnedMesh::colors`), so
        // the factor here is white: glTF multiplies COLOR_0 by it.
        let mut pbr = json!({
            "baseColorFactor": [1.0, 1.0, 1.0, 1.0],
            "metallicFactor": mat.metallic,
            "roughnessFactor": mat.roughness,
        });
        if let Some(tex) = &mat.base_color_texture
            && let Some(png) = png_of(tex)
        {
            let view = b.image_view(&png);
            images.push(json!({"bufferView": view, "mimeType": "image/png"}));
            samplers.push(sampler_json(tex));
            textures.push(json!({"source": images.len() - 1, "sampler": samplers.len() - 1}));
            pbr["baseColorTexture"] = json!({"index": textures.len() - 1});
        }
        let mut out = json!({
            "name": mat.name.clone().unwrap_or_else(|| format!("{}_material", s.name)),
            "pbrMetallicRoughness": pbr,
            "doubleSided": mat.double_sided,
        });
        match mat.alpha_mode {
            AlphaMode::Opaque => {}
            AlphaMode::Mask { cutoff } => {
                out["alphaMode"] = json!("MASK");
                out["alphaCutoff"] = json!(cutoff);
            }
            AlphaMode::Blend => out["alphaMode"] = json!("BLEND"),
        }
        if mat.emissive.iter().any(|&e| e > 0.0) {
            out["emissiveFactor"] = json!(mat.emissive.map(|e| e.clamp(0.0, 1.0)));
        }
        if mat.unlit {
            out["extensions"] = json!({"KHR_materials_unlit": {}});
        }
        materials.push(out);
    }
    if m.materials.is_empty() {
        materials.push(json!({"name": format!("{}_material", s.name)}));
    }
    let mut primitives = Vec::new();
    if m.parts.is_empty() {
        let idx = b.indices(&m.indices);
        primitives.push(json!({
            "attributes": attributes, "indices": idx, "material": first_material, "mode": 4
        }));
    }
    for part in &m.parts {
        let start = part.first_index as usize;
        let end = (start + part.num_indices as usize).min(m.indices.len());
        let idx = b.indices(&m.indices[start..end]);
        let material =
            first_material + usize::from(part.material).min(m.materials.len().max(1) - 1);
        primitives.push(json!({
            "attributes": attributes, "indices": idx, "material": material, "mode": 4
        }));
    }
    meshes.push(json!({"name": s.name, "primitives": primitives}));
    meshes.len() - 1
}

fn png_of(tex: &TextureImage) -> Option<Vec<u8>> {
    let img = image::RgbaImage::from_raw(tex.width, tex.height, tex.rgba.clone())?;
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).ok()?;
    Some(out.into_inner())
}

fn sampler_json(tex: &TextureImage) -> Value {
    use crate::skin::material::Wrap;
    let wrap = |w: Wrap| match w {
        Wrap::Repeat => 10497,
        Wrap::Mirror => 33648,
        Wrap::Clamp => 33071,
    };
    let s = tex.sampler;
    let mag = if s.mag_linear { 9729 } else { 9728 };
    let min = match (s.mipmaps, s.min_linear, s.mip_linear) {
        (false, false, _) => 9728,
        (false, true, _) => 9729,
        (true, false, false) => 9984,
        (true, true, false) => 9985,
        (true, false, true) => 9986,
        (true, true, true) => 9987,
    };
    json!({"wrapS": wrap(s.wrap_u), "wrapT": wrap(s.wrap_v), "magFilter": mag, "minFilter": min})
}

/// A UV sphere (`rings` × `segments`) of unit radius: positions (= normals) and indices.
fn sphere(rings: u32, segments: u32) -> (Vec<Vec3>, Vec<u32>) {
    let mut pos = Vec::new();
    for r in 0..=rings {
        let theta = std::f32::consts::PI * r as f32 / rings as f32;
        for s in 0..=segments {
            let phi = std::f32::consts::TAU * s as f32 / segments as f32;
            pos.push(Vec3::new(
                theta.sin() * phi.cos(),
                theta.cos(),
                theta.sin() * phi.sin(),
            ));
        }
    }
    let mut idx = Vec::new();
    let w = segments + 1;
    for r in 0..rings {
        for s in 0..segments {
            let (a, b) = (r * w + s, (r + 1) * w + s);
            idx.extend([a, a + 1, b, a + 1, b + 1, b]);
        }
    }
    (pos, idx)
}

/// The document's props: meshes (a shared unit sphere per kind, the tank's lines) and nodes.
fn write_props(
    b: &mut GlbBuilder,
    props: &[Prop],
    materials: &mut Vec<Value>,
    meshes: &mut Vec<Value>,
    nodes: &mut Vec<Value>,
    scene: &mut Vec<usize>,
) {
    if props.is_empty() {
        return;
    }
    let (sp, si) = sphere(12, 24);
    let pos = b.positions(&sp);
    let nor = b.vec3s(&sp);
    let idx = b.indices(&si);
    let mut sphere_mesh = |name: &str, color: [f32; 4], roughness: f32| {
        materials.push(json!({
            "name": name,
            "pbrMetallicRoughness": {
                "baseColorFactor": color, "metallicFactor": 0.0, "roughnessFactor": roughness
            }
        }));
        meshes.push(json!({"name": name, "primitives": [{
            "attributes": {"POSITION": pos, "NORMAL": nor}, "indices": idx,
            "material": materials.len() - 1, "mode": 4
        }]}));
        meshes.len() - 1
    };
    let rock = sphere_mesh("rock", [0.35, 0.33, 0.3, 1.0], 0.9);
    let pellet = sphere_mesh("food", [0.8, 0.55, 0.2, 1.0], 0.6);
    let (mut rocks, mut foods) = (0, 0);
    for p in props {
        match *p {
            Prop::Rock { centre, radius } => {
                nodes.push(json!({
                    "name": format!("rock_{rocks}"), "mesh": rock,
                    "translation": centre.to_array(), "scale": [radius, radius, radius]
                }));
                rocks += 1;
            }
            Prop::Food { pos, radius } => {
                nodes.push(json!({
                    "name": format!("food_{foods}"), "mesh": pellet,
                    "translation": pos.to_array(), "scale": [radius, radius, radius]
                }));
                foods += 1;
            }
            Prop::Tank { min, max } => {
                let corners: Vec<Vec3> = (0..8)
                    .map(|i| {
                        Vec3::new(
                            if i & 1 == 0 { min.x } else { max.x },
                            if i & 2 == 0 { min.y } else { max.y },
                            if i & 4 == 0 { min.z } else { max.z },
                        )
                    })
                    .collect();
                let edges: Vec<u32> = vec![
                    0, 1, 2, 3, 4, 5, 6, 7, 0, 2, 1, 3, 4, 6, 5, 7, 0, 4, 1, 5, 2, 6, 3, 7,
                ];
                let cp = b.positions(&corners);
                let ci = b.indices(&edges);
                materials.push(json!({
                    "name": "tank",
                    "pbrMetallicRoughness": {"baseColorFactor": [0.6, 0.8, 0.9, 1.0]}
                }));
                meshes.push(json!({"name": "tank", "primitives": [{
                    "attributes": {"POSITION": cp}, "indices": ci,
                    "material": materials.len() - 1, "mode": 1
                }]}));
                nodes.push(json!({"name": "tank", "mesh": meshes.len() - 1}));
            }
        }
        scene.push(nodes.len() - 1);
    }
}

impl SchoolAnimation<'_> {
    /// Writes the document (see the module docs). `progress(done, total)` is called after each
    /// fish's channels.
    pub fn write(&self, generator: &str, progress: &mut dyn FnMut(usize, usize)) -> SchoolDocument {
        let mut b = GlbBuilder::new();
        let (mut materials, mut textures, mut images, mut samplers, mut meshes) =
            (Vec::new(), Vec::new(), Vec::new(), Vec::new(), Vec::new());
        let mut species_mesh = Vec::with_capacity(self.species.len());
        let mut species_ibm = Vec::with_capacity(self.species.len());
        for s in &self.species {
            let mesh = write_species(
                &mut b,
                s,
                &mut materials,
                &mut textures,
                &mut images,
                &mut samplers,
                &mut meshes,
            );
            species_mesh.push(mesh);
            species_ibm.push(b.mat4s(&s.model.inverse_bind_poses));
        }
        let keys = self.times.len();
        let times = b.key_times(&self.times);
        let mut nodes: Vec<Value> = Vec::new();
        let mut scene: Vec<usize> = Vec::new();
        let mut skins: Vec<Value> = Vec::new();
        let mut samplers_anim: Vec<Value> = Vec::new();
        let mut channels: Vec<Value> = Vec::new();
        let total = self.fish.len();
        for (done, f) in self.fish.iter().enumerate() {
            let s = &self.species[f.species];
            let skel = &s.model.skeleton;
            let n = skel.num_joints();
            let fish_node = nodes.len();
            let body_node = fish_node + 1;
            let first_joint = fish_node + 2;
            let mesh_node = first_joint + n;
            let (scale, rotation, translation) =
                s.rig.model_to_body.to_scale_rotation_translation();
            let mut fish = json!({
                "name": f.name,
                "children": [body_node],
                "translation": f.translation.first().copied().unwrap_or(Vec3::ZERO).to_array(),
                "rotation": quat_array(f.rotation.first().copied().unwrap_or(Quat::IDENTITY)),
                "extras": {"shoal": f.extras},
            });
            let always = f.present.iter().all(|&p| p);
            if !always {
                let s0 = if f.present.first().copied().unwrap_or(false) {
                    1.0
                } else {
                    0.0
                };
                fish["scale"] = json!([s0, s0, s0]);
            }
            nodes.push(fish);
            let roots: Vec<usize> = (0..n)
                .filter(|&j| skel.parents()[j] == NO_PARENT)
                .map(|j| first_joint + j)
                .collect();
            nodes.push(json!({
                "name": format!("{}_body", f.name),
                "translation": translation.to_array(),
                "rotation": quat_array(rotation),
                "scale": scale.to_array(),
                "children": roots,
            }));
            let mut animated_rest: Vec<Option<usize>> = vec![None; n];
            for (k, &j) in s.rig.driven_joints.iter().enumerate() {
                animated_rest[j] = Some(k);
            }
            let driven = s.rig.driven_joints.len();
            for (j, animated) in animated_rest.iter().enumerate() {
                let rest = skel.rest_locals()[j];
                let rotation = match *animated {
                    Some(k) if keys > 0 => f.joint_rotations[k],
                    _ => rest.rotation,
                };
                let mut node = json!({
                    "name": format!("{}_{}", f.name, super::sanitize_name(&skel.names()[j])),
                    "translation": rest.translation.to_array(),
                    "rotation": quat_array(rotation),
                    "scale": rest.scale.to_array(),
                });
                let children: Vec<usize> = (0..n)
                    .filter(|&c| usize::from(skel.parents()[c]) == j)
                    .map(|c| first_joint + c)
                    .collect();
                if !children.is_empty() {
                    node["children"] = json!(children);
                }
                nodes.push(node);
            }
            nodes.push(json!({
                "name": format!("{}_mesh", f.name),
                "mesh": species_mesh[f.species],
                "skin": skins.len(),
            }));
            skins.push(json!({
                "name": format!("{}_skin", f.name),
                "inverseBindMatrices": species_ibm[f.species],
                "joints": (first_joint..first_joint + n).collect::<Vec<_>>(),
                "skeleton": body_node,
            }));
            scene.push(fish_node);
            scene.push(mesh_node);
            if keys == 0 {
                continue;
            }
            let mut channel = |b: &mut GlbBuilder,
                               node: usize,
                               path: &str,
                               data: &[f32],
                               ty: &str,
                               step: bool| {
                let out = b.key_values(data, keys, ty);
                samplers_anim.push(json!({
                    "input": times, "output": out,
                    "interpolation": if step { "STEP" } else { "LINEAR" }
                }));
                channels.push(json!({
                    "sampler": samplers_anim.len() - 1,
                    "target": {"node": node, "path": path}
                }));
            };
            let t: Vec<f32> = f.translation.iter().flat_map(|v| v.to_array()).collect();
            channel(&mut b, fish_node, "translation", &t, "VEC3", false);
            let r: Vec<f32> = f.rotation.iter().flat_map(|q| q.to_array()).collect();
            channel(&mut b, fish_node, "rotation", &r, "VEC4", false);
            if !always {
                let sc: Vec<f32> = f
                    .present
                    .iter()
                    .flat_map(|&p| [f32::from(u8::from(p)); 3])
                    .collect();
                channel(&mut b, fish_node, "scale", &sc, "VEC3", true);
            }
            for (k, &j) in s.rig.driven_joints.iter().enumerate() {
                let q: Vec<f32> = (0..keys)
                    .flat_map(|i| f.joint_rotations[i * driven + k].to_array())
                    .collect();
                channel(&mut b, first_joint + j, "rotation", &q, "VEC4", false);
            }
            progress(done + 1, total);
        }
        write_props(
            &mut b,
            &self.props,
            &mut materials,
            &mut meshes,
            &mut nodes,
            &mut scene,
        );
        let mut root = json!({
            "asset": {"version": "2.0", "generator": generator},
            "scene": 0,
            "scenes": [{"name": "school", "nodes": scene, "extras": {"shoal": self.extras}}],
            "nodes": nodes,
            "meshes": meshes,
            "materials": materials,
        });
        if !skins.is_empty() {
            root["skins"] = Value::Array(skins);
        }
        if !channels.is_empty() {
            root["animations"] = json!([{
                "name": "school", "samplers": samplers_anim, "channels": channels
            }]);
        }
        if !images.is_empty() {
            root["images"] = Value::Array(images);
            root["textures"] = Value::Array(textures);
            root["samplers"] = Value::Array(samplers);
        }
        if materials_use_unlit(&root) {
            root["extensionsUsed"] = json!(["KHR_materials_unlit"]);
        }
        SchoolDocument { builder: b, root }
    }
}

fn materials_use_unlit(root: &Value) -> bool {
    root["materials"].as_array().is_some_and(|m| {
        m.iter()
            .any(|m| m["extensions"]["KHR_materials_unlit"].is_object())
    })
}

/// Every joint's world matrix of a fish posed with root translation `t`, rotation `r` and
/// driven-joint rotations `driven` (in `rig.driven_joints` order), through the same node
/// hierarchy the document writes: fish node · model → body · joint locals.
pub fn joint_world_matrices(
    model: &FishModel,
    rig: &SpeciesRig,
    t: Vec3,
    r: Quat,
    driven: &[Quat],
) -> Vec<Mat4> {
    let skel = &model.skeleton;
    let mut locals = skel.rest_locals().to_vec();
    for (&j, &q) in rig.driven_joints.iter().zip(driven) {
        locals[j].rotation = q;
    }
    let top = Mat4::from_rotation_translation(r, t) * rig.model_to_body;
    let mut out: Vec<Mat4> = Vec::with_capacity(locals.len());
    for (j, l) in locals.iter().enumerate() {
        let parent = skel.parents()[j];
        let p = if parent == NO_PARENT {
            top
        } else {
            out[usize::from(parent)]
        };
        out.push(p * l.to_mat4());
    }
    out
}
