//! `shoal asset species` (issue 15, bring your own fish): motion suggested from the body's shape,
//! a species file the scripting layer loads and swims, and no silent overwrite.

use std::path::Path;
use std::process::Command;

use shoal_core::asset::species_file::suggest;
use shoal_core::skin::FishModel;

use crate::common;

fn model(name: &str) -> FishModel {
    FishModel::load(&common::repo().join("assets").join(name)).unwrap()
}

#[test]
fn deep_bodies_get_porgy_motion_and_slender_ones_eel_motion() {
    let porgy = suggest("p", "black_porgy.glb", &model("black_porgy.glb")).unwrap();
    assert_eq!(porgy.swimming_mode, "carangiform", "{}", porgy.slenderness);
    assert_eq!(porgy.base, "black_porgy");
    // The deep body gets the black porgy's motion (issue 16's carangiform values).
    let porgy_motion = shoal_core::motion::MotionParams::BLACK_PORGY;
    assert!((porgy.desc.motion.p - porgy_motion.p).abs() < 1e-6);
    assert_eq!(porgy.desc.motion.l, 50.0);
    // (The suggestion rounds λ to whole units: 1.2·50 = 60.000004 in f32.)
    assert_eq!(porgy.desc.motion.lambda, porgy_motion.lambda.round());
    assert_eq!(porgy.desc.motion.turn_axis_fraction(), 0.4);
    assert_eq!(
        porgy.desc.motion.front_wave,
        shoal_core::motion::FrontWave::Recoil
    );
    let eel = suggest("e", "eel.glb", &model("eel.glb")).unwrap();
    assert_eq!(
        eel.swimming_mode, "anguilliform-like",
        "{}",
        eel.slenderness
    );
    assert_eq!(eel.base, "eel");
    // The slender one the eel's (anguilliform: the wave runs from the snout).
    let eel_motion = shoal_core::species::SpeciesDesc::eel().motion;
    assert!((eel.desc.motion.p - eel_motion.p).abs() < 1e-6);
    assert_eq!(
        eel.desc.motion.lambda,
        (eel_motion.lambda / eel_motion.l * eel.desc.motion.l).round()
    );
    assert_eq!(
        eel.desc.motion.front_wave,
        shoal_core::motion::FrontWave::Anguilliform
    );
    assert!(eel.slenderness > 2.0 * porgy.slenderness);
    assert_eq!(porgy.desc.vertebral_joints.len(), 6);
    assert!(porgy.desc.motion.validate().is_ok());
    assert!(eel.desc.motion.validate().is_ok());
}

#[test]
fn an_unrigged_model_is_refused_with_a_hint() {
    // RiggedSimple has joints, but none named spine_*.
    let m =
        FishModel::load(&shoal_core::source_root().join("../shared/gltf-samples/RiggedSimple.glb"))
            .unwrap();
    let e = suggest("x", "x.glb", &m).unwrap_err().to_string();
    assert!(e.contains("shoal asset rig"), "{e}");
}

fn shoal(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_shoal"))
        .args(args)
        .output()
        .unwrap()
}

#[test]
fn species_command_writes_a_loadable_species_and_refuses_to_overwrite() {
    use shoal_core::asset::rig::{RigOptions, rig_file};
    let (_dir, root) = common::scratch_repo();
    let rigged = rig_file(
        &shoal_core::source_root().join("../shared/gltf-samples/RedFinnedFish/scene.gltf"),
        &RigOptions::default(),
    )
    .unwrap();
    let glb = root.join("assets/red_finned_fish.glb");
    std::fs::write(&glb, &rigged.glb).unwrap();
    let root_s = root.to_str().unwrap();
    let glb_s = glb.to_str().unwrap();
    let args = [
        "asset", "species", "--model", glb_s, "--name", "red_fin", "--root", root_s,
    ];
    let out = shoal(&args);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("species = \"red_fin\""), "{stdout}");
    let file = root.join("scripts/species/red_fin.lua");
    let text = std::fs::read_to_string(&file).unwrap();
    assert!(text.contains("asset = \"red_finned_fish.glb\""), "{text}");
    assert!(text.contains("\"spine_1\", \"spine_2\""), "{text}");
    // The file's alphaCutoff of 1.0 would leave the filtered fins in ribbons: 0.5 is suggested.
    assert!(text.contains("alpha_cutoff = 0.5"), "{text}");
    // Typed as the shipped species files are, so `shoal check` and an editor know its fields.
    assert!(
        text.contains("---@type shoal.SpeciesFile\nlocal species = {"),
        "{text}"
    );
    assert!(text.trim_end().ends_with("return species"), "{text}");

    // A scene with the printed snippet loads the species and its fish swim.
    let snippet = stdout
        .lines()
        .skip_while(|l| !l.contains("species = "))
        .collect::<Vec<_>>()
        .join("\n");
    let scene = format!(
        "return {{ tank = {{ min = {{ -500, 0, -300 }}, max = {{ 500, 400, 300 }} }},\n\
         fish = {{\n{snippet}\n}} }}\n"
    );
    std::fs::write(root.join("scripts/scenes/red.lua"), scene).unwrap();
    let mut sim =
        shoal_script::Simulation::from_scene(&root, Path::new("scenes/red.lua"), 1).unwrap();
    assert_eq!(sim.world().num_fish(), 6);
    let id = sim.world().fish_ids().next().unwrap();
    let before = sim.world().root(id).unwrap().pos;
    sim.run(1.0);
    common::assert_no_script_errors(&sim);
    assert!(sim.load_errors().is_empty(), "{:?}", sim.load_errors());
    assert!(sim.world().root(id).unwrap().pos.distance(before) > 1.0);

    // Running again does not overwrite; --force does.
    std::fs::write(&file, "-- my edits\n").unwrap();
    let again = shoal(&args);
    let stderr = String::from_utf8_lossy(&again.stderr);
    assert!(!again.status.success());
    assert!(
        stderr.contains("already exists") && stderr.contains("--force"),
        "{stderr}"
    );
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "-- my edits\n");
    let mut forced = args.to_vec();
    forced.push("--force");
    assert!(shoal(&forced).status.success());
    assert!(
        std::fs::read_to_string(&file)
            .unwrap()
            .contains("vertebral_joints")
    );

    // A bad name is refused before anything is written.
    let bad = shoal(&[
        "asset", "species", "--model", glb_s, "--name", "../evil", "--root", root_s,
    ]);
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--name"));
}

/// `shoal asset rig` says which way the fish lies in words a designer reads, not Rust's
/// `Vec3(-1.0, -0.0, -0.0)`.
#[test]
fn rig_reports_the_long_axis_as_plain_numbers() {
    let dir = tempfile::tempdir().unwrap();
    let out_path = dir.path().join("red.glb");
    let input = shoal_core::source_root().join("../shared/gltf-samples/RedFinnedFish/scene.gltf");
    let out = shoal(&[
        "asset",
        "rig",
        "--in",
        input.to_str().unwrap(),
        "--out",
        out_path.to_str().unwrap(),
    ]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{stdout}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let line = stdout.lines().find(|l| l.contains("long axis")).unwrap();
    assert!(!line.contains("Vec3") && !line.contains("-0.00"), "{line}");
    assert!(line.contains("long axis ("), "{line}");
}
