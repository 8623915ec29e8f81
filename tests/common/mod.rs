//! Helpers shared by the integration tests (script tests and asset tests).
#![allow(dead_code)]

use std::path::{Path, PathBuf};
use std::process::Command;

use glam::{Mat4, Vec3};
use shoal::motion::MotionParams;
use shoal::script::Simulation;
use shoal::skeleton::JointTransform;
use shoal::skin::FishModel;
use shoal::world::{Species, SpeciesDesc};

/// The repository root (holds `scripts/`).
pub fn repo() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
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
    shoal::skin::palette(&models, &model.inverse_bind_poses, &mut pal).unwrap();
    let mut out = vec![Vec3::ZERO; model.mesh.num_vertices()];
    shoal::skin::LinearBlendSkinningJob {
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

/// Fails the test with every script error the simulation logged, if it logged any.
#[track_caller]
pub fn assert_no_script_errors(sim: &Simulation) {
    let errors = sim.error_messages();
    assert!(errors.is_empty(), "script errors: {errors:?}");
}

/// The generated black porgy (`assets/black_porgy.glb`) and its species rig, as loaded for the
/// renderer's tests: the model as the file has it, bound by `SpeciesRig::bind`.
pub struct PosedPorgy {
    /// The model.
    pub model: FishModel,
    /// Its binding (driven joints, bend axes, model → body frame).
    pub rig: shoal::species::SpeciesRig,
}

impl PosedPorgy {
    /// Loads and binds the porgy.
    pub fn load() -> Self {
        let model = FishModel::load(&repo().join("assets/black_porgy.glb"))
            .expect("the generated porgy asset loads");
        let rig = shoal::species::SpeciesRig::bind(&SpeciesDesc::black_porgy(), &model)
            .expect("the porgy binds");
        Self { model, rig }
    }

    /// The mesh to upload, labelled with the species name.
    pub fn upload(&self) -> shoal::render::MeshUpload<'_> {
        shoal::render::MeshUpload::from_skinned_mesh("black_porgy", &self.model.mesh)
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

/// A behaviour (`behaviors/split.lua`) whose `tick` calls `heavy` (defined at line 1) and `light`
/// (line 6), heavy doing ten times light's work per decision (`n` and 10·`n` sines), in the
/// same loop: the profiler tests' known cost split.
pub fn split_behavior(n: u32) -> String {
    format!(
        "\
local function heavy(n)
  local x = 0
  for i = 1, n * 10 do x = x + math.sin(i) end
  return x
end
local function light(n)
  local x = 0
  for i = 1, n do x = x + math.sin(i) end
  return x
end
return {{ tick = function(fish)
  fish.memory.x = heavy({n}) + light({n})
end }}
"
    )
}

/// Ten black porgies (a bench world, seed 5) and ten eels spawned across the tank, swimming.
pub fn porgy_and_eel_world() -> shoal::world::World {
    use shoal::world::SpawnParams;
    use shoal::world::bench::bench_world;
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
