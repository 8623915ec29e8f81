//! [`WorldState`]: everything that defines a world at a tick, as plain data.
//!
//! Fish (roots, motion players, joint arrays, behaviours, random generators, steering memos),
//! food, rocks, currents, the scene's own random generator and food-drop clock, and the clock.
//! It can be cloned, compared and put back ([`World::snapshot`], [`World::restore`]); what the
//! world derives from it — the spatial grids, the predator list, the palette layout and the
//! palettes — is rebuilt on restore. Species are the world's configuration, not its state: a
//! restored state runs with the species loaded now (so a rewound world replays under edited
//! species files).

use std::collections::VecDeque;

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg32;

use super::food::FoodPhysics;
use super::store::FishStore;
use super::{Current, Food, FoodId, Obstacle, Tank, World};

/// How many eaten pellets the world remembers (who ate them, when), for [`World::food`].
pub const EATEN_HISTORY: usize = 4096;

/// Periodic food drops (a scene's `food_drops`): `count` pellets every `every` seconds from
/// `start`, at random points of `region` (default: a thin layer under the surface).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct FoodDrops {
    /// Seconds between drops; a drop happens only if this is positive.
    pub every: f32,
    /// Pellets per drop.
    pub count: u32,
    /// Time of the first drop, seconds.
    pub start: f32,
    /// Where pellets appear (lower and upper corner), or `None` for under the surface.
    pub region: Option<(Vec3, Vec3)>,
}

/// Everything that defines a world at a tick (see the module docs). Two worlds with equal states
/// and the same species run the same future. (Not conversely: a world posing on the GPU leaves
/// its fish's joint arrays and the players' head recoil, which the future never reads, stale;
/// [`World::restore`] and the CPU pose stage bring them up to date.)
#[derive(Clone, Debug, PartialEq)]
pub struct WorldState {
    /// The tank.
    pub tank: Tank,
    /// The seed the world was created with.
    pub seed: u64,
    /// Simulated time, seconds.
    pub time: f64,
    /// Motion steps taken.
    pub tick: u64,
    /// The fish.
    pub(super) fish: FishStore,
    /// Pellets in the water, in the order they were dropped (their ids increase).
    pub(super) foods: Vec<(FoodId, Food)>,
    /// The pellets eaten, in id order (the order they were dropped); at most [`EATEN_HISTORY`],
    /// the oldest forgotten first.
    pub(super) eaten: VecDeque<(FoodId, Food)>,
    /// The id the next pellet gets.
    pub(super) next_food: u32,
    /// Rocks, by [`super::ObstacleId`].
    pub(super) obstacles: Vec<Obstacle>,
    /// Current zones.
    pub(super) currents: Vec<Current>,
    /// The scene's random generator: placements, fish seeds, food drops.
    pub(super) scene_rng: Pcg32,
    /// Periodic food drops, if the scene has them.
    pub(super) food_drops: Option<FoodDrops>,
    /// Time of the next food drop, seconds.
    pub(super) next_drop_s: f64,
    /// How pellets sink and how long they last.
    pub(super) food_physics: FoodPhysics,
    /// Whether the world's last grid rebuild filled the crowd columns (see `index.rs`; the grid
    /// stage keeps it current). The crowd queries sum over the columns
    /// in another order than over the fish arrays, so the sums round differently; a restored
    /// world fills the columns exactly when the snapshot's world had them, or a replay from a
    /// snapshot parts from its recording (70 of 10,000 fish did, one tick after the snapshot).
    pub(super) crowd_columns: bool,
}

impl WorldState {
    /// The state of an empty world.
    pub(super) fn new(tank: Tank, seed: u64) -> Self {
        Self {
            tank,
            seed,
            time: 0.0,
            tick: 0,
            fish: FishStore::default(),
            foods: Vec::new(),
            eaten: VecDeque::new(),
            next_food: 0,
            obstacles: Vec::new(),
            currents: Vec::new(),
            scene_rng: Pcg32::seed_from_u64(seed ^ 0x5eed_5cee),
            food_drops: None,
            next_drop_s: f64::INFINITY,
            food_physics: FoodPhysics::default(),
            crowd_columns: false,
        }
    }

    /// Number of live fish.
    pub fn num_fish(&self) -> usize {
        self.fish.len()
    }

    /// Number of pellets in the water.
    pub fn num_foods(&self) -> usize {
        self.foods.len()
    }

    /// Bytes this state holds (its arrays' capacity and behaviour names, not counting
    /// allocator overhead): what keeping one costs, for the window's history ring.
    pub fn approx_bytes(&self) -> usize {
        use std::mem::size_of_val;
        fn vec<T>(v: &Vec<T>) -> usize {
            v.capacity() * std::mem::size_of::<T>()
        }
        let f = &self.fish;
        // Each shared name once (fish running one behaviour hold the same allocation).
        let mut distinct: Vec<&std::sync::Arc<str>> = Vec::new();
        for b in f.behaviors.iter().flatten() {
            if !distinct.iter().any(|d| std::sync::Arc::ptr_eq(d, b)) {
                distinct.push(b);
            }
        }
        let names: usize = distinct.iter().map(|b| b.len()).sum();
        size_of_val(self)
            + vec(&f.ids)
            + vec(&f.roots)
            + vec(&f.species)
            + vec(&f.players)
            + vec(&f.yaw)
            + vec(&f.lateral)
            + vec(&f.behaviors)
            + names
            + vec(&f.seeds)
            + vec(&f.rngs)
            + vec(&f.contact)
            + vec(&f.steer)
            + vec(&f.last_decided)
            + vec(&f.alerted)
            + vec(&f.threat_seen)
            + vec(&self.foods)
            + self.eaten.capacity() * std::mem::size_of::<(FoodId, Food)>()
            + vec(&self.obstacles)
            + vec(&self.currents)
    }
}

/// A random point of the box `min`..`max` (corners in any order; a flat axis gives its value),
/// one draw per axis, x then y then z.
pub fn random_point(rng: &mut Pcg32, min: Vec3, max: Vec3) -> Vec3 {
    let mut p = Vec3::ZERO;
    for i in 0..3 {
        let (lo, hi) = (min[i].min(max[i]), min[i].max(max[i]));
        p[i] = if hi > lo {
            rng.random_range(lo..hi)
        } else {
            lo
        };
    }
    p
}

impl World {
    /// A copy of the world's state (see [`WorldState`]).
    pub fn snapshot(&self) -> WorldState {
        self.state.clone()
    }

    /// Puts back a state taken by [`World::snapshot`] of this world (or of a world with the same
    /// species), and rebuilds what the world derives from it: the predator list, the palette
    /// layout, the grids, and the palettes. The world then runs exactly as it did from the
    /// snapshot's tick.
    pub fn restore(&mut self, state: WorldState) -> Result<(), super::WorldError> {
        if let Some(&s) = state
            .fish
            .species
            .iter()
            .find(|s| usize::from(s.0) >= self.catalog.species.len())
        {
            return Err(super::WorldError::UnknownSpecies(s));
        }
        let tank_changed = state.tank != self.state.tank;
        self.state = state;
        if tank_changed {
            let fresh = Self::from_state(self.state.clone());
            self.index.grid = fresh.index.grid;
            self.index.food_grid = fresh.index.food_grid;
        }
        self.index.food_changed();
        // The columns exactly when the snapshot's world had them (see `WorldState::crowd_columns`).
        self.index.crowd_wanted.store(
            self.state.crowd_columns,
            std::sync::atomic::Ordering::Relaxed,
        );
        // The state may come from a world that left the body shapes to the GPU.
        self.pose.shapes_current = false;
        self.refresh_predators();
        self.relayout_palettes();
        self.rebuild_grid();
        self.update_pose();
        Ok(())
    }

    /// The scene's random generator (placements and fish seeds; food drops draw from it too).
    pub fn scene_rng(&mut self) -> &mut Pcg32 {
        &mut self.state.scene_rng
    }

    /// Sets the periodic food drops (`None`: none); the first drop happens at `drops.start`.
    pub fn set_food_drops(&mut self, drops: Option<FoodDrops>) {
        self.state.next_drop_s = drops.map_or(f64::INFINITY, |d| f64::from(d.start));
        self.state.food_drops = drops;
    }

    /// The scene-events stage: drops the pellets of a food drop that is due.
    pub fn scene_events(&mut self) {
        let Some(drops) = self.state.food_drops else {
            return;
        };
        let now = self.state.time;
        if now + 1e-9 < self.state.next_drop_s || drops.every.is_nan() || drops.every <= 0.0 {
            return;
        }
        self.state.next_drop_s += f64::from(drops.every);
        let tank = self.state.tank;
        let (min, max) = drops.region.unwrap_or((
            Vec3::new(tank.min.x * 0.8, tank.max.y * 0.95, tank.min.z * 0.8),
            Vec3::new(tank.max.x * 0.8, tank.max.y * 0.97, tank.max.z * 0.8),
        ));
        for _ in 0..drops.count {
            let p = random_point(&mut self.state.scene_rng, min, max);
            self.add_food(p);
        }
    }
}
