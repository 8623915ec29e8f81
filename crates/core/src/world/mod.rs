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
//! plain state), `registry.rs` (species: the catalogue), `index.rs` (the spatial index),
//! `pose/buffers.rs` (the pose stage's output), `population.rs` (spawning fish, food, rocks,
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
pub mod footprint;
pub mod grid;
mod index;
pub mod lod;
pub mod measures;
mod nearest;
mod perception;
mod population;
pub mod pose;
mod registry;
pub mod sense;
mod shape;
mod stages;
mod state;
pub mod steer;
mod store;
#[cfg(test)]
mod test_world;
pub mod tick;
mod types;

use index::SpatialIndex;
use pose::buffers::PoseBuffers;

pub use crate::skin::FishModel;
pub use crate::species::{SpeciesDesc, SpeciesRig};
pub use contact::{drift, resolve_contact};
pub use crowd::{CROWD_DENSE, CROWD_NEAREST, CROWD_SAMPLE, Crowd};
pub use fish::{FishControls, FishRef};
pub use food::FoodPhysics;
pub use lod::{Lod, LodBand, LodCounts, LodError, MIN_PHASE_BLOCKS, WokenBy, phase_block};
pub use registry::Species;
pub use state::{EATEN_HISTORY, FoodDrops, WorldState, random_point};
pub use tick::{Behavior, Pipeline, TICK_DT, step};
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

/// An aquarium, in four separate values the stages take explicitly (as Rapier's pipeline takes
/// its body, collider and broad-phase sets):
///
/// - the [`WorldState`]: everything that defines it at a tick, plain data;
/// - the species catalogue (`registry.rs`): its configuration, with what is prepared per
///   species for the stages (pose plans, wave tables);
/// - the spatial index (`index.rs`): grids, crowding columns and predator spots, which the grid
///   stage derives from the state and the sensors read;
/// - the pose buffers (`pose/buffers.rs`): the palettes or GPU records the pose stage writes.
///
/// The state changes only through this type's methods and the stages of a tick
/// ([`tick::step`]); what is derived is rebuilt by the stages, or by [`World::restore`].
pub struct World {
    /// Everything that defines the world at a tick (see [`WorldState`]).
    state: WorldState,
    /// The species and what is prepared per species for the stages.
    catalog: registry::Catalog,
    /// What the grid stage derives from the state for the next tick's sensing.
    index: SpatialIndex,
    /// What the pose stage writes: skinning palettes or the GPU pass's records.
    pose: PoseBuffers,
    counters: StageCounters,
    rejected_motion_steps: u64,
    /// The behaviour level-of-detail settings (`lod.rs`).
    lod: Lod,
    /// How the last schedule fell.
    lod_counts: LodCounts,
    /// The last schedule's per-fish marks (a buffer kept between ticks).
    lod_marks: Vec<u8>,
    /// The last schedule's per-fish sightings (what of predators and pellets is in view; see
    /// `lod::Sight`; a buffer).
    lod_alert: Vec<std::sync::atomic::AtomicU32>,
    /// The last schedule's band of each fish (a buffer).
    lod_bands: Vec<u8>,
    /// One capped band's candidates, (distance and slot key, dense index) (a buffer).
    lod_near: Vec<(u64, u32)>,
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
        Self {
            state,
            catalog: registry::Catalog::default(),
            index: SpatialIndex::new(&tank),
            pose: PoseBuffers::default(),
            counters: StageCounters::default(),
            rejected_motion_steps: 0,
            lod: Lod::default(),
            lod_counts: LodCounts::default(),
            lod_marks: Vec::new(),
            lod_alert: Vec::new(),
            lod_bands: Vec::new(),
            lod_near: Vec::new(),
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
