//! In GPU pose mode the motion stage moves the roots only and the GPU pass samples each body's
//! shape: the world must still answer every question about the shape (lateral, yaws, a fish's
//! palette) exactly as a world that computed it on the CPU, and a world switched back to the CPU
//! (or restored from a GPU-mode snapshot) must continue as if it never left.

use crate::common;

use glam::Mat4;
use shoal_core::motion::{MotionRequest, Side, TurnKind};
use shoal_core::world::{PoseMode, TICK_HZ, World};

const DT: f32 = (1.0 / TICK_HZ) as f32;

fn bits(v: &[f32]) -> Vec<u32> {
    v.iter().map(|x| x.to_bits()).collect()
}

/// Turns of every kind, given to a few fish at a time, so shapes cross-fade and turn waves run.
fn steer(w: &mut World, tick: usize) {
    let kinds = [TurnKind::Quick, TurnKind::Normal, TurnKind::Serial];
    let ids: Vec<_> = w.fish_ids().collect();
    for (k, id) in ids.iter().enumerate() {
        if (tick + 7 * k).is_multiple_of(50) {
            let turn = MotionRequest::Turn {
                kind: kinds[(k + tick / 50) % kinds.len()],
                angle: 0.9,
                side: if k % 2 == 0 { Side::Left } else { Side::Right },
            };
            w.request(*id, turn, true).unwrap();
        }
    }
}

fn tick(w: &mut World, t: usize) {
    steer(w, t);
    w.step_motion(DT);
    w.update_pose();
}

fn palettes_of(w: &World) -> Vec<Vec<Mat4>> {
    w.fish_ids()
        .map(|id| {
            let mut p = Vec::new();
            assert!(w.joint_palette(id, &mut p));
            p
        })
        .collect()
}

#[test]
fn a_world_posed_on_the_gpu_derives_the_shapes_a_cpu_world_stores() {
    let mut cpu = common::porgy_and_eel_world();
    let mut gpu = common::porgy_and_eel_world();
    gpu.set_pose_mode(PoseMode::Gpu);
    let mut compared = 0;
    let mut records_before = Vec::new();
    for t in 0..240 {
        tick(&mut cpu, t);
        tick(&mut gpu, t);
        assert!(gpu.poses_on_gpu() && !cpu.poses_on_gpu());
        // The roots do not depend on where the shape is sampled.
        for id in cpu.fish_ids() {
            assert_eq!(cpu.root(id), gpu.root(id), "tick {t}");
        }
        if t % 15 != 14 {
            continue;
        }
        for id in cpu.fish_ids() {
            let (lc, lg) = (cpu.lateral(id).unwrap(), gpu.lateral(id).unwrap());
            assert_eq!(bits(&lc), bits(&lg), "tick {t} fish {id:?} lateral");
            let (yc, yg) = (cpu.yaw(id).unwrap(), gpu.yaw(id).unwrap());
            assert_eq!(bits(&yc), bits(&yg), "tick {t} fish {id:?} yaw");
            assert!(yc.iter().any(|&y| y != 0.0), "the fish swim bent");
        }
        for (c, g) in palettes_of(&cpu).iter().zip(&palettes_of(&gpu)) {
            for (a, b) in c.iter().zip(g) {
                assert!(a.abs_diff_eq(*b, 1e-3), "tick {t}: {a} against {b}");
            }
        }
        // The records carry the shape's terms, which move from tick to tick.
        let records = gpu.gpu_pose_records().to_vec();
        assert_eq!(records.len(), 20);
        assert_ne!(records, records_before);
        records_before = records;
        compared += 1;
    }
    assert_eq!(compared, 16);
    // Back on the CPU, the world is the CPU world: stored shapes, the players' head recoil and
    // the palettes, bit for bit.
    gpu.set_pose_mode(PoseMode::Cpu);
    gpu.update_pose();
    assert!(gpu.gpu_pose_records().is_empty());
    assert_eq!(gpu.palettes(), cpu.palettes());
    assert!(
        gpu.snapshot() == cpu.snapshot(),
        "states differ after the switch"
    );
    // And both run on together.
    for t in 240..300 {
        tick(&mut cpu, t);
        tick(&mut gpu, t);
    }
    assert_eq!(gpu.palettes(), cpu.palettes());
    assert!(gpu.snapshot() == cpu.snapshot());
}

#[test]
fn a_snapshot_taken_in_gpu_mode_restores_into_a_cpu_world() {
    let mut cpu = common::porgy_and_eel_world();
    let mut gpu = common::porgy_and_eel_world();
    gpu.set_pose_mode(PoseMode::Gpu);
    for t in 0..90 {
        tick(&mut cpu, t);
        tick(&mut gpu, t);
    }
    // The GPU world's stored shapes are stale: its snapshot is not the CPU world's.
    let taken = gpu.snapshot();
    assert!(taken != cpu.snapshot());
    let mut restored = common::porgy_and_eel_world();
    restored.restore(taken).unwrap();
    restored.update_pose();
    assert_eq!(restored.palettes(), cpu.palettes());
    assert!(restored.snapshot() == cpu.snapshot());
}

/// The records are the state's, whatever the last motion stage saw: a world restored to another
/// state at the same tick, or given a new fish between its motion and pose stages, writes the
/// records a world that holds that state writes. (A cache of the motion stage's shape terms was
/// tried and measured no faster; this guards any later one.)
#[test]
fn records_follow_the_state_not_the_last_motion_stage() {
    let mut a = common::porgy_and_eel_world();
    let mut b = common::porgy_and_eel_world();
    a.set_pose_mode(PoseMode::Gpu);
    b.set_pose_mode(PoseMode::Gpu);
    for t in 0..60 {
        tick(&mut a, t);
        // B turns other fish at other times: at tick 60 its players differ from A's.
        tick(&mut b, t + 25);
    }
    assert_eq!(a.tick_count(), b.tick_count());
    assert_ne!(a.gpu_pose_records(), b.gpu_pose_records());
    b.restore(a.snapshot()).unwrap();
    b.update_pose();
    assert_eq!(a.gpu_pose_records(), b.gpu_pose_records());
    // After a motion stage, a fish spawned before the pose stage gets a record of its own.
    tick(&mut a, 60);
    a.step_motion(DT);
    let first = a.fish_ids().next().unwrap();
    let spawn = shoal_core::world::SpawnParams {
        species: a.species_of(first).unwrap(),
        pos: a.root(first).unwrap().pos,
        heading: 1.0,
        pitch: 0.0,
        speed: 30.0,
        behavior: None,
        seed: 77,
    };
    a.spawn(spawn).unwrap();
    a.update_pose();
    let records = a.gpu_pose_records();
    assert_eq!(records.len(), 21);
    let mut fresh = common::porgy_and_eel_world();
    fresh.restore(a.snapshot()).unwrap();
    fresh.set_pose_mode(PoseMode::Gpu);
    fresh.update_pose();
    assert_eq!(fresh.gpu_pose_records(), records);
}

/// `World::advance` writes the GPU records, the anchors and the crowd columns' headings in the
/// motion pass: a world ticked with it must stay bit for bit the world ticked through the three
/// stages one after another, in either pose mode, with crowd queries asked (so the columns are
/// filled from the headings the motion pass wrote) and not.
#[test]
fn advance_is_motion_then_pose_then_grid_in_either_pose_mode() {
    for mode in [PoseMode::Gpu, PoseMode::Cpu] {
        let mut staged = common::porgy_and_eel_world();
        let mut fused = common::porgy_and_eel_world();
        staged.set_pose_mode(mode);
        fused.set_pose_mode(mode);
        let mut crowds_seen = 0;
        for t in 0..240 {
            steer(&mut staged, t);
            steer(&mut fused, t);
            // Crowd queries for the first half only: the columns are filled, then dropped.
            let ask = t < 120;
            let ids: Vec<_> = staged.fish_ids().collect();
            for &id in &ids {
                if ask {
                    let a = staged.steer_crowd(id, 50.0, 200.0, 300.0, 40.0);
                    let b = fused.steer_crowd(id, 50.0, 200.0, 300.0, 40.0);
                    assert_eq!(a, b, "{mode:?} tick {t} fish {id:?}: crowd answers");
                    crowds_seen += usize::from(a.is_some_and(|c| c.alignment.is_some()));
                }
            }
            staged.step_motion(DT);
            staged.update_pose();
            staged.rebuild_grid();
            fused.advance(DT);
            assert_eq!(staged.poses_on_gpu(), mode == PoseMode::Gpu);
            assert_eq!(
                staged.gpu_pose_records(),
                fused.gpu_pose_records(),
                "{mode:?} tick {t}: records"
            );
            assert_eq!(
                staged.pose_anchors(),
                fused.pose_anchors(),
                "{mode:?} tick {t}: anchors"
            );
            assert_eq!(staged.palettes(), fused.palettes(), "{mode:?} tick {t}");
            assert!(staged.snapshot() == fused.snapshot(), "{mode:?} tick {t}");
        }
        assert_eq!(
            fused.gpu_pose_records().len(),
            (mode == PoseMode::Gpu) as usize * 20
        );
        assert!(crowds_seen > 500, "{mode:?}: {crowds_seen} alignments");
    }
}
