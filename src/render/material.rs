//! A species' material on the GPU: its base-colour texture (Rgba8UnormSrgb with a mip chain
//! made on the CPU in linear light), its sampler and a small uniform of alpha mode, cutoff,
//! flags and emissive colour; one bind group (group 1 of the fish pipelines) per mesh, so a
//! textured species is still one instanced draw per level of detail.
//!
//! A mesh with no texture gets a 1×1 white one: the fragment shader does the same work for
//! every species, and the vertex colours (base colour factor × COLOR_0) carry the colour.

use bytemuck::{Pod, Zeroable};

use crate::skin::Material;
use crate::skin::material::{AlphaMode, Sampler, TextureImage, Wrap, srgb_to_linear};

/// `MaterialParams.alpha_mode` values (see `shaders/fish.wgsl`).
pub const ALPHA_OPAQUE: u32 = 0;
/// Discard below the cutoff.
pub const ALPHA_MASK: u32 = 1;
/// Blended, drawn in the second fish pass.
pub const ALPHA_BLEND: u32 = 2;
/// `MaterialParams.flags` bit: the material is unlit (`KHR_materials_unlit`).
pub const FLAG_UNLIT: u32 = 1;

/// The uniform of group 1, binding 2.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(super) struct MaterialParams {
    alpha_mode: u32,
    alpha_cutoff: f32,
    flags: u32,
    _pad: u32,
    emissive: [f32; 4],
}

/// A material uploaded: its bind group and whether it is drawn in the blended pass.
#[derive(Debug)]
pub(super) struct GpuMaterial {
    pub bind_group: wgpu::BindGroup,
    pub blend: bool,
}

/// The bind group layout of group 1: texture, sampler, params.
pub(super) fn layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("material bind group layout"),
        entries: &[
            wgpu::BindGroupLayoutEntry {
                binding: 0,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Texture {
                    sample_type: wgpu::TextureSampleType::Float { filterable: true },
                    view_dimension: wgpu::TextureViewDimension::D2,
                    multisampled: false,
                },
                count: None,
            },
            wgpu::BindGroupLayoutEntry {
                binding: 1,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
                count: None,
            },
            wgpu::BindGroupLayoutEntry {
                binding: 2,
                visibility: wgpu::ShaderStages::FRAGMENT,
                ty: wgpu::BindingType::Buffer {
                    ty: wgpu::BufferBindingType::Uniform,
                    has_dynamic_offset: false,
                    min_binding_size: None,
                },
                count: None,
            },
        ],
    })
}

/// The mip chain of an sRGB RGBA8 image, full size first, each level half the previous
/// (rounded down, at least 1), averaged in linear light (alpha linearly).
///
/// With `mask_cutoff` (a `MASK` material) alpha is kept binary instead: a texel of the next level
/// is opaque (1) where at least half of the texels it covers pass the cutoff, else clear (0).
/// Averaged alpha would sink below the cutoff at a distance and the fins would crumble away (the
/// RedFinnedFish's cutoff is 1.0, so any averaging at an edge cut the texel).
pub fn mip_chain(
    width: u32,
    height: u32,
    rgba: &[u8],
    mask_cutoff: Option<f32>,
) -> Vec<(u32, u32, Vec<u8>)> {
    let lut: Vec<f32> = (0..=255u8).map(srgb_to_linear).collect();
    let mut levels = vec![(width, height, rgba.to_vec())];
    let mut linear: Vec<f32> = rgba
        .chunks_exact(4)
        .flat_map(|p| {
            [
                lut[usize::from(p[0])],
                lut[usize::from(p[1])],
                lut[usize::from(p[2])],
                f32::from(p[3]) / 255.0,
            ]
        })
        .collect();
    let (mut w, mut h) = (width as usize, height as usize);
    while w > 1 || h > 1 {
        let (nw, nh) = ((w / 2).max(1), (h / 2).max(1));
        let mut next = vec![0.0f32; nw * nh * 4];
        let pass = |a: f32| match mask_cutoff {
            Some(c) => {
                if a >= c {
                    1.0
                } else {
                    0.0
                }
            }
            None => a,
        };
        // Each texel of the next level averages the 2×2 (or 2×1 / 1×2) block above it.
        let (sx, sy) = (if w > 1 { 2 } else { 1 }, if h > 1 { 2 } else { 1 });
        let inv = 1.0 / (sx * sy) as f32;
        for y in 0..nh {
            for x in 0..nw {
                let o = (y * nw + x) * 4;
                for dy in 0..sy {
                    for dx in 0..sx {
                        let i = ((y * sy + dy) * w + x * sx + dx) * 4;
                        for k in 0..3 {
                            next[o + k] += linear[i + k] * inv;
                        }
                        next[o + 3] += pass(linear[i + 3]) * inv;
                    }
                }
                if mask_cutoff.is_some() {
                    next[o + 3] = if next[o + 3] >= 0.5 { 1.0 } else { 0.0 };
                }
            }
        }
        let bytes = next
            .chunks_exact(4)
            .flat_map(|p| {
                [
                    crate::skin::material::linear_to_srgb8(p[0]),
                    crate::skin::material::linear_to_srgb8(p[1]),
                    crate::skin::material::linear_to_srgb8(p[2]),
                    (p[3].clamp(0.0, 1.0) * 255.0).round() as u8,
                ]
            })
            .collect();
        levels.push((nw as u32, nh as u32, bytes));
        linear = next;
        (w, h) = (nw, nh);
    }
    levels
}

fn address(w: Wrap) -> wgpu::AddressMode {
    match w {
        Wrap::Repeat => wgpu::AddressMode::Repeat,
        Wrap::Mirror => wgpu::AddressMode::MirrorRepeat,
        Wrap::Clamp => wgpu::AddressMode::ClampToEdge,
    }
}

fn filter(linear: bool) -> wgpu::FilterMode {
    if linear {
        wgpu::FilterMode::Linear
    } else {
        wgpu::FilterMode::Nearest
    }
}

/// Uploads `material` (or the plain white default) and makes its bind group.
pub(super) fn upload(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    layout: &wgpu::BindGroupLayout,
    label: &str,
    material: Option<&Material>,
) -> GpuMaterial {
    use wgpu::util::DeviceExt;
    let default = Material::default();
    let material = material.unwrap_or(&default);
    let white = TextureImage {
        width: 1,
        height: 1,
        rgba: vec![255; 4],
        sampler: Sampler::default(),
        label: "white".into(),
    };
    let image = material.base_color_texture.as_deref().unwrap_or(&white);
    let mask_cutoff = match material.alpha_mode {
        AlphaMode::Mask { cutoff } => Some(cutoff),
        _ => None,
    };
    let levels = if image.sampler.mipmaps {
        mip_chain(image.width, image.height, &image.rgba, mask_cutoff)
    } else {
        vec![(image.width, image.height, image.rgba.clone())]
    };
    let data: Vec<u8> = levels.iter().flat_map(|l| l.2.iter().copied()).collect();
    let texture_label = format!("{label} base colour");
    let texture = device.create_texture_with_data(
        queue,
        &wgpu::TextureDescriptor {
            label: Some(&texture_label),
            size: wgpu::Extent3d {
                width: image.width,
                height: image.height,
                depth_or_array_layers: 1,
            },
            mip_level_count: levels.len() as u32,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: wgpu::TextureFormat::Rgba8UnormSrgb,
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        },
        wgpu::util::TextureDataOrder::LayerMajor,
        &data,
    );
    let s = image.sampler;
    let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some(&texture_label),
        address_mode_u: address(s.wrap_u),
        address_mode_v: address(s.wrap_v),
        mag_filter: filter(s.mag_linear),
        min_filter: filter(s.min_linear),
        mipmap_filter: if s.mip_linear {
            wgpu::MipmapFilterMode::Linear
        } else {
            wgpu::MipmapFilterMode::Nearest
        },
        ..Default::default()
    });
    let (alpha_mode, alpha_cutoff) = match material.alpha_mode {
        AlphaMode::Opaque => (ALPHA_OPAQUE, 0.0),
        AlphaMode::Mask { cutoff } => (ALPHA_MASK, cutoff),
        AlphaMode::Blend => (ALPHA_BLEND, 0.0),
    };
    let params = MaterialParams {
        alpha_mode,
        alpha_cutoff,
        flags: if material.unlit { FLAG_UNLIT } else { 0 },
        _pad: 0,
        emissive: [
            material.emissive[0],
            material.emissive[1],
            material.emissive[2],
            0.0,
        ],
    };
    let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("material params"),
        contents: bytemuck::bytes_of(&params),
        usage: wgpu::BufferUsages::UNIFORM,
    });
    let view = texture.create_view(&wgpu::TextureViewDescriptor::default());
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(&texture_label),
        layout,
        entries: &[
            wgpu::BindGroupEntry {
                binding: 0,
                resource: wgpu::BindingResource::TextureView(&view),
            },
            wgpu::BindGroupEntry {
                binding: 1,
                resource: wgpu::BindingResource::Sampler(&sampler),
            },
            wgpu::BindGroupEntry {
                binding: 2,
                resource: params.as_entire_binding(),
            },
        ],
    });
    GpuMaterial {
        bind_group,
        blend: material.alpha_mode == AlphaMode::Blend,
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mip_chain_averages_in_linear_light() {
        // Black and white texels average to linear 0.5, which is sRGB 188, not 128.
        let rgba = [
            0, 0, 0, 255, 255, 255, 255, 255, 0, 0, 0, 255, 255, 255, 255, 255,
        ];
        let levels = mip_chain(2, 2, &rgba, None);
        assert_eq!(levels.len(), 2);
        assert_eq!((levels[1].0, levels[1].1), (1, 1));
        assert_eq!(levels[1].2[0], 188);
        assert_eq!(levels[1].2[3], 255);
    }

    #[test]
    fn mip_chain_of_a_non_square_image_ends_at_one_texel() {
        let levels = mip_chain(8, 2, &[128; 8 * 2 * 4], None);
        let sizes: Vec<(u32, u32)> = levels.iter().map(|l| (l.0, l.1)).collect();
        assert_eq!(sizes, vec![(8, 2), (4, 1), (2, 1), (1, 1)]);
        assert!(levels.iter().all(|l| l.2.len() == (l.0 * l.1 * 4) as usize));
    }

    #[test]
    fn masked_mips_keep_coverage_binary() {
        // Alphas 255, 255, 254, 0 with cutoff 1.0: two of four pass, so the texel stays opaque;
        // averaged it would be 0.75 and cut away.
        let a = |v| [200, 100, 50, v];
        let rgba = [a(255), a(255), a(254), a(0)].concat();
        assert_eq!(mip_chain(2, 2, &rgba, Some(1.0))[1].2[3], 255);
        assert_eq!(mip_chain(2, 2, &rgba, None)[1].2[3], 191);
        let rgba = [a(255), a(0), a(254), a(0)].concat();
        assert_eq!(mip_chain(2, 2, &rgba, Some(1.0))[1].2[3], 0);
    }
}
