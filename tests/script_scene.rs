//! Scenes and species files: the default scene runs with every shipped behaviour, species data
//! reloads into live fish, and per-species decision rates hold.

mod common;

use std::path::Path;

use glam::Vec3;
use shoal::script::{ReloadEvent, Simulation};

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
