//! The console REPL (issue 17): Lua evaluated in the selected fish's context, sandboxed and
//! budgeted.

use crate::common;

use std::path::Path;

use shoal_script::Simulation;

#[test]
fn the_console_evaluates_in_the_fishs_context_within_the_sandbox() {
    let mut sim =
        Simulation::from_scene(common::repo(), Path::new("scenes/default.lua"), 4).unwrap();
    sim.run(1.0);
    let id = sim.world().fish_ids().next().unwrap();
    assert_eq!(sim.eval_fish(id, "1 + 2").unwrap(), 3);
    assert_eq!(
        sim.eval_fish(id, "fish.behavior").unwrap(),
        sim.world().behavior_of(id).unwrap()
    );
    assert_eq!(
        sim.eval_fish(id, "fish.memory").unwrap(),
        sim.memory_json(id)
    );
    // A statement runs and gives nothing; what it set is there afterwards.
    assert!(
        sim.eval_fish(id, "fish.memory.probe = 41")
            .unwrap()
            .is_null()
    );
    assert_eq!(sim.eval_fish(id, "fish.memory.probe + 1").unwrap(), 42);

    let err = sim.eval_fish(id, "fish.memory.(").unwrap_err().to_string();
    assert!(err.contains("console (fish #"), "{err}");
    let err = sim
        .eval_fish(id, "os.execute('true')")
        .unwrap_err()
        .to_string();
    assert!(err.contains("execute"), "{err}");
    let err = sim
        .eval_fish(id, "while true do end")
        .unwrap_err()
        .to_string();
    assert!(
        err.to_lowercase().contains("budget") || err.contains("limit"),
        "{err}"
    );
    // The aquarium goes on.
    sim.run(0.5);
    common::assert_no_script_errors(&sim);
    assert!(sim.despawn(id));
    assert!(
        sim.eval_fish(id, "1")
            .unwrap_err()
            .to_string()
            .contains("not in the tank")
    );
}
