//! `shoal asset` (placeholder until its issue lands).

use std::process::ExitCode;

/// Arguments of `shoal asset`.
#[derive(Debug, Default, clap::Args)]
pub struct Args {}

/// Runs `shoal asset`.
pub fn run(_args: Args) -> anyhow::Result<ExitCode> {
    anyhow::bail!("`shoal asset` is not built yet")
}
