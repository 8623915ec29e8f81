//! The `shoal` command line. Errors reach the user through `anyhow` here and nowhere else.

use clap::Parser;

fn main() -> std::process::ExitCode {
    env_logger::Builder::from_env(env_logger::Env::default().default_filter_or("info"))
        .format_timestamp(None)
        .init();
    let cli = shoal::cli::Cli::parse();
    match shoal::cli::run(cli) {
        Ok(code) => code,
        Err(err) => {
            eprintln!("error: {}", shoal::cli::error_chain(&err));
            std::process::ExitCode::FAILURE
        }
    }
}
