//! `shoal render`: renders a scene headless to a PNG (last frame), a GIF, or a directory of
//! numbered PNGs. Works without a GPU through a software Vulkan adapter (lavapipe).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;

use crate::render::{
    DemoScene, DemoSceneConfig, Gpu, OffscreenTarget, Renderer, SceneDriver, WorldScene,
};
use crate::script::Simulation;
use crate::world::bench::{RustSim, bench_world};
use crate::world::driver::WanderDriver;
use crate::world::{Species, SpeciesDesc};

/// Arguments of `shoal render`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Scene: a Lua scene (`scripts/scenes/*.lua`), `porgies` (black porgies from
    /// `assets/black_porgy.glb`, built-in wander/school behaviour), `demo` (procedural fish) or a
    /// demo JSON file. Default: `scripts/scenes/default.lua`, else `porgies`, else `demo`.
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Simulated seconds to render.
    #[arg(long, default_value_t = 3.0)]
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
    /// Number of fish (`porgies` and `demo` scenes; a Lua scene sets its own).
    #[arg(long)]
    pub fish: Option<usize>,
    /// Output: `*.png` (last frame), `*.gif` (animation) or a directory (numbered PNGs).
    #[arg(long)]
    pub out: PathBuf,
}

/// Parses `WIDTHxHEIGHT`.
pub fn parse_size(s: &str) -> Result<(u32, u32), String> {
    let (w, h) = s
        .split_once(['x', 'X'])
        .ok_or_else(|| format!("size `{s}` is not WIDTHxHEIGHT (e.g. 960x540)"))?;
    let parse = |v: &str| {
        v.trim()
            .parse::<u32>()
            .ok()
            .filter(|n| (1..=8192).contains(n))
            .ok_or_else(|| format!("size `{s}`: `{v}` is not a number in 1..=8192"))
    };
    Ok((parse(w)?, parse(h)?))
}

/// The repository root that holds `scripts/` and `assets/`: the working directory when it has
/// them, else the source tree this binary was built from.
pub fn project_root() -> PathBuf {
    let cwd = std::env::current_dir().unwrap_or_else(|_| PathBuf::from("."));
    if cwd.join("scripts").is_dir() {
        cwd
    } else {
        PathBuf::from(env!("CARGO_MANIFEST_DIR"))
    }
}

/// Fish in the `porgies` scene when `--fish` is not given.
pub const DEFAULT_PORGIES: usize = 40;

/// A world of `fish` black porgies (the generated asset, `assets/black_porgy.glb`) at constant
/// density, driven by the built-in Rust wander/school driver.
pub fn porgy_scene(fish: usize, seed: u64) -> anyhow::Result<Box<dyn SceneDriver>> {
    let assets = project_root().join("assets");
    let species = Species::load(SpeciesDesc::black_porgy(), &assets)
        .with_context(|| format!("loading the black porgy from `{}`", assets.display()))?;
    let world = bench_world(species, fish, seed)?;
    let sim = RustSim {
        world,
        driver: WanderDriver::default(),
    };
    Ok(Box::new(WorldScene::new(sim)))
}

/// Builds the scene named by `--scene` (see [`Args::scene`]) with the `--seed` and `--fish`
/// overrides. With no `--scene`: the default Lua scene, else the porgy world, else the demo,
/// whichever loads first (saying why the others did not).
pub fn load_scene(
    scene: Option<&Path>,
    seed: Option<u64>,
    fish: Option<usize>,
) -> anyhow::Result<Box<dyn SceneDriver>> {
    let root = project_root();
    let seed_or_1 = seed.unwrap_or(1);
    let lua = |path: &Path| -> anyhow::Result<Box<dyn SceneDriver>> {
        if fish.is_some() {
            anyhow::bail!(
                "--fish applies to `--scene demo` and `--scene porgies`; the Lua scene `{}` sets \
                 its own fish",
                path.display()
            );
        }
        let sim = Simulation::from_scene(&root, path, seed_or_1)
            .with_context(|| format!("loading scene `{}`", path.display()))?;
        Ok(Box::new(WorldScene::new(sim)))
    };
    let demo = |config: Option<DemoSceneConfig>| -> anyhow::Result<Box<dyn SceneDriver>> {
        let mut config = config.unwrap_or_default();
        if let Some(seed) = seed {
            config.seed = seed;
        }
        if let Some(fish) = fish {
            config.fish = fish;
        }
        config.validate().map_err(anyhow::Error::msg)?;
        Ok(Box::new(DemoScene::new(config)))
    };
    match scene {
        Some(p) if p.extension().is_some_and(|e| e == "lua") => lua(p),
        Some(p) if p.as_os_str() == "porgies" => {
            porgy_scene(fish.unwrap_or(DEFAULT_PORGIES), seed_or_1)
        }
        Some(p) if p.as_os_str() == "demo" => demo(None),
        Some(p) => demo(Some(DemoSceneConfig::load(p).map_err(anyhow::Error::msg)?)),
        None => {
            let default_lua = root.join("scripts/scenes/default.lua");
            if fish.is_none() && default_lua.is_file() {
                match lua(&default_lua) {
                    Ok(s) => return Ok(s),
                    Err(e) => log::warn!("{e:#}; showing the porgy world instead"),
                }
            }
            match porgy_scene(fish.unwrap_or(DEFAULT_PORGIES), seed_or_1) {
                Ok(s) => Ok(s),
                Err(e) => {
                    log::warn!("{e:#}; showing the procedural demo instead");
                    demo(None)
                }
            }
        }
    }
}

enum Output {
    Png(PathBuf),
    Gif(PathBuf),
    Dir(PathBuf),
}

/// Runs `shoal render`.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    if !(args.seconds.is_finite() && args.seconds >= 0.0) {
        anyhow::bail!("--seconds {} must be a number ≥ 0", args.seconds);
    }
    if args.fps == 0 || args.fps > 240 {
        anyhow::bail!("--fps {} must be in 1..=240", args.fps);
    }
    let mut scene = load_scene(args.scene.as_deref(), args.seed, args.fish)?;
    let output = classify(&args.out);

    let gpu = Gpu::headless()?;
    println!("adapter: {}", gpu.adapter_summary());
    let mut renderer = Renderer::new(&gpu, OffscreenTarget::FORMAT)?;
    render_frames(&gpu, &mut renderer, scene.as_mut(), &args, &output)?;
    Ok(ExitCode::SUCCESS)
}

fn classify(out: &Path) -> Output {
    match out
        .extension()
        .and_then(|e| e.to_str())
        .map(str::to_ascii_lowercase)
    {
        Some(e) if e == "png" => Output::Png(out.to_owned()),
        Some(e) if e == "gif" => Output::Gif(out.to_owned()),
        _ => Output::Dir(out.to_owned()),
    }
}

fn render_frames(
    gpu: &Gpu,
    renderer: &mut Renderer,
    scene: &mut dyn SceneDriver,
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
    let camera = scene.default_camera();
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
            let mut input = scene.frame_input();
            input.camera = camera;
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
    println!("wrote {} ({num_frames} frames simulated)", out.display());
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
