//! The world's fish: handles, validation at the boundary, sensors, steering and contact.

use crate::world_common;

use std::f32::consts::{FRAC_PI_2, PI};

use glam::Vec3;
use proptest::prelude::*;
use shoal_core::motion::MotionRequest;
use shoal_core::world::{
    FishId, FoodId, ObstacleId, PerceptKind, SpawnParams, TICK_HZ, WorldError,
};
use world_common::{L, at, spawn, tank, world};

const DT: f32 = (1.0 / TICK_HZ) as f32;

#[test]
fn despawned_handles_are_rejected_even_after_their_slot_is_reused() {
    let (mut w, porgy, _) = world();
    let a = spawn(&mut w, porgy, Vec3::new(100.0, 100.0, 100.0), 0.0);
    let b = spawn(&mut w, porgy, Vec3::new(200.0, 100.0, 100.0), 0.0);
    assert!(w.despawn(a));
    assert!(!w.despawn(a), "second despawn of the same id");
    assert!(!w.is_alive(a));
    assert!(w.root(a).is_none() && w.body_sense(a).is_none());
    // The slot is reused with a new generation; the old id still misses.
    let c = spawn(&mut w, porgy, Vec3::new(300.0, 100.0, 100.0), 0.0);
    assert_eq!(c.index, a.index);
    assert_ne!(c.generation, a.generation);
    assert!(!w.is_alive(a));
    assert_eq!(
        w.request(a, MotionRequest::Swim { speed: 1.0 }, false),
        Err(WorldError::StaleFish(a))
    );
    // The fish that moved in the dense arrays kept its own data.
    assert_eq!(w.root(b).unwrap().pos, Vec3::new(200.0, 100.0, 100.0));
    assert_eq!(w.root(c).unwrap().pos, Vec3::new(300.0, 100.0, 100.0));
    assert_eq!(w.num_fish(), 2);
    let ids: Vec<FishId> = w.fish_ids().collect();
    assert_eq!(ids, vec![b, c]);
    // Palette ranges follow the dense order after the swap: 7 slots per fish (the placement
    // and the 6 driven joints' entries; the 10 joints' other entries are copies of these).
    w.update_pose();
    assert_eq!(w.num_palette_slots(porgy), 7);
    assert_eq!(w.palette_range(b), Some(0..7));
    assert_eq!(w.palette_range(c), Some(7..14));
    assert_eq!(w.palette_range(a), None);
}

#[test]
fn spawn_refuses_nan_infinity_negative_speed_and_outside_positions() {
    let (mut w, porgy, _) = world();
    let good = at(porgy, Vec3::new(100.0, 100.0, 100.0), 0.0);
    let nan_y = SpawnParams {
        pos: Vec3::new(100.0, f32::NAN, 100.0),
        ..good.clone()
    };
    let err = w.spawn(nan_y).unwrap_err();
    assert!(
        matches!(
            err,
            WorldError::NonFinite {
                what: "spawn pos.y",
                ..
            }
        ),
        "{err}"
    );
    assert!(err.to_string().contains("spawn pos.y"), "{err}");
    let inf_heading = SpawnParams {
        heading: f32::INFINITY,
        ..good.clone()
    };
    assert!(matches!(
        w.spawn(inf_heading),
        Err(WorldError::NonFinite {
            what: "spawn heading",
            ..
        })
    ));
    let backwards = SpawnParams {
        speed: -1.0,
        ..good.clone()
    };
    assert!(matches!(
        w.spawn(backwards),
        Err(WorldError::OutOfRange {
            what: "spawn speed",
            ..
        })
    ));
    let outside = SpawnParams {
        pos: Vec3::new(-1.0, 100.0, 100.0),
        ..good.clone()
    };
    assert!(matches!(
        w.spawn(outside),
        Err(WorldError::OutsideTank { .. })
    ));
    let unknown = SpawnParams {
        species: shoal_core::world::SpeciesId(9),
        ..good.clone()
    };
    assert!(matches!(
        w.spawn(unknown),
        Err(WorldError::UnknownSpecies(_))
    ));
    assert_eq!(w.num_fish(), 0, "nothing half-spawned");
    assert!(w.spawn(good).is_ok());
}

#[test]
fn requests_and_steering_refuse_non_finite_values() {
    let (mut w, porgy, _) = world();
    let id = spawn(&mut w, porgy, Vec3::new(100.0, 100.0, 100.0), 0.0);
    let err = w
        .request(
            id,
            MotionRequest::Accelerate {
                speed: 10.0,
                duration: f32::NAN,
            },
            false,
        )
        .unwrap_err();
    assert!(err.to_string().contains("accelerate duration"), "{err}");
    assert!(matches!(
        w.steer_to(id, 0.0, f32::NAN, 1.0),
        Err(WorldError::NonFinite {
            what: "steer depth",
            ..
        })
    ));
    for _ in 0..10 {
        w.step_motion(DT);
    }
    let r = w.root(id).unwrap();
    assert!(r.pos.is_finite() && r.heading.is_finite());
}

/// Every live fish within `radius` of `pos`, by the same inclusive test the grid makes
/// (d² ≤ r²): comparing `distance(..) <= radius` instead disagrees with it for a fish whose
/// squared distance rounds just above r² but whose square root rounds to r exactly.
fn brute_force(w: &shoal_core::world::World, pos: Vec3, radius: f32) -> Vec<FishId> {
    let mut v: Vec<FishId> = w
        .fish_ids()
        .filter(|&id| w.root(id).unwrap().pos.distance_squared(pos) <= radius * radius)
        .collect();
    v.sort();
    v
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(40))]

    /// World::neighbors equals a brute-force scan, also with fish spawned and despawned since the
    /// grid was last rebuilt.
    #[test]
    fn neighbors_equal_brute_force(
        fish in prop::collection::vec((0.0f32..1.0, 0.0f32..1.0, 0.0f32..1.0), 1..120),
        late in prop::collection::vec((0.0f32..1.0, 0.0f32..1.0, 0.0f32..1.0), 0..20),
        kill in prop::collection::vec(any::<prop::sample::Index>(), 0..10),
        queries in prop::collection::vec(((0.0f32..1.0, 0.0f32..1.0, 0.0f32..1.0), 0.0f32..400.0), 1..10),
    ) {
        let (mut w, porgy, _) = world();
        let t = tank();
        let place = |(x, y, z): (f32, f32, f32)| t.min + (t.max - t.min) * Vec3::new(x, y, z);
        let ids: Vec<FishId> = fish.iter().map(|&p| spawn(&mut w, porgy, place(p), 0.0)).collect();
        w.rebuild_grid();
        for &p in &late {
            spawn(&mut w, porgy, place(p), 0.0);
        }
        for k in &kill {
            w.despawn(ids[k.index(ids.len())]);
        }
        let mut out = Vec::new();
        for (p, r) in queries {
            w.neighbors(place(p), r, &mut out);
            out.sort();
            prop_assert_eq!(&out, &brute_force(&w, place(p), r));
        }
        w.rebuild_grid();
        for &id in &ids {
            if let Some(root) = w.root(id) {
                w.neighbors(root.pos, 150.0, &mut out);
                out.sort();
                prop_assert_eq!(&out, &brute_force(&w, root.pos, 150.0));
            }
        }
    }
}

#[test]
fn vision_respects_range_and_angle_sorts_nearest_first_and_signs_bearings() {
    let (mut w, porgy, shark) = world();
    let eye = Vec3::new(500.0, 200.0, 250.0);
    // Facing +x; the view cone is 300° (150° either side), the range 4 L = 200.
    let me = spawn(&mut w, porgy, eye, 0.0);
    let ahead_left = spawn(&mut w, porgy, eye + Vec3::new(60.0, 0.0, -60.0), 1.0);
    let near_right = spawn(&mut w, porgy, eye + Vec3::new(0.0, 0.0, 40.0), 0.0);
    let above = spawn(&mut w, porgy, eye + Vec3::new(0.0, 100.0, 0.0), 0.0);
    let _behind = spawn(&mut w, porgy, eye + Vec3::new(-100.0, 0.0, 5.0), 0.0); // 177° off
    let _far = spawn(&mut w, porgy, eye + Vec3::new(250.0, 0.0, 0.0), 0.0);
    let predator = spawn(&mut w, shark, eye + Vec3::new(150.0, 0.0, 0.0), PI);
    let food = w.add_food(eye + Vec3::new(30.0, -10.0, 0.0));
    let rock = w.add_obstacle(eye + Vec3::new(0.0, 0.0, -170.0), 20.0);
    let eaten = w.add_food(eye + Vec3::new(25.0, 0.0, 60.0));
    w.rebuild_grid();
    // Spawned after the rebuild: still seen. It eats the pellet 5 units from its mouth
    // (reach 0.3 L = 15), which then is no longer seen.
    let eater = spawn(&mut w, porgy, eye + Vec3::new(20.0, 0.0, 60.0), PI);
    assert!(w.try_eat(eater, eaten));
    assert!(!w.try_eat(eater, eaten), "eaten food cannot be eaten twice");
    assert!(!w.try_eat(eater, food), "out of reach");

    let mut seen = Vec::new();
    w.vision(me, &mut seen);
    let dist: Vec<f32> = seen.iter().map(|p| p.distance).collect();
    assert!(
        dist.windows(2).all(|d| d[0] <= d[1]),
        "nearest first: {dist:?}"
    );
    let names: Vec<(PerceptKind, Option<FishId>)> = seen.iter().map(|p| (p.kind, p.fish)).collect();
    assert_eq!(
        names,
        vec![
            (PerceptKind::Food, None),               // 31.6
            (PerceptKind::Fish, Some(near_right)),   // 40
            (PerceptKind::Fish, Some(eater)),        // 63.2
            (PerceptKind::Fish, Some(ahead_left)),   // 84.9
            (PerceptKind::Fish, Some(above)),        // 100
            (PerceptKind::Obstacle, None),           // 150 to the surface
            (PerceptKind::Predator, Some(predator)), // 150
        ]
    );
    let by_fish = |id| seen.iter().find(|p| p.fish == Some(id)).unwrap();
    assert!(
        (by_fish(ahead_left).bearing - PI / 4.0).abs() < 1e-5,
        "left is +"
    );
    assert!(
        (by_fish(near_right).bearing + FRAC_PI_2).abs() < 1e-5,
        "right is −"
    );
    assert!((by_fish(above).elevation - FRAC_PI_2).abs() < 1e-5);
    assert_eq!(by_fish(ahead_left).heading, 1.0);
    assert_eq!(by_fish(predator).species, Some(shark));
    let rock_seen = seen
        .iter()
        .find(|p| p.kind == PerceptKind::Obstacle)
        .unwrap();
    assert_eq!(rock_seen.obstacle, Some(rock));
    assert!((rock_seen.distance - 150.0).abs() < 1e-3);
    assert_eq!(
        seen.iter()
            .find(|p| p.kind == PerceptKind::Food)
            .unwrap()
            .food,
        Some(food)
    );

    // The shark sees the porgies as fish, and not itself.
    w.vision(predator, &mut seen);
    assert!(seen.iter().all(|p| p.fish != Some(predator)));
    assert!(
        seen.iter()
            .any(|p| p.fish == Some(me) && p.kind == PerceptKind::Fish)
    );

    // A stale id sees nothing.
    w.despawn(me);
    w.vision(me, &mut seen);
    assert!(seen.is_empty());
    let _ = ObstacleId(0);
}

#[test]
fn body_sense_measures_the_tank() {
    let (mut w, porgy, _) = world();
    // Tank is 1000 × 400 × 500.
    let id = spawn(&mut w, porgy, Vec3::new(900.0, 150.0, 230.0), 0.3);
    let s = w.body_sense(id).unwrap();
    assert_eq!(s.depth, 250.0);
    assert_eq!(s.to_surface, 250.0);
    assert_eq!(s.to_floor, 150.0);
    assert_eq!(s.to_wall, 100.0);
    assert_eq!(s.wall_normal, Vec3::NEG_X);
    assert_eq!(s.heading, 0.3);
    assert!(!s.contact);
}

#[test]
fn steer_to_picks_the_turn_kind_from_the_speed() {
    let (mut w, porgy, _) = world();
    let centre = Vec3::new(500.0, 200.0, 250.0);
    let fast = w
        .spawn(SpawnParams {
            speed: 50.0,
            ..at(porgy, centre, 0.0)
        })
        .unwrap();
    let slow = spawn(&mut w, porgy, centre + Vec3::new(0.0, 0.0, 100.0), 0.0);
    for _ in 0..60 {
        w.step_motion(DT);
    }
    let depth = 200.0;
    w.steer_to(fast, 2.5, depth, 50.0).unwrap();
    w.steer_to(slow, 2.5, depth, 0.0).unwrap();
    w.step_motion(DT);
    assert_eq!(w.current_motion(fast), Some("serial_turn"));
    assert_eq!(w.current_motion(slow), Some("quick_turn"));
    // Asking again for the same thing changes nothing (no jitter, no queue growth).
    for _ in 0..5 {
        w.steer_to(fast, 2.5, depth, 50.0).unwrap();
        w.step_motion(DT);
        assert_eq!(w.current_motion(fast), Some("serial_turn"));
        assert_eq!(w.queue_len(fast), Some(0));
    }
    // Small correction while swimming: a normal turn, to the right.
    let third = w
        .spawn(SpawnParams {
            speed: 50.0,
            ..at(porgy, centre + Vec3::new(0.0, 0.0, -100.0), 0.0)
        })
        .unwrap();
    for _ in 0..60 {
        w.step_motion(DT);
    }
    w.steer_to(third, -0.4, depth, 50.0).unwrap();
    w.step_motion(DT);
    assert_eq!(w.current_motion(third), Some("normal_turn"));
    // Carried out, the turn ends near the wished heading.
    for _ in 0..240 {
        w.steer_to(third, -0.4, depth, 50.0).unwrap();
        w.step_motion(DT);
    }
    let h = w.root(third).unwrap().heading;
    assert!((h + 0.4).abs() < 0.15, "heading {h}");
}

#[test]
fn a_fish_scripted_to_ram_a_wall_never_leaves_the_tank() {
    let (mut w, porgy, _) = world();
    let t = tank();
    let id = w
        .spawn(SpawnParams {
            speed: 100.0,
            ..at(porgy, Vec3::new(800.0, 100.0, 250.0), 0.0)
        })
        .unwrap();
    let rock = w.add_obstacle(Vec3::new(300.0, 100.0, 250.0), 40.0);
    let mut touched = false;
    for tick in 0..1800 {
        // The script insists on +x, then −x through the rock, then the floor, at 3× cruise.
        let heading = if tick < 600 { 0.0 } else { PI };
        let depth = if tick < 1200 { 300.0 } else { 400.0 };
        w.steer_to(id, heading, depth, 150.0).unwrap();
        if tick % 97 == 0 {
            w.request(id, MotionRequest::Descend { depth: 500.0 }, true)
                .unwrap();
        }
        w.step_motion(DT);
        let r = w.root(id).unwrap();
        assert!(t.contains(r.pos), "tick {tick}: {r:?}");
        let o = w.obstacles()[rock.0 as usize];
        assert!(
            r.pos.distance(o.pos) >= o.radius - 1e-3,
            "tick {tick}: inside the rock {r:?}"
        );
        touched |= w.body_sense(id).unwrap().contact;
    }
    assert!(touched, "the walls were felt");
}

#[test]
fn fish_eat_food_within_reach_of_the_mouth() {
    let (mut w, porgy, _) = world();
    let id = spawn(&mut w, porgy, Vec3::new(100.0, 100.0, 100.0), 0.0);
    let near = w.add_food(Vec3::new(110.0, 100.0, 100.0)); // 10 < 0.3 L = 15
    let far = w.add_food(Vec3::new(120.0, 100.0, 100.0));
    assert!(!w.try_eat(id, far));
    assert!(w.try_eat(id, near));
    let f = w.food(near).unwrap();
    assert!(f.eaten && f.eaten_by == Some(id) && f.eaten_at == Some(0.0));
    assert!(!w.food(far).unwrap().eaten);
    assert!(!w.try_eat(id, FoodId(99)));
    let _ = L;
}

#[test]
fn vision_nearest_keeps_the_head_of_the_full_list() {
    let (mut w, porgy, _) = world();
    let centre = Vec3::new(500.0, 200.0, 250.0);
    let me = spawn(&mut w, porgy, centre, 0.0);
    for i in 0..40 {
        let a = i as f32 * 0.7;
        let r = 20.0 + (i * 37 % 150) as f32;
        spawn(
            &mut w,
            porgy,
            centre + Vec3::new(a.cos() * r, (i % 5) as f32 * 7.0, a.sin() * r),
            a,
        );
    }
    w.add_food(centre + Vec3::new(35.0, 0.0, 0.0));
    w.rebuild_grid();
    let mut all = Vec::new();
    let mut few = Vec::new();
    w.vision(me, &mut all);
    assert!(all.len() > 10, "{}", all.len());
    for max in [0, 1, 5, 10, all.len(), all.len() + 3] {
        w.vision_nearest(me, max, &mut few);
        assert_eq!(few.as_slice(), &all[..max.min(all.len())], "max {max}");
    }
}

#[test]
fn vision_batch_equals_one_query_per_fish_on_any_thread_count() {
    let (mut w, porgy, shark) = world();
    let t = tank();
    for i in 0..150u32 {
        let f = |k: u32| ((i * k) % 97) as f32 / 97.0;
        let pos = t.min + (t.max - t.min) * Vec3::new(f(13), f(29), f(53));
        let species = if i % 25 == 0 { shark } else { porgy };
        spawn(&mut w, species, pos, i as f32 * 0.37);
    }
    w.add_food(Vec3::new(400.0, 200.0, 200.0));
    w.add_obstacle(Vec3::new(600.0, 200.0, 300.0), 40.0);
    w.rebuild_grid();
    let mut ids: Vec<FishId> = w.fish_ids().collect();
    let gone = ids[10];
    w.despawn(gone); // a stale id in the batch gets an empty list
    ids.reverse();
    let mut one = Vec::new();
    for threads in [1, 2] {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        let mut batch = shoal_core::world::VisionBatch::default();
        pool.install(|| w.vision_batch(&ids, 8, &mut batch));
        assert_eq!(batch.len(), ids.len());
        let mut total = 0;
        for (i, &id) in ids.iter().enumerate() {
            w.vision_nearest(id, 8, &mut one);
            assert_eq!(batch.get(i), one.as_slice(), "fish {i}, {threads} threads");
            total += one.len();
        }
        assert!(total > 300, "the scene is not empty: {total}");
        assert!(
            batch
                .get(ids.iter().position(|&i| i == gone).unwrap())
                .is_empty()
        );
    }
}

/// Fish running one behaviour share its name's allocation (the behaviour stage finds a fish's
/// module by that pointer), a switch to a name some fish already runs shares it too, and
/// another name gets its own.
#[test]
fn fish_running_one_behaviour_share_its_name() {
    let (mut w, porgy, _) = world();
    let with = |name: &str, x: f32| SpawnParams {
        behavior: Some(name.to_owned()),
        ..at(porgy, Vec3::new(x, 100.0, 100.0), 0.0)
    };
    let a = w.spawn(with("school", 100.0)).unwrap();
    let b = w.spawn(with("forage", 200.0)).unwrap();
    let c = w.spawn(with("school", 300.0)).unwrap();
    let name = |w: &shoal_core::world::World, id| w.behavior_name_of(id).unwrap().clone();
    assert!(std::sync::Arc::ptr_eq(&name(&w, a), &name(&w, c)));
    assert!(!std::sync::Arc::ptr_eq(&name(&w, a), &name(&w, b)));
    assert!(w.set_behavior(b, Some("school".to_owned())));
    assert!(std::sync::Arc::ptr_eq(&name(&w, a), &name(&w, b)));
    assert_eq!(w.behavior_of(b), Some("school"));
    assert!(w.set_behavior(c, Some("wander".to_owned())));
    assert_eq!(w.behavior_of(c), Some("wander"));
    assert!(!std::sync::Arc::ptr_eq(&name(&w, a), &name(&w, c)));
}
