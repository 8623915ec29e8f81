//! Saved files applied to a running simulation: behaviour modules (every lane), species data
//! (live fish pick it up), and the scene (restarted on request).

use std::path::{Path, PathBuf};

use super::Simulation;
use crate::api;
use crate::error::ScriptError;
use crate::host::Reloaded;
use crate::log::LogLevel;
use crate::reload::ScriptWatcher;
use shoal_core::world::SpeciesId;

/// What `reload_changed` did with each path, for the console.
#[derive(Debug, Clone, PartialEq)]
pub enum ReloadEvent {
    /// Behaviour modules reloaded.
    Behaviors(Vec<String>),
    /// A species' data now applies to its live fish.
    Species(String),
    /// The current scene's file changed: the panel offers a restart.
    SceneChanged,
    /// The current scene's file was written with what already runs (saved from the window):
    /// nothing to restart.
    SceneUnchanged,
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
            Self::SceneUnchanged => write!(f, "the scene file matches the running scene"),
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

impl Simulation {
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
        let time_s = self.sim.world().time();
        for p in paths {
            let real = p.canonicalize().unwrap_or_else(|_| p.clone());
            if self.scene_path.as_deref() == Some(real.as_path()) {
                let display = self.host().root().display_of(&real);
                // Saved from the window: the file says what already runs.
                if let Ok(desc) = super::read_scene(self.host(), &real, &display)
                    && self.scene.as_ref() == Some(&desc)
                {
                    events.push(ReloadEvent::SceneUnchanged);
                    continue;
                }
                self.scene_changed = true;
                let msg = format!(
                    "{}: scene changed — restart?",
                    self.host().root().display_of(&real)
                );
                self.host_mut().log(LogLevel::Info, &msg, None, time_s);
                events.push(ReloadEvent::SceneChanged);
                continue;
            }
            if let Some(i) = self
                .sim
                .behavior
                .species
                .iter()
                .position(|s| s.path == real)
            {
                events.push(self.reload_species(i, &real, time_s));
                continue;
            }
            // Every lane reloads; lane 0's outcome is reported (the lanes run the same files).
            let mut outcome = None;
            for lane in &mut self.sim.behavior.lanes {
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
                                .position(|(n, m)| **n == *stem && m.is_none())
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
                match self
                    .sim
                    .world_mut()
                    .replace_species(SpeciesId(i as u16), species)
                {
                    Ok(()) => {
                        self.sim.behavior.species[i].period_ticks = period;
                        for lane in &self.sim.behavior.lanes {
                            // A failure here can only be out of memory; the caches then
                            // hold the old names until the next reload.
                            let _ = api::invalidate_species(lane.host.lua());
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
        if fresh.sim.behavior.lanes.len() != self.sim.behavior.lanes.len() {
            fresh.set_lanes(self.sim.behavior.lanes.len())?;
        }
        fresh.watcher = self.watcher.take();
        // `--lod on|off` outlasts the restart; the scene's bands and focus are the edited file's.
        if let Some(on) = self.lod_override {
            fresh.set_lod_on(on);
        }
        *self = fresh;
        Ok(())
    }
}
