//! `shoal run`: the aquarium window with the tuning panel.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;

use crate::app::{
    AppOptions, Aquarium, OverlayToggles, SimView, SplitVersions, run_aquarium, run_window,
};
use crate::script::Simulation;
use crate::timeline::run_file::{Run, changed_scripts, read_scripts};
use crate::world::FishId;

/// Arguments of `shoal run`.
#[derive(Debug, Default, clap::Args)]
pub struct Args {
    /// Scene: a Lua scene (a `.lua` file, or the name of one in `scripts/scenes/`) or `porgies`
    /// (black porgies from `assets/black_porgy.glb`, built-in wander/school behaviour).
    /// Default: `scripts/scenes/default.lua`, else `porgies`.
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Random seed of the scene.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Draw this many frames, then exit (for tests and scripted runs).
    #[arg(long)]
    pub frames: Option<u64>,
    /// Number of fish (`porgies` scene; a Lua scene sets its own).
    #[arg(long)]
    pub fish: Option<usize>,
    /// Select (and follow) this fish at start (0-based, in the scene's order).
    #[arg(long)]
    pub select: Option<usize>,
    /// Show every debug overlay at start.
    #[arg(long)]
    pub overlays: bool,
    /// Multisample anti-aliasing, samples a pixel: 4 or 1. Default: 4 on a GPU, 1 on a
    /// software renderer such as lavapipe (where 4 costs ~2.7× the frame time).
    #[arg(long, value_name = "N", value_parser = parse_msaa)]
    pub msaa: Option<u32>,
    /// Open a recording (`.shoalrun`, from `shoal record`, `replay`, or a failing behaviour
    /// test's `--trace`) at `--at`: its scene and seed, paused at that moment, with the
    /// recording's future as the ghost that playing on (with the current scripts) is compared
    /// with.
    #[arg(long, value_name = "RUN", conflicts_with_all = ["scene", "seed", "fish"])]
    pub open: Option<PathBuf>,
    /// With `--open`: the moment to open at, seconds into the recording (default: its start).
    #[arg(long, value_name = "T", requires = "open")]
    pub at: Option<f64>,
    /// Split tank: run a second version of the scripts beside these, from the same scene and
    /// seed, time-locked in one window (A left, B right). B is a scripts directory, or
    /// `git:REV` for the scripts directory at revision REV of the git repository they are in.
    #[arg(long, value_name = "DIR|git:REV", conflicts_with = "open")]
    pub split: Option<String>,
    /// Where the scripts come from (`--scripts DIR`, `SHOAL_SCRIPTS`).
    #[command(flatten)]
    pub scripts: super::ScriptsArg,
    /// Debugging the behaviours from an editor (`--dap [ADDR]`). While a breakpoint holds the
    /// simulation, the window does not redraw.
    #[command(flatten)]
    pub dap: super::DapArg,
}

/// `--msaa`: 1 or 4.
fn parse_msaa(s: &str) -> Result<u32, String> {
    match s.trim() {
        "1" => Ok(1),
        "4" => Ok(4),
        other => Err(format!(
            "{other:?} is not a sample count shoal draws with: 1 (off) or 4"
        )),
    }
}

/// Runs `shoal run`.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let source = args.scripts.resolve()?;
    println!("{source}");
    let debugger = args.dap.start()?;
    let result = run_with(&args, &source);
    if let Some(d) = debugger {
        d.finish(i32::from(result.is_err()));
    }
    result
}

fn run_with(args: &Args, source: &super::ScriptSource) -> anyhow::Result<ExitCode> {
    if let Some(run) = &args.open {
        return open(args, source, run);
    }
    if let Some(spec) = &args.split {
        return run_split(args, source, spec);
    }
    let sim = super::render::load_scene(source, args.scene.as_deref(), args.seed, args.fish)?;
    let select = super::render::check_select(args.select, sim.world())?;
    let presented = run_window(sim, options(args, select))?;
    println!("presented {presented} frames");
    Ok(ExitCode::SUCCESS)
}

fn options(args: &Args, select: Option<FishId>) -> AppOptions {
    AppOptions {
        frames: args.frames,
        select,
        overlays: if args.overlays {
            OverlayToggles::ALL
        } else {
            OverlayToggles::default()
        },
        msaa: args.msaa,
    }
}

/// `shoal run --open RUN [--at T]`.
fn open(args: &Args, source: &super::ScriptSource, path: &Path) -> anyhow::Result<ExitCode> {
    let run = Run::read(path)?;
    let at = args.at.unwrap_or(0.0);
    let name = path.display().to_string();
    let (sim, tick) = crate::timeline::resume(&run, &source.root, &source.scripts, at)
        .with_context(|| format!("opening {name} at {at} s"))?;
    let select = super::render::check_select(args.select, sim.world())?;
    let scripts = read_scripts(&source.scripts)
        .with_context(|| format!("reading {}", source.scripts.display()))?;
    let changed = changed_scripts(&run.header.scripts, &scripts);
    let ghost = run.frames[tick..]
        .iter()
        .enumerate()
        .map(|(k, frame)| {
            let ids = frame
                .iter()
                .map(|p| FishId {
                    index: p.index,
                    generation: p.generation,
                })
                .collect();
            let pos = frame.iter().map(|p| p.pos).collect();
            ((tick + k) as u64, ids, pos)
        })
        .collect();
    let note = if changed.is_empty() {
        format!(
            "opened {name} at {:.2} s (paused): the scripts are the recording's, so playing on \
             follows it exactly",
            run.time_of(tick)
        )
    } else {
        format!(
            "opened {name} at {:.2} s (paused) with these scripts ({} changed since the \
             recording: {}); the recording's future is the ghost",
            run.time_of(tick),
            changed.len(),
            changed.join(", ")
        )
    };
    let later = run
        .header
        .inputs
        .iter()
        .filter(|i| i.tick > tick as u64)
        .count();
    let note = if later > 0 {
        format!(
            "{note}. The test did {later} more things to its world after this moment (spawns, \
             food, motions); the window runs on without them, the ghost has them"
        )
    } else {
        note
    };
    println!("{note}");
    let options = options(args, select);
    let mut aq = Aquarium::new(Box::new(sim), options);
    aq.open_recording(ghost, note);
    let presented = run_aquarium(aq, options)?;
    println!("presented {presented} frames");
    Ok(ExitCode::SUCCESS)
}

/// Version B of a split tank (`--split DIR` or `--split git:REV`): its scripts directory and
/// label. A git revision's scripts are written into a temporary directory that lives as long as
/// this value.
#[derive(Debug)]
pub struct SplitSource {
    /// B's scripts directory.
    pub scripts: PathBuf,
    /// What B is, for the window's labels (`git:HEAD~1 (3f2a1c0)` or the directory).
    pub label: String,
    _temp: Option<tempfile::TempDir>,
}

/// Resolves `--split SPEC` against A's scripts directory `a_scripts`: a scripts directory, or
/// `git:REV` — the scripts directory of revision REV of the git repository `a_scripts` is in,
/// materialised into a temporary directory. A missing directory, a missing git, a scripts
/// directory outside a repository or an unknown revision is an error saying which.
pub fn split_source(spec: &str, a_scripts: &Path) -> anyhow::Result<SplitSource> {
    let Some(rev) = spec.strip_prefix("git:") else {
        let dir = Path::new(spec);
        if !dir.is_dir() {
            anyhow::bail!(
                "--split {spec}: no such directory (B is a scripts directory holding behaviors/, \
                 species/ and scenes/, or git:REV for a revision of the repository the scripts \
                 are in)"
            );
        }
        let dir = dir.canonicalize().unwrap_or_else(|_| dir.to_path_buf());
        return Ok(SplitSource {
            label: dir.display().to_string(),
            scripts: dir,
            _temp: None,
        });
    };
    if rev.is_empty() || rev.starts_with('-') {
        anyhow::bail!("--split {spec}: expected git:REV with a revision, e.g. git:HEAD~1");
    }
    let top = git(spec, a_scripts, &["rev-parse", "--show-toplevel"]).map_err(|e| {
        anyhow::anyhow!(
            "{e}: the scripts directory {} must be inside a git repository for git:REV",
            a_scripts.display()
        )
    })?;
    let top = PathBuf::from(String::from_utf8_lossy(&top).trim());
    let prefix = git(spec, a_scripts, &["rev-parse", "--show-prefix"])?;
    let prefix = String::from_utf8_lossy(&prefix).trim().to_owned();
    let commit = git(
        spec,
        &top,
        &[
            "rev-parse",
            "--verify",
            "--quiet",
            &format!("{rev}^{{commit}}"),
        ],
    )
    .map_err(|_| {
        anyhow::anyhow!(
            "--split {spec}: no revision `{rev}` in the git repository {}",
            top.display()
        )
    })?;
    let commit = String::from_utf8_lossy(&commit).trim().to_owned();
    let path = if prefix.is_empty() { "." } else { &prefix };
    let listing = git(spec, &top, &["ls-tree", "-r", "-z", &commit, "--", path])?;
    let temp = tempfile::Builder::new()
        .prefix("shoal-split-")
        .tempdir()
        .with_context(|| format!("--split {spec}: cannot make a temporary directory"))?;
    let mut files = 0;
    for entry in listing.split(|&b| b == 0).filter(|e| !e.is_empty()) {
        // `<mode> <type> <object>\t<path>`
        let entry = String::from_utf8_lossy(entry);
        let Some((meta, file)) = entry.split_once('\t') else {
            continue;
        };
        let mut meta = meta.split(' ');
        let (Some(_mode), Some("blob"), Some(object)) = (meta.next(), meta.next(), meta.next())
        else {
            continue;
        };
        let rel = file.strip_prefix(prefix.as_str()).unwrap_or(file);
        let out = temp.path().join(rel);
        let text = git(spec, &top, &["cat-file", "blob", object])?;
        if let Some(parent) = out.parent() {
            std::fs::create_dir_all(parent)
                .with_context(|| format!("--split {spec}: cannot write {}", parent.display()))?;
        }
        std::fs::write(&out, text)
            .with_context(|| format!("--split {spec}: cannot write {}", out.display()))?;
        files += 1;
    }
    if files == 0 {
        anyhow::bail!(
            "--split {spec}: the revision has no `{path}` directory (the scripts directory in the \
             repository {})",
            top.display()
        );
    }
    let short = git(spec, &top, &["rev-parse", "--short", &commit])?;
    Ok(SplitSource {
        label: format!("git:{rev} ({})", String::from_utf8_lossy(&short).trim()),
        scripts: temp.path().to_path_buf(),
        _temp: Some(temp),
    })
}

/// Runs `git -C dir args…` and returns its stdout; an error names `--split SPEC` and says what
/// git said (or that git cannot be run).
fn git(spec: &str, dir: &Path, args: &[&str]) -> anyhow::Result<Vec<u8>> {
    let out = std::process::Command::new("git")
        .arg("-C")
        .arg(dir)
        .args(args)
        .output()
        .map_err(|e| {
            anyhow::anyhow!(
                "--split {spec}: cannot run git ({e}); install git, or pass a scripts directory \
                 instead"
            )
        })?;
    if !out.status.success() {
        let said = String::from_utf8_lossy(&out.stderr);
        let said = said.trim();
        anyhow::bail!(
            "--split {spec}: git {} failed{}",
            args.first().copied().unwrap_or_default(),
            if said.is_empty() {
                String::new()
            } else {
                format!(" ({said})")
            }
        );
    }
    Ok(out.stdout)
}

/// `shoal run --split B`: A (the usual scripts) and B side by side.
fn run_split(args: &Args, source: &super::ScriptSource, spec: &str) -> anyhow::Result<ExitCode> {
    if args.fish.is_some() {
        anyhow::bail!(
            "--fish applies to `--scene porgies`; a split tank runs a Lua scene, which sets its \
             own fish"
        );
    }
    if args.scene.as_deref() == Some(Path::new("porgies")) {
        anyhow::bail!(
            "--split compares two versions of the scripts, and the `porgies` scene has none: \
             pass a Lua scene (--scene NAME)"
        );
    }
    let scene = super::timeline::scene_in(&source.scripts, args.scene.as_deref())?;
    let b = split_source(spec, &source.scripts)?;
    if !b.scripts.join(&scene).is_file() {
        anyhow::bail!(
            "--split {spec}: B ({}) has no {scene} (the scene is named relative to each scripts \
             directory)",
            b.label
        );
    }
    let seed = args.seed.unwrap_or(1);
    let load = |scripts: &Path, which: &str| -> anyhow::Result<Simulation> {
        Simulation::from_scene_with_scripts(&source.root, scripts, &scripts.join(&scene), seed)
            .with_context(|| format!("loading scene `{scene}` of {which}"))
    };
    let a_sim = load(&source.scripts, "A")?;
    let mut b_sim = load(&b.scripts, &format!("B ({})", b.label))?;
    b_sim.set_lanes(a_sim.num_lanes())?;
    let select = super::render::check_select(args.select, a_sim.world())?;
    let versions = SplitVersions {
        a: source.scripts.display().to_string(),
        b: b.label.clone(),
        dirs: Some((source.scripts.clone(), b.scripts.clone())),
    };
    println!(
        "split tank: A = {}, B = {}; {scene}, seed {seed}, {} lanes",
        versions.a,
        versions.b,
        a_sim.num_lanes()
    );
    let options = options(args, select);
    let aq = Aquarium::new_split(Box::new(a_sim), Box::new(b_sim), versions, options)?;
    let changed = aq.split_changed_files();
    if changed.is_empty() {
        println!("no script file differs between A and B");
    } else {
        println!("files that differ: {}", changed.join(", "));
    }
    let presented = run_aquarium(aq, options)?;
    println!("presented {presented} frames");
    Ok(ExitCode::SUCCESS)
}
