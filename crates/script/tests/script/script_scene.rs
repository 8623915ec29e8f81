//! Scenes and species files: the default scene runs with every shipped behaviour, species data
//! reloads into live fish, and per-species decision rates hold.

use crate::common;

use std::path::Path;

use glam::Vec3;
use shoal_script::{ReloadEvent, Simulation};

#[test]
fn test_default_scene_runs_without_script_errors() {
    let mut sim =
        Simulation::from_scene(common::repo(), Path::new("scenes/default.lua"), 1).unwrap();
    assert_eq!(sim.world().num_fish(), 37);
    // Pellets given out: in the water, or eaten (an eaten pellet leaves the food list).
    let pellets =
        |sim: &Simulation| sim.world().foods().count() + sim.world().eaten_foods().count();
    let foods_at_start = pellets(&sim);
    sim.run(20.0);
    common::assert_no_script_errors(&sim);
    assert!(sim.load_errors().is_empty(), "{:?}", sim.load_errors());
    // Food drops every 5 s from t = 3: at 3, 8, 13, 18 → 4 drops of 3 pellets.
    assert_eq!(pellets(&sim), foods_at_start + 12);
    let tank = *sim.world().tank();
    for id in sim.world().fish_ids() {
        let p = sim.world().root(id).unwrap().pos;
        assert!(tank.contains(p), "{id:?} left the tank: {p}");
        let intention = sim.inspect(id).into_iter().find(|(k, _)| k == "intention");
        assert!(intention.is_some(), "{id:?} has decided");
    }
    // The pellets sink through the school, and hungry porgies break off to eat them (when
    // they floated at the surface, the first bite came after ~2.5 minutes on average).
    sim.run(25.0);
    let eaten = sim.world().eaten_foods().count();
    assert!(eaten >= 1, "no pellet eaten in 45 s");
    let lowest = sim
        .world()
        .foods()
        .map(|(_, f)| f.pos.y)
        .fold(f32::MAX, f32::min);
    assert!(
        lowest < 100.0,
        "pellets sink towards the floor: lowest at {lowest}"
    );
}

#[test]
fn test_species_files_set_decision_rates() {
    // scripts/species/eel.lua asks for 5 decisions a second, black_porgy.lua for 10.
    let (_d, root) = common::scratch_repo();
    std::fs::write(
        root.join("scripts/behaviors/count.lua"),
        "return { tick = function(fish) fish.memory.n = (fish.memory.n or 0) + 1 end }\n",
    )
    .unwrap();
    let mut sim = Simulation::from_scene(&root, Path::new("scenes/empty_tank.lua"), 2).unwrap();
    let eel = sim
        .spawn(
            "eel",
            Vec3::new(0.0, 100.0, 0.0),
            0.0,
            0.0,
            None,
            Some("count"),
        )
        .unwrap();
    let porgy = sim
        .spawn(
            "black_porgy",
            Vec3::new(0.0, 200.0, 0.0),
            0.0,
            0.0,
            None,
            Some("count"),
        )
        .unwrap();
    sim.run(1.0);
    assert_eq!(sim.memory_json(eel)["n"], 5);
    assert_eq!(sim.memory_json(porgy)["n"], 10);
}

#[test]
fn test_species_reload_applies_to_live_fish() {
    let (_d, root) = common::scratch_repo();
    let mut sim = Simulation::from_scene(&root, Path::new("scenes/default.lua"), 3).unwrap();
    sim.run(0.5);
    let sid = sim.world().species_by_name("black_porgy").unwrap();
    let before = sim.world().species(sid).desc.max_speed;
    let file = root.join("scripts/species/black_porgy.lua");
    std::fs::write(
        &file,
        "return { base = 'black_porgy', decision_hz = 10, max_speed = 77 }\n",
    )
    .unwrap();
    let events = sim.reload_changed(std::slice::from_ref(&file));
    assert_eq!(events, [ReloadEvent::Species("black_porgy".into())]);
    assert_ne!(before, 77.0);
    assert_eq!(sim.world().species(sid).desc.max_speed, 77.0);
    sim.run(0.5);
    common::assert_no_script_errors(&sim);
    // A broken species file keeps the old data and says why.
    std::fs::write(&file, "return { base = 'black_porgy', decision_hz = 0 }\n").unwrap();
    let events = sim.reload_changed(std::slice::from_ref(&file));
    assert_eq!(
        events,
        [ReloadEvent::Failed(
            "scripts/species/black_porgy.lua: decision_hz must be a number in (0, 60], got 0"
                .into()
        )]
    );
    assert_eq!(sim.world().species(sid).desc.max_speed, 77.0);
}

/// A scene whose pellets sink and dissolve: a drop at the surface reaches the floor and lies
/// there until the lifetime ends; nobody eats it (no fish), so it dissolves uneaten.
#[test]
fn test_scene_pellets_sink_settle_and_dissolve() {
    let (_dir, root) = common::scratch_repo();
    let scene = root.join("scripts/scenes/sinking.lua");
    std::fs::write(
        &scene,
        "return { tank = { min = {-200, 0, -200}, max = {200, 300, 200} },\n\
         food = { {0, 290, 0} }, food_sink_speed = 20, food_lifetime = 20 }\n",
    )
    .unwrap();
    let mut sim = Simulation::from_scene(&root, Path::new("scenes/sinking.lua"), 1).unwrap();
    let (id, _) = sim.world().foods().next().expect("the pellet");
    sim.run(5.0);
    let y = sim.world().food(id).unwrap().pos.y;
    assert!((y - 190.0).abs() < 0.5, "20 units/s for 5 s from 290: {y}");
    sim.run(10.0);
    let f = *sim.world().food(id).unwrap();
    assert!(f.settled && f.pos.y == 0.0, "on the floor: {f:?}");
    sim.run(6.0);
    assert!(sim.world().food(id).is_none(), "dissolved after 20 s");
    assert!(!sim.world().was_eaten(id));
}

/// Nonsense pellet physics are refused with the file and the key.
#[test]
fn test_scene_food_physics_errors_name_the_key() {
    let (_dir, root) = common::scratch_repo();
    for (body, key) in [
        (
            "food_sink_speed = -3",
            "food_sink_speed: -3 is out of range",
        ),
        ("food_lifetime = 0", "food_lifetime: 0 is out of range"),
        ("food_sink = 3", "food_sink"),
    ] {
        std::fs::write(
            root.join("scripts/scenes/bad.lua"),
            format!(
                "return {{ tank = {{ min = {{0, 0, 0}}, max = {{100, 100, 100}} }}, {body} }}\n"
            ),
        )
        .unwrap();
        let err = Simulation::from_scene(&root, Path::new("scenes/bad.lua"), 1)
            .err()
            .unwrap_or_else(|| panic!("{body} accepted"))
            .to_string();
        assert!(err.contains("scenes/bad.lua"), "{body}: {err}");
        assert!(err.contains(key), "{body}: {err}");
    }
}

/// A scene's own measures: sampled once per simulated second for every fish, the mean over fish
/// and samples; nil leaves a fish out, true counts 1; the shoal sensors answer for the fish; a
/// measure that fails is logged by name with file:line while the others and the run go on; and
/// the values do not depend on the number of script lanes.
#[test]
fn test_scene_measures_sample_every_fish_once_a_second() {
    let (_dir, root) = common::scratch_repo();
    std::fs::write(
        root.join("scripts/scenes/measured.lua"),
        "return { tank = { min = {-300, 0, -300}, max = {300, 300, 300} },\n\
         fish = { { species = \"black_porgy\", count = 6, behavior = \"wander\" },\n\
                  { species = \"eel\", count = 2 } },\n\
         measures = {\n\
           one = function(fish) return 1 end,\n\
           porgy_only = function(fish) if fish.species ~= \"black_porgy\" then return nil end return 2 end,\n\
           is_eel = function(fish) return fish.species == \"eel\" end,\n\
           height = function(fish) return shoal.body().y end,\n\
           broken = function(fish) return fish.memory.missing.x end,\n\
         } }\n",
    )
    .unwrap();
    let run = |lanes: usize| {
        let mut sim = Simulation::from_scene(&root, Path::new("scenes/measured.lua"), 4).unwrap();
        sim.set_lanes(lanes).unwrap();
        assert_eq!(
            sim.measure_names(),
            ["broken", "height", "is_eel", "one", "porgy_only"]
        );
        sim.run(0.9);
        assert_eq!(sim.measures()[3].1.samples, 0, "no sample before 1 s");
        sim.run(2.1);
        sim
    };
    let sim = run(1);
    let m: std::collections::BTreeMap<String, shoal_script::MeasureResult> =
        sim.measures().into_iter().collect();
    // 8 fish × 3 samples (1 s, 2 s, 3 s).
    assert_eq!((m["one"].mean, m["one"].samples), (Some(1.0), 24));
    assert_eq!(
        (m["porgy_only"].mean, m["porgy_only"].samples),
        (Some(2.0), 18)
    );
    assert_eq!(m["is_eel"].mean, Some(0.25));
    let h = m["height"].mean.unwrap();
    assert!(
        h > 0.0 && h < 300.0,
        "shoal.body() answered for each fish: {h}"
    );
    assert_eq!((m["broken"].mean, m["broken"].errors), (None, 24));
    let first = m["broken"].first_error.clone().unwrap();
    assert!(
        first.contains("scenes/measured.lua:9:") && first.contains("missing"),
        "{first}"
    );
    let logged = sim.error_messages().join("\n");
    assert!(
        logged.contains("measure \"broken\": ") && logged.contains("measured.lua:9:"),
        "{logged}"
    );
    let four = run(4);
    assert_eq!(
        four.measures(),
        sim.measures(),
        "the same whatever the lanes"
    );
}

/// `measures` that is not a table of functions is refused at load with its field path.
#[test]
fn test_scene_measures_must_be_functions() {
    let (_dir, root) = common::scratch_repo();
    for (body, expected) in [
        ("measures = 3", "measures: expected a table of functions"),
        (
            "measures = { hiding = 0.5 }",
            "measures.hiding: expected a function(fish) returning a number",
        ),
        (
            "measures = { function() end }",
            "measures: a measure is named by a string key",
        ),
        ("measure = {}", "did you mean \"measures\""),
    ] {
        std::fs::write(
            root.join("scripts/scenes/bad.lua"),
            format!(
                "return {{ tank = {{ min = {{0, 0, 0}}, max = {{100, 100, 100}} }}, {body} }}\n"
            ),
        )
        .unwrap();
        let err = Simulation::from_scene(&root, Path::new("scenes/bad.lua"), 1)
            .err()
            .unwrap_or_else(|| panic!("{body} accepted"))
            .to_string();
        assert!(
            err.contains("scenes/bad.lua") && err.contains(expected),
            "{body}: {err}"
        );
    }
}

/// The window's live scene edits: rocks and current zones reach the world at once, a group's
/// `params` reach its fish, and what needs a restart (the tank) or is not a number (NaN) is
/// refused, naming it, with nothing changed.
#[test]
fn a_live_scene_edit_moves_rocks_and_zones_and_refuses_the_rest() {
    let (_d, root) = common::scratch_repo();
    let mut sim = Simulation::from_scene(&root, Path::new("scenes/default.lua"), 5).unwrap();
    let mut desc = sim.scene().unwrap().clone();
    desc.obstacles[0].pos = [1.0, 2.0, 3.0];
    desc.obstacles[1].radius = 70.0;
    desc.currents.clear();
    sim.apply_scene_edit(desc.clone()).unwrap();
    let w = sim.world();
    assert_eq!(w.obstacles()[0].pos, Vec3::new(1.0, 2.0, 3.0));
    assert_eq!(w.obstacles()[1].radius, 70.0);
    assert!(w.currents().is_empty());
    assert_eq!(sim.scene(), Some(&desc));
    let mut bigger = desc.clone();
    bigger.tank.max[0] = 900.0;
    let err = sim.apply_scene_edit(bigger).unwrap_err().to_string();
    assert!(
        err.contains("scenes/default.lua") && err.contains("restart"),
        "{err}"
    );
    let mut nan = desc.clone();
    nan.obstacles[1].radius = f32::NAN;
    let err = sim.apply_scene_edit(nan).unwrap_err().to_string();
    assert!(err.contains("obstacles[2]"), "{err}");
    assert_eq!(sim.scene(), Some(&desc), "a refused edit changes nothing");
    assert_eq!(sim.world().obstacles()[1].radius, 70.0);
    // A state kept before an edit, put back, runs on with the rocks as edited now.
    let before = sim.snapshot().unwrap();
    let mut moved = desc.clone();
    moved.obstacles[1].pos = [9.0, 8.0, 7.0];
    sim.apply_scene_edit(moved).unwrap();
    sim.step();
    sim.restore(&before).unwrap();
    assert_eq!(sim.world().obstacles()[1].pos, Vec3::new(9.0, 8.0, 7.0));
    assert_eq!(sim.world().obstacles().len(), 2);
    assert!(sim.world().currents().is_empty());
}
