//! The aquarium's panel driven like a user would: widgets found by their label and clicked
//! through egui's own input (`egui_kittest`), over a real simulation (the Lua host, real
//! species). Each test checks the simulation, not just the widget: clicking "quick turn left"
//! must start a quick turn on the selected fish, and a click on the panel must not change the
//! selection (the picker used to take every click that reached the window).

use std::path::{Path, PathBuf};

use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use glam::Vec2;
use shoal_app::{AppOptions, Aquarium, Showable};
use shoal_core::world::FishId;
use shoal_script::Simulation;

const VIEW: Vec2 = Vec2::new(960.0, 600.0);

pub(crate) fn repo() -> PathBuf {
    shoal_core::source_root().to_path_buf()
}

/// A copy of `scripts/` in a temporary directory, plus `extra` files (path under scripts/,
/// source).
pub(crate) fn scripts_with(extra: &[(&str, &str)]) -> tempfile::TempDir {
    let dir = tempfile::tempdir().expect("temp dir");
    copy_dir(&repo().join("scripts"), dir.path());
    for (path, source) in extra {
        let p = dir.path().join(path);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, source).unwrap();
    }
    dir
}

fn copy_dir(from: &Path, to: &Path) {
    std::fs::create_dir_all(to).unwrap();
    for e in std::fs::read_dir(from).unwrap().flatten() {
        let target = to.join(e.file_name());
        if e.path().is_dir() {
            copy_dir(&e.path(), &target);
        } else {
            std::fs::copy(e.path(), target).unwrap();
        }
    }
}

/// Three black porgies with no behaviour (so only the panel moves them) and one running
/// `behavior` if given.
fn aquarium(scripts: &Path, behavior: Option<&str>, select: Option<usize>) -> Aquarium {
    let extra = behavior.map_or(String::new(), |b| {
        format!(r#"{{ species = "black_porgy", behavior = "{b}", pos = {{0, 150, 100}} }},"#)
    });
    let scene = format!(
        r#"return {{
  tank = {{ min = {{-400, 0, -250}}, max = {{400, 300, 250}} }},
  fish = {{
    {{ species = "black_porgy", pos = {{-120, 150, 0}}, heading = 0, speed = 30 }},
    {{ species = "black_porgy", pos = {{0, 150, 0}}, heading = 0, speed = 30 }},
    {{ species = "black_porgy", pos = {{120, 150, 0}}, heading = 0, speed = 30 }},
    {extra}
  }},
}}"#
    );
    std::fs::write(scripts.join("scenes/panel_test.lua"), scene).unwrap();
    let sim = Simulation::from_scene_with_scripts(
        &repo(),
        scripts,
        Path::new("scenes/panel_test.lua"),
        3,
    )
    .expect("the test scene loads");
    let options = AppOptions {
        select: select.map(|i| sim.world().fish_id_slice()[i]),
        ..AppOptions::default()
    };
    let mut aq = Aquarium::new(Box::new(sim), options);
    aq.advance(1.0 / 60.0);
    aq
}

pub(crate) fn harness(aq: Aquarium) -> Harness<'static, Aquarium> {
    Harness::builder()
        .with_size(egui::vec2(520.0, 1600.0))
        .build_ui_state(|ui, aq: &mut Aquarium| aq.panel(ui), aq)
}

/// Fish `i` of the scene (0-based, in spawn order).
fn fish(aq: &Aquarium, i: usize) -> FishId {
    aq.scene.world().fish_id_slice()[i]
}

/// The inspector's value for `key` of fish `i`.
fn inspect(aq: &Aquarium, i: usize, key: &str) -> String {
    aq.scene
        .inspect(fish(aq, i))
        .into_iter()
        .find(|(k, _)| k == key)
        .map(|(_, v)| v)
        .unwrap_or_default()
}

/// The pixel at the centre of fish `i` in a `VIEW`-sized window.
fn pixel_of(aq: &Aquarium, i: usize) -> Vec2 {
    let camera = aq.camera();
    let c = aq.scene.fish_info(fish(aq, i)).unwrap().center;
    let ndc = camera.view_proj(VIEW.x / VIEW.y).project_point3(c);
    Vec2::new((ndc.x + 1.0) * 0.5 * VIEW.x, (1.0 - ndc.y) * 0.5 * VIEW.y)
}

#[test]
fn clicking_a_fish_selects_it_and_a_click_on_the_panel_does_not_change_the_selection() {
    let scripts = scripts_with(&[]);
    let mut aq = aquarium(scripts.path(), None, None);
    assert_eq!(aq.selected(), None);
    // Fish 2 is nearest the default camera's side; its centre picks a fish on that ray.
    let at = pixel_of(&aq, 1);
    aq.click(at, VIEW, false);
    let picked = aq.selected().expect("a click on a fish selects it");
    // The same spot, but where the panel covers the view: the panel takes the click.
    aq.click(pixel_of(&aq, 0), VIEW, true);
    assert_eq!(
        aq.selected(),
        Some(picked),
        "a panel click must not reach the picker"
    );
    // Open water (the top-left corner looks up into the empty tank) deselects.
    aq.click(Vec2::new(2.0, 2.0), VIEW, false);
    assert_eq!(aq.selected(), None);
}

#[test]
fn every_motion_button_starts_that_motion_on_the_selected_fish() {
    let scripts = scripts_with(&[]);
    let aq = aquarium(scripts.path(), None, Some(1));
    let mut h = harness(aq);
    h.run();
    let buttons = [
        ("accelerate", "accelerate"),
        ("stop", "stop"),
        ("swim", "swim"),
        ("normal turn left", "normal_turn"),
        ("normal turn right", "normal_turn"),
        ("quick turn left", "quick_turn"),
        ("quick turn right", "quick_turn"),
        ("serial turn left", "serial_turn"),
        ("serial turn right", "serial_turn"),
        ("ascend", "ascend"),
        ("descend", "descend"),
    ];
    for (label, motion) in buttons {
        // Start from a plain swim so every button's effect is a change.
        if label != "swim" {
            h.get_by_label("swim").click();
            h.run();
            h.state_mut().advance(1.0 / 60.0);
        }
        h.get_by_label(label).click();
        h.run();
        // A request starts on the motion layer's next tick, as in the window's next frame.
        h.state_mut().advance(1.0 / 60.0);
        let aq = h.state_mut();
        assert_eq!(
            aq.selected(),
            Some(fish(aq, 1)),
            "{label}: the click kept the selection"
        );
        let now = inspect(aq, 1, "motion");
        assert!(
            now.starts_with(motion),
            "after clicking {label:?} fish 1 should run {motion}, runs {now:?}"
        );
        assert!(
            aq.console()
                .any(|l| l == format!("fish #1: {label} requested")),
            "the console says what was requested"
        );
        // Only the selected fish moved.
        assert!(inspect(aq, 0, "motion").starts_with("swim"));
    }
}

#[test]
fn follow_pause_step_and_overlays_work_from_the_panel() {
    let scripts = scripts_with(&[]);
    let aq = aquarium(scripts.path(), None, Some(0));
    let mut h = harness(aq);
    h.run();
    assert!(h.state().following(), "--select follows the fish");
    h.get_by_label("follow").click();
    h.run();
    assert!(!h.state().following());
    h.get_by_label("follow").click();
    h.run();
    assert!(h.state().following());

    h.get_by_label("pause").click();
    h.run();
    assert!(h.state().paused());
    let t0 = h.state().scene.time_s();
    h.state_mut().advance(0.5);
    assert_eq!(h.state().scene.time_s(), t0, "paused: no time passes");
    h.get_by_label("step").click();
    h.run();
    h.state_mut().advance(0.5);
    let dt = h.state().scene.time_s() - t0;
    assert!(
        (dt - 1.0 / 60.0).abs() < 1e-4,
        "step is one tick, got {dt} s"
    );
    h.get_by_label("play").click();
    h.run();
    assert!(!h.state().paused());
    let t1 = h.state().scene.time_s();
    h.state_mut().advance(0.05);
    assert!(h.state().scene.time_s() > t1, "playing again");

    assert!(h.state().overlay_lines().is_empty());
    h.get_by_label("skeleton and joints").click();
    h.run();
    assert!(h.state().overlays().skeleton);
    h.state_mut().advance(1.0 / 60.0);
    assert!(
        !h.state().overlay_lines().is_empty(),
        "the skeleton overlay draws segments"
    );
    h.get_by_label("skeleton and joints").click();
    h.run();
    h.state_mut().advance(1.0 / 60.0);
    assert!(h.state().overlay_lines().is_empty());
}

#[test]
fn a_slider_changes_the_live_species() {
    let scripts = scripts_with(&[]);
    let aq = aquarium(scripts.path(), None, Some(0));
    let mut h = harness(aq);
    h.run();
    let before = h.state().scene.motion_params(0).unwrap();
    // The slider and its number box share the label; set the slider itself.
    h.get_by_role_and_label(egui::accesskit::Role::Slider, "s (speed, units/s)")
        .set_value_accesskit(f64::from(before.s) + 17.0);
    h.run();
    let after = h.state().scene.motion_params(0).unwrap();
    assert!(
        (after.s - (before.s + 17.0)).abs() < 0.5,
        "speed slider: {} → {}",
        before.s,
        after.s
    );
    assert_eq!(after.p, before.p, "only the speed changed");
}

#[test]
fn the_console_shows_a_script_error_with_file_and_line() {
    let scripts = scripts_with(&[(
        "behaviors/broken.lua",
        "return { tick = function(fish)\n  error('boom at the reef')\nend }\n",
    )]);
    let aq = aquarium(scripts.path(), Some("broken"), None);
    let mut h = harness(aq);
    h.state_mut().advance(0.5);
    h.run();
    assert!(
        h.query_by_label_contains("boom at the reef").is_some(),
        "the console panel shows the error"
    );
    let line = h
        .state()
        .console()
        .find(|l| l.contains("boom at the reef"))
        .expect("a console line")
        .to_owned();
    assert!(
        line.contains("broken.lua:2:") && line.contains("fish #3") && line.contains("error"),
        "the line names the error, file:line and the fish: {line}"
    );
}

/// A despawned selected fish clears the selection (and the follow camera, the inspector); the
/// selection never moves to the fish that takes its place in the world's order.
#[test]
fn despawning_the_selected_fish_clears_the_selection() {
    let scripts = scripts_with(&[]);
    let mut aq = aquarium(scripts.path(), None, Some(0));
    let gone = fish(&aq, 0);
    assert_eq!(aq.selected(), Some(gone));
    assert!(aq.following());
    assert!(aq.scene.sim_mut().world_mut().despawn(gone));
    // The last fish now sits where fish 0 was in the world's dense order.
    assert_eq!(aq.scene.world().num_fish(), 2);
    aq.advance(1.0 / 60.0);
    assert_eq!(
        aq.selected(),
        None,
        "the selection must not move to another fish"
    );
    assert!(!aq.following());
    assert!(
        aq.console()
            .any(|l| l.contains(&format!("fish #{} is gone", gone.index))),
        "the console says why the selection went"
    );
    let mut h = harness(aq);
    h.run();
    assert!(
        h.query_by_label("click a fish to select it").is_some(),
        "the panel shows no fish"
    );
}

#[test]
fn food_drops_from_the_panel_ahead_of_the_fish_and_by_shift_click_where_clicked() {
    let scripts = scripts_with(&[]);
    let aq = aquarium(scripts.path(), None, Some(1));
    let mut h = harness(aq);
    h.run();
    assert_eq!(h.state().scene.world().foods().count(), 0);
    let root = *h.state().scene.world().root(fish(h.state(), 1)).unwrap();
    h.get_by_label("drop food").click();
    h.run();
    let w = h.state().scene.world();
    let pellets: Vec<_> = w.foods().map(|(_, f)| f.pos).collect();
    assert_eq!(pellets.len(), 1, "one pellet dropped");
    // Two body lengths (2 × 50) ahead of the selected fish, just under the surface (y 300).
    let ahead = root.pos + glam::Vec3::new(root.heading.cos(), 0.0, -root.heading.sin()) * 100.0;
    assert!(
        (pellets[0].x - ahead.x).abs() < 1e-3 && (pellets[0].z - ahead.z).abs() < 1e-3,
        "above the point ahead of the fish: {} vs {ahead}",
        pellets[0]
    );
    assert!(
        (pellets[0].y - 291.0).abs() < 1e-3,
        "under the surface: {}",
        pellets[0]
    );
    assert!(
        h.state()
            .console()
            .any(|l| l.starts_with("food #0 dropped at") && l.contains("does not sink")),
        "the console says where, and that this scene's food floats: {:?}",
        h.state().console().collect::<Vec<_>>()
    );

    // Shift+click on the floor: the pellet starts above the clicked spot; no fish is picked.
    let mut aq = h.into_state();
    let selected = aq.selected();
    let floor = glam::Vec3::new(150.0, 0.0, 60.0);
    let ndc = aq.camera().view_proj(VIEW.x / VIEW.y).project_point3(floor);
    let at = Vec2::new((ndc.x + 1.0) * 0.5 * VIEW.x, (1.0 - ndc.y) * 0.5 * VIEW.y);
    aq.set_shift(true);
    aq.click(at, VIEW, false);
    assert_eq!(aq.selected(), selected, "a shift+click does not select");
    let last = aq.scene.world().foods().last().map(|(_, f)| f.pos).unwrap();
    assert_eq!(aq.scene.world().foods().count(), 2);
    assert!(
        (last.x - floor.x).abs() < 0.5 && (last.z - floor.z).abs() < 0.5,
        "above the clicked floor point: {last}"
    );
    // A plain click still selects (the top-left corner is open water: deselects).
    aq.set_shift(false);
    aq.click(Vec2::new(2.0, 2.0), VIEW, false);
    assert_eq!(aq.selected(), None);
    assert_eq!(aq.scene.world().foods().count(), 2);
}

/// One frame of the window's side panel, as `shoal run` draws it (egui's root `Ui` of a
/// 1000×700-point window; egui_kittest's harness lays its `Ui` out inside a frame of its own),
/// after `events`. Returns the panel's rectangle.
fn window_frame(ctx: &egui::Context, aq: &mut Aquarium, events: Vec<egui::Event>) -> egui::Rect {
    let input = egui::RawInput {
        screen_rect: Some(egui::Rect::from_min_size(
            egui::Pos2::ZERO,
            egui::vec2(1000.0, 700.0),
        )),
        events,
        ..Default::default()
    };
    let mut panel = egui::Rect::NOTHING;
    let mut output = ctx.run_ui(input, |ui| panel = aq.side_panel(ui));
    output.textures_delta.clear(); // no renderer to hand the font atlas to
    panel
}

/// A designer on a small screen drags the panel's left edge to the right to give the view more
/// room. The scripts profile table and the watch, pause-when and logpoint fields held the
/// panel at ~450 points whatever the drag; the table now scrolls sideways and the fields
/// shrink, so the panel follows the drag.
#[test]
fn the_panel_can_be_dragged_narrower() {
    let scripts = scripts_with(&[]);
    let mut aq = aquarium(scripts.path(), Some("school"), None);
    for _ in 0..30 {
        aq.advance(1.0 / 60.0);
    }
    let ctx = egui::Context::default();
    let mut before = window_frame(&ctx, &mut aq, vec![]);
    for _ in 0..3 {
        before = window_frame(&ctx, &mut aq, vec![]);
    }
    assert!(
        before.width() >= 440.0 && (before.right() - 1000.0).abs() <= 1.0,
        "the panel opens on the right, wide enough for the scripts table: {before:?}"
    );
    let y = 300.0;
    let at = |dx: f32| egui::pos2(before.left() + dx, y);
    let moved = |dx: f32| egui::Event::PointerMoved(at(dx));
    let button = |dx: f32, pressed: bool| egui::Event::PointerButton {
        pos: at(dx),
        button: egui::PointerButton::Primary,
        pressed,
        modifiers: egui::Modifiers::NONE,
    };
    window_frame(&ctx, &mut aq, vec![moved(1.0)]);
    window_frame(&ctx, &mut aq, vec![button(1.0, true)]);
    for dx in [20.0, 60.0, 100.0] {
        window_frame(&ctx, &mut aq, vec![moved(dx)]);
    }
    window_frame(&ctx, &mut aq, vec![button(100.0, false)]);
    let after = window_frame(&ctx, &mut aq, vec![]);
    assert!(
        after.width() <= before.width() - 95.0,
        "dragged 100 points to the right, the panel went from {} to {} points wide",
        before.width(),
        after.width()
    );
    assert!(
        (after.right() - 1000.0).abs() <= 1.0,
        "the panel stays on the right: {after:?}"
    );
}

/// A script error on the selected fish shows in the inspector without widening the panel: the
/// message wraps at the panel's edge (it used to stretch the panel by its whole length the
/// moment the error appeared, pushing the view aside).
#[test]
fn a_long_script_error_in_the_inspector_wraps_inside_the_panel() {
    let broken = r#"local M = {}
function M.tick(fish)
  error("this behaviour fails on purpose with a message long enough to be wider than any panel a designer would keep open")
end
return M
"#;
    let scripts = scripts_with(&[("behaviors/broken.lua", broken)]);
    let mut aq = aquarium(scripts.path(), Some("broken"), Some(3));
    for _ in 0..30 {
        aq.advance(1.0 / 60.0);
    }
    let ctx = egui::Context::default();
    let mut panel = egui::Rect::NOTHING;
    for _ in 0..4 {
        panel = window_frame(&ctx, &mut aq, vec![]);
    }
    assert!(
        aq.scene
            .inspect(fish(&aq, 3))
            .iter()
            .any(|(k, v)| k == "error" && v.contains("fails on purpose")),
        "the inspector has the error line"
    );
    assert!(
        panel.width() <= 451.0,
        "the panel stays at its 450 points: {panel:?}"
    );
}

/// In the split tank the inspector has three columns (key, A, B); a long script error in B's
/// column wraps inside the panel instead of stretching it by the message's length.
#[test]
fn a_long_error_in_the_split_tanks_inspector_wraps_inside_the_panel() {
    let broken = r#"local M = {}
function M.tick(fish)
  error("this behaviour fails on purpose with a message long enough to be wider than any panel a designer would keep open")
end
return M
"#;
    let a_dir = scripts_with(&[(
        "behaviors/broken.lua",
        "return { tick = function(fish) end }\n",
    )]);
    let b_dir = scripts_with(&[("behaviors/broken.lua", broken)]);
    // The panel tests' scene (three porgies and one running `broken`), written into A's scripts.
    drop(aquarium(a_dir.path(), Some("broken"), Some(3)));
    std::fs::copy(
        a_dir.path().join("scenes/panel_test.lua"),
        b_dir.path().join("scenes/panel_test.lua"),
    )
    .unwrap();
    let load = |dir: &Path| {
        Simulation::from_scene_with_scripts(&repo(), dir, Path::new("scenes/panel_test.lua"), 3)
            .expect("the test scene loads")
    };
    let (sa, sb) = (load(a_dir.path()), load(b_dir.path()));
    let options = AppOptions {
        select: Some(sa.world().fish_id_slice()[3]),
        ..AppOptions::default()
    };
    let versions = shoal_app::SplitVersions {
        a: "A".into(),
        b: "B".into(),
        dirs: None,
    };
    let mut aq = Aquarium::new_split(Box::new(sa), Box::new(sb), versions, options).unwrap();
    for _ in 0..30 {
        aq.advance(1.0 / 60.0);
    }
    assert!(
        aq.split_inspect()
            .iter()
            .any(|(k, v)| k == "error" && v.contains("fails on purpose")),
        "B's inspector has the error line: {:?}",
        aq.split_inspect()
    );
    let ctx = egui::Context::default();
    let mut panel = egui::Rect::NOTHING;
    for _ in 0..4 {
        panel = window_frame(&ctx, &mut aq, vec![]);
    }
    assert!(
        panel.width() <= 451.0,
        "the panel stays at its 450 points: {panel:?}"
    );
}

/// The porgy file's last field line, after which the panel inserts a `motion` table.
const PORGY_LAST: &str = "  decision_hz = 10,        -- behaviour decisions per second (staggered over the 60 Hz tick)\n";

pub(crate) fn set_speed(h: &mut Harness<'static, Aquarium>, s: f64) -> f32 {
    h.get_by_role_and_label(egui::accesskit::Role::Slider, "s (speed, units/s)")
        .set_value_accesskit(s);
    h.run();
    h.state().scene.motion_params(0).unwrap().s
}

#[test]
fn saving_a_tuned_slider_changes_exactly_that_literal_and_the_reload_changes_nothing() {
    let scripts = scripts_with(&[]);
    let porgy = scripts.path().join("species/black_porgy.lua");
    let before = std::fs::read_to_string(&porgy).unwrap();
    assert!(
        before.contains(PORGY_LAST),
        "the shipped porgy changed: update this test"
    );
    let mut h = harness(aquarium(scripts.path(), None, None));
    h.run();
    h.get_by_label("no unsaved changes (species/black_porgy.lua)");
    let saved_s = h.state().scene.motion_params(0).unwrap().s;
    let s = set_speed(&mut h, 70.0);
    assert!((s - 70.0).abs() < 0.5, "the slider set {s}");
    h.get_by_label(&format!("motion.s: {saved_s} → {s}"));
    h.get_by_label("save to species file").click();
    h.run();
    let after = std::fs::read_to_string(&porgy).unwrap();
    assert_eq!(
        after,
        before.replacen(
            PORGY_LAST,
            &format!("{PORGY_LAST}  motion = {{ s = {s} }},\n"),
            1
        )
    );
    h.get_by_label("no unsaved changes (species/black_porgy.lua)");
    // The hot reload the save triggers finds nothing to change.
    let live = h.state().scene.motion_params(0).unwrap();
    let events = h.state_mut().scene.sim_mut().reload_changed(&[porgy]);
    assert_eq!(events.len(), 1, "{events:?}");
    assert!(
        events[0].contains("reloaded species black_porgy"),
        "{events:?}"
    );
    h.run();
    assert_eq!(h.state().scene.motion_params(0).unwrap(), live);
    h.get_by_label("no unsaved changes (species/black_porgy.lua)");
    // "revert" after a further tweak goes back to the saved value exactly.
    set_speed(&mut h, 90.0);
    h.get_by_label("revert").click();
    h.run();
    assert_eq!(h.state().scene.motion_params(0).unwrap(), live);
}

#[test]
fn a_file_changed_by_hand_under_unsaved_tuning_is_asked_about_not_overwritten() {
    let scripts = scripts_with(&[]);
    let porgy = scripts.path().join("species/black_porgy.lua");
    let mut h = harness(aquarium(scripts.path(), None, None));
    h.run();
    let s = set_speed(&mut h, 80.0);
    // The designer edits the file by hand meanwhile; the hot reload applies it.
    let by_hand = std::fs::read_to_string(&porgy).unwrap().replacen(
        PORGY_LAST,
        &format!("{PORGY_LAST}  motion = {{ s = 40, omega = 9 }}, -- typed by hand\n"),
        1,
    );
    std::fs::write(&porgy, &by_hand).unwrap();
    h.state_mut()
        .scene
        .sim_mut()
        .reload_changed(std::slice::from_ref(&porgy));
    h.run();
    h.run();
    h.get_by_label(
        "species/black_porgy.lua changed on disk while the panel had unsaved values for it",
    );
    assert_eq!(
        h.state().scene.motion_params(0).unwrap().s,
        s,
        "the tuning stays live"
    );
    assert_eq!(
        std::fs::read_to_string(&porgy).unwrap(),
        by_hand,
        "nothing written yet"
    );
    h.get_by_label("save my values over it").click();
    h.run();
    assert_eq!(
        std::fs::read_to_string(&porgy).unwrap(),
        by_hand.replacen("{ s = 40,", &format!("{{ s = {s},"), 1),
        "only the tuned literal changed; the hand edit's other value and comment stay"
    );
}

#[test]
fn a_value_written_as_an_expression_is_replaced_only_after_confirmation() {
    let porgy_src = "return {\n  base = \"black_porgy\",\n  motion = {\n    s = 25 * 2,   -- two of the old speed\n  },\n}\n";
    let scripts = scripts_with(&[("species/black_porgy.lua", porgy_src)]);
    let porgy = scripts.path().join("species/black_porgy.lua");
    let mut h = harness(aquarium(scripts.path(), None, None));
    h.run();
    let s = set_speed(&mut h, 60.0);
    h.get_by_label("save to species file").click();
    h.run();
    assert_eq!(std::fs::read_to_string(&porgy).unwrap(), porgy_src);
    h.get_by_label("cancel").click();
    h.run();
    h.get_by_label("save to species file").click();
    h.run();
    h.get_by_label("replace the expression").click();
    h.run();
    assert_eq!(
        std::fs::read_to_string(&porgy).unwrap(),
        porgy_src.replacen("s = 25 * 2,", &format!("s = {s} --[[was: 25 * 2]],"), 1)
    );
}

/// Two wandering porgies 3,000 units apart in a long tank, with level of detail on: a near band
/// of 200 units at full rate and the rest at a quarter.
const LOD_TWO_FISH: &str = r#"return {
  tank = { min = {-2000, 0, -400}, max = {2000, 400, 400} },
  lod = { on = true, bands = { {radius = 200, every = 1}, {every = 4} } },
  fish = {
    { species = "black_porgy", behavior = "wander", pos = {1500, 200, 0}, heading = 0 },
    { species = "black_porgy", behavior = "wander", pos = {-1500, 200, 0}, heading = 0 },
  },
}"#;

/// The timings section shows how many decisions a tick makes and, with behaviour level of
/// detail on, how the fish fall into its bands: the selected fish is near a focus (full rate),
/// a fish far from it and from the camera is in the slow band.
#[test]
fn the_panel_shows_the_behaviour_level_of_detail_bands_and_decisions() {
    let scripts = scripts_with(&[("scenes/lod_panel.lua", LOD_TWO_FISH)]);
    let sim = Simulation::from_scene_with_scripts(
        &repo(),
        scripts.path(),
        Path::new("scenes/lod_panel.lua"),
        3,
    )
    .expect("the test scene loads");
    let options = AppOptions {
        select: Some(sim.world().fish_id_slice()[0]),
        ..AppOptions::default()
    };
    let mut aq = Aquarium::new(Box::new(sim), options);
    for _ in 0..30 {
        aq.advance(1.0 / 60.0);
    }
    let counts = *aq.scene.world().lod_counts();
    assert_eq!(
        counts.fish[..2],
        [1, 1],
        "the selected fish near, the other far"
    );
    let mut h = harness(aq);
    h.run();
    // The whole line, as the counts of the last tick say it should read.
    let line = format!(
        "decisions {} this tick; behaviour level of detail on: band 1 (1/1) {}/1 fish, \
         band 2 (1/4) {}/1 fish; {} woken",
        counts.total(),
        counts.decisions[0],
        counts.decisions[1],
        counts.woken
    );
    assert!(
        h.query_by_label_contains(&line).is_some(),
        "no panel line {line:?}"
    );
}

/// In the split tank B gets the level-of-detail focus as A does (the camera's target and the
/// selected fish, where it is in B): the selected fish is in the near band on both sides, and
/// B's focus is A's.
#[test]
fn the_split_tanks_b_gets_the_level_of_detail_focus_too() {
    let scripts = scripts_with(&[("scenes/lod_split.lua", LOD_TWO_FISH)]);
    let load = || {
        Simulation::from_scene_with_scripts(
            &repo(),
            scripts.path(),
            Path::new("scenes/lod_split.lua"),
            3,
        )
        .expect("the test scene loads")
    };
    let (sa, sb) = (load(), load());
    let selected = sa.world().fish_id_slice()[0];
    let options = AppOptions {
        select: Some(selected),
        ..AppOptions::default()
    };
    let versions = shoal_app::SplitVersions {
        a: "A".into(),
        b: "B".into(),
        dirs: None,
    };
    let mut aq = Aquarium::new_split(Box::new(sa), Box::new(sb), versions, options).unwrap();
    for _ in 0..30 {
        aq.advance(1.0 / 60.0);
    }
    let a = aq.scene.world();
    let b = aq.split_scene().expect("a split tank").world();
    assert_eq!(
        a.lod_counts().fish[..2],
        [1, 1],
        "A: the selected fish near"
    );
    assert_eq!(
        b.lod_counts().fish[..2],
        [1, 1],
        "B: the selected fish near"
    );
    assert_eq!(
        b.lod().focus.len(),
        2,
        "B focuses on the camera and the fish"
    );
    // One camera, and the same scripts and seed (the fish is where it is in A): A's focus,
    // set at the frame's start (the camera has followed the fish since).
    assert_eq!(b.lod().focus, a.lod().focus);
    assert!(b.lod().focus[1].distance(b.root(selected).unwrap().pos) < 10.0);
}
