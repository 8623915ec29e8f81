//! `shoal kinematics --midline`: real animals measured with the same code as shoal's fish, on
//! fishmechr's lamprey and zebrafish (tests/data/midline, CC BY 4.0, attribution in its
//! README.md). Each measure is checked against an independent analysis written here on the raw
//! file (a Fourier transform and zero crossings of the tail tip's sideways position, the
//! centroid's travel, the first frame's arc length) and against what fishmechr's documentation
//! says about the data.

use std::f64::consts::TAU;
use std::path::{Path, PathBuf};
use std::process::Command;

fn repo() -> &'static Path {
    shoal_core::source_root()
}

fn data(name: &str) -> PathBuf {
    repo().join("tests/data/midline").join(name)
}

fn shoal(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_shoal"))
        .args(args)
        .current_dir(repo())
        .output()
        .expect("run shoal")
}

fn json(args: &[&str]) -> serde_json::Value {
    let out = shoal(args);
    assert!(
        out.status.success(),
        "{args:?}: {}",
        String::from_utf8_lossy(&out.stderr)
    );
    serde_json::from_slice(&out.stdout).unwrap()
}

/// The raw file: times and, per frame, the points' (x, y).
fn raw(name: &str) -> (Vec<f64>, Vec<Vec<(f64, f64)>>) {
    let text = std::fs::read_to_string(data(name)).unwrap();
    let mut times: Vec<f64> = Vec::new();
    let mut frames: Vec<Vec<(f64, f64)>> = Vec::new();
    for line in text.lines().skip(1) {
        let v: Vec<f64> = line.split(',').map(|s| s.parse().unwrap()).collect();
        if times.last() != Some(&v[0]) {
            times.push(v[0]);
            frames.push(Vec::new());
        }
        frames.last_mut().unwrap().push((v[2], v[3]));
    }
    (times, frames)
}

/// `v` less its least-squares line over time.
fn detrend(v: &[f64]) -> Vec<f64> {
    let n = v.len() as f64;
    let mt = (n - 1.0) / 2.0;
    let mv = v.iter().sum::<f64>() / n;
    let (mut sxy, mut sxx) = (0.0, 0.0);
    for (k, y) in v.iter().enumerate() {
        sxy += (k as f64 - mt) * (y - mv);
        sxx += (k as f64 - mt).powi(2);
    }
    let b = sxy / sxx;
    v.iter()
        .enumerate()
        .map(|(k, y)| y - mv - b * (k as f64 - mt))
        .collect()
}

/// Complex Fourier coefficient of `v` (sampled at `rate`) at `f` Hz, Hann-windowed.
fn dft(v: &[f64], rate: f64, f: f64) -> (f64, f64) {
    let n = v.len() as f64;
    let (mut re, mut im) = (0.0, 0.0);
    for (k, y) in v.iter().enumerate() {
        let w = 0.5 - 0.5 * (TAU * k as f64 / (n - 1.0)).cos();
        let a = TAU * f * k as f64 / rate;
        re += w * y * a.cos();
        im -= w * y * a.sin();
    }
    (re, im)
}

/// The frequency (0.5–15 Hz, 0.01 Hz steps) with the largest Fourier amplitude.
fn fft_peak(v: &[f64], rate: f64) -> f64 {
    (50..=1500)
        .map(|i| i as f64 / 100.0)
        .max_by(|&a, &b| {
            let (ra, ia) = dft(v, rate, a);
            let (rb, ib) = dft(v, rate, b);
            (ra * ra + ia * ia).total_cmp(&(rb * rb + ib * ib))
        })
        .unwrap()
}

/// Upward zero crossings per second, over whole periods.
fn zero_crossing_hz(v: &[f64], rate: f64) -> f64 {
    let ups: Vec<f64> = v
        .windows(2)
        .enumerate()
        .filter(|(_, w)| w[0] < 0.0 && w[1] >= 0.0)
        .map(|(k, w)| k as f64 + w[0] / (w[0] - w[1]))
        .collect();
    (ups.len() - 1) as f64 * rate / (ups[ups.len() - 1] - ups[0])
}

/// An independent analysis of a file whose animal swims along the file's x axis: f from the
/// tail tip's y, body length from the first frame, the centroid's speed, and λ from the phase
/// of each point's y at f along the back half.
struct Independent {
    f_fft: f64,
    f_zero_crossings: f64,
    body_length: f64,
    speed: f64,
    wavelength: f64,
}

fn independent(name: &str) -> Independent {
    let (times, frames) = raw(name);
    let rate = (times.len() - 1) as f64 / (times[times.len() - 1] - times[0]);
    let n = frames[0].len();
    let arc = |f: &[(f64, f64)]| -> Vec<f64> {
        let mut s = vec![0.0];
        for w in f.windows(2) {
            s.push(s.last().unwrap() + (w[1].0 - w[0].0).hypot(w[1].1 - w[0].1));
        }
        s
    };
    let first = arc(&frames[0]);
    let body_length = first[n - 1];
    let tail = detrend(&frames.iter().map(|f| f[n - 1].1).collect::<Vec<_>>());
    let f_fft = fft_peak(&tail, rate);
    let f_zero_crossings = zero_crossing_hz(&tail, rate);
    let cx = |f: &Vec<(f64, f64)>| f.iter().map(|p| p.0).sum::<f64>() / n as f64;
    let speed = (cx(&frames[0]) - cx(&frames[frames.len() - 1])).abs()
        / (times[times.len() - 1] - times[0])
        / body_length;
    // Phase of each point's sideways motion at f, unwrapped from head to tail; slope over the
    // back half of the body (stations from the first frame).
    let mut phase: Vec<f64> = (0..n)
        .map(|i| {
            let y = detrend(&frames.iter().map(|f| f[i].1).collect::<Vec<_>>());
            let (re, im) = dft(&y, rate, f_fft);
            im.atan2(re)
        })
        .collect();
    for i in 1..n {
        while phase[i] - phase[i - 1] > std::f64::consts::PI {
            phase[i] -= TAU;
        }
        while phase[i] - phase[i - 1] < -std::f64::consts::PI {
            phase[i] += TAU;
        }
    }
    let pts: Vec<(f64, f64)> = (0..n)
        .map(|i| (first[i] / body_length, phase[i]))
        .filter(|p| p.0 >= 0.5)
        .collect();
    let m = pts.len() as f64;
    let mx = pts.iter().map(|p| p.0).sum::<f64>() / m;
    let my = pts.iter().map(|p| p.1).sum::<f64>() / m;
    let slope = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>()
        / pts.iter().map(|p| (p.0 - mx).powi(2)).sum::<f64>();
    Independent {
        f_fft,
        f_zero_crossings,
        body_length,
        speed,
        wavelength: TAU / slope.abs(),
    }
}

fn close(what: &str, ours: f64, theirs: f64, rel: f64) {
    eprintln!("{what}: ours {ours:.4}, independent {theirs:.4}");
    assert!(
        (ours - theirs).abs() <= rel * theirs.abs(),
        "{what}: ours {ours:.4}, independent {theirs:.4} (tolerance {:.0} %)",
        rel * 100.0
    );
}

fn envelope(j: &serde_json::Value) -> Vec<(f64, f64)> {
    j["envelope"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| (p["x"].as_f64().unwrap(), p["amplitude"].as_f64().unwrap()))
        .collect()
}

/// The sea lamprey: fishmechr's documentation (R/data.R, vignettes/fishmechr.Rmd) says 20
/// points head (1) to tail (20), 50 Hz ("sampfreq"), steady swimming, "the four cycles that are
/// present in this trial", and that body phase decreases along the body: a wave travelling
/// backwards. An anguilliform swimmer: the amplitude rises along the body and more than one
/// wave is on it.
#[test]
fn test_lamprey_midline_matches_documentation_and_independent_analysis() {
    let path = data("lamprey.csv");
    let j = json(&["kinematics", "--midline", path.to_str().unwrap(), "--json"]);
    let info = &j["info"];
    assert_eq!(info["points"], 20);
    assert_eq!(info["frames"], 78);
    assert!((info["rate_hz"].as_f64().unwrap() - 50.0).abs() < 1e-3);
    // At least the documentation's four whole cycles (the vignette's filter and cycle finder
    // may drop a partial one at an end that our crossings keep).
    let beats = j["num_beats"].as_u64().unwrap();
    assert!((4..=5).contains(&beats), "{beats} whole beats");
    let ind = independent("lamprey.csv");
    let f = j["tail_beat_hz"].as_f64().unwrap();
    close("f vs tail-tip Fourier peak", f, ind.f_fft, 0.08);
    close(
        "f vs tail-tip zero crossings",
        f,
        ind.f_zero_crossings,
        0.08,
    );
    close(
        "body length (mm)",
        info["body_length"].as_f64().unwrap(),
        ind.body_length,
        0.05,
    );
    close(
        "speed (L/s)",
        j["speed_body_lengths_per_s"].as_f64().unwrap(),
        ind.speed,
        0.1,
    );
    let wavelength = j["wavelength"].as_f64().unwrap();
    close("body wavelength (L)", wavelength, ind.wavelength, 0.15);
    // Swimming towards −x in the file.
    assert!(info["direction"][0].as_f64().unwrap() < -0.95);
    // Backward travelling wave, more than one on the body.
    assert!(wavelength.is_finite() && wavelength < 1.0, "{wavelength}");
    assert!(j["waves_on_body"].as_f64().unwrap() > 1.0);
    // The derived measures follow from the measured ones.
    let u = j["speed_body_lengths_per_s"].as_f64().unwrap();
    let a = j["tail_amplitude_peak_to_peak"].as_f64().unwrap();
    close(
        "stride U/f",
        j["stride_length"].as_f64().unwrap(),
        u / f,
        1e-3,
    );
    close(
        "St = fA/U",
        j["strouhal"].as_f64().unwrap(),
        f * a / u,
        1e-3,
    );
    close(
        "slip U/(fλ)",
        j["slip"].as_f64().unwrap(),
        u / (f * wavelength),
        1e-3,
    );
    // Amplitude rises along the back two thirds, largest at the tail.
    let e = envelope(&j);
    let at = |x: f64| {
        e.iter()
            .min_by(|p, q| (p.0 - x).abs().total_cmp(&(q.0 - x).abs()))
            .unwrap()
            .1
    };
    assert!(at(0.3) < at(0.6) && at(0.6) < at(1.0), "{e:?}");
    assert!(e.iter().all(|p| p.1 <= at(1.0)), "{e:?}");
}

/// The zebrafish holds station in a flow tank: without a flow speed it is refused with a hint;
/// with one, f and λ match the independent analysis, and the envelope is carangiform: small in
/// front (smallest in the front half), largest at the tail.
#[test]
fn test_zebrafish_midline_in_a_flow_tank() {
    let path = data("zebrafish_060rpm.csv");
    let p = path.to_str().unwrap();
    let out = shoal(&["kinematics", "--midline", p]);
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("zebrafish_060rpm.csv") && err.contains("--flow-speed"),
        "{err}"
    );
    let j = json(&["kinematics", "--midline", p, "--flow-speed", "2", "--json"]);
    assert_eq!(j["info"]["points"], 6);
    let ind = independent("zebrafish_060rpm.csv");
    let f = j["tail_beat_hz"].as_f64().unwrap();
    close("f vs tail-tip Fourier peak", f, ind.f_fft, 0.08);
    close(
        "f vs tail-tip zero crossings",
        f,
        ind.f_zero_crossings,
        0.08,
    );
    close(
        "body wavelength (L)",
        j["wavelength"].as_f64().unwrap(),
        ind.wavelength,
        0.15,
    );
    // The flow speed plus its small drift through the frame.
    let u = j["speed_body_lengths_per_s"].as_f64().unwrap();
    assert!((u - 2.0).abs() < 0.3, "{u}");
    let e = envelope(&j);
    let tail = e.last().unwrap().1;
    assert!(j["min_amplitude_x"].as_f64().unwrap() < 0.5);
    assert!(e.iter().all(|p| p.1 <= tail), "{e:?}");
    let smallest = e.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
    assert!(tail > 3.0 * smallest, "{e:?}");
}

/// `--compare-species` measures the species at the animal's speed; `--plot` draws both.
#[test]
fn test_midline_compare_species_and_plot() {
    let dir = std::env::temp_dir().join(format!("shoal-midline-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let png = dir.join("lamprey.png");
    let path = data("lamprey.csv");
    let j = json(&[
        "kinematics",
        "--midline",
        path.to_str().unwrap(),
        "--compare-species",
        "eel",
        "--plot",
        png.to_str().unwrap(),
        "--json",
    ]);
    let theirs = &j["compare_species"];
    let u = j["speed_body_lengths_per_s"].as_f64().unwrap();
    let v = theirs["requested_speed_body_lengths_per_s"]
        .as_f64()
        .unwrap();
    assert!((u - v).abs() < 1e-4, "{u} vs {v}");
    assert!(theirs["envelope"].as_array().unwrap().len() == 21);
    let img = image::open(&png).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (1400, 650));
    // The animal's curve (black) and the species' (red) are both in the left panel.
    let count = |pred: &dyn Fn(&image::Rgb<u8>) -> bool| {
        (0..700)
            .flat_map(|x| (60..640).map(move |y| (x, y)))
            .filter(|&(x, y)| pred(img.get_pixel(x, y)))
            .count()
    };
    assert!(count(&|p| p.0.iter().all(|&c| c < 60)) > 500);
    assert!(count(&|p| p.0[0] > 180 && p.0[1] < 100 && p.0[2] < 80) > 300);
    std::fs::remove_dir_all(&dir).ok();
}

/// Bad files and arguments: one clear line each, naming the file and the line or column.
#[test]
fn test_midline_rejects_bad_files_clearly() {
    let dir = std::env::temp_dir().join(format!("shoal-midline-bad-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let good = std::fs::read_to_string(data("lamprey.csv")).unwrap();
    let lines: Vec<&str> = good.lines().collect();
    let write = |name: &str, text: String| {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    };
    let with_line = |i: usize, new: &str| {
        let mut l = lines.clone();
        l[i] = new;
        l.join("\n")
    };
    // Line 50 of the file is index 49.
    let nan_line = {
        let f: Vec<&str> = lines[49].split(',').collect();
        format!("{},{},{},NaN", f[0], f[1], f[2])
    };
    let swapped = {
        let mut l = lines.clone();
        l.swap(30, 31);
        l.join("\n")
    };
    let still: String = std::iter::once("t,point,x,y".to_owned())
        .chain((0..100).flat_map(|k| {
            (0..10).map(move |i| {
                format!(
                    "{},{},{},0",
                    k as f64 / 50.0,
                    i + 1,
                    -10.0 * i as f64 - 2.0 * k as f64
                )
            })
        }))
        .collect::<Vec<_>>()
        .join("\n");
    let cases = [
        (
            write("nocol.csv", with_line(0, "t,point,x,z")),
            vec!["nocol.csv", "line 1", "no column 'y'"],
        ),
        (
            write("oneframe.csv", lines[..21].join("\n")),
            vec!["oneframe.csv", "1 frame(s)"],
        ),
        (
            write("nan.csv", with_line(49, &nan_line)),
            vec![
                "nan.csv",
                "line 50, column y",
                "'NaN' is not a finite number",
            ],
        ),
        (
            write("order.csv", swapped),
            vec![
                "order.csv",
                "line 32, column point",
                "must increase from head to tail",
            ],
        ),
        (
            write("text.csv", with_line(5, "0.06,five,1,2")),
            vec![
                "text.csv",
                "line 6, column point",
                "'five' is not an integer",
            ],
        ),
        (
            write("still.csv", still),
            vec!["still.csv", "not beating its tail"],
        ),
        (
            write("empty.csv", "t,point,x,y\n".to_owned()),
            vec!["empty.csv", "no rows"],
        ),
        (dir.join("missing.csv"), vec!["missing.csv"]),
    ];
    for (path, needles) in cases {
        let out = shoal(&["kinematics", "--midline", path.to_str().unwrap()]);
        assert!(!out.status.success(), "{} succeeded", path.display());
        let err = String::from_utf8_lossy(&out.stderr);
        for needle in needles {
            assert!(
                err.contains(needle),
                "{}: {needle:?} not in {err}",
                path.display()
            );
        }
        assert_eq!(err.trim().lines().count(), 1, "{err}");
        assert!(!err.contains("panicked"), "{err}");
    }
    let lamprey = data("lamprey.csv");
    let l = lamprey.to_str().unwrap();
    for (args, needle) in [
        (
            vec!["--midline", l, "--flow-speed", "NaN"],
            "--flow-speed NaN",
        ),
        (
            vec!["--midline", l, "--flow-speed", "-1"],
            "--flow-speed -1",
        ),
        (vec!["--flow-speed", "1"], "--midline"),
        (
            vec!["--midline", l, "--species", "eel"],
            "cannot be used with",
        ),
        (
            vec!["--midline", l, "--compare-species", "shark"],
            "unknown species \"shark\"",
        ),
    ] {
        let mut full = vec!["kinematics"];
        full.extend(&args);
        let out = shoal(&full);
        assert!(!out.status.success(), "{args:?} succeeded");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(needle), "{args:?}: {err}");
    }
    std::fs::remove_dir_all(&dir).ok();
}
