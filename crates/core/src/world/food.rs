//! Pellets once they are in the water: they sink at the scene's speed and drift with the current
//! zones until they settle on the floor or on top of a rock, and an uneaten pellet dissolves
//! after the scene's lifetime. The motion stage moves them ([`World::step_food`]).

use glam::Vec3;

use super::contact::drift;
use super::{Obstacle, Tank, World};

/// How a scene's pellets behave once dropped (scene keys `food_sink_speed` and
/// `food_lifetime`). The default leaves a pellet where it was dropped, for ever — unless a
/// current zone carries it.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct FoodPhysics {
    /// How fast pellets sink, world units per second (0: they float where they are dropped).
    pub sink_speed: f32,
    /// Seconds an uneaten pellet lasts in the water before it dissolves (`None`: for ever).
    pub lifetime: Option<f32>,
}

/// Where a pellet moved to `p` ends up: inside the tank and outside every rock, and whether it
/// has settled there — on the floor, or on a rock's upper cap (lower on a rock's flank it is only
/// pushed out, so as it sinks on it slides off the rock).
fn settle(p: Vec3, tank: &Tank, obstacles: &[Obstacle]) -> (Vec3, bool) {
    let mut p = p.clamp(tank.min, tank.max);
    let mut settled = p.y <= tank.min.y;
    for o in obstacles {
        let out = p - o.pos;
        if out.length_squared() < o.radius * o.radius {
            let n = out.normalize_or(Vec3::Y);
            p = (o.pos + n * o.radius).clamp(tank.min, tank.max);
            settled |= n.y > ROCK_CAP_NORMAL_Y;
        }
    }
    (p, settled)
}

/// A pellet pushed out of a rock settles there when the rock's surface normal at that point
/// points this much upwards (within ~45° of the vertical); lower down it slides off.
const ROCK_CAP_NORMAL_Y: f32 = 0.7;

impl World {
    /// Sets how pellets sink and how long they last (see [`FoodPhysics`]); values that make no
    /// sense (a negative or non-finite speed, a lifetime that is not positive and finite) are
    /// taken as "no sinking" and "for ever".
    pub fn set_food_physics(&mut self, physics: FoodPhysics) {
        let sink_speed = if physics.sink_speed.is_finite() {
            physics.sink_speed.max(0.0)
        } else {
            0.0
        };
        let lifetime = physics.lifetime.filter(|l| l.is_finite() && *l > 0.0);
        self.state.food_physics = FoodPhysics {
            sink_speed,
            lifetime,
        };
    }

    /// How pellets sink and how long they last.
    pub fn food_physics(&self) -> FoodPhysics {
        self.state.food_physics
    }

    /// The pellets' part of the motion stage: uneaten pellets older than the lifetime dissolve
    /// (they leave the water without joining the eaten history), the others sink and drift by
    /// `dt` seconds and settle. Moving or removing any drops the food grid, which the grid stage
    /// then rebuilds.
    pub(super) fn step_food(&mut self, dt: f32) {
        let physics = self.state.food_physics;
        let now = self.state.time;
        if let Some(life) = physics.lifetime {
            let before = self.state.foods.len();
            self.state
                .foods
                .retain(|(_, f)| now - f.dropped_at < f64::from(life));
            if self.state.foods.len() != before {
                self.index.food_changed();
            }
        }
        let currents = &self.state.currents;
        if physics.sink_speed == 0.0 && currents.is_empty() {
            return;
        }
        let (tank, obstacles) = (self.state.tank, &self.state.obstacles);
        let sink = Vec3::new(0.0, -physics.sink_speed, 0.0);
        let mut moved = false;
        for (_, f) in &mut self.state.foods {
            if f.settled {
                continue;
            }
            let v = sink + drift(currents, f.pos);
            if v == Vec3::ZERO {
                continue;
            }
            (f.pos, f.settled) = settle(f.pos + v * dt, &tank, obstacles);
            moved = true;
        }
        if moved {
            self.index.food_changed();
        }
    }
}
