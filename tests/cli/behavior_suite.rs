//! Runs the shipped Lua behaviour suite (`tests/behavior/*_test.lua`) under `cargo test`, and
//! checks the runner itself: determinism, failure reports, traces, discovery and filters.

use std::path::{Path, PathBuf};

use shoal_script::testing::{self, RunOptions, Summary};

fn root() -> PathBuf {
    shoal_core::source_root().to_path_buf()
}

fn options() -> RunOptions {
    RunOptions {
        lod: None,
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

/// The whole shipped suite passes with behaviour level of detail on in every world (`shoal test
/// --lod on`): the tests that count decisions pin their own setting or focus.
#[test]
fn test_shipped_behavior_suite_passes_with_level_of_detail_on() {
    let files = testing::discover(&[root().join("tests/behavior")]).unwrap();
    let opts = RunOptions {
        lod: Some(true),
        ..options()
    };
    let outcomes = testing::run_files(&files, &opts, |_| {});
    assert!(outcomes.len() >= 12);
    let failed: Vec<String> = outcomes
        .iter()
        .filter(|o| !o.passed())
        .map(testing::format_outcome)
        .collect();
    assert!(
        failed.is_empty(),
        "failing with --lod on:\n{}",
        failed.join("\n")
    );
}

/// `t:world{lod = ...}` pins level of detail for its world whatever `--lod` says, and
/// `t:world{focus = ...}` keeps the fish near it at full rate: with `--lod on`, a probe that
/// counts its decisions makes all 30 of three seconds in both, and 10 (a third: the default far
/// band's rate) in a world that pins neither. Bad values and the unknown-key list name the new
/// keys.
#[test]
fn test_world_options_pin_level_of_detail_and_its_focus() {
    let dir = tempfile::tempdir().unwrap();
    let file = write(
        dir.path(),
        "lod_test.lua",
        r#"
local COUNTER = "return { behave = function(fish) fish.memory.n = (fish.memory.n or 0) + 1 end }"
local function count(t, opts)
  opts.scratch = true
  local w = t:world(opts)
  w:write_script("behaviors/counter.lua", COUNTER)
  local fish = w:spawn{ species = "black_porgy", pos = {0, 200, 0}, heading = 0, speed = 0,
                        behavior = "counter" }
  w:run(3)
  return fish.memory.n
end
test("pinned off", function(t)
  local n = count(t, { seed = 1, lod = false })
  t:expect(n == 30, "30 decisions with lod = false, got " .. tostring(n))
end)
test("focus on the probe", function(t)
  local n = count(t, { seed = 1, focus = {0, 200, 0} })
  t:expect(n == 30, "30 decisions at the focus, got " .. tostring(n))
end)
test("a list of focus points", function(t)
  local n = count(t, { seed = 1, focus = { {900, 200, 0}, {0, 200, 0} } })
  t:expect(n == 30, "30 decisions at the second focus, got " .. tostring(n))
end)
test("neither", function(t)
  local n = count(t, { seed = 1 })
  t:expect(n == 10, "a third of the rate with --lod on and no focus, got " .. tostring(n))
end)
test("bad lod", function(t) t:world{ lod = "yes" } end)
test("bad focus", function(t) t:world{ focus = { {0, 1} } } end)
test("typo", function(t) t:world{ focuss = {0, 0, 0} } end)
"#,
    );
    let opts = RunOptions {
        lod: Some(true),
        ..options()
    };
    let outcomes = testing::run_files(std::slice::from_ref(&file), &opts, |_| {});
    let by_name = |name: &str| {
        outcomes
            .iter()
            .find(|o| o.name == name)
            .unwrap_or_else(|| panic!("no outcome {name}"))
    };
    for name in [
        "pinned off",
        "focus on the probe",
        "a list of focus points",
        "neither",
    ] {
        assert!(
            by_name(name).passed(),
            "{}",
            testing::format_outcome(by_name(name))
        );
    }
    let message = |name: &str| {
        let o = by_name(name);
        assert!(!o.passed(), "{name} passed");
        testing::format_outcome(o)
    };
    let bad_lod = message("bad lod");
    assert!(
        bad_lod.contains("t:world lod must be true or false") && bad_lod.contains("lod_test.lua:"),
        "{bad_lod}"
    );
    let bad_focus = message("bad focus");
    assert!(bad_focus.contains("t:world focus[1][3]"), "{bad_focus}");
    let typo = message("typo");
    assert!(
        typo.contains("unknown key `focuss`")
            && typo.contains("did you mean `focus`")
            && typo.contains("lod, focus"),
        "{typo}"
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
            lod: None,
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

/// A failed `t:expect` with a message shows the designer's message, then the condition's value
/// named as such: not "expected: intends to hide, got graze — got false" (issue 36).
#[test]
fn a_failed_expect_reads_as_the_designer_wrote_it() {
    let dir = tempfile::tempdir().unwrap();
    let file = write(
        dir.path(),
        "expect_test.lua",
        "test(\"hides\", function(t)\n  local intention = \"graze\"\n  t:expect(intention == \"hide\", \"intends to hide, got \" .. intention)\n  t:expect(nil)\nend)\n",
    );
    let outcomes = testing::run_files(std::slice::from_ref(&file), &options(), |_| {});
    let failures = &outcomes[0].failures;
    assert_eq!(failures.len(), 2, "{failures:?}");
    assert_eq!(
        failures[0].message,
        "intends to hide, got graze (t:expect's condition was false)"
    );
    assert_eq!(
        failures[1].message,
        "t:expect: the condition does not hold (it is nil)"
    );
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
        lod: None,
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
    // The trace: a CSV with the fish moving along +x and a PNG top view. The first seven
    // columns (t, fish, x, y, z, heading, speed) are numbers; motion, intention and memory follow.
    let csv = std::fs::read_to_string(trace.join("fail_test-too_far.csv")).unwrap();
    let last: Vec<f64> = csv
        .lines()
        .last()
        .unwrap()
        .split(',')
        .take(7)
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
        lod: None,
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

/// Runs one test file written into a temporary directory and returns its outcomes.
fn run_source(name: &str, source: &str, trace: Option<&Path>) -> Vec<testing::TestOutcome> {
    let dir = tempfile::tempdir().unwrap();
    let file = write(dir.path(), name, source);
    let opts = RunOptions {
        lod: None,
        trace_dir: trace.map(Path::to_path_buf),
        ..options()
    };
    testing::run_files(std::slice::from_ref(&file), &opts, |_| {})
}

/// A behaviour runtime error, a broken instruction budget and a file that fails to load each fail
/// the test whose world ran them, named with file:line; `allow_errors = true` opts out.
#[test]
fn test_script_errors_fail_the_test_unless_allowed() {
    let source = r#"
local function world_with(t, body, allow)
  local w = t:world{ seed = 2, scratch = true, allow_errors = allow }
  w:write_script("behaviors/under_test.lua", body)
  w:spawn{ species = "black_porgy", pos = {0, 200, 0}, behavior = "under_test" }
  w:run(1)
  return w
end
local RUNTIME = "local M = {}\nfunction M.tick(fish)\n  local x = nil\n  return x.y\nend\nreturn M\n"
local LOOP = "local M = {}\nfunction M.tick(fish)\n  while true do end\nend\nreturn M\n"
local SYNTAX = "local M = {\nfunction M.tick(fish)\nreturn M\n"
test("runtime", function(t) world_with(t, RUNTIME, false); t:expect(true) end)
test("budget", function(t) world_with(t, LOOP, false); t:expect(true) end)
test("load", function(t) world_with(t, SYNTAX, false); t:expect(true) end)
test("allowed", function(t)
  local w = world_with(t, RUNTIME, true)
  t:expect(#w:errors() == 1, "the error is still in w:errors()")
end)
test("clean", function(t) world_with(t, "return { tick = function(fish) end }", false); t:expect(true) end)
"#;
    let outcomes = run_source("errors_test.lua", source, None);
    let by_name = |n: &str| outcomes.iter().find(|o| o.name == n).unwrap();
    for (name, needle) in [
        ("runtime", "under_test.lua:4:"),
        ("budget", "instruction budget exceeded"),
        ("load", "under_test.lua:"),
    ] {
        let o = by_name(name);
        assert!(
            !o.passed(),
            "{name} should fail: {}",
            testing::format_outcome(o)
        );
        let f = &o.failures[0];
        assert_eq!(
            f.line,
            Some(3),
            "the failure points at the t:world line: {f}"
        );
        assert!(
            f.message.contains(needle) && f.message.contains("allow_errors = true"),
            "{name}: {f}"
        );
    }
    let allowed = by_name("allowed");
    assert!(allowed.passed(), "{}", testing::format_outcome(allowed));
    assert!(
        allowed
            .output
            .iter()
            .any(|l| l.error && l.message.contains("under_test.lua:4:")),
        "an allowed error is still shown under the test: {:?}",
        allowed.output
    );
    assert!(
        testing::format_outcome(allowed).contains("error (allowed)"),
        "{}",
        testing::format_outcome(allowed)
    );
    assert!(by_name("clean").passed());
}

/// What a behaviour prints is kept with the test, in order, with its time and file:line.
#[test]
fn test_prints_are_kept_with_their_test() {
    let source = r#"
test("talks", function(t)
  local w = t:world{ seed = 4, scratch = true }
  w:write_script("behaviors/talker.lua", "local M = {}\nfunction M.tick(fish)\n  fish.memory.n = (fish.memory.n or 0) + 1\n  print('decision ' .. fish.memory.n)\nend\nreturn M\n")
  w:spawn{ species = "black_porgy", pos = {0, 200, 0}, behavior = "talker" }
  w:run(0.5)
  t:expect(true)
end)
test("quiet", function(t) t:expect(true) end)
"#;
    let outcomes = run_source("talk_test.lua", source, None);
    let talks = &outcomes[0];
    let printed: Vec<&str> = talks
        .output
        .iter()
        .filter(|l| !l.error)
        .map(|l| l.message.as_str())
        .collect();
    assert!(
        printed
            .first()
            .is_some_and(|m| m.contains("talker.lua:4: decision 1")),
        "{printed:?}"
    );
    assert!(printed.len() >= 2, "several decisions printed: {printed:?}");
    assert!(outcomes[1].output.is_empty(), "prints stay with their test");
    let text = testing::format_outcome(talks);
    assert!(
        text.lines().nth(1).is_some_and(
            |l| l.starts_with("    print [t = ") && l.contains("talker.lua:4: decision 1")
        ),
        "{text}"
    );
}

/// A line of script output reads `[t = …] fish N: file:line: text`.
#[test]
fn test_script_line_format_names_time_and_fish() {
    let outcome = testing::TestOutcome {
        file: PathBuf::from("x_test.lua"),
        name: "n".into(),
        failures: Vec::new(),
        sim_seconds: 2.0,
        wall: std::time::Duration::ZERO,
        num_checks: 1,
        trace_files: Vec::new(),
        output: vec![
            testing::ScriptLine {
                world: 0,
                time_s: 1.25,
                fish: Some(3),
                message: "scripts/behaviors/a.lua:7: hello".into(),
                error: false,
                repeats: 0,
                warning: false,
            },
            testing::ScriptLine {
                world: 0,
                time_s: 1.5,
                fish: Some(4),
                message: "scripts/behaviors/a.lua:7: hello".into(),
                error: false,
                repeats: 4,
                warning: false,
            },
        ],
    };
    let text = testing::format_outcome(&outcome);
    assert_eq!(
        text.lines().nth(1),
        Some("    print [t = 1.25 s] fish 3: scripts/behaviors/a.lua:7: hello"),
        "{text}"
    );
    // A line the same fish printed five times in a row is counted, not dropped.
    assert_eq!(
        text.lines().nth(2),
        Some("    print [t = 1.50 s] fish 4: scripts/behaviors/a.lua:7: hello (×5)"),
        "{text}"
    );
}

/// A misspelt key is an error naming it and the key meant, not silently ignored.
#[test]
fn test_unknown_keys_are_errors_with_a_suggestion() {
    let source = r#"
test("spawn typo", function(t)
  local w = t:world{ seed = 1 }
  w:spawn{ species = "black_porgy", pos = {0, 200, 0}, behaviour = "forage" }
end)
test("world typo", function(t)
  t:world{ sead = 1 }
end)
test("far off", function(t)
  t:world{ colour = "red" }
end)
"#;
    let outcomes = run_source("keys_test.lua", source, None);
    let f = &outcomes[0].failures[0];
    assert_eq!(f.line, Some(4), "{f}");
    assert!(
        f.message.contains("unknown key `behaviour`")
            && f.message.contains("did you mean `behavior`?"),
        "{f}"
    );
    let f = &outcomes[1].failures[0];
    assert!(
        f.message.contains("unknown key `sead`") && f.message.contains("did you mean `seed`?"),
        "{f}"
    );
    let f = &outcomes[2].failures[0];
    assert!(
        f.message.contains("unknown key `colour`")
            && !f.message.contains("did you mean")
            && f.message.contains("allow_errors"),
        "lists the keys there are: {f}"
    );
}

/// A comparison given something that is not a number (a field still nil) fails that check,
/// saying which value, and the test goes on; bad `t:world{food = …}` values name the key.
#[test]
fn test_comparisons_of_non_numbers_fail_with_what_was_given() {
    let source = r#"
test("nil compared", function(t)
  local w = t:world{ seed = 1 }
  local pellet = w:food{ pos = {0, 200, 0} }
  t:less(pellet.eaten_at, 20, "eaten soon")
  t:near(1, "x", 0.1, "close")
  t:greater(2, 1, "still checked")
end)
test("bad food physics", function(t)
  t:world{ food = { sink_speed = -1 } }
end)
test("food typo", function(t)
  t:world{ food = { sink = 1 } }
end)
"#;
    let outcomes = run_source("compare_test.lua", source, None);
    let failures: Vec<&str> = outcomes[0]
        .failures
        .iter()
        .map(|f| f.message.as_str())
        .collect();
    assert_eq!(
        failures,
        vec![
            "eaten soon: t:less's first value must be a number, got nil",
            "close: t:near's second value must be a number, got \"x\"",
        ],
        "the third check passed and nothing else failed"
    );
    let f = &outcomes[1].failures[0];
    assert!(f.message.contains("food.sink_speed must be ≥ 0"), "{f}");
    let f = &outcomes[2].failures[0];
    assert!(
        f.message.contains("unknown key `sink`") && f.message.contains("sink_speed"),
        "{f}"
    );
}

/// The trace CSV carries motion, intention and memory; a spreadsheet-style reader parses the
/// memory column back to the fish's memory.
#[test]
fn test_trace_csv_has_motion_intention_and_memory() {
    let dir = tempfile::tempdir().unwrap();
    let source = r#"
test("forager", function(t)
  local w = t:world{ seed = 7 }
  w:spawn{ species = "black_porgy", pos = {0, 200, 0}, heading = 0, behavior = "forage" }
  w:food{ pos = {150, 200, 50} }
  w:food{ pos = {-300, 200, -200} }
  w:obstacle{ pos = {-100, 200, 150}, radius = 40 }
  w:run(6)
  t:expect(false, "forced failure to write a trace")
end)
"#;
    let outcomes = run_source("csv_test.lua", source, Some(dir.path()));
    // CSV, top view and the recording to reopen it.
    assert_eq!(outcomes[0].trace_files.len(), 3, "{:?}", outcomes[0]);
    let mut reader = csv::Reader::from_path(dir.path().join("csv_test-forager.csv")).unwrap();
    let header: Vec<String> = reader.headers().unwrap().iter().map(String::from).collect();
    assert_eq!(
        header,
        [
            "t",
            "fish",
            "x",
            "y",
            "z",
            "heading",
            "speed",
            "motion",
            "intention",
            "memory"
        ]
    );
    let rows: Vec<csv::StringRecord> = reader.records().map(Result::unwrap).collect();
    let last = rows.last().unwrap();
    assert!(!last[7].is_empty(), "a motion is playing: {last:?}");
    assert!(
        ["eat", "search", "wander", "avoid"].contains(&&last[8]),
        "the forage intention: {last:?}"
    );
    let memory: serde_json::Value = serde_json::from_str(&last[9]).unwrap();
    assert!(
        memory.get("hunger").is_some_and(|h| h.is_number()),
        "memory holds hunger: {memory}"
    );
    let png = image::open(dir.path().join("csv_test-forager.png"))
        .unwrap()
        .to_rgb8();
    let count = |rgb: [u8; 3]| png.pixels().filter(|p| p.0 == rgb).count();
    assert!(count([20, 60, 110]) > 500, "the tank outline is drawn");
    assert!(count([120, 116, 110]) > 300, "the rock is drawn to scale");
    assert!(count([20, 150, 40]) > 50, "food is drawn");
}

/// `--filter` text found in no test name or file name is an error listing the tests there are.
#[test]
fn test_filter_matching_nothing_lists_tests() {
    let dir = tempfile::tempdir().unwrap();
    let file = write(
        dir.path(),
        "named_test.lua",
        "test(\"first\", function(t) t:expect(true) end)\ntest(\"second\", function(t) t:expect(true) end)\n",
    );
    let err = testing::no_match(&[file], "zzz", &options()).to_string();
    assert!(err.contains("\"zzz\""), "{err}");
    assert!(
        err.contains("named_test.lua :: first") && err.contains("named_test.lua :: second"),
        "{err}"
    );
}

/// A failing test's `--trace` writes a recording (`.shoalrun`) of its world — setup, the test's
/// actions by tick, every tick's poses — that opens again at any moment exactly as it was
/// (`shoal run --open`), including things the test did halfway through.
#[test]
fn test_a_failing_test_writes_a_recording_that_reopens_exactly() {
    let dir = tempfile::tempdir().unwrap();
    let trace = dir.path().join("trace");
    std::fs::create_dir_all(&trace).unwrap();
    let file = write(
        dir.path(),
        "rec_test.lua",
        r#"test("late arrivals", function(t)
  local w = t:world{ seed = 4, tank = { min = {-400, 0, -300}, max = {400, 400, 300} } }
  local a = w:spawn{ species = "black_porgy", pos = {-100, 200, 0}, behavior = "forage" }
  w:food{ pos = {100, 200, 30} }
  w:run(1)
  local b = w:spawn{ species = "black_porgy", pos = {100, 150, 0}, heading = 3, behavior = "school" }
  b:turn("quick", 90, "left")
  w:obstacle{ pos = {0, 100, 100}, radius = 40 }
  w:run(1.5)
  a:set_behavior("wander")
  w:run(0.5)
  t:expect(false, "forced failure at 3 s")
end)
"#,
    );
    let opts = RunOptions {
        lod: None,
        trace_dir: Some(trace.clone()),
        ..options()
    };
    let outcomes = testing::run_files(std::slice::from_ref(&file), &opts, |_| {});
    let path = trace.join("rec_test-late_arrivals.shoalrun");
    assert!(
        outcomes[0].trace_files.contains(&path),
        "{:?}",
        outcomes[0].trace_files
    );
    let report = testing::format_outcome(&outcomes[0]);
    assert!(
        report.contains("shoal run --open") && report.contains("--at 3.00"),
        "{report}"
    );
    let run = shoal_script::timeline::run_file::Run::read(&path).unwrap();
    assert_eq!(run.frames.len(), 181, "3 s of ticks and the first frame");
    assert_eq!(run.header.scene, "scenes/empty_tank.lua");
    assert!(run.header.inputs.len() >= 7, "{:?}", run.header.inputs);
    assert_eq!(run.frames[0].len(), 1, "the first fish only at the start");
    assert_eq!(run.frames[180].len(), 2);
    // Opened at 2 s (after the second spawn), 2.5 s (after the behaviour switch) and the end:
    // the recording's own poses, and playing on with its inputs reproduces the rest.
    for at in [0.0, 2.0, 2.5, 3.0] {
        let (sim, tick) =
            shoal_script::timeline::resume(&run, &root(), &root().join("scripts"), at)
                .unwrap_or_else(|e| panic!("at {at} s: {e}"));
        assert_eq!(shoal_script::timeline::poses(sim.world()), run.frames[tick]);
    }
    let again = shoal_script::timeline::replay(&shoal_script::timeline::ReplaySpec {
        run: &run,
        run_name: "rec",
        root: &root(),
        scripts: &root().join("scripts"),
        from_s: 0.5,
        seconds: None,
    })
    .unwrap();
    assert_eq!(
        again.frames, run.frames,
        "a replay applies the test's actions too"
    );
}
