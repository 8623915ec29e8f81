//! `shoal plot` (placeholder until its issue lands).

use std::process::ExitCode;

/// Arguments of `shoal plot`.
#[derive(Debug, Default, clap::Args)]
pub struct Args {}

/// Runs `shoal plot`.
pub fn run(_args: Args) -> anyhow::Result<ExitCode> {
    anyhow::bail!("`shoal plot` is not built yet")
}
