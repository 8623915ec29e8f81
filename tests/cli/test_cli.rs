//! `shoal test` as a designer runs it: output of prints and script errors, a filter that matches
//! nothing, and `--watch` rerunning once per save.

use std::io::{BufRead, BufReader};
use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::sync::mpsc;
use std::time::{Duration, Instant};

fn root() -> PathBuf {
    shoal_core::source_root().to_path_buf()
}

fn shoal_test(dir: &Path, args: &[&str]) -> Output {
    Command::new(env!("CARGO_BIN_EXE_shoal"))
        .current_dir(root())
        .env_remove("RUST_LOG")
        .arg("test")
        .arg(dir)
        .args(args)
        .output()
        .unwrap()
}

/// A scratch world whose behaviour prints, and one whose behaviour fails.
const SCRIPTED: &str = r#"
local PRINTER = [[
local M = {}
function M.tick(fish)
  fish.memory.n = (fish.memory.n or 0) + 1
  if fish.memory.n == 3 then print("third decision of fish " .. fish.id) end
end
return M
]]
local BROKEN = [[
local M = {}
function M.tick(fish)
  error("broken on purpose")
end
return M
]]

test("prints", function(t)
  local w = t:world{ seed = 1, scratch = true }
  w:write_script("behaviors/printer.lua", PRINTER)
  w:spawn{ species = "black_porgy", pos = {0, 200, 0}, behavior = "printer" }
  w:run(1)
  t:expect(true)
end)

test("breaks", function(t)
  local w = t:world{ seed = 1, scratch = true }
  w:write_script("behaviors/broken.lua", BROKEN)
  w:spawn{ species = "black_porgy", pos = {0, 200, 0}, behavior = "broken" }
  w:run(1)
  t:expect(true, "checks pass; only the script failed")
end)
"#;

#[test]
fn prints_go_under_their_test_on_stdout_and_script_errors_fail() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("scripted_test.lua"), SCRIPTED).unwrap();
    let out = shoal_test(dir.path(), &[]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "a script error fails the run");
    let lines: Vec<&str> = stdout.lines().collect();
    let pass = lines
        .iter()
        .position(|l| l.starts_with("PASS scripted_test.lua :: prints"))
        .unwrap_or_else(|| panic!("{stdout}"));
    // The print is the line right under its test, with its simulated time and file:line (the
    // fish id comes from the script log's entry; see `testing::ScriptLine`).
    let print = lines[pass + 1];
    assert!(
        print.starts_with("    print [t = ")
            && print.contains("behaviors/printer.lua:4: third decision of fish 0"),
        "{stdout}"
    );
    assert!(
        !stderr.contains("third decision"),
        "prints are not echoed among log lines on stderr: {stderr}"
    );
    let fail = lines
        .iter()
        .position(|l| l.starts_with("FAIL scripted_test.lua :: breaks"))
        .unwrap_or_else(|| panic!("{stdout}"));
    let why = lines[fail + 1];
    assert!(
        why.contains("scripted_test.lua:27:")
            && why.contains("behaviors/broken.lua:3: broken on purpose")
            && why.contains("allow_errors = true"),
        "the failure names the world's line, the script error's file:line and the opt-out: {stdout}"
    );
    assert!(
        stdout.lines().any(|l| l == "1 passed, 1 failed"),
        "{stdout}"
    );
}

#[test]
fn a_filter_that_matches_nothing_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(
        dir.path().join("few_test.lua"),
        "test(\"alpha\", function(t) t:expect(true) end)\ntest(\"beta\", function(t) t:expect(true) end)\n",
    )
    .unwrap();
    let out = shoal_test(dir.path(), &["--filter", "gamma"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(!out.status.success(), "{stderr}");
    assert!(stderr.contains("\"gamma\""), "names the filter: {stderr}");
    assert!(
        stderr.contains("few_test.lua :: alpha") && stderr.contains("few_test.lua :: beta"),
        "lists the tests there are: {stderr}"
    );
    // A filter that matches still runs just that test.
    let out = shoal_test(dir.path(), &["--filter", "bet"]);
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(out.status.success(), "{stdout}");
    assert!(
        stdout.lines().any(|l| l == "1 passed, 0 failed"),
        "{stdout}"
    );
}

/// Kills the watcher however the test ends.
struct Killed(Child);

impl Drop for Killed {
    fn drop(&mut self) {
        let _ = self.0.kill();
        let _ = self.0.wait();
    }
}

fn is_summary(line: &str) -> bool {
    let words: Vec<&str> = line.split(' ').collect();
    matches!(words.as_slice(), [p, "passed,", f, "failed"]
        if p.parse::<u32>().is_ok() && f.parse::<u32>().is_ok())
}

/// Lines read from `rx` up to the first for which `done` holds; fails if none comes within
/// `timeout`.
fn collect_until(
    rx: &mpsc::Receiver<String>,
    timeout: Duration,
    done: impl Fn(&str) -> bool,
) -> Vec<String> {
    let deadline = Instant::now() + timeout;
    let mut lines = Vec::new();
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        match rx.recv_timeout(left) {
            Ok(line) => {
                let stop = done(&line);
                lines.push(line);
                if stop {
                    return lines;
                }
            }
            Err(e) => panic!("waited {timeout:?} ({e}); the lines so far: {lines:#?}"),
        }
    }
}

/// Lines read from `rx` until `until` is seen or `timeout` passes.
fn collect(rx: &mpsc::Receiver<String>, timeout: Duration, until: Option<&str>) -> Vec<String> {
    let deadline = Instant::now() + timeout;
    let mut lines = Vec::new();
    while let Some(left) = deadline.checked_duration_since(Instant::now()) {
        match rx.recv_timeout(left) {
            Ok(line) => {
                let done = until.is_some_and(|u| line.contains(u));
                lines.push(line);
                if done {
                    break;
                }
            }
            Err(_) => break,
        }
    }
    lines
}

/// One save, one rerun: the runner's own reads of the test files do not trigger it, and saving
/// the same text again does nothing. Waits on the runner's output, not on time: with
/// `SHOAL_WATCH_TRACE` the watcher says when a batch of events ran nothing.
#[test]
fn watch_runs_once_per_save() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("tiny_test.lua");
    let source = "test(\"tiny\", function(t) t:expect(true) end)\n";
    std::fs::write(&file, source).unwrap();
    let mut child = Command::new(env!("CARGO_BIN_EXE_shoal"))
        .current_dir(dir.path())
        .env_remove("RUST_LOG")
        .env("SHOAL_WATCH_TRACE", "1")
        .args(["test", "--watch", "."])
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let stdout = child.stdout.take().unwrap();
    let _guard = Killed(child);
    let (tx, rx) = mpsc::channel();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines() {
            if tx.send(line.unwrap_or_default()).is_err() {
                break;
            }
        }
    });
    // Each step waits (a minute at most) for what must happen.
    let wait = Duration::from_secs(60);
    let mut lines = collect(&rx, wait, Some("watching for changes"));
    assert!(
        lines.iter().any(|l| l.contains("watching for changes")),
        "the watcher started: {lines:?}"
    );
    let rerun = |l: &str| l.contains("tiny_test.lua changed, rerunning");
    // A save: its rerun, to its summary line.
    std::fs::write(&file, format!("{source}-- edited\n")).unwrap();
    lines.extend(collect_until(&rx, wait, is_summary));
    assert!(
        lines.iter().any(|l| rerun(l)),
        "the save reran the tests, naming the file: {lines:#?}"
    );
    // The same text saved again: the watcher looks and runs nothing (a rerun here fails below).
    std::fs::write(&file, format!("{source}-- edited\n")).unwrap();
    lines.extend(collect_until(&rx, wait, |l| {
        l.contains("saved with the same text: no rerun") || rerun(l)
    }));
    // Another save with new text: its rerun is the proof that whatever the first save, the
    // runner's reads of the files and the same-text save caused has come in before it.
    std::fs::write(&file, format!("{source}-- edited again\n")).unwrap();
    let before = lines.len();
    lines.extend(collect_until(&rx, wait, |l| rerun(l)));
    lines.extend(collect_until(&rx, wait, is_summary));
    assert!(
        lines[before..].iter().any(|l| rerun(l)),
        "the second save reran the tests: {lines:#?}"
    );
    let runs = lines.iter().filter(|l| is_summary(l)).count();
    assert_eq!(runs, 3, "the first run plus one per new text: {lines:#?}");
    let reruns = lines.iter().filter(|l| rerun(l)).count();
    assert_eq!(reruns, 2, "one rerun per save with new text: {lines:#?}");
}
