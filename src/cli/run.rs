//! `shoal run`: the aquarium window with the tuning panel.

use std::path::PathBuf;
use std::process::ExitCode;

use crate::render::OverlayToggles;
use crate::render::app::{AppOptions, run_window};

/// Arguments of `shoal run`.
#[derive(Debug, Default, clap::Args)]
pub struct Args {
    /// Scene: a Lua scene (`scripts/scenes/*.lua`), `porgies` (black porgies from
    /// `assets/black_porgy.glb`, built-in wander/school behaviour), `demo` (procedural fish) or a
    /// demo JSON file. Default: `scripts/scenes/default.lua`, else `porgies`, else `demo`.
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Random seed of the scene.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Draw this many frames, then exit (for tests and scripted runs).
    #[arg(long)]
    pub frames: Option<u64>,
    /// Number of fish (`porgies` and `demo` scenes; a Lua scene sets its own).
    #[arg(long)]
    pub fish: Option<usize>,
    /// Select (and follow) this fish at start.
    #[arg(long)]
    pub select: Option<usize>,
    /// Show every debug overlay at start.
    #[arg(long)]
    pub overlays: bool,
    #[command(flatten)]
    pub scripts: super::ScriptsArg,
}

/// Runs `shoal run`.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let source = args.scripts.resolve()?;
    println!("{source}");
    let scene = super::render::load_scene(&source, args.scene.as_deref(), args.seed, args.fish)?;
    super::render::check_select(args.select, scene.num_fish())?;
    let all = args.overlays;
    let options = AppOptions {
        frames: args.frames,
        select: args.select,
        overlays: OverlayToggles {
            skeleton: all,
            midline: all,
            velocity: all,
            sensors: all,
        },
    };
    let presented = run_window(scene, options)?;
    println!("presented {presented} frames");
    Ok(ExitCode::SUCCESS)
}
