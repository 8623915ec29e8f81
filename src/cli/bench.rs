//! `shoal bench`: benchmarks. `shoal bench render` measures offscreen frame times.

use std::process::ExitCode;
use std::time::Instant;

use crate::render::{DemoScene, DemoSceneConfig, Gpu, OffscreenTarget, Renderer, SceneDriver};

/// Arguments of `shoal bench`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Which benchmark.
    #[command(subcommand)]
    pub which: Bench,
}

/// The benchmarks.
#[derive(Debug, clap::Subcommand)]
pub enum Bench {
    /// Offscreen render frame times (median, p99) for several fish counts.
    Render(RenderArgs),
}

/// Arguments of `shoal bench render`.
#[derive(Debug, clap::Args)]
pub struct RenderArgs {
    /// Fish counts to measure, comma separated.
    #[arg(long, value_delimiter = ',', default_value = "1,100,1000,10000")]
    pub fish: Vec<usize>,
    /// Image size, WIDTHxHEIGHT pixels.
    #[arg(long, default_value = "1920x1080", value_parser = super::render::parse_size)]
    pub size: (u32, u32),
    /// Measured frames per fish count (after 3 warm-up frames).
    #[arg(long, default_value_t = 30)]
    pub frames: usize,
}

/// Frame-time statistics of one run, milliseconds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FrameStats {
    /// Median frame time.
    pub median_ms: f64,
    /// 99th percentile frame time (nearest rank).
    pub p99_ms: f64,
    /// Mean CPU time writing palettes and instances.
    pub upload_ms: f64,
    /// Draw calls in the scene pass.
    pub draw_calls: u32,
}

/// Median and nearest-rank p99 of `samples` (sorted in place). Empty input gives zeros.
pub fn median_p99(samples: &mut [f64]) -> (f64, f64) {
    if samples.is_empty() {
        return (0.0, 0.0);
    }
    samples.sort_by(f64::total_cmp);
    let n = samples.len();
    let median = if n % 2 == 1 {
        samples[n / 2]
    } else {
        0.5 * (samples[n / 2 - 1] + samples[n / 2])
    };
    let rank = ((0.99 * n as f64).ceil() as usize).clamp(1, n);
    (median, samples[rank - 1])
}

/// Runs `shoal bench`.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    match args.which {
        Bench::Render(a) => run_render(a),
    }
}

fn run_render(args: RenderArgs) -> anyhow::Result<ExitCode> {
    if args.frames == 0 {
        anyhow::bail!("--frames must be at least 1");
    }
    let gpu = Gpu::headless()?;
    println!("adapter: {}", gpu.adapter_summary());
    let target = OffscreenTarget::new(&gpu, args.size.0, args.size.1);
    println!(
        "{:>7} {:>12} {:>10} {:>10} {:>8}   ({}x{}, {} frames each, GPU work waited for every frame)",
        "fish", "median ms", "p99 ms", "upload ms", "draws", args.size.0, args.size.1, args.frames
    );
    for &n in &args.fish {
        let mut renderer = Renderer::new(&gpu, OffscreenTarget::FORMAT)?;
        let config = DemoSceneConfig {
            fish: n,
            ..DemoSceneConfig::default()
        };
        config.validate().map_err(anyhow::Error::msg)?;
        let mut scene = DemoScene::new(config);
        for m in scene.meshes() {
            renderer.upload_mesh(&gpu, &m)?;
        }
        let camera = scene.default_camera();
        let mut times = Vec::with_capacity(args.frames);
        let mut upload = 0.0;
        for frame in 0..args.frames + 3 {
            scene.step(1.0 / 60.0);
            let mut input = scene.frame_input();
            input.camera = camera;
            let start = Instant::now();
            renderer.render(&gpu, target.view(), target.size(), &input)?;
            gpu.wait_idle();
            let ms = start.elapsed().as_secs_f64() * 1e3;
            if frame >= 3 {
                times.push(ms);
                upload += f64::from(renderer.timings().upload_ms);
            }
        }
        let (median, p99) = median_p99(&mut times);
        println!(
            "{n:>7} {median:>12.2} {p99:>10.2} {:>10.3} {:>8}",
            upload / args.frames as f64,
            renderer.timings().num_draw_calls
        );
    }
    Ok(ExitCode::SUCCESS)
}

#[cfg(test)]
mod tests {
    use super::median_p99;

    #[test]
    fn median_and_p99_by_hand() {
        let mut v: Vec<f64> = (1..=100).map(f64::from).rev().collect();
        assert_eq!(median_p99(&mut v), (50.5, 99.0));
        let mut odd = vec![3.0, 1.0, 2.0];
        assert_eq!(median_p99(&mut odd), (2.0, 3.0));
        assert_eq!(median_p99(&mut []), (0.0, 0.0));
    }
}
