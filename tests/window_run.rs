//! `shoal run` opens its window under a virtual X server (Xvfb), draws frames and exits cleanly
//! on request; without a display it says to use `shoal render`.

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

mod xvfb_common;

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
    let xvfb = xvfb_common::start(90..400);
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

/// The real window, clicked like a user: under Xvfb, `xdotool` moves the pointer onto the
/// panel's "quick turn left" button (the window prints where its buttons are with
/// `SHOAL_UI_TRACE`) and clicks. The click must reach the button — the console says the quick
/// turn was requested for the selected fish — and must not reach the fish picker (which used to
/// take every release and deselect the fish).
#[test]
fn xdotool_click_on_a_motion_button_turns_the_selected_fish() {
    use std::io::{BufRead, BufReader};
    const XDOTOOL: &str = "/usr/bin/xdotool";
    assert!(
        Path::new(XDOTOOL).exists(),
        "{XDOTOOL} is missing: install it (Debian: apt install xdotool) — CI installs it in .ci/run"
    );
    let xvfb = xvfb_common::start(90..400);
    let display = format!(":{}", xvfb.display);
    let mut child = Command::new(env!("CARGO_BIN_EXE_shoal"))
        .args(["run", "--frames", "100000", "--select", "0"])
        .env("DISPLAY", &display)
        .env("SHOAL_UI_TRACE", "1")
        .env_remove("WAYLAND_DISPLAY")
        .stdout(Stdio::piped())
        .stderr(Stdio::null())
        .spawn()
        .expect("shoal runs");
    let stdout = child.stdout.take().unwrap();
    let (tx, rx) = std::sync::mpsc::channel::<String>();
    std::thread::spawn(move || {
        for line in BufReader::new(stdout).lines().map_while(Result::ok) {
            if tx.send(line).is_err() {
                break;
            }
        }
    });
    // Kills the window whatever happens below.
    struct Kill(Child);
    impl Drop for Kill {
        fn drop(&mut self) {
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }
    let _kill = Kill(child);
    let mut seen: Vec<String> = Vec::new();
    // The first line `pred` accepts within `limit`; every line read is kept in `seen`.
    let wait_for =
        |seen: &mut Vec<String>, pred: &dyn Fn(&str) -> bool, limit: Duration| -> Option<String> {
            let start = Instant::now();
            while start.elapsed() < limit {
                match rx.recv_timeout(Duration::from_millis(200)) {
                    Ok(line) => {
                        let hit = pred(&line);
                        seen.push(line.clone());
                        if hit {
                            return Some(line);
                        }
                    }
                    Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {}
                    Err(_) => break,
                }
            }
            None
        };
    const BUTTON: &str = "ui: button \"quick turn left\" at ";
    wait_for(
        &mut seen,
        &|l| l.starts_with(BUTTON),
        Duration::from_secs(180),
    )
    .unwrap_or_else(|| panic!("the window never drew the motion buttons:\n{seen:#?}"));
    // The panel settles its layout over the first frames; the window prints a button again
    // whenever it moves. Use where it is now.
    let _ = wait_for(&mut seen, &|_| false, Duration::from_secs(3));
    let button = seen
        .iter()
        .rev()
        .find(|l| l.starts_with(BUTTON))
        .cloned()
        .expect("the button line");
    let at = button
        .split(" at ")
        .nth(1)
        .and_then(|r| r.split(' ').next())
        .expect("x,y");
    let (x, y) = at.split_once(',').expect("x,y");
    // Let the window settle for a few frames, then click like a user.
    std::thread::sleep(Duration::from_millis(500));
    let xdotool = |args: &[&str]| {
        let status = Command::new(XDOTOOL)
            .args(args)
            .env("DISPLAY", &display)
            .status()
            .expect("xdotool runs");
        assert!(status.success(), "xdotool {args:?} failed: {status:?}");
    };
    // Move onto the button, let a few frames see the pointer there (as a hand would), click.
    xdotool(&["mousemove", x, y]);
    std::thread::sleep(Duration::from_millis(700));
    xdotool(&["click", "1"]);
    let before_click = seen.len();
    let requested = wait_for(
        &mut seen,
        &|l| l.contains("fish #0: quick turn left requested"),
        Duration::from_secs(60),
    );
    assert!(
        requested.is_some(),
        "the click did not reach the button:\n{seen:#?}"
    );
    // A few more frames: the release must not have reached the picker.
    let _ = wait_for(&mut seen, &|_| false, Duration::from_secs(2));
    assert!(
        !seen[before_click..]
            .iter()
            .any(|l| l.starts_with("selected: ")),
        "the panel click changed the selection:\n{seen:#?}"
    );
}
