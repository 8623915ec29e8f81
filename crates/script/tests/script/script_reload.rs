//! Hot reload: live fish keep memory and position and pick up new code; a broken file keeps the
//! last good version running and reports file:line until fixed; scene edits raise a flag.

use crate::common;

use std::path::PathBuf;
use std::time::{Duration, Instant};

use glam::Vec3;
use shoal_core::world::FishId;
use shoal_script::{ReloadEvent, Simulation};

const V1: &str = "local M = {}\nM.version = 1\nfunction M.tick(fish)\n  local m = fish.memory\n  m.n = (m.n or 0) + 1\n  m.version = M.version\nend\nreturn M\n";
const V2: &str = "local M = {}\nM.version = 2\nfunction M.tick(fish)\n  local m = fish.memory\n  m.n = (m.n or 0) + 1\n  m.version = M.version\nend\nreturn M\n";
const BROKEN: &str = "local M = {}\nM.version = = 3\nreturn M\n";

fn setup() -> (tempfile::TempDir, PathBuf, Simulation, FishId) {
    let (dir, root) = common::scratch_repo();
    let file = root.join("scripts/behaviors/counter.lua");
    std::fs::write(&file, V1).unwrap();
    let mut sim = common::sim_in(&root, 5);
    let id = sim
        .spawn(
            "black_porgy",
            Vec3::new(0.0, 200.0, 0.0),
            0.0,
            0.0,
            Some(50.0),
            Some("counter"),
        )
        .unwrap();
    sim.run(1.0);
    (dir, file, sim, id)
}

fn mem(sim: &Simulation, id: FishId) -> serde_json::Value {
    sim.memory_json(id)
}

#[test]
fn test_reload_keeps_memory_and_position() {
    let (_d, file, mut sim, id) = setup();
    assert_eq!(mem(&sim, id), serde_json::json!({"n": 10, "version": 1}));
    let pos = sim.world().root(id).unwrap().pos;
    std::fs::write(&file, V2).unwrap();
    let events = sim.reload_changed(std::slice::from_ref(&file));
    assert_eq!(events, [ReloadEvent::Behaviors(vec!["counter".into()])]);
    assert_eq!(
        sim.world().root(id).unwrap().pos,
        pos,
        "reloading moves nothing"
    );
    sim.run(1.0);
    assert_eq!(
        mem(&sim, id),
        serde_json::json!({"n": 20, "version": 2}),
        "the count went on from 10 under the new code"
    );
}

#[test]
fn test_broken_reload_keeps_the_old_version_until_fixed() {
    let (_d, file, mut sim, id) = setup();
    std::fs::write(&file, BROKEN).unwrap();
    let events = sim.reload_changed(std::slice::from_ref(&file));
    let msg = "scripts/behaviors/counter.lua:2: unexpected symbol near '='";
    assert_eq!(events, [ReloadEvent::Failed(msg.into())]);
    assert_eq!(
        sim.load_errors(),
        [("scripts/behaviors/counter.lua".to_owned(), msg.to_owned())]
    );
    sim.run(1.0);
    assert_eq!(mem(&sim, id), serde_json::json!({"n": 20, "version": 1}));
    assert!(sim.drain_log().iter().any(|e| e.message == msg));
    // Fixed: the error goes away and the new code runs.
    std::fs::write(&file, V2).unwrap();
    sim.reload_changed(std::slice::from_ref(&file));
    assert!(sim.load_errors().is_empty());
    sim.run(0.5);
    assert_eq!(mem(&sim, id), serde_json::json!({"n": 25, "version": 2}));
}

#[test]
fn test_reload_of_a_required_library_reaches_its_users() {
    let (_d, root) = common::scratch_repo();
    let lib = root.join("scripts/behaviors/lib/numbers.lua");
    std::fs::write(&lib, "return { k = 1 }\n").unwrap();
    std::fs::write(
        root.join("scripts/behaviors/user.lua"),
        "local numbers = require('behaviors.lib.numbers')\nreturn { tick = function(fish) fish.memory.k = numbers.k end }\n",
    )
    .unwrap();
    let mut sim = common::sim_in(&root, 5);
    let id = sim
        .spawn(
            "black_porgy",
            Vec3::new(0.0, 200.0, 0.0),
            0.0,
            0.0,
            Some(50.0),
            Some("user"),
        )
        .unwrap();
    sim.run(0.2);
    assert_eq!(mem(&sim, id)["k"], 1);
    std::fs::write(&lib, "return { k = 2 }\n").unwrap();
    let events = sim.reload_changed(std::slice::from_ref(&lib));
    assert!(
        matches!(&events[..], [ReloadEvent::Behaviors(names)] if names.contains(&"user".to_owned())),
        "{events:?}"
    );
    sim.run(0.2);
    assert_eq!(mem(&sim, id)["k"], 2);
}

#[test]
fn test_a_behaviour_that_failed_to_load_runs_once_fixed() {
    let (_d, root) = common::scratch_repo();
    let file = root.join("scripts/behaviors/late.lua");
    std::fs::write(&file, "return {\n").unwrap();
    let mut sim = common::sim_in(&root, 5);
    let id = sim
        .spawn(
            "black_porgy",
            Vec3::new(0.0, 200.0, 0.0),
            0.0,
            0.0,
            Some(50.0),
            Some("late"),
        )
        .unwrap();
    sim.run(0.5);
    assert_eq!(sim.load_errors().len(), 1);
    std::fs::write(
        &file,
        "return { tick = function(fish) fish.memory.ok = true end }\n",
    )
    .unwrap();
    sim.reload_changed(std::slice::from_ref(&file));
    sim.run(0.2);
    assert_eq!(mem(&sim, id)["ok"], true);
    assert!(sim.load_errors().is_empty());
}

#[test]
fn test_editing_the_scene_offers_a_restart() {
    let (_d, root) = common::scratch_repo();
    let scene = root.join("scripts/scenes/empty_tank.lua");
    let mut sim = common::sim_in(&root, 5);
    sim.spawn(
        "black_porgy",
        Vec3::new(0.0, 200.0, 0.0),
        0.0,
        0.0,
        Some(50.0),
        None,
    )
    .unwrap();
    assert!(!sim.scene_changed());
    std::fs::write(
        &scene,
        "return { tank = { min = { -100, 0, -100 }, max = { 100, 100, 100 } } }\n",
    )
    .unwrap();
    assert_eq!(
        sim.reload_changed(std::slice::from_ref(&scene)),
        [ReloadEvent::SceneChanged]
    );
    assert!(sim.scene_changed());
    assert_eq!(
        sim.world().num_fish(),
        1,
        "nothing changes until the restart"
    );
    sim.restart_scene().unwrap();
    assert!(!sim.scene_changed());
    assert_eq!(sim.world().num_fish(), 0);
    assert_eq!(sim.world().tank().max, Vec3::splat(100.0));
}

fn wait_for_reload(sim: &mut Simulation, limit: Duration) -> Vec<ReloadEvent> {
    let start = Instant::now();
    while start.elapsed() < limit {
        let ev = sim.poll_reload();
        if !ev.is_empty() {
            return ev;
        }
        std::thread::sleep(Duration::from_millis(10));
    }
    Vec::new()
}

#[test]
fn test_watcher_picks_up_writes_and_rename_saves() {
    let (_d, file, mut sim, id) = setup();
    sim.watch().unwrap();
    std::thread::sleep(Duration::from_millis(100));
    // A plain write.
    std::fs::write(&file, V2).unwrap();
    let ev = wait_for_reload(&mut sim, Duration::from_secs(5));
    assert_eq!(ev, [ReloadEvent::Behaviors(vec!["counter".into()])]);
    sim.run(0.2);
    assert_eq!(mem(&sim, id)["version"], 2);
    // An editor's save: write a temporary file, rename it over the original.
    let tmp = file.with_extension("lua.swp");
    std::fs::write(&tmp, V1).unwrap();
    std::fs::rename(&tmp, &file).unwrap();
    let ev = wait_for_reload(&mut sim, Duration::from_secs(5));
    assert_eq!(ev, [ReloadEvent::Behaviors(vec!["counter".into()])]);
    sim.run(0.2);
    assert_eq!(mem(&sim, id)["version"], 1);
}
