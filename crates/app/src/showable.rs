//! [`Showable`]: what the window sees of a simulation, and its two implementations — the Lua
//! behaviour host ([`shoal_script::Simulation`]) and the built-in Rust wander driver
//! ([`shoal_core::world::driver::WanderPipeline`]).
//!
//! The impls are kept together and short on purpose: they are the only lines of the app that
//! name the simulation types, so a change of the world's tick API is adapted here.

use shoal_core::motion::MotionError;
use shoal_core::world::driver::WanderPipeline;
use shoal_core::world::{FishId, World, WorldError, WorldState};
use shoal_script::log::LogLevel;
use shoal_script::logpoints::SetLogpointsError;
use shoal_script::scene::SceneDesc;
use shoal_script::{EvalError, ScriptError, SimSnapshot, Simulation};

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
    /// This simulation cannot be kept and put back (the window has no history for it).
    #[error("this simulation cannot be rewound")]
    NoSnapshots,
    /// A state taken from another kind of simulation.
    #[error("this state was taken from another kind of simulation")]
    WrongSnapshot,
    /// The simulation runs no scripts (the built-in Rust driver), so there is no Lua to
    /// evaluate and no file to put logpoints in.
    #[error("this simulation runs no scripts")]
    NoScripts,
    /// Lua evaluated in a fish's context (the console, a watch, "pause when") gave no value.
    #[error(transparent)]
    Eval(#[from] EvalError),
    /// A file's logpoints were not set.
    #[error(transparent)]
    Logpoints(#[from] SetLogpointsError),
    /// A scene edit the window cannot make.
    #[error("scene edit: {0}")]
    SceneEdit(String),
}

/// A simulation at one tick, kept by the window's history ring and put back by
/// [`Showable::restore`]: opaque to the app, one variant per simulation kind.
#[derive(Debug)]
pub enum SimState {
    /// The Lua host's world and script lanes' fish tables.
    Script(Box<SimSnapshot>),
    /// The Rust driver's world.
    Rust(Box<WorldState>),
}

impl SimState {
    /// Simulated time of the state, seconds.
    pub fn time_s(&self) -> f64 {
        match self {
            Self::Script(s) => s.time(),
            Self::Rust(w) => w.time,
        }
    }

    /// Motion steps taken when the state was kept.
    pub fn tick(&self) -> u64 {
        match self {
            Self::Script(s) => s.world().tick,
            Self::Rust(w) => w.tick,
        }
    }

    /// Bytes it holds (see [`WorldState::approx_bytes`]).
    pub fn approx_bytes(&self) -> usize {
        match self {
            Self::Script(s) => s.approx_bytes(),
            Self::Rust(w) => w.approx_bytes(),
        }
    }
}

/// One console line from a simulation.
#[derive(Debug, Clone, PartialEq)]
pub struct LogLine {
    /// The text shown.
    pub text: String,
    /// For a script error: the simulated time it happened, seconds (the timeline's "jump to
    /// last error" goes there).
    pub error_at_s: Option<f64>,
}

impl LogLine {
    /// A line that is not a script error.
    pub fn note(text: impl Into<String>) -> Self {
        Self {
            text: text.into(),
            error_at_s: None,
        }
    }
}

/// A simulation the window and `shoal render` can show: one fixed 60 Hz tick at a time over a
/// [`World`], plus the designer-facing extras (inspector, log, hot reload) where it has them.
///
/// Fish are addressed by [`FishId`] (generational: a despawned fish's handle stays invalid).
pub trait Showable {
    /// Runs one tick (1 / [`shoal_core::world::TICK_HZ`] s): behaviour, motion, pose, grid.
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
    fn drain_log(&mut self) -> Vec<LogLine> {
        Vec::new()
    }
    /// The simulation as it is now, to put back later with [`Showable::restore`]. Fails when
    /// the state cannot be kept (a fish table holds a function: the error names the fish and
    /// the field), or for a simulation that cannot be rewound.
    fn snapshot(&self) -> Result<SimState, SimError> {
        Err(SimError::NoSnapshots)
    }
    /// Puts back a state taken by [`Showable::snapshot`] of this simulation; it then runs the
    /// same future as it did from there (with edited scripts, the new scripts' future).
    fn restore(&mut self, state: &SimState) -> Result<(), SimError> {
        let _ = state;
        Err(SimError::NoSnapshots)
    }
    /// Starts watching script files for edits (see [`Showable::poll_reload`]).
    fn watch(&mut self) -> Result<(), SimError> {
        Ok(())
    }
    /// The file species `species` was read from, where the panel saves tuned values (`None`:
    /// built in Rust).
    fn species_file(&self, species: usize) -> Option<std::path::PathBuf> {
        let _ = species;
        None
    }
    /// The scene running, with the window's live edits (`None`: not built from a scene file).
    fn scene_desc(&self) -> Option<&SceneDesc> {
        None
    }
    /// The scene file, where the panel saves scene edits.
    fn scene_file(&self) -> Option<std::path::PathBuf> {
        None
    }
    /// Makes `desc` the running scene (see [`Simulation::apply_scene_edit`]).
    fn apply_scene_edit(&mut self, desc: SceneDesc) -> Result<(), SimError> {
        let _ = desc;
        Err(SimError::NoSceneFile)
    }
    /// Applies edited scripts; one console line per reload event.
    fn poll_reload(&mut self) -> Vec<String> {
        Vec::new()
    }
    /// Applies the edits of these files now, without a watcher (what
    /// [`Showable::poll_reload`] does for the files it saw change); one console line per event.
    fn reload_changed(&mut self, paths: &[std::path::PathBuf]) -> Vec<String> {
        let _ = paths;
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
    /// What each behaviour module's decisions have cost (none without scripts).
    fn profile(&self) -> Vec<shoal_script::sim::ModuleProfile> {
        Vec::new()
    }
    /// Starts the profile over.
    fn reset_profile(&mut self) {}
    /// Turns the per-function stack sampling of the profile on or off (see
    /// [`Simulation::set_function_sampling`]).
    fn set_function_sampling(&mut self, on: bool) {
        let _ = on;
    }
    /// Whether the profile samples functions.
    fn function_sampling(&self) -> bool {
        false
    }
    /// Evaluates Lua in fish `id`'s context (the console and watches).
    fn eval_fish(&self, id: FishId, code: &str) -> Result<serde_json::Value, SimError> {
        let _ = (id, code);
        Err(SimError::NoScripts)
    }
    /// The Lua console's answer to `code` (see [`Simulation::console_eval`]).
    fn console_eval(&self, id: FishId, code: &str) -> Result<String, SimError> {
        self.eval_fish(id, code).map(|v| format!("= {v}"))
    }
    /// Sets one script file's logpoints (see [`Simulation::set_logpoints`]).
    fn set_logpoints(
        &mut self,
        file: &str,
        points: Vec<shoal_script::logpoints::Logpoint>,
    ) -> Result<(), SimError> {
        let _ = (file, points);
        Err(SimError::NoScripts)
    }
}

impl<S: Showable + ?Sized> Showable for Box<S> {
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
    fn drain_log(&mut self) -> Vec<LogLine> {
        (**self).drain_log()
    }
    fn snapshot(&self) -> Result<SimState, SimError> {
        (**self).snapshot()
    }
    fn restore(&mut self, state: &SimState) -> Result<(), SimError> {
        (**self).restore(state)
    }
    fn watch(&mut self) -> Result<(), SimError> {
        (**self).watch()
    }
    fn species_file(&self, species: usize) -> Option<std::path::PathBuf> {
        (**self).species_file(species)
    }
    fn scene_desc(&self) -> Option<&SceneDesc> {
        (**self).scene_desc()
    }
    fn scene_file(&self) -> Option<std::path::PathBuf> {
        (**self).scene_file()
    }
    fn apply_scene_edit(&mut self, desc: SceneDesc) -> Result<(), SimError> {
        (**self).apply_scene_edit(desc)
    }
    fn poll_reload(&mut self) -> Vec<String> {
        (**self).poll_reload()
    }
    fn reload_changed(&mut self, paths: &[std::path::PathBuf]) -> Vec<String> {
        (**self).reload_changed(paths)
    }
    fn scene_changed(&self) -> bool {
        (**self).scene_changed()
    }
    fn restart_scene(&mut self) -> Result<(), SimError> {
        (**self).restart_scene()
    }
    fn profile(&self) -> Vec<shoal_script::sim::ModuleProfile> {
        (**self).profile()
    }
    fn reset_profile(&mut self) {
        (**self).reset_profile();
    }
    fn set_function_sampling(&mut self, on: bool) {
        (**self).set_function_sampling(on);
    }
    fn function_sampling(&self) -> bool {
        (**self).function_sampling()
    }
    fn eval_fish(&self, id: FishId, code: &str) -> Result<serde_json::Value, SimError> {
        (**self).eval_fish(id, code)
    }
    fn console_eval(&self, id: FishId, code: &str) -> Result<String, SimError> {
        (**self).console_eval(id, code)
    }
    fn set_logpoints(
        &mut self,
        file: &str,
        points: Vec<shoal_script::logpoints::Logpoint>,
    ) -> Result<(), SimError> {
        (**self).set_logpoints(file, points)
    }
}

impl Showable for Simulation {
    fn tick(&mut self) {
        self.step();
    }
    fn profile(&self) -> Vec<shoal_script::sim::ModuleProfile> {
        Simulation::profile(self)
    }
    fn reset_profile(&mut self) {
        Simulation::reset_profile(self);
    }
    fn set_function_sampling(&mut self, on: bool) {
        let every = on.then_some(shoal_script::sim::SAMPLE_EVERY);
        Simulation::set_function_sampling(self, every);
    }
    fn function_sampling(&self) -> bool {
        Simulation::function_sampling(self).is_some()
    }
    fn eval_fish(&self, id: FishId, code: &str) -> Result<serde_json::Value, SimError> {
        Ok(Simulation::eval_fish(self, id, code)?)
    }
    fn console_eval(&self, id: FishId, code: &str) -> Result<String, SimError> {
        Ok(Simulation::console_eval(self, id, code)?)
    }
    fn set_logpoints(
        &mut self,
        file: &str,
        points: Vec<shoal_script::logpoints::Logpoint>,
    ) -> Result<(), SimError> {
        Ok(Simulation::set_logpoints(self, file, points)?)
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
    fn drain_log(&mut self) -> Vec<LogLine> {
        Simulation::drain_log(self)
            .into_iter()
            .map(|e| LogLine {
                text: e.to_string(),
                error_at_s: (e.level == LogLevel::Error).then_some(e.time_s),
            })
            .collect()
    }
    fn snapshot(&self) -> Result<SimState, SimError> {
        Ok(SimState::Script(Box::new(Simulation::snapshot(self)?)))
    }
    fn restore(&mut self, state: &SimState) -> Result<(), SimError> {
        match state {
            SimState::Script(s) => Ok(Simulation::restore(self, s)?),
            SimState::Rust(_) => Err(SimError::WrongSnapshot),
        }
    }
    fn watch(&mut self) -> Result<(), SimError> {
        Ok(Simulation::watch(self)?)
    }
    fn species_file(&self, species: usize) -> Option<std::path::PathBuf> {
        Simulation::species_file(self, species).map(std::path::Path::to_path_buf)
    }
    fn scene_desc(&self) -> Option<&SceneDesc> {
        Simulation::scene(self)
    }
    fn scene_file(&self) -> Option<std::path::PathBuf> {
        Simulation::scene_file(self).map(std::path::Path::to_path_buf)
    }
    fn apply_scene_edit(&mut self, desc: SceneDesc) -> Result<(), SimError> {
        Ok(Simulation::apply_scene_edit(self, desc)?)
    }
    fn poll_reload(&mut self) -> Vec<String> {
        Simulation::poll_reload(self)
            .into_iter()
            .map(|e| e.to_string())
            .collect()
    }
    fn reload_changed(&mut self, paths: &[std::path::PathBuf]) -> Vec<String> {
        Simulation::reload_changed(self, paths)
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

impl Showable for WanderPipeline {
    fn tick(&mut self) {
        WanderPipeline::tick(self);
    }
    fn world(&self) -> &World {
        WanderPipeline::world(self)
    }
    fn world_mut(&mut self) -> &mut World {
        WanderPipeline::world_mut(self)
    }
    fn snapshot(&self) -> Result<SimState, SimError> {
        Ok(SimState::Rust(Box::new(
            WanderPipeline::world(self).snapshot(),
        )))
    }
    fn restore(&mut self, state: &SimState) -> Result<(), SimError> {
        match state {
            SimState::Rust(w) => Ok(WanderPipeline::world_mut(self).restore((**w).clone())?),
            SimState::Script(_) => Err(SimError::WrongSnapshot),
        }
    }
}
