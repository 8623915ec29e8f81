//! Mesh uploads: checked, levels of detail built, vertex, index and texture-coordinate buffers
//! and the material created.

use super::{GpuMesh, Renderer, SurfaceVertex, Vertex};
use crate::lod::{LodLevel, MeshBounds, MeshLods, split_levels_by_material};
use crate::material;
use crate::{Gpu, MeshId, MeshUpload, RenderError};

impl Renderer {
    /// Uploads one species' mesh; the returned id is used by [`super::FishInstance::mesh`].
    /// Builds its levels of detail ([`MeshLods::build`]) and bounding sphere on the way.
    pub fn upload_mesh(&mut self, gpu: &Gpu, mesh: &MeshUpload<'_>) -> Result<MeshId, RenderError> {
        let bad = |why: String| RenderError::InvalidMesh {
            label: mesh.label.to_owned(),
            why,
        };
        let n = mesh.positions.len();
        for (name, len) in [
            ("normals", mesh.normals.len()),
            ("colors", mesh.colors.len()),
            ("joints", mesh.joints.len()),
            ("weights", mesh.weights.len()),
        ] {
            if len != n {
                return Err(bad(format!(
                    "{name} has {len} entries but positions has {n}"
                )));
            }
        }
        if !mesh.uvs.is_empty() && mesh.uvs.len() != n {
            return Err(bad(format!(
                "uvs has {} entries but positions has {n}",
                mesh.uvs.len()
            )));
        }
        if !mesh.tangents.is_empty() && mesh.tangents.len() != n {
            return Err(bad(format!(
                "tangents has {} entries but positions has {n}",
                mesh.tangents.len()
            )));
        }
        let num_materials = mesh.materials.len().max(1);
        for (k, part) in mesh.parts.iter().enumerate() {
            let end = u64::from(part.first_index) + u64::from(part.num_indices);
            if end > mesh.indices.len() as u64 || usize::from(part.material) >= num_materials {
                return Err(bad(format!(
                    "part {k} (indices {}..{end}, material {}) is outside the {} indices or {num_materials} materials",
                    part.first_index,
                    part.material,
                    mesh.indices.len()
                )));
            }
        }
        if n == 0 || mesh.indices.is_empty() {
            return Err(bad("no vertices or no indices".into()));
        }
        if !mesh.indices.len().is_multiple_of(3) {
            return Err(bad(format!(
                "{} indices is not a whole number of triangles",
                mesh.indices.len()
            )));
        }
        if let Some((i, &ix)) = mesh
            .indices
            .iter()
            .enumerate()
            .find(|(_, ix)| **ix as usize >= n)
        {
            return Err(bad(format!(
                "index {i} is {ix}, but there are only {n} vertices"
            )));
        }
        let finite = |v: &[f32]| v.iter().all(|x| x.is_finite());
        if let Some(i) = (0..n).find(|&i| {
            !finite(&mesh.positions[i]) || !finite(&mesh.normals[i]) || !finite(&mesh.weights[i])
        }) {
            return Err(bad(format!("vertex {i} has a NaN or infinite value")));
        }
        let num_joints = mesh
            .joints
            .iter()
            .flat_map(|j| j.iter())
            .map(|&j| u32::from(j) + 1)
            .max()
            .unwrap_or(1);
        let vertices: Vec<Vertex> = (0..n)
            .map(|i| Vertex {
                position: mesh.positions[i],
                normal: mesh.normals[i],
                color: mesh.colors[i],
                joints: mesh.joints[i],
                weights: mesh.weights[i],
            })
            .collect();
        let mut lods = MeshLods::build(mesh);
        // Each vertex's material, from the parts (material 0 outside them).
        let mut vertex_material = vec![0u16; n];
        for part in mesh.parts {
            let range = part.first_index as usize..(part.first_index + part.num_indices) as usize;
            for &i in &mesh.indices[range] {
                vertex_material[i as usize] = part.material;
            }
        }
        let shadow_level = lods.shadow_level();
        let mut level_parts = split_levels_by_material(
            &mut lods.indices,
            &[lods.levels.as_slice(), lods.shadow.as_slice()].concat(),
            &vertex_material,
        );
        let shadow_parts = if lods.shadow.is_some() {
            level_parts.pop().unwrap_or_default()
        } else {
            level_parts.last().cloned().unwrap_or_default()
        };
        use wgpu::util::DeviceExt;
        let vertex_label = format!("{} vertices", mesh.label);
        let index_label = format!("{} indices", mesh.label);
        let vertices = gpu
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(&vertex_label),
                contents: bytemuck::cast_slice(&vertices),
                usage: wgpu::BufferUsages::VERTEX | wgpu::BufferUsages::STORAGE,
            });
        let indices = gpu
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(&index_label),
                contents: bytemuck::cast_slice(&lods.indices),
                usage: wgpu::BufferUsages::INDEX,
            });
        let clean = |x: f32| if x.is_finite() { x } else { 0.0 };
        let surface: Vec<SurfaceVertex> = (0..n)
            .map(|i| SurfaceVertex {
                uv: mesh.uvs.get(i).map_or([0.0; 2], |uv| uv.map(clean)),
                tangent: mesh.tangents.get(i).map_or([0.0; 4], |t| t.map(clean)),
            })
            .collect();
        let surface_label = format!("{} texture coordinates and tangents", mesh.label);
        let surface = gpu
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(&surface_label),
                contents: bytemuck::cast_slice(&surface),
                usage: wgpu::BufferUsages::VERTEX,
            });
        // Textures without coordinates cannot be sampled: keep the rest of the material.
        let plain: Vec<shoal_core::skin::Material> = mesh
            .materials
            .iter()
            .map(|m| {
                if mesh.uvs.is_empty() && m.has_textures() {
                    m.without_textures()
                } else {
                    m.clone()
                }
            })
            .collect();
        let materials: Vec<_> = (0..num_materials)
            .map(|k| {
                let label = format!("{} material {k}", mesh.label);
                material::upload(
                    &gpu.device,
                    &gpu.queue,
                    &self.material_layout,
                    &label,
                    plain.get(k),
                    !mesh.tangents.is_empty(),
                )
            })
            .collect();
        // The instances are checked against the meshes: again with this one.
        self.checked_instances = None;
        let first_bucket = self.num_lod_buckets;
        self.num_lod_buckets += lods.levels.len() as u32;
        self.meshes.push(GpuMesh {
            vertices,
            indices,
            levels: lods.levels,
            bounds: MeshBounds::from_positions(mesh.positions),
            first_bucket,
            num_vertices: n as u32,
            num_joints,
            surface,
            materials,
            level_parts,
            shadow_level,
            shadow_parts,
        });
        Ok(MeshId(self.meshes.len() as u32 - 1))
    }

    /// A mesh's levels of detail, full detail first (index ranges into its one index buffer).
    pub fn mesh_lods(&self, mesh: MeshId) -> Option<&[LodLevel]> {
        self.meshes
            .get(mesh.0 as usize)
            .map(|m| m.levels.as_slice())
    }

    /// The level a mesh's shadows are drawn with.
    pub fn mesh_shadow_level(&self, id: MeshId) -> Option<LodLevel> {
        self.meshes.get(id.0 as usize).map(|m| m.shadow_level)
    }

    /// Number of joints a mesh's vertices refer to (its highest joint index + 1).
    pub fn mesh_num_joints(&self, mesh: MeshId) -> Option<u32> {
        self.meshes.get(mesh.0 as usize).map(|m| m.num_joints)
    }
}
