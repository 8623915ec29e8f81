//! Every shipped species measured as biologists measure fish (`shoal kinematics`), against
//! published ranges. Sources, figures and how each quantity is defined: docs/motion.md,
//! "Kinematics against published data". Ranges, not points: published values differ between
//! species, individuals and studies.

use std::path::Path;
use std::process::Command;

use shoal_core::motion::kinematics::{
    LAMPREY, Measurement, Mode, Subject, measure, measure_midline, published, read_midline,
};
use shoal_core::motion::{MotionPlayer, MotionRequest, RootState, Side, TurnKind};
use shoal_script::kinematics::subject;

fn repo() -> &'static Path {
    shoal_core::source_root()
}

fn measured(species: &str, speeds: &[f32]) -> (Subject, Vec<Measurement>) {
    let s = subject(Some(species), None, None, repo()).unwrap();
    let ms = measure(&s, speeds).unwrap();
    (s, ms)
}

/// Every species file shipped in `scripts/species`, by name, sorted.
fn shipped_species() -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(repo().join("scripts/species"))
        .unwrap()
        .filter_map(|e| {
            let name = e.unwrap().file_name().into_string().unwrap();
            name.strip_suffix(".lua").map(str::to_owned)
        })
        .collect();
    names.sort();
    names
}

fn within(what: &str, v: f32, lo: f32, hi: f32, context: &str) {
    assert!(
        (lo..=hi).contains(&v),
        "{context}: {what} = {v:.4}, published range [{lo}, {hi}]"
    );
}

const SPEEDS: [f32; 4] = [0.5, 1.0, 2.0, 3.0];

/// Every shipped species, at 0.5 – 3 L/s, against every published range of its swimming mode
/// (`shoal_core::motion::kinematics::published`: snout amplitude, where and how small the smallest
/// amplitude is, tail amplitude and excursion, body wavelength, waves on the body, Strouhal
/// number, stride length, slip; sources in docs/motion.md). Ranges, not points: published
/// values differ between species, individuals and studies. Plus the envelope's shape:
/// carangiform fish hold the front third still and put the amplitude at the tail (Jayne &
/// Lauder 1995; Videler & Hess 1984); anguilliform ones undulate the whole body. The frequency
/// rises with speed while the tail amplitude does not (Bainbridge 1958).
#[test]
fn test_every_shipped_species_swims_within_published_ranges() {
    let species = shipped_species();
    for must in ["black_porgy", "barracuda", "eel"] {
        assert!(
            species.iter().any(|s| s == must),
            "{must} not in {species:?}"
        );
    }
    for name in &species {
        let (s, ms) = measured(name, &SPEEDS);
        let want = if name == "eel" {
            Mode::Anguilliform
        } else {
            Mode::Carangiform
        };
        assert_eq!(s.mode, want, "{name}: mode");
        let (_, ranges) = published(s.mode);
        assert!(ranges.len() >= 8, "{name}: {} ranges", ranges.len());
        for m in &ms {
            let k = &m.kinematics;
            let ctx = format!("{name} at {} L/s", m.requested_speed_body_lengths_per_s);
            within(
                "speed U",
                k.speed_body_lengths_per_s,
                0.99 * m.requested_speed_body_lengths_per_s,
                1.01 * m.requested_speed_body_lengths_per_s,
                &ctx,
            );
            for r in ranges {
                within(
                    r.what,
                    (r.measured)(k),
                    r.lo,
                    r.hi,
                    &format!("{ctx} ({})", r.source),
                );
            }
            let tail = k.envelope.last().unwrap().amplitude;
            let smallest = k
                .envelope
                .iter()
                .map(|p| p.amplitude)
                .fold(f32::INFINITY, f32::min);
            match s.mode {
                Mode::Carangiform => {
                    let front_max = k
                        .envelope
                        .iter()
                        .filter(|p| p.x <= 1.0 / 3.0 + 1e-3)
                        .map(|p| p.amplitude)
                        .fold(0.0f32, f32::max);
                    within("front-third max / tail", front_max / tail, 0.0, 0.3, &ctx);
                    within(
                        "tail / mid-body",
                        tail / k.amplitude_at(0.5),
                        3.0,
                        20.0,
                        &ctx,
                    );
                    // Steep rise: from the quietest point the amplitude only grows to the tail
                    // (within the rigid segments' few per cent).
                    let after: Vec<f32> = k
                        .envelope
                        .iter()
                        .filter(|p| p.x >= k.min_amplitude_x)
                        .map(|p| p.amplitude)
                        .collect();
                    for w in after.windows(2) {
                        assert!(w[1] >= 0.9 * w[0] - 1e-3, "{ctx}: envelope falls {w:?}");
                    }
                }
                Mode::Anguilliform => {
                    // Gillis 1998: a "nonlinear increase" of amplitude along the body, the front
                    // not undulating significantly: from the snout the envelope only rises (no
                    // dip, no node; within 3 % for the rigid segments), and from 0.4 L back it
                    // carries at least a quarter of the tail's (Müller et al. 2001: the whole
                    // body makes thrust).
                    for w in k.envelope.windows(2) {
                        assert!(
                            w[1].amplitude >= 0.97 * w[0].amplitude,
                            "{ctx}: envelope falls from {:?} to {:?}",
                            w[0],
                            w[1]
                        );
                    }
                    assert!(smallest <= k.envelope[0].amplitude + 1e-6, "{ctx}");
                    for x in [0.4, 0.5, 0.6, 0.8] {
                        within(
                            "a(x) / tail",
                            k.amplitude_at(x) / tail,
                            0.25,
                            1.0,
                            &format!("{ctx}, x = {x}"),
                        );
                    }
                }
            }
        }
        // Bainbridge 1958: frequency rises with speed, the tail amplitude does not.
        for w in ms.windows(2) {
            assert!(
                w[1].kinematics.tail_beat_hz > 1.2 * w[0].kinematics.tail_beat_hz,
                "{name}: {} Hz at {} L/s, {} Hz at {} L/s",
                w[0].kinematics.tail_beat_hz,
                w[0].requested_speed_body_lengths_per_s,
                w[1].kinematics.tail_beat_hz,
                w[1].requested_speed_body_lengths_per_s
            );
            let (a0, a1) = (
                w[0].kinematics.tail_amplitude_peak_to_peak,
                w[1].kinematics.tail_amplitude_peak_to_peak,
            );
            assert!(
                (a1 - a0).abs() < 0.1 * a0,
                "{name}: tail amplitude {a0} → {a1}"
            );
        }
    }
}

/// The two modes differ as published: the eel's body from 0.3 L (where the porgy is quietest)
/// moves more than the porgy's, its mid-body carries a larger share of its tail's amplitude, and
/// its wave is shorter. (Its head moves less: eels barely yaw the head, Gillis 1998 and D'Août &
/// Aerts 1999, while the porgy's recoils.)
#[test]
fn test_eel_undulates_more_of_its_body_than_the_porgy() {
    let speeds = [0.5, 1.0, 2.0, 3.0];
    let (_, eel) = measured("eel", &speeds);
    let (_, porgy) = measured("black_porgy", &speeds);
    for (e, c) in eel.iter().zip(&porgy) {
        let (k, kc) = (&e.kinematics, &c.kinematics);
        let ctx = format!("at {} L/s", e.requested_speed_body_lengths_per_s);
        // Where the porgy is quietest the eel undulates.
        for x in [0.3, 0.4] {
            assert!(
                k.amplitude_at(x) > 1.3 * kc.amplitude_at(x),
                "{ctx}: eel a({x}) = {} is not larger than the porgy's {}",
                k.amplitude_at(x),
                kc.amplitude_at(x)
            );
        }
        // The middle, relative to each fish's own tail (the envelopes are compared in shape, as
        // Müller et al. 2001 contrast the eel's linear rise with the carangiform curve): the
        // eel's mid-body carries a larger share of its tail's amplitude.
        let (tail, tail_c) = (
            k.envelope.last().unwrap().amplitude,
            kc.envelope.last().unwrap().amplitude,
        );
        for x in [0.4, 0.5, 0.6, 0.7] {
            let (r, rc) = (k.amplitude_at(x) / tail, kc.amplitude_at(x) / tail_c);
            assert!(r > 1.3 * rc, "{ctx}: a({x})/tail eel {r}, porgy {rc}");
        }
        assert!(k.wavelength < 0.85 * kc.wavelength, "{ctx}: wavelengths");
    }
}

/// The porgy's swim wave is quietest where carangiform fish are (its pivot, 0.3 L), while it
/// turns about its turning axis (0.4 L): the two are separate parameters.
#[test]
fn test_porgy_is_quietest_in_its_front_third_but_turns_about_its_axis() {
    let (s, ms) = measured("black_porgy", &[1.0]);
    assert!((s.params.p - 0.3).abs() < 1e-6);
    assert_eq!(s.params.turn_axis_fraction(), 0.4);
    let k = &ms[0].kinematics;
    assert!(
        (k.min_amplitude_x - s.params.p).abs() <= 0.05 + 1e-6,
        "quietest at {}",
        k.min_amplitude_x
    );
    // The body recoils sideways (its mass comes from the model), so the quietest point keeps a
    // few thousandths of a body length, as the bass's smallest z_max (about 0.004 L) does,
    // instead of being a still node.
    assert!(!s.body.mass.is_empty(), "the porgy has no mass model");
    let smallest = k
        .envelope
        .iter()
        .map(|e| e.amplitude)
        .fold(f32::INFINITY, f32::min);
    assert!(
        (0.004..=0.012).contains(&smallest),
        "smallest amplitude {smallest} L"
    );
}

/// Steps `player` until it plays something other than `kind` (or `max_s` passes), returning the
/// root at each step.
fn play_turn(
    player: &mut MotionPlayer,
    s: &Subject,
    root: &mut RootState,
    kind: TurnKind,
) -> Vec<RootState> {
    let dt = 1.0 / 240.0;
    let mut lateral = vec![0.0; s.body.joints_x.len()];
    let mut yaw = vec![0.0; s.body.num_joints()];
    let mut roots = vec![*root];
    player.step(dt, &s.params, &s.body, root, &mut lateral, &mut yaw);
    roots.push(*root);
    let mut t = 0.0;
    while player.current_name() == kind.name() && t < 60.0 {
        player.step(dt, &s.params, &s.body, root, &mut lateral, &mut yaw);
        roots.push(*root);
        t += dt;
    }
    assert!(t < 60.0, "{} never ended", kind.name());
    roots
}

/// A player of `s` cruising at its speed for a second, then turning.
fn turn_from_cruise(s: &Subject, kind: TurnKind, side: Side, angle: f32) -> Vec<RootState> {
    let mut player = MotionPlayer::new();
    let mut root = RootState {
        speed: s.params.s,
        ..RootState::default()
    };
    let mut lateral = vec![0.0; s.body.joints_x.len()];
    let mut yaw = vec![0.0; s.body.num_joints()];
    player
        .push(MotionRequest::Swim { speed: s.params.s })
        .unwrap();
    for _ in 0..240 {
        player.step(
            1.0 / 240.0,
            &s.params,
            &s.body,
            &mut root,
            &mut lateral,
            &mut yaw,
        );
    }
    player
        .push(MotionRequest::Turn { kind, angle, side })
        .unwrap();
    play_turn(&mut player, s, &mut root, kind)
}

/// Where the turning axis is: `arm` behind the root (the head) along the heading.
fn axis_point(root: &RootState, arm: f32) -> glam::Vec3 {
    root.pos - arm * root.forward()
}

/// Every shipped species turns by the angle asked for, within ±10 %, with all three turns, both
/// ways, at 30°, 90° and 180°, on its own body; and its quick turn stays a near-in-place turn
/// (the turning axis travels less than 0.8 body lengths through a 90° quick turn, under half
/// what a normal turn of the same angle at the same speed takes), while the head swings round
/// the axis.
#[test]
fn test_every_shipped_species_turns_to_its_heading_and_quick_turns_in_place() {
    use std::f32::consts::{FRAC_PI_2, PI};
    for name in shipped_species() {
        let s = subject(Some(&name), None, None, repo()).unwrap();
        let l = s.params.l;
        for kind in [TurnKind::Normal, TurnKind::Quick, TurnKind::Serial] {
            for side in [Side::Left, Side::Right] {
                for angle in [PI / 6.0, FRAC_PI_2, PI] {
                    let roots = turn_from_cruise(&s, kind, side, angle);
                    let (start, end) = (roots[0].heading, roots.last().unwrap().heading);
                    let turned = shoal_core::math::wrap_angle(end - start);
                    let want = -side.d() * angle;
                    let err = if angle >= PI - 1e-3 {
                        (turned.abs() - angle).abs()
                    } else {
                        (turned - want).abs()
                    };
                    assert!(
                        err <= 0.1 * angle,
                        "{name} {kind:?} {side:?} {angle}: turned {turned}, wanted {want}"
                    );
                }
            }
        }
        let arm = s.params.turn_axis_fraction() * l;
        let travel = |roots: &[RootState]| {
            (axis_point(roots.last().unwrap(), arm) - axis_point(&roots[0], arm)).length()
        };
        let quick = turn_from_cruise(&s, TurnKind::Quick, Side::Left, FRAC_PI_2);
        let normal = turn_from_cruise(&s, TurnKind::Normal, Side::Left, FRAC_PI_2);
        let (q, n) = (travel(&quick) / l, travel(&normal) / l);
        assert!(q < 0.8, "{name}: quick turn's axis travelled {q} L");
        assert!(q < 0.5 * n, "{name}: quick {q} L vs normal {n} L");
        let slowest = quick.iter().map(|r| r.speed).fold(f32::INFINITY, f32::min);
        assert!(
            slowest < 0.02 * s.params.s,
            "{name}: quick turn slowest {slowest}"
        );
        // The head swings round the axis: it travels further than the axis does.
        let head = (quick.last().unwrap().pos - quick[0].pos).length() / l;
        assert!(head > q, "{name}: head {head} L, axis {q} L");
    }
}

fn shoal(args: &[&str]) -> std::process::Output {
    Command::new(env!("CARGO_BIN_EXE_shoal"))
        .args(args)
        .current_dir(repo())
        .output()
        .expect("run shoal")
}

#[test]
fn test_kinematics_cli_prints_definitions_and_json() {
    let out = shoal(&["kinematics", "--species", "black_porgy", "--speed", "1"]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8(out.stdout).unwrap();
    for needle in [
        "tail-beat frequency f (Hz)",
        "Strouhal number f·A/U",
        "envelope a(x), half peak-to-peak",
        "x = 1.0",
        "PEAK-TO-PEAK",
        "Saadat et al. 2017",
    ] {
        assert!(text.contains(needle), "missing {needle:?} in\n{text}");
    }
    let out = shoal(&[
        "kinematics",
        "--preset",
        "ex1",
        "--speed",
        "0.5,2",
        "--json",
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let json: serde_json::Value = serde_json::from_slice(&out.stdout).unwrap();
    assert_eq!(json["name"], "ex1");
    assert!((json["params"]["p"].as_f64().unwrap() - 0.4).abs() < 1e-6);
    let ms = json["measurements"].as_array().unwrap();
    assert_eq!(ms.len(), 2);
    assert!(ms[0]["envelope"].as_array().unwrap().len() >= 11);
    assert!(
        json["definitions"]["strouhal"]
            .as_str()
            .unwrap()
            .contains("f·A/U")
    );
    // Table 1's ex1: s·p·ω/λ = 1.5 Hz per body length per second.
    let f = ms[1]["tail_beat_hz"].as_f64().unwrap();
    assert!((f - 3.0).abs() < 0.05, "{f}");
}

#[test]
fn test_kinematics_cli_rejects_bad_input_clearly() {
    for (args, needle) in [
        (vec!["--species", "shark"], "unknown species \"shark\""),
        (vec!["--preset", "ex9"], "unknown motion preset \"ex9\""),
        (vec!["--speed", "NaN"], "--speed NaN"),
        (vec!["--speed", "-1"], "--speed -1"),
        (vec!["--speed", "0"], "--speed 0"),
        (vec!["--speed", "1,fast"], "fast"),
        (
            vec!["--species", "eel", "--preset", "ex1"],
            "cannot be used with",
        ),
    ] {
        let mut full = vec!["kinematics"];
        full.extend(&args);
        let out = shoal(&full);
        assert!(!out.status.success(), "{args:?} succeeded");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(needle), "{args:?}: {err}");
        assert!(!err.contains("panicked"), "{args:?}: {err}");
    }
}

#[test]
fn test_kinematics_plot_writes_a_png() {
    let dir = std::env::temp_dir().join(format!("shoal-kinematics-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let png = dir.join("eel.png");
    let out = shoal(&[
        "kinematics",
        "--species",
        "eel",
        "--speed",
        "1",
        "--plot",
        png.to_str().unwrap(),
    ]);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let img = image::open(&png).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (1400, 650));
    // Something was drawn in each panel (not a blank canvas).
    let dark = |x0: u32, x1: u32| {
        (x0..x1)
            .flat_map(|x| (60..640).map(move |y| (x, y)))
            .filter(|&(x, y)| img.get_pixel(x, y).0.iter().all(|&c| c < 100))
            .count()
    };
    assert!(dark(0, 700) > 500 && dark(700, 1400) > 500);
    std::fs::remove_dir_all(&dir).ok();
}

/// The eel against the measured sea lamprey (fishmechr's `lampreydata`), where the eel papers
/// give no number: the lamprey still measures what [`LAMPREY`] says (the anguilliform ranges are
/// built from it), and at every speed the eel's wavelength, stride and slip lie within 20 % of
/// the lamprey's, its mid-body carries a share of its tail's amplitude near the lamprey's, and
/// its head moves no more than the lamprey's.
#[test]
fn test_eel_against_the_measured_lamprey() {
    let m = read_midline(&repo().join("tests/data/midline/lamprey.csv")).unwrap();
    let lamprey = measure_midline(&m, None).unwrap().kinematics;
    for (what, figure, measured) in [
        ("snout", LAMPREY.snout, lamprey.envelope[0].amplitude),
        ("wavelength", LAMPREY.wavelength, lamprey.wavelength),
        ("stride", LAMPREY.stride_length, lamprey.stride_length),
        ("slip", LAMPREY.slip, lamprey.slip),
    ] {
        assert!(
            (figure - measured).abs() <= 0.01,
            "LAMPREY.{what} = {figure}, the lamprey measures {measured}"
        );
    }
    let share = |k: &shoal_core::motion::kinematics::Kinematics| {
        k.amplitude_at(0.5) / k.envelope.last().unwrap().amplitude
    };
    let (_, eel) = measured("eel", &SPEEDS);
    for e in &eel {
        let k = &e.kinematics;
        let ctx = format!("eel at {} L/s", e.requested_speed_body_lengths_per_s);
        for (what, ours, theirs) in [
            ("wavelength", k.wavelength, lamprey.wavelength),
            ("stride", k.stride_length, lamprey.stride_length),
            ("slip", k.slip, lamprey.slip),
        ] {
            within(what, ours, 0.8 * theirs, 1.2 * theirs, &ctx);
        }
        within(
            "a(0.5)/a(1)",
            share(k),
            share(&lamprey) - 0.15,
            share(&lamprey) + 0.15,
            &ctx,
        );
        assert!(
            k.envelope[0].amplitude <= lamprey.envelope[0].amplitude,
            "{ctx}"
        );
    }
}
