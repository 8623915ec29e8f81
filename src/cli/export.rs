//! `shoal export` and `shoal inspect`: a recording out of shoal, as glTF animation or as data
//! (see [`shoal_script::timeline::export`]).
//!
//! ```text
//! shoal export RUN.shoalrun --out FILE.glb|FILE.gltf [--from T0] [--to T1] [--fish IDS]
//!              [--rate HZ] [--props] [--memory-limit MIB]
//! shoal inspect RUN.shoalrun [--at T] [--json]
//! ```

use std::io::{IsTerminal, Write};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::{Duration, Instant};

use anyhow::Context;

use shoal_script::timeline::export::{self, ExportSpec, Stage};
use shoal_script::timeline::run_file::Run;

/// Arguments of `shoal export`.
#[derive(Debug, clap::Args)]
pub struct ExportArgs {
    /// The recording (`shoal record`, `shoal replay`, or a failing behaviour test's `--trace`).
    pub run: PathBuf,
    /// The file to write: `.glb` (one binary file) or `.gltf` (JSON, with a `.bin` beside it).
    #[arg(long)]
    pub out: PathBuf,
    /// Start, seconds into the recording (default 0).
    #[arg(long)]
    pub from: Option<f64>,
    /// End, seconds into the recording (default its end).
    #[arg(long)]
    pub to: Option<f64>,
    /// Only these fish: comma-separated ids as `shoal inspect` prints them (`3`, `#3`, `3.1`
    /// for generation 1 of slot 3, `fish_3`, ranges `3-7`).
    #[arg(long)]
    pub fish: Option<String>,
    /// Keys per second (default: the recording's tick rate, 60). Lower rates make smaller
    /// files; the largest error this causes is reported.
    #[arg(long)]
    pub rate: Option<f64>,
    /// Also write the tank's edges, the rocks and the food pellets (where they are at the
    /// start) as static nodes.
    #[arg(long)]
    pub props: bool,
    /// Refuse an export that would need more memory than this, MiB (the estimate is printed).
    #[arg(long, default_value_t = 4096, value_name = "MIB")]
    pub memory_limit: u64,
    /// Where the species' assets come from (`--scripts DIR`, `SHOAL_SCRIPTS`): the recording
    /// runs again with its own scripts, but its fish models are read from the assets.
    #[command(flatten)]
    pub scripts: super::ScriptsArg,
}

/// Arguments of `shoal inspect`.
#[derive(Debug, clap::Args)]
pub struct InspectArgs {
    /// The recording.
    pub run: PathBuf,
    /// Also every fish's root, heading and joint world positions at this time, seconds.
    #[arg(long)]
    pub at: Option<f64>,
    /// Print JSON instead of text.
    #[arg(long)]
    pub json: bool,
    /// Where the species' assets come from (`--scripts DIR`, `SHOAL_SCRIPTS`).
    #[command(flatten)]
    pub scripts: super::ScriptsArg,
}

/// Reports progress on stderr: a line at most every second, once the work has taken longer
/// than a second (small exports stay quiet).
struct Progress {
    start: Instant,
    last: Instant,
    tty: bool,
}

impl Progress {
    fn new() -> Self {
        let now = Instant::now();
        Self {
            start: now,
            last: now,
            tty: std::io::stderr().is_terminal(),
        }
    }

    fn report(&mut self, stage: Stage, done: usize, total: usize) {
        let now = Instant::now();
        let finished = done == total;
        if now - self.start < Duration::from_secs(1)
            || (now - self.last < Duration::from_secs(1) && !finished)
        {
            return;
        }
        self.last = now;
        let what = match stage {
            Stage::Replay => "running the recording again: tick",
            Stage::Write => "writing fish",
        };
        let pct = (done * 100).checked_div(total).unwrap_or(100);
        let mut err = std::io::stderr().lock();
        if self.tty {
            let _ = write!(err, "\r{what} {done}/{total} ({pct} %)   ");
            if finished {
                let _ = writeln!(err);
            }
        } else {
            let _ = writeln!(err, "{what} {done}/{total} ({pct} %)");
        }
    }
}

fn out_kind(out: &Path) -> anyhow::Result<bool> {
    match out.extension().and_then(|e| e.to_str()) {
        Some("glb") => Ok(true),
        Some("gltf") => Ok(false),
        _ => anyhow::bail!(
            "--out {}: glTF is written as a .glb (binary) or .gltf (JSON with a .bin) file",
            out.display()
        ),
    }
}

/// `name` as a URI path segment: unreserved characters kept, the rest percent-encoded.
fn uri_segment(name: &str) -> String {
    name.bytes()
        .map(|b| {
            if b.is_ascii_alphanumeric() || b"-._~".contains(&b) {
                (b as char).to_string()
            } else {
                format!("%{b:02X}")
            }
        })
        .collect()
}

fn read_run(path: &Path) -> anyhow::Result<Run> {
    Ok(Run::read(path)?)
}

/// Runs `shoal export`.
pub fn run_export(args: ExportArgs) -> anyhow::Result<ExitCode> {
    let glb = out_kind(&args.out)?;
    let run = read_run(&args.run)?;
    let source = args.scripts.resolve()?;
    let fish = args
        .fish
        .as_deref()
        .map(export::parse_fish_ids)
        .transpose()?;
    let name = args.run.display().to_string();
    let started = Instant::now();
    let mut progress = Progress::new();
    let done = export::export(
        &ExportSpec {
            run: &run,
            run_name: &name,
            root: &source.root,
            from_s: args.from,
            to_s: args.to,
            fish,
            rate_hz: args.rate,
            props: args.props,
            memory_limit: args.memory_limit.saturating_mul(1 << 20),
        },
        &mut |stage, done, total| progress.report(stage, done, total),
    )
    .with_context(|| format!("exporting {name}"))?;
    let summary = format!(
        "{} fish ({}), {:.2} s at {} keys/s ({} keys)",
        done.fish,
        done.species.join(", "),
        done.seconds,
        done.rate_hz,
        done.keys
    );
    let bytes = if glb {
        let bytes = done.document.to_glb();
        if u32::try_from(bytes.len()).is_err() {
            anyhow::bail!(
                "--out {}: {} bytes, more than a .glb can hold (4 GiB); write .gltf instead",
                args.out.display(),
                bytes.len()
            );
        }
        write_file(&args.out, &bytes)?;
        bytes.len()
    } else {
        let bin = args.out.with_extension("bin");
        let bin_name = bin
            .file_name()
            .map(|n| n.to_string_lossy().into_owned())
            .unwrap_or_default();
        let (json, data) = done.document.to_gltf(&uri_segment(&bin_name));
        write_file(&bin, &data)?;
        write_file(&args.out, &json)?;
        json.len() + data.len()
    };
    println!(
        "exported {summary} to {} ({:.1} MB) in {:.1} s",
        args.out.display(),
        bytes as f64 / 1e6,
        started.elapsed().as_secs_f64()
    );
    if done.appearing_or_leaving > 0 {
        println!(
            "{} fish are not in the world for the whole span: they are scaled to 0 while absent",
            done.appearing_or_leaving
        );
    }
    if let Some((err, at, fish)) = &done.rate_error {
        println!(
            "at {} keys/s the joints are up to {err:.4} body lengths from shoal's pose between \
             keys (fish {fish} at {at:.3} s); the default rate ({} keys/s) is exact",
            done.rate_hz, run.header.tick_hz
        );
    }
    if done.props > 0 {
        println!("props: {} static nodes (tank, rocks, food)", done.props);
    }
    Ok(ExitCode::SUCCESS)
}

fn write_file(path: &Path, bytes: &[u8]) -> anyhow::Result<()> {
    std::fs::write(path, bytes).with_context(|| format!("writing {}", path.display()))
}

/// Runs `shoal inspect`.
pub fn run_inspect(args: InspectArgs) -> anyhow::Result<ExitCode> {
    let run = read_run(&args.run)?;
    let source = args.scripts.resolve()?;
    let name = args.run.display().to_string();
    let ins = export::inspect(&run, &source.root, args.at)
        .with_context(|| format!("inspecting {name}"))?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&ins)?);
        return Ok(ExitCode::SUCCESS);
    }
    println!(
        "{name}: {} recorded by shoal {}",
        ins.scene, ins.shoal_version
    );
    println!(
        "  seed {}, {} lanes, {} Hz, {:.2} s ({} frames), {} scripts, {} inputs",
        ins.seed,
        ins.lanes,
        ins.tick_hz,
        ins.seconds,
        ins.frames,
        ins.scripts.len(),
        ins.inputs
    );
    if let Some(of) = &ins.replay_of {
        println!(
            "  a replay of {} from {:.2} s (changed: {})",
            of.run,
            of.from_s,
            if of.changed.is_empty() {
                "nothing".to_owned()
            } else {
                of.changed.join(", ")
            }
        );
    }
    println!("  scripts: {}", ins.scripts.join(", "));
    println!("  {} fish:", ins.fish.len());
    println!(
        "    {:<8} {:<14} {:<12} {:>6} {:>8} {:>8}",
        "id", "species", "behaviour", "L", "from, s", "to, s"
    );
    for f in &ins.fish {
        println!(
            "    {:<8} {:<14} {:<12} {:>6} {:>8.2} {:>8.2}",
            f.id,
            f.species,
            f.behavior.as_deref().unwrap_or("-"),
            f.body_length,
            f.from_s,
            f.to_s
        );
    }
    if let Some(m) = &ins.at {
        println!(
            "  at {:.3} s (tick {}): where each fish is (its head end), heading and pitch (degrees), then each joint's world position",
            m.t_s, m.tick
        );
        for f in &m.fish {
            println!(
                "    {:<8} at ({:.2}, {:.2}, {:.2})  heading {:.1}  pitch {:.1}",
                f.id,
                f.pos[0],
                f.pos[1],
                f.pos[2],
                f.heading.to_degrees(),
                f.pitch.to_degrees()
            );
            let joints: Vec<String> = f
                .joints
                .iter()
                .map(|j| {
                    format!(
                        "{} ({:.2}, {:.2}, {:.2})",
                        j.name, j.pos[0], j.pos[1], j.pos[2]
                    )
                })
                .collect();
            for line in joints.chunks(4) {
                println!("      {}", line.join("  "));
            }
        }
    }
    Ok(ExitCode::SUCCESS)
}
