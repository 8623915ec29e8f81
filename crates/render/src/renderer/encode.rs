//! One frame: check it, upload it (globals, palettes, culled and bucketed instances, lines),
//! and record the scene pass (background, floor, shadows, fish by level of detail, lines).

use std::time::Instant;

use bytemuck::Zeroable;
use glam::{Mat4, Vec3};

use super::cull_pass::DrawKind;
use super::pose_pass::fish_palette_len;
use super::{CULLED, Culling, Globals, InstanceRaw, LineVertex, RenderTimings, Renderer};
use crate::lod::{Frustum, LodSelector, NEAR_SHADOW_LOD, ShadowProjection};
use crate::{FrameInput, Gpu, RenderError};

/// What the frame's camera and light work out to, shared by the upload steps.
struct View {
    view_proj: Mat4,
    eye: Vec3,
    light: Vec3,
}

/// Vertex counts of the line buffer: tank edges first, then overlays up to `all`.
struct LineCounts {
    tank: u32,
    all: u32,
}

impl Renderer {
    /// Checks a frame against the uploaded meshes. The instances are checked once per
    /// [`FrameInput::instances_revision`] (again after a mesh upload or clear, or when the
    /// palette's length changes).
    fn validate(&mut self, input: &FrameInput<'_>) -> Result<(), RenderError> {
        let key = input.instances_revision.map(|r| {
            (
                r,
                input.instances.len(),
                self.meshes.len(),
                fish_palette_len(input),
            )
        });
        if key.is_none() || key != self.checked_instances {
            self.checked_instances = None;
            self.validate_instances(input)?;
            self.checked_instances = key;
        }
        if let Some(pose) = &input.gpu_pose {
            super::pose_pass::validate(pose, input.instances.len())?;
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

    /// Checks each instance's mesh and palette range.
    fn validate_instances(&self, input: &FrameInput<'_>) -> Result<(), RenderError> {
        for (i, inst) in input.instances.iter().enumerate() {
            let Some(mesh) = self.meshes.get(inst.mesh.0 as usize) else {
                return Err(RenderError::InvalidFrame(format!(
                    "fish {i} uses mesh {} but only {} meshes are uploaded",
                    inst.mesh.0,
                    self.meshes.len()
                )));
            };
            let end = inst.palette_offset as usize + mesh.num_joints as usize;
            if end > fish_palette_len(input) {
                return Err(RenderError::InvalidFrame(format!(
                    "fish {i} needs palette entries {}..{end} but the palette has {}",
                    inst.palette_offset,
                    fish_palette_len(input)
                )));
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
        self.encode_part(gpu, encoder, view, size, input, FramePart::WHOLE)
    }

    /// [`Renderer::encode`] for one part of a frame drawn over several submissions (the window
    /// draws a slow view a slice of the fish at a time): `input` holds that part's fish (their
    /// instances, pose records and anchors, with their palette offsets into the whole frame's
    /// palette) and props. The first part clears `view` and the depth and draws the water and
    /// floor; the others draw over what the earlier parts left (the depth is kept between
    /// them, so the fish hide each other as in one pass); the last draws the tank's edges and
    /// the overlays. Every part must be submitted before the next is encoded, with the same
    /// `view`, `size` and camera.
    pub fn encode_part(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        view: &wgpu::TextureView,
        size: (u32, u32),
        input: &FrameInput<'_>,
        part: FramePart,
    ) -> Result<(), RenderError> {
        let t_check = Instant::now();
        self.validate(input)?;
        self.frame += 1;
        let t0 = Instant::now();
        self.ensure_attachments(&gpu.device, size);
        let frame = self.write_globals(gpu, input, size);
        self.write_palettes(gpu, input);
        let t_pose = Instant::now();
        self.record_frame_pose(gpu, encoder, input);
        let t_cull = Instant::now();
        let gpu_cull = self.culling == Culling::Gpu;
        let mut stats = if gpu_cull {
            self.cull_on_gpu(gpu, encoder, input, &frame, size.1);
            // The counts stay on the GPU: those last read back (a frame or two old, or read by
            // `read_gpu_counts`).
            self.cull.last_counts
        } else {
            let stats = self.assign_buckets(input, &frame, size.1);
            self.write_instances(gpu, input);
            stats
        };
        let cull_ms = t_cull.elapsed().as_secs_f32() * 1e3;
        self.last_frame_gpu_culled = gpu_cull;
        let lines = self.write_lines(gpu, input);
        let t1 = Instant::now();
        let draws =
            self.record_scene_pass(encoder, view, input.look.shadows, &lines, part, &mut stats)?;
        let t2 = Instant::now();
        let mut timings = RenderTimings {
            frame: self.frame,
            check_ms: (t0 - t_check).as_secs_f32() * 1e3,
            upload_ms: (t1 - t0).as_secs_f32() * 1e3,
            pose_upload_ms: (t_cull - t_pose).as_secs_f32() * 1e3,
            cull_ms,
            draw_ms: (t2 - t1).as_secs_f32() * 1e3,
            num_draw_calls: draws,
            ..stats
        };
        if gpu_cull {
            let other_draws = draws.saturating_sub(self.cull.draws.len() as u32);
            self.note_other_draws(self.frame, other_draws);
            timings.records_ms = self.cull.records_ms;
            timings.num_records_written = self.cull.record_sync.written;
        } else {
            // The CPU path records only draws with instances, and counts this frame.
            timings.num_nonempty_draw_calls = draws;
            timings.counts_frame = self.frame;
        }
        self.timings = timings;
        Ok(())
    }

    /// What both cullings (GPU and CPU) judge each fish by: the view's frustum, the level
    /// selector for the view's height in pixels and the tolerance, and the shadow projection when
    /// shadows are drawn.
    fn cull_inputs(
        &self,
        input: &FrameInput<'_>,
        frame: &View,
        height_px: u32,
    ) -> (Frustum, LodSelector, Option<ShadowProjection>) {
        let frustum = Frustum::from_view_proj(&frame.view_proj);
        let selector = LodSelector::new(
            frame.eye,
            input.camera.fov_y_rad,
            height_px.max(1),
            self.lod_tolerance_px,
        );
        let shadow = input
            .look
            .shadows
            .then(|| ShadowProjection::new(input.tank.min.y, frame.light));
        (frustum, selector, shadow)
    }

    /// The frame's culling on the GPU: the same frustum, level selector and shadow projection
    /// as [`Renderer::assign_buckets`] ([`Self::cull_inputs`]), handed to the culling pass.
    fn cull_on_gpu(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        input: &FrameInput<'_>,
        frame: &View,
        height_px: u32,
    ) {
        let (frustum, selector, shadow) = self.cull_inputs(input, frame, height_px);
        self.record_gpu_cull(gpu, encoder, input, &frustum, &selector, shadow);
    }

    /// The globals uniform: camera, tank, fog, caustics, light and water colours.
    fn write_globals(&self, gpu: &Gpu, input: &FrameInput<'_>, size: (u32, u32)) -> View {
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
        gpu.queue
            .write_buffer(&self.globals, 0, bytemuck::bytes_of(&globals));
        View {
            view_proj,
            eye,
            light,
        }
    }

    /// Palettes: one upload for every fish (or room for the GPU pose pass to write them), then
    /// one matrix per prop behind them.
    fn write_palettes(&mut self, gpu: &Gpu, input: &FrameInput<'_>) {
        let (device, queue) = (&gpu.device, &gpu.queue);
        let palette_bytes: &[u8] = if input.gpu_pose.is_some() {
            &[]
        } else {
            bytemuck::cast_slice(input.palettes)
        };
        let fish_bytes = (fish_palette_len(input) * std::mem::size_of::<Mat4>()) as u64;
        self.scratch_props.clear();
        self.scratch_props
            .extend(input.props.iter().map(|p| p.transform));
        let prop_bytes: &[u8] = bytemuck::cast_slice(&self.scratch_props);
        let total = fish_bytes + prop_bytes.len() as u64;
        if self.palettes.ensure(device, total) {
            self.bind_group = super::make_scene_bind_group(
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
            queue.write_buffer(&self.palettes.buffer, fish_bytes, prop_bytes);
        }
    }

    /// Culling and levels of detail: each fish (then each prop) gets a bucket for its draw, one
    /// per (mesh, level), and one for its shadow, one per mesh; culled ones get none. Counts the
    /// instances per bucket and returns the frame's fish counts.
    fn assign_buckets(
        &mut self,
        input: &FrameInput<'_>,
        frame: &View,
        height_px: u32,
    ) -> RenderTimings {
        let (frustum, selector, shadow) = self.cull_inputs(input, frame, height_px);
        let num_buckets = self.num_lod_buckets as usize + 2 * self.meshes.len();
        self.scratch_ranges.clear();
        self.scratch_ranges.resize(num_buckets, (0, 0));
        self.scratch_buckets.clear();
        let mut stats = RenderTimings::default();
        let fish = input.instances.iter().enumerate().map(|(i, inst)| {
            let joint0 = match &input.gpu_pose {
                Some(pose) => &pose.anchors[i],
                None => &input.palettes[inst.palette_offset as usize],
            };
            (inst.mesh, joint0, true)
        });
        let props = input.props.iter().map(|p| (p.mesh, &p.transform, false));
        for (mesh_id, joint0, is_fish) in fish.chain(props) {
            let mesh = &self.meshes[mesh_id.0 as usize];
            let (sphere, scale) = mesh.bounds.world_sphere(joint0);
            let in_view = frustum.intersects(sphere);
            let shadow_in_view =
                shadow.is_some_and(|projection| frustum.intersects(projection.project(sphere)));
            // The level, for the fish's draw and its shadow's: only when either is drawn.
            let lod = if in_view || shadow_in_view {
                selector.select(&mesh.levels, sphere, scale)
            } else {
                0
            };
            let draw = if in_view {
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
            let shade = if shadow_in_view {
                // A fish drawn at one of the levels for a few pixels casts the outline shadow;
                // nearer ones the fish's own detail, at least `NEAR_SHADOW_LOD`'s.
                let far = lod > NEAR_SHADOW_LOD;
                if is_fish {
                    stats.num_shadows_drawn += 1;
                    stats.num_outline_shadows += u32::from(far);
                }
                self.num_lod_buckets + 2 * mesh_id.0 + u32::from(far)
            } else {
                CULLED
            };
            for bucket in [draw, shade] {
                if bucket != CULLED {
                    self.scratch_ranges[bucket as usize].1 += 1;
                }
            }
            self.scratch_buckets.push([draw, shade]);
        }
        stats
    }

    /// Instances grouped by bucket (a counting sort into reused scratch), then uploaded. Turns
    /// each bucket's count into its `(begin, end)` range.
    fn write_instances(&mut self, gpu: &Gpu, input: &FrameInput<'_>) {
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
        let first_prop = fish_palette_len(input) as u32;
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
        let instance_len = std::mem::size_of_val(self.scratch_instances.as_slice()) as u64;
        let stride = self.draw_base_stride as usize;
        self.scratch_bases.clear();
        self.scratch_bases
            .resize(self.scratch_ranges.len().max(1) * stride, 0);
        // Each bucket's first instance, where its draws read it (`DrawBase` in fish.wgsl).
        for (k, &(begin, _)) in self.scratch_ranges.iter().enumerate() {
            self.scratch_bases[k * stride..k * stride + 4].copy_from_slice(&begin.to_ne_bytes());
        }
        let grew = self.instances.ensure(&gpu.device, instance_len)
            | self
                .draw_bases
                .ensure(&gpu.device, self.scratch_bases.len() as u64);
        if grew {
            self.rebuild_draw_bind_group(&gpu.device);
        }
        if instance_len > 0 {
            gpu.queue.write_buffer(
                &self.instances.buffer,
                0,
                bytemuck::cast_slice(&self.scratch_instances),
            );
        }
        gpu.queue
            .write_buffer(&self.draw_bases.buffer, 0, &self.scratch_bases);
    }

    /// Lines: tank edges (fogged, depth tested) then overlays (on top).
    fn write_lines(&mut self, gpu: &Gpu, input: &FrameInput<'_>) -> LineCounts {
        self.scratch_lines.clear();
        push_box_edges(
            &mut self.scratch_lines,
            input.tank.min,
            input.tank.max,
            [0.3, 0.5, 0.55, 0.55],
        );
        let tank = self.scratch_lines.len() as u32;
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
        let all = self.scratch_lines.len() as u32;
        let line_bytes: &[u8] = bytemuck::cast_slice(&self.scratch_lines);
        self.lines.ensure(&gpu.device, line_bytes.len() as u64);
        gpu.queue.write_buffer(&self.lines.buffer, 0, line_bytes);
        LineCounts { tank, all }
    }

    /// Records the scene pass (or `part` of it, see [`Renderer::encode_part`]); returns its draw
    /// calls and adds its triangles to `stats`.
    fn record_scene_pass(
        &self,
        encoder: &mut wgpu::CommandEncoder,
        view: &wgpu::TextureView,
        shadows: bool,
        lines: &LineCounts,
        part: FramePart,
        stats: &mut RenderTimings,
    ) -> Result<u32, RenderError> {
        let Some(att) = self.attachments.as_ref() else {
            return Err(RenderError::InvalidFrame("no attachments".into()));
        };
        let (color_view, resolve) = match &att.msaa {
            Some(msaa) => (msaa, Some(view)),
            None => (view, None),
        };
        // A part the next one draws over keeps its multisampled colour and its depth.
        let keep = |kept: bool| {
            if kept {
                wgpu::StoreOp::Store
            } else {
                wgpu::StoreOp::Discard
            }
        };
        let mut pass = encoder.begin_render_pass(&wgpu::RenderPassDescriptor {
            label: Some("scene pass"),
            color_attachments: &[Some(wgpu::RenderPassColorAttachment {
                view: color_view,
                depth_slice: None,
                resolve_target: resolve,
                ops: wgpu::Operations {
                    load: if part.first {
                        wgpu::LoadOp::Clear(wgpu::Color::BLACK)
                    } else {
                        wgpu::LoadOp::Load
                    },
                    store: keep(resolve.is_none() || !part.last),
                },
            })],
            depth_stencil_attachment: Some(wgpu::RenderPassDepthStencilAttachment {
                view: &att.depth,
                depth_ops: Some(wgpu::Operations {
                    load: if part.first {
                        wgpu::LoadOp::Clear(1.0)
                    } else {
                        wgpu::LoadOp::Load
                    },
                    store: keep(!part.last),
                }),
                stencil_ops: None,
            }),
            timestamp_writes: None,
            occlusion_query_set: None,
            multiview_mask: None,
        });
        pass.set_bind_group(0, &self.bind_group, &[]);
        let mut draws = 0;
        if part.first {
            pass.set_pipeline(&self.pipelines.background);
            pass.draw(0..3, 0..1);
            pass.set_pipeline(&self.pipelines.floor);
            pass.draw(0..6, 0..1);
            draws += 2;
        }

        let mut triangles = 0u64;
        if self.last_frame_gpu_culled {
            // The triangles are counted when the counts are read back.
            self.draw_indirect(&mut pass, &mut draws);
        } else {
            if shadows {
                self.draw_shadows(&mut pass, &mut draws, &mut triangles);
            }
            self.draw_fish(&mut pass, &mut draws, &mut triangles);
            stats.num_triangles = triangles;
        }

        if !part.last {
            return Ok(draws);
        }
        pass.set_vertex_buffer(0, self.lines.buffer.slice(..));
        pass.set_pipeline(&self.pipelines.lines_fogged);
        pass.draw(0..lines.tank, 0..1);
        draws += 1;
        if lines.all > lines.tank {
            pass.set_pipeline(&self.pipelines.lines_overlay);
            pass.draw(lines.tank..lines.all, 0..1);
            draws += 1;
        }
        Ok(draws)
    }

    /// The GPU-culled frame's draws ([`super::cull_pass::CullBuffers::draws`]): every one is
    /// recorded, its instance count written by the culling pass (0 where nothing is in view).
    fn draw_indirect(&self, pass: &mut wgpu::RenderPass<'_>, draws: &mut u32) {
        let mut kind = None;
        let mut mesh_bound = None;
        let mut material_bound = None;
        for (d, draw) in self.cull.draws.iter().enumerate() {
            if kind != Some(draw.kind) {
                pass.set_pipeline(match draw.kind {
                    DrawKind::Shadow => &self.pipelines.shadows,
                    DrawKind::Opaque => &self.pipelines.fish,
                    DrawKind::Blend => &self.pipelines.fish_blend,
                });
                kind = Some(draw.kind);
                mesh_bound = None;
                material_bound = None;
            }
            let mesh = &self.meshes[draw.mesh];
            if mesh_bound != Some(draw.mesh) {
                pass.set_vertex_buffer(0, mesh.vertices.slice(..));
                pass.set_vertex_buffer(2, mesh.surface.slice(..));
                pass.set_index_buffer(mesh.indices.slice(..), wgpu::IndexFormat::Uint32);
                mesh_bound = Some(draw.mesh);
                material_bound = None;
            }
            if material_bound != Some(draw.material) {
                pass.set_bind_group(1, &mesh.materials[draw.material].bind_group, &[]);
                material_bound = Some(draw.material);
            }
            pass.set_bind_group(
                2,
                &self.draw_bind_group,
                &[draw.bucket * self.draw_base_stride],
            );
            pass.draw_indexed_indirect(&self.cull.args.buffer, d as u64 * 20);
            *draws += 1;
        }
    }

    /// Shadow draws per mesh and material with shadows in view. Shadows are small and dark: a
    /// fish at one of the levels for a few pixels (coarser than [`NEAR_SHADOW_LOD`]) casts the
    /// mesh's outline shadow level ([`MeshLods::shadow`](crate::lod::MeshLods::shadow)), a
    /// nearer one level [`NEAR_SHADOW_LOD`] (or the coarsest there is).
    fn draw_shadows(&self, pass: &mut wgpu::RenderPass<'_>, draws: &mut u32, triangles: &mut u64) {
        pass.set_pipeline(&self.pipelines.shadows);
        let shadow_ranges = self.scratch_ranges[self.num_lod_buckets as usize..].chunks_exact(2);
        let first_shadow = self.num_lod_buckets;
        let shadows =
            self.meshes
                .iter()
                .zip(shadow_ranges)
                .enumerate()
                .flat_map(|(m, (mesh, ranges))| {
                    let near = NEAR_SHADOW_LOD.min(mesh.levels.len() - 1);
                    let bucket = first_shadow + 2 * m as u32;
                    [
                        (
                            mesh,
                            mesh.levels[near],
                            &mesh.level_parts[near],
                            ranges[0],
                            bucket,
                        ),
                        (
                            mesh,
                            mesh.shadow_level,
                            &mesh.shadow_parts,
                            ranges[1],
                            bucket + 1,
                        ),
                    ]
                });
        for (mesh, level, parts, (begin, end), bucket) in shadows {
            if end == begin {
                continue;
            }
            pass.set_vertex_buffer(0, mesh.vertices.slice(..));
            pass.set_vertex_buffer(2, mesh.surface.slice(..));
            pass.set_index_buffer(mesh.indices.slice(..), wgpu::IndexFormat::Uint32);
            pass.set_bind_group(2, &self.draw_bind_group, &[bucket * self.draw_base_stride]);
            for part in parts {
                pass.set_bind_group(
                    1,
                    &mesh.materials[usize::from(part.material)].bind_group,
                    &[],
                );
                pass.draw_indexed(part_range(part), 0, 0..end - begin);
                *draws += 1;
            }
            *triangles += u64::from(level.num_triangles()) * u64::from(end - begin);
        }
    }

    /// One draw per mesh, level of detail with fish in view and material: opaque and masked
    /// materials first, then blended ones over them.
    fn draw_fish(&self, pass: &mut wgpu::RenderPass<'_>, draws: &mut u32, triangles: &mut u64) {
        for blend_pass in [false, true] {
            pass.set_pipeline(if blend_pass {
                &self.pipelines.fish_blend
            } else {
                &self.pipelines.fish
            });
            for mesh in &self.meshes {
                if !mesh.materials.iter().any(|m| m.blend == blend_pass) {
                    continue;
                }
                let first = mesh.first_bucket as usize;
                let ranges = &self.scratch_ranges[first..first + mesh.levels.len()];
                if ranges.iter().all(|&(begin, end)| end == begin) {
                    continue;
                }
                pass.set_vertex_buffer(0, mesh.vertices.slice(..));
                pass.set_vertex_buffer(2, mesh.surface.slice(..));
                pass.set_index_buffer(mesh.indices.slice(..), wgpu::IndexFormat::Uint32);
                for (level, (parts, &(begin, end))) in
                    mesh.level_parts.iter().zip(ranges).enumerate()
                {
                    if end == begin {
                        continue;
                    }
                    let bucket = mesh.first_bucket + level as u32;
                    pass.set_bind_group(
                        2,
                        &self.draw_bind_group,
                        &[bucket * self.draw_base_stride],
                    );
                    for part in parts {
                        let material = &mesh.materials[usize::from(part.material)];
                        if material.blend != blend_pass {
                            continue;
                        }
                        pass.set_bind_group(1, &material.bind_group, &[]);
                        pass.draw_indexed(part_range(part), 0, 0..end - begin);
                        *triangles += u64::from(part.num_indices / 3) * u64::from(end - begin);
                        *draws += 1;
                    }
                }
            }
        }
    }
}

/// Which part of a frame drawn over several submissions [`Renderer::encode_part`] draws.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct FramePart {
    /// The first: clears the view and the depth, draws the water and the floor.
    pub first: bool,
    /// The last: draws the tank's edges and the overlays; the depth is not kept after it.
    pub last: bool,
}

impl FramePart {
    /// A whole frame in one part (what [`Renderer::encode`] draws).
    pub const WHOLE: Self = Self {
        first: true,
        last: true,
    };
}

/// The index range of one material's part of a level.
fn part_range(part: &shoal_core::skin::MeshPart) -> std::ops::Range<u32> {
    part.first_index..part.first_index + part.num_indices
}

/// The twelve edges of the box `min`–`max` as line-list vertices.
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
