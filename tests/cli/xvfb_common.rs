//! A virtual X server (Xvfb) for the tests that open shoal's real window.
#![allow(dead_code)]

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

const XVFB: &str = "/usr/bin/Xvfb";

/// Kills the Xvfb it owns when dropped.
pub struct Xvfb {
    child: Child,
    /// The X display number it serves (`DISPLAY=:N`).
    pub display: u32,
}

impl Drop for Xvfb {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// Starts Xvfb (1600×1000: room for shoal's window at its preferred 1280×760) on a display
/// number no other server holds, searched in `displays` (offset by the process id; each test
/// binary searches its own range, so parallel runs do not pick the same free number at once),
/// and waits for its socket.
pub fn start(displays: std::ops::Range<u32>) -> Xvfb {
    start_sized(displays, 1600, 1000)
}

/// [`start`] with a screen of `width`×`height` pixels.
pub fn start_sized(displays: std::ops::Range<u32>, width: u32, height: u32) -> Xvfb {
    assert!(
        Path::new(XVFB).exists(),
        "{XVFB} is missing: install it (Debian: apt install xvfb) — CI installs it in .ci/run"
    );
    let display = displays
        .map(|n| n + std::process::id() % 200)
        .find(|n| {
            !Path::new(&format!("/tmp/.X{n}-lock")).exists()
                && !Path::new(&format!("/tmp/.X11-unix/X{n}")).exists()
        })
        .expect("a free X display number");
    let child = Command::new(XVFB)
        .arg(format!(":{display}"))
        .args([
            "-screen",
            "0",
            &format!("{width}x{height}x24"),
            "-nolisten",
            "tcp",
        ])
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
