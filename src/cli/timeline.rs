//! `shoal record`, `shoal replay`, `shoal diff`: time travel, headless (see [`shoal_script::timeline`]).
//!
//! ```text
//! shoal record [--scene S] [--seed N] [--lanes N] [--scripts DIR] --seconds T --out RUN.shoalrun
//! shoal replay RUN --from T0 [--seconds T1] [--scripts DIR] --out RUN2.shoalrun
//! shoal diff RUN RUN2 [--json] [--plot PNG]
//! ```

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;

use shoal_script::timeline::run_file::Run;
use shoal_script::timeline::{self, RecordSpec, ReplaySpec};

/// Arguments of `shoal record`.
#[derive(Debug, clap::Args)]
pub struct RecordArgs {
    /// The scene: a name in `scripts/scenes/` (default: `default`) or a `.lua` file inside the
    /// scripts directory.
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// The simulation's seed.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Script lanes (default: one per CPU thread); the replay uses as many.
    #[arg(long)]
    pub lanes: Option<usize>,
    /// Seconds of simulated time to record.
    #[arg(long, allow_negative_numbers = true)]
    pub seconds: f64,
    /// The recording to write (`.shoalrun`).
    #[arg(long)]
    pub out: PathBuf,
    /// Where the scripts come from (`--scripts DIR`, `SHOAL_SCRIPTS`).
    #[command(flatten)]
    pub scripts: super::ScriptsArg,
    #[command(flatten)]
    pub lod: super::LodArg,
}

/// Arguments of `shoal replay`.
#[derive(Debug, clap::Args)]
pub struct ReplayArgs {
    /// The recording to replay.
    pub run: PathBuf,
    /// When the current scripts take over, seconds into the recording.
    #[arg(long, allow_negative_numbers = true)]
    pub from: f64,
    /// Seconds to run after that (default: to the end of the recording).
    #[arg(long, allow_negative_numbers = true)]
    pub seconds: Option<f64>,
    /// The new recording to write.
    #[arg(long)]
    pub out: PathBuf,
    /// Where the scripts to replay with come from (`--scripts DIR`, `SHOAL_SCRIPTS`).
    #[command(flatten)]
    pub scripts: super::ScriptsArg,
}

/// Arguments of `shoal diff`.
#[derive(Debug, clap::Args)]
pub struct DiffArgs {
    /// The first run.
    pub a: PathBuf,
    /// The second run.
    pub b: PathBuf,
    /// Print JSON (`diverged`, `first_divergence_s`, per fish) instead of a table.
    #[arg(long)]
    pub json: bool,
    /// Also draw both runs' paths from above into this PNG.
    #[arg(long)]
    pub plot: Option<PathBuf>,
}

fn check_out(out: &Path) -> anyhow::Result<()> {
    if out.extension().is_none_or(|e| e != "shoalrun") {
        anyhow::bail!(
            "--out {}: a recording is written as a .shoalrun file",
            out.display()
        );
    }
    Ok(())
}

/// The scene's path relative to the scripts directory.
pub(super) fn scene_in(scripts: &Path, scene: Option<&Path>) -> anyhow::Result<String> {
    let scene = scene.unwrap_or(Path::new("default"));
    let candidates = [
        scene.to_path_buf(),
        scripts.join(scene),
        scripts.join("scenes").join(scene),
        scripts.join("scenes").join(scene).with_extension("lua"),
    ];
    let Some(found) = candidates.iter().find(|p| p.is_file()) else {
        anyhow::bail!(
            "no scene `{}` (looked for it as a file and in {}/scenes/)",
            scene.display(),
            scripts.display()
        );
    };
    let found = found.canonicalize().unwrap_or_else(|_| found.clone());
    let scripts = scripts
        .canonicalize()
        .unwrap_or_else(|_| scripts.to_path_buf());
    let rel = found.strip_prefix(&scripts).map_err(|_| {
        anyhow::anyhow!(
            "the scene {} is outside the scripts directory {}: a recording keeps the scripts \
             directory's files, so record a scene from inside it (or pass --scripts)",
            found.display(),
            scripts.display()
        )
    })?;
    Ok(rel
        .components()
        .map(|c| c.as_os_str().to_string_lossy())
        .collect::<Vec<_>>()
        .join("/"))
}

/// Runs `shoal record`.
pub fn record(args: RecordArgs) -> anyhow::Result<ExitCode> {
    check_out(&args.out)?;
    let source = args.scripts.resolve()?;
    println!("{source}");
    let scene = scene_in(&source.scripts, args.scene.as_deref())?;
    let lanes = args
        .lanes
        .unwrap_or_else(shoal_script::sim::default_lanes)
        .max(1);
    let run = timeline::record(&RecordSpec {
        root: &source.root,
        scripts: &source.scripts,
        scene: &scene,
        seed: args.seed,
        lanes,
        seconds: args.seconds,
        lod: args.lod.on(),
    })?;
    run.write(&args.out)?;
    let fish = run.frames.last().map_or(0, Vec::len);
    println!(
        "recorded {:.2} s of {scene} (seed {}, {lanes} lanes, level of detail {}, {fish} fish, \
         {} scripts) to {}",
        run.seconds(),
        args.seed,
        if run.header.lod { "on" } else { "off" },
        run.header.scripts.len(),
        args.out.display()
    );
    Ok(ExitCode::SUCCESS)
}

/// Runs `shoal replay`.
pub fn replay(args: ReplayArgs) -> anyhow::Result<ExitCode> {
    check_out(&args.out)?;
    let run = Run::read(&args.run)?;
    let source = args.scripts.resolve()?;
    println!("{source}");
    let name = args.run.display().to_string();
    let new = timeline::replay(&ReplaySpec {
        run: &run,
        run_name: &name,
        root: &source.root,
        scripts: &source.scripts,
        from_s: args.from,
        seconds: args.seconds,
    })
    .with_context(|| format!("replaying {name}"))?;
    new.write(&args.out)?;
    let of = new
        .header
        .replay_of
        .as_ref()
        .expect("a replay says what it replays");
    if of.changed.is_empty() {
        println!("the scripts are the recording's own: the replay should match it exactly");
    } else {
        println!(
            "scripts changed since the recording: {}",
            of.changed.join(", ")
        );
    }
    println!(
        "replayed {name} from {:.2} s to {:.2} s with these scripts into {}",
        of.from_s,
        new.seconds(),
        args.out.display()
    );
    Ok(ExitCode::SUCCESS)
}

/// Runs `shoal diff`.
pub fn diff(args: DiffArgs) -> anyhow::Result<ExitCode> {
    let a = Run::read(&args.a)?;
    let b = Run::read(&args.b)?;
    if a.header.tick_hz != b.header.tick_hz {
        anyhow::bail!(
            "{} ticks at {} Hz, {} at {} Hz: runs must share a tick rate to compare",
            args.a.display(),
            a.header.tick_hz,
            args.b.display(),
            b.header.tick_hz
        );
    }
    let d = timeline::diff(&a, &b);
    if let Some(plot) = &args.plot {
        if plot.extension().is_none_or(|e| e != "png") {
            anyhow::bail!(
                "--plot {}: the plot is written as a .png file",
                plot.display()
            );
        }
        timeline::plot::write(&a, &b, &d, plot)?;
    }
    if args.json {
        println!("{}", serde_json::to_string_pretty(&d)?);
        return Ok(ExitCode::SUCCESS);
    }
    println!(
        "compared {:.2} s ({} ticks) of {} and {}",
        d.seconds_compared,
        d.ticks_compared,
        args.a.display(),
        args.b.display()
    );
    match d.first_divergence_s {
        None => println!("identical: no fish differs at any tick"),
        Some(t) => {
            let parted: Vec<_> = d
                .fish
                .iter()
                .filter(|f| f.first_divergence_s.is_some())
                .collect();
            println!(
                "the runs part at {t:.3} s; {} of {} fish diverged:",
                parted.len(),
                d.fish.len()
            );
            println!(
                "  {:<8} {:>12} {:>16} {:>10}",
                "fish", "parts at, s", "max apart, units", "at, s"
            );
            for f in parted {
                let only = match f.only_in {
                    Some(r) => format!("  (only in run {r} at times)"),
                    None => String::new(),
                };
                println!(
                    "  {:<8} {:>12.3} {:>16.1} {:>10.2}{only}",
                    f.fish,
                    f.first_divergence_s.unwrap_or(0.0),
                    f.max_separation,
                    f.max_separation_at_s
                );
            }
        }
    }
    if let Some(plot) = &args.plot {
        println!("plot: {}", plot.display());
    }
    Ok(ExitCode::SUCCESS)
}
