//! A species' materials on the GPU: each material's five textures (base colour and emissive as
//! Rgba8UnormSrgb, normal, metallic-roughness and occlusion as Rgba8Unorm, each with a mip chain
//! made on the CPU, colour ones in linear light), their samplers and a small uniform of alpha
//! mode, cutoff, flags and factors; one bind group (group 1 of the fish pipelines) per material,
//! so a textured species is still one instanced draw per material and level of detail.
//!
//! A material without some texture gets a 1×1 stand-in that leaves its factor as it is (white;
//! a flat (0.5, 0.5, 1) normal): the fragment shader does the same work for every species, and
//! the vertex colours (base colour factor × COLOR_0) carry the colour.

use bytemuck::{Pod, Zeroable};

use shoal_core::skin::Material;
use shoal_core::skin::material::{AlphaMode, Sampler, TextureImage, Wrap, srgb_to_linear};

/// `MaterialParams.alpha_mode` values (see `shaders/fish.wgsl`).
pub const ALPHA_OPAQUE: u32 = 0;
/// Discard below the cutoff.
pub const ALPHA_MASK: u32 = 1;
/// Blended, drawn in the second fish pass.
pub const ALPHA_BLEND: u32 = 2;
/// `MaterialParams.flags` bit: the material is unlit (`KHR_materials_unlit`).
pub const FLAG_UNLIT: u32 = 1;
/// `MaterialParams.flags` bit: the material has a normal map (and the mesh tangents).
pub const FLAG_NORMAL_MAP: u32 = 2;
/// `MaterialParams.flags` bit: the material has a metallic-roughness texture.
pub const FLAG_METALLIC_ROUGHNESS_MAP: u32 = 4;
/// `MaterialParams.flags` bit: the material has an occlusion texture.
pub const FLAG_OCCLUSION_MAP: u32 = 8;
/// `MaterialParams.flags` bit: the material has an emissive texture.
pub const FLAG_EMISSIVE_MAP: u32 = 16;

/// The uniform of group 1, binding 2.
#[repr(C)]
#[derive(Debug, Clone, Copy, Pod, Zeroable)]
pub(super) struct MaterialParams {
    alpha_mode: u32,
    alpha_cutoff: f32,
    flags: u32,
    normal_scale: f32,
    emissive: [f32; 4],
    metallic: f32,
    roughness: f32,
    occlusion_strength: f32,
    _pad: f32,
}

/// A material uploaded: its bind group and whether it is drawn in the blended pass.
#[derive(Debug)]
pub(super) struct GpuMaterial {
    pub bind_group: wgpu::BindGroup,
    pub blend: bool,
}

/// The texture slots of group 1, in binding order (texture at `2k + 1` … see [`layout`]).
const SLOTS: usize = 5;

/// The bind group layout of group 1: base-colour texture (0) and sampler (1), params (2), then
/// normal (3, 4), metallic-roughness (5, 6), occlusion (7, 8) and emissive (9, 10) textures and
/// samplers.
pub(super) fn layout(device: &wgpu::Device) -> wgpu::BindGroupLayout {
    let texture = |binding| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Texture {
            sample_type: wgpu::TextureSampleType::Float { filterable: true },
            view_dimension: wgpu::TextureViewDimension::D2,
            multisampled: false,
        },
        count: None,
    };
    let sampler = |binding| wgpu::BindGroupLayoutEntry {
        binding,
        visibility: wgpu::ShaderStages::FRAGMENT,
        ty: wgpu::BindingType::Sampler(wgpu::SamplerBindingType::Filtering),
        count: None,
    };
    let mut entries = vec![
        texture(0),
        sampler(1),
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
    ];
    for k in 1..SLOTS as u32 {
        entries.push(texture(1 + 2 * k));
        entries.push(sampler(2 + 2 * k));
    }
    device.create_bind_group_layout(&wgpu::BindGroupLayoutDescriptor {
        label: Some("material bind group layout"),
        entries: &entries,
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
    mip_chain_encoded(width, height, rgba, mask_cutoff, true)
}

/// Like [`mip_chain`]; `srgb` false for an image of linear data (normal, metallic-roughness,
/// occlusion), whose bytes are averaged as they are.
pub fn mip_chain_encoded(
    width: u32,
    height: u32,
    rgba: &[u8],
    mask_cutoff: Option<f32>,
    srgb: bool,
) -> Vec<(u32, u32, Vec<u8>)> {
    let lut: Vec<f32> = (0..=255u8)
        .map(|c| {
            if srgb {
                srgb_to_linear(c)
            } else {
                f32::from(c) / 255.0
            }
        })
        .collect();
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
        let encode = |x: f32| {
            if srgb {
                shoal_core::skin::material::linear_to_srgb8(x)
            } else {
                (x.clamp(0.0, 1.0) * 255.0).round() as u8
            }
        };
        let bytes = next
            .chunks_exact(4)
            .flat_map(|p| {
                [
                    encode(p[0]),
                    encode(p[1]),
                    encode(p[2]),
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

/// One texture of a material uploaded: the image (or the 1×1 `fallback` texel), its mips and
/// its sampler.
fn upload_texture(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    label: &str,
    image: Option<&TextureImage>,
    fallback: [u8; 4],
    srgb: bool,
    mask_cutoff: Option<f32>,
) -> (wgpu::TextureView, wgpu::Sampler) {
    use wgpu::util::DeviceExt;
    let stand_in = TextureImage {
        width: 1,
        height: 1,
        rgba: fallback.to_vec(),
        sampler: Sampler::default(),
        label: "stand-in".into(),
    };
    let image = image.unwrap_or(&stand_in);
    let levels = if image.sampler.mipmaps {
        mip_chain_encoded(image.width, image.height, &image.rgba, mask_cutoff, srgb)
    } else {
        vec![(image.width, image.height, image.rgba.clone())]
    };
    let data: Vec<u8> = levels.iter().flat_map(|l| l.2.iter().copied()).collect();
    let texture = device.create_texture_with_data(
        queue,
        &wgpu::TextureDescriptor {
            label: Some(label),
            size: wgpu::Extent3d {
                width: image.width,
                height: image.height,
                depth_or_array_layers: 1,
            },
            mip_level_count: levels.len() as u32,
            sample_count: 1,
            dimension: wgpu::TextureDimension::D2,
            format: if srgb {
                wgpu::TextureFormat::Rgba8UnormSrgb
            } else {
                wgpu::TextureFormat::Rgba8Unorm
            },
            usage: wgpu::TextureUsages::TEXTURE_BINDING | wgpu::TextureUsages::COPY_DST,
            view_formats: &[],
        },
        wgpu::util::TextureDataOrder::LayerMajor,
        &data,
    );
    let s = image.sampler;
    let sampler = device.create_sampler(&wgpu::SamplerDescriptor {
        label: Some(label),
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
    (
        texture.create_view(&wgpu::TextureViewDescriptor::default()),
        sampler,
    )
}

/// Uploads `material` (or the plain white default) and makes its bind group. `has_tangents`:
/// the mesh has tangents, without which a normal map is not drawn.
pub(super) fn upload(
    device: &wgpu::Device,
    queue: &wgpu::Queue,
    layout: &wgpu::BindGroupLayout,
    label: &str,
    material: Option<&Material>,
    has_tangents: bool,
) -> GpuMaterial {
    use wgpu::util::DeviceExt;
    let default = Material::default();
    let material = material.unwrap_or(&default);
    let mask_cutoff = match material.alpha_mode {
        AlphaMode::Mask { cutoff } => Some(cutoff),
        _ => None,
    };
    let normal_map = material.normal_texture.as_deref().filter(|_| has_tangents);
    let textures = [
        (
            "base colour",
            material.base_color_texture.as_deref(),
            [255; 4],
            true,
            mask_cutoff,
        ),
        ("normal", normal_map, [128, 128, 255, 255], false, None),
        (
            "metallic-roughness",
            material.metallic_roughness_texture.as_deref(),
            [255; 4],
            false,
            None,
        ),
        (
            "occlusion",
            material.occlusion_texture.as_deref(),
            [255; 4],
            false,
            None,
        ),
        (
            "emissive",
            material.emissive_texture.as_deref(),
            [255; 4],
            true,
            None,
        ),
    ];
    let views: Vec<(wgpu::TextureView, wgpu::Sampler)> = textures
        .iter()
        .map(|&(what, image, fallback, srgb, cutoff)| {
            let label = format!("{label} {what}");
            upload_texture(device, queue, &label, image, fallback, srgb, cutoff)
        })
        .collect();
    let (alpha_mode, alpha_cutoff) = match material.alpha_mode {
        AlphaMode::Opaque => (ALPHA_OPAQUE, 0.0),
        AlphaMode::Mask { cutoff } => (ALPHA_MASK, cutoff),
        AlphaMode::Blend => (ALPHA_BLEND, 0.0),
    };
    let finite = |x: f32, default: f32| if x.is_finite() { x } else { default };
    let mut flags = 0;
    if material.unlit {
        flags |= FLAG_UNLIT;
    }
    for (present, flag) in [
        (normal_map.is_some(), FLAG_NORMAL_MAP),
        (
            material.metallic_roughness_texture.is_some(),
            FLAG_METALLIC_ROUGHNESS_MAP,
        ),
        (material.occlusion_texture.is_some(), FLAG_OCCLUSION_MAP),
        (material.emissive_texture.is_some(), FLAG_EMISSIVE_MAP),
    ] {
        if present {
            flags |= flag;
        }
    }
    let params = MaterialParams {
        alpha_mode,
        alpha_cutoff,
        flags,
        normal_scale: finite(material.normal_scale, 1.0),
        emissive: [
            material.emissive[0],
            material.emissive[1],
            material.emissive[2],
            0.0,
        ],
        metallic: finite(material.metallic, 0.0).clamp(0.0, 1.0),
        roughness: finite(material.roughness, 1.0).clamp(0.0, 1.0),
        occlusion_strength: finite(material.occlusion_strength, 1.0).clamp(0.0, 1.0),
        _pad: 0.0,
    };
    let params = device.create_buffer_init(&wgpu::util::BufferInitDescriptor {
        label: Some("material params"),
        contents: bytemuck::bytes_of(&params),
        usage: wgpu::BufferUsages::UNIFORM,
    });
    let mut entries = vec![
        wgpu::BindGroupEntry {
            binding: 0,
            resource: wgpu::BindingResource::TextureView(&views[0].0),
        },
        wgpu::BindGroupEntry {
            binding: 1,
            resource: wgpu::BindingResource::Sampler(&views[0].1),
        },
        wgpu::BindGroupEntry {
            binding: 2,
            resource: params.as_entire_binding(),
        },
    ];
    for (k, (view, sampler)) in views.iter().enumerate().skip(1) {
        entries.push(wgpu::BindGroupEntry {
            binding: 1 + 2 * k as u32,
            resource: wgpu::BindingResource::TextureView(view),
        });
        entries.push(wgpu::BindGroupEntry {
            binding: 2 + 2 * k as u32,
            resource: wgpu::BindingResource::Sampler(sampler),
        });
    }
    let bind_group = device.create_bind_group(&wgpu::BindGroupDescriptor {
        label: Some(label),
        layout,
        entries: &entries,
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
    fn linear_mips_average_the_bytes() {
        // Data textures (normal, metallic-roughness, occlusion) are not sRGB: 0 and 255 give 128.
        let rgba = [0, 0, 0, 255, 255, 255, 255, 255];
        let levels = mip_chain_encoded(2, 1, &rgba, None, false);
        assert_eq!(levels[1].2[..3], [128, 128, 128]);
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
