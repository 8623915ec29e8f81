//! The world seam: `app::WorldScene` over the real world (black porgies from the generated asset,
//! built-in Rust driver) feeds the renderer the world's own palettes, one instance per fish.

mod common;

use shoal::app::WorldScene;
use shoal::motion::MotionRequest;
use shoal::render::{Gpu, OffscreenTarget, Renderer};
use shoal::world::bench::{RustSim, bench_world};
use shoal::world::driver::WanderDriver;
use shoal::world::{Species, SpeciesDesc};

fn porgy_scene(fish: usize) -> WorldScene<RustSim> {
    let assets = std::path::PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("assets");
    let species = Species::load(SpeciesDesc::black_porgy(), &assets).expect("porgy loads");
    let world = bench_world(species, fish, 3).unwrap();
    WorldScene::new(RustSim::new(world, WanderDriver::default()))
}

#[test]
fn instances_point_at_the_worlds_palettes_and_ticks_follow_time() {
    let mut scene = porgy_scene(12);
    {
        let input = scene.frame_input();
        let w = scene.sim().world();
        assert_eq!(input.instances.len(), 12);
        assert_eq!(input.palettes.len(), w.palettes().len());
        for (inst, off) in input.instances.iter().zip(w.palette_offsets()) {
            assert_eq!(inst.palette_offset, *off);
            assert_eq!(inst.mesh.0, 0);
        }
        // Meshes: the porgy, then the rock and pellet props.
        assert_eq!(scene.meshes().len(), 3);
    }
    let before = scene.sim().world().tick_count();
    scene.step(0.1); // 6 ticks at 60 Hz
    assert_eq!(scene.sim().world().tick_count() - before, 6);
    scene.step(1.0 / 120.0); // half a tick: accumulates, no tick yet
    assert_eq!(scene.sim().world().tick_count() - before, 6);
    scene.step(1.0 / 120.0);
    assert_eq!(scene.sim().world().tick_count() - before, 7);
    // A long step runs every tick it covers (`shoal render --fps 4` simulates 15 ticks a frame;
    // it used to stop at 8 and drop the rest). The window bounds its frames' real time instead.
    scene.step(2.0);
    assert_eq!(scene.sim().world().tick_count() - before, 127);
    scene.step(1.0 / 60.0);
    assert_eq!(scene.sim().world().tick_count() - before, 128);
}

#[test]
fn panel_edits_reach_the_world_and_bad_values_are_refused() {
    let mut scene = porgy_scene(4);
    let mut p = scene.motion_params(0).unwrap();
    p.max_amp *= 1.5;
    scene.set_motion_params(0, p).unwrap();
    assert_eq!(scene.motion_params(0).unwrap().max_amp, p.max_amp);
    let mut bad = p;
    bad.tt = f32::NAN;
    let err = scene.set_motion_params(0, bad).unwrap_err().to_string();
    assert!(err.contains("tt") || err.contains("Tt"), "{err}");
    assert_eq!(
        scene.motion_params(0).unwrap().tt,
        p.tt,
        "a refused edit changes nothing"
    );

    let ids = scene.world().fish_id_slice().to_vec();
    scene
        .request_motion(ids[2], MotionRequest::Stop { duration: 0.5 })
        .unwrap();
    scene.step(1.0 / 60.0);
    let lines = scene.inspect(ids[2]);
    assert!(
        lines
            .iter()
            .any(|(k, v)| k == "motion" && v.contains("stop")),
        "{lines:?}"
    );
    // A fish that is gone: despawned, its handle refused (not another fish's).
    assert!(scene.sim_mut().world_mut().despawn(ids[3]));
    assert!(
        scene
            .request_motion(ids[3], MotionRequest::Swim { speed: 10.0 })
            .is_err()
    );
    let mut wave = Vec::new();
    scene.step(0.2);
    scene.body_wave(ids[0], &mut wave);
    assert_eq!(
        wave.len(),
        7,
        "six driven joints and the tail tip: {wave:?}"
    );
}

#[test]
fn renders_the_world_offscreen() {
    let mut scene = porgy_scene(20);
    scene.step(0.25);
    let gpu = Gpu::headless().expect("a GPU adapter (lavapipe: apt install mesa-vulkan-drivers)");
    let mut renderer = Renderer::new(&gpu, OffscreenTarget::FORMAT).unwrap();
    for m in scene.meshes() {
        renderer.upload_mesh(&gpu, &m).unwrap();
    }
    let target = OffscreenTarget::new(&gpu, 160, 96);
    let input = scene.frame_input();
    renderer
        .render(&gpu, target.view(), target.size(), &input)
        .unwrap();
    let img = target.read_rgba8(&gpu).unwrap();
    // Fish are darker than the water behind them in places: the image is not just background.
    let distinct: std::collections::HashSet<[u8; 4]> = img.pixels().map(|p| p.0).collect();
    assert!(distinct.len() > 500, "only {} colours", distinct.len());
    // Species meshes plus props: background, floor, shadow + fish for the porgy mesh, tank.
    assert_eq!(renderer.timings().num_draw_calls, 5);
}

/// Editing the scene file of a running Lua scene: the scene reports the change (the panel then
/// offers a restart) and restarting loads the edited file, with its new fish and meshes.
#[test]
fn an_edited_scene_file_restarts_with_its_new_contents() {
    use shoal::script::Simulation;
    let (dir, _root) = common::scratch_repo();
    let scene_path = dir.path().join("scripts/scenes/restart.lua");
    let scene_text = |count: usize| {
        format!(
            "return {{ tank = {{ min = {{ -500, 0, -300 }}, max = {{ 500, 400, 300 }} }},\n\
             fish = {{ {{ species = \"black_porgy\", count = {count}, behavior = \"wander\",\n\
             region = {{ min = {{ -200, 150, -120 }}, max = {{ 200, 260, 120 }} }} }} }} }}\n"
        )
    };
    std::fs::write(&scene_path, scene_text(3)).unwrap();
    let sim = Simulation::from_scene(dir.path(), &scene_path, 5).unwrap();
    let mut scene = WorldScene::new(sim);
    assert_eq!(scene.num_fish(), 3);
    assert!(!scene.scene_changed());

    std::fs::write(&scene_path, scene_text(7)).unwrap();
    // What the file watcher does on a save.
    let mut sim_events = Vec::new();
    {
        let sim = scene.sim_mut();
        sim_events.extend(sim.reload_changed(std::slice::from_ref(&scene_path)));
    }
    assert!(!sim_events.is_empty());
    assert!(scene.scene_changed(), "the panel must offer a restart");
    assert_eq!(
        scene.num_fish(),
        3,
        "nothing changes until the designer restarts"
    );

    assert!(matches!(scene.restart_scene(), Ok(true)));
    assert_eq!(scene.num_fish(), 7);
    assert!(!scene.scene_changed());
    let input = scene.frame_input();
    assert_eq!(input.instances.len(), 7);
    assert_eq!(input.palettes.len(), scene.sim().world().palettes().len());
}
