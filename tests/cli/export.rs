//! A recording out of shoal (issue 38): `shoal export` writes glTF that the Khronos validator
//! passes and that three.js (GLTFLoader + AnimationMixer under node, an implementation
//! independent of shoal) plays with every joint where `shoal inspect` says it is; bad input
//! gets one line each.

use crate::common;

use std::collections::HashMap;
use std::path::Path;
use std::process::Command;

use glam::Vec3;
use shoal_script::timeline::export::{self, ExportSpec};
use shoal_script::timeline::inputs::{Input, TimedInput};
use shoal_script::timeline::run_file::Run;
use shoal_script::timeline::{self, RecordSpec};

/// Runs the built `shoal` in `dir`: success, stdout, stderr.
fn shoal(dir: &Path, args: &[&str]) -> (bool, String, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_shoal"))
        .args(args)
        .current_dir(dir)
        .env("SHOAL_SCRIPTS", common::repo().join("scripts"))
        .output()
        .unwrap();
    (
        out.status.success(),
        String::from_utf8_lossy(&out.stdout).into_owned(),
        String::from_utf8_lossy(&out.stderr).into_owned(),
    )
}

/// Joint world positions three.js computes for `file` at `times`, by node name.
fn three_js_joints(file: &Path, times: &[f64]) -> HashMap<String, Vec<[f64; 3]>> {
    let tools = common::repo().join("tools");
    assert!(
        tools.join("node_modules/three").is_dir(),
        "three.js is not installed: run `npm ci` in tools/ (needs node and npm)"
    );
    let out = Command::new("node")
        .arg(tools.join("threejs-joints.mjs"))
        .arg(file)
        .args(times.iter().map(f64::to_string))
        .output()
        .expect("running node");
    assert!(
        out.status.success(),
        "three.js: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let v: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    v["joints"]
        .as_array()
        .unwrap()
        .iter()
        .map(|j| {
            let pos = j["pos"]
                .as_array()
                .unwrap()
                .iter()
                .map(|p| [0, 1, 2].map(|i| p[i].as_f64().unwrap()))
                .collect();
            (j["node"].as_str().unwrap().to_owned(), pos)
        })
        .collect()
}

#[test]
fn three_js_plays_the_exported_default_scene_with_every_joint_where_inspect_says() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (ok, out, err) = shoal(d, &["record", "--seconds", "10", "--out", "a.shoalrun"]);
    assert!(ok, "{out}{err}");
    let (ok, out, err) = shoal(d, &["export", "a.shoalrun", "--out", "a.glb"]);
    assert!(ok, "{out}{err}");
    assert!(out.contains("exported 37 fish"), "{out}");
    assert!(out.contains("601 keys"), "{out}");
    common::validate(&[&d.join("a.glb")]);

    let times = [0.0, 2.5, 5.0, 9.9];
    let three = three_js_joints(&d.join("a.glb"), &times);
    let mut compared = 0;
    for (i, t) in times.iter().enumerate() {
        let (ok, out, err) = shoal(
            d,
            &["inspect", "a.shoalrun", "--at", &t.to_string(), "--json"],
        );
        assert!(ok, "{err}");
        let ins: serde_json::Value = serde_json::from_str(&out).unwrap();
        let fish = ins["at"]["fish"].as_array().unwrap();
        assert_eq!(fish.len(), 37);
        for f in fish {
            let l = f["body_length"].as_f64().unwrap();
            for j in f["joints"].as_array().unwrap() {
                let node = j["node"].as_str().unwrap();
                let want = [0, 1, 2].map(|k| j["pos"][k].as_f64().unwrap());
                let got = three
                    .get(node)
                    .unwrap_or_else(|| panic!("three.js has no joint {node}"))[i];
                let dist = (0..3)
                    .map(|k| (got[k] - want[k]).powi(2))
                    .sum::<f64>()
                    .sqrt();
                assert!(
                    dist < 1e-3 * l,
                    "{node} at {t} s: three.js {got:?}, shoal inspect {want:?} ({} L apart)",
                    dist / l
                );
                compared += 1;
            }
        }
    }
    // Every joint three.js animates is one inspect reports.
    assert_eq!(compared, three.len() * times.len());

    // The .gltf form (JSON with a .bin beside it) is the same document.
    let (ok, out, err) = shoal(
        d,
        &[
            "export",
            "a.shoalrun",
            "--out",
            "b.gltf",
            "--fish",
            "0,35",
            "--to",
            "3",
            "--props",
        ],
    );
    assert!(ok, "{out}{err}");
    assert!(out.contains("exported 2 fish (black_porgy, eel)"), "{out}");
    assert!(d.join("b.bin").is_file());
    common::validate(&[&d.join("b.gltf")]);
    let b = three_js_joints(&d.join("b.gltf"), &[2.5]);
    for (node, pos) in &b {
        let a = &three[node][1];
        let dist = (0..3)
            .map(|k| (pos[0][k] - a[k]).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(dist < 1e-3, "{node}: {pos:?} against {a:?}");
    }
    assert!(
        b.keys()
            .all(|n| n.starts_with("fish_0_") || n.starts_with("fish_35_"))
    );
}

#[test]
fn bad_input_gets_one_clear_line_each() {
    let dir = tempfile::tempdir().unwrap();
    let d = dir.path();
    let (ok, out, err) = shoal(d, &["record", "--seconds", "1", "--out", "a.shoalrun"]);
    assert!(ok, "{out}{err}");
    std::fs::write(d.join("text.shoalrun"), "not a recording").unwrap();
    // A recording whose eel names a model the assets do not have.
    let mut run = Run::read(&d.join("a.shoalrun")).unwrap();
    let eel = run.header.scripts.get_mut("species/eel.lua").unwrap();
    assert!(eel.text.contains("base = \"eel\","));
    eel.text = eel.text.replace(
        "base = \"eel\",",
        "base = \"eel\", asset = \"no_such_eel.glb\",",
    );
    eel.crc32 = crc32fast::hash(eel.text.as_bytes());
    run.write(&d.join("noeel.shoalrun")).unwrap();

    let cases: [(&[&str], &[&str]); 7] = [
        (
            &["export", "text.shoalrun", "--out", "x.glb"],
            &["text.shoalrun", "not a shoal recording"],
        ),
        (
            &[
                "export",
                "a.shoalrun",
                "--out",
                "x.glb",
                "--from",
                "0.5",
                "--to",
                "0.5",
            ],
            &["--from 0.5 --to 0.5", "empty time range", "0 to 1.00 s"],
        ),
        (
            &["export", "a.shoalrun", "--out", "x.glb", "--fish", "3,99"],
            &["--fish", "#99 is not in the recording", "#0–#36"],
        ),
        (
            &["export", "noeel.shoalrun", "--out", "x.glb"],
            &["recording:species/eel.lua", "no_such_eel.glb"],
        ),
        (
            &[
                "export",
                "a.shoalrun",
                "--out",
                "x.glb",
                "--memory-limit",
                "1",
            ],
            &["refused", "MiB", "--memory-limit"],
        ),
        (
            &["export", "a.shoalrun", "--out", "x.obj"],
            &["--out x.obj", ".glb", ".gltf"],
        ),
        (
            &["inspect", "a.shoalrun", "--at", "5"],
            &["--at 5", "outside the recording"],
        ),
    ];
    for (args, wants) in cases {
        let (ok, out, err) = shoal(d, args);
        assert!(!ok, "{args:?} succeeded: {out}");
        let lines: Vec<&str> = err.lines().collect();
        assert_eq!(lines.len(), 1, "{args:?}: not one line:\n{err}");
        for w in wants {
            assert!(lines[0].contains(w), "{args:?}: {:?} lacks {w:?}", lines[0]);
        }
        assert!(!d.join("x.glb").exists());
    }
}

/// A default-scene recording with a porgy spawned at `spawn_tick` (an input, as a behaviour
/// test's `w:spawn` records it), built tick by tick as `shoal record` does.
fn run_with_a_spawn(root: &Path, ticks: usize, spawn_tick: u64) -> Run {
    let mut run = timeline::record(&RecordSpec {
        root,
        scripts: &root.join("scripts"),
        scene: "scenes/default.lua",
        seed: 3,
        lanes: 1,
        seconds: 0.0,
        lod: None,
    })
    .unwrap();
    let inputs = vec![TimedInput {
        tick: spawn_tick,
        input: Input::Spawn {
            species: "black_porgy".into(),
            pos: Vec3::new(0.0, 200.0, 0.0),
            heading: 1.0,
            pitch: 0.0,
            speed: None,
            behavior: Some("wander".into()),
        },
    }];
    let mut sim = shoal_script::Simulation::from_scene_with_scripts(
        root,
        &root.join("scripts"),
        Path::new("scenes/default.lua"),
        3,
    )
    .unwrap();
    sim.set_lanes(1).unwrap();
    for _ in 0..ticks {
        sim.step();
        run.frames.push(timeline::poses(sim.world()));
        let tick = sim.world().tick_count();
        timeline::inputs::apply_at(&mut sim, &inputs, tick).unwrap();
    }
    run.header.inputs = inputs;
    run
}

#[test]
fn a_fish_that_appears_mid_run_is_exported_scaled_to_zero_until_it_does() {
    let root = common::repo();
    let run = run_with_a_spawn(root, 90, 30);
    assert_eq!(run.frames[30].len(), 37);
    assert_eq!(run.frames[31].len(), 38);
    let spec = ExportSpec {
        run: &run,
        run_name: "spawn.shoalrun",
        root,
        from_s: None,
        to_s: None,
        fish: Some(export::parse_fish_ids("0,37").unwrap()),
        rate_hz: Some(30.0),
        props: false,
        memory_limit: 1 << 30,
    };
    let mut reports = 0;
    let done = export::export(&spec, &mut |_, _, _| reports += 1).unwrap();
    assert!(reports > 0);
    assert_eq!(
        (done.fish, done.appearing_or_leaving, done.keys),
        (2, 1, 46)
    );
    // Below the tick rate the error is measured and reported.
    let (err, _, _) = done.rate_error.clone().unwrap();
    assert!(err > 0.0 && err < 0.5, "{err}");
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("spawn.glb");
    std::fs::write(&path, done.document.to_glb()).unwrap();
    common::validate(&[&path]);
    // three.js: the new fish's joints sit on one point (scale 0) before it spawns, and at the
    // time it first appears they are where inspect puts them.
    let three = three_js_joints(&path, &[0.2, 1.0]);
    let joints: Vec<&Vec<[f64; 3]>> = three
        .iter()
        .filter(|(n, _)| n.starts_with("fish_37_"))
        .map(|(_, p)| p)
        .collect();
    assert!(joints.len() > 5);
    for p in &joints {
        let d = (0..3)
            .map(|k| (p[0][k] - joints[0][0][k]).abs())
            .fold(0.0, f64::max);
        assert!(d < 1e-6, "before the spawn the joints collapse: {d}");
    }
    let ins = export::inspect(&run, root, Some(1.0)).unwrap();
    let fish = ins.fish.iter().find(|f| f.id == "#37").unwrap();
    assert_eq!(
        (fish.species.as_str(), fish.behavior.as_deref()),
        ("black_porgy", Some("wander"))
    );
    assert!((fish.from_s - 31.0 / 60.0).abs() < 1e-9, "{}", fish.from_s);
    let at = ins.at.unwrap();
    let f = at.fish.iter().find(|f| f.id == "#37").unwrap();
    for j in &f.joints {
        let got = three[&j.node][1];
        let d = (0..3)
            .map(|k| (got[k] - f64::from(j.pos[k])).powi(2))
            .sum::<f64>()
            .sqrt();
        assert!(d < 1e-3 * f64::from(f.body_length), "{}: {d}", j.node);
    }
}
