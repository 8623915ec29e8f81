//! The profile (issue 17): what each behaviour's decisions cost, which of its functions take the
//! time (stack samples, with file:line) and what they allocate, checked against scripts with a
//! known split of work.

use crate::common;

use glam::Vec3;

#[test]
fn the_profile_splits_cost_by_module_as_the_work_is_split() {
    let (_dir, root) = common::scratch_repo();
    let behavior = |n: u32| {
        format!(
            "return {{ tick = function(fish)\n  local x = 0\n  for i = 1, {n} do x = x + math.sin(i) end\n  fish.memory.x = x\nend }}\n"
        )
    };
    let dir = root.join("scripts/behaviors");
    std::fs::write(dir.join("heavy.lua"), behavior(20_000)).unwrap();
    std::fs::write(dir.join("light.lua"), behavior(2_000)).unwrap();
    std::fs::write(
        dir.join("broken.lua"),
        "return { tick = function(fish) error('nope') end }\n",
    )
    .unwrap();
    let mut sim = common::sim_in(&root, 3);
    for (k, b) in ["heavy", "light"].iter().cycle().take(20).enumerate() {
        let pos = Vec3::new(-200.0 + 20.0 * k as f32, 150.0, 0.0);
        sim.spawn("black_porgy", pos, 0.0, 0.0, Some(40.0), Some(b))
            .unwrap();
    }
    let broken = sim
        .spawn(
            "black_porgy",
            Vec3::new(0.0, 100.0, 50.0),
            0.0,
            0.0,
            Some(40.0),
            Some("broken"),
        )
        .unwrap();
    sim.run(2.0);
    let p = sim.profile();
    let get = |name: &str| p.iter().find(|m| m.module == name).unwrap().clone();
    let (heavy, light, bad) = (get("heavy"), get("light"), get("broken"));
    // 10 fish each at 10 Hz for 2 s.
    assert_eq!(heavy.calls, 200);
    assert_eq!(light.calls, 200);
    assert_eq!(p[0].module, "heavy", "most expensive first: {p:?}");
    let ratio = heavy.behavior_ms / light.behavior_ms;
    assert!((4.0..30.0).contains(&ratio), "heavy/light = {ratio}");
    assert!(heavy.ms_per_sim_s > 0.0 && heavy.us_per_call > light.us_per_call);
    assert_eq!(
        bad.errors,
        bad.calls.min(5),
        "it errors until switched off: {bad:?}"
    );
    assert!(sim.world().is_alive(broken));

    sim.reset_profile();
    assert!(sim.profile().is_empty());
    sim.run(0.5);
    assert_eq!(get_calls(&sim, "heavy"), 50);
}

fn get_calls(sim: &shoal_script::Simulation, name: &str) -> u64 {
    sim.profile()
        .iter()
        .find(|m| m.module == name)
        .map_or(0, |m| m.calls)
}

/// Spawns `count` porgies running `behavior` in a row.
fn spawn_row(sim: &mut shoal_script::Simulation, behavior: &str, count: usize, y: f32) {
    for k in 0..count {
        let pos = Vec3::new(-200.0 + 20.0 * k as f32, y, 0.0);
        sim.spawn("black_porgy", pos, 0.0, 0.0, Some(40.0), Some(behavior))
            .unwrap();
    }
}

#[cfg(target_os = "linux")]
#[test]
fn sampled_functions_split_as_the_work_is_split_and_name_their_lines() {
    let (_dir, root) = common::scratch_repo();
    std::fs::write(
        root.join("scripts/behaviors/split.lua"),
        common::split_behavior(3000),
    )
    .unwrap();
    let mut sim = common::sim_in(&root, 3);
    sim.set_function_sampling(Some(shoal_script::sim::SAMPLE_EVERY));
    spawn_row(&mut sim, "split", 20, 150.0);
    // Until there are a few hundred samples (about one per millisecond of Lua), at most 30 s
    // of simulated time.
    let mut module = None;
    for _ in 0..60 {
        sim.run(0.5);
        let p = sim.profile();
        let m = p.iter().find(|m| m.module == "split").unwrap().clone();
        if m.samples >= 400 {
            module = Some(m);
            break;
        }
    }
    let m = module.expect("400 samples within 30 simulated seconds");
    let f = |name: &str| {
        m.functions
            .iter()
            .find(|f| f.frame.name == name)
            .unwrap_or_else(|| panic!("{name} in {:#?}", m.functions))
            .clone()
    };
    let (heavy, light) = (f("heavy"), f("light"));
    assert_eq!(heavy.frame.file, "scripts/behaviors/split.lua");
    assert_eq!((heavy.frame.line, light.frame.line), (1, 6), "linedefined");
    let ratio = heavy.self_samples as f64 / light.self_samples.max(1) as f64;
    assert!(
        (4.0..25.0).contains(&ratio),
        "heavy/light samples {} / {} = {ratio}",
        heavy.self_samples,
        light.self_samples
    );
    assert_eq!(m.functions[0].frame.name, "heavy", "most self time first");
    // The tick calls both: on the stack in (nearly) every sample, its own code nearly never.
    let tick = m
        .functions
        .iter()
        .find(|f| f.frame.line == 11)
        .expect("the tick function, defined at line 11");
    assert!(tick.total_share > 0.95, "{tick:?}");
    // Time estimated from the shares adds up to the module's measured time.
    let est: f64 = m.functions.iter().map(|f| f.self_ms_per_sim_s).sum();
    assert!((est - m.ms_per_sim_s).abs() < 1e-6 * m.ms_per_sim_s.max(1.0));
    assert!(
        m.stacks[0].frames.last().unwrap().starts_with("heavy ("),
        "{:?}",
        m.stacks[0]
    );

    // Off: nothing more is sampled.
    sim.set_function_sampling(None);
    sim.reset_profile();
    sim.run(1.0);
    let p = sim.profile();
    assert_eq!(p.iter().find(|m| m.module == "split").unwrap().samples, 0);
}

#[test]
fn samples_are_kept_per_module_as_the_cost_is_split() {
    let (_dir, root) = common::scratch_repo();
    let dir = root.join("scripts/behaviors");
    let behavior = |n: u32| {
        format!(
            "local function work(n)\n  local x = 0\n  for i = 1, n do x = x + math.sin(i) end\n  return x\nend\nreturn {{ tick = function(fish) fish.memory.x = work({n}) end }}\n"
        )
    };
    std::fs::write(dir.join("heavy.lua"), behavior(30_000)).unwrap();
    std::fs::write(dir.join("light.lua"), behavior(3_000)).unwrap();
    let mut sim = common::sim_in(&root, 3);
    sim.set_function_sampling(Some(shoal_script::sim::SAMPLE_EVERY));
    spawn_row(&mut sim, "heavy", 10, 150.0);
    spawn_row(&mut sim, "light", 10, 100.0);
    sim.run(4.0);
    let p = sim.profile();
    let get = |name: &str| p.iter().find(|m| m.module == name).unwrap().clone();
    let (heavy, light) = (get("heavy"), get("light"));
    if cfg!(target_os = "linux") {
        assert!(heavy.samples >= 100, "{}", heavy.samples);
        let ratio = heavy.samples as f64 / light.samples.max(1) as f64;
        assert!((4.0..25.0).contains(&ratio), "{heavy:?} {light:?}");
        // Each module's functions are its own file's.
        assert!(
            heavy
                .functions
                .iter()
                .all(|f| f.frame.file == "scripts/behaviors/heavy.lua"),
            "{:?}",
            heavy.functions
        );
        assert_eq!(heavy.functions[0].frame.name, "work");
        assert_eq!(heavy.functions[0].frame.line, 1);
    } else {
        assert_eq!(heavy.samples + light.samples, 0, "sampled only on Linux");
    }
}

#[test]
fn a_module_that_allocates_is_charged_its_bytes() {
    let (_dir, root) = common::scratch_repo();
    let dir = root.join("scripts/behaviors");
    // 100 tables of 8 array slots per decision: at least 100 × (table + 8 × 16 bytes).
    std::fs::write(
        dir.join("hoarder.lua"),
        "return { tick = function(fish)\n  local t = {}\n  for i = 1, 100 do t[i] = { 1, 2, 3, 4, 5, 6, 7, 8 } end\n  fish.memory.n = #t\nend }\n",
    )
    .unwrap();
    std::fs::write(
        dir.join("frugal.lua"),
        "return { tick = function(fish)\n  local x = 0\n  for i = 1, 100 do x = x + i * 0.5 end\n  fish.memory.n = x\nend }\n",
    )
    .unwrap();
    let mut sim = common::sim_in(&root, 3);
    spawn_row(&mut sim, "hoarder", 5, 150.0);
    spawn_row(&mut sim, "frugal", 5, 100.0);
    sim.run(1.0);
    sim.reset_profile();
    sim.run(2.0);
    let p = sim.profile();
    let get = |name: &str| p.iter().find(|m| m.module == name).unwrap().clone();
    let (hoarder, frugal) = (get("hoarder"), get("frugal"));
    assert_eq!((hoarder.calls, frugal.calls), (100, 100));
    assert!(
        hoarder.alloc_bytes_per_call > 100.0 * (56.0 + 8.0 * 16.0),
        "{hoarder:?}"
    );
    // Once its fish have their tables, a decision of frugal allocates (next to) nothing.
    assert!(frugal.alloc_bytes_per_call < 64.0, "{frugal:?}");
    assert!(
        (hoarder.alloc_kib_per_sim_s - hoarder.alloc_bytes_per_call * 50.0 / 1024.0).abs() < 1.0
    );
    assert!(sim.script_memory() > 0);
}

/// A call metered from its first instruction is sampled by its budget hook, which is not re-armed
/// for the samples: the instruction count, and so where the budget stops the call, is exactly
/// what it is without sampling.
#[cfg(target_os = "linux")]
#[test]
fn sampling_a_metered_call_leaves_its_instruction_count_exact() {
    use shoal_core::world::FishId;
    use shoal_script::{Limits, ScriptHost};
    use std::time::Duration;

    let (_dir, root) = common::scratch_repo();
    std::fs::write(
        root.join("scripts/behaviors/counter.lua"),
        "return { tick = function(fish)\n  local m = fish.memory\n  for i = 1, math.huge do m.i = i end\nend }\n",
    )
    .unwrap();
    let limits = Limits {
        instructions_per_call: 5_000_000,
        metered_after: Duration::ZERO,
        time_per_call: Duration::from_secs(20),
        ..Limits::default()
    };
    let fish = FishId {
        index: 0,
        generation: 0,
    };
    let stopped_at = |sample: bool| {
        let mut h = ScriptHost::new(&root.join("scripts"), limits).unwrap();
        let m = h.module("counter", 0.0).unwrap();
        if sample {
            h.meter()
                .set_sampling(Some(shoal_script::sim::SAMPLE_EVERY));
        }
        h.meter().set_tag(Some(m));
        let t = h.fish_table(fish, "black_porgy", "counter").unwrap();
        let err = h.run(m, fish, &t, 0.0).unwrap_err().to_string();
        assert!(
            err.starts_with("scripts/behaviors/counter.lua:3: instruction budget exceeded"),
            "{err}"
        );
        (
            h.memory_json(fish)["i"].as_i64().unwrap(),
            h.meter().sampler().taken(),
        )
    };
    let (plain, none) = stopped_at(false);
    let (sampled, samples) = stopped_at(true);
    assert_eq!(none, 0);
    assert!(samples >= 5, "{samples} samples of a call of tens of ms");
    assert_eq!(
        plain, sampled,
        "the budget stops the loop at the same iteration"
    );
}
