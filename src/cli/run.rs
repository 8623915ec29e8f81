//! `shoal run`: the aquarium window with the tuning panel.

use std::path::PathBuf;
use std::process::ExitCode;

use crate::app::{AppOptions, OverlayToggles, SimView, run_window};

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
    /// Where the scripts come from (`--scripts DIR`, `SHOAL_SCRIPTS`).
    #[command(flatten)]
    pub scripts: super::ScriptsArg,
}

/// Runs `shoal run`.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let source = args.scripts.resolve()?;
    println!("{source}");
    let sim = super::render::load_scene(&source, args.scene.as_deref(), args.seed, args.fish)?;
    let select = super::render::check_select(args.select, sim.world())?;
    let options = AppOptions {
        frames: args.frames,
        select,
        overlays: if args.overlays {
            OverlayToggles::ALL
        } else {
            OverlayToggles::default()
        },
    };
    let presented = run_window(sim, options)?;
    println!("presented {presented} frames");
    Ok(ExitCode::SUCCESS)
}
