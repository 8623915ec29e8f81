//! `shoal test` (placeholder until its issue lands).

use std::process::ExitCode;

/// Arguments of `shoal test`.
#[derive(Debug, Default, clap::Args)]
pub struct Args {}

/// Runs `shoal test`.
pub fn run(_args: Args) -> anyhow::Result<ExitCode> {
    anyhow::bail!("`shoal test` is not built yet")
}
