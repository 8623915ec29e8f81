//! GPU skinning (the WGSL function the vertex shader uses, run through the renderer's read-back
//! compute pass) against a CPU linear-blend-skinning reference written here from eq. (1):
//! v' = Σ_n w_n · (M_n · v).

use crate::common;
use crate::common::UploadPorgy as _;

use glam::{Mat4, Quat, Vec3};
use shoal_render::testmesh::TestFish;
use shoal_render::{Gpu, MeshUpload, OffscreenTarget, Renderer};

/// CPU reference, eq. (1), one vertex.
fn cpu_skin(position: [f32; 3], joints: [u16; 4], weights: [f32; 4], palette: &[Mat4]) -> Vec3 {
    let v = Vec3::from(position);
    joints
        .iter()
        .zip(weights)
        .map(|(&j, w)| palette[j as usize].transform_point3(v) * w)
        .sum()
}

fn gpu() -> Gpu {
    Gpu::headless().expect("a GPU adapter (lavapipe in CI: apt install mesa-vulkan-drivers)")
}

/// A little two-bone strip (ASCII: joints at x = 0 and x = 1, vertices at x = 0, 0.5, 1, 1.5):
///
/// ```text
///   y=1  v1 ── v3 ── v5 ── v7
///        |  \  |  \  |  \  |
///   y=0  v0 ── v2 ── v4 ── v6
///        j0         j1
/// ```
/// Weights: x = 0 → j0 only; x = 0.5 → 0.75/0.25; x = 1 → 0.5/0.5; x = 1.5 → j1 only.
#[test]
fn gpu_skinning_matches_cpu_lbs_on_a_two_bone_strip() {
    let xs = [0.0f32, 0.5, 1.0, 1.5];
    let w0 = [1.0f32, 0.75, 0.5, 0.0];
    let mut positions = Vec::new();
    let mut joints = Vec::new();
    let mut weights = Vec::new();
    for (x, w) in xs.iter().zip(w0) {
        for y in [0.0, 1.0] {
            positions.push([*x, y, 0.0]);
            joints.push([0u16, 1, 0, 0]);
            weights.push([w, 1.0 - w, 0.0, 0.0]);
        }
    }
    let n = positions.len();
    let indices: Vec<u32> = (0..3u32)
        .flat_map(|i| {
            let a = 2 * i;
            [a, a + 2, a + 1, a + 1, a + 2, a + 3]
        })
        .collect();
    let mesh = MeshUpload {
        label: "strip",
        positions: &positions,
        normals: &vec![[0.0, 0.0, 1.0]; n],
        colors: &vec![[1.0; 4]; n],
        joints: &joints,
        weights: &weights,
        indices: &indices,
        uvs: &[],
        tangents: &[],
        materials: &[],
        parts: &[],
    };
    // Palette at offset 3 (first three entries are decoys that must not be used).
    let decoy = Mat4::from_scale(Vec3::splat(100.0));
    let m0 = Mat4::from_translation(Vec3::new(10.0, 0.0, 0.0));
    let m1 = Mat4::from_rotation_translation(Quat::from_rotation_z(0.5), Vec3::new(0.0, 2.0, 0.0))
        * Mat4::from_translation(Vec3::new(-1.0, 0.0, 0.0));
    let palette = [decoy, decoy, decoy, m0, m1];

    let gpu = gpu();
    let mut renderer = Renderer::new(&gpu, OffscreenTarget::FORMAT).unwrap();
    let id = renderer.upload_mesh(&gpu, &mesh).unwrap();
    let skinned = renderer.skin_positions(&gpu, id, &palette, 3).unwrap();
    assert_eq!(skinned.len(), n);
    #[allow(clippy::needless_range_loop)]
    for i in 0..n {
        let want = cpu_skin(positions[i], joints[i], weights[i], &palette[3..]);
        assert!(
            (skinned[i] - want).length() < 1e-4,
            "vertex {i}: GPU {:?} vs CPU {want:?}",
            skinned[i]
        );
    }
    // Hand-derived: v0 = (0,0,0) is on j0 only → translated by (10,0,0).
    assert!((skinned[0] - Vec3::new(10.0, 0.0, 0.0)).length() < 1e-5);
    // v6 = (1.5,0,0) on j1 only → rotate (0.5,0,0) by 0.5 rad about z, then +(0,2,0).
    let want6 = Vec3::new(0.5 * 0.5f32.cos(), 2.0 + 0.5 * 0.5f32.sin(), 0.0);
    assert!((skinned[6] - want6).length() < 1e-5, "{:?}", skinned[6]);
}

#[test]
fn gpu_skinning_matches_cpu_lbs_on_the_procedural_fish_in_a_swimming_pose() {
    let fish = TestFish::demo();
    let nj = fish.num_joints();
    // Two fish in one flat palette: check the second (non-zero offset).
    let yaws: Vec<f32> = (0..nj).map(|j| 0.15 * (j as f32 * 0.9).sin()).collect();
    let mut palette = vec![Mat4::IDENTITY; 2 * nj];
    let root = Mat4::from_rotation_translation(
        Quat::from_rotation_y(1.1) * Quat::from_rotation_z(0.2),
        Vec3::new(30.0, 80.0, -20.0),
    );
    fish.palette(Mat4::IDENTITY, &vec![0.0; nj], &mut palette[..nj]);
    fish.palette(root, &yaws, &mut palette[nj..]);

    let gpu = gpu();
    let mut renderer = Renderer::new(&gpu, OffscreenTarget::FORMAT).unwrap();
    let id = renderer.upload_mesh(&gpu, &fish.upload()).unwrap();
    let skinned = renderer
        .skin_positions(&gpu, id, &palette, nj as u32)
        .unwrap();
    let mut max_err = 0.0f32;
    let mut max_move = 0.0f32;
    for (i, gpu_pos) in skinned.iter().enumerate() {
        let want = cpu_skin(
            fish.positions[i],
            fish.joints[i],
            fish.weights[i],
            &palette[nj..],
        );
        max_err = max_err.max((*gpu_pos - want).length());
        max_move = max_move.max((want - Vec3::from(fish.positions[i])).length());
    }
    // Positions are ~100 units from the origin: f32 agreement to 1e-3 units.
    assert!(max_err < 1e-3, "max GPU-CPU difference {max_err}");
    assert!(
        max_move > 10.0,
        "the pose must actually move vertices ({max_move})"
    );
}

#[test]
fn skin_read_back_rejects_a_short_palette() {
    let fish = TestFish::demo();
    let gpu = gpu();
    let mut renderer = Renderer::new(&gpu, OffscreenTarget::FORMAT).unwrap();
    let id = renderer.upload_mesh(&gpu, &fish.upload()).unwrap();
    let palette = vec![Mat4::IDENTITY; fish.num_joints() - 1];
    let err = renderer.skin_positions(&gpu, id, &palette, 0).unwrap_err();
    assert!(err.to_string().contains("palette"), "{err}");
}

/// The same comparison against the skin layer's CPU reference job (eq. 1 in `skin::lbs`).
#[test]
fn gpu_skinning_matches_the_skin_layers_cpu_job() {
    use shoal_core::skin::LinearBlendSkinningJob;
    let fish = TestFish::demo();
    let nj = fish.num_joints();
    let yaws: Vec<f32> = (0..nj).map(|j| -0.2 * (j as f32 * 0.7).cos()).collect();
    let mut palette = vec![Mat4::IDENTITY; nj];
    let root =
        Mat4::from_rotation_translation(Quat::from_rotation_y(-2.0), Vec3::new(-50.0, 20.0, 70.0));
    fish.palette(root, &yaws, &mut palette);

    let positions: Vec<Vec3> = fish.positions.iter().map(|p| Vec3::from(*p)).collect();
    let normals: Vec<Vec3> = fish.normals.iter().map(|n| Vec3::from(*n)).collect();
    let mut cpu_positions = vec![Vec3::ZERO; positions.len()];
    let mut cpu_normals = vec![Vec3::ZERO; positions.len()];
    LinearBlendSkinningJob {
        palette: &palette,
        positions_in: &positions,
        normals_in: &normals,
        joints: &fish.joints,
        weights: &fish.weights,
        positions_out: &mut cpu_positions,
        normals_out: &mut cpu_normals,
    }
    .run()
    .unwrap();

    let gpu = gpu();
    let mut renderer = Renderer::new(&gpu, OffscreenTarget::FORMAT).unwrap();
    let id = renderer.upload_mesh(&gpu, &fish.upload()).unwrap();
    let skinned = renderer.skin_positions(&gpu, id, &palette, 0).unwrap();
    let max_err = skinned
        .iter()
        .zip(&cpu_positions)
        .map(|(g, c)| (*g - *c).length())
        .fold(0.0f32, f32::max);
    assert!(
        max_err < 1e-3,
        "max GPU vs skin::LinearBlendSkinningJob difference {max_err}"
    );
}

/// A skin-layer `SkinnedMesh` uploads through `MeshUpload::from_skinned_mesh` unchanged.
#[test]
fn skinned_mesh_from_the_skin_layer_uploads_and_skins() {
    let fish = TestFish::demo();
    let mesh = shoal_core::skin::SkinnedMesh {
        positions: fish.positions.iter().map(|p| Vec3::from(*p)).collect(),
        normals: fish.normals.iter().map(|n| Vec3::from(*n)).collect(),
        colors: fish.colors.clone(),
        joints: fish.joints.clone(),
        weights: fish.weights.clone(),
        indices: fish.indices.clone(),
        ..Default::default()
    };
    let upload = MeshUpload::from_skinned_mesh("porgy stand-in", &mesh);
    assert_eq!(upload.positions, &fish.positions[..]);
    assert_eq!(upload.normals, &fish.normals[..]);
    let gpu = gpu();
    let mut renderer = Renderer::new(&gpu, OffscreenTarget::FORMAT).unwrap();
    let id = renderer.upload_mesh(&gpu, &upload).unwrap();
    let shift = Mat4::from_translation(Vec3::new(0.0, 5.0, 0.0));
    let palette = vec![shift; fish.num_joints()];
    let skinned = renderer.skin_positions(&gpu, id, &palette, 0).unwrap();
    for (g, p) in skinned.iter().zip(&mesh.positions) {
        assert!((*g - (*p + Vec3::Y * 5.0)).length() < 1e-4);
    }
}

/// GPU skinning of the generated black porgy (30 joints, ~5.6k triangles) in a swimming pose
/// against the skin layer's CPU job.
#[test]
fn gpu_skinning_matches_the_skin_layer_on_the_black_porgy_asset() {
    use shoal_core::skin::LinearBlendSkinningJob;
    let rig = common::PosedPorgy::load();
    let driven = rig.rig.body.num_joints();
    let yaw: Vec<f32> = (0..driven).map(|j| 0.3 * (j as f32 * 1.2).sin()).collect();
    let mut palette = vec![Mat4::IDENTITY; rig.num_joints()];
    let root =
        Mat4::from_rotation_translation(Quat::from_rotation_y(0.7), Vec3::new(10.0, 60.0, -5.0));
    rig.palette(root, &yaw, &mut palette);

    let mesh = &rig.model.mesh;
    let n = mesh.num_vertices();
    let mut cpu_positions = vec![Vec3::ZERO; n];
    let mut cpu_normals = vec![Vec3::ZERO; n];
    LinearBlendSkinningJob {
        palette: &palette,
        positions_in: &mesh.positions,
        normals_in: &mesh.normals,
        joints: &mesh.joints,
        weights: &mesh.weights,
        positions_out: &mut cpu_positions,
        normals_out: &mut cpu_normals,
    }
    .run()
    .unwrap();

    let gpu = gpu();
    let mut renderer = Renderer::new(&gpu, OffscreenTarget::FORMAT).unwrap();
    let id = renderer.upload_mesh(&gpu, &rig.upload()).unwrap();
    let skinned = renderer.skin_positions(&gpu, id, &palette, 0).unwrap();
    assert_eq!(skinned.len(), n);
    let max_err = skinned
        .iter()
        .zip(&cpu_positions)
        .map(|(g, c)| (*g - *c).length())
        .fold(0.0f32, f32::max);
    // The fish is 50 units long ~60 units from the origin: agreement to 1e-3 units.
    assert!(
        max_err < 1e-3,
        "max GPU vs CPU difference {max_err} over {n} vertices"
    );
    let spread = cpu_positions
        .iter()
        .map(|p| (*p - cpu_positions[0]).length())
        .fold(0.0f32, f32::max);
    assert!(
        spread > 30.0,
        "the posed fish should span its body length ({spread})"
    );
}
