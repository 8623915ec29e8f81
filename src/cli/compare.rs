//! `shoal compare`: an A/B experiment between two versions of the scripts over many seeds (see
//! [`shoal_script::timeline::compare`]).
//!
//! ```text
//! shoal compare --a DIR --b DIR [--scene S] --seeds N --seconds T [--shard i/n] [--json] [--plot PNG]
//! shoal compare --merge SHARD.json... [--json] [--plot PNG]
//! ```

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;

use shoal_script::timeline::compare::{self, CompareSpec, Comparison, Estimate};

/// Arguments of `shoal compare`.
#[derive(Debug, clap::Args)]
pub struct Args {
    /// Version A: a scripts directory (behaviors/, species/, scenes/).
    #[arg(long, value_name = "DIR", required_unless_present = "merge")]
    pub a: Option<PathBuf>,
    /// Version B: a scripts directory.
    #[arg(long, value_name = "DIR", required_unless_present = "merge")]
    pub b: Option<PathBuf>,
    /// The scene, by name in each version's `scenes/` (default: `default`) or as a path inside
    /// A's scripts directory.
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Seeds to run each version with (1, 2, … N).
    #[arg(long, required_unless_present = "merge")]
    pub seeds: Option<u64>,
    /// Simulated seconds per run.
    #[arg(long, required_unless_present = "merge", allow_negative_numbers = true)]
    pub seconds: Option<f64>,
    /// Run only this shard of the seeds (`i/n`, 1-based: seeds i, i+n, i+2n…); merge the
    /// shards' `--json` outputs with `--merge`. `auto` (or `auto/n`) takes the shard from the
    /// scheduler running the command: a Slurm job array, GitLab CI's `parallel:`, a Kubernetes
    /// Indexed Job (count from `auto/n`) or `SHOAL_SHARD=i/n`.
    #[arg(long, value_parser = compare::parse_shard_arg)]
    pub shard: Option<compare::ShardArg>,
    /// Merge the JSON of shards of one experiment instead of running one.
    #[arg(long, num_args = 1.., value_name = "SHARD.json", conflicts_with_all = ["a", "b", "seeds", "seconds", "shard", "scene", "lod_a", "lod_b"])]
    pub merge: Vec<PathBuf>,
    /// Behaviour level of detail for version A (default: the scene's).
    #[arg(long, value_name = "on|off")]
    pub lod_a: Option<super::OnOff>,
    /// Behaviour level of detail for version B (default: the scene's). `--a S --b S --lod-a off
    /// --lod-b on` measures what level of detail changes in what the fish do.
    #[arg(long, value_name = "on|off")]
    pub lod_b: Option<super::OnOff>,
    /// Print the comparison as JSON (every run's measures and the summary).
    #[arg(long)]
    pub json: bool,
    /// Also draw the comparison into this PNG.
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

/// Runs `shoal compare`.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    if let Some(plot) = &args.plot
        && plot.extension().is_none_or(|e| e != "png")
    {
        anyhow::bail!(
            "--plot {}: the plot is written as a .png file",
            plot.display()
        );
    }
    let c = if args.merge.is_empty() {
        run_experiment(&args)?
    } else {
        merge(&args.merge)?
    };
    report_measure_errors(&c);
    if let Some(plot) = &args.plot {
        shoal_script::timeline::compare_plot::write(&c, plot)?;
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&c)?);
    } else {
        print_table(&c);
        if let Some(plot) = &args.plot {
            println!("plot: {}", plot.display());
        }
    }
    Ok(ExitCode::SUCCESS)
}

fn version_dir(flag: &str, dir: &Path) -> anyhow::Result<PathBuf> {
    if !dir.is_dir() {
        anyhow::bail!(
            "--{flag} {}: no such directory (a version is a scripts directory holding behaviors/, \
             species/ and scenes/)",
            dir.display()
        );
    }
    Ok(dir.canonicalize().unwrap_or_else(|_| dir.to_path_buf()))
}

fn run_experiment(args: &Args) -> anyhow::Result<Comparison> {
    let (Some(a), Some(b), Some(seeds), Some(seconds)) =
        (&args.a, &args.b, args.seeds, args.seconds)
    else {
        anyhow::bail!("--a, --b, --seeds and --seconds are needed to run an experiment");
    };
    let (a, b) = (version_dir("a", a)?, version_dir("b", b)?);
    if seeds == 0 {
        anyhow::bail!("--seeds 0: an experiment needs at least one seed (2 or more for intervals)");
    }
    if !(seconds.is_finite() && seconds > 0.0) {
        anyhow::bail!("--seconds {seconds}: expected a number of seconds > 0");
    }
    let scene = super::timeline::scene_in(&a, args.scene.as_deref())?;
    if !b.join(&scene).is_file() {
        anyhow::bail!(
            "--b {}: no scene {scene} in it (both versions run the same scene, named relative to \
             each scripts directory)",
            b.display()
        );
    }
    let root = super::ScriptsArg {
        scripts: Some(a.clone()),
    }
    .resolve()?
    .root;
    let shard_of = args
        .shard
        .map(|arg| compare::resolve_shard(arg, |name| std::env::var(name).ok()))
        .transpose()?;
    let seeds_here = compare::shard_seeds(seeds, shard_of);
    let threads = rayon::current_num_threads();
    let shard = shard_of.map_or(String::new(), |(i, n)| format!(" (shard {i}/{n})"));
    let lod = |v: Option<super::OnOff>| match v {
        Some(super::OnOff::On) => " (level of detail on)",
        Some(super::OnOff::Off) => " (level of detail off)",
        None => "",
    };
    if !args.json {
        println!(
            "comparing A = {}{} and B = {}{} on {scene}: {} seeds{shard} × {seconds} s, {} runs on {threads} threads",
            a.display(),
            lod(args.lod_a),
            b.display(),
            lod(args.lod_b),
            seeds_here.len(),
            2 * seeds_here.len()
        );
    }
    Ok(compare::compare(&CompareSpec {
        root: &root,
        a: &a,
        b: &b,
        scene: &scene,
        seeds,
        shard: shard_of,
        seconds,
        lod_a: args.lod_a.map(super::OnOff::on),
        lod_b: args.lod_b.map(super::OnOff::on),
    })?)
}

fn merge(files: &[PathBuf]) -> anyhow::Result<Comparison> {
    let parts = files
        .iter()
        .map(|f| {
            let text = std::fs::read_to_string(f).with_context(|| format!("{}", f.display()))?;
            let c: Comparison = serde_json::from_str(&text).with_context(|| {
                format!(
                    "{}: not the JSON of `shoal compare --json` (or of a newer shoal)",
                    f.display()
                )
            })?;
            Ok((f.display().to_string(), c))
        })
        .collect::<anyhow::Result<Vec<_>>>()?;
    Ok(compare::merge(parts)?)
}

/// On stderr (so `--json` stays JSON): each scene measure that failed, by version and name,
/// with how often, in how many runs, and the first error (`file:line: message`).
fn report_measure_errors(c: &Comparison) {
    for (version, v) in [("A", &c.a), ("B", &c.b)] {
        let mut failed: std::collections::BTreeMap<&str, (u64, usize, &str)> = Default::default();
        for r in &v.runs {
            for (name, e) in &r.measure_errors {
                let entry = failed.entry(name).or_insert((0, 0, e.first.as_str()));
                entry.0 += e.count;
                entry.1 += 1;
            }
        }
        for (name, (count, runs, first)) in failed {
            eprintln!(
                "{version}: measure \"{name}\" failed {count} times in {runs} of {} runs (its value \
                 is over the samples that worked); first: {first}",
                v.runs.len()
            );
        }
    }
}

fn fmt_estimate(e: &Estimate) -> String {
    let n = e.n;
    match (e.mean, e.low, e.high) {
        (Some(m), Some(l), Some(h)) => format!("{m:>9.3} [{l:.3}, {h:.3}] n={n}"),
        (Some(m), _, _) => format!("{m:>9.3} n={n}"),
        _ => format!("— n={n}"),
    }
}

fn print_table(c: &Comparison) {
    if c.changed.is_empty() && c.a.lod != c.b.lod {
        println!(
            "A and B have the same scripts; only behaviour level of detail differs (--lod-a, \
             --lod-b)"
        );
    } else if c.changed.is_empty() {
        println!(
            "A and B have the same scripts: every measure but decision cost (a timing) should be \
             the same"
        );
    } else {
        println!("files that differ: {}", c.changed.join(", "));
    }
    println!(
        "{} seeds per version; mean [95 % interval] n=values it rests on; B − A paired by seed",
        c.a.runs.len()
    );
    println!(
        "  {:<24} {:>36} {:>36} {:>36}",
        "measure", "A", "B", "B − A"
    );
    for m in &c.summary {
        let verdict = if m.significant { "  significant" } else { "" };
        // A scene measure that failed on some samples is a mean over the others: say so on its
        // row, where the verdict is read (stderr has the first error).
        let failed: Vec<String> = [("A", &c.a), ("B", &c.b)]
            .into_iter()
            .filter_map(|(version, v)| {
                let count: u64 = v
                    .runs
                    .iter()
                    .filter_map(|r| r.measure_errors.get(&m.measure))
                    .map(|e| e.count)
                    .sum();
                (count > 0).then(|| format!("{version} failed {count}×"))
            })
            .collect();
        let failed = if failed.is_empty() {
            String::new()
        } else {
            format!("  ({}: over the samples that worked)", failed.join(", "))
        };
        println!(
            "  {:<24} {:>36} {:>36} {:>36}{verdict}{failed}",
            m.label,
            fmt_estimate(&m.a),
            fmt_estimate(&m.b),
            fmt_estimate(&m.b_minus_a)
        );
    }
    if c.a.runs.len() < 2 {
        println!("(intervals need 2 seeds or more)");
    }
}
