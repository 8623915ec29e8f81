//! The GPU pose pass (issue 18): the renderer poses the fish from one record each
//! (`shaders/pose.wgsl`), and what it writes is the CPU pose stage's palette to f32 rounding,
//! whose frames look the same. Runs on lavapipe in CI.

use crate::common;

use glam::{Mat4, Vec3};
use shoal_app::WorldScene;
use shoal_core::world::driver::{WanderDriver, WanderPipeline};
use shoal_render::{Camera, Gpu, GpuPoseFrame, OffscreenTarget, RenderError, Renderer};

/// Ten porgies and ten eels two seconds into swimming (bent bodies), posed on the GPU.
fn scene() -> WorldScene<WanderPipeline> {
    let world = common::porgy_and_eel_world();
    let mut scene = WorldScene::new(WanderPipeline::new(world, WanderDriver::default()));
    scene.step(2.0);
    scene
}

fn renderer(gpu: &Gpu, scene: &WorldScene<WanderPipeline>) -> Renderer {
    let mut renderer = Renderer::new(gpu, OffscreenTarget::FORMAT).unwrap();
    for m in scene.meshes() {
        renderer.upload_mesh(gpu, &m).unwrap();
    }
    renderer
}

fn gpu() -> Gpu {
    Gpu::headless().expect("a GPU adapter (lavapipe: apt install mesa-vulkan-drivers)")
}

/// Largest difference between two matrices relative to the larger's largest element (or 1).
fn relative_error(a: &Mat4, b: &Mat4) -> f32 {
    let scale = b.abs().to_cols_array().into_iter().fold(1.0f32, f32::max);
    (*a - *b)
        .abs()
        .to_cols_array()
        .into_iter()
        .fold(0.0, f32::max)
        / scale
}

/// `scene()` with every fish a fraction of a second into a turn (quick, normal and serial in
/// turn), so the pass's shape step runs both turn waves and the cross-fade from the swim.
fn turning_scene() -> WorldScene<WanderPipeline> {
    use shoal_core::motion::{MotionRequest, Side, TurnKind};
    let mut scene = scene();
    let w = scene.sim_mut().world_mut();
    let ids: Vec<_> = w.fish_ids().collect();
    for (k, id) in ids.into_iter().enumerate() {
        let kinds = [TurnKind::Quick, TurnKind::Normal, TurnKind::Serial];
        let turn = MotionRequest::Turn {
            kind: kinds[k % 3],
            angle: 1.0,
            side: if k % 2 == 0 { Side::Left } else { Side::Right },
        };
        w.request(id, turn, true).unwrap();
    }
    scene.step(0.2);
    scene
}

#[test]
fn the_pose_pass_writes_the_cpu_stages_palettes() {
    let gpu = gpu();
    let mut scene = turning_scene();
    let records = scene.world().gpu_pose_records();
    // kind 1: a normal turn's wave; kind 2: a quick or serial turn's; weight < 1: cross-fading.
    for kind in [1, 2] {
        assert!(
            records
                .iter()
                .any(|r| r.current.kind == kind && r.current.ip > 0.0)
        );
    }
    assert!(records.iter().any(|r| r.wave[2] < 1.0));
    let mut renderer = renderer(&gpu, &scene);
    let posed = {
        let input = scene.frame_input();
        let pose = input.gpu_pose.expect("the scene poses on the GPU");
        (
            renderer.pose_palettes(&gpu, &pose).unwrap(),
            pose.anchors.to_vec(),
        )
    };
    let (gpu_palette, anchors) = posed;
    // The same tick posed on the CPU.
    assert!(!scene.set_gpu_pose(false));
    let w = scene.world();
    assert_eq!(gpu_palette.len(), w.palettes().len());
    let mut worst = 0.0f32;
    for (i, &id) in w.fish_id_slice().iter().enumerate() {
        let range = w.palette_range(id).unwrap();
        for (k, (g, c)) in gpu_palette[range.clone()]
            .iter()
            .zip(&w.palettes()[range.clone()])
            .enumerate()
        {
            let e = relative_error(g, c);
            assert!(
                e < 2e-4,
                "fish {id:?} slot {k}: GPU {g:?} against CPU {c:?}"
            );
            worst = worst.max(e);
        }
        // Culling reads slot 0: the CPU's own to rounding, and what the pass wrote there.
        let slot0 = &w.palettes()[range.start];
        assert!(relative_error(&anchors[i], slot0) < 2e-6, "fish {id:?}");
        assert!(relative_error(&anchors[i], &gpu_palette[range.start]) < 2e-6);
    }
    eprintln!("largest relative difference, GPU against CPU: {worst:e}");
    // Every fish is somewhere else: a pass that wrote one fish everywhere would fail.
    let tails: Vec<Vec3> = w
        .fish_id_slice()
        .iter()
        .map(|&id| {
            let range = w.palette_range(id).unwrap();
            gpu_palette[range.end - 1].w_axis.truncate()
        })
        .collect();
    assert!(tails.windows(2).all(|t| t[0].distance(t[1]) > 1.0));
}

#[test]
fn frames_posed_on_the_gpu_look_as_frames_posed_on_the_cpu() {
    let gpu = gpu();
    let mut scene = scene();
    let mut renderer = renderer(&gpu, &scene);
    // Close on an eel (fish 10) so the bodies fill the frame.
    let id = scene.world().fish_id_slice()[10];
    let root = *scene.world().root(id).unwrap();
    let camera = Camera {
        target: root.pos,
        yaw_rad: 0.4,
        pitch_rad: 0.9,
        distance: 220.0,
        fov_y_rad: 0.8,
    };
    let target = OffscreenTarget::new(&gpu, 200, 150);
    let mut frame = |scene: &WorldScene<WanderPipeline>| {
        let mut input = scene.frame_input();
        input.camera = camera;
        renderer
            .render(&gpu, target.view(), target.size(), &input)
            .unwrap();
        target.read_rgba8(&gpu).unwrap()
    };
    let on_gpu = frame(&scene);
    assert!(!scene.set_gpu_pose(false));
    let on_cpu = frame(&scene);
    // Something is drawn where the fish is: the frame is not just water.
    let water = frame(&{
        let mut empty = WorldScene::new(WanderPipeline::new(
            shoal_core::world::World::new(*scene.world().tank(), 1),
            WanderDriver::default(),
        ));
        empty.set_gpu_pose(true);
        empty
    });
    let differing = |a: &image::RgbaImage, b: &image::RgbaImage, by: u8| {
        a.pixels()
            .zip(b.pixels())
            .filter(|(p, q)| p.0.iter().zip(q.0).any(|(x, y)| x.abs_diff(y) > by))
            .count()
    };
    let fish_pixels = differing(&on_cpu, &water, 8);
    assert!(fish_pixels > 500, "only {fish_pixels} pixels show fish");
    let off = differing(&on_gpu, &on_cpu, 8);
    assert!(
        off * 200 < fish_pixels,
        "{off} of the {fish_pixels} fish pixels differ between GPU and CPU posing"
    );
}

#[test]
fn a_frame_whose_records_are_out_of_range_is_an_error_not_a_crash() {
    let gpu = gpu();
    let scene = scene();
    let mut renderer = renderer(&gpu, &scene);
    let target = OffscreenTarget::new(&gpu, 64, 48);
    let input = scene.frame_input();
    let pose = input.gpu_pose.unwrap();
    // The frame with `bad` as its GPU pose: its error.
    let mut render_with = |bad: GpuPoseFrame<'_>| {
        let frame = shoal_render::FrameInput {
            gpu_pose: Some(bad),
            ..input
        };
        renderer
            .render(&gpu, target.view(), target.size(), &frame)
            .unwrap_err()
            .to_string()
    };
    let mut fish = pose.fish.to_vec();
    fish[3].program = 9;
    let err = render_with(GpuPoseFrame {
        fish: &fish,
        ..pose
    });
    assert!(err.contains("fish 3 uses program 9"), "{err}");
    fish[3] = pose.fish[3];
    fish[4].palette_offset = u32::MAX;
    let err = render_with(GpuPoseFrame {
        fish: &fish,
        ..pose
    });
    assert!(err.contains("fish 4 writes palette entries"), "{err}");
    fish[4] = pose.fish[4];
    fish[5].palette_offset = pose.palette_len;
    let err = render_with(GpuPoseFrame {
        fish: &fish,
        ..pose
    });
    assert!(err.contains("fish 5 writes palette entries"), "{err}");
    // A palette far larger than the records can fill (the buffer is sized from it).
    let err = render_with(GpuPoseFrame {
        palette_len: u32::MAX,
        ..pose
    });
    assert!(err.contains("palette entries for 20 fish records"), "{err}");
    // A program reaching past the arrays (with sums that would overflow a u32), and one whose
    // step reads a model matrix not yet made.
    let mut programs = pose.programs.clone();
    programs.programs[0].first_model = u32::MAX;
    let err = render_with(GpuPoseFrame {
        programs: &programs,
        ..pose
    });
    assert!(err.contains("program 0 reaches past"), "{err}");
    let mut programs = pose.programs.clone();
    programs.models[1].parent = 1;
    let err = render_with(GpuPoseFrame {
        programs: &programs,
        ..pose
    });
    assert!(err.contains("model step 1: parent"), "{err}");
    let invalid = renderer
        .render(
            &gpu,
            target.view(),
            target.size(),
            &shoal_render::FrameInput {
                gpu_pose: Some(GpuPoseFrame {
                    fish: &fish,
                    ..pose
                }),
                ..input
            },
        )
        .unwrap_err();
    assert!(matches!(invalid, RenderError::InvalidFrame(_)));
    // The good frame still draws.
    renderer
        .render(&gpu, target.view(), target.size(), &input)
        .unwrap();
}

/// `pose.wgsl` reloads like the other shaders: a broken edit is reported by file and the pass
/// keeps running the previous pipeline; a good edit takes effect.
#[test]
fn an_edited_pose_shader_is_reloaded_and_a_broken_one_reported() {
    use shoal_render::shaders::ShaderSources;
    let gpu = gpu();
    let scene = scene();
    let mut renderer = renderer(&gpu, &scene);
    let input = scene.frame_input();
    let pose = input.gpu_pose.unwrap();
    let before = renderer.pose_palettes(&gpu, &pose).unwrap();
    let with = |text: &str| {
        let mut sources = ShaderSources::embedded();
        for (name, t) in &mut sources.files {
            if name == "pose.wgsl" {
                *t = text.to_owned();
            }
        }
        sources
    };
    let err = renderer
        .reload_shaders(&gpu, with("fn cs_pose( -> not wgsl"))
        .unwrap_err();
    assert!(
        matches!(&err, RenderError::Shader { file, .. } if file == "pose.wgsl"),
        "{err}"
    );
    assert_eq!(renderer.pose_palettes(&gpu, &pose).unwrap(), before);
    // Every entry 10 units higher.
    let raised = ShaderSources::embedded().get("pose.wgsl").replace(
        "palette[f.palette_offset + k] = entry;",
        "palette[f.palette_offset + k] = entry + mat4x4<f32>(vec4<f32>(0.0), vec4<f32>(0.0), \
         vec4<f32>(0.0), vec4<f32>(0.0, 10.0, 0.0, 0.0));",
    );
    assert_ne!(raised, ShaderSources::embedded().get("pose.wgsl"));
    renderer.reload_shaders(&gpu, with(&raised)).unwrap();
    let after = renderer.pose_palettes(&gpu, &pose).unwrap();
    assert_eq!(after.len(), before.len());
    for (a, b) in after.iter().zip(&before) {
        assert!((a.w_axis.y - b.w_axis.y - 10.0).abs() < 1e-3, "{a:?} {b:?}");
        assert_eq!(a.x_axis, b.x_axis);
    }
}

/// A species reloaded with another palette layout while the world is paused (no tick, so no pose
/// stage): the next frame's records already follow the new layout, and it draws.
#[test]
fn a_species_reloaded_while_paused_draws_from_fresh_records() {
    use shoal_core::world::{Species, SpeciesDesc, SpeciesId};
    let gpu = gpu();
    let mut scene = scene();
    let mut desc = SpeciesDesc::black_porgy();
    desc.vertebral_joints.pop();
    let porgy = Species::load(desc, &common::repo().join("assets")).unwrap();
    let world = scene.sim_mut().world_mut();
    let slots = world.num_palette_slots(SpeciesId(0));
    world.replace_species(SpeciesId(0), porgy).unwrap();
    assert_ne!(world.num_palette_slots(SpeciesId(0)), slots);
    scene.step(0.0);
    assert!(scene.take_meshes_changed());
    let mut renderer = renderer(&gpu, &scene);
    let input = scene.frame_input();
    let pose = input.gpu_pose.unwrap();
    for (inst, record) in input.instances.iter().zip(pose.fish) {
        assert_eq!(inst.palette_offset, record.palette_offset);
    }
    assert_eq!(
        Some(&pose.palette_len),
        scene.world().palette_offsets().last()
    );
    let target = OffscreenTarget::new(&gpu, 64, 48);
    renderer
        .render(&gpu, target.view(), target.size(), &input)
        .unwrap();
}
