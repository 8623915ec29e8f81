//! `shoal run` opens its window under a virtual X server (Xvfb), draws frames and exits cleanly
//! on request; without a display it says to use `shoal render`.

use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::{Duration, Instant};

use crate::xvfb_common;

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
    // MSAA by default: off on a software renderer (lavapipe, as in CI), 4× on a GPU.
    let software = stdout
        .lines()
        .any(|l| l.starts_with("adapter: ") && l.contains(", Cpu,"));
    let msaa = if software {
        "MSAA 1× (a software renderer"
    } else {
        "MSAA 4×"
    };
    assert!(
        stderr.contains(msaa),
        "expected {msaa:?}\nstdout:\n{stdout}\nstderr:\n{stderr}"
    );
}

/// `shoal` with `args` and no display at all.
fn without_display(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_shoal"))
        .args(args)
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .expect("shoal runs")
}

#[test]
fn shoal_run_refuses_an_msaa_count_it_does_not_draw_with() {
    let out = without_display(&["run", "--msaa", "2"]);
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(2), "{stderr}");
    assert!(
        stderr.contains("--msaa") && stderr.contains("1 (off) or 4"),
        "{stderr}"
    );
}

#[test]
fn shoal_run_without_a_display_points_to_shoal_render() {
    let out = without_display(&["run", "--frames", "1"]);
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(stderr.contains("shoal render"), "stderr:\n{stderr}");
}

/// `shoal run` under its own Xvfb with `SHOAL_UI_TRACE`, driven like a user with `xdotool`:
/// every line the window prints is kept, and the window is killed when this is dropped.
struct TracedWindow {
    child: Child,
    lines: std::sync::mpsc::Receiver<String>,
    /// Every line read so far.
    seen: Vec<String>,
    display: String,
    _xvfb: xvfb_common::Xvfb,
}

const XDOTOOL: &str = "/usr/bin/xdotool";

impl TracedWindow {
    fn start(args: &[&str]) -> Self {
        Self::start_on(args, (1600, 1000))
    }

    /// [`TracedWindow::start`] on a screen of `screen` pixels.
    fn start_on(args: &[&str], screen: (u32, u32)) -> Self {
        use std::io::{BufRead, BufReader};
        assert!(
            Path::new(XDOTOOL).exists(),
            "{XDOTOOL} is missing: install it (Debian: apt install xdotool) — CI installs it in .ci/run"
        );
        let xvfb = xvfb_common::start_sized(90..400, screen.0, screen.1);
        let display = format!(":{}", xvfb.display);
        let mut child = Command::new(env!("CARGO_BIN_EXE_shoal"))
            .args(args)
            .env("DISPLAY", &display)
            .env("SHOAL_UI_TRACE", "1")
            .env_remove("WAYLAND_DISPLAY")
            .stdout(Stdio::piped())
            .stderr(Stdio::null())
            .spawn()
            .expect("shoal runs");
        let stdout = child.stdout.take().unwrap();
        let (tx, lines) = std::sync::mpsc::channel::<String>();
        std::thread::spawn(move || {
            for line in BufReader::new(stdout).lines().map_while(Result::ok) {
                if tx.send(line).is_err() {
                    break;
                }
            }
        });
        Self {
            child,
            lines,
            seen: Vec::new(),
            display,
            _xvfb: xvfb,
        }
    }

    /// The first line `pred` accepts within `limit`, reading (and keeping) lines until then.
    fn wait_for(&mut self, pred: &dyn Fn(&str) -> bool, limit: Duration) -> Option<String> {
        let start = Instant::now();
        while start.elapsed() < limit {
            match self.lines.recv_timeout(Duration::from_millis(200)) {
                Ok(line) => {
                    let hit = pred(&line);
                    self.seen.push(line.clone());
                    if hit {
                        return Some(line);
                    }
                }
                Err(std::sync::mpsc::RecvTimeoutError::Timeout) => {}
                Err(_) => break,
            }
        }
        None
    }

    /// [`TracedWindow::wait_for`], also accepting a line read since `seen[from]` (the helpers
    /// below read on past the event they wait for, so what it caused may have been read).
    fn wait_since(
        &mut self,
        from: usize,
        pred: &dyn Fn(&str) -> bool,
        limit: Duration,
    ) -> Option<String> {
        match self.seen[from.min(self.seen.len())..]
            .iter()
            .find(|l| pred(l))
        {
            Some(line) => Some(line.clone()),
            None => self.wait_for(pred, limit),
        }
    }

    /// [`TracedWindow::wait_since`] that must find the line: panics with `failure` and every
    /// line seen when it does not come within `limit`.
    fn expect_since(
        &mut self,
        from: usize,
        pred: &dyn Fn(&str) -> bool,
        limit: Duration,
        failure: &str,
    ) -> String {
        self.wait_since(from, pred, limit)
            .unwrap_or_else(|| panic!("{failure}:\n{:#?}", self.seen))
    }

    /// Waits until the window has presented `n` more frames (it prints `ui: frame N` after each
    /// with `SHOAL_UI_TRACE`): time measured in frames, not seconds, so a slow renderer waits
    /// longer instead of letting the check pass before anything was drawn.
    fn frames(&mut self, n: usize) {
        // Lines already waiting are of frames before now.
        while let Ok(line) = self.lines.try_recv() {
            self.seen.push(line);
        }
        for k in 0..n {
            self.wait_for(&|l| l.starts_with("ui: frame "), Duration::from_secs(120))
                .unwrap_or_else(|| {
                    panic!(
                        "the window stopped presenting frames ({k} of {n}):\n{:#?}",
                        self.seen
                    )
                });
        }
    }

    /// Where the button `label` is now (screen pixels: the window sits at the origin), once
    /// the panel has drawn it and settled its layout.
    fn button(&mut self, label: &str) -> (String, String) {
        let prefix = format!("ui: button {label:?} at ");
        if !self.seen.iter().any(|l| l.starts_with(&prefix)) {
            self.wait_for(&|l| l.starts_with(&prefix), Duration::from_secs(180))
                .unwrap_or_else(|| panic!("the window never drew {label:?}:\n{:#?}", self.seen));
            // The panel settles its layout over the first frames; the window prints a button
            // again whenever it moves.
            self.frames(5);
        }
        let line = self
            .seen
            .iter()
            .rev()
            .find(|l| l.starts_with(&prefix))
            .cloned()
            .expect("the button line");
        let at = line
            .split(" at ")
            .nth(1)
            .and_then(|r| r.split(' ').next())
            .expect("x,y");
        let (x, y) = at.split_once(',').expect("x,y");
        (x.to_owned(), y.to_owned())
    }

    /// The window's latest `ui: 3D view WxH, panel from x=Some(L)` line.
    fn view_line(&self) -> String {
        self.seen
            .iter()
            .rev()
            .find(|l| l.starts_with("ui: 3D view "))
            .cloned()
            .unwrap_or_else(|| {
                panic!(
                    "the window never said how big its view is:\n{:#?}",
                    self.seen
                )
            })
    }

    fn xdotool(&self, args: &[&str]) {
        let status = Command::new(XDOTOOL)
            .args(args)
            .env("DISPLAY", &self.display)
            .status()
            .expect("xdotool runs");
        assert!(status.success(), "xdotool {args:?} failed: {status:?}");
    }

    /// Waits until the window has received a pointer event `pred` accepts (`ui: pointer …`,
    /// printed as the event arrives), then for `frames` frames drawn after it: under load the
    /// window can be several frames behind `xdotool`, and frames counted before the event
    /// arrived saw nothing of it.
    fn received(&mut self, what: &str, pred: &dyn Fn(&str) -> bool, frames: usize) {
        let failure = format!("the window never received {what}");
        self.expect_since(self.seen.len(), pred, Duration::from_secs(120), &failure);
        self.frames(frames);
    }

    /// Moves the pointer to `x`,`y` and waits until the window has seen it there for `frames`
    /// frames.
    fn pointer_to(&mut self, x: &str, y: &str, frames: usize) {
        let at = format!("ui: pointer at {x},{y}");
        let there = self
            .seen
            .iter()
            .rev()
            .find(|l| l.starts_with("ui: pointer at "))
            .is_some_and(|l| *l == at);
        self.xdotool(&["mousemove", x, y]);
        if there {
            // No move, no event.
            self.frames(frames);
        } else {
            self.received(&at, &|l| l == at, frames);
        }
    }

    /// `xdotool mousedown 1` / `mouseup 1` / `click 1`, waiting until the window has the press
    /// (and the release) and `frames` frames after it. Returns where in `seen` the lines after
    /// the action begin.
    fn button_1(&mut self, action: &str, frames: usize) -> usize {
        let mark = self.seen.len();
        self.xdotool(&[action, "1"]);
        let state = if action == "mousedown" {
            "Pressed"
        } else {
            "Released"
        };
        let line = format!("ui: pointer {state} Left");
        self.received(&line, &|l| l.starts_with(&line), frames);
        mark
    }

    /// `clicks` clicks of the wheel at the pointer, down or up, waiting until the window has had
    /// them all.
    fn scroll(&mut self, down: bool, clicks: usize) {
        let mark = self.seen.len();
        let repeat = clicks.to_string();
        let button = if down { "5" } else { "4" };
        self.xdotool(&["click", "--repeat", &repeat, "--delay", "50", button]);
        // (Under Xvfb winit gives two wheel events per click.)
        while self.seen[mark..]
            .iter()
            .filter(|l| *l == "ui: wheel")
            .count()
            < 2 * clicks
        {
            self.expect_since(
                self.seen.len(),
                &|l| l == "ui: wheel",
                Duration::from_secs(120),
                "the window never received the wheel",
            );
        }
        self.frames(10);
    }

    /// Whether a line `pred` accepts was read since `seen[from]` or comes within `n` more
    /// frames.
    fn within_frames(&mut self, from: usize, pred: &dyn Fn(&str) -> bool, n: usize) -> bool {
        let mut frames = 0;
        let mut k = from.min(self.seen.len());
        loop {
            while k < self.seen.len() {
                let line = &self.seen[k];
                if pred(line) {
                    return true;
                }
                frames += usize::from(line.starts_with("ui: frame "));
                k += 1;
            }
            if frames > n {
                return false;
            }
            self.wait_for(
                &|l| l.starts_with("ui: frame ") || pred(l),
                Duration::from_secs(120),
            )
            .unwrap_or_else(|| panic!("the window stopped presenting frames:\n{:#?}", self.seen));
        }
    }

    /// Moves onto the button `label`, lets a few frames see the pointer there (as a hand
    /// would), and clicks, until the window says the button took the click (`ui: clicked`,
    /// traced on the frame egui counts it). A panel that is still scrolling moves the button
    /// under the pointer: the pointer follows it until two looks agree. Returns where in
    /// `seen` the lines after the click that was taken begin.
    ///
    /// A click is tried again (at most twice) when the window did not take it: egui counts a
    /// press and a release in frames more than 0.8 s apart as no click, and a loaded CI machine
    /// has been seen to lose one that way. A button that takes no click at all still fails.
    fn click_button(&mut self, label: &str) -> usize {
        let taken = format!("ui: clicked {label:?}");
        for attempt in 1..=3 {
            let mut at = self.button(label);
            for _ in 0..10 {
                self.pointer_to(&at.0, &at.1, 3);
                let now = self.button(label);
                if now == at {
                    break;
                }
                at = now;
            }
            let mark = self.button_1("click", 1);
            if self.within_frames(mark, &|l| l == taken, 10) {
                return mark;
            }
            let slow: Vec<&String> = self.seen[mark.saturating_sub(40)..]
                .iter()
                .filter(|l| l.starts_with("ui: frame ") && l.contains(" after "))
                .collect();
            eprintln!(
                "click {attempt} on {label:?} at {},{} was not taken by the window \
                 (slow frames around it: {slow:?})",
                at.0, at.1
            );
        }
        panic!(
            "the window never took a click on {label:?} in 3 tries:\n{:#?}",
            self.seen
        )
    }
}

impl Drop for TracedWindow {
    fn drop(&mut self) {
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}

/// The real window, clicked like a user: under Xvfb, `xdotool` moves the pointer onto the
/// panel's "quick turn left" button (the window prints where its buttons are with
/// `SHOAL_UI_TRACE`) and clicks. The click must reach the button — the console says the quick
/// turn was requested for the selected fish — and must not reach the fish picker (which used to
/// take every release and deselect the fish).
#[test]
fn xdotool_click_on_a_motion_button_turns_the_selected_fish() {
    let mut w = TracedWindow::start(&["run", "--frames", "100000", "--select", "0"]);
    w.button("quick turn left");
    // Let the window settle for a few frames, then click like a user.
    w.frames(3);
    let before_click = w.click_button("quick turn left");
    let requested = w.wait_since(
        before_click,
        &|l| l.contains("fish #0: quick turn left requested"),
        Duration::from_secs(60),
    );
    assert!(
        requested.is_some(),
        "the click did not reach the button:\n{:#?}",
        w.seen
    );
    // A few more frames: the release must not have reached the picker.
    w.frames(5);
    assert!(
        !w.seen[before_click..]
            .iter()
            .any(|l| l.starts_with("selected: ")),
        "the panel click changed the selection:\n{:#?}",
        w.seen
    );
}

/// A click in the view right after the pointer leaves the panel, before the window draws
/// another frame, is the view's: it reaches the fish picker. The window used to ask egui
/// whether the pointer was over the panel, and egui answered from its last frame (pointer
/// still on the panel), so the click was dropped — on lavapipe's quarter-second frames, every
/// quick click after using the panel. The picker prints `selected: …` for every click it gets,
/// a hit or a miss (the camera's follow may not have settled on fish 0 under load), so the
/// line is the evidence that the click reached it.
#[test]
fn xdotool_quick_click_in_the_view_after_the_panel_reaches_the_picker() {
    // Fish 0 selected: pausing and clicking change nothing else that prints `selected: `.
    let mut w = TracedWindow::start(&["run", "--frames", "100000", "--select", "0"]);
    let clicked = w.click_button("pause");
    w.expect_since(
        clicked,
        &|l| l.starts_with("ui: button \"play\""),
        Duration::from_secs(60),
        "pause did not pause",
    );
    // The pointer rests on the panel for several frames, then moves into the view (x 640 is
    // left of the panel, which begins near 830) and clicks in one go.
    w.frames(5);
    let before_click = w.seen.len();
    w.xdotool(&["mousemove", "640", "380", "click", "1"]);
    let picked = w.wait_for(&|l| l.starts_with("selected: "), Duration::from_secs(60));
    assert!(
        picked.is_some(),
        "the quick click in the view did not reach the picker:\n{:#?}",
        &w.seen[before_click..]
    );
}

/// Feeding from the window: the panel's "drop food" button drops a pellet, and a shift+click in
/// the view drops one there instead of picking a fish (the window follows shift through winit's
/// modifier events, which X delivers to the focused window).
#[test]
fn xdotool_drop_food_button_and_shift_click_in_the_view() {
    let mut w = TracedWindow::start(&["run", "--frames", "100000"]);
    let clicked = w.click_button("drop food");
    w.expect_since(
        clicked,
        &|l| l.starts_with("console: food #") && l.contains(" dropped at "),
        Duration::from_secs(60),
        "the button dropped no food",
    );
    let window = Command::new(XDOTOOL)
        .args(["search", "--name", "shoal"])
        .env("DISPLAY", &w.display)
        .output()
        .expect("xdotool runs");
    let id = String::from_utf8_lossy(&window.stdout)
        .lines()
        .next()
        .expect("the window is found by its title")
        .to_owned();
    w.xdotool(&["windowfocus", &id]);
    // Onto the floor in front of the camera, then a click with shift held.
    w.pointer_to("300", "600", 3);
    let before = w.seen.len();
    w.xdotool(&["keydown", "shift"]);
    w.frames(2);
    w.xdotool(&["click", "1"]);
    w.frames(2);
    w.xdotool(&["keyup", "shift"]);
    let food = |l: &str| l.starts_with("console: food #") && l.contains(" dropped at ");
    // The frames waited for above may have read the line already.
    let dropped = w.seen[before..].iter().any(|l| food(l))
        || w.wait_for(&food, Duration::from_secs(60)).is_some();
    assert!(
        dropped,
        "the shift+click dropped no food:\n{:#?}",
        &w.seen[before..]
    );
    assert!(
        !w.seen[before..].iter().any(|l| l.starts_with("selected: ")),
        "the shift+click also picked:\n{:#?}",
        &w.seen[before..]
    );
}

/// The 3D view is drawn left of the panel, not under it: the window says how wide it draws the
/// view, and that is where the panel begins (so the camera looks at the middle of what is seen,
/// and a followed fish is there). A click in the middle of that view reaches the picker.
#[test]
fn the_3d_view_ends_where_the_panel_begins() {
    // (With --msaa 4, which the window then says it uses whatever the adapter.)
    let mut w = TracedWindow::start(&["run", "--frames", "100000", "--msaa", "4"]);
    // The panel settles its layout over the first frames: its buttons stop moving.
    w.button("pause");
    assert!(
        w.seen
            .iter()
            .any(|l| l.starts_with("console: ") && l.contains("MSAA 4× (--msaa)")),
        "the window did not draw with the MSAA asked for:\n{:#?}",
        w.seen
    );
    let line = w.view_line();
    // "ui: 3D view WxH, panel from x=Some(L)"
    let size = line["ui: 3D view ".len()..].split(',').next().unwrap();
    let (width, height) = size.split_once('x').expect("WxH");
    let width: u32 = width.parse().expect("width");
    assert_eq!(height, "760", "{line}");
    let panel_left: u32 = line
        .split("x=Some(")
        .nth(1)
        .and_then(|r| r.strip_suffix(')'))
        .and_then(|x| x.parse::<f32>().ok())
        .unwrap_or_else(|| panic!("no panel in {line:?}")) as u32;
    assert_eq!(width, panel_left, "{line}");
    assert!(width < 1280 && width > 400, "{line}");
    // A click in the middle of the view is the view's.
    let before_click = w.seen.len();
    let x = (width / 2).to_string();
    w.pointer_to(&x, "380", 3);
    w.xdotool(&["click", "1"]);
    assert!(
        w.wait_for(&|l| l.starts_with("selected: "), Duration::from_secs(60))
            .is_some(),
        "the click in the middle of the view did not reach the picker:\n{:#?}",
        &w.seen[before_click..]
    );
}

/// On a screen smaller than the window's preferred 1280×760 (here 1024×640) the window opens
/// inside it, so the panel on the right and the bottom of the view can be reached. It used to
/// open at 1280×760 whatever the screen, with half the panel off it.
#[test]
fn the_window_fits_a_small_screen() {
    let mut w = TracedWindow::start_on(&["run", "--frames", "100000"], (1024, 640));
    w.button("pause");
    let line = w.view_line();
    let window = Command::new(XDOTOOL)
        .args(["search", "--name", "shoal", "getwindowgeometry"])
        .env("DISPLAY", &w.display)
        .output()
        .expect("xdotool runs");
    let geometry = String::from_utf8_lossy(&window.stdout).into_owned();
    // "  Geometry: WxH"
    let (width, height) = geometry
        .lines()
        .find_map(|l| l.trim().strip_prefix("Geometry: "))
        .and_then(|g| g.split_once('x'))
        .and_then(|(w, h)| Some((w.parse::<u32>().ok()?, h.parse::<u32>().ok()?)))
        .unwrap_or_else(|| panic!("no geometry in {geometry:?}"));
    assert!(
        width <= 1024 && height <= 640 && width >= 900 && height >= 500,
        "a {width}×{height} window on a 1024×640 screen ({line})"
    );
    // The view ends where the panel begins, and the panel ends inside the screen.
    let view_height: u32 = line["ui: 3D view ".len()..]
        .split(',')
        .next()
        .and_then(|s| s.split_once('x'))
        .and_then(|(_, h)| h.parse().ok())
        .unwrap_or_else(|| panic!("no view size in {line:?}"));
    assert_eq!(view_height, height, "{line}");
    let (x, y) = w.button("pause");
    let (x, y): (f32, f32) = (x.parse().expect("x"), y.parse().expect("y"));
    assert!(
        x < width as f32 && y < height as f32,
        "the pause button at {x},{y}"
    );
}

/// The real window, tuned and saved like a user: `xdotool` drags the speed slider (the window
/// prints where it is with `SHOAL_UI_TRACE`) and clicks "save to species file"; the porgy's file
/// then has exactly one line more, the `motion` table with the speed the slider shows.
#[test]
fn xdotool_drag_the_speed_slider_and_save_it_to_the_species_file() {
    let dir = tempfile::tempdir().unwrap();
    let scripts = dir.path().join("scripts");
    crate::common::copy_dir(&shoal_core::source_root().join("scripts"), &scripts);
    let scene = scripts.join("scenes/few.lua");
    std::fs::write(
        &scene,
        "return {\n  tank = { min = {-400, 0, -250}, max = {400, 300, 250} },\n  fish = {\n    \
         { species = \"black_porgy\", count = 2, pos = {0, 150, 0}, heading = 0 },\n  },\n}\n",
    )
    .unwrap();
    let porgy = scripts.join("species/black_porgy.lua");
    let before = std::fs::read_to_string(&porgy).unwrap();
    let mut w = TracedWindow::start(&[
        "run",
        "--frames",
        "100000",
        "--scripts",
        scripts.to_str().unwrap(),
        "--scene",
        scene.to_str().unwrap(),
    ]);
    let label = "s (speed, units/s)";
    w.button(label);
    w.frames(3);
    // The traced line gives the slider's centre and size; its rail starts at the left edge.
    let line = w
        .seen
        .iter()
        .rev()
        .find(|l| l.starts_with(&format!("ui: button {label:?} at ")))
        .cloned()
        .unwrap();
    let (x, y) = w.button(label);
    let width: f32 = line
        .split(" size ")
        .nth(1)
        .and_then(|s| s.split('x').next())
        .and_then(|s| s.parse().ok())
        .expect("size");
    let left = x.parse::<f32>().unwrap() - width / 2.0;
    let (from, to) = (format!("{:.0}", left + 4.0), format!("{:.0}", left + 45.0));
    w.pointer_to(&from, &y, 2);
    w.button_1("mousedown", 2);
    w.pointer_to(&to, &y, 2);
    w.button_1("mouseup", 2);
    // The new button is below the fold of the 760-pixel window: scroll the panel down to it
    // (the window prints it again where it lands).
    let clicked = w.scroll_and_click("save to species file");
    w.expect_since(
        clicked,
        &|l| l.starts_with("console: ") && l.contains("black_porgy.lua: saved 1 value(s)"),
        Duration::from_secs(120),
        "the console never said the porgy was saved",
    );
    let mut after = before.clone();
    for _ in 0..200 {
        w.frames(1);
        after = std::fs::read_to_string(&porgy).unwrap();
        if after != before {
            break;
        }
    }
    let last = "(staggered over the 60 Hz tick)\n";
    let (head, tail) = after.split_at(after.find(last).expect("the last field") + last.len());
    let inserted = tail
        .strip_suffix("}\nreturn species\n")
        .expect("the end of the file");
    assert_eq!(
        format!("{head}}}\nreturn species\n"),
        before,
        "nothing else changed"
    );
    let s: f32 = inserted
        .strip_prefix("  motion = { s = ")
        .and_then(|r| r.strip_suffix(" },\n"))
        .and_then(|v| v.parse().ok())
        .unwrap_or_else(|| panic!("one motion line: {inserted:?}"));
    assert!(s > 0.0 && s < 200.0 && s != 50.0, "the dragged speed {s}");
}

impl TracedWindow {
    /// Scrolls the panel until the button `label` is inside the window (off it, above or below,
    /// it is drawn, and traced, outside it), then clicks it. A few wheel clicks at a time, and
    /// back up if they overshoot: under load the window can take a burst of wheel events as
    /// one long scroll, and once carried a button from below the fold past the top.
    fn scroll_and_click(&mut self, label: &str) -> usize {
        for _ in 0..24 {
            let (x, y) = self.button(label);
            // `ui: 3D view WxH, …`: the window's height.
            let height: f32 = self
                .view_line()
                .split_once('x')
                .and_then(|(_, r)| r.split(',').next())
                .and_then(|h| h.parse().ok())
                .expect("the view's height");
            let y = y.parse::<f32>().unwrap_or(f32::MAX);
            let (below, above) = (y >= height - 30.0, y < 30.0);
            if !(below || above) {
                break;
            }
            self.pointer_to(&x, "400", 2);
            self.scroll(below, 3);
        }
        self.click_button(label)
    }
}

/// The real window, used like a designer would: "edit scene in the view", press on the rock in
/// the view, drag it with the mouse, "save to scene file". The scene file then holds the rock's
/// new position, and nothing else of it changed (its comments included).
#[test]
fn xdotool_drag_a_rock_in_the_view_and_save_it_to_the_scene_file() {
    let dir = tempfile::tempdir().unwrap();
    let scripts = dir.path().join("scripts");
    crate::common::copy_dir(&shoal_core::source_root().join("scripts"), &scripts);
    let scene = scripts.join("scenes/rocks.lua");
    let rock_line = "    { pos = { 100, 40, 0 }, radius = 40 },  -- the rock to move\n";
    let before = format!(
        "-- One porgy and a rock to move.\nreturn {{\n  tank = {{ min = {{-400, 0, -250}}, max = {{400, 300, 250}} }},\n  \
         fish = {{\n    {{ species = \"black_porgy\", count = 1, pos = {{0, 150, 0}}, heading = 0 }},\n  }},\n  \
         obstacles = {{\n{rock_line}  }},\n}}\n"
    );
    std::fs::write(&scene, &before).unwrap();
    let mut w = TracedWindow::start(&[
        "run",
        "--frames",
        "100000",
        "--scripts",
        scripts.to_str().unwrap(),
        "--scene",
        scene.to_str().unwrap(),
    ]);
    let clicked = w.scroll_and_click("edit scene in the view");
    let line = w.expect_since(
        clicked,
        &|l| l.starts_with("ui: rock 1 at "),
        Duration::from_secs(120),
        "the window never said where the rock is",
    );
    let (x, y) = line["ui: rock 1 at ".len()..]
        .split_once(',')
        .map(|(x, y)| (x.parse::<i32>().unwrap(), y.parse::<i32>().unwrap()))
        .unwrap();
    w.pointer_to(&x.to_string(), &y.to_string(), 2);
    let pressed = w.button_1("mousedown", 2);
    for k in 1..=6 {
        let (tx, ty) = (x - 15 * k, y + 5 * k);
        w.pointer_to(&tx.to_string(), &ty.to_string(), 1);
    }
    w.button_1("mouseup", 3);
    // The window prints the rock again wherever the drag takes it.
    w.expect_since(
        pressed,
        &|l| l.starts_with("ui: rock 1 at ") && *l != line,
        Duration::from_secs(120),
        "the rock never moved in the view",
    );
    let clicked = w.scroll_and_click("save to scene file");
    w.expect_since(
        clicked,
        &|l| l.starts_with("console: ") && l.contains("rocks.lua: saved 1 scene value(s)"),
        Duration::from_secs(120),
        "the console never said the scene was saved",
    );
    let mut after = before.clone();
    for _ in 0..200 {
        w.frames(1);
        after = std::fs::read_to_string(&scene).unwrap();
        if after != before {
            break;
        }
    }
    let (head, rest) = before.split_once(rock_line).unwrap();
    let new_line = after
        .strip_prefix(head)
        .and_then(|a| a.strip_suffix(rest))
        .unwrap_or_else(|| panic!("only the rock's line changed:\n{after}"));
    let pos = new_line
        .strip_prefix("    { pos = { ")
        .and_then(|l| l.strip_suffix(" }, radius = 40 },  -- the rock to move\n"))
        .unwrap_or_else(|| panic!("the rock's line: {new_line:?}"));
    let xyz: Vec<f32> = pos.split(", ").map(|v| v.parse().unwrap()).collect();
    assert_eq!(xyz.len(), 3, "{pos}");
    assert_eq!(xyz[1], 40.0, "it moved over the plane at its height");
    assert!(
        (xyz[0] - 100.0).abs() + xyz[2].abs() > 20.0,
        "the rock moved with the mouse: {pos}"
    );
}
