//! `shoal run`: the aquarium window with the tuning panel.

use std::path::PathBuf;
use std::process::ExitCode;

use crate::render::app::{AppOptions, run_window};
use crate::render::{DemoScene, DemoSceneConfig, OverlayToggles};

/// Arguments of `shoal run`.
#[derive(Debug, Default, clap::Args)]
pub struct Args {
    /// Scene file (JSON: fish, seed, tank, camera, caustics). Default: the built-in aquarium.
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Draw this many frames, then exit (for tests and scripted runs).
    #[arg(long)]
    pub frames: Option<u64>,
    /// Number of fish (overrides the scene's).
    #[arg(long)]
    pub fish: Option<usize>,
    /// Select (and follow) this fish at start.
    #[arg(long)]
    pub select: Option<usize>,
    /// Show every debug overlay at start.
    #[arg(long)]
    pub overlays: bool,
}

/// Runs `shoal run`.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let mut config = match &args.scene {
        Some(path) => DemoSceneConfig::load(path).map_err(anyhow::Error::msg)?,
        None => DemoSceneConfig::default(),
    };
    if let Some(n) = args.fish {
        config.fish = n;
    }
    config.validate().map_err(anyhow::Error::msg)?;
    let scene = Box::new(DemoScene::new(config));
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
