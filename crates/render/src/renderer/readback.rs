//! Reading back from the GPU: skinned positions for tests ([`Renderer::skin_positions`]) and the
//! buffer mapping the offscreen target uses too.

use bytemuck::{Pod, Zeroable};
use glam::{Mat4, Vec3};

use super::Renderer;
use crate::{Gpu, MeshId, RenderError};

#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
struct ReadbackParams {
    palette_offset: u32,
    num_vertices: u32,
    _pad: [u32; 2],
}

impl Renderer {
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

/// Maps a `MAP_READ` buffer, waits, and copies its bytes out.
pub(crate) fn map_read(gpu: &Gpu, buffer: &wgpu::Buffer) -> Result<Vec<u8>, RenderError> {
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
