//! `shoal test [PATH...] [--filter TEXT] [--trace DIR] [--watch]`: headless Lua behaviour tests.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use anyhow::Context;

use crate::testing::{self, RunOptions, Summary};

/// Arguments of `shoal test`.
#[derive(Debug, Default, clap::Args)]
pub struct Args {
    /// Test files or directories searched for `*_test.lua` (default: tests/behavior/).
    pub paths: Vec<PathBuf>,
    /// Run only tests whose name or file name contains this text.
    #[arg(long)]
    pub filter: Option<String>,
    /// Write each failing test's trajectories (CSV) and a top-view plot (PNG) here.
    #[arg(long, value_name = "DIR")]
    pub trace: Option<PathBuf>,
    /// Rerun the tests whenever a file under the test paths or scripts/ is saved.
    #[arg(long)]
    pub watch: bool,
}

/// Runs `shoal test`.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let root = std::env::current_dir().context("cannot read the current directory")?;
    let paths = if args.paths.is_empty() {
        vec![PathBuf::from("tests/behavior")]
    } else {
        args.paths.clone()
    };
    if let Some(dir) = &args.trace {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create trace directory {}", dir.display()))?;
    }
    let options = RunOptions {
        filter: args.filter.clone(),
        trace_dir: args.trace.clone(),
        root: root.clone(),
    };
    let summary = run_once(&paths, &options)?;
    if !args.watch {
        return Ok(if summary.failed == 0 {
            ExitCode::SUCCESS
        } else {
            ExitCode::FAILURE
        });
    }
    watch(&paths, &root, &options)
}

fn run_once(paths: &[PathBuf], options: &RunOptions) -> anyhow::Result<Summary> {
    let files = testing::discover(paths)?;
    let outcomes = testing::run_files(&files, options, |outcome| {
        println!("{}", testing::format_outcome(outcome));
    });
    let summary = Summary::of(&outcomes);
    println!("{summary}");
    Ok(summary)
}

fn watch(
    paths: &[PathBuf],
    root: &std::path::Path,
    options: &RunOptions,
) -> anyhow::Result<ExitCode> {
    use notify::RecursiveMode;
    use notify_debouncer_full::new_debouncer;

    let (tx, rx) = std::sync::mpsc::channel();
    let mut debouncer = new_debouncer(Duration::from_millis(150), None, tx)
        .context("cannot start the file watcher")?;
    let mut watched: Vec<PathBuf> = paths.to_vec();
    watched.push(root.join("scripts"));
    for path in &watched {
        // Directories, not files: editors save by writing a new file and renaming it over.
        let dir = if path.is_dir() {
            path.clone()
        } else {
            path.parent()
                .map(|p| p.to_path_buf())
                .unwrap_or_else(|| root.to_path_buf())
        };
        debouncer
            .watch(&dir, RecursiveMode::Recursive)
            .with_context(|| format!("cannot watch {}", dir.display()))?;
    }
    println!("watching for changes (Ctrl-C to stop)");
    for events in rx {
        let Ok(events) = events else { continue };
        let lua_changed = events.iter().any(|e| {
            e.paths
                .iter()
                .any(|p| p.extension().is_some_and(|x| x == "lua"))
        });
        if lua_changed {
            println!("\n--- change detected, rerunning ---");
            if let Err(err) = run_once(paths, options) {
                println!("error: {err:#}");
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}
