//! `shoal render`: renders a scene headless to a PNG (last frame), a GIF, or a directory of
//! numbered PNGs. Works without a GPU through a software Vulkan adapter (lavapipe).

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;

use crate::render::{DemoScene, DemoSceneConfig, Gpu, OffscreenTarget, Renderer, SceneDriver};

/// Arguments of `shoal render`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Scene file (JSON: fish, seed, tank, camera, caustics). Default: the built-in aquarium.
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
    /// Number of fish (overrides the scene's).
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
    let mut config = match &args.scene {
        Some(path) => DemoSceneConfig::load(path).map_err(anyhow::Error::msg)?,
        None => DemoSceneConfig::default(),
    };
    if let Some(seed) = args.seed {
        config.seed = seed;
    }
    if let Some(fish) = args.fish {
        config.fish = fish;
    }
    config.validate().map_err(anyhow::Error::msg)?;
    let output = classify(&args.out);

    let gpu = Gpu::headless()?;
    println!("adapter: {}", gpu.adapter_summary());
    let mut renderer = Renderer::new(&gpu, OffscreenTarget::FORMAT)?;
    let mut scene = DemoScene::new(config);
    render_frames(&gpu, &mut renderer, &mut scene, &args, &output)?;
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
