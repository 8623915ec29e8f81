//! Time travel for behaviour design (issue 14), headless: record a run, replay it from any moment
//! with edited scripts, and compare two runs fish by fish.
//!
//! A simulation is deterministic (same scene, seed and scripts → the same run bit for bit,
//! whatever the number of lanes), so a recording ([`run_file::Run`]) keeps what is needed to run
//! it again — the scene, the seed, the number of lanes and the text of every script — and what it
//! showed: every fish's pose at every tick. [`replay`] re-runs the recorded scripts up to the
//! chosen moment (checking that they reproduce the recording exactly), moves that state —
//! the world and every fish's script table — into a simulation of the current scripts
//! ([`crate::Simulation::snapshot`] / `restore`), and goes on from there: what would
//! have happened had the edit been saved at that moment. [`diff`] finds where two runs part.
//!
//! Module-level Lua variables are not part of a fish's state: a replay starts the new scripts'
//! modules fresh, as a hot reload does.

pub mod compare;
pub mod compare_plot;
pub mod export;
pub mod inputs;
pub mod plot;
pub mod run_file;

use std::collections::HashMap;
use std::path::{Path, PathBuf};

use crate::{ScriptError, Simulation};
use run_file::{Pose, ReplayOf, Run, RunHeader, changed_scripts, read_scripts};
use shoal_core::world::{TICK_HZ, World};

/// Why a recording or replay failed.
#[derive(Debug, thiserror::Error)]
pub enum TimelineError {
    /// Reading or writing a recording.
    #[error(transparent)]
    File(#[from] run_file::RunFileError),
    /// The scripts or scene.
    #[error(transparent)]
    Script(#[from] ScriptError),
    /// Reading the scripts directory or writing the recorded scripts out.
    #[error("{path}: {source}")]
    Io {
        /// The path.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// Something about the request.
    #[error("{0}")]
    Invalid(String),
    /// A recorded input no longer applies.
    #[error(transparent)]
    Input(#[from] inputs::RecordedInputError),
    /// The recording's own scripts (written to a temporary directory to run again) or the
    /// species they name failed to load; the message names them as `recording:PATH`.
    #[error("{0}")]
    RecordedScripts(String),
}

/// Every fish's pose now, in the world's dense order.
pub fn poses(world: &World) -> Vec<Pose> {
    world
        .fish_ids()
        .zip(world.roots())
        .map(|(id, r)| Pose {
            index: id.index,
            generation: id.generation,
            pos: r.pos,
            heading: r.heading,
        })
        .collect()
}

/// What to record.
#[derive(Debug, Clone)]
pub struct RecordSpec<'a> {
    /// The repository root (assets).
    pub root: &'a Path,
    /// The scripts directory.
    pub scripts: &'a Path,
    /// The scene file, relative to `scripts` (`scenes/default.lua`).
    pub scene: &'a str,
    /// The seed.
    pub seed: u64,
    /// Script lanes.
    pub lanes: usize,
    /// Seconds to record.
    pub seconds: f64,
    /// Behaviour level of detail on or off (`--lod`); `None`: the scene's default.
    pub lod: Option<bool>,
}

fn ticks_of(seconds: f64) -> Result<usize, TimelineError> {
    if !(seconds.is_finite() && seconds >= 0.0) {
        return Err(TimelineError::Invalid(format!(
            "seconds is {seconds}: expected a number ≥ 0"
        )));
    }
    Ok((seconds * TICK_HZ).round() as usize)
}

fn load(spec: &RecordSpec<'_>) -> Result<Simulation, TimelineError> {
    let mut sim = Simulation::from_scene_with_scripts(
        spec.root,
        spec.scripts,
        Path::new(spec.scene),
        spec.seed,
    )?;
    sim.set_lanes(spec.lanes)?;
    if let Some(on) = spec.lod {
        sim.set_lod_on(on);
    }
    Ok(sim)
}

/// Runs `sim` for `ticks` ticks, appending a frame after each, and applying the recorded
/// `inputs` of each tick after its frame.
fn run_frames(
    sim: &mut Simulation,
    ticks: usize,
    frames: &mut Vec<Vec<Pose>>,
    inputs: &[inputs::TimedInput],
) -> Result<(), TimelineError> {
    for _ in 0..ticks {
        sim.step();
        frames.push(poses(sim.world()));
        apply_inputs(sim, inputs)?;
    }
    Ok(())
}

/// Applies the recorded inputs of the tick `sim` stands at.
fn apply_inputs(sim: &mut Simulation, inputs: &[inputs::TimedInput]) -> Result<(), TimelineError> {
    if inputs.is_empty() {
        return Ok(());
    }
    let tick = sim.world().tick_count();
    Ok(inputs::apply_at(sim, inputs, tick)?)
}

/// Records `spec.seconds` of the scene.
pub fn record(spec: &RecordSpec<'_>) -> Result<Run, TimelineError> {
    let ticks = ticks_of(spec.seconds)?;
    let scripts = read_scripts(spec.scripts).map_err(|source| TimelineError::Io {
        path: spec.scripts.to_path_buf(),
        source,
    })?;
    if !scripts.contains_key(spec.scene) {
        return Err(TimelineError::Invalid(format!(
            "the scene `{}` is not in the scripts directory {}: a recording keeps the scripts \
             directory's files, so the scene must be one of them",
            spec.scene,
            spec.scripts.display()
        )));
    }
    let mut sim = load(spec)?;
    let tank = *sim.world().tank();
    let mut frames = vec![poses(sim.world())];
    run_frames(&mut sim, ticks, &mut frames, &[])?;
    Ok(Run {
        header: RunHeader {
            shoal_version: env!("CARGO_PKG_VERSION").to_owned(),
            scene: spec.scene.to_owned(),
            seed: spec.seed,
            lanes: spec.lanes,
            tick_hz: TICK_HZ,
            tank: [tank.min.to_array(), tank.max.to_array()],
            scripts,
            replay_of: None,
            inputs: Vec::new(),
            lod: sim.world().lod().on,
        },
        frames,
    })
}

/// What to replay.
#[derive(Debug, Clone)]
pub struct ReplaySpec<'a> {
    /// The recording, and its name as the user gave it.
    pub run: &'a Run,
    /// Its name, for the new recording's header.
    pub run_name: &'a str,
    /// The repository root (assets).
    pub root: &'a Path,
    /// The scripts to replay with.
    pub scripts: &'a Path,
    /// When the new scripts take over, seconds.
    pub from_s: f64,
    /// How long after that to run (default: to the end of the recording).
    pub seconds: Option<f64>,
}

/// Re-runs `spec.run` with its own scripts up to `spec.from_s` (checking every frame against
/// the recording), then goes on with the scripts in `spec.scripts` from that state. The new
/// recording's frames up to `from_s` are the original's.
pub fn replay(spec: &ReplaySpec<'_>) -> Result<Run, TimelineError> {
    let run = spec.run;
    let total = run.frames.len() - 1;
    let (mut now, from) = resume(run, spec.root, spec.scripts, spec.from_s)?;
    let after = match spec.seconds {
        Some(s) => ticks_of(s)?,
        None => total - from,
    };
    let mut frames = run.frames[..=from].to_vec();
    run_frames(&mut now, after, &mut frames, &run.header.inputs)?;
    let scripts = read_scripts(spec.scripts).map_err(|source| TimelineError::Io {
        path: spec.scripts.to_path_buf(),
        source,
    })?;
    let changed = changed_scripts(&run.header.scripts, &scripts);
    Ok(Run {
        header: RunHeader {
            shoal_version: env!("CARGO_PKG_VERSION").to_owned(),
            scripts,
            replay_of: Some(ReplayOf {
                run: spec.run_name.to_owned(),
                from_s: run.time_of(from),
                changed,
            }),
            ..run.header.clone()
        },
        frames,
    })
}

/// The moment `at_s` of `run`, live: the recording's own scripts run up to it (each tick
/// checked against the recording), and that state — the world and every fish's script table —
/// moved into a simulation of the scripts in `scripts` (which may be edited). Returns the
/// simulation and the tick it stands at (an index into `run.frames`).
pub fn resume(
    run: &Run,
    root: &Path,
    scripts: &Path,
    at_s: f64,
) -> Result<(Simulation, usize), TimelineError> {
    let total = run.frames.len() - 1;
    let at = ticks_of(at_s)?;
    if at > total {
        return Err(TimelineError::Invalid(format!(
            "{at_s} s is after the end of the recording ({:.2} s)",
            run.seconds()
        )));
    }
    let (past, _old) = replay_recorded(run, root, at, |_, _| Ok(()))?;
    let snapshot = past.snapshot()?;
    let mut now = load(&RecordSpec {
        root,
        scripts,
        scene: &run.header.scene,
        seed: run.header.seed,
        lanes: run.header.lanes,
        seconds: 0.0,
        lod: Some(run.header.lod),
    })?;
    // Species a test spawned load on first use: load the same ones, in the same order, so
    // the state's species ids mean the same.
    let w = past.world();
    for k in now.world().num_species()..w.num_species() {
        let name = w
            .species(shoal_core::world::SpeciesId(k as u16))
            .desc
            .name
            .clone();
        now.species_id(&name)?;
    }
    drop(past);
    now.restore(&snapshot)?;
    Ok((now, at))
}

/// Runs `run` again with its own scripts (written to a temporary directory, returned with the
/// simulation so that it outlives it) from tick 0 to tick `last`, checking each frame against
/// the recording and calling `visit(k, sim)` at each tick `k` once the simulation stands there
/// (its inputs of that tick not yet applied, as when the frame was recorded).
pub fn replay_recorded(
    run: &Run,
    root: &Path,
    last: usize,
    mut visit: impl FnMut(usize, &Simulation) -> Result<(), TimelineError>,
) -> Result<(Simulation, tempfile::TempDir), TimelineError> {
    let total = run.frames.len() - 1;
    if last > total {
        return Err(TimelineError::Invalid(format!(
            "tick {last} is after the end of the recording (tick {total})"
        )));
    }
    let old = tempfile::tempdir().map_err(|source| TimelineError::Io {
        path: std::env::temp_dir(),
        source,
    })?;
    write_scripts(old.path(), &run.header.scripts)?;
    let mut past = load(&RecordSpec {
        root,
        scripts: old.path(),
        scene: &run.header.scene,
        seed: run.header.seed,
        lanes: run.header.lanes,
        seconds: 0.0,
        lod: Some(run.header.lod),
    })
    .map_err(|e| match e {
        // Name the recorded scripts as the recording's, not by the temporary directory.
        TimelineError::Script(e) => {
            let mut text = e.to_string();
            let dir = old.path();
            let mut names = vec![format!("{}/", dir.display())];
            if let Some(name) = dir.file_name() {
                names.push(format!("{}/", name.to_string_lossy()));
            }
            for n in names {
                text = text.replace(&n, "recording:");
            }
            TimelineError::RecordedScripts(text)
        }
        e => e,
    })?;
    let inputs = &run.header.inputs;
    // Inputs of tick 0 (a test's tank and first spawns) come before the first frame.
    apply_inputs(&mut past, inputs)?;
    check_frame(run, 0, &poses(past.world()))?;
    visit(0, &past)?;
    for k in 1..=last {
        past.step();
        check_frame(run, k, &poses(past.world()))?;
        visit(k, &past)?;
        apply_inputs(&mut past, inputs)?;
    }
    Ok((past, old))
}

fn same_frame(a: &[Pose], b: &[Pose]) -> bool {
    a.len() == b.len() && a.iter().zip(b).all(|(p, q)| p.same_as(q))
}

fn check_frame(run: &Run, k: usize, got: &[Pose]) -> Result<(), TimelineError> {
    if same_frame(&run.frames[k], got) {
        Ok(())
    } else {
        Err(not_reproduced(run, k))
    }
}

fn not_reproduced(run: &Run, k: usize) -> TimelineError {
    TimelineError::Invalid(format!(
        "the recording's own scripts do not reproduce it: tick {k} ({:.3} s) differs (recorded \
         by shoal {}, this is {}; a change of shoal, of the assets or of the machine's \
         floating point can do that)",
        run.time_of(k),
        run.header.shoal_version,
        env!("CARGO_PKG_VERSION")
    ))
}

/// Writes recorded scripts into `dir` (their relative paths recreated).
fn write_scripts(
    dir: &Path,
    scripts: &std::collections::BTreeMap<String, run_file::ScriptFile>,
) -> Result<(), TimelineError> {
    for (rel, file) in scripts {
        if rel.split('/').any(|c| c == ".." || c.is_empty()) || rel.starts_with('/') {
            return Err(TimelineError::Invalid(format!(
                "the recording names a script `{rel}` outside its scripts directory"
            )));
        }
        let path = dir.join(rel);
        let io = |source| TimelineError::Io {
            path: path.clone(),
            source,
        };
        if let Some(parent) = path.parent() {
            std::fs::create_dir_all(parent).map_err(io)?;
        }
        std::fs::write(&path, &file.text).map_err(io)?;
    }
    Ok(())
}

/// How one fish differs between two runs.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct FishDiff {
    /// The fish, as `#index` (generation when not 0: `#index.gen`).
    pub fish: String,
    /// When its pose first differs, seconds (`None`: never).
    pub first_divergence_s: Option<f64>,
    /// Largest distance between its two positions, world units.
    pub max_separation: f32,
    /// When that was, seconds.
    pub max_separation_at_s: f64,
    /// Set when the fish is in only one run at some tick: `"a"` or `"b"`.
    pub only_in: Option<&'static str>,
}

/// How two runs differ.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct RunDiff {
    /// Whether any fish's pose differs at any compared tick.
    pub diverged: bool,
    /// The earliest divergence, seconds.
    pub first_divergence_s: Option<f64>,
    /// Ticks compared (the shorter run's).
    pub ticks_compared: usize,
    /// Seconds compared.
    pub seconds_compared: f64,
    /// Per fish, those that diverged first, then the rest by id.
    pub fish: Vec<FishDiff>,
}

/// Compares two runs tick by tick over the shorter one.
pub fn diff(a: &Run, b: &Run) -> RunDiff {
    let n = a.frames.len().min(b.frames.len());
    let hz = a.header.tick_hz;
    let mut per: HashMap<(u32, u32), FishDiff> = HashMap::new();
    let mut first: Option<f64> = None;
    for k in 0..n {
        let t = k as f64 / hz;
        let bmap: HashMap<(u32, u32), &Pose> = b.frames[k]
            .iter()
            .map(|p| ((p.index, p.generation), p))
            .collect();
        for p in &a.frames[k] {
            let key = (p.index, p.generation);
            let d = fish_entry(&mut per, p);
            match bmap.get(&key) {
                Some(q) => {
                    if !p.same_as(q) && d.first_divergence_s.is_none() {
                        d.first_divergence_s = Some(t);
                    }
                    let sep = p.pos.distance(q.pos);
                    if sep > d.max_separation {
                        d.max_separation = sep;
                        d.max_separation_at_s = t;
                    }
                }
                None => {
                    d.only_in.get_or_insert("a");
                    d.first_divergence_s.get_or_insert(t);
                }
            }
            if let Some(f) = d.first_divergence_s {
                first = Some(first.map_or(f, |x: f64| x.min(f)));
            }
        }
        let amap: std::collections::HashSet<(u32, u32)> = a.frames[k]
            .iter()
            .map(|p| (p.index, p.generation))
            .collect();
        for q in &b.frames[k] {
            if !amap.contains(&(q.index, q.generation)) {
                let d = fish_entry(&mut per, q);
                d.only_in.get_or_insert("b");
                d.first_divergence_s.get_or_insert(t);
                first = Some(first.map_or(t, |x: f64| x.min(t)));
            }
        }
    }
    let mut fish: Vec<(&(u32, u32), FishDiff)> = per.iter().map(|(k, v)| (k, v.clone())).collect();
    fish.sort_by(|(ka, a), (kb, b)| {
        let ta = a.first_divergence_s.unwrap_or(f64::INFINITY);
        let tb = b.first_divergence_s.unwrap_or(f64::INFINITY);
        ta.total_cmp(&tb).then(ka.cmp(kb))
    });
    RunDiff {
        diverged: first.is_some(),
        first_divergence_s: first,
        ticks_compared: n.saturating_sub(1),
        seconds_compared: n.saturating_sub(1) as f64 / hz,
        fish: fish.into_iter().map(|(_, d)| d).collect(),
    }
}

/// The fish's entry of a diff, made on first sight.
fn fish_entry<'m>(per: &'m mut HashMap<(u32, u32), FishDiff>, p: &Pose) -> &'m mut FishDiff {
    per.entry((p.index, p.generation))
        .or_insert_with(|| FishDiff {
            fish: if p.generation == 0 {
                format!("#{}", p.index)
            } else {
                format!("#{}.{}", p.index, p.generation)
            },
            first_divergence_s: None,
            max_separation: 0.0,
            max_separation_at_s: 0.0,
            only_in: None,
        })
}
