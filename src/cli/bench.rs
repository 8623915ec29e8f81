//! `shoal bench`: measured speed of the simulation (issue 7) and of rendering.
//!
//! `shoal bench sim --fish 1000,10000 [--seconds 5] [--json]` builds a scene per fish count (the
//! default species at constant density, [`shoal::world::bench::bench_world`]), warms it up for a
//! second, then times each 60 Hz tick and reports the median and p99 milliseconds, fish-ticks per
//! second and the split by stage. Behaviour is the built-in Rust wander/school driver until the
//! Lua simulation implements [`Ticker`] (the seam in `world::bench`).
//!
//! `shoal bench render --fish 1,100,1000,10000 [--size 1920x1080] [--frames 30]` renders the
//! demo aquarium offscreen per fish count, waits for the GPU every frame, and reports the median
//! and p99 frame time, the CPU upload time and the draw calls (which do not grow with fish).

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context;

use crate::render::{DemoScene, DemoSceneConfig, Gpu, OffscreenTarget, Renderer, SceneDriver};
use crate::world::bench::{RustSim, SimBenchResult, Ticker, bench_world, measure};
use crate::world::driver::WanderDriver;
use crate::world::{Species, SpeciesDesc, TICK_HZ};

/// Arguments of `shoal bench`.
#[derive(Debug, Default, clap::Args)]
pub struct Args {
    /// What to measure.
    #[command(subcommand)]
    pub what: Option<What>,
}

/// The benchmarks.
#[derive(Debug, clap::Subcommand)]
pub enum What {
    /// Simulation ticks without rendering: behaviour, perception, motion, skeleton, palettes.
    Sim(SimArgs),
    /// Offscreen render frame times (median, p99) for several fish counts.
    Render(RenderArgs),
}

/// Arguments of `shoal bench sim`.
#[derive(Debug, clap::Args)]
pub struct SimArgs {
    /// Fish counts to measure, comma-separated.
    #[arg(long, value_delimiter = ',', default_value = "1000,10000")]
    pub fish: Vec<usize>,
    /// Simulated seconds measured per fish count (after one second of warm-up).
    #[arg(long, default_value_t = 5.0)]
    pub seconds: f64,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Directory holding the species' assets.
    #[arg(long, default_value = "assets")]
    pub assets: PathBuf,
    /// Seed of the scene.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
}

/// Runs `shoal bench`.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    match args.what {
        Some(What::Sim(sim)) => run_sim(sim),
        Some(What::Render(render)) => run_render(render),
        None => anyhow::bail!(
            "say what to measure: `shoal bench sim --fish 1000,10000` or \
             `shoal bench render --fish 1,100,1000,10000`"
        ),
    }
}

fn run_sim(args: SimArgs) -> anyhow::Result<ExitCode> {
    if !(args.seconds.is_finite() && args.seconds > 0.0) {
        anyhow::bail!("--seconds {} must be a positive number", args.seconds);
    }
    if args.fish.is_empty() || args.fish.contains(&0) {
        anyhow::bail!("--fish needs positive counts, e.g. --fish 1000,10000");
    }
    let species = Species::load(SpeciesDesc::black_porgy(), &args.assets)
        .context("loading the benchmark species (is --assets right?)")?;
    let ticks = (args.seconds * TICK_HZ).round().max(1.0) as usize;
    let mut results: Vec<SimBenchResult> = Vec::new();
    for &fish in &args.fish {
        let world = bench_world(species.clone(), fish, args.seed)?;
        let mut sim = RustSim {
            world,
            driver: WanderDriver::default(),
        };
        let result = measure(&mut sim, TICK_HZ as usize, ticks);
        debug_assert_eq!(sim.world().num_fish(), fish);
        if !args.json {
            print_row(&result, results.is_empty());
        }
        results.push(result);
    }
    if args.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({
                "driver": "rust-wander (built-in; no Lua)",
                "tick_hz": TICK_HZ,
                "results": results,
            }))?
        );
    } else if let [first, .., last] = results.as_slice() {
        println!(
            "cost per fish at {} fish is {:.2}× that at {} fish",
            last.fish,
            last.us_per_fish / first.us_per_fish,
            first.fish
        );
    }
    Ok(ExitCode::SUCCESS)
}

fn print_row(r: &SimBenchResult, header: bool) {
    if header {
        println!(
            "driver: built-in Rust wander/school (no Lua), {} threads; stage columns are medians, ms",
            r.threads
        );
        println!(
            "{:>7} {:>9} {:>8} {:>10} {:>9} | {:>7} {:>7} {:>7} {:>7} {:>7} {:>7}",
            "fish",
            "median ms",
            "p99 ms",
            "fish-tick/s",
            "µs/fish",
            "percep",
            "behav",
            "motion",
            "skel",
            "palette",
            "grid"
        );
    }
    let s = &r.stages;
    println!(
        "{:>7} {:>9.3} {:>8.3} {:>10.3e} {:>9.3} | {:>7.3} {:>7.3} {:>7.3} {:>7.3} {:>7.3} {:>7.3}",
        r.fish,
        r.median_ms,
        r.p99_ms,
        r.fish_ticks_per_s,
        r.us_per_fish,
        s.perception,
        s.behavior,
        s.motion,
        s.skeleton,
        s.palette,
        s.grid
    );
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
    /// Measured frames per fish count (after one warm-up frame).
    #[arg(long, default_value_t = 30)]
    pub frames: usize,
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
        // The demo scene draws the generated black porgy (procedural fish if it cannot load).
        let config = DemoSceneConfig {
            fish: n,
            ..DemoSceneConfig::default()
        };
        config.validate().map_err(anyhow::Error::msg)?;
        let mut scene = DemoScene::new(config);
        for m in scene.meshes() {
            if n == args.fish[0] {
                println!(
                    "mesh: {} ({} triangles, {} joints)",
                    m.label,
                    m.indices.len() / 3,
                    scene.rig().num_joints()
                );
            }
            renderer.upload_mesh(&gpu, &m)?;
        }
        let camera = scene.default_camera();
        let mut times = Vec::with_capacity(args.frames);
        let mut upload = 0.0;
        for frame in 0..args.frames + 1 {
            scene.step(1.0 / 60.0);
            let mut input = scene.frame_input();
            input.camera = camera;
            let start = Instant::now();
            renderer.render(&gpu, target.view(), target.size(), &input)?;
            gpu.wait_idle();
            let ms = start.elapsed().as_secs_f64() * 1e3;
            if frame >= 1 {
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
