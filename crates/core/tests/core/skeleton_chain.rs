//! The vertebral chain, Euler-angle helpers and forward kinematics, on hand-checkable numbers.

use std::f32::consts::{FRAC_PI_2, FRAC_PI_4};

use glam::{Mat4, Quat, Vec3, Vec4};
use shoal_core::motion::{Body, MidlinePoseJob, MotionPlayer, Preset};
use shoal_core::skeleton::{
    EulerAngles, JointKind, JointTransform, LocalToModelJob, SkeletonError, VertebralChain,
};

fn assert_mat_eq(got: Mat4, want: Mat4, what: &str) {
    assert!(
        got.abs_diff_eq(want, 1e-6),
        "{what}:\n got  {got:?}\n want {want:?}"
    );
}

/// A tiny chain, seen from above (+x right, −z up the page = the fish's left):
///
/// ```text
///             tip (−1, 0, −2)
///              │
///              │ 2
///              │
///   vertebra_1 ●────1────● head (0, 0, 0)   fish faces +x →
///          (−1, 0, 0)
/// ```
///
/// Rest pose: head at the origin, vertebra_1 one unit behind it, tail tip two more behind
/// (body length 3, joints_x = [1/3, 1]). Bending vertebra_1 by 90° to the left swings the tail
/// segment to −z. Ry(−90°) has columns x = (0, 0, 1), y = (0, 1, 0), z = (−1, 0, 0).
#[test]
fn test_forward_kinematics_on_a_tiny_chain() {
    let chain = VertebralChain::new(3.0, &[1.0 / 3.0, 1.0]).unwrap();
    let skeleton = chain.skeleton();
    assert_eq!(skeleton.num_joints(), 3);
    assert_eq!(skeleton.names(), ["head", "vertebra_1", "tail_tip"]);
    assert_eq!(skeleton.kind(0), JointKind::Root);
    assert_eq!(skeleton.kind(1), JointKind::Inner);
    assert_eq!(skeleton.kind(2), JointKind::Leaf);
    assert!((skeleton.bone_lengths()[1] - 1.0).abs() < 1e-6);
    assert!((skeleton.bone_lengths()[2] - 2.0).abs() < 1e-6);

    let mut locals = [JointTransform::IDENTITY; 3];
    chain.pose(&[FRAC_PI_2], &mut locals).run().unwrap();
    let mut models = [Mat4::IDENTITY; 3];
    skeleton
        .local_to_model(Mat4::IDENTITY, &locals, &mut models)
        .run()
        .unwrap();

    assert_mat_eq(models[0], Mat4::IDENTITY, "head");
    let bent = Mat4::from_cols(
        Vec4::new(0.0, 0.0, 1.0, 0.0),
        Vec4::new(0.0, 1.0, 0.0, 0.0),
        Vec4::new(-1.0, 0.0, 0.0, 0.0),
        Vec4::new(-1.0, 0.0, 0.0, 1.0),
    );
    assert_mat_eq(models[1], bent, "vertebra_1");
    let tip = Mat4::from_cols(
        Vec4::new(0.0, 0.0, 1.0, 0.0),
        Vec4::new(0.0, 1.0, 0.0, 0.0),
        Vec4::new(-1.0, 0.0, 0.0, 0.0),
        Vec4::new(-1.0, 0.0, -2.0, 1.0),
    );
    assert_mat_eq(models[2], tip, "tail_tip");

    // Placing the fish in the world: root transform = translate (10, 5, 0), heading 90°
    // (facing −z). The body trails towards +z; the bent tail points to the fish's left, −x.
    let root = Mat4::from_rotation_translation(
        Quat::from_rotation_y(FRAC_PI_2),
        Vec3::new(10.0, 5.0, 0.0),
    );
    skeleton
        .local_to_model(root, &locals, &mut models)
        .run()
        .unwrap();
    assert!(
        models[2]
            .w_axis
            .truncate()
            .abs_diff_eq(Vec3::new(8.0, 5.0, 1.0), 1e-5),
        "{:?}",
        models[2].w_axis
    );
}

/// Euler angles about the column's axes: yaw turns forward (+x) to the left (−z), pitch raises
/// it (+y), roll turns the dorsal axis (+y) to the right (+z); the order is yaw, pitch, roll.
#[test]
fn test_euler_angles_axes_and_round_trip() {
    let yaw = EulerAngles {
        yaw: FRAC_PI_2,
        ..EulerAngles::ZERO
    };
    assert!((yaw.to_quat() * Vec3::X).abs_diff_eq(Vec3::NEG_Z, 1e-6));
    let pitch = EulerAngles {
        pitch: FRAC_PI_2,
        ..EulerAngles::ZERO
    };
    assert!((pitch.to_quat() * Vec3::X).abs_diff_eq(Vec3::Y, 1e-6));
    let roll = EulerAngles {
        roll: FRAC_PI_2,
        ..EulerAngles::ZERO
    };
    assert!((roll.to_quat() * Vec3::Y).abs_diff_eq(Vec3::Z, 1e-6));
    // Yaw 90° then pitch 45°: forward is up-left, (0, sin 45°, −cos 45°).
    let both = EulerAngles {
        yaw: FRAC_PI_2,
        pitch: FRAC_PI_4,
        roll: 0.0,
    };
    let h = std::f32::consts::FRAC_1_SQRT_2;
    assert!((both.to_quat() * Vec3::X).abs_diff_eq(Vec3::new(0.0, h, -h), 1e-6));
    // Same rotation as the motion layer's root: heading then pitch.
    let root = shoal_core::motion::RootState {
        heading: FRAC_PI_2,
        pitch: FRAC_PI_4,
        ..Default::default()
    };
    assert!(root.rotation().abs_diff_eq(both.to_quat(), 1e-6));
    for angles in [
        EulerAngles {
            yaw: 0.3,
            pitch: -0.4,
            roll: 1.1,
        },
        EulerAngles {
            yaw: -2.5,
            pitch: 1.2,
            roll: -0.2,
        },
    ] {
        let back = EulerAngles::from_quat(angles.to_quat());
        assert!((back.yaw - angles.yaw).abs() < 1e-5, "{back:?}");
        assert!((back.pitch - angles.pitch).abs() < 1e-5, "{back:?}");
        assert!((back.roll - angles.roll).abs() < 1e-5, "{back:?}");
    }
    // A bend to the left is a negative Euler yaw: the part behind (−x) swings to −z.
    let bend = EulerAngles::from_bend_left(FRAC_PI_2);
    assert!((bend.to_quat() * Vec3::NEG_X).abs_diff_eq(Vec3::NEG_Z, 1e-6));
}

/// One validity test per job, naming every bad input.
#[test]
fn test_chain_and_pose_job_validity() {
    let bad_chains: [(f32, &[f32], &str); 6] = [
        (0.0, &[0.5, 1.0], "body_length[0] = 0"),
        (f32::NAN, &[0.5, 1.0], "body_length[0] = NaN"),
        (1.0, &[0.5, 0.4, 1.0], "joints_x[1] = 0.4"),
        (1.0, &[0.0, 1.0], "joints_x[0] = 0"),
        (1.0, &[0.5, 0.9], "joints_x[1] = 0.9"),
        (1.0, &[1.0], "joints_x[0] = 1"),
    ];
    for (length, joints_x, needle) in bad_chains {
        let err = VertebralChain::new(length, joints_x)
            .unwrap_err()
            .to_string();
        assert!(err.contains(needle), "{err} should name {needle}");
    }
    assert!(
        VertebralChain::new(1.0, &[])
            .unwrap_err()
            .to_string()
            .contains("joints_x[0] = nothing")
    );

    let chain = VertebralChain::black_porgy(50.0).unwrap();
    assert_eq!(chain.num_driven(), 6);
    assert_eq!(chain.skeleton().num_joints(), 8);
    let bends = [0.1; 6];
    let mut locals = [JointTransform::IDENTITY; 8];
    assert!(chain.pose(&bends, &mut locals).validate().is_ok());
    let err = chain.pose(&bends[..5], &mut locals).validate().unwrap_err();
    assert_eq!(
        err,
        SkeletonError::SliceLength {
            what: "bend_left",
            len: 5,
            expected: 6
        }
    );
    let mut short = [JointTransform::IDENTITY; 7];
    let err = chain.pose(&bends, &mut short).validate().unwrap_err();
    assert_eq!(
        err.to_string(),
        "locals has 7 entries, expected 8 (one per joint)"
    );
    let nan = [0.1, 0.1, f32::NAN, 0.1, 0.1, 0.1];
    let err = chain.pose(&nan, &mut locals).run().unwrap_err().to_string();
    assert_eq!(err, "bend_left[2] = NaN: joint angles must be finite");
    let mut job = chain.pose(&bends, &mut locals);
    job.head_yaw = f32::INFINITY;
    assert!(
        job.validate()
            .unwrap_err()
            .to_string()
            .contains("head_yaw[0] = inf")
    );
    let mut job = chain.pose(&bends, &mut locals);
    job.head_lateral = f32::NAN;
    assert!(
        job.validate()
            .unwrap_err()
            .to_string()
            .contains("head_lateral")
    );
    let mut job = chain.pose(&bends, &mut locals);
    job.rest_locals = &[JointTransform::IDENTITY; 2];
    assert!(matches!(
        job.validate(),
        Err(SkeletonError::SliceLength {
            what: "rest_locals",
            ..
        })
    ));

    // LocalToModelJob names each slice.
    let parents = chain.skeleton().parents();
    let mut models = [Mat4::IDENTITY; 8];
    let err = LocalToModelJob {
        skeleton_parents: parents,
        root: Mat4::IDENTITY,
        locals: &locals[..7],
        models: &mut models,
    }
    .run()
    .unwrap_err();
    assert_eq!(
        err.to_string(),
        "locals has 7 entries, expected 8 (one per joint)"
    );
    let err = LocalToModelJob {
        skeleton_parents: parents,
        root: Mat4::IDENTITY,
        locals: &locals,
        models: &mut models[..3],
    }
    .run()
    .unwrap_err();
    assert_eq!(
        err.to_string(),
        "models has 3 entries, expected 8 (one per joint)"
    );
}

/// The skeleton, posed with the motion player's yaws and placed by its root, puts every joint
/// where the motion layer's own midline forward kinematics does: the two layers agree on signs,
/// axes and the head's recoil, through a whole quick turn.
#[test]
fn test_posed_skeleton_matches_motion_midline() {
    let preset = Preset::by_name("ex3").unwrap();
    let params = preset.params;
    let body = Body::black_porgy();
    let chain = VertebralChain::new(params.l, &body.joints_x).unwrap();
    let mut player = MotionPlayer::new();
    player.push(preset.request().unwrap()).unwrap();
    let mut root = preset.initial_root();
    let mut lateral = [0.0; 7];
    let mut yaw = [0.0; 6];
    let mut locals = [JointTransform::IDENTITY; 8];
    let mut models = [Mat4::IDENTITY; 8];
    let mut points = [Vec3::ZERO; 8];
    for step in 0..180 {
        player.step(
            1.0 / 60.0,
            &params,
            &body,
            &mut root,
            &mut lateral,
            &mut yaw,
        );
        let mut job = chain.pose(&yaw, &mut locals);
        job.head_lateral = player.head_lateral();
        job.head_yaw = player.head_yaw();
        job.run().unwrap();
        let placement = Mat4::from_rotation_translation(root.rotation(), root.pos);
        chain
            .skeleton()
            .local_to_model(placement, &locals, &mut models)
            .run()
            .unwrap();
        MidlinePoseJob {
            root: &root,
            body: &body,
            l: params.l,
            head_lateral: player.head_lateral(),
            head_yaw: player.head_yaw(),
            yaw: &yaw,
            points: &mut points,
        }
        .run()
        .unwrap();
        for (joint, point) in points.iter().enumerate() {
            let got = models[joint].w_axis.truncate();
            assert!(
                got.abs_diff_eq(*point, 1e-3),
                "step {step}, joint {joint}: skeleton {got}, midline {point}"
            );
        }
    }
}
