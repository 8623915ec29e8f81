//! `shoal run`: the aquarium window with the tuning panel.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context;

use shoal_app::{
    AppOptions, Aquarium, OverlayToggles, Showable, SplitVersions, run_aquarium, run_window,
};
use shoal_core::world::FishId;
use shoal_script::Simulation;
use shoal_script::timeline::run_file::{Run, changed_scripts, read_scripts};
use shoal_script::versions::split_source;

/// Arguments of `shoal run`.
#[derive(Debug, Default, clap::Args)]
pub struct Args {
    /// Scene: a Lua scene (a `.lua` file, or the name of one in `scripts/scenes/`) or `porgies`
    /// (black porgies from `assets/black_porgy.glb`, built-in wander/school behaviour).
    /// Default: `scripts/scenes/default.lua`, else `porgies`.
    #[arg(long)]
    pub scene: Option<PathBuf>,
    /// Random seed of the scene.
    #[arg(long)]
    pub seed: Option<u64>,
    /// Draw this many frames, then exit (for tests and scripted runs).
    #[arg(long)]
    pub frames: Option<u64>,
    /// Number of fish (`porgies` scene; a Lua scene sets its own).
    #[arg(long)]
    pub fish: Option<usize>,
    /// Select (and follow) this fish at start (0-based, in the scene's order).
    #[arg(long)]
    pub select: Option<usize>,
    /// Show every debug overlay at start.
    #[arg(long)]
    pub overlays: bool,
    /// Multisample anti-aliasing, samples a pixel: 4 or 1. Default: 4 on a GPU, 1 on a
    /// software renderer such as lavapipe (where 4 costs ~2.7× the frame time).
    #[arg(long, value_name = "N", value_parser = parse_msaa)]
    pub msaa: Option<u32>,
    /// Open a recording (`.shoalrun`, from `shoal record`, `replay`, or a failing behaviour
    /// test's `--trace`) at `--at`: its scene and seed, paused at that moment, with the
    /// recording's future as the ghost that playing on (with the current scripts) is compared
    /// with.
    #[arg(long, value_name = "RUN", conflicts_with_all = ["scene", "seed", "fish"])]
    pub open: Option<PathBuf>,
    /// With `--open`: the moment to open at, seconds into the recording (default: its start).
    #[arg(long, value_name = "T", requires = "open")]
    pub at: Option<f64>,
    /// Split tank: run a second version of the scripts beside these, from the same scene and
    /// seed, time-locked in one window (A left, B right). B is a scripts directory, or
    /// `git:REV` for the scripts directory at revision REV of the git repository they are in.
    #[arg(long, value_name = "DIR|git:REV", conflicts_with = "open")]
    pub split: Option<String>,
    /// Where the scripts come from (`--scripts DIR`, `SHOAL_SCRIPTS`).
    #[command(flatten)]
    pub scripts: super::ScriptsArg,
    /// Behaviour level of detail (`--lod on|off`); the window focuses it on the camera's focus
    /// and the selected fish.
    #[command(flatten)]
    pub lod: super::LodArg,
    /// Debugging the behaviours from an editor (`--dap [ADDR]`). While a breakpoint holds the
    /// simulation, the window does not redraw.
    #[command(flatten)]
    pub dap: super::DapArg,
}

/// `--msaa`: 1 or 4.
fn parse_msaa(s: &str) -> anyhow::Result<u32> {
    match s.trim() {
        "1" => Ok(1),
        "4" => Ok(4),
        other => anyhow::bail!("{other:?} is not a sample count shoal draws with: 1 (off) or 4"),
    }
}

/// Runs `shoal run`.
pub fn run(args: Args) -> anyhow::Result<ExitCode> {
    let source = args.scripts.resolve()?;
    println!("{source}");
    let debugger = args.dap.start()?;
    let result = run_with(&args, &source);
    if let Some(d) = debugger {
        d.finish(i32::from(result.is_err()));
    }
    result
}

fn run_with(args: &Args, source: &super::ScriptSource) -> anyhow::Result<ExitCode> {
    if let Some(run) = &args.open {
        return open(args, source, run);
    }
    if let Some(spec) = &args.split {
        return run_split(args, source, spec);
    }
    let sim = super::render::load_scene(
        source,
        args.scene.as_deref(),
        args.seed,
        args.fish,
        &args.lod,
    )?;
    let select = super::render::check_select(args.select, sim.world())?;
    let presented = run_window(sim, options(args, select))?;
    println!("presented {presented} frames");
    Ok(ExitCode::SUCCESS)
}

fn options(args: &Args, select: Option<FishId>) -> AppOptions {
    AppOptions {
        frames: args.frames,
        select,
        overlays: if args.overlays {
            OverlayToggles::ALL
        } else {
            OverlayToggles::default()
        },
        msaa: args.msaa,
    }
}

/// `shoal run --open RUN [--at T]`.
fn open(args: &Args, source: &super::ScriptSource, path: &Path) -> anyhow::Result<ExitCode> {
    let run = Run::read(path)?;
    if let Some(lod) = args.lod.on()
        && lod != run.header.lod
    {
        anyhow::bail!(
            "--lod {}: {} was recorded with level of detail {}, and opening it runs it as it \
             was recorded (leave --lod out)",
            if lod { "on" } else { "off" },
            path.display(),
            if run.header.lod { "on" } else { "off" }
        );
    }
    let at = args.at.unwrap_or(0.0);
    let name = path.display().to_string();
    let (sim, tick) = shoal_script::timeline::resume(&run, &source.root, &source.scripts, at)
        .with_context(|| format!("opening {name} at {at} s"))?;
    let select = super::render::check_select(args.select, sim.world())?;
    let scripts = read_scripts(&source.scripts)
        .with_context(|| format!("reading {}", source.scripts.display()))?;
    let changed = changed_scripts(&run.header.scripts, &scripts);
    let ghost = run.frames[tick..]
        .iter()
        .enumerate()
        .map(|(k, frame)| {
            let ids = frame
                .iter()
                .map(|p| FishId {
                    index: p.index,
                    generation: p.generation,
                })
                .collect();
            let pos = frame.iter().map(|p| p.pos).collect();
            ((tick + k) as u64, ids, pos)
        })
        .collect();
    let note = if changed.is_empty() {
        format!(
            "opened {name} at {:.2} s (paused): the scripts are the recording's, so playing on \
             follows it exactly",
            run.time_of(tick)
        )
    } else {
        format!(
            "opened {name} at {:.2} s (paused) with these scripts ({} changed since the \
             recording: {}); the recording's future is the ghost",
            run.time_of(tick),
            changed.len(),
            changed.join(", ")
        )
    };
    let later = run
        .header
        .inputs
        .iter()
        .filter(|i| i.tick > tick as u64)
        .count();
    let note = if later > 0 {
        format!(
            "{note}. The test did {later} more things to its world after this moment (spawns, \
             food, motions); the window runs on without them, the ghost has them"
        )
    } else {
        note
    };
    println!("{note}");
    let options = options(args, select);
    let mut aq = Aquarium::new(Box::new(sim), options);
    aq.open_recording(ghost, note);
    let presented = run_aquarium(aq, options)?;
    println!("presented {presented} frames");
    Ok(ExitCode::SUCCESS)
}

/// `shoal run --split B`: A (the usual scripts) and B side by side.
fn run_split(args: &Args, source: &super::ScriptSource, spec: &str) -> anyhow::Result<ExitCode> {
    if args.fish.is_some() {
        anyhow::bail!(
            "--fish applies to `--scene porgies`; a split tank runs a Lua scene, which sets its \
             own fish"
        );
    }
    if args.scene.as_deref() == Some(Path::new("porgies")) {
        anyhow::bail!(
            "--split compares two versions of the scripts, and the `porgies` scene has none: \
             pass a Lua scene (--scene NAME)"
        );
    }
    let scene = super::timeline::scene_in(&source.scripts, args.scene.as_deref())?;
    let b = split_source(spec, &source.scripts)?;
    if !b.scripts.join(&scene).is_file() {
        anyhow::bail!(
            "--split {spec}: B ({}) has no {scene} (the scene is named relative to each scripts \
             directory)",
            b.label
        );
    }
    let seed = args.seed.unwrap_or(1);
    let load = |scripts: &Path, which: &str| -> anyhow::Result<Simulation> {
        Simulation::from_scene_reporting(
            &source.root,
            scripts,
            &scripts.join(&scene),
            seed,
            &mut super::SpawnProgress::new(),
        )
        .with_context(|| format!("loading scene `{scene}` of {which}"))
    };
    let mut a_sim = load(&source.scripts, "A")?;
    args.lod.apply(&mut a_sim);
    if let Some(line) = super::borrowed_models_line(&a_sim) {
        println!("{line}");
    }
    let mut b_sim = load(&b.scripts, &format!("B ({})", b.label))?;
    b_sim.set_lanes(a_sim.num_lanes())?;
    args.lod.apply(&mut b_sim);
    let select = super::render::check_select(args.select, a_sim.world())?;
    let versions = SplitVersions {
        a: source.scripts.display().to_string(),
        b: b.label.clone(),
        dirs: Some((source.scripts.clone(), b.scripts.clone())),
    };
    println!(
        "split tank: A = {}, B = {}; {scene}, seed {seed}, {} lanes",
        versions.a,
        versions.b,
        a_sim.num_lanes()
    );
    let options = options(args, select);
    let aq = Aquarium::new_split(Box::new(a_sim), Box::new(b_sim), versions, options)?;
    let changed = aq.split_changed_files();
    if changed.is_empty() {
        println!("no script file differs between A and B");
    } else {
        println!("files that differ: {}", changed.join(", "));
    }
    let presented = run_aquarium(aq, options)?;
    println!("presented {presented} frames");
    Ok(ExitCode::SUCCESS)
}
