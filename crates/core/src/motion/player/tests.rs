//! Unit tests of the motion player (its private stages and tables included).

use super::*;
use crate::motion::{Side, TurnKind};

fn run(
    player: &mut MotionPlayer,
    params: &MotionParams,
    root: &mut RootState,
    seconds: f32,
) -> (Vec<f32>, Vec<f32>) {
    let body = Body::black_porgy();
    let mut lateral = vec![0.0; 7];
    let mut yaw = vec![0.0; 6];
    let dt = 1.0 / 60.0;
    let steps = (seconds / dt).round() as usize;
    for _ in 0..steps {
        player.step(dt, params, &body, root, &mut lateral, &mut yaw);
    }
    (lateral, yaw)
}

#[test]
fn test_progress_reaches_one_for_every_stroke_count() {
    let params = MotionParams::default();
    for angle in [0.3, 1.0, 1.6, 3.0] {
        let a = Active::start(
            Some(MotionRequest::Turn {
                kind: TurnKind::Serial,
                angle,
                side: Side::Left,
            }),
            50.0,
            &params,
        );
        assert_eq!(a.progress(0.0), 0.0);
        assert!((a.progress(a.duration_s) - 1.0).abs() < 1e-6);
        // Monotone.
        let mut last = 0.0;
        for k in 0..=100 {
            let g = a.progress(a.duration_s * k as f32 / 100.0);
            assert!(g >= last - 1e-6);
            last = g;
        }
    }
}

#[test]
fn test_steady_swim_advances_at_s() {
    let params = MotionParams::default();
    let mut player = MotionPlayer::new();
    let mut root = RootState {
        speed: 50.0,
        ..RootState::default()
    };
    player.push(MotionRequest::Swim { speed: 50.0 }).unwrap();
    run(&mut player, &params, &mut root, 1.0);
    let x0 = root.pos.x;
    run(&mut player, &params, &mut root, 2.0);
    assert!(
        ((root.pos.x - x0) - 100.0).abs() < 0.01,
        "{}",
        root.pos.x - x0
    );
    assert!(root.pos.z.abs() < 1e-4);
    assert_eq!(player.current_name(), "swim");
}

#[test]
fn test_quick_turn_left_turns_ninety_degrees_in_tt() {
    let params = MotionParams::default();
    let mut player = MotionPlayer::new();
    let mut root = RootState {
        speed: 50.0,
        ..RootState::default()
    };
    player
        .push(MotionRequest::Turn {
            kind: TurnKind::Quick,
            angle: std::f32::consts::FRAC_PI_2,
            side: Side::Left,
        })
        .unwrap();
    run(&mut player, &params, &mut root, params.tt);
    assert!(
        (root.heading - std::f32::consts::FRAC_PI_2).abs() < 1e-3,
        "{}",
        root.heading
    );
}

/// Parameters that failed validation still never put NaN or infinity into the outputs.
#[test]
fn test_invalid_params_never_produce_nan() {
    let ok = MotionParams::default();
    let bad = [
        MotionParams { p: f32::NAN, ..ok },
        MotionParams { lambda: 0.0, ..ok },
        MotionParams { l: 0.0, ..ok },
        MotionParams { tt: 0.0, ..ok },
        MotionParams { p: 0.1, ..ok },
        MotionParams {
            omega: f32::INFINITY,
            ..ok
        },
        MotionParams {
            max_amp: f32::NAN,
            ..ok
        },
    ];
    let body = Body::black_porgy();
    for params in bad {
        for request in [
            MotionRequest::Swim { speed: 50.0 },
            MotionRequest::Turn {
                kind: TurnKind::Quick,
                angle: 1.0,
                side: Side::Right,
            },
            MotionRequest::Turn {
                kind: TurnKind::Normal,
                angle: 1.0,
                side: Side::Left,
            },
            MotionRequest::Ascend { height: 10.0 },
        ] {
            let mut player = MotionPlayer::new();
            let mut root = RootState {
                speed: 50.0,
                ..RootState::default()
            };
            player.push(request).unwrap();
            let mut lateral = [0.0; 7];
            let mut yaw = [0.0; 6];
            for _ in 0..200 {
                player.step(
                    1.0 / 60.0,
                    &params,
                    &body,
                    &mut root,
                    &mut lateral,
                    &mut yaw,
                );
                assert!(
                    lateral.iter().chain(yaw.iter()).all(|v| v.is_finite())
                        && root.pos.is_finite()
                        && root.heading.is_finite()
                        && root.pitch.is_finite()
                        && root.speed.is_finite(),
                    "{params:?} {request:?}: {lateral:?} {yaw:?} {root:?}"
                );
            }
        }
    }
}

/// The shape as it was evaluated before [`WaveTable`]: every sine directly, from the wave
/// functions of `wave.rs`.
fn shape_direct(a: &Active, params: &MotionParams, phase: f32, gain: f32, x: f32) -> f32 {
    let (p, l) = (params.p, params.l);
    let xl = x * l;
    let s = wave::swim_wave(
        xl,
        p,
        l,
        params.max_amp,
        params.lambda,
        params.lambda_prime(),
        (params.front_amp, params.front_wave),
        phase,
        gain,
    );
    let Plan::Turn {
        kind,
        d,
        wavelength,
        strokes,
        ..
    } = a.plan
    else {
        return s;
    };
    let ip = a.ip(a.elapsed_s);
    let xp = wave::x_prime(xl, p, l);
    if ip == 0.0 || xp < 0.0 {
        return s;
    }
    let amp = wave::amplitude(xl, p, l, params.max_amp);
    let t = match kind {
        TurnKind::Normal => wave::f_nt(amp, xp, params.lambda, phase, d, params.f),
        TurnKind::Quick | TurnKind::Serial => {
            let theta = TAU * wave::omega_2(params.tt) * a.elapsed_s - TAU * xp / wavelength;
            if theta < 0.0 || theta > strokes as f32 * PI {
                0.0
            } else {
                let gain = if kind == TurnKind::Quick {
                    QUICK_TURN_BEND_GAIN
                } else {
                    SERIAL_TURN_BEND_GAIN
                };
                wave::f_st(
                    amp * gain * params.f,
                    xp,
                    wavelength,
                    a.elapsed_s,
                    params.tt,
                    d,
                )
            }
        }
    };
    wave::t_locomotion(s, t, ip)
}

/// The tabled shape is the paper's equations evaluated sine by sine, within 2e-7 body
/// lengths, through every kind of motion and the cross-fades between them, for two species'
/// parameters; and `step_with` (the world's path) gives bitwise what `step` gives.
#[test]
fn test_tabled_shape_matches_direct_evaluation() {
    let eel = MotionParams {
        p: 0.2,
        s: 30.0,
        l: 70.0,
        max_amp: 70.0 / 8.0,
        lambda: 42.0,
        omega: 3.0,
        tt: 2.5,
        f: 1.0,
        turn_angle: FRAC_PI_4,
        turn_axis: Some(0.3),
        front_amp: 0.035,
        front_wave: crate::motion::FrontWave::Travelling,
    };
    let requests = [
        MotionRequest::Swim { speed: 50.0 },
        MotionRequest::Turn {
            kind: TurnKind::Normal,
            angle: 1.2,
            side: Side::Left,
        },
        MotionRequest::Turn {
            kind: TurnKind::Quick,
            angle: 1.6,
            side: Side::Right,
        },
        MotionRequest::Turn {
            kind: TurnKind::Serial,
            angle: 2.5,
            side: Side::Left,
        },
        MotionRequest::Ascend { height: 30.0 },
        MotionRequest::Accelerate {
            speed: 90.0,
            duration: 0.7,
        },
        MotionRequest::Stop { duration: 0.5 },
    ];
    for (params, body) in [
        (MotionParams::default(), Body::black_porgy()),
        (eel, Body::evenly_spaced(9)),
    ] {
        let table = WaveTable::new(&params, &body);
        let other = WaveTable::new(&MotionParams::default(), &Body::evenly_spaced(4));
        let n = body.joints_x.len();
        let mut player = MotionPlayer::with_phase(1.0);
        let mut twin = player.clone();
        let mut root = RootState {
            speed: 40.0,
            ..RootState::default()
        };
        let mut twin_root = root;
        let (mut lateral, mut yaw) = (vec![0.0; n], vec![0.0; n - 1]);
        let (mut twin_lateral, mut twin_yaw) = (lateral.clone(), yaw.clone());
        let (mut worst, mut turning) = (0.0f32, 0);
        for (k, request) in requests.iter().cycle().take(40).enumerate() {
            if k % 3 == 0 {
                player.interrupt(*request).unwrap();
                twin.interrupt(*request).unwrap();
            } else {
                player.push(*request).unwrap();
                twin.push(*request).unwrap();
            }
            for step in 0..50 {
                player.step(
                    1.0 / 60.0,
                    &params,
                    &body,
                    &mut root,
                    &mut lateral,
                    &mut yaw,
                );
                // The world's path, every other step with a table for another body.
                let t = if step % 2 == 0 { &table } else { &other };
                twin.step_with(
                    1.0 / 60.0,
                    &params,
                    &body,
                    t,
                    &mut twin_root,
                    &mut twin_lateral,
                    &mut twin_yaw,
                );
                let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                assert_eq!(bits(&lateral), bits(&twin_lateral));
                assert_eq!(bits(&yaw), bits(&twin_yaw));
                assert_eq!(root, twin_root);
                // Each motion's shape at every sample, tabled and direct.
                let context = ShapeContext {
                    gain: smoothstep(
                        root.speed / (FULL_AMPLITUDE_SPEED_BODY_LENGTHS_PER_S * params.l),
                    ),
                    phase: player.phase.sin_cos(),
                    tt: params.tt,
                    f: params.f,
                };
                for a in std::iter::once(&player.current).chain(player.previous.as_ref()) {
                    turning += usize::from(a.ip(a.elapsed_s) > 0.0);
                    let turn = TurnStep::new(a, &context, &table);
                    for (sample, x) in table
                        .samples
                        .iter()
                        .zip(std::iter::once(0.0).chain(body.joints_x.iter().copied()))
                    {
                        let tabled = shape(a, &context, &turn, sample);
                        let direct = shape_direct(a, &params, player.phase, context.gain, x);
                        worst = worst.max((tabled - direct).abs() / params.l);
                    }
                }
            }
        }
        assert!(turning > 500, "turns were exercised: {turning}");
        assert!(
            worst <= 2e-6,
            "tabled shape differs by {worst} body lengths"
        );
    }
}

/// 10,000 fish each hold a player: keep it within a few cache lines.
#[test]
fn test_player_state_is_small() {
    let size = std::mem::size_of::<MotionPlayer>();
    assert!(size <= 192, "MotionPlayer is {size} bytes");
}

/// A quick turn from rest turns the body about its turning axis: the point `turn_axis`·l behind
/// the head stays where it was while the head swings round it, whatever the swim wave's pivot
/// `p`; without a turning axis the body turns about the pivot, as in the paper.
#[test]
fn test_turns_yaw_about_the_turning_axis_not_the_pivot() {
    let point = |root: &RootState, x: f32, l: f32| root.pos - x * l * root.forward();
    for (turn_axis, about) in [(Some(0.45), 0.45), (Some(0.2), 0.2), (None, 0.3)] {
        let params = MotionParams {
            p: 0.3,
            turn_axis,
            ..MotionParams::BLACK_PORGY
        };
        params.validate().unwrap();
        let mut player = MotionPlayer::new();
        let mut root = RootState::default();
        player
            .push(MotionRequest::Turn {
                kind: TurnKind::Quick,
                angle: 1.5,
                side: Side::Left,
            })
            .unwrap();
        let start = root;
        run(&mut player, &params, &mut root, params.tt + 0.1);
        assert!((root.heading - 1.5).abs() < 1e-3, "{}", root.heading);
        let l = params.l;
        let stayed = (point(&root, about, l) - point(&start, about, l)).length();
        assert!(stayed < 1e-3 * l, "{turn_axis:?}: axis moved {stayed}");
        // Any other point of the body moved: the head by about 2·sin(0.75)·about·l.
        let head = (root.pos - start.pos).length();
        assert!(
            (head - 2.0 * 0.75f32.sin() * about * l).abs() < 1e-2 * l,
            "{turn_axis:?}: head moved {head}"
        );
        let other = if about == 0.3 { 0.4 } else { 0.3 };
        assert!((point(&root, other, l) - point(&start, other, l)).length() > 0.05 * l);
    }
    // A turning axis off the body is refused, naming the field.
    let bad = MotionParams {
        turn_axis: Some(1.5),
        ..MotionParams::BLACK_PORGY
    };
    let e = bad.validate().unwrap_err().to_string();
    assert!(e.contains("turn_axis = 1.5"), "{e}");
    let bad = MotionParams {
        turn_axis: Some(f32::NAN),
        ..MotionParams::BLACK_PORGY
    };
    assert!(
        bad.validate()
            .unwrap_err()
            .to_string()
            .contains("turn_axis")
    );
}

/// A body with a mass model recoils sideways: at every step its centre of mass is on the travel
/// line, and the posed body is the unrecoiled one shifted sideways as a whole (the joint yaws are
/// the same), by an amount that is not always 0.
#[test]
fn test_recoil_keeps_the_centre_of_mass_on_the_travel_line() {
    let params = MotionParams::BLACK_PORGY;
    let rigid = Body::black_porgy();
    let mut massive = Body::black_porgy();
    massive.mass = vec![0.25, 0.3, 0.2, 0.12, 0.07, 0.04, 0.02];
    massive.validate().unwrap();
    let (mut a, mut b) = (MotionPlayer::new(), MotionPlayer::new());
    let cruising = RootState {
        speed: params.s,
        ..RootState::default()
    };
    let (mut root_a, mut root_b) = (cruising, cruising);
    for player in [&mut a, &mut b] {
        player
            .push(MotionRequest::Swim { speed: params.s })
            .unwrap();
    }
    let (mut lat_a, mut lat_b) = (vec![0.0; 7], vec![0.0; 7]);
    let (mut yaw_a, mut yaw_b) = (vec![0.0; 6], vec![0.0; 6]);
    let mut largest_shift = 0.0f32;
    for _ in 0..180 {
        a.step(
            1.0 / 60.0,
            &params,
            &rigid,
            &mut root_a,
            &mut lat_a,
            &mut yaw_a,
        );
        b.step(
            1.0 / 60.0,
            &params,
            &massive,
            &mut root_b,
            &mut lat_b,
            &mut yaw_b,
        );
        let centre = massive.recoil(b.head_lateral(), &lat_b);
        assert!(centre.abs() < 1e-4, "centre of mass {centre} off the line");
        assert_eq!(yaw_a, yaw_b, "recoil must not change the bends");
        assert_eq!(root_a, root_b, "recoil must not move the root");
        let shift = a.head_lateral() - b.head_lateral();
        for (ya, yb) in lat_a.iter().zip(&lat_b) {
            assert!((ya - yb - shift).abs() < 1e-4, "{ya} {yb} {shift}");
        }
        largest_shift = largest_shift.max(shift.abs());
    }
    assert!(
        largest_shift > 0.1,
        "the body never recoiled ({largest_shift})"
    );
}

/// The root-only step and the shape derived afterwards are, bit for bit, the whole step: through
/// swims, each kind of turn and their cross-fades, a player stepped with `advance_tabled` and
/// given `shape_tabled`'s head with `set_head_shape` equals one stepped with `step_tabled`, and so
/// do the arrays.
#[test]
fn test_advance_then_shape_is_the_whole_step_bit_for_bit() {
    let params = MotionParams::default();
    let body = Body::black_porgy();
    let table = WaveTable::new(&params, &body);
    let mut whole = MotionPlayer::with_phase(1.3);
    let mut split = whole.clone();
    let mut root_whole = RootState::default();
    let mut root_split = root_whole;
    let (mut lat_w, mut yaw_w) = (vec![0.0; 7], vec![0.0; 6]);
    let (mut lat_s, mut yaw_s) = (vec![0.0; 7], vec![0.0; 6]);
    let requests = [
        MotionRequest::Swim { speed: 60.0 },
        MotionRequest::Turn {
            kind: TurnKind::Quick,
            angle: 1.0,
            side: Side::Left,
        },
        MotionRequest::Turn {
            kind: TurnKind::Serial,
            angle: 2.0,
            side: Side::Right,
        },
        MotionRequest::Turn {
            kind: TurnKind::Normal,
            angle: 0.8,
            side: Side::Left,
        },
    ];
    let mut checked = 0;
    for step in 0..400 {
        if step % 40 == 0 {
            let r = requests[(step / 40) % requests.len()];
            whole.interrupt(r).unwrap();
            split.interrupt(r).unwrap();
        }
        whole.step_tabled(
            1.0 / 60.0,
            &params,
            &body,
            &table,
            &mut root_whole,
            &mut lat_w,
            &mut yaw_w,
        );
        split.advance_tabled(1.0 / 60.0, &params, &mut root_split);
        assert_eq!(root_whole, root_split);
        if step % 3 == 0 {
            // Derived without touching the player, then stored.
            let (head_lateral, head_yaw) = split.shape_tabled(
                root_split.speed,
                &params,
                &body,
                &table,
                &mut lat_s,
                &mut yaw_s,
            );
            assert_eq!(head_lateral.to_bits(), whole.head_lateral().to_bits());
            assert_eq!(head_yaw.to_bits(), whole.head_yaw().to_bits());
            split.set_head_shape((head_lateral, head_yaw));
            let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
            assert_eq!(bits(&lat_s), bits(&lat_w), "step {step}");
            assert_eq!(bits(&yaw_s), bits(&yaw_w), "step {step}");
            assert_eq!(split, whole, "step {step}");
            assert!(yaw_w.iter().any(|&y| y != 0.0));
            checked += 1;
        }
    }
    assert!(checked > 100);
}
