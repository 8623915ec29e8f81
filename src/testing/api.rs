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
//!   `l`, `max_amp`, `lambda`, `omega`, `tt` in seconds, `f`, `turn_angle`).
//! - `t:expect(cond, msg)`, `t:near(actual, expected, tol, msg)`, `t:less(a, b, msg)`,
//!   `t:greater(a, b, msg)`: record a failure (with file, line, expected, actual, simulated time)
//!   and carry on; a Lua error ends the test as a failure.
//! - A key an option table does not take is an error naming it, with a "did you mean".
//! - What the world's scripts `print` is kept with the test ([`ScriptLine`]).

use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard};
use std::time::Instant;

use glam::Vec3;
use mlua::{Lua, LuaSerdeExt, Table, UserData, UserDataFields, UserDataMethods, Value};

use super::trace::{Sample, Trace};
use super::{Failure, RunOptions, ScriptLine, TestOutcome};
use crate::motion::MotionRequest;
use crate::script::Simulation;
use crate::script::log::{LogEntry, LogLevel};
use crate::world::{FishId, FoodId};

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
        self.sim.step();
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
const WORLD_KEYS: &[&str] = &["seed", "scene", "tank", "scratch", "allow_errors"];
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
    let hint = crate::script::scene::did_you_mean(key, known)
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

impl TestHandle {
    fn fail(&self, lua: &Lua, message: String) {
        let mut state = self.0.borrow_mut();
        let file = state.file.clone();
        let sim_time = state.last_time;
        state.failures.push(Failure {
            file,
            line: caller_line(lua),
            message,
            sim_time,
        });
    }

    fn check(&self, lua: &Lua, ok: bool, message: impl FnOnce() -> String) -> bool {
        self.0.borrow_mut().num_checks += 1;
        if !ok {
            self.fail(lua, message());
        }
        ok
    }
}

fn describe(value: &Value) -> String {
    match value {
        Value::Nil => "nil".into(),
        Value::Boolean(b) => b.to_string(),
        Value::Integer(i) => i.to_string(),
        Value::Number(n) => format!("{n:.4}"),
        Value::String(s) => format!("{:?}", s.to_string_lossy()),
        other => other.type_name().to_string(),
    }
}

impl UserData for TestHandle {
    fn add_methods<M: UserDataMethods<Self>>(methods: &mut M) {
        methods.add_method("world", |lua, this, opts: Option<Table>| {
            let opts = match opts {
                Some(t) => t,
                None => lua.create_table()?,
            };
            check_keys(lua, &opts, "t:world", WORLD_KEYS)?;
            let seed: u64 = opts.get::<Option<u64>>("seed")?.unwrap_or(1);
            let scene: Option<String> = opts.get("scene")?;
            let scratch_wanted = opts.get::<Option<bool>>("scratch")?.unwrap_or(false);
            let allow_errors = opts.get::<Option<bool>>("allow_errors")?.unwrap_or(false);
            let line = caller_line(lua);
            let mut root = this.0.borrow().root.clone();
            let scratch = if scratch_wanted {
                let dir = make_scratch(&root)
                    .map_err(|e| located(lua, format!("t:world scratch copy: {e}")))?;
                root = dir.path().to_path_buf();
                Some(dir)
            } else {
                None
            };
            let mut sim = match &scene {
                Some(scene) => Simulation::from_scene(&root, Path::new(scene), seed),
                None => Simulation::empty(&root, seed),
            }
            .map_err(|e| located(lua, format!("t:world: {e}")))?;
            if let Some(tank) = opts.get::<Option<Table>>("tank")? {
                check_keys(lua, &tank, "t:world tank", TANK_KEYS)?;
                let min = vec3_from(&tank.get("min")?, "tank.min")?;
                let max = vec3_from(&tank.get("max")?, "tank.max")?;
                sim.set_tank(min, max)
                    .map_err(|e| located(lua, format!("t:world: {e}")))?;
            }
            let world = Cell::new(WorldState {
                sim,
                scratch,
                allow_errors,
                line,
                log: Vec::new(),
                trace: Vec::new(),
                fish: Vec::new(),
                foods: Vec::new(),
            });
            this.0.borrow_mut().worlds.push(world.clone());
            Ok(WorldHandle {
                world,
                test: this.0.clone(),
            })
        });
        methods.add_method(
            "expect",
            |lua, this, (cond, msg): (Value, Option<String>)| {
                let ok = !matches!(cond, Value::Nil | Value::Boolean(false));
                Ok(this.check(lua, ok, || {
                    format!(
                        "expected: {} — got {}",
                        msg.unwrap_or_else(|| "condition to hold".into()),
                        describe(&cond)
                    )
                }))
            },
        );
        methods.add_method(
            "near",
            |lua, this, (actual, expected, tol, msg): (f64, f64, f64, Option<String>)| {
                let ok = (actual - expected).abs() <= tol;
                Ok(this.check(lua, ok, || {
                    format!(
                        "{}: expected {expected:.4} ± {tol:.4}, actual {actual:.4} (off by {:.4})",
                        msg.unwrap_or_else(|| "values differ".into()),
                        (actual - expected).abs()
                    )
                }))
            },
        );
        methods.add_method(
            "less",
            |lua, this, (a, b, msg): (f64, f64, Option<String>)| {
                Ok(this.check(lua, a < b, || {
                    format!(
                        "{}: expected {a:.4} < {b:.4}",
                        msg.unwrap_or_else(|| "comparison failed".into())
                    )
                }))
            },
        );
        methods.add_method(
            "greater",
            |lua, this, (a, b, msg): (f64, f64, Option<String>)| {
                Ok(this.check(lua, a > b, || {
                    format!(
                        "{}: expected {a:.4} > {b:.4}",
                        msg.unwrap_or_else(|| "comparison failed".into())
                    )
                }))
            },
        );
    }
}

impl WorldHandle {
    fn advance(&self, ticks: u64) {
        let mut world = self.world.borrow_mut();
        for _ in 0..ticks {
            world.step();
        }
        world.drain_log();
        let now = world.sim.world().time();
        drop(world);
        let mut test = self.test.borrow_mut();
        test.sim_seconds += ticks as f64 / crate::world::TICK_HZ;
        test.last_time = now;
    }

    /// Root positions of the live fish among `fishes` (a Lua array of fish).
    fn positions_of(&self, fishes: &Table) -> mlua::Result<Vec<Vec3>> {
        let ids = Self::ids_of(fishes)?;
        let world = self.world.borrow();
        Ok(ids
            .iter()
            .filter_map(|&id| world.sim.world().root(id).map(|r| r.pos))
            .collect())
    }

    fn ids_of(fishes: &Table) -> mlua::Result<Vec<FishId>> {
        let mut ids = Vec::new();
        for value in fishes.sequence_values::<mlua::AnyUserData>() {
            ids.push(value?.borrow::<FishHandle>()?.id);
        }
        Ok(ids)
    }
}

fn ticks_for(seconds: f64) -> mlua::Result<u64> {
    if !seconds.is_finite() || seconds < 0.0 {
        return Err(mlua::Error::runtime(format!(
            "simulated time must be a finite number ≥ 0, got {seconds}"
        )));
    }
    Ok((seconds * crate::world::TICK_HZ).round() as u64)
}

impl UserData for WorldHandle {
    fn add_fields<F: UserDataFields<Self>>(fields: &mut F) {
        fields.add_field_method_get("time", |_, this| Ok(this.world.borrow().sim.world().time()));
    }

    fn add_methods<M: UserDataMethods<Self>>(methods: &mut M) {
        methods.add_method("spawn", |lua, this, opts: Table| {
            check_keys(lua, &opts, "w:spawn", SPAWN_KEYS)?;
            let species: String = opts
                .get::<Option<String>>("species")?
                .ok_or_else(|| located(lua, "w:spawn needs species = \"name\""))?;
            let pos = vec3_from(&opts.get("pos")?, "pos")?;
            let heading: f32 = opts.get::<Option<f32>>("heading")?.unwrap_or(0.0);
            let pitch: f32 = opts.get::<Option<f32>>("pitch")?.unwrap_or(0.0);
            let speed: Option<f32> = opts.get("speed")?;
            let behavior: Option<String> = opts.get("behavior")?;
            let mut world = this.world.borrow_mut();
            let id = world
                .sim
                .spawn(&species, pos, heading, pitch, speed, behavior.as_deref())
                .map_err(|e| located(lua, format!("w:spawn: {e}")))?;
            world.fish.push(id);
            world.record_fish(id);
            Ok(FishHandle {
                world: this.world.clone(),
                id,
            })
        });
        methods.add_method("food", |lua, this, opts: Table| {
            check_keys(lua, &opts, "w:food", FOOD_KEYS)?;
            let pos = vec3_from(&opts.get("pos")?, "pos")?;
            let mut world = this.world.borrow_mut();
            let id = world.sim.world_mut().add_food(pos);
            world.foods.push(id);
            Ok(FoodHandle {
                world: this.world.clone(),
                id,
            })
        });
        methods.add_method("obstacle", |lua, this, opts: Table| {
            check_keys(lua, &opts, "w:obstacle", OBSTACLE_KEYS)?;
            let pos = vec3_from(&opts.get("pos")?, "pos")?;
            let radius: f32 = opts.get("radius")?;
            if !(radius.is_finite() && radius > 0.0) {
                return Err(mlua::Error::runtime(format!(
                    "w:obstacle radius must be > 0, got {radius}"
                )));
            }
            this.world
                .borrow_mut()
                .sim
                .world_mut()
                .add_obstacle(pos, radius);
            Ok(())
        });
        methods.add_method("run", |_, this, seconds: f64| {
            this.advance(ticks_for(seconds)?);
            Ok(())
        });
        methods.add_method("step", |_, this, n: Option<u64>| {
            this.advance(n.unwrap_or(1));
            Ok(())
        });
        methods.add_method(
            "run_until",
            |_, this, (cond, max_seconds): (mlua::Function, f64)| {
                let max_ticks = ticks_for(max_seconds)?;
                let handle = this.clone();
                for _ in 0..max_ticks {
                    if cond.call::<bool>(handle.clone())? {
                        return Ok((true, this.world.borrow().sim.world().time()));
                    }
                    this.advance(1);
                }
                let done = cond.call::<bool>(handle)?;
                Ok((done, this.world.borrow().sim.world().time()))
            },
        );
        methods.add_method("polarization", |_, this, fishes: Table| {
            let ids = Self::ids_of(&fishes)?;
            let world = this.world.borrow();
            Ok(polarization(ids.iter().filter_map(|&id| {
                world.sim.world().root(id).map(|r| r.heading)
            })))
        });
        methods.add_method("nearest_distance", |_, this, fishes: Table| {
            Ok(nearest_distances(&this.positions_of(&fishes)?).0)
        });
        methods.add_method("min_distance", |_, this, fishes: Table| {
            Ok(nearest_distances(&this.positions_of(&fishes)?).1)
        });
        methods.add_method("centroid", |lua, this, fishes: Table| {
            let points = this.positions_of(&fishes)?;
            let c = points.iter().copied().sum::<Vec3>() / points.len().max(1) as f32;
            vec3_to(lua, c)
        });
        methods.add_method("tank", |lua, this, ()| {
            let world = this.world.borrow();
            let tank = world.sim.world().tank();
            let t = lua.create_table()?;
            t.set("min", vec3_to(lua, tank.min)?)?;
            t.set("max", vec3_to(lua, tank.max)?)?;
            Ok(t)
        });
        methods.add_method("obstacles", |lua, this, ()| {
            let world = this.world.borrow();
            let out = lua.create_table()?;
            for (i, o) in world.sim.world().obstacles().iter().enumerate() {
                let t = lua.create_table()?;
                t.set("pos", vec3_to(lua, o.pos)?)?;
                t.set("radius", o.radius)?;
                out.raw_set(i + 1, t)?;
            }
            Ok(out)
        });
        methods.add_method("errors", |lua, this, ()| {
            let world = this.world.borrow();
            lua.create_sequence_from(world.sim.error_messages())
        });
        methods.add_method(
            "write_script",
            |_, this, (relative, source): (String, String)| {
                let mut world = this.world.borrow_mut();
                let Some(dir) = world.scratch.as_ref() else {
                    return Err(mlua::Error::runtime(
                        "w:write_script needs a world made with t:world{ scratch = true }",
                    ));
                };
                let relative = Path::new(&relative);
                if relative.is_absolute()
                    || relative
                        .components()
                        .any(|c| matches!(c, std::path::Component::ParentDir))
                {
                    return Err(mlua::Error::runtime(format!(
                        "w:write_script: {} must be a path inside scripts/",
                        relative.display()
                    )));
                }
                let path = dir.path().join("scripts").join(relative);
                if let Some(parent) = path.parent() {
                    std::fs::create_dir_all(parent).map_err(mlua::Error::external)?;
                }
                std::fs::write(&path, source).map_err(mlua::Error::external)?;
                // As the file watcher would on a save: reload what the file affects.
                let events = world.sim.reload_changed(&[path]);
                Ok(events
                    .iter()
                    .map(|e| format!("{e:?}"))
                    .collect::<Vec<_>>()
                    .join("; "))
            },
        );
        methods.add_method("fish_count", |_, this, ()| {
            Ok(this.world.borrow().sim.world().num_fish())
        });
    }
}

/// |mean of unit horizontal heading vectors|: 1 when all fish face the same way, near 0 when
/// headings are spread evenly.
pub fn polarization(headings: impl Iterator<Item = f32>) -> f64 {
    let (mut sx, mut sz, mut n) = (0f64, 0f64, 0usize);
    for h in headings {
        sx += f64::from(h.cos());
        sz += f64::from(h.sin());
        n += 1;
    }
    if n == 0 {
        return 0.0;
    }
    (sx * sx + sz * sz).sqrt() / n as f64
}

/// (mean, minimum) over points of the distance to each point's nearest other point; (0, 0) with
/// fewer than two points.
pub fn nearest_distances(points: &[Vec3]) -> (f64, f64) {
    if points.len() < 2 {
        return (0.0, 0.0);
    }
    let mut sum = 0f64;
    let mut min = f64::INFINITY;
    for (i, p) in points.iter().enumerate() {
        let nearest = points
            .iter()
            .enumerate()
            .filter(|&(j, _)| j != i)
            .map(|(_, q)| f64::from(p.distance(*q)))
            .fold(f64::INFINITY, f64::min);
        sum += nearest;
        min = min.min(nearest);
    }
    (sum / points.len() as f64, min)
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

/// A side or turn kind named by a test, parsed by the motion layer's one parser; the error lists
/// the accepted names.
fn parse_name<T: std::str::FromStr<Err = crate::motion::UnknownName>>(
    method: &str,
    word: &str,
) -> mlua::Result<T> {
    word.parse()
        .map_err(|e| mlua::Error::runtime(format!("{method}: {e}")))
}

impl FishHandle {
    fn request(&self, lua: &Lua, request: MotionRequest) -> mlua::Result<()> {
        self.world
            .borrow_mut()
            .sim
            .world_mut()
            .request(self.id, request, true)
            .map_err(|e| located(lua, e))
    }
}

impl UserData for FishHandle {
    fn add_fields<F: UserDataFields<Self>>(fields: &mut F) {
        fields.add_field_method_get("id", |_, this| Ok(this.id.index));
        fields.add_field_method_get("alive", |_, this| {
            Ok(this.world.borrow().sim.world().is_alive(this.id))
        });
        fields.add_field_method_get("pos", |lua, this| {
            let world = this.world.borrow();
            let root = world.sim.world().root(this.id).copied().unwrap_or_default();
            vec3_to(lua, root.pos)
        });
        fields.add_field_method_get("heading", |_, this| {
            let world = this.world.borrow();
            Ok(world.sim.world().root(this.id).map(|r| r.heading))
        });
        fields.add_field_method_get("pitch", |_, this| {
            let world = this.world.borrow();
            Ok(world.sim.world().root(this.id).map(|r| r.pitch))
        });
        fields.add_field_method_get("speed", |_, this| {
            let world = this.world.borrow();
            Ok(world.sim.world().root(this.id).map(|r| r.speed))
        });
        fields.add_field_method_get("depth", |_, this| {
            let world = this.world.borrow();
            let w = world.sim.world();
            Ok(w.root(this.id).map(|r| w.tank().depth_of(r.pos.y)))
        });
        fields.add_field_method_get("behavior", |_, this| {
            let world = this.world.borrow();
            Ok(world.sim.world().behavior_of(this.id).map(str::to_owned))
        });
        fields.add_field_method_get("motion", |_, this| {
            let world = this.world.borrow();
            Ok(world.sim.world().current_motion(this.id))
        });
        fields.add_field_method_get("params", |lua, this| {
            let world = this.world.borrow();
            let w = world.sim.world();
            match w.species_of(this.id) {
                Some(sid) => lua.to_value(&w.species(sid).desc.motion),
                None => Ok(Value::Nil),
            }
        });
        fields.add_field_method_get("species", |_, this| {
            let world = this.world.borrow();
            let w = world.sim.world();
            Ok(w.species_of(this.id)
                .map(|sid| w.species(sid).desc.name.clone()))
        });
        fields.add_field_method_get("memory", |lua, this| {
            let world = this.world.borrow();
            json_to_lua(lua, &world.sim.memory_json(this.id))
        });
        fields.add_field_method_get("intention", |lua, this| {
            let world = this.world.borrow();
            json_to_lua(lua, &world.sim.script_field_json(this.id, "intention"))
        });
        fields.add_field_method_get("percepts", |lua, this| {
            let world = this.world.borrow();
            json_to_lua(lua, &world.sim.script_field_json(this.id, "percepts"))
        });
    }

    fn add_methods<M: UserDataMethods<Self>>(methods: &mut M) {
        methods.add_method("swim", |lua, this, speed: f32| {
            this.request(lua, MotionRequest::Swim { speed })
        });
        methods.add_method("accelerate", |lua, this, (speed, duration): (f32, f32)| {
            this.request(lua, MotionRequest::Accelerate { speed, duration })
        });
        methods.add_method("stop", |lua, this, duration: Option<f32>| {
            this.request(
                lua,
                MotionRequest::Stop {
                    duration: duration.unwrap_or(1.0),
                },
            )
        });
        methods.add_method(
            "turn",
            |lua, this, (kind, degrees, side): (String, f32, String)| {
                this.request(
                    lua,
                    MotionRequest::Turn {
                        kind: parse_name("turn", &kind)?,
                        angle: degrees.to_radians(),
                        side: parse_name("turn", &side)?,
                    },
                )
            },
        );
        methods.add_method("ascend", |lua, this, height: f32| {
            this.request(lua, MotionRequest::Ascend { height })
        });
        methods.add_method("descend", |lua, this, depth: f32| {
            this.request(lua, MotionRequest::Descend { depth })
        });
        methods.add_method("set_behavior", |_, this, name: Option<String>| {
            let mut world = this.world.borrow_mut();
            Ok(world.sim.world_mut().set_behavior(this.id, name))
        });
    }
}

impl UserData for FoodHandle {
    fn add_fields<F: UserDataFields<Self>>(fields: &mut F) {
        fields.add_field_method_get("eaten", |_, this| {
            let world = this.world.borrow();
            Ok(world.sim.world().food(this.id).is_some_and(|f| f.eaten))
        });
        fields.add_field_method_get("eaten_at", |_, this| {
            let world = this.world.borrow();
            Ok(world.sim.world().food(this.id).and_then(|f| f.eaten_at))
        });
        fields.add_field_method_get("pos", |lua, this| {
            let world = this.world.borrow();
            let pos = world
                .sim
                .world()
                .food(this.id)
                .map(|f| f.pos)
                .unwrap_or_default();
            vec3_to(lua, pos)
        });
    }
}

/// A Lua state for test files: the standard library without `io`, `os` (but `os.clock`),
/// `debug`'s mutating parts or binary chunk loading. Test files are trusted more than fish
/// scripts (they are the designer's own checks), but they still cannot touch the machine.
fn test_lua() -> mlua::Result<Lua> {
    let lua = Lua::new();
    let globals = lua.globals();
    let clock: mlua::Function = globals.get::<Table>("os")?.get("clock")?;
    let os = lua.create_table()?;
    os.set("clock", clock)?;
    globals.set("os", os)?;
    for name in ["io", "debug", "dofile", "loadfile", "package", "require"] {
        globals.set(name, Value::Nil)?;
    }
    Ok(lua)
}

/// The tests a file declares, in order, with the Lua state they run in; an error message when the
/// file does not load.
type Declared = (Lua, Vec<(String, mlua::Function)>);

fn load_tests(file: &Path, options: &RunOptions) -> Result<Declared, String> {
    let source = std::fs::read_to_string(file).map_err(|e| format!("cannot read: {e}"))?;
    let lua = test_lua().map_err(|e| format!("cannot create a Lua state: {e}"))?;
    let declared: Cell<Vec<(String, mlua::Function)>> = Cell::new(Vec::new());
    let register = {
        let declared = declared.clone();
        lua.create_function(move |_, (name, f): (String, mlua::Function)| {
            declared.borrow_mut().push((name, f));
            Ok(())
        })
    };
    register
        .and_then(|f| lua.globals().set("test", f))
        .map_err(|e| format!("cannot register test(): {e}"))?;
    let chunk_name = format!("@{}", display_path(file, &options.root));
    lua.load(&source)
        .set_name(chunk_name)
        .exec()
        .map_err(|e| first_line(&e.to_string()))?;
    let tests = std::mem::take(&mut *declared.borrow_mut());
    Ok((lua, tests))
}

/// The names of the tests a file declares (none if it does not load).
pub fn test_names(file: &Path, options: &RunOptions) -> Vec<String> {
    load_tests(file, options)
        .map(|(_, tests)| tests.into_iter().map(|(name, _)| name).collect())
        .unwrap_or_default()
}

/// Runs every test of one file (filtered by `options.filter`) and returns their outcomes.
/// A file that does not load yields one failed outcome named after the file.
pub fn run_file(file: &Path, options: &RunOptions) -> Vec<TestOutcome> {
    let (lua, tests) = match load_tests(file, options) {
        Ok(declared) => declared,
        Err(message) => {
            return vec![TestOutcome {
                file: file.to_path_buf(),
                name: "(load)".into(),
                failures: vec![Failure {
                    file: file.to_path_buf(),
                    line: None,
                    message,
                    sim_time: 0.0,
                }],
                sim_seconds: 0.0,
                wall: std::time::Duration::ZERO,
                num_checks: 0,
                trace_files: Vec::new(),
                output: Vec::new(),
            }];
        }
    };
    let file_name = file
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut outcomes = Vec::new();
    for (name, function) in tests {
        if let Some(filter) = &options.filter
            && !name.contains(filter.as_str())
            && !file_name.contains(filter.as_str())
        {
            continue;
        }
        outcomes.push(run_one(&lua, file, &name, function, options));
    }
    outcomes
}

/// Most distinct script errors reported as failures per world; the rest are counted.
const ERRORS_REPORTED: usize = 5;

/// Splits what a world's scripts logged into failures (its errors, unless the world allows them)
/// and output lines (prints, and the errors it allows), errors deduplicated by message.
fn script_report(
    file: &Path,
    index: usize,
    world: &WorldState,
    failures: &mut Vec<Failure>,
    output: &mut Vec<ScriptLine>,
) {
    let mut seen_errors: Vec<&str> = Vec::new();
    let mut unreported = 0usize;
    for entry in &world.log {
        let is_error = entry.level == LogLevel::Error;
        if is_error {
            if seen_errors.contains(&entry.message.as_str()) {
                continue;
            }
            seen_errors.push(&entry.message);
        }
        if is_error && !world.allow_errors {
            if seen_errors.len() > ERRORS_REPORTED {
                unreported += 1;
                continue;
            }
            let fish = entry
                .fish
                .map(|f| format!(" in fish {}", f.index))
                .unwrap_or_default();
            failures.push(Failure {
                file: file.to_path_buf(),
                line: world.line,
                message: format!(
                    "script error{fish}: {} (a test that expects errors makes this world with \
                     t:world{{ allow_errors = true }} and checks w:errors())",
                    entry.message
                ),
                sim_time: entry.time_s,
            });
            continue;
        }
        output.push(ScriptLine {
            world: index,
            time_s: entry.time_s,
            fish: entry.fish.map(|f| f.index),
            message: entry.message.clone(),
            error: is_error,
            repeats: entry.repeats,
            warning: entry.level == LogLevel::Warning,
        });
    }
    if unreported > 0 {
        failures.push(Failure {
            file: file.to_path_buf(),
            line: world.line,
            message: format!("… and {unreported} more distinct script errors in this world"),
            sim_time: world.sim.world().time(),
        });
    }
}

fn run_one(
    lua: &Lua,
    file: &Path,
    name: &str,
    function: mlua::Function,
    options: &RunOptions,
) -> TestOutcome {
    let start = Instant::now();
    let state: Shared = Cell::new(TestState {
        file: file.to_path_buf(),
        root: options.root.clone(),
        failures: Vec::new(),
        num_checks: 0,
        sim_seconds: 0.0,
        last_time: 0.0,
        worlds: Vec::new(),
    });
    let result = lua
        .create_userdata(TestHandle(state.clone()))
        .and_then(|t| function.call::<()>(t));
    if let Err(e) = result {
        let (line, message) = split_lua_error(&e.to_string());
        let mut s = state.borrow_mut();
        let sim_time = s.last_time;
        s.failures.push(Failure {
            file: file.to_path_buf(),
            line,
            message: format!("error: {message}"),
            sim_time,
        });
    }
    // Free the test's worlds before the next test (userdata may linger until GC).
    let _ = lua.gc_collect();
    let state = Arc::try_unwrap(state.0)
        .map(|m| m.into_inner().unwrap_or_else(|e| e.into_inner()))
        .unwrap_or_else(|rc| {
            let s = rc.lock().unwrap_or_else(|e| e.into_inner());
            TestState {
                file: s.file.clone(),
                root: s.root.clone(),
                failures: s.failures.clone(),
                num_checks: s.num_checks,
                sim_seconds: s.sim_seconds,
                last_time: s.last_time,
                worlds: s.worlds.clone(),
            }
        });
    // Script errors first: they are usually why a check failed.
    let mut failures = Vec::new();
    let mut output = Vec::new();
    for (i, world) in state.worlds.iter().enumerate() {
        let mut world = world.borrow_mut();
        world.drain_log();
        script_report(file, i, &world, &mut failures, &mut output);
    }
    failures.extend(state.failures);
    let mut trace_files = Vec::new();
    if !failures.is_empty()
        && let Some(dir) = &options.trace_dir
    {
        let stem = format!(
            "{}-{}",
            file.file_stem()
                .map(|s| s.to_string_lossy())
                .unwrap_or_default(),
            slug(name)
        );
        for (i, world) in state.worlds.iter().enumerate() {
            let trace = world.borrow().to_trace();
            let base = if state.worlds.len() == 1 {
                stem.clone()
            } else {
                format!("{stem}-world{i}")
            };
            let csv = dir.join(format!("{base}.csv"));
            let png = dir.join(format!("{base}.png"));
            match trace
                .write_csv(&csv)
                .and_then(|()| trace.write_top_view(&png))
            {
                Ok(()) => trace_files.extend([csv, png]),
                Err(e) => failures.push(Failure {
                    file: file.to_path_buf(),
                    line: None,
                    message: format!("trace not written: {e}"),
                    sim_time: state.last_time,
                }),
            }
        }
    }
    TestOutcome {
        file: file.to_path_buf(),
        name: name.to_string(),
        failures,
        sim_seconds: state.sim_seconds,
        wall: super::elapsed_since(start),
        num_checks: state.num_checks,
        trace_files,
        output,
    }
}

fn slug(name: &str) -> String {
    name.chars()
        .map(|c| {
            if c.is_ascii_alphanumeric() {
                c.to_ascii_lowercase()
            } else {
                '_'
            }
        })
        .collect()
}

fn display_path(file: &Path, root: &Path) -> String {
    file.strip_prefix(root)
        .unwrap_or(file)
        .display()
        .to_string()
}

fn first_line(text: &str) -> String {
    text.lines().next().unwrap_or(text).to_string()
}

/// Lua errors read `[runtime error: ]file.lua:line: message`; split the line number out when
/// it is there.
fn split_lua_error(text: &str) -> (Option<usize>, String) {
    let first = first_line(text);
    if let Some(at) = first.find(".lua:") {
        let rest = &first[at + ".lua:".len()..];
        let digits: String = rest.chars().take_while(char::is_ascii_digit).collect();
        if let (Ok(line), Some(message)) = (digits.parse(), rest[digits.len()..].strip_prefix(':'))
        {
            return (Some(line), message.trim().to_string());
        }
    }
    (None, first)
}

#[cfg(test)]
mod tests {
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
