//! The layering the workspace promises: each crate's dependency tree, as Cargo resolves it,
//! holds none of the higher layers' libraries.

use std::process::Command;

/// The packages in `package`'s normal (not dev) dependency tree, by name.
fn dependency_names(package: &str) -> Vec<String> {
    let out = Command::new(env!("CARGO"))
        .current_dir(shoal_core::source_root())
        .args([
            "tree",
            "--offline",
            "--package",
            package,
            "--edges",
            "normal",
            "--prefix",
            "none",
            "--format",
            "{p}",
        ])
        .output()
        .expect("cargo runs");
    assert!(
        out.status.success(),
        "cargo tree -p {package} failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout)
        .lines()
        .filter_map(|l| l.split_whitespace().next())
        .map(str::to_owned)
        .collect()
}

fn assert_none_of(package: &str, forbidden: &[&str]) {
    let names = dependency_names(package);
    assert!(
        names.iter().any(|n| n == package),
        "the tree names {package} itself: {names:?}"
    );
    let found: Vec<&String> = names
        .iter()
        .filter(|n| forbidden.contains(&n.as_str()))
        .collect();
    assert!(found.is_empty(), "{package} depends on {found:?}");
}

#[test]
fn core_has_no_gpu_window_or_lua() {
    assert_none_of(
        "shoal-core",
        &[
            "wgpu",
            "winit",
            "egui",
            "mlua",
            "shoal-script",
            "shoal-render",
            "shoal-app",
        ],
    );
}

#[test]
fn the_script_and_render_crates_stay_below_the_window() {
    assert_none_of(
        "shoal-script",
        &["wgpu", "winit", "egui", "shoal-render", "shoal-app"],
    );
    assert_none_of(
        "shoal-render",
        &["winit", "egui", "mlua", "shoal-script", "shoal-app"],
    );
}
