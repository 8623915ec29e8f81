//! A built-in Rust [`Behavior`]: wander + schooling + wall, rock and predator avoidance, decided
//! at a per-fish rate staggered across fish.
//!
//! It lets the Rust stages be measured (`shoal bench sim --driver rust`) and exercised in tests
//! without the Lua host; the Lua scripts (`script::Simulation`) are the other implementation of
//! the same trait, ticked by the same [`super::tick::step`]. Its decisions use only the public
//! sensor and steering API the Lua API exposes, so its perception cost is representative of the
//! scripts'.

use std::sync::Arc;
use std::time::Instant;

use rand::Rng;

use super::steer::{self, Steer};
use super::tick::{Behavior, exclusive};
use super::{FishControls, FishId, FishRef, PerceptKind, TICK_HZ, VisionBatch, World};

/// A world whose fish the built-in Rust driver decides for (`shoal bench sim --driver rust`, the
/// renderer's tests).
pub type WanderPipeline = super::Pipeline<WanderDriver>;

/// Parameters of [`WanderDriver`], in body lengths and seconds. `Copy`, see [`Default`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct WanderParams {
    /// Decisions per second per fish (default 10, issue 5's default behaviour rate).
    pub decision_hz: f64,
    /// Largest heading change per decision while wandering, radians (default 0.5).
    pub wander_turn: f32,
    /// Largest depth change per decision while wandering, body lengths (default 0.3).
    pub wander_depth_lengths: f32,
    /// Neighbours closer than this push away, body lengths (default 1).
    pub separation_lengths: f32,
    /// Keep this far from the tank's walls, floor and surface, body lengths (default 2).
    pub wall_margin_lengths: f32,
    /// Look this far ahead for rocks, body lengths (default 3).
    pub obstacle_lookahead_lengths: f32,
    /// Percepts a decision considers, nearest first (default 24).
    pub max_percepts: usize,
}

impl Default for WanderParams {
    fn default() -> Self {
        Self {
            decision_hz: 10.0,
            wander_turn: 0.5,
            wander_depth_lengths: 0.3,
            separation_lengths: 1.0,
            wall_margin_lengths: 2.0,
            obstacle_lookahead_lengths: 3.0,
            max_percepts: 24,
        }
    }
}

/// Decides for every fish of a [`World`] in Rust (see the module docs).
#[derive(Default)]
pub struct WanderDriver {
    /// The behaviour parameters.
    pub params: WanderParams,
    batch: VisionBatch,
    ids: Vec<FishId>,
    /// The deciding fish's controls, checked out of the world for its decision.
    controls: FishControls,
    decisions_last_tick: usize,
}

impl WanderDriver {
    /// A driver with `params`.
    pub fn new(params: WanderParams) -> Self {
        Self {
            params,
            ..Self::default()
        }
    }

    /// Fish decisions made in the last tick.
    pub fn decisions_last_tick(&self) -> usize {
        self.decisions_last_tick
    }

    /// The decisions due this tick: fish `i` decides on ticks where `(tick + i) % period == 0`,
    /// `period = TICK_HZ / decision_hz`; their vision is sensed in one parallel batch, then they
    /// decide one after another, as a Lua host would. Sensor time goes to `perception_ns`, the
    /// decisions themselves to `lua_ns` (the behaviour stage; no Lua runs here).
    fn decide_due(&mut self, world: &mut World) {
        let period = (TICK_HZ / self.params.decision_hz.max(1e-3))
            .round()
            .max(1.0) as u64;
        let tick = world.tick_count();
        // Taken out of self so `decide` can borrow self while iterating.
        let mut due = std::mem::take(&mut self.ids);
        due.clear();
        due.extend(
            world
                .fish_ids()
                .enumerate()
                .filter(|(i, _)| (tick + *i as u64).is_multiple_of(period))
                .map(|(_, id)| id),
        );
        let t0 = Instant::now();
        world.vision_batch(&due, self.params.max_percepts, &mut self.batch);
        let t1 = Instant::now();
        let mut controls = std::mem::take(&mut self.controls);
        for (k, &id) in due.iter().enumerate() {
            if !world.check_out(id, &mut controls) {
                continue;
            }
            if let Some(fish) = world.fish(id)
                && let Some(want) = self.decide_one(fish, &mut controls, k)
            {
                // A refused request leaves the fish doing what it did; nothing to recover.
                let _ = fish.steer_to(&mut controls, want.heading, want.depth, want.speed);
            }
            world.check_in(id, &mut controls);
        }
        self.controls = controls;
        let t2 = Instant::now();
        self.decisions_last_tick = due.len();
        self.ids = due;
        let counters = world.counters_mut();
        counters.perception_ns = (t1 - t0).as_nanos() as u64;
        counters.lua_ns = (t2 - t1).as_nanos() as u64;
        // The decisions run one after another on this thread; the sensing ran in parallel.
        counters.decisions = self.decisions_last_tick as u64;
        counters.decide_cpu_ns = counters.lua_ns;
        counters.sense_cpu_ns = 0;
    }

    fn decide_one(
        &self,
        fish: FishRef<'_>,
        controls: &mut FishControls,
        k: usize,
    ) -> Option<Steer> {
        let percepts = self.batch.get(k);
        let agent = fish.agent();
        let species = fish.species();
        let l = species.body_length();
        let cruise = species.desc.motion.s;
        let max_speed = species.desc.max_speed.max(cruise);
        let p = &self.params;

        if let Some(threat) = percepts.iter().find(|s| s.kind == PerceptKind::Predator) {
            return Some(steer::flee(&agent, threat.pos, max_speed));
        }
        if let Some(s) = fish.avoid_walls(p.wall_margin_lengths * l, cruise) {
            return Some(s);
        }
        if let Some(s) = fish.avoid_obstacles(p.obstacle_lookahead_lengths * l, 0.5 * l, cruise) {
            return Some(s);
        }
        let mates = || percepts.iter().filter(|s| s.kind == PerceptKind::Fish);
        let mut parts: [(Steer, f32); 4] = [(agent.hold(), 0.0); 4];
        if let Some(s) = steer::separation(
            &agent,
            mates().map(|s| s.pos),
            p.separation_lengths * l,
            cruise,
        ) {
            parts[0] = (s, 2.0);
        }
        if let Some(s) = steer::alignment(&agent, mates().map(|s| s.heading), cruise) {
            parts[1] = (s, 1.0);
        }
        if let Some(s) = steer::cohesion(&agent, mates().map(|s| s.pos), cruise) {
            parts[2] = (s, 0.5);
        }
        let rng = controls.rng();
        let speed = cruise * rng.random_range(0.8..1.2);
        parts[3] = (
            steer::wander(
                rng,
                &agent,
                p.wander_turn,
                p.wander_depth_lengths * l,
                speed,
            ),
            1.0,
        );
        steer::blend(&parts)
    }
}

impl Behavior for WanderDriver {
    fn decide(&mut self, world: &mut Arc<World>) {
        self.decide_due(exclusive(world));
    }
}
