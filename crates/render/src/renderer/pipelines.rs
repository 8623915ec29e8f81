//! Shader modules and pipelines: compiled inside validation error scopes so a bad shader is an
//! error (and the previous pipelines keep drawing), never a panic.

use super::{DEPTH_FORMAT, LineVertex, Pipelines, SurfaceVertex, Vertex};
use crate::RenderError;
use crate::shaders::ShaderSources;

/// The bind group layouts the pipelines are built against.
pub(super) struct Layouts<'a> {
    /// Group 0 of every scene pipeline: globals and the palette buffer.
    pub scene: &'a wgpu::BindGroupLayout,
    /// Group 1 of the fish pipelines: the species' material.
    pub material: &'a wgpu::BindGroupLayout,
    /// The skin read-back compute pass's only group.
    pub readback: &'a wgpu::BindGroupLayout,
    /// The GPU pose pass's only group.
    pub pose: &'a wgpu::BindGroupLayout,
    /// Group 2 of the fish pipelines: the draws' instances and the draw-base uniform.
    pub draw: &'a wgpu::BindGroupLayout,
    /// The GPU culling pass's only group.
    pub cull: &'a wgpu::BindGroupLayout,
}

/// The compiled shader modules.
struct Modules {
    fish: wgpu::ShaderModule,
    environment: wgpu::ShaderModule,
    lines: wgpu::ShaderModule,
    readback: wgpu::ShaderModule,
    pose: wgpu::ShaderModule,
    cull: wgpu::ShaderModule,
}

/// Compiles every pipeline inside a validation error scope so a bad shader returns an error.
pub(super) fn build_pipelines(
    device: &wgpu::Device,
    sources: &ShaderSources,
    layouts: &Layouts<'_>,
    color_format: wgpu::TextureFormat,
    sample_count: u32,
) -> Result<Pipelines, RenderError> {
    let modules = compile_modules(device, sources)?;
    let scope = device.push_error_scope(wgpu::ErrorFilter::Validation);
    let f = Factory::new(device, layouts, color_format, sample_count);
    let (background, floor) = f.environment(&modules.environment);
    let (fish, fish_blend, shadows) = f.fish(&modules.fish);
    let (lines_fogged, lines_overlay) = f.lines(&modules.lines);
    let skin_readback = f.skin_readback(&modules.readback);
    let pose = f.compute(&modules.pose, layouts.pose, "pose", "cs_pose");
    let cull_count = f.compute(&modules.cull, layouts.cull, "culling count", "cs_count");
    let cull_offsets = f.compute(&modules.cull, layouts.cull, "culling offsets", "cs_offsets");
    let cull_scatter = f.compute(&modules.cull, layouts.cull, "culling scatter", "cs_scatter");
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
        pose,
        cull_count,
        cull_offsets,
        cull_scatter,
    })
}

/// Composes and compiles the shader modules; the first that fails is the error, with a map of
/// the files its compiled text joins.
fn compile_modules(device: &wgpu::Device, sources: &ShaderSources) -> Result<Modules, RenderError> {
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
    Ok(Modules {
        fish: module("fish.wgsl", true, true)?,
        environment: module("environment.wgsl", true, false)?,
        lines: module("lines.wgsl", true, false)?,
        readback: module("skin_readback.wgsl", false, true)?,
        pose: module("pose.wgsl", false, false)?,
        cull: module("cull.wgsl", false, false)?,
    })
}

/// One render pipeline's varying parts (see [`Factory::render`]).
struct RenderPipe<'a> {
    label: &'a str,
    layout: &'a wgpu::PipelineLayout,
    module: &'a wgpu::ShaderModule,
    vs: &'a str,
    fs: &'a str,
    buffers: &'a [Option<wgpu::VertexBufferLayout<'a>>],
    primitive: wgpu::PrimitiveState,
    depth_stencil: Option<wgpu::DepthStencilState>,
    targets: &'a [Option<wgpu::ColorTargetState>],
}

/// What every pipeline shares: the device, the pipeline layouts, the colour format and the
/// multisampling.
struct Factory<'a> {
    device: &'a wgpu::Device,
    readback_layout: &'a wgpu::BindGroupLayout,
    scene_pl: wgpu::PipelineLayout,
    fish_pl: wgpu::PipelineLayout,
    color_format: wgpu::TextureFormat,
    multisample: wgpu::MultisampleState,
}

impl<'a> Factory<'a> {
    fn new(
        device: &'a wgpu::Device,
        layouts: &Layouts<'a>,
        color_format: wgpu::TextureFormat,
        sample_count: u32,
    ) -> Self {
        let scene_pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("scene pipeline layout"),
            bind_group_layouts: &[Some(layouts.scene)],
            immediate_size: 0,
        });
        let fish_pl = device.create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
            label: Some("fish pipeline layout"),
            bind_group_layouts: &[
                Some(layouts.scene),
                Some(layouts.material),
                Some(layouts.draw),
            ],
            immediate_size: 0,
        });
        Self {
            device,
            readback_layout: layouts.readback,
            scene_pl,
            fish_pl,
            color_format,
            multisample: wgpu::MultisampleState {
                count: sample_count,
                mask: !0,
                alpha_to_coverage_enabled: false,
            },
        }
    }

    fn depth(write: bool, compare: wgpu::CompareFunction) -> Option<wgpu::DepthStencilState> {
        Some(wgpu::DepthStencilState {
            format: DEPTH_FORMAT,
            depth_write_enabled: Some(write),
            depth_compare: Some(compare),
            stencil: wgpu::StencilState::default(),
            bias: wgpu::DepthBiasState::default(),
        })
    }

    fn target(&self, blend: Option<wgpu::BlendState>) -> [Option<wgpu::ColorTargetState>; 1] {
        [Some(wgpu::ColorTargetState {
            format: self.color_format,
            blend,
            write_mask: wgpu::ColorWrites::ALL,
        })]
    }

    fn render(&self, p: RenderPipe<'_>) -> wgpu::RenderPipeline {
        self.device
            .create_render_pipeline(&wgpu::RenderPipelineDescriptor {
                label: Some(p.label),
                layout: Some(p.layout),
                vertex: wgpu::VertexState {
                    module: p.module,
                    entry_point: Some(p.vs),
                    compilation_options: Default::default(),
                    buffers: p.buffers,
                },
                primitive: p.primitive,
                depth_stencil: p.depth_stencil,
                multisample: self.multisample,
                fragment: Some(wgpu::FragmentState {
                    module: p.module,
                    entry_point: Some(p.fs),
                    compilation_options: Default::default(),
                    targets: p.targets,
                }),
                multiview_mask: None,
                cache: None,
            })
    }

    /// The water background and the sand floor (full-screen and floor quads, no vertex
    /// buffers).
    fn environment(
        &self,
        module: &wgpu::ShaderModule,
    ) -> (wgpu::RenderPipeline, wgpu::RenderPipeline) {
        let opaque = self.target(None);
        let pipe = |label, vs, fs, depth_stencil| RenderPipe {
            label,
            layout: &self.scene_pl,
            module,
            vs,
            fs,
            buffers: &[],
            primitive: wgpu::PrimitiveState::default(),
            depth_stencil,
            targets: &opaque,
        };
        let background = self.render(pipe(
            "background pipeline",
            "vs_background",
            "fs_background",
            Self::depth(false, wgpu::CompareFunction::Always),
        ));
        let floor = self.render(pipe(
            "floor pipeline",
            "vs_floor",
            "fs_floor",
            Self::depth(true, wgpu::CompareFunction::Less),
        ));
        (background, floor)
    }

    /// Opaque fish, blended fish and fish shadows: the same mesh vertices, texture coordinates
    /// and tangents (slots 0 and 2; the instances are read from group 2), different blending
    /// and depth.
    fn fish(
        &self,
        module: &wgpu::ShaderModule,
    ) -> (
        wgpu::RenderPipeline,
        wgpu::RenderPipeline,
        wgpu::RenderPipeline,
    ) {
        let vertex_attrs = wgpu::vertex_attr_array![
            0 => Float32x3, 1 => Float32x3, 2 => Float32x4, 3 => Uint16x4, 4 => Float32x4
        ];
        let surface_attrs = wgpu::vertex_attr_array![8 => Float32x2, 9 => Float32x4];
        let buffers = [
            Some(wgpu::VertexBufferLayout {
                array_stride: std::mem::size_of::<Vertex>() as u64,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &vertex_attrs,
            }),
            None,
            Some(wgpu::VertexBufferLayout {
                array_stride: std::mem::size_of::<SurfaceVertex>() as u64,
                step_mode: wgpu::VertexStepMode::Vertex,
                attributes: &surface_attrs,
            }),
        ];
        let two_sided = wgpu::PrimitiveState {
            cull_mode: None,
            ..Default::default()
        };
        let pipe = |label, vs, fs, depth_stencil, targets| RenderPipe {
            label,
            layout: &self.fish_pl,
            module,
            vs,
            fs,
            buffers: &buffers,
            primitive: two_sided,
            depth_stencil,
            targets,
        };
        let opaque = self.target(None);
        let blended = self.target(Some(wgpu::BlendState::ALPHA_BLENDING));
        // Multiply the floor by the shadow's shade; depth tested against the floor, not written.
        let multiply = self.target(Some(wgpu::BlendState {
            color: wgpu::BlendComponent {
                src_factor: wgpu::BlendFactor::Zero,
                dst_factor: wgpu::BlendFactor::Src,
                operation: wgpu::BlendOperation::Add,
            },
            alpha: wgpu::BlendComponent::OVER,
        }));
        let fish = self.render(pipe(
            "fish pipeline",
            "vs_main",
            "fs_main",
            Self::depth(true, wgpu::CompareFunction::Less),
            &opaque,
        ));
        // BLEND materials: after every opaque fish, blended over them, depth tested against them
        // but not written, so blended fins show through each other and from both sides.
        let fish_blend = self.render(pipe(
            "blended fish pipeline",
            "vs_main",
            "fs_main",
            Self::depth(false, wgpu::CompareFunction::Less),
            &blended,
        ));
        let shadows = self.render(pipe(
            "fish shadow pipeline",
            "vs_shadow",
            "fs_shadow",
            Self::depth(false, wgpu::CompareFunction::LessEqual),
            &multiply,
        ));
        (fish, fish_blend, shadows)
    }

    /// Tank edges (fogged, depth tested) and overlays (on top of everything).
    fn lines(&self, module: &wgpu::ShaderModule) -> (wgpu::RenderPipeline, wgpu::RenderPipeline) {
        let line_attrs = wgpu::vertex_attr_array![0 => Float32x3, 1 => Float32x4];
        let buffers = [Some(wgpu::VertexBufferLayout {
            array_stride: std::mem::size_of::<LineVertex>() as u64,
            step_mode: wgpu::VertexStepMode::Vertex,
            attributes: &line_attrs,
        })];
        let blended = self.target(Some(wgpu::BlendState::ALPHA_BLENDING));
        let pipe = |label, fs, depth_stencil| RenderPipe {
            label,
            layout: &self.scene_pl,
            module,
            vs: "vs_line",
            fs,
            buffers: &buffers,
            primitive: wgpu::PrimitiveState {
                topology: wgpu::PrimitiveTopology::LineList,
                ..Default::default()
            },
            depth_stencil,
            targets: &blended,
        };
        let fogged = self.render(pipe(
            "tank edge lines pipeline",
            "fs_line_fogged",
            Self::depth(true, wgpu::CompareFunction::Less),
        ));
        let overlay = self.render(pipe(
            "overlay lines pipeline",
            "fs_line_overlay",
            Self::depth(false, wgpu::CompareFunction::Always),
        ));
        (fogged, overlay)
    }

    /// The compute pass [`super::Renderer::skin_positions`] runs.
    fn skin_readback(&self, module: &wgpu::ShaderModule) -> wgpu::ComputePipeline {
        self.compute(module, self.readback_layout, "skin read-back", "cs_skin")
    }

    /// A compute pipeline with one bind group of `layout`.
    fn compute(
        &self,
        module: &wgpu::ShaderModule,
        layout: &wgpu::BindGroupLayout,
        name: &str,
        entry_point: &str,
    ) -> wgpu::ComputePipeline {
        let layout = self
            .device
            .create_pipeline_layout(&wgpu::PipelineLayoutDescriptor {
                label: Some(&format!("{name} pipeline layout")),
                bind_group_layouts: &[Some(layout)],
                immediate_size: 0,
            });
        self.device
            .create_compute_pipeline(&wgpu::ComputePipelineDescriptor {
                label: Some(&format!("{name} pipeline")),
                layout: Some(&layout),
                module,
                entry_point: Some(entry_point),
                compilation_options: Default::default(),
                cache: None,
            })
    }
}
