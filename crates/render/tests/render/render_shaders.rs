//! Shader reloading: a broken WGSL file is reported and the previous pipelines keep drawing; a
//! valid edit takes effect; the directory watcher notices saves.

use std::time::{Duration, Instant};

use glam::{Mat4, Vec3};
use shoal_render::shaders::{ShaderSources, ShaderWatcher};
use shoal_render::testmesh::TestFish;
use shoal_render::{
    Camera, FishInstance, FrameInput, Gpu, Look, OffscreenTarget, RenderError, Renderer, TankBounds,
};

fn render_fish(gpu: &Gpu, renderer: &mut Renderer, palette: &[Mat4]) -> image::RgbaImage {
    let instances = [FishInstance {
        mesh: shoal_render::MeshId(0),
        palette_offset: 0,
        tint: [1.0; 3],
        selected: false,
    }];
    let input = FrameInput {
        gpu_pose: None,
        palettes: palette,
        instances: &instances,
        instances_revision: None,
        camera: Camera {
            target: Vec3::new(-25.0, 60.0, 0.0),
            yaw_rad: 0.0,
            pitch_rad: 0.0,
            distance: 80.0,
            fov_y_rad: 0.9,
        },
        tank: TankBounds::default(),
        time_s: 0.0,
        props: &[],
        overlay: &[],
        look: Look::default(),
    };
    let target = OffscreenTarget::new(gpu, 96, 64);
    renderer
        .render(gpu, target.view(), target.size(), &input)
        .unwrap();
    target.read_rgba8(gpu).unwrap()
}

fn with_file(name: &str, text: &str) -> ShaderSources {
    let mut s = ShaderSources::embedded();
    for (n, t) in &mut s.files {
        if n == name {
            *t = text.to_owned();
        }
    }
    s
}

#[test]
fn broken_shader_is_reported_and_previous_pipeline_keeps_drawing() {
    let gpu = Gpu::headless().expect("a GPU adapter (lavapipe: apt install mesa-vulkan-drivers)");
    let mut renderer = Renderer::new(&gpu, OffscreenTarget::FORMAT).unwrap();
    let fish = TestFish::demo();
    renderer.upload_mesh(&gpu, &fish.upload()).unwrap();
    let mut palette = vec![Mat4::IDENTITY; fish.num_joints()];
    fish.palette(
        Mat4::from_translation(Vec3::new(0.0, 60.0, 0.0)),
        &vec![0.0; fish.num_joints()],
        &mut palette,
    );
    let before = render_fish(&gpu, &mut renderer, &palette);

    // A syntax error.
    let broken = with_file("fish.wgsl", "fn vs_main( -> this is not wgsl");
    let err = renderer.reload_shaders(&gpu, broken).unwrap_err();
    match &err {
        RenderError::Shader { file, message } => {
            assert_eq!(file, "fish.wgsl");
            // The message maps the composed text's lines back to files.
            assert!(message.contains("fish.wgsl = lines "), "{message}");
        }
        other => panic!("expected a shader error, got {other}"),
    }
    // A type error that parses (validation, not parsing, must catch it).
    let bad_type = ShaderSources::embedded()
        .get("fish.wgsl")
        .replace("out.flags = inst.flags;", "out.flags = inst.tint;");
    assert!(
        renderer
            .reload_shaders(&gpu, with_file("fish.wgsl", &bad_type))
            .is_err()
    );
    let after = render_fish(&gpu, &mut renderer, &palette);
    assert_eq!(before, after, "the previous pipelines must keep drawing");

    // A valid edit: fish drawn flat magenta.
    let magenta = ShaderSources::embedded().get("fish.wgsl").replace(
        "return vec4<f32>(apply_fog(color, in.world_pos), 1.0);",
        "return vec4<f32>(1.0, 0.0, 1.0, 1.0);",
    );
    renderer
        .reload_shaders(&gpu, with_file("fish.wgsl", &magenta))
        .unwrap();
    let edited = render_fish(&gpu, &mut renderer, &palette);
    let magenta_pixels = edited
        .pixels()
        .filter(|p| p[0] == 255 && p[1] == 0 && p[2] == 255)
        .count();
    assert!(magenta_pixels > 200, "only {magenta_pixels} magenta pixels");
    assert_eq!(
        before
            .pixels()
            .filter(|p| p[0] == 255 && p[1] == 0 && p[2] == 255)
            .count(),
        0
    );
}

#[test]
fn watcher_notices_a_saved_wgsl_file() {
    let dir = tempfile::tempdir().unwrap();
    // The watcher reports paths as it watches them.
    let base = dir.path().canonicalize().unwrap();
    let path = base.join("fish.wgsl");
    std::fs::write(&path, "// v1").unwrap();
    let watcher = ShaderWatcher::new(&base).unwrap();
    std::fs::write(&path, "// v2").unwrap();
    // A second file saved after it is the marker that every event of the first save has come in
    // (the watcher hands them over in the order they happened).
    let first = base.join("a_marker.wgsl");
    std::fs::write(&first, "// marker").unwrap();
    let saved = saves_until(&watcher, &first);
    assert_eq!(
        saved,
        [first.clone(), path.clone()],
        "the save is reported, once"
    );
    // Reading the files back (as a reload does) is not a change: by the time the next marker's
    // save is reported, the read's events have come in too, and none names fish.wgsl.
    let _ = ShaderSources::load_dir(&base).unwrap();
    let second = base.join("b_marker.wgsl");
    std::fs::write(&second, "// marker").unwrap();
    let saved = saves_until(&watcher, &second);
    assert_eq!(saved, [second], "a read must not count as a save");
}

/// Every `.wgsl` file the watcher reports saved until it reports `marker` (sorted, each once);
/// fails if that takes a minute.
fn saves_until(watcher: &ShaderWatcher, marker: &std::path::Path) -> Vec<std::path::PathBuf> {
    let deadline = Instant::now() + Duration::from_secs(60);
    let mut saved = Vec::new();
    while !saved.iter().any(|p| p == marker) {
        assert!(
            Instant::now() < deadline,
            "{} was not reported saved (so far: {saved:?})",
            marker.display()
        );
        saved.extend(watcher.saved());
        std::thread::sleep(Duration::from_millis(20));
    }
    saved.sort();
    saved.dedup();
    saved
}
