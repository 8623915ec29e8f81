//! Linear blend skinning (eq. (1)) on a two-joint chain with hand-derived results, and the job's
//! validation.
//!
//! ```text
//!        y
//!        |   v2 (1,1,0): ½ joint 0 + ½ joint 1
//!        |
//!  joint 0 ──── v0 ──── joint 1 ──── v1 ──→ x
//!  (0,0,0)   (0.5,0,0)  (1,0,0)   (1.5,0,0)
//! ```
//! Joint 1 is joint 0's child, one unit along x. Rotating joint 1 by 90° about +z maps
//! v1 → (1, 0.5, 0), v2's joint-1 part → (0, 0, 0) so v2 → (0.5, 0.5, 0), v0 stays.

use glam::{Mat4, Quat, Vec3};
use shoal_core::skeleton::{JointTransform, NO_PARENT, Skeleton};
use shoal_core::skin::{LinearBlendSkinningJob, SkinError, palette, transform_normal};

fn chain() -> Skeleton {
    Skeleton::new(
        vec![NO_PARENT, 0],
        vec!["j0".into(), "j1".into()],
        vec![
            JointTransform::IDENTITY,
            JointTransform {
                translation: Vec3::X,
                ..JointTransform::IDENTITY
            },
        ],
    )
    .unwrap()
}

const POSITIONS: [Vec3; 3] = [
    Vec3::new(0.5, 0.0, 0.0),
    Vec3::new(1.5, 0.0, 0.0),
    Vec3::new(1.0, 1.0, 0.0),
];
const NORMALS: [Vec3; 3] = [Vec3::Y, Vec3::Y, Vec3::X];
const JOINTS: [[u16; 4]; 3] = [[0, 0, 0, 0], [1, 0, 0, 0], [0, 1, 0, 0]];
const WEIGHTS: [[f32; 4]; 3] = [
    [1.0, 0.0, 0.0, 0.0],
    [1.0, 0.0, 0.0, 0.0],
    [0.5, 0.5, 0.0, 0.0],
];

fn skin_chain(root: Mat4, rotation_1: Quat) -> ([Vec3; 3], [Vec3; 3]) {
    let sk = chain();
    let ibms: Vec<Mat4> = sk.rest_models().iter().map(|m| m.inverse()).collect();
    let mut locals = sk.rest_locals().to_vec();
    locals[1].rotation = rotation_1;
    let mut models = [Mat4::IDENTITY; 2];
    sk.local_to_model(root, &locals, &mut models).run().unwrap();
    let mut pal = [Mat4::IDENTITY; 2];
    palette(&models, &ibms, &mut pal).unwrap();
    let mut pos = [Vec3::ZERO; 3];
    let mut nor = [Vec3::ZERO; 3];
    LinearBlendSkinningJob {
        palette: &pal,
        positions_in: &POSITIONS,
        normals_in: &NORMALS,
        joints: &JOINTS,
        weights: &WEIGHTS,
        positions_out: &mut pos,
        normals_out: &mut nor,
    }
    .run()
    .unwrap();
    (pos, nor)
}

fn close(a: Vec3, b: Vec3) -> bool {
    a.distance(b) < 1e-6
}

#[test]
fn rest_pose_is_the_identity() {
    let (pos, nor) = skin_chain(Mat4::IDENTITY, Quat::IDENTITY);
    for k in 0..3 {
        assert!(close(pos[k], POSITIONS[k]));
        assert!(close(nor[k], NORMALS[k]));
    }
}

#[test]
fn rotating_the_child_joint_matches_hand_derivation() {
    let (pos, nor) = skin_chain(
        Mat4::IDENTITY,
        Quat::from_rotation_z(std::f32::consts::FRAC_PI_2),
    );
    assert!(close(pos[0], Vec3::new(0.5, 0.0, 0.0)), "{}", pos[0]);
    assert!(close(pos[1], Vec3::new(1.0, 0.5, 0.0)), "{}", pos[1]);
    assert!(close(pos[2], Vec3::new(0.5, 0.5, 0.0)), "{}", pos[2]);
    // v1's normal +y turns with joint 1 to −x; v2's +x is the blend of +x and +y, normalized.
    assert!(close(nor[1], -Vec3::X), "{}", nor[1]);
    let h = std::f32::consts::FRAC_1_SQRT_2;
    assert!(close(nor[2], Vec3::new(h, h, 0.0)), "{}", nor[2]);
}

#[test]
fn root_transform_moves_everything() {
    let (pos, _) = skin_chain(
        Mat4::from_translation(Vec3::new(0.0, 0.0, 5.0)),
        Quat::IDENTITY,
    );
    for k in 0..3 {
        assert!(close(pos[k], POSITIONS[k] + Vec3::new(0.0, 0.0, 5.0)));
    }
}

#[test]
fn normals_use_the_inverse_transpose_under_non_uniform_scale() {
    // Scaling x by 2: a 45° normal (1,1,0)/√2 becomes (½, 1, 0)/|·| = (0.4472, 0.8944, 0).
    let m = Mat4::from_scale(Vec3::new(2.0, 1.0, 1.0));
    let n = transform_normal(&m, Vec3::new(1.0, 1.0, 0.0).normalize());
    assert!(close(n, Vec3::new(1.0, 2.0, 0.0) / 5f32.sqrt()), "{n}");
    // A mirror keeps normals pointing out of the mirrored surface.
    let n = transform_normal(&Mat4::from_scale(Vec3::new(-1.0, 1.0, 1.0)), Vec3::X);
    assert!(close(n, -Vec3::X), "{n}");
}

#[test]
fn validate_names_every_bad_slice() {
    let pal = [Mat4::IDENTITY; 2];
    let mut pos = [Vec3::ZERO; 3];
    let mut nor = [Vec3::ZERO; 3];
    let err = LinearBlendSkinningJob {
        palette: &pal,
        positions_in: &POSITIONS,
        normals_in: &NORMALS,
        joints: &JOINTS[..2],
        weights: &WEIGHTS,
        positions_out: &mut pos,
        normals_out: &mut nor,
    }
    .validate()
    .unwrap_err();
    assert!(matches!(
        err,
        SkinError::JobSlice {
            what: "joints",
            len: 2,
            expected: 3,
            ..
        }
    ));
    let err = LinearBlendSkinningJob {
        palette: &pal,
        positions_in: &POSITIONS,
        normals_in: &NORMALS,
        joints: &JOINTS,
        weights: &WEIGHTS[..1],
        positions_out: &mut pos,
        normals_out: &mut nor,
    }
    .validate()
    .unwrap_err();
    assert!(matches!(
        err,
        SkinError::JobSlice {
            what: "weights",
            ..
        }
    ));
    let err = LinearBlendSkinningJob {
        palette: &pal,
        positions_in: &POSITIONS,
        normals_in: &NORMALS,
        joints: &JOINTS,
        weights: &WEIGHTS,
        positions_out: &mut pos[..1],
        normals_out: &mut nor,
    }
    .validate()
    .unwrap_err();
    assert!(matches!(
        err,
        SkinError::JobSlice {
            what: "positions_out",
            ..
        }
    ));
    let err = LinearBlendSkinningJob {
        palette: &pal,
        positions_in: &POSITIONS,
        normals_in: &NORMALS,
        joints: &JOINTS,
        weights: &WEIGHTS,
        positions_out: &mut pos,
        normals_out: &mut [],
    }
    .validate()
    .unwrap_err();
    assert!(matches!(
        err,
        SkinError::JobSlice {
            what: "normals_out",
            ..
        }
    ));
    // Positions only is fine.
    LinearBlendSkinningJob {
        palette: &pal,
        positions_in: &POSITIONS,
        normals_in: &[],
        joints: &JOINTS,
        weights: &WEIGHTS,
        positions_out: &mut pos,
        normals_out: &mut [],
    }
    .run()
    .unwrap();
    // A joint outside the palette is an error, not a panic; with weight 0 it is never read.
    let bad = [[0, 7, 0, 0], [1, 0, 0, 0], [0, 1, 0, 0]];
    let err = LinearBlendSkinningJob {
        palette: &pal,
        positions_in: &POSITIONS,
        normals_in: &[],
        joints: &bad,
        weights: &[[0.5, 0.5, 0.0, 0.0], WEIGHTS[1], WEIGHTS[2]],
        positions_out: &mut pos,
        normals_out: &mut [],
    }
    .run()
    .unwrap_err();
    assert!(matches!(
        err,
        SkinError::JointOutOfRange {
            vertex: 0,
            joint: 7,
            num_joints: 2
        }
    ));
    LinearBlendSkinningJob {
        palette: &pal,
        positions_in: &POSITIONS,
        normals_in: &[],
        joints: &bad,
        weights: &WEIGHTS,
        positions_out: &mut pos,
        normals_out: &mut [],
    }
    .run()
    .unwrap();
    let mut out = [Mat4::IDENTITY; 1];
    assert!(matches!(
        palette(&pal, &pal, &mut out),
        Err(SkinError::JobSlice {
            what: "palette",
            ..
        })
    ));
}
