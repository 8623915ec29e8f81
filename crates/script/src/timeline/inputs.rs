//! What a behaviour test does to its world from outside the scripts — sets the tank, spawns
//! fish, drops food, places rocks, requests motions, switches behaviours — kept with the tick it
//! happened at, so a recording of a test world (`shoal test --trace`) runs again exactly: the
//! same inputs at the same ticks over the same scene and seed. The test API applies each input
//! through [`apply`], the same function a replay uses.

use glam::Vec3;
use serde::{Deserialize, Serialize};

use crate::{ScriptError, Simulation};
use shoal_core::motion::MotionRequest;
use shoal_core::world::{FishId, FoodPhysics, WorldError};

/// Why an input was refused.
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    /// The simulation refused it (an unknown species or behaviour, a tank out of range).
    #[error(transparent)]
    Script(#[from] ScriptError),
    /// The world refused it (a motion request out of range, a fish that is gone).
    #[error(transparent)]
    World(#[from] WorldError),
}

/// A recorded input that a replay could not apply.
#[derive(Debug, thiserror::Error)]
#[error("the recorded input at tick {tick}: {source}")]
pub struct RecordedInputError {
    /// The tick it was recorded at.
    pub tick: u64,
    /// Why it was refused.
    pub source: InputError,
}

/// One action on the world from outside the scripts.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Input {
    /// The tank's bounds (`t:world{tank = …}`).
    Tank {
        /// Lower corner.
        min: Vec3,
        /// Upper corner.
        max: Vec3,
    },
    /// A fish (`w:spawn{…}`).
    Spawn {
        /// Species name.
        species: String,
        /// Root position.
        pos: Vec3,
        /// Heading, radians.
        heading: f32,
        /// Pitch, radians.
        pitch: f32,
        /// Starting speed (default: the species' cruising speed).
        speed: Option<f32>,
        /// Behaviour module.
        behavior: Option<String>,
    },
    /// How pellets sink and how long they last (`t:world{food = …}`).
    FoodPhysics {
        /// Sinking speed, world units per second.
        sink_speed: f32,
        /// Seconds an uneaten pellet lasts (none: for ever).
        lifetime: Option<f32>,
    },
    /// A food pellet (`w:food{…}`).
    Food {
        /// Where.
        pos: Vec3,
    },
    /// A rock (`w:obstacle{…}`).
    Obstacle {
        /// Centre.
        pos: Vec3,
        /// Radius.
        radius: f32,
    },
    /// A motion requested directly (`fish:swim(…)`, `fish:turn(…)`…).
    Motion {
        /// The fish's slot.
        index: u32,
        /// The fish's generation.
        generation: u32,
        /// What.
        request: MotionRequest,
    },
    /// A behaviour switched (`fish:set_behavior(…)`).
    SetBehavior {
        /// The fish's slot.
        index: u32,
        /// The fish's generation.
        generation: u32,
        /// The new behaviour (none: the fish only plays requested motions).
        behavior: Option<String>,
    },
    /// The level-of-detail focus moved (a window's camera or selection, `t:world{focus = …}`):
    /// the schedule reads it, so a replay must see it at the same tick.
    LodFocus {
        /// The focus points (none: every fish in the last band).
        points: Vec<Vec3>,
    },
}

/// An input and the tick it happened at: after the tick's frame, before the next tick.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct TimedInput {
    /// The world's tick count when it happened.
    pub tick: u64,
    /// What happened.
    pub input: Input,
}

/// What applying an input made.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Applied {
    /// Nothing new to hand back.
    Done,
    /// A fish.
    Fish(FishId),
    /// A pellet.
    Food(shoal_core::world::FoodId),
    /// `fish:set_behavior`: whether the fish was alive.
    Switched(bool),
}

/// Applies `input` to `sim`; the message of an error names what was refused.
pub fn apply(sim: &mut Simulation, input: &Input) -> Result<Applied, InputError> {
    match input {
        Input::Tank { min, max } => Ok(sim.set_tank(*min, *max).map(|()| Applied::Done)?),
        Input::Spawn {
            species,
            pos,
            heading,
            pitch,
            speed,
            behavior,
        } => Ok(sim
            .spawn(species, *pos, *heading, *pitch, *speed, behavior.as_deref())
            .map(Applied::Fish)?),
        Input::FoodPhysics {
            sink_speed,
            lifetime,
        } => {
            sim.world_mut().set_food_physics(FoodPhysics {
                sink_speed: *sink_speed,
                lifetime: *lifetime,
            });
            Ok(Applied::Done)
        }
        Input::Food { pos } => Ok(Applied::Food(sim.world_mut().add_food(*pos))),
        Input::Obstacle { pos, radius } => {
            sim.world_mut().add_obstacle(*pos, *radius);
            Ok(Applied::Done)
        }
        Input::Motion {
            index,
            generation,
            request,
        } => {
            let id = FishId {
                index: *index,
                generation: *generation,
            };
            Ok(sim
                .world_mut()
                .request(id, *request, true)
                .map(|_| Applied::Done)?)
        }
        Input::SetBehavior {
            index,
            generation,
            behavior,
        } => {
            let id = FishId {
                index: *index,
                generation: *generation,
            };
            Ok(Applied::Switched(
                sim.world_mut().set_behavior(id, behavior.clone()),
            ))
        }
        Input::LodFocus { points } => {
            sim.set_lod_focus(points.clone());
            Ok(Applied::Done)
        }
    }
}

/// Applies every input of `inputs` (sorted by tick) at `tick`.
pub fn apply_at(
    sim: &mut Simulation,
    inputs: &[TimedInput],
    tick: u64,
) -> Result<(), RecordedInputError> {
    let from = inputs.partition_point(|i| i.tick < tick);
    for i in inputs[from..].iter().take_while(|i| i.tick == tick) {
        apply(sim, &i.input).map_err(|source| RecordedInputError { tick, source })?;
    }
    Ok(())
}
