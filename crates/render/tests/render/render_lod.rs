//! Frustum culling and levels of detail (issue 4): fish outside the view are not drawn, their
//! shadows are judged where they lie, the level-of-detail index lists are real simplifications
//! over the same vertices, a far fish gets a coarser level than a near one, and the culling
//! sphere holds the whole skinned fish however the motion layer bends it.

use crate::common;
use crate::common::UploadPorgy as _;

use glam::{Mat4, Quat, Vec3};
use shoal_core::motion::{
    Body, MotionParams, MotionPlayer, MotionRequest, RootState, Side, TurnKind,
};
use shoal_core::world::{Species, SpeciesDesc};
use shoal_render::lod::{LOD_TRIANGLE_RATIOS, MIN_TRIANGLES_FOR_LODS, NEAR_SHADOW_LOD};
use shoal_render::testmesh::TestFish;
use shoal_render::{
    Camera, FishInstance, FrameInput, Gpu, Look, MAX_LODS, MeshBounds, MeshId, MeshLods,
    MeshUpload, OffscreenTarget, Renderer, TankBounds,
};

fn gpu() -> Gpu {
    Gpu::headless().expect("a GPU adapter (lavapipe in CI: apt install mesa-vulkan-drivers)")
}

fn porgy() -> common::PosedPorgy {
    common::PosedPorgy::load()
}

/// One fish of `fish` straight (all yaws 0) with its root (snout) at `pos`, facing +x.
fn straight_palette(fish: &TestFish, pos: Vec3) -> Vec<Mat4> {
    let mut palette = vec![Mat4::IDENTITY; fish.num_joints()];
    fish.palette(
        Mat4::from_translation(pos),
        &vec![0.0; fish.num_joints()],
        &mut palette,
    );
    palette
}

fn frame<'a>(
    palettes: &'a [Mat4],
    instances: &'a [FishInstance],
    camera: Camera,
    look: Look,
) -> FrameInput<'a> {
    FrameInput {
        gpu_pose: None,
        palettes,
        instances,
        instances_revision: None,
        camera,
        tank: TankBounds::default(),
        time_s: 1.0,
        props: &[],
        overlay: &[],
        look,
    }
}

fn instance(mesh: MeshId, palette_offset: u32) -> FishInstance {
    FishInstance {
        mesh,
        palette_offset,
        tint: [1.0; 3],
        selected: false,
    }
}

/// Triangles the last frame should have submitted: each drawn fish at its level, each shadow at
/// the coarsest level.
fn expected_triangles(renderer: &Renderer, mesh: MeshId) -> u64 {
    let t = renderer.timings();
    let levels = renderer.mesh_lods(mesh).unwrap();
    let fish: u64 = levels
        .iter()
        .zip(t.num_fish_per_lod)
        .map(|(l, n)| u64::from(l.num_triangles()) * u64::from(n))
        .sum();
    let near = levels[NEAR_SHADOW_LOD.min(levels.len() - 1)].num_triangles();
    let outline = renderer.mesh_shadow_level(mesh).unwrap().num_triangles();
    let shadows = u64::from(near) * u64::from(t.num_shadows_drawn - t.num_outline_shadows)
        + u64::from(outline) * u64::from(t.num_outline_shadows);
    fish + shadows
}

/// A fish in front of the camera is drawn; one behind the camera and one far off to the side
/// are culled, and so are their shadows; the triangles submitted are the drawn fish's.
#[test]
fn fish_behind_or_beside_the_camera_are_culled() {
    let gpu = gpu();
    let mut renderer = Renderer::new(&gpu, OffscreenTarget::FORMAT).unwrap();
    // Pins the CPU path's counts and draw calls (render_cull checks the GPU path against it).
    renderer.set_culling(shoal_render::Culling::Cpu);
    let fish = TestFish::demo();
    let mesh = renderer.upload_mesh(&gpu, &fish.upload()).unwrap();
    let camera = Camera {
        target: Vec3::new(0.0, 100.0, 0.0),
        yaw_rad: 0.0,
        pitch_rad: 0.2,
        distance: 300.0,
        fov_y_rad: 50f32.to_radians(),
    };
    let eye = camera.eye();
    let back = (eye - camera.target).normalize();
    let inside = camera.target + Vec3::X * 25.0;
    let behind = eye + back * 200.0;
    let beside = camera.target + Vec3::X * 3_000.0;
    let nj = fish.num_joints();
    let mut palettes = Vec::new();
    for pos in [inside, behind, beside] {
        palettes.extend(straight_palette(&fish, pos));
    }
    let instances: Vec<FishInstance> = (0..3).map(|k| instance(mesh, (k * nj) as u32)).collect();
    let target = OffscreenTarget::new(&gpu, 96, 64);
    let input = frame(&palettes, &instances, camera, Look::default());
    renderer
        .render(&gpu, target.view(), target.size(), &input)
        .unwrap();
    let t = renderer.timings();
    assert_eq!(t.num_fish_drawn, 1, "{t:?}");
    assert_eq!(t.num_fish_culled, 2, "{t:?}");
    assert_eq!(t.num_fish_per_lod.iter().sum::<u32>(), 1, "{t:?}");
    assert_eq!(t.num_shadows_drawn, 1, "{t:?}");
    assert_eq!(
        t.num_triangles,
        expected_triangles(&renderer, mesh),
        "{t:?}"
    );
    // Background, floor, one shadow draw, one fish draw, tank edges.
    assert_eq!(t.num_draw_calls, 5);

    // Moved in front of the camera, all three are drawn.
    let mut palettes = Vec::new();
    for k in 0..3 {
        palettes.extend(straight_palette(
            &fish,
            inside + Vec3::new(-30.0 * k as f32, 10.0 * k as f32, 0.0),
        ));
    }
    let input = frame(&palettes, &instances, camera, Look::default());
    renderer
        .render(&gpu, target.view(), target.size(), &input)
        .unwrap();
    let t = renderer.timings();
    assert_eq!((t.num_fish_drawn, t.num_fish_culled), (3, 0), "{t:?}");
    assert_eq!(
        t.num_triangles,
        expected_triangles(&renderer, mesh),
        "{t:?}"
    );
}

/// A fish above and behind a camera that looks down at the sand is not drawn, but its shadow,
/// straight below it on the sand in the middle of the view, is: the sand there is darker than
/// without the fish.
#[test]
fn a_shadow_in_view_is_drawn_for_a_fish_out_of_view() {
    let gpu = gpu();
    let mut renderer = Renderer::new(&gpu, OffscreenTarget::FORMAT).unwrap();
    // Pins the CPU path's counts and draw calls (render_cull checks the GPU path against it).
    renderer.set_culling(shoal_render::Culling::Cpu);
    let fish = TestFish::demo();
    let mesh = renderer.upload_mesh(&gpu, &fish.upload()).unwrap();
    let camera = Camera {
        target: Vec3::ZERO,
        yaw_rad: 0.0,
        pitch_rad: 1.45,
        distance: 120.0,
        fov_y_rad: 50f32.to_radians(),
    };
    assert!(camera.eye().y < 125.0);
    // Snout at x = +25 so the body's middle is right above the target; high above the eye.
    let palettes = straight_palette(&fish, Vec3::new(25.0, 200.0, 0.0));
    let instances = [instance(mesh, 0)];
    let look = Look {
        light_dir: Vec3::Y,
        caustic_strength: 0.0,
        ..Look::default()
    };
    let target = OffscreenTarget::new(&gpu, 96, 64);
    let input = frame(&palettes, &instances, camera, look);
    renderer
        .render(&gpu, target.view(), target.size(), &input)
        .unwrap();
    let with_fish = target.read_rgba8(&gpu).unwrap();
    let t = renderer.timings();
    assert_eq!((t.num_fish_drawn, t.num_fish_culled), (0, 1), "{t:?}");
    assert_eq!(t.num_shadows_drawn, 1, "{t:?}");
    assert_eq!(
        t.num_triangles,
        expected_triangles(&renderer, mesh),
        "{t:?}"
    );

    renderer
        .render(
            &gpu,
            target.view(),
            target.size(),
            &frame(&[], &[], camera, look),
        )
        .unwrap();
    let without = target.read_rgba8(&gpu).unwrap();
    let centre = |img: &image::RgbaImage| {
        let p = img.get_pixel(48, 32);
        u32::from(p[0]) + u32::from(p[1]) + u32::from(p[2])
    };
    assert!(
        centre(&with_fish) + 30 < centre(&without),
        "the shadow should darken the sand: {} vs {}",
        centre(&with_fish),
        centre(&without)
    );

    // With shadows off neither is drawn.
    let input = frame(
        &palettes,
        &instances,
        camera,
        Look {
            shadows: false,
            ..look
        },
    );
    renderer
        .render(&gpu, target.view(), target.size(), &input)
        .unwrap();
    let t = renderer.timings();
    assert_eq!(
        (t.num_fish_drawn, t.num_shadows_drawn, t.num_triangles),
        (0, 0, 0)
    );
}

/// Checks one mesh's levels: full detail first and unchanged, then each about its ratio of the
/// one before (or, where the simplifier's error cap stops it, still a quarter fewer), every index
/// a vertex of the mesh, no collapsed triangle, and growing error; then the shadow level after
/// them, a quarter smaller than the coarsest at least.
fn check_levels(name: &str, mesh: &MeshUpload<'_>, lods: &MeshLods) {
    let n = mesh.positions.len() as u32;
    let full = mesh.indices.len() as u32;
    assert!(
        (3..=MAX_LODS).contains(&lods.levels.len()),
        "{name}: {:?}",
        lods.levels
    );
    assert_eq!(lods.levels[0].num_indices, full);
    assert_eq!(&lods.indices[..full as usize], mesh.indices);
    let mut previous = lods.levels[0];
    for (k, level) in lods.levels[1..].iter().enumerate() {
        let target = previous.num_triangles() as f32 * LOD_TRIANGLE_RATIOS[k];
        let got = level.num_triangles() as f32;
        // The halving steps (k ≥ 2) may stop short of their target at the error cap, but must
        // still drop a quarter of the triangles.
        let capped = k >= 2 && got <= previous.num_triangles() as f32 * 0.75;
        assert!(
            (got <= target + 1.0 && got >= target * 0.75) || capped,
            "{name}: {got} triangles for a target of {target}"
        );
        assert_eq!(
            level.first_index,
            previous.first_index + previous.num_indices
        );
        assert!(level.error >= previous.error && level.error.is_finite());
        let range = level.first_index as usize..(level.first_index + level.num_indices) as usize;
        for tri in lods.indices[range].chunks_exact(3) {
            assert!(tri.iter().all(|&i| i < n), "{name}: {tri:?} ≥ {n}");
            assert!(
                tri[0] != tri[1] && tri[1] != tri[2] && tri[0] != tri[2],
                "{name}: collapsed {tri:?}"
            );
        }
        previous = *level;
    }
    let Some(shadow) = lods.shadow else {
        // No outline level: shadows use the coarsest.
        assert_eq!(lods.shadow_level(), previous, "{name}");
        assert_eq!(
            lods.indices.len() as u32,
            previous.first_index + previous.num_indices
        );
        return;
    };
    assert_eq!(
        shadow.first_index,
        previous.first_index + previous.num_indices
    );
    assert!(
        shadow.num_triangles() * 4 <= previous.num_triangles() * 3 && shadow.num_triangles() > 0,
        "{name}: shadow {shadow:?} against the coarsest {previous:?}"
    );
    let range = shadow.first_index as usize..(shadow.first_index + shadow.num_indices) as usize;
    assert!(lods.indices[range].iter().all(|&i| i < n), "{name}");
    assert_eq!(lods.shadow_level(), shadow);
    assert_eq!(
        lods.indices.len() as u32,
        shadow.first_index + shadow.num_indices
    );
}

/// The porgy asset and the procedural fish get five levels (1, ~1/4, ~1/16, then halves) and an
/// outline level for shadows, over their own vertices; the renderer uploads exactly those. Small meshes (the
/// props) keep one level.
#[test]
fn lod_index_lists_are_quarter_steps_over_the_same_vertices() {
    let rig = porgy();
    let upload = rig.upload();
    let lods = MeshLods::build(&upload);
    check_levels("porgy", &upload, &lods);
    assert_eq!(lods.levels.len(), MAX_LODS, "the porgy gets every level");
    let shadow = lods
        .shadow
        .expect("the porgy gets an outline level for shadows");
    assert!(shadow.num_triangles() <= 32, "{shadow:?}");
    let procedural = TestFish::demo();
    let proc_upload = procedural.upload();
    check_levels("procedural", &proc_upload, &MeshLods::build(&proc_upload));
    let rock = shoal_render::props::PropMesh::rock();
    let rock_upload = rock.upload();
    assert!(rock_upload.indices.len() / 3 < MIN_TRIANGLES_FOR_LODS);
    assert_eq!(MeshLods::build(&rock_upload).levels.len(), 1);

    let gpu = gpu();
    let mut renderer = Renderer::new(&gpu, OffscreenTarget::FORMAT).unwrap();
    let id = renderer.upload_mesh(&gpu, &upload).unwrap();
    assert_eq!(renderer.mesh_lods(id).unwrap(), lods.levels.as_slice());
}

/// Two porgies in view, one close up and one far off: the close one is drawn at full detail,
/// the far one at a coarser level; with a tolerance of 0 both are at full detail.
#[test]
fn a_far_fish_uses_a_coarser_level_than_a_near_one() {
    let gpu = gpu();
    let mut renderer = Renderer::new(&gpu, OffscreenTarget::FORMAT).unwrap();
    // Pins the CPU path's counts and draw calls (render_cull checks the GPU path against it).
    renderer.set_culling(shoal_render::Culling::Cpu);
    let rig = porgy();
    let mesh = renderer.upload_mesh(&gpu, &rig.upload()).unwrap();
    let nj = rig.num_joints();
    let yaw = vec![0.1; rig.rig.body.num_joints()];
    let camera = Camera {
        target: Vec3::new(0.0, 100.0, 0.0),
        yaw_rad: 0.0,
        pitch_rad: 0.0,
        distance: 70.0,
        fov_y_rad: 50f32.to_radians(),
    };
    let place = |distance_from_eye: f32| {
        // Straight ahead of the eye (the eye looks along −z), broadside on.
        camera.eye() + Vec3::new(25.0, 0.0, -distance_from_eye)
    };
    let mut palettes = vec![Mat4::IDENTITY; 2 * nj];
    for (k, d) in [70.0, 2_500.0].into_iter().enumerate() {
        rig.palette(
            Mat4::from_rotation_translation(Quat::IDENTITY, place(d)),
            &yaw,
            &mut palettes[k * nj..(k + 1) * nj],
        );
    }
    let target = OffscreenTarget::new(&gpu, 480, 360);
    let lod_of = |renderer: &mut Renderer, k: usize| {
        let instances = [instance(mesh, (k * nj) as u32)];
        let input = frame(&palettes, &instances, camera, Look::default());
        renderer
            .render(&gpu, target.view(), target.size(), &input)
            .unwrap();
        let t = renderer.timings();
        assert_eq!(t.num_fish_drawn, 1, "{t:?}");
        t.num_fish_per_lod.iter().position(|&n| n == 1).unwrap()
    };
    let near = lod_of(&mut renderer, 0);
    let far = lod_of(&mut renderer, 1);
    assert_eq!(near, 0, "a close-up is drawn at full detail");
    assert!(
        far > NEAR_SHADOW_LOD,
        "a fish 2,500 units away (~15 px long) uses one of the levels for a few pixels, got {far}"
    );
    // Both together: one draw per level in use, plus one shadow draw (the far fish's outline;
    // the near one's shadow falls outside this view).
    let instances = [instance(mesh, 0), instance(mesh, nj as u32)];
    renderer
        .render(
            &gpu,
            target.view(),
            target.size(),
            &frame(&palettes, &instances, camera, Look::default()),
        )
        .unwrap();
    let t = renderer.timings();
    assert_eq!(t.num_draw_calls, 2 + 1 + 2 + 1, "{t:?}");
    assert_eq!(t.num_outline_shadows, 1, "{t:?}");
    assert_eq!(
        t.num_triangles,
        expected_triangles(&renderer, mesh),
        "{t:?}"
    );

    renderer.set_lod_tolerance_px(0.0);
    assert_eq!(lod_of(&mut renderer, 1), 0);
}

/// CPU linear-blend skinning, eq. (1).
fn skin(mesh: &MeshUpload<'_>, i: usize, palette: &[Mat4]) -> Vec3 {
    let v = Vec3::from(mesh.positions[i]);
    mesh.joints[i]
        .iter()
        .zip(mesh.weights[i])
        .map(|(&j, w)| palette[usize::from(j)].transform_point3(v) * w)
        .sum()
}

/// The turn fish `fish` is made to start at second `second` of [`worst_bend`]'s three: quick
/// and normal turns of 90° and 180°, to both sides.
fn hard_turn(fish: usize, second: usize) -> MotionRequest {
    let kind = if fish.is_multiple_of(2) {
        TurnKind::Quick
    } else {
        TurnKind::Normal
    };
    let side = if (fish / 2 + second).is_multiple_of(2) {
        Side::Left
    } else {
        Side::Right
    };
    let angle = std::f32::consts::PI * if fish % 4 < 2 { 1.0 } else { 0.5 };
    MotionRequest::Turn { kind, angle, side }
}

/// Largest distance of a skinned vertex of `upload` from its culling sphere's centre, in culling
/// radii, over the frames `palettes` yields (each frame: every fish's palette).
fn worst_of(upload: &MeshUpload, frames: impl Iterator<Item = Vec<Vec<Mat4>>>) -> f32 {
    let bounds = MeshBounds::from_positions(upload.positions);
    let mut worst = 0.0f32;
    for frame in frames {
        for palette in &frame {
            let (sphere, _) = bounds.world_sphere(&palette[0]);
            for i in 0..upload.positions.len() {
                let d = skin(upload, i, palette).distance(sphere.center);
                worst = worst.max(d / sphere.radius);
            }
        }
    }
    worst
}

/// Largest skinned distance / culling radius of eight porgies in the world (the motion and pose
/// stages of the tick, no behaviour) made to turn hard every second for three seconds.
fn worst_bend_porgy() -> f32 {
    let assets = common::repo().join("assets");
    let species = Species::load(SpeciesDesc::black_porgy(), &assets).expect("porgy loads");
    let mut world = shoal_core::world::bench::bench_world(species, 8, 1).unwrap();
    let rig = porgy();
    let upload = rig.upload();
    let frames = (0..90).map(|step| {
        if step % 30 == 0 {
            let ids: Vec<_> = world.fish_ids().collect();
            for (fish, id) in ids.into_iter().enumerate() {
                world.request(id, hard_turn(fish, step / 30), true).unwrap();
            }
        }
        // 1/30 s: two 60 Hz ticks of motion, then the pose stage.
        world.step_motion(1.0 / 60.0);
        world.step_motion(1.0 / 60.0);
        world.update_pose();
        world
            .fish_ids()
            .map(|id| {
                let mut palette = Vec::new();
                assert!(world.joint_palette(id, &mut palette));
                palette
            })
            .collect()
    });
    worst_of(&upload, frames)
}

/// The same for eight procedural fish, each on its own motion player (the procedural mesh is
/// not a world species: its joints 1.. are the driven joints, posed directly).
fn worst_bend_procedural() -> f32 {
    let fish = TestFish::demo();
    let nj = fish.num_joints();
    let body = Body::evenly_spaced(nj);
    let params = MotionParams::BLACK_PORGY.with_length(fish.length);
    let mut swimmers: Vec<(MotionPlayer, RootState, Vec<f32>, Vec<f32>)> = (0..8)
        .map(|k| {
            let mut player = MotionPlayer::with_phase(k as f32 * 0.7);
            player
                .push(MotionRequest::Swim { speed: params.s })
                .unwrap();
            let root = RootState {
                pos: Vec3::new(-150.0 + 40.0 * k as f32, 120.0, 0.0),
                heading: k as f32,
                pitch: 0.0,
                speed: params.s,
            };
            (
                player,
                root,
                vec![0.0; body.joints_x.len()],
                vec![0.0; body.num_joints()],
            )
        })
        .collect();
    let upload = fish.upload();
    let frames = (0..90).map(|step| {
        swimmers
            .iter_mut()
            .enumerate()
            .map(|(k, (player, root, lateral, yaw))| {
                if step % 30 == 0 {
                    player.interrupt(hard_turn(k, step / 30)).unwrap();
                }
                player.step(1.0 / 30.0, &params, &body, root, lateral, yaw);
                let placement = Mat4::from_rotation_translation(
                    Quat::from_rotation_y(root.heading + player.head_yaw())
                        * Quat::from_rotation_z(root.pitch),
                    root.pos + root.left() * player.head_lateral(),
                );
                let mut yaws = vec![0.0; nj];
                let n = yaw.len().min(nj - 1);
                yaws[1..=n].copy_from_slice(&yaw[..n]);
                let mut palette = vec![Mat4::IDENTITY; nj];
                fish.palette(placement, &yaws, &mut palette);
                palette
            })
            .collect()
    });
    worst_of(&upload, frames)
}

/// The culling sphere (bind-space bounds carried by palette joint 0, grown for bending) holds
/// every skinned vertex of the porgy asset and the procedural fish while they swim and turn
/// hard: a sphere too small would make fish at the screen edges vanish early.
#[test]
fn the_culling_sphere_holds_the_bending_fish() {
    for (name, worst) in [
        ("porgy", worst_bend_porgy()),
        ("procedural", worst_bend_procedural()),
    ] {
        eprintln!("{name}: largest skinned distance / culling radius: {worst:.3}");
        assert!(
            worst <= 1.0,
            "{name}: a skinned vertex lies {worst:.3} culling radii from the centre"
        );
        // The margin is not absurdly loose either: the fish fills most of it.
        assert!(worst > 0.6, "{name}: worst {worst:.3}");
    }
}
