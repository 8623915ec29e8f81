//! Loading a test file and running its tests: each in a fresh world, with its failures, script
//! errors, prints and trace collected into a [`TestOutcome`].

use super::{Cell, Shared, TestHandle, TestState, WorldState};
use crate::log::LogLevel;
use crate::testing::{Failure, RunOptions, ScriptLine, TestOutcome};
use mlua::{Lua, Table, Value};
use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

/// A Lua state for test files: the standard library without `io`, `os` (but `os.clock`),
/// `debug`'s mutating parts or binary chunk loading. Test files are trusted more than fish
/// scripts (they are the designer's own checks), but they still cannot touch the machine.
pub(super) fn test_lua() -> mlua::Result<Lua> {
    let lua = Lua::new();
    let globals = lua.globals();
    let clock: mlua::Function = globals.get::<Table>("os")?.get("clock")?;
    let os = lua.create_table()?;
    os.set("clock", clock)?;
    globals.set("os", os)?;
    for name in ["io", "debug", "dofile", "loadfile", "package", "require"] {
        globals.set(name, Value::Nil)?;
    }
    Ok(lua)
}

/// The tests a file declares, in order, with the Lua state they run in.
type Declared = (Lua, Vec<(String, mlua::Function)>);

/// Why a test file did not load (its one failure, under the file's name).
#[derive(Debug, thiserror::Error)]
pub(super) enum TestFileError {
    /// The file could not be read.
    #[error("cannot read: {0}")]
    Read(#[source] std::io::Error),
    /// No Lua state could be made for it.
    #[error("cannot create a Lua state: {0}")]
    State(#[source] mlua::Error),
    /// `test` could not be made a global.
    #[error("cannot register test(): {0}")]
    Register(#[source] mlua::Error),
    /// Running the file raised an error (a syntax error, an error at its top level); the
    /// message is the first line of Lua's.
    #[error("{}", first_line(&.0.to_string()))]
    Run(mlua::Error),
}

pub(super) fn load_tests(file: &Path, options: &RunOptions) -> Result<Declared, TestFileError> {
    let source = std::fs::read_to_string(file).map_err(TestFileError::Read)?;
    let lua = test_lua().map_err(TestFileError::State)?;
    let declared: Cell<Vec<(String, mlua::Function)>> = Cell::new(Vec::new());
    let register = {
        let declared = declared.clone();
        lua.create_function(move |_, (name, f): (String, mlua::Function)| {
            declared.borrow_mut().push((name, f));
            Ok(())
        })
    };
    register
        .and_then(|f| lua.globals().set("test", f))
        .map_err(TestFileError::Register)?;
    let chunk_name = format!("@{}", display_path(file, &options.root));
    lua.load(&source)
        .set_name(chunk_name)
        .exec()
        .map_err(TestFileError::Run)?;
    let tests = std::mem::take(&mut *declared.borrow_mut());
    Ok((lua, tests))
}

/// The names of the tests a file declares (none if it does not load).
pub fn test_names(file: &Path, options: &RunOptions) -> Vec<String> {
    load_tests(file, options)
        .map(|(_, tests)| tests.into_iter().map(|(name, _)| name).collect())
        .unwrap_or_default()
}

/// Runs every test of one file (filtered by `options.filter`) and returns their outcomes.
/// A file that does not load yields one failed outcome named after the file.
pub fn run_file(file: &Path, options: &RunOptions) -> Vec<TestOutcome> {
    let (lua, tests) = match load_tests(file, options) {
        Ok(declared) => declared,
        Err(e) => {
            return vec![TestOutcome {
                file: file.to_path_buf(),
                name: "(load)".into(),
                failures: vec![Failure {
                    file: file.to_path_buf(),
                    line: None,
                    message: e.to_string(),
                    sim_time: 0.0,
                }],
                sim_seconds: 0.0,
                wall: std::time::Duration::ZERO,
                num_checks: 0,
                trace_files: Vec::new(),
                output: Vec::new(),
            }];
        }
    };
    let file_name = file
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut outcomes = Vec::new();
    for (name, function) in tests {
        if let Some(filter) = &options.filter
            && !name.contains(filter.as_str())
            && !file_name.contains(filter.as_str())
        {
            continue;
        }
        outcomes.push(run_one(&lua, file, &name, function, options));
    }
    outcomes
}

/// Most distinct script errors reported as failures per world; the rest are counted.
const ERRORS_REPORTED: usize = 5;

/// Splits what a world's scripts logged into failures (its errors, unless the world allows them)
/// and output lines (prints, and the errors it allows), errors deduplicated by message.
pub(super) fn script_report(
    file: &Path,
    index: usize,
    world: &WorldState,
    failures: &mut Vec<Failure>,
    output: &mut Vec<ScriptLine>,
) {
    let mut seen_errors: Vec<&str> = Vec::new();
    let mut unreported = 0usize;
    for entry in &world.log {
        let is_error = entry.level == LogLevel::Error;
        if is_error {
            if seen_errors.contains(&entry.message.as_str()) {
                continue;
            }
            seen_errors.push(&entry.message);
        }
        if is_error && !world.allow_errors {
            if seen_errors.len() > ERRORS_REPORTED {
                unreported += 1;
                continue;
            }
            let fish = entry
                .fish
                .map(|f| format!(" in fish {}", f.index))
                .unwrap_or_default();
            failures.push(Failure {
                file: file.to_path_buf(),
                line: world.line,
                message: format!(
                    "script error{fish}: {} (a test that expects errors makes this world with \
                     t:world{{ allow_errors = true }} and checks w:errors())",
                    entry.message
                ),
                sim_time: entry.time_s,
            });
            continue;
        }
        output.push(ScriptLine {
            world: index,
            time_s: entry.time_s,
            fish: entry.fish.map(|f| f.index),
            message: entry.message.clone(),
            error: is_error,
            repeats: entry.repeats,
            warning: entry.level == LogLevel::Warning,
        });
    }
    if unreported > 0 {
        failures.push(Failure {
            file: file.to_path_buf(),
            line: world.line,
            message: format!("… and {unreported} more distinct script errors in this world"),
            sim_time: world.sim.world().time(),
        });
    }
}

pub(super) fn run_one(
    lua: &Lua,
    file: &Path,
    name: &str,
    function: mlua::Function,
    options: &RunOptions,
) -> TestOutcome {
    let start = Instant::now();
    let state: Shared = Cell::new(TestState {
        file: file.to_path_buf(),
        root: options.root.clone(),
        failures: Vec::new(),
        num_checks: 0,
        sim_seconds: 0.0,
        last_time: 0.0,
        worlds: Vec::new(),
        record_runs: options.trace_dir.is_some(),
        lod: options.lod,
    });
    let result = lua
        .create_userdata(TestHandle(state.clone()))
        .and_then(|t| function.call::<()>(t));
    if let Err(e) = result {
        let (line, message) = split_lua_error(&e.to_string());
        let mut s = state.borrow_mut();
        let sim_time = s.last_time;
        s.failures.push(Failure {
            file: file.to_path_buf(),
            line,
            message: format!("error: {message}"),
            sim_time,
        });
    }
    // Free the test's worlds before the next test (userdata may linger until GC).
    let _ = lua.gc_collect();
    let state = Arc::try_unwrap(state.0)
        .map(|m| m.into_inner().unwrap_or_else(|e| e.into_inner()))
        .unwrap_or_else(|rc| {
            let s = rc.lock().unwrap_or_else(|e| e.into_inner());
            TestState {
                file: s.file.clone(),
                root: s.root.clone(),
                failures: s.failures.clone(),
                num_checks: s.num_checks,
                sim_seconds: s.sim_seconds,
                last_time: s.last_time,
                worlds: s.worlds.clone(),
                record_runs: s.record_runs,
                lod: s.lod,
            }
        });
    // Script errors first: they are usually why a check failed.
    let mut failures = Vec::new();
    let mut output = Vec::new();
    for (i, world) in state.worlds.iter().enumerate() {
        let mut world = world.borrow_mut();
        world.drain_log();
        script_report(file, i, &world, &mut failures, &mut output);
    }
    failures.extend(state.failures);
    let mut trace_files = Vec::new();
    if !failures.is_empty()
        && let Some(dir) = &options.trace_dir
    {
        let stem = format!(
            "{}-{}",
            file.file_stem()
                .map(|s| s.to_string_lossy())
                .unwrap_or_default(),
            slug(name)
        );
        for (i, world) in state.worlds.iter().enumerate() {
            let trace = world.borrow().to_trace();
            let base = if state.worlds.len() == 1 {
                stem.clone()
            } else {
                format!("{stem}-world{i}")
            };
            let csv = dir.join(format!("{base}.csv"));
            let png = dir.join(format!("{base}.png"));
            match trace
                .write_csv(&csv)
                .and_then(|()| trace.write_top_view(&png))
            {
                Ok(()) => trace_files.extend([csv, png]),
                Err(e) => failures.push(Failure {
                    file: file.to_path_buf(),
                    line: None,
                    message: format!("trace not written: {e}"),
                    sim_time: state.last_time,
                }),
            }
            // The recording, to open the failing moment in the window (`shoal run --open`).
            let run_path = dir.join(format!("{base}.shoalrun"));
            let written: Result<(), super::RecordingError> = world
                .borrow()
                .to_run()
                .map_err(Into::into)
                .and_then(|run| Ok(run.write(&run_path)?));
            match written {
                Ok(()) => trace_files.push(run_path),
                Err(why) => output.push(ScriptLine {
                    world: i,
                    time_s: state.last_time,
                    fish: None,
                    message: format!("no recording of this world: {why}"),
                    error: false,
                    repeats: 0,
                    warning: true,
                }),
            }
        }
    }
    TestOutcome {
        file: file.to_path_buf(),
        name: name.to_string(),
        failures,
        sim_seconds: state.sim_seconds,
        wall: crate::testing::elapsed_since(start),
        num_checks: state.num_checks,
        trace_files,
        output,
    }
}

pub(super) fn slug(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_lowercase()
            } else {
                '_'
            }
        })
        .collect()
}

pub(super) fn display_path(file: &Path, root: &Path) -> String {
    file.strip_prefix(root)
        .unwrap_or(file)
        .display()
        .to_string()
}

pub(super) fn first_line(text: &str) -> String {
    text.lines().next().unwrap_or(text).to_string()
}

/// Lua errors read `[runtime error: ]file.lua:line: message`; split the line number out when
/// it is there.
pub(super) fn split_lua_error(text: &str) -> (Option<usize>, String) {
    let first = first_line(text);
    if let Some(at) = first.find(".lua:") {
        let rest = &first[at + ".lua:".len()..];
        let digits: String = rest.chars().take_while(char::is_ascii_digit).collect();
        if let (Ok(line), Some(message)) = (digits.parse(), rest[digits.len()..].strip_prefix(':'))
        {
            return (Some(line), message.trim().to_string());
        }
    }
    (None, first)
}
