//! `shoal compare` (issue 14): A/B experiments over seeds, shards and their merge, and replay
//! exactness on every shipped scene.

use crate::common;

use std::path::Path;
use std::process::Command;

use shoal_script::timeline::compare::{self, CompareSpec, Comparison};
use shoal_script::timeline::{self, RecordSpec, ReplaySpec};

fn spec<'a>(
    root: &'a Path,
    a: &'a Path,
    b: &'a Path,
    shard: Option<(u32, u32)>,
) -> CompareSpec<'a> {
    CompareSpec {
        root,
        a,
        b,
        scene: "scenes/default.lua",
        seeds: 4,
        shard,
        seconds: 3.0,
        lod_a: None,
        lod_b: None,
    }
}

fn measure<'c>(c: &'c Comparison, key: &str) -> &'c compare::MeasureSummary {
    c.summary.iter().find(|m| m.measure == key).unwrap()
}

/// Every measure but the timing, per seed.
fn exact(c: &Comparison) -> Vec<Vec<Option<f64>>> {
    c.a.runs
        .iter()
        .chain(&c.b.runs)
        .map(|r| {
            c.summary
                .iter()
                .filter(|m| m.measure != "decision_us")
                .map(|m| compare::value(&m.measure, r))
                .collect()
        })
        .collect()
}

#[test]
fn the_same_scripts_measure_the_same_and_nothing_is_significant() {
    let scripts = common::repo().join("scripts");
    let c = compare::compare(&spec(common::repo(), &scripts, &scripts, None)).unwrap();
    assert!(c.changed.is_empty());
    assert_eq!(c.a.runs.len(), 4);
    assert_eq!(
        c.a.runs.iter().map(|r| r.seed).collect::<Vec<_>>(),
        vec![1, 2, 3, 4]
    );
    for m in c.summary.iter().filter(|m| m.measure != "decision_us") {
        assert!(!m.significant, "{}: {m:?}", m.measure);
        assert_eq!(m.a, m.b, "{}", m.measure);
    }
    // Different seeds are different tanks: the measures vary between seeds.
    let nn: Vec<f64> = c.a.runs.iter().map(|r| r.nearest_neighbour_l).collect();
    assert!(nn.iter().any(|&v| v != nn[0]), "{nn:?}");
    assert!(
        c.a.runs
            .iter()
            .all(|r| r.polarization > 0.0 && r.polarization <= 1.0)
    );
    assert!(c.a.runs.iter().all(|r| r.decision_us > 0.0));
}

#[test]
fn a_behaviour_that_fails_shows_as_significant_script_errors() {
    let (_dir, root) = common::scratch_repo();
    let a = common::repo().join("scripts");
    let b = root.join("scripts");
    let forage = b.join("behaviors/forage.lua");
    let src = std::fs::read_to_string(&forage).unwrap();
    std::fs::write(
        &forage,
        src.replace(
            "function M.behave(fish, intention, p)\n",
            "function M.behave(fish, intention, p)\n  error(\"lost the pellet\")\n",
        ),
    )
    .unwrap();
    let c = compare::compare(&spec(&root, &a, &b, None)).unwrap();
    assert_eq!(c.changed, vec!["behaviors/forage.lua".to_owned()]);
    let errors = measure(&c, "script_errors");
    assert_eq!(errors.a.mean, Some(0.0));
    assert!(errors.b.mean.unwrap() >= 4.0, "{errors:?}");
    assert!(errors.significant, "{errors:?}");
}

#[test]
fn shards_merge_into_the_whole_experiment() {
    let scripts = common::repo().join("scripts");
    let whole = compare::compare(&spec(common::repo(), &scripts, &scripts, None)).unwrap();
    let parts: Vec<(String, Comparison)> = (1..=3)
        .map(|i| {
            let c =
                compare::compare(&spec(common::repo(), &scripts, &scripts, Some((i, 3)))).unwrap();
            // Through JSON, as shards travel between machines.
            let json = serde_json::to_string(&c).unwrap();
            (
                format!("shard{i}.json"),
                serde_json::from_str(&json).unwrap(),
            )
        })
        .collect();
    assert_eq!(parts[0].1.a.runs.len(), 2, "seeds 1 and 4");
    let merged = compare::merge(parts.clone()).unwrap();
    assert_eq!(merged.shard, None);
    assert_eq!(exact(&merged), exact(&whole));
    // The same shard twice is refused, naming it.
    let twice = vec![parts[0].clone(), ("again.json".into(), parts[0].1.clone())];
    let e = compare::merge(twice).unwrap_err().to_string();
    assert!(e.contains("again.json") && e.contains("seed 1"), "{e}");
    // So is a shard of another experiment.
    let mut other = parts[1].clone();
    other.1.seconds = 9.0;
    other.0 = "other.json".into();
    let e = compare::merge(vec![parts[0].clone(), other])
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("other.json") && e.contains("same experiment"),
        "{e}"
    );
}

#[test]
fn the_compare_command_as_a_designer_uses_it() {
    let dir = tempfile::tempdir().unwrap();
    let scripts = common::repo().join("scripts");
    let scripts = scripts.to_str().unwrap();
    let run = |args: &[&str]| {
        let out = Command::new(env!("CARGO_BIN_EXE_shoal"))
            .args(args)
            .current_dir(dir.path())
            .output()
            .unwrap();
        (
            out.status.success(),
            String::from_utf8_lossy(&out.stdout).into_owned(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        )
    };
    let base = [
        "compare",
        "--a",
        scripts,
        "--b",
        scripts,
        "--seeds",
        "2",
        "--seconds",
        "1",
    ];
    let (ok, out, err) = run(&[&base[..], &["--plot", "c.png"]].concat());
    assert!(ok, "{out}{err}");
    assert!(out.contains("2 seeds × 1 s, 4 runs"), "{out}");
    assert!(out.contains("school polarization"), "{out}");
    assert!(dir.path().join("c.png").is_file());
    // Shards as separate processes, as schedulers start them: `--shard auto` reads a Slurm
    // array's index (0-based array here) for one and GitLab's parallel index for the other.
    let shards: [(&str, &[(&str, &str)]); 2] = [
        (
            "1",
            &[
                ("SLURM_ARRAY_TASK_ID", "0"),
                ("SLURM_ARRAY_TASK_MIN", "0"),
                ("SLURM_ARRAY_TASK_COUNT", "2"),
            ],
        ),
        ("2", &[("CI_NODE_INDEX", "2"), ("CI_NODE_TOTAL", "2")]),
    ];
    for (k, vars) in shards {
        let out = Command::new(env!("CARGO_BIN_EXE_shoal"))
            .args([&base[..], &["--shard", "auto", "--json"]].concat())
            .envs(vars.iter().copied())
            .current_dir(dir.path())
            .output()
            .unwrap();
        let (stdout, stderr) = (
            String::from_utf8_lossy(&out.stdout).into_owned(),
            String::from_utf8_lossy(&out.stderr).into_owned(),
        );
        assert!(out.status.success(), "{stderr}");
        let json: serde_json::Value = serde_json::from_str(&stdout).unwrap();
        assert_eq!(json["a"]["runs"].as_array().unwrap().len(), 1);
        assert_eq!(
            json["shard"],
            serde_json::json!([k.parse::<u32>().unwrap(), 2])
        );
        std::fs::write(dir.path().join(format!("s{k}.json")), stdout).unwrap();
    }
    let (ok, out, err) = run(&["compare", "--merge", "s1.json", "s2.json", "--json"]);
    assert!(ok, "{err}");
    let json: serde_json::Value = serde_json::from_str(&out).unwrap();
    assert_eq!(json["a"]["runs"].as_array().unwrap().len(), 2);
    // Bit for bit the runs of the unsharded experiment (all but the CPU time per decision,
    // which is measured, not simulated).
    let (ok, whole, err) = run(&[&base[..], &["--json"]].concat());
    assert!(ok, "{err}");
    let whole: serde_json::Value = serde_json::from_str(&whole).unwrap();
    let simulated = |v: &serde_json::Value| {
        let mut runs = v.as_array().unwrap().clone();
        for r in &mut runs {
            r.as_object_mut().unwrap().remove("decision_us");
        }
        runs
    };
    for version in ["a", "b"] {
        assert_eq!(
            simulated(&json[version]["runs"]),
            simulated(&whole[version]["runs"]),
            "{version}"
        );
    }
    let (ok, _, err) = run(&[&base[..], &["--shard", "auto"]].concat());
    assert!(
        !ok && err.contains("--shard auto: no scheduler's shard index"),
        "{err}"
    );
    assert!(
        json["summary"]
            .as_array()
            .unwrap()
            .iter()
            .any(|m| m["measure"] == "pellets_eaten")
    );

    let (ok, _, err) = run(&[&base[..], &["--shard", "3/2"]].concat());
    assert!(!ok && err.contains("--shard 3/2"), "{err}");
    let (ok, _, err) = run(&[
        "compare",
        "--a",
        scripts,
        "--b",
        "nowhere",
        "--seeds",
        "2",
        "--seconds",
        "1",
    ]);
    assert!(
        !ok && err.contains("--b nowhere: no such directory"),
        "{err}"
    );
    let (ok, _, err) = run(&[&base[..], &["--scene", "atlantis"]].concat());
    assert!(!ok && err.contains("no scene `atlantis`"), "{err}");
    std::fs::write(dir.path().join("junk.json"), "{}").unwrap();
    let (ok, _, err) = run(&["compare", "--merge", "junk.json"]);
    assert!(
        !ok && err.contains("junk.json: not the JSON of `shoal compare --json`"),
        "{err}"
    );
}

/// Every shipped scene, with one and several lanes: a replay from any snapshot with the
/// recording's own scripts is the recording, bit for bit. The 10,000-fish scene over half a
/// second (a debug build ticks it ~10× slower than release).
#[test]
fn replay_is_exact_on_every_shipped_scene() {
    let scenes = common::repo().join("scripts/scenes");
    let mut names: Vec<String> = std::fs::read_dir(&scenes)
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.ends_with(".lua"))
        .collect();
    names.sort();
    assert!(names.len() >= 2, "{names:?}");
    for name in &names {
        let scene = format!("scenes/{name}");
        let big = name.starts_with("big_");
        let (seconds, froms): (f64, &[f64]) = if big {
            (0.5, &[0.0, 0.25])
        } else {
            (4.0, &[0.0, 1.0, 2.35])
        };
        for lanes in [1, 3] {
            let run = timeline::record(&RecordSpec {
                root: common::repo(),
                scripts: &common::repo().join("scripts"),
                scene: &scene,
                seed: 7,
                lanes,
                seconds,
                lod: None,
            })
            .unwrap();
            // A whole second, a tick between, and the very start.
            for &from in froms {
                let again = timeline::replay(&ReplaySpec {
                    run: &run,
                    run_name: "run",
                    root: common::repo(),
                    scripts: &common::repo().join("scripts"),
                    from_s: from,
                    seconds: None,
                })
                .unwrap();
                assert_eq!(
                    again.frames, run.frames,
                    "{scene}, {lanes} lanes, from {from} s"
                );
            }
        }
    }
}

/// `shoal bench history`: the recording cost, state size and seek time, as JSON.
#[test]
fn the_history_bench_reports_cost_size_and_seek() {
    let out = Command::new(env!("CARGO_BIN_EXE_shoal"))
        .args([
            "bench",
            "history",
            "--fish",
            "60",
            "--pairs",
            "1",
            "--seeks",
            "3",
            "--minutes",
            "0.05",
            "--json",
            "--root",
        ])
        .arg(common::repo())
        .output()
        .unwrap();
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{text}{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_str(&text).unwrap();
    let row = &json["recording"][0];
    assert_eq!(row["fish"], 60);
    assert!(
        row["state_bytes_per_fish"].as_f64().unwrap() > 100.0,
        "{row}"
    );
    assert!(row["plain_ms_per_tick"].as_f64().unwrap() > 0.0);
    let seek = &json["seek"];
    assert_eq!(seek["seeks"], 3);
    assert!(seek["history_s"].as_f64().unwrap() >= 2.9, "{seek}");
    assert!(seek["max_ms"].as_f64().unwrap() >= seek["median_ms"].as_f64().unwrap());
    let bad = Command::new(env!("CARGO_BIN_EXE_shoal"))
        .args(["bench", "history", "--fish", "0"])
        .output()
        .unwrap();
    assert!(!bad.status.success());
    assert!(String::from_utf8_lossy(&bad.stderr).contains("--fish needs positive counts"));
}

/// A scene measure that fails on some samples is averaged over the others, which can make a
/// broken B look better; its row in the table says how often each version failed, beside the
/// verdict, and stderr gives the first error with its file and line.
#[test]
fn a_measure_that_fails_on_some_samples_is_flagged_on_its_row() {
    let dir = tempfile::tempdir().unwrap();
    let scripts = common::repo().join("scripts");
    let b = dir.path().join("b");
    common::copy_dir(&scripts, &b);
    let scene = b.join("scenes/default.lua");
    let text = std::fs::read_to_string(&scene).unwrap();
    let broken = text.replace(
        "return fish.intention == \"flee\"",
        "return fish.intention == \"flee\" or fish.memory.nope.x",
    );
    assert_ne!(broken, text, "the default scene's `fleeing` measure moved");
    std::fs::write(&scene, broken).unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_shoal"))
        .args(["compare", "--a"])
        .arg(&scripts)
        .arg("--b")
        .arg(&b)
        .args(["--seeds", "2", "--seconds", "3"])
        .current_dir(dir.path())
        .output()
        .unwrap();
    let (stdout, stderr) = (
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr),
    );
    assert!(out.status.success(), "{stderr}");
    let row = stdout
        .lines()
        .find(|l| l.trim_start().starts_with("fleeing"))
        .unwrap_or_else(|| panic!("no fleeing row: {stdout}"));
    assert!(
        row.contains("(B failed ") && row.contains("over the samples that worked"),
        "{row}"
    );
    assert!(!row.contains("A failed"), "{row}");
    let other = stdout
        .lines()
        .find(|l| l.trim_start().starts_with("predator_distance_l"))
        .unwrap();
    assert!(!other.contains("failed"), "{other}");
    assert!(stderr.contains("scenes/default.lua:52:"), "{stderr}");
}
