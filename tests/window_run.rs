//! `shoal run` opens its window under a virtual X server (Xvfb), draws frames and exits cleanly
//! on request; without a display it says to use `shoal render`.

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const XVFB: &str = "/usr/bin/Xvfb";

/// Kills the Xvfb it owns when dropped.
struct Xvfb {
    child: Child,
    display: u32,
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

fn start_xvfb() -> Xvfb {
    assert!(
        Path::new(XVFB).exists(),
        "{XVFB} is missing: install it (Debian: apt install xvfb) — CI installs it in .ci/run"
    );
    // A display number no other server (or parallel test run) holds.
    let display = (90..400)
        .map(|n| n + std::process::id() % 200)
        .find(|n| {
            !Path::new(&format!("/tmp/.X{n}-lock")).exists()
                && !Path::new(&format!("/tmp/.X11-unix/X{n}")).exists()
        })
        .expect("a free X display number");
    let child = Command::new(XVFB)
        .arg(format!(":{display}"))
        .args(["-screen", "0", "1280x800x24", "-nolisten", "tcp"])
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .expect("Xvfb starts");
    let xvfb = Xvfb { child, display };
    let socket = format!("/tmp/.X11-unix/X{display}");
    let start = Instant::now();
    while !Path::new(&socket).exists() {
        assert!(
            start.elapsed() < Duration::from_secs(20),
            "Xvfb :{display} did not come up"
        );
        std::thread::sleep(Duration::from_millis(50));
    }
    xvfb
}

/// Waits for `child` with a limit, killing it if it runs over.
fn wait_with_limit(mut child: Child, limit: Duration) -> std::process::Output {
    let start = Instant::now();
    loop {
        if child.try_wait().expect("wait").is_some() {
            return child.wait_with_output().expect("output");
        }
        if start.elapsed() > limit {
            let _ = child.kill();
            let out = child.wait_with_output().expect("output");
            panic!(
                "shoal run did not exit within {limit:?}\nstdout:\n{}\nstderr:\n{}",
                String::from_utf8_lossy(&out.stdout),
                String::from_utf8_lossy(&out.stderr)
            );
        }
        std::thread::sleep(Duration::from_millis(50));
    }
}

#[test]
fn shoal_run_presents_30_frames_under_xvfb_and_exits_cleanly() {
    let xvfb = start_xvfb();
    let child = Command::new(env!("CARGO_BIN_EXE_shoal"))
        .args(["run", "--frames", "30", "--select", "0", "--overlays"])
        .env("DISPLAY", format!(":{}", xvfb.display))
        .env_remove("WAYLAND_DISPLAY")
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("shoal runs");
    let out = wait_with_limit(child, Duration::from_secs(240));
    let stdout = String::from_utf8_lossy(&out.stdout);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        out.status.success(),
        "exit {:?}\nstdout:\n{stdout}\nstderr:\n{stderr}",
        out.status
    );
    let presented: u64 = stdout
        .lines()
        .find_map(|l| {
            l.strip_prefix("presented ")?
                .strip_suffix(" frames")?
                .parse()
                .ok()
        })
        .unwrap_or_else(|| panic!("no `presented N frames` line in stdout:\n{stdout}"));
    assert!(presented >= 30, "presented only {presented} frames");
    assert!(
        stdout.contains("adapter: "),
        "adapter not reported:\n{stdout}"
    );
}

#[test]
fn shoal_run_without_a_display_points_to_shoal_render() {
    let out = Command::new(env!("CARGO_BIN_EXE_shoal"))
        .args(["run", "--frames", "1"])
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .expect("shoal runs");
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("shoal render"), "stderr:\n{stderr}");
}
