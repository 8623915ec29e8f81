//! Malformed, unsupported and quirky input: every problem is an error naming the file (or one
//! warning where shoal can go on), and nothing panics — including truncated and bit-flipped
//! copies of the shared samples.

use std::path::{Path, PathBuf};

use glam::{Mat4, Vec3};
use serde_json::{Value, json};
use shoal_core::asset::GlbBuilder;
use shoal_core::skin::{FishModel, GltfScene, SkinError};

const FLOAT: u32 = 5126;
const UNSIGNED_BYTE: u32 = 5121;
const UNSIGNED_SHORT: u32 = 5123;

fn sample(name: &str) -> PathBuf {
    shoal_core::source_root()
        .join("../shared/gltf-samples")
        .join(name)
}

/// A chain of `n` joints j0 → j1 → … one unit apart along x (IBMs = inverse rest), and one
/// skinned mesh whose primitives `prims` writes with the builder.
fn chain_file(n: usize, prims: impl FnOnce(&mut GlbBuilder) -> Value) -> Vec<u8> {
    let mut b = GlbBuilder::new();
    let primitives = prims(&mut b);
    let ibms: Vec<Mat4> = (0..n)
        .map(|j| Mat4::from_translation(Vec3::new(-(j as f32), 0.0, 0.0)))
        .collect();
    let ibm = b.mat4s(&ibms);
    let mut nodes = vec![json!({"name": "mesh", "mesh": 0, "skin": 0})];
    for j in 0..n {
        let mut node = json!({"name": format!("j{j}"), "translation": [if j == 0 { 0.0 } else { 1.0 }, 0.0, 0.0]});
        if j + 1 < n {
            node["children"] = json!([j + 2]);
        }
        nodes.push(node);
    }
    b.finish(json!({
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": nodes,
        "meshes": [{"primitives": primitives}],
        "skins": [{"joints": (1..=n).collect::<Vec<_>>(), "inverseBindMatrices": ibm}]
    }))
}

fn load(bytes: &[u8], name: &str) -> Result<FishModel, SkinError> {
    let scene = GltfScene::from_bytes(bytes, Path::new(name))?;
    FishModel::from_scene(&scene)
}

fn tri(b: &mut GlbBuilder) -> usize {
    b.positions(&[Vec3::ZERO, Vec3::X, Vec3::Y])
}

fn f32_bytes(v: &[f32]) -> Vec<u8> {
    v.iter().flat_map(|f| f.to_le_bytes()).collect()
}

#[test]
fn weights_off_by_a_sum_warn_once_per_primitive_and_renormalize() {
    let bytes = chain_file(2, |b| {
        let mut prims = Vec::new();
        for _ in 0..2 {
            let pos = tri(b);
            let j = b.joints(&[[0, 1, 0, 0]; 3]);
            let w = b.vec4s(&[[0.5, 0.2, 0.0, 0.0]; 3]);
            prims.push(json!({"attributes": {"POSITION": pos, "JOINTS_0": j, "WEIGHTS_0": w}}));
        }
        json!(prims)
    });
    let model = load(&bytes, "sums.glb").unwrap();
    let sum_warnings: Vec<&String> = model
        .warnings
        .iter()
        .filter(|w| w.contains("do not sum to 1"))
        .collect();
    assert_eq!(sum_warnings.len(), 2, "{:?}", model.warnings);
    assert!(sum_warnings[0].contains("sums.glb") && sum_warnings[0].contains("3 of 3"));
    for w in &model.mesh.weights {
        assert!(
            (w[0] - 0.5 / 0.7).abs() < 1e-6 && (w[1] - 0.2 / 0.7).abs() < 1e-6,
            "{w:?}"
        );
    }
    // Non-indexed primitives become 0..n, merged with an offset.
    assert_eq!(model.mesh.indices, [0, 1, 2, 3, 4, 5]);
}

#[test]
fn joints_1_keeps_the_four_strongest_of_eight() {
    let bytes = chain_file(8, |b| {
        let pos = tri(b);
        let j0 = b.joints(&[[0, 1, 2, 3]; 3]);
        let w0 = b.vec4s(&[[0.05, 0.1, 0.15, 0.05]; 3]);
        let j1 = b.joints(&[[4, 5, 6, 7]; 3]);
        let w1 = b.vec4s(&[[0.2, 0.25, 0.1, 0.1]; 3]);
        json!([{"attributes": {"POSITION": pos, "JOINTS_0": j0, "WEIGHTS_0": w0,
                                "JOINTS_1": j1, "WEIGHTS_1": w1}}])
    });
    let model = load(&bytes, "eight.glb").unwrap();
    let name = |j: u16| model.skeleton.names()[usize::from(j)].clone();
    let joints: Vec<String> = model.mesh.joints[0].iter().map(|&j| name(j)).collect();
    // 0.25 (j5), 0.2 (j4), 0.15 (j2), then the first 0.1 met (j1); kept sum 0.7.
    assert_eq!(joints, ["j5", "j4", "j2", "j1"]);
    let w = model.mesh.weights[0];
    let expected = [0.25 / 0.7, 0.2 / 0.7, 0.15 / 0.7, 0.1 / 0.7];
    for k in 0..4 {
        assert!((w[k] - expected[k]).abs() < 1e-6, "{w:?}");
    }
    assert!(
        model
            .warnings
            .iter()
            .any(|w| w.contains("beyond the 4 strongest"))
    );
    assert!(
        !model.warnings.iter().any(|w| w.contains("do not sum")),
        "sum was 1 before dropping"
    );
}

#[test]
fn u8_joints_with_normalized_u16_weights() {
    let bytes = chain_file(2, |b| {
        let pos = tri(b);
        let j = b.raw_accessor(&[1u8, 0, 0, 0].repeat(3), UNSIGNED_BYTE, 3, "VEC4", false);
        let w: Vec<u8> = [65535u16, 0, 0, 0]
            .iter()
            .flat_map(|x| x.to_le_bytes())
            .collect();
        let w = b.raw_accessor(&w.repeat(3), UNSIGNED_SHORT, 3, "VEC4", true);
        json!([{"attributes": {"POSITION": pos, "JOINTS_0": j, "WEIGHTS_0": w}}])
    });
    let model = load(&bytes, "u16.glb").unwrap();
    // 65535 normalized is exactly 1: no renormalization warning (only the computed normals).
    assert_eq!(model.warnings.len(), 1, "{:?}", model.warnings);
    assert!(model.warnings[0].contains("no normals"));
    assert!(
        model
            .mesh
            .normals
            .iter()
            .all(|n| (n.length() - 1.0).abs() < 1e-5)
    );
    assert_eq!(model.mesh.weights[0], [1.0, 0.0, 0.0, 0.0]);
    assert_eq!(
        model.skeleton.names()[usize::from(model.mesh.joints[0][0])],
        "j1"
    );
    // IBM = inverse rest, so the rest pose is the bind shape.
    assert_eq!(model.mesh.positions[1], Vec3::X);
}

#[test]
fn joint_index_beyond_the_skin_is_an_error() {
    let bytes = chain_file(2, |b| {
        let pos = tri(b);
        let j = b.joints(&[[5, 0, 0, 0]; 3]);
        let w = b.vec4s(&[[1.0, 0.0, 0.0, 0.0]; 3]);
        json!([{"attributes": {"POSITION": pos, "JOINTS_0": j, "WEIGHTS_0": w}}])
    });
    let err = load(&bytes, "joints.glb").unwrap_err().to_string();
    assert!(
        err.contains("joints.glb") && err.contains("joint") && err.contains("2 joints"),
        "{err}"
    );
}

#[test]
fn negative_or_nan_weights_are_errors() {
    let bytes = chain_file(2, |b| {
        let pos = tri(b);
        let j = b.joints(&[[0, 1, 0, 0]; 3]);
        let w = b.raw_accessor(
            &f32_bytes(&[1.0, f32::NAN, 0.0, 0.0].repeat(3)),
            FLOAT,
            3,
            "VEC4",
            false,
        );
        json!([{"attributes": {"POSITION": pos, "JOINTS_0": j, "WEIGHTS_0": w}}])
    });
    let err = load(&bytes, "nan.glb").unwrap_err();
    assert!(
        matches!(&err, SkinError::Accessor { what, .. } if what.contains("WEIGHTS_0")),
        "{err}"
    );
}

#[test]
fn accessor_past_its_buffer_view_is_an_error() {
    let text = std::fs::read_to_string(sample("SimpleSkin.gltf")).unwrap();
    let mut json: Value = serde_json::from_str(&text).unwrap();
    json["accessors"][1]["count"] = json!(1000); // POSITION
    let bytes = serde_json::to_vec(&json).unwrap();
    let err = load(&bytes, "bad_accessor.gltf").unwrap_err();
    let msg = err.to_string();
    assert!(
        matches!(err, SkinError::Accessor { accessor: 1, .. }),
        "{msg}"
    );
    assert!(
        msg.contains("bad_accessor.gltf") && msg.contains("POSITION"),
        "{msg}"
    );
}

#[test]
fn draco_is_refused_by_name() {
    let text = std::fs::read_to_string(sample("SimpleSkin.gltf")).unwrap();
    let mut json: Value = serde_json::from_str(&text).unwrap();
    json["extensionsUsed"] = json!(["KHR_draco_mesh_compression"]);
    json["extensionsRequired"] = json!(["KHR_draco_mesh_compression"]);
    let err = load(&serde_json::to_vec(&json).unwrap(), "draco.gltf").unwrap_err();
    assert!(
        matches!(&err, SkinError::UnsupportedExtension { extension, .. } if extension == "KHR_draco_mesh_compression")
    );
    assert!(err.to_string().contains("draco.gltf"));
}

#[test]
fn morph_targets_only_and_no_skin_are_named() {
    let text = std::fs::read_to_string(sample("SimpleSkin.gltf")).unwrap();
    let mut json: Value = serde_json::from_str(&text).unwrap();
    json["nodes"][0].as_object_mut().unwrap().remove("skin");
    let plain = serde_json::to_vec(&json).unwrap();
    let err = load(&plain, "plain.gltf").unwrap_err().to_string();
    assert!(
        err.contains("plain.gltf") && err.contains("no skinned mesh") && err.contains("rig"),
        "{err}"
    );
    json["meshes"][0]["primitives"][0]["targets"] = json!([{"POSITION": 1}]);
    let err = load(&serde_json::to_vec(&json).unwrap(), "morph.gltf")
        .unwrap_err()
        .to_string();
    assert!(err.contains("morph targets"), "{err}");
}

#[test]
fn missing_file_and_garbage_name_the_file() {
    let err = FishModel::load(Path::new("/nonexistent/fish.glb"))
        .unwrap_err()
        .to_string();
    assert!(err.contains("/nonexistent/fish.glb"), "{err}");
    let err = load(b"not a gltf file", "garbage.gltf")
        .unwrap_err()
        .to_string();
    assert!(err.contains("garbage.gltf"), "{err}");
    let err = load(b"glTF\x02\x00\x00\x00\x10\x00\x00\x00", "short.glb")
        .unwrap_err()
        .to_string();
    assert!(err.contains("short.glb"), "{err}");
}

/// Deterministic xorshift so the fuzz cases are the same every run.
fn next(state: &mut u64) -> u64 {
    *state ^= *state << 13;
    *state ^= *state >> 7;
    *state ^= *state << 17;
    *state
}

#[test]
fn truncated_and_flipped_samples_never_panic() {
    for name in ["RiggedSimple.glb", "SimpleSkin.gltf", "RiggedFigure.glb"] {
        let original = std::fs::read(sample(name)).unwrap();
        let mut state = 0x9E37_79B9_7F4A_7C15u64;
        let mut cases: Vec<Vec<u8>> = Vec::new();
        for k in 1..40 {
            cases.push(original[..original.len() * k / 40].to_vec());
        }
        for _ in 0..150 {
            let mut bytes = original.clone();
            for _ in 0..(1 + next(&mut state) % 4) {
                let at = (next(&mut state) % bytes.len() as u64) as usize;
                bytes[at] ^= 1 << (next(&mut state) % 8);
            }
            cases.push(bytes);
        }
        let mut errors = 0;
        for bytes in &cases {
            match load(bytes, name) {
                Ok(model) => {
                    // Whatever loads must still be consistent.
                    assert_eq!(model.mesh.joints.len(), model.mesh.positions.len());
                    assert!(
                        model
                            .mesh
                            .indices
                            .iter()
                            .all(|&i| (i as usize) < model.mesh.positions.len())
                    );
                }
                Err(e) => {
                    errors += 1;
                    assert!(e.to_string().contains(name), "{e}");
                }
            }
        }
        assert!(
            errors > 39,
            "{name}: truncations must fail ({errors} errors)"
        );
    }
}
