//! Helpers shared by the integration tests of every crate (the others include this file):
//! the source tree, the shipped porgy, skinning on the CPU, the glTF validator.
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;

use glam::{Mat4, Vec3};
use shoal_core::motion::MotionParams;
use shoal_core::skeleton::JointTransform;
use shoal_core::skin::FishModel;
use shoal_core::world::{Species, SpeciesDesc};

/// The repository root (holds `scripts/`).
pub fn repo() -> &'static Path {
    shoal_core::source_root()
}

/// A copy of the repository's `scripts/` and `assets/` in a temporary directory (for tests that edit files).
pub fn scratch_repo() -> (tempfile::TempDir, PathBuf) {
    let dir = tempfile::tempdir().unwrap();
    copy_dir(&repo().join("scripts"), &dir.path().join("scripts"));
    copy_dir(&repo().join("assets"), &dir.path().join("assets"));
    let root = dir.path().to_path_buf();
    (dir, root)
}

/// Copies `from` into `to`, recursively.
pub fn copy_dir(from: &Path, to: &Path) {
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

/// The black porgy (`SpeciesDesc::black_porgy()` on `assets/black_porgy.glb`) under another
/// name; a predator swims faster and sees further.
pub fn species(name: &str, predator: bool) -> Species {
    let base = SpeciesDesc::black_porgy();
    let desc = SpeciesDesc {
        name: name.to_owned(),
        motion: MotionParams {
            s: if predator { 70.0 } else { 50.0 },
            ..base.motion
        },
        view_range: if predator { 500.0 } else { 300.0 },
        max_speed: if predator { 160.0 } else { 150.0 },
        predator,
        ..base
    };
    Species::load(desc, &repo().join("assets")).unwrap()
}

/// Runs the Khronos validator (tools/validate-gltf.mjs) on `files`; panics with its report on
/// any error or warning, or if the validator is not installed.
pub fn validate(files: &[&Path]) {
    let tools = shoal_core::source_root().join("tools");
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

/// Skins `model`'s bind-shape positions with the local joint transforms `locals` (forward
/// kinematics, palette, eq. (1)) and returns the skinned positions.
pub fn skin(model: &FishModel, locals: &[JointTransform]) -> Vec<Vec3> {
    let n = model.skeleton.num_joints();
    let mut models = vec![Mat4::IDENTITY; n];
    model
        .skeleton
        .local_to_model(Mat4::IDENTITY, locals, &mut models)
        .run()
        .unwrap();
    let mut pal = vec![Mat4::IDENTITY; n];
    shoal_core::skin::palette(&models, &model.inverse_bind_poses, &mut pal).unwrap();
    let mut out = vec![Vec3::ZERO; model.mesh.num_vertices()];
    shoal_core::skin::LinearBlendSkinningJob {
        palette: &pal,
        positions_in: &model.mesh.positions,
        normals_in: &[],
        joints: &model.mesh.joints,
        weights: &model.mesh.weights,
        positions_out: &mut out,
        normals_out: &mut [],
    }
    .run()
    .unwrap();
    out
}

/// The generated black porgy (`assets/black_porgy.glb`) and its species rig, as loaded for the
/// renderer's tests: the model as the file has it, bound by `SpeciesRig::bind`.
pub struct PosedPorgy {
    /// The model.
    pub model: FishModel,
    /// Its binding (driven joints, bend axes, model → body frame).
    pub rig: shoal_core::species::SpeciesRig,
}

impl PosedPorgy {
    /// Loads and binds the porgy.
    pub fn load() -> Self {
        let model = FishModel::load(&repo().join("assets/black_porgy.glb"))
            .expect("the generated porgy asset loads");
        let rig = shoal_core::species::SpeciesRig::bind(&SpeciesDesc::black_porgy(), &model)
            .expect("the porgy binds");
        Self { model, rig }
    }

    /// Palette entries per fish.
    pub fn num_joints(&self) -> usize {
        self.model.skeleton.num_joints()
    }

    /// The palette of a fish placed at `root` (world, body frame: root at the head end of the
    /// column, +x forward) with the motion layer's driven-joint `yaw`, into `out`.
    pub fn palette(&self, root: Mat4, yaw: &[f32], out: &mut [Mat4]) {
        let n = self.num_joints();
        let mut locals = vec![JointTransform::IDENTITY; n];
        self.rig.pose(yaw, &mut locals);
        let mut models = vec![Mat4::IDENTITY; n];
        self.model
            .skeleton
            .local_to_model(root * self.rig.model_to_body, &locals, &mut models)
            .run()
            .expect("the skeleton poses");
        for ((o, m), ibm) in out
            .iter_mut()
            .zip(&models)
            .zip(&self.model.inverse_bind_poses)
        {
            *o = *m * *ibm;
        }
    }
}

/// Ten black porgies (a bench world, seed 5) and ten eels spawned across the tank, swimming.
pub fn porgy_and_eel_world() -> shoal_core::world::World {
    use shoal_core::world::SpawnParams;
    use shoal_core::world::bench::bench_world;
    let assets = repo().join("assets");
    let shipped = |desc| Species::load(desc, &assets).expect("shipped species load");
    let mut world = bench_world(shipped(SpeciesDesc::black_porgy()), 10, 5).unwrap();
    let eel = world.add_species(shipped(SpeciesDesc::eel()));
    let (min, size) = (world.tank().min, world.tank().max - world.tank().min);
    for i in 0..10 {
        let f = 0.2 + 0.06 * i as f32;
        world
            .spawn(SpawnParams {
                species: eel,
                pos: min + size * Vec3::new(f, 0.3 + 0.03 * i as f32, 1.0 - f),
                heading: i as f32,
                pitch: 0.0,
                speed: 40.0,
                behavior: None,
                seed: 100 + i,
            })
            .unwrap();
    }
    world
}
