//! `shoal run`: the aquarium window with the tuning panel.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;

use crate::app::{AppOptions, Aquarium, OverlayToggles, SimView, run_aquarium, run_window};
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
    /// Open a recording (`.shoalrun`, from `shoal record`, `replay`, or a failing behaviour
    /// test's `--trace`) at `--at`: its scene and seed, paused at that moment, with the
    /// recording's future as the ghost that playing on (with the current scripts) is compared
    /// with.
    #[arg(long, value_name = "RUN", conflicts_with_all = ["scene", "seed", "fish"])]
    pub open: Option<PathBuf>,
    /// With `--open`: the moment to open at, seconds into the recording (default: its start).
    #[arg(long, value_name = "T", requires = "open")]
    pub at: Option<f64>,
    /// Where the scripts come from (`--scripts DIR`, `SHOAL_SCRIPTS`).
    #[command(flatten)]
    pub scripts: super::ScriptsArg,
}

/// Runs `shoal run`.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let source = args.scripts.resolve()?;
    println!("{source}");
    if let Some(run) = &args.open {
        return open(&args, &source, run);
    }
    let sim = super::render::load_scene(&source, args.scene.as_deref(), args.seed, args.fish)?;
    let select = super::render::check_select(args.select, sim.world())?;
    let presented = run_window(sim, options(&args, select))?;
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
