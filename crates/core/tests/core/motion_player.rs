//! Behaviour of the motion player: biology of the steady swim, turns, climbs, the queue.

use crate::motion_common;

use std::f32::consts::{FRAC_PI_2, PI};

use motion_common::{angle_diff, cruising, frequency_hz, peak_to_peak, record};
use shoal_core::motion::{
    Body, MotionParams, MotionPlayer, MotionRequest, Preset, RootState, Side, TurnKind,
};

const RATE_HZ: f32 = 240.0;

/// Strouhal number and tail excursion measured from the player's output, at 0.5 … 3 body
/// lengths per second: St = f·A/U in [0.2, 0.4] (Saadat et al. 2017, docs/motion.md) and peak-to-peak
/// tail excursion within 10 % of 0.2 body lengths (Bainbridge 1958).
#[test]
fn test_steady_swim_is_biologically_sane_across_speeds() {
    let params = MotionParams::default();
    let body = Body::black_porgy();
    for body_lengths_per_s in [0.5, 1.0, 1.5, 2.0, 3.0] {
        let speed = body_lengths_per_s * params.l;
        let (mut player, mut root) = cruising(&params, &body, speed);
        let x0 = root.pos.x;
        let seconds = 6.0;
        let frames = record(&mut player, &params, &body, &mut root, seconds, RATE_HZ);
        let tail: Vec<f32> = frames.iter().map(|f| f.lateral[6]).collect();
        let excursion = peak_to_peak(tail.iter().copied());
        let freq = frequency_hz(&tail, 1.0 / RATE_HZ);
        let measured_speed = (root.pos.x - x0) / seconds;
        let strouhal = freq * excursion / measured_speed;
        assert!(
            (measured_speed - speed).abs() < 1e-3 * speed,
            "{body_lengths_per_s} BL/s: root moved at {measured_speed}"
        );
        assert!(
            (0.2..=0.4).contains(&strouhal),
            "{body_lengths_per_s} BL/s: Strouhal {strouhal} (f = {freq} Hz, A = {excursion})"
        );
        let excursion_bl = excursion / params.l;
        assert!(
            (excursion_bl - 0.2).abs() <= 0.02,
            "{body_lengths_per_s} BL/s: tail excursion {excursion_bl} body lengths"
        );
        // The frequency is the one the parameters promise: s·p·ω/λ.
        let expected = params.tail_beat_hz(speed);
        assert!(
            (freq - expected).abs() < 0.02 * expected,
            "{freq} vs {expected}"
        );
    }
}

/// At the pivot the body hardly moves; the head recoils against the tail. (Unit joint weights
/// and short segments, so the posed body is the wave F itself to within a few per cent.) Table 1's
/// values, p = 0.4.
#[test]
fn test_pivot_is_the_quietest_point_and_head_recoils() {
    let params = MotionParams::TABLE_1;
    let mut body = Body::evenly_spaced(10); // joints at 0.1 … 0.9, one of them at the pivot 0.4.
    body.power = vec![1.0; 9];
    let (mut player, mut root) = cruising(&params, &body, params.s);
    let frames = record(&mut player, &params, &body, &mut root, 2.0, RATE_HZ);
    let range = |j: usize| peak_to_peak(frames.iter().map(|f| f.lateral[j]));
    let at_pivot = range(3);
    assert!(at_pivot < 0.03 * range(9), "pivot moves {at_pivot}");
    for j in [0, 1, 5, 6, 7, 8, 9] {
        assert!(range(j) > 5.0 * at_pivot);
    }
    // Behind the pivot the envelope is |A(x)| = |x − p|·maxAmp, in front |A_f(x)| = |x − p|/p ·
    // 0.02·l: the curve's tail tip (x = 1) sweeps 0.6·10 / (0.3/0.4 · 1) = 8 times the range at
    // x = 0.1; rigid segments carry a bend θ as sin θ rather than tan θ, which takes up to ~12 %
    // off the steep tail segment.
    let ratio = range(9) / range(0);
    assert!((7.0..=8.0).contains(&ratio), "tail/head range {ratio}");
    // Either side of the pivot the body moves in opposite directions (A(x) changes sign there):
    // the displacements at x = 0.3 and x = 0.5 are anti-correlated, by −cos(2π·0.1·l/λ) = −0.81
    // with the default λ = l.
    let dot = |i: usize, j: usize| {
        frames
            .iter()
            .map(|f| f.lateral[i] * f.lateral[j])
            .sum::<f32>()
    };
    let correlation = dot(2, 4) / (dot(2, 2) * dot(4, 4)).sqrt();
    assert!(correlation < -0.75, "correlation {correlation}");
}

fn turn(kind: TurnKind, side: Side, angle: f32, preset: &str) -> (Vec<motion_common::Frame>, f32) {
    let preset = Preset::by_name(preset).unwrap();
    let params = preset.params;
    let body = Body::black_porgy();
    let mut player = MotionPlayer::new();
    let mut root = preset.initial_root();
    player
        .push(MotionRequest::Turn { kind, angle, side })
        .unwrap();
    let mut frames = record(
        &mut player,
        &params,
        &body,
        &mut root,
        1.0 / RATE_HZ,
        RATE_HZ,
    );
    let duration = player.duration_s();
    let mut t = 0.0;
    while player.current_name() == kind.name() && t < 60.0 {
        frames.extend(record(
            &mut player,
            &params,
            &body,
            &mut root,
            0.25,
            RATE_HZ,
        ));
        t += 0.25;
    }
    (frames, duration)
}

#[test]
fn test_every_turn_lands_on_its_heading_both_sides() {
    for (kind, preset) in [
        (TurnKind::Normal, "ex2"),
        (TurnKind::Quick, "ex3"),
        (TurnKind::Serial, "ex4"),
    ] {
        for side in [Side::Left, Side::Right] {
            for angle in [FRAC_PI_2 / 3.0, FRAC_PI_2, PI] {
                let (frames, _) = turn(kind, side, angle, preset);
                let start = RootState::default().heading;
                let end = frames.last().unwrap().root.heading;
                let want = -side.d() * angle;
                let got = if angle >= PI - 1e-3 {
                    // ±π are the same heading; compare magnitudes.
                    angle_diff(start, end).abs() * want.signum()
                } else {
                    angle_diff(start, end)
                };
                assert!(
                    (got - want).abs() <= 0.1 * angle,
                    "{kind:?} {side:?} {angle}: turned {got}, wanted {want}"
                );
            }
        }
    }
}

/// Quick turn: halts while turning, in about Tt, with a small radius. Serial turn: keeps moving.
#[test]
fn test_quick_turn_halts_and_serial_turn_keeps_swimming() {
    let ex3 = Preset::by_name("ex3").unwrap();
    let (quick, quick_duration) = turn(TurnKind::Quick, Side::Left, FRAC_PI_2, "ex3");
    assert!((quick_duration - ex3.params.tt).abs() < 1e-6);
    let min_speed = quick
        .iter()
        .map(|f| f.root.speed)
        .fold(f32::INFINITY, f32::min);
    assert!(
        min_speed < 0.02 * ex3.params.s,
        "quick turn min speed {min_speed}"
    );
    // The root ends up within 0.7 body lengths of where it started: a tight turn.
    let quick_end = quick.last().unwrap().root.pos;
    assert!(quick_end.length() < 0.7 * ex3.params.l, "{quick_end}");

    let ex4 = Preset::by_name("ex4").unwrap();
    let (serial, serial_duration) = turn(TurnKind::Serial, Side::Left, FRAC_PI_2, "ex4");
    assert!(
        (serial_duration - 2.0 * ex4.params.tt).abs() < 1e-6,
        "two 45° strokes"
    );
    let min_speed = serial
        .iter()
        .map(|f| f.root.speed)
        .fold(f32::INFINITY, f32::min);
    assert!(
        min_speed > 0.9 * ex4.params.s,
        "serial turn slowed to {min_speed}"
    );
    // A left turn from heading +x ends up on the left (−z) side, having gone forward.
    let serial_end = serial.last().unwrap().root.pos;
    assert!(
        serial_end.x > ex4.params.l && serial_end.z < -ex4.params.l,
        "{serial_end}"
    );
}

/// During a left turn the tail is pushed to the left (C-bend concave to the turn side), and
/// during a right turn to the right: the same turn to both sides, from the same swim phase,
/// differs only by the turn wave, so the mean tail displacement of the left one lies to the left
/// of the right one's by a clear margin.
#[test]
fn test_turn_bends_tail_to_its_side() {
    for (kind, preset) in [
        (TurnKind::Normal, "ex2"),
        (TurnKind::Quick, "ex3"),
        (TurnKind::Serial, "ex4"),
    ] {
        let l = Preset::by_name(preset).unwrap().params.l;
        let mean_tail = |side| {
            let (frames, _) = turn(kind, side, FRAC_PI_2, preset);
            frames.iter().map(|f| f.lateral[6]).sum::<f32>() / frames.len() as f32
        };
        let (left, right) = (mean_tail(Side::Left), mean_tail(Side::Right));
        assert!(
            left - right > 0.04 * l,
            "{kind:?}: mean tail lateral {left} (left turn) vs {right} (right turn)"
        );
    }
    // Mid-way through a quick turn the fish has all but stopped, so the swim wave has faded and
    // the whole body behind the pivot is bent to the turn side.
    for side in [Side::Left, Side::Right] {
        let (frames, duration) = turn(TurnKind::Quick, side, FRAC_PI_2, "ex3");
        // `turn` records from the turn's first step at RATE_HZ.
        let mid = &frames[(0.5 * duration * RATE_HZ) as usize];
        assert_eq!(mid.motion, "quick_turn");
        for (j, lat) in mid.lateral.iter().enumerate().skip(1) {
            assert!(lat * -side.d() > 0.0, "{side:?}: joint {j} at {lat}");
        }
    }
}

#[test]
fn test_ascent_and_descent_reach_their_depth() {
    let params = MotionParams::default();
    let body = Body::black_porgy();
    for (request, dy) in [
        (MotionRequest::Ascend { height: 30.0 }, 30.0f32),
        (MotionRequest::Descend { depth: 80.0 }, -80.0),
        (MotionRequest::Ascend { height: 2.0 }, 2.0),
    ] {
        let (mut player, mut root) = cruising(&params, &body, params.s);
        let y0 = root.pos.y;
        player.push(request).unwrap();
        let mut max_pitch: f32 = 0.0;
        for _ in 0..40 {
            let frames = record(&mut player, &params, &body, &mut root, 0.25, 60.0);
            for f in &frames {
                max_pitch = max_pitch.max(f.root.pitch * dy.signum());
            }
            if player.current_name() == "swim" {
                break;
            }
        }
        assert_eq!(player.current_name(), "swim", "{request:?} never finished");
        let risen = root.pos.y - y0;
        assert!(
            (risen - dy).abs() <= 0.02 * dy.abs(),
            "{request:?}: {risen}"
        );
        assert!(
            max_pitch > 0.0 && max_pitch <= 0.53,
            "{request:?}: pitch {max_pitch}"
        );
        assert!(root.pitch.abs() < 0.02, "levels out: {}", root.pitch);
    }
}

/// From rest, an ascent first gets up to speed, so the pitch never exceeds 30°.
#[test]
fn test_ascent_from_rest_never_pitches_steeply() {
    let params = MotionParams::default();
    let body = Body::black_porgy();
    let mut player = MotionPlayer::new();
    let mut root = RootState::default();
    player.push(MotionRequest::Ascend { height: 40.0 }).unwrap();
    let frames = record(&mut player, &params, &body, &mut root, 8.0, 120.0);
    let max_pitch = frames.iter().map(|f| f.root.pitch).fold(0.0, f32::max);
    assert!(max_pitch <= PI / 6.0 + 1e-3, "pitch {max_pitch}");
    assert!((root.pos.y - 40.0).abs() < 0.02 * 40.0, "{}", root.pos.y);
    assert_eq!(player.current_name(), "swim");
}

/// Fig. 10: requests play to completion, in order; `interrupt` drops the queue and cuts in.
#[test]
fn test_queue_plays_in_order_and_interrupt_cuts_in() {
    let params = MotionParams::default();
    let body = Body::black_porgy();
    let mut player = MotionPlayer::new();
    let mut root = RootState::default();
    assert_eq!(player.current_name(), "idle");
    player
        .push(MotionRequest::Accelerate {
            speed: 60.0,
            duration: 1.0,
        })
        .unwrap();
    player
        .push(MotionRequest::Turn {
            kind: TurnKind::Normal,
            angle: 1.0,
            side: Side::Right,
        })
        .unwrap();
    player.push(MotionRequest::Stop { duration: 0.5 }).unwrap();
    assert_eq!(player.queue_len(), 3);
    let frames = record(&mut player, &params, &body, &mut root, 10.0, 60.0);
    let mut order: Vec<&str> = Vec::new();
    for f in &frames {
        if order.last() != Some(&f.motion) {
            order.push(f.motion);
        }
    }
    assert_eq!(order, ["accelerate", "normal_turn", "stop", "idle"]);
    // The accelerate reached its speed before the turn started.
    let last_accel = frames
        .iter()
        .rev()
        .find(|f| f.motion == "accelerate")
        .unwrap();
    assert!((last_accel.root.speed - 60.0).abs() < 1e-3);
    assert_eq!(root.speed, 0.0);

    // Interrupt a long turn halfway: the queue is dropped, the new motion starts next step.
    let mut player = MotionPlayer::new();
    let mut root = RootState {
        speed: 50.0,
        ..RootState::default()
    };
    player
        .push(MotionRequest::Turn {
            kind: TurnKind::Serial,
            angle: PI,
            side: Side::Left,
        })
        .unwrap();
    player.push(MotionRequest::Swim { speed: 10.0 }).unwrap();
    record(&mut player, &params, &body, &mut root, 1.0, 60.0);
    assert_eq!(player.current_name(), "serial_turn");
    player
        .interrupt(MotionRequest::Stop { duration: 1.0 })
        .unwrap();
    assert_eq!(player.queue_len(), 1);
    let frames = record(&mut player, &params, &body, &mut root, 1.0 / 60.0, 60.0);
    assert_eq!(frames[0].motion, "stop");
    assert_eq!(player.queue_len(), 0);
    // The body shape blends: no joint's displacement jumps by more than in a normal frame.
    let before = frames[0].lateral.clone();
    let after = record(&mut player, &params, &body, &mut root, 1.0 / 60.0, 60.0);
    for (a, b) in before.iter().zip(after[0].lateral.iter()) {
        assert!((a - b).abs() < 0.05 * params.l, "jump {a} → {b}");
    }
}

/// A swim request ends as soon as something else is queued and the fish keeps swimming after
/// a turn, at the speed the turn ended with.
#[test]
fn test_swim_gives_way_and_turns_continue_swimming() {
    let params = MotionParams::default();
    let body = Body::black_porgy();
    let (mut player, mut root) = cruising(&params, &body, 40.0);
    assert_eq!(player.current_name(), "swim");
    player
        .push(MotionRequest::Turn {
            kind: TurnKind::Quick,
            angle: FRAC_PI_2,
            side: Side::Right,
        })
        .unwrap();
    record(&mut player, &params, &body, &mut root, 0.1, 60.0);
    assert_eq!(player.current_name(), "quick_turn");
    record(
        &mut player,
        &params,
        &body,
        &mut root,
        params.tt + 0.1,
        60.0,
    );
    assert_eq!(
        player.current(),
        Some(MotionRequest::Swim { speed: 40.0 }),
        "continues at the speed it turned from"
    );
}

/// Changing speed never makes the wave jump or run backwards.
#[test]
fn test_phase_advances_smoothly_through_speed_changes() {
    let params = MotionParams::default();
    let body = Body::black_porgy();
    let mut player = MotionPlayer::new();
    let mut root = RootState::default();
    for request in [
        MotionRequest::Accelerate {
            speed: 150.0,
            duration: 0.7,
        },
        MotionRequest::Accelerate {
            speed: 20.0,
            duration: 0.3,
        },
        MotionRequest::Stop { duration: 0.4 },
        MotionRequest::Swim { speed: 90.0 },
    ] {
        player.push(request).unwrap();
    }
    let frames = record(&mut player, &params, &body, &mut root, 4.0, 120.0);
    let mut max_step = 0.0f32;
    for w in frames.windows(2) {
        let dphase = (w[1].phase - w[0].phase).rem_euclid(std::f32::consts::TAU);
        // Never backwards (a backwards step would wrap to nearly 2π).
        assert!(dphase < PI, "phase ran backwards at t = {}", w[1].t);
        max_step = max_step.max(dphase);
        for (a, b) in w[0].lateral.iter().zip(w[1].lateral.iter()) {
            assert!(
                (a - b).abs() < 0.03 * params.l,
                "lateral jump at t = {}",
                w[1].t
            );
        }
    }
    // Fastest phase step: 150 u/s → 3·1.5 Hz·2π / 120 Hz ≈ 0.35 rad.
    assert!(max_step < 0.4, "{max_step}");
}

#[test]
fn test_bad_requests_are_rejected_with_the_value() {
    let mut player = MotionPlayer::new();
    let err = player
        .push(MotionRequest::Swim { speed: -1.0 })
        .unwrap_err()
        .to_string();
    assert_eq!(
        err,
        "invalid motion parameter speed = -1: speed must not be negative"
    );
    let err = player
        .push(MotionRequest::Turn {
            kind: TurnKind::Quick,
            angle: f32::NAN,
            side: Side::Left,
        })
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("angle = NaN") && err.contains("finite"),
        "{err}"
    );
    assert!(
        player
            .interrupt(MotionRequest::Ascend { height: -3.0 })
            .is_err()
    );
    assert!(
        player
            .push(MotionRequest::Stop {
                duration: f32::INFINITY
            })
            .is_err()
    );
    assert_eq!(player.queue_len(), 0);
}

#[test]
fn test_params_validation_names_each_field() {
    let ok = MotionParams::default();
    ok.validate().unwrap();
    let cases: [(MotionParams, &str); 10] = [
        (MotionParams { p: 0.14, ..ok }, "p = 0.14"),
        (MotionParams { p: 1.0, ..ok }, "p = 1"),
        (MotionParams { s: -5.0, ..ok }, "s = -5"),
        (MotionParams { s: f32::NAN, ..ok }, "s = NaN"),
        (MotionParams { l: 0.0, ..ok }, "l = 0"),
        (
            MotionParams {
                max_amp: -1.0,
                ..ok
            },
            "max_amp = -1",
        ),
        (MotionParams { lambda: 0.0, ..ok }, "lambda = 0"),
        (MotionParams { tt: 0.0, ..ok }, "tt = 0"),
        (MotionParams { f: 2.5, ..ok }, "f = 2.5"),
        (
            MotionParams {
                turn_angle: 0.0,
                ..ok
            },
            "turn_angle = 0",
        ),
    ];
    for (params, needle) in cases {
        let err = params.validate().unwrap_err().to_string();
        assert!(err.contains(needle), "{err} should name {needle}");
    }
    let err = MotionParams { p: 0.1, ..ok }
        .validate()
        .unwrap_err()
        .to_string();
    assert!(err.contains("λ'"), "{err}");
}

/// The midline the player reports is the posed chain: forward kinematics of `head_lateral`,
/// `head_yaw` and the joint yaws through [`MidlinePoseJob`] puts the tail where `lateral` says,
/// for the swim and all three turns.
#[test]
fn test_posed_chain_follows_reported_midline() {
    use shoal_core::motion::{MidlinePoseJob, record_preset};
    for name in ["ex1", "ex2", "ex3", "ex4"] {
        let preset = Preset::by_name(name).unwrap();
        let body = Body::black_porgy();
        let rec = record_preset(&preset, &body, 3.0, 60.0).unwrap();
        let l = preset.params.l;
        let mut points = [glam::Vec3::ZERO; 8];
        let mut worst: f32 = 0.0;
        for f in &rec.frames {
            MidlinePoseJob {
                root: &f.root,
                body: &body,
                l,
                head_lateral: f.head_lateral,
                head_yaw: f.head_yaw,
                yaw: &f.yaw,
                points: &mut points,
            }
            .run()
            .unwrap();
            // Tail tip relative to the root, in the root's frame: sideways (left) component.
            let rel = points[7] - f.root.pos;
            let tail_left = rel.dot(f.root.left());
            worst = worst.max((tail_left - f.lateral[6]).abs());
        }
        assert!(worst < 1e-4 * l, "{name}: posed tail differs by {worst}");
    }
}
