//! The LuaLS definitions in `scripts/types/shoal.lua` match the API the host registers, and the
//! shipped scripts load.

use std::collections::BTreeSet;
use std::path::PathBuf;

use shoal_script::host::ScriptHost;
use shoal_script::{Limits, SceneDesc, api};

fn repo_scripts() -> PathBuf {
    shoal_core::source_root().join("scripts")
}

fn host() -> ScriptHost {
    let h = ScriptHost::new(&repo_scripts(), Limits::default()).unwrap();
    api::register(h.lua()).unwrap();
    h
}

#[test]
fn test_definitions_match_registered_functions() {
    let h = host();
    let registered: BTreeSet<String> = api::registered_names(h.lua())
        .unwrap()
        .into_iter()
        .collect();
    let defs = std::fs::read_to_string(repo_scripts().join("types/shoal.lua")).unwrap();
    assert!(defs.starts_with("---@meta"), "LuaLS needs ---@meta first");
    let documented: BTreeSet<String> = defs
        .lines()
        .filter_map(|l| l.strip_prefix("function shoal."))
        .map(|rest| rest[..rest.find('(').expect("a parameter list")].to_owned())
        .collect();
    let missing: Vec<_> = registered.difference(&documented).collect();
    let stale: Vec<_> = documented.difference(&registered).collect();
    assert!(
        missing.is_empty(),
        "registered but not in shoal.lua: {missing:?}"
    );
    assert!(
        stale.is_empty(),
        "in shoal.lua but not registered: {stale:?}"
    );
    assert!(registered.len() >= 25, "{registered:?}");
    for f in [
        "see",
        "body",
        "steer",
        "separation",
        "avoid_walls",
        "eat",
        "random",
    ] {
        assert!(registered.contains(f), "{f}");
    }
}

#[test]
fn test_every_shipped_behaviour_loads() {
    let mut h = host();
    let mut names = Vec::new();
    for e in std::fs::read_dir(repo_scripts().join("behaviors")).unwrap() {
        let p = e.unwrap().path();
        if p.extension().is_some_and(|x| x == "lua") {
            names.push(p.file_stem().unwrap().to_string_lossy().into_owned());
        }
    }
    names.sort();
    assert_eq!(names, ["flee", "forage", "predator", "school", "wander"]);
    for n in &names {
        assert!(h.module(n, 0.0).is_some(), "{n}: {:?}", h.load_errors());
    }
    assert!(h.error_messages().is_empty(), "{:?}", h.error_messages());
}

#[test]
fn test_api_outside_a_tick_is_an_error() {
    let h = host();
    let err = h
        .eval("scripts/console.lua", "local b = shoal.body()\nreturn b")
        .unwrap_err()
        .to_string();
    assert_eq!(
        err,
        "scripts/console.lua:1: shoal.body can only be called while a fish's behaviour runs (from tick, perceive, intend or behave)"
    );
}

#[test]
fn test_shipped_scenes_parse() {
    let h = host();
    for (file, min_fish) in [("default.lua", 30), ("empty_tank.lua", 0)] {
        let v = h
            .load_data_file(&repo_scripts().join("scenes").join(file))
            .unwrap();
        let scene: SceneDesc = shoal_script::scene::scene_from_lua(v, file).unwrap();
        let n: u32 = scene.fish.iter().map(|g| g.count).sum();
        assert!(n >= min_fish, "{file}: {n} fish");
        assert!(
            scene
                .tank
                .min
                .iter()
                .zip(scene.tank.max)
                .all(|(a, b)| *a < b)
        );
    }
    let v = h
        .load_data_file(&repo_scripts().join("scenes/default.lua"))
        .unwrap();
    let scene: SceneDesc = shoal_script::scene::scene_from_lua(v, "default.lua").unwrap();
    assert_eq!(scene.measures, ["fleeing", "predator_distance_l"]);
    let behaviors: BTreeSet<_> = scene
        .fish
        .iter()
        .filter_map(|g| g.behavior.clone())
        .collect();
    assert!(
        behaviors.contains("school") && behaviors.contains("predator"),
        "{behaviors:?}"
    );
    assert!(scene.food_drops.is_some_and(|d| d.every > 0.0));
}

/// Every method and field the behaviour-test API registers (`t`, `w`, a test's fish and food)
/// is in `scripts/types/shoal_test.lua`, and nothing there is stale.
#[test]
fn test_api_definitions_match_the_test_handles() {
    let root = shoal_core::source_root();
    let mut registered = BTreeSet::new();
    for file in ["test_handle.rs", "world_handle.rs", "fish_handle.rs"] {
        let src =
            std::fs::read_to_string(root.join("crates/script/src/testing/api").join(file)).unwrap();
        // `add_method("name"`, `add_field_method_get("name"`, or the name on the next line.
        let mut rest = src.as_str();
        let next = |r: &str| {
            [
                r.find("methods.add_method("),
                r.find("fields.add_field_method_get("),
            ]
            .into_iter()
            .flatten()
            .min()
        };
        while let Some(i) = next(rest) {
            let after = &rest[i..];
            let open = after.find('"').unwrap();
            let close = open + 1 + after[open + 1..].find('"').unwrap();
            registered.insert(after[open + 1..close].to_owned());
            rest = &after[close..];
        }
    }
    registered.insert("test".to_owned());
    let defs = std::fs::read_to_string(root.join("scripts/types/shoal_test.lua")).unwrap();
    assert!(defs.starts_with("---@meta"));
    let mut documented = BTreeSet::new();
    let mut in_handle_class = false;
    for line in defs.lines() {
        if let Some(class) = line
            .strip_prefix("---@class shoal.")
            .or_else(|| line.strip_prefix("---@class (exact) shoal."))
        {
            in_handle_class = ["Test", "TestWorld", "TestFish", "TestFood"]
                .contains(&class.split_whitespace().next().unwrap_or(""));
        } else if let Some(f) = line.strip_prefix("---@field ")
            && in_handle_class
        {
            documented.insert(f.split(['?', ' ']).next().unwrap().to_owned());
        } else if let Some(f) = line.strip_prefix("function ") {
            let name = f[..f.find('(').unwrap()].rsplit([':', '.']).next().unwrap();
            documented.insert(name.to_owned());
        }
    }
    let missing: Vec<_> = registered.difference(&documented).collect();
    let stale: Vec<_> = documented.difference(&registered).collect();
    assert!(
        missing.is_empty(),
        "registered but not in shoal_test.lua: {missing:?}"
    );
    assert!(
        stale.is_empty(),
        "in shoal_test.lua but not registered: {stale:?}"
    );
    assert!(registered.len() > 35, "{registered:?}");
}

/// The `---@field` names of `---@class shoal.<class>` (or `(exact)`) in a definitions file.
fn class_fields(defs: &str, class: &str) -> BTreeSet<String> {
    let mut fields = BTreeSet::new();
    let mut inside = false;
    for line in defs.lines() {
        if let Some(rest) = line.strip_prefix("---@class ") {
            let name = rest
                .trim_start_matches("(exact) ")
                .split_whitespace()
                .next();
            inside = name == Some(&format!("shoal.{class}"));
        } else if !line.starts_with("---") {
            inside = false;
        } else if let Some(f) = line.strip_prefix("---@field ")
            && inside
        {
            fields.insert(f.split(['?', ' ']).next().unwrap().to_owned());
        }
    }
    assert!(!fields.is_empty(), "no class shoal.{class}");
    fields
}

fn keys(v: &serde_json::Value) -> BTreeSet<String> {
    v.as_object().unwrap().keys().cloned().collect()
}

/// The species file format in `shoal.lua` (`shoal.SpeciesFile`, its `motion` and `drives`) has
/// exactly the fields a species description has, and a test fish's `params`
/// (`shoal.TestMotionParams`) exactly those of its motion parameters: a field added in Rust
/// and not in the definitions (or removed) fails here.
#[test]
fn test_data_format_definitions_match_the_species_description() {
    let root = shoal_core::source_root();
    let defs = std::fs::read_to_string(root.join("scripts/types/shoal.lua")).unwrap();
    let test_defs = std::fs::read_to_string(root.join("scripts/types/shoal_test.lua")).unwrap();
    for desc in [
        shoal_core::species::SpeciesDesc::black_porgy(),
        shoal_core::species::SpeciesDesc::eel(),
    ] {
        let json = serde_json::to_value(&desc).unwrap();
        let mut top = keys(&json);
        // Read by the species loader beside the description (crates/script/src/scene.rs).
        top.extend(["base".to_owned(), "decision_hz".to_owned()]);
        assert_eq!(class_fields(&defs, "SpeciesFile"), top, "shoal.SpeciesFile");
        assert_eq!(
            class_fields(&defs, "MotionParams"),
            keys(&json["motion"]),
            "shoal.MotionParams"
        );
        assert_eq!(
            class_fields(&defs, "Drives"),
            keys(&json["drives"]),
            "shoal.Drives"
        );
        assert_eq!(
            class_fields(&test_defs, "TestMotionParams"),
            keys(&json["motion"]),
            "shoal.TestMotionParams"
        );
    }
}
