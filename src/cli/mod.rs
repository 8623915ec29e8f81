//! Command-line interface: one file per subcommand, each with its `Args` and a `run`.

use std::process::ExitCode;

use clap::{Parser, Subcommand};

pub mod asset;
pub mod bench;
pub mod kinematics;
pub mod motion;
pub mod plot;
pub mod render;
pub mod run;
pub mod skin;
pub mod test;

/// shoal: script artificial fish in Lua and watch them swim.
#[derive(Debug, Parser)]
#[command(name = "shoal", version, about, long_about = None)]
pub struct Cli {
    #[command(subcommand)]
    pub command: Option<Command>,
}

/// Every subcommand. With none, `shoal` runs the aquarium (`shoal run`).
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Open the aquarium window with the tuning panel.
    Run(run::Args),
    /// Render a scene headless to a PNG, a GIF or a directory of frames.
    Render(render::Args),
    /// Print a sampled motion (Table 1 presets) as JSON or CSV.
    Motion(motion::Args),
    /// Plot a motion preset's body midlines (Fig. 4, 6-9 of the paper).
    Plot(plot::Args),
    /// Measure steady swimming as biologists do (frequency, envelope, wavelength, St).
    Kinematics(kinematics::Args),
    /// Skin a glTF model in a pose and write the skinned positions.
    Skin(skin::Args),
    /// Build assets: the generated black porgy and eel, or rig a static mesh.
    Asset(asset::Args),
    /// Run Lua behaviour tests headless.
    Test(test::Args),
    /// Benchmarks: simulation and rendering.
    Bench(bench::Args),
}

/// Runs the parsed command line and returns the process exit code.
pub fn run(cli: Cli) -> anyhow::Result<ExitCode> {
    match cli.command {
        None => run::run(run::Args::default()),
        Some(Command::Run(args)) => run::run(args),
        Some(Command::Render(args)) => render::run(args),
        Some(Command::Motion(args)) => motion::run(args),
        Some(Command::Plot(args)) => plot::run(args),
        Some(Command::Kinematics(args)) => kinematics::run(args),
        Some(Command::Skin(args)) => skin::run(args),
        Some(Command::Asset(args)) => asset::run(args),
        Some(Command::Test(args)) => test::run(args),
        Some(Command::Bench(args)) => bench::run(args),
    }
}
