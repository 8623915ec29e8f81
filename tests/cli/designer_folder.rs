//! A designer's own folder: a copy of `scripts/` beside an `assets/` holding only their own
//! model (what `shoal asset rig … --out assets/red.glb` leaves). Every shipped species still
//! swims, each missing model coming from the source tree with a line saying so, and `shoal
//! bench sim` finds scripts and models as `shoal run` does (issue 36, findings 1 and 5).

use crate::common;

use std::path::Path;
use std::process::{Command, Output};

/// A folder with a copy of the scripts and an `assets/` holding one model of the designer's.
fn designer_folder() -> tempfile::TempDir {
    let dir = tempfile::tempdir().unwrap();
    common::copy_dir(&common::repo().join("scripts"), &dir.path().join("scripts"));
    std::fs::create_dir_all(dir.path().join("assets")).unwrap();
    std::fs::copy(
        common::repo().join("assets/eel.glb"),
        dir.path().join("assets/red.glb"),
    )
    .unwrap();
    dir
}

fn shoal_in(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_shoal"))
        .current_dir(dir)
        .env_remove("SHOAL_SCRIPTS")
        .env_remove("RUST_LOG")
        .args(args)
        .output()
        .unwrap()
}

fn text(out: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

#[test]
fn the_shipped_species_swim_from_a_designer_folder_with_its_own_assets() {
    let dir = designer_folder();
    let out = shoal_in(
        dir.path(),
        &["bench", "sim", "--scene", "default", "--seconds", "0.1"],
    );
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    let scripts = dir.path().join("scripts");
    assert!(
        stdout.starts_with(&format!(
            "scripts: {} (the working directory's scripts/)",
            scripts.display()
        )),
        "{stdout}"
    );
    let source_assets = common::repo().join("assets");
    let models = stdout
        .lines()
        .find(|l| l.starts_with("models: "))
        .unwrap_or_else(|| panic!("no models line:\n{stdout}"));
    assert!(models.contains("black_porgy.glb"), "{models}");
    assert!(
        models.contains(&format!("from {}", source_assets.display())),
        "{models}"
    );
    assert!(
        models.contains(&format!("(not in {})", dir.path().join("assets").display())),
        "{models}"
    );
}

#[test]
fn a_model_of_the_folder_s_own_is_used_and_not_announced() {
    let dir = designer_folder();
    std::fs::copy(
        common::repo().join("assets/black_porgy.glb"),
        dir.path().join("assets/black_porgy.glb"),
    )
    .unwrap();
    let out = shoal_in(
        dir.path(),
        &["bench", "sim", "--scene", "default", "--seconds", "0.1"],
    );
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "{stdout}\n{stderr}");
    let models = stdout.lines().find(|l| l.starts_with("models: ")).unwrap();
    assert!(!models.contains("black_porgy.glb"), "{models}");
}

#[test]
fn bench_sim_layouts_find_the_scripts_and_models_as_run_does() {
    let dir = designer_folder();
    for driver in ["lua", "rust"] {
        let out = shoal_in(
            dir.path(),
            &[
                "bench",
                "sim",
                "--driver",
                driver,
                "--fish",
                "20",
                "--seconds",
                "0.1",
            ],
        );
        let (stdout, stderr) = text(&out);
        assert!(
            out.status.success(),
            "--driver {driver}: {stdout}\n{stderr}"
        );
        assert!(
            stdout.contains(&format!(
                "scripts: {}",
                dir.path().join("scripts").display()
            )),
            "--driver {driver}: {stdout}"
        );
    }
}
