//! [`SimView`]: what the window sees of a simulation, and its two implementations — the Lua
//! behaviour host ([`crate::script::Simulation`]) and the built-in Rust wander driver
//! ([`crate::world::bench::RustSim`]).
//!
//! The impls are kept together and short on purpose: they are the only lines of the app that
//! name the simulation types, so a change of the world's tick API is adapted here.

use crate::motion::MotionError;
use crate::script::{ScriptError, Simulation};
use crate::world::bench::RustSim;
use crate::world::{FishId, World, WorldError};

/// Why the window could not do what the designer asked of the simulation.
#[derive(Debug, thiserror::Error)]
pub enum SimError {
    /// The fish is gone (despawned, or the scene restarted).
    #[error("fish #{} is no longer in the tank", .0.index)]
    NoFish(FishId),
    /// No species with this index.
    #[error("no species {0}")]
    NoSpecies(usize),
    /// Motion parameters out of range (the error names the field).
    #[error(transparent)]
    Motion(#[from] MotionError),
    /// The world refused the change.
    #[error(transparent)]
    World(#[from] WorldError),
    /// The script layer failed (watching files, reloading the scene).
    #[error(transparent)]
    Script(#[from] ScriptError),
    /// The simulation was not loaded from a scene file, so there is nothing to restart from.
    #[error("this simulation has no scene file to restart from")]
    NoSceneFile,
}

/// A simulation the window and `shoal render` can show: one fixed 60 Hz tick at a time over a
/// [`World`], plus the designer-facing extras (inspector, log, hot reload) where it has them.
///
/// Fish are addressed by [`FishId`] (generational: a despawned fish's handle stays invalid).
pub trait SimView {
    /// Runs one tick (1 / [`crate::world::TICK_HZ`] s): behaviour, motion, pose, grid.
    fn tick(&mut self);
    /// The world.
    fn world(&self) -> &World;
    /// The world, mutably (motion requests, species edits).
    fn world_mut(&mut self) -> &mut World;
    /// Inspector lines for a fish: species and motion, plus behaviour, intention and percepts
    /// where the simulation knows them.
    fn inspect(&self, id: FishId) -> Vec<(String, String)> {
        let w = self.world();
        let mut out = Vec::new();
        if let Some(s) = w.species_of(id) {
            out.push(("species".into(), w.species(s).desc.name.clone()));
        }
        out.push((
            "motion".into(),
            w.current_motion(id).unwrap_or("idle").to_owned(),
        ));
        out
    }
    /// Log lines (script errors, prints) since the last call.
    fn drain_log(&mut self) -> Vec<String> {
        Vec::new()
    }
    /// Starts watching script files for edits (see [`SimView::poll_reload`]).
    fn watch(&mut self) -> Result<(), SimError> {
        Ok(())
    }
    /// Applies edited scripts; one console line per reload event.
    fn poll_reload(&mut self) -> Vec<String> {
        Vec::new()
    }
    /// True when the scene file was edited since it was loaded.
    fn scene_changed(&self) -> bool {
        false
    }
    /// Reloads the scene file and starts it again.
    fn restart_scene(&mut self) -> Result<(), SimError> {
        Err(SimError::NoSceneFile)
    }
}

impl<S: SimView + ?Sized> SimView for Box<S> {
    fn tick(&mut self) {
        (**self).tick();
    }
    fn world(&self) -> &World {
        (**self).world()
    }
    fn world_mut(&mut self) -> &mut World {
        (**self).world_mut()
    }
    fn inspect(&self, id: FishId) -> Vec<(String, String)> {
        (**self).inspect(id)
    }
    fn drain_log(&mut self) -> Vec<String> {
        (**self).drain_log()
    }
    fn watch(&mut self) -> Result<(), SimError> {
        (**self).watch()
    }
    fn poll_reload(&mut self) -> Vec<String> {
        (**self).poll_reload()
    }
    fn scene_changed(&self) -> bool {
        (**self).scene_changed()
    }
    fn restart_scene(&mut self) -> Result<(), SimError> {
        (**self).restart_scene()
    }
}

impl SimView for Simulation {
    fn tick(&mut self) {
        self.step();
    }
    fn world(&self) -> &World {
        Simulation::world(self)
    }
    fn world_mut(&mut self) -> &mut World {
        Simulation::world_mut(self)
    }
    fn inspect(&self, id: FishId) -> Vec<(String, String)> {
        Simulation::inspect(self, id)
    }
    fn drain_log(&mut self) -> Vec<String> {
        Simulation::drain_log(self)
            .into_iter()
            .map(|e| e.to_string())
            .collect()
    }
    fn watch(&mut self) -> Result<(), SimError> {
        Ok(Simulation::watch(self)?)
    }
    fn poll_reload(&mut self) -> Vec<String> {
        Simulation::poll_reload(self)
            .into_iter()
            .map(|e| e.to_string())
            .collect()
    }
    fn scene_changed(&self) -> bool {
        Simulation::scene_changed(self)
    }
    fn restart_scene(&mut self) -> Result<(), SimError> {
        Ok(Simulation::restart_scene(self)?)
    }
}

impl SimView for RustSim {
    fn tick(&mut self) {
        RustSim::tick(self);
    }
    fn world(&self) -> &World {
        RustSim::world(self)
    }
    fn world_mut(&mut self) -> &mut World {
        RustSim::world_mut(self)
    }
}
