//! `shoal render` (placeholder until its issue lands).

use std::process::ExitCode;

/// Arguments of `shoal render`.
#[derive(Debug, Default, clap::Args)]
pub struct Args {}

/// Runs `shoal render`.
pub fn run(_args: Args) -> anyhow::Result<ExitCode> {
    anyhow::bail!("`shoal render` is not built yet")
}
