//! The Lua surface of behaviour tests.
//!
//! ```lua
//! test("hungry porgy finds food", function(t)
//!   local w = t:world{ seed = 7, scene = "scenes/empty_tank.lua" }
//!   local fish = w:spawn{ species = "black_porgy", pos = {0, 1, 0}, heading = 0, behavior = "forage" }
//!   local food = w:food{ pos = {3, 1, 1} }
//!   w:run(20)
//!   t:expect(food.eaten, "food eaten within 20 s")
//! end)
//! ```
//!
//! - `test(name, fn)` declares a test; `fn(t)` runs after the whole file has been read.
//! - `t:world{seed, scene?, tank?, scratch?, allow_errors?}` → world. `scene` is relative to
//!   `scripts/`; `tank` is `{min = {x,y,z}, max = {x,y,z}}` and overrides the scene's tank. A
//!   script error in the world fails the test unless `allow_errors = true`.
//! - `w:spawn{species, pos, heading?, pitch?, speed?, behavior?}` → fish, whose fields `pos`,
//!   `heading`, `pitch`, `speed`, `depth`, `behavior`, `motion`, `memory`, `intention`,
//!   `percepts`, `id`, `alive` read the live state (`intention` and `percepts`: what its
//!   behaviour's last decision produced). A fish with no behaviour is driven by the test itself:
//!   `fish:swim(speed)`, `fish:accelerate(speed, seconds)`, `fish:stop(seconds?)`,
//!   `fish:turn(kind, degrees, side)` (`kind` = "normal" | "quick" | "serial", `side` = "left" |
//!   "right"), `fish:ascend(height)`, `fish:descend(depth)`, `fish:set_behavior(name)`.
//! - `w:food{pos}` → food with `eaten`, `eaten_at`, `pos`; `w:obstacle{pos, radius}`.
//! - `w:run(seconds)`, `w:step(n)`, `w:run_until(fn, max_seconds)` → `true, t` when `fn(w)` became
//!   true at simulated time `t`, `false, max` otherwise. `w.time` is the simulated time.
//! - `w:polarization(fishes)` (|mean unit heading|, 1 = all aligned), `w:nearest_distance(fishes)`
//!   (mean distance to each fish's nearest neighbour), `w:min_distance(fishes)`, `w:centroid(fishes)`,
//!   `w:tank()` → `{min, max}`, `w:errors()` → script errors so far (strings with file:line),
//!   `w:obstacles()`, `w:fish_count()`.
//! - `t:world{scratch = true}` gives the world a private copy of `scripts/` and `assets/`;
//!   `w:write_script(path, source)` then writes a script there (path relative to `scripts/`) and
//!   reloads what it affects, as saving it in an editor would in the aquarium.
//! - Fish also expose `species` (name) and `params` (the species' motion parameters: `p`, `s`,
//!   `l`, `max_amp`, `lambda`, `omega`, `tt` in seconds, `f`, `turn_angle`, `turn_axis` (nil:
//!   the pivot), `front_amp`, `front_wave`).
//! - `t:expect(cond, msg)`, `t:near(actual, expected, tol, msg)`, `t:less(a, b, msg)`,
//!   `t:greater(a, b, msg)`: record a failure (with file, line, expected, actual, simulated time)
//!   and carry on; a Lua error ends the test as a failure.
//! - A key an option table does not take is an error naming it, with a "did you mean".
//! - What the world's scripts `print` is kept with the test ([`ScriptLine`](super::ScriptLine)).
//!
//! Files: this one holds the state a running test shares and the helpers its handles use;
//! `test_handle` is `t`, `world_handle` is `w` (with its measures), `fish_handle` the fish and
//! food a test holds, and `run` loads a test file and runs its tests.

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard};

use glam::Vec3;
use mlua::{Lua, LuaSerdeExt, Table, Value};

use super::Failure;
use super::trace::{Sample, Trace};
use crate::Simulation;
use crate::log::LogEntry;
use crate::timeline::inputs::{Applied, Input, InputError, TimedInput};
use shoal_core::world::{FishId, FoodId};

mod fish_handle;
mod run;
mod test_handle;
mod world_handle;

pub use run::{run_file, test_names};
pub use shoal_core::world::measures::{nearest_distances, polarization};

/// Ticks between trace samples (6 = 10 Hz at the 60 Hz tick).
const TRACE_EVERY_TICKS: u64 = 6;

/// State shared by all checks of one running test.
struct TestState {
    file: PathBuf,
    root: PathBuf,
    failures: Vec<Failure>,
    num_checks: usize,
    sim_seconds: f64,
    last_time: f64,
    worlds: Vec<Cell<WorldState>>,
    /// Keep what a recording of each world needs (`--trace`): every tick's poses.
    record_runs: bool,
    /// `--lod on|off` for every world the test makes (`None`: the scene's default).
    lod: Option<bool>,
}

/// Why a test world cannot be written as a recording (`--trace`): said under the test, beside
/// its trace.
#[derive(Debug, Clone, thiserror::Error)]
enum NoRecording {
    /// The run did not keep the poses (no `--trace`).
    #[error("no recording was kept (run with --trace)")]
    NotKept,
    /// The world was made without a scene and there is no empty tank scene to name.
    #[error("the world has no scene file (no scripts/scenes/empty_tank.lua)")]
    NoScene,
    /// The world's scene is not a file under the scripts directory a replay could find.
    #[error("its scene {scene} is not inside {}", scripts.display())]
    SceneOutside {
        /// The scene as the test named it.
        scene: String,
        /// The scripts directory.
        scripts: PathBuf,
    },
}

/// Why a recording of a test world was not written.
#[derive(Debug, thiserror::Error)]
enum RecordingError {
    /// None could be made.
    #[error(transparent)]
    NotMade(#[from] NoRecording),
    /// Writing it failed.
    #[error(transparent)]
    Write(#[from] crate::timeline::run_file::RunFileError),
}

/// What a `.shoalrun` of a test world needs: how the world was made, what the test did to it
/// and when, and every tick's poses (kept only under `--trace`).
struct TestRecording {
    /// The scene, relative to the scripts directory, or why the world cannot be recorded.
    scene: Result<String, NoRecording>,
    seed: u64,
    scripts: std::collections::BTreeMap<String, crate::timeline::run_file::ScriptFile>,
    frames: Vec<Vec<crate::timeline::run_file::Pose>>,
}

struct WorldState {
    sim: Simulation,
    /// The private copy of `scripts/` and `assets/` of a `scratch = true` world (removed on drop).
    scratch: Option<tempfile::TempDir>,
    /// `t:world{ allow_errors = true }`: script errors are expected, not failures.
    allow_errors: bool,
    /// The test-file line of the `t:world` call that made this world.
    line: Option<usize>,
    /// What the world's scripts logged (prints, errors), oldest first.
    log: Vec<LogEntry>,
    trace: Vec<Sample>,
    fish: Vec<FishId>,
    foods: Vec<FoodId>,
    /// Everything the test did to the world from outside the scripts, by tick.
    inputs: Vec<TimedInput>,
    /// Poses and setup for a recording (`--trace`).
    recording: Option<TestRecording>,
}

/// A script value from [`Simulation::script_field_json`] for a CSV cell: a string as it is,
/// nothing for nil, anything else as compact JSON.
fn cell_text(value: serde_json::Value) -> String {
    match value {
        serde_json::Value::Null => String::new(),
        serde_json::Value::String(s) => s,
        other => other.to_string(),
    }
}

impl WorldState {
    /// Applies a test's action on the world and keeps it (with its tick) for a recording.
    fn input(&mut self, input: Input) -> Result<Applied, InputError> {
        let applied = crate::timeline::inputs::apply(&mut self.sim, &input)?;
        self.inputs.push(TimedInput {
            tick: self.sim.world().tick_count(),
            input,
        });
        Ok(applied)
    }

    /// The world as a recording (`.shoalrun`): `Err` says why it cannot be one.
    fn to_run(&self) -> Result<crate::timeline::run_file::Run, NoRecording> {
        use crate::timeline::run_file::{Run, RunHeader};
        let rec = self.recording.as_ref().ok_or(NoRecording::NotKept)?;
        let scene = rec.scene.clone()?;
        let mut frames = rec.frames.clone();
        if frames.is_empty() {
            frames.push(crate::timeline::poses(self.sim.world()));
        }
        let tank = self.sim.world().tank();
        Ok(Run {
            header: RunHeader {
                shoal_version: env!("CARGO_PKG_VERSION").to_owned(),
                scene,
                seed: rec.seed,
                lanes: self.sim.num_lanes(),
                tick_hz: shoal_core::world::TICK_HZ,
                tank: [tank.min.to_array(), tank.max.to_array()],
                scripts: rec.scripts.clone(),
                replay_of: None,
                inputs: self.inputs.clone(),
                lod: self.sim.world().lod().on,
            },
            frames,
        })
    }

    /// Records every fish's state.
    fn record(&mut self) {
        for i in 0..self.fish.len() {
            self.record_fish(self.fish[i]);
        }
    }

    /// Records one fish's state (a fish just spawned).
    fn record_fish(&mut self, id: FishId) {
        let sim = &self.sim;
        let world = sim.world();
        if let Some(root) = world.root(id) {
            self.trace.push(Sample {
                t: world.time(),
                fish: id.index,
                pos: root.pos,
                heading: root.heading,
                speed: root.speed,
                motion: world.current_motion(id).unwrap_or_default().to_owned(),
                intention: cell_text(sim.script_field_json(id, "intention")),
                memory: cell_text(sim.memory_json(id)),
            });
        }
    }

    /// Moves what the scripts logged since the last call into [`WorldState::log`].
    fn drain_log(&mut self) {
        let entries = self.sim.drain_log();
        self.log.extend(entries);
    }

    fn step(&mut self) {
        if let Some(rec) = &mut self.recording
            && rec.frames.is_empty()
        {
            // Frame 0: the world as the first tick finds it (after the test's setup).
            rec.frames.push(crate::timeline::poses(self.sim.world()));
        }
        self.sim.step();
        if let Some(rec) = &mut self.recording {
            rec.frames.push(crate::timeline::poses(self.sim.world()));
        }
        if self
            .sim
            .world()
            .tick_count()
            .is_multiple_of(TRACE_EVERY_TICKS)
        {
            self.record();
        }
    }

    fn to_trace(&self) -> Trace {
        let world = self.sim.world();
        let tank = world.tank();
        let labels = self
            .fish
            .iter()
            .map(|&id| {
                let species = world
                    .species_of(id)
                    .map(|s| world.species(s).desc.name.clone())
                    .unwrap_or_default();
                let behavior = world.behavior_of(id).unwrap_or("test-driven");
                (
                    id.index,
                    format!("fish {}: {species}, {behavior}", id.index),
                )
            })
            .collect();
        Trace {
            tank: (tank.min, tank.max),
            samples: self.trace.clone(),
            labels,
            foods: self
                .foods
                .iter()
                .filter_map(|&id| world.food(id).map(|f| (f.pos, f.eaten)))
                .collect(),
            obstacles: world
                .obstacles()
                .iter()
                .map(|o| (o.pos, o.radius))
                .collect(),
        }
    }
}

type Shared = Cell<TestState>;

/// State a test's userdata share. The Lua state is `Send` (mlua's `send` feature, which script
/// lanes need), so userdata hold it behind a mutex; a test uses it from one thread only, and no
/// borrow is held across a call back into Lua.
struct Cell<T>(Arc<Mutex<T>>);

impl<T> Clone for Cell<T> {
    fn clone(&self) -> Self {
        Self(self.0.clone())
    }
}

impl<T> Cell<T> {
    fn new(value: T) -> Self {
        Self(Arc::new(Mutex::new(value)))
    }

    /// The value (a panic in an earlier borrow leaves it usable).
    fn borrow(&self) -> MutexGuard<'_, T> {
        self.0.lock().unwrap_or_else(|e| e.into_inner())
    }

    fn borrow_mut(&self) -> MutexGuard<'_, T> {
        self.borrow()
    }
}

/// The `t` argument of a test function.
struct TestHandle(Shared);
/// A world created by `t:world`.
#[derive(Clone)]
struct WorldHandle {
    world: Cell<WorldState>,
    test: Shared,
}
/// A fish spawned by `w:spawn`.
#[derive(Clone)]
struct FishHandle {
    world: Cell<WorldState>,
    id: FishId,
}
/// Food added by `w:food`.
#[derive(Clone)]
struct FoodHandle {
    world: Cell<WorldState>,
    id: FoodId,
}

/// The line of the Lua code that called the current Rust function.
fn caller_line(lua: &Lua) -> Option<usize> {
    (1..6).find_map(|level| {
        lua.inspect_stack(level, |debug| {
            let source = debug.source();
            if source.what == "C" {
                None
            } else {
                debug.current_line()
            }
        })
        .flatten()
    })
}

/// A runtime error located at the Lua line that called into Rust (`file:line: message`), so
/// errors raised by the test API point at the test's own line like Lua's `error()` does.
fn located(lua: &Lua, message: impl std::fmt::Display) -> mlua::Error {
    let place = (1..6).find_map(|level| {
        lua.inspect_stack(level, |debug| {
            let source = debug.source();
            if source.what == "C" {
                return None;
            }
            let file = source.short_src.as_deref().unwrap_or("?").to_string();
            debug.current_line().map(|line| format!("{file}:{line}"))
        })
        .flatten()
    });
    match place {
        Some(place) => mlua::Error::runtime(format!("{place}: {message}")),
        None => mlua::Error::runtime(message.to_string()),
    }
}

/// The keys each option table of the test API takes.
const WORLD_KEYS: &[&str] = &[
    "seed",
    "scene",
    "tank",
    "food",
    "scratch",
    "allow_errors",
    "lod",
    "focus",
];
const FOOD_PHYSICS_KEYS: &[&str] = &["sink_speed", "lifetime"];
const TANK_KEYS: &[&str] = &["min", "max"];
const SPAWN_KEYS: &[&str] = &["species", "pos", "heading", "pitch", "speed", "behavior"];
const FOOD_KEYS: &[&str] = &["pos"];
const OBSTACLE_KEYS: &[&str] = &["pos", "radius"];

/// An error (at the test's line) for the first key of `table` that `what` does not take, naming
/// the key, the closest known one and every known one; so that a typo such as `behaviour` is not
/// silently ignored.
fn check_keys(lua: &Lua, table: &Table, what: &str, known: &[&str]) -> mlua::Result<()> {
    let mut unknown = Vec::new();
    for pair in table.pairs::<Value, Value>() {
        let (key, _) = pair?;
        let key = match &key {
            Value::String(s) => s.to_string_lossy(),
            other => other
                .to_string()
                .unwrap_or_else(|_| other.type_name().to_owned()),
        };
        if !known.contains(&key.as_str()) {
            unknown.push(key);
        }
    }
    // Table order is not stable: report the same key every run.
    unknown.sort();
    let Some(key) = unknown.first() else {
        return Ok(());
    };
    let hint = crate::scene::did_you_mean(key, known)
        .map(|k| format!(" — did you mean `{k}`?"))
        .unwrap_or_default();
    Err(located(
        lua,
        format!(
            "{what}: unknown key `{key}`{hint} ({what} takes {})",
            known.join(", ")
        ),
    ))
}

fn vec3_from(value: &Value, what: &str) -> mlua::Result<Vec3> {
    let Value::Table(t) = value else {
        return Err(mlua::Error::runtime(format!(
            "{what} must be a table {{x, y, z}}, got {}",
            value.type_name()
        )));
    };
    let mut v = [0f32; 3];
    for (i, slot) in v.iter_mut().enumerate() {
        let n: f64 = t
            .get(i + 1)
            .map_err(|_| mlua::Error::runtime(format!("{what}[{}] must be a number", i + 1)))?;
        if !n.is_finite() {
            return Err(mlua::Error::runtime(format!(
                "{what}[{}] = {n} is not a finite number",
                i + 1
            )));
        }
        *slot = n as f32;
    }
    Ok(Vec3::from_array(v))
}

fn vec3_to(lua: &Lua, v: Vec3) -> mlua::Result<Table> {
    let t = lua.create_table_with_capacity(3, 0)?;
    t.raw_set(1, v.x)?;
    t.raw_set(2, v.y)?;
    t.raw_set(3, v.z)?;
    Ok(t)
}

/// A private copy of `root/scripts` and `root/assets` so a test can write scripts freely.
fn make_scratch(root: &Path) -> std::io::Result<tempfile::TempDir> {
    fn copy_dir(from: &Path, to: &Path) -> std::io::Result<()> {
        std::fs::create_dir_all(to)?;
        for entry in std::fs::read_dir(from)? {
            let entry = entry?;
            let path = entry.path();
            if path.is_dir() {
                copy_dir(&path, &to.join(entry.file_name()))?;
            } else {
                std::fs::copy(&path, to.join(entry.file_name()))?;
            }
        }
        Ok(())
    }
    let dir = tempfile::tempdir()?;
    for sub in ["scripts", "assets"] {
        copy_dir(&root.join(sub), &dir.path().join(sub))?;
    }
    Ok(dir)
}

/// A script value read back from a fish (a copy: changing it does not change the fish); JSON
/// null is Lua nil.
fn json_to_lua(lua: &Lua, json: &serde_json::Value) -> mlua::Result<Value> {
    let options = mlua::serde::SerializeOptions::new()
        .serialize_none_to_null(false)
        .serialize_unit_to_null(false);
    lua.to_value_with(json, options)
}

#[cfg(test)]
mod tests {
    use super::run::split_lua_error;
    use super::*;

    #[test]
    fn polarization_of_aligned_and_opposed_headings() {
        assert!((polarization([0.3f32, 0.3, 0.3].into_iter()) - 1.0).abs() < 1e-6);
        assert!(polarization([0.0f32, std::f32::consts::PI].into_iter()) < 1e-6);
        // Three headings 120° apart cancel.
        let third = 2.0 * std::f32::consts::PI / 3.0;
        assert!(polarization([0.0, third, 2.0 * third].into_iter()) < 1e-6);
    }

    #[test]
    fn nearest_distances_on_a_line() {
        // 0 --1-- 1 ----3---- 4: nearest distances 1, 1, 3 → mean 5/3, min 1.
        let points = [Vec3::ZERO, Vec3::X, Vec3::X * 4.0];
        let (mean, min) = nearest_distances(&points);
        assert!((mean - 5.0 / 3.0).abs() < 1e-9);
        assert!((min - 1.0).abs() < 1e-9);
    }

    #[test]
    fn lua_error_lines_are_split_out() {
        assert_eq!(
            split_lua_error("tests/behavior/a_test.lua:12: boom\nstack traceback:"),
            (Some(12), "boom".to_string())
        );
        assert_eq!(
            split_lua_error("runtime error: /tmp/x/b_test.lua:3: attempt to index a nil value"),
            (Some(3), "attempt to index a nil value".to_string())
        );
        assert_eq!(
            split_lua_error("no line here"),
            (None, "no line here".into())
        );
    }
}
