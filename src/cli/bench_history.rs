//! `shoal bench history`: what the window's time travel costs (issue 14) — the history ring's
//! share of the tick at several fish counts, its memory per fish, and how long a seek anywhere
//! in five minutes of the default aquarium takes.
//!
//! Recording cost is measured by alternating one simulated second without the history and one
//! with it (a kept state per second, every fish's position per tick, as `shoal run` keeps),
//! on the same simulation, and comparing the medians of the seconds' mean tick times.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Instant;

use anyhow::Context;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg32;

use shoal_app::{AppOptions, Aquarium, Timeline};
use shoal_core::world::TICK_HZ;
use shoal_script::Simulation;

/// Arguments of `shoal bench history`.
#[derive(Debug, clap::Args)]
pub struct HistoryArgs {
    /// Fish counts to measure the recording cost at (the bench layout of `bench sim`).
    #[arg(long, value_delimiter = ',', default_value = "1000,10000")]
    pub fish: Vec<usize>,
    /// Pairs of seconds (one without the history, one with it) per fish count.
    #[arg(long, default_value_t = 8)]
    pub pairs: usize,
    /// Minutes of the default aquarium to fill the history with before seeking.
    #[arg(long, default_value_t = 5.0)]
    pub minutes: f64,
    /// Seeks to random moments of that history.
    #[arg(long, default_value_t = 40)]
    pub seeks: usize,
    /// Print JSON instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Repository root holding `scripts/` and `assets/`.
    #[arg(long, default_value = ".")]
    pub root: PathBuf,
}

#[derive(Debug, serde::Serialize)]
struct CostRow {
    fish: usize,
    plain_ms_per_tick: f64,
    with_history_ms_per_tick: f64,
    overhead_percent: f64,
    state_bytes_per_fish: f64,
    track_bytes_per_fish_per_tick: f64,
    snapshot_ms: f64,
}

#[derive(Debug, serde::Serialize)]
struct SeekRow {
    scene: &'static str,
    history_s: f64,
    history_mb: f64,
    seeks: usize,
    median_ms: f64,
    max_ms: f64,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    match v.len() {
        0 => f64::NAN,
        n if n % 2 == 1 => v[n / 2],
        n => 0.5 * (v[n / 2 - 1] + v[n / 2]),
    }
}

/// Runs `shoal bench history`.
pub fn run(args: HistoryArgs) -> anyhow::Result<ExitCode> {
    if args.fish.is_empty() || args.fish.contains(&0) || args.pairs == 0 {
        anyhow::bail!("--fish needs positive counts and --pairs at least 1");
    }
    if !(args.minutes.is_finite() && args.minutes > 0.0) || args.seeks == 0 {
        anyhow::bail!("--minutes must be positive and --seeks at least 1");
    }
    let mut costs = Vec::new();
    for &fish in &args.fish {
        let row = recording_cost(&args.root, fish, args.pairs)?;
        if !args.json {
            if costs.is_empty() {
                println!(
                    "{:>7} {:>14} {:>18} {:>9} {:>12} {:>16} {:>22}",
                    "fish",
                    "ms/tick plain",
                    "ms/tick + history",
                    "overhead",
                    "ms/state",
                    "B/fish per state",
                    "B/fish per tick (paths)"
                );
            }
            println!(
                "{:>7} {:>14.3} {:>18.3} {:>8.1}% {:>12.2} {:>16.0} {:>22.1}",
                row.fish,
                row.plain_ms_per_tick,
                row.with_history_ms_per_tick,
                row.overhead_percent,
                row.snapshot_ms,
                row.state_bytes_per_fish,
                row.track_bytes_per_fish_per_tick
            );
        }
        costs.push(row);
    }
    let seek = seek_cost(&args.root, args.minutes, args.seeks)?;
    if args.json {
        println!(
            "{}",
            serde_json::to_string_pretty(&serde_json::json!({
                "recording": costs,
                "seek": seek,
            }))?
        );
    } else {
        println!(
            "seek in {:.0} s of history of {} ({:.1} MB): median {:.1} ms, max {:.1} ms over {} seeks",
            seek.history_s, seek.scene, seek.history_mb, seek.median_ms, seek.max_ms, seek.seeks
        );
    }
    Ok(ExitCode::SUCCESS)
}

fn recording_cost(root: &Path, fish: usize, pairs: usize) -> anyhow::Result<CostRow> {
    let mut sim = super::lua_sim(&super::ScriptSource::of_root(root), fish, 1, None)?;
    let mut timeline = Timeline::new(shoal_app::DEFAULT_SPAN_S);
    let second = TICK_HZ as usize;
    for _ in 0..second {
        sim.step();
    }
    let (mut plain, mut with) = (Vec::new(), Vec::new());
    for _ in 0..pairs {
        let start = Instant::now();
        for _ in 0..second {
            sim.step();
        }
        plain.push(start.elapsed().as_secs_f64() * 1e3 / second as f64);
        let start = Instant::now();
        for _ in 0..second {
            sim.step();
            if let Some(line) = timeline.record(&sim) {
                anyhow::bail!("{line}");
            }
        }
        with.push(start.elapsed().as_secs_f64() * 1e3 / second as f64);
    }
    let (p, w) = (median(plain), median(with));
    let snaps: Vec<f64> = (0..5)
        .map(|_| {
            let start = Instant::now();
            let _ = shoal_app::Showable::snapshot(&sim);
            start.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    let states = timeline.num_states().max(1);
    let ticks = (timeline.span_s().map_or(0.0, |(a, b)| b - a) * TICK_HZ).max(1.0);
    Ok(CostRow {
        fish,
        plain_ms_per_tick: p,
        with_history_ms_per_tick: w,
        overhead_percent: 100.0 * (w - p) / p,
        state_bytes_per_fish: timeline.states_bytes() as f64 / states as f64 / fish as f64,
        track_bytes_per_fish_per_tick: timeline.track_bytes() as f64 / ticks / fish as f64,
        snapshot_ms: median(snaps),
    })
}

fn seek_cost(root: &Path, minutes: f64, seeks: usize) -> anyhow::Result<SeekRow> {
    const SCENE: &str = "scenes/default.lua";
    let sim = Simulation::from_scene(root, Path::new(SCENE), 1)
        .with_context(|| format!("loading {SCENE} under {}", root.display()))?;
    let mut aq = Aquarium::new(Box::new(sim), AppOptions::default());
    // Frames of the longest real time one frame simulates, until the history is full.
    let until = minutes * 60.0;
    while aq.scene.world().time() < until {
        aq.advance(0.1);
    }
    let (from, to) = aq.timeline().span_s().context("the history kept nothing")?;
    let mb = (aq.timeline().states_bytes() + aq.timeline().track_bytes()) as f64 / 1e6;
    let mut rng = Pcg32::seed_from_u64(7);
    let mut times = Vec::with_capacity(seeks);
    for _ in 0..seeks {
        let t = rng.random_range(from..to);
        let start = Instant::now();
        aq.seek(t);
        times.push(start.elapsed().as_secs_f64() * 1e3);
        let got = aq.scene.world().time();
        if (got - t).abs() > 1.0 / TICK_HZ {
            anyhow::bail!("seeking to {t:.3} s landed at {got:.3} s");
        }
    }
    let max = times.iter().copied().fold(0.0, f64::max);
    Ok(SeekRow {
        scene: SCENE,
        history_s: to - from,
        history_mb: mb,
        seeks,
        median_ms: median(times),
        max_ms: max,
    })
}
