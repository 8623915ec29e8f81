//! Culling and levels of detail on the GPU (`shaders/cull.wgsl`, issue 35): the same scene drawn
//! with the CPU's culling and with the GPU's gives the same picture and the same counts (fish
//! drawn and culled, per level, shadows, triangles), with shadows and without, at the default
//! tolerance and at 0; and the GPU path records as many draws for 10 fish as for 600.

use crate::common;
use crate::common::UploadPorgy as _;

use glam::{Mat4, Quat, Vec3};
use rand::{Rng, SeedableRng};
use shoal_render::props::PropMesh;
use shoal_render::{
    Camera, Culling, FishInstance, FrameInput, Gpu, Look, OffscreenTarget, Prop, RenderTimings,
    Renderer, TankBounds,
};

const WIDTH: u32 = 320;
const HEIGHT: u32 = 200;

fn gpu() -> Gpu {
    Gpu::headless().expect("a GPU adapter (lavapipe in CI: apt install mesa-vulkan-drivers)")
}

/// `n` porgies scattered over and well beyond the default tank (some behind the camera, some
/// far off, some close), every one bent a little differently, a few tinted and one selected;
/// two rocks and a pellet.
struct School {
    palettes: Vec<Mat4>,
    fish: Vec<(u32, [f32; 3], bool)>,
    props: Vec<(usize, Mat4)>,
}

fn school(rig: &common::PosedPorgy, n: usize) -> School {
    let nj = rig.num_joints();
    let mut rng = rand_pcg::Pcg32::seed_from_u64(35);
    let mut palettes = vec![Mat4::IDENTITY; n * nj];
    let mut fish = Vec::new();
    for i in 0..n {
        let pos = Vec3::new(
            rng.random_range(-900.0..900.0),
            rng.random_range(10.0..240.0),
            rng.random_range(-1_500.0..700.0),
        );
        let root = Mat4::from_rotation_translation(
            Quat::from_rotation_y(rng.random_range(0.0..std::f32::consts::TAU)),
            pos,
        );
        let phase: f32 = rng.random_range(0.0..std::f32::consts::TAU);
        let yaws: Vec<f32> = (0..rig.rig.body.num_joints())
            .map(|j| 0.15 * (phase + j as f32 * 0.8).sin())
            .collect();
        rig.palette(root, &yaws, &mut palettes[i * nj..(i + 1) * nj]);
        let tint = if i % 7 == 0 {
            [1.0, 0.6, 0.5]
        } else {
            [1.0; 3]
        };
        fish.push(((i * nj) as u32, tint, i == 3));
    }
    let props = vec![
        (
            0,
            Mat4::from_scale_rotation_translation(
                Vec3::splat(55.0),
                Quat::from_rotation_y(0.4),
                Vec3::new(150.0, 20.0, -80.0),
            ),
        ),
        (
            0,
            Mat4::from_scale_rotation_translation(
                Vec3::splat(35.0),
                Quat::IDENTITY,
                Vec3::new(-2_000.0, 10.0, 90.0),
            ),
        ),
        (
            1,
            Mat4::from_scale_rotation_translation(
                Vec3::splat(4.0),
                Quat::IDENTITY,
                Vec3::new(-40.0, 215.0, 20.0),
            ),
        ),
    ];
    School {
        palettes,
        fish,
        props,
    }
}

/// Draws `school` with `culling` at `tolerance_px`; the image and the counts (read back from
/// the GPU when it culled).
fn draw(
    gpu: &Gpu,
    rig: &common::PosedPorgy,
    school: &School,
    culling: Culling,
    tolerance_px: f32,
    shadows: bool,
) -> (image::RgbaImage, RenderTimings) {
    let mut renderer = Renderer::new(gpu, OffscreenTarget::FORMAT).unwrap();
    assert_eq!(renderer.set_culling(culling), culling, "lavapipe runs both");
    renderer.set_lod_tolerance_px(tolerance_px);
    let porgy = renderer.upload_mesh(gpu, &rig.upload()).unwrap();
    let rock = renderer
        .upload_mesh(gpu, &PropMesh::rock().upload())
        .unwrap();
    let pellet = renderer
        .upload_mesh(gpu, &PropMesh::pellet().upload())
        .unwrap();
    let instances: Vec<FishInstance> = school
        .fish
        .iter()
        .map(|&(palette_offset, tint, selected)| FishInstance {
            mesh: porgy,
            palette_offset,
            tint,
            selected,
        })
        .collect();
    let props: Vec<Prop> = school
        .props
        .iter()
        .map(|&(k, transform)| Prop {
            mesh: [rock, pellet][k],
            transform,
            tint: [1.0; 3],
        })
        .collect();
    let tank = TankBounds::default();
    let camera = Camera {
        target: tank.center(),
        yaw_rad: 0.35,
        pitch_rad: 0.25,
        distance: 700.0,
        fov_y_rad: 50f32.to_radians(),
    };
    let input = FrameInput {
        gpu_pose: None,
        palettes: &school.palettes,
        instances: &instances,
        camera,
        tank,
        time_s: 1.0,
        props: &props,
        overlay: &[],
        look: Look {
            shadows,
            ..Look::default()
        },
    };
    let target = OffscreenTarget::new(gpu, WIDTH, HEIGHT);
    // Twice: the second frame reuses every buffer the first one grew.
    for _ in 0..2 {
        renderer
            .render(gpu, target.view(), target.size(), &input)
            .unwrap();
    }
    let counts = renderer.read_gpu_counts(gpu).unwrap();
    (target.read_rgba8(gpu).unwrap(), counts)
}

/// Mean and largest difference over the RGB channels of two images.
fn difference(a: &image::RgbaImage, b: &image::RgbaImage) -> (f64, u8) {
    let mut sum = 0u64;
    let mut most = 0u8;
    for (p, q) in a.pixels().zip(b.pixels()) {
        for c in 0..3 {
            let d = p[c].abs_diff(q[c]);
            sum += u64::from(d);
            most = most.max(d);
        }
    }
    (sum as f64 / (3.0 * f64::from(a.width() * a.height())), most)
}

/// The counts the two paths must share.
fn counts(t: &RenderTimings) -> (u32, u32, [u32; 5], u32, u32, u64) {
    (
        t.num_fish_drawn,
        t.num_fish_culled,
        t.num_fish_per_lod,
        t.num_shadows_drawn,
        t.num_outline_shadows,
        t.num_triangles,
    )
}

#[test]
fn gpu_culling_draws_what_cpu_culling_draws() {
    let gpu = gpu();
    let rig = common::PosedPorgy::load();
    let school = school(&rig, 600);
    for (tolerance, shadows) in [(1.0, true), (0.0, true), (1.0, false)] {
        let (cpu_img, cpu) = draw(&gpu, &rig, &school, Culling::Cpu, tolerance, shadows);
        let (gpu_img, on_gpu) = draw(&gpu, &rig, &school, Culling::Gpu, tolerance, shadows);
        let case = format!("tolerance {tolerance}, shadows {shadows}");
        // The scene has something in each class, or the comparison would prove little.
        assert!(cpu.num_fish_culled > 50, "{case}: {cpu:?}");
        assert!(cpu.num_fish_drawn > 100, "{case}: {cpu:?}");
        if tolerance > 0.0 {
            assert!(
                cpu.num_fish_per_lod.iter().filter(|&&n| n > 0).count() >= 3,
                "{case}: {cpu:?}"
            );
        }
        assert_eq!(
            cpu.num_shadows_drawn > 0,
            shadows,
            "{case}: shadows drawn {cpu:?}"
        );
        assert_eq!(
            counts(&cpu),
            counts(&on_gpu),
            "{case}: CPU {cpu:?}, GPU {on_gpu:?}"
        );
        // Only the order of instances within a draw differs (the GPU groups them by atomic
        // counters): where two fish overlap at equal depth a pixel may differ.
        let (mean, most) = difference(&cpu_img, &gpu_img);
        assert!(
            mean < 0.05,
            "{case}: mean difference {mean} (largest {most})"
        );
        let picture = difference(&cpu_img, &image::RgbaImage::new(WIDTH, HEIGHT)).0;
        assert!(picture > 20.0, "{case}: something is drawn ({picture})");
    }
}

/// The GPU path records a fixed set of draws, whatever the number of fish in view.
#[test]
fn gpu_culling_records_as_many_draws_for_10_fish_as_for_600() {
    let gpu = gpu();
    let rig = common::PosedPorgy::load();
    let (_, few) = draw(&gpu, &rig, &school(&rig, 10), Culling::Gpu, 1.0, true);
    let (_, many) = draw(&gpu, &rig, &school(&rig, 600), Culling::Gpu, 1.0, true);
    assert!(
        many.num_fish_drawn > 10 * few.num_fish_drawn.max(1) / 2,
        "{few:?} {many:?}"
    );
    assert_eq!(few.num_draw_calls, many.num_draw_calls);
}
