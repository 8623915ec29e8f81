//! `shoal test [PATH...] [--filter TEXT] [--trace DIR] [--watch]`: headless Lua behaviour tests.

use std::collections::BTreeMap;
use std::hash::{DefaultHasher, Hash, Hasher};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

use anyhow::Context;
use notify::EventKind;
use notify::event::ModifyKind;

use shoal_script::testing::{self, RunOptions, Summary};

/// Arguments of `shoal test`.
#[derive(Debug, Default, clap::Args)]
pub struct Args {
    /// Test files or directories searched for `*_test.lua` (default: tests/behavior/).
    pub paths: Vec<PathBuf>,
    /// Run only tests whose name or file name contains this text (an error if none does).
    #[arg(long)]
    pub filter: Option<String>,
    /// Write each failing test's trajectories (CSV) and a top-view plot (PNG) here.
    #[arg(long, value_name = "DIR")]
    pub trace: Option<PathBuf>,
    /// Rerun the tests once each time a .lua file under the test paths or scripts/ is saved
    /// with new content.
    #[arg(long)]
    pub watch: bool,
    /// Where the scripts come from (`--scripts DIR`, `SHOAL_SCRIPTS`).
    #[command(flatten)]
    pub scripts: super::ScriptsArg,
    /// Behaviour level of detail in every test world (`--lod on|off`; default: each scene's).
    #[command(flatten)]
    pub lod: super::LodArg,
    /// Debugging the behaviours from an editor (`--dap [ADDR]`).
    #[command(flatten)]
    pub dap: super::DapArg,
}

/// The root the tests run against: `source.root` itself when the scripts are its `scripts/`,
/// else a temporary root whose `scripts` and `assets` point at `source.scripts` and
/// `source.root/assets` (kept alive by the returned directory).
fn test_root(source: &super::ScriptSource) -> anyhow::Result<(PathBuf, Option<tempfile::TempDir>)> {
    let own = source.root.join("scripts");
    if own.canonicalize().ok() == source.scripts.canonicalize().ok() {
        return Ok((source.root.clone(), None));
    }
    let dir = tempfile::tempdir().context("cannot make a directory for --scripts")?;
    #[cfg(unix)]
    {
        std::os::unix::fs::symlink(&source.scripts, dir.path().join("scripts"))
            .context("cannot link the --scripts directory")?;
        std::os::unix::fs::symlink(source.root.join("assets"), dir.path().join("assets"))
            .context("cannot link the assets directory")?;
    }
    #[cfg(not(unix))]
    anyhow::bail!("--scripts with shoal test needs a Unix system (symbolic links)");
    Ok((dir.path().to_path_buf(), Some(dir)))
}

/// Runs `shoal test`.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let source = args.scripts.resolve()?;
    println!("{source}");
    let (root, _linked) = test_root(&source)?;
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
        lod: args.lod.on(),
    };
    let debugger = args.dap.start()?;
    if !args.watch {
        let summary = run_once(&paths, &options);
        if let Some(d) = &debugger {
            let failed = !summary.as_ref().is_ok_and(|s| s.failed == 0);
            if let Ok(s) = &summary {
                d.output("console", &s.to_string());
            }
            d.finish(i32::from(failed));
        }
        let summary = summary?;
        return Ok(if summary.failed == 0 {
            ExitCode::SUCCESS
        } else {
            ExitCode::FAILURE
        });
    }
    watch(&paths, &root, &options)
}

/// Runs the tests once, printing each outcome as it finishes and the summary line.
fn run_once(paths: &[PathBuf], options: &RunOptions) -> anyhow::Result<Summary> {
    let files = testing::discover(paths)?;
    let debugger = shoal_script::debug::global();
    let outcomes = testing::run_files(&files, options, |outcome| {
        let line = testing::format_outcome(outcome);
        println!("{line}");
        if let Some(d) = &debugger {
            d.output("console", &line);
        }
    });
    if outcomes.is_empty()
        && let Some(filter) = &options.filter
    {
        return Err(testing::no_match(&files, filter, options).into());
    }
    let summary = Summary::of(&outcomes);
    println!("{summary}");
    Ok(summary)
}

/// Whether a file event can mean a `.lua` file's content changed: created, written, renamed
/// (editors save by renaming a new file over the old one) or removed. Reading a file (the
/// runner's own loads), closing it unchanged or touching its metadata cannot.
pub fn is_lua_content_event(event: &notify::Event) -> bool {
    let kind_may_change_content = matches!(
        event.kind,
        EventKind::Create(_)
            | EventKind::Remove(_)
            | EventKind::Modify(ModifyKind::Data(_) | ModifyKind::Name(_) | ModifyKind::Any)
    );
    kind_may_change_content
        && event
            .paths
            .iter()
            .any(|p| p.extension().is_some_and(|x| x == "lua"))
}

/// A hash of every `.lua` file under `dirs` (paths and contents): equal hashes mean no test or
/// script changed, whatever the file events said.
pub fn lua_fingerprint(dirs: &[PathBuf]) -> u64 {
    fn walk(path: &Path, files: &mut BTreeMap<PathBuf, Vec<u8>>) {
        if path.is_dir() {
            if let Ok(entries) = std::fs::read_dir(path) {
                for entry in entries.flatten() {
                    walk(&entry.path(), files);
                }
            }
        } else if path.extension().is_some_and(|x| x == "lua") {
            // A file that cannot be read (mid-save) hashes as empty; its next event rehashes it.
            files.insert(path.to_path_buf(), std::fs::read(path).unwrap_or_default());
        }
    }
    let mut files = BTreeMap::new();
    for dir in dirs {
        walk(dir, &mut files);
    }
    let mut hasher = DefaultHasher::new();
    files.hash(&mut hasher);
    hasher.finish()
}

/// Changed `.lua` files named by content events, shortest paths first, for the rerun banner.
fn changed_names(events: &[notify_debouncer_full::DebouncedEvent], root: &Path) -> String {
    let mut names: Vec<String> = events
        .iter()
        .filter(|e| is_lua_content_event(e))
        .flat_map(|e| e.paths.iter())
        .filter(|p| p.extension().is_some_and(|x| x == "lua"))
        .map(|p| p.strip_prefix(root).unwrap_or(p).display().to_string())
        .collect();
    names.sort();
    names.dedup();
    names.join(", ")
}

fn watch(paths: &[PathBuf], root: &Path, options: &RunOptions) -> anyhow::Result<ExitCode> {
    use notify::RecursiveMode;
    use notify_debouncer_full::new_debouncer;

    let (tx, rx) = std::sync::mpsc::channel();
    let mut debouncer = new_debouncer(Duration::from_millis(150), None, tx)
        .context("cannot start the file watcher")?;
    let mut watched: Vec<PathBuf> = Vec::new();
    // scripts/ where there is one: a directory of tests alone needs none.
    let scripts = Some(root.join("scripts")).filter(|p| p.is_dir());
    for path in paths.iter().cloned().chain(scripts) {
        // Directories, not files: editors save by writing a new file and renaming it over.
        let dir = if path.is_dir() {
            path
        } else {
            path.parent()
                .filter(|p| !p.as_os_str().is_empty())
                .map(Path::to_path_buf)
                .unwrap_or_else(|| root.to_path_buf())
        };
        if !watched.contains(&dir) {
            watched.push(dir);
        }
    }
    for dir in &watched {
        debouncer
            .watch(dir, RecursiveMode::Recursive)
            .with_context(|| format!("cannot watch {}", dir.display()))?;
    }
    // `SHOAL_WATCH_TRACE`: a line for each batch of file events that does not rerun the tests, so
    // a test can wait for the watcher's decision instead of sleeping.
    let trace = std::env::var_os("SHOAL_WATCH_TRACE").is_some_and(|v| !v.is_empty());
    let mut last = lua_fingerprint(&watched);
    if let Err(err) = run_once(paths, options) {
        println!("error: {err:#}");
    }
    println!("watching for changes (Ctrl-C to stop)");
    for events in rx {
        let Ok(events) = events else { continue };
        if !events.iter().any(|e| is_lua_content_event(e)) {
            if trace {
                println!(
                    "watch: {} file events, none a .lua save: no rerun",
                    events.len()
                );
            }
            continue;
        }
        // Saving the same text again, or a burst of events for one save, changes nothing.
        let now = lua_fingerprint(&watched);
        if now == last {
            if trace {
                println!(
                    "watch: {} saved with the same text: no rerun",
                    changed_names(&events, root)
                );
            }
            continue;
        }
        last = now;
        println!(
            "\n--- {} changed, rerunning ---",
            changed_names(&events, root)
        );
        if let Err(err) = run_once(paths, options) {
            println!("error: {err:#}");
        }
    }
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::*;
    use notify::event::{AccessKind, AccessMode, CreateKind, DataChange, MetadataKind};

    fn event(kind: EventKind, path: &str) -> notify::Event {
        notify::Event::new(kind).add_path(PathBuf::from(path))
    }

    #[test]
    fn reads_and_metadata_are_not_content_changes() {
        let reads = [
            EventKind::Access(AccessKind::Open(AccessMode::Read)),
            EventKind::Access(AccessKind::Close(AccessMode::Read)),
            EventKind::Access(AccessKind::Read),
            EventKind::Modify(ModifyKind::Metadata(MetadataKind::AccessTime)),
        ];
        for kind in reads {
            assert!(
                !is_lua_content_event(&event(kind, "tests/a_test.lua")),
                "{kind:?}"
            );
        }
        let writes = [
            EventKind::Create(CreateKind::File),
            EventKind::Modify(ModifyKind::Data(DataChange::Content)),
            EventKind::Modify(ModifyKind::Any),
            EventKind::Modify(ModifyKind::Name(notify::event::RenameMode::To)),
            EventKind::Remove(notify::event::RemoveKind::File),
        ];
        for kind in writes {
            assert!(
                is_lua_content_event(&event(kind, "tests/a_test.lua")),
                "{kind:?}"
            );
            assert!(
                !is_lua_content_event(&event(kind, "trace/a_test-x.csv")),
                "{kind:?} on a CSV"
            );
        }
    }

    #[test]
    fn fingerprint_follows_content_not_reads() {
        let dir = tempfile::tempdir().unwrap();
        let dirs = [dir.path().to_path_buf()];
        std::fs::create_dir_all(dir.path().join("sub")).unwrap();
        std::fs::write(dir.path().join("sub/a_test.lua"), "-- one").unwrap();
        std::fs::write(dir.path().join("notes.txt"), "x").unwrap();
        let first = lua_fingerprint(&dirs);
        let _ = std::fs::read(dir.path().join("sub/a_test.lua")).unwrap();
        std::fs::write(dir.path().join("notes.txt"), "y").unwrap();
        assert_eq!(lua_fingerprint(&dirs), first, "reads and non-Lua files");
        std::fs::write(dir.path().join("sub/a_test.lua"), "-- one").unwrap();
        assert_eq!(lua_fingerprint(&dirs), first, "the same text saved again");
        std::fs::write(dir.path().join("sub/a_test.lua"), "-- two").unwrap();
        assert_ne!(lua_fingerprint(&dirs), first, "new content");
    }
}
