//! `shoal bench sim` runs both drivers and reports one result per fish count (no timing is
//! asserted: speed is measured by the benchmark, not by tests).

use crate::common;

use std::process::Command;

fn bench(args: &[&str]) -> serde_json::Value {
    let out = Command::new(env!("CARGO_BIN_EXE_shoal"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args(["bench", "sim", "--seconds", "0.2", "--json"])
        .args(args)
        .output()
        .expect("run shoal");
    assert!(
        out.status.success(),
        "shoal bench sim failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).expect("JSON on stdout")
}

fn check(report: &serde_json::Value, counts: &[u64]) {
    let results = report["results"].as_array().unwrap();
    assert_eq!(results.len(), counts.len());
    for (r, &n) in results.iter().zip(counts) {
        assert_eq!(r["fish"].as_u64(), Some(n));
        assert_eq!(r["ticks"].as_u64(), Some(12), "0.2 s at 60 Hz");
        let median = r["median_ms"].as_f64().unwrap();
        assert!(median > 0.0 && r["p99_ms"].as_f64().unwrap() >= median);
        for stage in [
            "perception",
            "behavior",
            "motion",
            "skeleton",
            "palette",
            "grid",
        ] {
            assert!(r["stages"][stage].as_f64().unwrap() >= 0.0, "{stage}");
        }
        assert!(r["stages"]["motion"].as_f64().unwrap() > 0.0);
    }
}

#[test]
fn rust_driver_reports_each_count_and_draws_the_plot() {
    let dir = tempfile::tempdir().unwrap();
    let png = dir.path().join("sim.png");
    let report = bench(&[
        "--driver",
        "rust",
        "--fish",
        "20,40",
        "--plot",
        png.to_str().unwrap(),
    ]);
    check(&report, &[20, 40]);
    assert!(report["driver"].as_str().unwrap().starts_with("rust"));
    for r in report["results"].as_array().unwrap() {
        assert!(r["decide_us_per_decision"].as_f64().unwrap() > 0.0);
        assert!(r["sense_us_per_decision"].is_null(), "sensed in one batch");
    }
    let bytes = std::fs::read(&png).unwrap();
    assert_eq!(&bytes[..8], b"\x89PNG\r\n\x1a\n");
}

#[test]
fn lua_driver_runs_the_shipped_behaviours() {
    let report = bench(&["--driver", "lua", "--fish", "30"]);
    check(&report, &[30]);
    let r = &report["results"][0];
    assert!(r["stages"]["behavior"].as_f64().unwrap() > 0.0, "Lua ran");
    // Porgies and the barracuda decide at 10 Hz: each of the 30 fish once every 6 ticks.
    assert_eq!(r["decisions_per_tick"].as_f64(), Some(5.0));
    let decide = r["decide_us_per_decision"].as_f64().unwrap();
    let sense = r["sense_us_per_decision"].as_f64().unwrap();
    assert!(decide > 0.0 && sense > 0.0, "{decide} {sense}");
}

#[test]
fn bad_arguments_are_errors_naming_them() {
    let out = Command::new(env!("CARGO_BIN_EXE_shoal"))
        .args(["bench", "sim", "--seconds=-1"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--seconds"));
}

#[test]
fn a_scene_bench_reports_modules_with_their_top_functions_and_memory() {
    let (_dir, root) = common::scratch_repo();
    let root = root.as_path();
    std::fs::write(
        root.join("scripts/behaviors/burner.lua"),
        "local M = {}\n\nfunction M.burn(n)\n  local x = 0\n  for i = 1, n do x = x + math.sin(i) end\n  return x\nend\n\nfunction M.tick(fish)\n  fish.memory.x = M.burn(20000)\n  fish.memory.t = { fish.memory.x }\nend\n\nreturn M\n",
    )
    .unwrap();
    let scene = root.join("scripts/scenes/burn.lua");
    std::fs::write(
        &scene,
        "return {\n  tank = { min = { -500, 0, -300 }, max = { 500, 400, 300 } },\n  fish = { { species = \"black_porgy\", count = 12, behavior = \"burner\",\n             region = { min = { -200, 150, -120 }, max = { 200, 260, 120 } } } },\n}\n",
    )
    .unwrap();
    let out = Command::new(env!("CARGO_BIN_EXE_shoal"))
        .current_dir(root)
        .args(["bench", "sim", "--seconds", "2", "--json", "--scene"])
        .arg(&scene)
        .args(["--root"])
        .arg(root)
        .output()
        .expect("run shoal");
    assert!(
        out.status.success(),
        "shoal bench sim --scene failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    let m = &report["modules"]["burner"];
    assert_eq!(m["calls"].as_u64(), Some(240), "12 fish at 10 Hz for 2 s");
    assert!(m["alloc_bytes_per_call"].as_f64().unwrap() > 40.0, "{m}");
    assert!(report["script_memory_bytes"].as_u64().unwrap() > 0);
    assert_eq!(report["function_sampling"].as_bool(), Some(true));
    if cfg!(target_os = "linux") {
        let top = &m["functions"][0];
        assert_eq!(top["name"].as_str(), Some("burn"), "{m}");
        assert_eq!(top["file"].as_str(), Some("scripts/behaviors/burner.lua"));
        assert_eq!(top["line"].as_u64(), Some(3));
        assert!(top["self_samples"].as_u64().unwrap() > 0);
        assert!(top["self_ms_per_sim_s"].as_f64().unwrap() > 0.0);
        assert!(
            m["stacks"][0]["frames"].as_array().unwrap().len() >= 2,
            "{m}"
        );
    }
}

#[test]
fn a_scene_bench_takes_a_scene_by_name_and_names_the_scenes_there_are() {
    let (_dir, root) = common::scratch_repo();
    let root = root.as_path();
    std::fs::write(
        root.join("scripts/scenes/few.lua"),
        "return {\n  tank = { min = { -500, 0, -300 }, max = { 500, 400, 300 } },\n  fish = { { species = \"black_porgy\", count = 3, behavior = \"wander\",\n             region = { min = { -200, 150, -120 }, max = { 200, 260, 120 } } } },\n}\n",
    )
    .unwrap();
    let bench = |scene: &str| {
        Command::new(env!("CARGO_BIN_EXE_shoal"))
            .current_dir(root)
            .args([
                "bench",
                "sim",
                "--seconds",
                "0.5",
                "--json",
                "--scene",
                scene,
            ])
            .args(["--root"])
            .arg(root)
            .output()
            .expect("run shoal")
    };
    let out = bench("few");
    assert!(
        out.status.success(),
        "shoal bench sim --scene few failed: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report: serde_json::Value = serde_json::from_slice(&out.stdout).expect("JSON on stdout");
    assert!(
        report["scene"]
            .as_str()
            .unwrap()
            .ends_with("scenes/few.lua"),
        "{report}"
    );
    assert_eq!(
        report["modules"]["wander"]["calls"].as_u64(),
        Some(15),
        "3 fish at 10 Hz for 0.5 s"
    );

    let out = bench("nosuch");
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("no scene `nosuch`") && err.contains("few"),
        "{err}"
    );
}

/// `--pose gpu` measures what the window's CPU does: the motion pass writes the GPU pass's
/// records as it moves each fish, so the skeleton and palette columns are 0 and the motion
/// column holds the records; `--pose cpu` (the default) poses every palette.
#[test]
fn pose_on_the_gpu_leaves_the_skeleton_stage_to_the_pass() {
    let stages = |pose: &str| {
        let report = bench(&["--driver", "rust", "--fish", "400", "--pose", pose]);
        check(&report, &[400]);
        assert_eq!(report["pose"].as_str(), Some(pose));
        let s = &report["results"][0]["stages"];
        (
            s["motion"].as_f64().unwrap(),
            s["skeleton"].as_f64().unwrap(),
            s["palette"].as_f64().unwrap(),
        )
    };
    let (motion, skeleton, palette) = stages("gpu");
    assert_eq!((skeleton, palette), (0.0, 0.0), "no pose stage runs");
    assert!(motion > 0.0, "the motion pass, records and all, is timed");
    let (_, skeleton, palette) = stages("cpu");
    assert!(skeleton > 0.0 && palette > 0.0, "{skeleton} {palette}");
    let out = Command::new(env!("CARGO_BIN_EXE_shoal"))
        .args(["bench", "sim", "--pose", "vulkan"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("--pose") && err.contains("gpu"), "{err}");
}

/// `--threads N` runs the bench in a rayon pool of N (the result says so) with N script lanes;
/// 0 is refused, naming the flag.
#[test]
fn threads_sets_the_pool_and_the_lanes() {
    let report = bench(&["--driver", "lua", "--fish", "30", "--threads", "3"]);
    check(&report, &[30]);
    assert_eq!(report["results"][0]["threads"].as_u64(), Some(3));
    let out = Command::new(env!("CARGO_BIN_EXE_shoal"))
        .current_dir(env!("CARGO_MANIFEST_DIR"))
        .args([
            "bench",
            "sim",
            "--seconds",
            "0.2",
            "--fish",
            "30",
            "--threads",
            "3",
        ])
        .output()
        .unwrap();
    assert!(out.status.success());
    let text = String::from_utf8_lossy(&out.stdout);
    assert!(text.contains("script lanes: 3"), "{text}");
    assert!(text.contains("3 threads"), "{text}");
    let out = Command::new(env!("CARGO_BIN_EXE_shoal"))
        .args(["bench", "sim", "--threads", "0"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--threads 0"));
}
