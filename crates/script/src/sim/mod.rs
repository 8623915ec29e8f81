//! [`Simulation`]: a world, the Lua scripts that decide for its fish, and the scene they came
//! from, stepped one fixed 60 Hz tick at a time by [`shoal_core::world::step`] (scene events →
//! behaviour → motion → pose → grid).
//!
//! The scripts are the tick's behaviour stage ([`Scripts`], a [`shoal_core::world::Behavior`]): the
//! fish whose staggered slot is due decide — fish `i` decides on ticks where
//! `(tick + i) % period == 0`, `period = round(60 / decision_hz)` (default 10 Hz → every 6th
//! tick), so the Lua cost per frame stays flat — timed into `lua_ns`, with the sensor queries
//! they make timed separately into `perception_ns`. The decisions run in parallel **script
//! lanes** (see below).
//!
//! The files: this one builds a simulation from a scene (fish, species, spawning); `lanes.rs`
//! runs the decisions; `console.rs` reports (inspector lines, log, errors); `reload.rs` applies
//! saved files.
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

use glam::Vec3;
use mlua::Value;
use rand::Rng;

use super::error::ScriptError;
use super::host::ScriptHost;
use super::reload::ScriptWatcher;
use super::sandbox::Limits;
use super::scene::{BoxDesc, SceneDesc, SpeciesFile, species_from_table};
use shoal_core::world::{
    Current, FishId, FoodDrops, FoodPhysics, Pipeline, SpawnParams, Species, SpeciesId, TICK_HZ,
    Tank, World, random_point,
};

mod bench;
mod console;
mod lanes;
mod live_edit;
mod measures;
mod reload;
mod snapshot;

pub use bench::bench_school;
pub use console::{FLAME_STACKS, ModuleProfile, SAMPLE_EVERY};
use lanes::Lane;
pub use lanes::{ModuleStats, Scripts, default_lanes, lane_index};
pub use measures::MeasureResult;
pub use reload::ReloadEvent;

pub use snapshot::SimSnapshot;

/// A species the simulation loaded from `scripts/species/`.
#[derive(Debug, Clone)]
struct SpeciesSlot {
    /// The species file.
    path: PathBuf,
    /// Ticks between two decisions of one fish.
    period_ticks: u64,
}

/// Fish spawned between two [`SetupProgress::spawned`] reports.
pub const SETUP_PROGRESS_EVERY: u64 = 1000;

/// What [`Simulation::from_scene_reporting`] tells as it sets a scene up.
pub trait SetupProgress {
    /// The scene is read and fits: `total` fish are about to be spawned.
    fn start(&mut self, total: u64) {
        let _ = total;
    }
    /// `done` fish are spawned (every [`SETUP_PROGRESS_EVERY`]).
    fn spawned(&mut self, done: u64) {
        let _ = done;
    }
    /// Every fish is spawned and the scene's food, rocks and currents are in.
    fn finish(&mut self, total: u64) {
        let _ = total;
    }
}

/// No report.
impl SetupProgress for () {}

/// The aquarium: world, scripts, scene.
pub struct Simulation {
    /// The world and the script lanes deciding for its fish (the tick's behaviour stage).
    sim: Pipeline<Scripts>,
    scripts_dir: PathBuf,
    /// The repository root the assets are found under.
    root: PathBuf,
    assets_dir: PathBuf,
    /// Where a model missing from `assets_dir` is taken from: the source tree's `assets/`
    /// (none when that is `assets_dir`). A designer's own folder with one model of theirs in
    /// `assets/` still swims the shipped species.
    asset_fallback: Option<PathBuf>,
    /// The models taken from `asset_fallback`, in the order first loaded.
    borrowed_models: Vec<BorrowedModel>,
    scene_path: Option<PathBuf>,
    scene: Option<SceneDesc>,
    seed: u64,
    watcher: Option<ScriptWatcher>,
    scene_changed: bool,
    reload_events: Vec<ReloadEvent>,
    /// Each fish's `fish.params` from its scene group (only fish that have some).
    fish_params: std::collections::HashMap<FishId, Arc<serde_json::Value>>,
    /// The fish each scene group spawned, by group (the panel's `params` edits reach them).
    group_fish: Vec<Vec<FishId>>,
    /// The window moved, added or removed rocks or current zones: a restored state keeps them
    /// as edited (see [`Simulation::apply_scene_edit`]).
    props_edited: bool,
    /// Simulated time [`Simulation::profile`] counts from.
    profile_since_s: f64,
    /// How often the lanes' Lua stacks are sampled (see [`Simulation::set_function_sampling`]).
    sample_every: Option<std::time::Duration>,
    /// The scene's own measures and what they have sampled (see [`Simulation::measures`]).
    measures: measures::Measures,
    /// `--lod on|off`, if given: it overrides the scene's default, also across restarts.
    lod_override: Option<bool>,
}

/// A model a simulation took from the source tree's `assets/` because its own models
/// directory lacks it (see [`Simulation::borrowed_models`]).
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BorrowedModel {
    /// The species file's `asset`, e.g. `black_porgy.glb`.
    pub asset: String,
    /// The directory it was loaded from.
    pub dir: PathBuf,
}

/// The source tree's `assets/`, unless that is `assets_dir` itself.
fn asset_fallback(assets_dir: &Path) -> Option<PathBuf> {
    let source = shoal_core::source_root().join("assets");
    let same = match (assets_dir.canonicalize(), source.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => assets_dir == source,
    };
    (!same && source.is_dir()).then_some(source)
}

fn v3(a: [f32; 3]) -> Vec3 {
    Vec3::from_array(a)
}

/// The scene's food drops as the world runs them.
fn food_drops(desc: &SceneDesc) -> Option<FoodDrops> {
    desc.food_drops.map(|d| FoodDrops {
        every: d.every,
        count: d.count,
        start: d.start.unwrap_or(d.every),
        region: d.region.map(|r| (v3(r.min), v3(r.max))),
    })
}

/// How the scene's pellets sink and how long they last.
fn food_physics(desc: &SceneDesc) -> FoodPhysics {
    FoodPhysics {
        sink_speed: desc.food_sink_speed.unwrap_or(0.0),
        lifetime: desc.food_lifetime,
    }
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
        Self::from_scene_reporting(root, scripts_dir, scene, seed, &mut ())
    }

    /// [`Simulation::from_scene_with_scripts`], telling `progress` how the spawning goes (a
    /// scene of 200,000 fish takes a while to set up). Either way a scene whose fish would not
    /// fit in the memory available is refused before any is spawned
    /// ([`shoal_core::world::footprint`]).
    pub fn from_scene_reporting(
        root: &Path,
        scripts_dir: &Path,
        scene: &Path,
        seed: u64,
        progress: &mut dyn SetupProgress,
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
        let total: u64 = desc.fish.iter().map(|g| u64::from(g.count)).sum();
        shoal_core::world::footprint::check_fits(
            total,
            shoal_core::world::footprint::available_bytes(),
        )
        .map_err(|source| ScriptError::TooManyFish {
            file: display.clone(),
            source,
        })?;
        let mut sim = Self::with_host(root, host, &desc, seed)?;
        sim.scene_path = Some(path.canonicalize().unwrap_or(path));
        progress.start(total);
        sim.populate(&desc, &display, progress)?;
        progress.finish(total);
        sim.measures = measures::Measures::new(&desc.measures);
        sim.scene = Some(desc);
        Ok(sim)
    }

    /// An empty tank (`scripts/scenes/empty_tank.lua` if it exists, else 20 × 8 × 12 body
    /// lengths of a black porgy) with no fish; species load on first [`Simulation::spawn`].
    pub fn empty(root: &Path, seed: u64) -> Result<Self, ScriptError> {
        Self::empty_with_scripts(root, &root.join("scripts"), seed)
    }

    /// [`Simulation::empty`] with the scripts from `scripts_dir` (its
    /// `scenes/empty_tank.lua` when it has one) and the models under `root`.
    pub fn empty_with_scripts(
        root: &Path,
        scripts_dir: &Path,
        seed: u64,
    ) -> Result<Self, ScriptError> {
        let empty = scripts_dir.join("scenes/empty_tank.lua");
        if empty.is_file() {
            return Self::from_scene_with_scripts(root, scripts_dir, &empty, seed);
        }
        let scripts_dir = scripts_dir.to_path_buf();
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
            food_sink_speed: None,
            food_lifetime: None,
            obstacles: Vec::new(),
            currents: Vec::new(),
            measures: Vec::new(),
            lod: None,
        };
        Self::with_host(root, host, &desc, seed)
    }

    /// Runs the decisions in `n` script lanes (at least 1) from now on. Rebuilds the Lua states:
    /// behaviours reload and every fish's `memory` starts empty again, so call it before the
    /// first tick.
    pub fn set_lanes(&mut self, n: usize) -> Result<(), ScriptError> {
        self.rebuild_lanes(self.host().limits(), n.max(1))
    }

    /// Runs the scripts under `debugger`'s breakpoints from now on, in one lane (like
    /// [`Simulation::set_lanes`], this rebuilds the Lua states: call it before the first tick).
    pub fn attach_debugger(
        &mut self,
        debugger: Arc<super::debug::Debugger>,
    ) -> Result<(), ScriptError> {
        self.rebuild_lanes(self.host().limits(), 1)?;
        self.sim.behavior.debugger = Some(debugger);
        Ok(())
    }

    /// Turns behaviour level of detail on or off (`--lod on|off`), overriding the scene's
    /// default (its `lod.on`); the bands and focus stay the scene's.
    pub fn set_lod_on(&mut self, on: bool) {
        self.lod_override = Some(on);
        let mut lod = self.sim.world().lod().clone();
        lod.on = on;
        self.sim
            .world_mut()
            .set_lod(lod)
            .expect("the level of detail was checked when it was set");
    }

    /// Moves the level-of-detail focus points (a window's camera focus and selected fish). An
    /// input: a recording keeps it ([`crate::timeline::inputs::Input::LodFocus`]).
    pub fn set_lod_focus(&mut self, focus: Vec<Vec3>) {
        self.sim.world_mut().set_lod_focus(focus);
    }

    /// Number of script lanes.
    pub fn num_lanes(&self) -> usize {
        self.sim.behavior.lanes.len()
    }

    fn rebuild_lanes(&mut self, limits: Limits, n: usize) -> Result<(), ScriptError> {
        let lanes = (0..n)
            .map(|_| Lane::new(&self.scripts_dir, limits))
            .collect::<Result<Vec<_>, _>>()?;
        self.sim.behavior.lanes = lanes;
        self.set_function_sampling(self.sample_every);
        for (&id, params) in &self.fish_params {
            let lane = lane_index(id, n);
            self.sim.behavior.lanes[lane]
                .host
                .set_params(id, Arc::clone(params))?;
        }
        Ok(())
    }

    /// Gives fish `id` the table `params` as `fish.params` (a scene group's `params`): at once
    /// when the fish has decided already, else when it first decides.
    pub fn set_params(&mut self, id: FishId, params: serde_json::Value) -> Result<(), ScriptError> {
        let params = Arc::new(params);
        let lane = lane_index(id, self.sim.behavior.lanes.len());
        self.fish_params.insert(id, Arc::clone(&params));
        self.sim.behavior.lanes[lane].host.set_params(id, params)
    }

    /// The lane fish `id` decides in.
    fn lane_of(&self, id: FishId) -> &Lane {
        &self.sim.behavior.lanes[lane_index(id, self.sim.behavior.lanes.len())]
    }

    /// Lane 0's script host: it reads data files and logs what concerns no fish.
    fn host(&self) -> &ScriptHost {
        &self.sim.behavior.lanes[0].host
    }

    fn host_mut(&mut self) -> &mut ScriptHost {
        &mut self.sim.behavior.lanes[0].host
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
        // Under a debugger the scripts run in one lane, on the simulation's thread (see
        // `script::debug`); results do not depend on the number of lanes.
        let debugger = super::debug::global();
        let num_lanes = if debugger.is_some() {
            1
        } else {
            default_lanes()
        };
        for _ in 1..num_lanes {
            lanes.push(Lane::new(&scripts_dir, limits)?);
        }
        let tank = tank_of(&desc.tank, "scene tank")?;
        let assets_dir = root.join(desc.assets.as_deref().unwrap_or("assets"));
        let mut world = World::new(tank, seed);
        world.set_food_drops(food_drops(desc));
        world.set_food_physics(food_physics(desc));
        if let Some(lod) = &desc.lod {
            world.set_lod(lod.to_lod()).map_err(|e| ScriptError::Data {
                file: "scene lod".into(),
                why: e.to_string(),
            })?;
        }
        let scripts = Scripts {
            lanes,
            species: Vec::new(),
            debugger,
            min_periods: Vec::new(),
            due: Vec::new(),
        };
        Ok(Self {
            sim: Pipeline::new(world, scripts),
            scripts_dir,
            root: root.to_path_buf(),
            asset_fallback: asset_fallback(&assets_dir),
            borrowed_models: Default::default(),
            assets_dir,
            scene_path: None,
            scene: None,
            seed,
            watcher: None,
            scene_changed: false,
            reload_events: Vec::new(),
            fish_params: std::collections::HashMap::new(),
            group_fish: Vec::new(),
            props_edited: false,
            profile_since_s: 0.0,
            sample_every: None,
            measures: measures::Measures::default(),
            lod_override: None,
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
        if self.sim.world().num_fish() > 0 {
            return Err(ScriptError::Data {
                file: "tank".into(),
                why: "the tank can only change before any fish is spawned".into(),
            });
        }
        let mut world = World::new(tank, self.seed);
        for i in 0..self.sim.behavior.species.len() {
            let s = self.sim.world().species(SpeciesId(i as u16)).clone();
            world.add_species(s);
        }
        world
            .set_lod(self.sim.world().lod().clone())
            .expect("the level of detail was checked when it was set");
        // The scene's generator and food drops go on in the new tank.
        *world.scene_rng() = self.sim.world_mut().scene_rng().clone();
        world.set_food_drops(self.scene.as_ref().and_then(food_drops));
        world.set_food_physics(self.scene.as_ref().map(food_physics).unwrap_or_default());
        self.sim.set_world(world);
        Ok(())
    }

    fn populate(
        &mut self,
        desc: &SceneDesc,
        display: &str,
        progress: &mut dyn SetupProgress,
    ) -> Result<(), ScriptError> {
        let mut spawned = 0u64;
        for name in &desc.species {
            self.species_id(name)?;
        }
        let tank = *self.sim.world().tank();
        let middle = BoxDesc {
            min: (tank.min + (tank.max - tank.min) * 0.25).to_array(),
            max: (tank.min + (tank.max - tank.min) * 0.75).to_array(),
        };
        for (g, group) in desc.fish.iter().enumerate() {
            let sid = self.species_id(&group.species)?;
            let cruise = self.sim.world().species(sid).desc.motion.s;
            let region = group.region.unwrap_or(middle);
            for k in 0..group.count {
                let pos = match (k, group.pos) {
                    (0, Some(p)) => v3(p),
                    _ => random_point(
                        self.sim.world_mut().scene_rng(),
                        v3(region.min),
                        v3(region.max),
                    ),
                };
                let heading = match group.heading {
                    Some(h) => h,
                    None => self
                        .sim
                        .world_mut()
                        .scene_rng()
                        .random_range(-std::f32::consts::PI..std::f32::consts::PI),
                };
                let seed = self.sim.world_mut().scene_rng().random::<u64>();
                let id = self
                    .sim
                    .world_mut()
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
                    self.set_params(id, params.clone())?;
                }
                spawned += 1;
                if spawned.is_multiple_of(SETUP_PROGRESS_EVERY) {
                    progress.spawned(spawned);
                }
                if self.group_fish.len() <= g {
                    self.group_fish.resize(g + 1, Vec::new());
                }
                self.group_fish[g].push(id);
            }
        }
        for f in &desc.food {
            self.sim.world_mut().add_food(v3(*f));
        }
        for o in &desc.obstacles {
            self.sim.world_mut().add_obstacle(v3(o.pos), o.radius);
        }
        for c in &desc.currents {
            self.sim.world_mut().add_current(Current {
                pos: v3(c.pos),
                radius: c.radius,
                velocity: v3(c.velocity),
            });
        }
        self.sim.world_mut().rebuild_grid();
        Ok(())
    }

    /// The species called `name`, loading `scripts/species/<name>.lua` on first use.
    pub fn species_id(&mut self, name: &str) -> Result<SpeciesId, ScriptError> {
        if let Some(id) = self.sim.world().species_by_name(name) {
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
        let id = self.sim.world_mut().add_species(species);
        let slot = SpeciesSlot { path, period_ticks };
        let i = usize::from(id.0);
        if self.sim.behavior.species.len() <= i {
            self.sim.behavior.species.resize(i + 1, slot.clone());
        }
        self.sim.behavior.species[i] = slot;
        Ok(id)
    }

    /// The file species `i` was read from (`None` for a species built in Rust): where the
    /// panel saves its tuned values.
    pub fn species_file(&self, i: usize) -> Option<&Path> {
        self.sim
            .behavior
            .species
            .get(i)
            .map(|s| s.path.as_path())
            .filter(|p| !p.as_os_str().is_empty())
    }

    /// Adds a species built in Rust (not from a file) whose fish decide `decision_hz` times per
    /// second. It is not hot-reloaded.
    pub fn add_species(&mut self, species: Species, decision_hz: f64) -> SpeciesId {
        let hz = if decision_hz.is_finite() && decision_hz > 0.0 {
            decision_hz
        } else {
            10.0
        };
        let id = self.sim.world_mut().add_species(species);
        let slot = SpeciesSlot {
            path: PathBuf::new(),
            period_ticks: (TICK_HZ / hz).round().max(1.0) as u64,
        };
        let i = usize::from(id.0);
        if self.sim.behavior.species.len() <= i {
            self.sim.behavior.species.resize(i + 1, slot.clone());
        }
        self.sim.behavior.species[i] = slot;
        id
    }

    fn load_species(&mut self, path: &Path) -> Result<(Species, u64), ScriptError> {
        let file = read_species(self.host(), path)?;
        let period = (TICK_HZ / file.decision_hz).round().max(1.0) as u64;
        let display = self.host().root().display_of(path);
        let dir = match &self.asset_fallback {
            Some(fallback)
                if !self.assets_dir.join(&file.desc.asset).is_file()
                    && fallback.join(&file.desc.asset).is_file() =>
            {
                if !self
                    .borrowed_models
                    .iter()
                    .any(|b| b.asset == file.desc.asset)
                {
                    self.borrowed_models.push(BorrowedModel {
                        asset: file.desc.asset.clone(),
                        dir: fallback.clone(),
                    });
                }
                fallback
            }
            _ => &self.assets_dir,
        };
        let species = Species::load(file.desc, dir).map_err(|source| ScriptError::World {
            context: display,
            source,
        })?;
        Ok((species, period))
    }

    /// The models directory this simulation looks in first (`assets/` beside the scripts, or
    /// the scene's `assets`).
    pub fn assets_dir(&self) -> &Path {
        &self.assets_dir
    }

    /// The models that were not in [`Simulation::assets_dir`] and came from the source tree's
    /// `assets/` instead, in the order first loaded.
    pub fn borrowed_models(&self) -> &[BorrowedModel] {
        &self.borrowed_models
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
        let speed = speed.unwrap_or(self.sim.world().species(sid).desc.motion.s);
        let seed = self.sim.world_mut().scene_rng().random::<u64>();
        self.sim
            .world_mut()
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
        let lane = lane_index(id, self.sim.behavior.lanes.len());
        self.sim.behavior.lanes[lane].host.forget_fish(id);
        self.fish_params.remove(&id);
        self.sim.world_mut().despawn(id)
    }

    /// The world.
    pub fn world(&self) -> &World {
        self.sim.world()
    }

    /// The world, mutable (spawn, food, obstacles…).
    pub fn world_mut(&mut self) -> &mut World {
        self.sim.world_mut()
    }

    /// The scene this simulation runs: as built from its file, with the window's live edits
    /// ([`Simulation::apply_scene_edit`]).
    pub fn scene(&self) -> Option<&SceneDesc> {
        self.scene.as_ref()
    }

    /// The scene file this simulation was built from.
    pub fn scene_file(&self) -> Option<&Path> {
        self.scene_path.as_deref()
    }

    /// Runs one fixed tick (1/60 s): [`shoal_core::world::step`] with the scripts as its behaviour.
    pub fn step(&mut self) {
        self.sim.tick();
        if self.measures.is_due(self.sim.world().tick_count()) {
            self.sample_measures();
        }
    }

    /// The world and the scripts as one [`Pipeline`] (for `shoal bench sim`, which ticks either
    /// behaviour the same way).
    pub fn pipeline_mut(&mut self) -> &mut Pipeline<Scripts> {
        &mut self.sim
    }

    /// The behaviour stage alone: the decisions due this tick, without advancing time (for
    /// benchmarks).
    pub fn run_behaviors(&mut self) {
        self.sim.decide();
    }

    /// Runs `seconds` of simulated time (rounded to whole ticks).
    pub fn run(&mut self, seconds: f64) {
        let ticks = (seconds * TICK_HZ).round().max(0.0) as u64;
        for _ in 0..ticks {
            self.step();
        }
    }
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
    scene_from_value(host, read_lua_file(host, path)?, display)
}

/// A scene file's value read and checked as the simulation does (types, ranges, that its species
/// and behaviours exist); `display` names the file in messages.
pub(crate) fn scene_from_value(
    host: &ScriptHost,
    v: Value,
    display: &str,
) -> Result<SceneDesc, ScriptError> {
    let desc: SceneDesc = super::scene::scene_from_lua(v, display)?;
    super::scene::validate_scene(&desc).map_err(|e| ScriptError::Scene {
        file: display.to_owned(),
        source: Box::new(e),
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
    species_from_value(host, read_lua_file(host, path)?, &display)
}

/// A species file's value read and checked as the simulation does; `display` names the file.
pub(crate) fn species_from_value(
    host: &ScriptHost,
    v: Value,
    display: &str,
) -> Result<SpeciesFile, ScriptError> {
    let display = display.to_owned();
    let Value::Table(t) = v else {
        return Err(ScriptError::Data {
            file: display,
            why: "a species file must return a table".into(),
        });
    };
    Ok(species_from_table(host.lua(), &display, t)?)
}
