//! What a simulation reports: inspector lines of a fish, its script table as JSON, the console
//! log of every lane, and the errors so far.

use std::time::Duration;

use mlua::{Table, Value};

use super::{ModuleStats, Simulation};
use crate::error::EvalError;
use crate::log::{LogEntry, LogLevel};
use crate::logpoints::SetLogpointsError;
use crate::profiler::{self, Frame, FunctionProfile, StackProfile};
use shoal_core::world::FishId;

/// What one behaviour module's decisions cost, over every lane (see [`Simulation::profile`]).
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct ModuleProfile {
    /// The behaviour (`forage`).
    pub module: String,
    /// Decisions run.
    pub calls: u64,
    /// CPU milliseconds of behaviour code (sensor queries not included).
    pub behavior_ms: f64,
    /// CPU milliseconds of the sensor queries the decisions made.
    pub sensing_ms: f64,
    /// CPU microseconds per decision, behaviour and sensing.
    pub us_per_call: f64,
    /// CPU milliseconds per simulated second (behaviour and sensing): what the module costs
    /// the aquarium.
    pub ms_per_sim_s: f64,
    /// Decisions that raised an error.
    pub errors: u64,
    /// Decisions stopped by the instruction budget, time limit or memory limit.
    pub limit_stops: u64,
    /// KiB the decisions allocated in Lua per simulated second: the garbage the collector
    /// sweeps on the module's behalf.
    pub alloc_kib_per_sim_s: f64,
    /// Bytes allocated per decision.
    pub alloc_bytes_per_call: f64,
    /// Stack samples taken during the module's decisions (0 while function sampling is off:
    /// [`Simulation::set_function_sampling`]).
    pub samples: u64,
    /// The module's functions by the samples, most time of their own first (with file:line).
    pub functions: Vec<FunctionProfile>,
    /// The module's most sampled stacks, for a flame view (at most [`FLAME_STACKS`]).
    pub stacks: Vec<StackProfile>,
}

/// Stacks kept per module in [`ModuleProfile::stacks`].
pub const FLAME_STACKS: usize = 24;

/// How often the Lua stack is sampled while function sampling is on: about every look of the
/// watchdog, which looks every millisecond.
pub const SAMPLE_EVERY: Duration = Duration::from_millis(1);

impl Simulation {
    /// What each behaviour module's decisions have cost since the simulation started (or since
    /// [`Simulation::reset_profile`]), summed over the lanes, the most expensive first. Timed per
    /// decision on the lane's thread, so it is CPU time; no Lua hook is involved. Allocations are
    /// counted by the state's allocator; the per-function figures come from stack samples, taken
    /// while [`Simulation::set_function_sampling`] is on.
    pub fn profile(&self) -> Vec<ModuleProfile> {
        let mut by_name: Vec<(String, ModuleStats)> = Vec::new();
        let mut stacks: Vec<(String, Vec<Frame>, u64)> = Vec::new();
        for lane in &self.sim.behavior.lanes {
            for (i, s) in lane.profile.iter().enumerate() {
                let Some(name) = lane.host.module_name(i) else {
                    continue;
                };
                if s.calls == 0 {
                    continue;
                }
                match by_name.iter_mut().find(|(n, _)| n == name) {
                    Some((_, t)) => {
                        t.calls += s.calls;
                        t.total_ns += s.total_ns;
                        t.sense_ns += s.sense_ns;
                        t.errors += s.errors;
                        t.limit_stops += s.limit_stops;
                        t.alloc_bytes += s.alloc_bytes;
                    }
                    None => by_name.push((name.to_owned(), *s)),
                }
            }
            for (tag, frames, n) in lane.host.meter().sampler().stacks() {
                if let Some(name) = lane.host.module_name(tag as usize) {
                    stacks.push((name.to_owned(), frames, n));
                }
            }
        }
        let span = (self.sim.world().time() - self.profile_since_s).max(1e-9);
        let mut out: Vec<ModuleProfile> = by_name
            .into_iter()
            .map(|(module, s)| {
                let ms_per_sim_s = s.total_ns as f64 / 1e6 / span;
                let mine = || {
                    stacks
                        .iter()
                        .filter(|(m, _, _)| *m == module)
                        .map(|(_, f, n)| (f.as_slice(), *n))
                };
                ModuleProfile {
                    calls: s.calls,
                    behavior_ms: s.total_ns.saturating_sub(s.sense_ns) as f64 / 1e6,
                    sensing_ms: s.sense_ns as f64 / 1e6,
                    us_per_call: s.total_ns as f64 / 1e3 / s.calls as f64,
                    ms_per_sim_s,
                    errors: s.errors,
                    limit_stops: s.limit_stops,
                    alloc_kib_per_sim_s: s.alloc_bytes as f64 / 1024.0 / span,
                    alloc_bytes_per_call: s.alloc_bytes as f64 / s.calls as f64,
                    samples: mine().map(|(_, n)| n).sum(),
                    functions: profiler::functions(mine(), ms_per_sim_s),
                    stacks: profiler::flame(mine(), FLAME_STACKS),
                    module,
                }
            })
            .collect();
        out.sort_by(|a, b| {
            (b.behavior_ms + b.sensing_ms)
                .total_cmp(&(a.behavior_ms + a.sensing_ms))
                .then_with(|| a.module.cmp(&b.module))
        });
        out
    }

    /// Starts [`Simulation::profile`] afresh from now (e.g. after a warm-up).
    pub fn reset_profile(&mut self) {
        for lane in &mut self.sim.behavior.lanes {
            lane.profile.clear();
            lane.host.meter().sampler().clear();
        }
        self.profile_since_s = self.sim.world().time();
    }

    /// Samples the Lua stacks of the decisions about every `every` of their run, for the
    /// per-function profile (`None`: off, the default; [`SAMPLE_EVERY`] is the usual
    /// interval). No hook runs per instruction: see [`crate::profiler`]. Only on Linux,
    /// where the watchdog watches the lanes; elsewhere nothing is sampled.
    pub fn set_function_sampling(&mut self, every: Option<Duration>) {
        self.sample_every = every;
        for lane in &self.sim.behavior.lanes {
            lane.host.meter().set_sampling(every);
        }
    }

    /// Whether function sampling is on, and how often (see
    /// [`Simulation::set_function_sampling`]).
    pub fn function_sampling(&self) -> Option<Duration> {
        self.sample_every
    }

    /// Bytes the lanes' Lua states hold now (live data and garbage not yet collected), summed.
    pub fn script_memory(&self) -> usize {
        self.sim
            .behavior
            .lanes
            .iter()
            .map(|l| l.host.lua().used_memory())
            .sum()
    }

    /// Key/value lines describing a fish for the inspector panel: species, behaviour, motion,
    /// root state, the intention and percepts its behaviour produced last, its memory and its
    /// last script error.
    pub fn inspect(&self, id: FishId) -> Vec<(String, String)> {
        let mut out = Vec::new();
        let w = self.sim.world();
        let Some(root) = w.root(id) else {
            out.push(("fish".into(), format!("{id:?} does not exist")));
            return out;
        };
        let sid = w.species_of(id);
        out.push((
            "fish".into(),
            format!("#{} (gen {})", id.index, id.generation),
        ));
        if let Some(s) = sid {
            out.push(("species".into(), w.species(s).desc.name.clone()));
        }
        let host = &self.lane_of(id).host;
        let behavior = match w.behavior_of(id) {
            Some(name) => match host.quarantine_of(name) {
                Some(why) => format!("{name} — switched off after {why}; save the file to retry"),
                None => name.to_owned(),
            },
            None => "(none)".to_owned(),
        };
        out.push(("behavior".into(), behavior));
        out.push((
            "motion".into(),
            format!(
                "{} (+{} queued)",
                w.current_motion(id).unwrap_or("idle"),
                w.queue_len(id).unwrap_or(0)
            ),
        ));
        out.push((
            "pos".into(),
            format!("{:.1}, {:.1}, {:.1}", root.pos.x, root.pos.y, root.pos.z),
        ));
        out.push((
            "heading".into(),
            format!("{:.1}°", root.heading.to_degrees()),
        ));
        out.push(("speed".into(), format!("{:.1}", root.speed)));
        out.push((
            "depth".into(),
            format!("{:.1}", w.tank().depth_of(root.pos.y)),
        ));
        if let Some(t) = host.existing_fish_table(id) {
            let intention: Value = t.raw_get("intention").unwrap_or(Value::Nil);
            out.push(("intention".into(), short(&intention)));
            if let Ok(Value::Table(p)) = t.raw_get::<Value>("percepts") {
                for (k, v) in sorted_pairs(&p) {
                    out.push((format!("percept.{k}"), short(&v)));
                }
            }
            if let Ok(Value::Table(m)) = t.raw_get::<Value>("memory") {
                for (k, v) in sorted_pairs(&m) {
                    out.push((format!("memory.{k}"), short(&v)));
                }
            }
        }
        if let Some(e) = host.fish_error(id) {
            out.push(("error".into(), e.to_owned()));
        }
        out
    }

    /// Behaviours switched off after repeated failures (see [`ScriptHost::quarantine_of`]), with
    /// why, in any lane.
    pub fn switched_off(&self) -> Vec<(String, String)> {
        let mut out: Vec<(String, String)> = Vec::new();
        for lane in &self.sim.behavior.lanes {
            for (name, _) in &lane.module_of {
                if let Some(why) = lane.host.quarantine_of(name)
                    && !out.iter().any(|(n, _)| **n == **name)
                {
                    out.push((name.to_string(), why.to_owned()));
                }
            }
        }
        out
    }

    /// Evaluates Lua in fish `id`'s context (its table as `fish`), in its lane: see
    /// [`crate::ScriptHost::eval_fish`].
    pub fn eval_fish(&self, id: FishId, code: &str) -> Result<serde_json::Value, EvalError> {
        if !self.sim.world().is_alive(id) {
            return Err(EvalError::NotInTank(id));
        }
        self.lane_of(id).host.eval_fish(id, code)
    }

    /// The Lua console's answer to `code` run in fish `id`'s context: `= VALUE` for an
    /// expression (`= nil` when it has none, as Lua says it), `ok` for a statement, which has
    /// no value (not JSON's `null`).
    pub fn console_eval(&self, id: FishId, code: &str) -> Result<String, EvalError> {
        let value = self.eval_fish(id, code)?;
        Ok(if !self.lane_of(id).host.is_expression(code) {
            "ok".to_owned()
        } else if value.is_null() {
            "= nil".to_owned()
        } else {
            format!("= {value}")
        })
    }

    /// Sets the logpoints of one script file (`behaviors/forage.lua`, relative to the scripts
    /// directory, or as the console names it, `scripts/behaviors/forage.lua`), replacing that
    /// file's earlier ones; an empty list removes them. The file is reloaded with the logpoints'
    /// calls in it (see [`crate::logpoints`]): fish keep their memory, as on a save.
    /// Refused, naming the line, when a logpoint's line does not start a statement or its
    /// message does not parse.
    pub fn set_logpoints(
        &mut self,
        file: &str,
        points: Vec<crate::logpoints::Logpoint>,
    ) -> Result<(), SetLogpointsError> {
        let root = self.host().root().clone();
        let rel = file
            .strip_prefix(&format!("{}/", root.display))
            .unwrap_or(file);
        let path = root.dir.join(rel);
        let real = path
            .canonicalize()
            .map_err(|_| SetLogpointsError::NoSuchScript {
                file: file.to_owned(),
                dir: root.dir.clone(),
            })?;
        if !real.starts_with(&root.dir) {
            return Err(SetLogpointsError::OutsideScripts {
                file: file.to_owned(),
            });
        }
        let name = root.display_of(&real);
        let text = std::fs::read_to_string(&real).map_err(|source| SetLogpointsError::Read {
            file: name.clone(),
            source,
        })?;
        let injected = crate::logpoints::inject(&text, &points).map_err(|source| {
            SetLogpointsError::Logpoint {
                file: name.clone(),
                source,
            }
        })?;
        if self.host().check_compiles(&name, &text).is_ok() {
            self.host().check_compiles(&name, &injected).map_err(|_| {
                SetLogpointsError::NotAStatement {
                    file: name.clone(),
                    lines: points.iter().map(|p| p.line).collect(),
                }
            })?;
        }
        for lane in &mut self.sim.behavior.lanes {
            let mut all = lane.host.logpoints().unwrap_or_default();
            if points.is_empty() {
                all.0.remove(&real);
            } else {
                all.0.insert(real.clone(), points.clone());
            }
            lane.host.set_logpoints(all);
        }
        self.reload_changed(&[real]);
        Ok(())
    }

    /// A fish's memory table as JSON.
    pub fn memory_json(&self, id: FishId) -> serde_json::Value {
        self.lane_of(id).host.memory_json(id)
    }

    /// A field of a fish's script table as JSON — `intention` and `percepts` are what its
    /// behaviour produced at its last decision (as [`Simulation::inspect`] shows them); null when
    /// unset or before the fish's first decision.
    pub fn script_field_json(&self, id: FishId, key: &str) -> serde_json::Value {
        self.lane_of(id)
            .host
            .existing_fish_table(id)
            .and_then(|t| t.raw_get::<Value>(key).ok())
            .map_or(serde_json::Value::Null, |v| {
                crate::host::value_to_json(&v, 0)
            })
    }

    /// Console entries logged since the last call, from every lane, oldest first: each distinct
    /// error or warning once (an error every lane logged — a file failing to load, a runaway
    /// behaviour that fish of two lanes run — appears once, with the first fish), each notice no
    /// fish gave once, and every print of a fish.
    pub fn drain_log(&mut self) -> Vec<LogEntry> {
        let mut all: Vec<LogEntry> = Vec::new();
        for lane in &mut self.sim.behavior.lanes {
            for e in lane.host.drain_log() {
                // Every lane loads the same files, so what no fish said (a host notice, a print
                // at a module's top level) comes once per lane: keep one. Errors and warnings are
                // kept once whichever fish hit them; a fish's prints all stay.
                let seen = all.iter().any(|a| {
                    a.level == e.level
                        && a.message == e.message
                        && (e.level != LogLevel::Info || (a.fish.is_none() && e.fish.is_none()))
                });
                if !seen {
                    all.push(e);
                }
            }
        }
        // Stable: a lane's entries of one tick keep their order.
        all.sort_by(|a, b| a.time_s.total_cmp(&b.time_s));
        all
    }

    /// Every distinct script error so far (`file:line: message`), lane by lane, oldest first.
    pub fn error_messages(&self) -> Vec<String> {
        let mut all: Vec<String> = Vec::new();
        for lane in &self.sim.behavior.lanes {
            for m in lane.host.error_messages() {
                if !all.contains(m) {
                    all.push(m.clone());
                }
            }
        }
        all
    }

    /// Script files that currently fail to load, with their errors (shown until fixed).
    pub fn load_errors(&self) -> Vec<(String, String)> {
        let mut all = std::collections::BTreeMap::new();
        for lane in &self.sim.behavior.lanes {
            for (k, v) in lane.host.load_errors() {
                all.entry(k.clone()).or_insert_with(|| v.clone());
            }
        }
        all.into_iter().collect()
    }
}

fn sorted_pairs(t: &Table) -> Vec<(String, Value)> {
    let mut v: Vec<(String, Value)> = t
        .pairs::<Value, Value>()
        .flatten()
        .map(|(k, v)| (short(&k), v))
        .collect();
    v.sort_by(|a, b| a.0.cmp(&b.0));
    v.truncate(32);
    v
}

/// A value in a few characters: numbers to 2 decimals, tables shallowly: a list in its order
/// (`{250.00, 60.00, -120.00}`), then the named fields by name, at most 8 shown.
fn short(v: &Value) -> String {
    const SHOWN: usize = 8;
    match v {
        Value::Nil => "nil".into(),
        Value::Boolean(b) => b.to_string(),
        Value::Integer(i) => i.to_string(),
        Value::Number(n) => format!("{n:.2}"),
        Value::String(s) => s.to_string_lossy(),
        Value::Table(t) => {
            let item = |v: &Value| match v {
                Value::Table(_) => "{…}".to_owned(),
                other => short(other),
            };
            let len = t.raw_len();
            let in_list =
                |k: &Value| matches!(k, Value::Integer(i) if *i >= 1 && (*i as usize) <= len);
            let mut parts: Vec<String> = (1..=len)
                .take(SHOWN)
                .map(|i| item(&t.raw_get::<Value>(i).unwrap_or(Value::Nil)))
                .collect();
            let mut named: Vec<String> = t
                .pairs::<Value, Value>()
                .flatten()
                .filter(|(k, _)| !in_list(k))
                .map(|(k, v)| format!("{}={}", short(&k), item(&v)))
                .collect();
            named.sort();
            let total = len + named.len();
            parts.extend(named.into_iter().take(SHOWN.saturating_sub(parts.len())));
            if total > parts.len() {
                parts.push("…".into());
            }
            format!("{{{}}}", parts.join(", "))
        }
        other => other.type_name().to_owned(),
    }
}
