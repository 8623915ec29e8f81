//! `shoal motion` end to end: the JSON shape, the CSV, and errors that name the bad value.

use std::process::Command;

fn shoal(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_shoal"))
        .args(args)
        .output()
        .expect("run shoal")
}

#[test]
fn test_motion_json_shape_for_every_preset() {
    for preset in ["ex1", "ex2", "ex3", "ex4"] {
        let out = shoal(&[
            "motion",
            "--preset",
            preset,
            "--seconds",
            "4",
            "--rate",
            "60",
        ]);
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
        assert_eq!(json["preset"], preset);
        assert_eq!(json["rate_hz"], 60.0);
        let joints_x = json["joints_x"].as_array().unwrap();
        assert_eq!(joints_x.len(), 7);
        assert_eq!(joints_x[6], 1.0);
        let frames = json["frames"].as_array().unwrap();
        assert_eq!(frames.len(), 241);
        for frame in frames {
            assert_eq!(frame["lateral"].as_array().unwrap().len(), 7);
            assert_eq!(frame["yaw"].as_array().unwrap().len(), 6);
            let root = &frame["root"];
            assert_eq!(root["pos"].as_array().unwrap().len(), 3);
            for key in ["heading", "pitch", "speed"] {
                assert!(root[key].is_number(), "{preset}: root.{key}");
            }
            assert!(frame["t"].is_number() && frame["motion"].is_string());
        }
        let last = &frames[240];
        assert!((last["t"].as_f64().unwrap() - 4.0).abs() < 1e-4);
        // Every Table 1 turn is to the left (d = −1): heading rises towards +90°.
        if preset != "ex1" {
            let heading = frames
                .iter()
                .map(|f| f["root"]["heading"].as_f64().unwrap())
                .fold(f64::NEG_INFINITY, f64::max);
            assert!(heading > 1.3, "{preset}: heading reached only {heading}");
        }
    }
}

#[test]
fn test_motion_overrides_and_csv() {
    let out = shoal(&[
        "motion",
        "--preset",
        "ex3",
        "--d",
        "1",
        "--angle",
        "45",
        "--tt",
        "1",
        "--seconds",
        "2",
        "--rate",
        "30",
        "--format",
        "csv",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    assert!(text.contains("tt=1 "), "{text}");
    assert!(text.contains("d=1 turn=quick"));
    let rows: Vec<&str> = text.lines().filter(|l| !l.starts_with('#')).collect();
    assert_eq!(rows.len(), 1 + 61);
    assert!(rows[0].starts_with("t,motion,x,y,z,heading,pitch,speed,lateral_0"));
    // A 45° right turn in Tt = 1 s: after 2 s the heading is −π/4.
    let heading: f32 = rows[61].split(',').nth(5).unwrap().parse().unwrap();
    assert!((heading + std::f32::consts::FRAC_PI_4).abs() < 0.1 * std::f32::consts::FRAC_PI_4);
}

#[test]
fn test_motion_bad_input_names_the_value() {
    for (args, needle) in [
        (&["--preset", "ex7"][..], "unknown motion preset \"ex7\""),
        (&["--p", "0.1"][..], "p = 0.1"),
        (&["--s", "-1"][..], "s = -1: speed must not be negative"),
        (&["--s", "NaN"][..], "s = NaN"),
        (&["--d", "3"][..], "d = 3"),
        (&["--f", "0.5"][..], "f = 0.5"),
        (&["--seconds", "0"][..], "seconds = 0"),
    ] {
        let mut full = vec!["motion"];
        full.extend_from_slice(args);
        let out = shoal(&full);
        assert!(!out.status.success(), "{args:?} should fail");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
}

#[test]
fn test_motion_angle_is_checked_in_degrees_as_typed() {
    let out = shoal(&["motion", "--preset", "ex2", "--angle", "-90"]);
    assert!(!out.status.success());
    let stderr = String::from_utf8_lossy(&out.stderr);
    assert!(
        stderr.contains("--angle -90") && stderr.contains("degrees") && !stderr.contains("radian"),
        "{stderr}"
    );
}
