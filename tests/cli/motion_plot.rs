//! `shoal plot` end to end: it writes a PNG of the requested size with both panels drawn, and
//! refuses bad input without panicking.

use std::process::Command;

fn shoal(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_shoal"))
        .args(args)
        .output()
        .expect("run shoal")
}

/// Counts pixels in columns [x0, x1) that are strongly coloured (the time-coloured bodies, not
/// the white background, grey grid, envelope or black text), split into bluish and reddish.
fn coloured(img: &image::RgbImage, x0: u32, x1: u32) -> (usize, usize) {
    let (mut blue, mut red) = (0, 0);
    for y in 0..img.height() {
        for x in x0..x1 {
            let [r, g, b] = img.get_pixel(x, y).0;
            let (r, g, b) = (i32::from(r), i32::from(g), i32::from(b));
            if b > r + 60 && b > g {
                blue += 1;
            }
            if r > b + 60 && r > g + 40 {
                red += 1;
            }
        }
    }
    (blue, red)
}

#[test]
fn test_plot_writes_both_panels() {
    let dir = tempfile::tempdir().unwrap();
    for preset in ["ex1", "ex3"] {
        let out = dir.path().join(format!("{preset}.png"));
        let result = shoal(&[
            "plot",
            "--preset",
            preset,
            "--out",
            out.to_str().unwrap(),
            "--width",
            "1000",
            "--height",
            "500",
        ]);
        assert!(
            result.status.success(),
            "{}",
            String::from_utf8_lossy(&result.stderr)
        );
        let img = image::open(&out).unwrap().to_rgb8();
        assert_eq!(img.dimensions(), (1000, 500));
        // Each panel holds early (blue) and late (red) bodies.
        for (x0, x1) in [(0, 500), (500, 1000)] {
            let (blue, red) = coloured(&img, x0, x1);
            assert!(
                blue > 300 && red > 300,
                "{preset} [{x0}, {x1}): {blue} blue, {red} red"
            );
        }
    }
}

#[test]
fn test_plot_bad_input_is_an_error() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("x.png");
    for (args, needle) in [
        (vec!["--preset", "ex0"], "unknown motion preset"),
        (vec!["--p", "0.05"], "p = 0.05"),
        (vec!["--width", "10"], "image size 10×700"),
    ] {
        let mut full = vec!["plot", "--out", out.to_str().unwrap()];
        full.extend(args.iter().copied());
        let result = shoal(&full);
        assert!(!result.status.success());
        let err = String::from_utf8_lossy(&result.stderr);
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(!err.contains("panicked"));
    }
    // An output path that cannot be written is an error too, not a panic.
    let result = shoal(&["plot", "--out", "/nonexistent-dir/x.png"]);
    assert!(!result.status.success());
    assert!(!String::from_utf8_lossy(&result.stderr).contains("panicked"));
}

/// Without a usable font the figure is still drawn, just without any text.
#[test]
fn test_plot_without_fonts_still_draws() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("plain.png");
    let preset = shoal_core::motion::Preset::by_name("ex4").unwrap();
    shoal_script::plot::motion::draw_figure(&preset, &out, (800, 400), false).unwrap();
    let img = image::open(&out).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (800, 400));
    for (x0, x1) in [(0, 400), (400, 800)] {
        let (blue, red) = coloured(&img, x0, x1);
        assert!(
            blue > 200 && red > 200,
            "[{x0}, {x1}): {blue} blue, {red} red"
        );
    }
    // No text: the title strip at the top stays white.
    for y in 0..6 {
        for x in 0..800 {
            assert_eq!(img.get_pixel(x, y).0, [255, 255, 255], "({x}, {y})");
        }
    }
}
