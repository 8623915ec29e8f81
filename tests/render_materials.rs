//! glTF materials in the renderer and the CPU preview (issue 15): base-colour textures, alpha
//! modes, a missing or broken image, draw calls that do not grow with the fish count, and the
//! third-party RedFinnedFish, rigged, as a reference image.
//!
//! Runs on lavapipe (software Vulkan) like the other render tests.

use std::path::{Path, PathBuf};

use glam::{Mat4, Vec3};
use serde_json::{Value, json};
use shoal::asset::{Influences, MaterialSet, RiggedMesh};
use shoal::render::{
    Camera, FishInstance, FrameInput, Gpu, Look, MeshId, MeshUpload, OffscreenTarget, Renderer,
    TankBounds,
};
use shoal::skin::{AlphaMode, FishModel};

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
) -> (image::RgbaImage, shoal::render::RenderTimings) {
    let mut renderer = Renderer::new(gpu, OffscreenTarget::FORMAT).unwrap();
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
        palettes: &palettes,
        instances: &instances,
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
    let tex = model.mesh.material.base_color_texture.as_ref().unwrap();
    assert_eq!((tex.width, tex.height), (2, 2));
    assert!(model.mesh.material.unlit);
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
        masked.mesh.material.alpha_mode,
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
        assert!(model.mesh.material.base_color_texture.is_none());
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
    use shoal::asset::preview::{View, render_views_material};
    let dir = tempfile::tempdir().unwrap();
    let glb = quad(0.0).to_glb(&textured(four_colours(), unlit()), "test");
    let model = load(&write(dir.path(), "quad.glb", &glb));
    let size = 64;
    let cpu = render_views_material(
        &model.mesh.positions,
        &model.mesh.colors,
        &model.mesh.uvs,
        Some(&model.mesh.material),
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

fn red_finned_fish() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../shared/gltf-samples/RedFinnedFish/scene.gltf")
}

/// The rigged RedFinnedFish in a close-up: its texture shows (the textured picture differs from
/// the vertex-colour one over most of the body, in many colours), its alpha-masked fin cards are
/// cut to the fins' shape (fewer fish pixels than with the material ignored), and the picture
/// matches `tests/reference/red_finned_fish.png` (same tolerance as `render_reference.rs`;
/// `SHOAL_BLESS=1` rewrites it).
#[test]
fn rigged_red_finned_fish_close_up() {
    use shoal::asset::rig::{RigOptions, rig_file};
    let rigged = rig_file(&red_finned_fish(), &RigOptions::default()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = write(dir.path(), "red_finned_fish.glb", &rigged.glb);
    let model = load(&path);
    assert!(
        model.mesh.material.base_color_texture.is_some(),
        "{:?}",
        model.warnings
    );
    assert!(matches!(
        model.mesh.material.alpha_mode,
        AlphaMode::Mask { .. }
    ));
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
        material: None,
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
        let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("docs/images");
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

/// Compares with `tests/reference/<name>.png` like `render_reference.rs` (a pixel differs when
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
