//! Where a tick happens: [`step`], the one function that writes the stage sequence.
//!
//! ```text
//! step(world, behavior)
//!   1. scene events   World::scene_events     periodic food drops
//!   2. behaviour      Behavior::decide        the fish due this tick decide (Lua or Rust);
//!                                             perception_ns, lua_ns
//!   3. motion         World::step_motion      motion players, currents, contact, then the
//!                                             pellets (sinking, drifting, dissolving); motion_ns
//!                                             (PoseMode::Gpu: the roots only; the body's
//!                                             shape is the pose pass's)
//!   4. pose           World::update_pose      skeletons and skinning palettes;
//!                                             skeleton_ns, palette_ns (PoseMode::Gpu:
//!                                             records for the renderer's pose pass)
//!   5. grid           World::rebuild_grid     the spatial grids the next tick senses; grid_ns
//! ```
//!
//! Stages 3 to 5 run as one call, [`World::advance`]: the same results as the three methods one
//! after another (`world_gpu_shape::advance_is_motion_then_pose_then_grid_in_either_pose_mode`),
//! with what the pose and grid stages would read of each fish again (its GPU pose record and
//! anchor, its heading's cosine and sine) written by the motion pass while it has the fish at
//! hand.
//!
//! Each Rust stage is a one-line method of [`World`] that hands its parts to the stage
//! explicitly: motion takes the state and the species catalogue (`stages::move_fish`), pose
//! writes the pose buffers from the state and the catalogue (`PoseBuffers::update`), grid
//! rebuilds the spatial index from the state (`SpatialIndex::rebuild`). So what each stage
//! reads and writes is in its signature.
//!
//! The behaviour layer is the only part that differs between simulations: the Lua scripts
//! (`script::Simulation`'s script lanes) and the built-in Rust driver
//! ([`super::driver::WanderDriver`]) are two implementations of [`Behavior`]. [`Pipeline`] pairs a
//! world with one.

use std::sync::Arc;

use super::{TICK_HZ, World};

/// One tick's length, seconds (1 / [`TICK_HZ`]).
pub const TICK_DT: f32 = (1.0 / TICK_HZ) as f32;

/// The behaviour layer of a simulation: what the fish due this tick decide.
pub trait Behavior {
    /// Runs the decisions due this tick (stage 2 of [`step`]) and fills the world's
    /// `perception_ns`, `lua_ns`, `decisions`, `decide_cpu_ns` and `sense_cpu_ns` counters.
    ///
    /// The world comes in an [`Arc`] so decisions can share it read-only across threads; it is
    /// not shared when this is called, and must not be when it returns (take it mutably with
    /// [`Arc::get_mut`] for what changes it, e.g. checking fish controls out and in).
    fn decide(&mut self, world: &mut Arc<World>);
}

/// The world, exclusively: it is shared only inside [`Behavior::decide`].
pub fn exclusive(world: &mut Arc<World>) -> &mut World {
    Arc::get_mut(world).expect("the world is shared only during the behaviour stage")
}

/// One fixed tick of [`TICK_DT`] seconds: scene events, behaviour, motion, pose, grid (see the
/// module docs). Every simulation ticks through here.
pub fn step(world: &mut Arc<World>, behavior: &mut (impl Behavior + ?Sized)) {
    exclusive(world).scene_events();
    behavior.decide(world);
    // Stages 3 to 5: motion, pose, grid (`World::advance`: in fewer passes over the fish).
    exclusive(world).advance(TICK_DT);
}

/// A world and the behaviour that decides for its fish, ticked by [`step`].
pub struct Pipeline<B> {
    world: Arc<World>,
    /// The behaviour layer.
    pub behavior: B,
}

impl<B: Behavior> Pipeline<B> {
    /// Pairs `world` with `behavior`.
    pub fn new(world: World, behavior: B) -> Self {
        Self {
            world: Arc::new(world),
            behavior,
        }
    }

    /// Runs one tick.
    pub fn tick(&mut self) {
        step(&mut self.world, &mut self.behavior);
    }

    /// The behaviour stage alone (stage 2 of [`step`]), without advancing time: for benchmarks
    /// of the decisions.
    pub fn decide(&mut self) {
        self.behavior.decide(&mut self.world);
    }

    /// The world.
    pub fn world(&self) -> &World {
        &self.world
    }

    /// The world, mutably (spawning, food, motion requests, species edits).
    pub fn world_mut(&mut self) -> &mut World {
        exclusive(&mut self.world)
    }

    /// The world and the behaviour, both mutably (for a behaviour's own edits of the world).
    pub fn parts_mut(&mut self) -> (&mut World, &mut B) {
        (exclusive(&mut self.world), &mut self.behavior)
    }

    /// The world as the behaviour stage shares it.
    pub fn shared_world(&self) -> &Arc<World> {
        &self.world
    }

    /// The world, taken out of the simulation.
    pub fn into_world(self) -> World {
        Arc::try_unwrap(self.world)
            .unwrap_or_else(|_| unreachable!("the world is shared only during the behaviour stage"))
    }

    /// Replaces the world (a new tank or scene), keeping the behaviour.
    pub fn set_world(&mut self, world: World) {
        self.world = Arc::new(world);
    }
}
