//! The world's state as plain data (issue 12): a snapshot can be compared and restored, a
//! restored world runs the same future, and eaten food leaves the world (so what perception
//! scans does not grow over a long session).

use glam::Vec3;
use shoal_core::world::bench::bench_world;
use shoal_core::world::driver::{WanderDriver, WanderPipeline};
use shoal_core::world::{
    EATEN_HISTORY, FoodDrops, PerceptKind, SpawnParams, Species, SpeciesDesc, Tank, World,
};

fn porgy() -> Species {
    let assets = shoal_core::source_root().join("assets");
    Species::load(SpeciesDesc::black_porgy(), &assets).expect("porgy loads")
}

/// Every fish's root, bit for bit, and the palettes' first matrices.
fn fingerprint(w: &World) -> Vec<u32> {
    let mut out = Vec::new();
    for r in w.roots() {
        out.extend(r.pos.to_array().map(f32::to_bits));
        out.extend([r.heading.to_bits(), r.pitch.to_bits(), r.speed.to_bits()]);
    }
    for m in w.palettes().iter().step_by(7) {
        out.extend(m.to_cols_array().map(f32::to_bits));
    }
    out
}

#[test]
fn a_restored_world_runs_the_same_future_bit_for_bit() {
    let mut sim = WanderPipeline::new(
        bench_world(porgy(), 300, 11).unwrap(),
        WanderDriver::default(),
    );
    for _ in 0..45 {
        sim.tick();
    }
    let snapshot = sim.world().snapshot();
    assert_eq!(&snapshot, sim.world().state());
    let mut first = Vec::new();
    for _ in 0..90 {
        sim.tick();
        first.push(fingerprint(sim.world()));
    }
    assert_ne!(&snapshot, sim.world().state(), "ticking changes the state");
    let after = sim.world().snapshot();

    sim.world_mut().restore(snapshot.clone()).unwrap();
    assert_eq!(sim.world().state(), &snapshot);
    assert_eq!(sim.world().tick_count(), 45);
    for (k, expected) in first.iter().enumerate() {
        sim.tick();
        assert_eq!(
            &fingerprint(sim.world()),
            expected,
            "tick {} after the restore",
            k + 1
        );
    }
    assert_eq!(sim.world().state(), &after);
}

#[test]
fn a_state_restores_into_a_fresh_world_with_the_same_species() {
    let mut a = WanderPipeline::new(
        bench_world(porgy(), 120, 5).unwrap(),
        WanderDriver::default(),
    );
    for _ in 0..30 {
        a.tick();
    }
    let state = a.world().snapshot();
    // Another world: same species, different fish, tank and seed.
    let mut b = WanderPipeline::new(
        bench_world(porgy(), 10, 99).unwrap(),
        WanderDriver::default(),
    );
    b.world_mut().restore(state).unwrap();
    assert_eq!(b.world().num_fish(), 120);
    assert_eq!(b.world().tank(), a.world().tank());
    for _ in 0..30 {
        a.tick();
        b.tick();
    }
    assert_eq!(fingerprint(a.world()), fingerprint(b.world()));
    assert_eq!(a.world().state(), b.world().state());

    // A state naming a species the world does not have is refused, and the world is unchanged.
    let empty = World::new(*a.world().tank(), 1);
    let mut c = empty;
    let before = c.snapshot();
    let err = c.restore(a.world().snapshot()).unwrap_err();
    assert!(err.to_string().contains("no species"), "{err}");
    assert_eq!(c.state(), &before);
}

fn one_fish_world() -> (World, shoal_core::world::FishId, Vec3) {
    let tank = Tank {
        min: Vec3::new(-400.0, 0.0, -300.0),
        max: Vec3::new(400.0, 300.0, 300.0),
    };
    let mut w = World::new(tank, 3);
    let sid = w.add_species(porgy());
    let pos = Vec3::new(0.0, 150.0, 0.0);
    let id = w
        .spawn(SpawnParams {
            species: sid,
            pos,
            heading: 0.0,
            pitch: 0.0,
            speed: 0.0,
            behavior: None,
            seed: 1,
        })
        .unwrap();
    w.rebuild_grid();
    (w, id, pos)
}

#[test]
fn eaten_food_leaves_the_world_and_its_grid() {
    let (mut w, id, mouth) = one_fish_world();
    let ahead = mouth + Vec3::new(60.0, 0.0, 0.0);
    let bite = w.add_food(mouth + Vec3::new(1.0, 0.0, 0.0));
    let seen = w.add_food(ahead);
    w.rebuild_grid();
    let in_view = |w: &World| {
        let mut v = Vec::new();
        w.vision(id, &mut v);
        v.iter()
            .filter(|p| p.kind == PerceptKind::Food)
            .map(|p| p.food.unwrap())
            .collect::<Vec<_>>()
    };
    assert_eq!(in_view(&w), vec![bite, seen]);
    assert!(w.try_eat(id, bite));
    assert!(!w.try_eat(id, bite), "a pellet is eaten once");
    // Gone from the water at once (before any rebuild) and after the next rebuild.
    assert_eq!(in_view(&w), vec![seen]);
    assert_eq!(w.foods().map(|(f, _)| f).collect::<Vec<_>>(), vec![seen]);
    w.rebuild_grid();
    assert_eq!(in_view(&w), vec![seen]);
    assert_eq!(
        w.nearest_in_view(id, PerceptKind::Food, None).unwrap().food,
        Some(seen)
    );
    // Who ate it and when is still known.
    let f = w.food(bite).unwrap();
    assert!(f.eaten && f.eaten_by == Some(id));
    assert!(w.was_eaten(bite) && !w.was_eaten(seen));
    // Ids are never given twice.
    let next = w.add_food(ahead);
    assert!(next > seen);
}

#[test]
fn over_a_long_session_the_food_perception_scans_stays_bounded() {
    // An hour of the default scene's drops (3 pellets every 5 s), each eaten soon after it
    // falls: before, every pellet ever dropped stayed in the food list and its grid.
    let (mut w, id, mouth) = one_fish_world();
    w.set_food_drops(Some(FoodDrops {
        every: 5.0,
        count: 3,
        start: 0.0,
        region: Some((mouth, mouth + Vec3::splat(1.0))),
    }));
    let mut eaten = 0;
    let mut first = None;
    let mut most_in_water = 0;
    for _ in 0..(3600 * 60 / 10) {
        // Ten ticks at a time: drops, then motion (the fish stays put at speed 0).
        for _ in 0..10 {
            w.scene_events();
            w.step_motion(1.0 / 60.0);
        }
        w.rebuild_grid();
        most_in_water = most_in_water.max(w.state().num_foods());
        let pellets: Vec<_> = w.foods().map(|(f, _)| f).collect();
        for f in pellets {
            first.get_or_insert(f);
            eaten += usize::from(w.try_eat(id, f));
        }
    }
    assert_eq!(eaten, 3 * 720, "every pellet of an hour's drops was eaten");
    assert_eq!(w.state().num_foods(), 0, "none is left in the water");
    assert!(
        most_in_water <= 3,
        "at most one drop in the water: {most_in_water}"
    );
    assert_eq!(w.eaten_foods().count(), EATEN_HISTORY.min(eaten));
    let first = first.unwrap();
    assert!(w.was_eaten(first), "an early pellet still reads as eaten");
}
