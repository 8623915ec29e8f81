//! The shipped behaviours do what they say: measurable outcomes over simulated seconds.

use crate::common;

use glam::Vec3;
use shoal_core::world::FishId;
use shoal_script::Simulation;

fn polarization(sim: &Simulation, ids: &[FishId]) -> f32 {
    let mut sum = glam::Vec2::ZERO;
    for &id in ids {
        let h = sim.world().root(id).unwrap().heading;
        sum += glam::Vec2::new(h.cos(), h.sin());
    }
    sum.length() / ids.len() as f32
}

fn centroid(sim: &Simulation, ids: &[FishId]) -> Vec3 {
    ids.iter()
        .map(|&i| sim.world().root(i).unwrap().pos)
        .sum::<Vec3>()
        / ids.len() as f32
}

#[test]
fn test_hungry_forager_eats_food_and_hunger_falls() {
    let mut sim = common::sim(7);
    let fish = sim
        .spawn(
            "black_porgy",
            Vec3::new(-100.0, 200.0, 0.0),
            0.0,
            0.0,
            None,
            Some("forage"),
        )
        .unwrap();
    let food = sim.world_mut().add_food(Vec3::new(150.0, 230.0, 80.0));
    sim.run(20.0);
    let f = *sim.world().food(food).unwrap();
    assert!(f.eaten, "{:?}", sim.inspect(fish));
    assert_eq!(f.eaten_by, Some(fish));
    let m = sim.memory_json(fish);
    assert_eq!(m["meals"], 1);
    // 0.5 at the start + 0.01/s, minus one meal of 0.4.
    let hunger = m["hunger"].as_f64().unwrap();
    assert!(
        (hunger - (0.5 + 0.01 * 20.0 - 0.4)).abs() < 0.02,
        "{hunger}"
    );
    common::assert_no_script_errors(&sim);
}

#[test]
fn test_hunger_rises_without_food() {
    let mut sim = common::sim(7);
    let fish = sim
        .spawn(
            "black_porgy",
            Vec3::new(0.0, 200.0, 0.0),
            0.0,
            0.0,
            None,
            Some("forage"),
        )
        .unwrap();
    sim.run(1.0);
    let h1 = sim.memory_json(fish)["hunger"].as_f64().unwrap();
    sim.run(10.0);
    let h2 = sim.memory_json(fish)["hunger"].as_f64().unwrap();
    assert!((h2 - h1 - 0.1).abs() < 0.005, "{h1} → {h2}");
    let intention = sim
        .inspect(fish)
        .into_iter()
        .find(|(k, _)| k == "intention");
    assert_eq!(intention.map(|(_, v)| v), Some("search".to_owned()));
}

#[test]
fn test_school_polarization_rises() {
    let mut sim = common::sim(11);
    // A wide tank so the measure is about schooling, not about wheeling at the walls.
    sim.set_tank(
        Vec3::new(-2000.0, 0.0, -2000.0),
        Vec3::new(2000.0, 400.0, 2000.0),
    )
    .unwrap();
    let mut ids = Vec::new();
    for i in 0..20 {
        let (x, z) = ((i % 5) as f32 * 45.0 - 90.0, (i / 5) as f32 * 45.0 - 70.0);
        // Headings spread over the whole circle: polarization starts near 0.
        let heading = i as f32 * 2.4;
        ids.push(
            sim.spawn(
                "black_porgy",
                Vec3::new(x, 200.0, z),
                heading,
                0.0,
                None,
                Some("school"),
            )
            .unwrap(),
        );
    }
    let p0 = polarization(&sim, &ids);
    sim.run(30.0);
    let p1 = polarization(&sim, &ids);
    assert!(p0 < 0.3, "start {p0}");
    assert!(p1 > 0.8, "polarization {p0} → {p1}");
    common::assert_no_script_errors(&sim);
}

#[test]
fn test_school_keeps_its_distance() {
    let mut sim = common::sim(12);
    let mut ids = Vec::new();
    for i in 0..12 {
        let (x, z) = ((i % 4) as f32 * 30.0, (i / 4) as f32 * 30.0);
        ids.push(
            sim.spawn(
                "black_porgy",
                Vec3::new(x, 200.0, z),
                0.3,
                0.0,
                None,
                Some("school"),
            )
            .unwrap(),
        );
    }
    sim.run(20.0);
    let c = centroid(&sim, &ids);
    let mut nearest_sum = 0.0;
    for &a in &ids {
        let pa = sim.world().root(a).unwrap().pos;
        let nearest = ids
            .iter()
            .filter(|&&b| b != a)
            .map(|&b| sim.world().root(b).unwrap().pos.distance(pa))
            .fold(f32::INFINITY, f32::min);
        nearest_sum += nearest;
        assert!(pa.distance(c) < 400.0, "a fish strayed from the school");
    }
    let mean = nearest_sum / ids.len() as f32;
    // About a body length (50) apart: neither piled up nor scattered.
    assert!(
        (20.0..120.0).contains(&mean),
        "mean nearest-neighbour distance {mean}"
    );
}

#[test]
fn test_flee_increases_distance_from_a_predator() {
    let mut sim = common::sim(3);
    let prey = sim
        .spawn(
            "black_porgy",
            Vec3::new(0.0, 200.0, 0.0),
            std::f32::consts::PI,
            0.0,
            Some(20.0),
            Some("flee"),
        )
        .unwrap();
    // A predator 150 units away, in view, swimming slowly after it (no script).
    let pred = sim
        .spawn(
            "barracuda",
            Vec3::new(-150.0, 200.0, 0.0),
            0.0,
            0.0,
            Some(20.0),
            None,
        )
        .unwrap();
    sim.world_mut().rebuild_grid();
    let d0 = sim
        .world()
        .root(prey)
        .unwrap()
        .pos
        .distance(sim.world().root(pred).unwrap().pos);
    sim.run(2.0);
    assert!(sim.memory_json(prey)["fear"].as_f64().unwrap() > 0.5);
    let intention = sim
        .inspect(prey)
        .into_iter()
        .find(|(k, _)| k == "intention");
    assert_eq!(intention.map(|(_, v)| v), Some("flee".to_owned()));
    sim.run(4.0);
    let d1 = sim
        .world()
        .root(prey)
        .unwrap()
        .pos
        .distance(sim.world().root(pred).unwrap().pos);
    assert!(d1 > d0 + 100.0, "{d0} → {d1}");
}

#[test]
fn test_predator_closes_in_on_porgies() {
    let mut sim = common::sim(4);
    let pred = sim
        .spawn(
            "barracuda",
            Vec3::new(-200.0, 200.0, 0.0),
            0.0,
            0.0,
            None,
            Some("predator"),
        )
        .unwrap();
    let prey = sim
        .spawn(
            "black_porgy",
            Vec3::new(100.0, 200.0, 50.0),
            0.0,
            0.0,
            Some(20.0),
            None,
        )
        .unwrap();
    sim.world_mut().rebuild_grid();
    let mut closest = f32::INFINITY;
    for _ in 0..(15 * 60) {
        sim.step();
        let d = sim
            .world()
            .root(pred)
            .unwrap()
            .pos
            .distance(sim.world().root(prey).unwrap().pos);
        closest = closest.min(d);
    }
    let m = sim.memory_json(pred);
    assert!(
        m["catches"].as_i64().unwrap_or(0) >= 1 || closest < 40.0,
        "closest {closest}, memory {m}"
    );
    common::assert_no_script_errors(&sim);
}

#[test]
fn test_wanderers_avoid_rocks_and_walls() {
    let mut sim = common::sim(9);
    sim.world_mut()
        .add_obstacle(Vec3::new(200.0, 200.0, 0.0), 60.0);
    let mut ids = Vec::new();
    for i in 0..6 {
        ids.push(
            sim.spawn(
                "black_porgy",
                Vec3::new(-100.0, 150.0 + 20.0 * i as f32, -100.0 + 40.0 * i as f32),
                0.0,
                0.0,
                None,
                Some("wander"),
            )
            .unwrap(),
        );
    }
    let mut contacts = 0;
    let ticks = 40 * 60;
    for _ in 0..ticks {
        sim.step();
        contacts += ids
            .iter()
            .filter(|&&i| sim.world().body_sense(i).unwrap().contact)
            .count();
    }
    // Contact is the world's hard stop; avoidance should make it rare.
    assert!(
        (contacts as f32) < 0.02 * (ticks * ids.len()) as f32,
        "{contacts} contact ticks"
    );
}

#[test]
fn test_runs_are_reproducible() {
    let run = || {
        let mut sim = common::sim(21);
        let ids: Vec<FishId> = (0..8)
            .map(|i| {
                sim.spawn(
                    "black_porgy",
                    Vec3::new(-150.0 + 40.0 * i as f32, 200.0, 0.0),
                    i as f32,
                    0.0,
                    None,
                    Some("school"),
                )
                .unwrap()
            })
            .collect();
        sim.run(5.0);
        ids.iter()
            .map(|&i| *sim.world().root(i).unwrap())
            .collect::<Vec<_>>()
    };
    assert_eq!(run(), run());
}
