//! glTF 2.0 materials for the runtime: what a species looks like beyond its per-vertex colours.
//!
//! [`read_materials`] records each material of a file when it is read (cheap: no image is
//! decoded); [`SceneMaterial::resolve`] decodes the images of each material a
//! [`super::FishModel`] uses. An image that is missing or malformed is a warning naming the file,
//! the image and which texture it is, and the fish is drawn with that texture's factors
//! (base colour factor × vertex colour, metallic and roughness factors, no normal map, no
//! occlusion, the emissive factor alone): never an error, never a black fish.
//!
//! What is kept: the base-colour, normal, metallic-roughness, occlusion and emissive textures
//! (each with its sampler), `baseColorFactor` (already in the vertex colours), `metallicFactor`,
//! `roughnessFactor`, the normal scale, the occlusion strength, `emissiveFactor`,
//! `alphaMode` / `alphaCutoff`, `doubleSided` and `KHR_materials_unlit`.
//!
//! One set of texture coordinates per material: the texCoord set and `KHR_texture_transform` of
//! its first texture (base colour, normal, metallic-roughness, occlusion, emissive, in that
//! order), baked into the mesh's texture coordinates. A texture of the same material that uses
//! another set or another transform is left out with a warning (rare in exported files: Blender
//! and the Sketchfab exports use one set for every map).

use std::path::{Path, PathBuf};
use std::sync::Arc;

/// How a material's alpha is used (glTF `alphaMode`).
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub enum AlphaMode {
    /// Alpha ignored; fully opaque.
    #[default]
    Opaque,
    /// Drawn where alpha ≥ `cutoff`, discarded elsewhere (`MASK`, default cutoff 0.5).
    Mask {
        /// `alphaCutoff`.
        cutoff: f32,
    },
    /// Blended over what is behind (`BLEND`).
    Blend,
}

/// Texture coordinate wrapping (glTF `wrapS` / `wrapT`).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Wrap {
    /// `REPEAT` (the default).
    #[default]
    Repeat,
    /// `MIRRORED_REPEAT`.
    Mirror,
    /// `CLAMP_TO_EDGE`.
    Clamp,
}

/// A texture's sampler: wrapping and filtering.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Sampler {
    /// Along u (`wrapS`).
    pub wrap_u: Wrap,
    /// Along v (`wrapT`).
    pub wrap_v: Wrap,
    /// Magnification is linear (else nearest). Default linear.
    pub mag_linear: bool,
    /// Minification within a level is linear (else nearest). Default linear.
    pub min_linear: bool,
    /// Blend between mip levels (else nearest level). Default linear.
    pub mip_linear: bool,
    /// Mipmaps are used at all (`NEAREST` / `LINEAR` min filters turn them off).
    pub mipmaps: bool,
}

impl Default for Sampler {
    fn default() -> Self {
        Self {
            wrap_u: Wrap::Repeat,
            wrap_v: Wrap::Repeat,
            mag_linear: true,
            min_linear: true,
            mip_linear: true,
            mipmaps: true,
        }
    }
}

/// A decoded image: RGBA8, rows top first. Base-colour and emissive images are sRGB-encoded
/// colour (and linear alpha); normal, metallic-roughness and occlusion images are linear data.
#[derive(Clone, PartialEq)]
pub struct TextureImage {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// `width × height × 4` bytes.
    pub rgba: Vec<u8>,
    /// How it is sampled.
    pub sampler: Sampler,
    /// Where it came from (`image 0 (textures/body.png)`), for messages.
    pub label: String,
}

impl std::fmt::Debug for TextureImage {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("TextureImage")
            .field("width", &self.width)
            .field("height", &self.height)
            .field("sampler", &self.sampler)
            .field("label", &self.label)
            .finish_non_exhaustive()
    }
}

impl TextureImage {
    /// The texel at integer coordinates (wrapped as the sampler says), as linear RGBA.
    pub fn texel_linear(&self, x: i64, y: i64) -> [f32; 4] {
        let wrap = |i: i64, n: u32, mode: Wrap| -> usize {
            let n = i64::from(n.max(1));
            match mode {
                Wrap::Repeat => i.rem_euclid(n) as usize,
                Wrap::Clamp => i.clamp(0, n - 1) as usize,
                Wrap::Mirror => {
                    let m = i.rem_euclid(2 * n);
                    (if m < n { m } else { 2 * n - 1 - m }) as usize
                }
            }
        };
        let x = wrap(x, self.width, self.sampler.wrap_u);
        let y = wrap(y, self.height, self.sampler.wrap_v);
        let at = (y * self.width as usize + x) * 4;
        let p = &self.rgba[at..at + 4];
        [
            srgb_to_linear(p[0]),
            srgb_to_linear(p[1]),
            srgb_to_linear(p[2]),
            f32::from(p[3]) / 255.0,
        ]
    }

    /// Bilinear (or nearest, as the sampler's magnification says) sample of the full-size
    /// image at texture coordinates `uv` (glTF convention: v down), linear RGBA.
    pub fn sample_linear(&self, uv: [f32; 2]) -> [f32; 4] {
        let x = uv[0] * self.width as f32 - 0.5;
        let y = uv[1] * self.height as f32 - 0.5;
        if !self.sampler.mag_linear {
            return self.texel_linear(x.round() as i64, y.round() as i64);
        }
        let (x0, y0) = (x.floor(), y.floor());
        let (fx, fy) = (x - x0, y - y0);
        let (x0, y0) = (x0 as i64, y0 as i64);
        let mut out = [0.0f32; 4];
        for (dx, dy, w) in [
            (0, 0, (1.0 - fx) * (1.0 - fy)),
            (1, 0, fx * (1.0 - fy)),
            (0, 1, (1.0 - fx) * fy),
            (1, 1, fx * fy),
        ] {
            let t = self.texel_linear(x0 + dx, y0 + dy);
            for k in 0..4 {
                out[k] += t[k] * w;
            }
        }
        out
    }
}

/// A linear colour channel as an 8-bit sRGB value (the inverse of [`srgb_to_linear`]), clamped
/// to [0, 1] first.
pub fn linear_to_srgb8(linear: f32) -> u8 {
    let c = linear.clamp(0.0, 1.0);
    let s = if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0).round() as u8
}

/// sRGB-encoded byte → linear value in [0, 1].
pub fn srgb_to_linear(c: u8) -> f32 {
    let s = f32::from(c) / 255.0;
    if s <= 0.040_45 {
        s / 12.92
    } else {
        ((s + 0.055) / 1.055).powf(2.4)
    }
}

/// The material a species is drawn with.
#[derive(Debug, Clone, PartialEq)]
pub struct Material {
    /// The material's name in the file, if any.
    pub name: Option<String>,
    /// `baseColorFactor` (informational: the vertex colours already include it).
    pub base_color_factor: [f32; 4],
    /// The decoded base-colour texture; `None` when the material has none or it could not be
    /// read (then a warning says why).
    pub base_color_texture: Option<Arc<TextureImage>>,
    /// `metallicFactor` (glTF default 1).
    pub metallic: f32,
    /// `roughnessFactor` (glTF default 1).
    pub roughness: f32,
    /// `metallicRoughnessTexture`: roughness in G, metallic in B (linear), multiplying the
    /// factors.
    pub metallic_roughness_texture: Option<Arc<TextureImage>>,
    /// `normalTexture` (tangent space, linear RGB).
    pub normal_texture: Option<Arc<TextureImage>>,
    /// `normalTexture.scale`: the map's x and y are multiplied by it.
    pub normal_scale: f32,
    /// `occlusionTexture` (R channel, linear).
    pub occlusion_texture: Option<Arc<TextureImage>>,
    /// `occlusionTexture.strength`: 0 no effect, 1 the full map.
    pub occlusion_strength: f32,
    /// `emissiveTexture` (sRGB), multiplying `emissive`.
    pub emissive_texture: Option<Arc<TextureImage>>,
    /// Alpha handling.
    pub alpha_mode: AlphaMode,
    /// Both faces are lit as front faces (`doubleSided`). Fish are always drawn without
    /// back-face culling, since fins are single sheets; this only matters for lighting.
    pub double_sided: bool,
    /// `KHR_materials_unlit`: the base colour is shown as is, without lighting.
    pub unlit: bool,
    /// `emissiveFactor`, linear RGB added to the lit colour.
    pub emissive: [f32; 3],
}

impl Default for Material {
    /// A plain white dielectric (metallic 0, roughness 0.5), what meshes without a material
    /// (the procedural test fish, props, glTF primitives with no material) are drawn with.
    /// glTF's own defaults (metallic 1, roughness 1) only apply to materials a file declares.
    fn default() -> Self {
        Self {
            name: None,
            base_color_factor: [1.0; 4],
            base_color_texture: None,
            metallic: 0.0,
            roughness: 0.5,
            metallic_roughness_texture: None,
            normal_texture: None,
            normal_scale: 1.0,
            occlusion_texture: None,
            occlusion_strength: 1.0,
            emissive_texture: None,
            alpha_mode: AlphaMode::Opaque,
            double_sided: false,
            unlit: false,
            emissive: [0.0; 3],
        }
    }
}

/// Where an image's bytes are.
#[derive(Debug, Clone)]
pub enum ImageSource {
    /// An external file (the URI resolved against the glTF file's folder).
    File(PathBuf),
    /// Bytes inside the file (a buffer view or a data URI).
    Bytes(Arc<[u8]>),
    /// Not readable; why.
    Unreadable(String),
}

/// A material as recorded when the file is read; images not yet decoded.
#[derive(Debug, Clone, Default)]
pub struct SceneMaterial {
    /// The material with no texture decoded yet.
    pub material: Material,
    /// The base-colour texture, if the material has one.
    pub base_color: Option<SceneTexture>,
    /// The metallic-roughness texture, if any.
    pub metallic_roughness: Option<SceneTexture>,
    /// The normal texture, if any.
    pub normal: Option<SceneTexture>,
    /// The occlusion texture, if any.
    pub occlusion: Option<SceneTexture>,
    /// The emissive texture, if any.
    pub emissive: Option<SceneTexture>,
}

/// Which of a material's textures (for messages and for how its image is stored).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TextureKind {
    /// `baseColorTexture` (sRGB).
    BaseColor,
    /// `normalTexture` (linear).
    Normal,
    /// `metallicRoughnessTexture` (linear).
    MetallicRoughness,
    /// `occlusionTexture` (linear).
    Occlusion,
    /// `emissiveTexture` (sRGB).
    Emissive,
}

impl TextureKind {
    /// Every kind, in the order the texture coordinates are chosen from.
    pub const ALL: [TextureKind; 5] = [
        TextureKind::BaseColor,
        TextureKind::Normal,
        TextureKind::MetallicRoughness,
        TextureKind::Occlusion,
        TextureKind::Emissive,
    ];

    /// How messages name it (`base colour texture` …).
    pub fn name(self) -> &'static str {
        match self {
            TextureKind::BaseColor => "base colour texture",
            TextureKind::Normal => "normal texture",
            TextureKind::MetallicRoughness => "metallic-roughness texture",
            TextureKind::Occlusion => "occlusion texture",
            TextureKind::Emissive => "emissive texture",
        }
    }

    /// What the fish is drawn with instead when the texture cannot be used.
    fn fallback(self) -> &'static str {
        match self {
            TextureKind::BaseColor => "drawn with the base colour only",
            TextureKind::Normal => "drawn without the normal map",
            TextureKind::MetallicRoughness => "drawn with the metallic and roughness factors",
            TextureKind::Occlusion => "drawn without occlusion",
            TextureKind::Emissive => "drawn with the emissive factor only",
        }
    }
}

/// A texture reference of a [`SceneMaterial`].
#[derive(Debug, Clone)]
pub struct SceneTexture {
    /// The image index in the file.
    pub image: usize,
    /// The image's URI or name, for messages.
    pub image_name: String,
    /// Its bytes.
    pub source: ImageSource,
    /// How it is sampled.
    pub sampler: Sampler,
    /// Which TEXCOORD_n set it uses (`KHR_texture_transform`'s override applied).
    pub tex_coord: u32,
    /// `KHR_texture_transform` as a 2×3 affine matrix (rows), identity when absent.
    pub transform: [[f32; 3]; 2],
}

/// The largest side a base-colour texture keeps; larger images are downsampled when decoded
/// (a fish fills at most a few hundred pixels of the screen; 2048 keeps texel detail at a
/// full-screen close-up while a 4096² image would cost 85 MB of GPU memory with mipmaps).
pub const MAX_TEXTURE_SIDE: u32 = 2048;

const IDENTITY_TRANSFORM: [[f32; 3]; 2] = [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]];

/// Records every material of `doc`. `buffers` are the file's buffers; `path` the file (image
/// URIs resolve against its folder).
pub fn read_materials(doc: &gltf::Document, buffers: &[&[u8]], path: &Path) -> Vec<SceneMaterial> {
    doc.materials()
        .map(|m| {
            let pbr = m.pbr_metallic_roughness();
            let normal = m.normal_texture();
            let occlusion = m.occlusion_texture();
            let material = Material {
                name: m.name().map(str::to_string),
                base_color_factor: pbr.base_color_factor(),
                base_color_texture: None,
                metallic: pbr.metallic_factor(),
                roughness: pbr.roughness_factor(),
                metallic_roughness_texture: None,
                normal_texture: None,
                normal_scale: normal.as_ref().map_or(1.0, |n| n.scale()),
                occlusion_texture: None,
                occlusion_strength: occlusion.as_ref().map_or(1.0, |o| o.strength()),
                emissive_texture: None,
                alpha_mode: match m.alpha_mode() {
                    gltf::material::AlphaMode::Opaque => AlphaMode::Opaque,
                    gltf::material::AlphaMode::Mask => AlphaMode::Mask {
                        cutoff: m.alpha_cutoff().unwrap_or(0.5),
                    },
                    gltf::material::AlphaMode::Blend => AlphaMode::Blend,
                },
                double_sided: m.double_sided(),
                unlit: m.unlit(),
                emissive: m.emissive_factor(),
            };
            let base_color = pbr
                .base_color_texture()
                .map(|info| scene_texture(doc.as_json(), &info, buffers, path));
            let metallic_roughness = pbr
                .metallic_roughness_texture()
                .map(|info| scene_texture(doc.as_json(), &info, buffers, path));
            // Normal and occlusion infos are their own types; their texture and set are the
            // same fields.
            let normal = normal.map(|n| {
                let mut t =
                    scene_texture_of(doc.as_json(), &n.texture(), n.tex_coord(), buffers, path);
                if let Some(v) = n.extension_value("KHR_texture_transform") {
                    t.transform = transform_from_json(v, &mut t.tex_coord);
                }
                t
            });
            let occlusion = occlusion.map(|o| {
                let mut t =
                    scene_texture_of(doc.as_json(), &o.texture(), o.tex_coord(), buffers, path);
                if let Some(v) = o.extension_value("KHR_texture_transform") {
                    t.transform = transform_from_json(v, &mut t.tex_coord);
                }
                t
            });
            let emissive = m
                .emissive_texture()
                .map(|info| scene_texture(doc.as_json(), &info, buffers, path));
            SceneMaterial {
                material,
                base_color,
                metallic_roughness,
                normal,
                occlusion,
                emissive,
            }
        })
        .collect()
}

/// uv' = T · R · S · uv, `KHR_texture_transform`'s definition, as a 2×3 matrix.
fn transform_matrix(offset: [f32; 2], rotation: f32, scale: [f32; 2]) -> [[f32; 3]; 2] {
    let [ox, oy] = offset;
    let [sx, sy] = scale;
    let (sin, cos) = rotation.sin_cos();
    [[cos * sx, sin * sy, ox], [-sin * sx, cos * sy, oy]]
}

/// `KHR_texture_transform` of a normal or occlusion texture (the gltf crate has no typed
/// accessor for those): read from the extension's JSON, defaults where a field is missing or
/// not a number. Sets `tex_coord` when the extension overrides it.
fn transform_from_json(v: &serde_json::Value, tex_coord: &mut u32) -> [[f32; 3]; 2] {
    let pair = |key: &str, default: [f32; 2]| -> [f32; 2] {
        match v.get(key).and_then(|p| p.as_array()) {
            Some(a) if a.len() == 2 => [
                a[0].as_f64().map_or(default[0], |x| x as f32),
                a[1].as_f64().map_or(default[1], |x| x as f32),
            ],
            _ => default,
        }
    };
    if let Some(set) = v.get("texCoord").and_then(|t| t.as_u64()) {
        *tex_coord = set as u32;
    }
    let rotation = v.get("rotation").and_then(|r| r.as_f64()).unwrap_or(0.0) as f32;
    transform_matrix(
        pair("offset", [0.0, 0.0]),
        rotation,
        pair("scale", [1.0, 1.0]),
    )
}

fn scene_texture(
    root: &gltf::json::Root,
    info: &gltf::texture::Info,
    buffers: &[&[u8]],
    path: &Path,
) -> SceneTexture {
    let mut t = scene_texture_of(root, &info.texture(), info.tex_coord(), buffers, path);
    if let Some(tt) = info.texture_transform() {
        if let Some(set) = tt.tex_coord() {
            t.tex_coord = set;
        }
        t.transform = transform_matrix(tt.offset(), tt.rotation(), tt.scale());
    }
    t
}

/// Why image `index` of a file cannot be read at all, before asking the gltf crate for its
/// source (which panics on an image with neither a `uri` nor a `bufferView`, or a `bufferView`
/// without a `mimeType`; its validation lets both through).
pub fn image_problem(root: &gltf::json::Root, index: usize) -> Option<&'static str> {
    let image = root.images.get(index)?;
    match (&image.uri, &image.buffer_view) {
        (None, None) => Some("the image has neither a uri nor a bufferView"),
        (_, Some(_)) if image.mime_type.is_none() => {
            Some("the image has a bufferView but no mimeType")
        }
        (_, Some(v)) if v.value() >= root.buffer_views.len() => {
            Some("the image's bufferView does not exist")
        }
        _ => None,
    }
}

fn scene_texture_of(
    root: &gltf::json::Root,
    tex: &gltf::Texture,
    tex_coord: u32,
    buffers: &[&[u8]],
    path: &Path,
) -> SceneTexture {
    let image = tex.source();
    let s = tex.sampler();
    let wrap = |w: gltf::texture::WrappingMode| match w {
        gltf::texture::WrappingMode::Repeat => Wrap::Repeat,
        gltf::texture::WrappingMode::MirroredRepeat => Wrap::Mirror,
        gltf::texture::WrappingMode::ClampToEdge => Wrap::Clamp,
    };
    use gltf::texture::{MagFilter, MinFilter};
    let (min_linear, mip_linear, mipmaps) = match s.min_filter() {
        None | Some(MinFilter::LinearMipmapLinear) => (true, true, true),
        Some(MinFilter::Nearest) => (false, false, false),
        Some(MinFilter::Linear) => (true, false, false),
        Some(MinFilter::NearestMipmapNearest) => (false, false, true),
        Some(MinFilter::LinearMipmapNearest) => (true, false, true),
        Some(MinFilter::NearestMipmapLinear) => (false, true, true),
    };
    let sampler = Sampler {
        wrap_u: wrap(s.wrap_s()),
        wrap_v: wrap(s.wrap_t()),
        mag_linear: s.mag_filter() != Some(MagFilter::Nearest),
        min_linear,
        mip_linear,
        mipmaps,
    };
    let transform = IDENTITY_TRANSFORM;
    let index = image.index();
    if let Some(problem) = image_problem(root, index) {
        return SceneTexture {
            image: index,
            image_name: format!("image {index}"),
            source: ImageSource::Unreadable(problem.into()),
            sampler,
            tex_coord,
            transform,
        };
    }
    let (image_name, source) = match image.source() {
        gltf::image::Source::Uri { uri, .. } => {
            if uri.starts_with("data:") {
                let name = format!("image {index} (data URI)");
                let src = match decode_data_uri(uri) {
                    Some(bytes) => ImageSource::Bytes(bytes.into()),
                    None => ImageSource::Unreadable("malformed base64 data URI".into()),
                };
                (name, src)
            } else {
                let base = path.parent().unwrap_or(Path::new("."));
                let file = base.join(percent_decode(uri));
                (format!("image {index} ({uri})"), ImageSource::File(file))
            }
        }
        gltf::image::Source::View { view, .. } => {
            let name = format!(
                "image {index} ({})",
                image.name().unwrap_or("in a buffer view")
            );
            let bytes = buffers.get(view.buffer().index()).and_then(|b| {
                let end = view.offset().checked_add(view.length())?;
                b.get(view.offset()..end)
            });
            let src = match bytes {
                Some(b) => ImageSource::Bytes(b.into()),
                None => ImageSource::Unreadable(format!(
                    "buffer view {} lies outside its buffer",
                    view.index()
                )),
            };
            (name, src)
        }
    };
    SceneTexture {
        image: index,
        image_name,
        source,
        sampler,
        tex_coord,
        transform,
    }
}

impl SceneMaterial {
    /// The material's texture of `kind`, if it has one.
    pub fn texture(&self, kind: TextureKind) -> Option<&SceneTexture> {
        match kind {
            TextureKind::BaseColor => self.base_color.as_ref(),
            TextureKind::Normal => self.normal.as_ref(),
            TextureKind::MetallicRoughness => self.metallic_roughness.as_ref(),
            TextureKind::Occlusion => self.occlusion.as_ref(),
            TextureKind::Emissive => self.emissive.as_ref(),
        }
    }

    /// The texture coordinates the material is drawn with: the set and transform of its first
    /// texture ([`TextureKind::ALL`] order), `None` when it has no texture.
    pub fn uv_source(&self) -> Option<(u32, [[f32; 3]; 2])> {
        TextureKind::ALL
            .iter()
            .find_map(|&k| self.texture(k))
            .map(|t| (t.tex_coord, t.transform))
    }

    /// The material with its images decoded (downsampled to [`MAX_TEXTURE_SIDE`], several at
    /// once). `has_uvs` says whether every vertex drawn with it has the coordinate set of
    /// [`SceneMaterial::uv_source`]. Anything that stops a texture from being used adds a
    /// warning naming `path`, the image and the kind of texture, and the material is drawn
    /// without that texture (with its factors).
    pub fn resolve(&self, path: &Path, has_uvs: bool, warnings: &mut Vec<String>) -> Material {
        use rayon::prelude::*;
        let mut material = self.material.clone();
        let Some(source) = self.uv_source() else {
            return material;
        };
        let file = path.display();
        let mut wanted = Vec::new();
        for kind in TextureKind::ALL {
            let Some(tex) = self.texture(kind) else {
                continue;
            };
            let (name, fallback) = (kind.name(), kind.fallback());
            if (tex.tex_coord, tex.transform) != source {
                warnings.push(format!(
                    "{file}: {}: the {name} uses TEXCOORD_{} or a texture transform other than the material's first texture (TEXCOORD_{}), and shoal draws a material with one set; {fallback}",
                    tex.image_name, tex.tex_coord, source.0
                ));
            } else if !has_uvs {
                warnings.push(format!(
                    "{file}: {}: the {name} needs TEXCOORD_{} on every vertex; {fallback}",
                    tex.image_name, tex.tex_coord
                ));
            } else {
                wanted.push((kind, tex));
            }
        }
        let decoded: Vec<_> = wanted
            .par_iter()
            .map(|&(kind, tex)| (kind, tex, decode(tex)))
            .collect();
        for (kind, tex, result) in decoded {
            match result {
                Ok(image) => {
                    let image = Some(Arc::new(image));
                    match kind {
                        TextureKind::BaseColor => material.base_color_texture = image,
                        TextureKind::Normal => material.normal_texture = image,
                        TextureKind::MetallicRoughness => {
                            material.metallic_roughness_texture = image;
                        }
                        TextureKind::Occlusion => material.occlusion_texture = image,
                        TextureKind::Emissive => material.emissive_texture = image,
                    }
                }
                Err(why) => warnings.push(format!(
                    "{file}: {}: {why}; the {} is not used, {}",
                    tex.image_name,
                    kind.name(),
                    kind.fallback()
                )),
            }
        }
        material
    }
}

impl Material {
    /// Whether any texture is drawn (the mesh then needs texture coordinates).
    pub fn has_textures(&self) -> bool {
        self.base_color_texture.is_some()
            || self.normal_texture.is_some()
            || self.metallic_roughness_texture.is_some()
            || self.occlusion_texture.is_some()
            || self.emissive_texture.is_some()
    }

    /// The material without any texture (drawn with its factors).
    pub fn without_textures(&self) -> Material {
        Material {
            base_color_texture: None,
            normal_texture: None,
            metallic_roughness_texture: None,
            occlusion_texture: None,
            emissive_texture: None,
            ..self.clone()
        }
    }
}

/// Why a material's texture is not drawn (a warning: the material falls back to its factors).
#[derive(Debug, thiserror::Error)]
enum DecodeError {
    /// The image file could not be read.
    #[error("cannot read {}: {source}", path.display())]
    Read {
        /// The image file.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The glTF already said why its image cannot be had (see [`ImageSource::Unreadable`]).
    #[error("{0}")]
    Unreadable(String),
    /// The bytes are no image the `image` crate reads.
    #[error("cannot decode: {0}")]
    Decode(#[source] image::ImageError),
    /// The image has no pixels.
    #[error("the image is empty")]
    Empty,
}

fn decode(tex: &SceneTexture) -> Result<TextureImage, DecodeError> {
    let bytes: Arc<[u8]> = match &tex.source {
        ImageSource::Bytes(b) => b.clone(),
        ImageSource::File(f) => std::fs::read(f)
            .map_err(|source| DecodeError::Read {
                path: f.clone(),
                source,
            })?
            .into(),
        ImageSource::Unreadable(why) => return Err(DecodeError::Unreadable(why.clone())),
    };
    let img = image::load_from_memory(&bytes).map_err(DecodeError::Decode)?;
    let mut rgba = img.to_rgba8();
    let (w, h) = rgba.dimensions();
    if w == 0 || h == 0 {
        return Err(DecodeError::Empty);
    }
    let largest = w.max(h);
    if largest > MAX_TEXTURE_SIDE {
        let scale = MAX_TEXTURE_SIDE as f32 / largest as f32;
        let nw = ((w as f32 * scale).round() as u32).max(1);
        let nh = ((h as f32 * scale).round() as u32).max(1);
        rgba = image::imageops::resize(&rgba, nw, nh, image::imageops::FilterType::Triangle);
    }
    let (width, height) = rgba.dimensions();
    Ok(TextureImage {
        width,
        height,
        rgba: rgba.into_raw(),
        sampler: tex.sampler,
        label: tex.image_name.clone(),
    })
}

/// Applies a 2×3 texture transform to coordinates.
pub fn transform_uvs(uvs: &mut [[f32; 2]], t: &[[f32; 3]; 2]) {
    if *t == IDENTITY_TRANSFORM {
        return;
    }
    for uv in uvs {
        let [u, v] = *uv;
        *uv = [
            t[0][0] * u + t[0][1] * v + t[0][2],
            t[1][0] * u + t[1][1] * v + t[1][2],
        ];
    }
}

fn decode_data_uri(uri: &str) -> Option<Vec<u8>> {
    let (_, data) = uri.split_once(";base64,")?;
    base64::decode(data).ok()
}

/// `%XX` escapes in a URI path decoded.
pub fn percent_decode(s: &str) -> String {
    let hex = |b: u8| (b as char).to_digit(16);
    let bytes = s.as_bytes();
    let mut out = Vec::with_capacity(bytes.len());
    let mut i = 0;
    while i < bytes.len() {
        if bytes[i] == b'%'
            && i + 2 < bytes.len()
            && let (Some(h), Some(l)) = (hex(bytes[i + 1]), hex(bytes[i + 2]))
        {
            out.push((h * 16 + l) as u8);
            i += 3;
            continue;
        }
        out.push(bytes[i]);
        i += 1;
    }
    String::from_utf8_lossy(&out).into_owned()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn data_uris_decode() {
        assert_eq!(
            decode_data_uri("data:image/png;base64,aGVsbG8=").unwrap(),
            b"hello"
        );
        assert!(decode_data_uri("data:image/png;base64,a*b").is_none());
    }

    #[test]
    fn wrap_modes_pick_the_right_texels() {
        let rgba: Vec<u8> = (0..4u8).flat_map(|i| [i * 60, 0, 0, 255]).collect();
        let mut t = TextureImage {
            width: 4,
            height: 1,
            rgba,
            sampler: Sampler::default(),
            label: "t".into(),
        };
        let red = |t: &TextureImage, x| t.texel_linear(x, 0)[0];
        assert_eq!(red(&t, 5), red(&t, 1));
        t.sampler.wrap_u = Wrap::Clamp;
        assert_eq!(red(&t, 9), red(&t, 3));
        t.sampler.wrap_u = Wrap::Mirror;
        assert_eq!(red(&t, 4), red(&t, 3));
        assert_eq!(red(&t, -1), red(&t, 0));
    }

    #[test]
    fn texture_transform_json_matches_the_typed_one() {
        // What normal and occlusion textures read from their extension JSON.
        let mut set = 0;
        let v = serde_json::json!({"offset": [0.5, -1.0], "scale": [2.0, 3.0], "texCoord": 1});
        assert_eq!(
            transform_from_json(&v, &mut set),
            [[2.0, 0.0, 0.5], [0.0, 3.0, -1.0]]
        );
        assert_eq!(set, 1);
        let r = std::f32::consts::FRAC_PI_2;
        let t = transform_from_json(
            &serde_json::json!({"rotation": r, "scale": "bad"}),
            &mut set,
        );
        assert_eq!(t, transform_matrix([0.0, 0.0], r, [1.0, 1.0]));
    }

    #[test]
    fn texture_transform_offsets_and_scales() {
        let mut uv = [[1.0, 1.0]];
        transform_uvs(&mut uv, &[[2.0, 0.0, 0.5], [0.0, 3.0, -1.0]]);
        assert_eq!(uv[0], [2.5, 2.0]);
    }
}
