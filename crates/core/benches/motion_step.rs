//! Criterion benchmark of one fish's `MotionPlayer::step` (6 driven joints, 60 Hz), swimming and
//! turning: the per-fish cost of the motion layer in the 10,000-fish scale target.
//!
//! Run with `cargo bench --bench motion_step`.

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use shoal_core::motion::{
    Body, MotionParams, MotionPlayer, MotionRequest, RootState, Side, TurnKind,
};

fn step(c: &mut Criterion) {
    let params = MotionParams::default();
    let body = Body::black_porgy();
    let mut lateral = [0.0f32; 7];
    let mut yaw = [0.0f32; 6];
    let turn = MotionRequest::Turn {
        kind: TurnKind::Serial,
        angle: std::f32::consts::FRAC_PI_2,
        side: Side::Left,
    };
    for (name, keep_turning) in [("swim", false), ("turning", true)] {
        let mut player = MotionPlayer::new();
        let mut root = RootState {
            speed: 50.0,
            ..RootState::default()
        };
        player.push(MotionRequest::Swim { speed: 50.0 }).unwrap();
        player.step(
            1.0 / 60.0,
            &params,
            &body,
            &mut root,
            &mut lateral,
            &mut yaw,
        );
        c.bench_function(&format!("motion_step/{name}"), |b| {
            b.iter(|| {
                // Queue the next turn as soon as one ends (the queue reuses its storage).
                if keep_turning && player.queue_len() == 0 && player.current_name() == "swim" {
                    player.push(turn).unwrap();
                }
                player.step(
                    black_box(1.0 / 60.0),
                    &params,
                    &body,
                    &mut root,
                    &mut lateral,
                    &mut yaw,
                );
                black_box(yaw[5])
            })
        });
    }
}

criterion_group!(benches, step);
criterion_main!(benches);
