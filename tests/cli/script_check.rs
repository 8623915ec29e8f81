//! `shoal check` as a designer runs it: the shipped scripts and behaviour tests are clean under
//! the pinned `emmylua_check`, a type error or a misspelt global in a script of one's own is
//! reported as `file:line:column`, and a machine without the checker is told how to install it.
//!
//! The tests that run the checker need `emmylua_check` on PATH (`.ci/run --setup` installs it);
//! without it they fail, saying so, rather than pass unchecked.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};

use crate::common;

fn root() -> PathBuf {
    shoal_core::source_root().to_path_buf()
}

fn shoal_check(cwd: &Path, args: &[&str], path_var: Option<&str>) -> Output {
    let mut cmd = Command::new(env!("CARGO_BIN_EXE_shoal"));
    cmd.current_dir(cwd)
        .env_remove("RUST_LOG")
        .env_remove("SHOAL_SCRIPTS")
        .arg("check")
        .args(args);
    if let Some(p) = path_var {
        cmd.env("PATH", p);
    }
    cmd.output().unwrap()
}

fn text(out: &Output) -> (String, String) {
    (
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Fails the calling test when the checker is not installed (it must not pass unchecked).
fn require_checker() {
    let found = std::env::var_os("PATH")
        .is_some_and(|p| std::env::split_paths(&p).any(|d| d.join("emmylua_check").is_file()));
    assert!(
        found,
        "emmylua_check is not on PATH: install it with `cargo install --locked \
         emmylua_check@{}` (or run .ci/run --setup)",
        shoal_script::check::CHECKER_VERSION
    );
}

#[test]
fn test_shipped_scripts_and_tests_have_no_diagnostics() {
    require_checker();
    let out = shoal_check(&root(), &[], None);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "stdout:\n{stdout}\nstderr:\n{stderr}");
    assert!(stdout.contains("check: no diagnostics"), "{stdout}");
    assert!(
        !stderr.contains("note:"),
        "the pinned version should be installed: {stderr}"
    );
}

/// A behaviour of one's own with two mistakes a checker catches and Lua does not until the line
/// runs: a string where the API declares a number, and a misspelt global.
const BAD: &str = r#"local M = {}

function M.tick(_fish)
  shoal.swim("fast")
  shaol.stop()
end

return M
"#;

#[test]
fn test_type_error_and_undefined_global_name_file_and_line() {
    require_checker();
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("typo.lua"), BAD).unwrap();
    std::fs::write(dir.path().join("fine.lua"), "local M = {}\nreturn M\n").unwrap();
    let out = shoal_check(&root(), &[dir.path().to_str().unwrap()], None);
    let (stdout, stderr) = text(&out);
    assert_eq!(
        out.status.code(),
        Some(1),
        "stdout:\n{stdout}\nstderr:\n{stderr}"
    );
    let typo = dir.path().canonicalize().unwrap().join("typo.lua");
    let lines: Vec<&str> = stdout.lines().filter(|l| l.contains("typo.lua")).collect();
    let at = |line: u32| {
        lines
            .iter()
            .find(|l| l.starts_with(&format!("{}:{line}:", typo.display())))
            .unwrap_or_else(|| panic!("nothing at typo.lua:{line} in:\n{stdout}"))
    };
    assert!(at(4).contains("number"), "{stdout}");
    assert!(at(5).contains("shaol"), "{stdout}");
    assert!(!stdout.contains("fine.lua"), "{stdout}");
    assert!(
        stdout.contains("check: 2 diagnostics in 1 file ("),
        "{stdout}"
    );

    // One file asked for: only its diagnostics, paths relative to the working directory.
    let out = shoal_check(dir.path(), &["typo.lua"], None);
    let (stdout, stderr) = text(&out);
    assert_eq!(out.status.code(), Some(1), "{stdout}\n{stderr}");
    assert!(
        stdout.lines().any(|l| l.starts_with("typo.lua:4:")),
        "{stdout}"
    );
}

/// A designer's own folder holding a copy of `scripts/` (no config of its own) is checked with
/// shoal's config as if it sat beside them: the copy alone, clean, and a mistake added to it is
/// still found with the API's types. shoal's config used to bring the source tree's `scripts/`
/// in too, so every class the copy declares was reported twice (13 warnings on a clean copy).
#[test]
fn test_a_copy_of_the_scripts_elsewhere_is_checked_on_its_own() {
    require_checker();
    let dir = tempfile::tempdir().unwrap();
    common::copy_dir(&root().join("scripts"), &dir.path().join("scripts"));
    assert!(!dir.path().join(".emmyrc.json").exists());
    let out = shoal_check(dir.path(), &[], None);
    let (stdout, stderr) = text(&out);
    assert!(out.status.success(), "stdout:\n{stdout}\nstderr:\n{stderr}");
    assert!(stdout.contains("check: no diagnostics"), "{stdout}");

    std::fs::write(dir.path().join("scripts/behaviors/typo.lua"), BAD).unwrap();
    let out = shoal_check(dir.path(), &[], None);
    let (stdout, stderr) = text(&out);
    assert_eq!(out.status.code(), Some(1), "{stdout}\n{stderr}");
    assert!(
        stdout
            .lines()
            .any(|l| l.starts_with("scripts/behaviors/typo.lua:4:") && l.contains("number")),
        "{stdout}"
    );
    assert!(
        stdout.contains("check: 2 diagnostics in 1 file ("),
        "only the two mistakes: {stdout}"
    );
}

#[test]
fn test_without_the_checker_says_how_to_install_it() {
    let empty = tempfile::tempdir().unwrap();
    let out = shoal_check(&root(), &[], Some(empty.path().to_str().unwrap()));
    let (stdout, stderr) = text(&out);
    assert_eq!(out.status.code(), Some(2), "{stdout}\n{stderr}");
    let install = format!(
        "cargo install --locked emmylua_check@{}",
        shoal_script::check::CHECKER_VERSION
    );
    assert!(
        stderr.contains("`emmylua_check` is not installed"),
        "{stderr}"
    );
    assert!(stderr.contains(&install), "{stderr}");
}

#[test]
fn test_a_missing_path_is_an_error_naming_it() {
    let out = shoal_check(&root(), &["scripts/behaviours"], None);
    let (stdout, stderr) = text(&out);
    assert_eq!(out.status.code(), Some(1), "{stdout}\n{stderr}");
    assert!(
        stderr.contains("scripts/behaviours: no such file or directory"),
        "{stderr}"
    );
}

#[test]
fn test_help_says_how_to_install_and_what_the_exit_codes_are() {
    let out = shoal_check(&root(), &["--help"], None);
    let (stdout, _) = text(&out);
    assert!(out.status.success());
    assert!(
        stdout.contains("cargo install --locked emmylua_check@"),
        "{stdout}"
    );
    assert!(
        stdout.contains("2 when emmylua_check is not installed"),
        "{stdout}"
    );
    assert!(stdout.contains("file:line:column"), "{stdout}");
}

#[test]
fn test_ci_installs_the_pinned_version_and_runs_the_check() {
    let ci = std::fs::read_to_string(root().join(".ci/run")).unwrap();
    let pin = format!(
        "EMMYLUA_CHECK_VERSION={}",
        shoal_script::check::CHECKER_VERSION
    );
    assert!(ci.contains(&pin), ".ci/run should pin {pin}");
    assert!(
        ci.contains("cargo run --quiet -- check"),
        ".ci/run should run shoal check"
    );
}
