//! `shoal skin`: skin every skinned primitive of a glTF file's default scene in a pose and write
//! the scene-space positions as JSON.

use std::collections::BTreeMap;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;
use glam::Quat;

use shoal_core::skin::{GltfScene, PoseRotations, PosedPrimitive};

/// Arguments of `shoal skin`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// The model (.gltf or .glb).
    #[arg(long)]
    pub model: PathBuf,
    /// A pose: `{"joints": {"<joint node name>": {"rotation": [x, y, z, w]}}}`; each entry
    /// replaces that node's local rotation. Without it, the rest pose.
    #[arg(long)]
    pub pose: Option<PathBuf>,
    /// Output JSON: `{"primitives": [{"node", "mesh", "primitive", "positions"}]}`.
    #[arg(long)]
    pub out: PathBuf,
}

#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct PoseFile {
    joints: BTreeMap<String, JointPose>,
}

#[derive(Debug, serde::Deserialize)]
#[serde(deny_unknown_fields)]
struct JointPose {
    rotation: [f32; 4],
}

#[derive(Debug, serde::Serialize)]
struct Output<'a> {
    primitives: &'a [PosedPrimitive],
}

/// Reads a pose file into node-name → rotation.
pub fn read_pose(path: &std::path::Path) -> anyhow::Result<PoseRotations> {
    let text = std::fs::read_to_string(path)
        .with_context(|| format!("reading pose {}", path.display()))?;
    let pose: PoseFile = serde_json::from_str(&text).with_context(|| {
        format!(
            "{}: expected {{\"joints\": {{NAME: {{\"rotation\": [x, y, z, w]}}}}}}",
            path.display()
        )
    })?;
    Ok(pose
        .joints
        .into_iter()
        .map(|(name, j)| (name, Quat::from_array(j.rotation)))
        .collect())
}

/// Runs `shoal skin`.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let scene = GltfScene::load(&args.model)?;
    for w in &scene.warnings {
        eprintln!("warning: {w}");
    }
    let locals = match &args.pose {
        Some(p) => scene.posed_locals(&read_pose(p)?)?,
        None => scene.rest_locals(),
    };
    let primitives = scene.pose_scene(&locals)?;
    let json = serde_json::to_string(&Output {
        primitives: &primitives,
    })?;
    if let Some(dir) = args.out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    std::fs::write(&args.out, json).with_context(|| format!("writing {}", args.out.display()))?;
    let vertices: usize = primitives.iter().map(|p| p.positions.len()).sum();
    println!(
        "wrote {}: {} primitives, {vertices} vertices",
        args.out.display(),
        primitives.len()
    );
    Ok(ExitCode::SUCCESS)
}
