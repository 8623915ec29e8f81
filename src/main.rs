//! The `shoal` command line. Errors reach the user through `anyhow` here and nowhere else.

use clap::Parser;

mod cli;

fn main() -> std::process::ExitCode {
    let cli = crate::cli::Cli::parse();
    env_logger::Builder::from_env(
        env_logger::Env::default().default_filter_or(cli.default_log_filter()),
    )
    .format_timestamp(None)
    .init();
    match crate::cli::run(cli) {
        Ok(code) => code,
        Err(err) => {
            eprintln!("error: {}", crate::cli::error_chain(&err));
            std::process::ExitCode::FAILURE
        }
    }
}
