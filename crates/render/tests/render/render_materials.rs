//! glTF materials in the renderer and the CPU preview (issue 15): base-colour textures, alpha
//! modes, a missing or broken image, draw calls that do not grow with the fish count, and the
//! third-party RedFinnedFish, rigged, as a reference image; emissive, occlusion, normal and
//! metallic-roughness maps checked at known pixels, each kind missing or broken, and species
//! whose primitives use several materials.
//!
//! Runs on lavapipe (software Vulkan) like the other render tests.

use std::path::{Path, PathBuf};

use glam::{Mat4, Vec3};
use serde_json::{Value, json};
use shoal_core::asset::{Influences, MaterialSet, RiggedMesh};
use shoal_core::skin::{AlphaMode, FishModel};
use shoal_render::{
    Camera, FishInstance, FrameInput, Gpu, Look, MeshId, MeshUpload, OffscreenTarget, Renderer,
    TankBounds,
};

const RED: [u8; 4] = [255, 0, 0, 255];
const GREEN: [u8; 4] = [0, 255, 0, 255];
const BLUE: [u8; 4] = [0, 0, 255, 255];
const YELLOW: [u8; 4] = [255, 255, 0, 255];

fn gpu() -> Gpu {
    Gpu::headless().expect("a GPU adapter (lavapipe: apt install mesa-vulkan-drivers)")
}

/// PNG bytes of a `w × h` image from row-major RGBA texels.
fn png(w: u32, h: u32, texels: &[[u8; 4]]) -> Vec<u8> {
    let img = image::RgbaImage::from_raw(w, h, texels.concat()).unwrap();
    let mut out = std::io::Cursor::new(Vec::new());
    img.write_to(&mut out, image::ImageFormat::Png).unwrap();
    out.into_inner()
}

/// A 2 × 2 quad in the xy plane at `z`, facing +z, on one joint (plus a leaf), its texture
/// coordinates spanning the texture once (glTF: v down, so the image's top row is at +y).
fn quad(z: f32) -> RiggedMesh {
    RiggedMesh {
        name: "quad".into(),
        joint_names: vec!["root".into(), "tail_end".into()],
        joint_parents: vec![None, Some(0)],
        joint_positions: vec![Vec3::new(0.0, 0.0, z), Vec3::new(1.0, 0.0, z)],
        positions: vec![
            Vec3::new(-1.0, 1.0, z),
            Vec3::new(1.0, 1.0, z),
            Vec3::new(-1.0, -1.0, z),
            Vec3::new(1.0, -1.0, z),
        ],
        normals: vec![Vec3::Z; 4],
        colors: vec![[1.0; 4]; 4],
        uvs: Some(vec![[0.0, 0.0], [1.0, 0.0], [0.0, 1.0], [1.0, 1.0]]),
        tangents: None,
        influences: vec![Influences::from_pairs(&[(0, 1.0)], 0); 4],
        indices: vec![0, 2, 1, 1, 2, 3],
        parts: Vec::new(),
    }
}

/// A material set with one embedded image and the given material JSON (its
/// `pbrMetallicRoughness.baseColorTexture` pointing at texture 0 with a nearest sampler).
fn textured(image: Vec<u8>, mut material: Value) -> MaterialSet {
    material["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": 0});
    MaterialSet {
        materials: json!([material]),
        textures: json!([{"sampler": 0, "source": 0}]),
        samplers: json!([{"magFilter": 9728, "minFilter": 9728, "wrapS": 33071, "wrapT": 33071}]),
        images: vec![(image, "image/png".into())],
        material: 0,
    }
}

/// The four-colour test texture: red, green / blue, yellow.
fn four_colours() -> Vec<u8> {
    png(2, 2, &[RED, GREEN, BLUE, YELLOW])
}

fn unlit() -> Value {
    json!({"name": "test", "pbrMetallicRoughness": {}, "extensions": {"KHR_materials_unlit": {}}})
}

fn write(dir: &Path, name: &str, bytes: &[u8]) -> PathBuf {
    let p = dir.join(name);
    std::fs::write(&p, bytes).unwrap();
    p
}

/// Water that leaves colours alone: no fog, and the tank's surface below every test mesh (so
/// no depth tint), no caustics, no shadows.
fn clear_look() -> Look {
    Look {
        fog_density_per_unit: 0.0,
        caustic_strength: 0.0,
        shadows: false,
        ..Look::default()
    }
}

fn tank() -> TankBounds {
    TankBounds {
        min: Vec3::new(-50.0, -60.0, -50.0),
        max: Vec3::new(50.0, -10.0, 50.0),
    }
}

/// Renders the given meshes (uploaded in order), one fish per `(mesh, palette)`.
fn render(
    gpu: &Gpu,
    meshes: &[MeshUpload<'_>],
    fish: &[(u32, Mat4)],
    camera: Camera,
    size: (u32, u32),
    look: Look,
) -> (image::RgbaImage, shoal_render::RenderTimings) {
    let mut renderer = Renderer::new(gpu, OffscreenTarget::FORMAT).unwrap();
    // Pins the CPU path's counts and draw calls (render_cull checks the GPU path against it).
    renderer.set_culling(shoal_render::Culling::Cpu);
    for m in meshes {
        renderer.upload_mesh(gpu, m).unwrap();
    }
    let mut palettes = Vec::new();
    let mut instances = Vec::new();
    for &(mesh, root) in fish {
        let joints = renderer.mesh_num_joints(MeshId(mesh)).unwrap() as usize;
        instances.push(FishInstance {
            mesh: MeshId(mesh),
            palette_offset: palettes.len() as u32,
            tint: [1.0; 3],
            selected: false,
        });
        palettes.extend(std::iter::repeat_n(root, joints));
    }
    let input = FrameInput {
        gpu_pose: None,
        palettes: &palettes,
        instances: &instances,
        instances_revision: None,
        camera,
        tank: tank(),
        time_s: 0.0,
        props: &[],
        overlay: &[],
        look,
    };
    let target = OffscreenTarget::new(gpu, size.0, size.1);
    renderer
        .render(gpu, target.view(), target.size(), &input)
        .unwrap();
    (target.read_rgba8(gpu).unwrap(), renderer.timings())
}

/// Looking at the origin from +z.
fn front_camera(distance: f32) -> Camera {
    Camera {
        target: Vec3::ZERO,
        yaw_rad: 0.0,
        pitch_rad: 0.0,
        distance,
        fov_y_rad: 0.9,
    }
}

fn load(path: &Path) -> FishModel {
    FishModel::load(path).unwrap_or_else(|e| panic!("{e}"))
}

#[test]
fn textured_quad_shows_its_texels_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let glb = quad(0.0).to_glb(&textured(four_colours(), unlit()), "test");
    let model = load(&write(dir.path(), "quad.glb", &glb));
    assert!(model.warnings.is_empty(), "{:?}", model.warnings);
    let tex = model.mesh.material().base_color_texture.as_ref().unwrap();
    assert_eq!((tex.width, tex.height), (2, 2));
    assert!(model.mesh.material().unlit);
    let gpu = gpu();
    let upload = MeshUpload::from_skinned_mesh("quad", &model.mesh);
    let (img, _) = render(
        &gpu,
        &[upload],
        &[(0, Mat4::IDENTITY)],
        front_camera(3.0),
        (64, 64),
        clear_look(),
    );
    // The quad spans about 2 / (2 · 3 · tan 0.45) ≈ 69 % of the view: quadrant centres at
    // 50 % ± 17 %.
    for (x, y, want) in [
        (21, 21, RED),
        (42, 21, GREEN),
        (21, 42, BLUE),
        (42, 42, YELLOW),
    ] {
        assert_eq!(img.get_pixel(x, y).0, want, "pixel ({x}, {y})");
    }
}

/// MASK cuts away texels below the cutoff; BLEND shows what is behind, whichever species was
/// uploaded first.
#[test]
fn mask_discards_and_blend_mixes_over_opaque_fish() {
    let dir = tempfile::tempdir().unwrap();
    let half = [255, 255, 255, 128];
    // Left column: opaque red / transparent; right column: half-transparent white.
    let image = png(2, 2, &[RED, half, [255, 0, 0, 0], half]);
    let mut mask = unlit();
    mask["alphaMode"] = json!("MASK");
    mask["alphaCutoff"] = json!(0.6);
    let masked = load(&write(
        dir.path(),
        "mask.glb",
        &quad(0.5).to_glb(&textured(image.clone(), mask), "test"),
    ));
    assert_eq!(
        masked.mesh.material().alpha_mode,
        AlphaMode::Mask { cutoff: 0.6 }
    );
    let mut blend = unlit();
    blend["alphaMode"] = json!("BLEND");
    let blended = load(&write(
        dir.path(),
        "blend.glb",
        &quad(0.5).to_glb(&textured(image, blend), "test"),
    ));
    // Behind both: an opaque blue quad.
    let behind = load(&write(
        dir.path(),
        "behind.glb",
        &quad(0.0).to_glb(&textured(png(1, 1, &[BLUE]), unlit()), "test"),
    ));
    let gpu = gpu();
    fn front(m: &FishModel) -> MeshUpload<'_> {
        MeshUpload::from_skinned_mesh("front", &m.mesh)
    }
    let back = MeshUpload::from_skinned_mesh("behind", &behind.mesh);
    let fish = [(0, Mat4::IDENTITY), (1, Mat4::IDENTITY)];
    let (img, _) = render(
        &gpu,
        &[front(&masked), back],
        &fish,
        front_camera(3.0),
        (64, 64),
        clear_look(),
    );
    // Top left: opaque red kept; bottom left: alpha 0 cut, blue shows; right: alpha 0.5 < 0.6
    // cut, blue shows.
    assert_eq!(img.get_pixel(20, 20).0, RED);
    assert_eq!(img.get_pixel(20, 44).0, BLUE);
    assert_eq!(img.get_pixel(44, 20).0, BLUE);
    let (img, _) = render(
        &gpu,
        &[front(&blended), back],
        &fish,
        front_camera(3.0),
        (64, 64),
        clear_look(),
    );
    // Right column: half white over blue (linear 0.5 → sRGB ≈ 188 in red and green).
    let p = img.get_pixel(44, 20).0;
    assert!(
        (170..=205).contains(&p[0]) && (170..=205).contains(&p[1]) && p[2] == 255,
        "blended pixel {p:?}"
    );
    // Bottom left: alpha 0 shows only the blue behind.
    assert_eq!(img.get_pixel(20, 44).0, BLUE);
}

/// Patches a GLB's JSON chunk (for a broken image reference).
fn patch_glb(glb: &[u8], f: impl FnOnce(&mut Value)) -> Vec<u8> {
    let json_len = u32::from_le_bytes(glb[12..16].try_into().unwrap()) as usize;
    let mut root: Value = serde_json::from_slice(&glb[20..20 + json_len]).unwrap();
    f(&mut root);
    let mut text = serde_json::to_vec(&root).unwrap();
    while !text.len().is_multiple_of(4) {
        text.push(b' ');
    }
    let bin = &glb[20 + json_len..];
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&((12 + 8 + text.len() + bin.len()) as u32).to_le_bytes());
    out.extend_from_slice(&(text.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&text);
    out.extend_from_slice(bin);
    out
}

/// A missing or undecodable image is a warning naming the file and the image; the fish is drawn
/// with its base colour, not black.
#[test]
fn missing_or_broken_texture_warns_and_draws_the_base_colour() {
    let dir = tempfile::tempdir().unwrap();
    let mut material = unlit();
    material["pbrMetallicRoughness"]["baseColorFactor"] = json!([0.0, 1.0, 0.0, 1.0]);
    let good = quad(0.0).to_glb(&textured(four_colours(), material.clone()), "test");
    let missing = patch_glb(&good, |root| {
        root["images"][0] = json!({"uri": "textures/gone.png"});
    });
    let broken = quad(0.0).to_glb(&textured(b"not a png at all".to_vec(), material), "test");
    let gpu = gpu();
    for (name, bytes, says) in [
        ("missing.glb", missing, "gone.png"),
        ("broken.glb", broken, "cannot decode"),
    ] {
        let path = write(dir.path(), name, &bytes);
        let model = load(&path);
        let warning = model
            .warnings
            .iter()
            .find(|w| w.contains("image 0"))
            .unwrap_or_else(|| panic!("{name}: no image warning in {:?}", model.warnings));
        assert!(
            warning.contains(name) && warning.contains(says) && warning.contains("base colour"),
            "{warning}"
        );
        assert!(model.mesh.material().base_color_texture.is_none());
        let (img, _) = render(
            &gpu,
            &[MeshUpload::from_skinned_mesh(name, &model.mesh)],
            &[(0, Mat4::IDENTITY)],
            front_camera(3.0),
            (64, 64),
            clear_look(),
        );
        for (x, y) in [(21, 21), (42, 42)] {
            assert_eq!(img.get_pixel(x, y).0, GREEN, "{name} at ({x}, {y})");
        }
    }
}

/// One draw per species and level whatever the number of textured fish.
#[test]
fn textured_draw_calls_do_not_grow_with_the_fish_count() {
    let dir = tempfile::tempdir().unwrap();
    let glb = quad(0.0).to_glb(&textured(four_colours(), unlit()), "test");
    let model = load(&write(dir.path(), "quad.glb", &glb));
    let gpu = gpu();
    let count = |n: usize| {
        let fish: Vec<(u32, Mat4)> = (0..n)
            .map(|i| {
                let a = i as f32 * 0.37;
                (
                    0,
                    Mat4::from_translation(Vec3::new(a.sin(), a.cos(), -0.01 * i as f32)),
                )
            })
            .collect();
        let (_, t) = render(
            &gpu,
            &[MeshUpload::from_skinned_mesh("quad", &model.mesh)],
            &fish,
            front_camera(6.0),
            (32, 32),
            clear_look(),
        );
        assert_eq!(t.num_fish_drawn as usize, n);
        t.num_draw_calls
    };
    let one = count(1);
    assert_eq!(count(200), one);
    assert_eq!(count(1000), one);
}

/// The CPU preview and the renderer agree on a textured fish's colours: the unlit four-colour
/// quad seen face on gives the same texels in both.
#[test]
fn cpu_preview_and_gpu_agree_on_texture_colours() {
    use shoal_core::asset::preview::{View, render_views_material};
    let dir = tempfile::tempdir().unwrap();
    let glb = quad(0.0).to_glb(&textured(four_colours(), unlit()), "test");
    let model = load(&write(dir.path(), "quad.glb", &glb));
    let size = 64;
    let cpu = render_views_material(
        &model.mesh.positions,
        &model.mesh.colors,
        &model.mesh.uvs,
        Some(model.mesh.material()),
        &model.mesh.indices,
        &[View {
            right: Vec3::X,
            up: Vec3::Y,
        }],
        size,
    );
    let gpu = gpu();
    let (img, _) = render(
        &gpu,
        &[MeshUpload::from_skinned_mesh("quad", &model.mesh)],
        &[(0, Mat4::IDENTITY)],
        front_camera(3.0),
        (size, size),
        clear_look(),
    );
    // The preview scales the quad's bounding radius (√2) to 48 % of the panel: quadrant
    // centres at 50 % ± 17 %, as in the GPU image.
    for (x, y) in [(21, 21), (42, 21), (21, 42), (42, 42)] {
        let c = cpu.get_pixel(x, y).0;
        let g = img.get_pixel(x, y).0;
        assert_eq!([c[0], c[1], c[2]], [g[0], g[1], g[2]], "pixel ({x}, {y})");
    }
}

/// `../shared` beside the checkout, or `SHOAL_SHARED_DIR` where a checkout lives elsewhere.
fn red_finned_fish() -> PathBuf {
    let shared = std::env::var_os("SHOAL_SHARED_DIR").map_or_else(
        || shoal_core::source_root().join("../shared"),
        PathBuf::from,
    );
    shared.join("gltf-samples/RedFinnedFish/scene.gltf")
}

/// The rigged RedFinnedFish in a close-up: its texture shows (the textured picture differs from
/// the vertex-colour one over most of the body, in many colours), its alpha-masked fin cards are
/// cut to the fins' shape (fewer fish pixels than with the material ignored), and the picture
/// matches `crates/render/tests/reference/red_finned_fish.png` (same tolerance as `render_reference.rs`;
/// `SHOAL_BLESS=1` rewrites it).
#[test]
fn rigged_red_finned_fish_close_up() {
    use shoal_core::asset::rig::{RigOptions, rig_file};
    let rigged = rig_file(&red_finned_fish(), &RigOptions::default()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "red_finned_fish.glb", &rigged.glb);
    let model = load(&path);
    assert!(
        model.mesh.material().base_color_texture.is_some(),
        "{:?}",
        model.warnings
    );
    assert!(matches!(
        model.mesh.material().alpha_mode,
        AlphaMode::Mask { .. }
    ));
    // Its normal and metallic-roughness maps are drawn too, the normal map with the file's
    // tangents (kept by the rigger, carried into the bind shape).
    assert!(model.mesh.material().normal_texture.is_some());
    assert!(model.mesh.material().metallic_roughness_texture.is_some());
    assert_eq!(model.mesh.tangents.len(), model.mesh.positions.len());
    assert!(model.mesh.tangents.iter().all(|t| {
        let l = Vec3::new(t[0], t[1], t[2]).length();
        (l - 1.0).abs() < 1e-3 && t[3].abs() == 1.0
    }));
    let (lo, hi) = model
        .mesh
        .positions
        .iter()
        .fold((Vec3::INFINITY, Vec3::NEG_INFINITY), |(a, b), p| {
            (a.min(*p), b.max(*p))
        });
    // The file is in metres (0.76 long): scale it to aquarium units.
    let scale = 100.0;
    let centre = (lo + hi) * 0.5 * scale;
    let length = (hi - lo).max_element() * scale;
    // Side view (the fish lies along x), the fish above the water surface so only light and
    // texture colour it.
    let camera = Camera {
        target: centre,
        yaw_rad: 0.0,
        pitch_rad: 0.1,
        distance: length * 0.95,
        fov_y_rad: 0.9,
    };
    let look = Look {
        fog_density_per_unit: 0.0,
        shadows: false,
        caustic_strength: 0.0,
        ..Look::default()
    };
    let gpu = gpu();
    let size = (256, 160);
    let textured = MeshUpload::from_skinned_mesh("red finned fish", &model.mesh);
    let plain = MeshUpload {
        tangents: &[],
        materials: &[],
        parts: &[],
        uvs: &[],
        ..textured
    };
    let fish = [(0, Mat4::from_scale(Vec3::splat(scale)))];
    let (with_tex, _) = render(&gpu, &[textured], &fish, camera, size, look);
    let (without, _) = render(&gpu, &[plain], &fish, camera, size, look);
    let (empty, _) = render(&gpu, &[plain], &[], camera, size, look);
    let covered = |img: &image::RgbaImage| {
        img.enumerate_pixels()
            .filter(|(x, y, p)| p.0 != empty.get_pixel(*x, *y).0)
            .count()
    };
    let (n_tex, n_plain) = (covered(&with_tex), covered(&without));
    assert!(n_plain > 2000, "the fish covers {n_plain} pixels");
    assert!(
        (n_tex as f64) < 0.97 * n_plain as f64,
        "alpha-masked fins: {n_tex} fish pixels textured vs {n_plain} with the material ignored"
    );
    let mut colours = std::collections::BTreeSet::new();
    let mut changed = 0;
    for (x, y, p) in with_tex.enumerate_pixels() {
        if p.0 != empty.get_pixel(x, y).0 {
            colours.insert([p[0] / 16, p[1] / 16, p[2] / 16]);
            let q = without.get_pixel(x, y).0;
            if (0..3).any(|c| p[c].abs_diff(q[c]) > 24) {
                changed += 1;
            }
        }
    }
    assert!(
        changed as f64 > 0.5 * n_tex as f64,
        "the texture changes only {changed} of {n_tex} fish pixels"
    );
    assert!(colours.len() > 40, "only {} colours", colours.len());
    check_reference("red_finned_fish", &with_tex);

    // `SHOAL_DOC_IMAGES=1` also writes the before/after pictures of scripts/README.md's "Bring
    // your own fish" (material ignored, as the renderer drew it before issue 15; and now).
    if std::env::var_os("SHOAL_DOC_IMAGES").is_some_and(|v| v == "1") {
        let dir = shoal_core::source_root().join("docs/images");
        let big = (512, 320);
        render(&gpu, &[plain], &fish, camera, big, look)
            .0
            .save(dir.join("byof-before.png"))
            .unwrap();
        render(&gpu, &[textured], &fish, camera, big, look)
            .0
            .save(dir.join("byof-after.png"))
            .unwrap();
    }
}

/// Compares with `crates/render/tests/reference/<name>.png` like `render_reference.rs` (a pixel differs when
/// a channel is off by more than 16; at most 0.5 % may differ).
fn check_reference(name: &str, actual: &image::RgbaImage) {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/reference");
    let reference_path = dir.join(format!("{name}.png"));
    let actual_path = dir.join(format!("{name}-actual.png"));
    if std::env::var_os("SHOAL_BLESS").is_some_and(|v| v == "1") {
        actual.save(&reference_path).unwrap();
        return;
    }
    let Ok(reference) = image::open(&reference_path) else {
        actual.save(&actual_path).unwrap();
        panic!(
            "no reference {}; wrote {}: inspect it and run with SHOAL_BLESS=1 to accept",
            reference_path.display(),
            actual_path.display()
        );
    };
    let reference = reference.to_rgba8();
    assert_eq!(reference.dimensions(), actual.dimensions());
    let differing = actual
        .enumerate_pixels()
        .filter(|(x, y, a)| {
            let r = reference.get_pixel(*x, *y);
            (0..3).any(|c| a[c].abs_diff(r[c]) > 16)
        })
        .count();
    let fraction = differing as f64 / f64::from(actual.width() * actual.height());
    if fraction > 0.005 {
        actual.save(&actual_path).unwrap();
        panic!(
            "{name}: {:.2} % of pixels differ; see {}",
            fraction * 100.0,
            actual_path.display()
        );
    }
    let _ = std::fs::remove_file(&actual_path);
}

/// A material set with the given material JSON and 2 × 2 images (nearest, clamped); `maps` names
/// which texture info of the material points at which image, e.g. `("emissiveTexture", png)`.
/// `pbrMetallicRoughness.…` keys go inside that object.
fn with_maps(mut material: Value, maps: Vec<(&str, Vec<u8>)>) -> MaterialSet {
    let mut textures = Vec::new();
    let mut images = Vec::new();
    for (k, (key, image)) in maps.into_iter().enumerate() {
        let info = json!({"index": k});
        match key.strip_prefix("pbrMetallicRoughness.") {
            Some(inner) => material["pbrMetallicRoughness"][inner] = info,
            None => material[key] = info,
        }
        textures.push(json!({"sampler": 0, "source": k}));
        images.push((image, "image/png".to_string()));
    }
    MaterialSet {
        materials: json!([material]),
        textures: Value::Array(textures),
        samplers: json!([{"magFilter": 9728, "minFilter": 9728, "wrapS": 33071, "wrapT": 33071}]),
        images,
        material: 0,
    }
}

/// A lit material: base colour factor, metallic and roughness.
fn lit(base: [f32; 4], metallic: f32, roughness: f32) -> Value {
    json!({"name": "lit", "pbrMetallicRoughness": {
        "baseColorFactor": base, "metallicFactor": metallic, "roughnessFactor": roughness
    }})
}

/// The quad with `set` rendered face on (64 × 64) under `look`, after loading it with no
/// warnings.
fn render_quad(gpu: &Gpu, set: &MaterialSet, look: Look) -> image::RgbaImage {
    let dir = tempfile::tempdir().unwrap();
    let model = load(&write(
        dir.path(),
        "maps.glb",
        &quad(0.0).to_glb(set, "test"),
    ));
    assert!(model.warnings.is_empty(), "{:?}", model.warnings);
    let upload = MeshUpload::from_skinned_mesh("maps", &model.mesh);
    render(
        gpu,
        &[upload],
        &[(0, Mat4::IDENTITY)],
        front_camera(3.0),
        (64, 64),
        look,
    )
    .0
}

/// Quadrant centres of [`render_quad`]'s picture: top left, top right, bottom left, bottom
/// right (the texels of a 2 × 2 map in row order).
const QUADRANTS: [(u32, u32); 4] = [(21, 21), (42, 21), (21, 42), (42, 42)];

fn quadrants(img: &image::RgbaImage) -> [[u8; 4]; 4] {
    QUADRANTS.map(|(x, y)| img.get_pixel(x, y).0)
}

/// In darkness (no sun on the front, black water) a black quad glows only where its emissive
/// texture is lit: the red texel shows red, the black ones stay black.
#[test]
fn emissive_texture_lights_its_texels_in_darkness() {
    let dark = Look {
        water_deep: [0.0; 3],
        water_shallow: [0.0; 3],
        light_dir: Vec3::new(0.0, 0.0, -1.0),
        ..clear_look()
    };
    let mut m = lit([0.0, 0.0, 0.0, 1.0], 0.0, 1.0);
    m["emissiveFactor"] = json!([1.0, 1.0, 1.0]);
    let black = [0, 0, 0, 255];
    let set = with_maps(
        m,
        vec![("emissiveTexture", png(2, 2, &[RED, black, black, black]))],
    );
    let q = quadrants(&render_quad(&gpu(), &set, dark));
    assert!(q[0][0] >= 250 && q[0][1] <= 5 && q[0][2] <= 5, "{:?}", q[0]);
    for p in &q[1..] {
        assert!(p[0] <= 8 && p[1] <= 8 && p[2] <= 8, "{p:?}");
    }
}

/// The occlusion map darkens the ambient (water) light where it is black; with the sun behind
/// the quad only ambient light reaches its front. Strength 0 turns it off.
#[test]
fn occlusion_texture_darkens_its_black_texels() {
    let ambient_only = Look {
        water_deep: [1.0; 3],
        water_shallow: [1.0; 3],
        light_dir: Vec3::new(0.0, 0.0, -1.0),
        ..clear_look()
    };
    let white = [255; 4];
    let black = [0, 0, 0, 255];
    let occlusion = png(2, 2, &[black, white, black, white]);
    let gpu = gpu();
    let q = quadrants(&render_quad(
        &gpu,
        &with_maps(
            lit([1.0; 4], 0.0, 1.0),
            vec![("occlusionTexture", occlusion.clone())],
        ),
        ambient_only,
    ));
    // Left column occluded, right column open.
    for (dark, open) in [(q[0], q[1]), (q[2], q[3])] {
        assert!(open[1] > 120, "open texel {open:?}");
        assert!(
            i32::from(dark[1]) + 80 < i32::from(open[1]),
            "occluded {dark:?} vs open {open:?}"
        );
    }
    let mut set = with_maps(
        lit([1.0; 4], 0.0, 1.0),
        vec![("occlusionTexture", occlusion)],
    );
    set.materials[0]["occlusionTexture"]["strength"] = json!(0.0);
    let q = quadrants(&render_quad(&gpu, &set, ambient_only));
    assert_eq!(q[0], q[1], "strength 0 leaves the occluded texel lit");
}

/// A normal map tilts the shading: with the sun to the right (+x), texels whose normals lean
/// right are brighter than flat ones, and those leaning left darker; move the sun to the left
/// and the order turns round. The quad has no TANGENT, so this also checks the generated
/// (MikkTSpace) tangents point along +u, which is +x on the quad.
#[test]
fn normal_map_tilts_the_shading_towards_its_texels_normals() {
    let flat = [128, 128, 255, 255];
    let right = [218, 128, 218, 255]; // (0.7, 0, 0.7)
    let left = [38, 128, 218, 255]; // (−0.7, 0, 0.7)
    let normals = png(2, 2, &[flat, right, left, flat]);
    let set = with_maps(
        lit([0.8, 0.8, 0.8, 1.0], 0.0, 1.0),
        vec![("normalTexture", normals)],
    );
    let gpu = gpu();
    let shade = |sun_x: f32| {
        let look = Look {
            light_dir: Vec3::new(sun_x, 0.0, 0.35),
            ..clear_look()
        };
        quadrants(&render_quad(&gpu, &set, look)).map(|p| i32::from(p[1]))
    };
    let [flat_a, lean_right, lean_left, flat_b] = shade(1.0);
    assert!((flat_a - flat_b).abs() <= 2, "{flat_a} vs {flat_b}");
    assert!(
        lean_right > flat_a + 25,
        "right {lean_right} vs flat {flat_a}"
    );
    assert!(lean_left + 25 < flat_a, "left {lean_left} vs flat {flat_a}");
    let [flat_a, lean_right, lean_left, _] = shade(-1.0);
    assert!(
        lean_left > flat_a + 25,
        "sun left: left {lean_left} vs flat {flat_a}"
    );
    assert!(
        lean_right + 25 < flat_a,
        "sun left: right {lean_right} vs flat {flat_a}"
    );
}

/// Metallic-roughness: with the sun behind the camera, a red dielectric texel is lit red with a
/// white highlight (some green and blue), a red metal has no diffuse light and only red
/// reflections, and a smooth metal mirrors the sun far brighter than a rough one.
#[test]
fn metallic_roughness_texture_sets_metal_and_gloss_per_texel() {
    // G = roughness, B = metallic.
    let dielectric = [0, 255, 0, 255];
    let rough_metal = [0, 255, 255, 255];
    let smooth_metal = [0, 50, 255, 255];
    let mr = png(2, 2, &[dielectric, rough_metal, smooth_metal, rough_metal]);
    let set = with_maps(
        lit([1.0, 0.0, 0.0, 1.0], 1.0, 1.0),
        vec![("pbrMetallicRoughness.metallicRoughnessTexture", mr)],
    );
    let look = Look {
        light_dir: Vec3::new(0.0, 0.0, 1.0),
        ..clear_look()
    };
    let q = quadrants(&render_quad(&gpu(), &set, look));
    let (d, rough, smooth) = (
        q[0].map(i32::from),
        q[1].map(i32::from),
        q[2].map(i32::from),
    );
    assert!(d[0] > 200, "dielectric {d:?}");
    assert!(
        rough[1] < 20 && rough[2] < 20,
        "a red metal reflects red only: {rough:?}"
    );
    assert!(rough[0] + 40 < d[0], "metal {rough:?} vs dielectric {d:?}");
    assert!(
        smooth[0] > rough[0] + 40,
        "smooth {smooth:?} vs rough {rough:?}"
    );
    // The same texels shade the same, but for the view direction's small change.
    assert!(
        (0..3).all(|c| q[1][c].abs_diff(q[3][c]) <= 3),
        "{:?} vs {:?}",
        q[1],
        q[3]
    );
}

/// Each kind of map missing or undecodable is a warning naming the file, the image and the
/// kind; the fish is drawn exactly as with the material's factors alone (not black).
#[test]
fn missing_or_broken_maps_warn_and_draw_with_the_factors() {
    let dir = tempfile::tempdir().unwrap();
    let gpu = gpu();
    let mut base = lit([0.2, 0.6, 0.3, 1.0], 0.3, 0.5);
    base["emissiveFactor"] = json!([0.1, 0.0, 0.0]);
    let look = clear_look();
    let factors_only = render_quad(&gpu, &with_maps(base.clone(), vec![]), look);
    for p in quadrants(&factors_only) {
        assert!(p[1] > 40, "the factors-only quad is not dark: {p:?}");
    }
    for (key, kind) in [
        ("normalTexture", "normal texture"),
        (
            "pbrMetallicRoughness.metallicRoughnessTexture",
            "metallic-roughness texture",
        ),
        ("occlusionTexture", "occlusion texture"),
        ("emissiveTexture", "emissive texture"),
    ] {
        let broken = with_maps(base.clone(), vec![(key, b"not a png".to_vec())]);
        let good = with_maps(base.clone(), vec![(key, png(1, 1, &[[255; 4]]))]);
        let missing = patch_glb(&quad(0.0).to_glb(&good, "test"), |root| {
            root["images"][0] = json!({"uri": "maps/gone.png"});
        });
        for (name, bytes, says) in [
            (
                "broken.glb",
                quad(0.0).to_glb(&broken, "test"),
                "cannot decode",
            ),
            ("missing.glb", missing, "gone.png"),
        ] {
            let path = write(dir.path(), name, &bytes);
            let model = load(&path);
            let warning = model
                .warnings
                .iter()
                .find(|w| w.contains("image 0"))
                .unwrap_or_else(|| panic!("{key} {name}: no warning in {:?}", model.warnings));
            assert!(
                warning.contains(name) && warning.contains(says) && warning.contains(kind),
                "{warning}"
            );
            assert!(!model.mesh.material().has_textures(), "{key} {name}");
            let (img, _) = render(
                &gpu,
                &[MeshUpload::from_skinned_mesh(name, &model.mesh)],
                &[(0, Mat4::IDENTITY)],
                front_camera(3.0),
                (64, 64),
                look,
            );
            assert!(
                img.pixels().eq(factors_only.pixels()),
                "{key} {name}: not drawn as with the factors"
            );
        }
    }
}

/// A species whose primitives use different materials draws each with its own: the top-left
/// triangle with an unlit red factor, the bottom-right one with the unlit four-colour texture;
/// one draw more than a one-material species, still the same for 1 or 500 fish.
#[test]
fn several_materials_in_one_species_each_draw_their_own() {
    let dir = tempfile::tempdir().unwrap();
    let mut red = unlit();
    red["pbrMetallicRoughness"]["baseColorFactor"] = json!([1.0, 0.0, 0.0, 1.0]);
    let mut textured_unlit = unlit();
    textured_unlit["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": 0});
    let set = MaterialSet {
        materials: json!([red, textured_unlit]),
        ..textured(four_colours(), unlit())
    };
    let mut two = quad(0.0);
    // Triangle (0, 2, 1) is the top-left half, (1, 2, 3) the bottom-right.
    two.parts = vec![(3, 0), (3, 1)];
    let model = load(&write(dir.path(), "two.glb", &two.to_glb(&set, "test")));
    assert!(model.warnings.is_empty(), "{:?}", model.warnings);
    assert_eq!(model.mesh.materials.len(), 2);
    assert!(model.mesh.materials[0].base_color_texture.is_none());
    assert!(model.mesh.materials[1].base_color_texture.is_some());
    let one = load(&write(
        dir.path(),
        "one.glb",
        &quad(0.0).to_glb(&textured(four_colours(), unlit()), "test"),
    ));
    let gpu = gpu();
    let draw = |model: &FishModel, n: usize| {
        let fish: Vec<(u32, Mat4)> = (0..n)
            .map(|i| {
                (
                    0,
                    Mat4::from_translation(Vec3::new(0.0, 0.0, -0.01 * i as f32)),
                )
            })
            .collect();
        render(
            &gpu,
            &[MeshUpload::from_skinned_mesh("quad", &model.mesh)],
            &fish,
            front_camera(3.0),
            (64, 64),
            clear_look(),
        )
    };
    let (img, t) = draw(&model, 1);
    // Top-left corner region: red factor; bottom right: the yellow texel; top right and
    // bottom left lie on the diagonal, so look just off it.
    assert_eq!(img.get_pixel(18, 18).0, RED);
    assert_eq!(img.get_pixel(45, 45).0, YELLOW);
    assert_eq!(
        img.get_pixel(40, 28).0,
        GREEN,
        "texture side of the diagonal, top right"
    );
    assert_eq!(img.get_pixel(26, 30).0, RED, "factor side of the diagonal");
    let (_, t_one) = draw(&one, 1);
    assert_eq!(t.num_draw_calls, t_one.num_draw_calls + 1);
    assert_eq!(draw(&model, 500).1.num_draw_calls, t.num_draw_calls);
}

/// `shoal asset rig` keeps every material of a mesh whose primitives use several, and a normal
/// map the file gives no tangents for (the loader then makes MikkTSpace tangents: unit length,
/// perpendicular to the normals, along +u, which is +x here).
#[test]
fn the_rigger_keeps_several_materials_and_an_untangented_normal_map() {
    use shoal_core::asset::rig::{RigOptions, rig_file};
    let dir = tempfile::tempdir().unwrap();
    let mut red = unlit();
    red["pbrMetallicRoughness"]["baseColorFactor"] = json!([1.0, 0.0, 0.0, 1.0]);
    let mut mapped = lit([1.0; 4], 0.0, 0.5);
    mapped["pbrMetallicRoughness"]["baseColorTexture"] = json!({"index": 0});
    mapped["normalTexture"] = json!({"index": 1, "scale": 0.5});
    let set = MaterialSet {
        materials: json!([red, mapped]),
        textures: json!([{"sampler": 0, "source": 0}, {"sampler": 0, "source": 1}]),
        images: vec![
            (four_colours(), "image/png".into()),
            (png(1, 1, &[[128, 128, 255, 255]]), "image/png".into()),
        ],
        ..textured(four_colours(), unlit())
    };
    // A long quad (6 × 2) so the rigger finds its long axis.
    let mut long = quad(0.0);
    for p in &mut long.positions {
        p.x *= 3.0;
    }
    long.parts = vec![(3, 0), (3, 1)];
    let input = write(dir.path(), "two.glb", &long.to_glb(&set, "test"));
    let rigged = rig_file(&input, &RigOptions::default()).unwrap();
    let gltf = gltf::Gltf::from_slice(&rigged.glb).unwrap();
    let mesh = gltf.meshes().next().unwrap();
    let materials: Vec<Option<usize>> = mesh.primitives().map(|p| p.material().index()).collect();
    assert_eq!(materials, vec![Some(0), Some(1)], "{:?}", rigged.warnings);
    let kept = gltf.materials().nth(1).unwrap();
    assert_eq!(kept.normal_texture().map(|n| n.scale()), Some(0.5));
    let model = load(&write(dir.path(), "rigged.glb", &rigged.glb));
    assert_eq!(model.mesh.materials.len(), 2);
    assert!(model.mesh.materials[1].normal_texture.is_some());
    assert_eq!(model.mesh.tangents.len(), model.mesh.positions.len());
    for (t, n) in model.mesh.tangents.iter().zip(&model.mesh.normals) {
        let t3 = Vec3::new(t[0], t[1], t[2]);
        assert!(
            (t3.length() - 1.0).abs() < 1e-4 && t3.dot(*n).abs() < 1e-4,
            "{t:?}"
        );
        assert!(t3.x > 0.99 && t[3].abs() == 1.0, "{t:?}");
    }
}

/// One species with an opaque part and a `BLEND` part (a body and its see-through fins): the
/// blended part is drawn after every opaque fish, so a fish uploaded after it still shows
/// through, while the opaque part hides it.
#[test]
fn a_blended_part_of_a_species_is_drawn_after_the_opaque_fish() {
    let dir = tempfile::tempdir().unwrap();
    let mut red = unlit();
    red["pbrMetallicRoughness"]["baseColorFactor"] = json!([1.0, 0.0, 0.0, 1.0]);
    let mut half_white = unlit();
    half_white["pbrMetallicRoughness"]["baseColorFactor"] = json!([1.0, 1.0, 1.0, 0.5]);
    half_white["alphaMode"] = json!("BLEND");
    let set = MaterialSet {
        materials: json!([red, half_white]),
        ..textured(four_colours(), unlit())
    };
    let mut two = quad(0.5);
    two.parts = vec![(3, 0), (3, 1)];
    let front = load(&write(dir.path(), "two.glb", &two.to_glb(&set, "test")));
    let behind = load(&write(
        dir.path(),
        "behind.glb",
        &quad(0.0).to_glb(&textured(png(1, 1, &[BLUE]), unlit()), "test"),
    ));
    let (img, _) = render(
        &gpu(),
        &[
            MeshUpload::from_skinned_mesh("front", &front.mesh),
            MeshUpload::from_skinned_mesh("behind", &behind.mesh),
        ],
        &[(0, Mat4::IDENTITY), (1, Mat4::IDENTITY)],
        front_camera(3.0),
        (64, 64),
        clear_look(),
    );
    assert_eq!(
        img.get_pixel(18, 18).0,
        RED,
        "the opaque part hides the blue quad"
    );
    let p = img.get_pixel(45, 45).0;
    assert!(
        (170..=205).contains(&p[0]) && (170..=205).contains(&p[1]) && p[2] == 255,
        "half white over blue: {p:?}"
    );
}

/// A map on another texture coordinate set than the material's first texture is left out with a
/// warning naming the set (shoal draws a material with one set); the rest of the material stays.
#[test]
fn a_map_on_another_coordinate_set_is_left_out_with_a_warning() {
    let dir = tempfile::tempdir().unwrap();
    let mut set = with_maps(
        lit([1.0; 4], 0.0, 1.0),
        vec![
            ("pbrMetallicRoughness.baseColorTexture", four_colours()),
            ("emissiveTexture", png(1, 1, &[[255; 4]])),
        ],
    );
    set.materials[0]["emissiveTexture"]["texCoord"] = json!(1);
    let model = load(&write(
        dir.path(),
        "sets.glb",
        &quad(0.0).to_glb(&set, "test"),
    ));
    let warning = model
        .warnings
        .iter()
        .find(|w| w.contains("emissive texture"))
        .unwrap_or_else(|| panic!("no warning in {:?}", model.warnings));
    assert!(
        warning.contains("TEXCOORD_1") && warning.contains("sets.glb"),
        "{warning}"
    );
    assert!(model.mesh.material().emissive_texture.is_none());
    assert!(model.mesh.material().base_color_texture.is_some());
}
