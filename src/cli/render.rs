//! `shoal render`: renders a scene headless to a PNG (last frame), a GIF, or a directory of
//! numbered PNGs. Works without a GPU through a software Vulkan adapter (lavapipe).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;

use shoal_app::{DynScene, OverlayToggles, Showable, WorldScene};
use shoal_core::world::bench::bench_world;
use shoal_core::world::driver::{WanderDriver, WanderPipeline};
use shoal_core::world::{Species, SpeciesDesc};
use shoal_render::{Gpu, OffscreenTarget, Renderer};
use shoal_script::Simulation;

/// Arguments of `shoal render`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Scene: a Lua scene (a `.lua` file, or the name of one in `scripts/scenes/`) or `porgies`
    /// (black porgies from `assets/black_porgy.glb`, built-in wander/school behaviour).
    /// Default: `scripts/scenes/default.lua`, else `porgies`.
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Simulated seconds to render.
    #[arg(long, default_value_t = 3.0, allow_negative_numbers = true)]
    pub seconds: f32,
    /// Frames per simulated second.
    #[arg(long, default_value_t = 30)]
    pub fps: u32,
    /// Image size, WIDTHxHEIGHT pixels.
    #[arg(long, default_value = "960x540", value_parser = parse_size)]
    pub size: (u32, u32),
    /// Random seed (overrides the scene's).
    #[arg(long)]
    pub seed: Option<u64>,
    /// Number of fish (`porgies` scene; a Lua scene sets its own).
    #[arg(long)]
    pub fish: Option<usize>,
    /// Output: `*.png` (last frame), `*.gif` (animation) or a directory (numbered PNGs).
    #[arg(long)]
    pub out: PathBuf,
    /// Camera: `default` (the window's start view), `top` (the tank from above), `orbit` (once
    /// around the tank over the clip), `follow` (close on the `--select`ed fish) or a fixed
    /// `EX,EY,EZ:TX,TY,TZ` (eye and target, world units).
    #[arg(long, default_value = "default", value_parser = parse_camera, allow_hyphen_values = true)]
    pub camera: CameraSpec,
    /// Highlight this fish (0-based, as in the window's panel); `--camera follow` follows it.
    #[arg(long)]
    pub select: Option<usize>,
    /// Draw every debug overlay (skeletons, midlines, velocity, sensor ranges).
    #[arg(long)]
    pub overlays: bool,
    /// Largest projected error of a coarser level of detail, pixels (as `bench render`); 0 draws
    /// every fish at full detail.
    #[arg(long, default_value_t = shoal_render::DEFAULT_LOD_TOLERANCE_PX, allow_negative_numbers = true)]
    pub lod_tolerance_px: f32,
    /// Where the scripts come from (`--scripts DIR`, `SHOAL_SCRIPTS`).
    #[command(flatten)]
    pub scripts: super::ScriptsArg,
    /// Behaviour level of detail (`--lod on|off`).
    #[command(flatten)]
    pub lod: super::LodArg,
}

/// Where `shoal render` looks from (see [`Args::camera`]).
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum CameraSpec {
    /// The window's start view.
    Default,
    /// Straight down onto the tank.
    Top,
    /// Once around the tank over the clip.
    Orbit,
    /// Close on the selected fish, following it.
    Follow,
    /// A fixed eye looking at a target, world units.
    Fixed {
        /// Eye position.
        eye: glam::Vec3,
        /// Point looked at.
        target: glam::Vec3,
    },
}

/// Parses [`Args::camera`].
pub fn parse_camera(s: &str) -> anyhow::Result<CameraSpec> {
    match s.trim() {
        "default" => return Ok(CameraSpec::Default),
        "top" => return Ok(CameraSpec::Top),
        "orbit" => return Ok(CameraSpec::Orbit),
        "follow" => return Ok(CameraSpec::Follow),
        _ => {}
    }
    let bad = || {
        anyhow::anyhow!(
            "camera `{s}`: expected default, top, orbit, follow, or EX,EY,EZ:TX,TY,TZ (eye and \
             target, world units)"
        )
    };
    let (eye, target) = s.split_once(':').ok_or_else(bad)?;
    let v3 = |t: &str| -> anyhow::Result<glam::Vec3> {
        let v: Vec<f32> = t
            .split(',')
            .map(|x| x.trim().parse::<f32>().map_err(|_| bad()))
            .collect::<Result<_, _>>()?;
        match v[..] {
            [x, y, z] if v.iter().all(|c| c.is_finite()) => Ok(glam::Vec3::new(x, y, z)),
            _ => Err(bad()),
        }
    };
    let (eye, target) = (v3(eye)?, v3(target)?);
    if (eye - target).length() < 1e-3 {
        anyhow::bail!("camera `{s}`: the eye and the target are the same point");
    }
    Ok(CameraSpec::Fixed { eye, target })
}

/// The camera for frame `frame` of `num_frames` (see [`CameraSpec`]).
pub fn camera_for<S: Showable>(
    spec: CameraSpec,
    scene: &WorldScene<S>,
    select: Option<shoal_core::world::FishId>,
    frame: u64,
    num_frames: u64,
) -> shoal_render::Camera {
    let base = scene.default_camera();
    let tank = scene.frame_input().tank;
    match spec {
        CameraSpec::Default => base,
        CameraSpec::Top => shoal_render::Camera {
            target: tank.center(),
            pitch_rad: 1.5,
            yaw_rad: 0.0,
            distance: tank.size().x.max(tank.size().z) * 1.05 + tank.size().y * 0.5,
            ..base
        },
        CameraSpec::Orbit => shoal_render::Camera {
            yaw_rad: base.yaw_rad + std::f32::consts::TAU * frame as f32 / num_frames.max(1) as f32,
            ..base
        },
        CameraSpec::Follow => match select.and_then(|i| scene.fish_info(i)) {
            Some(info) => shoal_render::Camera {
                target: info.center,
                distance: info.radius * 5.0,
                pitch_rad: 0.35,
                ..base
            },
            None => base,
        },
        CameraSpec::Fixed { eye, target } => {
            let d = eye - target;
            let distance = d.length();
            shoal_render::Camera {
                target,
                distance,
                pitch_rad: (d.y / distance).clamp(-1.0, 1.0).asin(),
                yaw_rad: d.x.atan2(d.z),
                ..base
            }
        }
    }
}

/// Parses `WIDTHxHEIGHT`.
pub fn parse_size(s: &str) -> anyhow::Result<(u32, u32)> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .with_context(|| format!("size `{s}` is not WIDTHxHEIGHT (e.g. 960x540)"))?;
    let parse = |v: &str| {
        v.trim()
            .parse::<u32>()
            .ok()
            .filter(|n| (1..=8192).contains(n))
            .with_context(|| format!("size `{s}`: `{v}` is not a number in 1..=8192"))
    };
    Ok((parse(w)?, parse(h)?))
}

/// Fish in the `porgies` scene when `--fish` is not given.
pub const DEFAULT_PORGIES: usize = 40;

/// The most fish `--fish` gives the `porgies` scene: 200,000 took 33 s and 2.9 GB before the
/// first frame here, with nothing shown meanwhile; 100,000 draws at a few frames a second.
pub const MAX_PORGIES: usize = 100_000;

/// A world of `fish` black porgies (the generated asset, `assets/black_porgy.glb`) at constant
/// density, driven by the built-in Rust wander/school driver.
pub fn porgy_sim(root: &Path, fish: usize, seed: u64) -> anyhow::Result<WanderPipeline> {
    let desc = SpeciesDesc::black_porgy();
    // The model from the folder's own `assets/`, else the source tree's (as for Lua scenes).
    let assets = [
        root.join("assets"),
        shoal_core::source_root().join("assets"),
    ]
    .into_iter()
    .find(|dir| dir.join(&desc.asset).is_file())
    .unwrap_or_else(|| root.join("assets"));
    let species = Species::load(desc, &assets)
        .with_context(|| format!("loading the black porgy from `{}`", assets.display()))?;
    let world = bench_world(species, fish, seed)?;
    Ok(WanderPipeline::new(world, WanderDriver::default()))
}

/// Builds the scene named by `--scene` (see [`Args::scene`]) with the `--seed` and `--fish`
/// overrides. With no `--scene`: the default Lua scene, else the porgy world (saying why the Lua
/// scene did not load).
pub fn load_scene(
    source: &super::ScriptSource,
    scene: Option<&Path>,
    seed: Option<u64>,
    fish: Option<usize>,
    lod: &super::LodArg,
) -> anyhow::Result<Box<dyn Showable>> {
    let root = &source.root;
    let seed_or_1 = seed.unwrap_or(1);
    let lua = |path: &Path| -> anyhow::Result<Box<dyn Showable>> {
        if fish.is_some() {
            anyhow::bail!(
                "--fish applies to `--scene porgies`; the Lua scene `{}` sets its own fish",
                path.display()
            );
        }
        let mut sim = Simulation::from_scene_reporting(
            root,
            &source.scripts,
            path,
            seed_or_1,
            &mut super::SpawnProgress::new(),
        )
        .with_context(|| format!("loading scene `{}`", path.display()))?;
        lod.apply(&mut sim);
        if let Some(line) = super::borrowed_models_line(&sim) {
            println!("{line}");
        }
        Ok(Box::new(sim))
    };
    let porgies = || -> anyhow::Result<Box<dyn Showable>> {
        if lod.lod.is_some() {
            anyhow::bail!(
                "--lod applies to Lua scenes: the `porgies` scene's built-in behaviour has no \
                 behaviour scripts to schedule (pass a Lua scene with --scene NAME)"
            );
        }
        if let Some(n) = fish.filter(|&n| n == 0 || n > MAX_PORGIES) {
            let would_take = shoal_core::world::footprint::human(
                shoal_core::world::footprint::estimate_bytes(n as u64),
            );
            anyhow::bail!(
                "--fish {n}: the porgies scene takes 1 to {MAX_PORGIES} fish ({n} would take \
                 about {would_take} of memory; `shoal bench sim --fish N` measures larger schools \
                 without drawing them)"
            );
        }
        Ok(Box::new(porgy_sim(
            root,
            fish.unwrap_or(DEFAULT_PORGIES),
            seed_or_1,
        )?))
    };
    match scene {
        Some(p) if p.extension().is_some_and(|e| e == "lua") => lua(p),
        Some(p) if p.as_os_str() == "porgies" => porgies(),
        Some(p) => match named_scene(&source.scripts, p) {
            Some(named) => lua(&named),
            None => Err(unknown_scene(p, &source.scripts, true)),
        },
        None => {
            let default_lua = source.scripts.join("scenes").join("default.lua");
            if fish.is_none() && default_lua.is_file() {
                match lua(&default_lua) {
                    Ok(s) => return Ok(s),
                    Err(e) => log::warn!(
                        "{}; showing the porgy world instead",
                        super::error_chain(&e)
                    ),
                }
            }
            porgies()
        }
    }
}

/// The Lua file of scene `name` in `scripts/scenes/` (`name` without an extension), if there
/// is one.
pub(super) fn named_scene(scripts: &Path, name: &Path) -> Option<PathBuf> {
    let path = scripts.join("scenes").join(name).with_extension("lua");
    (name.extension().is_none() && path.is_file()).then_some(path)
}

/// The error for a `--scene` that is neither a Lua file nor a known name: it lists the scenes
/// there are.
pub(super) fn unknown_scene(scene: &Path, scripts: &Path, porgies: bool) -> anyhow::Error {
    let dir = scripts.join("scenes");
    let mut names: Vec<String> = std::fs::read_dir(&dir)
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|e| {
            let name = e.file_name().to_string_lossy().into_owned();
            name.strip_suffix(".lua").map(str::to_owned)
        })
        .collect();
    names.sort();
    if porgies {
        names.push("porgies".into());
    }
    let why = if scene.as_os_str() == "demo" {
        " (the procedural `demo` scene was retired: every scene now runs the real simulation)"
    } else {
        ""
    };
    anyhow::anyhow!(
        "no scene `{}`{why}. A scene is a Lua file (`--scene path/to/scene.lua`) or one of: {}",
        scene.display(),
        names.join(", ")
    )
}

/// `--lod-tolerance-px` (`render` and `bench render`): a number of pixels ≥ 0.
pub fn check_lod_tolerance(px: f32) -> anyhow::Result<()> {
    if !(px.is_finite() && px >= 0.0) {
        anyhow::bail!("--lod-tolerance-px {px} must be a number ≥ 0");
    }
    Ok(())
}

enum Output {
    Png(PathBuf),
    Gif(PathBuf),
    Dir(PathBuf),
}

/// Runs `shoal render`.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    check_lod_tolerance(args.lod_tolerance_px)?;
    if !(args.seconds.is_finite() && args.seconds >= 0.0) {
        anyhow::bail!("--seconds {} must be a number ≥ 0", args.seconds);
    }
    if args.fps == 0 || args.fps > 240 {
        anyhow::bail!("--fps {} must be in 1..=240", args.fps);
    }
    let output = classify(&args.out)?;
    let source = args.scripts.resolve()?;
    println!("{source}");
    let mut scene = WorldScene::new(load_scene(
        &source,
        args.scene.as_deref(),
        args.seed,
        args.fish,
        &args.lod,
    )?);
    let select = check_select(args.select, scene.world())?;
    if args.camera == CameraSpec::Follow && select.is_none() {
        anyhow::bail!("--camera follow needs a fish to follow: add --select N");
    }
    scene.set_selected(select);

    let gpu = Gpu::headless()?;
    println!("adapter: {}", gpu.adapter_summary());
    let mut renderer = Renderer::new(&gpu, OffscreenTarget::FORMAT)?;
    renderer.set_lod_tolerance_px(args.lod_tolerance_px);
    render_frames(&gpu, &mut renderer, &mut scene, select, &args, &output)?;
    Ok(ExitCode::SUCCESS)
}

/// The fish `--select N` names (0-based, in the world's order), or an error naming the range.
pub fn check_select(
    select: Option<usize>,
    world: &shoal_core::world::World,
) -> anyhow::Result<Option<shoal_core::world::FishId>> {
    let Some(i) = select else { return Ok(None) };
    if let Some(&id) = world.fish_id_slice().get(i) {
        return Ok(Some(id));
    }
    let num_fish = world.num_fish();
    let range = if num_fish > 0 {
        format!(", numbered 0 to {}", num_fish - 1)
    } else {
        String::new()
    };
    anyhow::bail!("--select {i}: the scene has {num_fish} fish{range}")
}

/// What `--out` asks for: a `.png`, a `.gif`, or a directory (an existing one, or a path without
/// an extension). Any other extension is refused before anything is rendered.
fn classify(out: &Path) -> anyhow::Result<Output> {
    if out.is_dir() {
        return Ok(Output::Dir(out.to_owned()));
    }
    match out
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
    {
        Some(e) if e == "png" => Ok(Output::Png(out.to_owned())),
        Some(e) if e == "gif" => Ok(Output::Gif(out.to_owned())),
        None => Ok(Output::Dir(out.to_owned())),
        Some(e) => anyhow::bail!(
            "--out {}: shoal render cannot write .{e} files; it writes .png (the last frame), \
             .gif (an animation) or a directory of numbered PNGs (a path without an extension)",
            out.display()
        ),
    }
}

fn render_frames(
    gpu: &Gpu,
    renderer: &mut Renderer,
    scene: &mut DynScene,
    select: Option<shoal_core::world::FishId>,
    args: &Args,
    output: &Output,
) -> anyhow::Result<()> {
    let meshes = scene.meshes();
    for m in &meshes {
        renderer.upload_mesh(gpu, m)?;
    }
    drop(meshes);
    let target = OffscreenTarget::new(gpu, args.size.0, args.size.1);
    let dt = 1.0 / args.fps as f32;
    let num_frames = ((args.seconds * args.fps as f32).round() as u64).max(1);
    let progress = if num_frames > 1 {
        let bar = indicatif::ProgressBar::new(num_frames);
        bar.set_style(
            indicatif::ProgressStyle::with_template("{bar:40} {pos}/{len} frames ({eta} left)")
                .unwrap_or_else(|_| indicatif::ProgressStyle::default_bar()),
        );
        Some(bar)
    } else {
        None
    };
    if let Output::Dir(dir) = output {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create output directory `{}`", dir.display()))?;
    }
    let mut gif_frames = Vec::new();
    let mut overlay = Vec::new();
    for frame in 0..num_frames {
        if frame > 0 {
            scene.step(dt);
        }
        let last = frame + 1 == num_frames;
        let draw = match output {
            Output::Png(_) => last,
            _ => true,
        };
        if draw {
            overlay.clear();
            if args.overlays {
                scene.overlay_lines(OverlayToggles::ALL, &mut overlay);
            }
            let mut input = scene.frame_input();
            input.camera = camera_for(args.camera, scene, select, frame, num_frames);
            input.overlay = &overlay;
            renderer.render(gpu, target.view(), target.size(), &input)?;
            let image = target.read_rgba8(gpu)?;
            match output {
                Output::Png(path) => save_png(&image, path)?,
                Output::Dir(dir) => save_png(&image, &dir.join(format!("frame_{frame:05}.png")))?,
                Output::Gif(_) => gif_frames.push(image),
            }
        }
        if let Some(bar) = &progress {
            bar.inc(1);
        }
    }
    if let Some(bar) = progress {
        bar.finish();
    }
    if let Output::Gif(path) = output {
        save_gif(gif_frames, args.fps, path)?;
    }
    let out = match output {
        Output::Png(p) | Output::Gif(p) | Output::Dir(p) => p,
    };
    println!(
        "wrote {} ({num_frames} frames, the last at t = {:.2} s of simulated time)",
        out.display(),
        scene.time_s()
    );
    Ok(())
}

fn save_png(image: &image::RgbaImage, path: &Path) -> anyhow::Result<()> {
    image
        .save_with_format(path, image::ImageFormat::Png)
        .with_context(|| format!("cannot write `{}`", path.display()))
}

fn save_gif(frames: Vec<image::RgbaImage>, fps: u32, path: &Path) -> anyhow::Result<()> {
    let file = std::fs::File::create(path)
        .with_context(|| format!("cannot create `{}`", path.display()))?;
    let mut encoder =
        image::codecs::gif::GifEncoder::new_with_speed(std::io::BufWriter::new(file), 10);
    encoder
        .set_repeat(image::codecs::gif::Repeat::Infinite)
        .with_context(|| format!("cannot write `{}`", path.display()))?;
    let delay = image::Delay::from_numer_denom_ms(1000, fps);
    encoder
        .encode_frames(
            frames
                .into_iter()
                .map(|f| image::Frame::from_parts(f, 0, 0, delay)),
        )
        .with_context(|| format!("cannot write `{}`", path.display()))
}
