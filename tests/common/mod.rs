//! Helpers shared by the integration tests (script tests and asset tests).
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;
use std::sync::Arc;

use glam::{Mat4, Vec3};
use shoal::motion::{Body, MotionParams};
use shoal::script::Simulation;
use shoal::skeleton::{JointTransform, NO_PARENT, Skeleton};
use shoal::world::{FishModel, Species, SpeciesDesc, SpeciesRig};

/// The repository root (holds `scripts/`).
pub fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// A copy of the repository's `scripts/` in a temporary directory (for tests that edit files).
pub fn scratch_repo() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    copy_dir(&repo().join("scripts"), &dir.path().join("scripts"));
    let root = dir.path().to_path_buf();
    (dir, root)
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap() {
        let e = e.unwrap();
        let p = e.path();
        if p.is_dir() {
            copy_dir(&p, &to.join(e.file_name()));
        } else {
            std::fs::copy(&p, to.join(e.file_name())).unwrap();
        }
    }
}

/// A black-porgy-like species built in Rust: Table 1's motion parameters (l = 50), a chain
/// skeleton of 7 segments.
pub fn species(name: &str, predator: bool) -> Species {
    let motion = MotionParams::BLACK_PORGY;
    let body = Body::black_porgy();
    let n = body.joints_x.len() + 1;
    let mut parents = vec![NO_PARENT];
    parents.extend((0..n - 1).map(|i| i as u16));
    let names = (0..n).map(|i| format!("j{i}")).collect();
    let seg = motion.l / (n - 1) as f32;
    let locals: Vec<JointTransform> = (0..n)
        .map(|i| JointTransform {
            translation: if i == 0 {
                Vec3::ZERO
            } else {
                Vec3::new(-seg, 0.0, 0.0)
            },
            ..JointTransform::IDENTITY
        })
        .collect();
    let skeleton = Skeleton::new(parents, names, locals).unwrap();
    let ibms = skeleton.rest_models().iter().map(Mat4::inverse).collect();
    Species {
        desc: SpeciesDesc {
            name: name.to_owned(),
            asset: String::new(),
            motion: MotionParams {
                s: if predator { 70.0 } else { 50.0 },
                ..motion
            },
            view_range: if predator { 500.0 } else { 300.0 },
            view_angle_deg: 300.0,
            max_speed: if predator { 160.0 } else { 150.0 },
            predator,
        },
        rig: SpeciesRig {
            body,
            model_to_body: Mat4::IDENTITY,
        },
        model: Arc::new(FishModel {
            skeleton,
            inverse_bind_poses: ibms,
        }),
    }
}

/// An empty-tank simulation of the repository's scripts with the test species
/// `black_porgy` and `barracuda` added.
pub fn sim(seed: u64) -> Simulation {
    sim_in(repo(), seed)
}

/// Like [`sim`] for the scripts under `root`.
pub fn sim_in(root: &Path, seed: u64) -> Simulation {
    let mut s = Simulation::from_scene(root, Path::new("scenes/empty_tank.lua"), seed).unwrap();
    s.add_species(species("black_porgy", false), 10.0);
    s.add_species(species("barracuda", true), 10.0);
    s
}

/// Runs the Khronos validator (tools/validate-gltf.mjs) on `files`; panics with its report on
/// any error or warning, or if the validator is not installed.
pub fn validate(files: &[&Path]) {
    let tools = Path::new(env!("CARGO_MANIFEST_DIR")).join("tools");
    assert!(
        tools.join("node_modules/gltf-validator").is_dir(),
        "the glTF validator is not installed: run `npm ci` in tools/ (needs node and npm)"
    );
    let out = Command::new("node")
        .arg(tools.join("validate-gltf.mjs"))
        .args(files)
        .output()
        .expect("running node: install nodejs to run the glTF validator");
    let report = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "validator found errors or warnings:\n{report}\n{}",
        String::from_utf8_lossy(&out.stderr)
    );
    for f in files {
        assert!(
            report.contains(&format!("{}: 0 errors, 0 warnings", f.display())),
            "{report}"
        );
    }
}
