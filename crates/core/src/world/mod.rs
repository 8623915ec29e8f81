//! The world: every fish, the tank, food, obstacles and currents, and the Rust stages of a tick.
//!
//! It answers the perception layer's sensors (paper section 3.1: the vision sensor and the body
//! sensor) from a uniform spatial grid ([`grid`]), hands each fish to the behaviour layer as one
//! agent view ([`World::fish`], with the steering helpers of [`steer`]), turns a desired
//! heading/depth/speed into motion requests ([`World::steer_to`]), and runs the layers below the
//! scripts: motion ([`World::step_motion`]), skeleton and skinning palettes
//! ([`World::update_pose`]).
//!
//! **Where a tick happens:** [`tick::step`], the one place the stage sequence is written —
//! scene events → behaviour ([`Behavior`]: the Lua scripts or the built-in Rust driver) → motion
//! → pose → grid, each stage timed into [`StageCounters`], Rapier-style.
//!
//! **What a world is at a tick:** [`WorldState`], plain data that can be cloned, compared and
//! restored ([`World::snapshot`], [`World::restore`]); everything else in [`World`] (species,
//! grids, palettes) is configuration or derived from it.
//!
//! The files follow the world's sections: `types.rs` (value types and errors), `state.rs` (the
//! plain state), `registry.rs` (species), `population.rs` (spawning fish, food, rocks,
//! currents), `fish.rs` (the agent view and motion requests), `perception.rs` (vision and body
//! sense), `stages.rs` (the Rust stages), `contact.rs` (currents and hard contact), `tick.rs`
//! (the pipeline).
//!
//! Fish live in a structure of arrays (`store.rs`) addressed by generational [`FishId`] handles.
//!
//! Conventions (from `crates/core/src/motion/mod.rs`): +y up; heading radians counter-clockwise seen from
//! above, 0 = +x, a left turn increases it; forward = (cos h·cos p, sin p, −sin h·cos p); lengths
//! in world units, a species' body length being `SpeciesDesc.motion.l`; a fish's `pos` is its
//! root, the head end of the vertebral column.

pub mod bench;
mod contact;
mod crowd;
pub mod driver;
mod fish;
mod food;
pub mod grid;
pub mod measures;
mod nearest;
mod perception;
mod population;
pub mod pose;
mod registry;
pub mod sense;
mod stages;
mod state;
pub mod steer;
mod store;
#[cfg(test)]
mod test_world;
pub mod tick;
mod types;

use std::sync::atomic::AtomicBool;

use glam::Mat4;

use crate::motion::WaveTable;
use grid::Grid;

pub use crate::skin::FishModel;
pub use crate::species::{SpeciesDesc, SpeciesRig};
pub use contact::{drift, resolve_contact};
pub use crowd::Crowd;
pub use fish::{FishControls, FishRef};
pub use food::FoodPhysics;
pub use registry::Species;
pub use state::{EATEN_HISTORY, FoodDrops, WorldState, random_point};
pub use tick::{Behavior, Sim, TICK_DT, step};
pub use types::{
    BodySense, Current, Food, Obstacle, Percept, PerceptKind, SpawnParams, StageCounters, Tank,
    VisionBatch, WorldError,
};

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

/// A food pellet's handle: pellets are numbered in the order they are dropped, and a number is
/// never given twice (an eaten pellet leaves the world; see [`World::food`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct FoodId(pub u32);

/// Index of an obstacle.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct ObstacleId(pub u32);

/// Where a world's pose stage (stage 4 of [`tick::step`]) poses its fish.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum PoseMode {
    /// Every fish's skinning palette on the CPU, into [`World::palettes`] (tests, CPU skinning,
    /// headless tools; the default).
    #[default]
    Cpu,
    /// Only what the renderer's GPU pose pass needs: one small record per fish
    /// ([`World::gpu_pose_records`]) and the palette entry it culls with
    /// ([`World::pose_anchors`]); the GPU samples the bodies' shapes and writes the palettes
    /// (see [`pose::gpu`]). The motion stage then moves the roots only: the fish's stored
    /// joint arrays go stale, and [`World::lateral`], [`World::yaw`] and
    /// [`World::joint_palette`] derive them from the motion players instead (the same values);
    /// a CPU pose stage refreshes them first. Falls back to [`PoseMode::Cpu`] while a species
    /// is too big for the pass ([`World::gpu_pose_programs`] says why).
    Gpu,
}

/// Index of a species in the world.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct SpeciesId(pub u16);

/// An aquarium: its [`WorldState`] (everything that defines it at a tick, plain data), its
/// species, and what the stages derive from the state (the spatial grids, the skinning palettes,
/// the stage timings).
///
/// The state changes only through this type's methods and the stages of a tick
/// ([`tick::step`]); what is derived is rebuilt by the stages, or by [`World::restore`].
pub struct World {
    /// Everything that defines the world at a tick (see [`WorldState`]).
    state: WorldState,
    species: Vec<Species>,
    /// Per species: its skeleton prepared for the pose stage.
    pose_plans: Vec<pose::PosePlan>,
    /// Per species: its body wave's constants for the motion stage.
    wave_tables: Vec<WaveTable>,
    /// Live fish of species whose description marks them predators (see `nearest.rs`).
    predators: Vec<FishId>,
    /// The predator fish as of the last grid rebuild, packed for the scan in `nearest.rs`
    /// (position, species, id, dense index side by side: one cache line per few predators
    /// instead of four scattered reads each). Valid while the grid is exact and current.
    predator_spots: Vec<nearest::PredatorSpot>,

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
    /// Per grid slot: what the crowding rules read of each candidate (position, heading cosine
    /// and sine, species, dense index), one column per field; filled only while crowd queries
    /// are being made (`crowd_wanted`), else empty.
    crowd_columns: crowd::CrowdColumns,
    /// A crowd query ran since the last rebuild: the next rebuild fills `crowd_columns`. Worlds
    /// whose behaviours never ask do not pay for the cosines.
    crowd_wanted: AtomicBool,
    food_grid: Grid,
    /// Live pellets `0..food_in_grid` (positions in `state.foods`) are in `food_grid`; later
    /// ones are searched linearly. Eating a pellet empties the grid until the next rebuild.
    food_in_grid: usize,

    /// `palette_offsets[i]..palette_offsets[i + 1]` is dense fish i's palette range (its
    /// species' slots, see `pose.rs`).
    palette_offsets: Vec<u32>,
    palettes: Vec<Mat4>,
    /// Where the pose stage poses (see [`PoseMode`]).
    pose_mode: PoseMode,
    /// The species' pose programs for the GPU pass, rebuilt with `pose_plans`; an error names
    /// a species whose skeleton is too big for it (the stage then poses on the CPU).
    gpu_programs: Result<crate::skin::pose_program::GpuPosePrograms, String>,
    /// After a GPU-mode pose stage, per dense fish: its record for the pose pass.
    gpu_fish: Vec<crate::skin::pose_program::GpuFishPose>,
    /// After a GPU-mode pose stage, per dense fish: its palette's slot 0 (culling).
    pose_anchors: Vec<Mat4>,
    /// The fish's stored body shapes (`yaw`, `lateral`, the players' head recoil) are the
    /// players' current ones. False after a motion stage that left the shape to the GPU pass
    /// ([`PoseMode::Gpu`]) and after a restore: readers then derive it from the players, and
    /// the CPU pose stage refreshes it first.
    shapes_current: bool,
    counters: StageCounters,
    rejected_motion_steps: u64,
}

impl World {
    /// An empty world in `tank`; `seed` is the world's own seed (scenes derive fish seeds from
    /// its scene generator, [`World::scene_rng`]).
    pub fn new(tank: Tank, seed: u64) -> Self {
        Self::from_state(WorldState::new(tank, seed))
    }

    /// A world around `state`, with no species yet and nothing derived.
    fn from_state(state: WorldState) -> Self {
        let tank = state.tank;
        let grid = Grid::new(tank.min, tank.max, tank.extent().max_element() / 16.0);
        let food_grid = grid.clone();
        Self {
            state,
            species: Vec::new(),
            pose_plans: Vec::new(),
            wave_tables: Vec::new(),
            predators: Vec::new(),
            predator_spots: Vec::new(),
            grid,
            grid_ids: Vec::new(),
            grid_exact: true,
            grid_positions_current: true,
            spawned_since_grid: Vec::new(),
            grid_species: Vec::new(),
            crowd_columns: crowd::CrowdColumns::default(),
            crowd_wanted: AtomicBool::new(false),
            food_grid,
            food_in_grid: 0,
            palette_offsets: vec![0],
            palettes: Vec::new(),
            pose_mode: PoseMode::Cpu,
            gpu_programs: Ok(crate::skin::pose_program::GpuPosePrograms::default()),
            gpu_fish: Vec::new(),
            pose_anchors: Vec::new(),
            shapes_current: true,
            counters: StageCounters::default(),
            rejected_motion_steps: 0,
        }
    }

    /// The tank.
    pub fn tank(&self) -> &Tank {
        &self.state.tank
    }

    /// The seed the world was created with.
    pub fn seed(&self) -> u64 {
        self.state.seed
    }

    /// Simulated time, seconds (advanced by [`World::step_motion`]).
    pub fn time(&self) -> f64 {
        self.state.time
    }

    /// Number of motion steps taken.
    pub fn tick_count(&self) -> u64 {
        self.state.tick
    }

    /// Everything that defines the world at this tick, as plain data.
    pub fn state(&self) -> &WorldState {
        &self.state
    }
}
