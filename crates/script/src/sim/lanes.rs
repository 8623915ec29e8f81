//! The behaviour stage of a Lua simulation: [`Scripts`], script lanes running the decisions due
//! this tick in parallel against the shared world.

use std::path::Path;
use std::sync::Arc;
use std::time::Instant;

use super::SpeciesSlot;
use crate::api::{self, Ctx};
use crate::debug::{self, Debugger};
use crate::error::{ScriptError, describe};
use crate::host::{ModuleIndex, ScriptHost};
use crate::log::LogLevel;
use crate::sandbox::Limits;
use shoal_core::world::tick::exclusive;
use shoal_core::world::{Behavior, FishControls, FishId, FoodId, SpeciesId, World};

/// A decision due this tick, in the lane of its fish.
struct Due {
    id: FishId,
    /// Its species (read when it was picked).
    species: SpeciesId,
    /// Position in this tick's decision order (all lanes).
    order: u32,
    /// The fish's controls while it decides (checked out of the world).
    controls: FishControls,
}

/// The lane's module for `behavior`, loading it on first use. Found by the name's allocation
/// (fish running one behaviour share it; see `World::behavior_name_of`), by its text only when
/// that misses: a string comparison per decision read each fish's name from memory.
fn module_for(
    module_of: &mut Vec<(Arc<str>, Option<ModuleIndex>)>,
    host: &mut ScriptHost,
    behavior: &Arc<str>,
    time_s: f64,
) -> Option<ModuleIndex> {
    if let Some((_, m)) = module_of
        .iter()
        .find(|(name, _)| Arc::ptr_eq(name, behavior))
    {
        return *m;
    }
    if let Some((_, m)) = module_of.iter().find(|(name, _)| name == behavior) {
        return *m;
    }
    let m = host.module(behavior, time_s);
    module_of.push((Arc::clone(behavior), m));
    m
}

/// One script lane: a Lua state with its own copy of the behaviour modules, running the decisions
/// of the fish whose slot index ≡ the lane's number (mod the number of lanes).
pub(super) struct Lane {
    pub(super) host: ScriptHost,
    /// Behaviour name → the lane's module (`None`: it failed to load). A handful of entries,
    /// searched linearly.
    pub(super) module_of: Vec<(Arc<str>, Option<ModuleIndex>)>,
    due: Vec<Due>,
    /// `due.len()` entries are live; the rest keep their buffers for later ticks.
    num_due: usize,
    /// Pellets bitten this stage: (decision order, fish, pellet).
    claims: Vec<(u32, FishId, FoodId)>,
    /// Sensor nanoseconds and total nanoseconds of the lane's last stage.
    perception_ns: u64,
    total_ns: u64,
    /// Decisions the lane's last stage ran.
    decided: u64,
    /// Decisions the lane has begun (it times the sensing of one in [`api::SENSE_SAMPLE`]: the
    /// first, then every that many).
    sense_sampled: u32,
    /// Per behaviour module (by the host's module index): what its decisions cost so far.
    pub(super) profile: Vec<ModuleStats>,
    /// This lane's copy of the scene's measure functions, in the order of the scene's names,
    /// loaded on the first sample (see `measures.rs`); `Err` holds why they could not be.
    pub(super) measures: Option<Result<Vec<mlua::Function>, String>>,
}

/// What one behaviour module's decisions cost in one lane (see `Simulation::profile`).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct ModuleStats {
    /// Decisions run.
    pub calls: u64,
    /// CPU nanoseconds of the decisions, sensor queries included.
    pub total_ns: u64,
    /// CPU nanoseconds of the sensor queries they made.
    pub sense_ns: u64,
    /// Decisions that raised an error.
    pub errors: u64,
    /// Decisions stopped by the instruction budget, the time limit or the memory limit.
    pub limit_stops: u64,
    /// Bytes the decisions allocated in Lua (see [`crate::profiler`]).
    pub alloc_bytes: u64,
}

impl Lane {
    pub(super) fn new(scripts_dir: &Path, limits: Limits) -> Result<Self, ScriptError> {
        Self::with_host(ScriptHost::new(scripts_dir, limits)?)
    }

    /// A lane around `host`, with the `shoal` API registered in it.
    pub(super) fn with_host(host: ScriptHost) -> Result<Self, ScriptError> {
        api::register(host.lua()).map_err(|e| ScriptError::Lua(describe(&e)))?;
        Ok(Self {
            host,
            module_of: Vec::new(),
            due: Vec::new(),
            num_due: 0,
            claims: Vec::new(),
            perception_ns: 0,
            total_ns: 0,
            decided: 0,
            sense_sampled: 0,
            profile: Vec::new(),
            measures: None,
        })
    }

    /// Queues a decision (reusing a buffer of an earlier tick).
    fn push(&mut self, id: FishId, species: SpeciesId, order: u32) {
        if let Some(d) = self.due.get_mut(self.num_due) {
            d.id = id;
            d.species = species;
            d.order = order;
        } else {
            self.due.push(Due {
                id,
                species,
                order,
                controls: FishControls::default(),
            });
        }
        self.num_due += 1;
    }

    /// Runs the queued decisions against the shared world, one after another (under `debugger`'s
    /// breakpoints, if one is attached).
    fn run(&mut self, world: &Arc<World>, time_s: f64, debugger: Option<&Arc<Debugger>>) {
        let start = Instant::now();
        let lua = self.host.lua().clone();
        if let Some(mut c) = lua.app_data_mut::<Ctx>() {
            c.perception_ns = 0;
            c.claims.clear();
        }
        self.claims.clear();
        let host = &mut self.host;
        let module_of = &mut self.module_of;
        let decided = &mut self.decided;
        *decided = 0;
        let profile = &mut self.profile;
        let due = &mut self.due[..self.num_due];
        let claims = &mut self.claims;
        let mut stopped = 0u64;
        let stopped_ns = &mut stopped;
        let sampled = &mut self.sense_sampled;
        // A lane with few decisions this tick times every sensor query: one sampled decision
        // counted four times could claim more time than the whole stage took (a lane of three
        // decisions whose one timed decision was its slowest), and the clock reads cost
        // nothing that matters at this size.
        let time_every = due.len() < TIME_EVERY_BELOW;
        let result = (|| {
            host.set_stage(Some((time_s, world)))?;
            if let Some(mut c) = lua.app_data_mut::<Ctx>() {
                c.world = Some(Arc::clone(world));
            }
            for i in 0..due.len() {
                // At 100,000 fish each decision's motion player and Lua table are far from the
                // last one's, and their first reads stall: start loading the next ones now
                // (about 3 % of a decision's CPU time; docs/performance.md).
                if let Some(next) = due.get(i + 1) {
                    shoal_core::prefetch::prefetch(next.controls.player(), 8);
                }
                if let Some(after) = due.get(i + 2) {
                    host.prefetch_fish_table(after.id);
                }
                let d = &mut due[i];
                // The fish's module and table are found here, in the lane's thread.
                let sid = d.species;
                let Some(behavior) = world.behavior_name_of(d.id) else {
                    continue;
                };
                let Some(module) = module_for(module_of, host, behavior, time_s) else {
                    continue;
                };
                if host.is_switched_off(module) {
                    // Quarantined: the fish keeps its last motion, at no cost.
                    continue;
                }
                // One borrow of the API context before the decision and one after.
                let sensed_before = match lua.app_data_mut::<Ctx>() {
                    Some(mut c) => {
                        c.fish = Some(d.id);
                        c.percepts_of = None;
                        c.sense_weight = if time_every {
                            1
                        } else if (*sampled).is_multiple_of(api::SENSE_SAMPLE) {
                            api::SENSE_SAMPLE
                        } else {
                            0
                        };
                        *sampled = sampled.wrapping_add(1);
                        std::mem::swap(&mut c.controls, &mut d.controls);
                        c.perception_ns
                    }
                    None => 0,
                };
                let species = &world.species(sid).desc.name;
                // Stack samples taken during the decision are the module's.
                host.meter().set_tag(Some(module));
                let allocated_before = host.meter().allocated();
                let started = Instant::now();
                let hooked =
                    debugger.is_some_and(|dbg| debug::begin_decision(dbg, host, module, d.id));
                let outcome = host.run_fish(module, d.id, (sid, species), behavior, time_s);
                // Time held at a breakpoint is no cost of the script.
                let mut held_ns = 0;
                if let Some(dbg) = debugger {
                    if hooked {
                        held_ns = debug::end_decision(dbg, host);
                    }
                    if let Err(e) = &outcome {
                        dbg.script_error(&e.to_string());
                    }
                }
                *stopped_ns += held_ns;
                let failed = outcome.is_err();
                let took = (started.elapsed().as_nanos() as u64).saturating_sub(held_ns);
                let allocated = host.meter().allocated().wrapping_sub(allocated_before);
                host.meter().set_tag(None);
                let sensed = match lua.app_data_mut::<Ctx>() {
                    Some(mut c) => {
                        std::mem::swap(&mut c.controls, &mut d.controls);
                        let order = d.order;
                        claims.extend(c.claims.drain(..).map(|(f, food)| (order, f, food)));
                        c.perception_ns
                    }
                    None => 0,
                };
                if profile.len() <= module {
                    profile.resize(module + 1, ModuleStats::default());
                }
                let stats = &mut profile[module];
                stats.calls += 1;
                stats.total_ns += took;
                stats.sense_ns += sensed.saturating_sub(sensed_before);
                stats.errors += u64::from(failed);
                stats.limit_stops += u64::from(failed && host.last_call_hit_limit());
                stats.alloc_bytes += allocated;
                host.count_outcome(module, failed, time_s);
                *decided += 1;
            }
            if let Some(mut c) = lua.app_data_mut::<Ctx>() {
                c.fish = None;
                c.percepts_of = None;
                c.world = None;
                c.sense_weight = 1;
            }
            host.set_stage(None)
        })();
        if let Some(mut c) = lua.app_data_mut::<Ctx>() {
            // Let go of the world even if the stage stopped half-way.
            c.world = None;
            c.fish = None;
        }
        if let Err(e) = result {
            self.host.log(
                LogLevel::Error,
                &format!("script host: {}", describe(&e)),
                None,
                time_s,
            );
        }
        self.perception_ns = lua.app_data_ref::<Ctx>().map_or(0, |c| c.perception_ns);
        self.total_ns = (start.elapsed().as_nanos() as u64).saturating_sub(stopped);
    }
}

/// Below this many decisions due in a lane on a tick, every sensor query is timed (see
/// [`api::SENSE_SAMPLE`] for the sampling above it).
const TIME_EVERY_BELOW: usize = 64;

/// The lane fish `id` decides in, of `lanes`: a hash of its slot index, not the index itself —
/// the fish due on one tick share their index modulo the decision period (fish `i` decides when
/// `(tick + i) % period == 0`), so `i % lanes` would put a whole tick's decisions in one lane.
pub fn lane_index(id: FishId, lanes: usize) -> usize {
    let h = id.index.wrapping_mul(0x9E37_79B9) >> 16;
    h as usize % lanes.max(1)
}

/// Default number of script lanes: one per rayon thread (at most 16).
pub fn default_lanes() -> usize {
    rayon::current_num_threads().clamp(1, 16)
}

/// The scripts of a simulation as the tick's behaviour stage: the script lanes, and each
/// species' decision period.
pub struct Scripts {
    /// Script lanes; lane 0 also reads data files and reports load errors.
    pub(super) lanes: Vec<Lane>,
    /// Per species: its file and decision period.
    pub(super) species: Vec<SpeciesSlot>,
    /// The debugger breakpoints come from, if one is attached (then there is one lane).
    pub(super) debugger: Option<Arc<Debugger>>,
    /// Per behaviour running this tick: the longest period its `min_decision_hz` allows
    /// (`u64::MAX`: none asked).
    pub(super) min_periods: Vec<(Arc<str>, u64)>,
    /// This tick's decisions in order (a buffer kept between ticks).
    pub(super) due: Vec<(FishId, SpeciesId)>,
}

impl Behavior for Scripts {
    /// Runs the behaviour scripts of the fish whose staggered slot is due this tick, in the
    /// script lanes (see the module docs of `script::sim`).
    fn decide(&mut self, world: &mut Arc<World>) {
        use rayon::prelude::*;
        let start = Instant::now();
        let time_s = world.time();
        let num_lanes = self.lanes.len();
        for lane in &mut self.lanes {
            lane.num_due = 0;
        }
        // The behaviours' minimum rates (`min_decision_hz`), read from lane 0's modules for
        // every behaviour a fish runs now: the schedule below must not depend on which lane
        // happened to load a module first.
        self.min_periods.clear();
        let names = if world.lod().on {
            world.behavior_names()
        } else {
            Vec::new()
        };
        for name in names {
            if self.min_periods.iter().any(|(n, _)| **n == *name) {
                continue;
            }
            let host = &mut self.lanes[0].host;
            let cap = host
                .module(&name, time_s)
                .and_then(|m| host.min_decision_hz(m))
                .map_or(u64::MAX, |hz| {
                    (shoal_core::world::TICK_HZ / hz).floor().max(1.0) as u64
                });
            self.min_periods.push((name, cap));
        }
        let species = &self.species;
        let min_periods = &self.min_periods;
        let mut due = std::mem::take(&mut self.due);
        exclusive(world).schedule_decisions(
            |sid, behavior| {
                let base = species
                    .get(usize::from(sid.0))
                    .map_or(6, |s| s.period_ticks);
                let cap = min_periods
                    .iter()
                    .find(|(n, _)| **n == *behavior)
                    .map_or(u64::MAX, |(_, c)| *c);
                (base, cap)
            },
            &mut due,
        );
        // Only picking the lanes is sequential; each lane finds their modules and tables.
        for (order, &(id, sid)) in due.iter().enumerate() {
            self.lanes[lane_index(id, num_lanes)].push(id, sid, order as u32);
        }
        self.due = due;
        let w = exclusive(world);
        for lane in &mut self.lanes {
            for d in &mut lane.due[..lane.num_due] {
                w.check_out(d.id, &mut d.controls);
            }
        }
        let shared: &Arc<World> = world;
        let debugger = self.debugger.as_ref();
        let busy = self.lanes.iter().filter(|l| l.num_due > 0).count();
        let lanes_start = Instant::now();
        if busy > 1 {
            self.lanes
                .par_iter_mut()
                .with_max_len(1)
                .for_each(|lane| lane.run(shared, time_s, debugger));
        } else {
            for lane in &mut self.lanes {
                lane.run(shared, time_s, debugger);
            }
        }
        let lanes_wall = lanes_start.elapsed().as_nanos() as u64;
        let mut claims = Vec::new();
        let (mut perception, mut lanes_total, mut decisions) = (0u64, 0u64, 0u64);
        let w = exclusive(world);
        for lane in &mut self.lanes {
            for d in &mut lane.due[..lane.num_due] {
                w.check_in(d.id, &mut d.controls);
            }
            claims.append(&mut lane.claims);
            perception += lane.perception_ns;
            lanes_total += lane.total_ns;
            decisions += lane.decided;
        }
        // Bites in decision order: the first fish to bite a pellet this tick eats it.
        claims.sort_by_key(|c| c.0);
        for (_, fish, food) in claims {
            exclusive(world).try_eat(fish, food);
        }
        // The stage's wall time: the lanes' split between sensing and Lua as their CPU time
        // was; the rest (schedule, controls out and in, bites) is the schedule's.
        let total = start.elapsed().as_nanos() as u64;
        let lanes_wall = lanes_wall.min(total);
        let perception_wall = if lanes_total > 0 {
            (u128::from(lanes_wall) * u128::from(perception) / u128::from(lanes_total)) as u64
        } else {
            0
        };
        let c = exclusive(world).counters_mut();
        c.perception_ns = perception_wall.min(lanes_wall);
        c.lua_ns = lanes_wall - c.perception_ns;
        c.schedule_ns = total - lanes_wall;
        // Each lane runs on one thread, so its time is (all but preemption) CPU time.
        c.decisions = decisions;
        c.sense_cpu_ns = perception;
        c.decide_cpu_ns = lanes_total.saturating_sub(perception);
    }
}
