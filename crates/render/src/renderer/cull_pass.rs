//! Culling and levels of detail on the GPU (`shaders/cull.wgsl`): the GPU keeps one record per
//! fish and prop (its palette offset, mesh, tint) between frames, which the CPU brings up to date
//! by writing only those that changed ([`super::records`]), and a table per mesh; the CPU
//! records a fixed set of passes and indirect draws, one per mesh, level and material (and per
//! mesh and material for the near and outline shadows), so its work per frame does not depend
//! on how many fish are in view, nor, while the caller's [`FrameInput::instances_revision`]
//! stays the same, on how many fish there are (it keeps their records; otherwise it builds and
//! compares each fish's record: see [`super::records`]). The compute passes cull each record against the view, pick its level by projected error
//! (the arithmetic of [`crate::lod`]), group the instances by draw and write each draw's indirect
//! arguments. The counts the CPU path keeps for [`super::RenderTimings`] stay on the GPU until
//! [`Renderer::read_gpu_counts`] reads them, or the window's read-back without waiting brings
//! an earlier frame's ([`super::RenderTimings::counts_frame`] names it).
//!
//! Indirect draws start at instance 0: a first instance there needs
//! `Features::INDIRECT_FIRST_INSTANCE`, so each draw's instances are found through its own
//! entry of the draw-base uniform (group 2 of the fish pipelines, by dynamic offset), which the
//! CPU path writes from the CPU.

use std::sync::Arc;
use std::sync::atomic::{AtomicU8, Ordering};
use std::time::Instant;

use bytemuck::{Pod, Zeroable};

use super::records::{RecordBuffer, SyncStats};
use super::{GrowBuffer, RenderTimings, Renderer};
use crate::lod::{BEND_MARGIN, Frustum, LodSelector, MAX_LODS, NEAR_SHADOW_LOD, ShadowProjection};
use crate::{FrameInput, Gpu, RenderError};

/// Fish per workgroup (`@workgroup_size` of `cs_count` and `cs_scatter`).
const WORKGROUP: u32 = 64;

/// Counters before the per-bucket counts in the state buffer (`STATS` in `cull.wgsl`): fish
/// drawn, culled, shadows, outline shadows, fish per level.
const STATS: usize = 16;

/// How culling and levels of detail are worked out each frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Culling {
    /// On the CPU: the renderer sorts the instances by draw and uploads them; one draw per
    /// mesh, level and material with fish in view.
    Cpu,
    /// On the GPU (a compute pass and indirect draws), where the adapter runs indirect draws.
    Gpu,
}

/// One fish or prop for the culling pass (`Record` in `cull.wgsl`).
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct CullRecord {
    palette_offset: u32,
    flags: u32,
    mesh: u32,
    is_fish: u32,
    tint: [f32; 4],
}

/// `CullParams` in `cull.wgsl`.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct CullParams {
    planes: [[f32; 4]; 6],
    eye_ppu: [f32; 4],
    lod_shadow: [f32; 4],
    shadow: [f32; 4],
    counts: [u32; 4],
    base_stride: [u32; 4],
}

/// Which pipeline a GPU-culled draw uses.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum DrawKind {
    Shadow,
    Opaque,
    Blend,
}

/// One indirect draw: a mesh's material part of one level, reading one bucket.
#[derive(Debug, Clone, Copy)]
pub(super) struct IndirectDraw {
    pub kind: DrawKind,
    pub mesh: usize,
    pub material: usize,
    pub bucket: u32,
    pub first_index: u32,
    pub num_indices: u32,
}

/// A frame whose counts are read back: which frame, its indirect draws (the bucket each one
/// reads) and its other draws (background, floor, lines), which always draw.
#[derive(Debug, Default)]
struct PendingCounts {
    frame: u64,
    draws: Vec<IndirectDraw>,
    other_draws: u32,
}

/// Where the counts' read-back for the window stands (see [`Renderer::poll_gpu_counts`]).
#[derive(Debug)]
enum CountsReadback {
    /// Nothing pending: the next GPU-culled frame copies its counts.
    Idle,
    /// A frame's counts are being copied (submitted with that frame).
    Copied,
    /// Being mapped: 0 waiting, 1 mapped, 2 failed.
    Mapping(Arc<AtomicU8>),
}

/// The culling pass's buffers (grow-only), its uniform and the frame's draw list.
#[derive(Debug)]
pub(super) struct CullBuffers {
    /// One per fish, then per prop; written where they changed ([`RecordBuffer::sync_from`]).
    records: RecordBuffer<CullRecord>,
    /// What the last frame's record sync wrote, and how long it took (CPU, milliseconds).
    pub record_sync: SyncStats,
    pub records_ms: f32,
    /// [`FrameInput::instances_revision`] and the number of fish of the records the GPU holds:
    /// a frame with the same (`Some`) revision keeps the fish's records as they are.
    fish_revision: Option<u64>,
    num_fish: usize,
    tables: GrowBuffer,
    params: wgpu::Buffer,
    state: GrowBuffer,
    pub args: GrowBuffer,
    scratch_tables: Vec<[u32; 4]>,
    /// The last frame's draws, in recording order (shadows, opaque, blended).
    pub draws: Vec<IndirectDraw>,
    /// Buckets of the last GPU-culled frame (0: none was).
    num_buckets: u32,
    /// The counts of the latest GPU-culled frame read back (a frame or two old, or as new as
    /// [`Renderer::read_gpu_counts`]); [`RenderTimings::counts_frame`] says which frame.
    pub last_counts: RenderTimings,
    /// The frame whose counts are being read back without waiting: its number, its draws and
    /// how many draws it recorded besides them (valid while `readback` is not idle).
    pending: PendingCounts,
    /// Where the counts are copied for reading without waiting (`MAP_READ`).
    staging: Option<wgpu::Buffer>,
    readback: CountsReadback,
}

impl CullBuffers {
    pub fn new(device: &wgpu::Device) -> Self {
        let storage = |label, extra| {
            GrowBuffer::new(device, label, wgpu::BufferUsages::STORAGE | extra, 4096)
        };
        Self {
            records: RecordBuffer::new(storage(
                "culling pass: records",
                wgpu::BufferUsages::empty(),
            )),
            tables: storage(
                "culling pass: mesh and draw tables",
                wgpu::BufferUsages::empty(),
            ),
            params: device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("culling pass: params"),
                size: std::mem::size_of::<CullParams>() as u64,
                usage: wgpu::BufferUsages::UNIFORM | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }),
            state: storage("culling pass: counters", wgpu::BufferUsages::COPY_SRC),
            args: storage("culling pass: indirect draws", wgpu::BufferUsages::INDIRECT),
            record_sync: SyncStats::default(),
            records_ms: 0.0,
            fish_revision: None,
            num_fish: 0,
            scratch_tables: Vec::new(),
            draws: Vec::new(),
            num_buckets: 0,
            last_counts: RenderTimings::default(),
            pending: PendingCounts::default(),
            staging: None,
            readback: CountsReadback::Idle,
        }
    }
}

/// Whether `gpu`'s adapter can cull on the GPU: indirect draws and compute shaders.
pub(super) fn gpu_culling_supported(gpu: &Gpu) -> bool {
    let flags = gpu.adapter.get_downlevel_capabilities().flags;
    flags.contains(wgpu::DownlevelFlags::INDIRECT_EXECUTION)
        && flags.contains(wgpu::DownlevelFlags::COMPUTE_SHADERS)
}

/// The culling a new renderer starts with: on the GPU where supported, unless the environment
/// variable `SHOAL_CULLING` is `cpu`.
pub(super) fn default_culling(gpu: &Gpu) -> Culling {
    let forced_cpu = std::env::var("SHOAL_CULLING").is_ok_and(|v| v.eq_ignore_ascii_case("cpu"));
    if !forced_cpu && gpu_culling_supported(gpu) {
        Culling::Gpu
    } else {
        Culling::Cpu
    }
}

/// The counts in the state buffer's first `STATS` + buckets words of frame `frame`, whose
/// indirect draws were `draws` and which recorded `other_draws` draws besides, into `t`.
fn apply_counts(
    t: &mut RenderTimings,
    words: &[u32],
    draws: &[IndirectDraw],
    other_draws: u32,
    frame: u64,
) {
    if words.len() < STATS {
        return;
    }
    let counts = &words[STATS..];
    let instances = |d: &IndirectDraw| counts.get(d.bucket as usize).copied().unwrap_or(0);
    t.num_fish_drawn = words[0];
    t.num_fish_culled = words[1];
    t.num_shadows_drawn = words[2];
    t.num_outline_shadows = words[3];
    t.num_fish_per_lod.copy_from_slice(&words[4..4 + MAX_LODS]);
    t.num_triangles = draws
        .iter()
        .map(|d| u64::from(d.num_indices / 3) * u64::from(instances(d)))
        .sum();
    t.num_nonempty_draw_calls =
        other_draws + draws.iter().filter(|d| instances(d) > 0).count() as u32;
    t.counts_frame = frame;
}

impl Renderer {
    /// The window's counts without waiting for the GPU: a GPU-culled frame copies its counts
    /// into a staging buffer (when none is pending), the next frame asks for it to be mapped,
    /// and a later one reads it once mapped. So [`Renderer::timings`] shows counts a frame or
    /// two old.
    fn poll_gpu_counts(&mut self, gpu: &Gpu) {
        let _ = gpu.device.poll(wgpu::PollType::Poll);
        let c = &mut self.cull;
        let Some(staging) = c.staging.as_ref() else {
            return;
        };
        match &c.readback {
            CountsReadback::Idle => {}
            CountsReadback::Copied => {
                let flag = Arc::new(AtomicU8::new(0));
                let done = flag.clone();
                staging.map_async(wgpu::MapMode::Read, .., move |r| {
                    done.store(if r.is_ok() { 1 } else { 2 }, Ordering::Release);
                });
                c.readback = CountsReadback::Mapping(flag);
            }
            CountsReadback::Mapping(flag) => match flag.load(Ordering::Acquire) {
                0 => {}
                state => {
                    if state == 1 {
                        if let Ok(range) = staging.slice(..).get_mapped_range() {
                            let words: Vec<u32> = bytemuck::pod_collect_to_vec(&range);
                            drop(range);
                            let p = &c.pending;
                            apply_counts(
                                &mut c.last_counts,
                                &words,
                                &p.draws,
                                p.other_draws,
                                p.frame,
                            );
                        }
                        staging.unmap();
                    }
                    c.readback = CountsReadback::Idle;
                }
            },
        }
    }

    /// After the culling passes: copies the counts for [`Renderer::poll_gpu_counts`] when no
    /// read-back is pending, noting which frame they are from and its draws.
    fn copy_gpu_counts(&mut self, device: &wgpu::Device, encoder: &mut wgpu::CommandEncoder) {
        let frame = self.frame;
        let c = &mut self.cull;
        if !matches!(c.readback, CountsReadback::Idle) {
            return;
        }
        c.pending.frame = frame;
        c.pending.draws.clone_from(&c.draws);
        c.pending.other_draws = 0;
        let size = ((STATS + c.num_buckets as usize) * 4) as u64;
        if c.staging.as_ref().is_none_or(|b| b.size() < size) {
            c.staging = Some(device.create_buffer(&wgpu::BufferDescriptor {
                label: Some("culling counts (window)"),
                size: size.next_power_of_two(),
                usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
                mapped_at_creation: false,
            }));
        }
        if let Some(staging) = &c.staging {
            encoder.copy_buffer_to_buffer(&c.state.buffer, 0, staging, 0, size);
            c.readback = CountsReadback::Copied;
        }
    }

    /// The draws of a GPU-culled frame, in the order the CPU path records them: shadows (near
    /// level, then outline, per mesh and material), then opaque fish, then blended fish, per
    /// mesh, level and material. They depend on the meshes only.
    fn build_indirect_draws(&mut self, shadows: bool) {
        let draws = &mut self.cull.draws;
        draws.clear();
        for (m, mesh) in self.meshes.iter().enumerate() {
            if !shadows {
                break;
            }
            let near = NEAR_SHADOW_LOD.min(mesh.levels.len() - 1);
            let first_shadow = self.num_lod_buckets + 2 * m as u32;
            for (k, parts) in [&mesh.level_parts[near], &mesh.shadow_parts]
                .into_iter()
                .enumerate()
            {
                draws.extend(parts.iter().map(|p| IndirectDraw {
                    kind: DrawKind::Shadow,
                    mesh: m,
                    material: usize::from(p.material),
                    bucket: first_shadow + k as u32,
                    first_index: p.first_index,
                    num_indices: p.num_indices,
                }));
            }
        }
        for kind in [DrawKind::Opaque, DrawKind::Blend] {
            for (m, mesh) in self.meshes.iter().enumerate() {
                for (level, parts) in mesh.level_parts.iter().enumerate() {
                    for p in parts {
                        let material = usize::from(p.material);
                        if mesh.materials[material].blend != (kind == DrawKind::Blend) {
                            continue;
                        }
                        draws.push(IndirectDraw {
                            kind,
                            mesh: m,
                            material,
                            bucket: mesh.first_bucket + level as u32,
                            first_index: p.first_index,
                            num_indices: p.num_indices,
                        });
                    }
                }
            }
        }
    }

    /// Uploads the frame's records and tables and records the culling passes: after them the
    /// instance buffer, the draw-base uniform and the indirect arguments hold the frame's draws
    /// ([`CullBuffers::draws`]).
    pub(super) fn record_gpu_cull(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        input: &FrameInput<'_>,
        frustum: &Frustum,
        selector: &LodSelector,
        shadow: Option<ShadowProjection>,
    ) {
        self.poll_gpu_counts(gpu);
        let (device, queue) = (&gpu.device, &gpu.queue);
        self.build_indirect_draws(shadow.is_some());
        let num_buckets = self.num_lod_buckets + 2 * self.meshes.len() as u32;
        self.cull.num_buckets = num_buckets;

        let t_records = Instant::now();
        let first_prop = super::fish_palette_len(input) as u32;
        let fish = input.instances.iter().map(|inst| CullRecord {
            palette_offset: inst.palette_offset,
            flags: u32::from(inst.selected),
            mesh: inst.mesh.0,
            is_fish: 1,
            tint: [inst.tint[0], inst.tint[1], inst.tint[2], 1.0],
        });
        let props = input.props.iter().enumerate().map(|(k, p)| CullRecord {
            palette_offset: first_prop + k as u32,
            flags: 0,
            mesh: p.mesh.0,
            is_fish: 0,
            tint: [p.tint[0], p.tint[1], p.tint[2], 1.0],
        });
        let num_fish = input.instances.len();
        let num_records = (num_fish + input.props.len()) as u32;
        let c = &mut self.cull;
        // The caller's revision says the instances are those the fish's records were built
        // from: only the props' records (after them) are built and compared, so a steady frame
        // costs nothing per fish here.
        let keep = match input.instances_revision {
            Some(r)
                if c.fish_revision == Some(r)
                    && c.num_fish == num_fish
                    && c.records.len() >= num_fish =>
            {
                num_fish
            }
            _ => 0,
        };
        let next = c.records.next();
        if keep == 0 {
            next.extend(fish);
        }
        next.extend(props);
        c.record_sync = c.records.sync_from(device, queue, keep);
        c.fish_revision = input.instances_revision;
        c.num_fish = num_fish;
        self.cull.records_ms = t_records.elapsed().as_secs_f32() * 1e3;

        let c = &mut self.cull;
        c.scratch_tables.clear();
        for (m, mesh) in self.meshes.iter().enumerate() {
            let b = mesh.bounds;
            let mut errors = [0.0f32; 8];
            for (e, level) in errors.iter_mut().zip(&mesh.levels) {
                *e = level.error;
            }
            c.scratch_tables.extend([
                [b.center.x, b.center.y, b.center.z, b.radius].map(f32::to_bits),
                [
                    mesh.first_bucket,
                    mesh.levels.len().min(MAX_LODS) as u32,
                    self.num_lod_buckets + 2 * m as u32,
                    0,
                ],
                [errors[0], errors[1], errors[2], errors[3]].map(f32::to_bits),
                [errors[4], errors[5], errors[6], errors[7]].map(f32::to_bits),
            ]);
        }
        let draws_at = c.scratch_tables.len() as u32;
        c.scratch_tables.extend(
            c.draws
                .iter()
                .map(|d| [d.bucket, d.first_index, d.num_indices, 0]),
        );

        let stride = self.draw_base_stride;
        let (floor_y, shift, stretch) = shadow.map_or((0.0, [0.0; 2], 1.0), |s| s.parts());
        let params = CullParams {
            planes: frustum.planes().map(|p| p.to_array()),
            eye_ppu: selector
                .eye
                .extend(selector.px_per_unit_at_unit_distance)
                .to_array(),
            lod_shadow: [selector.tolerance_px, floor_y, shift[0], shift[1]],
            shadow: [
                stretch,
                if shadow.is_some() { 1.0 } else { 0.0 },
                BEND_MARGIN,
                NEAR_SHADOW_LOD as f32,
            ],
            counts: [num_records, num_buckets, c.draws.len() as u32, draws_at],
            base_stride: [stride / 4, 0, 0, 0],
        };
        queue.write_buffer(&c.params, 0, bytemuck::bytes_of(&params));
        let upload = |buffer: &mut GrowBuffer, bytes: &[u8]| {
            buffer.ensure(device, bytes.len() as u64);
            if !bytes.is_empty() {
                queue.write_buffer(&buffer.buffer, 0, bytes);
            }
        };
        upload(&mut c.tables, bytemuck::cast_slice(&c.scratch_tables));
        let state_bytes =
            ((STATS + 2 * num_buckets as usize + 4 * num_records as usize) * 4) as u64;
        c.state.ensure(device, state_bytes);
        c.args.ensure(device, (c.draws.len() as u64 * 20).max(20));
        // Every record can be drawn twice (fish and shadow).
        let grew_instances = self
            .instances
            .ensure(device, u64::from(num_records) * 2 * 32);
        let grew_bases = self
            .draw_bases
            .ensure(device, u64::from(num_buckets.max(1)) * u64::from(stride));
        if grew_instances || grew_bases {
            self.rebuild_draw_bind_group(device);
        }
        let c = &self.cull;
        encoder.clear_buffer(&c.state.buffer, 0, Some(state_bytes));
        if num_records > 0 || !c.draws.is_empty() {
            self.dispatch_cull(gpu, encoder, num_records);
        }
        self.copy_gpu_counts(device, encoder);
    }

    /// Records the three culling passes over `num_records` records.
    fn dispatch_cull(&self, gpu: &Gpu, encoder: &mut wgpu::CommandEncoder, num_records: u32) {
        let device = &gpu.device;
        let c = &self.cull;
        fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
            wgpu::BindGroupEntry {
                binding,
                resource: buffer.as_entire_binding(),
            }
        }
        let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("culling pass bind group"),
            layout: &self.cull_layout,
            entries: &[
                entry(0, &c.records.gpu.buffer),
                entry(1, &c.tables.buffer),
                entry(2, &c.params),
                entry(3, &self.palettes.buffer),
                entry(4, &c.state.buffer),
                entry(5, &self.instances.buffer),
                entry(6, &self.draw_bases.buffer),
                entry(7, &c.args.buffer),
            ],
        });
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("culling pass"),
            timestamp_writes: None,
        });
        pass.set_bind_group(0, &bind_group, &[]);
        let groups = num_records.div_ceil(WORKGROUP);
        if groups > 0 {
            pass.set_pipeline(&self.pipelines.cull_count);
            pass.dispatch_workgroups(groups, 1, 1);
        }
        pass.set_pipeline(&self.pipelines.cull_offsets);
        pass.dispatch_workgroups(1, 1, 1);
        if groups > 0 {
            pass.set_pipeline(&self.pipelines.cull_scatter);
            pass.dispatch_workgroups(groups, 1, 1);
        }
    }

    /// After the frame's scene pass: the draws it recorded besides the indirect ones, for the
    /// counts read back from it ([`RenderTimings::num_nonempty_draw_calls`]).
    pub(super) fn note_other_draws(&mut self, frame: u64, other_draws: u32) {
        let p = &mut self.cull.pending;
        if p.frame == frame {
            p.other_draws = other_draws;
        }
    }

    /// Reads back the counts of the last frame culled on the GPU (fish drawn and culled, per
    /// level, shadows, triangles, draws that drew something) into [`Renderer::timings`], and
    /// returns them; waits for the GPU. [`RenderTimings::counts_frame`] is then the last frame.
    /// Frames culled on the CPU have their counts already: they are returned as they are.
    pub fn read_gpu_counts(&mut self, gpu: &Gpu) -> Result<RenderTimings, RenderError> {
        if !self.last_frame_gpu_culled {
            return Ok(self.timings);
        }
        let n = STATS + self.cull.num_buckets as usize;
        let size = (n * 4) as u64;
        let staging = gpu.device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("culling counts staging"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor {
                label: Some("culling counts read-back"),
            });
        encoder.copy_buffer_to_buffer(&self.cull.state.buffer, 0, &staging, 0, size);
        gpu.queue.submit([encoder.finish()]);
        let bytes = super::map_read(gpu, &staging)?;
        let words: Vec<u32> = bytemuck::pod_collect_to_vec(&bytes);
        let t = &mut self.timings;
        let other_draws = t
            .num_draw_calls
            .saturating_sub(self.cull.draws.len() as u32);
        apply_counts(t, &words, &self.cull.draws, other_draws, self.frame);
        Ok(*t)
    }
}
