//! Pellets in the water: sinking, settling on the floor and on rocks, drifting with currents,
//! dissolving, and the eaten history they leave.

use crate::world_common;

use glam::Vec3;
use shoal_core::world::{Current, FoodPhysics, PerceptKind, TICK_DT, TICK_HZ, World};
use world_common::{spawn, tank, world};

/// Runs the motion stage (which moves the pellets) and the grid stage for `seconds`.
fn run(w: &mut World, seconds: f64) {
    for _ in 0..(seconds * TICK_HZ).round() as u64 {
        w.step_motion(TICK_DT);
        w.rebuild_grid();
    }
}

fn sinking(speed: f32) -> FoodPhysics {
    FoodPhysics {
        sink_speed: speed,
        lifetime: None,
    }
}

#[test]
fn by_default_a_pellet_stays_where_it_was_dropped() {
    let (mut w, _, _) = world();
    let at = Vec3::new(300.0, 350.0, 200.0);
    let id = w.add_food(at);
    run(&mut w, 5.0);
    let f = w.food(id).expect("still in the water");
    assert_eq!(f.pos, at);
    assert!(!f.settled);
}

#[test]
fn a_pellet_sinks_at_the_scene_speed_and_settles_on_the_floor() {
    let (mut w, _, _) = world();
    w.set_food_physics(sinking(20.0));
    let id = w.add_food(Vec3::new(300.0, 300.0, 200.0));
    run(&mut w, 2.0);
    let f = *w.food(id).unwrap();
    assert!(
        (f.pos.y - 260.0).abs() < 0.05,
        "20 units/s for 2 s: {}",
        f.pos.y
    );
    assert_eq!(
        (f.pos.x, f.pos.z),
        (300.0, 200.0),
        "no current: straight down"
    );
    assert!(!f.settled);
    run(&mut w, 14.0);
    let f = *w.food(id).unwrap();
    assert_eq!(f.pos.y, tank().min.y, "on the floor");
    assert!(f.settled);
    run(&mut w, 1.0);
    assert_eq!(w.food(id).unwrap().pos, f.pos, "a settled pellet stays");
}

#[test]
fn a_pellet_settles_on_top_of_a_rock_and_slides_off_its_flank() {
    let (mut w, _, _) = world();
    w.set_food_physics(sinking(30.0));
    let centre = Vec3::new(400.0, 60.0, 200.0);
    w.add_obstacle(centre, 50.0);
    let on_top = w.add_food(Vec3::new(400.0, 300.0, 200.0));
    // 45 units off the axis: it meets the rock where the surface is steep.
    let flank = w.add_food(Vec3::new(445.0, 300.0, 200.0));
    run(&mut w, 12.0);
    let top = *w.food(on_top).unwrap();
    assert!(top.settled);
    assert!(
        (top.pos - Vec3::new(400.0, 110.0, 200.0)).length() < 0.01,
        "on the rock's top: {}",
        top.pos
    );
    let side = *w.food(flank).unwrap();
    assert!(side.settled);
    assert_eq!(side.pos.y, 0.0, "slid off onto the floor: {}", side.pos);
    assert!(
        side.pos.distance(centre) >= 50.0 - 1e-3,
        "outside the rock: {}",
        side.pos
    );
}

#[test]
fn a_current_carries_pellets_and_fish_see_them_where_they_are() {
    let (mut w, porgy, _) = world();
    w.add_current(Current {
        pos: Vec3::new(300.0, 200.0, 250.0),
        radius: 400.0,
        velocity: Vec3::new(100.0, 0.0, 0.0),
    });
    let id = w.add_food(Vec3::new(100.0, 200.0, 250.0));
    // Facing the pellet from 500 units: out of its view range (200) until the current brings
    // the pellet across the grid to within 100 units.
    let me = spawn(
        &mut w,
        porgy,
        Vec3::new(600.0, 200.0, 250.0),
        std::f32::consts::PI,
    );
    w.rebuild_grid();
    let seen_food = |w: &World| {
        let mut seen = Vec::new();
        w.vision(me, &mut seen);
        seen.into_iter().find(|p| p.kind == PerceptKind::Food)
    };
    assert!(seen_food(&w).is_none(), "out of sight at first");
    run(&mut w, 4.0);
    let f = *w.food(id).unwrap();
    assert!(
        (f.pos.x - 500.0).abs() < 0.5,
        "100 units/s for 4 s: {}",
        f.pos
    );
    let eye = w.fish(me).unwrap().root().pos;
    let food = seen_food(&w).expect("the pellet is seen where it drifted to");
    assert!(
        (food.distance - f.pos.distance(eye)).abs() < 1e-3,
        "seen at its new place: {} vs {}",
        food.distance,
        f.pos
    );
}

#[test]
fn an_uneaten_pellet_dissolves_after_the_lifetime_and_does_not_count_as_eaten() {
    let (mut w, porgy, _) = world();
    w.set_food_physics(FoodPhysics {
        sink_speed: 0.0,
        lifetime: Some(2.0),
    });
    let eye = Vec3::new(200.0, 200.0, 250.0);
    let eater = spawn(&mut w, porgy, eye, 0.0);
    let eaten = w.add_food(eye + Vec3::new(5.0, 0.0, 0.0));
    run(&mut w, 1.0);
    let late = w.add_food(Vec3::new(600.0, 200.0, 250.0));
    assert!(w.try_eat(eater, eaten));
    run(&mut w, 1.5);
    let early = w.add_food(Vec3::new(300.0, 200.0, 250.0));
    assert!(w.food(late).is_some(), "1.5 s old: still there");
    run(&mut w, 1.0);
    assert!(w.food(late).is_none(), "2.5 s old: dissolved");
    assert!(!w.was_eaten(late), "dissolved is not eaten");
    assert!(w.food(early).is_some());
    // The pellets left shifted in the list: the eater sees the one left where it is.
    let mut seen = Vec::new();
    w.vision(eater, &mut seen);
    let food = seen
        .iter()
        .find(|p| p.kind == PerceptKind::Food)
        .expect("seen");
    let mouth = w.fish(eater).unwrap().root().pos;
    assert!((food.distance - w.food(early).unwrap().pos.distance(mouth)).abs() < 1e-3);
    assert!(w.was_eaten(eaten), "the eaten pellet stays eaten");
    assert_eq!(w.eaten_foods().count(), 1);
    assert_eq!(w.foods().count(), 1);
}

#[test]
fn pellets_eaten_out_of_order_are_all_remembered() {
    let (mut w, porgy, _) = world();
    let eye = Vec3::new(200.0, 200.0, 250.0);
    let eater = spawn(&mut w, porgy, eye, 0.0);
    let first = w.add_food(eye + Vec3::new(5.0, 0.0, 0.0));
    let second = w.add_food(eye + Vec3::new(0.0, 5.0, 0.0));
    let third = w.add_food(eye + Vec3::new(0.0, 0.0, 5.0));
    // Eaten last-dropped first: the history is still searched by id.
    for id in [third, first, second] {
        assert!(w.try_eat(eater, id));
    }
    for id in [first, second, third] {
        let f = w.food(id).expect("remembered");
        assert!(f.eaten && f.eaten_by == Some(eater), "{id:?}");
        assert!(w.was_eaten(id));
    }
    let ids: Vec<_> = w.eaten_foods().map(|(id, _)| id).collect();
    assert_eq!(
        ids,
        vec![first, second, third],
        "in the order they were dropped"
    );
}

#[test]
fn nonsense_physics_are_taken_as_none() {
    let (mut w, _, _) = world();
    w.set_food_physics(FoodPhysics {
        sink_speed: f32::NAN,
        lifetime: Some(-1.0),
    });
    assert_eq!(w.food_physics(), FoodPhysics::default());
    w.set_food_physics(FoodPhysics {
        sink_speed: -5.0,
        lifetime: Some(f32::INFINITY),
    });
    assert_eq!(w.food_physics(), FoodPhysics::default());
}
