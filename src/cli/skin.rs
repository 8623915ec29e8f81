//! `shoal skin` (placeholder until its issue lands).

use std::process::ExitCode;

/// Arguments of `shoal skin`.
#[derive(Debug, Default, clap::Args)]
pub struct Args {}

/// Runs `shoal skin`.
pub fn run(_args: Args) -> anyhow::Result<ExitCode> {
    anyhow::bail!("`shoal skin` is not built yet")
}
