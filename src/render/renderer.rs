//! The renderer: pipelines, grow-only buffers, one palette upload each frame, and one instanced
//! draw per species and level of detail that has fish in view (plus one per species for the
//! shadows, at the coarsest level). Fish outside the view are left out of the instance buffer
//! (see [`super::lod`]).

use std::time::Instant;

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3};

use super::lod::{
    Frustum, LodLevel, LodSelector, MAX_LODS, MeshBounds, MeshLods, ShadowProjection,
};
use super::material::{self, GpuMaterial};
use super::shaders::ShaderSources;
use super::{FrameInput, Gpu, MeshId, MeshUpload, RenderError};

/// Depth buffer format.
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// The largest projected geometric error, in pixels, that a coarser level of detail may show
/// before the renderer uses a finer one (see [`Renderer::set_lod_tolerance_px`]).
pub const DEFAULT_LOD_TOLERANCE_PX: f32 = 1.0;

/// Per-stage CPU timings and counts of the last frame (times in milliseconds).
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RenderTimings {
    /// Culling, choosing levels of detail, sorting instances and writing the palette, instance
    /// and line buffers.
    pub upload_ms: f32,
    /// Recording and submitting the draw commands.
    pub draw_ms: f32,
    /// Number of draw calls in the scene pass (background, floor, one per species' shadows and
    /// one per species and level of detail with fish in view, tank edges, overlays).
    pub num_draw_calls: u32,
    /// Fish drawn (bounding sphere in or touching the view).
    pub num_fish_drawn: u32,
    /// Fish left out because their bounding sphere is wholly outside the view.
    pub num_fish_culled: u32,
    /// Fish shadows drawn (0 with [`super::Look::shadows`] off).
    pub num_shadows_drawn: u32,
    /// Fish drawn at each level of detail, full detail first.
    pub num_fish_per_lod: [u32; MAX_LODS],
    /// Triangles submitted by the fish, shadow and prop draws: instances × their level's
    /// triangles.
    pub num_triangles: u64,
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct Vertex {
    position: [f32; 3],
    normal: [f32; 3],
    color: [f32; 4],
    joints: [u16; 4],
    weights: [f32; 4],
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct InstanceRaw {
    palette_offset: u32,
    flags: u32,
    _pad: [u32; 2],
    tint: [f32; 4],
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct LineVertex {
    position: [f32; 3],
    color: [f32; 4],
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct Globals {
    view_proj: [[f32; 4]; 4],
    inv_view_proj: [[f32; 4]; 4],
    eye_time: [f32; 4],
    tank_min_fog: [f32; 4],
    tank_max_caustic: [f32; 4],
    light_dir: [f32; 4],
    water_deep: [f32; 4],
    water_shallow: [f32; 4],
}

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct ReadbackParams {
    palette_offset: u32,
    num_vertices: u32,
    _pad: [u32; 2],
}

/// A buffer that only grows (to the next power of two), so steady frames create nothing.
#[derive(Debug)]
struct GrowBuffer {
    label: &'static str,
    usage: wgpu::BufferUsages,
    buffer: wgpu::Buffer,
}

impl GrowBuffer {
    fn new(
        device: &wgpu::Device,
        label: &'static str,
        usage: wgpu::BufferUsages,
        size: u64,
    ) -> Self {
        let buffer = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some(label),
            size: size.max(256),
            usage: usage | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        Self {
            label,
            usage,
            buffer,
        }
    }

    /// Makes room for `size` bytes; true if the buffer was replaced (bind groups must follow).
    fn ensure(&mut self, device: &wgpu::Device, size: u64) -> bool {
        if size <= self.buffer.size() {
            return false;
        }
        *self = Self::new(device, self.label, self.usage, size.next_power_of_two());
        true
    }
}

#[derive(Debug)]
struct GpuMesh {
    vertices: wgpu::Buffer,
    /// Every level's indices, finest first ([`MeshLods::indices`]).
    indices: wgpu::Buffer,
    /// At least one level; the last is the coarsest (used for shadows).
    levels: Vec<LodLevel>,
    bounds: MeshBounds,
    /// This mesh's first instance bucket: one bucket per level, meshes one after the other.
    first_bucket: u32,
    num_vertices: u32,
    num_joints: u32,
    /// Base-colour texture coordinates (vertex buffer slot 2; zeros without a texture).
    uvs: wgpu::Buffer,
    /// Its material (bind group 1); blended species are drawn in the second fish pass.
    material: GpuMaterial,
}

/// Instance bucket of something not drawn (culled).
const CULLED: u32 = u32::MAX;

#[derive(Debug)]
struct Pipelines {
    background: wgpu::RenderPipeline,
    floor: wgpu::RenderPipeline,
    fish: wgpu::RenderPipeline,
    /// Fish whose material is `BLEND`: alpha blended, depth tested but not written.
    fish_blend: wgpu::RenderPipeline,
    shadows: wgpu::RenderPipeline,
    lines_fogged: wgpu::RenderPipeline,
    lines_overlay: wgpu::RenderPipeline,
    skin_readback: wgpu::ComputePipeline,
}

#[derive(Debug)]
struct Attachments {
    size: (u32, u32),
    msaa: Option<wgpu::TextureView>,
    depth: wgpu::TextureView,
}

/// Draws [`FrameInput`]s into a colour view of a fixed format (window surface or
/// [`super::OffscreenTarget`]).
#[derive(Debug)]
pub struct Renderer {
    color_format: wgpu::TextureFormat,
    sample_count: u32,
    sources: ShaderSources,
    scene_layout: wgpu::BindGroupLayout,
    material_layout: wgpu::BindGroupLayout,
    readback_layout: wgpu::BindGroupLayout,
    globals: wgpu::Buffer,
    palettes: GrowBuffer,
    instances: GrowBuffer,
    lines: GrowBuffer,
    bind_group: wgpu::BindGroup,
    pipelines: Pipelines,
    meshes: Vec<GpuMesh>,
    /// Instance buckets of every mesh's levels (the shadow buckets, one per mesh, follow).
    num_lod_buckets: u32,
    lod_tolerance_px: f32,
    attachments: Option<Attachments>,
    scratch_instances: Vec<InstanceRaw>,
    /// Per fish, then per prop: its bucket for the fish draws and for the shadow draws.
    scratch_buckets: Vec<[u32; 2]>,
    scratch_ranges: Vec<(u32, u32)>,
    scratch_props: Vec<Mat4>,
    scratch_lines: Vec<LineVertex>,
    timings: RenderTimings,
}

impl Renderer {
    /// Creates a renderer drawing into views of `color_format`, with 4× MSAA where the adapter
    /// supports it for that format (1× otherwise), using the embedded shaders.
    pub fn new(gpu: &Gpu, color_format: wgpu::TextureFormat) -> Result<Self, RenderError> {
        Self::with_shaders(gpu, color_format, ShaderSources::embedded())
    }

    /// Like [`Renderer::new`] with the given shader sources.
    pub fn with_shaders(
        gpu: &Gpu,
        color_format: wgpu::TextureFormat,
        sources: ShaderSources,
    ) -> Result<Self, RenderError> {
        let device = &gpu.device;
        let color_ok = gpu
            .adapter
            .get_texture_format_features(color_format)
            .flags
            .sample_count_supported(4);
        let depth_ok = gpu
            .adapter
            .get_texture_format_features(DEPTH_FORMAT)
            .flags
            .sample_count_supported(4);
        let sample_count = if color_ok && depth_ok { 4 } else { 1 };

        let scene_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("scene bind group layout"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::VERTEX_FRAGMENT,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::VERTEX,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Storage { read_only: true },
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
            ],
        });
        let material_layout = material::layout(device);
        let storage_entry = |binding: u32, read_only: bool| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Storage { read_only },
                has_dynamic_offset: false,
                min_binding_size: None,
            },
            count: None,
        };
        let readback_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("skin read-back bind group layout"),
            entries: &[
                storage_entry(0, true),
                storage_entry(1, true),
                wgpu::BindGroupLayoutEntry {
                    binding: 2,
                    visibility: wgpu::ShaderStages::COMPUTE,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
                storage_entry(3, false),
            ],
        });
        let globals = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("globals uniform"),
            size: std::mem::size_of::<Globals>() as u64,
            usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let palettes = GrowBuffer::new(
            device,
            "joint palettes (all fish)",
            wgpu::BufferUsages::STORAGE,
            64 * 1024,
        );
        let instances = GrowBuffer::new(
            device,
            "fish instances",
            wgpu::BufferUsages::VERTEX,
            32 * 1024,
        );
        let lines = GrowBuffer::new(
            device,
            "line vertices",
            wgpu::BufferUsages::VERTEX,
            16 * 1024,
        );
        let bind_group = make_scene_bind_group(device, &scene_layout, &globals, &palettes.buffer);
        let pipelines = build_pipelines(
            device,
            &sources,
            &scene_layout,
            &material_layout,
            &readback_layout,
            color_format,
            sample_count,
        )?;
        Ok(Self {
            color_format,
            sample_count,
            sources,
            scene_layout,
            material_layout,
            readback_layout,
            globals,
            palettes,
            instances,
            lines,
            bind_group,
            pipelines,
            meshes: Vec::new(),
            num_lod_buckets: 0,
            lod_tolerance_px: DEFAULT_LOD_TOLERANCE_PX,
            attachments: None,
            scratch_instances: Vec::new(),
            scratch_buckets: Vec::new(),
            scratch_ranges: Vec::new(),
            scratch_props: Vec::new(),
            scratch_lines: Vec::new(),
            timings: RenderTimings::default(),
        })
    }

    /// The colour format this renderer draws into.
    pub fn color_format(&self) -> wgpu::TextureFormat {
        self.color_format
    }

    /// MSAA sample count in use (4, or 1 where the adapter lacks 4×).
    pub fn sample_count(&self) -> u32 {
        self.sample_count
    }

    /// Timings and counts of the last [`Renderer::render`] or [`Renderer::encode`].
    pub fn timings(&self) -> RenderTimings {
        self.timings
    }

    /// The largest projected error, pixels, a coarser level of detail may show
    /// ([`DEFAULT_LOD_TOLERANCE_PX`] unless set).
    pub fn lod_tolerance_px(&self) -> f32 {
        self.lod_tolerance_px
    }

    /// Sets the level-of-detail tolerance in pixels: 0 draws every fish at full detail, larger
    /// values switch to coarser levels sooner. Negative or NaN counts as 0.
    pub fn set_lod_tolerance_px(&mut self, tolerance_px: f32) {
        self.lod_tolerance_px = tolerance_px.max(0.0);
    }

    /// The shader sources now in use.
    pub fn shader_sources(&self) -> &ShaderSources {
        &self.sources
    }

    /// Rebuilds every pipeline from `sources`. On a WGSL or pipeline error, returns it and keeps
    /// drawing with the previous pipelines (never panics on bad shader text).
    pub fn reload_shaders(&mut self, gpu: &Gpu, sources: ShaderSources) -> Result<(), RenderError> {
        let pipelines = build_pipelines(
            &gpu.device,
            &sources,
            &self.scene_layout,
            &self.material_layout,
            &self.readback_layout,
            self.color_format,
            self.sample_count,
        )?;
        self.pipelines = pipelines;
        self.sources = sources;
        Ok(())
    }

    /// Forgets every uploaded mesh (before uploading a restarted scene's meshes again, whose ids
    /// then start from 0 as before).
    pub fn clear_meshes(&mut self) {
        self.meshes.clear();
        self.num_lod_buckets = 0;
    }

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
        let lods = MeshLods::build(mesh);
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
        let uvs: Vec<[f32; 2]> = if mesh.uvs.is_empty() {
            vec![[0.0; 2]; n]
        } else {
            mesh.uvs
                .iter()
                .map(|uv| uv.map(|x| if x.is_finite() { x } else { 0.0 }))
                .collect()
        };
        let uv_label = format!("{} texture coordinates", mesh.label);
        let uvs = gpu
            .device
            .create_buffer_init(&wgpu::util::BufferInitDescriptor {
                label: Some(&uv_label),
                contents: bytemuck::cast_slice(&uvs),
                usage: wgpu::BufferUsages::VERTEX,
            });
        // A texture without coordinates cannot be sampled: keep the rest of the material.
        let without_uvs = mesh
            .material
            .filter(|m| mesh.uvs.is_empty() && m.base_color_texture.is_some())
            .map(|m| crate::skin::Material {
                base_color_texture: None,
                ..m.clone()
            });
        let material = material::upload(
            &gpu.device,
            &gpu.queue,
            &self.material_layout,
            mesh.label,
            without_uvs.as_ref().or(mesh.material),
        );
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
            uvs,
            material,
        });
        Ok(MeshId(self.meshes.len() as u32 - 1))
    }

    /// A mesh's levels of detail, full detail first (index ranges into its one index buffer).
    pub fn mesh_lods(&self, mesh: MeshId) -> Option<&[LodLevel]> {
        self.meshes
            .get(mesh.0 as usize)
            .map(|m| m.levels.as_slice())
    }

    /// A mesh's bind-space bounding sphere, as used for culling.
    pub fn mesh_bounds(&self, mesh: MeshId) -> Option<MeshBounds> {
        self.meshes.get(mesh.0 as usize).map(|m| m.bounds)
    }

    /// Number of joints a mesh's vertices refer to (its highest joint index + 1).
    pub fn mesh_num_joints(&self, mesh: MeshId) -> Option<u32> {
        self.meshes.get(mesh.0 as usize).map(|m| m.num_joints)
    }

    fn ensure_attachments(&mut self, device: &wgpu::Device, size: (u32, u32)) {
        if self.attachments.as_ref().is_some_and(|a| a.size == size) {
            return;
        }
        let extent = wgpu::Extent3d {
            width: size.0.max(1),
            height: size.1.max(1),
            depth_or_array_layers: 1,
        };
        let msaa = (self.sample_count > 1).then(|| {
            device
                .create_texture(&wgpu::TextureDescriptor {
                    label: Some("msaa colour"),
                    size: extent,
                    mip_level_count: 1,
                    sample_count: self.sample_count,
                    dimension: wgpu::TextureDimension::D2,
                    format: self.color_format,
                    usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                    view_formats: &[],
                })
                .create_view(&wgpu::TextureViewDescriptor::default())
        });
        let depth = device
            .create_texture(&wgpu::TextureDescriptor {
                label: Some("depth"),
                size: extent,
                mip_level_count: 1,
                sample_count: self.sample_count,
                dimension: wgpu::TextureDimension::D2,
                format: DEPTH_FORMAT,
                usage: wgpu::TextureUsages::RENDER_ATTACHMENT,
                view_formats: &[],
            })
            .create_view(&wgpu::TextureViewDescriptor::default());
        self.attachments = Some(Attachments { size, msaa, depth });
    }

    /// Checks a frame against the uploaded meshes.
    fn validate(&self, input: &FrameInput<'_>) -> Result<(), RenderError> {
        for (i, inst) in input.instances.iter().enumerate() {
            let Some(mesh) = self.meshes.get(inst.mesh.0 as usize) else {
                return Err(RenderError::InvalidFrame(format!(
                    "fish {i} uses mesh {} but only {} meshes are uploaded",
                    inst.mesh.0,
                    self.meshes.len()
                )));
            };
            let end = inst.palette_offset as usize + mesh.num_joints as usize;
            if end > input.palettes.len() {
                return Err(RenderError::InvalidFrame(format!(
                    "fish {i} needs palette entries {}..{end} but the palette has {}",
                    inst.palette_offset,
                    input.palettes.len()
                )));
            }
        }
        for (i, prop) in input.props.iter().enumerate() {
            match self.meshes.get(prop.mesh.0 as usize) {
                None => {
                    return Err(RenderError::InvalidFrame(format!(
                        "prop {i} uses mesh {} but only {} meshes are uploaded",
                        prop.mesh.0,
                        self.meshes.len()
                    )));
                }
                Some(m) if m.num_joints != 1 => {
                    return Err(RenderError::InvalidFrame(format!(
                        "prop {i} uses mesh {} with {} joints; props need one-joint meshes",
                        prop.mesh.0, m.num_joints
                    )));
                }
                Some(_) => {}
            }
        }
        Ok(())
    }

    /// Uploads the frame and records its scene pass into `encoder`, drawing into `view` (of
    /// [`Renderer::color_format`], `size` pixels). Clears the view.
    pub fn encode(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        view: &wgpu::TextureView,
        size: (u32, u32),
        input: &FrameInput<'_>,
    ) -> Result<(), RenderError> {
        self.validate(input)?;
        let device = &gpu.device;
        let queue = &gpu.queue;
        let t0 = Instant::now();
        self.ensure_attachments(device, size);

        // Globals.
        let aspect = size.0.max(1) as f32 / size.1.max(1) as f32;
        let view_proj = input.camera.view_proj(aspect);
        let eye = input.camera.eye();
        let look = &input.look;
        let light = look.light_dir.normalize_or(Vec3::Y);
        let globals = Globals {
            view_proj: view_proj.to_cols_array_2d(),
            inv_view_proj: view_proj.inverse().to_cols_array_2d(),
            eye_time: [eye.x, eye.y, eye.z, input.time_s],
            tank_min_fog: input.tank.min.extend(look.fog_density_per_unit).to_array(),
            tank_max_caustic: input.tank.max.extend(look.caustic_strength).to_array(),
            light_dir: light.extend(0.0).to_array(),
            water_deep: Vec3::from(look.water_deep).extend(1.0).to_array(),
            water_shallow: Vec3::from(look.water_shallow).extend(1.0).to_array(),
        };
        queue.write_buffer(&self.globals, 0, bytemuck::bytes_of(&globals));

        // Palettes: one upload for every fish, then one matrix per prop behind them.
        let palette_bytes: &[u8] = bytemuck::cast_slice(input.palettes);
        self.scratch_props.clear();
        self.scratch_props
            .extend(input.props.iter().map(|p| p.transform));
        let prop_bytes: &[u8] = bytemuck::cast_slice(&self.scratch_props);
        let total = (palette_bytes.len() + prop_bytes.len()) as u64;
        if self.palettes.ensure(device, total) {
            self.bind_group = make_scene_bind_group(
                device,
                &self.scene_layout,
                &self.globals,
                &self.palettes.buffer,
            );
        }
        if !palette_bytes.is_empty() {
            queue.write_buffer(&self.palettes.buffer, 0, palette_bytes);
        }
        if !prop_bytes.is_empty() {
            queue.write_buffer(
                &self.palettes.buffer,
                palette_bytes.len() as u64,
                prop_bytes,
            );
        }

        // Culling and levels of detail: each fish (then each prop) gets a bucket for its draw,
        // one per (mesh, level), and one for its shadow, one per mesh; culled ones get none.
        let frustum = Frustum::from_view_proj(&view_proj);
        let selector = LodSelector::new(
            eye,
            input.camera.fov_y_rad,
            size.1.max(1),
            self.lod_tolerance_px,
        );
        let shadow = look
            .shadows
            .then(|| ShadowProjection::new(input.tank.min.y, light));
        let num_buckets = self.num_lod_buckets as usize + self.meshes.len();
        self.scratch_ranges.clear();
        self.scratch_ranges.resize(num_buckets, (0, 0));
        self.scratch_buckets.clear();
        let mut stats = RenderTimings::default();
        let fish = input.instances.iter().map(|inst| {
            (
                inst.mesh,
                &input.palettes[inst.palette_offset as usize],
                true,
            )
        });
        let props = input.props.iter().map(|p| (p.mesh, &p.transform, false));
        for (mesh_id, joint0, is_fish) in fish.chain(props) {
            let mesh = &self.meshes[mesh_id.0 as usize];
            let (sphere, scale) = mesh.bounds.world_sphere(joint0);
            let draw = if frustum.intersects(sphere) {
                let lod = selector.select(&mesh.levels, sphere, scale);
                if is_fish {
                    stats.num_fish_drawn += 1;
                    stats.num_fish_per_lod[lod] += 1;
                }
                mesh.first_bucket + lod as u32
            } else {
                if is_fish {
                    stats.num_fish_culled += 1;
                }
                CULLED
            };
            let shade = match shadow {
                Some(projection) if frustum.intersects(projection.project(sphere)) => {
                    if is_fish {
                        stats.num_shadows_drawn += 1;
                    }
                    self.num_lod_buckets + mesh_id.0
                }
                _ => CULLED,
            };
            for bucket in [draw, shade] {
                if bucket != CULLED {
                    self.scratch_ranges[bucket as usize].1 += 1;
                }
            }
            self.scratch_buckets.push([draw, shade]);
        }

        // Instances grouped by bucket: a counting sort into reused scratch.
        let mut start = 0;
        for r in &mut self.scratch_ranges {
            r.0 = start;
            start += r.1;
            r.1 = r.0; // becomes the fill cursor, then the end
        }
        self.scratch_instances.clear();
        self.scratch_instances
            .resize(start as usize, InstanceRaw::zeroed());
        let fish = input.instances.iter().map(|inst| InstanceRaw {
            palette_offset: inst.palette_offset,
            flags: u32::from(inst.selected),
            _pad: [0; 2],
            tint: [inst.tint[0], inst.tint[1], inst.tint[2], 1.0],
        });
        let first_prop = input.palettes.len() as u32;
        let props = input.props.iter().enumerate().map(|(k, p)| InstanceRaw {
            palette_offset: first_prop + k as u32,
            flags: 0,
            _pad: [0; 2],
            tint: [p.tint[0], p.tint[1], p.tint[2], 1.0],
        });
        for (raw, buckets) in fish.chain(props).zip(&self.scratch_buckets) {
            for &bucket in buckets {
                if bucket != CULLED {
                    let r = &mut self.scratch_ranges[bucket as usize];
                    self.scratch_instances[r.1 as usize] = raw;
                    r.1 += 1;
                }
            }
        }
        let instance_bytes: &[u8] = bytemuck::cast_slice(&self.scratch_instances);
        self.instances.ensure(device, instance_bytes.len() as u64);
        if !instance_bytes.is_empty() {
            queue.write_buffer(&self.instances.buffer, 0, instance_bytes);
        }

        // Lines: tank edges (fogged, depth tested) then overlays (on top).
        self.scratch_lines.clear();
        push_box_edges(
            &mut self.scratch_lines,
            input.tank.min,
            input.tank.max,
            [0.3, 0.5, 0.55, 0.55],
        );
        let num_tank_lines = self.scratch_lines.len() as u32;
        for l in input.overlay {
            self.scratch_lines.push(LineVertex {
                position: l.a.to_array(),
                color: l.color,
            });
            self.scratch_lines.push(LineVertex {
                position: l.b.to_array(),
                color: l.color,
            });
        }
        let num_lines = self.scratch_lines.len() as u32;
        let line_bytes: &[u8] = bytemuck::cast_slice(&self.scratch_lines);
        self.lines.ensure(device, line_bytes.len() as u64);
        queue.write_buffer(&self.lines.buffer, 0, line_bytes);
        let t1 = Instant::now();

        let Some(att) = self.attachments.as_ref() else {
            return Err(RenderError::InvalidFrame("no attachments".into()));
        };
        let (color_view, resolve) = match &att.msaa {
            Some(msaa) => (msaa, Some(view)),
            None => (view, None),
        };
        let mut draws = 0;
        {
            let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
                label: Some("scene pass"),
                color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                    view: color_view,
                    depth_slice: None,
                    resolve_target: resolve,
                    ops: wgpu::Operations {
                        load: wgpu::LoadOp::Clear(wgpu::Color::BLACK),
                        store: if resolve.is_some() {
                            wgpu::StoreOp::Discard
                        } else {
                            wgpu::StoreOp::Store
                        },
                    },
                })],
                depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                    view: &att.depth,
                    depth_ops: Some(wgpu::Operations {
                        load: wgpu::LoadOp::Clear(1.0),
                        store: wgpu::StoreOp::Discard,
                    }),
                    stencil_ops: None,
                }),
                timestamp_writes: None,
                occlusion_query_set: None,
                multiview_mask: None,
            });
            pass.set_bind_group(0, &self.bind_group, &[]);
            pass.set_pipeline(&self.pipelines.background);
            pass.draw(0..3, 0..1);
            pass.set_pipeline(&self.pipelines.floor);
            pass.draw(0..6, 0..1);
            draws += 2;

            pass.set_vertex_buffer(1, self.instances.buffer.slice(..));
            let mut triangles = 0u64;
            if input.look.shadows {
                // Shadows are small and dark: always the coarsest level.
                pass.set_pipeline(&self.pipelines.shadows);
                let shadow_ranges = &self.scratch_ranges[self.num_lod_buckets as usize..];
                for (mesh, &(begin, end)) in self.meshes.iter().zip(shadow_ranges) {
                    let Some(level) = mesh.levels.last().filter(|_| end > begin) else {
                        continue;
                    };
                    pass.set_bind_group(1, &mesh.material.bind_group, &[]);
                    pass.set_vertex_buffer(0, mesh.vertices.slice(..));
                    pass.set_vertex_buffer(2, mesh.uvs.slice(..));
                    pass.set_index_buffer(mesh.indices.slice(..), wgpu::IndexFormat::Uint32);
                    pass.draw_indexed(level_range(level), 0, begin..end);
                    triangles += u64::from(level.num_triangles()) * u64::from(end - begin);
                    draws += 1;
                }
            }
            // Opaque and masked species first, then blended ones over them.
            for blend_pass in [false, true] {
                pass.set_pipeline(if blend_pass {
                    &self.pipelines.fish_blend
                } else {
                    &self.pipelines.fish
                });
                for mesh in self
                    .meshes
                    .iter()
                    .filter(|m| m.material.blend == blend_pass)
                {
                    let first = mesh.first_bucket as usize;
                    let ranges = &self.scratch_ranges[first..first + mesh.levels.len()];
                    if ranges.iter().all(|&(begin, end)| end == begin) {
                        continue;
                    }
                    pass.set_bind_group(1, &mesh.material.bind_group, &[]);
                    pass.set_vertex_buffer(0, mesh.vertices.slice(..));
                    pass.set_vertex_buffer(2, mesh.uvs.slice(..));
                    pass.set_index_buffer(mesh.indices.slice(..), wgpu::IndexFormat::Uint32);
                    for (level, &(begin, end)) in mesh.levels.iter().zip(ranges) {
                        if end > begin {
                            pass.draw_indexed(level_range(level), 0, begin..end);
                            triangles += u64::from(level.num_triangles()) * u64::from(end - begin);
                            draws += 1;
                        }
                    }
                }
            }
            stats.num_triangles = triangles;

            pass.set_vertex_buffer(0, self.lines.buffer.slice(..));
            pass.set_pipeline(&self.pipelines.lines_fogged);
            pass.draw(0..num_tank_lines, 0..1);
            draws += 1;
            if num_lines > num_tank_lines {
                pass.set_pipeline(&self.pipelines.lines_overlay);
                pass.draw(num_tank_lines..num_lines, 0..1);
                draws += 1;
            }
        }
        let t2 = Instant::now();
        self.timings = RenderTimings {
            upload_ms: (t1 - t0).as_secs_f32() * 1e3,
            draw_ms: (t2 - t1).as_secs_f32() * 1e3,
            num_draw_calls: draws,
            ..stats
        };
        Ok(())
    }

    /// Uploads and draws one frame into `view` and submits it.
    pub fn render(
        &mut self,
        gpu: &Gpu,
        view: &wgpu::TextureView,
        size: (u32, u32),
        input: &FrameInput<'_>,
    ) -> Result<(), RenderError> {
        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("frame encoder"),
            });
        self.encode(gpu, &mut encoder, view, size, input)?;
        let t = Instant::now();
        gpu.queue.submit([encoder.finish()]);
        self.timings.draw_ms += t.elapsed().as_secs_f32() * 1e3;
        Ok(())
    }

    /// Skins `mesh`'s bind-pose positions on the GPU with `palettes[palette_offset..]`, using the
    /// same WGSL skinning function as the vertex shader, and reads them back (world space).
    ///
    /// For tests and tools: allocates its buffers per call.
    pub fn skin_positions(
        &self,
        gpu: &Gpu,
        mesh: MeshId,
        palettes: &[Mat4],
        palette_offset: u32,
    ) -> Result<Vec<Vec3>, RenderError> {
        use wgpu::util::DeviceExt;
        let Some(m) = self.meshes.get(mesh.0 as usize) else {
            return Err(RenderError::InvalidFrame(format!("no mesh {}", mesh.0)));
        };
        if palette_offset as usize + m.num_joints as usize > palettes.len() {
            return Err(RenderError::InvalidFrame(format!(
                "mesh needs {} palette entries from {palette_offset}, palette has {}",
                m.num_joints,
                palettes.len()
            )));
        }
        let device = &gpu.device;
        let palette_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("read-back palette"),
            contents: bytemuck::cast_slice(palettes),
            usage: wgpu::BufferUsages::STORAGE,
        });
        let params = ReadbackParams {
            palette_offset,
            num_vertices: m.num_vertices,
            _pad: [0; 2],
        };
        let params_buf = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("read-back params"),
            contents: bytemuck::bytes_of(&params),
            usage: wgpu::BufferUsages::UNIFORM,
        });
        let out_size = u64::from(m.num_vertices) * 16;
        let out_buf = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("skinned positions (GPU)"),
            size: out_size,
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
            mapped_at_creation: false,
        });
        let staging = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("skinned positions staging"),
            size: out_size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("skin read-back bind group"),
            layout: &self.readback_layout,
            entries: &[
                wgpu::BindGroupEntry {
                    binding: 0,
                    resource: m.vertices.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 1,
                    resource: palette_buf.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 2,
                    resource: params_buf.as_entire_binding(),
                },
                wgpu::BindGroupEntry {
                    binding: 3,
                    resource: out_buf.as_entire_binding(),
                },
            ],
        });
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("skin read-back encoder"),
        });
        {
            let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
                label: Some("skin read-back pass"),
                timestamp_writes: None,
            });
            pass.set_pipeline(&self.pipelines.skin_readback);
            pass.set_bind_group(0, &bind_group, &[]);
            pass.dispatch_workgroups(m.num_vertices.div_ceil(64), 1, 1);
        }
        encoder.copy_buffer_to_buffer(&out_buf, 0, &staging, 0, out_size);
        gpu.queue.submit([encoder.finish()]);
        let words = map_read(gpu, &staging)?;
        let floats: &[f32] = bytemuck::cast_slice(&words);
        Ok(floats
            .chunks_exact(4)
            .map(|c| Vec3::new(c[0], c[1], c[2]))
            .collect())
    }
}

/// The index range of one level of detail.
fn level_range(level: &LodLevel) -> std::ops::Range<u32> {
    level.first_index..level.first_index + level.num_indices
}

/// Maps a `MAP_READ` buffer, waits, and copies its bytes out.
pub(super) fn map_read(gpu: &Gpu, buffer: &wgpu::Buffer) -> Result<Vec<u8>, RenderError> {
    let (tx, rx) = std::sync::mpsc::channel();
    buffer.map_async(wgpu::MapMode::Read, .., move |r| {
        let _ = tx.send(r);
    });
    gpu.device
        .poll(wgpu::PollType::Wait {
            submission_index: None,
            timeout: None,
        })
        .map_err(|e| RenderError::Readback(e.to_string()))?;
    rx.recv()
        .map_err(|e| RenderError::Readback(e.to_string()))?
        .map_err(|e| RenderError::Readback(e.to_string()))?;
    let bytes = buffer
        .slice(..)
        .get_mapped_range()
        .map_err(|e| RenderError::Readback(e.to_string()))?
        .to_vec();
    buffer.unmap();
    Ok(bytes)
}

fn make_scene_bind_group(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    globals: &wgpu::Buffer,
    palettes: &wgpu::Buffer,
) -> wgpu::BindGroup {
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("scene bind group"),
        layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: globals.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: palettes.as_entire_binding(),
            },
        ],
    })
}

fn push_box_edges(out: &mut Vec<LineVertex>, min: Vec3, max: Vec3, color: [f32; 4]) {
    let c = |i: usize| {
        Vec3::new(
            if i & 1 == 0 { min.x } else { max.x },
            if i & 2 == 0 { min.y } else { max.y },
            if i & 4 == 0 { min.z } else { max.z },
        )
    };
    for a in 0..8usize {
        for bit in [1usize, 2, 4] {
            if a & bit == 0 {
                for p in [c(a), c(a | bit)] {
                    out.push(LineVertex {
                        position: p.to_array(),
                        color,
                    });
                }
            }
        }
    }
}

/// Compiles every pipeline inside a validation error scope so a bad shader returns an error.
fn build_pipelines(
    device: &wgpu::Device,
    sources: &ShaderSources,
    scene_layout: &wgpu::BindGroupLayout,
    material_layout: &wgpu::BindGroupLayout,
    readback_layout: &wgpu::BindGroupLayout,
    color_format: wgpu::TextureFormat,
    sample_count: u32,
) -> Result<Pipelines, RenderError> {
    let module =
        |file: &str, common: bool, skinning: bool| -> Result<wgpu::ShaderModule, RenderError> {
            let text = sources.compose(file, common, skinning);
            let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
            let m = device.create_shader_module(wgpu::ShaderModuleDescriptor {
                label: Some(file),
                source: wgpu::ShaderSource::Wgsl(text.into()),
            });
            match pollster::block_on(scope.pop()) {
                None => Ok(m),
                Some(e) => Err(RenderError::Shader {
                    file: file.to_owned(),
                    message: format!(
                        "{e}\n(the compiled text joins files: {})",
                        sources.line_map(file, common, skinning)
                    ),
                }),
            }
        };
    let fish_mod = module("fish.wgsl", true, true)?;
    let env_mod = module("environment.wgsl", true, false)?;
    let lines_mod = module("lines.wgsl", true, false)?;
    let readback_mod = module("skin_readback.wgsl", false, true)?;

    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let scene_pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("scene pipeline layout"),
        bind_group_layouts: &[Some(scene_layout)],
        immediate_size: 0,
    });
    let fish_pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("fish pipeline layout"),
        bind_group_layouts: &[Some(scene_layout), Some(material_layout)],
        immediate_size: 0,
    });
    let readback_pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
        label: Some("skin read-back pipeline layout"),
        bind_group_layouts: &[Some(readback_layout)],
        immediate_size: 0,
    });
    let multisample = wgpu::MultisampleState {
        count: sample_count,
        mask: !0,
        alpha_to_coverage_enabled: false,
    };
    let depth = |write: bool, compare: wgpu::CompareFunction| {
        Some(wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(write),
            depth_compare: Some(compare),
            stencil: wgpu::StencilState::default(),
            bias: wgpu::DepthBiasState::default(),
        })
    };
    let opaque = [Some(wgpu::ColorTargetState {
        format: color_format,
        blend: None,
        write_mask: wgpu::ColorWrites::ALL,
    })];
    let blended = [Some(wgpu::ColorTargetState {
        format: color_format,
        blend: Some(wgpu::BlendState::ALPHA_BLENDING),
        write_mask: wgpu::ColorWrites::ALL,
    })];
    let tri = wgpu::PrimitiveState::default();
    let simple = |label: &str,
                  layout: &wgpu::PipelineLayout,
                  module: &wgpu::ShaderModule,
                  vs: &str,
                  fs: &str,
                  buffers: &[Option<wgpu::VertexBufferLayout<'_>>],
                  primitive: wgpu::PrimitiveState,
                  depth_stencil: Option<wgpu::DepthStencilState>,
                  targets: &[Option<wgpu::ColorTargetState>]| {
        device.create_render_pipeline(&wgpu::RenderPipelineDescriptor {
            label: Some(label),
            layout: Some(layout),
            vertex: wgpu::VertexState {
                module,
                entry_point: Some(vs),
                compilation_options: Default::default(),
                buffers,
            },
            primitive,
            depth_stencil,
            multisample,
            fragment: Some(wgpu::FragmentState {
                module,
                entry_point: Some(fs),
                compilation_options: Default::default(),
                targets,
            }),
            multiview_mask: None,
            cache: None,
        })
    };
    let background = simple(
        "background pipeline",
        &scene_pl,
        &env_mod,
        "vs_background",
        "fs_background",
        &[],
        tri,
        depth(false, wgpu::CompareFunction::Always),
        &opaque,
    );
    let floor = simple(
        "floor pipeline",
        &scene_pl,
        &env_mod,
        "vs_floor",
        "fs_floor",
        &[],
        tri,
        depth(true, wgpu::CompareFunction::Less),
        &opaque,
    );
    let vertex_attrs = wgpu::vertex_attr_array![
        0 => Float32x3, 1 => Float32x3, 2 => Float32x4, 3 => Uint16x4, 4 => Float32x4
    ];
    let instance_attrs = wgpu::vertex_attr_array![5 => Uint32, 6 => Uint32, 7 => Float32x4];
    // The instance's tint sits after 8 bytes of padding: give attribute 7 its real offset.
    let instance_attrs = [
        instance_attrs[0],
        instance_attrs[1],
        wgpu::VertexAttribute {
            format: wgpu::VertexFormat::Float32x4,
            offset: 16,
            shader_location: 7,
        },
    ];
    let uv_attrs = wgpu::vertex_attr_array![8 => Float32x2];
    // Fish and their shadows read the same mesh vertices, per-instance data and texture
    // coordinates.
    let fish_buffers = [
        Some(wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<Vertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &vertex_attrs,
        }),
        Some(wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<InstanceRaw>() as u64,
            step_mode: wgpu::VertexStepMode::Instance,
            attributes: &instance_attrs,
        }),
        Some(wgpu::VertexBufferLayout {
            array_stride: 8,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &uv_attrs,
        }),
    ];
    let fish = simple(
        "fish pipeline",
        &fish_pl,
        &fish_mod,
        "vs_main",
        "fs_main",
        &fish_buffers,
        wgpu::PrimitiveState {
            cull_mode: None,
            ..Default::default()
        },
        depth(true, wgpu::CompareFunction::Less),
        &opaque,
    );
    // BLEND materials: after every opaque fish, blended over them, depth tested against them
    // but not written, so blended fins show through each other and from both sides.
    let fish_blend = simple(
        "blended fish pipeline",
        &fish_pl,
        &fish_mod,
        "vs_main",
        "fs_main",
        &fish_buffers,
        wgpu::PrimitiveState {
            cull_mode: None,
            ..Default::default()
        },
        depth(false, wgpu::CompareFunction::Less),
        &blended,
    );
    // Multiply the floor by the shadow's shade; depth tested against the floor, not written.
    let multiply = [Some(wgpu::ColorTargetState {
        format: color_format,
        blend: Some(wgpu::BlendState {
            color: wgpu::BlendComponent {
                src_factor: wgpu::BlendFactor::Zero,
                dst_factor: wgpu::BlendFactor::Src,
                operation: wgpu::BlendOperation::Add,
            },
            alpha: wgpu::BlendComponent::OVER,
        }),
        write_mask: wgpu::ColorWrites::ALL,
    })];
    let shadows = simple(
        "fish shadow pipeline",
        &fish_pl,
        &fish_mod,
        "vs_shadow",
        "fs_shadow",
        &fish_buffers,
        wgpu::PrimitiveState {
            cull_mode: None,
            ..Default::default()
        },
        depth(false, wgpu::CompareFunction::LessEqual),
        &multiply,
    );
    let line_attrs = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x4];
    let line_buffers = [Some(wgpu::VertexBufferLayout {
        array_stride: std::mem::size_of::<LineVertex>() as u64,
        step_mode: wgpu::VertexStepMode::Vertex,
        attributes: &line_attrs,
    })];
    let lines_prim = wgpu::PrimitiveState {
        topology: wgpu::PrimitiveTopology::LineList,
        ..Default::default()
    };
    let lines_fogged = simple(
        "tank edge lines pipeline",
        &scene_pl,
        &lines_mod,
        "vs_line",
        "fs_line_fogged",
        &line_buffers,
        lines_prim,
        depth(true, wgpu::CompareFunction::Less),
        &blended,
    );
    let lines_overlay = simple(
        "overlay lines pipeline",
        &scene_pl,
        &lines_mod,
        "vs_line",
        "fs_line_overlay",
        &line_buffers,
        lines_prim,
        depth(false, wgpu::CompareFunction::Always),
        &blended,
    );
    let skin_readback = device.create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
        label: Some("skin read-back pipeline"),
        layout: Some(&readback_pl),
        module: &readback_mod,
        entry_point: Some("cs_skin"),
        compilation_options: Default::default(),
        cache: None,
    });
    if let Some(e) = pollster::block_on(scope.pop()) {
        return Err(RenderError::Shader {
            file: "(pipeline)".into(),
            message: e.to_string(),
        });
    }
    Ok(Pipelines {
        background,
        floor,
        fish,
        fish_blend,
        shadows,
        lines_fogged,
        lines_overlay,
        skin_readback,
    })
}
