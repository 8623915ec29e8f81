//! The split tank (issue 14, `shoal run --split`): two versions of the scripts run side by side
//! from the same scene and seed, time-locked, driven through the panel like a designer would
//! (`egui_kittest`, widgets by label) over the real default aquarium; and `--split`'s errors.

use crate::common;

use std::path::{Path, PathBuf};
use std::process::Command;

use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use glam::{Vec2, Vec3};
use shoal_app::{AppOptions, Aquarium, GHOST_COLOR, SplitVersions};
use shoal_core::world::{FishId, World};
use shoal_script::Simulation;

const DT: f32 = 1.0 / 60.0;
const SEED: u64 = 7;

fn load(root: &Path, scripts: &Path) -> Simulation {
    Simulation::from_scene_with_scripts(root, scripts, &scripts.join("scenes/default.lua"), SEED)
        .expect("the default scene loads")
}

/// A split tank of the default aquarium: A from `a`, B from `b` (assets from `root`).
fn split(root: &Path, a: &Path, b: &Path) -> Aquarium {
    let versions = SplitVersions {
        a: "A".into(),
        b: "B".into(),
        dirs: Some((a.to_path_buf(), b.to_path_buf())),
    };
    Aquarium::new_split(
        Box::new(load(root, a)),
        Box::new(load(root, b)),
        versions,
        AppOptions::default(),
    )
    .expect("the two versions make a split tank")
}

fn harness(aq: Aquarium) -> Harness<'static, Aquarium> {
    Harness::builder()
        .with_size(egui::vec2(520.0, 2200.0))
        .build_ui_state(|ui, aq: &mut Aquarium| aq.panel(ui), aq)
}

/// Every fish's position, to the bit.
fn positions(w: &World) -> Vec<(FishId, [u32; 3])> {
    w.fish_id_slice()
        .iter()
        .map(|&id| (id, w.root(id).unwrap().pos.to_array().map(f32::to_bits)))
        .collect()
}

fn b_world(aq: &Aquarium) -> &World {
    aq.split_scene().expect("a split tank").world()
}

/// Sets the timeline slider to `time_s` and lets the aquarium take it.
fn scrub(h: &mut Harness<'static, Aquarium>, time_s: f64) {
    h.get_by_role_and_label(egui::accesskit::Role::Slider, "time (s)")
        .set_value_accesskit(time_s);
    h.run();
    h.state_mut().advance(DT);
    h.run();
}

#[test]
fn the_same_scripts_run_in_lockstep_and_no_fish_differs() {
    let (_dir, root) = common::scratch_repo();
    let scripts = root.join("scripts");
    let mut h = harness(split(&root, &scripts, &scripts));
    h.run();
    // Uneven frames: B runs exactly the ticks A runs, whatever the frame time.
    for k in 0..200 {
        let dt = [DT, 2.5 * DT, 0.4 * DT][k % 3];
        h.state_mut().advance(dt);
        let aq = h.state();
        assert_eq!(aq.scene.world().tick_count(), b_world(aq).tick_count());
        assert_eq!(aq.scene.world().time(), b_world(aq).time(), "the clocks");
        assert_eq!(positions(aq.scene.world()), positions(b_world(aq)));
    }
    assert!(h.state().scene.world().tick_count() > 150);
    assert!(h.state().split_divergences().is_empty());
    assert!(h.state().split_changed_files().is_empty());
    h.run();
    assert!(h.query_by_label("no script file differs").is_some());
    assert!(
        h.query_by_label_contains("0 fish differ between A and B")
            .is_some()
    );

    // Pause, step and the slider act on both.
    h.get_by_label("pause").click();
    h.run();
    h.state_mut().advance(DT);
    let paused_at = h.state().scene.world().tick_count();
    h.state_mut().advance(DT);
    assert_eq!(h.state().scene.world().tick_count(), paused_at);
    assert_eq!(b_world(h.state()).tick_count(), paused_at);
    h.get_by_label("step").click();
    h.run();
    h.state_mut().advance(DT);
    assert_eq!(h.state().scene.world().tick_count(), paused_at + 1);
    assert_eq!(b_world(h.state()).tick_count(), paused_at + 1);
    scrub(&mut h, 1.5);
    assert_eq!(h.state().scene.world().tick_count(), 90);
    assert_eq!(b_world(h.state()).tick_count(), 90);
    assert_eq!(
        positions(h.state().scene.world()),
        positions(b_world(h.state()))
    );
    h.get_by_label("step back").click();
    h.run();
    h.state_mut().advance(DT);
    assert_eq!(b_world(h.state()).tick_count(), 89);
    assert!(h.state().split_divergences().is_empty());
}

#[test]
fn an_edited_behaviour_in_b_lists_the_fish_that_differ_while_a_matches_a_plain_run() {
    let (_dir, root) = common::scratch_repo();
    let (_dir_b, root_b) = common::scratch_repo();
    let (a, b) = (root.join("scripts"), root_b.join("scripts"));
    // B searches wider when it sees no food.
    let forage = b.join("behaviors/forage.lua");
    let src = std::fs::read_to_string(&forage).unwrap();
    let edited = src.replace("common.wander(fish, 1.2)", "common.wander(fish, 2.5)");
    assert_ne!(src, edited, "the edit applies");
    std::fs::write(&forage, edited).unwrap();

    let mut plain = load(&root, &a);
    let mut h = harness(split(&root, &a, &b));
    assert_eq!(h.state().split_changed_files(), ["behaviors/forage.lua"]);
    h.run();
    let seconds = 8;
    for _ in 0..seconds * 60 {
        h.state_mut().advance(DT);
        plain.step();
        let aq = h.state();
        assert_eq!(aq.scene.world().tick_count(), b_world(aq).tick_count());
        assert_eq!(
            positions(aq.scene.world()),
            positions(plain.world()),
            "A is the plain run of A, bit for bit, at tick {}",
            plain.world().tick_count()
        );
    }
    let now = h.state().scene.world().time();
    let diverged = h.state().split_divergences().to_vec();
    assert!(
        !diverged.is_empty(),
        "a wider search turn moves some forager within {seconds} s"
    );
    for d in &diverged {
        assert!(d.first_s > 0.0 && d.first_s <= now, "{d:?}");
        assert!(d.max_distance > 0.0, "{d:?}");
        let (pa, pb) = (
            h.state().scene.world().root(d.fish).unwrap().pos,
            b_world(h.state()).root(d.fish).unwrap().pos,
        );
        assert!(pa.distance(pb) <= d.max_distance + 1e-3, "{d:?}");
    }
    // Fish not listed are where they are in A, to the bit.
    let (pa, pb) = (
        positions(h.state().scene.world()),
        positions(b_world(h.state())),
    );
    for ((id, a), (_, b)) in pa.iter().zip(&pb) {
        if diverged.iter().all(|d| d.fish != *id) {
            assert_eq!(a, b, "fish #{} is not listed but differs", id.index);
        }
    }
    h.run();
    assert!(
        h.query_by_label("files that differ: behaviors/forage.lua")
            .is_some()
    );
    let header = format!("{} fish differ between A and B", diverged.len());
    assert!(h.query_by_label_contains(&header).is_some(), "{header}");

    // A row selects that fish in both views; the inspector shows both.
    let first = diverged[0];
    let row = format!(
        "fish #{} at {:.2} s, up to {:.1} apart",
        first.fish.index, first.first_s, first.max_distance
    );
    h.get_by_label(&row).click();
    h.run();
    h.state_mut().advance(0.0);
    assert_eq!(h.state().selected(), Some(first.fish));
    assert_eq!(
        h.state().split_scene().unwrap().selected(),
        Some(first.fish)
    );
    assert!(!h.state().split_inspect().is_empty(), "B's inspector");
    assert!(
        h.state()
            .split_overlay_lines()
            .iter()
            .any(|l| l.color == GHOST_COLOR),
        "B's view draws A's path beside the fish that left it"
    );

    // Back before the first divergence: both at that moment, nothing differs yet.
    let earliest = diverged.iter().map(|d| d.first_s).fold(f64::MAX, f64::min);
    let before = ((earliest - 0.5).max(0.0) * 60.0).floor() / 60.0;
    scrub(&mut h, before);
    let tick = (before * 60.0).round() as u64;
    assert_eq!(h.state().scene.world().tick_count(), tick);
    assert_eq!(b_world(h.state()).tick_count(), tick);
    assert!(
        h.state().split_divergences().is_empty(),
        "{:?} at {before} s",
        h.state().split_divergences()
    );
    // And forward again to the end: the same fish as when it was run.
    scrub(&mut h, now);
    let mut again = h.state().split_divergences().to_vec();
    let mut want = diverged.clone();
    again.sort_by_key(|d| d.fish.index);
    want.sort_by_key(|d| d.fish.index);
    assert_eq!(again, want);
}

/// A fish's projected centre in B's half (the right one) of a `size` split view.
fn in_b_half(aq: &Aquarium, id: FishId, size: Vec2) -> Vec2 {
    let half = Vec2::new(size.x * 0.5, size.y);
    let c: Vec3 = aq.split_scene().unwrap().fish_info(id).unwrap().center;
    let ndc = aq.camera().view_proj(half.x / half.y).project_point3(c);
    Vec2::new(
        half.x + (ndc.x + 1.0) * 0.5 * half.x,
        (1.0 - ndc.y) * 0.5 * half.y,
    )
}

#[test]
fn a_click_in_b_view_selects_that_fish_in_both() {
    let (_dir, root) = common::scratch_repo();
    let scripts = root.join("scripts");
    let mut aq = split(&root, &scripts, &scripts);
    aq.advance(DT);
    let size = Vec2::new(1200.0, 600.0);
    let mut picked = None;
    let ids = aq.split_scene().unwrap().world().fish_id_slice().to_vec();
    for id in ids {
        let at = in_b_half(&aq, id, size);
        aq.click(at, size, false);
        if aq.selected() == Some(id) {
            picked = Some(id);
            break;
        }
    }
    let id = picked.expect("some B fish is in front where it is drawn");
    assert_eq!(aq.split_scene().unwrap().selected(), Some(id));
    // Open water in B's half selects nothing.
    aq.click(Vec2::new(size.x * 0.5 + 2.0, 2.0), size, false);
    assert_eq!(aq.selected(), None);
}

fn shoal_run(args: &[&str]) -> (bool, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_shoal"))
        .arg("run")
        .args(args)
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .env_remove("SHOAL_SCRIPTS")
        .output()
        .unwrap();
    let text =
        String::from_utf8_lossy(&out.stdout).to_string() + &String::from_utf8_lossy(&out.stderr);
    (out.status.success(), text)
}

fn git(dir: &Path, args: &[&str]) {
    let ok = Command::new("git")
        .arg("-C")
        .arg(dir)
        .args([
            "-c",
            "user.name=t",
            "-c",
            "user.email=t@t",
            "-c",
            "commit.gpgsign=false",
        ])
        .args(args)
        .status()
        .unwrap()
        .success();
    assert!(ok, "git {args:?}");
}

#[test]
fn bad_split_input_is_a_clear_error() {
    let (_dir, root) = common::scratch_repo();
    let scripts = root.join("scripts");
    let s = scripts.to_str().unwrap();

    let (ok, text) = shoal_run(&["--scripts", s, "--split", "/no/such/scripts"]);
    assert!(!ok);
    assert!(
        text.contains("--split /no/such/scripts: no such directory"),
        "{text}"
    );

    // Not in a repository: git:REV cannot work.
    let (ok, text) = shoal_run(&["--scripts", s, "--split", "git:HEAD"]);
    assert!(!ok);
    assert!(
        text.contains("--split git:HEAD") && text.contains("inside a git repository"),
        "{text}"
    );

    // No git to run.
    let out = Command::new(env!("CARGO_BIN_EXE_shoal"))
        .args(["run", "--scripts", s, "--split", "git:HEAD"])
        .env("PATH", "")
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success());
    assert!(text.contains("--split git:HEAD: cannot run git"), "{text}");

    git(&root, &["init", "-q"]);
    git(&root, &["add", "scripts"]);
    git(&root, &["commit", "-q", "-m", "scripts"]);
    let (ok, text) = shoal_run(&["--scripts", s, "--split", "git:no-such-rev"]);
    assert!(!ok);
    assert!(
        text.contains("--split git:no-such-rev: no revision `no-such-rev`"),
        "{text}"
    );
    let (ok, text) = shoal_run(&["--scripts", s, "--split", "git:"]);
    assert!(!ok);
    assert!(text.contains("expected git:REV with a revision"), "{text}");

    // A scene B does not have.
    let (_dir_b, root_b) = common::scratch_repo();
    std::fs::remove_file(root_b.join("scripts/scenes/empty_tank.lua")).unwrap();
    let b = root_b.join("scripts");
    let (ok, text) = shoal_run(&[
        "--scripts",
        s,
        "--scene",
        "empty_tank",
        "--split",
        b.to_str().unwrap(),
    ]);
    assert!(!ok);
    assert!(text.contains("has no scenes/empty_tank.lua"), "{text}");

    // A good B gets as far as the window (none here), after saying what it compares.
    let (ok, text) = shoal_run(&["--scripts", s, "--split", "git:HEAD"]);
    assert!(!ok);
    assert!(text.contains("split tank: A = "), "{text}");
    assert!(text.contains("B = git:HEAD ("), "{text}");
    assert!(text.contains("cannot open a window"), "{text}");
}

#[test]
fn git_rev_materialises_that_revision_of_the_scripts() {
    let (_dir, root) = common::scratch_repo();
    let scripts = root.join("scripts");
    git(&root, &["init", "-q"]);
    git(&root, &["add", "scripts"]);
    git(&root, &["commit", "-q", "-m", "before"]);
    let forage = scripts.join("behaviors/forage.lua");
    let before = std::fs::read_to_string(&forage).unwrap();
    std::fs::write(&forage, before.replace("1.2)", "2.5)")).unwrap();
    git(&root, &["commit", "-q", "-am", "wider search"]);

    let b = shoal_script::versions::split_source("git:HEAD~1", &scripts).expect("HEAD~1 exists");
    assert!(b.label.starts_with("git:HEAD~1 ("), "{}", b.label);
    let got = std::fs::read_to_string(b.scripts.join("behaviors/forage.lua")).unwrap();
    assert_eq!(got, before, "the previous revision's forage.lua");
    assert!(b.scripts.join("scenes/default.lua").is_file());
    assert!(b.scripts.join("species/black_porgy.lua").is_file());
    let dir: PathBuf = b.scripts.clone();
    drop(b);
    assert!(!dir.exists(), "the temporary copy goes with it");
}

#[test]
fn saving_a_script_of_b_reloads_b_alone_and_lists_the_file_that_differs() {
    let (_dir, root) = common::scratch_repo();
    let (_dir_b, root_b) = common::scratch_repo();
    let (a, b) = (root.join("scripts"), root_b.join("scripts"));
    let mut aq = split(&root, &a, &b);
    aq.scene
        .enable_hot_reload()
        .expect("A's scripts are watched");
    aq.split_scene_mut()
        .unwrap()
        .enable_hot_reload()
        .expect("B's scripts are watched");
    aq.advance(DT);
    assert!(aq.split_changed_files().is_empty());
    std::thread::sleep(std::time::Duration::from_millis(100));

    let forage = b.join("behaviors/forage.lua");
    let src = std::fs::read_to_string(&forage).unwrap();
    std::fs::write(
        &forage,
        src.replace("common.wander(fish, 1.2)", "common.wander(fish, 2.5)"),
    )
    .unwrap();
    let start = std::time::Instant::now();
    while aq.split_changed_files().is_empty() && start.elapsed().as_secs() < 10 {
        aq.advance(DT);
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    assert_eq!(aq.split_changed_files(), ["behaviors/forage.lua"]);
    assert!(
        aq.console()
            .any(|l| l.starts_with("B: ") && l.contains("reloaded behaviour forage")),
        "B's reload is in the console: {:?}",
        aq.console().collect::<Vec<_>>()
    );
    assert!(
        !aq.console()
            .any(|l| !l.starts_with("B: ") && l.contains("reloaded")),
        "A did not reload: {:?}",
        aq.console().collect::<Vec<_>>()
    );
    for _ in 0..8 * 60 {
        aq.advance(DT);
    }
    assert!(
        !aq.split_divergences().is_empty(),
        "B's foragers now search wider than A's"
    );
}
