//! Runs the shipped Lua behaviour suite (`tests/behavior/*_test.lua`) under `cargo test`, and
//! checks the runner itself: determinism, failure reports, traces, discovery and filters.

use std::path::{Path, PathBuf};

use shoal::testing::{self, RunOptions, Summary};

fn root() -> PathBuf {
    PathBuf::from(env!("CARGO_MANIFEST_DIR"))
}

fn options() -> RunOptions {
    RunOptions {
        filter: None,
        trace_dir: None,
        root: root(),
    }
}

fn write(dir: &Path, name: &str, source: &str) -> PathBuf {
    let path = dir.join(name);
    std::fs::write(&path, source).unwrap();
    path
}

#[test]
fn test_shipped_behavior_suite_passes() {
    let files = testing::discover(&[root().join("tests/behavior")]).unwrap();
    assert!(
        files.len() >= 5,
        "expected the shipped suite, found {files:?}"
    );
    let outcomes = testing::run_files(&files, &options(), |o| {
        println!("{}", testing::format_outcome(o))
    });
    let summary = Summary::of(&outcomes);
    println!("behaviour suite: {summary}");
    assert!(outcomes.len() >= 12, "at least twelve behaviour tests ship");
    let failed: Vec<String> = outcomes
        .iter()
        .filter(|o| !o.passed())
        .map(testing::format_outcome)
        .collect();
    assert!(
        failed.is_empty(),
        "failing behaviour tests:\n{}",
        failed.join("\n")
    );
    assert!(
        outcomes.iter().all(|o| o.num_checks > 0),
        "every test checks something"
    );
}

/// The same test run twice gives bit-identical trajectories.
#[test]
fn test_runs_are_bit_identical() {
    let dir = tempfile::tempdir().unwrap();
    let trace_a = dir.path().join("a");
    let trace_b = dir.path().join("b");
    std::fs::create_dir_all(&trace_a).unwrap();
    std::fs::create_dir_all(&trace_b).unwrap();
    // A failing check at the end forces a trace to be written; the trajectories are then compared
    // byte for byte.
    let file = write(
        dir.path(),
        "det_test.lua",
        r#"
test("school then fail", function(t)
  local w = t:world{ seed = 99 }
  local fishes = {}
  for i = 1, 8 do
    fishes[i] = w:spawn{ species = "black_porgy", pos = {-200 + 40 * i, 200, 20 * i},
                         heading = i, behavior = i % 2 == 0 and "school" or "wander" }
  end
  w:food{ pos = {100, 200, 0} }
  w:run(8)
  t:expect(false, "forced failure to write a trace")
end)
"#,
    );
    for trace in [&trace_a, &trace_b] {
        let opts = RunOptions {
            trace_dir: Some(trace.clone()),
            ..options()
        };
        let outcomes = testing::run_files(std::slice::from_ref(&file), &opts, |_| {});
        assert_eq!(outcomes.len(), 1);
        assert!(!outcomes[0].passed());
    }
    let a = std::fs::read(trace_a.join("det_test-school_then_fail.csv")).unwrap();
    let b = std::fs::read(trace_b.join("det_test-school_then_fail.csv")).unwrap();
    assert!(a.len() > 1000, "the trace holds trajectories");
    assert_eq!(a, b, "two runs of the same seeded test differ");
}

#[test]
fn test_failure_names_file_line_expected_actual_and_time() {
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("trace");
    std::fs::create_dir_all(&trace).unwrap();
    let file = write(
        dir.path(),
        "fail_test.lua",
        "test(\"too far\", function(t)\n  local w = t:world{ seed = 1 }\n  local f = w:spawn{ species = \"black_porgy\", pos = {0, 200, 0} }\n  f:swim(50)\n  w:run(2)\n  t:near(f.pos[1], 0, 1, \"fish stays put\")\nend)\n",
    );
    let opts = RunOptions {
        trace_dir: Some(trace.clone()),
        ..options()
    };
    let outcomes = testing::run_files(std::slice::from_ref(&file), &opts, |_| {});
    let failure = &outcomes[0].failures[0];
    assert_eq!(failure.line, Some(6));
    assert!(failure.message.contains("fish stays put"), "{failure}");
    assert!(failure.message.contains("expected 0.0000"), "{failure}");
    assert!((failure.sim_time - 2.0).abs() < 1e-6, "{failure}");
    let text = failure.to_string();
    assert!(text.contains("fail_test.lua:6:"), "{text}");
    // The trace: a CSV with the fish moving along +x and a PNG top view.
    let csv = std::fs::read_to_string(trace.join("fail_test-too_far.csv")).unwrap();
    let last: Vec<f64> = csv
        .lines()
        .last()
        .unwrap()
        .split(',')
        .map(|v| v.parse().unwrap())
        .collect();
    assert!(last[2] > 50.0, "the traced fish moved along +x: {last:?}");
    let png = image::open(trace.join("fail_test-too_far.png")).unwrap();
    assert!(png.width() >= 320);
}

#[test]
fn test_lua_errors_and_load_errors_are_failures_with_lines() {
    let dir = tempfile::tempdir().unwrap();
    let runtime = write(
        dir.path(),
        "runtime_test.lua",
        "test(\"boom\", function(t)\n  local x = nil\n  return x.field\nend)\n",
    );
    let syntax = write(
        dir.path(),
        "syntax_test.lua",
        "test(\"never\", function(t)\n  if then\nend)\n",
    );
    let outcomes = testing::run_files(&[runtime, syntax], &options(), |_| {});
    assert_eq!(outcomes.len(), 2);
    assert_eq!(
        outcomes[0].failures[0].line,
        Some(3),
        "{:?}",
        outcomes[0].failures
    );
    assert_eq!(outcomes[1].name, "(load)");
    assert!(
        outcomes[1].failures[0]
            .message
            .contains("syntax_test.lua:2"),
        "{:?}",
        outcomes[1].failures
    );
    assert_eq!(
        Summary::of(&outcomes),
        Summary {
            passed: 0,
            failed: 2
        }
    );
}

#[test]
fn test_discovery_and_filter() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::create_dir_all(dir.path().join("sub")).unwrap();
    write(
        dir.path(),
        "a_test.lua",
        "test(\"alpha\", function(t) t:expect(true) end)\ntest(\"beta\", function(t) t:expect(true) end)\n",
    );
    write(
        &dir.path().join("sub"),
        "b_test.lua",
        "test(\"gamma\", function(t) t:expect(1 < 2) end)\n",
    );
    write(dir.path(), "helper.lua", "error('not a test file')\n");
    let files = testing::discover(&[dir.path().to_path_buf()]).unwrap();
    assert_eq!(files.len(), 2, "{files:?}");
    let opts = RunOptions {
        filter: Some("gam".into()),
        ..options()
    };
    let outcomes = testing::run_files(&files, &opts, |_| {});
    assert_eq!(outcomes.len(), 1);
    assert_eq!(outcomes[0].name, "gamma");
    assert!(outcomes[0].passed());
    assert!(testing::discover(&[dir.path().join("missing")]).is_err());
}

/// `shoal test` prints one line per test and the summary line, and exits non-zero on failure.
#[test]
fn test_cli_output_and_exit_code() {
    let dir = tempfile::tempdir().unwrap();
    write(
        dir.path(),
        "cli_test.lua",
        "test(\"ok\", function(t) t:expect(true, \"fine\") end)\ntest(\"bad\", function(t) t:expect(false, \"broken\") end)\n",
    );
    let out = std::process::Command::new(env!("CARGO_BIN_EXE_shoal"))
        .current_dir(root())
        .arg("test")
        .arg(dir.path())
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(!out.status.success());
    assert!(stdout.contains("PASS cli_test.lua :: ok"), "{stdout}");
    assert!(stdout.contains("FAIL cli_test.lua :: bad"), "{stdout}");
    assert!(
        stdout.lines().any(|l| l == "1 passed, 1 failed"),
        "{stdout}"
    );
}
