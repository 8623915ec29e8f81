//! The panel's Scene section: a group's `params` tuned live (the scripts read them at once),
//! listed as unsaved, saved into the scene file with only those literals changed, the reload
//! of the saved file changing nothing, and undo/redo returning the exact previous scene.

use std::path::Path;

use egui::accesskit::Role;
use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use glam::{Vec2, Vec3};
use shoal_app::{AppOptions, Aquarium, Showable};
use shoal_script::Simulation;

use super::window_panel::{harness, repo, scripts_with, set_speed};

/// A scene whose group has `params`, with comments a save must keep.
const SCENE: &str = r#"-- A scene to tune: two porgies whose behaviour reads its params.
return {
  tank = { min = {-400, 0, -250}, max = {400, 300, 250} },
  fish = {
    { species = "black_porgy", count = 2, behavior = "knobs",
      region = { min = {-100, 100, -50}, max = {100, 200, 50} },
      params = {
        gain = 0.5,    -- how hard it turns
        laps = 3,      -- whole laps
        shy = false,   -- hides when true
      } },
  },
  obstacles = {
    { pos = { 250, 60, -120 }, radius = 60 },   -- the big rock
    { pos = { -280, 40, 150 }, radius = 45 },   -- the small one
  },
}
"#;

/// A behaviour that copies `fish.params` into memory each decision (so a test sees what the
/// script read).
const KNOBS: &str = r#"local M = {}
function M.perceive(fish) return {} end
function M.intend(fish, p)
  fish.memory.gain = fish.params.gain
  fish.memory.shy = fish.params.shy
  return "cruise"
end
function M.behave(fish, intention) end
return M
"#;

fn scene_aquarium(scripts: &Path) -> Aquarium {
    let sim = Simulation::from_scene_with_scripts(
        &repo(),
        scripts,
        Path::new("scenes/knobs_test.lua"),
        5,
    )
    .expect("the test scene loads");
    let mut aq = Aquarium::new(Box::new(sim), AppOptions::default());
    aq.advance(0.25);
    aq
}

/// What fish `i`'s script last copied from `fish.params.KEY` into its memory.
fn seen(h: &Harness<'static, Aquarium>, i: usize, key: &str) -> serde_json::Value {
    let id = h.state().scene.world().fish_id_slice()[i];
    h.state()
        .scene
        .sim()
        .eval_fish(id, &format!("fish.memory.{key}"))
        .expect("eval")
}

fn set_drag(h: &mut Harness<'static, Aquarium>, label: &str, v: f64) {
    h.get_by_role_and_label(Role::SpinButton, label)
        .set_value_accesskit(v);
    h.run();
}

#[test]
fn scene_params_tune_live_save_exactly_those_literals_and_undo_exactly() {
    let scripts = scripts_with(&[
        ("scenes/knobs_test.lua", SCENE),
        ("behaviors/knobs.lua", KNOBS),
    ]);
    let file = scripts.path().join("scenes/knobs_test.lua");
    let mut h = harness(scene_aquarium(scripts.path()));
    h.run();
    h.get_by_label("no unsaved scene changes (scenes/knobs_test.lua)");
    assert_eq!(seen(&h, 0, "gain"), serde_json::json!(0.5));
    let original = h.state().scene.sim().scene_desc().cloned().unwrap();

    // Live: the scripts read the new values on their next decision.
    set_drag(&mut h, "fish[1].params.gain", 0.8);
    h.get_by_label("fish[1].params.shy").click();
    h.run();
    h.state_mut().advance(0.25);
    h.run();
    for i in 0..2 {
        assert_eq!(seen(&h, i, "gain"), serde_json::json!(0.8), "fish {i}");
        assert_eq!(seen(&h, i, "shy"), serde_json::json!(true), "fish {i}");
    }
    h.get_by_label("unsaved scene changes (scenes/knobs_test.lua):");
    h.get_by_label("fish[1].params.gain = 0.8");
    h.get_by_label("fish[1].params.shy = true");

    // Undo returns the exact scene before each edit; redo the one after.
    let edited = h.state().scene.sim().scene_desc().cloned().unwrap();
    h.get_by_label("undo").click();
    h.run();
    h.get_by_label("undo").click();
    h.run();
    assert_eq!(h.state().scene.sim().scene_desc(), Some(&original));
    h.get_by_label("no unsaved scene changes (scenes/knobs_test.lua)");
    h.get_by_label("redo").click();
    h.run();
    h.get_by_label("redo").click();
    h.run();
    assert_eq!(h.state().scene.sim().scene_desc(), Some(&edited));

    // A whole number stays whole; a drag's float noise is not saved.
    set_drag(&mut h, "fish[1].params.laps", 4.4);
    h.get_by_label("save to scene file").click();
    h.run();
    let after = std::fs::read_to_string(&file).unwrap();
    let expected = SCENE
        .replacen("gain = 0.5,", "gain = 0.8,", 1)
        .replacen("laps = 3,", "laps = 4,", 1)
        .replacen("shy = false,", "shy = true,", 1);
    assert_eq!(after, expected);
    h.get_by_label("no unsaved scene changes (scenes/knobs_test.lua)");

    // The reload the save triggers finds nothing to change (no restart offered).
    let events = h.state_mut().scene.sim_mut().reload_changed(&[file]);
    assert_eq!(
        events,
        ["the scene file matches the running scene".to_owned()]
    );
    assert!(!h.state().scene.sim().scene_changed());
    h.run();
    h.get_by_label("no unsaved scene changes (scenes/knobs_test.lua)");
}

#[test]
fn a_motion_slider_saves_the_value_it_shows_not_the_float_under_it() {
    let scripts = scripts_with(&[
        ("scenes/knobs_test.lua", SCENE),
        ("behaviors/knobs.lua", KNOBS),
    ]);
    let porgy = scripts.path().join("species/black_porgy.lua");
    let mut h = harness(scene_aquarium(scripts.path()));
    h.run();
    let s = set_speed(&mut h, 63.27586);
    assert_eq!(s, 63.3, "the slider steps by the 0.1 it shows");
    h.get_by_label("save to species file").click();
    h.run();
    let after = std::fs::read_to_string(&porgy).unwrap();
    assert!(after.contains("motion = { s = 63.3 },"), "{after}");
    assert_eq!(h.state().scene.motion_params(0).unwrap().s, 63.3);
}

const VIEW: Vec2 = Vec2::new(960.0, 600.0);

/// Where `p` shows in a `VIEW`-sized view.
fn pixel(aq: &Aquarium, p: Vec3) -> Vec2 {
    let ndc = aq.camera().view_proj(VIEW.x / VIEW.y).project_point3(p);
    Vec2::new((ndc.x + 1.0) * 0.5 * VIEW.x, (1.0 - ndc.y) * 0.5 * VIEW.y)
}

fn rock(h: &Harness<'static, Aquarium>, i: usize) -> Vec3 {
    h.state().scene.world().obstacles()[i].pos
}

#[test]
fn a_rock_dragged_in_the_view_moves_live_undoes_exactly_resizes_and_saves_with_comments() {
    let scripts = scripts_with(&[
        ("scenes/knobs_test.lua", SCENE),
        ("behaviors/knobs.lua", KNOBS),
    ]);
    let file = scripts.path().join("scenes/knobs_test.lua");
    let mut h = harness(scene_aquarium(scripts.path()));
    h.run();
    let original = h.state().scene.sim().scene_desc().cloned().unwrap();
    let start = Vec3::new(250.0, 60.0, -120.0);
    assert_eq!(rock(&h, 0), start);
    let at = pixel(h.state(), start);
    // Without "edit scene" a press on the rock is the camera's.
    assert!(!h.state_mut().press_in_view(at, VIEW));
    h.state_mut().release_in_view();
    h.get_by_label("edit scene in the view").click();
    h.run();
    assert!(
        h.state_mut().press_in_view(at, VIEW),
        "the press picks the rock"
    );
    for k in 1..=8 {
        let to = at + Vec2::new(-12.0 * k as f32, 6.0 * k as f32);
        assert!(h.state_mut().drag_in_view(to, VIEW));
    }
    h.state_mut().release_in_view();
    h.run();
    let moved = rock(&h, 0);
    assert_eq!(moved.y, 60.0, "it moves over the plane at its height");
    assert!(
        (moved - start).length() > 20.0,
        "the rock followed the pointer: {moved}"
    );
    // The rock is where the pointer left it (within the rounding to 0.1).
    let end = pixel(h.state(), moved);
    let want = at + Vec2::new(-96.0, 48.0);
    assert!((end - want).length() < 1.5, "{end} vs {want}");
    assert_eq!(
        h.state().edited_scene().unwrap().obstacles[0].pos,
        moved.to_array()
    );
    // The whole drag is one undo step, back to exactly the scene before.
    h.get_by_label("undo").click();
    h.run();
    assert_eq!(rock(&h, 0), start);
    assert_eq!(h.state().scene.sim().scene_desc(), Some(&original));
    h.get_by_label("redo").click();
    h.run();
    assert_eq!(rock(&h, 0), moved);
    // Resized in the inspector.
    set_drag(&mut h, "obstacles[1].radius", 75.04);
    assert_eq!(h.state().scene.world().obstacles()[0].radius, 75.0);
    h.get_by_label("save to scene file").click();
    h.run();
    let after = std::fs::read_to_string(&file).unwrap();
    let expected = SCENE.replacen(
        "{ pos = { 250, 60, -120 }, radius = 60 },   -- the big rock",
        &format!(
            "{{ pos = {{ {}, 60, {} }}, radius = 75 }},   -- the big rock",
            moved.x, moved.z
        ),
        1,
    );
    assert_eq!(after, expected);
    let events = h.state_mut().scene.sim_mut().reload_changed(&[file]);
    assert_eq!(
        events,
        ["the scene file matches the running scene".to_owned()]
    );
}

#[test]
fn rocks_and_current_zones_are_added_and_deleted_undoably_and_saved() {
    let scripts = scripts_with(&[
        ("scenes/knobs_test.lua", SCENE),
        ("behaviors/knobs.lua", KNOBS),
    ]);
    let file = scripts.path().join("scenes/knobs_test.lua");
    let mut h = harness(scene_aquarium(scripts.path()));
    h.run();
    let original = h.state().scene.sim().scene_desc().cloned().unwrap();
    // Pick the big rock and delete it; the small one is left.
    h.get_by_label("edit scene in the view").click();
    h.run();
    let at = pixel(h.state(), rock(&h, 0));
    assert!(h.state_mut().press_in_view(at, VIEW));
    h.state_mut().release_in_view();
    h.run();
    h.get_by_label("delete").click();
    h.run();
    assert_eq!(h.state().scene.world().obstacles().len(), 1);
    assert_eq!(rock(&h, 0), Vec3::new(-280.0, 40.0, 150.0));
    h.get_by_label("undo").click();
    h.run();
    assert_eq!(h.state().scene.sim().scene_desc(), Some(&original));
    assert_eq!(h.state().scene.world().obstacles().len(), 2);
    h.get_by_label("redo").click();
    h.run();
    // A rock and a current zone at the camera's target.
    h.get_by_label("add rock").click();
    h.run();
    h.get_by_label("add current zone").click();
    h.run();
    let w = h.state().scene.world();
    assert_eq!(w.obstacles().len(), 2);
    assert_eq!(w.currents().len(), 1, "the zone drifts fish at once");
    // The item just added is the one picked, its values in the panel.
    h.get_by_role_and_label(Role::SpinButton, "currents[1].radius");
    // Ctrl+Z takes the zone back out, Ctrl+Shift+Z puts it back.
    h.key_press_modifiers(egui::Modifiers::COMMAND, egui::Key::Z);
    h.run();
    assert!(h.state().scene.world().currents().is_empty());
    h.key_press_modifiers(
        egui::Modifiers::COMMAND | egui::Modifiers::SHIFT,
        egui::Key::Z,
    );
    h.run();
    let w = h.state().scene.world();
    assert_eq!(w.currents().len(), 1);
    let new_rock = w.obstacles()[1].pos;
    let zone = w.currents()[0].pos;
    h.get_by_label("save to scene file").click();
    h.run();
    let after = std::fs::read_to_string(&file).unwrap();
    let expected = SCENE
        .replacen(
            "    { pos = { 250, 60, -120 }, radius = 60 },   -- the big rock\n",
            "",
            1,
        )
        .replacen(
            "-- the small one\n",
            &format!(
                "-- the small one\n    {{ pos = {{ {}, {}, {} }}, radius = 40 }},\n",
                new_rock.x, new_rock.y, new_rock.z
            ),
            1,
        )
        .replacen(
            "  },\n}\n",
            &format!(
                "  }},\n  currents = {{ {{ pos = {{ {}, {}, {} }}, radius = 100, velocity = {{ 10, 0, 0 }} }} }},\n}}\n",
                zone.x, zone.y, zone.z
            ),
            1,
        );
    assert_eq!(after, expected);
    let events = h.state_mut().scene.sim_mut().reload_changed(&[file]);
    assert_eq!(
        events,
        ["the scene file matches the running scene".to_owned()]
    );
}
