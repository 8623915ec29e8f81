//! The `shoal` API end to end: behaviour scripts driving fish in a world.

use crate::common;

use glam::Vec3;
use shoal_core::world::FishId;
use shoal_script::Simulation;

/// A simulation whose scripts dir holds one behaviour `probe` with `src`.
fn probe(src: &str) -> (tempfile::TempDir, Simulation) {
    let (dir, root) = common::scratch_repo();
    std::fs::write(root.join("scripts/behaviors/probe.lua"), src).unwrap();
    let sim = common::sim_in(&root, 3);
    (dir, sim)
}

fn spawn(sim: &mut Simulation, pos: Vec3, heading: f32, behavior: &str) -> FishId {
    sim.spawn("black_porgy", pos, heading, 0.0, Some(50.0), Some(behavior))
        .unwrap()
}

fn mem(sim: &Simulation, id: FishId) -> serde_json::Value {
    sim.memory_json(id)
}

#[test]
fn test_body_reports_the_fish_state() {
    let (_d, mut sim) = probe(
        "return { tick = function(fish)\n  local b = shoal.body()\n  fish.memory.b = { b.x, b.y, b.z, b.depth, b.to_floor, b.heading, b.speed, b.motion }\nend }\n",
    );
    let id = spawn(&mut sim, Vec3::new(0.0, 100.0, 0.0), 0.5, "probe");
    sim.step();
    assert_eq!(
        mem(&sim, id)["b"][7],
        "idle",
        "the spawn swim starts in the first motion step"
    );
    for _ in 0..5 {
        sim.step();
    }
    let b0 = mem(&sim, id)["b"].clone();
    assert_eq!(
        b0[0], 0.0,
        "the sixth step has not run the fish's decision again yet"
    );
    sim.step();
    let b = mem(&sim, id)["b"].clone();
    let root = *sim.world().root(id).unwrap();
    let f = |i: usize| b[i].as_f64().unwrap() as f32;
    // The decision at tick 6 saw the state after six motion steps (0.1 s at 50 units/s).
    let prev =
        root.pos - Vec3::new(root.heading.cos(), 0.0, -root.heading.sin()) * root.speed / 60.0;
    assert!(
        (f(0) - prev.x).abs() < 0.5 && (f(2) - prev.z).abs() < 0.5,
        "{b} vs {root:?}"
    );
    assert!(f(0) > 3.0 && f(2) < -1.5, "moved along heading 0.5: {b}");
    assert!((f(1) - 100.0).abs() < 0.5);
    assert!(
        (f(3) - (400.0 - f(1))).abs() < 1e-3,
        "depth below the surface at y = 400"
    );
    assert!(
        (f(4) - f(1)).abs() < 1e-3,
        "height above the floor at y = 0"
    );
    assert!((f(5) - 0.5).abs() < 1e-3);
    assert!((f(6) - 50.0).abs() < 1.0);
    assert_eq!(b[7], "swim");
}

#[test]
fn test_see_lists_percepts_nearest_first() {
    let (_d, mut sim) = probe(
        "return { tick = function(fish)\n  local out = {}\n  for i, p in ipairs(shoal.see()) do out[i] = { p.kind, p.id, math.floor(p.distance + 0.5), p.species or '' } end\n  fish.memory.seen = out\n  local f = shoal.see('food', 1)\n  fish.memory.first_food = f[1] and f[1].id\n  fish.memory.n_food = #f\nend }\n",
    );
    let id = spawn(&mut sim, Vec3::new(0.0, 200.0, 0.0), 0.0, "probe");
    let other = sim
        .spawn(
            "black_porgy",
            Vec3::new(100.0, 200.0, 0.0),
            0.0,
            0.0,
            Some(0.0),
            None,
        )
        .unwrap();
    let _behind = sim
        .spawn(
            "black_porgy",
            Vec3::new(-60.0, 200.0, 60.0),
            0.0,
            0.0,
            Some(0.0),
            None,
        )
        .unwrap();
    let _blind_spot = sim
        .spawn(
            "black_porgy",
            Vec3::new(-70.0, 200.0, 0.0),
            0.0,
            0.0,
            Some(0.0),
            None,
        )
        .unwrap();
    sim.world_mut().add_food(Vec3::new(40.0, 200.0, 30.0));
    sim.world_mut().add_food(Vec3::new(200.0, 200.0, 0.0));
    sim.world_mut().rebuild_grid();
    sim.step();
    let m = mem(&sim, id);
    let seen = m["seen"].as_array().unwrap();
    // Food at 50, the porgy behind-left at 85 (135° off axis: inside the 300° cone), the porgy
    // ahead at 100, food at 200; the porgy straight behind is in the blind spot.
    let kinds: Vec<&str> = seen.iter().map(|p| p[0].as_str().unwrap()).collect();
    assert_eq!(kinds, ["food", "fish", "fish", "food"], "{seen:?}");
    assert_eq!(seen[0][2], 50);
    assert_eq!(seen[2][1], other.index);
    assert_eq!(seen[2][3], "black_porgy");
    assert_eq!(m["first_food"], 0);
    assert_eq!(m["n_food"], 1);
}

#[test]
fn test_nearest_filters_by_kind_and_species() {
    let (_d, mut sim) = probe(
        "return { tick = function(fish)\n  local p = shoal.nearest('predator')\n  fish.memory.pred = p and p.species\n  local q = shoal.nearest('fish', 'black_porgy')\n  fish.memory.porgy = q and q.id\n  fish.memory.none = shoal.nearest('food') == nil\nend }\n",
    );
    let id = spawn(&mut sim, Vec3::new(0.0, 200.0, 0.0), 0.0, "probe");
    sim.spawn(
        "barracuda",
        Vec3::new(80.0, 200.0, 0.0),
        0.0,
        0.0,
        Some(0.0),
        None,
    )
    .unwrap();
    let p = sim
        .spawn(
            "black_porgy",
            Vec3::new(150.0, 200.0, 0.0),
            0.0,
            0.0,
            Some(0.0),
            None,
        )
        .unwrap();
    sim.world_mut().rebuild_grid();
    sim.step();
    let m = mem(&sim, id);
    assert_eq!(m["pred"], "barracuda");
    assert_eq!(m["porgy"], p.index);
    assert_eq!(m["none"], true);
}

#[test]
fn test_motion_requests_reach_the_player() {
    for (call, motion) in [
        ("shoal.stop(0.5, true)", "stop"),
        ("shoal.accelerate(80, 1, true)", "accelerate"),
        (
            "shoal.turn('quick', math.rad(90), 'left', true)",
            "quick_turn",
        ),
        (
            "shoal.normal_turn(math.rad(45), 'right', true)",
            "normal_turn",
        ),
        (
            "shoal.serial_turn(math.rad(90), 'left', true)",
            "serial_turn",
        ),
        ("shoal.ascend(50, true)", "ascend"),
        ("shoal.descend(50, true)", "descend"),
        ("shoal.swim(30, true)", "swim"),
    ] {
        let src = format!(
            "return {{ tick = function(fish)\n  if not fish.memory.done then {call}; fish.memory.done = true end\nend }}\n"
        );
        let (_d, mut sim) = probe(&src);
        let id = spawn(&mut sim, Vec3::new(0.0, 200.0, 0.0), 0.0, "probe");
        sim.step();
        assert_eq!(
            sim.world().current_motion(id),
            Some(motion),
            "{call}: {:?}",
            sim.error_messages()
        );
    }
}

#[test]
fn test_queued_requests_wait_their_turn() {
    let (_d, mut sim) = probe(
        "return { tick = function(fish)\n  if not fish.memory.done then\n    shoal.accelerate(40, 1)\n    shoal.swim(20)\n    fish.memory.done = true\n  end\n  fish.memory.motion = { shoal.motion() }\nend }\n",
    );
    let id = sim
        .spawn(
            "black_porgy",
            Vec3::new(0.0, 200.0, 0.0),
            0.0,
            0.0,
            Some(0.0),
            Some("probe"),
        )
        .unwrap();
    sim.step();
    assert_eq!(sim.world().current_motion(id), Some("accelerate"));
    assert_eq!(sim.world().queue_len(id), Some(1));
    sim.run(0.1);
    assert_eq!(
        mem(&sim, id)["motion"],
        serde_json::json!(["accelerate", 1])
    );
    sim.run(1.5);
    assert_eq!(sim.world().current_motion(id), Some("swim"));
    assert_eq!(mem(&sim, id)["motion"], serde_json::json!(["swim", 0]));
}

#[test]
fn test_bad_arguments_name_the_line() {
    let (_d, mut sim) =
        probe("return { tick = function(fish)\n  shoal.turn('sideways', 1, 'left')\nend }\n");
    spawn(&mut sim, Vec3::new(0.0, 200.0, 0.0), 0.0, "probe");
    sim.step();
    assert_eq!(
        sim.error_messages(),
        [
            "scripts/behaviors/probe.lua:2: shoal.turn: kind must be \"normal\", \"quick\" or \"serial\", got \"sideways\""
        ]
    );
    let (_d, mut sim) = probe("return { tick = function(fish)\n\n  shoal.swim(0/0)\nend }\n");
    spawn(&mut sim, Vec3::new(0.0, 200.0, 0.0), 0.0, "probe");
    sim.step();
    let errs = sim.error_messages();
    assert_eq!(errs.len(), 1);
    assert!(
        errs[0].starts_with("scripts/behaviors/probe.lua:3: shoal.swim: "),
        "{errs:?}"
    );
}

#[test]
fn test_steer_turns_the_fish_towards_a_heading() {
    let (_d, mut sim) =
        probe("return { tick = function(fish)\n  shoal.steer(math.rad(90), 200, 50)\nend }\n");
    let id = spawn(&mut sim, Vec3::new(0.0, 200.0, 0.0), 0.0, "probe");
    sim.run(8.0);
    let h = sim.world().root(id).unwrap().heading;
    assert!((h - std::f32::consts::FRAC_PI_2).abs() < 0.2, "heading {h}");
}

#[test]
fn test_seek_leads_to_the_target_and_eat_eats_it() {
    let (_d, mut sim) = probe(
        "return { tick = function(fish)\n  local f = shoal.nearest('food')\n  if not f then return 'idle' end\n  if shoal.eat(f.id) then fish.memory.ate = shoal.time() return 'ate' end\n  shoal.steer(shoal.seek(f.x, f.y, f.z))\n  return 'seek'\nend }\n",
    );
    let id = spawn(&mut sim, Vec3::new(-200.0, 200.0, 0.0), 0.0, "probe");
    let food = sim.world_mut().add_food(Vec3::new(100.0, 220.0, 60.0));
    sim.run(15.0);
    assert!(
        sim.world().food(food).unwrap().eaten,
        "{:?}",
        sim.inspect(id)
    );
    assert_eq!(sim.world().food(food).unwrap().eaten_by, Some(id));
    assert!(mem(&sim, id)["ate"].as_f64().unwrap() > 1.0);
}

#[test]
fn test_eat_out_of_reach_fails() {
    let (_d, mut sim) =
        probe("return { tick = function(fish)\n  fish.memory.ate = shoal.eat(0)\nend }\n");
    let id = spawn(&mut sim, Vec3::new(0.0, 200.0, 0.0), 0.0, "probe");
    sim.world_mut().add_food(Vec3::new(200.0, 200.0, 0.0));
    sim.step();
    assert_eq!(mem(&sim, id)["ate"], false);
}

#[test]
fn test_steering_helpers_return_heading_depth_speed() {
    let (_d, mut sim) = probe(
        "return { tick = function(fish)\n  local m = fish.memory\n  m.seek = { shoal.seek(100, 200, 0, 40) }\n  m.flee = { shoal.flee(100, 200, 0, 90) }\n  m.arrive = { shoal.arrive(10, 200, 0) }\n  m.sep = { shoal.separation() }\n  m.coh = { shoal.cohesion(300) }\n  m.ali = { shoal.alignment(300) }\n  m.walls = { shoal.avoid_walls() }\n  m.rocks = { shoal.avoid_obstacles() }\n  m.wander = { shoal.wander() }\n  m.blend = { shoal.blend(0, 100, 10, 1, math.pi / 2, 200, 30, 1) }\n  m.blend_nil = { shoal.blend(nil, nil, nil, 1) }\nend }\n",
    );
    let id = spawn(&mut sim, Vec3::new(0.0, 200.0, 0.0), 0.0, "probe");
    sim.spawn(
        "black_porgy",
        Vec3::new(0.0, 200.0, 30.0),
        1.0,
        0.0,
        Some(0.0),
        None,
    )
    .unwrap();
    sim.world_mut().rebuild_grid();
    sim.step();
    let m = mem(&sim, id);
    let f = |k: &str, i: usize| m[k][i].as_f64().unwrap();
    // Seek straight ahead (+x) at the asked speed, depth 200 (y = 200 under a surface at 400).
    assert!(f("seek", 0).abs() < 1e-6 && (f("seek", 1) - 200.0).abs() < 1e-3);
    assert_eq!(f("seek", 2), 40.0);
    // Flee: the opposite heading.
    assert!((f("flee", 0).abs() - std::f64::consts::PI).abs() < 1e-5);
    assert_eq!(f("flee", 2), 90.0);
    // Arrive slows down within two body lengths.
    assert!(f("arrive", 2) < 50.0);
    // The neighbour 30 units to the fish's right (+z is right of +x heading): separation pushes
    // left (heading > 0), cohesion pulls right (heading < 0); alignment takes its heading 1.0.
    assert!(f("sep", 0) > 0.5, "{m}");
    assert!(f("coh", 0) < -0.5, "{m}");
    assert!((f("ali", 0) - 1.0).abs() < 1e-5);
    // Nothing to avoid in mid-water: nil.
    assert_eq!(m["walls"], serde_json::json!({}));
    assert_eq!(m["rocks"], serde_json::json!({}));
    assert_eq!(m["wander"].as_array().unwrap().len(), 3);
    assert!((f("blend", 0) - std::f64::consts::FRAC_PI_4).abs() < 1e-9);
    assert_eq!(f("blend", 1), 150.0);
    assert_eq!(f("blend", 2), 20.0);
    assert_eq!(m["blend_nil"], serde_json::json!({}));
}

/// `shoal.crowd` is `shoal.blend` of separation, alignment and cohesion with their own radii,
/// among neighbours of two species at several distances.
#[test]
fn test_crowd_is_the_blend_of_the_three_rules() {
    let (_d, mut sim) = probe(
        "return { tick = function(fish)\n  local m = fish.memory\n  local hs, ds, ss = shoal.separation(60)\n  local ha, da, sa = shoal.alignment(200)\n  local hc, dc, sc = shoal.cohesion(300)\n  m.blend = { shoal.blend(hs, ds, ss, 1.5, ha, da, sa, 2, hc, dc, sc, 0.5) }\n  m.crowd = { shoal.crowd(60, 1.5, 200, 2, 300, 0.5) }\n  m.alone = { shoal.crowd(1, 1, 1, 1, 1, 1) }\n  m.bad = tostring(select(2, pcall(shoal.crowd, 0/0, 1, 1, 1, 1, 1)))\n  m.all = { shoal.crowd(60, 1.5, 200, 2, 300, 0.5, nil, \"all\") }\n  m.two = { shoal.crowd(60, 1.5, 200, 2, 300, 0.5, nil, 2) }\n  m.bad_k = {}\n  for _, k in ipairs({ 0, 2.5, \"most\", {} }) do\n    m.bad_k[#m.bad_k + 1] = tostring(select(2, pcall(shoal.crowd, 60, 1, 1, 1, 1, 1, nil, k)))\n  end\nend }\n",
    );
    let id = spawn(&mut sim, Vec3::new(0.0, 200.0, 0.0), 0.0, "probe");
    for (i, (x, z, heading)) in [
        (20.0, 30.0, 1.0),
        (-40.0, 10.0, 2.0),
        (100.0, -80.0, -0.5),
        (-150.0, 120.0, 0.3),
        (250.0, 0.0, 2.5),
    ]
    .into_iter()
    .enumerate()
    {
        let species = if i == 1 { "barracuda" } else { "black_porgy" };
        sim.spawn(
            species,
            Vec3::new(x, 200.0 + 5.0 * i as f32, z),
            heading,
            0.0,
            Some(0.0),
            None,
        )
        .unwrap();
    }
    sim.world_mut().rebuild_grid();
    sim.step();
    let m = mem(&sim, id);
    let (blend, crowd) = (
        m["blend"].as_array().unwrap(),
        m["crowd"].as_array().unwrap(),
    );
    assert_eq!(crowd.len(), 3, "{m}");
    for i in 0..3 {
        let (b, c) = (blend[i].as_f64().unwrap(), crowd[i].as_f64().unwrap());
        assert!((b - c).abs() < 1e-9, "value {i}: blend {b}, crowd {c}");
    }
    assert_eq!(
        m["alone"],
        serde_json::json!({}),
        "no neighbour within 1 unit"
    );
    let bad = m["bad"].as_str().unwrap_or_else(|| panic!("{m}"));
    assert!(
        bad.contains("shoal.crowd: separation radius is NaN"),
        "{bad}"
    );
    // Five neighbours: the default (every fish, unsampled at this density) and "all" take them
    // all; the nearest 2 leave out the others' pull.
    assert_eq!(m["all"], m["crowd"], "{m}");
    let two = m["two"].as_array().unwrap();
    assert!(
        (0..3).any(|i| (two[i].as_f64().unwrap() - blend[i].as_f64().unwrap()).abs() > 1e-3),
        "the nearest 2 answer as all 5: {m}"
    );
    let bad_k = m["bad_k"].as_array().unwrap();
    for (b, shown) in bad_k.iter().zip(["0", "2.5", "\"most\"", "a table"]) {
        let b = b.as_str().unwrap();
        assert!(
            b.contains(&format!(
                "shoal.crowd: nearest is {shown}: must be a whole number"
            )),
            "{b}"
        );
    }
}

/// In a packed school `shoal.crowd`'s default samples alignment and cohesion (its answer is
/// not "all"'s, bit for bit) and stays close to every fish's answer, unlike the nearest few;
/// the same call on the same world gives the same answer.
#[test]
fn test_crowd_samples_a_packed_school_and_stays_close_to_all() {
    let (_d, mut sim) = probe(
        "return { tick = function(fish)\n  local m = fish.memory\n  m.crowd = { shoal.crowd(50, 1, 200, 2, 300, 1) }\n  m.again = { shoal.crowd(50, 1, 200, 2, 300, 1) }\n  m.all = { shoal.crowd(50, 1, 200, 2, 300, 1, nil, \"all\") }\n  m.few = { shoal.crowd(50, 1, 200, 2, 300, 1, nil, 6) }\nend }\n",
    );
    let centre = Vec3::new(0.0, 300.0, 0.0);
    let id = spawn(&mut sim, centre, 0.0, "probe");
    // 3,000 porgies within 100 units of the probe (about 90 a cubic body length: more than
    // the 2,048 the cells within the widest radius may hold unsampled), heading roughly +x,
    // the school's centre off to one side.
    let (mut k, mut spawned) = (0u32, 0);
    while spawned < 3000 {
        let h = |n: u32, m: u32| ((n.wrapping_mul(2_654_435_761) >> 8) % m) as f32 / m as f32;
        let p = Vec3::new(h(k, 997), h(k + 7, 991), h(k + 13, 983)) * 2.0 - Vec3::ONE;
        k += 1;
        if p.length() > 1.0 {
            continue;
        }
        spawned += 1;
        let pos = centre + p * 100.0 + Vec3::new(40.0, 0.0, 0.0);
        sim.spawn(
            "black_porgy",
            pos,
            0.4 * (h(k, 89) - 0.5),
            0.0,
            Some(0.0),
            Some("probe"),
        )
        .unwrap();
    }
    // Every fish runs the probe (so crowd queries are made every tick, and the grid keeps its
    // crowding columns); the probe fish decides again six ticks later.
    for _ in 0..7 {
        sim.step();
    }
    let m = mem(&sim, id);
    let heading = |key: &str| m[key][0].as_f64().unwrap_or_else(|| panic!("{key}: {m}"));
    let turn = |a: f64, b: f64| {
        let d = (a - b).rem_euclid(std::f64::consts::TAU);
        d.min(std::f64::consts::TAU - d)
    };
    assert_eq!(m["crowd"], m["again"], "{m}");
    assert_ne!(m["crowd"], m["all"], "the default sampled nothing: {m}");
    let (sampled, few) = (
        turn(heading("crowd"), heading("all")),
        turn(heading("few"), heading("all")),
    );
    assert!(
        sampled < 0.1,
        "the sample turned {sampled} rad from every fish's answer: {m}"
    );
    assert!(
        few > sampled,
        "the nearest 6 ({few} rad) closer than the sample ({sampled}): {m}"
    );
}

#[test]
fn test_avoid_walls_points_back_into_the_tank() {
    let (_d, mut sim) =
        probe("return { tick = function(fish)\n  fish.memory.w = { shoal.avoid_walls() }\nend }\n");
    // Near the +x wall (x max = 500), heading into it.
    let id = spawn(&mut sim, Vec3::new(470.0, 200.0, 0.0), 0.0, "probe");
    sim.step();
    let h = mem(&sim, id)["w"][0].as_f64().unwrap();
    assert!(h.cos() < 0.0, "heading {h} should point away from +x");
}

#[test]
fn test_random_is_seeded_per_fish() {
    let src = "return { tick = function(fish)\n  local m = fish.memory\n  m.r = m.r or {}\n  m.r[#m.r + 1] = shoal.random(1, 1000)\n  m.f = shoal.random()\nend }\n";
    let run = || {
        let (_d, mut sim) = probe(src);
        let a = spawn(&mut sim, Vec3::new(0.0, 200.0, 0.0), 0.0, "probe");
        let b = spawn(&mut sim, Vec3::new(100.0, 200.0, 0.0), 0.0, "probe");
        sim.run(1.0);
        (mem(&sim, a), mem(&sim, b))
    };
    let (a1, b1) = run();
    let (a2, b2) = run();
    assert_eq!(a1, a2, "same seed, same numbers");
    assert_eq!(b1, b2);
    assert_ne!(a1["r"], b1["r"], "each fish has its own generator");
    assert_eq!(
        a1["r"].as_array().unwrap().len(),
        10,
        "10 decisions in 1 s at 10 Hz"
    );
    let f = a1["f"].as_f64().unwrap();
    assert!((0.0..1.0).contains(&f));
}

#[test]
fn test_species_and_time() {
    let (_d, mut sim) = probe(
        "return { tick = function(fish)\n  local s = shoal.species()\n  fish.memory.s = { s.name, s.length, s.cruise_speed, s.predator }\n  fish.memory.t = shoal.time()\nend }\n",
    );
    let id = spawn(&mut sim, Vec3::new(0.0, 200.0, 0.0), 0.0, "probe");
    sim.run(0.5);
    let m = mem(&sim, id);
    assert_eq!(
        m["s"],
        serde_json::json!(["black_porgy", 50.0, 50.0, false])
    );
    let t = m["t"].as_f64().unwrap();
    assert!(t > 0.3 && t < 0.5, "{t}");
}

#[test]
fn test_decisions_are_staggered_at_10_hz() {
    let (_d, mut sim) = probe(
        "return { tick = function(fish)\n  local m = fish.memory\n  m.n = (m.n or 0) + 1\n  m.first = m.first or shoal.time()\nend }\n",
    );
    let ids: Vec<FishId> = (0..12)
        .map(|i| {
            spawn(
                &mut sim,
                Vec3::new(-300.0 + 50.0 * i as f32, 200.0, 0.0),
                0.0,
                "probe",
            )
        })
        .collect();
    let mut per_tick = Vec::new();
    for _ in 0..60 {
        let before: i64 = ids
            .iter()
            .map(|&i| mem(&sim, i)["n"].as_i64().unwrap_or(0))
            .sum();
        sim.step();
        let after: i64 = ids
            .iter()
            .map(|&i| mem(&sim, i)["n"].as_i64().unwrap_or(0))
            .sum();
        per_tick.push(after - before);
    }
    // 12 fish, period 6: exactly 2 decide on every tick; each fish 10 times a second.
    assert!(per_tick.iter().all(|&n| n == 2), "{per_tick:?}");
    for &i in &ids {
        assert_eq!(mem(&sim, i)["n"], 10);
    }
}

/// The inspector's value of `key`, failing with every line when it is missing.
fn inspected(lines: &[(String, String)], key: &str) -> String {
    lines
        .iter()
        .find(|(k, _)| k == key)
        .map(|(_, v)| v.clone())
        .unwrap_or_else(|| panic!("{key} missing from {lines:?}"))
}

#[test]
fn test_inspect_shows_intention_percepts_and_memory() {
    let (_d, mut sim) = probe(
        "local M = {}\nfunction M.perceive(fish) return { food = 3 } end\nfunction M.intend(fish, p) return p.food > 2 and 'eat' or 'wander' end\nfunction M.behave(fish, i, p) fish.memory.last = i end\nreturn M\n",
    );
    let id = spawn(&mut sim, Vec3::new(0.0, 200.0, 0.0), 0.0, "probe");
    sim.step();
    let lines = sim.inspect(id);
    let get = |k: &str| inspected(&lines, k);
    assert_eq!(get("intention"), "eat");
    assert_eq!(get("percept.food"), "3");
    assert_eq!(get("memory.last"), "eat");
    assert_eq!(get("species"), "black_porgy");
    assert_eq!(get("behavior"), "probe");
}

/// The inspector shows a Lua list in its order, not sorted as text, then its named fields.
#[test]
fn test_inspect_shows_lists_in_their_order() {
    let (_d, mut sim) = probe(
        "local M = {}\nfunction M.behave(fish) fish.memory.rock = {250.5, 60, -120, 60}\nfish.memory.order = {3, 1, 2}\nfish.memory.mixed = {30, 10, b = 2, a = 1}\nend\nreturn M\n",
    );
    let id = spawn(&mut sim, Vec3::new(0.0, 200.0, 0.0), 0.0, "probe");
    sim.step();
    let lines = sim.inspect(id);
    let get = |k: &str| inspected(&lines, k);
    assert_eq!(get("memory.rock"), "{250.50, 60, -120, 60}");
    assert_eq!(get("memory.order"), "{3, 1, 2}");
    assert_eq!(get("memory.mixed"), "{30, 10, a=1, b=2}");
}

/// The Lua console answers an expression with its value (`= nil` for none) and a statement
/// with `ok`, not JSON's `= null` (issue 36).
#[test]
fn test_console_answers_statements_and_expressions_in_lua_terms() {
    let (_d, mut sim) = probe("local M = {}\nfunction M.behave(fish) end\nreturn M\n");
    let id = spawn(&mut sim, Vec3::new(0.0, 200.0, 0.0), 0.0, "probe");
    sim.step();
    assert_eq!(sim.console_eval(id, "fish.memory.x = 5").unwrap(), "ok");
    assert_eq!(sim.console_eval(id, "fish.memory.x * 2").unwrap(), "= 10");
    assert_eq!(sim.console_eval(id, "fish.memory.nope").unwrap(), "= nil");
    assert!(sim.console_eval(id, "fish.memory.nope.x").is_err());
}

#[test]
fn test_stage_timings_are_recorded() {
    let (_d, mut sim) = probe("return { tick = function(fish) shoal.see() end }\n");
    for i in 0..20 {
        spawn(
            &mut sim,
            Vec3::new(-400.0 + 40.0 * i as f32, 200.0, 0.0),
            0.0,
            "probe",
        );
    }
    sim.step();
    let c = *sim.world().counters();
    assert!(
        c.lua_ns > 0 && c.perception_ns > 0 && c.motion_ns > 0,
        "{c:?}"
    );
}

#[test]
fn test_a_failing_fish_keeps_its_motion_and_others_run() {
    let (dir, root) = common::scratch_repo();
    std::fs::write(
        root.join("scripts/behaviors/bad.lua"),
        "return { tick = function(fish)\n  error('boom')\nend }\n",
    )
    .unwrap();
    let mut sim = common::sim_in(&root, 1);
    let bad = sim
        .spawn(
            "black_porgy",
            Vec3::new(0.0, 200.0, 0.0),
            0.0,
            0.0,
            Some(50.0),
            Some("bad"),
        )
        .unwrap();
    let good = sim
        .spawn(
            "black_porgy",
            Vec3::new(0.0, 200.0, 150.0),
            0.0,
            0.0,
            Some(50.0),
            Some("wander"),
        )
        .unwrap();
    let x0 = sim.world().root(bad).unwrap().pos.x;
    sim.run(2.0);
    assert_eq!(sim.world().current_motion(bad), Some("swim"));
    assert!(
        sim.world().root(bad).unwrap().pos.x > x0 + 50.0,
        "still swimming"
    );
    let intention = sim
        .inspect(good)
        .into_iter()
        .find(|(k, _)| k == "intention");
    assert_eq!(intention, Some(("intention".into(), "wander".into())));
    assert_eq!(sim.error_messages(), ["scripts/behaviors/bad.lua:2: boom"]);
    let log = sim.drain_log();
    assert_eq!(log.iter().filter(|e| e.message.contains("boom")).count(), 1);
    drop(dir);
}

#[test]
fn test_nearest_agrees_with_the_full_vision_list() {
    // nearest() answers from the grid without building the percept list; after see() it answers
    // from the list. Both must name the same thing at the same distance.
    let (_d, mut sim) = probe(
        "local function get(k, s)\n  local p = shoal.nearest(k, s)\n  return p and { p.kind, p.id, p.distance, p.bearing, p.elevation } or 'none'\nend\nreturn { tick = function(fish)\n  local m = fish.memory\n  m.grid = { get('fish'), get('food'), get('predator'), get('fish', 'barracuda') }\n  shoal.see()\n  m.list = { get('fish'), get('food'), get('predator'), get('fish', 'barracuda') }\nend }\n",
    );
    let watcher = spawn(&mut sim, Vec3::new(0.0, 200.0, 0.0), 0.7, "probe");
    for i in 0..40 {
        let a = i as f32 * 2.399;
        let r = 30.0 + 7.0 * i as f32;
        let p = Vec3::new(a.cos() * r, 200.0 + (a * 3.0).sin() * 60.0, a.sin() * r);
        let species = if i % 13 == 5 {
            "barracuda"
        } else {
            "black_porgy"
        };
        sim.spawn(species, p, a, 0.0, Some(0.0), None).unwrap();
        if i % 3 == 0 {
            sim.world_mut().add_food(p + Vec3::new(20.0, -10.0, 15.0));
        }
    }
    sim.world_mut().rebuild_grid();
    sim.step();
    let m = mem(&sim, watcher);
    assert_eq!(m["grid"], m["list"], "{m}");
    assert_ne!(m["grid"][0], "none");
    assert_ne!(m["grid"][1], "none");
    assert_ne!(m["grid"][2], "none");
}

#[test]
fn test_reused_answers_never_carry_another_fishs_values() {
    // One lane runs both fish one after another, sharing the API's reused tables and its caches
    // of species tables and names: a barracuda that sees a porgy (a percept with a species)
    // decides just before a porgy that sees only food (a percept without one), and each asks
    // for its own species. Were a previous decision's answer to leak, the porgy would read
    // the barracuda's species, or the porgy's name on its pellet.
    let (_d, mut sim) = probe(
        "return { tick = function(fish)\n  local m = fish.memory\n  local me = shoal.species()\n  m.me = me.name\n  m.predator = me.predator\n  if me.name == 'barracuda' then\n    local n = shoal.nearest('fish')\n    m.saw = n and n.species\n    m.saw_kind = n and n.kind\n  else\n    local f = shoal.nearest('food')\n    m.food_species = f and (f.species or 'none')\n    m.food_kind = f and f.kind\n    m.nothing = shoal.nearest('predator', 'no_such_species') == nil\n  end\n  m.motion = shoal.body().motion\nend }\n",
    );
    sim.set_lanes(1).unwrap();
    let mut pairs = Vec::new();
    for k in 0..6 {
        let x = -300.0 + 120.0 * k as f32;
        let barracuda = sim
            .spawn(
                "barracuda",
                Vec3::new(x, 200.0, 0.0),
                0.0,
                0.0,
                Some(0.0),
                Some("probe"),
            )
            .unwrap();
        // Ahead of the barracuda; the porgy looks away from it, at a pellet.
        let porgy = sim
            .spawn(
                "black_porgy",
                Vec3::new(x + 40.0, 200.0, 0.0),
                0.0,
                0.0,
                Some(0.0),
                Some("probe"),
            )
            .unwrap();
        sim.world_mut().add_food(Vec3::new(x + 70.0, 200.0, 0.0));
        pairs.push((barracuda, porgy));
    }
    sim.world_mut().rebuild_grid();
    sim.run(0.5);
    assert!(
        sim.error_messages().is_empty(),
        "{:?}",
        sim.error_messages()
    );
    for (barracuda, porgy) in pairs {
        let b = mem(&sim, barracuda);
        assert_eq!(b["me"], "barracuda", "{b}");
        assert_eq!(b["predator"], true, "{b}");
        assert_eq!(b["saw"], "black_porgy", "{b}");
        assert_eq!(b["saw_kind"], "fish", "{b}");
        let p = mem(&sim, porgy);
        assert_eq!(p["me"], "black_porgy", "{p}");
        assert_eq!(p["predator"], false, "{p}");
        assert_eq!(p["food_species"], "none", "a pellet has no species: {p}");
        assert_eq!(p["food_kind"], "food", "{p}");
        assert_eq!(p["nothing"], true, "{p}");
        assert!(p["motion"].is_string(), "{p}");
    }
}
