//! `w`, a test's world: spawning, running simulated time, and the measures tests check.

use super::{
    FOOD_KEYS, FishHandle, FoodHandle, OBSTACLE_KEYS, SPAWN_KEYS, WorldHandle, check_keys, located,
    vec3_from, vec3_to,
};
use crate::timeline::inputs::{Applied, Input};
use glam::Vec3;
use mlua::{Table, UserData, UserDataFields, UserDataMethods};
use shoal_core::world::FishId;
use shoal_core::world::measures::{nearest_distances, polarization};
use std::path::Path;

impl WorldHandle {
    pub(super) fn advance(&self, ticks: u64) {
        let mut world = self.world.borrow_mut();
        for _ in 0..ticks {
            world.step();
        }
        world.drain_log();
        let now = world.sim.world().time();
        drop(world);
        let mut test = self.test.borrow_mut();
        test.sim_seconds += ticks as f64 / shoal_core::world::TICK_HZ;
        test.last_time = now;
    }

    /// Root positions of the live fish among `fishes` (a Lua array of fish).
    pub(super) fn positions_of(&self, fishes: &Table) -> mlua::Result<Vec<Vec3>> {
        let ids = Self::ids_of(fishes)?;
        let world = self.world.borrow();
        Ok(ids
            .iter()
            .filter_map(|&id| world.sim.world().root(id).map(|r| r.pos))
            .collect())
    }

    pub(super) fn ids_of(fishes: &Table) -> mlua::Result<Vec<FishId>> {
        let mut ids = Vec::new();
        for value in fishes.sequence_values::<mlua::AnyUserData>() {
            ids.push(value?.borrow::<FishHandle>()?.id);
        }
        Ok(ids)
    }
}

pub(super) fn ticks_for(seconds: f64) -> mlua::Result<u64> {
    if !seconds.is_finite() || seconds < 0.0 {
        return Err(mlua::Error::runtime(format!(
            "simulated time must be a finite number ≥ 0, got {seconds}"
        )));
    }
    Ok((seconds * shoal_core::world::TICK_HZ).round() as u64)
}

impl UserData for WorldHandle {
    fn add_fields<F: UserDataFields<Self>>(fields: &mut F) {
        fields.add_field_method_get("time", |_, this| Ok(this.world.borrow().sim.world().time()));
    }

    fn add_methods<M: UserDataMethods<Self>>(methods: &mut M) {
        add_population_methods(methods);
        add_clock_methods(methods);
        add_measure_methods(methods);
        add_script_methods(methods);
    }
}

/// `w:spawn{…}`, `w:food{…}`, `w:obstacle{…}`: what the world holds.
fn add_population_methods<M: UserDataMethods<WorldHandle>>(methods: &mut M) {
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
        let made = world.input(Input::Spawn {
            species,
            pos,
            heading,
            pitch,
            speed,
            behavior,
        });
        let id = match made {
            Ok(Applied::Fish(id)) => id,
            Ok(_) => return Err(located(lua, "w:spawn: no fish was made")),
            Err(e) => return Err(located(lua, format!("w:spawn: {e}"))),
        };
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
        let Ok(Applied::Food(id)) = world.input(Input::Food { pos }) else {
            return Err(located(lua, "w:food: no pellet was made"));
        };
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
            .input(Input::Obstacle { pos, radius })
            .map_err(|e| located(lua, format!("w:obstacle: {e}")))?;
        Ok(())
    });
}

/// `w:run(seconds)`, `w:step(n)`, `w:run_until(fn, max_seconds)`: simulated time.
fn add_clock_methods<M: UserDataMethods<WorldHandle>>(methods: &mut M) {
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
}

/// `w:polarization`, `w:nearest_distance`, `w:min_distance`, `w:centroid`, `w:tank`,
/// `w:obstacles`, `w:errors`, `w:fish_count`, `w:measure(name)` (a scene measure's mean so
/// far): what a test measures.
fn add_measure_methods<M: UserDataMethods<WorldHandle>>(methods: &mut M) {
    methods.add_method("polarization", |_, this, fishes: Table| {
        let ids = WorldHandle::ids_of(&fishes)?;
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
    methods.add_method("fish_count", |_, this, ()| {
        Ok(this.world.borrow().sim.world().num_fish())
    });
    methods.add_method("measure", |_, this, name: String| {
        let world = this.world.borrow();
        let measures = world.sim.measures();
        let Some((_, m)) = measures.iter().find(|(n, _)| *n == name) else {
            let known: Vec<&str> = measures.iter().map(|(n, _)| n.as_str()).collect();
            return Err(mlua::Error::runtime(format!(
                "w:measure: {} (a scene declares its measures as measures = {{ NAME = \
                 function(fish) … end }})",
                crate::scene::unknown_name("measure", &name, &known)
            )));
        };
        m.mean.ok_or_else(|| {
            mlua::Error::runtime(match &m.first_error {
                Some(e) => format!("w:measure(\"{name}\"): no value, every call failed: {e}"),
                None => format!(
                    "w:measure(\"{name}\"): no value yet: measures are sampled once per \
                     simulated second (run the world at least 1 s), and a fish whose measure \
                     returns nil is left out"
                ),
            })
        })
    });
}

/// `w:write_script(path, source)`: a scratch world's scripts, edited as in the aquarium.
fn add_script_methods<M: UserDataMethods<WorldHandle>>(methods: &mut M) {
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
}
