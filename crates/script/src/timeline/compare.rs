//! `shoal compare`: an A/B experiment between two versions of the scripts over many seeds.
//!
//! Each version runs the same scene from the same seeds (so seed *k* of A and seed *k* of B start
//! from the same tank), every run on its own core. Per run it measures what a designer tunes a
//! behaviour for ([`RunMeasures`]); per version the mean and its 95 % interval over the seeds;
//! and, because the runs are paired by seed, the difference B − A per seed, whose mean and 95 %
//! interval say whether the versions differ (significant when the interval leaves out 0: a
//! paired t-test at the 5 % level). Seeds can be split over machines (`--shard i/n`) and the
//! shards' JSON merged afterwards ([`merge`]).

use std::collections::{BTreeMap, HashMap};
use std::path::Path;

use glam::Vec3;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use statrs::distribution::{ContinuousCDF, StudentsT};

use super::TimelineError;
use super::run_file::read_scripts;
use crate::Simulation;
use shoal_core::world::{FishId, TICK_HZ, World};

/// How often polarization and nearest-neighbour distance are sampled, seconds.
pub const SAMPLE_EVERY_S: f64 = 0.5;

/// What one run of one version measured.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RunMeasures {
    /// The seed.
    pub seed: u64,
    /// Pellets eaten during the run.
    pub pellets_eaten: f64,
    /// Seconds to the first pellet eaten (`None`: nothing was eaten).
    pub first_bite_s: Option<f64>,
    /// Mean school polarization, |mean unit heading| of the schooling fish (behaviour `school`;
    /// every fish when no fish schools), sampled every [`SAMPLE_EVERY_S`].
    pub polarization: f64,
    /// Mean distance from each of those fish to its nearest other one, in its body lengths,
    /// sampled likewise.
    pub nearest_neighbour_l: f64,
    /// Times a fish touched a tank wall (the contact stage had to push it back in).
    pub wall_contacts: f64,
    /// Times a fish touched a rock.
    pub rock_contacts: f64,
    /// Catches counted by the scripts: the sum of every fish's `memory.catches` at the end.
    pub catches: f64,
    /// Script decisions that raised an error or were stopped by a limit.
    pub script_errors: f64,
    /// CPU microseconds per decision (behaviour and sensing). A timing, so it varies from run to
    /// run and with what else the machine does; the other measures are exact.
    pub decision_us: f64,
    /// The scene's own measures (`measures = { NAME = function(fish) … end }`), by name: the
    /// mean over fish and once-a-second samples (`None`: no fish gave a value).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub measures: BTreeMap<String, Option<f64>>,
    /// The scene's measures that failed during the run, by name: how many calls, and the
    /// first error (`file:line: message`).
    #[serde(default, skip_serializing_if = "BTreeMap::is_empty")]
    pub measure_errors: BTreeMap<String, MeasureErrors>,
}

/// How a scene measure failed in one run.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MeasureErrors {
    /// Calls that raised an error or returned something other than a number.
    pub count: u64,
    /// The first error, `file:line: message`.
    pub first: String,
}

/// One measure: its JSON key, its label, and how to read it from a run.
struct Measure {
    key: &'static str,
    label: &'static str,
    get: fn(&RunMeasures) -> Option<f64>,
}

const MEASURES: [Measure; 9] = [
    Measure {
        key: "pellets_eaten",
        label: "pellets eaten",
        get: |m| Some(m.pellets_eaten),
    },
    Measure {
        key: "first_bite_s",
        label: "time to first bite, s",
        get: |m| m.first_bite_s,
    },
    Measure {
        key: "polarization",
        label: "school polarization",
        get: |m| Some(m.polarization),
    },
    Measure {
        key: "nearest_neighbour_l",
        label: "nearest neighbour, L",
        get: |m| Some(m.nearest_neighbour_l),
    },
    Measure {
        key: "wall_contacts",
        label: "wall contacts",
        get: |m| Some(m.wall_contacts),
    },
    Measure {
        key: "rock_contacts",
        label: "rock contacts",
        get: |m| Some(m.rock_contacts),
    },
    Measure {
        key: "catches",
        label: "predator catches",
        get: |m| Some(m.catches),
    },
    Measure {
        key: "script_errors",
        label: "script errors",
        get: |m| Some(m.script_errors),
    },
    Measure {
        key: "decision_us",
        label: "decision cost, µs",
        get: |m| Some(m.decision_us),
    },
];

/// The value of the measure with JSON key `key` in run `r` (`None` for an unknown key or a
/// measure the run does not have, such as the time to a first bite that never came): one of
/// compare's own, else one of the scene's by its name.
pub fn value(key: &str, r: &RunMeasures) -> Option<f64> {
    match MEASURES.iter().find(|m| m.key == key) {
        Some(m) => (m.get)(r),
        None => r.measures.get(key).copied().flatten(),
    }
}

/// The JSON keys of compare's own measures: a scene's measure may not take one of them.
pub fn builtin_keys() -> impl Iterator<Item = &'static str> {
    MEASURES.iter().map(|m| m.key)
}

/// A mean with its 95 % interval (Student's t over `n` values; no interval below 2 values).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Estimate {
    /// Values it is made of.
    pub n: usize,
    /// Their mean (`None` with no values).
    pub mean: Option<f64>,
    /// The 95 % interval's low end.
    pub low: Option<f64>,
    /// The 95 % interval's high end.
    pub high: Option<f64>,
}

impl Estimate {
    /// The mean of `values` and its 95 % interval.
    pub fn of(values: &[f64]) -> Self {
        let n = values.len();
        if n == 0 {
            return Self {
                n,
                mean: None,
                low: None,
                high: None,
            };
        }
        let mean = values.iter().sum::<f64>() / n as f64;
        if n < 2 {
            return Self {
                n,
                mean: Some(mean),
                low: None,
                high: None,
            };
        }
        let var = values.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1) as f64;
        let t = StudentsT::new(0.0, 1.0, (n - 1) as f64)
            .map(|d| d.inverse_cdf(0.975))
            .unwrap_or(f64::NAN);
        let half = t * (var / n as f64).sqrt();
        Self {
            n,
            mean: Some(mean),
            low: Some(mean - half),
            high: Some(mean + half),
        }
    }

    /// Whether the interval leaves out 0 (always false without an interval).
    pub fn excludes_zero(&self) -> bool {
        match (self.low, self.high) {
            (Some(l), Some(h)) => l > 0.0 || h < 0.0,
            _ => false,
        }
    }
}

/// One measure compared.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct MeasureSummary {
    /// Its JSON key (`pellets_eaten`).
    pub measure: String,
    /// Its label (`pellets eaten`).
    pub label: String,
    /// Version A over its seeds.
    pub a: Estimate,
    /// Version B over its seeds.
    pub b: Estimate,
    /// B − A, seed by seed (seeds where both have a value).
    pub b_minus_a: Estimate,
    /// Whether B − A's 95 % interval leaves out 0.
    pub significant: bool,
}

/// One version of the scripts in a comparison.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Version {
    /// The scripts directory as given.
    pub dir: String,
    /// CRC-32 of each `.lua` file, by path inside the directory.
    pub scripts: BTreeMap<String, u32>,
    /// Each seed's run.
    pub runs: Vec<RunMeasures>,
    /// Behaviour level of detail as `--lod-a`/`--lod-b` set it (`None`: the scene's default).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lod: Option<bool>,
}

/// A comparison, or one shard of one (its JSON is what `--json` prints and `--merge` reads).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Comparison {
    /// The format of this JSON.
    pub format: u32,
    /// The shoal that ran it.
    pub shoal_version: String,
    /// The scene, relative to each scripts directory.
    pub scene: String,
    /// Simulated seconds per run.
    pub seconds: f64,
    /// The shard this is (`(i, n)`, 1-based), or `None` for all seeds.
    pub shard: Option<(u32, u32)>,
    /// The script files that differ between A and B.
    pub changed: Vec<String>,
    /// Version A.
    pub a: Version,
    /// Version B.
    pub b: Version,
    /// Per measure, A, B and B − A.
    pub summary: Vec<MeasureSummary>,
}

/// The JSON format [`Comparison`] is written in.
pub const FORMAT: u32 = 1;

/// What to compare.
#[derive(Debug, Clone)]
pub struct CompareSpec<'a> {
    /// The repository root (assets).
    pub root: &'a Path,
    /// Version A's scripts directory.
    pub a: &'a Path,
    /// Version B's scripts directory.
    pub b: &'a Path,
    /// The scene, relative to each scripts directory (`scenes/default.lua`).
    pub scene: &'a str,
    /// Seeds run: `1..=seeds`.
    pub seeds: u64,
    /// This shard's part of the seeds (`(i, n)`, 1-based): seeds `s` with `(s - 1) % n == i - 1`.
    pub shard: Option<(u32, u32)>,
    /// Simulated seconds per run.
    pub seconds: f64,
    /// Behaviour level of detail for A (`--lod-a on|off`; `None`: the scene's default).
    pub lod_a: Option<bool>,
    /// The same for B (`--lod-b`).
    pub lod_b: Option<bool>,
}

/// The seeds a shard runs.
pub fn shard_seeds(seeds: u64, shard: Option<(u32, u32)>) -> Vec<u64> {
    (1..=seeds)
        .filter(|s| shard.is_none_or(|(i, n)| (s - 1) % u64::from(n) == u64::from(i - 1)))
        .collect()
}

/// What `--shard` was given: a fixed `i/n`, or `auto` (optionally `auto/n`), resolved from the
/// scheduler's environment when the command runs ([`resolve_shard`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ShardArg {
    /// `i/n`, 1 ≤ i ≤ n.
    Fixed(u32, u32),
    /// `auto` or `auto/n`: the index (and, without `/n`, the count) from the environment.
    Auto(Option<u32>),
}

/// The schedulers' variables `--shard auto` reads, in the order tried: `SHOAL_SHARD` (`i/n`);
/// a Slurm job array (`SLURM_ARRAY_TASK_ID`, `SLURM_ARRAY_TASK_MIN`, `SLURM_ARRAY_TASK_COUNT`);
/// GitLab CI's `parallel:` (`CI_NODE_INDEX`, 1-based, `CI_NODE_TOTAL`); a Kubernetes Indexed
/// Job (`JOB_COMPLETION_INDEX`, 0-based; the count is not in its environment: `--shard auto/n`).
pub const SHARD_VARIABLES: [&str; 7] = [
    "SHOAL_SHARD",
    "SLURM_ARRAY_TASK_ID",
    "SLURM_ARRAY_TASK_MIN",
    "SLURM_ARRAY_TASK_COUNT",
    "CI_NODE_INDEX",
    "CI_NODE_TOTAL",
    "JOB_COMPLETION_INDEX",
];

/// `--shard` given something shoal cannot use.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ShardError {
    /// Not `i/n` with 1 ≤ i ≤ n, nor `auto` or `auto/n`.
    #[error("--shard {0}: expected i/n with 1 ≤ i ≤ n, such as 2/4, or auto (auto/n)")]
    Syntax(String),
    /// `auto`, and none of the schedulers' variables is set.
    #[error(
        "--shard {0}: no scheduler's shard index in the environment (looked for SHOAL_SHARD, \
         SLURM_ARRAY_TASK_ID, CI_NODE_INDEX, JOB_COMPLETION_INDEX)"
    )]
    NoScheduler(String),
    /// A scheduler's variable holds something that is not a shard of the count.
    #[error("--shard {arg}: {variable}={value} {why}")]
    Variable {
        /// What `--shard` was given.
        arg: String,
        /// The variable.
        variable: &'static str,
        /// Its value.
        value: String,
        /// What is wrong with it.
        why: &'static str,
    },
}

/// Parses `i/n` (1 ≤ i ≤ n).
pub fn parse_shard(text: &str) -> Result<(u32, u32), ShardError> {
    let bad = || ShardError::Syntax(text.to_owned());
    let (i, n) = text.split_once('/').ok_or_else(bad)?;
    let (i, n): (u32, u32) = (
        i.trim().parse().map_err(|_| bad())?,
        n.trim().parse().map_err(|_| bad())?,
    );
    if i == 0 || n == 0 || i > n {
        return Err(bad());
    }
    Ok((i, n))
}

/// Parses `--shard`: `i/n`, `auto` or `auto/n`.
pub fn parse_shard_arg(text: &str) -> Result<ShardArg, ShardError> {
    match text.trim().strip_prefix("auto") {
        Some("") => Ok(ShardArg::Auto(None)),
        Some(rest) => match rest.strip_prefix('/').map(|n| n.trim().parse::<u32>()) {
            Some(Ok(n)) if n > 0 => Ok(ShardArg::Auto(Some(n))),
            _ => Err(ShardError::Syntax(text.to_owned())),
        },
        None => parse_shard(text).map(|(i, n)| ShardArg::Fixed(i, n)),
    }
}

/// The shard `arg` names, reading the schedulers' variables through `env` (see
/// [`SHARD_VARIABLES`]); `auto/n` takes its count from `n`, over any in the environment.
pub fn resolve_shard(
    arg: ShardArg,
    env: impl Fn(&str) -> Option<String>,
) -> Result<(u32, u32), ShardError> {
    let count = match arg {
        ShardArg::Fixed(i, n) => return Ok((i, n)),
        ShardArg::Auto(count) => count,
    };
    let name = match count {
        Some(n) => format!("auto/{n}"),
        None => "auto".to_owned(),
    };
    let number = |variable: &'static str| -> Result<Option<u32>, ShardError> {
        env(variable)
            .map(|value| {
                value
                    .trim()
                    .parse::<u32>()
                    .map_err(|_| ShardError::Variable {
                        arg: name.clone(),
                        variable,
                        value: value.clone(),
                        why: "is not a whole number",
                    })
            })
            .transpose()
    };
    let check = |i: u32, n: Option<u32>, variable: &'static str| {
        let n = count.or(n).ok_or(ShardError::Variable {
            arg: name.clone(),
            variable,
            value: i.to_string(),
            why: "gives the index but not the count: use --shard auto/N",
        })?;
        if i == 0 || i > n {
            return Err(ShardError::Variable {
                arg: name.clone(),
                variable,
                value: env(variable).unwrap_or_default(),
                why: "is not a shard of the count",
            });
        }
        Ok((i, n))
    };
    if let Some(value) = env("SHOAL_SHARD") {
        let (i, n) = parse_shard(&value).map_err(|_| ShardError::Variable {
            arg: name.clone(),
            variable: "SHOAL_SHARD",
            value: value.clone(),
            why: "is not i/n with 1 ≤ i ≤ n",
        })?;
        return check(i, Some(n), "SHOAL_SHARD");
    }
    if let Some(id) = number("SLURM_ARRAY_TASK_ID")? {
        // Arrays may start anywhere (--array=0-7 or 1-8): the shard is the id's place in it.
        let min = number("SLURM_ARRAY_TASK_MIN")?.unwrap_or(1).min(id);
        return check(
            id - min + 1,
            number("SLURM_ARRAY_TASK_COUNT")?,
            "SLURM_ARRAY_TASK_ID",
        );
    }
    if let Some(i) = number("CI_NODE_INDEX")? {
        return check(i, number("CI_NODE_TOTAL")?, "CI_NODE_INDEX");
    }
    if let Some(i) = number("JOB_COMPLETION_INDEX")? {
        return check(i + 1, None, "JOB_COMPLETION_INDEX");
    }
    Err(ShardError::NoScheduler(name))
}

/// Runs the experiment: every (version, seed) run on its own core.
pub fn compare(spec: &CompareSpec<'_>) -> Result<Comparison, TimelineError> {
    if !(spec.seconds.is_finite() && spec.seconds > 0.0) {
        return Err(TimelineError::Invalid(format!(
            "--seconds {}: expected a number of seconds > 0",
            spec.seconds
        )));
    }
    if spec.seeds == 0 {
        return Err(TimelineError::Invalid(
            "--seeds 0: an experiment needs at least one seed (2 or more for intervals)".into(),
        ));
    }
    let hashes = |dir: &Path| {
        read_scripts(dir)
            .map(|s| s.into_iter().map(|(k, v)| (k, v.crc32)).collect())
            .map_err(|source| TimelineError::Io {
                path: dir.to_path_buf(),
                source,
            })
    };
    let (ha, hb): (BTreeMap<String, u32>, BTreeMap<String, u32>) =
        (hashes(spec.a)?, hashes(spec.b)?);
    for (dir, h) in [(spec.a, &ha), (spec.b, &hb)] {
        if !h.contains_key(spec.scene) {
            return Err(TimelineError::Invalid(format!(
                "{}: no scene {} in it (both versions run the same scene, named relative to each \
                 scripts directory)",
                dir.display(),
                spec.scene
            )));
        }
    }
    let seeds = shard_seeds(spec.seeds, spec.shard);
    let jobs: Vec<(usize, u64)> = [0, 1]
        .iter()
        .flat_map(|&v| seeds.iter().map(move |&s| (v, s)))
        .collect();
    let results: Vec<Result<(usize, RunMeasures), TimelineError>> = jobs
        .par_iter()
        .map(|&(v, seed)| {
            let (dir, lod) = if v == 0 {
                (spec.a, spec.lod_a)
            } else {
                (spec.b, spec.lod_b)
            };
            measure_run(spec.root, dir, spec.scene, seed, spec.seconds, lod).map(|m| (v, m))
        })
        .collect();
    let mut runs: [Vec<RunMeasures>; 2] = [Vec::new(), Vec::new()];
    for r in results {
        let (v, m) = r?;
        runs[v].push(m);
    }
    let [ra, rb] = runs;
    let changed = super::run_file::changed_keys(&ha, &hb);
    Ok(finish(Comparison {
        format: FORMAT,
        shoal_version: env!("CARGO_PKG_VERSION").to_owned(),
        scene: spec.scene.to_owned(),
        seconds: spec.seconds,
        shard: spec.shard,
        changed,
        a: Version {
            dir: spec.a.display().to_string(),
            scripts: ha,
            runs: ra,
            lod: spec.lod_a,
        },
        b: Version {
            dir: spec.b.display().to_string(),
            scripts: hb,
            runs: rb,
            lod: spec.lod_b,
        },
        summary: Vec::new(),
    }))
}

/// Sorts the runs by seed and computes the summary.
fn finish(mut c: Comparison) -> Comparison {
    c.a.runs.sort_by_key(|m| m.seed);
    c.b.runs.sort_by_key(|m| m.seed);
    c.summary = summarize(&c.a.runs, &c.b.runs);
    c
}

/// Per measure: A, B, and B − A paired by seed; compare's own measures first, then the scenes'
/// own, by name (a measure only one version's scene has is summarized with no values for the
/// other).
pub fn summarize(a: &[RunMeasures], b: &[RunMeasures]) -> Vec<MeasureSummary> {
    let scene_measures: std::collections::BTreeSet<&String> =
        a.iter().chain(b).flat_map(|r| r.measures.keys()).collect();
    let builtin = MEASURES
        .iter()
        .map(|m| summary_of(a, b, m.key, m.label, m.get));
    let scene = scene_measures
        .into_iter()
        .map(|name| summary_of(a, b, name, name, |r: &RunMeasures| value(name, r)));
    builtin.chain(scene).collect()
}

fn summary_of(
    a: &[RunMeasures],
    b: &[RunMeasures],
    key: &str,
    label: &str,
    get: impl Fn(&RunMeasures) -> Option<f64>,
) -> MeasureSummary {
    let by_seed: HashMap<u64, &RunMeasures> = b.iter().map(|m| (m.seed, m)).collect();
    let va: Vec<f64> = a.iter().filter_map(&get).collect();
    let vb: Vec<f64> = b.iter().filter_map(&get).collect();
    let d: Vec<f64> = a
        .iter()
        .filter_map(|ra| {
            let rb = by_seed.get(&ra.seed)?;
            Some(get(rb)? - get(ra)?)
        })
        .collect();
    let diff = Estimate::of(&d);
    MeasureSummary {
        measure: key.to_owned(),
        label: label.to_owned(),
        a: Estimate::of(&va),
        b: Estimate::of(&vb),
        b_minus_a: diff,
        significant: diff.excludes_zero(),
    }
}

/// Why shards could not be merged (see [`merge`]). Each names the shard.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum MergeError {
    /// Nothing to merge.
    #[error("--merge needs at least one shard's JSON")]
    NoShards,
    /// A shard of another comparison format.
    #[error("{name}: comparison format {found} (this shoal reads {FORMAT})")]
    Format {
        /// The shard, as named on the command line.
        name: String,
        /// Its format.
        found: u32,
    },
    /// A shard whose scene, length or scripts differ from the first's.
    #[error(
        "{name} is not a shard of the same experiment as {first}: the scene, the seconds or the \
         scripts of A or B differ"
    )]
    OtherExperiment {
        /// The shard.
        name: String,
        /// The first shard, which the others must match.
        first: String,
    },
    /// Two shards ran the same seed.
    #[error("{name}: seed {seed} is already in another shard (shards must not overlap)")]
    SeedTwice {
        /// The shard.
        name: String,
        /// The seed.
        seed: u64,
    },
}

/// Merges shards of one experiment (same scene, length and scripts; no seed twice) into one
/// comparison with its summary recomputed over every seed.
pub fn merge(parts: Vec<(String, Comparison)>) -> Result<Comparison, MergeError> {
    let mut parts = parts.into_iter();
    let Some((first_name, mut all)) = parts.next() else {
        return Err(MergeError::NoShards);
    };
    if all.format != FORMAT {
        return Err(MergeError::Format {
            name: first_name,
            found: all.format,
        });
    }
    for (name, part) in parts {
        if part.format != FORMAT {
            return Err(MergeError::Format {
                name,
                found: part.format,
            });
        }
        let same = part.scene == all.scene
            && part.seconds == all.seconds
            && part.a.scripts == all.a.scripts
            && part.b.scripts == all.b.scripts
            && part.a.lod == all.a.lod
            && part.b.lod == all.b.lod;
        if !same {
            return Err(MergeError::OtherExperiment {
                name,
                first: first_name,
            });
        }
        for (mine, theirs) in [
            (&mut all.a.runs, part.a.runs),
            (&mut all.b.runs, part.b.runs),
        ] {
            for r in theirs {
                if mine.iter().any(|m| m.seed == r.seed) {
                    return Err(MergeError::SeedTwice { name, seed: r.seed });
                }
                mine.push(r);
            }
        }
    }
    all.shard = None;
    Ok(finish(all))
}

/// Runs one version of the scripts for one seed and measures it.
pub fn measure_run(
    root: &Path,
    scripts: &Path,
    scene: &str,
    seed: u64,
    seconds: f64,
    lod: Option<bool>,
) -> Result<RunMeasures, TimelineError> {
    let mut sim = Simulation::from_scene_with_scripts(root, scripts, Path::new(scene), seed)
        .map_err(|e| TimelineError::Invalid(format!("{}: {e}", scripts.display())))?;
    if let Some(name) = sim
        .measure_names()
        .iter()
        .find(|n| builtin_keys().any(|k| k == n.as_str()))
    {
        return Err(TimelineError::Invalid(format!(
            "{}: {scene}: measures.{name} has the name of one of compare's own measures ({}); \
             give it another name",
            scripts.display(),
            builtin_keys().collect::<Vec<_>>().join(", ")
        )));
    }
    if let Some(on) = lod {
        sim.set_lod_on(on);
    }
    // The experiment's parallelism is across runs; one lane per run keeps each on one core.
    sim.set_lanes(1)?;
    sim.reset_profile();
    let ticks = (seconds * TICK_HZ).round() as u64;
    let sample_every = ((SAMPLE_EVERY_S * TICK_HZ).round() as u64).max(1);
    let mut contact = Contacts::default();
    let (mut pol, mut nn) = (Vec::new(), Vec::new());
    let start = sim.world().time();
    let eaten_before: usize = sim.world().eaten_foods().count();
    for tick in 1..=ticks {
        sim.step();
        contact.count(sim.world());
        if tick % sample_every == 0 {
            let (p, n) = school_sample(sim.world());
            pol.extend(p);
            nn.extend(n);
        }
    }
    let world = sim.world();
    let eaten: Vec<f64> = world
        .eaten_foods()
        .filter_map(|(_, f)| f.eaten_at)
        .filter(|&t| t >= start)
        .collect();
    let catches = world
        .fish_ids()
        .filter_map(|id| sim.memory_json(id).get("catches")?.as_f64())
        .fold(0.0, |sum, c| sum + c);
    let profile = sim.profile();
    let (calls, ms, errors) = profile.iter().fold((0u64, 0f64, 0u64), |acc, p| {
        (
            acc.0 + p.calls,
            acc.1 + p.behavior_ms + p.sensing_ms,
            acc.2 + p.errors + p.limit_stops,
        )
    });
    let mean = |v: &[f64]| {
        if v.is_empty() {
            0.0
        } else {
            v.iter().sum::<f64>() / v.len() as f64
        }
    };
    let scene_measures = sim.measures();
    Ok(RunMeasures {
        measures: scene_measures
            .iter()
            .map(|(name, m)| (name.clone(), m.mean))
            .collect(),
        measure_errors: scene_measures
            .into_iter()
            .filter_map(|(name, m)| {
                let first = m.first_error?;
                Some((
                    name,
                    MeasureErrors {
                        count: m.errors,
                        first,
                    },
                ))
            })
            .collect(),
        seed,
        pellets_eaten: (world.eaten_foods().count() - eaten_before) as f64,
        first_bite_s: eaten
            .iter()
            .copied()
            .fold(None, |m: Option<f64>, t| Some(m.map_or(t, |m| m.min(t))))
            .map(|t| t - start),
        polarization: mean(&pol),
        nearest_neighbour_l: mean(&nn),
        wall_contacts: contact.wall as f64,
        rock_contacts: contact.rock as f64,
        catches,
        script_errors: errors as f64,
        decision_us: if calls == 0 {
            0.0
        } else {
            ms * 1000.0 / calls as f64
        },
    })
}

/// Counts contact events: a fish that was clear last tick and had to be pushed back this tick.
#[derive(Default)]
struct Contacts {
    touching: HashMap<FishId, bool>,
    wall: u64,
    rock: u64,
}

impl Contacts {
    fn count(&mut self, world: &World) {
        let tank = world.tank();
        for id in world.fish_ids() {
            let Some(f) = world.fish(id) else { continue };
            let now = f.contact();
            let was = self.touching.insert(id, now).unwrap_or(false);
            if !now || was {
                continue;
            }
            let p = f.root().pos;
            let to_wall = (p - tank.min).min(tank.max - p).min_element();
            let to_rock = world
                .obstacles()
                .iter()
                .map(|o| p.distance(o.pos) - o.radius)
                .fold(f32::INFINITY, f32::min);
            if to_rock < to_wall {
                self.rock += 1;
            } else {
                self.wall += 1;
            }
        }
    }
}

/// Polarization and mean nearest-neighbour distance (body lengths) of the schooling fish now
/// (every fish when none schools); nothing with fewer than two.
fn school_sample(world: &World) -> (Option<f64>, Option<f64>) {
    let schooling: Vec<FishId> = world
        .fish_ids()
        .filter(|&id| world.behavior_of(id) == Some("school"))
        .collect();
    let ids: Vec<FishId> = if schooling.is_empty() {
        world.fish_ids().collect()
    } else {
        schooling
    };
    if ids.len() < 2 {
        return (None, None);
    }
    let fish: Vec<(Vec3, f32, f32)> = ids
        .iter()
        .filter_map(|&id| {
            let f = world.fish(id)?;
            Some((f.root().pos, f.root().heading, f.species().body_length()))
        })
        .collect();
    let pol = shoal_core::world::measures::polarization(fish.iter().map(|f| f.1));
    let mut sum = 0f64;
    for (i, (p, _, l)) in fish.iter().enumerate() {
        let nearest = fish
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != i)
            .map(|(_, q)| p.distance(q.0))
            .fold(f32::INFINITY, f32::min);
        sum += f64::from(nearest / l.max(f32::EPSILON));
    }
    (Some(pol), Some(sum / fish.len() as f64))
}

#[cfg(test)]
mod tests {
    /// `--shard auto` as each scheduler runs it: the index (and count) from its variables,
    /// 0- or 1-based as it numbers them; one line naming the variable for each thing wrong.
    #[test]
    fn auto_shards_read_each_schedulers_variables() {
        let with = |vars: &[(&str, &str)]| {
            let vars: Vec<(String, String)> = vars
                .iter()
                .map(|(k, v)| ((*k).to_owned(), (*v).to_owned()))
                .collect();
            move |name: &str| vars.iter().find(|(k, _)| k == name).map(|(_, v)| v.clone())
        };
        let auto = ShardArg::Auto(None);
        let slurm = with(&[
            ("SLURM_ARRAY_TASK_ID", "3"),
            ("SLURM_ARRAY_TASK_MIN", "0"),
            ("SLURM_ARRAY_TASK_COUNT", "8"),
        ]);
        assert_eq!(resolve_shard(auto, slurm), Ok((4, 8)));
        let slurm_1 = with(&[
            ("SLURM_ARRAY_TASK_ID", "8"),
            ("SLURM_ARRAY_TASK_MIN", "1"),
            ("SLURM_ARRAY_TASK_COUNT", "8"),
        ]);
        assert_eq!(resolve_shard(auto, slurm_1), Ok((8, 8)));
        let gitlab = with(&[("CI_NODE_INDEX", "2"), ("CI_NODE_TOTAL", "5")]);
        assert_eq!(resolve_shard(auto, gitlab), Ok((2, 5)));
        let k8s = with(&[("JOB_COMPLETION_INDEX", "0")]);
        assert_eq!(resolve_shard(ShardArg::Auto(Some(4)), &k8s), Ok((1, 4)));
        let e = resolve_shard(auto, &k8s).unwrap_err().to_string();
        assert!(
            e.contains("JOB_COMPLETION_INDEX") && e.contains("auto/N"),
            "{e}"
        );
        assert_eq!(
            resolve_shard(auto, with(&[("SHOAL_SHARD", "3/4")])),
            Ok((3, 4))
        );
        assert_eq!(resolve_shard(ShardArg::Fixed(2, 3), with(&[])), Ok((2, 3)));
        let e = resolve_shard(auto, with(&[])).unwrap_err().to_string();
        assert!(
            e.contains("--shard auto: no scheduler") && e.contains("SLURM_ARRAY_TASK_ID"),
            "{e}"
        );
        let e = resolve_shard(
            auto,
            with(&[("CI_NODE_INDEX", "6"), ("CI_NODE_TOTAL", "5")]),
        )
        .unwrap_err()
        .to_string();
        assert!(
            e.contains("CI_NODE_INDEX=6") && e.contains("not a shard"),
            "{e}"
        );
        let e = resolve_shard(auto, with(&[("SLURM_ARRAY_TASK_ID", "x")]))
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("SLURM_ARRAY_TASK_ID=x is not a whole number"),
            "{e}"
        );
    }

    use super::*;

    #[test]
    fn an_interval_matches_students_t() {
        // n = 5, mean 3, sample sd = sqrt(2.5); t(0.975, 4) = 2.776.
        let e = Estimate::of(&[1.0, 2.0, 3.0, 4.0, 5.0]);
        assert_eq!(e.mean, Some(3.0));
        let half = 2.776_445 * (2.5f64 / 5.0).sqrt();
        assert!((e.high.unwrap() - (3.0 + half)).abs() < 1e-4, "{e:?}");
        assert!((e.low.unwrap() - (3.0 - half)).abs() < 1e-4, "{e:?}");
        assert!(e.excludes_zero());
        assert!(!Estimate::of(&[-1.0, 1.0, 0.5]).excludes_zero());
        assert_eq!(Estimate::of(&[2.0]).low, None);
        assert!(!Estimate::of(&[2.0]).excludes_zero());
    }

    #[test]
    fn shards_split_the_seeds_without_overlap() {
        let all: Vec<u64> = (1..=3)
            .flat_map(|i| shard_seeds(10, Some((i, 3))))
            .collect();
        let mut sorted = all.clone();
        sorted.sort_unstable();
        assert_eq!(sorted, (1..=10).collect::<Vec<_>>());
        assert_eq!(shard_seeds(10, Some((2, 3))), vec![2, 5, 8]);
        assert_eq!(parse_shard("2/4"), Ok((2, 4)));
        assert_eq!(parse_shard_arg("2/4"), Ok(ShardArg::Fixed(2, 4)));
        assert_eq!(parse_shard_arg("auto"), Ok(ShardArg::Auto(None)));
        assert_eq!(parse_shard_arg("auto/8"), Ok(ShardArg::Auto(Some(8))));
        for bad in ["auto/0", "auto/x", "autox", "auto8"] {
            assert!(parse_shard_arg(bad).is_err(), "{bad}");
        }
        for bad in ["0/4", "5/4", "2", "a/b", "1/0"] {
            assert!(parse_shard(bad).is_err(), "{bad}");
        }
    }

    fn run(seed: u64, eaten: f64) -> RunMeasures {
        RunMeasures {
            seed,
            pellets_eaten: eaten,
            first_bite_s: (eaten > 0.0).then_some(10.0 / eaten),
            polarization: 0.5,
            nearest_neighbour_l: 1.0,
            wall_contacts: 0.0,
            rock_contacts: 0.0,
            catches: 0.0,
            script_errors: 0.0,
            decision_us: 1.0,
            measures: BTreeMap::new(),
            measure_errors: BTreeMap::new(),
        }
    }

    /// A scene's own measures are summarized after compare's, by name, paired by seed like
    /// them; one only B's scene has gets no values for A; and they survive the JSON shards
    /// carry to `--merge`.
    #[test]
    fn scene_measures_are_summarized_beside_the_builtin_ones() {
        let with = |seed: u64, name: &str, v: f64| {
            let mut r = run(seed, 1.0);
            r.measures.insert(name.to_owned(), Some(v));
            r
        };
        let a = vec![with(1, "hiding", 0.2), with(2, "hiding", 0.4)];
        let mut b = vec![with(1, "hiding", 0.5), with(2, "hiding", 0.7)];
        b[0].measures.insert("new".into(), Some(3.0));
        b[1].measures.insert("new".into(), None);
        let s = summarize(&a, &b);
        assert_eq!(s.len(), MEASURES.len() + 2);
        let hiding = &s[MEASURES.len()];
        assert_eq!((hiding.measure.as_str(), hiding.b_minus_a.n), ("hiding", 2));
        assert!((hiding.b_minus_a.mean.unwrap() - 0.3).abs() < 1e-12);
        assert!(hiding.significant, "{hiding:?}");
        let new = &s[MEASURES.len() + 1];
        assert_eq!((new.a.n, new.b.n, new.b_minus_a.n), (0, 1, 0));
        let json = serde_json::to_string(&b[0]).unwrap();
        assert!(
            json.contains(r#""measures":{"hiding":0.5,"new":3.0}"#),
            "{json}"
        );
        let back: RunMeasures = serde_json::from_str(&json).unwrap();
        assert_eq!(back, b[0]);
        assert_eq!(value("hiding", &back), Some(0.5));
        assert_eq!(value("pellets_eaten", &back), Some(1.0));
    }

    #[test]
    fn differences_are_paired_by_seed() {
        // B eats exactly one more pellet than A on every seed, though seeds vary a lot: the
        // paired difference is significant even where A's and B's intervals overlap.
        let a: Vec<_> = [3.0, 10.0, 6.0, 1.0]
            .iter()
            .enumerate()
            .map(|(i, &e)| run(i as u64 + 1, e))
            .collect();
        let b: Vec<_> = a
            .iter()
            .map(|r| run(r.seed, r.pellets_eaten + 1.0))
            .collect();
        let s = summarize(&a, &b);
        let eaten = s.iter().find(|m| m.measure == "pellets_eaten").unwrap();
        assert_eq!(eaten.b_minus_a.mean, Some(1.0));
        assert!(eaten.significant);
        assert!(eaten.a.high.unwrap() > eaten.b.low.unwrap());
        let pol = s.iter().find(|m| m.measure == "polarization").unwrap();
        assert!(!pol.significant);
        // A seed where A ate nothing has no time to first bite: it is left out of that pairing.
        let a0 = vec![run(1, 0.0), run(2, 2.0)];
        let b0 = vec![run(1, 1.0), run(2, 4.0)];
        let bite = summarize(&a0, &b0)
            .into_iter()
            .find(|m| m.measure == "first_bite_s")
            .unwrap();
        assert_eq!(bite.b_minus_a.n, 1);
        assert_eq!(bite.a.n, 1);
        assert_eq!(bite.b.n, 2);
    }
}
