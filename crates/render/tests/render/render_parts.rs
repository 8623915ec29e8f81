//! A frame drawn in parts (`Renderer::encode_part`, issue 35: the window draws a slow view a
//! slice of the fish at a time, over several frames) is the frame drawn whole: the same picture,
//! with both cullings, with and without MSAA; and each part adds its own fish.

use crate::common;
use crate::common::UploadPorgy as _;

use glam::{Mat4, Quat, Vec3};
use shoal_render::props::PropMesh;
use shoal_render::shaders::ShaderSources;
use shoal_render::{
    Camera, Culling, FishInstance, FrameInput, FramePart, Gpu, Look, OffscreenTarget, OverlayLine,
    Prop, Renderer, TankBounds,
};

const WIDTH: u32 = 320;
const HEIGHT: u32 = 200;

/// 120 porgies on a grid through the tank, each bent by its own phase, palettes laid out fish
/// after fish.
fn school(rig: &common::PosedPorgy) -> (Vec<Mat4>, Vec<u32>) {
    let nj = rig.num_joints();
    let n = 120;
    let mut palettes = vec![Mat4::IDENTITY; n * nj];
    let mut offsets = Vec::new();
    for i in 0..n {
        let pos = Vec3::new(
            -450.0 + 75.0 * (i % 12) as f32,
            30.0 + 20.0 * (i / 12) as f32,
            -300.0 + 53.0 * ((i * 7) % 11) as f32,
        );
        let root = Mat4::from_rotation_translation(Quat::from_rotation_y(0.5 * i as f32), pos);
        let yaws: Vec<f32> = (0..rig.rig.body.num_joints())
            .map(|j| 0.2 * (i as f32 + j as f32 * 0.8).sin())
            .collect();
        rig.palette(root, &yaws, &mut palettes[i * nj..(i + 1) * nj]);
        offsets.push((i * nj) as u32);
    }
    (palettes, offsets)
}

/// Draws the school with `culling` and `msaa`, whole when `parts` is 1, else in `parts` slices
/// of the fish (props in the first, the overlay in the last), each submitted on its own.
/// With `stop_after`, only that many parts are drawn.
fn draw(
    gpu: &Gpu,
    rig: &common::PosedPorgy,
    culling: Culling,
    msaa: u32,
    parts: usize,
    stop_after: Option<usize>,
) -> image::RgbaImage {
    let mut renderer = Renderer::with_shaders_and_msaa(
        gpu,
        OffscreenTarget::FORMAT,
        ShaderSources::embedded(),
        msaa,
    )
    .unwrap();
    assert_eq!(renderer.set_culling(culling), culling, "lavapipe runs both");
    let porgy = renderer.upload_mesh(gpu, &rig.upload()).unwrap();
    let rock = renderer
        .upload_mesh(gpu, &PropMesh::rock().upload())
        .unwrap();
    let (palettes, offsets) = school(rig);
    let instances: Vec<FishInstance> = offsets
        .iter()
        .enumerate()
        .map(|(i, &palette_offset)| FishInstance {
            mesh: porgy,
            palette_offset,
            tint: if i % 5 == 0 {
                [1.0, 0.6, 0.5]
            } else {
                [1.0; 3]
            },
            selected: i == 7,
        })
        .collect();
    let props = [Prop {
        mesh: rock,
        transform: Mat4::from_scale_rotation_translation(
            Vec3::splat(60.0),
            Quat::from_rotation_y(0.4),
            Vec3::new(100.0, 20.0, 0.0),
        ),
        tint: [1.0; 3],
    }];
    let overlay = [OverlayLine {
        a: Vec3::new(-400.0, 100.0, 0.0),
        b: Vec3::new(400.0, 150.0, 0.0),
        color: [1.0, 1.0, 0.0, 1.0],
    }];
    let tank = TankBounds::default();
    let whole = FrameInput {
        gpu_pose: None,
        palettes: &palettes,
        instances: &instances,
        instances_revision: None,
        camera: Camera {
            target: tank.center(),
            yaw_rad: 0.35,
            pitch_rad: 0.3,
            distance: 900.0,
            fov_y_rad: 50f32.to_radians(),
        },
        tank,
        time_s: 1.0,
        props: &props,
        overlay: &overlay,
        look: Look::default(),
    };
    let target = OffscreenTarget::new(gpu, WIDTH, HEIGHT);
    let each = instances.len().div_ceil(parts);
    for k in 0..stop_after.unwrap_or(parts) {
        let part = FramePart {
            first: k == 0,
            last: k + 1 == parts,
        };
        let fish = k * each..((k + 1) * each).min(instances.len());
        let input = FrameInput {
            instances: &instances[fish],
            instances_revision: None,
            props: if part.first { &props } else { &[] },
            overlay: if part.last { &overlay } else { &[] },
            ..whole
        };
        let mut encoder = gpu
            .device
            .create_command_encoder(&wgpu::CommandEncoderDescriptor { label: None });
        renderer
            .encode_part(
                gpu,
                &mut encoder,
                target.view(),
                target.size(),
                &input,
                part,
            )
            .unwrap();
        gpu.queue.submit([encoder.finish()]);
    }
    target.read_rgba8(gpu).unwrap()
}

/// Mean difference over the RGB channels of two images.
fn mean_difference(a: &image::RgbaImage, b: &image::RgbaImage) -> f64 {
    let sum: u64 = a
        .pixels()
        .zip(b.pixels())
        .map(|(p, q)| (0..3).map(|c| u64::from(p[c].abs_diff(q[c]))).sum::<u64>())
        .sum();
    sum as f64 / (3.0 * f64::from(a.width() * a.height()))
}

#[test]
fn a_frame_drawn_in_parts_is_the_frame_drawn_whole() {
    let gpu = Gpu::headless().expect("a GPU adapter (lavapipe in CI)");
    let rig = common::PosedPorgy::load();
    for (culling, msaa) in [(Culling::Cpu, 1), (Culling::Gpu, 1), (Culling::Cpu, 4)] {
        let case = format!("{culling:?} culling, MSAA {msaa}");
        let whole = draw(&gpu, &rig, culling, msaa, 1, None);
        let parts = draw(&gpu, &rig, culling, msaa, 3, None);
        let diff = mean_difference(&whole, &parts);
        assert!(diff < 0.05, "{case}: in 3 parts differs by {diff}");
        // Each part draws fish of its own: two parts of three lack the last third's fish, and
        // the tank's edges and overlay (the last part's).
        let two = draw(&gpu, &rig, culling, msaa, 3, Some(2));
        let missing = mean_difference(&whole, &two);
        assert!(
            missing > 0.3,
            "{case}: the last part adds little ({missing})"
        );
        let background = mean_difference(&whole, &image::RgbaImage::new(WIDTH, HEIGHT));
        assert!(
            background > 20.0,
            "{case}: something is drawn ({background})"
        );
    }
}
