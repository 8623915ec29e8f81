//! The per-module profile (issue 17): what each behaviour's decisions cost, checked against
//! scripts with a known split of work.

mod common;

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

fn get_calls(sim: &shoal::script::Simulation, name: &str) -> u64 {
    sim.profile()
        .iter()
        .find(|m| m.module == name)
        .map_or(0, |m| m.calls)
}
