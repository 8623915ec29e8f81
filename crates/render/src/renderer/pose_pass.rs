//! The GPU pose pass: checks a frame's [`GpuPoseFrame`], uploads it and records the compute
//! pass that writes the fish's palettes (`shaders/pose.wgsl`); and a read-back of that pass for
//! tests.

use glam::Mat4;
use wgpu::util::DeviceExt;

use super::{GrowBuffer, PoseBuffers, Renderer};
use crate::{FrameInput, Gpu, GpuPoseFrame, RenderError};
use shoal_core::skin::pose_program::{
    GPU_NOT_DRIVEN, GPU_POSE_MAX_MODELS, GPU_POSE_MAX_SAMPLES, GPU_POSE_MAX_YAWS, GpuPosePrograms,
};

/// Fish per workgroup (`@workgroup_size` in `pose.wgsl`).
const WORKGROUP: u32 = 64;

/// Entries of the palette the fish take: the pose pass's `palette_len`, or the CPU palettes'.
pub(super) fn fish_palette_len(input: &FrameInput<'_>) -> usize {
    match &input.gpu_pose {
        Some(pose) => pose.palette_len as usize,
        None => input.palettes.len(),
    }
}

/// Checks that every program stays inside its arrays and refers only to earlier model steps,
/// and that every record names a program and writes inside `palette_len`: the pass then reads
/// and writes nothing out of place.
pub(super) fn validate(pose: &GpuPoseFrame<'_>, num_instances: usize) -> Result<(), RenderError> {
    let bad = |what: String| Err(RenderError::InvalidFrame(format!("GPU pose: {what}")));
    if pose.anchors.len() != num_instances {
        return bad(format!(
            "{} culling anchors for {num_instances} fish instances",
            pose.anchors.len()
        ));
    }
    let p = pose.programs;
    for (k, prog) in p.programs.iter().enumerate() {
        // Summed in usize: nothing in a frame can overflow the check.
        let models =
            prog.first_model as usize..prog.first_model as usize + prog.num_models as usize;
        let slots = prog.first_slot as usize..prog.first_slot as usize + prog.num_slots as usize;
        let samples =
            prog.first_sample as usize..prog.first_sample as usize + prog.num_samples as usize;
        if models.end > p.models.len() || slots.end > p.slots.len() || samples.end > p.samples.len()
        {
            return bad(format!("program {k} reaches past the step arrays"));
        }
        if prog.num_samples as usize > GPU_POSE_MAX_SAMPLES {
            return bad(format!(
                "program {k} has {} shape samples; the pass holds {GPU_POSE_MAX_SAMPLES}",
                prog.num_samples
            ));
        }
        if prog.num_models as usize > GPU_POSE_MAX_MODELS {
            return bad(format!(
                "program {k} has {} model steps; the pass holds {GPU_POSE_MAX_MODELS}",
                prog.num_models
            ));
        }
        for (i, step) in p.models[models].iter().enumerate() {
            let yaw_ok =
                step.yaw_slot == GPU_NOT_DRIVEN || (step.yaw_slot as usize) < GPU_POSE_MAX_YAWS;
            if step.parent >= i as i32 || !yaw_ok {
                return bad(format!(
                    "program {k}, model step {i}: parent or yaw out of range"
                ));
            }
        }
        if p.slots[slots]
            .iter()
            .any(|s| s.left >= prog.num_models as i32)
        {
            return bad(format!(
                "program {k}: a slot reads a model step it does not make"
            ));
        }
    }
    // The buffer is sized from `palette_len`: no more than the records can write.
    let most_slots = p.programs.iter().map(|g| u64::from(g.num_slots)).max();
    let most = pose.fish.len() as u64 * most_slots.unwrap_or(0);
    if u64::from(pose.palette_len) > most {
        return bad(format!(
            "{} palette entries for {} fish records that can write at most {most}",
            pose.palette_len,
            pose.fish.len()
        ));
    }
    for (i, f) in pose.fish.iter().enumerate() {
        let Some(prog) = p.programs.get(f.program as usize) else {
            return bad(format!(
                "fish {i} uses program {} of {}",
                f.program,
                p.programs.len()
            ));
        };
        if f.palette_offset as u64 + u64::from(prog.num_slots) > u64::from(pose.palette_len) {
            return bad(format!(
                "fish {i} writes palette entries {}..{} past the fish's {}",
                f.palette_offset,
                u64::from(f.palette_offset) + u64::from(prog.num_slots),
                pose.palette_len
            ));
        }
    }
    Ok(())
}

/// Makes room for `bytes` in `buffer` and writes them (nothing to write for an empty slice).
fn upload(gpu: &Gpu, buffer: &mut GrowBuffer, bytes: &[u8]) {
    buffer.ensure(&gpu.device, bytes.len() as u64);
    if !bytes.is_empty() {
        gpu.queue.write_buffer(&buffer.buffer, 0, bytes);
    }
}

impl PoseBuffers {
    /// Uploads the frame's programs and records.
    fn write(&mut self, gpu: &Gpu, pose: &GpuPoseFrame<'_>) {
        let programs: &GpuPosePrograms = pose.programs;
        upload(gpu, &mut self.fish, bytemuck::cast_slice(pose.fish));
        upload(
            gpu,
            &mut self.programs,
            bytemuck::cast_slice(&programs.programs),
        );
        upload(
            gpu,
            &mut self.models,
            bytemuck::cast_slice(&programs.models),
        );
        upload(gpu, &mut self.slots, bytemuck::cast_slice(&programs.slots));
        upload(
            gpu,
            &mut self.samples,
            bytemuck::cast_slice(&programs.samples),
        );
        let params = [pose.fish.len() as u32, 0, 0, 0];
        gpu.queue
            .write_buffer(&self.params, 0, bytemuck::cast_slice(&params));
    }
}

impl Renderer {
    /// Uploads `pose` and records the pass writing its fish's entries of `palette` (which must
    /// hold `pose.palette_len` entries).
    fn record_pose_pass(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        pose: &GpuPoseFrame<'_>,
        palette: &wgpu::Buffer,
    ) {
        if pose.fish.is_empty() {
            return;
        }
        self.pose.write(gpu, pose);
        let b = &self.pose;
        fn entry(binding: u32, buffer: &wgpu::Buffer) -> wgpu::BindGroupEntry<'_> {
            wgpu::BindGroupEntry {
                binding,
                resource: buffer.as_entire_binding(),
            }
        }
        let bind_group = gpu.device.create_bind_group(&wgpu::BindGroupDescriptor {
            label: Some("pose pass bind group"),
            layout: &self.pose_layout,
            entries: &[
                entry(0, &b.fish.buffer),
                entry(1, &b.programs.buffer),
                entry(2, &b.models.buffer),
                entry(3, &b.slots.buffer),
                entry(4, &b.params),
                entry(5, palette),
                entry(6, &b.samples.buffer),
            ],
        });
        let mut pass = encoder.begin_compute_pass(&wgpu::ComputePassDescriptor {
            label: Some("pose pass"),
            timestamp_writes: None,
        });
        pass.set_pipeline(&self.pipelines.pose);
        pass.set_bind_group(0, &bind_group, &[]);
        pass.dispatch_workgroups((pose.fish.len() as u32).div_ceil(WORKGROUP), 1, 1);
    }

    /// Records the frame's pose pass into the palette buffer, if it has one.
    pub(super) fn record_frame_pose(
        &mut self,
        gpu: &Gpu,
        encoder: &mut wgpu::CommandEncoder,
        input: &FrameInput<'_>,
    ) {
        if let Some(pose) = &input.gpu_pose {
            // The buffer is taken out for the call (the pass writes it while `self` is borrowed).
            let palette = self.palettes.buffer.clone();
            self.record_pose_pass(gpu, encoder, pose, &palette);
        }
    }

    /// Runs the GPU pose pass over `pose` alone and reads the fish's palette entries back
    /// (`pose.palette_len` of them): so tests can compare it with the CPU pose stage.
    pub fn pose_palettes(
        &mut self,
        gpu: &Gpu,
        pose: &GpuPoseFrame<'_>,
    ) -> Result<Vec<Mat4>, RenderError> {
        validate(pose, pose.anchors.len())?;
        let size = (u64::from(pose.palette_len) * 64).max(64);
        let device = &gpu.device;
        let palette = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
            label: Some("pose read-back palette"),
            contents: &vec![0u8; size as usize],
            usage: wgpu::BufferUsages::STORAGE | wgpu::BufferUsages::COPY_SRC,
        });
        let staging = device.create_buffer(&wgpu::BufferDescriptor {
            label: Some("pose read-back staging"),
            size,
            usage: wgpu::BufferUsages::MAP_READ | wgpu::BufferUsages::COPY_DST,
            mapped_at_creation: false,
        });
        let mut encoder = device.create_command_encoder(&wgpu::CommandEncoderDescriptor {
            label: Some("pose read-back encoder"),
        });
        self.record_pose_pass(gpu, &mut encoder, pose, &palette);
        encoder.copy_buffer_to_buffer(&palette, 0, &staging, 0, size);
        gpu.queue.submit([encoder.finish()]);
        let bytes = super::map_read(gpu, &staging)?;
        let floats: Vec<f32> = bytemuck::pod_collect_to_vec(&bytes);
        Ok(floats
            .chunks_exact(16)
            .take(pose.palette_len as usize)
            .map(Mat4::from_cols_slice)
            .collect())
    }
}
