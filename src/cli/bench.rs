//! `shoal bench`: measured speed of the simulation (issue 7) and of rendering.
//!
//! `shoal bench sim --fish 1000,10000 [--seconds 5] [--json]` builds a scene per fish count (the
//! default species at constant density, [`shoal::world::bench::bench_world`]), warms it up for a
//! second, then times each 60 Hz tick and reports the median and p99 milliseconds, fish-ticks per
//! second and the split by stage. Behaviour is the built-in Rust wander/school driver until the
//! Lua simulation implements [`Ticker`] (the seam in `world::bench`).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context;

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
        None => anyhow::bail!("say what to measure: `shoal bench sim --fish 1000,10000`"),
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
            "{:>7} {:>9} {:>8} {:>10} {:>9} | {:>7} {:>7} {:>7} {:>7} {:>7} {:>7} | {:>7} {:>9}",
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
            "grid",
            "in view",
            "nearest L"
        );
    }
    let s = &r.stages;
    println!(
        "{:>7} {:>9.3} {:>8.3} {:>10.3e} {:>9.3} | {:>7.3} {:>7.3} {:>7.3} {:>7.3} {:>7.3} {:>7.3} | {:>7.1} {:>9.2}",
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
        s.grid,
        r.mean_in_view,
        r.mean_nearest_lengths
    );
}
