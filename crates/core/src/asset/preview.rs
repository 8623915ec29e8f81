//! A CPU preview of a skinned fish: side and top orthographic views, flat-shaded triangles with
//! a z-buffer. For checking shape, fins and bending by eye (`shoal asset preview`); the real
//! renderer is `shoal-render`.
//!
//! With materials ([`render_views_material`], [`render_views_mesh`] for a mesh with several)
//! it samples each triangle's base-colour texture (bilinear, at full size) and honours the alpha
//! mode as the renderer does: `MASK` cuts texels below the cutoff away, `BLEND` blends over what
//! is drawn (in triangle order, depth tested, not written), and an unlit material is not shaded.
//!
//! The preview models base colour and alpha only: normal, metallic-roughness, occlusion and
//! emissive maps, and the renderer's water lighting, are not drawn here (its shading is a fixed
//! flat light for judging shape). Where it claims to agree with the renderer is an unlit
//! material's texture colours (`crates/render/tests/render/render_materials.rs` checks them pixel for pixel).

use glam::{Vec3, Vec4};
use image::{Rgb, RgbImage};

use crate::skin::{AlphaMode, Material, SkinnedMesh};

/// One orthographic view: screen right and up directions (unit, perpendicular); depth is
/// `right × up` (towards the viewer).
#[derive(Debug, Clone, Copy)]
pub struct View {
    /// Screen-right direction in model space.
    pub right: Vec3,
    /// Screen-up direction in model space.
    pub up: Vec3,
}

/// Draws `views` side by side vertically (one panel each, `size` × `size` pixels) of the mesh
/// given by `positions`, vertex `colors` (linear RGBA) and a triangle list. All panels share one
/// scale so sizes compare.
pub fn render_views(
    positions: &[Vec3],
    colors: &[[f32; 4]],
    indices: &[u32],
    views: &[View],
    size: u32,
) -> RgbImage {
    draw(positions, colors, &[], |_| None, indices, views, size)
}

/// Like [`render_views`] for a skinned mesh posed at `positions`: its vertex colours, texture
/// coordinates and each part's material.
pub fn render_views_mesh(
    positions: &[Vec3],
    mesh: &SkinnedMesh,
    views: &[View],
    size: u32,
) -> RgbImage {
    // The material of each triangle, from the mesh's parts (material 0 outside them).
    let mut of_triangle = vec![0u16; mesh.indices.len() / 3];
    for part in &mesh.parts {
        let first = part.first_index as usize / 3;
        let end = (first + part.num_indices as usize / 3).min(of_triangle.len());
        for t in of_triangle.get_mut(first..end).into_iter().flatten() {
            *t = part.material;
        }
    }
    draw(
        positions,
        &mesh.colors,
        &mesh.uvs,
        |t| {
            mesh.materials
                .get(usize::from(of_triangle[t]))
                .or(mesh.materials.first())
        },
        &mesh.indices,
        views,
        size,
    )
}

/// Like [`render_views`], with the mesh's material and its base-colour texture coordinates
/// (`uvs`, one per vertex; empty when the material has no texture).
pub fn render_views_material(
    positions: &[Vec3],
    colors: &[[f32; 4]],
    uvs: &[[f32; 2]],
    material: Option<&Material>,
    indices: &[u32],
    views: &[View],
    size: u32,
) -> RgbImage {
    draw(positions, colors, uvs, |_| material, indices, views, size)
}

/// The rasterizer behind the public functions; `material_of(t)` is triangle t's material.
fn draw<'m>(
    positions: &[Vec3],
    colors: &[[f32; 4]],
    uvs: &[[f32; 2]],
    material_of: impl Fn(usize) -> Option<&'m Material>,
    indices: &[u32],
    views: &[View],
    size: u32,
) -> RgbImage {
    let mut img = RgbImage::from_pixel(size, size * views.len() as u32, Rgb([24, 40, 64]));
    let centre = positions.iter().copied().sum::<Vec3>() / positions.len().max(1) as f32;
    let radius = positions
        .iter()
        .map(|p| p.distance(centre))
        .fold(1e-6f32, f32::max);
    let scale = 0.48 * size as f32 / radius;
    let light = Vec3::new(0.3, 0.8, 0.5).normalize();
    for (panel, view) in views.iter().enumerate() {
        let depth_dir = view.right.cross(view.up);
        let mut zbuf = vec![f32::NEG_INFINITY; (size * size) as usize];
        let project = |p: Vec3| -> Vec3 {
            let d = p - centre;
            Vec3::new(
                size as f32 * 0.5 + d.dot(view.right) * scale,
                size as f32 * 0.5 - d.dot(view.up) * scale,
                d.dot(depth_dir),
            )
        };
        for (t, tri) in indices.chunks_exact(3).enumerate() {
            let [a, b, c] = [tri[0] as usize, tri[1] as usize, tri[2] as usize];
            if a >= positions.len() || b >= positions.len() || c >= positions.len() {
                continue;
            }
            let material = material_of(t);
            let texture = material
                .and_then(|m| m.base_color_texture.as_deref())
                .filter(|_| uvs.len() == positions.len());
            let alpha_mode = material.map_or(AlphaMode::Opaque, |m| m.alpha_mode);
            let unlit = material.is_some_and(|m| m.unlit);
            let n = (positions[b] - positions[a])
                .cross(positions[c] - positions[a])
                .normalize_or_zero();
            let shade = if unlit {
                1.0
            } else {
                0.35 + 0.65 * n.dot(light).abs()
            };
            let col = (Vec4::from(colors[a]) + Vec4::from(colors[b]) + Vec4::from(colors[c])) / 3.0;
            let (pa, pb, pc) = (
                project(positions[a]),
                project(positions[b]),
                project(positions[c]),
            );
            let area = (pb.x - pa.x) * (pc.y - pa.y) - (pb.y - pa.y) * (pc.x - pa.x);
            if area.abs() < 1e-9 {
                continue;
            }
            let x0 = pa.x.min(pb.x).min(pc.x).floor().max(0.0) as u32;
            let x1 = pa.x.max(pb.x).max(pc.x).ceil().min(size as f32 - 1.0) as u32;
            let y0 = pa.y.min(pb.y).min(pc.y).floor().max(0.0) as u32;
            let y1 = pa.y.max(pb.y).max(pc.y).ceil().min(size as f32 - 1.0) as u32;
            for y in y0..=y1 {
                for x in x0..=x1 {
                    let (px, py) = (x as f32 + 0.5, y as f32 + 0.5);
                    let w0 = ((pb.x - px) * (pc.y - py) - (pb.y - py) * (pc.x - px)) / area;
                    let w1 = ((pc.x - px) * (pa.y - py) - (pc.y - py) * (pa.x - px)) / area;
                    let w2 = 1.0 - w0 - w1;
                    if w0 < 0.0 || w1 < 0.0 || w2 < 0.0 {
                        continue;
                    }
                    let z = w0 * pa.z + w1 * pb.z + w2 * pc.z;
                    let zi = (y * size + x) as usize;
                    if z <= zbuf[zi] {
                        continue;
                    }
                    let mut rgba = col;
                    if let Some(t) = texture {
                        let uv = [
                            w0 * uvs[a][0] + w1 * uvs[b][0] + w2 * uvs[c][0],
                            w0 * uvs[a][1] + w1 * uvs[b][1] + w2 * uvs[c][1],
                        ];
                        rgba *= Vec4::from(t.sample_linear(uv));
                    }
                    let lit = rgba.truncate() * shade;
                    let py = y + panel as u32 * size;
                    match alpha_mode {
                        AlphaMode::Opaque => {}
                        AlphaMode::Mask { cutoff } => {
                            if rgba.w < cutoff {
                                continue;
                            }
                        }
                        AlphaMode::Blend => {
                            let below = img
                                .get_pixel(x, py)
                                .0
                                .map(crate::skin::material::srgb_to_linear);
                            let a = rgba.w.clamp(0.0, 1.0);
                            let out = lit * a + Vec3::new(below[0], below[1], below[2]) * (1.0 - a);
                            img.put_pixel(
                                x,
                                py,
                                Rgb([
                                    crate::skin::material::linear_to_srgb8(out.x),
                                    crate::skin::material::linear_to_srgb8(out.y),
                                    crate::skin::material::linear_to_srgb8(out.z),
                                ]),
                            );
                            continue;
                        }
                    }
                    zbuf[zi] = z;
                    img.put_pixel(
                        x,
                        py,
                        Rgb([
                            crate::skin::material::linear_to_srgb8(lit.x),
                            crate::skin::material::linear_to_srgb8(lit.y),
                            crate::skin::material::linear_to_srgb8(lit.z),
                        ]),
                    );
                }
            }
        }
    }
    img
}
