//! Auto-rigging a real static fish (RedFinnedFish from ../shared/gltf-samples): the result is a
//! valid GLB that loads, binds as a species with the generated chain, and bends sideways.

use std::path::PathBuf;

use shoal_core::asset::rig::{Axis, HeadEnd, RigError, RigOptions, rig_file};
use shoal_core::skin::FishModel;
use shoal_core::species::{SpeciesDesc, SpeciesRig};

use crate::common;

fn red_finned_fish() -> PathBuf {
    shoal_core::source_root().join("../shared/gltf-samples/RedFinnedFish/scene.gltf")
}

#[test]
fn rigged_red_finned_fish_loads_binds_bends_and_validates() {
    let rigged = rig_file(&red_finned_fish(), &RigOptions::default()).unwrap();
    assert_eq!(
        rigged.joint_names,
        [
            "root", "spine_1", "spine_2", "spine_3", "spine_4", "spine_5", "spine_6", "tail_end"
        ]
    );
    assert_eq!(rigged.driven_joints.len(), 6);
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("red_finned_fish.glb");
    std::fs::write(&out, &rigged.glb).unwrap();
    common::validate(&[&out]);

    // The base colour texture and UVs survive.
    let gltf = gltf::Gltf::open(&out).unwrap();
    let material = gltf.materials().next().unwrap();
    assert!(
        material
            .pbr_metallic_roughness()
            .base_color_texture()
            .is_some()
    );
    // So do the normal and metallic-roughness maps, the alpha mode and double-sidedness:
    // three textures, each its own embedded image (issue 15).
    let pbr = material.pbr_metallic_roughness();
    let normal = material.normal_texture().expect("normal map kept");
    let mr = pbr
        .metallic_roughness_texture()
        .expect("metallic-roughness map kept");
    let base = pbr.base_color_texture().unwrap();
    let images: std::collections::BTreeSet<usize> = [
        base.texture().source().index(),
        normal.texture().source().index(),
        mr.texture().source().index(),
    ]
    .into();
    assert_eq!(images.len(), 3);
    assert_eq!(gltf.images().len(), 3);
    assert_eq!(material.alpha_mode(), gltf::material::AlphaMode::Mask);
    assert_eq!(material.alpha_cutoff(), Some(1.0));
    assert!(material.double_sided());
    assert_eq!(pbr.metallic_factor(), 0.0);
    assert!(
        !rigged.warnings.iter().any(|w| w.contains("dropped")),
        "{:?}",
        rigged.warnings
    );
    // The embedded images are the source PNGs, byte for byte.
    let source = std::fs::read(
        red_finned_fish()
            .parent()
            .unwrap()
            .join("textures/Full_Fish_Material_normal.png"),
    )
    .unwrap();
    let blob = gltf.blob.as_ref().unwrap();
    let gltf::image::Source::View { view, .. } = normal.texture().source().source() else {
        panic!("the normal map is not embedded");
    };
    assert_eq!(
        &blob[view.offset()..view.offset() + view.length()],
        &source[..]
    );
    let prim = gltf.meshes().next().unwrap().primitives().next().unwrap();
    assert_eq!(
        prim.get(&gltf::Semantic::TexCoords(0)).unwrap().count(),
        676
    );

    let model = FishModel::load(&out).unwrap();
    assert_eq!(model.skeleton.num_joints(), 8);
    assert_eq!(model.mesh.num_vertices(), 676);
    assert_eq!(model.mesh.indices.len(), 3864);
    let mut desc = SpeciesDesc::black_porgy();
    desc.asset = "red_finned_fish.glb".into();
    desc.vertebral_joints = rigged.driven_joints.clone();
    let rig = SpeciesRig::bind(&desc, &model).unwrap();
    assert!(rig.body.joints_x.windows(2).all(|w| w[0] < w[1]));
    // The chain runs along the long axis: in this file's scene space the fish lies along X.
    assert!(rig.model_forward.x.abs() > 0.99, "{}", rig.model_forward);

    // Bend the middle joint: the tail swings sideways, the head stays.
    let rest = common::skin(&model, model.skeleton.rest_locals());
    let mut locals = model.skeleton.rest_locals().to_vec();
    let mut yaw = vec![0.0; rig.num_driven()];
    let mid = rig.num_driven() / 2;
    yaw[mid] = 0.5;
    rig.pose(&yaw, &mut locals);
    let bent = common::skin(&model, &locals);
    let forward = rig.model_forward;
    let up = rig.model_up;
    let left = up.cross(forward);
    let head_t = rest
        .iter()
        .map(|p| p.dot(forward))
        .fold(f32::NEG_INFINITY, f32::max);
    let len = rig.model_body_length;
    let (mut lateral, mut vertical, mut n) = (0.0f32, 0.0f32, 0);
    for (v, (a, b)) in rest.iter().zip(&bent).enumerate() {
        let x = (head_t - a.dot(forward)) / len;
        if x < rig.body.joints_x[mid] - 0.1 {
            assert!(a.distance(*b) < 1e-4 * len, "head-side vertex {v} moved");
        }
        if x > 0.9 {
            lateral += (*b - *a).dot(left);
            vertical += (*b - *a).dot(up).abs();
            n += 1;
        }
    }
    assert!(n > 0);
    let (lateral, vertical) = (lateral / n as f32 / len, vertical / n as f32 / len);
    assert!(
        lateral > 0.05,
        "tail moved {lateral} body lengths to the left"
    );
    assert!(
        vertical < 0.1 * lateral,
        "the bend is sideways, not up/down ({vertical})"
    );
}

#[test]
fn head_override_and_options() {
    let auto = rig_file(&red_finned_fish(), &RigOptions::default()).unwrap();
    let flipped = rig_file(
        &red_finned_fish(),
        &RigOptions {
            head: if auto.head_positive {
                HeadEnd::Negative
            } else {
                HeadEnd::Positive
            },
            ..RigOptions::default()
        },
    )
    .unwrap();
    assert!(
        (auto.axis + flipped.axis).length() < 1e-5,
        "{} vs {}",
        auto.axis,
        flipped.axis
    );
    let root = |r: &shoal_core::asset::rig::Rigged| r.mesh.joint_positions[0];
    assert!(
        (root(&auto) - root(&flipped)).dot(auto.axis) > 0.0,
        "root moved to the other end"
    );
    let three = rig_file(
        &red_finned_fish(),
        &RigOptions {
            num_joints: 3,
            axis: Axis::X,
            ..RigOptions::default()
        },
    )
    .unwrap();
    assert_eq!(
        three.joint_names,
        ["root", "spine_1", "spine_2", "tail_end"]
    );
    let err = rig_file(
        &red_finned_fish(),
        &RigOptions {
            num_joints: 1,
            ..RigOptions::default()
        },
    )
    .unwrap_err();
    assert!(matches!(err, RigError::Option(_)), "{err}");
    assert!(Axis::parse("w").is_err() && HeadEnd::parse("up").is_err());
}

#[test]
fn rigging_the_generated_fish_finds_their_snouts() {
    // The generated fish face +Z; re-rigging them (their skins ignored) must find the same head.
    for file in ["assets/black_porgy.glb", "assets/eel.glb"] {
        let path = shoal_core::source_root().join(file);
        let rigged = rig_file(&path, &RigOptions::default()).unwrap();
        assert!(
            rigged.axis.abs_diff_eq(glam::Vec3::Z, 1e-6),
            "{file}: {}",
            rigged.axis
        );
        assert!(
            rigged
                .warnings
                .iter()
                .any(|w| w.contains("already skinned"))
        );
        // root sits near the snout (z = +0.5), tail_end at the tail tip (z = −0.5).
        let j = &rigged.mesh.joint_positions;
        assert!(
            j[0].z > 0.3 && (j[j.len() - 1].z + 0.5).abs() < 0.02,
            "{file}: {j:?}"
        );
    }
}
