//! `shoal check [PATHS]`: runs the Lua type checker ([`shoal_script::check`]) and prints its
//! diagnostics.

use std::path::PathBuf;
use std::process::ExitCode;

use shoal_script::check::{
    CHECKER, CHECKER_VERSION, CONFIG_FILE, CheckError, Severity, check, checker_version,
    find_config, find_on_path, plan,
};

/// Exit code when the checker is missing (1 is "diagnostics found").
const EXIT_NOT_INSTALLED: u8 = 2;

/// Arguments of `shoal check`.
#[derive(Debug, Default, clap::Args)]
#[command(after_help = format!(
    "Runs {CHECKER} (install it with `cargo install --locked {CHECKER}@{CHECKER_VERSION}`) over \
     the given Lua files and directories with the shipped config ({CONFIG_FILE} beside the \
     scripts directory, else shoal's source tree's; the definitions are the scripts' \
     types/shoal.lua and shoal_test.lua) and prints each diagnostic in those paths as \
     `file:line:column: severity: message [code]`. Errors, warnings and hints (an unused local: \
     name it `_x`) all count.\n\n\
     Exit status: 0 when there is no diagnostic, 1 when there are any (or a path does not \
     exist), 2 when {CHECKER} is not installed."
))]
pub struct Args {
    /// Lua files or directories to check (default: the scripts directory and the tests/behavior/
    /// beside it).
    pub paths: Vec<PathBuf>,
    /// Where the scripts come from (`--scripts DIR`, `SHOAL_SCRIPTS`).
    #[command(flatten)]
    pub scripts: super::ScriptsArg,
}

/// Runs `shoal check`.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let source = args.scripts.resolve()?;
    println!("{source}");
    let Some(checker) = find_on_path(CHECKER, std::env::var_os("PATH")) else {
        eprintln!("error: {}", CheckError::NotInstalled);
        return Ok(ExitCode::from(EXIT_NOT_INSTALLED));
    };
    match checker_version(&checker) {
        Some(v) if v == CHECKER_VERSION => {}
        found => eprintln!(
            "note: {} is version {}; the shipped scripts are checked with {CHECKER_VERSION} \
             (cargo install --locked {CHECKER}@{CHECKER_VERSION}), other versions may report \
             differently",
            checker.display(),
            found.as_deref().unwrap_or("unknown")
        ),
    }
    let config = find_config(&source.scripts)?;
    let plan = plan(&args.paths, &source.scripts, checker, config)?;
    let cwd = std::env::current_dir().unwrap_or_else(|_| ".".into());
    let diagnostics = check(&plan, &cwd)?;
    for d in &diagnostics {
        println!("{d}");
    }
    let count = |s: Severity| diagnostics.iter().filter(|d| d.severity == s).count();
    let files = {
        let mut f: Vec<_> = diagnostics.iter().map(|d| &d.path).collect();
        f.dedup();
        f.len()
    };
    if diagnostics.is_empty() {
        println!(
            "check: no diagnostics ({CHECKER}, config {})",
            plan.config.display()
        );
        Ok(ExitCode::SUCCESS)
    } else {
        let n = |k: usize, what: &str| format!("{k} {what}{}", if k == 1 { "" } else { "s" });
        let (errors, warnings) = (count(Severity::Error), count(Severity::Warning));
        println!(
            "check: {} in {} ({}, {}, {} other)",
            n(diagnostics.len(), "diagnostic"),
            n(files, "file"),
            n(errors, "error"),
            n(warnings, "warning"),
            diagnostics.len() - errors - warnings
        );
        Ok(ExitCode::FAILURE)
    }
}
