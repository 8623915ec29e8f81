//! The designer's live loop: what a new user hits first. A behaviour that keeps failing is
//! switched off, prints say when, which fish and where, scene and species files reject unknown
//! keys and names with a suggestion and name the field, and scene groups hand `params` to their
//! fish. Each test failed before its fix.

use crate::common;

use std::path::{Path, PathBuf};

use shoal_script::{ReloadEvent, Simulation};

/// A scratch copy of the repository with `files` (path under the root, source) written.
fn scratch(files: &[(&str, &str)]) -> (tempfile::TempDir, PathBuf) {
    let (dir, root) = common::scratch_repo();
    for (path, source) in files {
        let p = root.join(path);
        std::fs::create_dir_all(p.parent().unwrap()).unwrap();
        std::fs::write(p, source).unwrap();
    }
    (dir, root)
}

fn scene_of(groups: &str) -> String {
    format!(
        "return {{\n  tank = {{ min = {{-400, 0, -250}}, max = {{400, 300, 250}} }},\n  fish = {{\n{groups}\n  }},\n}}\n"
    )
}

fn load_err(root: &Path, scene: &str) -> String {
    match Simulation::from_scene(root, Path::new(scene), 1) {
        Ok(_) => panic!("{scene} should not load"),
        Err(e) => e.to_string(),
    }
}

#[test]
fn a_runaway_behaviour_is_switched_off_and_its_fish_cost_nothing_until_the_file_is_saved() {
    let (_d, root) = scratch(&[
        (
            "scripts/behaviors/runaway.lua",
            "return { tick = function(fish) while true do end end }\n",
        ),
        (
            "scripts/scenes/runaway.lua",
            &scene_of(
                r#"    { species = "black_porgy", count = 12, behavior = "runaway" },
    { species = "black_porgy", count = 6, behavior = "wander" },"#,
            ),
        ),
    ]);
    let mut sim = Simulation::from_scene(&root, Path::new("scenes/runaway.lua"), 4).unwrap();
    sim.run(3.0);
    let off = sim.switched_off();
    assert_eq!(off.len(), 1, "{off:?}");
    assert_eq!(off[0].0, "runaway");
    assert!(off[0].1.contains("budget"), "{off:?}");
    // The console says so, once, as a warning (the budget errors themselves are errors).
    let lines: Vec<String> = sim.drain_log().iter().map(|e| e.to_string()).collect();
    let notices: Vec<&String> = lines
        .iter()
        .filter(|l| l.contains("switched off"))
        .collect();
    assert_eq!(notices.len(), 1, "{lines:#?}");
    assert!(
        notices[0].contains("warning") && notices[0].contains("behaviors/runaway.lua"),
        "{notices:?}"
    );
    assert!(
        sim.error_messages()
            .iter()
            .any(|e| e.contains("runaway.lua:1:")),
        "the budget error names file:line: {:?}",
        sim.error_messages()
    );
    // Switched off: the next decisions of its fish are not run at all; the wanderers still are.
    let mut decided = 0;
    for _ in 0..12 {
        sim.step();
        decided += sim.world().counters().decisions;
    }
    assert_eq!(decided, 12, "12 ticks × (6 wanderers / period 6) decisions");
    // The inspector says so.
    let id = sim.world().fish_ids().next().unwrap();
    let behavior = sim
        .inspect(id)
        .into_iter()
        .find(|(k, _)| k == "behavior")
        .unwrap()
        .1;
    assert!(behavior.contains("switched off"), "{behavior}");
    // Saving the fixed file runs it again.
    let fixed = root.join("scripts/behaviors/runaway.lua");
    std::fs::write(
        &fixed,
        "return { tick = function(fish) fish.memory.ok = true end }\n",
    )
    .unwrap();
    let events = sim.reload_changed(&[fixed]);
    assert!(
        events
            .iter()
            .any(|e| matches!(e, ReloadEvent::Behaviors(n) if n.contains(&"runaway".to_owned()))),
        "{events:?}"
    );
    assert!(sim.switched_off().is_empty());
    sim.run(0.5);
    assert_eq!(sim.memory_json(id)["ok"], serde_json::json!(true));
}

#[test]
fn a_behaviour_that_errors_on_every_call_is_switched_off_after_a_few_strikes() {
    let (_d, root) = scratch(&[
        (
            "scripts/behaviors/broken.lua",
            "return { tick = function(fish) error('no reef here') end }\n",
        ),
        (
            "scripts/scenes/broken.lua",
            &scene_of(r#"    { species = "black_porgy", count = 3, behavior = "broken" },"#),
        ),
    ]);
    let mut sim = Simulation::from_scene(&root, Path::new("scenes/broken.lua"), 4).unwrap();
    sim.step();
    assert!(
        sim.switched_off().is_empty(),
        "one failed decision is not yet a quarantine"
    );
    sim.run(1.0);
    let off = sim.switched_off();
    assert_eq!(off.len(), 1, "{off:?}");
    assert!(off[0].1.contains("failed calls in a row"), "{off:?}");
}

#[test]
fn prints_carry_time_fish_and_line_and_repeats_are_counted() {
    let (_d, root) = scratch(&[
        (
            "scripts/behaviors/chatty.lua",
            "return { tick = function(fish)\n  print('hello from', fish.species)\nend }\n",
        ),
        (
            "scripts/scenes/chatty.lua",
            &scene_of(r#"    { species = "black_porgy", count = 2, behavior = "chatty" },"#),
        ),
    ]);
    let mut sim = Simulation::from_scene(&root, Path::new("scenes/chatty.lua"), 4).unwrap();
    sim.run(1.0);
    let lines: Vec<String> = sim.drain_log().iter().map(|e| e.to_string()).collect();
    // Two fish, ten decisions a second each: not one collapsed line.
    let fish0: Vec<&String> = lines.iter().filter(|l| l.contains("fish #0 ")).collect();
    let fish1: Vec<&String> = lines.iter().filter(|l| l.contains("fish #1 ")).collect();
    assert!(!fish0.is_empty() && !fish1.is_empty(), "{lines:#?}");
    for l in &lines {
        assert!(l.contains("chatty.lua:2: hello from\tblack_porgy"), "{l}");
        assert!(!l.starts_with("[0.00 s]") || l.contains("fish #"), "{l}");
    }
    let repeats: u64 = sim.drain_log().iter().map(|e| e.repeats + 1).sum();
    assert_eq!(repeats, 0, "drained");
    // Over the second, each print is there once per decision: counted, not dropped.
    let mut sim = Simulation::from_scene(&root, Path::new("scenes/chatty.lua"), 4).unwrap();
    sim.run(1.0);
    let total: u64 = sim.drain_log().iter().map(|e| e.repeats + 1).sum();
    assert_eq!(total, 20, "2 fish × 10 decisions in 1 s");
    // Times are the decision's simulated time, not 0.
    sim.run(0.5);
    let later = sim.drain_log();
    assert!(later.iter().all(|e| e.time_s >= 1.0), "{later:?}");
}

#[test]
fn unknown_scene_keys_are_errors_with_the_field_and_a_suggestion() {
    let (_d, root) = scratch(&[(
        "scripts/scenes/typo.lua",
        &scene_of(
            r#"    { species = "black_porgy", count = 2, behavior = "wander" },
    { species = "black_porgy", count = 30, behaviour = "school" },"#,
        ),
    )]);
    let e = load_err(&root, "scenes/typo.lua");
    assert!(e.contains("scripts/scenes/typo.lua"), "{e}");
    assert!(
        e.contains("fish[2]"),
        "names the group as Lua counts it: {e}"
    );
    assert!(e.contains("unknown key \"behaviour\""), "{e}");
    assert!(e.contains("did you mean \"behavior\"?"), "{e}");
}

#[test]
fn unknown_behaviour_and_species_names_are_errors_with_a_suggestion() {
    let (_d, root) = scratch(&[
        (
            "scripts/scenes/b.lua",
            &scene_of(r#"    { species = "black_porgy", behavior = "schol" },"#),
        ),
        (
            "scripts/scenes/s.lua",
            &scene_of(r#"    { species = "black_porgie" },"#),
        ),
    ]);
    let e = load_err(&root, "scenes/b.lua");
    assert!(e.contains("fish[1].behavior"), "{e}");
    assert!(e.contains("did you mean \"school\"?"), "{e}");
    let e = load_err(&root, "scenes/s.lua");
    assert!(e.contains("fish[1].species"), "{e}");
    assert!(e.contains("did you mean \"black_porgy\"?"), "{e}");
}

#[test]
fn out_of_range_numbers_name_the_field_and_the_range_in_designer_words() {
    let (_d, root) = scratch(&[
        (
            "scripts/scenes/neg.lua",
            &scene_of(r#"    { species = "black_porgy", count = -5 },"#),
        ),
        (
            "scripts/scenes/speed.lua",
            &scene_of(r#"    { species = "black_porgy", speed = -3 },"#),
        ),
        (
            "scripts/scenes/rock.lua",
            "return { tank = { min = {-400, 0, -250}, max = {400, 300, 250} },\n  obstacles = { { pos = {0, 0, 0}, radius = 0 } } }\n",
        ),
    ]);
    let e = load_err(&root, "scenes/neg.lua");
    assert!(e.contains("fish[1].count"), "{e}");
    assert!(e.contains("got -5, expected a whole number ≥ 0"), "{e}");
    assert!(
        !e.contains("deserialize error") && !e.contains("u32"),
        "{e}"
    );
    let e = load_err(&root, "scenes/speed.lua");
    assert!(e.contains("fish[1].speed: -3"), "{e}");
    assert!(e.contains("world units per second"), "{e}");
    let e = load_err(&root, "scenes/rock.lua");
    assert!(e.contains("obstacles[1].radius"), "{e}");
}

#[test]
fn a_scene_outside_scripts_is_named_by_its_path() {
    let dir = tempfile::tempdir().unwrap();
    let scene = dir.path().join("elsewhere.lua");
    std::fs::write(
        &scene,
        scene_of(r#"    { species = "black_porgy", count = -1 },"#),
    )
    .unwrap();
    let e = match Simulation::from_scene(common::repo(), &scene, 1) {
        Ok(_) => panic!("should not load"),
        Err(e) => e.to_string(),
    };
    assert!(e.starts_with(&scene.display().to_string()), "{e}");
    assert!(!e.contains("scripts//"), "{e}");
}

#[test]
fn unknown_species_keys_are_errors_with_a_suggestion() {
    let (_d, root) = scratch(&[
        (
            "scripts/species/typo_fish.lua",
            "return { base = \"black_porgy\", name = \"typo_fish\", motion = { lamda = 40 } }\n",
        ),
        (
            "scripts/scenes/t.lua",
            &scene_of(r#"    { species = "typo_fish" },"#),
        ),
    ]);
    let e = load_err(&root, "scenes/t.lua");
    assert!(e.contains("typo_fish.lua"), "{e}");
    assert!(e.contains("motion.lamda"), "{e}");
    assert!(e.contains("did you mean \"lambda\"?"), "{e}");
}

/// Motion values out of range are refused when the species loads, naming the file and the field
/// (issue 16's turning axis and front wave included), instead of swimming a broken fish.
#[test]
fn out_of_range_motion_values_are_errors_naming_the_field() {
    for (motion, needle) in [
        ("turn_axis = 2", "turn_axis = 2"),
        ("turn_axis = 0/0", "turn_axis = NaN"),
        ("front_amp = -0.1", "front_amp = -0.1"),
        ("p = 0.1", "p = 0.1"),
        (
            "front_wave = \"wiggle\"",
            "`recoil`, `travelling`, `anguilliform`",
        ),
    ] {
        let (_d, root) = scratch(&[
            (
                "scripts/species/odd_fish.lua",
                &format!(
                    "return {{ base = \"black_porgy\", name = \"odd_fish\", motion = {{ {motion} }} }}\n"
                ),
            ),
            (
                "scripts/scenes/t.lua",
                &scene_of(r#"    { species = "odd_fish" },"#),
            ),
        ]);
        let e = load_err(&root, "scenes/t.lua");
        assert!(e.contains("odd_fish.lua"), "{motion}: {e}");
        assert!(e.contains(needle), "{motion}: {e}");
    }
}

#[test]
fn scene_params_reach_the_fish_as_fish_params() {
    let (_d, root) = scratch(&[
        (
            "scripts/behaviors/patrol_probe.lua",
            "return { tick = function(fish)\n  local w = fish.params.waypoints\n  fish.memory.n = #w\n  fish.memory.first_x = w[1][1]\n  fish.memory.name = fish.params.name or 'none'\nend }\n",
        ),
        (
            "scripts/scenes/p.lua",
            &scene_of(
                r#"    { species = "black_porgy", behavior = "patrol_probe",
      params = { name = "north", waypoints = { {-200, 150, 0}, {200, 150, 0}, {0, 150, 100} } } },
    { species = "black_porgy", behavior = "patrol_probe", params = { waypoints = { {5, 1, 1} } } },"#,
            ),
        ),
    ]);
    let mut sim = Simulation::from_scene(&root, Path::new("scenes/p.lua"), 2).unwrap();
    sim.run(0.5);
    common::assert_no_script_errors(&sim);
    let ids: Vec<_> = sim.world().fish_ids().collect();
    let a = sim.memory_json(ids[0]);
    let b = sim.memory_json(ids[1]);
    assert_eq!(a["n"], serde_json::json!(3));
    assert_eq!(a["first_x"], serde_json::json!(-200));
    assert_eq!(a["name"], serde_json::json!("north"));
    assert_eq!(b["n"], serde_json::json!(1));
    assert_eq!(b["name"], serde_json::json!("none"));
}

/// NaN or an infinity in a group's `params` is refused at load with its field path, as every
/// other non-finite number in a scene is, instead of reaching the fish as a userdata `null`.
#[test]
fn non_finite_scene_params_are_refused_with_their_field_path() {
    for (params, path, shown) in [
        (
            "{ hide_at = { 1, 0/0, 3 } }",
            "fish[2].params.hide_at[2]",
            "NaN",
        ),
        ("{ radius = 1/0 }", "fish[2].params.radius", "inf"),
        ("{ deep = { x = -1/0 } }", "fish[2].params.deep.x", "-inf"),
    ] {
        let (_d, root) = scratch(&[(
            "scripts/scenes/p.lua",
            &scene_of(&format!(
                "    {{ species = \"black_porgy\" }},\n    {{ species = \"black_porgy\", params = {params} }},"
            )),
        )]);
        let e = load_err(&root, "scenes/p.lua");
        assert!(e.contains("p.lua"), "{params}: {e}");
        assert!(
            e.contains(&format!("{path}: {shown} is not a finite number")),
            "{params}: {e}"
        );
    }
}

/// A logpoint whose `{expression}` fails is the logpoint's failure: one warning naming it, no
/// error counted against the behaviour, and the behaviour runs on (issue 36, finding 4).
#[test]
fn a_logpoint_whose_expression_fails_is_not_an_error_of_the_behaviour() {
    let (_d, root) = scratch(&[
        (
            "scripts/behaviors/shy.lua",
            "return { tick = function(fish)\n  local m = fish.memory\n  m.n = (m.n or 0) + 1\nend }\n",
        ),
        (
            "scripts/scenes/s.lua",
            &scene_of(r#"    { species = "black_porgy", count = 3, behavior = "shy" },"#),
        ),
    ]);
    let mut sim = Simulation::from_scene(&root, Path::new("scenes/s.lua"), 1).unwrap();
    sim.set_logpoints(
        "behaviors/shy.lua",
        vec![shoal_script::logpoints::Logpoint {
            line: 3,
            message: "rock {m.rock[1]} n {m.n}".into(),
        }],
    )
    .unwrap();
    sim.run(2.0);
    assert!(
        sim.error_messages().is_empty(),
        "{:?}",
        sim.error_messages()
    );
    let shy = sim
        .profile()
        .into_iter()
        .find(|m| m.module == "shy")
        .unwrap();
    assert!(shy.calls > 20, "{shy:?}");
    assert_eq!(shy.errors, 0, "a logpoint's failure is not the module's");
    let ids: Vec<_> = sim.world().fish_ids().collect();
    assert!(
        sim.memory_json(ids[0])["n"].as_u64().unwrap() > 10,
        "the behaviour ran on"
    );
    let log = sim.drain_log();
    let failed: Vec<_> = log
        .iter()
        .filter(|e| e.message.contains("logpoint {m.rock[1]} failed"))
        .collect();
    assert_eq!(failed.len(), 1, "shown once: {log:?}");
    assert_eq!(failed[0].level, shoal_script::log::LogLevel::Warning);
    assert!(
        failed[0].message.contains("shy.lua:3:"),
        "{}",
        failed[0].message
    );
    assert!(
        !log.iter()
            .any(|e| e.level == shoal_script::log::LogLevel::Error),
        "{log:?}"
    );
}

#[test]
fn spawning_with_an_unknown_behaviour_or_species_says_what_exists() {
    let mut sim = Simulation::empty(common::repo(), 1).unwrap();
    let e = sim
        .spawn(
            "black_porgy",
            glam::Vec3::new(0.0, 100.0, 0.0),
            0.0,
            0.0,
            None,
            Some("forrage"),
        )
        .unwrap_err()
        .to_string();
    assert!(e.contains("did you mean \"forage\"?"), "{e}");
    let e = sim
        .spawn(
            "eal",
            glam::Vec3::new(0.0, 100.0, 0.0),
            0.0,
            0.0,
            None,
            None,
        )
        .unwrap_err()
        .to_string();
    assert!(e.contains("did you mean \"eel\"?"), "{e}");
}

#[test]
fn reload_events_read_as_sentences_in_the_console() {
    assert_eq!(
        ReloadEvent::Behaviors(vec!["forage".into()]).to_string(),
        "reloaded behaviour forage"
    );
    let failed = ReloadEvent::Failed("scripts/behaviors/forage.lua:3: 'end' expected".into());
    assert_eq!(
        failed.to_string(),
        "scripts/behaviors/forage.lua: reload failed, the last good version keeps running"
    );
    assert!(
        !ReloadEvent::SceneChanged
            .to_string()
            .contains("SceneChanged")
    );
}

#[test]
fn an_error_raised_in_every_lane_reaches_the_console_once() {
    let (_d, root) = scratch(&[
        (
            "scripts/behaviors/broken.lua",
            "return { tick = function(fish) error('no reef here') end }\n",
        ),
        (
            "scripts/scenes/broken.lua",
            &scene_of(r#"    { species = "black_porgy", count = 16, behavior = "broken" },"#),
        ),
    ]);
    let mut sim = Simulation::from_scene(&root, Path::new("scenes/broken.lua"), 4).unwrap();
    sim.set_lanes(4).unwrap();
    sim.run(1.0);
    let lines: Vec<String> = sim.drain_log().iter().map(|e| e.to_string()).collect();
    let errors = lines.iter().filter(|l| l.contains("no reef here")).count();
    assert_eq!(errors, 1, "{lines:#?}");
}

#[test]
fn a_species_can_cut_its_models_alpha_at_its_own_cutoff() {
    let (_d, root) = scratch(&[
        (
            "scripts/species/masked.lua",
            "return { base = \"black_porgy\", name = \"masked\", alpha_cutoff = 0.5 }\n",
        ),
        (
            "scripts/species/bad_cut.lua",
            "return { base = \"black_porgy\", name = \"bad_cut\", alpha_cutoff = 2 }\n",
        ),
    ]);
    let mut sim = Simulation::empty(&root, 1).unwrap();
    let id = sim.species_id("masked").unwrap();
    assert_eq!(
        sim.world().species(id).model.mesh.material().alpha_mode,
        shoal_core::skin::AlphaMode::Mask { cutoff: 0.5 }
    );
    let porgy = sim.species_id("black_porgy").unwrap();
    assert_eq!(
        sim.world().species(porgy).model.mesh.material().alpha_mode,
        shoal_core::skin::AlphaMode::Opaque,
        "without the field the file's alpha mode stands"
    );
    let e = sim.species_id("bad_cut").unwrap_err().to_string();
    assert!(e.contains("alpha_cutoff") && e.contains("(0, 1]"), "{e}");
}

/// Every lane loads the module, so a print at its top level (no fish) and the "runs again"
/// notice after a save used to reach the console once per lane.
#[test]
fn what_no_fish_said_reaches_the_console_once_whatever_the_lanes() {
    let (_d, root) = scratch(&[
        (
            "scripts/behaviors/loud.lua",
            "print('loud loaded')\nreturn { tick = function(fish) print('tick') end }\n",
        ),
        (
            "scripts/scenes/loud.lua",
            &scene_of(r#"    { species = "black_porgy", count = 16, behavior = "loud" },"#),
        ),
    ]);
    let mut sim = Simulation::from_scene(&root, Path::new("scenes/loud.lua"), 4).unwrap();
    sim.set_lanes(4).unwrap();
    sim.run(1.0);
    let lines: Vec<String> = sim.drain_log().iter().map(|e| e.to_string()).collect();
    assert_eq!(
        lines.iter().filter(|l| l.contains("loud loaded")).count(),
        1,
        "{lines:#?}"
    );
    // Each fish's own prints all stay (one line per fish at least, repeats counted on it).
    assert!(
        lines.iter().filter(|l| l.contains(": tick")).count() >= 16,
        "{lines:#?}"
    );
}
