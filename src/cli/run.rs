//! `shoal run` (placeholder until its issue lands).

use std::process::ExitCode;

/// Arguments of `shoal run`.
#[derive(Debug, Default, clap::Args)]
pub struct Args {}

/// Runs `shoal run`.
pub fn run(_args: Args) -> anyhow::Result<ExitCode> {
    anyhow::bail!("`shoal run` is not built yet")
}
