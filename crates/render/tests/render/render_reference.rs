//! Reference-image tests: fixed scenes rendered offscreen at a fixed time and seed, compared with
//! the PNGs in `crates/render/tests/reference/`.
//!
//! Tolerance: a pixel differs when any RGB channel differs by more than 16 (of 255); a test
//! fails when more than 0.5 % of pixels differ. Set on lavapipe (Mesa 22.3, llvmpipe); MSAA
//! edges and fog gradients differ by a few levels between rasterizers, which this absorbs, while
//! a moved fish, a lost floor or broken skinning changes several percent of the image.
//!
//! On failure `<name>-actual.png` and `<name>-difference.png` are written beside the reference.
//! `SHOAL_BLESS=1 cargo test --test render_reference` rewrites the references.

use crate::common;
use crate::common::UploadPorgy as _;

use std::path::PathBuf;

use glam::{Mat4, Quat, Vec3};
use shoal_render::testmesh::TestFish;
use shoal_render::{
    Camera, FishInstance, FrameInput, Gpu, Look, OffscreenTarget, OverlayLine, Renderer, TankBounds,
};

const WIDTH: u32 = 256;
const HEIGHT: u32 = 192;
const CHANNEL_TOLERANCE: u8 = 16;
const MAX_DIFFERING_FRACTION: f64 = 0.005;

fn reference_dir() -> PathBuf {
    std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("tests/reference")
}

fn gpu() -> Gpu {
    Gpu::headless().expect("a GPU adapter (lavapipe in CI: apt install mesa-vulkan-drivers)")
}

/// Compares `actual` with `crates/render/tests/reference/<name>.png` (or writes it when blessing).
fn check(name: &str, actual: &image::RgbaImage) {
    let dir = reference_dir();
    let reference_path = dir.join(format!("{name}.png"));
    let actual_path = dir.join(format!("{name}-actual.png"));
    let diff_path = dir.join(format!("{name}-difference.png"));
    if std::env::var_os("SHOAL_BLESS").is_some_and(|v| v == "1") {
        std::fs::create_dir_all(&dir).unwrap();
        actual.save(&reference_path).unwrap();
        let _ = std::fs::remove_file(&actual_path);
        let _ = std::fs::remove_file(&diff_path);
        return;
    }
    let Ok(reference) = image::open(&reference_path) else {
        actual.save(&actual_path).unwrap();
        panic!(
            "no reference {}; wrote {} — inspect it and run with SHOAL_BLESS=1 to accept",
            reference_path.display(),
            actual_path.display()
        );
    };
    let reference = reference.to_rgba8();
    assert_eq!(
        reference.dimensions(),
        actual.dimensions(),
        "{name}: size changed"
    );
    let mut diff = image::RgbaImage::new(actual.width(), actual.height());
    let mut differing = 0usize;
    for (x, y, a) in actual.enumerate_pixels() {
        let r = reference.get_pixel(x, y);
        let d = (0..3).map(|c| a[c].abs_diff(r[c])).max().unwrap_or(0);
        if d > CHANNEL_TOLERANCE {
            differing += 1;
            diff.put_pixel(x, y, image::Rgba([255, 0, 255, 255]));
        } else {
            let g = a[1] / 3;
            diff.put_pixel(x, y, image::Rgba([g, g, g, 255]));
        }
    }
    let fraction = differing as f64 / f64::from(actual.width() * actual.height());
    if fraction > MAX_DIFFERING_FRACTION {
        actual.save(&actual_path).unwrap();
        diff.save(&diff_path).unwrap();
        panic!(
            "{name}: {:.2} % of pixels differ by more than {CHANNEL_TOLERANCE} (limit {:.2} %); \
             see {} and {}",
            fraction * 100.0,
            MAX_DIFFERING_FRACTION * 100.0,
            actual_path.display(),
            diff_path.display()
        );
    }
    let _ = std::fs::remove_file(&actual_path);
    let _ = std::fs::remove_file(&diff_path);
}

fn render(gpu: &Gpu, renderer: &mut Renderer, input: &FrameInput<'_>) -> image::RgbaImage {
    let target = OffscreenTarget::new(gpu, WIDTH, HEIGHT);
    renderer
        .render(gpu, target.view(), target.size(), input)
        .unwrap();
    target.read_rgba8(gpu).unwrap()
}

/// Mean linear-ish colour of a pixel rectangle (sRGB bytes averaged).
fn mean_rgb(img: &image::RgbaImage, x0: u32, y0: u32, x1: u32, y1: u32) -> [f32; 3] {
    let mut sum = [0.0f32; 3];
    let mut n = 0.0;
    for y in y0..y1 {
        for x in x0..x1 {
            let p = img.get_pixel(x, y);
            for c in 0..3 {
                sum[c] += f32::from(p[c]);
            }
            n += 1.0;
        }
    }
    sum.map(|s| s / n)
}

/// A small aquarium from explicit data (no motion layer, so motion tuning never moves it): 16
/// procedural fish at seeded places and poses, two rocks and three food pellets.
#[test]
fn aquarium_with_fish_rocks_and_food() {
    use rand::{Rng, SeedableRng};
    use shoal_render::Prop;
    use shoal_render::props::PropMesh;
    let gpu = gpu();
    let mut renderer = Renderer::new(&gpu, OffscreenTarget::FORMAT).unwrap();
    // Pins the CPU path's counts and draw calls (render_cull checks the GPU path against it).
    renderer.set_culling(shoal_render::Culling::Cpu);
    let fish = TestFish::demo();
    let fish_mesh = renderer.upload_mesh(&gpu, &fish.upload()).unwrap();
    let rock = renderer
        .upload_mesh(&gpu, &PropMesh::rock().upload())
        .unwrap();
    let pellet = renderer
        .upload_mesh(&gpu, &PropMesh::pellet().upload())
        .unwrap();
    let nj = fish.num_joints();
    let mut rng = rand_pcg::Pcg32::seed_from_u64(7);
    let mut palette = vec![Mat4::IDENTITY; 16 * nj];
    let mut instances = Vec::new();
    for i in 0..16usize {
        let pos = Vec3::new(
            rng.random_range(-220.0..220.0),
            rng.random_range(40.0..200.0),
            rng.random_range(-120.0..120.0),
        );
        let root = Mat4::from_rotation_translation(
            Quat::from_rotation_y(rng.random_range(0.0..std::f32::consts::TAU)),
            pos,
        );
        let phase: f32 = rng.random_range(0.0..std::f32::consts::TAU);
        let yaws: Vec<f32> = (0..nj)
            .map(|j| {
                if j == 0 {
                    0.0
                } else {
                    0.2 * (phase + j as f32 * 0.8).sin()
                }
            })
            .collect();
        fish.palette(root, &yaws, &mut palette[i * nj..(i + 1) * nj]);
        instances.push(FishInstance {
            mesh: fish_mesh,
            palette_offset: (i * nj) as u32,
            tint: [1.0; 3],
            selected: false,
        });
    }
    let props = [
        Prop {
            mesh: rock,
            transform: Mat4::from_scale_rotation_translation(
                Vec3::splat(55.0),
                Quat::from_rotation_y(0.4),
                Vec3::new(150.0, 20.0, -80.0),
            ),
            tint: [1.0; 3],
        },
        Prop {
            mesh: rock,
            transform: Mat4::from_scale_rotation_translation(
                Vec3::splat(35.0),
                Quat::IDENTITY,
                Vec3::new(-170.0, 10.0, 90.0),
            ),
            tint: [1.0; 3],
        },
    ]
    .into_iter()
    .chain((0..3).map(|k| Prop {
        mesh: pellet,
        transform: Mat4::from_scale_rotation_translation(
            Vec3::splat(4.0),
            Quat::IDENTITY,
            Vec3::new(-40.0 + 40.0 * k as f32, 215.0, 20.0),
        ),
        tint: [1.0; 3],
    }))
    .collect::<Vec<_>>();
    // A view of the whole default tank, a little above its centre.
    let tank = TankBounds::default();
    let size = tank.size();
    let camera = Camera {
        target: tank.center() - Vec3::Y * size.y * 0.1,
        yaw_rad: 0.35,
        pitch_rad: 0.2,
        distance: size.x.max(size.z) * 0.9,
        fov_y_rad: 50f32.to_radians(),
    };
    let input = FrameInput {
        gpu_pose: None,
        palettes: &palette,
        instances: &instances,
        instances_revision: None,
        camera,
        tank: TankBounds::default(),
        time_s: 1.0,
        props: &props,
        overlay: &[],
        look: Look::default(),
    };
    let img = render(&gpu, &mut renderer, &input);
    // Background, floor, shadows and fish (one draw each per mesh: 3 meshes), tank edges.
    assert_eq!(renderer.timings().num_draw_calls, 2 + 3 + 3 + 1);
    // The look, independent of the reference: blue-green water above, sand below.
    let water = mean_rgb(&img, 0, 0, WIDTH, 12);
    assert!(
        water[2] > water[0] + 40.0 && water[1] > water[0] + 30.0,
        "water {water:?}"
    );
    let sand = mean_rgb(
        &img,
        WIDTH / 2 - 20,
        HEIGHT - 20,
        WIDTH / 2 + 20,
        HEIGHT - 4,
    );
    assert!(sand[0] > sand[2], "floor should read as sand, got {sand:?}");
    check("aquarium", &img);
}

/// The generated black porgy asset (`assets/black_porgy.glb`), bound by the species rig and
/// posed by the motion layer's yaws, three fish close up: checks the real asset's skinning,
/// vertex colours and fins through the whole pipeline.
#[test]
fn black_porgy_asset_posed_by_the_species_rig() {
    let gpu = gpu();
    let mut renderer = Renderer::new(&gpu, OffscreenTarget::FORMAT).unwrap();
    let rig = common::PosedPorgy::load();
    let mesh = renderer.upload_mesh(&gpu, &rig.upload()).unwrap();
    let nj = rig.num_joints();
    let num_driven = rig.rig.body.num_joints();
    let mut palette = vec![Mat4::IDENTITY; 3 * nj];
    let mut instances = Vec::new();
    for k in 0..3usize {
        let yaw: Vec<f32> = (0..num_driven)
            .map(|j| 0.25 * ((j as f32) * 0.9 + k as f32 * 1.3).sin())
            .collect();
        let root = Mat4::from_rotation_translation(
            Quat::from_rotation_y(0.5 * k as f32 - 0.4),
            Vec3::new(
                -40.0 + 45.0 * k as f32,
                50.0 + 12.0 * k as f32,
                -10.0 * k as f32,
            ),
        );
        rig.palette(root, &yaw, &mut palette[k * nj..(k + 1) * nj]);
        instances.push(FishInstance {
            mesh,
            palette_offset: (k * nj) as u32,
            tint: [1.0; 3],
            selected: k == 1,
        });
    }
    let input = FrameInput {
        gpu_pose: None,
        palettes: &palette,
        instances: &instances,
        instances_revision: None,
        camera: Camera {
            target: Vec3::new(0.0, 55.0, 0.0),
            yaw_rad: 0.15,
            pitch_rad: 0.25,
            distance: 130.0,
            fov_y_rad: 50f32.to_radians(),
        },
        tank: TankBounds::default(),
        time_s: 1.0,
        props: &[],
        overlay: &[],
        look: Look::default(),
    };
    let img = render(&gpu, &mut renderer, &input);
    check("black_porgy", &img);
}

/// One fish in a fixed swimming pose, close up, with skeleton overlay lines.
#[test]
fn skinned_fish_closeup_with_skeleton_overlay() {
    let gpu = gpu();
    let mut renderer = Renderer::new(&gpu, OffscreenTarget::FORMAT).unwrap();
    let fish = TestFish::demo();
    let mesh = renderer.upload_mesh(&gpu, &fish.upload()).unwrap();
    let nj = fish.num_joints();
    let yaws: Vec<f32> = (0..nj)
        .map(|j| {
            if j == 0 {
                0.0
            } else {
                0.22 * (j as f32 * 1.1).sin()
            }
        })
        .collect();
    let mut palette = vec![Mat4::IDENTITY; nj];
    let root =
        Mat4::from_rotation_translation(Quat::from_rotation_y(0.3), Vec3::new(25.0, 60.0, 0.0));
    fish.palette(root, &yaws, &mut palette);
    let seg = fish.length / nj as f32;
    let overlay: Vec<OverlayLine> = (0..nj)
        .map(|j| {
            let a = palette[j].transform_point3(Vec3::new(-(j as f32) * seg, 0.0, 0.0));
            let b = if j + 1 < nj {
                palette[j + 1].transform_point3(Vec3::new(-((j + 1) as f32) * seg, 0.0, 0.0))
            } else {
                palette[j].transform_point3(Vec3::new(-fish.length, 0.0, 0.0))
            };
            OverlayLine {
                a,
                b,
                color: [1.0, 0.85, 0.2, 1.0],
            }
        })
        .collect();
    let instances = [FishInstance {
        mesh,
        palette_offset: 0,
        tint: [1.0; 3],
        selected: false,
    }];
    let input = FrameInput {
        gpu_pose: None,
        palettes: &palette,
        instances: &instances,
        instances_revision: None,
        camera: Camera {
            target: Vec3::new(0.0, 55.0, 0.0),
            yaw_rad: 0.2,
            pitch_rad: 0.35,
            distance: 90.0,
            fov_y_rad: 50f32.to_radians(),
        },
        tank: TankBounds::default(),
        time_s: 2.0,
        props: &[],
        overlay: &overlay,
        look: Look::default(),
    };
    let img = render(&gpu, &mut renderer, &input);
    check("fish_closeup", &img);
}

/// A grid of 64 instanced fish with tints, one selected: one draw call for all of them (and one
/// for all their shadows).
#[test]
fn instanced_school_is_one_draw_call() {
    let gpu = gpu();
    let mut renderer = Renderer::new(&gpu, OffscreenTarget::FORMAT).unwrap();
    // Pins the CPU path's counts and draw calls (render_cull checks the GPU path against it).
    renderer.set_culling(shoal_render::Culling::Cpu);
    let fish = TestFish::demo();
    let mesh = renderer.upload_mesh(&gpu, &fish.upload()).unwrap();
    let nj = fish.num_joints();
    let mut palette = vec![Mat4::IDENTITY; 64 * nj];
    let mut instances = Vec::new();
    for i in 0..64usize {
        let (gx, gz) = ((i % 8) as f32, (i / 8) as f32);
        let root = Mat4::from_rotation_translation(
            Quat::from_rotation_y(0.4 * gx),
            Vec3::new(-200.0 + gx * 60.0, 30.0 + gz * 24.0, 40.0 - gz * 10.0),
        );
        let yaws: Vec<f32> = (0..nj).map(|j| 0.15 * ((j + i) as f32).sin()).collect();
        fish.palette(root, &yaws, &mut palette[i * nj..(i + 1) * nj]);
        let t = 0.7 + 0.6 * (i as f32 / 63.0);
        instances.push(FishInstance {
            mesh,
            palette_offset: (i * nj) as u32,
            tint: [t, 1.0, 2.0 - t],
            selected: i == 27,
        });
    }
    let input = FrameInput {
        gpu_pose: None,
        palettes: &palette,
        instances: &instances,
        instances_revision: None,
        camera: Camera::default(),
        tank: TankBounds::default(),
        time_s: 0.5,
        props: &[],
        overlay: &[],
        look: Look::default(),
    };
    let img = render(&gpu, &mut renderer, &input);
    // Background + floor + one shadow draw + one fish draw + tank edges, however many fish.
    assert_eq!(renderer.timings().num_draw_calls, 5);
    let one = FrameInput {
        gpu_pose: None,
        instances: &instances[..1],
        instances_revision: None,
        ..input
    };
    let _ = render(&gpu, &mut renderer, &one);
    assert_eq!(renderer.timings().num_draw_calls, 5);
    check("instanced_school", &img);
}

/// Without fish and with caustics off the floor is static: two times give the same image; with
/// caustics on, the floor moves over time.
#[test]
fn caustics_animate_with_time() {
    let gpu = gpu();
    let mut renderer = Renderer::new(&gpu, OffscreenTarget::FORMAT).unwrap();
    let frame = |time_s: f32, caustic_strength: f32| FrameInput {
        gpu_pose: None,
        palettes: &[],
        instances: &[],
        instances_revision: None,
        camera: Camera::default(),
        tank: TankBounds::default(),
        time_s,
        props: &[],
        overlay: &[],
        look: Look {
            caustic_strength,
            ..Look::default()
        },
    };
    let changed = |a: &image::RgbaImage, b: &image::RgbaImage| {
        a.pixels().zip(b.pixels()).filter(|(p, q)| p != q).count()
    };
    let a = render(&gpu, &mut renderer, &frame(1.0, 0.0));
    let b = render(&gpu, &mut renderer, &frame(1.2, 0.0));
    let background_only = changed(&a, &b);
    let c = render(&gpu, &mut renderer, &frame(1.0, 1.0));
    let d = render(&gpu, &mut renderer, &frame(1.2, 1.0));
    let with_caustics = changed(&c, &d);
    assert!(
        with_caustics > background_only + 1000,
        "caustics should animate the floor: {with_caustics} vs {background_only} changed pixels"
    );
}
