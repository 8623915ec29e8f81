//! `shoal skin --model FILE [--pose POSE.json] --out OUT.json` on the shared samples, run as a
//! designer runs it.

use std::path::PathBuf;

use serde_json::Value;

fn sample(name: &str) -> PathBuf {
    shoal_core::source_root()
        .join("../shared/gltf-samples")
        .join(name)
}

/// Runs `shoal skin` on a shared sample; the JSON it wrote, or what it printed on failure.
fn skin(model: &str, pose: Option<&str>) -> Result<Value, String> {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out.json");
    let mut cmd = std::process::Command::new(env!("CARGO_BIN_EXE_shoal"));
    cmd.arg("skin")
        .arg("--model")
        .arg(sample(model))
        .arg("--out")
        .arg(&out);
    if let Some(text) = pose {
        let p = dir.path().join("pose.json");
        std::fs::write(&p, text).unwrap();
        cmd.arg("--pose").arg(p);
    }
    let run = cmd.output().expect("the shoal binary runs");
    if !run.status.success() {
        return Err(String::from_utf8_lossy(&run.stderr).into_owned());
    }
    Ok(serde_json::from_str(&std::fs::read_to_string(out).unwrap()).unwrap())
}

fn positions(v: &Value, prim: usize) -> Vec<[f64; 3]> {
    v["primitives"][prim]["positions"]
        .as_array()
        .unwrap()
        .iter()
        .map(|p| {
            [
                p[0].as_f64().unwrap(),
                p[1].as_f64().unwrap(),
                p[2].as_f64().unwrap(),
            ]
        })
        .collect()
}

#[test]
fn every_sample_skins_at_rest() {
    let expect = [
        ("RiggedSimple.gltf", 1, 160),
        ("RiggedSimple.glb", 1, 160),
        ("RiggedFigure.glb", 1, 370),
        ("SimpleSkin.gltf", 1, 10),
        ("SimpleSkin_bevy_variant.gltf", 1, 10),
        ("RecursiveSkeletons.glb", 84, 40),
        ("RedFinnedFish/scene.gltf", 1, 676),
    ];
    for (file, prims, verts) in expect {
        let out = skin(file, None).unwrap();
        let list = out["primitives"].as_array().unwrap();
        assert_eq!(list.len(), prims, "{file}");
        for p in list {
            assert!(p["node"].is_u64() && p["mesh"].is_u64() && p["primitive"].is_u64());
            assert_eq!(p["positions"].as_array().unwrap().len(), verts, "{file}");
        }
    }
    // SimpleSkin at rest: joint·IBM = identity, so positions are the raw ones, x in −0.5..0.5,
    // y in 0..2. The Bevy variant stores x in 0..1 and its IBMs shift by −0.5: same result.
    for file in ["SimpleSkin.gltf", "SimpleSkin_bevy_variant.gltf"] {
        let p = positions(&skin(file, None).unwrap(), 0);
        assert_eq!(p[0], [-0.5, 0.0, 0.0], "{file}");
        assert_eq!(p[1], [0.5, 0.0, 0.0], "{file}");
        assert_eq!(p[9], [0.5, 2.0, 0.0], "{file}");
    }
}

#[test]
fn a_pose_rotation_replaces_the_joint_rotation() {
    // RiggedSimple: rotate Bone.001 by 90° about its local x.
    let h = std::f64::consts::FRAC_1_SQRT_2;
    let pose = format!(r#"{{"joints": {{"Bone.001": {{"rotation": [{h}, 0, 0, {h}]}}}}}}"#);
    let rest = positions(&skin("RiggedSimple.gltf", None).unwrap(), 0);
    let posed = positions(&skin("RiggedSimple.gltf", Some(&pose)).unwrap(), 0);
    let moved = rest
        .iter()
        .zip(&posed)
        .filter(|(a, b)| (0..3).map(|k| (a[k] - b[k]).powi(2)).sum::<f64>().sqrt() > 1e-3)
        .count();
    // The cylinder's upper half follows Bone.001, the lower half stays.
    assert!(moved > 40 && moved < 160, "{moved} vertices moved");
}

#[test]
fn bad_pose_files_are_errors_naming_the_problem() {
    let err = skin(
        "RiggedSimple.gltf",
        Some(r#"{"joints": {"Nope": {"rotation": [0,0,0,1]}}}"#),
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("Nope") && err.contains("Bone"), "{err}");
    let err = skin(
        "RiggedSimple.gltf",
        Some(r#"{"joints": {"Bone": {"rotation": [0,0,0,0]}}}"#),
    )
    .unwrap_err()
    .to_string();
    assert!(err.contains("quaternion"), "{err}");
    let err = format!(
        "{:#}",
        skin(
            "RiggedSimple.gltf",
            Some(r#"{"joints": {"Bone": {"rot": [0,0,0,1]}}}"#)
        )
        .unwrap_err()
    );
    assert!(
        err.contains("pose.json") && err.contains("rotation"),
        "{err}"
    );
}
