//! Every command ends quietly when its reader closes the pipe (`shoal test | head -1`):
//! exit 0, nothing on stderr, no panic and no backtrace (issue 36, finding 3).

use std::io::Read;
use std::process::{Command, Stdio};

/// Runs shoal with `args`, its stdout a pipe whose reading end is closed before shoal writes
/// anything, so its first line meets a closed pipe whatever the timing.
fn with_closed_stdout(args: &[&str]) -> (std::process::ExitStatus, String) {
    let mut child = Command::new(env!("CARGO_BIN_EXE_shoal"))
        .current_dir(shoal_core::source_root())
        .env_remove("RUST_LOG")
        .env("RUST_BACKTRACE", "1")
        .args(args)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    drop(child.stdout.take());
    let mut stderr = String::new();
    child
        .stderr
        .take()
        .unwrap()
        .read_to_string(&mut stderr)
        .unwrap();
    (child.wait().unwrap(), stderr)
}

#[test]
fn commands_end_quietly_on_a_closed_pipe() {
    for args in [
        &["test", "tests/behavior/motion_test.lua"][..],
        &[
            "motion",
            "--preset",
            "ex1",
            "--seconds",
            "1",
            "--format",
            "csv",
        ],
        &[
            "compare",
            "--a",
            "scripts",
            "--b",
            "scripts",
            "--seeds",
            "2",
            "--seconds",
            "1",
        ],
    ] {
        let (status, stderr) = with_closed_stdout(args);
        assert!(
            status.success(),
            "shoal {args:?}: {status}, stderr:\n{stderr}"
        );
        assert!(
            !stderr.contains("panicked") && !stderr.contains("Broken pipe"),
            "shoal {args:?}: stderr:\n{stderr}"
        );
    }
}
