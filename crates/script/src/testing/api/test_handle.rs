//! `t`, the handle a test function receives: `t:world{…}` and the checks.

use super::{
    Cell, FOOD_PHYSICS_KEYS, TANK_KEYS, TestHandle, WORLD_KEYS, WorldHandle, WorldState,
    caller_line, check_keys, located, make_scratch, vec3_from,
};
use super::{NoRecording, TestRecording};
use crate::Simulation;
use crate::testing::Failure;
use crate::timeline::inputs::Input;
use glam::Vec3;
use mlua::{Lua, Table, UserData, UserDataMethods, Value};
use std::path::Path;

/// What a recording of a test world made from `scene` (or the empty tank) needs, read now: the
/// scene relative to the scripts directory and every script's text.
fn recording_of(root: &Path, scene: Option<&str>, seed: u64) -> TestRecording {
    let scripts_dir = root.join("scripts");
    let base = scripts_dir.canonicalize().unwrap_or(scripts_dir.clone());
    let scene = match scene {
        None if scripts_dir.join("scenes/empty_tank.lua").is_file() => {
            Ok("scenes/empty_tank.lua".to_owned())
        }
        None => Err(NoRecording::NoScene),
        Some(s) => [
            Path::new(s).to_path_buf(),
            root.join(s),
            scripts_dir.join(s),
            scripts_dir.join("scenes").join(s),
        ]
        .into_iter()
        .find(|p| p.is_file())
        .and_then(|p| p.canonicalize().ok())
        .and_then(|p| {
            p.strip_prefix(&base).ok().map(|rel| {
                rel.components()
                    .map(|c| c.as_os_str().to_string_lossy())
                    .collect::<Vec<_>>()
                    .join("/")
            })
        })
        .ok_or_else(|| NoRecording::SceneOutside {
            scene: s.to_owned(),
            scripts: scripts_dir.clone(),
        }),
    };
    let scripts = crate::timeline::run_file::read_scripts(&scripts_dir).unwrap_or_default();
    TestRecording {
        scene,
        seed,
        scripts,
        frames: Vec::new(),
    }
}

impl TestHandle {
    pub(super) fn fail(&self, lua: &Lua, message: String) {
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

    pub(super) fn check(&self, lua: &Lua, ok: bool, message: impl FnOnce() -> String) -> bool {
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

/// The numbers a comparison (`t:near`, `t:less`, `t:greater`) was given; a value that is not a
/// number (a field that is still nil, say) fails the check, naming which argument it was,
/// instead of raising a conversion error.
fn numbers<const N: usize>(
    lua: &Lua,
    this: &TestHandle,
    call: &str,
    what: &str,
    values: [&Value; N],
) -> Option<[f64; N]> {
    const ORDINALS: [&str; 3] = ["first", "second", "third"];
    let mut out = [0.0; N];
    for (i, v) in values.into_iter().enumerate() {
        match v {
            Value::Integer(n) => out[i] = *n as f64,
            Value::Number(n) => out[i] = *n,
            other => {
                this.check(lua, false, || {
                    format!(
                        "{what}: {call}'s {} value must be a number, got {}",
                        ORDINALS[i],
                        describe(other)
                    )
                });
                return None;
            }
        }
    }
    Some(out)
}

/// `t:world{focus = ...}`: one point `{x, y, z}` or a list of them (`{}`: no focus); `None`
/// when left out.
fn focus_points(lua: &Lua, value: &Value) -> mlua::Result<Option<Vec<Vec3>>> {
    let table = match value {
        Value::Nil => return Ok(None),
        Value::Table(t) => t,
        other => {
            return Err(located(
                lua,
                format!(
                    "t:world focus must be a point {{x, y, z}} or a list of points, got {}",
                    describe(other)
                ),
            ));
        }
    };
    let first: Value = table.raw_get(1)?;
    if matches!(first, Value::Integer(_) | Value::Number(_)) {
        let p = vec3_from(value, "t:world focus").map_err(|e| located(lua, e.to_string()))?;
        return Ok(Some(vec![p]));
    }
    let mut points = Vec::new();
    for (i, p) in table.sequence_values::<Value>().enumerate() {
        let p = vec3_from(&p?, &format!("t:world focus[{}]", i + 1))
            .map_err(|e| located(lua, e.to_string()))?;
        points.push(p);
    }
    Ok(Some(points))
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
            // The world's own level of detail beats `--lod`: a test that counts decisions
            // (which level of detail cuts) pins it.
            let lod = match opts.get::<Value>("lod")? {
                Value::Nil => None,
                Value::Boolean(on) => Some(on),
                other => {
                    return Err(located(
                        lua,
                        format!(
                            "t:world lod must be true or false (behaviour level of detail on or \
                             off in this world, whatever --lod says), got {}",
                            describe(&other)
                        ),
                    ));
                }
            };
            let focus = focus_points(lua, &opts.get::<Value>("focus")?)?;
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
            if let Some(on) = lod.or(this.0.borrow().lod) {
                sim.set_lod_on(on);
            }
            let recording = this
                .0
                .borrow()
                .record_runs
                .then(|| recording_of(&root, scene.as_deref(), seed));
            let mut state = WorldState {
                sim,
                scratch,
                allow_errors,
                line,
                log: Vec::new(),
                trace: Vec::new(),
                fish: Vec::new(),
                foods: Vec::new(),
                inputs: Vec::new(),
                recording,
            };
            if let Some(tank) = opts.get::<Option<Table>>("tank")? {
                check_keys(lua, &tank, "t:world tank", TANK_KEYS)?;
                let min = vec3_from(&tank.get("min")?, "tank.min")?;
                let max = vec3_from(&tank.get("max")?, "tank.max")?;
                state
                    .input(Input::Tank { min, max })
                    .map_err(|e| located(lua, format!("t:world: {e}")))?;
            }
            if let Some(food) = opts.get::<Option<Table>>("food")? {
                check_keys(lua, &food, "t:world food", FOOD_PHYSICS_KEYS)?;
                let sink_speed: f32 = food.get::<Option<f32>>("sink_speed")?.unwrap_or(0.0);
                if !(sink_speed.is_finite() && sink_speed >= 0.0) {
                    return Err(located(
                        lua,
                        format!("t:world food.sink_speed must be ≥ 0 (units/s), got {sink_speed}"),
                    ));
                }
                let lifetime: Option<f32> = food.get("lifetime")?;
                if let Some(l) = lifetime
                    && !(l.is_finite() && l > 0.0)
                {
                    return Err(located(
                        lua,
                        format!("t:world food.lifetime must be > 0 (seconds), got {l}"),
                    ));
                }
                state
                    .input(Input::FoodPhysics {
                        sink_speed,
                        lifetime,
                    })
                    .map_err(|e| located(lua, format!("t:world: {e}")))?;
            }
            if let Some(points) = focus {
                // An input, as the window's camera is: a recording of the test keeps it.
                state
                    .input(Input::LodFocus { points })
                    .map_err(|e| located(lua, format!("t:world: {e}")))?;
            }
            let world = Cell::new(state);
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
                // The designer's message says what was expected (often with the actual value
                // in it: "intends to hide, got graze"); the condition's own value comes after
                // it, named as such, not as a second "got".
                Ok(this.check(lua, ok, || match msg {
                    Some(msg) => format!("{msg} (t:expect's condition was {})", describe(&cond)),
                    None => format!(
                        "t:expect: the condition does not hold (it is {})",
                        describe(&cond)
                    ),
                }))
            },
        );
        methods.add_method(
            "near",
            |lua, this, (actual, expected, tol, msg): (Value, Value, Value, Option<String>)| {
                let what = msg.unwrap_or_else(|| "values differ".into());
                let Some([actual, expected, tol]) =
                    numbers(lua, this, "t:near", &what, [&actual, &expected, &tol])
                else {
                    return Ok(false);
                };
                let ok = (actual - expected).abs() <= tol;
                Ok(this.check(lua, ok, || {
                    format!(
                        "{what}: expected {expected:.4} ± {tol:.4}, actual {actual:.4} (off by {:.4})",
                        (actual - expected).abs()
                    )
                }))
            },
        );
        methods.add_method(
            "less",
            |lua, this, (a, b, msg): (Value, Value, Option<String>)| {
                let what = msg.unwrap_or_else(|| "comparison failed".into());
                let Some([a, b]) = numbers(lua, this, "t:less", &what, [&a, &b]) else {
                    return Ok(false);
                };
                Ok(this.check(lua, a < b, || format!("{what}: expected {a:.4} < {b:.4}")))
            },
        );
        methods.add_method(
            "greater",
            |lua, this, (a, b, msg): (Value, Value, Option<String>)| {
                let what = msg.unwrap_or_else(|| "comparison failed".into());
                let Some([a, b]) = numbers(lua, this, "t:greater", &what, [&a, &b]) else {
                    return Ok(false);
                };
                Ok(this.check(lua, a > b, || format!("{what}: expected {a:.4} > {b:.4}")))
            },
        );
    }
}
