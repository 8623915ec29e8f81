//! Who is in the tank: spawning and despawning fish, dropping and eating food, rocks and
//! current zones, and the per-fish arrays read back in dense order.

use std::f32::consts::TAU;

use glam::Vec3;
use rand::{Rng, SeedableRng};
use rand_pcg::Pcg32;

use super::sense::wrap_angle;
use super::state::EATEN_HISTORY;
use super::store::NewFish;
use super::types::{finite, finite3};
use super::{
    Current, EAT_REACH_LENGTHS, FishId, Food, FoodId, Obstacle, ObstacleId, SpawnParams, SpeciesId,
    World, WorldError,
};
use crate::motion::{MotionPlayer, MotionRequest, RootState};

impl World {
    // ---- fish -------------------------------------------------------------------------------

    /// Spawns a fish. Fails on an unknown or invalid species, a NaN or infinite value (naming
    /// it), a negative speed, or a position outside the tank.
    pub fn spawn(&mut self, p: SpawnParams) -> Result<FishId, WorldError> {
        let species = self
            .catalog
            .species
            .get(usize::from(p.species.0))
            .ok_or(WorldError::UnknownSpecies(p.species))?;
        species.validate()?;
        finite3(["spawn pos.x", "spawn pos.y", "spawn pos.z"], p.pos)?;
        finite("spawn heading", p.heading)?;
        finite("spawn pitch", p.pitch)?;
        finite("spawn speed", p.speed)?;
        if p.speed < 0.0 {
            return Err(WorldError::OutOfRange {
                what: "spawn speed",
                value: p.speed,
                why: "must not be negative",
            });
        }
        if !self.state.tank.contains(p.pos) {
            return Err(WorldError::OutsideTank {
                what: "spawn pos",
                pos: p.pos,
                min: self.state.tank.min,
                max: self.state.tank.max,
            });
        }
        // Each fish's wave starts at its own phase (from its seed) so a shoal does not beat in
        // lockstep.
        let phase = Pcg32::seed_from_u64(p.seed ^ 0x005E_ED0F_F15E_u64).random::<f32>() * TAU;
        let mut player = MotionPlayer::with_phase(phase);
        if p.speed > 0.0 {
            player.push(MotionRequest::Swim { speed: p.speed })?;
        }
        let slots = self.catalog.plans[usize::from(p.species.0)].num_slots() as u32;
        let predator = species.desc.predator;
        let id = self.state.fish.insert(NewFish {
            root: RootState {
                pos: p.pos,
                heading: wrap_angle(p.heading),
                pitch: p.pitch,
                speed: p.speed,
            },
            species: p.species,
            player,
            behavior: p.behavior,
            seed: p.seed,
        });
        let last = *self.pose.palette_offsets.last().unwrap_or(&0);
        self.pose.palette_offsets.push(last + slots);
        self.pose.fish_revision = super::pose::buffers::next_fish_revision();
        if predator {
            self.index.predators.push(id);
        }
        self.index.spawned_since_grid.push(id);
        self.index.grid_exact = false;
        Ok(id)
    }

    /// Removes a fish. Returns false if `id` was already gone.
    pub fn despawn(&mut self, id: FishId) -> bool {
        if self.state.fish.remove(id).is_none() {
            return false;
        }
        if let Some(k) = self.index.predators.iter().position(|&p| p == id) {
            self.index.predators.swap_remove(k);
        }
        self.index.grid_exact = false;
        self.index.spawned_since_grid.retain(|&f| f != id);
        self.relayout_palettes();
        true
    }

    pub(super) fn relayout_palettes(&mut self) {
        self.pose.fish_revision = super::pose::buffers::next_fish_revision();
        self.pose.palette_offsets.clear();
        self.pose.palette_offsets.push(0);
        let mut total = 0u32;
        for &s in &self.state.fish.species {
            total += self.catalog.plans[usize::from(s.0)].num_slots() as u32;
            self.pose.palette_offsets.push(total);
        }
    }

    /// Whether `id` names a live fish.
    pub fn is_alive(&self, id: FishId) -> bool {
        self.state.fish.dense(id).is_some()
    }

    /// Number of live fish.
    pub fn num_fish(&self) -> usize {
        self.state.fish.len()
    }

    /// Live fish in dense order (deterministic: spawn order, with a despawned fish's place taken
    /// by the last one).
    pub fn fish_ids(&self) -> impl Iterator<Item = FishId> + '_ {
        self.state.fish.ids.iter().copied()
    }

    /// Fish that run a behaviour script, with their species, in dense order (read straight
    /// from the fish arrays: the behaviour stage picks the fish due each tick from this).
    pub fn scripted_fish(&self) -> impl Iterator<Item = (FishId, SpeciesId)> + '_ {
        let f = &self.state.fish;
        f.ids
            .iter()
            .zip(&f.species)
            .zip(&f.behaviors)
            .filter_map(|((&id, &species), b)| b.as_ref().map(|_| (id, species)))
    }

    /// Live fish handles, dense order.
    pub fn fish_id_slice(&self) -> &[FishId] {
        &self.state.fish.ids
    }

    /// Root states of all live fish, dense order (same order as [`World::fish_ids`]).
    pub fn roots(&self) -> &[RootState] {
        &self.state.fish.roots
    }

    /// Species of all live fish, dense order.
    pub fn fish_species(&self) -> &[SpeciesId] {
        &self.state.fish.species
    }

    /// A fish's root state.
    pub fn root(&self, id: FishId) -> Option<&RootState> {
        self.state.fish.dense(id).map(|d| &self.state.fish.roots[d])
    }

    /// A fish's species.
    pub fn species_of(&self, id: FishId) -> Option<SpeciesId> {
        self.state
            .fish
            .dense(id)
            .map(|d| self.state.fish.species[d])
    }

    /// The behaviour script a fish runs.
    pub fn behavior_of(&self, id: FishId) -> Option<&str> {
        self.behavior_name_of(id).map(|name| &**name)
    }

    /// [`World::behavior_of`] as the name's shared allocation: fish running the same behaviour
    /// hold the same one, so callers can tell names apart by pointer.
    pub fn behavior_name_of(&self, id: FishId) -> Option<&std::sync::Arc<str>> {
        self.state
            .fish
            .dense(id)
            .and_then(|d| self.state.fish.behaviors[d].as_ref())
    }

    /// The distinct behaviours the fish run, in the order first met (dense order). Chunks of
    /// fish are scanned over rayon's threads and their lists joined in chunk order, so the
    /// order is the same whatever the thread count.
    pub fn behavior_names(&self) -> Vec<std::sync::Arc<str>> {
        use rayon::prelude::*;
        use std::sync::Arc;
        fn add(names: &mut Vec<Arc<str>>, b: &Arc<str>) {
            if !names.iter().any(|n| Arc::ptr_eq(n, b) || **n == **b) {
                names.push(Arc::clone(b));
            }
        }
        let per_chunk: Vec<Vec<Arc<str>>> = self
            .state
            .fish
            .behaviors
            .par_chunks(8192)
            .map(|chunk| {
                let mut names = Vec::new();
                let mut last: Option<&Arc<str>> = None;
                for b in chunk.iter().flatten() {
                    if last.is_some_and(|l| Arc::ptr_eq(l, b)) {
                        continue;
                    }
                    last = Some(b);
                    add(&mut names, b);
                }
                names
            })
            .collect();
        let mut names = Vec::new();
        for b in per_chunk.iter().flatten() {
            add(&mut names, b);
        }
        names
    }

    /// Sets (or clears) the behaviour a fish runs. False if `id` is stale.
    pub fn set_behavior(&mut self, id: FishId, behavior: Option<String>) -> bool {
        let Some(d) = self.state.fish.dense(id) else {
            return false;
        };
        self.state.fish.behaviors[d] = behavior.map(|name| self.state.fish.intern(name));
        true
    }

    // ---- food, obstacles, currents ----------------------------------------------------------

    /// Drops a food pellet at `pos` (clamped into the tank; a non-finite coordinate becomes the
    /// tank's centre on that axis).
    pub fn add_food(&mut self, pos: Vec3) -> FoodId {
        let tank = self.state.tank;
        let centre = (tank.min + tank.max) * 0.5;
        let pos = Vec3::select(pos.is_finite_mask(), pos, centre).clamp(tank.min, tank.max);
        let id = FoodId(self.state.next_food);
        self.state.next_food += 1;
        self.state.foods.push((
            id,
            Food {
                pos,
                eaten: false,
                eaten_by: None,
                eaten_at: None,
                dropped_at: self.state.time,
                settled: false,
            },
        ));
        id
    }

    /// Where pellet `id` is in the water, if it is.
    pub(super) fn food_index(&self, id: FoodId) -> Option<usize> {
        self.state.foods.binary_search_by_key(&id, |(i, _)| *i).ok()
    }

    /// A food pellet: one in the water, or one of the last [`EATEN_HISTORY`] eaten (with who ate
    /// it and when). `None` for an id never given, or a pellet eaten longer ago than that (see
    /// [`World::was_eaten`]).
    pub fn food(&self, id: FoodId) -> Option<&Food> {
        if let Some(i) = self.food_index(id) {
            return Some(&self.state.foods[i].1);
        }
        self.state
            .eaten
            .binary_search_by_key(&id, |(i, _)| *i)
            .ok()
            .map(|i| &self.state.eaten[i].1)
    }

    /// Whether pellet `id` was given out and has been eaten, however long ago: `false` for a
    /// pellet in the water or one that dissolved uneaten (see [`super::FoodPhysics`]). A pellet
    /// older than every one the eaten history remembers counts as eaten once it has left the
    /// water.
    pub fn was_eaten(&self, id: FoodId) -> bool {
        if id.0 >= self.state.next_food || self.food_index(id).is_some() {
            return false;
        }
        let eaten = &self.state.eaten;
        let remembered = eaten.binary_search_by_key(&id, |(i, _)| *i).is_ok();
        let before_history =
            eaten.len() == EATEN_HISTORY && eaten.front().is_some_and(|(first, _)| id < *first);
        remembered || before_history
    }

    /// The pellets in the water, in the order they were dropped.
    pub fn foods(&self) -> impl Iterator<Item = (FoodId, &Food)> {
        self.state.foods.iter().map(|(id, f)| (*id, f))
    }

    /// The last [`EATEN_HISTORY`] pellets eaten, in the order they were dropped.
    pub fn eaten_foods(&self) -> impl Iterator<Item = (FoodId, &Food)> {
        self.state.eaten.iter().map(|(id, f)| (*id, f))
    }

    /// Whether the fish could eat the pellet now: it is in the water and lies within
    /// [`EAT_REACH_LENGTHS`] body lengths of the fish's mouth (its root).
    pub fn can_eat(&self, fish: FishId, food: FoodId) -> bool {
        let Some(d) = self.state.fish.dense(fish) else {
            return false;
        };
        let reach = EAT_REACH_LENGTHS
            * self.catalog.species[usize::from(self.state.fish.species[d].0)].body_length();
        let mouth = self.state.fish.roots[d].pos;
        self.food_index(food)
            .is_some_and(|i| self.state.foods[i].1.pos.distance(mouth) <= reach)
    }

    /// The fish eats the pellet if [`World::can_eat`]: the pellet leaves the water (and the
    /// food grid, which is searched linearly until the next [`World::rebuild_grid`]) and joins
    /// the eaten history. Returns whether it ate.
    pub fn try_eat(&mut self, fish: FishId, food: FoodId) -> bool {
        if !self.can_eat(fish, food) {
            return false;
        }
        self.take_food(food, Some(fish))
    }

    /// Takes pellet `food` out of the water into the eaten history (eaten by `by`, now).
    /// False if it is not in the water.
    pub(super) fn take_food(&mut self, food: FoodId, by: Option<FishId>) -> bool {
        let Some(i) = self.food_index(food) else {
            return false;
        };
        let (id, mut f) = self.state.foods.remove(i);
        f.eaten = true;
        f.eaten_by = by;
        f.eaten_at = Some(self.state.time);
        // Kept in id order (pellets are not eaten in the order they were dropped), which
        // `food` and `was_eaten` search by; when full, the oldest pellet is forgotten.
        if self.state.eaten.len() == EATEN_HISTORY {
            self.state.eaten.pop_front();
        }
        let at = self.state.eaten.partition_point(|(i, _)| *i < id);
        self.state.eaten.insert(at, (id, f));
        // The grid's keys are positions in the list, which just shifted.
        self.index.food_changed();
        true
    }

    /// Adds a spherical obstacle (non-finite or negative values are clamped to the tank centre
    /// and radius 0).
    pub fn add_obstacle(&mut self, pos: Vec3, radius: f32) -> ObstacleId {
        let centre = (self.state.tank.min + self.state.tank.max) * 0.5;
        let pos = Vec3::select(pos.is_finite_mask(), pos, centre);
        let radius = if radius.is_finite() {
            radius.max(0.0)
        } else {
            0.0
        };
        self.state.obstacles.push(Obstacle { pos, radius });
        ObstacleId((self.state.obstacles.len() - 1) as u32)
    }

    /// Replaces every obstacle (the window's scene edits), each as [`World::add_obstacle`]
    /// takes it.
    pub fn set_obstacles(&mut self, obstacles: impl IntoIterator<Item = (Vec3, f32)>) {
        self.state.obstacles.clear();
        for (pos, radius) in obstacles {
            self.add_obstacle(pos, radius);
        }
    }

    /// All obstacles, by [`ObstacleId`].
    pub fn obstacles(&self) -> &[Obstacle] {
        &self.state.obstacles
    }

    /// Adds a current zone (ignored if any value is not finite).
    pub fn add_current(&mut self, c: Current) {
        if c.pos.is_finite() && c.velocity.is_finite() && c.radius.is_finite() && c.radius > 0.0 {
            self.state.currents.push(c);
        } else {
            log::warn!("ignoring current with non-finite or non-positive values: {c:?}");
        }
    }

    /// Replaces every current zone (the window's scene edits), each as [`World::add_current`]
    /// takes it.
    pub fn set_currents(&mut self, currents: impl IntoIterator<Item = Current>) {
        self.state.currents.clear();
        for c in currents {
            self.add_current(c);
        }
    }

    /// All current zones.
    pub fn currents(&self) -> &[Current] {
        &self.state.currents
    }
}
