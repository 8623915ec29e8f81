//! The `shoal` command line. Errors reach the user through `anyhow` here and nowhere else.

use clap::Parser;

mod cli;

fn main() -> std::process::ExitCode {
    quiet_on_closed_pipe();
    let cli = crate::cli::Cli::parse();
    env_logger::Builder::from_env(
        env_logger::Env::default().default_filter_or(cli.default_log_filter()),
    )
    .format_timestamp(None)
    .init();
    match crate::cli::run(cli) {
        Ok(code) => code,
        Err(err) if crate::cli::is_closed_pipe(&err) => std::process::ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {}", crate::cli::error_chain(&err));
            std::process::ExitCode::FAILURE
        }
    }
}

/// Ends the process quietly (exit 0) when its reader went away: `shoal test | head -1` closes
/// the pipe after one line, and the next `println!` panics with "failed printing to stdout:
/// Broken pipe". Rust ignores SIGPIPE, so every command would otherwise end in that panic and a
/// backtrace. Catching it here, once, covers every command and every thread that prints; a
/// write that returns its error instead (`writeln!` into a locked stdout) reaches `main`'s
/// [`cli::is_closed_pipe`] check. Restoring the default SIGPIPE action would do the same without
/// a hook, but would also kill the window or the DAP server when a child's pipe closes.
fn quiet_on_closed_pipe() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let text = info
            .payload()
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| info.payload().downcast_ref::<&str>().copied())
            .unwrap_or("");
        if crate::cli::is_closed_pipe_panic(text) {
            std::process::exit(0);
        }
        default(info);
    }));
}
