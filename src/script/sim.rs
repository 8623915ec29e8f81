//! [`Simulation`]: a world plus the script host, stepped one fixed 60 Hz tick at a time.
//!
//! A tick is a straight sequence of named stages, each timed into the world's
//! [`StageCounters`](crate::world::StageCounters):
//!
//! 1. scene events (periodic food drops);
//! 2. behaviour scripts of the fish whose staggered slot is due — fish `i` decides on ticks where
//!    `(tick + i) % period == 0`, `period = round(60 / decision_hz)` (default 10 Hz → every 6th
//!    tick), so the Lua cost per frame stays flat — timed into `lua_ns`, with the sensor queries
//!    they make timed separately into `perception_ns`. The decisions run in parallel **script
//!    lanes** (see below);
//! 3. `World::step_motion` (the motion layer, every tick), `World::update_pose`,
//!    `World::rebuild_grid`.
//!
//! ## Script lanes
//!
//! Lua runs one thread per state, so the simulation keeps several Lua states — lanes, one per
//! rayon thread by default ([`Simulation::set_lanes`]) — each with its own copy of the behaviour
//! modules, and a fish always decides in the same lane ([`lane_index`], a hash of its slot index;
//! its table and `memory` live there).
//! During the stage the world is shared read-only by every lane: each deciding fish's motion
//! player, steering memo and random generator are checked out of the world for its decision
//! ([`World::check_out`]) and put back after, and the pellets fish bite (`shoal.eat`) are
//! applied when every lane is done, in decision order. A decision therefore depends only on the
//! world as the tick began, on the fish's own state and on its script, never on which lane ran
//! it or when, so results are the same whatever the number of lanes or threads — as long as
//! scripts keep per-fish state in `fish.memory`: a module-level variable is per lane.

use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

use glam::Vec3;
use mlua::{Table, Value};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg32;

use super::api::{self, Ctx};
use super::error::{ScriptError, describe};
use super::host::{ModuleIndex, Reloaded, ScriptHost};
use super::log::{LogEntry, LogLevel};
use super::reload::ScriptWatcher;
use super::sandbox::Limits;
use super::scene::{BoxDesc, SceneDesc, SpeciesFile, species_from_table};
use crate::world::{
    Current, FishControls, FishId, FoodId, SpawnParams, Species, SpeciesId, TICK_HZ, Tank, World,
};

/// A species the simulation loaded from `scripts/species/`.
#[derive(Debug, Clone)]
struct SpeciesSlot {
    /// The species file.
    path: PathBuf,
    /// Ticks between two decisions of one fish.
    period_ticks: u64,
}

/// What `reload_changed` did with each path, for the console.
#[derive(Debug, Clone, PartialEq)]
pub enum ReloadEvent {
    /// Behaviour modules reloaded.
    Behaviors(Vec<String>),
    /// A species' data now applies to its live fish.
    Species(String),
    /// The current scene's file changed: the panel offers a restart.
    SceneChanged,
    /// A file failed to load; the last good version keeps running.
    Failed(String),
}

impl std::fmt::Display for ReloadEvent {
    /// One console line: what was reloaded, or the load error (`file:line: message`).
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Behaviors(names) => write!(f, "reloaded behaviour {}", names.join(", ")),
            Self::Species(name) => write!(f, "reloaded species {name}: its fish use it now"),
            Self::SceneChanged => {
                write!(f, "the scene file changed: restart the scene to apply it")
            }
            Self::Failed(msg) => {
                // The error itself is logged on its own line; name the file here.
                let file = msg.split(':').next().unwrap_or(msg);
                write!(
                    f,
                    "{file}: reload failed, the last good version keeps running"
                )
            }
        }
    }
}

/// A decision due this tick, in the lane of its fish.
struct Due {
    id: FishId,
    /// Position in this tick's decision order (all lanes).
    order: u32,
    /// The fish's controls while it decides (checked out of the world).
    controls: FishControls,
}

/// The lane's module for `behavior`, loading it on first use.
fn module_for(
    module_of: &mut Vec<(String, Option<ModuleIndex>)>,
    host: &mut ScriptHost,
    behavior: &str,
    time_s: f64,
) -> Option<ModuleIndex> {
    if let Some((_, m)) = module_of.iter().find(|(name, _)| name == behavior) {
        return *m;
    }
    let m = host.module(behavior, time_s);
    module_of.push((behavior.to_owned(), m));
    m
}

/// One script lane: a Lua state with its own copy of the behaviour modules, running the decisions
/// of the fish whose slot index ≡ the lane's number (mod the number of lanes).
struct Lane {
    host: ScriptHost,
    /// Behaviour name → the lane's module (`None`: it failed to load). A handful of entries,
    /// searched linearly.
    module_of: Vec<(String, Option<ModuleIndex>)>,
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
}

impl Lane {
    fn new(scripts_dir: &Path, limits: Limits) -> Result<Self, ScriptError> {
        Self::with_host(ScriptHost::new(scripts_dir, limits)?)
    }

    /// A lane around `host`, with the `shoal` API registered in it.
    fn with_host(host: ScriptHost) -> Result<Self, ScriptError> {
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
        })
    }

    /// Queues a decision (reusing a buffer of an earlier tick).
    fn push(&mut self, id: FishId, order: u32) {
        if let Some(d) = self.due.get_mut(self.num_due) {
            d.id = id;
            d.order = order;
        } else {
            self.due.push(Due {
                id,
                order,
                controls: FishControls::default(),
            });
        }
        self.num_due += 1;
    }

    /// Runs the queued decisions against the shared world, one after another.
    fn run(&mut self, world: &Arc<World>, time_s: f64) {
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
        let due = &mut self.due[..self.num_due];
        let claims = &mut self.claims;
        let result = (|| {
            host.set_stage(Some((time_s, world)))?;
            if let Some(mut c) = lua.app_data_mut::<Ctx>() {
                c.world = Some(Arc::clone(world));
            }
            for d in due.iter_mut() {
                // The fish's module and table are found here, in the lane's thread.
                let (Some(behavior), Some(sid)) = (world.behavior_of(d.id), world.species_of(d.id))
                else {
                    continue;
                };
                let Some(module) = module_for(module_of, host, behavior, time_s) else {
                    continue;
                };
                if host.is_switched_off(module) {
                    // Quarantined: the fish keeps its last motion, at no cost.
                    continue;
                }
                if let Some(mut c) = lua.app_data_mut::<Ctx>() {
                    c.fish = Some(d.id);
                    c.percepts_of = None;
                    std::mem::swap(&mut c.controls, &mut d.controls);
                }
                let species = &world.species(sid).desc.name;
                let failed = host
                    .run_fish(module, d.id, species, behavior, time_s)
                    .is_err();
                host.count_outcome(module, failed, time_s);
                *decided += 1;
                if let Some(mut c) = lua.app_data_mut::<Ctx>() {
                    std::mem::swap(&mut c.controls, &mut d.controls);
                    let order = d.order;
                    claims.extend(c.claims.drain(..).map(|(f, food)| (order, f, food)));
                }
            }
            if let Some(mut c) = lua.app_data_mut::<Ctx>() {
                c.fish = None;
                c.percepts_of = None;
                c.world = None;
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
        self.total_ns = start.elapsed().as_nanos() as u64;
    }
}

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

/// The aquarium: world, scripts, scene.
pub struct Simulation {
    /// Shared read-only with the script lanes during the behaviour stage; unique otherwise.
    world: Arc<World>,
    /// Script lanes; lane 0 also reads data files and reports load errors.
    lanes: Vec<Lane>,
    scripts_dir: PathBuf,
    /// The repository root the assets are found under.
    root: PathBuf,
    assets_dir: PathBuf,
    scene_path: Option<PathBuf>,
    scene: Option<SceneDesc>,
    seed: u64,
    species: Vec<SpeciesSlot>,
    rng: Pcg32,
    next_drop_s: f64,
    watcher: Option<ScriptWatcher>,
    scene_changed: bool,
    reload_events: Vec<ReloadEvent>,
    /// Each fish's `fish.params` from its scene group (only fish that have some).
    fish_params: std::collections::HashMap<FishId, Arc<serde_json::Value>>,
}

fn v3(a: [f32; 3]) -> Vec3 {
    Vec3::from_array(a)
}

impl Simulation {
    /// A simulation of the scene file `scene` (a path relative to the repository root `root`, to
    /// `root/scripts/`, or absolute), seeded with `seed`. Scripts come from `root/scripts/`,
    /// species assets from `root/assets/` (or the scene's `assets`).
    pub fn from_scene(root: &Path, scene: &Path, seed: u64) -> Result<Self, ScriptError> {
        Self::from_scene_with_scripts(root, &root.join("scripts"), scene, seed)
    }

    /// Like [`Simulation::from_scene`], with the scripts (behaviours, species, scenes) from
    /// `scripts_dir` instead of `root/scripts/` (`--scripts DIR`); assets still come from `root`.
    /// `scene` may also be relative to `scripts_dir` or to `scripts_dir/scenes/`.
    pub fn from_scene_with_scripts(
        root: &Path,
        scripts_dir: &Path,
        scene: &Path,
        seed: u64,
    ) -> Result<Self, ScriptError> {
        let scripts_dir = scripts_dir.to_path_buf();
        let path = [
            scene.to_path_buf(),
            root.join(scene),
            scripts_dir.join(scene),
            scripts_dir.join("scenes").join(scene),
        ]
        .into_iter()
        .find(|p| p.is_file())
        .ok_or_else(|| ScriptError::Io {
            path: scene.to_path_buf(),
            source: std::io::Error::new(std::io::ErrorKind::NotFound, "scene file not found"),
        })?;
        let host = ScriptHost::new(&scripts_dir, Limits::default())?;
        let display = host
            .root()
            .display_of(&path.canonicalize().unwrap_or(path.clone()));
        let desc = read_scene(&host, &path, &display)?;
        let mut sim = Self::with_host(root, host, &desc, seed)?;
        sim.scene_path = Some(path.canonicalize().unwrap_or(path));
        sim.populate(&desc, &display)?;
        sim.scene = Some(desc);
        Ok(sim)
    }

    /// An empty tank (`scripts/scenes/empty_tank.lua` if it exists, else 20 × 8 × 12 body
    /// lengths of a black porgy) with no fish; species load on first [`Simulation::spawn`].
    pub fn empty(root: &Path, seed: u64) -> Result<Self, ScriptError> {
        let empty = root.join("scripts/scenes/empty_tank.lua");
        if empty.is_file() {
            return Self::from_scene(root, &empty, seed);
        }
        let scripts_dir = root.join("scripts");
        let host = ScriptHost::new(&scripts_dir, Limits::default())?;
        let desc = SceneDesc {
            tank: BoxDesc {
                min: [-500.0, 0.0, -300.0],
                max: [500.0, 400.0, 300.0],
            },
            assets: None,
            species: Vec::new(),
            fish: Vec::new(),
            food: Vec::new(),
            food_drops: None,
            obstacles: Vec::new(),
            currents: Vec::new(),
        };
        Self::with_host(root, host, &desc, seed)
    }

    /// Like [`Simulation::from_scene`] with explicit limits for the Lua state.
    pub fn from_scene_with_limits(
        root: &Path,
        scene: &Path,
        seed: u64,
        limits: Limits,
    ) -> Result<Self, ScriptError> {
        let mut sim = Self::from_scene(root, scene, seed)?;
        if limits != sim.host().limits() {
            // Rebuild the hosts under the new limits; the scene's fish have not run yet.
            sim.rebuild_lanes(limits, sim.lanes.len())?;
        }
        Ok(sim)
    }

    /// Runs the decisions in `n` script lanes (at least 1) from now on. Rebuilds the Lua states:
    /// behaviours reload and every fish's `memory` starts empty again, so call it before the
    /// first tick.
    pub fn set_lanes(&mut self, n: usize) -> Result<(), ScriptError> {
        self.rebuild_lanes(self.host().limits(), n.max(1))
    }

    /// Number of script lanes.
    pub fn num_lanes(&self) -> usize {
        self.lanes.len()
    }

    fn rebuild_lanes(&mut self, limits: Limits, n: usize) -> Result<(), ScriptError> {
        let lanes = (0..n)
            .map(|_| Lane::new(&self.scripts_dir, limits))
            .collect::<Result<Vec<_>, _>>()?;
        self.lanes = lanes;
        for (&id, params) in &self.fish_params {
            let lane = lane_index(id, n);
            self.lanes[lane].host.set_params(id, Arc::clone(params));
        }
        Ok(())
    }

    /// Gives fish `id` the table `params` as `fish.params` (a scene group's `params`); it
    /// applies when the fish first decides.
    pub fn set_params(&mut self, id: FishId, params: serde_json::Value) {
        let params = Arc::new(params);
        let lane = lane_index(id, self.lanes.len());
        self.lanes[lane].host.set_params(id, Arc::clone(&params));
        self.fish_params.insert(id, params);
    }

    /// The lane fish `id` decides in.
    fn lane_of(&self, id: FishId) -> &Lane {
        &self.lanes[lane_index(id, self.lanes.len())]
    }

    /// Lane 0's script host: it reads data files and logs what concerns no fish.
    fn host(&self) -> &ScriptHost {
        &self.lanes[0].host
    }

    fn host_mut(&mut self) -> &mut ScriptHost {
        &mut self.lanes[0].host
    }

    fn with_host(
        root: &Path,
        host: ScriptHost,
        desc: &SceneDesc,
        seed: u64,
    ) -> Result<Self, ScriptError> {
        let scripts_dir = host.root().dir.clone();
        let limits = host.limits();
        let mut lanes = vec![Lane::with_host(host)?];
        for _ in 1..default_lanes() {
            lanes.push(Lane::new(&scripts_dir, limits)?);
        }
        let tank = tank_of(&desc.tank, "scene tank")?;
        let assets_dir = root.join(desc.assets.as_deref().unwrap_or("assets"));
        let first_drop = desc
            .food_drops
            .map(|d| f64::from(d.start.unwrap_or(d.every)))
            .unwrap_or(f64::INFINITY);
        Ok(Self {
            world: Arc::new(World::new(tank, seed)),
            scripts_dir,
            root: root.to_path_buf(),
            lanes,
            assets_dir,
            scene_path: None,
            scene: None,
            seed,
            species: Vec::new(),
            rng: Pcg32::seed_from_u64(seed ^ 0x5eed_5cee),
            next_drop_s: first_drop,
            watcher: None,
            scene_changed: false,
            reload_events: Vec::new(),
            fish_params: std::collections::HashMap::new(),
        })
    }

    /// Replaces the tank (only before any fish is spawned).
    pub fn set_tank(&mut self, min: Vec3, max: Vec3) -> Result<(), ScriptError> {
        let tank = tank_of(
            &BoxDesc {
                min: min.to_array(),
                max: max.to_array(),
            },
            "tank",
        )?;
        if self.world.num_fish() > 0 {
            return Err(ScriptError::Data {
                file: "tank".into(),
                why: "the tank can only change before any fish is spawned".into(),
            });
        }
        let mut world = World::new(tank, self.seed);
        for i in 0..self.species.len() {
            let s = self.world.species(SpeciesId(i as u16)).clone();
            world.add_species(s);
        }
        self.world = Arc::new(world);
        Ok(())
    }

    fn populate(&mut self, desc: &SceneDesc, display: &str) -> Result<(), ScriptError> {
        for name in &desc.species {
            self.species_id(name)?;
        }
        let tank = *self.world.tank();
        let middle = BoxDesc {
            min: (tank.min + (tank.max - tank.min) * 0.25).to_array(),
            max: (tank.min + (tank.max - tank.min) * 0.75).to_array(),
        };
        for (g, group) in desc.fish.iter().enumerate() {
            let sid = self.species_id(&group.species)?;
            let cruise = self.world.species(sid).desc.motion.s;
            let region = group.region.unwrap_or(middle);
            for k in 0..group.count {
                let pos = match (k, group.pos) {
                    (0, Some(p)) => v3(p),
                    _ => self.random_in(&region),
                };
                let heading = match group.heading {
                    Some(h) => h,
                    None => self
                        .rng
                        .random_range(-std::f32::consts::PI..std::f32::consts::PI),
                };
                let seed = self.rng.random::<u64>();
                let id = wm(&mut self.world)
                    .spawn(SpawnParams {
                        species: sid,
                        pos,
                        heading,
                        pitch: 0.0,
                        speed: group.speed.unwrap_or(cruise),
                        behavior: group.behavior.clone(),
                        seed,
                    })
                    .map_err(|source| ScriptError::World {
                        context: format!(
                            "{display}: fish[{}] (fish {} of the group)",
                            g + 1,
                            k + 1
                        ),
                        source,
                    })?;
                if let Some(params) = &group.params {
                    self.set_params(id, params.clone());
                }
            }
        }
        for f in &desc.food {
            wm(&mut self.world).add_food(v3(*f));
        }
        for o in &desc.obstacles {
            wm(&mut self.world).add_obstacle(v3(o.pos), o.radius);
        }
        for c in &desc.currents {
            wm(&mut self.world).add_current(Current {
                pos: v3(c.pos),
                radius: c.radius,
                velocity: v3(c.velocity),
            });
        }
        wm(&mut self.world).rebuild_grid();
        Ok(())
    }

    fn random_in(&mut self, b: &BoxDesc) -> Vec3 {
        let mut p = [0.0f32; 3];
        for (i, v) in p.iter_mut().enumerate() {
            let (lo, hi) = (b.min[i].min(b.max[i]), b.min[i].max(b.max[i]));
            *v = if hi > lo {
                self.rng.random_range(lo..hi)
            } else {
                lo
            };
        }
        Vec3::from_array(p)
    }

    /// The species called `name`, loading `scripts/species/<name>.lua` on first use.
    pub fn species_id(&mut self, name: &str) -> Result<SpeciesId, ScriptError> {
        if let Some(id) = self.world.species_by_name(name) {
            return Ok(id);
        }
        let path = self
            .host()
            .root()
            .resolve_module(&format!("species/{name}"))
            .map_err(|_| ScriptError::Data {
                file: format!("species '{name}'"),
                why: format!(
                    "{} — there is no scripts/species/{name}.lua",
                    super::scene::unknown_name(
                        "species",
                        name,
                        &script_names(self.host(), "species")
                    )
                ),
            })?;
        let (species, period_ticks) = self.load_species(&path)?;
        let id = wm(&mut self.world).add_species(species);
        let slot = SpeciesSlot { path, period_ticks };
        let i = usize::from(id.0);
        if self.species.len() <= i {
            self.species.resize(i + 1, slot.clone());
        }
        self.species[i] = slot;
        Ok(id)
    }

    /// Adds a species built in Rust (not from a file) whose fish decide `decision_hz` times per
    /// second. It is not hot-reloaded.
    pub fn add_species(&mut self, species: Species, decision_hz: f64) -> SpeciesId {
        let hz = if decision_hz.is_finite() && decision_hz > 0.0 {
            decision_hz
        } else {
            10.0
        };
        let id = wm(&mut self.world).add_species(species);
        let slot = SpeciesSlot {
            path: PathBuf::new(),
            period_ticks: (TICK_HZ / hz).round().max(1.0) as u64,
        };
        let i = usize::from(id.0);
        if self.species.len() <= i {
            self.species.resize(i + 1, slot.clone());
        }
        self.species[i] = slot;
        id
    }

    fn load_species(&self, path: &Path) -> Result<(Species, u64), ScriptError> {
        let file = read_species(self.host(), path)?;
        let period = (TICK_HZ / file.decision_hz).round().max(1.0) as u64;
        let display = self.host().root().display_of(path);
        let species =
            Species::load(file.desc, &self.assets_dir).map_err(|source| ScriptError::World {
                context: display,
                source,
            })?;
        Ok((species, period))
    }

    /// Spawns a fish of species `species` (loaded on first use) at `pos`.
    pub fn spawn(
        &mut self,
        species: &str,
        pos: Vec3,
        heading: f32,
        pitch: f32,
        speed: Option<f32>,
        behavior: Option<&str>,
    ) -> Result<FishId, ScriptError> {
        let sid = self.species_id(species)?;
        if let Some(b) = behavior {
            check_name(self.host(), "behaviors", b, "spawn", "behavior")?;
        }
        let speed = speed.unwrap_or(self.world.species(sid).desc.motion.s);
        let seed = self.rng.random::<u64>();
        wm(&mut self.world)
            .spawn(SpawnParams {
                species: sid,
                pos,
                heading,
                pitch,
                speed,
                behavior: behavior.map(str::to_owned),
                seed,
            })
            .map_err(|source| ScriptError::World {
                context: format!("spawning a {species}"),
                source,
            })
    }

    /// Removes a fish and forgets its script table and memory. False if it was already gone.
    pub fn despawn(&mut self, id: FishId) -> bool {
        let lane = lane_index(id, self.lanes.len());
        self.lanes[lane].host.forget_fish(id);
        self.fish_params.remove(&id);
        wm(&mut self.world).despawn(id)
    }

    /// The world.
    pub fn world(&self) -> &World {
        &self.world
    }

    /// The world, mutable (spawn, food, obstacles…).
    pub fn world_mut(&mut self) -> &mut World {
        wm(&mut self.world)
    }

    /// The scene this simulation was built from.
    pub fn scene(&self) -> Option<&SceneDesc> {
        self.scene.as_ref()
    }

    /// Runs one fixed tick (1/60 s).
    pub fn step(&mut self) {
        self.drop_food();
        self.run_behaviors();
        let dt = (1.0 / TICK_HZ) as f32;
        wm(&mut self.world).step_motion(dt);
        wm(&mut self.world).update_pose();
        wm(&mut self.world).rebuild_grid();
    }

    /// Runs `seconds` of simulated time (rounded to whole ticks).
    pub fn run(&mut self, seconds: f64) {
        let ticks = (seconds * TICK_HZ).round().max(0.0) as u64;
        for _ in 0..ticks {
            self.step();
        }
    }

    fn drop_food(&mut self) {
        let Some(drops) = self.scene.as_ref().and_then(|s| s.food_drops) else {
            return;
        };
        let now = self.world.time();
        if now + 1e-9 < self.next_drop_s || drops.every.is_nan() || drops.every <= 0.0 {
            return;
        }
        self.next_drop_s += f64::from(drops.every);
        let tank = *self.world.tank();
        let region = drops.region.unwrap_or(BoxDesc {
            min: [tank.min.x * 0.8, tank.max.y * 0.95, tank.min.z * 0.8],
            max: [tank.max.x * 0.8, tank.max.y * 0.97, tank.max.z * 0.8],
        });
        for _ in 0..drops.count {
            let p = self.random_in(&region);
            wm(&mut self.world).add_food(p);
        }
    }

    /// Stage 2 alone: runs the behaviour scripts of the fish whose staggered slot is due this
    /// tick (without advancing time; [`Simulation::step`] calls it). Public for benchmarks.
    pub fn run_behaviors(&mut self) {
        use rayon::prelude::*;
        let start = Instant::now();
        let tick = self.world.tick_count();
        let time_s = self.world.time();
        let num_lanes = self.lanes.len();
        for lane in &mut self.lanes {
            lane.num_due = 0;
        }
        // Only picking the fish is sequential; each lane finds their modules and tables.
        let mut order = 0u32;
        for id in self.world.fish_ids() {
            let Some(sid) = self.world.species_of(id) else {
                continue;
            };
            let period = self
                .species
                .get(usize::from(sid.0))
                .map_or(6, |s| s.period_ticks);
            if !(tick + u64::from(id.index)).is_multiple_of(period)
                || self.world.behavior_of(id).is_none()
            {
                continue;
            }
            self.lanes[lane_index(id, num_lanes)].push(id, order);
            order += 1;
        }
        for lane in &mut self.lanes {
            for d in &mut lane.due[..lane.num_due] {
                wm(&mut self.world).check_out(d.id, &mut d.controls);
            }
        }
        let world = &self.world;
        let busy = self.lanes.iter().filter(|l| l.num_due > 0).count();
        if busy > 1 {
            self.lanes
                .par_iter_mut()
                .with_max_len(1)
                .for_each(|lane| lane.run(world, time_s));
        } else {
            for lane in &mut self.lanes {
                lane.run(world, time_s);
            }
        }
        let mut claims = Vec::new();
        let (mut perception, mut lanes_total, mut decisions) = (0u64, 0u64, 0u64);
        for lane in &mut self.lanes {
            for d in &mut lane.due[..lane.num_due] {
                wm(&mut self.world).check_in(d.id, &mut d.controls);
            }
            claims.append(&mut lane.claims);
            perception += lane.perception_ns;
            lanes_total += lane.total_ns;
            decisions += lane.decided;
        }
        // Bites in decision order: the first fish to bite a pellet this tick eats it.
        claims.sort_by_key(|c| c.0);
        for (_, fish, food) in claims {
            wm(&mut self.world).try_eat(fish, food);
        }
        // The stage's wall time, split between sensing and Lua as the lanes' CPU time was.
        let total = start.elapsed().as_nanos() as u64;
        let perception_wall = if lanes_total > 0 {
            (u128::from(total) * u128::from(perception) / u128::from(lanes_total)) as u64
        } else {
            0
        };
        let c = wm(&mut self.world).counters_mut();
        c.perception_ns = perception_wall.min(total);
        c.lua_ns = total.saturating_sub(c.perception_ns);
        // Each lane runs on one thread, so its time is (all but preemption) CPU time.
        c.decisions = decisions;
        c.sense_cpu_ns = perception;
        c.decide_cpu_ns = lanes_total.saturating_sub(perception);
    }

    /// Key/value lines describing a fish for the inspector panel: species, behaviour, motion,
    /// root state, the intention and percepts its behaviour produced last, its memory and its
    /// last script error.
    pub fn inspect(&self, id: FishId) -> Vec<(String, String)> {
        let mut out = Vec::new();
        let w = &self.world;
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
        for lane in &self.lanes {
            for (name, _) in &lane.module_of {
                if let Some(why) = lane.host.quarantine_of(name)
                    && !out.iter().any(|(n, _)| n == name)
                {
                    out.push((name.clone(), why.to_owned()));
                }
            }
        }
        out
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
                super::host::value_to_json(&v, 0)
            })
    }

    /// Console entries logged since the last call, from every lane, oldest first: each distinct
    /// error or warning once (an error every lane logged — a file failing to load, a runaway
    /// behaviour that fish of two lanes run — appears once, with the first fish), each notice no
    /// fish gave once, and every print of a fish.
    pub fn drain_log(&mut self) -> Vec<LogEntry> {
        let mut all: Vec<LogEntry> = Vec::new();
        for lane in &mut self.lanes {
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
        for lane in &self.lanes {
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
        for lane in &self.lanes {
            for (k, v) in lane.host.load_errors() {
                all.entry(k.clone()).or_insert_with(|| v.clone());
            }
        }
        all.into_iter().collect()
    }

    /// Starts watching `scripts/` so that [`Simulation::poll_reload`] picks up saved files.
    pub fn watch(&mut self) -> Result<(), ScriptError> {
        self.watcher = Some(ScriptWatcher::new(&self.scripts_dir)?);
        Ok(())
    }

    /// Reloads what changed on disk since the last call (call once per frame; cheap when
    /// nothing changed). Needs [`Simulation::watch`].
    pub fn poll_reload(&mut self) -> Vec<ReloadEvent> {
        let Some(w) = &self.watcher else {
            return Vec::new();
        };
        let changed = w.changed();
        if changed.is_empty() {
            return Vec::new();
        }
        self.reload_changed(&changed)
    }

    /// Reloads what the changed files affect: behaviour modules (and the modules using a changed
    /// library), species data (applied to live fish), or the scene (sets
    /// [`Simulation::scene_changed`]). Usable without a watcher.
    pub fn reload_changed(&mut self, paths: &[PathBuf]) -> Vec<ReloadEvent> {
        let mut events = Vec::new();
        let time_s = self.world.time();
        for p in paths {
            let real = p.canonicalize().unwrap_or_else(|_| p.clone());
            if self.scene_path.as_deref() == Some(real.as_path()) {
                self.scene_changed = true;
                let msg = format!(
                    "{}: scene changed — restart?",
                    self.host().root().display_of(&real)
                );
                self.host_mut().log(LogLevel::Info, &msg, None, time_s);
                events.push(ReloadEvent::SceneChanged);
                continue;
            }
            if let Some(i) = self.species.iter().position(|s| s.path == real) {
                events.push(self.reload_species(i, &real, time_s));
                continue;
            }
            // Every lane reloads; lane 0's outcome is reported (the lanes run the same files).
            let mut outcome = None;
            for lane in &mut self.lanes {
                let r = lane.host.reload_path(&real, time_s);
                match &r {
                    // Modules that failed their first load may load now.
                    Reloaded::Modules(_) => lane.module_of.retain(|(_, m)| m.is_some()),
                    Reloaded::NotAModule => {
                        let stem = real.file_stem().map(|s| s.to_string_lossy().into_owned());
                        let in_behaviors = real.parent().is_some_and(|d| d.ends_with("behaviors"));
                        let never_loaded = |stem: &str| {
                            lane.module_of
                                .iter()
                                .position(|(n, m)| n == stem && m.is_none())
                        };
                        if let (Some(stem), true) = (stem, in_behaviors)
                            && let Some(i) = never_loaded(&stem)
                        {
                            // A behaviour that never loaded: try again on next use.
                            lane.module_of.swap_remove(i);
                            outcome.get_or_insert(ReloadEvent::Behaviors(vec![stem]));
                        }
                    }
                    Reloaded::Failed(_) => {}
                }
                match r {
                    Reloaded::Modules(names) => {
                        outcome.get_or_insert(ReloadEvent::Behaviors(names));
                    }
                    Reloaded::Failed(msg) => {
                        outcome.get_or_insert(ReloadEvent::Failed(msg));
                    }
                    Reloaded::NotAModule => {}
                }
            }
            events.extend(outcome);
        }
        self.reload_events.extend(events.iter().cloned());
        events
    }

    fn reload_species(&mut self, i: usize, path: &Path, time_s: f64) -> ReloadEvent {
        let display = self.host().root().display_of(path);
        match self.load_species(path) {
            Ok((species, period)) => {
                let name = species.desc.name.clone();
                match wm(&mut self.world).replace_species(SpeciesId(i as u16), species) {
                    Ok(()) => {
                        self.species[i].period_ticks = period;
                        for lane in &self.lanes {
                            if let Some(mut c) = lane.host.lua().app_data_mut::<Ctx>() {
                                c.invalidate_species();
                            }
                        }
                        self.host_mut().log(
                            LogLevel::Info,
                            &format!("{display}: species '{name}' reloaded"),
                            None,
                            time_s,
                        );
                        ReloadEvent::Species(name)
                    }
                    Err(e) => {
                        let msg = format!("{display}: {e}");
                        self.host_mut().log(LogLevel::Error, &msg, None, time_s);
                        ReloadEvent::Failed(msg)
                    }
                }
            }
            Err(e) => {
                let msg = e.to_string();
                self.host_mut().log(LogLevel::Error, &msg, None, time_s);
                ReloadEvent::Failed(msg)
            }
        }
    }

    /// True once the scene file changed on disk since the scene was (re)started.
    pub fn scene_changed(&self) -> bool {
        self.scene_changed
    }

    /// Rebuilds the simulation from the (edited) scene file with the same seed, keeping the file
    /// watcher. On error the current simulation is left as it was.
    pub fn restart_scene(&mut self) -> Result<(), ScriptError> {
        let Some(scene) = self.scene_path.clone() else {
            return Ok(());
        };
        let mut fresh =
            Self::from_scene_with_scripts(&self.root, &self.scripts_dir, &scene, self.seed)?;
        if fresh.lanes.len() != self.lanes.len() {
            fresh.set_lanes(self.lanes.len())?;
        }
        fresh.watcher = self.watcher.take();
        *self = fresh;
        Ok(())
    }
}

/// The world for changing it: only the behaviour stage shares it, and the lanes let go of it
/// before the stage ends.
fn wm(world: &mut Arc<World>) -> &mut World {
    Arc::get_mut(world).expect("the script lanes hold the world only during the behaviour stage")
}

fn tank_of(b: &BoxDesc, what: &str) -> Result<Tank, ScriptError> {
    let (min, max) = (v3(b.min), v3(b.max));
    if !(min.is_finite() && max.is_finite() && min.cmplt(max).all()) {
        return Err(ScriptError::Data {
            file: what.into(),
            why: format!("tank min {min} must be below max {max} on every axis, all finite"),
        });
    }
    Ok(Tank { min, max })
}

fn read_lua_file(host: &ScriptHost, path: &Path) -> Result<Value, ScriptError> {
    host.load_data_file(path)
}

fn read_scene(host: &ScriptHost, path: &Path, display: &str) -> Result<SceneDesc, ScriptError> {
    let v = read_lua_file(host, path)?;
    let desc: SceneDesc = super::scene::from_lua_value(v, display).map_err(ScriptError::Invalid)?;
    super::scene::validate_scene(&desc).map_err(|why| ScriptError::Data {
        file: display.to_owned(),
        why,
    })?;
    // Names that must exist: each group's species and behaviour.
    for (g, group) in desc.fish.iter().enumerate() {
        check_name(
            host,
            "species",
            &group.species,
            display,
            &format!("fish[{}].species", g + 1),
        )?;
        if let Some(b) = &group.behavior {
            check_name(
                host,
                "behaviors",
                b,
                display,
                &format!("fish[{}].behavior", g + 1),
            )?;
        }
    }
    for (i, s) in desc.species.iter().enumerate() {
        check_name(host, "species", s, display, &format!("species[{}]", i + 1))?;
    }
    Ok(desc)
}

/// The `.lua` files of `scripts/<dir>/`, by name without the extension, sorted.
pub(crate) fn script_names(host: &ScriptHost, dir: &str) -> Vec<String> {
    let mut names: Vec<String> = std::fs::read_dir(host.root().dir.join(dir))
        .into_iter()
        .flatten()
        .flatten()
        .filter_map(|e| {
            let p = e.path();
            (p.extension().is_some_and(|x| x == "lua") && p.is_file())
                .then(|| p.file_stem().map(|s| s.to_string_lossy().into_owned()))
                .flatten()
        })
        .collect();
    names.sort();
    names
}

/// An error naming `field` of the scene `display` when `scripts/<dir>/<name>.lua` does not exist,
/// with the closest existing name.
fn check_name(
    host: &ScriptHost,
    dir: &str,
    name: &str,
    display: &str,
    field: &str,
) -> Result<(), ScriptError> {
    if host.root().resolve_module(&format!("{dir}/{name}")).is_ok() {
        return Ok(());
    }
    let what = if dir == "behaviors" {
        "behaviour"
    } else {
        "species"
    };
    let known = script_names(host, dir);
    Err(ScriptError::Data {
        file: display.to_owned(),
        why: format!(
            "{field}: {} — there is no scripts/{dir}/{name}.lua",
            super::scene::unknown_name(what, name, &known)
        ),
    })
}

fn read_species(host: &ScriptHost, path: &Path) -> Result<SpeciesFile, ScriptError> {
    let display = host.root().display_of(path);
    let Value::Table(t) = read_lua_file(host, path)? else {
        return Err(ScriptError::Data {
            file: display,
            why: "a species file must return a table".into(),
        });
    };
    species_from_table(host.lua(), &display, t).map_err(ScriptError::Invalid)
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

/// A value in a few characters: numbers to 2 decimals, tables shallowly.
fn short(v: &Value) -> String {
    match v {
        Value::Nil => "nil".into(),
        Value::Boolean(b) => b.to_string(),
        Value::Integer(i) => i.to_string(),
        Value::Number(n) => format!("{n:.2}"),
        Value::String(s) => s.to_string_lossy(),
        Value::Table(t) => {
            let mut parts: Vec<String> = t
                .pairs::<Value, Value>()
                .flatten()
                .take(8)
                .map(|(k, v)| {
                    let v = match &v {
                        Value::Table(_) => "{…}".to_owned(),
                        other => short(other),
                    };
                    match k {
                        Value::Integer(_) => v,
                        k => format!("{}={v}", short(&k)),
                    }
                })
                .collect();
            parts.sort();
            format!("{{{}}}", parts.join(", "))
        }
        other => other.type_name().to_owned(),
    }
}
