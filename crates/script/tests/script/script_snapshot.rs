//! Rewinding a Lua simulation (issues 12 and 14): a snapshot holds the world's state and every
//! lane's fish tables, and a restored simulation runs the same future bit for bit.

use crate::common;

use std::path::Path;

use glam::Vec3;
use shoal_script::Simulation;

fn default_scene(lanes: usize) -> Simulation {
    let mut sim =
        Simulation::from_scene(common::repo(), Path::new("scenes/default.lua"), 21).unwrap();
    sim.set_lanes(lanes).unwrap();
    sim
}

/// The world's state and every fish's memory, as text.
fn fingerprint(sim: &Simulation) -> String {
    let w = sim.world();
    let mut out = format!("{:?}\n", w.state());
    for id in w.fish_ids() {
        out.push_str(&format!("{id:?} {}\n", sim.memory_json(id)));
    }
    out
}

#[test]
fn a_restored_simulation_runs_the_same_future_with_one_or_two_lanes() {
    for lanes in [1, 2] {
        let mut sim = default_scene(lanes);
        sim.run(4.0);
        let snap = sim.snapshot().unwrap();
        assert_eq!(snap.time(), sim.world().time());
        let mut first = Vec::new();
        for _ in 0..180 {
            sim.step();
            first.push(fingerprint(&sim));
        }
        sim.restore(&snap).unwrap();
        assert_eq!(sim.world().state(), snap.world());
        for (k, expected) in first.iter().enumerate() {
            sim.step();
            assert!(
                &fingerprint(&sim) == expected,
                "{lanes} lanes: tick {} after the restore differs",
                k + 1
            );
        }
        // A snapshot can be restored again.
        sim.restore(&snap).unwrap();
        sim.step();
        assert_eq!(&fingerprint(&sim), &first[0]);
        common::assert_no_script_errors(&sim);
    }
}

#[test]
fn restoring_brings_back_fish_despawned_since_and_their_memory() {
    let mut sim = default_scene(2);
    sim.run(2.0);
    let snap = sim.snapshot().unwrap();
    let id = sim.world().fish_ids().nth(3).unwrap();
    let memory = sim.memory_json(id);
    assert!(memory.is_object(), "the fish decided already: {memory}");
    assert!(sim.despawn(id));
    sim.run(1.0);
    sim.restore(&snap).unwrap();
    assert!(sim.world().is_alive(id));
    assert_eq!(sim.memory_json(id), memory);
}

#[test]
fn a_function_in_fish_memory_is_refused_naming_the_fish_and_field() {
    let (_dir, root) = common::scratch_repo();
    std::fs::write(
        root.join("scripts/behaviors/probe.lua"),
        "return { tick = function(fish)\n  fish.memory.plan = { next = function() end }\nend }\n",
    )
    .unwrap();
    let mut sim = common::sim_in(&root, 3);
    let id = sim
        .spawn(
            "black_porgy",
            Vec3::new(0.0, 100.0, 0.0),
            0.0,
            0.0,
            Some(50.0),
            Some("probe"),
        )
        .unwrap();
    sim.run(0.2);
    let err = sim.snapshot().unwrap_err().to_string();
    assert!(
        err.contains(&format!("fish #{}", id.index))
            && err.contains("memory.plan.next")
            && err.contains("function (defined at scripts/behaviors/probe.lua:2)"),
        "the error names the fish, the field, and where the function comes from: {err}"
    );
}

#[test]
fn a_snapshot_restores_into_another_simulation_of_the_same_scene() {
    let mut a = default_scene(2);
    a.run(3.0);
    let snap = a.snapshot().unwrap();
    let mut b = default_scene(2);
    b.restore(&snap).unwrap();
    for k in 0..120 {
        a.step();
        b.step();
        assert!(
            fingerprint(&a) == fingerprint(&b),
            "tick {} after the restore differs",
            k + 1
        );
    }
    // A different number of lanes cannot take it.
    let mut c = default_scene(1);
    let err = c.restore(&snap).unwrap_err().to_string();
    assert!(err.contains("2 script lanes"), "{err}");
}
