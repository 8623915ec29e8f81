//! Helpers shared by the motion integration tests: run a player and record what it outputs.

#![allow(dead_code)]

use shoal_core::motion::{Body, MotionParams, MotionPlayer, MotionRequest, RootState};

/// One recorded step.
#[derive(Debug, Clone)]
pub struct Frame {
    pub t: f32,
    pub motion: &'static str,
    pub lateral: Vec<f32>,
    pub yaw: Vec<f32>,
    pub root: RootState,
    pub phase: f32,
}

/// Steps `player` for `seconds` at `rate_hz`, recording every step.
pub fn record(
    player: &mut MotionPlayer,
    params: &MotionParams,
    body: &Body,
    root: &mut RootState,
    seconds: f32,
    rate_hz: f32,
) -> Vec<Frame> {
    let dt = 1.0 / rate_hz;
    let steps = (seconds * rate_hz).round() as usize;
    let mut lateral = vec![0.0; body.joints_x.len()];
    let mut yaw = vec![0.0; body.num_joints()];
    let mut frames = Vec::with_capacity(steps);
    for k in 0..steps {
        player.step(dt, params, body, root, &mut lateral, &mut yaw);
        frames.push(Frame {
            t: (k + 1) as f32 * dt,
            motion: player.current_name(),
            lateral: lateral.clone(),
            yaw: yaw.clone(),
            root: *root,
            phase: player.phase(),
        });
    }
    frames
}

/// A player already cruising at `speed` (root speed set, `Swim` queued and settled for 1 s).
pub fn cruising(params: &MotionParams, body: &Body, speed: f32) -> (MotionPlayer, RootState) {
    let mut player = MotionPlayer::new();
    let mut root = RootState {
        speed,
        ..RootState::default()
    };
    player.push(MotionRequest::Swim { speed }).unwrap();
    record(&mut player, params, body, &mut root, 1.0, 120.0);
    (player, root)
}

/// Peak-to-peak range of a series.
pub fn peak_to_peak(values: impl Iterator<Item = f32>) -> f32 {
    let (lo, hi) = values.fold((f32::INFINITY, f32::NEG_INFINITY), |(lo, hi), v| {
        (lo.min(v), hi.max(v))
    });
    hi - lo
}

/// Frequency, hertz, of a periodic series from its upward zero crossings (about its mean).
pub fn frequency_hz(series: &[f32], dt: f32) -> f32 {
    let mean = series.iter().sum::<f32>() / series.len() as f32;
    let crossings: Vec<f32> = series
        .windows(2)
        .enumerate()
        .filter(|(_, w)| w[0] - mean < 0.0 && w[1] - mean >= 0.0)
        .map(|(i, w)| {
            // Linear interpolation of the crossing time.
            let a = w[0] - mean;
            let b = w[1] - mean;
            (i as f32 + a / (a - b)) * dt
        })
        .collect();
    if crossings.len() < 2 {
        return 0.0;
    }
    (crossings.len() - 1) as f32 / (crossings[crossings.len() - 1] - crossings[0])
}

/// Signed smallest difference b − a of two angles, radians in (−π, π].
pub fn angle_diff(a: f32, b: f32) -> f32 {
    let d = (b - a).rem_euclid(std::f32::consts::TAU);
    if d > std::f32::consts::PI {
        d - std::f32::consts::TAU
    } else {
        d
    }
}
