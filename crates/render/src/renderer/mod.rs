//! The renderer: pipelines, grow-only buffers, one palette upload each frame, and one instanced
//! draw per species, material and level of detail that has fish in view (plus one per species
//! and material for the shadows, at the coarsest level). Fish outside the view are left out of the instance buffer
//! (see [`super::lod`]).
//!
//! This file holds the renderer's state and its set-up; the steps live beside it:
//! [`pipelines`] (shader modules and pipelines), [`upload`] (meshes), [`encode`] (one frame:
//! uploads, culling and levels of detail, the scene pass) and [`readback`] (GPU skinning read
//! back for tests).

mod cull_pass;
mod encode;
mod pipelines;
mod pose_pass;
mod readback;
mod records;
mod upload;

pub use encode::FramePart;

use std::time::Instant;

use bytemuck::{Pod, Zeroable};
use glam::Mat4;

use super::lod::{LodLevel, MAX_LODS, MeshBounds};
use super::material::{self, GpuMaterial};
use super::shaders::ShaderSources;
use super::{FrameInput, Gpu, RenderError};
use cull_pass::CullBuffers;
pub use cull_pass::Culling;
use pipelines::{Layouts, build_pipelines};
use pose_pass::fish_palette_len;
pub(super) use readback::map_read;

/// Depth buffer format.
const DEPTH_FORMAT: wgpu::TextureFormat = wgpu::TextureFormat::Depth32Float;

/// The largest projected geometric error, in pixels, that a coarser level of detail may show
/// before the renderer uses a finer one (see [`Renderer::set_lod_tolerance_px`]).
pub const DEFAULT_LOD_TOLERANCE_PX: f32 = 1.0;

/// Per-stage CPU timings and counts of the last frame (times in milliseconds).
///
/// The times, [`RenderTimings::num_draw_calls`] and the record figures are those of frame
/// [`RenderTimings::frame`]. The counts (fish drawn, culled, per level, shadows, triangles,
/// draws that drew something) are those of frame [`RenderTimings::counts_frame`]: the same
/// frame on the CPU path and after [`Renderer::read_gpu_counts`]; culled on the GPU and read
/// without waiting (the window), an earlier one, or 0 while none has been read back yet.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct RenderTimings {
    /// The frame these timings are from: 1 for the renderer's first, counting every
    /// [`Renderer::encode`] (or [`Renderer::render`]).
    pub frame: u64,
    /// The frame the counts are from (see above); 0: no counts yet.
    pub counts_frame: u64,
    /// Checking the frame before the upload: each instance's mesh and palette range (once per
    /// [`crate::FrameInput::instances_revision`]; every frame without one), the GPU pose pass's
    /// records (every frame: they change as the fish move) and the props.
    pub check_ms: f32,
    /// Culling, choosing levels of detail, sorting instances and writing the palette, instance
    /// and line buffers.
    pub upload_ms: f32,
    /// Of `upload_ms`, writing the GPU pose pass's per-fish records and recording the pass (0
    /// without it): one record a fish a frame while the simulation runs on the CPU.
    pub pose_upload_ms: f32,
    /// Of `upload_ms`, culling and levels of detail: on the CPU ([`Culling::Cpu`]) choosing
    /// each instance's draws and writing the instances sorted by draw; on the GPU
    /// ([`Culling::Gpu`]) bringing the per-instance records up to date and recording the
    /// culling pass.
    pub cull_ms: f32,
    /// Of `cull_ms`, on the GPU path: comparing each fish's and prop's record (palette
    /// offset, mesh, tint, selected) with the one the GPU holds from earlier frames and writing
    /// the changed ones; the props' alone while the instances' revision stays the same. 0 on
    /// the CPU path.
    pub records_ms: f32,
    /// On the GPU path, records written this frame: every one in the first frame (or after
    /// the buffer grew), then only those that changed (0 in a steady frame, however the fish
    /// move: a move changes the palette, not the record). 0 on the CPU path.
    pub num_records_written: u32,
    /// Recording and submitting the draw commands.
    pub draw_ms: f32,
    /// Draw calls recorded in the scene pass: background, floor, tank edges, overlays, and the
    /// fish and shadow draws. On the CPU path those are one per mesh, level of detail with
    /// fish in view and material, and per mesh and material with shadows in view (near and
    /// outline); on the GPU path every mesh's, level's and material's draw is recorded
    /// (indirect, its instance count written by the culling pass, 0 for a level no fish uses).
    pub num_draw_calls: u32,
    /// Of those, the draws that drew something (of frame `counts_frame`): on the CPU path all
    /// of them; on the GPU path the indirect ones whose instance count was not 0, besides the
    /// background, floor and lines.
    pub num_nonempty_draw_calls: u32,
    /// Fish drawn (bounding sphere in or touching the view).
    pub num_fish_drawn: u32,
    /// Fish left out because their bounding sphere is wholly outside the view.
    pub num_fish_culled: u32,
    /// Fish shadows drawn (0 with [`super::Look::shadows`] off).
    pub num_shadows_drawn: u32,
    /// Of those, the shadows drawn at the mesh's outline level (fish coarser than
    /// [`crate::lod::NEAR_SHADOW_LOD`]); the others are at that level.
    pub num_outline_shadows: u32,
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
    /// Every level's indices, finest first ([`MeshLods::indices`](super::lod::MeshLods::indices)).
    indices: wgpu::Buffer,
    /// At least one level; the last is the coarsest.
    levels: Vec<LodLevel>,
    bounds: MeshBounds,
    /// This mesh's first instance bucket: one bucket per level, meshes one after the other.
    first_bucket: u32,
    num_vertices: u32,
    num_joints: u32,
    /// Texture coordinates and tangents (vertex buffer slot 2, [`SurfaceVertex`]; zeros where
    /// the mesh has none).
    surface: wgpu::Buffer,
    /// Its materials (bind group 1 each); blended ones are drawn in the second fish pass.
    materials: Vec<GpuMaterial>,
    /// Per level of detail, its index ranges by material (one draw each).
    level_parts: Vec<Vec<shoal_core::skin::MeshPart>>,
    /// The level shadows are drawn with ([`MeshLods::shadow_level`](super::lod::MeshLods::shadow_level)).
    shadow_level: LodLevel,
    /// Its index ranges by material.
    shadow_parts: Vec<shoal_core::skin::MeshPart>,
}

/// Vertex buffer slot 2 of the fish pipelines: texture coordinates and tangent.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct SurfaceVertex {
    uv: [f32; 2],
    tangent: [f32; 4],
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
    /// The GPU pose pass (`pose.wgsl`).
    pose: wgpu::ComputePipeline,
    /// The GPU culling pass (`cull.wgsl`): per record, once, per record.
    cull_count: wgpu::ComputePipeline,
    cull_offsets: wgpu::ComputePipeline,
    cull_scatter: wgpu::ComputePipeline,
}

/// The GPU pose pass's input buffers (grow-only) and its uniform.
#[derive(Debug)]
struct PoseBuffers {
    fish: GrowBuffer,
    programs: GrowBuffer,
    models: GrowBuffer,
    slots: GrowBuffer,
    samples: GrowBuffer,
    params: wgpu::Buffer,
}

impl PoseBuffers {
    fn new(device: &wgpu::Device) -> Self {
        let storage = |label| GrowBuffer::new(device, label, wgpu::BufferUsages::STORAGE, 4096);
        Self {
            fish: storage("pose pass: fish records"),
            programs: storage("pose pass: species programs"),
            models: storage("pose pass: model steps"),
            slots: storage("pose pass: palette slots"),
            samples: storage("pose pass: shape samples"),
            params: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("pose pass: params"),
                size: 16,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
        }
    }
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
    scene_layout: wgpu::BindGroupLayout,
    material_layout: wgpu::BindGroupLayout,
    readback_layout: wgpu::BindGroupLayout,
    pose_layout: wgpu::BindGroupLayout,
    draw_layout: wgpu::BindGroupLayout,
    cull_layout: wgpu::BindGroupLayout,
    globals: wgpu::Buffer,
    palettes: GrowBuffer,
    /// The GPU pose pass's inputs (see [`super::GpuPoseFrame`]), written each frame it runs.
    pose: PoseBuffers,
    /// Every draw's instances, grouped by draw (written by the CPU or by the culling pass).
    instances: GrowBuffer,
    /// Per bucket, at [`Renderer::draw_base_stride`] bytes: its first instance in `instances`
    /// (`DrawBase` in `fish.wgsl`, bound by dynamic offset per draw).
    draw_bases: GrowBuffer,
    /// Bytes between two buckets' entries of `draw_bases` (the adapter's uniform offset
    /// alignment).
    draw_base_stride: u32,
    /// Group 2 of the fish pipelines: `instances` and `draw_bases`.
    draw_bind_group: wgpu::BindGroup,
    /// The GPU culling pass's buffers.
    cull: CullBuffers,
    culling: Culling,
    culling_supported: bool,
    /// Whether the last frame was culled on the GPU (its counts are still there).
    last_frame_gpu_culled: bool,
    /// The instances last checked: their [`FrameInput::instances_revision`], number, and the
    /// meshes and fish palette entries they were checked against. A frame that matches all
    /// four skips checking each instance again.
    checked_instances: Option<(u64, usize, usize, usize)>,
    /// Frames encoded so far ([`RenderTimings::frame`] of the last).
    frame: u64,
    scratch_bases: Vec<u8>,
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
        Self::with_shaders_and_msaa(gpu, color_format, sources, 4)
    }

    /// Like [`Renderer::with_shaders`], multisampling with at most `max_samples` samples a
    /// pixel: 4 where the adapter supports it and `max_samples` allows, else 1.
    pub fn with_shaders_and_msaa(
        gpu: &Gpu,
        color_format: wgpu::TextureFormat,
        sources: ShaderSources,
        max_samples: u32,
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
        let sample_count = if color_ok && depth_ok && max_samples >= 4 {
            4
        } else {
            1
        };

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
        let uniform_entry = |binding: u32| wgpu::BindGroupLayoutEntry {
            binding,
            visibility: wgpu::ShaderStages::COMPUTE,
            ty: wgpu::BindingType::Buffer {
                ty: wgpu::BufferBindingType::Uniform,
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
                uniform_entry(2),
                storage_entry(3, false),
            ],
        });
        let pose_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("pose pass bind group layout"),
            entries: &[
                storage_entry(0, true),
                storage_entry(1, true),
                storage_entry(2, true),
                storage_entry(3, true),
                uniform_entry(4),
                storage_entry(5, false),
                storage_entry(6, true),
            ],
        });
        let draw_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("fish draw bind group layout"),
            entries: &[
                wgpu::BindGroupLayoutEntry {
                    binding: 0,
                    visibility: wgpu::ShaderStages::VERTEX,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Storage { read_only: true },
                        has_dynamic_offset: false,
                        min_binding_size: None,
                    },
                    count: None,
                },
                wgpu::BindGroupLayoutEntry {
                    binding: 1,
                    visibility: wgpu::ShaderStages::VERTEX,
                    ty: wgpu::BindingType::Buffer {
                        ty: wgpu::BufferBindingType::Uniform,
                        has_dynamic_offset: true,
                        min_binding_size: wgpu::BufferSize::new(DRAW_BASE_SIZE),
                    },
                    count: None,
                },
            ],
        });
        let cull_layout = device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
            label: Some("culling pass bind group layout"),
            entries: &[
                storage_entry(0, true),
                storage_entry(1, true),
                uniform_entry(2),
                storage_entry(3, true),
                storage_entry(4, false),
                storage_entry(5, false),
                storage_entry(6, false),
                storage_entry(7, false),
            ],
        });
        let draw_base_stride = device
            .limits()
            .min_uniform_buffer_offset_alignment
            .max(DRAW_BASE_SIZE as u32);
        let pose = PoseBuffers::new(device);
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
            wgpu::BufferUsages::STORAGE,
            32 * 1024,
        );
        let draw_bases = GrowBuffer::new(
            device,
            "fish draw bases",
            wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::STORAGE,
            64 * u64::from(draw_base_stride),
        );
        let draw_bind_group =
            make_draw_bind_group(device, &draw_layout, &instances.buffer, &draw_bases.buffer);
        let lines = GrowBuffer::new(
            device,
            "line vertices",
            wgpu::BufferUsages::VERTEX,
            16 * 1024,
        );
        let bind_group = make_scene_bind_group(device, &scene_layout, &globals, &palettes.buffer);
        let layouts = Layouts {
            scene: &scene_layout,
            material: &material_layout,
            readback: &readback_layout,
            pose: &pose_layout,
            draw: &draw_layout,
            cull: &cull_layout,
        };
        let pipelines = build_pipelines(device, &sources, &layouts, color_format, sample_count)?;
        let culling_supported = cull_pass::gpu_culling_supported(gpu);
        Ok(Self {
            color_format,
            sample_count,
            scene_layout,
            material_layout,
            readback_layout,
            pose_layout,
            draw_layout,
            cull_layout,
            globals,
            palettes,
            pose,
            instances,
            draw_bases,
            draw_base_stride,
            draw_bind_group,
            cull: CullBuffers::new(device),
            culling: cull_pass::default_culling(gpu),
            culling_supported,
            last_frame_gpu_culled: false,
            checked_instances: None,
            frame: 0,
            scratch_bases: Vec::new(),
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

    /// MSAA sample count in use (4, or 1 where the adapter lacks 4× or the renderer was made
    /// with fewer, [`Renderer::with_shaders_and_msaa`]).
    pub fn sample_count(&self) -> u32 {
        self.sample_count
    }

    /// Timings and counts of the last [`Renderer::render`] or [`Renderer::encode`]. Culled on
    /// the GPU ([`Culling::Gpu`]), the counts (fish drawn, culled, per level, shadows,
    /// triangles, draws that drew something) are those read back last, without waiting: a
    /// frame or two old, [`RenderTimings::counts_frame`] says which;
    /// [`Renderer::read_gpu_counts`] waits for the last frame's.
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

    /// How culling and levels of detail are worked out ([`Culling::Gpu`] by default where the
    /// adapter runs indirect draws, unless the environment variable `SHOAL_CULLING` is `cpu`).
    pub fn culling(&self) -> Culling {
        self.culling
    }

    /// Whether `gpu`'s adapter can cull on the GPU ([`Culling::Gpu`]): it runs indirect draws
    /// and compute shaders.
    pub fn gpu_culling_supported(gpu: &Gpu) -> bool {
        cull_pass::gpu_culling_supported(gpu)
    }

    /// Chooses where culling and levels of detail are worked out; [`Culling::Gpu`] falls back
    /// to [`Culling::Cpu`] on an adapter without indirect draws or compute shaders. Returns
    /// the culling now in use.
    pub fn set_culling(&mut self, culling: Culling) -> Culling {
        self.culling = if self.culling_supported {
            culling
        } else {
            Culling::Cpu
        };
        self.culling
    }

    /// Makes group 2 of the fish pipelines again after its buffers were replaced.
    fn rebuild_draw_bind_group(&mut self, device: &wgpu::Device) {
        self.draw_bind_group = make_draw_bind_group(
            device,
            &self.draw_layout,
            &self.instances.buffer,
            &self.draw_bases.buffer,
        );
    }

    /// Rebuilds every pipeline from `sources`. On a WGSL or pipeline error, returns it and keeps
    /// drawing with the previous pipelines (never panics on bad shader text).
    pub fn reload_shaders(&mut self, gpu: &Gpu, sources: ShaderSources) -> Result<(), RenderError> {
        let layouts = Layouts {
            scene: &self.scene_layout,
            material: &self.material_layout,
            readback: &self.readback_layout,
            pose: &self.pose_layout,
            draw: &self.draw_layout,
            cull: &self.cull_layout,
        };
        let pipelines = build_pipelines(
            &gpu.device,
            &sources,
            &layouts,
            self.color_format,
            self.sample_count,
        )?;
        self.pipelines = pipelines;
        Ok(())
    }

    /// Forgets every uploaded mesh (before uploading a restarted scene's meshes again, whose ids
    /// then start from 0 as before).
    pub fn clear_meshes(&mut self) {
        self.meshes.clear();
        self.num_lod_buckets = 0;
        // The instances are checked against the meshes: again against the new ones.
        self.checked_instances = None;
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
}

/// Bytes of one draw's entry of the draw-base uniform (`DrawBase` in `fish.wgsl`).
const DRAW_BASE_SIZE: u64 = 16;

/// Group 2 of the fish pipelines: the instances and the draw-base uniform (one entry bound per
/// draw by dynamic offset).
fn make_draw_bind_group(
    device: &wgpu::Device,
    layout: &wgpu::BindGroupLayout,
    instances: &wgpu::Buffer,
    bases: &wgpu::Buffer,
) -> wgpu::BindGroup {
    device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some("fish draw bind group"),
        layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: instances.as_entire_binding(),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: wgpu::BindingResource::Buffer(wgpu::BufferBinding {
                    buffer: bases,
                    offset: 0,
                    size: wgpu::BufferSize::new(DRAW_BASE_SIZE),
                }),
            },
        ],
    })
}

/// Group 0 of the scene pipelines: the globals uniform and the palette buffer.
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
