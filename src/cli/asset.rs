//! `shoal asset`: build the generated fish (`porgy`, `eel`) or rig a static fish mesh (`rig`).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;

/// Arguments of `shoal asset`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// What to build.
    #[command(subcommand)]
    pub what: What,
}

/// What to build.
#[derive(Debug, clap::Subcommand)]
pub enum What {
    /// Generate the black porgy (30 joints, ~5,700 triangles) as a GLB.
    Porgy {
        /// Output file.
        #[arg(long, default_value = "assets/black_porgy.glb")]
        out: PathBuf,
    },
    /// Generate the eel (the porgy's joints with 12 driven ones, long slender body) as a GLB.
    Eel {
        /// Output file.
        #[arg(long, default_value = "assets/eel.glb")]
        out: PathBuf,
    },
    /// Give a static fish mesh (.gltf/.glb) a vertebral chain and smooth skin weights.
    Rig(RigArgs),
    /// Draw a skinned fish (side view above, top view below) to a PNG, optionally bent.
    Preview {
        /// The skinned model (.gltf or .glb).
        #[arg(long)]
        model: PathBuf,
        /// Output PNG.
        #[arg(long)]
        out: PathBuf,
        /// Yaw (radians) applied to every driven joint `spine_*`; positive bends left. Default:
        /// 0 (a straight fish), or 0.25 with `--swim` (a wave you can see).
        #[arg(long, allow_hyphen_values = true)]
        yaw: Option<f32>,
        /// Panel size in pixels.
        #[arg(long, default_value_t = 512)]
        size: u32,
        /// Instead: a sheet of 8 top views over one tail beat of a travelling wave whose joint
        /// yaws peak at `--yaw` (a quick look at the fish swimming).
        #[arg(long)]
        swim: bool,
    },
    /// Write a species script for a rigged model (scripts/species/NAME.lua), its motion
    /// suggested from the body's shape, and print a scene snippet.
    Species(SpeciesArgs),
}

/// Arguments of `shoal asset species`.
#[derive(Debug, clap::Args)]
pub struct SpeciesArgs {
    /// The rigged model (.gltf/.glb with joints spine_1 …, e.g. from `shoal asset rig`).
    #[arg(long)]
    pub model: PathBuf,
    /// Species name: letters, digits and underscores (also the file name).
    #[arg(long)]
    pub name: String,
    /// The project folder holding scripts/ and assets/ (default: the current project).
    #[arg(long)]
    pub root: Option<PathBuf>,
    /// Overwrite an existing scripts/species/NAME.lua.
    #[arg(long)]
    pub force: bool,
}

/// Arguments of `shoal asset rig`.
#[derive(Debug, clap::Args)]
pub struct RigArgs {
    /// The static mesh (.gltf or .glb).
    #[arg(long = "in")]
    pub input: PathBuf,
    /// The rigged GLB to write.
    #[arg(long)]
    pub out: PathBuf,
    /// Vertebral chain joints, root included (2 to 64): root, spine_1 … spine_{N−1}; a leaf
    /// tail_end is added. 7 gives the paper's 7 segments with 6 driven joints.
    #[arg(long, default_value_t = 7)]
    pub joints: usize,
    /// The body's long axis: auto (principal axis of the vertices), x, y or z.
    #[arg(long, default_value = "auto")]
    pub axis: String,
    /// Which end of the long axis is the head: auto (the blunter, thicker end), + or -.
    #[arg(long, default_value = "auto", allow_hyphen_values = true)]
    pub head: String,
}

fn write(out: &PathBuf, bytes: &[u8]) -> anyhow::Result<()> {
    if let Some(dir) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    }
    std::fs::write(out, bytes).with_context(|| format!("writing {}", out.display()))
}

/// Runs `shoal asset`.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    match args.what {
        What::Porgy { out } => {
            let bytes = shoal_core::asset::black_porgy_glb();
            write(&out, &bytes)?;
            println!("wrote {} ({} bytes)", out.display(), bytes.len());
        }
        What::Eel { out } => {
            let bytes = shoal_core::asset::eel_glb();
            write(&out, &bytes)?;
            println!("wrote {} ({} bytes)", out.display(), bytes.len());
        }
        What::Rig(rig) => {
            let axis = shoal_core::asset::rig::Axis::parse(&rig.axis)?;
            let head = shoal_core::asset::rig::HeadEnd::parse(&rig.head)?;
            let opts = shoal_core::asset::rig::RigOptions {
                num_joints: rig.joints,
                axis,
                head,
            };
            let rigged = shoal_core::asset::rig::rig_file(&rig.input, &opts)?;
            for w in &rigged.warnings {
                eprintln!("warning: {w}");
            }
            write(&rig.out, &rigged.glb)?;
            // Two decimals without a `-0.00` for what is zero at that precision.
            let shown = |v: f32| if v.abs() < 0.005 { 0.0 } else { v };
            println!(
                "wrote {} ({} joints: {}; long axis ({:.2}, {:.2}, {:.2}), head at the {} end)",
                rig.out.display(),
                rigged.joint_names.len(),
                rigged.joint_names.join(", "),
                shown(rigged.axis.x),
                shown(rigged.axis.y),
                shown(rigged.axis.z),
                if rigged.head_positive { "+" } else { "-" }
            );
        }
        What::Preview {
            model,
            out,
            yaw,
            size,
            swim,
        } => {
            let img = if swim {
                // With a peak yaw of 0 all eight views would be the same straight fish.
                swim_sheet(&model, yaw.unwrap_or(SWIM_PREVIEW_YAW), size)?
            } else {
                preview(&model, yaw.unwrap_or(0.0), size)?
            };
            img.save(&out)
                .with_context(|| format!("writing {}", out.display()))?;
            println!("wrote {}", out.display());
        }
        What::Species(args) => species(&args)?,
    }
    Ok(ExitCode::SUCCESS)
}

/// Peak joint yaw of `shoal asset preview --swim` without `--yaw`, radians.
pub const SWIM_PREVIEW_YAW: f32 = 0.25;

/// `shoal asset species`: writes the species script and prints what to add to a scene.
pub fn species(args: &SpeciesArgs) -> anyhow::Result<()> {
    use shoal_core::asset::species_file::{relative_path, suggest};
    let name = &args.name;
    anyhow::ensure!(
        !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || c == '_'),
        "--name {name:?}: use letters, digits and underscores only (it is also the file name)"
    );
    let root = match &args.root {
        Some(root) => root.clone(),
        // The project the scripts come from: ./ when it has scripts/, else the source tree.
        None => super::ScriptsArg::default().resolve()?.root,
    };
    let species_dir = root.join("scripts").join("species");
    anyhow::ensure!(
        species_dir.is_dir(),
        "{}: no such folder; run in the project folder or give --root",
        species_dir.display()
    );
    let out = species_dir.join(format!("{name}.lua"));
    anyhow::ensure!(
        args.force || !out.exists(),
        "{} already exists; pass --force to overwrite it",
        out.display()
    );
    let fish = shoal_core::skin::FishModel::load(&args.model)?;
    for w in &fish.warnings {
        eprintln!("warning: {w}");
    }
    let asset = relative_path(&root.join("assets"), &args.model);
    let suggestion = suggest(name, &asset, &fish)
        .map_err(|e| anyhow::anyhow!("{}: {e}", args.model.display()))?;
    write(&out, suggestion.to_lua(&args.model).as_bytes())?;
    let m = &suggestion.desc.motion;
    println!(
        "wrote {} ({}: length {:.1}× its depth or width; l = {}, p = {:.2}, λ = {})",
        out.display(),
        suggestion.swimming_mode,
        suggestion.slenderness,
        m.l,
        m.p,
        m.lambda
    );
    println!("add to a scene's `fish` list (e.g. scripts/scenes/default.lua):");
    println!("{}", suggestion.scene_snippet());
    Ok(())
}

/// Skins `model` with every `spine_*` joint yawed by `yaw` and draws side and top views.
pub fn preview(model: &std::path::Path, yaw: f32, size: u32) -> anyhow::Result<image::RgbImage> {
    let fish = shoal_core::skin::FishModel::load(model)?;
    for w in &fish.warnings {
        eprintln!("warning: {w}");
    }
    let (rig, _) = preview_rig(model, &fish)?;
    let yaws = vec![yaw; rig.num_driven()];
    let (positions, f, u) = posed(&fish, &rig, &yaws)?;
    use shoal_core::asset::preview::{View, render_views_mesh};
    let right = f.cross(u);
    let views = [
        View { right: -f, up: u },
        View {
            right: -f,
            up: right,
        },
    ];
    Ok(render_views_mesh(&positions, &fish.mesh, &views, size))
}

/// Eight top views over one period of a travelling wave: joint k's yaw is
/// `amplitude · x_k · sin(2π(phase − x_k))` (x_k its position along the body).
pub fn swim_sheet(
    model: &std::path::Path,
    amplitude: f32,
    size: u32,
) -> anyhow::Result<image::RgbImage> {
    use shoal_core::asset::preview::{View, render_views_mesh};
    let fish = shoal_core::skin::FishModel::load(model)?;
    for w in &fish.warnings {
        eprintln!("warning: {w}");
    }
    let (rig, _) = preview_rig(model, &fish)?;
    let mut sheet = image::RgbImage::new(size * 4, size * 2);
    for frame in 0..8u32 {
        let phase = frame as f32 / 8.0;
        let yaws: Vec<f32> = rig.body.joints_x[..rig.num_driven()]
            .iter()
            .map(|&x| amplitude * x * (std::f32::consts::TAU * (phase - x)).sin())
            .collect();
        let (positions, f, u) = posed(&fish, &rig, &yaws)?;
        let views = [View {
            right: -f,
            up: f.cross(u),
        }];
        let img = render_views_mesh(&positions, &fish.mesh, &views, size);
        image::imageops::replace(
            &mut sheet,
            &img,
            i64::from(frame % 4 * size),
            i64::from(frame / 4 * size),
        );
    }
    Ok(sheet)
}

fn preview_rig(
    model: &std::path::Path,
    fish: &shoal_core::skin::FishModel,
) -> anyhow::Result<(shoal_core::species::SpeciesRig, ())> {
    let spines = shoal_core::asset::species_file::spine_joints(fish);
    anyhow::ensure!(
        !spines.is_empty(),
        "{}: no joints named spine_1, spine_2, …; rig it with `shoal asset rig`",
        model.display()
    );
    let mut desc = shoal_core::species::SpeciesDesc::black_porgy();
    desc.vertebral_joints = spines;
    Ok((shoal_core::species::SpeciesRig::bind(&desc, fish)?, ()))
}

/// Skins `fish` with the given driven-joint yaws; returns positions, forward and up.
fn posed(
    fish: &shoal_core::skin::FishModel,
    rig: &shoal_core::species::SpeciesRig,
    yaws: &[f32],
) -> anyhow::Result<(Vec<glam::Vec3>, glam::Vec3, glam::Vec3)> {
    use glam::{Mat4, Vec3};
    let n = fish.skeleton.num_joints();
    let mut locals = fish.skeleton.rest_locals().to_vec();
    rig.pose(yaws, &mut locals);
    let mut models = vec![Mat4::IDENTITY; n];
    fish.skeleton
        .local_to_model(Mat4::IDENTITY, &locals, &mut models)
        .run()?;
    let mut palette = vec![Mat4::IDENTITY; n];
    shoal_core::skin::palette(&models, &fish.inverse_bind_poses, &mut palette)?;
    let mut positions = vec![Vec3::ZERO; fish.mesh.num_vertices()];
    shoal_core::skin::LinearBlendSkinningJob {
        palette: &palette,
        positions_in: &fish.mesh.positions,
        normals_in: &[],
        joints: &fish.mesh.joints,
        weights: &fish.mesh.weights,
        positions_out: &mut positions,
        normals_out: &mut [],
    }
    .run()?;
    Ok((positions, rig.model_forward, rig.model_up))
}
