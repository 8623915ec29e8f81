//! A scene's own measures: `measures = { NAME = function(fish) return number end }` in the
//! scene file, sampled once per simulated second for every fish.
//!
//! Each function is called with the fish's table (what its behaviour sees: `memory`,
//! `intention`, `percepts`, `params`) while the `shoal` sensors answer for that fish
//! (`shoal.nearest("predator")`, `shoal.body()`, `shoal.species()`); motion requests made there
//! are dropped. It returns a number, a boolean (counted as 1 or 0) or nil (the fish is left out of
//! that sample). A run's value is the mean over every (fish, sample) pair that gave one. To count
//! events instead, let the behaviour count them in `fish.memory` and the measure return the
//! count: the mean then reads "events per fish so far, averaged over the run".
//!
//! A measure that raises an error (or returns something else) is logged by name with file:line,
//! once per distinct message, and counted; the other measures and the run go on. Each lane runs
//! the scene file once for its own copy of the functions (a Lua function lives in one state), and
//! the samples are added in fish order, so the results are the same whatever the number of lanes.

use std::sync::Arc;

use mlua::{Function, Table, Value};

use super::Simulation;
use super::lanes::{Lane, lane_index};
use crate::api::Ctx;
use crate::log::LogLevel;
use shoal_core::world::{FishControls, FishId, TICK_HZ, World};

/// What one measure gave so far.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct MeasureResult {
    /// Mean over every (fish, sample) that gave a value (`None` without any).
    pub mean: Option<f64>,
    /// (fish, sample) values it is the mean of.
    pub samples: u64,
    /// Calls that raised an error or returned something other than a number, boolean or nil.
    pub errors: u64,
    /// The first such error, `file:line: message`.
    pub first_error: Option<String>,
}

#[derive(Debug, Default)]
struct Sum {
    total: f64,
    samples: u64,
    errors: u64,
    first_error: Option<String>,
    last_logged: Option<String>,
}

/// The scene's measures and their sums.
#[derive(Debug, Default)]
pub(super) struct Measures {
    names: Vec<String>,
    sums: Vec<Sum>,
}

impl Measures {
    pub(super) fn new(names: &[String]) -> Self {
        Self {
            names: names.to_vec(),
            sums: names.iter().map(|_| Sum::default()).collect(),
        }
    }

    /// Whether a sample is due after tick `tick` (once per simulated second).
    pub(super) fn is_due(&self, tick: u64) -> bool {
        !self.names.is_empty() && tick > 0 && tick.is_multiple_of(TICK_HZ as u64)
    }
}

/// One value a measure gave for one fish.
struct Value1 {
    fish: u32,
    measure: usize,
    /// `Ok(None)`: the measure returned nil (the fish is left out).
    value: Result<Option<f64>, String>,
}

impl Simulation {
    /// The scene's measures, by name (sorted), with what they have sampled since the start.
    pub fn measures(&self) -> Vec<(String, MeasureResult)> {
        self.measures
            .names
            .iter()
            .zip(&self.measures.sums)
            .map(|(name, s)| {
                (
                    name.clone(),
                    MeasureResult {
                        mean: (s.samples > 0).then(|| s.total / s.samples as f64),
                        samples: s.samples,
                        errors: s.errors,
                        first_error: s.first_error.clone(),
                    },
                )
            })
            .collect()
    }

    /// The names of the scene's measures, sorted.
    pub fn measure_names(&self) -> &[String] {
        &self.measures.names
    }

    /// Samples every measure for every fish now.
    pub(super) fn sample_measures(&mut self) {
        let Some(scene) = self.scene_path.clone() else {
            return;
        };
        let world = Arc::clone(self.sim.shared_world());
        let num_lanes = self.sim.behavior.lanes.len();
        let mut by_lane: Vec<Vec<FishId>> = vec![Vec::new(); num_lanes];
        for id in world.fish_ids() {
            by_lane[lane_index(id, num_lanes)].push(id);
        }
        let names = &self.measures.names;
        let mut values = Vec::new();
        for (lane, ids) in self.sim.behavior.lanes.iter_mut().zip(&by_lane) {
            if !ids.is_empty() {
                sample_lane(lane, &world, &scene, names, ids, &mut values);
            }
        }
        drop(world);
        // In fish order, so the sums do not depend on the lanes.
        values.sort_by_key(|v| (v.fish, v.measure));
        let time = self.sim.world().time();
        let mut log = Vec::new();
        for v in values {
            let sum = &mut self.measures.sums[v.measure];
            match v.value {
                Ok(None) => {}
                Ok(Some(x)) => {
                    sum.total += x;
                    sum.samples += 1;
                }
                Err(e) => {
                    sum.errors += 1;
                    let msg = format!("measure \"{}\": {e}", self.measures.names[v.measure]);
                    if sum.first_error.is_none() {
                        sum.first_error = Some(e);
                    }
                    if sum.last_logged.as_deref() != Some(msg.as_str()) {
                        sum.last_logged = Some(msg.clone());
                        log.push(msg);
                    }
                }
            }
        }
        for msg in log {
            self.host_mut().log(LogLevel::Error, &msg, None, time);
        }
    }
}

/// Loads the lane's copy of the measure functions from the scene file.
fn load_functions(
    lane: &Lane,
    scene: &std::path::Path,
    names: &[String],
) -> Result<Vec<Function>, String> {
    let value = lane
        .host
        .load_data_file(scene)
        .map_err(|e| format!("the scene file could not be run again for its measures: {e}"))?;
    let measures = match value {
        Value::Table(t) => t.raw_get::<Option<Table>>("measures").ok().flatten(),
        _ => None,
    };
    let measures = measures.ok_or("the scene file no longer returns its measures table")?;
    names
        .iter()
        .map(|name| match measures.raw_get::<Value>(name.as_str()) {
            Ok(Value::Function(f)) => Ok(f),
            _ => Err(format!("the scene file no longer has measures.{name}")),
        })
        .collect()
}

/// Runs the measures for the fish `ids` of one lane, pushing one value per (fish, measure).
fn sample_lane(
    lane: &mut Lane,
    world: &Arc<World>,
    scene: &std::path::Path,
    names: &[String],
    ids: &[FishId],
    out: &mut Vec<Value1>,
) {
    if lane.measures.is_none() {
        lane.measures = Some(load_functions(lane, scene, names));
    }
    let functions = match lane.measures.as_ref() {
        Some(Ok(f)) => f.clone(),
        Some(Err(e)) => {
            for &id in ids {
                for measure in 0..names.len() {
                    out.push(Value1 {
                        fish: id.index,
                        measure,
                        value: Err(e.clone()),
                    });
                }
            }
            return;
        }
        None => return,
    };
    let host = &lane.host;
    let lua = host.lua().clone();
    if let Err(e) = host.set_stage(Some((world.time(), world))) {
        for &id in ids {
            for measure in 0..names.len() {
                out.push(Value1 {
                    fish: id.index,
                    measure,
                    value: Err(crate::error::describe(&e)),
                });
            }
        }
        return;
    }
    if let Some(mut c) = lua.app_data_mut::<Ctx>() {
        c.world = Some(Arc::clone(world));
    }
    for &id in ids {
        let Some(sid) = world.species_of(id) else {
            continue;
        };
        let species = &world.species(sid).desc.name;
        let behavior = world.behavior_name_of(id).map_or("", |b| &**b);
        if let Some(mut c) = lua.app_data_mut::<Ctx>() {
            c.fish = Some(id);
            c.percepts_of = None;
        }
        let fish = host.measure_fish_table(id, species, behavior);
        for (measure, f) in functions.iter().enumerate() {
            let value = match &fish {
                Ok(fish) => host
                    .call_measure(f, fish, sid.0 + 1)
                    .and_then(|v| number_of(&v, f)),
                Err(e) => Err(crate::error::describe(e)),
            };
            out.push(Value1 {
                fish: id.index,
                measure,
                value,
            });
        }
    }
    if let Some(mut c) = lua.app_data_mut::<Ctx>() {
        // A measure only reads: what it asked of the motion player or bit is dropped.
        c.fish = None;
        c.world = None;
        c.percepts_of = None;
        c.claims.clear();
        c.controls = FishControls::default();
    }
    let _ = host.set_stage(None);
}

/// A measure's return value as a number: numbers as they are, booleans as 1 or 0, nil as
/// `None` (the fish is left out of this sample).
fn number_of(v: &Value, f: &Function) -> Result<Option<f64>, String> {
    let x = match v {
        Value::Nil => return Ok(None),
        Value::Integer(i) => *i as f64,
        Value::Number(x) => *x,
        Value::Boolean(b) => f64::from(u8::from(*b)),
        other => {
            let info = f.info();
            let at = format!(
                "{}:{}",
                info.short_src.unwrap_or_default(),
                info.line_defined.unwrap_or(0)
            );
            return Err(format!(
                "{at}: returned {}; a measure returns a number (or a boolean, or nil to leave \
                 the fish out)",
                other.type_name()
            ));
        }
    };
    if !x.is_finite() {
        let info = f.info();
        return Err(format!(
            "{}:{}: returned {x}; a measure returns a finite number",
            info.short_src.unwrap_or_default(),
            info.line_defined.unwrap_or(0)
        ));
    }
    Ok(Some(x))
}
