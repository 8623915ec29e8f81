//! Behaviour level of detail (issue 34): the schedule's bands, phases, wake events and minimum
//! rates, and that a run with it on is as deterministic as one without — across lane counts and
//! in a bit-exact replay, a moving focus included.

use crate::common;

use std::path::Path;

use glam::Vec3;
use shoal_core::world::lod::default_bands;
use shoal_core::world::{FishId, Lod, LodBand, WokenBy};
use shoal_script::Simulation;
use shoal_script::timeline::inputs::{Input, TimedInput};
use shoal_script::timeline::{self, RecordSpec};

/// A behaviour that counts its decisions and never moves its fish.
const COUNTER: &str =
    "return { tick = function(fish)\n  fish.memory.n = (fish.memory.n or 0) + 1\nend }\n";

/// A scratch repository whose `probe` behaviour is `src`, with the test species loaded.
fn probe(src: &str, lanes: usize) -> (tempfile::TempDir, Simulation) {
    let (dir, root) = common::scratch_repo();
    std::fs::write(root.join("scripts/behaviors/probe.lua"), src).unwrap();
    let mut sim = common::sim_in(&root, 3);
    sim.set_lanes(lanes).unwrap();
    (dir, sim)
}

/// [`probe`] of [`COUNTER`] on one lane, with level of detail set to `lod`.
fn counter_with(lod: Lod) -> (tempfile::TempDir, Simulation) {
    let (dir, mut sim) = probe(COUNTER, 1);
    sim.world_mut().set_lod(lod).unwrap();
    (dir, sim)
}

/// Level of detail on, with no wall lookahead: only two body lengths and the swim until a fish
/// is due count.
fn no_lookahead() -> Lod {
    Lod {
        on: true,
        wall_lookahead: 0.0,
        ..Default::default()
    }
}

/// A still fish (speed 0, heading +x) running `probe` at `pos`.
fn still(sim: &mut Simulation, pos: Vec3) -> FishId {
    swimming(sim, pos, 0.0, 0.0)
}

/// A porgy's body length in this world (the test species).
fn porgy_length(sim: &Simulation) -> f32 {
    sim.world()
        .species(sim.world().species_by_name("black_porgy").unwrap())
        .body_length()
}

/// A still fish of `species` (speed 0, heading +x) at `pos`, running `behavior`.
fn still_of(sim: &mut Simulation, species: &str, pos: Vec3, behavior: Option<&str>) -> FishId {
    sim.spawn(species, pos, 0.0, 0.0, Some(0.0), behavior)
        .unwrap()
}

/// A fish running `probe` at `pos`, heading `heading` (radians, pitch 0) at `speed`.
fn swimming(sim: &mut Simulation, pos: Vec3, heading: f32, speed: f32) -> FishId {
    sim.spawn("black_porgy", pos, heading, 0.0, Some(speed), Some("probe"))
        .unwrap()
}

fn decisions(sim: &Simulation, id: FishId) -> u64 {
    sim.memory_json(id)["n"].as_u64().unwrap_or(0)
}

/// Twelve still fish in mid-water, far from the walls and from each other's view of anything,
/// and more than half a body length apart (nearer, they would wake each other).
fn row(sim: &mut Simulation, x: f32) -> Vec<FishId> {
    (0..12)
        .map(|k| {
            still(
                sim,
                Vec3::new(
                    x,
                    150.0 + 30.0 * (k % 3) as f32,
                    -45.0 + 30.0 * (k / 3) as f32,
                ),
            )
        })
        .collect()
}

fn bands(radii: [f32; 2]) -> Vec<LodBand> {
    capped(radii, [None, None])
}

/// [`bands`] with caps on the first two.
fn capped(radii: [f32; 2], caps: [Option<u32>; 2]) -> Vec<LodBand> {
    vec![
        LodBand {
            radius: radii[0],
            every: 1,
            cap: caps[0],
        },
        LodBand {
            radius: radii[1],
            every: 2,
            cap: caps[1],
        },
        LodBand {
            radius: f32::INFINITY,
            every: 4,
            cap: None,
        },
    ]
}

/// Off, every fish decides at its species' 10 Hz: 12 times in 72 ticks. On with no focus, every
/// fish is in the default last band (a third of the rate): exactly four times, each on its own
/// phase, so no tick holds more than its share.
#[test]
fn test_without_a_focus_every_fish_decides_at_the_last_bands_rate() {
    let every = default_bands().last().unwrap().every;
    assert_eq!(every, 3, "the default far band");
    for (on, expected) in [(false, 12), (true, 4)] {
        let (_d, mut sim) = probe(COUNTER, 2);
        sim.set_lod_on(on);
        let fish = row(&mut sim, 0.0);
        let mut per_tick = Vec::new();
        for _ in 0..72 {
            sim.step();
            per_tick.push(sim.world().lod_counts().total());
        }
        for &id in &fish {
            assert_eq!(decisions(&sim, id), expected, "lod {on}, fish {id:?}");
        }
        let most = *per_tick.iter().max().unwrap();
        let period = if on { 6 * every as usize } else { 6 };
        let share = 12usize.div_ceil(period);
        assert!(
            most as usize <= share,
            "lod {on}: a tick made {most} decisions, more than the phase spread allows ({share}): {per_tick:?}"
        );
        assert_eq!(sim.world().lod_counts().woken, 0);
    }
}

/// With a focus, each fish's band follows its distance: full rate near it, half in the middle
/// band, a quarter beyond; the counts per band say so.
#[test]
fn test_bands_follow_the_distance_to_the_focus() {
    let (_d, mut sim) = probe(COUNTER, 3);
    sim.world_mut()
        .set_lod(Lod {
            on: true,
            bands: bands([150.0, 450.0]),
            focus: vec![Vec3::new(-300.0, 180.0, 0.0)],
            wake: true,
            ..Default::default()
        })
        .unwrap();
    let near = row(&mut sim, -300.0);
    let middle = row(&mut sim, 0.0);
    let far = row(&mut sim, 300.0);
    let mut per_band = [0u32; 3];
    for _ in 0..48 {
        sim.step();
        let c = sim.world().lod_counts();
        assert_eq!(c.fish[..3], [12, 12, 12], "fish per band");
        for (b, n) in per_band.iter_mut().zip(c.decisions) {
            *b += n;
        }
    }
    for (fish, expected) in [(&near, 8), (&middle, 4), (&far, 2)] {
        for &id in fish {
            assert_eq!(decisions(&sim, id), expected, "fish {id:?}");
        }
    }
    assert_eq!(per_band, [96, 48, 24]);
    // Moving the focus moves the bands: now the far row is near.
    sim.set_lod_focus(vec![Vec3::new(300.0, 180.0, 0.0)]);
    let before: Vec<u64> = far.iter().map(|&id| decisions(&sim, id)).collect();
    for _ in 0..48 {
        sim.step();
    }
    for (&id, b) in far.iter().zip(before) {
        assert_eq!(decisions(&sim, id), b + 8, "fish {id:?} near the new focus");
    }
}

/// A band's cap: of the twelve fish within the first band only the five nearest the focus keep
/// it, the other seven drop to the second band, whose cap of ten keeps those seven and the three
/// nearest of its own twelve; the nine left drop to the last band. Exact counts every tick, and
/// each fish decides at the rate of the band it was left in.
#[test]
fn test_a_band_holds_at_most_its_cap_and_the_nearest_keep_it() {
    let (_d, mut sim) = probe(COUNTER, 3);
    let focus = Vec3::new(-300.0, 180.0, 0.0);
    sim.world_mut()
        .set_lod(Lod {
            on: true,
            bands: capped([150.0, 450.0], [Some(5), Some(10)]),
            focus: vec![focus],
            wake: true,
            ..Default::default()
        })
        .unwrap();
    let near = row(&mut sim, -300.0);
    let middle = row(&mut sim, 0.0);
    let far = row(&mut sim, 300.0);
    let by_distance = |fish: &[FishId], sim: &Simulation| {
        let mut v: Vec<FishId> = fish.to_vec();
        v.sort_by(|a, b| {
            let d = |id: &FishId| sim.world().root(*id).unwrap().pos.distance(focus);
            d(a).total_cmp(&d(b))
        });
        v
    };
    let near_sorted = by_distance(&near, &sim);
    let middle_sorted = by_distance(&middle, &sim);
    let mut per_band = [0u32; 3];
    for _ in 0..48 {
        sim.step();
        let c = sim.world().lod_counts();
        assert_eq!(c.fish[..3], [5, 10, 21], "fish per band");
        for (b, n) in per_band.iter_mut().zip(c.decisions) {
            *b += n;
        }
    }
    assert_eq!(per_band, [5 * 8, 10 * 4, 21 * 2]);
    for (k, &id) in near_sorted.iter().enumerate() {
        let expected = if k < 5 { 8 } else { 4 };
        assert_eq!(decisions(&sim, id), expected, "near fish {k} by distance");
    }
    for (k, &id) in middle_sorted.iter().enumerate() {
        let expected = if k < 3 { 4 } else { 2 };
        assert_eq!(decisions(&sim, id), expected, "middle fish {k} by distance");
    }
    for &id in &far {
        assert_eq!(decisions(&sim, id), 2);
    }
}

/// Fish at one distance from the focus rank by slot index: with a cap of two, of four fish
/// around the focus the two spawned first keep the band.
#[test]
fn test_a_cap_breaks_ties_by_slot() {
    let (_d, mut sim) = probe(COUNTER, 2);
    let focus = Vec3::new(0.0, 180.0, 0.0);
    sim.world_mut()
        .set_lod(Lod {
            on: true,
            bands: capped([150.0, 450.0], [Some(2), None]),
            focus: vec![focus],
            wake: true,
            ..Default::default()
        })
        .unwrap();
    let fish: Vec<FishId> = [
        Vec3::new(60.0, 0.0, 0.0),
        Vec3::new(-60.0, 0.0, 0.0),
        Vec3::new(0.0, 0.0, 60.0),
        Vec3::new(0.0, 0.0, -60.0),
    ]
    .into_iter()
    .map(|o| still(&mut sim, focus + o))
    .collect();
    let mut by_slot = fish.clone();
    by_slot.sort_by_key(|id| id.index);
    for _ in 0..48 {
        sim.step();
        assert_eq!(sim.world().lod_counts().fish[..2], [2, 2]);
    }
    let counts: Vec<u64> = by_slot.iter().map(|&id| decisions(&sim, id)).collect();
    assert_eq!(counts, [8, 8, 4, 4], "lowest slots first");
}

/// A pellet in view wakes a slow fish at once (it decides on the next tick although its band
/// would wait), and fish with nothing near them sleep on.
#[test]
fn test_food_in_reach_and_a_wall_ahead_wake_a_slow_fish_at_once() {
    let (_d, mut sim) = probe(COUNTER, 2);
    sim.set_lod_on(true);
    let fish = row(&mut sim, -200.0);
    let far = still(&mut sim, Vec3::new(250.0, 200.0, 150.0));
    for _ in 0..10 {
        sim.step();
    }
    // Slot 0 decided on tick 0 (its phase in the last band is tick 0, 18, …).
    let first = fish[0];
    assert_eq!(first.index, 0);
    assert_eq!(decisions(&sim, first), 1);
    let far_before = decisions(&sim, far);
    let pos = sim.world().root(first).unwrap().pos;
    sim.world_mut().add_food(pos + Vec3::new(20.0, 0.0, 0.0));
    sim.step();
    assert_eq!(
        decisions(&sim, first),
        2,
        "the pellet woke the fish beside it"
    );
    assert!(sim.world().lod_counts().woken >= 1);
    assert_eq!(decisions(&sim, far), far_before, "the far fish saw nothing");
    // A fish heading into the wall, one body length from it, is woken as soon as it may be.
    let (_d, mut sim) = probe(COUNTER, 1);
    sim.set_lod_on(true);
    let l = porgy_length(&sim);
    let walled = still(&mut sim, Vec3::new(500.0 - l, 200.0, 0.0));
    let free = still(&mut sim, Vec3::new(-200.0, 200.0, 0.0));
    let mut woken_by_walls = 0;
    for _ in 0..48 {
        sim.step();
        let by = sim.world().lod_counts().woken_by;
        assert_eq!((by.seen, by.neighbour), (0, 0));
        woken_by_walls += by.obstacle;
    }
    // Woken each base period (every 6 ticks), not every tick: 8 decisions, 3 of them due
    // (ticks 0, 18 and 36); the free fish (slot 1) decides on ticks 17 and 35 only.
    assert_eq!(decisions(&sim, walled), 8);
    assert_eq!(decisions(&sim, free), 2);
    assert_eq!(woken_by_walls, 5);
}

/// A still fish beside a side wall, heading along it (nothing straight ahead), is woken each
/// base period: a school presses fish along the glass, and looking only ahead missed them.
#[test]
fn test_a_side_wall_within_a_body_length_wakes_a_fish_swimming_along_it() {
    let (_d, mut sim) = probe(COUNTER, 1);
    sim.set_lod_on(true);
    let l = porgy_length(&sim);
    let along = swimming(
        &mut sim,
        Vec3::new(500.0 - 0.5 * l, 200.0, 0.0),
        std::f32::consts::FRAC_PI_2,
        0.0,
    );
    let free = still(&mut sim, Vec3::new(-200.0, 200.0, 0.0));
    for _ in 0..48 {
        sim.step();
    }
    assert_eq!(decisions(&sim, along), 8, "woken every base period");
    assert_eq!(decisions(&sim, free), 2);
}

/// A fast fish three body lengths from the wall and heading into it would reach it before it is
/// next due: it is woken at the first tick it may be (tick 6), although the wall is still more
/// than two body lengths ahead; the same fish heading away is not.
#[test]
fn test_a_fish_that_would_reach_a_wall_before_it_is_due_is_woken() {
    for (heading, expected) in [(0.0, 2), (std::f32::consts::PI, 1)] {
        // No lookahead (at six lengths a second it would wake the fish for the far wall too).
        let (_d, mut sim) = counter_with(no_lookahead());
        let l = porgy_length(&sim);
        let fish = swimming(
            &mut sim,
            Vec3::new(500.0 - 3.0 * l, 200.0, 0.0),
            heading,
            6.0 * l,
        );
        for _ in 0..7 {
            sim.step();
        }
        let x = sim.world().root(fish).unwrap().pos.x;
        assert!(
            500.0 - x > 2.0 * l,
            "heading {heading}: the wall is still more than two lengths away ({})",
            (500.0 - x) / l
        );
        assert_eq!(decisions(&sim, fish), expected, "heading {heading}");
    }
}

/// A fish cruising (one body length a second) straight for a side wall 3.6 body lengths
/// away is woken at the first tick it may be: the shipped behaviours turn from a wall they
/// would reach in 2.5 s at cruising speed, give or take a body length, and a slow fish must see
/// that wall when a full-rate one would. Five lengths away it is not woken; a fish a body length
/// above the floor or below the surface is woken every base period, whatever its heading.
#[test]
fn test_a_slow_fish_is_woken_for_a_wall_where_the_behaviours_would_turn_from_it() {
    let (_d, mut sim) = probe(COUNTER, 1);
    sim.set_lod_on(true);
    let l = porgy_length(&sim);
    let three = swimming(&mut sim, Vec3::new(500.0 - 3.6 * l, 200.0, 0.0), 0.0, l);
    let five = swimming(&mut sim, Vec3::new(500.0 - 5.0 * l, 200.0, -150.0), 0.0, l);
    let floor = swimming(&mut sim, Vec3::new(-200.0, 0.5 * l, 0.0), 0.0, l);
    let surface = swimming(&mut sim, Vec3::new(-200.0, 400.0 - 0.5 * l, 150.0), 0.0, l);
    for _ in 0..7 {
        sim.step();
    }
    assert_eq!(decisions(&sim, three), 2, "woken at tick 6");
    assert_eq!(
        decisions(&sim, five),
        0,
        "not woken (its phase comes at tick 23)"
    );
    for _ in 7..48 {
        sim.step();
    }
    assert_eq!(decisions(&sim, floor), 8, "woken every base period");
    assert_eq!(decisions(&sim, surface), 8, "woken every base period");
    // With no lookahead only two body lengths and the time until it is due count.
    let (_d, mut sim) = counter_with(no_lookahead());
    let three = swimming(&mut sim, Vec3::new(500.0 - 3.6 * l, 200.0, 0.0), 0.0, l);
    for _ in 0..7 {
        sim.step();
    }
    assert_eq!(decisions(&sim, three), 1, "not woken without the lookahead");
}

/// Two slow fish whose centres are a third of a body length apart are about to touch: each is
/// woken on the ticks it would decide at full rate, as a full-rate fish's separation would
/// answer. A pair 0.7 lengths apart is not woken; nor is a crowded pair with wakes off.
#[test]
fn test_a_fish_about_to_touch_another_is_woken_at_its_full_rate() {
    for wake in [true, false] {
        let (_d, mut sim) = counter_with(Lod {
            on: true,
            wake,
            ..Default::default()
        });
        let l = porgy_length(&sim);
        let close = [
            still(&mut sim, Vec3::new(-200.0, 200.0, 0.0)),
            still(&mut sim, Vec3::new(-200.0, 200.0, l / 3.0)),
        ];
        let apart = [
            still(&mut sim, Vec3::new(100.0, 200.0, 0.0)),
            still(&mut sim, Vec3::new(100.0, 200.0, 0.7 * l)),
        ];
        let mut by = WokenBy::<u32>::default();
        for _ in 0..48 {
            sim.step();
            by.add(sim.world().lod_counts().woken_by);
        }
        // Slot 0 decides on ticks 0, 6, … 42; slot 1 would on 5, 11, … 47, but a fish is woken
        // only once it has been idle a whole base period (tick 5 is too early).
        let expected = if wake { [8, 7] } else { [3, 2] };
        for (id, n) in close.into_iter().zip(expected) {
            assert_eq!(decisions(&sim, id), n, "wake {wake}: {id:?}");
        }
        for id in apart {
            assert_eq!(decisions(&sim, id), 2, "wake {wake}: {id:?}");
        }
        // Of the close pair's 15 decisions, 5 were due (ticks 0, 18, 36 and 17, 35): their
        // neighbour woke the other 10.
        assert_eq!(
            (by.seen, by.obstacle, by.neighbour),
            (0, 0, if wake { 10 } else { 0 }),
            "wake {wake}"
        );
    }
}

/// A predator that comes into a slow fish's view wakes it at once, by the fish's own view range:
/// a porgy (300 units) 280 units away is woken and one 340 away is not; a keener-eyed species
/// (450) 420 units away is woken too, farther than any porgy could see; another barracuda is
/// not (a predator alarms only other species).
#[test]
fn test_a_predator_coming_into_view_wakes_the_fish_that_see_it() {
    let (_d, mut sim) = probe(COUNTER, 1);
    sim.set_lod_on(true);
    let mut desc = shoal_core::world::SpeciesDesc::black_porgy();
    desc.name = "keen".into();
    desc.view_range = 450.0;
    let keen = shoal_core::world::Species::load(desc, &common::repo().join("assets")).unwrap();
    sim.add_species(keen, 10.0);
    let near = still(&mut sim, Vec3::new(-280.0, 200.0, 0.0));
    let beyond = still(&mut sim, Vec3::new(-340.0, 200.0, 0.0));
    let keen = still_of(
        &mut sim,
        "keen",
        Vec3::new(-420.0, 200.0, 0.0),
        Some("probe"),
    );
    let kin = still_of(
        &mut sim,
        "barracuda",
        Vec3::new(0.0, 200.0, 200.0),
        Some("probe"),
    );
    let counts = |sim: &Simulation| [near, beyond, keen, kin].map(|id| decisions(sim, id));
    // In the last band slot k decides on the ticks ≡ −k (mod 18): slot 0 on ticks 0 and 18,
    // the others once by tick 17. At tick 30 none is due and each has been idle at least a
    // base period (6 ticks), so each may be woken.
    for _ in 0..30 {
        sim.step();
    }
    assert_eq!(counts(&sim), [2, 1, 1, 1]);
    still_of(&mut sim, "barracuda", Vec3::new(0.0, 200.0, 0.0), None);
    // The grid as a tick leaves it, so the schedule marks the fish around the predator from
    // its grid query rather than scanning each fish.
    sim.world_mut().rebuild_grid();
    sim.step();
    assert_eq!(counts(&sim), [3, 1, 2, 1], "near, beyond, keen, kin");
    assert_eq!(sim.world().lod_counts().woken, 2);
    assert_eq!(
        sim.world().lod_counts().woken_by,
        WokenBy {
            seen: 2,
            obstacle: 0,
            neighbour: 0
        }
    );
}

/// A predator already in view that closes in wakes a slow fish on the ticks it would decide at
/// full rate, as a fleeing fish at full rate turns from it again; one that keeps its distance
/// wakes nobody, and a porgy it moved away from sleeps on.
#[test]
fn test_a_predator_closing_in_wakes_the_fish_it_hunts() {
    let (_d, mut sim) = probe(COUNTER, 1);
    sim.set_lod_on(true);
    // Slot 0 and slot 1, each 200 units from a still barracuda (porgies see 300).
    let hunted = still(&mut sim, Vec3::new(-200.0, 200.0, 0.0));
    let other = still(&mut sim, Vec3::new(200.0, 200.0, 0.0));
    let hunter = still_of(&mut sim, "barracuda", Vec3::new(0.0, 200.0, 0.0), None);
    let mut late_wakes = 0;
    for tick in 0..30 {
        sim.step();
        if tick >= 12 {
            late_wakes += sim.world().lod_counts().woken;
        }
    }
    // The hunted porgy decided on ticks 0 and 18 only (the barracuda was in view from the
    // start, so it never came into view); the other was woken once when it first could be.
    assert_eq!(decisions(&sim, hunted), 2);
    assert_eq!(
        late_wakes, 0,
        "a predator that keeps its distance wakes nobody"
    );
    let other_before = decisions(&sim, other);
    // The barracuda is now 120 units from the hunted porgy (closer than 0.8 × 200) and 280
    // from the other (in view, farther): tick 30 is the hunted one's full-rate tick.
    assert!(sim.despawn(hunter));
    still_of(&mut sim, "barracuda", Vec3::new(-80.0, 200.0, 0.0), None);
    sim.world_mut().rebuild_grid();
    sim.step();
    assert_eq!(decisions(&sim, hunted), 3, "woken by the closing predator");
    assert_eq!(decisions(&sim, other), other_before);
    assert_eq!(
        sim.world().lod_counts().woken_by,
        WokenBy {
            seen: 1,
            obstacle: 0,
            neighbour: 0
        }
    );
    // Having decided with it at 120 units, it is not woken again while the barracuda stays:
    // through tick 42 it decides only when due (tick 36), not on its full-rate tick 42.
    let mut wakes = 0;
    for _ in 31..=42 {
        sim.step();
        wakes += sim.world().lod_counts().woken;
    }
    assert_eq!(wakes, 0);
    assert_eq!(decisions(&sim, hunted), 4);
}

/// A behaviour that asks for a minimum rate keeps it however far its fish are; a bad value is
/// a load error that names the file and the field.
#[test]
fn test_a_behaviour_may_ask_for_a_minimum_rate() {
    let src = "return { min_decision_hz = 10, tick = function(fish)\n  fish.memory.n = (fish.memory.n or 0) + 1\nend }\n";
    let (_d, mut sim) = probe(src, 2);
    sim.set_lod_on(true);
    let fish = row(&mut sim, 0.0);
    for _ in 0..48 {
        sim.step();
    }
    common::assert_no_script_errors(&sim);
    for &id in &fish {
        assert_eq!(decisions(&sim, id), 8, "fish {id:?} at its minimum rate");
    }
    let (_d, mut sim) = probe(
        "return { min_decision_hz = 0, tick = function(fish) end }\n",
        1,
    );
    sim.set_lod_on(true);
    still(&mut sim, Vec3::new(0.0, 200.0, 0.0));
    sim.step();
    let errors = sim.error_messages();
    assert!(
        errors.iter().any(|e| e.contains("behaviors/probe.lua")
            && e.contains("min_decision_hz must be a number in (0, 60]")
            && e.contains("got 0")),
        "{errors:?}"
    );
}

/// Every fish's root, as bits.
fn roots(sim: &Simulation) -> Vec<[u32; 5]> {
    let w = sim.world();
    w.fish_ids()
        .map(|id| {
            let r = w.root(id).unwrap();
            let p = r.pos.to_array().map(f32::to_bits);
            [p[0], p[1], p[2], r.heading.to_bits(), r.speed.to_bits()]
        })
        .collect()
}

/// The default scene with level of detail on and a focus in one corner runs the same in one,
/// two or four lanes; and it really schedules (fewer decisions than with it off).
#[test]
fn test_with_level_of_detail_on_the_lanes_do_not_change_the_run() {
    let mut runs = Vec::new();
    let mut decided = Vec::new();
    for (lanes, on) in [(1, true), (2, true), (4, true), (2, false)] {
        let mut sim =
            Simulation::from_scene(common::repo(), Path::new("scenes/default.lua"), 5).unwrap();
        sim.set_lanes(lanes).unwrap();
        sim.set_lod_on(on);
        let lod = Lod {
            bands: bands([300.0, 700.0]),
            focus: vec![Vec3::new(-500.0, 200.0, -300.0)],
            ..sim.world().lod().clone()
        };
        sim.world_mut().set_lod(lod).unwrap();
        let mut n = 0u64;
        for _ in 0..600 {
            sim.step();
            n += u64::from(sim.world().lod_counts().total());
        }
        common::assert_no_script_errors(&sim);
        if on {
            runs.push((lanes, roots(&sim)));
        }
        decided.push(n);
    }
    for (lanes, r) in &runs[1..] {
        assert_eq!(
            &runs[0].1, r,
            "1 lane and {lanes} lanes differ with level of detail on"
        );
    }
    assert!(
        decided[0] < decided[3],
        "level of detail on decided {} times in 10 s, off {}",
        decided[0],
        decided[3]
    );
}

/// The benchmark school (3,000 fish: more than one chunk of every parallel pass, and slots
/// sharing phases in blocks of two, `shoal_core::world::phase_block`) with level of
/// detail on, a focus and capped bands, run in a rayon pool of one thread (one script lane) and
/// of four (four lanes): the world states are the same, every root bit for bit, and so is every
/// tick's schedule.
#[test]
fn test_pools_of_one_and_four_threads_run_the_same_world_bit_for_bit() {
    let run = |threads: usize| {
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(threads)
            .build()
            .unwrap();
        pool.install(|| {
            let root = common::repo();
            let mut sim =
                shoal_script::sim::bench_school(root, &root.join("scripts"), 3000, 4, None)
                    .unwrap();
            assert_eq!(
                sim.num_lanes(),
                threads,
                "lanes default to the pool's threads"
            );
            let tank = *sim.world().tank();
            let lod = Lod {
                on: true,
                bands: capped([500.0, 1000.0], [Some(300), Some(900)]),
                focus: vec![(tank.min * 3.0 + tank.max) * 0.25],
                wake: true,
                ..Default::default()
            };
            sim.world_mut().set_lod(lod).unwrap();
            let mut schedule = Vec::new();
            for _ in 0..90 {
                sim.step();
                schedule.push(*sim.world().lod_counts());
            }
            common::assert_no_script_errors(&sim);
            let state = sim.snapshot().unwrap().world().clone();
            (roots(&sim), schedule, state)
        })
    };
    let (one_roots, one_schedule, one_state) = run(1);
    let (four_roots, four_schedule, four_state) = run(4);
    let last = one_schedule.last().unwrap();
    assert_eq!(last.fish[..3].iter().sum::<u32>(), 3000);
    assert_eq!(
        last.fish[..2],
        [300, 900],
        "both capped bands are full: their caps hold"
    );
    assert!(
        one_schedule.iter().any(|c| c.woken > 0),
        "events woke fish, so the alert marks were exercised"
    );
    assert_eq!(one_schedule, four_schedule, "the schedules differ");
    assert!(one_roots == four_roots, "roots differ bitwise");
    assert!(one_state == four_state, "world states differ");
}

/// A recording made with level of detail on, whose focus moves mid-run (the window's camera, an
/// input), replays bit for bit; without the focus input the replay parts from it, so the
/// recording really depends on it.
#[test]
fn test_a_recording_with_level_of_detail_and_a_moving_focus_replays_bit_exactly() {
    let root = common::repo();
    let scripts = root.join("scripts");
    let spec = RecordSpec {
        root,
        scripts: &scripts,
        scene: "scenes/default.lua",
        seed: 9,
        lanes: 2,
        seconds: 0.0,
        lod: Some(true),
    };
    let mut run = timeline::record(&spec).unwrap();
    assert!(run.header.lod, "the header says level of detail was on");
    // The same run, by hand, with the focus moving to a corner at tick 30.
    let mut sim = Simulation::from_scene_with_scripts(
        root,
        &scripts,
        Path::new("scenes/default.lua"),
        spec.seed,
    )
    .unwrap();
    sim.set_lanes(2).unwrap();
    sim.set_lod_on(true);
    let focus = TimedInput {
        tick: 30,
        input: Input::LodFocus {
            points: vec![Vec3::new(-500.0, 0.0, -300.0)],
        },
    };
    for _ in 0..180 {
        sim.step();
        run.frames.push(timeline::poses(sim.world()));
        if sim.world().tick_count() == focus.tick {
            timeline::inputs::apply(&mut sim, &focus.input).unwrap();
        }
    }
    run.header.inputs = vec![focus];
    // Through the file format, as a replay reads it.
    let bytes = run.to_bytes();
    let read =
        shoal_script::timeline::run_file::Run::from_bytes(&bytes, Path::new("t.shoalrun")).unwrap();
    assert_eq!(read.header.inputs, run.header.inputs);
    timeline::replay_recorded(&read, root, 180, |_, _| Ok(())).expect("replays bit for bit");
    let mut without = read.clone();
    without.header.inputs.clear();
    let err = timeline::replay_recorded(&without, root, 180, |_, _| Ok(()))
        .err()
        .expect("without the focus the run differs");
    assert!(err.to_string().contains("tick"), "{err}");
}

/// A scene sets the default and the bands; bad fields are named with their path.
#[test]
fn test_a_scene_sets_level_of_detail_and_bad_fields_are_named() {
    let (_dir, root) = common::scratch_repo();
    let write = |body: &str| {
        std::fs::write(
            root.join("scripts/scenes/lod.lua"),
            format!("return {{ tank = {{ min = {{-200, 0, -200}}, max = {{200, 300, 200}} }}, {body} }}\n"),
        )
        .unwrap();
        Simulation::from_scene(&root, Path::new("scenes/lod.lua"), 1)
    };
    let sim = write(
        "lod = { on = true, focus = { {0, 100, 0} }, bands = { {radius = 100, every = 1}, {every = 3} } }",
    )
    .unwrap();
    let lod = sim.world().lod();
    assert!(lod.on);
    assert_eq!(lod.focus, [Vec3::new(0.0, 100.0, 0.0)]);
    assert_eq!(lod.bands.len(), 2);
    assert_eq!(lod.bands[1].every, 3);
    assert!(lod.bands[1].radius.is_infinite());
    assert_eq!(lod.bands[0].cap, None);
    assert_eq!(lod.wall_lookahead, 2.5, "the default lookahead");
    let sim = write("lod = { wall_lookahead = 4 }").unwrap();
    assert_eq!(sim.world().lod().wall_lookahead, 4.0);
    let sim =
        write("lod = { bands = { {radius = 100, every = 1, cap = 40}, {every = 3} } }").unwrap();
    assert_eq!(sim.world().lod().bands[0].cap, Some(40));
    for (body, wanted) in [
        ("lod = { bandz = {} }", "bands"),
        ("lod = { on = 'yes' }", "lod.on"),
        (
            "lod = { bands = { {radius = 100, every = 0} } }",
            "lod.bands[1].every: 0 must be a whole number from 1 to 600",
        ),
        (
            "lod = { bands = { {radius = 300, every = 1}, {radius = 200, every = 2} } }",
            "lod.bands[2].radius: 200",
        ),
        (
            "lod = { bands = { {every = 1}, {radius = 200, every = 2} } }",
            "lod.bands[1].radius",
        ),
        ("lod = { focus = { {0, 0/0, 0} } }", "lod.focus[1]"),
        (
            "lod = { wall_lookahead = -1 }",
            "lod.wall_lookahead: -1 must be a number of seconds from 0 to 60",
        ),
        (
            "lod = { bands = { {radius = 100, every = 1, cap = 5}, {every = 2, cap = 3} } }",
            "lod.bands[2].cap: the last band takes every fish",
        ),
        (
            "lod = { bands = { {radius = 100, every = 1, cap = -1}, {every = 2} } }",
            "lod.bands[1].cap: got -1, expected a whole number",
        ),
        (
            "lod = { bands = { {radius = 100, every = 1, capp = 5}, {every = 2} } }",
            "lod.bands[1].capp: unknown key \"capp\"; did you mean \"cap\"?",
        ),
    ] {
        let err = match write(body) {
            Ok(_) => panic!("{body} was accepted"),
            Err(e) => e.to_string(),
        };
        assert!(err.contains("scenes/lod.lua"), "{body}: {err}");
        assert!(err.contains(wanted), "{body}: {err}");
    }
}
