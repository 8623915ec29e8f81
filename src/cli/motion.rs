//! `shoal motion` (placeholder until its issue lands).

use std::process::ExitCode;

/// Arguments of `shoal motion`.
#[derive(Debug, Default, clap::Args)]
pub struct Args {}

/// Runs `shoal motion`.
pub fn run(_args: Args) -> anyhow::Result<ExitCode> {
    anyhow::bail!("`shoal motion` is not built yet")
}
