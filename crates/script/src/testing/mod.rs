//! Headless scripted behaviour tests (`shoal test`): `*_test.lua` files run deterministically on a
//! fixed timestep, with no rendering, no GPU and no display.
//!
//! A test file calls `test(name, fn)`; each `fn(t)` builds worlds with `t:world{…}`, spawns fish,
//! runs simulated time and checks outcomes with `t:expect` / `t:near` (see [`api`] for the whole
//! Lua surface). Every failed check records the test file and line, the expected and actual values
//! and the simulated time, so a designer can find the failure without a debugger. A script error
//! (a behaviour's runtime error, a broken budget, a file that fails to load) in one of a test's
//! worlds fails the test too, unless the world was made with `allow_errors = true`. What scripts
//! `print` is kept with the test that ran them ([`TestOutcome::output`]). With a trace
//! directory, each failing test also writes its fish trajectories (CSV) and a top-view plot (PNG).

pub mod api;
pub mod trace;

use std::path::{Path, PathBuf};
use std::time::{Duration, Instant};

/// What the runner was asked to do.
#[derive(Debug, Clone, Default)]
pub struct RunOptions {
    /// Only tests whose name (or file name) contains this text run.
    pub filter: Option<String>,
    /// Where failing tests write `<file>-<test>.csv` and `.png`; `None` writes nothing.
    pub trace_dir: Option<PathBuf>,
    /// Repository root: `scripts/` (behaviours, species, scenes) and `assets/` live under it.
    pub root: PathBuf,
    /// `--lod on|off`: behaviour level of detail in every test world (`None`: each scene's
    /// default).
    pub lod: Option<bool>,
}

/// One failed check (or the error that ended a test).
#[derive(Debug, Clone, PartialEq)]
pub struct Failure {
    /// The test file.
    pub file: PathBuf,
    /// Line in the test file, where known.
    pub line: Option<usize>,
    /// What went wrong, in the test's own words plus expected/actual values.
    pub message: String,
    /// Simulated seconds of the most recently run world when the check failed.
    pub sim_time: f64,
}

impl std::fmt::Display for Failure {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self.line {
            Some(line) => write!(f, "{}:{line}: ", self.file.display())?,
            None => write!(f, "{}: ", self.file.display())?,
        }
        write!(
            f,
            "{} (at simulated t = {:.2} s)",
            self.message, self.sim_time
        )
    }
}

/// A line the scripts of a test's world wrote: a `print` (or another console message, such as a
/// reload notice) or a script error.
#[derive(Debug, Clone, PartialEq)]
pub struct ScriptLine {
    /// Which of the test's worlds (0 = the first `t:world`).
    pub world: usize,
    /// Simulated seconds when it was written.
    pub time_s: f64,
    /// The fish whose script wrote it (`fish.id`), if any.
    pub fish: Option<u32>,
    /// `file:line: text` as the script console shows it.
    pub message: String,
    /// A script error (shown only where the world allows errors; otherwise it is a failure).
    pub error: bool,
    /// The same line written again by the same fish right after, folded into this one.
    pub repeats: u64,
    /// A notice of the host's rather than a print (a behaviour switched off after repeated
    /// errors).
    pub warning: bool,
}

impl ScriptLine {
    /// `[t = 1.23 s] fish 0: scripts/behaviors/x.lua:5: text`, plus the world where the test has
    /// several.
    fn describe(&self, several_worlds: bool) -> String {
        let mut s = format!("[t = {:.2} s]", self.time_s);
        if several_worlds {
            s.push_str(&format!(" world {}", self.world));
        }
        match self.fish {
            Some(fish) => s.push_str(&format!(" fish {fish}")),
            None => s.push_str(" (no fish)"),
        }
        s.push_str(": ");
        s.push_str(&self.message);
        if self.repeats > 0 {
            s.push_str(&format!(" (×{})", self.repeats + 1));
        }
        s
    }
}

/// The result of one `test(name, fn)`.
#[derive(Debug, Clone)]
pub struct TestOutcome {
    /// The file that declared the test.
    pub file: PathBuf,
    /// The test's name.
    pub name: String,
    /// Every failed check; empty means the test passed.
    pub failures: Vec<Failure>,
    /// Simulated seconds over all worlds the test ran.
    pub sim_seconds: f64,
    /// Wall-clock time the test took.
    pub wall: Duration,
    /// Number of checks (`expect`, `near`) the test made.
    pub num_checks: usize,
    /// Trace files written for this test, if it failed and tracing was on.
    pub trace_files: Vec<PathBuf>,
    /// What its worlds' scripts printed (and the errors its worlds allowed), in order.
    pub output: Vec<ScriptLine>,
}

impl TestOutcome {
    /// True when no check failed and the test ran to its end.
    pub fn passed(&self) -> bool {
        self.failures.is_empty()
    }
}

/// Totals over a run.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct Summary {
    /// Tests that passed.
    pub passed: usize,
    /// Tests that failed.
    pub failed: usize,
}

impl Summary {
    /// Adds up outcomes.
    pub fn of(outcomes: &[TestOutcome]) -> Self {
        let passed = outcomes.iter().filter(|o| o.passed()).count();
        Self {
            passed,
            failed: outcomes.len() - passed,
        }
    }
}

impl std::fmt::Display for Summary {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} passed, {} failed", self.passed, self.failed)
    }
}

/// Errors that stop a whole run (a test's own errors are [`Failure`]s instead).
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// A path given on the command line does not exist.
    #[error("no such test file or directory: {0}")]
    MissingPath(PathBuf),
    /// A directory could not be read.
    #[error("cannot read {path}: {source}")]
    Io {
        /// The directory.
        path: PathBuf,
        /// Why it could not be read.
        source: std::io::Error,
    },
    /// `--filter` matched no test.
    #[error("{}", no_match_message(filter, available))]
    NoMatch {
        /// The filter text.
        filter: String,
        /// `file :: name` of every test the files declare.
        available: Vec<String>,
    },
}

/// How many test names a [`RunError::NoMatch`] message lists.
const NAMES_LISTED: usize = 8;

fn no_match_message(filter: &str, available: &[String]) -> String {
    let mut s = format!(
        "--filter {filter:?} matches no test (it is looked for in test names and file names)"
    );
    if available.is_empty() {
        s.push_str("; the test files declare no tests");
        return s;
    }
    if available.len() > NAMES_LISTED {
        s.push_str(&format!("; the {} tests here include:", available.len()));
    } else {
        s.push_str("; the tests here are:");
    }
    for name in available.iter().take(NAMES_LISTED) {
        s.push_str(&format!("\n    {name}"));
    }
    if available.len() > NAMES_LISTED {
        s.push_str(&format!(
            "\n    … and {} more",
            available.len() - NAMES_LISTED
        ));
    }
    s
}

/// The [`RunError::NoMatch`] for `filter` over `files`, listing the tests they declare.
pub fn no_match(files: &[PathBuf], filter: &str, options: &RunOptions) -> RunError {
    let available = files
        .iter()
        .flat_map(|file| {
            let short = file
                .file_name()
                .map(|n| n.to_string_lossy().into_owned())
                .unwrap_or_default();
            api::test_names(file, options)
                .into_iter()
                .map(move |name| format!("{short} :: {name}"))
        })
        .collect();
    RunError::NoMatch {
        filter: filter.to_owned(),
        available,
    }
}

/// Every `*_test.lua` under `paths` (files are taken as given), sorted, without duplicates.
pub fn discover(paths: &[PathBuf]) -> Result<Vec<PathBuf>, RunError> {
    fn walk(dir: &Path, out: &mut Vec<PathBuf>) -> Result<(), RunError> {
        let entries = std::fs::read_dir(dir).map_err(|source| RunError::Io {
            path: dir.to_path_buf(),
            source,
        })?;
        for entry in entries {
            let path = entry
                .map_err(|source| RunError::Io {
                    path: dir.to_path_buf(),
                    source,
                })?
                .path();
            if path.is_dir() {
                walk(&path, out)?;
            } else if path
                .file_name()
                .and_then(|n| n.to_str())
                .is_some_and(|n| n.ends_with("_test.lua"))
            {
                out.push(path);
            }
        }
        Ok(())
    }
    let mut files = Vec::new();
    for path in paths {
        if path.is_dir() {
            walk(path, &mut files)?;
        } else if path.is_file() {
            files.push(path.clone());
        } else {
            return Err(RunError::MissingPath(path.clone()));
        }
    }
    files.sort();
    files.dedup();
    Ok(files)
}

/// Runs every test of every file, calling `on_outcome` as each finishes (for live output).
pub fn run_files(
    files: &[PathBuf],
    options: &RunOptions,
    mut on_outcome: impl FnMut(&TestOutcome),
) -> Vec<TestOutcome> {
    let mut outcomes = Vec::new();
    for file in files {
        for outcome in api::run_file(file, options) {
            on_outcome(&outcome);
            outcomes.push(outcome);
        }
    }
    outcomes
}

/// One line per test: status, name, simulated seconds, wall time; failures indented below.
pub fn format_outcome(outcome: &TestOutcome) -> String {
    let status = if outcome.passed() { "PASS" } else { "FAIL" };
    let file = outcome
        .file
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut line = format!(
        "{status} {file} :: {} ({:.1} s simulated, {:.0} ms wall)",
        outcome.name,
        outcome.sim_seconds,
        outcome.wall.as_secs_f64() * 1000.0
    );
    for failure in &outcome.failures {
        line.push_str(&format!("\n    {failure}"));
    }
    let several_worlds = outcome.output.iter().any(|l| l.world > 0);
    for out in &outcome.output {
        let label = if out.error {
            "error (allowed)"
        } else if out.warning {
            "warning"
        } else {
            "print"
        };
        line.push_str(&format!("\n    {label} {}", out.describe(several_worlds)));
    }
    for path in &outcome.trace_files {
        line.push_str(&format!("\n    trace: {}", path.display()));
        if path.extension().is_some_and(|e| e == "shoalrun") {
            let at = outcome.failures.first().map_or(0.0, |f| f.sim_time);
            line.push_str(&format!(
                "\n      open the failing moment: shoal run --open {} --at {at:.2}",
                path.display()
            ));
        }
    }
    line
}

/// Wall-clock helper shared by the runner.
pub(crate) fn elapsed_since(start: Instant) -> Duration {
    start.elapsed()
}
