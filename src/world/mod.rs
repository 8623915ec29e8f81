//! The world: every fish, the tank, food, obstacles and currents, and the Rust stages of a tick.
//!
//! It answers the perception layer's sensors (paper section 3.1: the vision sensor and the body
//! sensor) from a uniform spatial grid ([`grid`]), offers steering helpers ([`steer`]) that the
//! behaviour layer combines, turns a desired heading/depth/speed into motion requests
//! ([`World::steer_to`]), and runs the layers below the scripts: motion ([`World::step_motion`]),
//! skeleton and skinning palettes ([`World::update_pose`]).
//!
//! Fish live in a structure of arrays (`store.rs`) addressed by generational [`FishId`] handles.
//! A tick, Rapier-style, is a straight sequence of named stages each timed into
//! [`StageCounters`]; the Lua host (`script::Simulation`) drives it:
//! behaviour scripts → [`World::step_motion`] → [`World::update_pose`] → [`World::rebuild_grid`].
//!
//! Conventions (from `src/motion/mod.rs`): +y up; heading radians counter-clockwise seen from
//! above, 0 = +x, a left turn increases it; forward = (cos h·cos p, sin p, −sin h·cos p); lengths
//! in world units, a species' body length being `SpeciesDesc.motion.l`; a fish's `pos` is its
//! root, the head end of the vertebral column.

pub mod bench;
mod crowd;
pub mod driver;
pub mod grid;
mod nearest;
pub mod pose;
pub mod sense;
pub mod steer;
mod store;
#[cfg(test)]
mod test_world;

use std::f32::consts::TAU;
use std::ops::Range;
use std::path::Path;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use glam::{Mat4, Vec3};
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg32;

use crate::motion::{MotionError, MotionPlayer, MotionRequest, RootState, WaveTable};
use grid::Grid;
use sense::{ViewCone, bearing, elevation, forward, tank_distances, wrap_angle};
use steer::{Agent, Steer, SteerMemo, SteerParams};
use store::{FishStore, NewFish};

pub use crate::skin::FishModel;
pub use crate::species::{SpeciesDesc, SpeciesRig};
pub use crowd::Crowd;

/// The fixed motion tick, Hz.
pub const TICK_HZ: f64 = 60.0;

/// Most driven (vertebral) joints a species may have; per-fish yaw/lateral arrays are this size.
pub const MAX_DRIVEN_JOINTS: usize = 16;

/// How far a fish reaches to eat, as a fraction of its body length, measured from its root.
pub const EAT_REACH_LENGTHS: f32 = 0.3;

/// How close a fish's body may come to a wall or obstacle, as a fraction of its body length.
pub const CONTACT_MARGIN_LENGTHS: f32 = 0.02;

/// A stable fish handle: `index` names a slot, `generation` the fish that holds it now.
/// A handle whose fish was despawned is rejected everywhere, even after its slot is reused.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct FishId {
    /// Slot in the world's handle table.
    pub index: u32,
    /// Incremented each time the slot is freed.
    pub generation: u32,
}

/// Index of a food pellet (food is never removed, only eaten).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct FoodId(pub u32);

/// Index of an obstacle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ObstacleId(pub u32);

/// Index of a species in the world.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SpeciesId(pub u16);

/// The tank: an axis-aligned box. The floor is `min.y`, the water surface `max.y`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Tank {
    /// Lower corner, world units.
    pub min: Vec3,
    /// Upper corner, world units.
    pub max: Vec3,
}

impl Tank {
    /// Depth below the surface of height `y`, world units.
    pub fn depth_of(&self, y: f32) -> f32 {
        self.max.y - y
    }

    /// Whether `p` lies inside the tank (boundaries included).
    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    /// Size along each axis, world units.
    pub fn extent(&self) -> Vec3 {
        self.max - self.min
    }
}

/// Errors of the world: each names the value and why it was refused.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum WorldError {
    /// A number is NaN or infinite.
    #[error("{what} is {value}: must be a finite number")]
    NonFinite {
        /// Which value.
        what: &'static str,
        /// The value given.
        value: f32,
    },
    /// A number is finite but out of range.
    #[error("{what} is {value}: {why}")]
    OutOfRange {
        /// Which value.
        what: &'static str,
        /// The value given.
        value: f32,
        /// What was expected.
        why: &'static str,
    },
    /// A position lies outside the tank.
    #[error("{what} {pos} lies outside the tank ({min} .. {max})")]
    OutsideTank {
        /// Which position.
        what: &'static str,
        /// The position given.
        pos: Vec3,
        /// The tank's lower corner.
        min: Vec3,
        /// The tank's upper corner.
        max: Vec3,
    },
    /// No species has this id.
    #[error("no species with id {0:?}")]
    UnknownSpecies(SpeciesId),
    /// The fish was despawned (or never existed).
    #[error("fish {0:?} does not exist (despawned or never spawned)")]
    StaleFish(FishId),
    /// The species drives more joints than a fish's fixed-size arrays hold.
    #[error(
        "species {species:?} drives {joints} joints; at most {MAX_DRIVEN_JOINTS} are supported"
    )]
    TooManyDrivenJoints {
        /// The species' name.
        species: String,
        /// Its number of driven joints.
        joints: usize,
    },
    /// A species' rig and model disagree (joint count, inverse bind poses).
    #[error("species {species:?} is inconsistent: {why}")]
    BadSpecies {
        /// The species' name.
        species: String,
        /// What is wrong.
        why: String,
    },
    /// Loading a species' asset or binding its rig failed.
    #[error("cannot load species {species:?} from {path}: {reason}")]
    SpeciesLoad {
        /// The species' name.
        species: String,
        /// The asset path tried.
        path: String,
        /// The underlying error.
        reason: String,
    },
    /// The motion layer refused a request.
    #[error(transparent)]
    Motion(#[from] MotionError),
}

/// A species in the world: its data, its rig and its model (shared by every fish of it).
#[derive(Debug, Clone)]
pub struct Species {
    /// The species description (motion parameters, senses, drives).
    pub desc: SpeciesDesc,
    /// Binding of the motion layer's body to the model's skeleton.
    pub rig: SpeciesRig,
    /// The skinned model.
    pub model: Arc<FishModel>,
}

impl Species {
    /// Loads the species' asset (`desc.asset`, relative to `assets_dir`) and binds its rig.
    pub fn load(desc: SpeciesDesc, assets_dir: &Path) -> Result<Self, WorldError> {
        let path = assets_dir.join(&desc.asset);
        let fail = |reason: String| WorldError::SpeciesLoad {
            species: desc.name.clone(),
            path: path.display().to_string(),
            reason,
        };
        let mut model = FishModel::load(&path).map_err(|e| fail(e.to_string()))?;
        if let Some(cutoff) = desc.alpha_cutoff {
            model.mesh.material.alpha_mode = crate::skin::AlphaMode::Mask { cutoff };
        }
        // A texture that cannot be used is not fatal (the fish keeps its base colour), but a
        // designer should hear of it.
        for w in model.warnings.iter().filter(|w| w.contains("base colour")) {
            log::warn!("species {}: {w}", desc.name);
        }
        let rig = SpeciesRig::bind(&desc, &model).map_err(|e| fail(e.to_string()))?;
        let species = Self {
            desc,
            rig,
            model: Arc::new(model),
        };
        species.validate()?;
        Ok(species)
    }

    /// Checks what the world relies on: at most [`MAX_DRIVEN_JOINTS`] driven joints, one more
    /// midline sample than driven joints, one inverse bind pose per skeleton joint, and sane
    /// sensor ranges.
    pub fn validate(&self) -> Result<(), WorldError> {
        let name = || self.desc.name.clone();
        let driven = self.rig.body.power.len();
        if driven > MAX_DRIVEN_JOINTS {
            return Err(WorldError::TooManyDrivenJoints {
                species: name(),
                joints: driven,
            });
        }
        if self.rig.body.joints_x.len() != driven + 1 {
            return Err(WorldError::BadSpecies {
                species: name(),
                why: format!(
                    "body has {} joint positions for {driven} driven joints (expected {})",
                    self.rig.body.joints_x.len(),
                    driven + 1
                ),
            });
        }
        let joints = self.model.skeleton.num_joints();
        if self.model.inverse_bind_poses.len() != joints {
            return Err(WorldError::BadSpecies {
                species: name(),
                why: format!(
                    "{} inverse bind poses for {joints} joints",
                    self.model.inverse_bind_poses.len()
                ),
            });
        }
        for (what, v) in [
            ("view_range", self.desc.view_range),
            ("view_angle_deg", self.desc.view_angle_deg),
            ("max_speed", self.desc.max_speed),
            ("motion.l", self.desc.motion.l),
        ] {
            finite(what, v)?;
            if v < 0.0 {
                return Err(WorldError::OutOfRange {
                    what,
                    value: v,
                    why: "must not be negative",
                });
            }
        }
        Ok(())
    }

    /// Body length `l`, world units.
    pub fn body_length(&self) -> f32 {
        self.desc.motion.l
    }
}

/// Where and how a new fish starts.
#[derive(Debug, Clone, PartialEq)]
pub struct SpawnParams {
    /// Its species.
    pub species: SpeciesId,
    /// Root (head) position, world units; must lie inside the tank.
    pub pos: Vec3,
    /// Heading, radians.
    pub heading: f32,
    /// Pitch, radians, positive nose-up.
    pub pitch: f32,
    /// Starting speed, world units per second (≥ 0); a positive speed starts a swim.
    pub speed: f32,
    /// Name of the behaviour script it runs, if any.
    pub behavior: Option<String>,
    /// Seed of the fish's own random generator.
    pub seed: u64,
}

/// A food pellet. Eaten food stays in the list, marked.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Food {
    /// Position, world units.
    pub pos: Vec3,
    /// Whether a fish has eaten it.
    pub eaten: bool,
    /// Which fish ate it.
    pub eaten_by: Option<FishId>,
    /// World time it was eaten at, seconds.
    pub eaten_at: Option<f64>,
}

/// A spherical obstacle (a rock).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Obstacle {
    /// Centre, world units.
    pub pos: Vec3,
    /// Radius, world units.
    pub radius: f32,
}

/// A spherical zone of moving water: fish inside drift with `velocity`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Current {
    /// Centre, world units.
    pub pos: Vec3,
    /// Radius, world units; the drift fades out over the outer fifth.
    pub radius: f32,
    /// Drift velocity, world units per second.
    pub velocity: Vec3,
}

/// What a vision percept is.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum PerceptKind {
    /// A fish of a non-predator species (or of the viewer's own species).
    Fish,
    /// A food pellet not yet eaten.
    Food,
    /// An obstacle sphere.
    Obstacle,
    /// A fish of another species whose description marks it a predator.
    Predator,
}

/// One thing a fish sees.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Percept {
    /// What it is.
    pub kind: PerceptKind,
    /// The fish seen (fish and predators).
    pub fish: Option<FishId>,
    /// The food seen.
    pub food: Option<FoodId>,
    /// The obstacle seen.
    pub obstacle: Option<ObstacleId>,
    /// The seen fish's species.
    pub species: Option<SpeciesId>,
    /// Its position (an obstacle's centre), world units.
    pub pos: Vec3,
    /// Distance from the viewer's root, world units (to an obstacle's surface, 0 inside it).
    pub distance: f32,
    /// Radians relative to the viewer's heading, positive to its left, in (−π, π].
    pub bearing: f32,
    /// Radians above the horizontal plane through the viewer (negative below).
    pub elevation: f32,
    /// Heading of the seen fish, radians (0 for food and obstacles).
    pub heading: f32,
    /// Speed of the seen fish, world units per second (0 for food and obstacles).
    pub speed: f32,
}

/// Percepts of many fish, filled by [`World::vision_batch`].
#[derive(Debug, Default, Clone)]
pub struct VisionBatch {
    chunks: Vec<Vec<Percept>>,
    /// Per requested fish: (chunk, start, end) in `chunks`.
    spans: Vec<(u32, u32, u32)>,
}

impl VisionBatch {
    /// Fish per parallel task.
    const CHUNK: usize = 32;

    /// Number of fish in the batch.
    pub fn len(&self) -> usize {
        self.spans.len()
    }

    /// Whether the batch holds no fish.
    pub fn is_empty(&self) -> bool {
        self.spans.is_empty()
    }

    /// Percepts of the batch's `i`-th fish, nearest first (empty for a stale id or out of
    /// range).
    pub fn get(&self, i: usize) -> &[Percept] {
        match self.spans.get(i) {
            Some(&(c, start, end)) => &self.chunks[c as usize][start as usize..end as usize],
            None => &[],
        }
    }
}

/// What a fish feels of its own body and the tank (the paper's body sensor).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodySense {
    /// Root position, world units.
    pub pos: Vec3,
    /// Depth below the surface, world units.
    pub depth: f32,
    /// Height above the floor, world units.
    pub to_floor: f32,
    /// Distance below the surface, world units (equals `depth`).
    pub to_surface: f32,
    /// Distance to the nearest side wall, world units.
    pub to_wall: f32,
    /// Inward unit normal of that wall.
    pub wall_normal: Vec3,
    /// Whether it touched a wall, the floor, the surface or an obstacle in the last motion step.
    pub contact: bool,
    /// Forward speed, world units per second.
    pub speed: f32,
    /// Heading, radians.
    pub heading: f32,
    /// Pitch, radians.
    pub pitch: f32,
}

/// Wall time of each stage of the last tick, nanoseconds (the tuning panel and `shoal bench`
/// show these). The world fills `motion_ns`, `skeleton_ns`, `palette_ns` and `grid_ns`; the Lua
/// host (or a Rust driver) fills `perception_ns`, `lua_ns` and the per-decision figures.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct StageCounters {
    /// Sensor queries (vision, body sense, neighbour queries).
    pub perception_ns: u64,
    /// Behaviour scripts.
    pub lua_ns: u64,
    /// Motion players, currents and contact.
    pub motion_ns: u64,
    /// Rig pose and forward kinematics.
    pub skeleton_ns: u64,
    /// Skinning palettes.
    pub palette_ns: u64,
    /// Spatial grid rebuild.
    pub grid_ns: u64,
    /// Behaviour decisions made in the tick.
    pub decisions: u64,
    /// CPU time of those decisions' behaviour code, summed over threads, sensor queries not
    /// included (the cost per decision is this over `decisions`).
    pub decide_cpu_ns: u64,
    /// CPU time of the sensor queries those decisions made, summed over threads (0 where the
    /// sensing is not timed per decision).
    pub sense_cpu_ns: u64,
}

impl StageCounters {
    /// Sum of all stages, nanoseconds.
    pub fn total_ns(&self) -> u64 {
        self.perception_ns
            + self.lua_ns
            + self.motion_ns
            + self.skeleton_ns
            + self.palette_ns
            + self.grid_ns
    }
}

/// All simulated state of an aquarium and the Rust stages of its tick.
pub struct World {
    tank: Tank,
    seed: u64,
    time: f64,
    tick: u64,
    species: Vec<Species>,
    /// Per species: its skeleton prepared for the pose stage.
    pose_plans: Vec<pose::PosePlan>,
    /// Per species: its body wave's constants for the motion stage.
    wave_tables: Vec<WaveTable>,
    fish: FishStore,
    foods: Vec<Food>,
    obstacles: Vec<Obstacle>,
    currents: Vec<Current>,
    /// Live fish of species whose description marks them predators (see `nearest.rs`).
    predators: Vec<FishId>,

    grid: Grid,
    /// Fish in the grid, by grid key (the dense index at rebuild time).
    grid_ids: Vec<FishId>,
    /// No fish was spawned or despawned since the rebuild: grid keys are dense indices.
    grid_exact: bool,
    /// Additionally no fish moved since the rebuild: the grid's positions are the roots'.
    grid_positions_current: bool,
    /// Fish spawned since the last rebuild (searched linearly until the next one).
    spawned_since_grid: Vec<FishId>,
    /// Per grid slot (the grid's cell order): the fish's species at the rebuild.
    grid_species: Vec<SpeciesId>,
    /// Per grid slot: (cos, sin) of the fish's heading at the rebuild (what alignment sums);
    /// filled only while crowd queries are being made (`crowd_wanted`), else empty.
    grid_heading: Vec<glam::Vec2>,
    /// A crowd query ran since the last rebuild: the next rebuild fills `grid_heading`. Worlds
    /// whose behaviours never ask do not pay for the cosines.
    crowd_wanted: AtomicBool,
    food_grid: Grid,
    /// Foods `0..food_in_grid` are in `food_grid`; later ones are searched linearly.
    food_in_grid: usize,

    /// `palette_offsets[i]..palette_offsets[i + 1]` is dense fish i's palette range.
    palette_offsets: Vec<u32>,
    palettes: Vec<Mat4>,
    counters: StageCounters,
    rejected_motion_steps: u64,
}

fn finite(what: &'static str, value: f32) -> Result<(), WorldError> {
    if value.is_finite() {
        Ok(())
    } else {
        Err(WorldError::NonFinite { what, value })
    }
}

fn finite3(what: [&'static str; 3], v: Vec3) -> Result<(), WorldError> {
    finite(what[0], v.x)?;
    finite(what[1], v.y)?;
    finite(what[2], v.z)
}

/// Rejects a request carrying NaN or infinity, naming the field.
/// What a fish's behaviour may change while it decides, checked out of the world by
/// [`World::check_out`]: its motion player, its steering memo and its random generator.
pub struct FishControls {
    player: MotionPlayer,
    steer: SteerMemo,
    rng: Pcg32,
}

impl Default for FishControls {
    fn default() -> Self {
        Self {
            player: MotionPlayer::new(),
            steer: SteerMemo::default(),
            rng: Pcg32::seed_from_u64(0),
        }
    }
}

impl FishControls {
    /// The fish's motion player (current motion, queue).
    pub fn player(&self) -> &MotionPlayer {
        &self.player
    }

    /// The fish's own random generator.
    pub fn rng(&mut self) -> &mut Pcg32 {
        &mut self.rng
    }
}

fn validate_request(r: &MotionRequest) -> Result<(), WorldError> {
    match *r {
        MotionRequest::Swim { speed } => finite("swim speed", speed),
        MotionRequest::Accelerate { speed, duration } => {
            finite("accelerate speed", speed)?;
            finite("accelerate duration", duration)
        }
        MotionRequest::Stop { duration } => finite("stop duration", duration),
        MotionRequest::Turn { angle, .. } => finite("turn angle", angle),
        MotionRequest::Ascend { height } => finite("ascend height", height),
        MotionRequest::Descend { depth } => finite("descend depth", depth),
    }
}

impl World {
    /// An empty world in `tank`; `seed` is the world's own seed (scenes derive fish seeds from it).
    pub fn new(tank: Tank, seed: u64) -> Self {
        let grid = Grid::new(tank.min, tank.max, tank.extent().max_element() / 16.0);
        let food_grid = grid.clone();
        Self {
            tank,
            seed,
            time: 0.0,
            tick: 0,
            species: Vec::new(),
            pose_plans: Vec::new(),
            wave_tables: Vec::new(),
            fish: FishStore::default(),
            foods: Vec::new(),
            obstacles: Vec::new(),
            currents: Vec::new(),
            predators: Vec::new(),
            grid,
            grid_ids: Vec::new(),
            grid_exact: true,
            grid_positions_current: true,
            spawned_since_grid: Vec::new(),
            grid_species: Vec::new(),
            grid_heading: Vec::new(),
            crowd_wanted: AtomicBool::new(false),
            food_grid,
            food_in_grid: 0,
            palette_offsets: vec![0],
            palettes: Vec::new(),
            counters: StageCounters::default(),
            rejected_motion_steps: 0,
        }
    }

    /// The tank.
    pub fn tank(&self) -> &Tank {
        &self.tank
    }

    /// The seed the world was created with.
    pub fn seed(&self) -> u64 {
        self.seed
    }

    /// Simulated time, seconds (advanced by [`World::step_motion`]).
    pub fn time(&self) -> f64 {
        self.time
    }

    /// Number of motion steps taken.
    pub fn tick_count(&self) -> u64 {
        self.tick
    }

    // ---- species ----------------------------------------------------------------------------

    /// Adds a species. A species that fails [`Species::validate`] is still added, but spawning
    /// it fails with the validation error.
    pub fn add_species(&mut self, s: Species) -> SpeciesId {
        if let Err(e) = s.validate() {
            log::error!("species {:?}: {e}", s.desc.name);
        }
        self.pose_plans.push(pose::PosePlan::new(&s.rig, &s.model));
        self.wave_tables
            .push(WaveTable::new(&s.desc.motion, &s.rig.body));
        self.species.push(s);
        SpeciesId((self.species.len() - 1) as u16)
    }

    /// Replaces a species (hot reload): live fish of it pick up the new data on their next step.
    /// If the driven joint count changes, their joint arrays restart from rest.
    pub fn replace_species(&mut self, id: SpeciesId, s: Species) -> Result<(), WorldError> {
        s.validate()?;
        let slot = self
            .species
            .get_mut(usize::from(id.0))
            .ok_or(WorldError::UnknownSpecies(id))?;
        let joints_changed = slot.rig.body.power.len() != s.rig.body.power.len()
            || slot.model.skeleton.num_joints() != s.model.skeleton.num_joints();
        let predator_changed = slot.desc.predator != s.desc.predator;
        self.pose_plans[usize::from(id.0)] = pose::PosePlan::new(&s.rig, &s.model);
        self.wave_tables[usize::from(id.0)] = WaveTable::new(&s.desc.motion, &s.rig.body);
        *slot = s;
        if predator_changed {
            self.refresh_predators();
        }
        if joints_changed {
            for i in 0..self.fish.len() {
                if self.fish.species[i] == id {
                    self.fish.yaw[i] = [0.0; MAX_DRIVEN_JOINTS];
                    self.fish.lateral[i] = [0.0; MAX_DRIVEN_JOINTS + 1];
                }
            }
            self.relayout_palettes();
        }
        Ok(())
    }

    /// A species. Panics on an id this world did not issue (a programming error).
    pub fn species(&self, id: SpeciesId) -> &Species {
        &self.species[usize::from(id.0)]
    }

    /// A species, or `None` for an unknown id.
    pub fn try_species(&self, id: SpeciesId) -> Option<&Species> {
        self.species.get(usize::from(id.0))
    }

    /// Number of species.
    pub fn num_species(&self) -> usize {
        self.species.len()
    }

    /// The species named `name`.
    pub fn species_by_name(&self, name: &str) -> Option<SpeciesId> {
        self.species
            .iter()
            .position(|s| s.desc.name == name)
            .map(|i| SpeciesId(i as u16))
    }

    // ---- fish -------------------------------------------------------------------------------

    /// Spawns a fish. Fails on an unknown or invalid species, a NaN or infinite value (naming
    /// it), a negative speed, or a position outside the tank.
    pub fn spawn(&mut self, p: SpawnParams) -> Result<FishId, WorldError> {
        let species = self
            .species
            .get(usize::from(p.species.0))
            .ok_or(WorldError::UnknownSpecies(p.species))?;
        species.validate()?;
        finite3(["spawn pos.x", "spawn pos.y", "spawn pos.z"], p.pos)?;
        finite("spawn heading", p.heading)?;
        finite("spawn pitch", p.pitch)?;
        finite("spawn speed", p.speed)?;
        if p.speed < 0.0 {
            return Err(WorldError::OutOfRange {
                what: "spawn speed",
                value: p.speed,
                why: "must not be negative",
            });
        }
        if !self.tank.contains(p.pos) {
            return Err(WorldError::OutsideTank {
                what: "spawn pos",
                pos: p.pos,
                min: self.tank.min,
                max: self.tank.max,
            });
        }
        // Each fish's wave starts at its own phase (from its seed) so a shoal does not beat in
        // lockstep.
        let phase = Pcg32::seed_from_u64(p.seed ^ 0x005E_ED0F_F15E_u64).random::<f32>() * TAU;
        let mut player = MotionPlayer::with_phase(phase);
        if p.speed > 0.0 {
            player.push(MotionRequest::Swim { speed: p.speed })?;
        }
        let joints = species.model.skeleton.num_joints() as u32;
        let predator = species.desc.predator;
        let id = self.fish.insert(NewFish {
            root: RootState {
                pos: p.pos,
                heading: wrap_angle(p.heading),
                pitch: p.pitch,
                speed: p.speed,
            },
            species: p.species,
            player,
            behavior: p.behavior,
            seed: p.seed,
        });
        let last = *self.palette_offsets.last().unwrap_or(&0);
        self.palette_offsets.push(last + joints);
        if predator {
            self.predators.push(id);
        }
        self.spawned_since_grid.push(id);
        self.grid_exact = false;
        Ok(id)
    }

    /// Removes a fish. Returns false if `id` was already gone.
    pub fn despawn(&mut self, id: FishId) -> bool {
        if self.fish.remove(id).is_none() {
            return false;
        }
        if let Some(k) = self.predators.iter().position(|&p| p == id) {
            self.predators.swap_remove(k);
        }
        self.grid_exact = false;
        self.spawned_since_grid.retain(|&f| f != id);
        self.relayout_palettes();
        true
    }

    fn relayout_palettes(&mut self) {
        self.palette_offsets.clear();
        self.palette_offsets.push(0);
        let mut total = 0u32;
        for &s in &self.fish.species {
            total += self.species[usize::from(s.0)].model.skeleton.num_joints() as u32;
            self.palette_offsets.push(total);
        }
    }

    /// Whether `id` names a live fish.
    pub fn is_alive(&self, id: FishId) -> bool {
        self.fish.dense(id).is_some()
    }

    /// Number of live fish.
    pub fn num_fish(&self) -> usize {
        self.fish.len()
    }

    /// Live fish in dense order (deterministic: spawn order, with a despawned fish's place taken
    /// by the last one).
    pub fn fish_ids(&self) -> impl Iterator<Item = FishId> + '_ {
        self.fish.ids.iter().copied()
    }

    /// Live fish handles, dense order.
    pub fn fish_id_slice(&self) -> &[FishId] {
        &self.fish.ids
    }

    /// Root states of all live fish, dense order (same order as [`World::fish_ids`]).
    pub fn roots(&self) -> &[RootState] {
        &self.fish.roots
    }

    /// Species of all live fish, dense order.
    pub fn fish_species(&self) -> &[SpeciesId] {
        &self.fish.species
    }

    /// A fish's root state.
    pub fn root(&self, id: FishId) -> Option<&RootState> {
        self.fish.dense(id).map(|d| &self.fish.roots[d])
    }

    /// A fish's species.
    pub fn species_of(&self, id: FishId) -> Option<SpeciesId> {
        self.fish.dense(id).map(|d| self.fish.species[d])
    }

    /// The behaviour script a fish runs.
    pub fn behavior_of(&self, id: FishId) -> Option<&str> {
        self.fish
            .dense(id)
            .and_then(|d| self.fish.behaviors[d].as_deref())
    }

    /// Sets (or clears) the behaviour a fish runs. False if `id` is stale.
    pub fn set_behavior(&mut self, id: FishId, behavior: Option<String>) -> bool {
        let Some(d) = self.fish.dense(id) else {
            return false;
        };
        self.fish.behaviors[d] = behavior;
        true
    }

    /// The seed a fish was spawned with.
    pub fn seed_of(&self, id: FishId) -> Option<u64> {
        self.fish.dense(id).map(|d| self.fish.seeds[d])
    }

    /// A fish's own random generator (seeded from its spawn seed), for scripts' random numbers.
    pub fn rng_mut(&mut self, id: FishId) -> Option<&mut Pcg32> {
        self.fish.dense(id).map(|d| &mut self.fish.rngs[d])
    }

    /// Moves what a fish's behaviour may change while it decides — its motion player, steering
    /// memo and random generator — out of the world into `controls` (swapping, so `controls`'
    /// previous contents wait in the world). With every deciding fish's controls checked out,
    /// decisions of different fish can run in parallel against a shared `&World` (script lanes);
    /// [`World::check_in`] puts them back. Until then the world's own copy of the fish's motion
    /// state is a stand-in: read it from `controls`. False if `id` is stale.
    pub fn check_out(&mut self, id: FishId, controls: &mut FishControls) -> bool {
        let Some(d) = self.fish.dense(id) else {
            return false;
        };
        std::mem::swap(&mut self.fish.players[d], &mut controls.player);
        std::mem::swap(&mut self.fish.steer[d], &mut controls.steer);
        std::mem::swap(&mut self.fish.rngs[d], &mut controls.rng);
        true
    }

    /// Puts back what [`World::check_out`] took (the same swap). False if `id` is stale.
    pub fn check_in(&mut self, id: FishId, controls: &mut FishControls) -> bool {
        self.check_out(id, controls)
    }

    /// Name of the motion a fish is playing (see `MotionPlayer::current_name`).
    pub fn current_motion(&self, id: FishId) -> Option<&'static str> {
        self.fish
            .dense(id)
            .map(|d| self.fish.players[d].current_name())
    }

    /// Number of motion requests queued behind the current one.
    pub fn queue_len(&self, id: FishId) -> Option<usize> {
        self.fish
            .dense(id)
            .map(|d| self.fish.players[d].queue_len())
    }

    /// Whether the fish touched a wall, floor, surface or obstacle in the last motion step.
    pub fn contact(&self, id: FishId) -> Option<bool> {
        self.fish.dense(id).map(|d| self.fish.contact[d])
    }

    /// The midline's lateral displacement at each of the species' `body.joints_x`, world units.
    pub fn lateral(&self, id: FishId) -> Option<&[f32]> {
        let d = self.fish.dense(id)?;
        let n = self.species[usize::from(self.fish.species[d].0)]
            .rig
            .body
            .joints_x
            .len()
            .min(MAX_DRIVEN_JOINTS + 1);
        Some(&self.fish.lateral[d][..n])
    }

    /// Each driven joint's local yaw, radians.
    pub fn yaw(&self, id: FishId) -> Option<&[f32]> {
        let d = self.fish.dense(id)?;
        let n = self.species[usize::from(self.fish.species[d].0)]
            .rig
            .body
            .power
            .len()
            .min(MAX_DRIVEN_JOINTS);
        Some(&self.fish.yaw[d][..n])
    }

    /// Gives a fish a motion request: queued behind what plays, or (with `interrupt`) now.
    /// NaN or infinite values are refused naming the field; the motion layer refuses the rest.
    pub fn request(
        &mut self,
        id: FishId,
        r: MotionRequest,
        interrupt: bool,
    ) -> Result<(), WorldError> {
        self.with_controls(id, |w, c| w.request_with(id, c, r, interrupt))
    }

    /// [`World::request`] for a fish whose controls are checked out into `controls`.
    pub fn request_with(
        &self,
        id: FishId,
        controls: &mut FishControls,
        r: MotionRequest,
        interrupt: bool,
    ) -> Result<(), WorldError> {
        self.fish.dense(id).ok_or(WorldError::StaleFish(id))?;
        validate_request(&r)?;
        let player = &mut controls.player;
        if interrupt {
            player.interrupt(r)?;
        } else {
            player.push(r)?;
        }
        Ok(())
    }

    /// Steers towards a heading (radians), a depth below the surface (world units) and a speed
    /// (world units per second; clamped to the species' `max_speed`), choosing the motion:
    /// small heading error → normal turn; large → quick turn when slow, serial turn when fast;
    /// then ascend/descend; then accelerate/stop. A wish already being carried out requests
    /// nothing, so calling this every behaviour tick does not make the fish jitter
    /// (see [`steer::plan_steer`]).
    pub fn steer_to(
        &mut self,
        id: FishId,
        heading: f32,
        depth: f32,
        speed: f32,
    ) -> Result<(), WorldError> {
        self.with_controls(id, |w, c| w.steer_to_with(id, c, heading, depth, speed))
    }

    /// [`World::steer_to`] for a fish whose controls are checked out into `controls`.
    pub fn steer_to_with(
        &self,
        id: FishId,
        controls: &mut FishControls,
        heading: f32,
        depth: f32,
        speed: f32,
    ) -> Result<(), WorldError> {
        let d = self.fish.dense(id).ok_or(WorldError::StaleFish(id))?;
        finite("steer heading", heading)?;
        finite("steer depth", depth)?;
        finite("steer speed", speed)?;
        let species = &self.species[usize::from(self.fish.species[d].0)];
        let params = SteerParams::new(species.desc.motion.s, species.desc.motion.l);
        let margin = CONTACT_MARGIN_LENGTHS * species.desc.motion.l;
        let height = self.tank.extent().y;
        let want = Steer {
            heading: wrap_angle(heading),
            depth: depth.clamp(
                margin.min(height * 0.5),
                (height - margin).max(height * 0.5),
            ),
            speed: speed.clamp(0.0, species.desc.max_speed.max(0.0)),
        };
        let player = &mut controls.player;
        let plan = steer::plan_steer(
            &self.fish.roots[d],
            self.tank.max.y,
            player.current_name(),
            &mut controls.steer,
            want,
            &params,
        );
        if let Some(plan) = plan {
            if plan.interrupt {
                player.interrupt(plan.request)?;
            } else {
                player.push(plan.request)?;
            }
        }
        Ok(())
    }

    /// Runs `f` with the fish's controls checked out (for the `&mut self` conveniences).
    fn with_controls<R>(
        &mut self,
        id: FishId,
        f: impl FnOnce(&Self, &mut FishControls) -> Result<R, WorldError>,
    ) -> Result<R, WorldError> {
        let mut c = FishControls::default();
        if !self.check_out(id, &mut c) {
            return Err(WorldError::StaleFish(id));
        }
        let r = f(self, &mut c);
        self.check_in(id, &mut c);
        r
    }

    // ---- food, obstacles, currents ----------------------------------------------------------

    /// Drops a food pellet at `pos` (clamped into the tank; a non-finite coordinate becomes the
    /// tank's centre on that axis).
    pub fn add_food(&mut self, pos: Vec3) -> FoodId {
        let centre = (self.tank.min + self.tank.max) * 0.5;
        let pos =
            Vec3::select(pos.is_finite_mask(), pos, centre).clamp(self.tank.min, self.tank.max);
        self.foods.push(Food {
            pos,
            eaten: false,
            eaten_by: None,
            eaten_at: None,
        });
        FoodId((self.foods.len() - 1) as u32)
    }

    /// A food pellet.
    pub fn food(&self, id: FoodId) -> Option<&Food> {
        self.foods.get(id.0 as usize)
    }

    /// All food pellets, eaten ones included.
    pub fn foods(&self) -> impl Iterator<Item = (FoodId, &Food)> {
        self.foods
            .iter()
            .enumerate()
            .map(|(i, f)| (FoodId(i as u32), f))
    }

    /// Whether the fish could eat the pellet now: it is not eaten yet and lies within
    /// [`EAT_REACH_LENGTHS`] body lengths of the fish's mouth (its root).
    pub fn can_eat(&self, fish: FishId, food: FoodId) -> bool {
        let Some(d) = self.fish.dense(fish) else {
            return false;
        };
        let reach =
            EAT_REACH_LENGTHS * self.species[usize::from(self.fish.species[d].0)].body_length();
        let mouth = self.fish.roots[d].pos;
        self.foods
            .get(food.0 as usize)
            .is_some_and(|f| !f.eaten && f.pos.distance(mouth) <= reach)
    }

    /// The fish eats the pellet if [`World::can_eat`]. Returns whether it ate.
    pub fn try_eat(&mut self, fish: FishId, food: FoodId) -> bool {
        if !self.can_eat(fish, food) {
            return false;
        }
        let time = self.time;
        let Some(f) = self.foods.get_mut(food.0 as usize) else {
            return false;
        };
        f.eaten = true;
        f.eaten_by = Some(fish);
        f.eaten_at = Some(time);
        true
    }

    /// Adds a spherical obstacle (non-finite or negative values are clamped to the tank centre
    /// and radius 0).
    pub fn add_obstacle(&mut self, pos: Vec3, radius: f32) -> ObstacleId {
        let centre = (self.tank.min + self.tank.max) * 0.5;
        let pos = Vec3::select(pos.is_finite_mask(), pos, centre);
        let radius = if radius.is_finite() {
            radius.max(0.0)
        } else {
            0.0
        };
        self.obstacles.push(Obstacle { pos, radius });
        ObstacleId((self.obstacles.len() - 1) as u32)
    }

    /// All obstacles, by [`ObstacleId`].
    pub fn obstacles(&self) -> &[Obstacle] {
        &self.obstacles
    }

    /// Adds a current zone (ignored if any value is not finite).
    pub fn add_current(&mut self, c: Current) {
        if c.pos.is_finite() && c.velocity.is_finite() && c.radius.is_finite() && c.radius > 0.0 {
            self.currents.push(c);
        } else {
            log::warn!("ignoring current with non-finite or non-positive values: {c:?}");
        }
    }

    /// All current zones.
    pub fn currents(&self) -> &[Current] {
        &self.currents
    }

    // ---- perception -------------------------------------------------------------------------

    /// Calls `visit(dense index, position, distance²)` for every live fish within `radius` of
    /// `pos`, from the grid plus the fish spawned since its last rebuild. Positions and distances
    /// are current ones.
    fn for_each_fish_near(&self, pos: Vec3, radius: f32, mut visit: impl FnMut(usize, Vec3, f32)) {
        let r2 = radius * radius;
        if self.grid_exact && self.grid_positions_current {
            // Nothing moved since the rebuild: the grid's own (cell-ordered) copy of the positions
            // is exact, and reading it avoids a cache miss per candidate on the roots array.
            self.grid.for_each_within(pos, radius, |key, p, d2| {
                visit(key as usize, p, d2);
                true
            });
            return;
        }
        let mut check = |d: usize| {
            let p = self.fish.roots[d].pos;
            let d2 = p.distance_squared(pos);
            if d2 <= r2 {
                visit(d, p, d2);
            }
        };
        if self.grid_exact {
            self.grid.for_each_within(pos, radius, |key, _, _| {
                check(key as usize);
                true
            });
            return;
        }
        self.grid.for_each_within(pos, radius, |key, _, _| {
            if let Some(d) = self.fish.dense(self.grid_ids[key as usize]) {
                check(d);
            }
            true
        });
        for &id in &self.spawned_since_grid {
            if let Some(d) = self.fish.dense(id) {
                check(d);
            }
        }
    }

    /// Fish whose root lies within `radius` of `pos` (inclusive), in grid order. Answered from the
    /// spatial grid as of the last [`World::rebuild_grid`] plus fish spawned since.
    pub fn neighbors(&self, pos: Vec3, radius: f32, out: &mut Vec<FishId>) {
        out.clear();
        if !pos.is_finite() || radius.is_nan() || radius < 0.0 {
            return;
        }
        self.for_each_fish_near(pos, radius, |d, _, _| out.push(self.fish.ids[d]));
    }

    /// Everything the fish sees: fish (predators marked), uneaten food and obstacles within its
    /// species' `view_range` and inside its view cone (`view_angle_deg`, the cone's full opening
    /// around its forward direction), nearest first (ties broken by kind, then id, so the order
    /// is deterministic). Clears `out`; a stale id leaves it empty.
    pub fn vision(&self, id: FishId, out: &mut Vec<Percept>) {
        self.vision_nearest(id, usize::MAX, out);
    }

    /// [`World::vision`] keeping only the `max` nearest percepts (exactly the first `max` of the
    /// full list), for scripts that look at a few things: only those are sorted and built.
    pub fn vision_nearest(&self, id: FishId, max: usize, out: &mut Vec<Percept>) {
        out.clear();
        if let Some(d) = self.fish.dense(id) {
            self.append_vision(d, max, out);
        }
    }

    /// The `max` nearest percepts of each of `ids` (as [`World::vision_nearest`] gives them),
    /// computed in parallel over rayon's threads into `batch`; `batch.get(i)` is `ids[i]`'s.
    /// For a host that runs the decisions due this tick one after another: the sensing, the
    /// expensive part, then uses both cores. Results do not depend on the thread count, and the
    /// batch's buffers are reused, so a warm batch does not allocate.
    pub fn vision_batch(&self, ids: &[FishId], max: usize, batch: &mut VisionBatch) {
        use rayon::prelude::*;
        let num_chunks = ids.len().div_ceil(VisionBatch::CHUNK);
        if batch.chunks.len() < num_chunks {
            batch.chunks.resize_with(num_chunks, Vec::new);
        }
        batch.spans.clear();
        batch.spans.resize(ids.len(), (0, 0, 0));
        ids.par_chunks(VisionBatch::CHUNK)
            .zip(batch.chunks[..num_chunks].par_iter_mut())
            .zip(batch.spans.par_chunks_mut(VisionBatch::CHUNK))
            .enumerate()
            .for_each(|(c, ((ids, buf), spans))| {
                buf.clear();
                for (&id, span) in ids.iter().zip(spans) {
                    let start = buf.len() as u32;
                    if let Some(d) = self.fish.dense(id) {
                        self.append_vision(d, max, buf);
                    }
                    *span = (c as u32, start, buf.len() as u32);
                }
            });
    }

    /// Appends the `max` nearest percepts of dense fish `d` to `out`, nearest first.
    fn append_vision(&self, d: usize, max: usize, out: &mut Vec<Percept>) {
        if max == 0 {
            return;
        }
        SEEN.with_borrow_mut(|seen| {
            seen.clear();
            self.collect_seen(d, seen);
            if seen.len() > max {
                seen.select_nth_unstable_by_key(max - 1, |s| s.key);
                seen.truncate(max);
            }
            seen.sort_unstable_by_key(|s| s.key);
            let me = &self.fish.roots[d];
            out.extend(seen.iter().map(|s| self.percept_of(me, *s)));
        });
    }

    /// Everything in view of dense fish `d`, as sort keys (see [`Seen`]).
    fn collect_seen(&self, d: usize, seen: &mut Vec<Seen>) {
        let view = self.view_of(d);
        self.fish_seen(d, &view, |_, _| true, |s| seen.push(s));
        self.food_seen(&view, |s| seen.push(s));
        self.obstacles_seen(&view, |s| seen.push(s));
    }

    /// How dense fish `d` sees: from where, how far, how wide.
    fn view_of(&self, d: usize) -> View {
        let me = self.fish.roots[d];
        let species = self.fish.species[d];
        let desc = &self.species[usize::from(species.0)].desc;
        let fwd = forward(me.heading, me.pitch);
        View {
            pos: me.pos,
            species,
            range: desc.view_range,
            angle: desc.view_angle_deg,
            fwd,
            cone: ViewCone::new(me.pos, fwd, desc.view_angle_deg),
        }
    }

    /// How a fish of species `viewer` perceives a fish of species `other`.
    fn fish_kind(&self, viewer: SpeciesId, other: SpeciesId) -> PerceptKind {
        if other != viewer && self.species[usize::from(other.0)].desc.predator {
            PerceptKind::Predator
        } else {
            PerceptKind::Fish
        }
    }

    /// Calls `found` with every fish in `view` of dense fish `d` (itself excluded) that `want`
    /// (dense index, kind) accepts; `want` is asked before the view-cone test.
    fn fish_seen(
        &self,
        d: usize,
        view: &View,
        want: impl Fn(usize, PerceptKind) -> bool,
        mut found: impl FnMut(Seen),
    ) {
        self.for_each_fish_near(view.pos, view.range, |o, pos, d2| {
            if o == d {
                return;
            }
            let kind = self.fish_kind(view.species, self.fish.species[o]);
            if !want(o, kind) || !view.cone.contains(pos) {
                return;
            }
            found(Seen::new(d2.sqrt(), kind, self.fish.ids[o].index, o as u32));
        });
    }

    /// Calls `found` with every uneaten food pellet in `view`.
    fn food_seen(&self, view: &View, mut found: impl FnMut(Seen)) {
        let mut see_food = |i: usize, f: &Food| {
            if f.eaten || !view.cone.contains(f.pos) {
                return;
            }
            let dist = f.pos.distance(view.pos);
            if dist <= view.range {
                found(Seen::new(dist, PerceptKind::Food, i as u32, i as u32));
            }
        };
        self.food_grid
            .for_each_within(view.pos, view.range, |key, _, _| {
                see_food(key as usize, &self.foods[key as usize]);
                true
            });
        for (i, f) in self.foods.iter().enumerate().skip(self.food_in_grid) {
            see_food(i, f);
        }
    }

    /// Calls `found` with every obstacle any part of which is in `view`.
    fn obstacles_seen(&self, view: &View, mut found: impl FnMut(Seen)) {
        let (range, angle) = (view.range, view.angle);
        for (i, o) in self.obstacles.iter().enumerate() {
            let to_centre = o.pos.distance(view.pos);
            let distance = to_centre - o.radius;
            if distance > range {
                continue;
            }
            // Seen if any part of the sphere is inside the cone: widen the cone by the sphere's
            // angular radius.
            let visible = if to_centre <= o.radius || angle >= 360.0 {
                true
            } else {
                let half = (angle.max(0.0) * 0.5).to_radians();
                let angular_radius = (o.radius / to_centre).clamp(0.0, 1.0).asin();
                let off_axis = view
                    .fwd
                    .dot((o.pos - view.pos) / to_centre)
                    .clamp(-1.0, 1.0)
                    .acos();
                off_axis <= half + angular_radius
            };
            if visible {
                found(Seen::new(
                    distance,
                    PerceptKind::Obstacle,
                    i as u32,
                    i as u32,
                ));
            }
        }
    }

    /// Builds the percept of `s` as seen from `me`.
    fn percept_of(&self, me: &RootState, s: Seen) -> Percept {
        let (distance, kind) = s.distance_and_kind();
        let i = s.index as usize;
        let mut p = Percept {
            kind,
            fish: None,
            food: None,
            obstacle: None,
            species: None,
            pos: Vec3::ZERO,
            distance,
            bearing: 0.0,
            elevation: 0.0,
            heading: 0.0,
            speed: 0.0,
        };
        match kind {
            PerceptKind::Fish | PerceptKind::Predator => {
                let other = &self.fish.roots[i];
                p.fish = Some(self.fish.ids[i]);
                p.species = Some(self.fish.species[i]);
                p.pos = other.pos;
                p.heading = other.heading;
                p.speed = other.speed;
            }
            PerceptKind::Food => {
                p.food = Some(FoodId(s.index));
                p.pos = self.foods[i].pos;
            }
            PerceptKind::Obstacle => {
                p.obstacle = Some(ObstacleId(s.index));
                p.pos = self.obstacles[i].pos;
            }
        }
        p.bearing = bearing(me.pos, me.heading, p.pos);
        p.elevation = elevation(me.pos, p.pos);
        p
    }

    /// The fish's body sensor: depth, distances to floor, surface and nearest side wall (with
    /// its inward normal), contact in the last motion step, speed, heading and pitch.
    pub fn body_sense(&self, id: FishId) -> Option<BodySense> {
        let d = self.fish.dense(id)?;
        let r = &self.fish.roots[d];
        let (to_floor, to_surface, to_wall, wall_normal) = tank_distances(&self.tank, r.pos);
        Some(BodySense {
            pos: r.pos,
            depth: self.tank.depth_of(r.pos.y),
            to_floor,
            to_surface,
            to_wall,
            wall_normal,
            contact: self.fish.contact[d],
            speed: r.speed,
            heading: r.heading,
            pitch: r.pitch,
        })
    }

    // ---- steering wrappers ------------------------------------------------------------------

    /// The steering helpers' view of a fish (look-ahead one body length).
    pub fn agent(&self, id: FishId) -> Option<Agent> {
        let d = self.fish.dense(id)?;
        let r = &self.fish.roots[d];
        Some(Agent {
            pos: r.pos,
            heading: r.heading,
            pitch: r.pitch,
            speed: r.speed,
            surface_y: self.tank.max.y,
            lookahead: self.species[usize::from(self.fish.species[d].0)].body_length(),
        })
    }

    /// [`steer::seek`] for a fish.
    pub fn steer_seek(&self, id: FishId, target: Vec3, speed: f32) -> Option<Steer> {
        Some(steer::seek(&self.agent(id)?, target, speed))
    }

    /// [`steer::flee`] for a fish.
    pub fn steer_flee(&self, id: FishId, threat: Vec3, speed: f32) -> Option<Steer> {
        Some(steer::flee(&self.agent(id)?, threat, speed))
    }

    /// [`steer::arrive`] for a fish.
    pub fn steer_arrive(
        &self,
        id: FishId,
        target: Vec3,
        slow_radius: f32,
        speed: f32,
    ) -> Option<Steer> {
        Some(steer::arrive(&self.agent(id)?, target, slow_radius, speed))
    }

    /// [`steer::wander`] for a fish, drawing from the fish's own generator.
    pub fn steer_wander(
        &mut self,
        id: FishId,
        max_turn: f32,
        max_depth_change: f32,
        speed: f32,
    ) -> Option<Steer> {
        self.with_controls(id, |w, c| {
            Ok(w.steer_wander_with(id, c, max_turn, max_depth_change, speed))
        })
        .ok()
        .flatten()
    }

    /// [`World::steer_wander`] for a fish whose controls are checked out into `controls`.
    pub fn steer_wander_with(
        &self,
        id: FishId,
        controls: &mut FishControls,
        max_turn: f32,
        max_depth_change: f32,
        speed: f32,
    ) -> Option<Steer> {
        Some(steer::wander(
            &mut controls.rng,
            &self.agent(id)?,
            max_turn,
            max_depth_change,
            speed,
        ))
    }

    /// [`steer::avoid_obstacles`] for a fish against the world's obstacles.
    pub fn steer_avoid_obstacles(
        &self,
        id: FishId,
        lookahead: f32,
        clearance: f32,
        speed: f32,
    ) -> Option<Steer> {
        steer::avoid_obstacles(
            &self.agent(id)?,
            &self.obstacles,
            lookahead,
            clearance,
            speed,
        )
    }

    /// [`steer::avoid_walls`] for a fish against the tank.
    pub fn steer_avoid_walls(&self, id: FishId, margin: f32, speed: f32) -> Option<Steer> {
        steer::avoid_walls(&self.agent(id)?, &self.tank, margin, speed)
    }

    // ---- the Rust stages of a tick ----------------------------------------------------------

    /// Advances every fish by `dt` seconds (ignored unless finite and positive): motion players
    /// (locomotion and the body wave), drift in current zones, then hard contact — each fish's
    /// body (head, middle and tail along its heading) is pushed out of obstacles and back inside
    /// the tank, with `contact` set — so no script can take a fish out of the tank or through a
    /// rock. A motion step that yields a non-finite root is discarded (the fish keeps its last
    /// root and stops). Timed into `motion_ns`.
    pub fn step_motion(&mut self, dt: f32) {
        if !(dt.is_finite() && dt > 0.0) {
            return;
        }
        let start = Instant::now();
        let species = &self.species;
        let wave_tables = &self.wave_tables;
        let tank = self.tank;
        let obstacles = &self.obstacles;
        let currents = &self.currents;
        let fish = &mut self.fish;
        use rayon::prelude::*;
        let rejected: u64 = fish
            .players
            .par_iter_mut()
            .zip(fish.roots.par_iter_mut())
            .zip(fish.lateral.par_iter_mut())
            .zip(fish.yaw.par_iter_mut())
            .zip(fish.contact.par_iter_mut())
            .zip(fish.species.par_iter())
            .with_min_len(256)
            .map(|(((((player, root), lateral), yaw), contact), sid)| {
                let sp = &species[usize::from(sid.0)];
                let body = &sp.rig.body;
                let driven = body.power.len().min(MAX_DRIVEN_JOINTS);
                let samples = body.joints_x.len().min(MAX_DRIVEN_JOINTS + 1);
                let before = *root;
                // The table was built from this species' params and body when it was added or
                // replaced (species change no other way), so it matches without a check.
                let table = &wave_tables[usize::from(sid.0)];
                debug_assert!(table.matches(&sp.desc.motion, body));
                player.step_tabled(
                    dt,
                    &sp.desc.motion,
                    body,
                    table,
                    root,
                    &mut lateral[..samples],
                    &mut yaw[..driven],
                );
                let mut rejected = 0;
                if !(root.pos.is_finite()
                    && root.heading.is_finite()
                    && root.pitch.is_finite()
                    && root.speed.is_finite())
                {
                    *root = RootState {
                        speed: 0.0,
                        ..before
                    };
                    rejected = 1;
                }
                if lateral[..samples]
                    .iter()
                    .chain(&yaw[..driven])
                    .any(|v| !v.is_finite())
                {
                    lateral.fill(0.0);
                    yaw.fill(0.0);
                    rejected = 1;
                }
                root.heading = wrap_angle(root.heading);
                root.pos += drift(currents, root.pos) * dt;
                *contact = resolve_contact(root, sp.desc.motion.l, &tank, obstacles);
                rejected
            })
            .sum();
        if rejected > 0 {
            if self.rejected_motion_steps == 0 {
                log::warn!("{rejected} motion steps produced non-finite values and were discarded");
            }
            self.rejected_motion_steps += rejected;
        }
        self.grid_positions_current = false;
        self.time += f64::from(dt);
        self.tick += 1;
        self.counters.motion_ns = start.elapsed().as_nanos() as u64;
    }

    /// Motion steps discarded because they produced NaN or infinity (a motion-layer bug).
    pub fn rejected_motion_steps(&self) -> u64 {
        self.rejected_motion_steps
    }

    /// Poses every fish: species rig → local transforms → forward kinematics from the fish's
    /// placement (head at its root position, facing its heading and pitch) → skinning palette
    /// (model × inverse bind pose), into [`World::palettes`]. Runs over both cores with rayon;
    /// the result does not depend on the thread count. Timed into `skeleton_ns` and `palette_ns`
    /// (the stage's wall time split in proportion to the threads' time in each half).
    pub fn update_pose(&mut self) {
        let start = Instant::now();
        let total = *self.palette_offsets.last().unwrap_or(&0) as usize;
        if self.palettes.len() != total {
            self.palettes.resize(total, Mat4::IDENTITY);
        }
        let inputs = pose::PoseInputs {
            plans: &self.pose_plans,
            fish_species: &self.fish.species,
            roots: &self.fish.roots,
            yaw: &self.fish.yaw,
            offsets: &self.palette_offsets,
        };
        let timing = pose::PoseTiming::default();
        pose::run(&inputs, 0, self.fish.len(), &mut self.palettes, &timing);
        let wall = start.elapsed().as_nanos() as u64;
        let skel = timing.skeleton_ns.load(Ordering::Relaxed);
        let pal = timing.palette_ns.load(Ordering::Relaxed);
        let share = if skel + pal > 0 {
            skel as f64 / (skel + pal) as f64
        } else {
            0.5
        };
        self.counters.skeleton_ns = (wall as f64 * share) as u64;
        self.counters.palette_ns = wall - self.counters.skeleton_ns;
    }

    /// Rebuilds the spatial grid from the fish's current positions (and the food grid), with
    /// cells of half the longest view range. Timed into `grid_ns`.
    pub fn rebuild_grid(&mut self) {
        let start = Instant::now();
        let extent = self.tank.extent().max_element();
        let view = self
            .species
            .iter()
            .map(|s| s.desc.view_range)
            .filter(|r| r.is_finite() && *r > 0.0)
            .fold(0.0f32, f32::max);
        // Half-range cells: a query visits ~2.5x its sphere's volume (full-range cells visit
        // ~5x, and ~10x for the 300-unit crowd queries when a predator's 500-unit view sets the
        // size). No smaller than 1/64 of the tank, so a tiny view range cannot explode the count.
        let cell = if view > 0.0 {
            (0.5 * view).max(extent / 64.0)
        } else {
            extent / 16.0
        };
        if (cell - self.grid.cell_size()).abs() > 1e-6 * cell {
            self.grid.configure(self.tank.min, self.tank.max, cell);
            self.food_grid.configure(self.tank.min, self.tank.max, cell);
            self.food_in_grid = 0;
        }
        self.grid.rebuild(
            self.fish
                .roots
                .iter()
                .enumerate()
                .map(|(i, r)| (i as u32, r.pos)),
        );
        self.grid_ids.clone_from(&self.fish.ids);
        // What the crowding rules read per neighbour, copied into the grid's cell order so
        // their scans read contiguous memory (see `crowd.rs`); the headings' cosines and sines
        // (over both cores) only if crowd queries were made since the last rebuild.
        let (roots, species) = (&self.fish.roots, &self.fish.species);
        let keys = self.grid.keys();
        self.grid_species.clear();
        self.grid_species
            .extend(keys.iter().map(|&k| species[k as usize]));
        let wanted = self.crowd_wanted.swap(false, Ordering::Relaxed);
        self.grid_heading.clear();
        if wanted {
            use rayon::prelude::*;
            self.grid_heading.resize(keys.len(), glam::Vec2::ZERO);
            self.grid_heading
                .par_iter_mut()
                .zip(keys.par_iter())
                .with_min_len(1024)
                .for_each(|(out, &k)| *out = crowd::heading_vector(roots[k as usize].heading));
        }
        self.grid_exact = true;
        self.grid_positions_current = true;
        self.spawned_since_grid.clear();
        if self.food_in_grid != self.foods.len() {
            self.food_grid.rebuild(
                self.foods
                    .iter()
                    .enumerate()
                    .map(|(i, f)| (i as u32, f.pos)),
            );
            self.food_in_grid = self.foods.len();
        }
        self.counters.grid_ns = start.elapsed().as_nanos() as u64;
    }

    /// World-space skinning palettes of every fish, fish after fish (dense order), joint after
    /// joint; valid after [`World::update_pose`].
    pub fn palettes(&self) -> &[Mat4] {
        &self.palettes
    }

    /// The fish's range in [`World::palettes`].
    pub fn palette_range(&self, id: FishId) -> Option<Range<usize>> {
        let d = self.fish.dense(id)?;
        let range = self.palette_offsets[d] as usize..self.palette_offsets[d + 1] as usize;
        (range.end <= self.palettes.len()).then_some(range)
    }

    /// Palette start of each fish (dense order) plus the total at the end.
    pub fn palette_offsets(&self) -> &[u32] {
        &self.palette_offsets
    }

    /// Timings of the last tick's stages.
    pub fn counters(&self) -> &StageCounters {
        &self.counters
    }

    /// Timings, for the stages timed outside the world (perception, Lua).
    pub fn counters_mut(&mut self) -> &mut StageCounters {
        &mut self.counters
    }
}

/// Something in view before it becomes a [`Percept`]: a sort key that orders nearest first,
/// then by kind, then by id (a total order on distinct things, so vision is deterministic), and
/// where to find the thing (dense fish index, food or obstacle index).
#[derive(Clone, Copy, Debug)]
struct Seen {
    /// distance bits (non-negative floats order like their bits) << 32 | kind << 30 | id.
    key: u64,
    index: u32,
}

impl Seen {
    fn new(distance: f32, kind: PerceptKind, id: u32, index: u32) -> Self {
        // Clamp to +0.0 (never −0.0, whose bits would sort last).
        let distance = if distance > 0.0 { distance } else { 0.0 };
        let kind = kind as u64;
        Self {
            key: (u64::from(distance.to_bits()) << 32) | (kind << 30) | u64::from(id & 0x3FFF_FFFF),
            index,
        }
    }

    fn distance_and_kind(&self) -> (f32, PerceptKind) {
        let distance = f32::from_bits((self.key >> 32) as u32);
        let kind = match (self.key >> 30) & 3 {
            0 => PerceptKind::Fish,
            1 => PerceptKind::Food,
            2 => PerceptKind::Obstacle,
            _ => PerceptKind::Predator,
        };
        (distance, kind)
    }
}

/// How a fish sees (see [`World::vision`]): its root position, species, view range and cone.
#[derive(Clone, Copy, Debug)]
struct View {
    pos: Vec3,
    species: SpeciesId,
    range: f32,
    angle: f32,
    fwd: Vec3,
    cone: ViewCone,
}

thread_local! {
    /// Vision's scratch list, per thread so `vision` can take `&self` and never allocate once
    /// warm.
    static SEEN: std::cell::RefCell<Vec<Seen>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Sum of the drift velocities of the current zones at `p`, world units per second. Each zone
/// drifts at full strength inside 80 % of its radius, fading linearly to 0 at the radius.
pub fn drift(currents: &[Current], p: Vec3) -> Vec3 {
    currents
        .iter()
        .map(|c| {
            let d = c.pos.distance(p);
            let w = ((c.radius - d) / (0.2 * c.radius)).clamp(0.0, 1.0);
            c.velocity * w
        })
        .sum()
}

/// Whether a fish of body length `l` with its root at `pos` is so far inside `tank` and from
/// every obstacle that, whatever its heading and pitch, [`resolve_contact`] would find no contact
/// (most fish, most ticks): then placing its body samples (two `sin_cos`) is skipped. Each
/// sample lies within `l` of the root (|forward| = 1 up to rounding); the test keeps 1 % of `l`
/// plus 1e-5 of the coordinates' size on top, far more than the samples' rounding. `false`
/// whenever unsure (NaN included).
fn clear_of_contact(pos: Vec3, l: f32, margin: f32, tank: &Tank, obstacles: &[Obstacle]) -> bool {
    if !(l >= 0.0 && margin >= 0.0) {
        return false;
    }
    let size = pos.abs().max_element() + tank.min.abs().max(tank.max.abs()).max_element();
    let body = 1.01 * l + 1e-5 * size;
    let inside = (pos - (tank.min + Vec3::splat(margin + body))).min_element() > 0.0
        && ((tank.max - Vec3::splat(margin + body)) - pos).min_element() > 0.0;
    inside
        && obstacles.iter().all(|o| {
            let clearance = o.radius + margin + body + 1e-5 * o.pos.abs().max_element();
            // A NaN compares false: not clear.
            pos.distance_squared(o.pos) > clearance * clearance
        })
}

/// Pushes a fish of body length `l` (root at the head, body straight behind it along its
/// heading and pitch) out of `obstacles` and back inside `tank`, keeping
/// [`CONTACT_MARGIN_LENGTHS`]·`l` of clearance. Returns whether it had to. The tank wins over
/// obstacles; a fish longer than the tank keeps at least its head inside.
pub fn resolve_contact(root: &mut RootState, l: f32, tank: &Tank, obstacles: &[Obstacle]) -> bool {
    let margin = CONTACT_MARGIN_LENGTHS * l;
    if clear_of_contact(root.pos, l, margin, tank, obstacles) {
        return false;
    }
    let back = -forward(root.heading, root.pitch) * l;
    let samples = [0.0f32, 0.5, 1.0];
    let mut touched = false;

    for o in obstacles {
        let reach = o.radius + margin;
        // Push the whole body out by the deepest penetration among its samples (twice, so a
        // push out of one sample's way that lands another inside is also resolved).
        for _ in 0..2 {
            let mut push = Vec3::ZERO;
            let mut deepest = 0.0f32;
            for &t in &samples {
                let p = root.pos + back * t;
                let off = p - o.pos;
                let dist = off.length();
                let depth = reach - dist;
                if depth > deepest {
                    deepest = depth;
                    push = off.try_normalize().unwrap_or(Vec3::Y) * depth;
                }
            }
            if deepest <= 0.0 {
                break;
            }
            root.pos += push;
            touched = true;
        }
    }

    let lo = tank.min + Vec3::splat(margin);
    let hi = tank.max - Vec3::splat(margin);
    let (mut low, mut high) = (Vec3::splat(f32::INFINITY), Vec3::splat(f32::NEG_INFINITY));
    for &t in &samples {
        let p = root.pos + back * t;
        low = low.min(p);
        high = high.max(p);
    }
    let mut shift = Vec3::ZERO;
    for axis in 0..3 {
        if low[axis] < lo[axis] {
            shift[axis] = lo[axis] - low[axis];
        } else if high[axis] > hi[axis] {
            shift[axis] = hi[axis] - high[axis];
        }
    }
    if shift != Vec3::ZERO {
        root.pos += shift;
        touched = true;
    }
    // Whatever the geometry, the root ends inside the tank.
    let clamped = root.pos.clamp(tank.min, tank.max);
    if clamped != root.pos {
        root.pos = clamped;
        touched = true;
    }
    touched
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_cells_are_half_the_longest_view_range() {
        let scene = super::test_world::random_scene(1, 50);
        let longest = (0..scene.world.num_species())
            .map(|s| scene.world.species(SpeciesId(s as u16)).desc.view_range)
            .fold(0.0f32, f32::max);
        assert_eq!(scene.world.grid.cell_size(), 0.5 * longest);
        assert_eq!(scene.world.food_grid.cell_size(), 0.5 * longest);
    }

    #[test]
    fn seen_keys_round_trip_and_order_nearest_then_kind_then_id() {
        let kinds = [
            PerceptKind::Fish,
            PerceptKind::Food,
            PerceptKind::Obstacle,
            PerceptKind::Predator,
        ];
        for (k, kind) in kinds.into_iter().enumerate() {
            let s = Seen::new(12.5, kind, 7, 3);
            assert_eq!(s.distance_and_kind(), (12.5, kind));
            assert_eq!(s.key & 0x3FFF_FFFF, 7);
            assert_eq!((s.key >> 30) & 3, k as u64);
        }
        let near = Seen::new(1.0, PerceptKind::Predator, 9, 0).key;
        let far = Seen::new(1.5, PerceptKind::Fish, 0, 0).key;
        assert!(near < far);
        assert!(Seen::new(1.0, PerceptKind::Fish, 9, 0).key < near);
        assert!(Seen::new(1.0, PerceptKind::Predator, 8, 0).key < near);
        // Inside an obstacle: distance 0, never −0 (which would sort last).
        assert_eq!(
            Seen::new(-0.0, PerceptKind::Obstacle, 0, 0)
                .distance_and_kind()
                .0
                .to_bits(),
            0
        );
        assert!(Seen::new(-3.0, PerceptKind::Obstacle, 0, 0).key < far);
    }
}
