//! The fish and food handles a test holds: live state read back, and motions requested
//! directly.

use super::{FishHandle, FoodHandle, json_to_lua, located, vec3_to};
use crate::timeline::inputs::{Applied, Input};
use mlua::{Lua, LuaSerdeExt, UserData, UserDataFields, UserDataMethods, Value};
use shoal_core::motion::MotionRequest;

/// A side or turn kind named by a test, parsed by the motion layer's one parser; the error lists
/// the accepted names.
fn parse_name<T: std::str::FromStr<Err = shoal_core::motion::UnknownName>>(
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
            .input(Input::Motion {
                index: self.id.index,
                generation: self.id.generation,
                request,
            })
            .map(|_| ())
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
        methods.add_method("set_behavior", |lua, this, name: Option<String>| {
            let mut world = this.world.borrow_mut();
            let switched = world.input(Input::SetBehavior {
                index: this.id.index,
                generation: this.id.generation,
                behavior: name,
            });
            match switched {
                Ok(Applied::Switched(alive)) => Ok(alive),
                Ok(_) => Ok(false),
                Err(e) => Err(located(lua, e)),
            }
        });
    }
}

impl UserData for FoodHandle {
    fn add_fields<F: UserDataFields<Self>>(fields: &mut F) {
        fields.add_field_method_get("eaten", |_, this| {
            let world = this.world.borrow();
            Ok(world.sim.world().was_eaten(this.id))
        });
        fields.add_field_method_get("settled", |_, this| {
            let world = this.world.borrow();
            Ok(world.sim.world().food(this.id).is_some_and(|f| f.settled))
        });
        fields.add_field_method_get("dissolved", |_, this| {
            let world = this.world.borrow();
            let w = world.sim.world();
            let in_water = w.food(this.id).is_some_and(|f| !f.eaten);
            Ok(!in_water && !w.was_eaten(this.id))
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
