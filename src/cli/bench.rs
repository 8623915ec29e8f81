//! `shoal bench` (placeholder until its issue lands).

use std::process::ExitCode;

/// Arguments of `shoal bench`.
#[derive(Debug, Default, clap::Args)]
pub struct Args {}

/// Runs `shoal bench`.
pub fn run(_args: Args) -> anyhow::Result<ExitCode> {
    anyhow::bail!("`shoal bench` is not built yet")
}
