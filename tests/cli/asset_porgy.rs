//! The generated black porgy and eel: deterministic bytes, the committed files are current, the
//! Khronos validator accepts them, the paper's 30 joints / ~5,695 polygons, sound weights, and a
//! species binds and bends them the right way.

use std::path::PathBuf;

use glam::Vec3;
use shoal_core::asset::{DRIVEN_JOINTS, JOINT_NAMES};
use shoal_core::skeleton::JointTransform;
use shoal_core::skin::FishModel;
use shoal_core::species::{
    EEL_DRIVEN_JOINTS, SpeciesDesc, SpeciesError, SpeciesRig, generated_joint_names,
};

use crate::common;

fn repo(path: &str) -> PathBuf {
    shoal_core::source_root().join(path)
}

#[test]
fn generated_files_are_deterministic_and_committed() {
    let a = shoal_core::asset::black_porgy_glb();
    let b = shoal_core::asset::black_porgy_glb();
    assert_eq!(a, b, "two runs differ");
    let committed = std::fs::read(repo("assets/black_porgy.glb")).unwrap();
    assert!(
        committed == a,
        "assets/black_porgy.glb is stale: run `shoal asset porgy --out assets/black_porgy.glb`"
    );
    let eel = std::fs::read(repo("assets/eel.glb")).unwrap();
    assert!(
        eel == shoal_core::asset::eel_glb(),
        "assets/eel.glb is stale: run `shoal asset eel --out assets/eel.glb`"
    );
}

#[test]
fn generated_files_pass_the_khronos_validator() {
    common::validate(&[&repo("assets/black_porgy.glb"), &repo("assets/eel.glb")]);
}

fn check_weights(model: &FishModel) {
    for (v, (w, j)) in model
        .mesh
        .weights
        .iter()
        .zip(&model.mesh.joints)
        .enumerate()
    {
        let sum: f32 = w.iter().sum();
        assert!((sum - 1.0).abs() < 1e-6, "vertex {v} weights sum to {sum}");
        assert!(w.iter().all(|x| *x >= 0.0));
        assert!(
            j.iter()
                .all(|&k| usize::from(k) < model.skeleton.num_joints())
        );
    }
}

#[test]
fn porgy_has_the_papers_skeleton_and_polygon_budget() {
    let model = FishModel::load(&repo("assets/black_porgy.glb")).unwrap();
    assert!(model.warnings.is_empty(), "{:?}", model.warnings);
    assert_eq!(model.skeleton.num_joints(), 30);
    let mut names: Vec<&str> = model.skeleton.names().iter().map(String::as_str).collect();
    names.sort();
    let mut expected = JOINT_NAMES.to_vec();
    expected.sort();
    assert_eq!(names, expected);
    let tris = model.mesh.num_triangles();
    assert!((5000..=6500).contains(&tris), "{tris} triangles");
    check_weights(&model);
    // The vertebral chain root → spine_1 → … → spine_6 → tail_end: 7 segments, 6 driven joints.
    let sk = &model.skeleton;
    let parent = |n: &str| sk.names()[usize::from(sk.parents()[sk.find(n).unwrap()])].clone();
    assert_eq!(parent("spine_1"), "root");
    for k in 2..=6 {
        assert_eq!(parent(&format!("spine_{k}")), format!("spine_{}", k - 1));
    }
    assert_eq!(parent("tail_end"), "spine_6");
    // Faces +Z, up +Y: the snout is the +Z extreme; the body is deeper than wide.
    let max = model
        .mesh
        .positions
        .iter()
        .fold(Vec3::NEG_INFINITY, |m, p| m.max(*p));
    let min = model
        .mesh
        .positions
        .iter()
        .fold(Vec3::INFINITY, |m, p| m.min(*p));
    let snout = sk.rest_models()[sk.find("snout").unwrap()]
        .w_axis
        .truncate();
    assert!((snout.z - max.z).abs() < 1e-3);
    assert!((max.z - min.z - 1.0).abs() < 1e-3, "total length 1");
    let depth = max.y - min.y;
    let width = max.x - min.x;
    assert!(
        depth > 0.45 && width < 0.3,
        "deep and compressed: depth {depth}, width {width}"
    );
    // Countershading: on the mid-body flank (no fins there), the back is darker than the belly.
    let mean_lum = |keep: &dyn Fn(Vec3) -> bool| {
        let (mut sum, mut n) = (0.0, 0);
        for (p, c) in model.mesh.positions.iter().zip(&model.mesh.colors) {
            if p.z > -0.1 && p.z < -0.02 && p.x.abs() > 0.02 && keep(*p) {
                sum += c[0] + c[1] + c[2];
                n += 1;
            }
        }
        assert!(n > 5);
        sum / n as f32
    };
    let back = mean_lum(&|p| p.y > 0.1);
    let belly = mean_lum(&|p| p.y < -0.1);
    assert!(back < 0.5 * belly, "back {back}, belly {belly}");
}

#[test]
fn eel_is_long_and_slender_with_a_finer_chain() {
    let model = FishModel::load(&repo("assets/eel.glb")).unwrap();
    assert!(model.warnings.is_empty(), "{:?}", model.warnings);
    // The porgy's joints with a chain of EEL_DRIVEN_JOINTS (12) driven joints instead of 6:
    // root → spine_1 → … → spine_12 → tail_end, the caudal joints on the last one.
    let n = EEL_DRIVEN_JOINTS;
    assert_eq!(model.skeleton.num_joints(), 30 + n - 6);
    let mut names: Vec<&str> = model.skeleton.names().iter().map(String::as_str).collect();
    names.sort();
    let mut expected: Vec<String> = generated_joint_names(n).map(|s| s.into_owned()).collect();
    expected.sort();
    assert_eq!(names, expected);
    let sk = &model.skeleton;
    let parent = |n: &str| sk.names()[usize::from(sk.parents()[sk.find(n).unwrap()])].clone();
    assert_eq!(parent("spine_1"), "root");
    for k in 2..=n {
        assert_eq!(parent(&format!("spine_{k}")), format!("spine_{}", k - 1));
    }
    for leaf in ["tail_end", "caudal_upper_1", "caudal_lower_1"] {
        assert_eq!(parent(leaf), format!("spine_{n}"));
    }
    check_weights(&model);
    let max = model
        .mesh
        .positions
        .iter()
        .fold(Vec3::NEG_INFINITY, |m, p| m.max(*p));
    let min = model
        .mesh
        .positions
        .iter()
        .fold(Vec3::INFINITY, |m, p| m.min(*p));
    assert!((max.y - min.y) < 0.15, "slender");
    let rig = SpeciesRig::bind(&SpeciesDesc::eel(), &model).unwrap();
    let porgy = SpeciesRig::bind(
        &SpeciesDesc::black_porgy(),
        &FishModel::load(&repo("assets/black_porgy.glb")).unwrap(),
    )
    .unwrap();
    // The eel's driven joints start further forward than the porgy's, and lie closer together
    // behind its second joint (no segment longer than 0.07 L from there to the tail tip).
    assert!(rig.body.joints_x[0] < porgy.body.joints_x[0] - 0.08);
    assert_eq!(rig.num_driven(), n);
    assert!(
        rig.body.joints_x[1..]
            .windows(2)
            .all(|w| w[1] - w[0] < 0.07),
        "{:?}",
        rig.body.joints_x
    );
}

#[test]
fn porgy_binds_as_a_species() {
    let model = FishModel::load(&repo("assets/black_porgy.glb")).unwrap();
    let desc = SpeciesDesc::black_porgy();
    let rig = SpeciesRig::bind(&desc, &model).unwrap();
    assert_eq!(rig.num_driven(), 6);
    assert_eq!(rig.body.joints_x.len(), 7);
    assert_eq!(*rig.body.joints_x.last().unwrap(), 1.0);
    // The generator puts spine_k at these fractions of the length from the snout.
    let expected = [0.30, 0.41, 0.51, 0.60, 0.68, 0.76];
    for (x, e) in rig.body.joints_x.iter().zip(expected) {
        assert!((x - e).abs() < 1e-3, "{x} vs {e}");
    }
    assert_eq!(rig.body.power.len(), 6);
    assert!(
        rig.body.power.windows(2).all(|w| w[0] <= w[1]),
        "power rises tailwards"
    );
    // Asset +Z forward, +Y up.
    assert!(
        rig.model_forward.abs_diff_eq(Vec3::Z, 1e-3),
        "{}",
        rig.model_forward
    );
    assert!(rig.model_up.abs_diff_eq(Vec3::Y, 1e-3));
    // model_to_body: snout → origin, tail tip → (−l, ·, ·), left (+X asset) → −z body.
    let m = rig.model_to_body;
    let origin = m.inverse().transform_point3(Vec3::ZERO);
    assert!(
        (origin.z - 0.5).abs() < 1e-4 && origin.x.abs() < 1e-4,
        "{origin}"
    );
    let tail = m.transform_point3(Vec3::new(0.0, origin.y, -0.5));
    assert!(
        tail.abs_diff_eq(Vec3::new(-desc.motion.l, 0.0, 0.0), 1e-3),
        "{tail}"
    );
    let left = m.transform_vector3(Vec3::X);
    assert!(
        left.z < 0.0 && left.x.abs() < 1e-4 && left.y.abs() < 1e-4,
        "{left}"
    );
    let up = m.transform_vector3(Vec3::Y);
    assert!(up.y > 0.0 && up.x.abs() < 1e-4, "{up}");
}

#[test]
fn positive_yaw_bends_the_tail_to_the_left_and_leaves_the_head() {
    let model = FishModel::load(&repo("assets/black_porgy.glb")).unwrap();
    let rig = SpeciesRig::bind(&SpeciesDesc::black_porgy(), &model).unwrap();
    let rest = common::skin(&model, model.skeleton.rest_locals());
    let mut locals = vec![JointTransform::IDENTITY; model.skeleton.num_joints()];
    let mut yaw = [0.0f32; 6];
    yaw[2] = 0.4; // spine_3, mid body
    rig.pose(&yaw, &mut locals);
    let bent = common::skin(&model, &locals);
    let x3 = rig.body.joints_x[2];
    let mut tail_moves = 0.0f32;
    let mut n_tail = 0;
    for (v, (a, b)) in rest.iter().zip(&bent).enumerate() {
        let f = 0.5 - a.z; // fraction of length from the snout
        if f < x3 - 0.08 {
            assert!(a.distance(*b) < 1e-5, "head vertex {v} moved");
        }
        if f > 0.85 {
            tail_moves += b.x - a.x; // asset +X is the fish's left
            n_tail += 1;
        }
    }
    let mean = tail_moves / n_tail as f32;
    assert!(n_tail > 0 && mean > 0.05, "tail moved left by {mean}");
    // Zero yaw is the rest pose; the pose writes every joint.
    rig.pose(&[0.0; 6], &mut locals);
    assert_eq!(locals, model.skeleton.rest_locals());
}

#[test]
fn binding_names_missing_joints_and_bad_order() {
    let model = FishModel::load(&repo("assets/black_porgy.glb")).unwrap();
    let mut desc = SpeciesDesc::black_porgy();
    desc.vertebral_joints[3] = "spine_9".into();
    let err = SpeciesRig::bind(&desc, &model).unwrap_err();
    assert!(matches!(&err, SpeciesError::MissingJoint { joint, .. } if joint == "spine_9"));
    let text = err.to_string();
    assert!(
        text.contains("spine_9") && text.contains("tail_end") && text.contains("dorsal_1"),
        "{text}"
    );
    let mut desc = SpeciesDesc::black_porgy();
    desc.vertebral_joints.reverse();
    assert!(matches!(
        SpeciesRig::bind(&desc, &model),
        Err(SpeciesError::JointOrder { .. })
    ));
    let mut desc = SpeciesDesc::black_porgy();
    desc.motion.l = f32::NAN;
    assert!(matches!(
        SpeciesRig::bind(&desc, &model),
        Err(SpeciesError::InvalidField {
            field: "motion.l",
            ..
        })
    ));
    assert_eq!(DRIVEN_JOINTS.len(), 6);
    // Six driven joints name the porgy's joints exactly.
    assert!(
        generated_joint_names(6).eq(JOINT_NAMES.iter().map(|&n| std::borrow::Cow::Borrowed(n)))
    );
    // More follow spine_6; fewer drop the missing spine_k.
    let names = |n| generated_joint_names(n).collect::<Vec<_>>();
    let eight = names(8);
    let at = eight.iter().position(|n| n == "spine_6").unwrap();
    assert_eq!(eight.len(), 32);
    assert_eq!(eight[at + 1..at + 3], ["spine_7", "spine_8"]);
    let four = names(4);
    assert_eq!(four.len(), 28);
    assert!(!four.iter().any(|n| n == "spine_5" || n == "spine_6"));
}

#[test]
fn species_desc_reads_from_json_with_defaults() {
    let json = r#"{"name": "porgy2", "asset": "black_porgy.glb",
        "vertebral_joints": ["spine_1", "spine_2"],
        "motion": {"p": 0.4, "s": 50, "l": 50, "max_amp": 8, "lambda": 50, "omega": 3.75,
                   "tt": 2, "f": 1, "turn_angle": 1.57}}"#;
    let d: SpeciesDesc = serde_json::from_str(json).unwrap();
    assert_eq!(d.drives, shoal_core::species::Drives::default());
    assert_eq!(d.color_tint, None);
    assert!(!d.predator);
    assert!(d.view_range > 0.0 && d.max_speed > 0.0);
    d.validate().unwrap();
    let eel = SpeciesDesc::eel();
    let round: SpeciesDesc = serde_json::from_str(&serde_json::to_string(&eel).unwrap()).unwrap();
    assert_eq!(round, eel);
}

/// Every triangle's winding (counter-clockwise = front, glTF) agrees with its vertex normals, so
/// back-face culling keeps the visible side; and body normals point away from the body's axis.
#[test]
fn generated_faces_wind_outwards() {
    for file in ["assets/black_porgy.glb", "assets/eel.glb"] {
        let model = FishModel::load(&repo(file)).unwrap();
        let (p, n) = (&model.mesh.positions, &model.mesh.normals);
        let mut disagree = 0;
        for t in model.mesh.indices.chunks_exact(3) {
            let [a, b, c] = [t[0] as usize, t[1] as usize, t[2] as usize];
            let face = (p[b] - p[a]).cross(p[c] - p[a]);
            if face.length() < 1e-12 {
                continue;
            }
            if face.dot(n[a] + n[b] + n[c]) <= 0.0 {
                disagree += 1;
                if disagree < 12 {
                    eprintln!(
                        "{file}: triangle {a},{b},{c} at {} normal {}",
                        (p[a] + p[b] + p[c]) / 3.0,
                        n[a]
                    );
                }
            }
        }
        assert_eq!(
            disagree, 0,
            "{file}: {disagree} triangles wound against their normals"
        );
        // Mid-body flank vertices (|x| well off the median plane) face outwards in x.
        let mut outward = 0;
        let mut total = 0;
        for (q, m) in p.iter().zip(n) {
            if q.z.abs() < 0.05 && q.x.abs() > 0.015 {
                total += 1;
                if m.x * q.x > 0.0 {
                    outward += 1;
                }
            }
        }
        assert!(
            total > 10 && outward == total,
            "{file}: {outward}/{total} flank normals outward"
        );
    }
}

/// `shoal asset preview --swim` without `--yaw` shows the fish swimming: its eight top views
/// differ (with the old default of 0 rad they were eight identical straight fish).
#[test]
fn swim_preview_without_yaw_shows_a_moving_tail() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("swim.png");
    let status = std::process::Command::new(env!("CARGO_BIN_EXE_shoal"))
        .args(["asset", "preview", "--model"])
        .arg(repo("assets/black_porgy.glb"))
        .args(["--swim", "--size", "96", "--out"])
        .arg(&out)
        .status()
        .unwrap();
    assert!(status.success());
    let sheet = image::open(&out).unwrap().to_rgb8();
    let panel = |k: u32| {
        image::imageops::crop_imm(&sheet, k % 4 * 96, k / 4 * 96, 96, 96)
            .to_image()
            .into_raw()
    };
    let first = panel(0);
    let differing = (1..8).filter(|&k| panel(k) != first).count();
    assert!(
        differing >= 6,
        "only {differing} of 7 views differ from the first"
    );
}
