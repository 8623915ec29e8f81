//! The panel's Scripts section (issue 17), driven by widget label (`egui_kittest`) over the real
//! default aquarium: the per-module profile, the Lua console in the selected fish's context, and
//! watches plotted over time.

use crate::common;

use std::path::Path;

use egui_kittest::Harness;
use egui_kittest::kittest::Queryable;
use shoal_app::{AppOptions, Aquarium, Showable};
use shoal_core::world::FishId;
use shoal_script::Simulation;

const DT: f32 = 1.0 / 60.0;

/// The default aquarium with its first forager selected.
fn aquarium() -> (Aquarium, FishId) {
    let sim = Simulation::from_scene(common::repo(), Path::new("scenes/default.lua"), 5).unwrap();
    let forager = sim
        .world()
        .fish_ids()
        .find(|&id| sim.world().behavior_of(id) == Some("forage"))
        .expect("the default scene has foragers");
    let options = AppOptions {
        select: Some(forager),
        ..AppOptions::default()
    };
    (Aquarium::new(Box::new(sim), options), forager)
}

fn harness(aq: Aquarium) -> Harness<'static, Aquarium> {
    Harness::builder()
        .with_size(egui::vec2(560.0, 2600.0))
        .build_ui_state(|ui, aq: &mut Aquarium| aq.panel(ui), aq)
}

fn play(h: &mut Harness<'static, Aquarium>, ticks: usize) {
    for _ in 0..ticks {
        h.state_mut().advance(DT);
    }
    h.run();
}

fn type_into(h: &mut Harness<'static, Aquarium>, label: &str, text: &str) {
    h.get_by_role_and_label(egui::accesskit::Role::TextInput, label)
        .click();
    h.run();
    h.get_by_role_and_label(egui::accesskit::Role::TextInput, label)
        .type_text(text);
    h.run();
}

#[test]
fn the_profile_lists_each_behaviour_module_and_sorts() {
    let (aq, _) = aquarium();
    let mut h = harness(aq);
    play(&mut h, 120);
    let modules: Vec<String> = h
        .state()
        .scripts()
        .profile
        .iter()
        .map(|p| p.module.clone())
        .collect();
    for m in ["school", "forage", "wander", "predator"] {
        assert!(modules.iter().any(|x| x == m), "{m} in {modules:?}");
        assert!(
            h.query_all_by_label(m).next().is_some(),
            "the table shows {m}"
        );
    }
    let cost: Vec<f64> = h
        .state()
        .scripts()
        .profile
        .iter()
        .map(|p| p.ms_per_sim_s)
        .collect();
    assert!(
        cost.windows(2).all(|w| w[0] >= w[1]),
        "most expensive first: {cost:?}"
    );
    h.get_by_label("name").click();
    h.run();
    h.state_mut().advance(0.0);
    let names: Vec<String> = h
        .state()
        .scripts()
        .profile
        .iter()
        .map(|p| p.module.clone())
        .collect();
    let mut sorted = names.clone();
    sorted.sort();
    assert_eq!(names, sorted);
    // The school (30 fish) costs more per simulated second than the two wandering eels.
    let p = &h.state().scripts().profile;
    let of = |m: &str| p.iter().find(|x| x.module == m).unwrap().ms_per_sim_s;
    assert!(of("school") > of("wander"), "{p:?}");
}

#[test]
fn the_console_evaluates_lua_in_the_selected_fishs_context() {
    let (aq, fish) = aquarium();
    let mut h = harness(aq);
    play(&mut h, 60);
    type_into(&mut h, "lua", "fish.memory.hunger ~= nil and 42 or -1");
    h.get_by_label("eval").click();
    h.run();
    let console: Vec<String> = h.state().console().map(str::to_owned).collect();
    assert!(
        console
            .iter()
            .any(|l| l.contains("> fish.memory.hunger ~= nil and 42 or -1")
                && l.contains(&format!("fish #{}", fish.index))),
        "{console:?}"
    );
    assert!(console.iter().any(|l| l == "= 42"), "{console:?}");
    // The sandbox applies: no os library.
    let err = h
        .state()
        .scene
        .sim()
        .eval_fish(fish, "os.execute('true')")
        .unwrap_err()
        .to_string();
    assert!(err.contains("execute"), "{err}");
}

#[test]
fn watches_plot_expressions_over_the_selected_fish() {
    let (aq, _) = aquarium();
    let mut h = harness(aq);
    play(&mut h, 30);
    type_into(&mut h, "watch", "memory.hunger");
    h.get_by_label("add watch").click();
    h.run();
    type_into(&mut h, "watch", "speed");
    h.get_by_label("add watch").click();
    h.run();
    type_into(&mut h, "watch", "percepts.no_such_field.x");
    h.get_by_label("add watch").click();
    h.run();
    let exprs: Vec<String> = h
        .state()
        .scripts()
        .watches
        .iter()
        .map(|w| w.expr.clone())
        .collect();
    assert_eq!(
        exprs,
        ["memory.hunger", "speed", "percepts.no_such_field.x"]
    );
    play(&mut h, 300);
    let w = &h.state().scripts().watches;
    let hunger = &w[0].points;
    assert!(hunger.len() >= 290, "a point a tick: {}", hunger.len());
    let (first, last) = (hunger.front().unwrap(), hunger.back().unwrap());
    assert!(last[0] > first[0] + 4.5, "over simulated time");
    assert!(last[1] > first[1], "hunger rises: {first:?} → {last:?}");
    assert!(w[1].points.iter().all(|p| p[1] > 0.0), "the fish swims");
    assert!(
        w[2].last
            .as_ref()
            .is_err_and(|e| e.contains("no_such_field")),
        "a failing watch says why: {:?}",
        w[2].last
    );
    assert!(h.query_by_label_contains("memory.hunger = ").is_some());
    // Removing one keeps the others.
    h.get_all_by_label("remove").next().unwrap().click();
    h.run();
    h.state_mut().advance(0.0);
    assert_eq!(h.state().scripts().watches.len(), 2);
}

#[test]
fn pause_when_stops_at_the_tick_a_fish_meets_the_condition_and_selects_it() {
    let (aq, forager) = aquarium();
    let mut h = harness(aq);
    play(&mut h, 60);
    let hunger = |h: &Harness<'static, Aquarium>, id: FishId| {
        h.state()
            .scene
            .sim()
            .eval_fish(id, "fish.memory.hunger")
            .unwrap()
            .as_f64()
            .unwrap()
    };
    let now = hunger(&h, forager);
    let threshold = now + 0.015;
    type_into(
        &mut h,
        "pause when",
        &format!("fish == fish and memory.hunger ~= nil and memory.hunger > {threshold}"),
    );
    h.get_by_label("set").click();
    h.run();
    // Frames of 0.1 s (6 ticks each): the pause lands on the very tick, mid-frame.
    let mut frames = 0;
    while !h.state().paused() && frames < 100 {
        h.state_mut().advance(0.1);
        frames += 1;
    }
    h.run();
    assert!(h.state().paused(), "the condition was met within 10 s");
    let fish = h
        .state()
        .selected()
        .expect("the fish that met it is selected");
    let after = hunger(&h, fish);
    assert!(after > threshold, "{after} > {threshold}");
    // One tick earlier it did not hold: step back and look.
    h.get_by_label("step back").click();
    h.run();
    h.state_mut().advance(0.0);
    assert!(
        hunger(&h, fish) <= threshold,
        "it started to hold at the tick paused at"
    );
    let console: Vec<String> = h.state().console().map(str::to_owned).collect();
    assert!(
        console.iter().any(
            |l| l.starts_with("paused at ") && l.contains(&format!("fish #{} met", fish.index))
        ),
        "{console:?}"
    );
    // A condition that cannot run says why and is cleared.
    let (aq, _) = aquarium();
    let mut h = harness(aq);
    play(&mut h, 60);
    type_into(&mut h, "pause when", "memory.hunger +");
    h.get_by_label("set").click();
    h.run();
    h.state_mut().advance(DT);
    assert!(
        h.state().scripts().pause_when.is_none(),
        "{:?} {:?}",
        h.state().scripts().pause_when,
        h.state().console().collect::<Vec<_>>()
    );
    assert!(h.state().console().any(|l| l.contains("condition cleared")));
}

#[test]
fn a_logpoint_prints_its_message_where_the_line_runs_without_pausing() {
    let (_dir, root) = common::scratch_repo();
    let sim = Simulation::from_scene(&root, Path::new("scenes/default.lua"), 5).unwrap();
    let mut h = harness(Aquarium::new(Box::new(sim), AppOptions::default()));
    play(&mut h, 30);
    let forage = std::fs::read_to_string(root.join("scripts/behaviors/forage.lua")).unwrap();
    let line = forage
        .lines()
        .position(|l| l.trim() == "if intention == \"flee\" then")
        .expect("forage.lua's behave starts with the flee branch")
        + 1;
    type_into(
        &mut h,
        "logpoint",
        &format!("behaviors/forage.lua:{line} {{intention}} hunger={{fish.memory.hunger > 0}}"),
    );
    h.get_by_label("add logpoint").click();
    h.run();
    play(&mut h, 120);
    assert!(!h.state().paused(), "a logpoint does not pause");
    let console: Vec<String> = h.state().console().map(str::to_owned).collect();
    let hits: Vec<&String> = console
        .iter()
        .filter(|l| l.contains(&format!("forage.lua:{line}: logpoint: ")))
        .collect();
    assert!(
        hits.iter()
            .any(|l| l.contains("hunger=true") && l.contains("fish #")),
        "the foragers' decisions print, with the fish, the line's locals and expressions: {console:?}"
    );
    // The file itself is unchanged on disk.
    assert_eq!(
        std::fs::read_to_string(root.join("scripts/behaviors/forage.lua")).unwrap(),
        forage
    );
    // Removed: no more lines.
    h.get_by_label("remove logpoint").click();
    h.run();
    let before = h.state().console().count();
    play(&mut h, 120);
    assert!(
        h.state()
            .console()
            .skip(before)
            .all(|l| !l.contains("logpoint: ")),
        "{:?}",
        h.state().console().skip(before).collect::<Vec<_>>()
    );

    // A line that does not start a statement, and a bad place, are refused with the reason.
    let mut sim = Simulation::from_scene(&root, Path::new("scenes/default.lua"), 5).unwrap();
    let table_line = std::fs::read_to_string(root.join("scripts/scenes/default.lua"))
        .unwrap()
        .lines()
        .position(|l| l.contains("count = 4, behavior = \"forage\""))
        .unwrap()
        + 2;
    let e = sim
        .set_logpoints(
            "scenes/default.lua",
            vec![shoal_script::logpoints::Logpoint {
                line: table_line,
                message: "x".into(),
            }],
        )
        .unwrap_err()
        .to_string();
    assert!(e.contains("where a statement starts"), "{e}");
    let e = sim
        .set_logpoints("behaviors/nowhere.lua", vec![])
        .unwrap_err()
        .to_string();
    assert!(e.contains("no such script"), "{e}");
}

#[cfg(target_os = "linux")]
#[test]
fn sampling_functions_lists_the_hot_function_with_its_file_and_line() {
    let (_dir, root) = common::scratch_repo();
    std::fs::write(
        root.join("scripts/behaviors/split.lua"),
        common::split_behavior(2000),
    )
    .unwrap();
    let mut sim = common::sim_in(&root, 3);
    for k in 0..20 {
        let pos = glam::Vec3::new(-200.0 + 20.0 * k as f32, 150.0, 0.0);
        sim.spawn("black_porgy", pos, 0.0, 0.0, Some(40.0), Some("split"))
            .unwrap();
    }
    let mut h = harness(Aquarium::new(Box::new(sim), AppOptions::default()));
    play(&mut h, 30);
    assert!(
        h.state().scripts().top_functions.is_empty(),
        "no samples before the box is ticked"
    );
    h.get_by_label("sample functions").click();
    h.run();
    let mut samples = 0;
    for _ in 0..40 {
        play(&mut h, 30);
        samples = h.state().scripts().profile.iter().map(|p| p.samples).sum();
        if samples >= 100 {
            break;
        }
    }
    assert!(samples >= 100, "{samples} samples");
    let top = &h.state().scripts().top_functions;
    assert_eq!(top[0].function.frame.name, "heavy", "{top:#?}");
    assert_eq!(top[0].module, "split");
    // The table shows it with its file:line, as the designer reads it (and types it into the
    // logpoint field: relative to the scripts directory).
    assert!(h.query_by_label("heavy").is_some());
    assert!(h.query_by_label("behaviors/split.lua:1").is_some());
    assert!(h.query_by_label("behaviors/split.lua:6").is_some());
    // And the memory column is there.
    assert!(h.query_by_label("KiB alloc / sim s").is_some());
    // The flame view opens on the most sampled module.
    h.get_by_label("flame view").click();
    h.run();
    assert!(
        h.query_by_label_contains("most sampled stacks").is_some(),
        "the flame view says what it shows"
    );
    // Sortable: by name.
    h.get_by_label("function name").click();
    h.run();
    let names: Vec<String> = h
        .state()
        .scripts()
        .top_functions
        .iter()
        .map(|t| t.function.frame.name.clone())
        .collect();
    let mut sorted = names.clone();
    sorted.sort();
    assert_eq!(names, sorted);
}

/// Frames of a paused window until `done` holds (the file watcher reports within a quarter
/// second; the deadline only stops a broken build from hanging).
fn frames_until(h: &mut Harness<'static, Aquarium>, done: impl Fn(&Aquarium) -> bool) -> bool {
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(20);
    while std::time::Instant::now() < deadline {
        h.state_mut().advance(DT);
        h.run();
        if done(h.state()) {
            return true;
        }
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    false
}

/// Saving while paused reloads at once: the console says so, a syntax error shows, and an
/// edited scene file brings up its notice, all without playing or stepping (issue 36, finding 6).
#[test]
fn saving_while_paused_reloads_at_once() {
    let (_dir, root) = common::scratch_repo();
    let sim = Simulation::from_scene(&root, Path::new("scenes/default.lua"), 5).unwrap();
    let mut aq = Aquarium::new(Box::new(sim), AppOptions::default());
    aq.scene.enable_hot_reload().unwrap();
    let mut h = harness(aq);
    play(&mut h, 10);
    h.get_by_label("pause").click();
    h.run();
    assert!(h.state().paused());
    let paused_at = h.state().scene.world().time();

    let forage = root.join("scripts/behaviors/forage.lua");
    let good = std::fs::read_to_string(&forage).unwrap();
    std::fs::write(&forage, format!("{good}\n-- tuned\n")).unwrap();
    assert!(
        frames_until(&mut h, |aq| aq
            .console()
            .any(|l| l.contains("forage") && l.contains("reloaded"))),
        "a save while paused is reloaded and said: {:?}",
        h.state().console().collect::<Vec<_>>()
    );
    std::fs::write(&forage, "local M = {\nreturn M\n").unwrap();
    assert!(
        frames_until(&mut h, |aq| aq
            .console()
            .any(|l| l.contains("forage.lua:") && l.contains("expected"))),
        "a syntax error saved while paused shows: {:?}",
        h.state().console().collect::<Vec<_>>()
    );
    let scene = root.join("scripts/scenes/default.lua");
    let text = std::fs::read_to_string(&scene).unwrap();
    // A real change (a comment alone changes nothing to restart for: the file then matches
    // the running scene).
    assert!(text.contains("food_lifetime = 90,"));
    std::fs::write(
        &scene,
        text.replacen("food_lifetime = 90,", "food_lifetime = 80,", 1),
    )
    .unwrap();
    assert!(frames_until(&mut h, |aq| aq.scene.scene_changed()));
    h.run();
    h.get_by_label("the scene file changed");
    h.get_by_label("restart scene");
    assert!(h.state().paused());
    assert_eq!(
        h.state().scene.world().time(),
        paused_at,
        "nothing ran while paused"
    );
}
