//! Every shared glTF sample loads and skins correctly (see ../shared/gltf-samples/README.md for
//! the quirk each file exercises). Expected bind shapes are derived by hand from each file's
//! node layout, and raw vertex data is read independently through the `gltf` crate's reader.

use std::path::PathBuf;

use glam::{Mat4, Quat, Vec3};
use shoal_core::skeleton::JointTransform;
use shoal_core::skin::{FishModel, GltfScene, LinearBlendSkinningJob, PoseRotations, palette};

fn sample(name: &str) -> PathBuf {
    shoal_core::source_root()
        .to_path_buf()
        .join("../shared/gltf-samples")
        .join(name)
}

/// Raw POSITION of every primitive of mesh `mesh`, via the gltf crate.
fn raw_positions(name: &str, mesh: usize) -> Vec<Vec3> {
    let (doc, buffers, _) = gltf::import(sample(name)).expect("gltf crate imports the sample");
    let mesh = doc.meshes().nth(mesh).unwrap();
    let mut out = Vec::new();
    for p in mesh.primitives() {
        let r = p.reader(|b| Some(&buffers[b.index()]));
        out.extend(r.read_positions().unwrap().map(Vec3::from));
    }
    out
}

/// Skins `model` with `locals` and returns positions and normals.
fn skin(model: &FishModel, locals: &[JointTransform]) -> (Vec<Vec3>, Vec<Vec3>) {
    let n = model.skeleton.num_joints();
    let mut models = vec![Mat4::IDENTITY; n];
    model
        .skeleton
        .local_to_model(Mat4::IDENTITY, locals, &mut models)
        .run()
        .unwrap();
    let mut pal = vec![Mat4::IDENTITY; n];
    palette(&models, &model.inverse_bind_poses, &mut pal).unwrap();
    let mut pos = vec![Vec3::ZERO; model.mesh.num_vertices()];
    let mut nor = vec![Vec3::ZERO; model.mesh.num_vertices()];
    LinearBlendSkinningJob {
        palette: &pal,
        positions_in: &model.mesh.positions,
        normals_in: &model.mesh.normals,
        joints: &model.mesh.joints,
        weights: &model.mesh.weights,
        positions_out: &mut pos,
        normals_out: &mut nor,
    }
    .run()
    .unwrap();
    (pos, nor)
}

fn assert_close(a: &[Vec3], b: &[Vec3], tol: f32, what: &str) {
    assert_eq!(a.len(), b.len(), "{what}: lengths");
    for (i, (x, y)) in a.iter().zip(b).enumerate() {
        assert!(x.distance(*y) <= tol, "{what}: vertex {i}: {x} vs {y}");
    }
}

/// Rest pose skins to the bind shape; the bind shape is `expected`; a rotation of `joint`
/// moves only vertices weighted by it or its descendants.
fn check_model(model: &FishModel, expected_bind: &[Vec3], joint: usize) {
    let rest = model.skeleton.rest_locals().to_vec();
    let (pos, nor) = skin(model, &rest);
    assert_close(&pos, &model.mesh.positions, 1e-4, "rest pose vs bind shape");
    assert_close(
        &pos,
        expected_bind,
        1e-4,
        "bind shape vs hand-derived scene-space rest",
    );
    for (n, m) in nor.iter().zip(&model.mesh.normals) {
        assert!(n.distance(*m) < 1e-3 || *m == Vec3::ZERO);
    }
    for w in &model.mesh.weights {
        assert!((w.iter().sum::<f32>() - 1.0).abs() < 1e-5);
    }
    // Pose one joint: 60 degrees about an axis.
    let mut posed = rest.clone();
    posed[joint].rotation *= Quat::from_axis_angle(Vec3::new(0.3, 1.0, 0.2).normalize(), 1.0);
    let (moved, _) = skin(model, &posed);
    let mut affected = vec![false; model.skeleton.num_joints()];
    for j in 0..model.skeleton.num_joints() {
        let p = model.skeleton.parents()[j];
        affected[j] =
            j == joint || (p != shoal_core::skeleton::NO_PARENT && affected[usize::from(p)]);
    }
    let mut num_moved = 0;
    for v in 0..pos.len() {
        let influence: f32 = (0..4)
            .filter(|&k| affected[usize::from(model.mesh.joints[v][k])])
            .map(|k| model.mesh.weights[v][k])
            .sum();
        let d = pos[v].distance(moved[v]);
        if influence == 0.0 {
            assert!(
                d < 1e-5,
                "vertex {v} has no weight on joint {joint} but moved {d}"
            );
        } else if d > 1e-4 {
            num_moved += 1;
        }
    }
    assert!(num_moved > 0, "posing joint {joint} moved no vertex");
}

#[test]
fn rigged_simple_gltf_ignores_the_mesh_node_transform() {
    let model = FishModel::load(&sample("RiggedSimple.gltf")).unwrap();
    assert_eq!(model.skeleton.num_joints(), 2);
    assert_eq!(model.mesh.num_vertices(), 160);
    assert_eq!(model.mesh.indices.len(), 564);
    assert_eq!(model.skeleton.names(), ["Bone", "Bone.001"]);
    assert!(
        model
            .warnings
            .iter()
            .any(|w| w.contains("own transform is ignored"))
    );
    // joint·IBM = Z_UP at rest: (x, y, z) → (x, z, −y). Armature's 90° turn must not appear.
    let expected: Vec<Vec3> = raw_positions("RiggedSimple.gltf", 0)
        .iter()
        .map(|p| Vec3::new(p.x, p.z, -p.y))
        .collect();
    check_model(&model, &expected, 1);
}

#[test]
fn rigged_simple_gltf_and_glb_load_the_same() {
    let a = FishModel::load(&sample("RiggedSimple.gltf")).unwrap();
    let b = FishModel::load(&sample("RiggedSimple.glb")).unwrap();
    assert_eq!(a.skeleton.names(), b.skeleton.names());
    assert_eq!(a.mesh.joints, b.mesh.joints);
    assert_eq!(a.mesh.indices, b.mesh.indices);
    assert_eq!(a.mesh.weights, b.mesh.weights);
    // The JSON floats differ in the last digit only.
    assert_close(
        &a.mesh.positions,
        &b.mesh.positions,
        1e-5,
        "gltf vs glb positions",
    );
    for (x, y) in a.inverse_bind_poses.iter().zip(&b.inverse_bind_poses) {
        assert!(x.abs_diff_eq(*y, 1e-5));
    }
    let expected: Vec<Vec3> = raw_positions("RiggedSimple.glb", 0)
        .iter()
        .map(|p| Vec3::new(p.x, p.z, -p.y))
        .collect();
    check_model(&b, &expected, 1);
}

#[test]
fn rigged_figure_joints_index_skin_joints_not_nodes() {
    let model = FishModel::load(&sample("RiggedFigure.glb")).unwrap();
    assert_eq!(model.skeleton.num_joints(), 19);
    assert_eq!(model.mesh.num_vertices(), 370);
    assert_eq!(model.mesh.indices.len(), 768);
    assert_eq!(model.skeleton.names()[0], "torso_joint_1");
    // At rest joint·IBM = the mesh node's global transform (Z_UP); applied once, not twice.
    let expected: Vec<Vec3> = raw_positions("RiggedFigure.glb", 0)
        .iter()
        .map(|p| Vec3::new(p.x, p.z, -p.y))
        .collect();
    let arm = model.skeleton.find("arm_joint_L_1").unwrap();
    check_model(&model, &expected, arm);
    // Up to 4 influences really are used.
    assert!(model.mesh.weights.iter().any(|w| w[2] > 0.0));
}

#[test]
fn simple_skin_shared_strided_view() {
    let model = FishModel::load(&sample("SimpleSkin.gltf")).unwrap();
    assert_eq!(model.skeleton.num_joints(), 2);
    assert_eq!(model.mesh.num_vertices(), 10);
    assert_eq!(model.mesh.indices.len(), 24);
    assert_eq!(model.skeleton.names(), ["joint_0", "joint_1"]);
    // JOINTS_0 (stride 16, shared with WEIGHTS_0): the tutorial's rows are [0,0],[0,0],[0,1]×…
    // with weights 1 at the bottom, blending to joint 1 at the top.
    let weight_on = |v: usize, j: u16| -> f32 {
        (0..4)
            .filter(|&k| model.mesh.joints[v][k] == j)
            .map(|k| model.mesh.weights[v][k])
            .sum()
    };
    let on_joint_1: Vec<f32> = (0..10).map(|v| weight_on(v, 1)).collect();
    assert_eq!(
        on_joint_1,
        [0.0, 0.0, 0.25, 0.25, 0.5, 0.5, 0.75, 0.75, 1.0, 1.0]
    );
    assert_eq!(weight_on(0, 0), 1.0);
    let expected = raw_positions("SimpleSkin.gltf", 0);
    check_model(&model, &expected, 1);
}

#[test]
fn simple_skin_bevy_joints_below_the_mesh_node() {
    let model = FishModel::load(&sample("SimpleSkin_bevy_variant.gltf")).unwrap();
    // The mesh node is an identity root: nothing to ignore, so no such warning.
    assert!(!model.warnings.iter().any(|w| w.contains("own transform")));
    assert_eq!(model.skeleton.num_joints(), 2);
    assert_eq!(model.mesh.num_vertices(), 10);
    // joint·IBM = translate(−0.5, 0, 0) at rest (IBM ≠ inverse rest pose).
    let expected: Vec<Vec3> = raw_positions("SimpleSkin_bevy_variant.gltf", 0)
        .iter()
        .map(|p| *p - Vec3::new(0.5, 0.0, 0.0))
        .collect();
    check_model(&model, &expected, 1);
}

#[test]
fn recursive_skeletons_shared_mesh_u8_interleaved() {
    let path = sample("RecursiveSkeletons.glb");
    let model = FishModel::load(&path).unwrap();
    assert_eq!(model.skeleton.num_joints(), 10);
    assert_eq!(model.mesh.num_vertices(), 40);
    assert_eq!(model.mesh.indices.len(), 228);
    // Independent expectation: the glTF rule with the gltf crate's data for the first skinned
    // node: global(joint) · IBM · v with one influence per vertex.
    let (doc, buffers, _) = gltf::import(&path).unwrap();
    let mut parent = vec![None; doc.nodes().len()];
    for n in doc.nodes() {
        for c in n.children() {
            parent[c.index()] = Some(n.index());
        }
    }
    let global = |mut n: usize| {
        let mut m = Mat4::from_cols_array_2d(&doc.nodes().nth(n).unwrap().transform().matrix());
        while let Some(p) = parent[n] {
            m = Mat4::from_cols_array_2d(&doc.nodes().nth(p).unwrap().transform().matrix()) * m;
            n = p;
        }
        m
    };
    // The first skinned node depth-first in the scene.
    let scene = doc.scenes().next().unwrap();
    let mut stack: Vec<gltf::Node> = scene.nodes().collect();
    stack.reverse();
    let node = loop {
        let n = stack.pop().unwrap();
        if n.skin().is_some() {
            break n;
        }
        let mut c: Vec<_> = n.children().collect();
        c.reverse();
        stack.extend(c);
    };
    let skin = node.skin().unwrap();
    let ibms: Vec<Mat4> = skin
        .reader(|b| Some(&buffers[b.index()]))
        .read_inverse_bind_matrices()
        .unwrap()
        .map(|m| Mat4::from_cols_array_2d(&m))
        .collect();
    let joints: Vec<usize> = skin.joints().map(|j| j.index()).collect();
    let prim = node.mesh().unwrap().primitives().next().unwrap();
    let r = prim.reader(|b| Some(&buffers[b.index()]));
    let pos: Vec<Vec3> = r.read_positions().unwrap().map(Vec3::from).collect();
    let js: Vec<[u16; 4]> = r.read_joints(0).unwrap().into_u16().collect();
    // WEIGHTS_0 is [1, 0, 0, 0] for every vertex (its accessor's min = max); the gltf crate's
    // reader does not iterate it, so the single influence is used directly.
    let expected: Vec<Vec3> = (0..pos.len())
        .map(|v| {
            let j = usize::from(js[v][0]);
            (global(joints[j]) * ibms[j]).transform_point3(pos[v])
        })
        .collect();
    assert!(
        model
            .mesh
            .weights
            .iter()
            .all(|w| *w == [1.0, 0.0, 0.0, 0.0])
    );
    check_model(&model, &expected, 3);

    // The whole scene: 84 skinned nodes share the mesh, each skinned by its own skin.
    let scene = GltfScene::load(&path).unwrap();
    let posed = scene.pose_scene(&scene.rest_locals()).unwrap();
    let skinned = posed
        .iter()
        .filter(|p| scene.nodes[p.node].skin.is_some())
        .count();
    assert_eq!(skinned, 84);
    let meshes: std::collections::BTreeSet<usize> = posed.iter().map(|p| p.mesh).collect();
    assert_eq!(meshes.len(), 1, "one shared mesh");
    let first = posed.iter().find(|p| p.node == node.index()).unwrap();
    let got: Vec<Vec3> = first.positions.iter().map(|p| Vec3::from(*p)).collect();
    assert_close(&got, &expected, 1e-4, "scene skinning of the first node");
}

#[test]
fn red_finned_fish_has_no_skin_but_reads_as_a_scene() {
    let path = sample("RedFinnedFish/scene.gltf");
    let err = FishModel::load(&path).unwrap_err().to_string();
    assert!(
        err.contains("scene.gltf") && err.contains("no skinned mesh"),
        "{err}"
    );
    let scene = GltfScene::load(&path).unwrap();
    let n: usize = scene
        .meshes
        .iter()
        .flat_map(|m| &m.primitives)
        .map(|p| p.positions.len())
        .sum();
    assert_eq!(n, 676);
    let idx: usize = scene
        .meshes
        .iter()
        .flat_map(|m| &m.primitives)
        .map(|p| p.indices.len())
        .sum();
    assert_eq!(idx, 3864);
    // Unskinned nodes are placed by their global transform.
    let posed = scene.pose_scene(&scene.rest_locals()).unwrap();
    assert!(!posed.is_empty());
}

#[test]
fn pose_file_rotation_replaces_a_joint_rotation() {
    // SimpleSkin: rotating joint 1 (unnamed → no name) is not addressable; use RiggedSimple.
    let path = sample("RiggedSimple.gltf");
    let scene = GltfScene::load(&path).unwrap();
    let mut pose = PoseRotations::new();
    pose.insert("Bone.001".into(), Quat::from_rotation_x(0.5));
    let rest = scene.pose_scene(&scene.rest_locals()).unwrap();
    let posed = scene
        .pose_scene(&scene.posed_locals(&pose).unwrap())
        .unwrap();
    let moved = rest[0]
        .positions
        .iter()
        .zip(&posed[0].positions)
        .filter(|(a, b)| Vec3::from(**a).distance(Vec3::from(**b)) > 1e-3)
        .count();
    assert!(moved > 0 && moved < 160, "moved {moved}");
    pose.insert("Nope".into(), Quat::IDENTITY);
    let err = scene.posed_locals(&pose).unwrap_err().to_string();
    assert!(err.contains("Nope") && err.contains("Bone.001"), "{err}");
}
