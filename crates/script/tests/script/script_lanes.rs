//! Script lanes: the decisions of one tick run in several Lua states in parallel, and the results
//! do not depend on how many.

use crate::common;

use std::path::Path;

use glam::Vec3;
use shoal_core::world::FishId;
use shoal_script::{Simulation, lane_index};

/// Everything a run leaves behind that a script could have influenced: every fish's root state
/// (as bits), motion and memory, and who ate which pellet when.
fn fingerprint(sim: &Simulation) -> Vec<String> {
    let w = sim.world();
    let mut out = Vec::new();
    for id in w.fish_ids() {
        let r = w.root(id).unwrap();
        out.push(format!(
            "{id:?} {:?} {:08x} {:08x} {:08x} {} {}",
            r.pos.to_array().map(f32::to_bits),
            r.heading.to_bits(),
            r.pitch.to_bits(),
            r.speed.to_bits(),
            w.current_motion(id).unwrap(),
            sim.memory_json(id),
        ));
    }
    // Every pellet, in the water or eaten (eaten pellets leave the world's food list).
    let mut pellets: Vec<_> = w.foods().chain(w.eaten_foods()).collect();
    pellets.sort_by_key(|(id, _)| *id);
    for (id, f) in pellets {
        out.push(format!("{id:?} {:?} {:?}", f.eaten_by, f.eaten_at));
    }
    out
}

fn default_scene(lanes: usize) -> Simulation {
    let mut sim =
        Simulation::from_scene(common::repo(), Path::new("scenes/default.lua"), 7).unwrap();
    sim.set_lanes(lanes).unwrap();
    assert_eq!(sim.num_lanes(), lanes);
    sim
}

#[test]
fn test_the_default_scene_is_the_same_in_one_two_or_three_lanes() {
    let mut runs = Vec::new();
    for lanes in [1, 2, 3] {
        let mut sim = default_scene(lanes);
        // Pellets among the fish, so that bites happen early and often.
        for i in 0..40 {
            let t = i as f32;
            let pos = Vec3::new(-300.0 + 15.0 * t, 120.0 + 3.0 * t, 100.0 * (t * 0.7).sin());
            sim.world_mut().add_food(pos);
        }
        sim.run(20.0);
        common::assert_no_script_errors(&sim);
        runs.push((lanes, fingerprint(&sim)));
    }
    // The scene drops food every 5 s and hungry porgies eat it: bites are part of what must match.
    assert!(
        runs[0].1.iter().any(|l| l.contains("Some(FishId")),
        "some pellet was eaten in 20 s: {:#?}",
        runs[0].1
    );
    for (lanes, fp) in &runs[1..] {
        assert_eq!(&runs[0].1, fp, "1 lane and {lanes} lanes differ");
    }
}

/// A simulation whose scripts dir holds one behaviour `probe` with `src`.
fn probe(src: &str, lanes: usize) -> (tempfile::TempDir, Simulation) {
    let (dir, root) = common::scratch_repo();
    std::fs::write(root.join("scripts/behaviors/probe.lua"), src).unwrap();
    let mut sim = common::sim_in(&root, 3);
    sim.set_lanes(lanes).unwrap();
    (dir, sim)
}

fn spawn(sim: &mut Simulation, pos: Vec3, behavior: Option<&str>) -> FishId {
    sim.spawn("black_porgy", pos, 0.0, 0.0, Some(0.0), behavior)
        .unwrap()
}

/// Two fish bite the same pellet on the same tick, in different lanes: both bites succeed (each
/// saw the pellet uneaten as the tick began) and the pellet goes to the first in decision order.
#[test]
fn test_two_fish_biting_one_pellet_on_one_tick() {
    for lanes in [1, 4] {
        let (_d, mut sim) = probe(
            "return { tick = function(fish)\n  fish.memory.ate = shoal.eat(0)\nend }\n",
            lanes,
        );
        // Slots 0, 6, 12… all decide on tick 0 (10 Hz: every 6th tick, staggered by slot); the
        // second biter is the first of them in another lane than slot 0's.
        let first = spawn(&mut sim, Vec3::new(0.0, 200.0, 0.0), Some("probe"));
        let other = (1..)
            .map(|k| 6 * k)
            .find(|&i| {
                lanes == 1
                    || lane_index(
                        FishId {
                            index: i,
                            generation: 0,
                        },
                        lanes,
                    ) != lane_index(first, lanes)
            })
            .unwrap();
        for i in 1..other {
            spawn(
                &mut sim,
                Vec3::new(-450.0, 10.0 + 3.0 * i as f32, -250.0),
                None,
            );
        }
        let second = spawn(&mut sim, Vec3::new(2.0, 200.0, 0.0), Some("probe"));
        assert_eq!((first.index, second.index), (0, other));
        let food = sim.world_mut().add_food(Vec3::new(1.0, 200.0, 0.0));
        sim.step();
        assert_eq!(sim.memory_json(first)["ate"], true, "{lanes} lanes");
        assert_eq!(sim.memory_json(second)["ate"], true, "{lanes} lanes");
        let pellet = sim.world().food(food).unwrap();
        assert!(pellet.eaten);
        assert_eq!(pellet.eaten_by, Some(first), "{lanes} lanes");
        // Next time round the pellet is gone for both.
        sim.run(0.1);
        assert_eq!(sim.memory_json(first)["ate"], false);
        assert_eq!(sim.memory_json(second)["ate"], false);
    }
}

/// A module-level variable lives in its lane's Lua state; `fish.memory` is the place for state
/// that follows a fish.
#[test]
fn test_module_level_state_is_per_lane() {
    let src = "local n = 0\nreturn { tick = function(fish)\n  if fish.memory.n == nil then n = n + 1; fish.memory.n = n end\nend }\n";
    let counts = |lanes: usize| {
        let (_d, mut sim) = probe(src, lanes);
        let ids: Vec<FishId> = (0..4)
            .map(|i| {
                spawn(
                    &mut sim,
                    Vec3::new(-300.0 + 150.0 * i as f32, 200.0, 0.0),
                    Some("probe"),
                )
            })
            .collect();
        sim.run(0.2); // 12 ticks: every fish decides at least once
        ids.iter()
            .map(|&id| sim.memory_json(id)["n"].as_i64().unwrap())
            .collect::<Vec<_>>()
    };
    // Slot i first decides on tick (6 - i) % 6: fish 0, then 3, 2, 1.
    assert_eq!(counts(1), [1, 4, 3, 2]);
    // In lanes, each lane counts its own fish, in that same order.
    let lanes = 2;
    let order = [0u32, 3, 2, 1];
    let mut expected = [0i64; 4];
    let mut seen = vec![0i64; lanes];
    for i in order {
        let lane = lane_index(
            FishId {
                index: i,
                generation: 0,
            },
            lanes,
        );
        seen[lane] += 1;
        expected[i as usize] = seen[lane];
    }
    assert!(
        seen.iter().all(|&n| n > 0),
        "both lanes hold some of the 4 fish"
    );
    assert_eq!(counts(lanes), expected);
}

/// The fish due on one tick share their slot index modulo the decision period; the lanes must
/// still split them evenly, or one lane does a tick's work while the other waits.
#[test]
fn test_each_ticks_decisions_spread_over_the_lanes() {
    for period in [1u32, 2, 3, 6, 12] {
        for lanes in 2..=4usize {
            for residue in 0..period {
                let mut per_lane = vec![0usize; lanes];
                let due: Vec<u32> = (0..12_000).filter(|i| i % period == residue).collect();
                for &i in &due {
                    per_lane[lane_index(
                        FishId {
                            index: i,
                            generation: 0,
                        },
                        lanes,
                    )] += 1;
                }
                let fair = due.len() / lanes;
                for (lane, &n) in per_lane.iter().enumerate() {
                    assert!(
                        n * 10 >= fair * 9 && n * 10 <= fair * 11,
                        "period {period}, residue {residue}, {lanes} lanes: lane {lane} gets {n} of {}",
                        due.len()
                    );
                }
            }
        }
    }
}

/// Motion requests made in a lane reach the fish's own motion player (checked out for the
/// decision and put back), and queue reads inside the decision see them.
#[test]
fn test_requests_from_every_lane_reach_their_fish() {
    let (_d, mut sim) = probe(
        "return { tick = function(fish)\n  if not fish.memory.asked then\n    shoal.swim(80)\n    shoal.stop(1)\n    local _, queued = shoal.motion()\n    fish.memory.queued = queued\n    fish.memory.asked = true\n  end\nend }\n",
        3,
    );
    let ids: Vec<FishId> = (0..6)
        .map(|i| {
            spawn(
                &mut sim,
                Vec3::new(-300.0 + 100.0 * i as f32, 200.0, 0.0),
                Some("probe"),
            )
        })
        .collect();
    sim.run(0.1);
    for &id in &ids {
        assert_eq!(sim.memory_json(id)["queued"], 2, "{:?}", sim.inspect(id));
        // Back in the world: swim played (it only sets the speed), the stop plays or waits.
        let playing = sim.world().current_motion(id).unwrap();
        let queued = sim.world().queue_len(id).unwrap();
        assert!(
            (playing, queued) == ("stop", 0) || (playing, queued) == ("swim", 1),
            "{playing} + {queued} queued"
        );
    }
}
