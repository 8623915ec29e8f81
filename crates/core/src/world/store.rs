//! Fish state as a structure of arrays (issue 7), addressed by generational handles.
//!
//! Every per-fish field is its own dense array, indexed the same way, so a stage that needs only
//! roots and species (the grid, the pose job) streams only those. Despawning swaps the last fish
//! into the hole, so the arrays stay dense; handles survive that because a slot table maps each
//! handle's `index` to its dense position, and a per-slot generation makes stale handles miss.

use std::sync::Arc;

use rand::SeedableRng;
use rand_pcg::Pcg32;

use super::steer::SteerMemo;
use super::{FishId, MAX_DRIVEN_JOINTS, SpeciesId};
use crate::motion::{MotionPlayer, RootState};

/// Marks a free slot in the slot table.
const FREE: u32 = u32::MAX;

/// What a new fish starts with.
pub(crate) struct NewFish {
    pub root: RootState,
    pub species: SpeciesId,
    pub player: MotionPlayer,
    pub behavior: Option<String>,
    pub seed: u64,
}

/// The fish arrays. Fields are dense and parallel: entry `i` of each belongs to the same fish.
#[derive(Clone, Debug, Default, PartialEq)]
pub(crate) struct FishStore {
    generation: Vec<u32>,
    dense_of: Vec<u32>,
    free: Vec<u32>,

    pub ids: Vec<FishId>,
    pub roots: Vec<RootState>,
    pub species: Vec<SpeciesId>,
    /// Boxed: a decision checks a fish's player out of the world and back in (a sequential
    /// step of the tick), which then moves a pointer instead of ~190 bytes each way.
    #[allow(clippy::vec_box)]
    pub players: Vec<Box<MotionPlayer>>,
    /// Driven joints' local yaw, radians; the first `body.power.len()` entries are used. Written
    /// by the motion stage when it evaluates the body's shape (not in GPU pose mode: see
    /// `World::shape_of`); a function of the player's state, so it never changes the future.
    pub yaw: Vec<[f32; MAX_DRIVEN_JOINTS]>,
    /// Midline lateral displacement at `body.joints_x`, world units; first `joints_x.len()` used
    /// (written with `yaw`).
    pub lateral: Vec<[f32; MAX_DRIVEN_JOINTS + 1]>,
    /// Each fish's behaviour, by name. Fish running the same behaviour share one allocation
    /// ([`FishStore::intern`]), so a state clones without copying names and the behaviour stage
    /// finds a fish's module by pointer.
    pub behaviors: Vec<Option<Arc<str>>>,
    pub seeds: Vec<u64>,
    pub rngs: Vec<Pcg32>,
    pub contact: Vec<bool>,
    pub steer: Vec<SteerMemo>,
    /// The tick each fish last decided (0 before its first decision): the level-of-detail
    /// schedule wakes a slow fish only if it has not decided for a whole base period.
    pub last_decided: Vec<u64>,
    /// Whether a predator or pellet was in the fish's view range when it last decided (the
    /// level-of-detail schedule wakes it when one comes into view, not while one stays).
    pub alerted: Vec<bool>,
    /// The squared distance to the nearest predator of another species in the fish's view
    /// range when it last decided (infinite: none): the schedule wakes a slow fish when one
    /// has closed in since ([`super::lod::THREAT_CLOSING`]).
    pub threat_seen: Vec<f32>,
}

impl FishStore {
    pub fn len(&self) -> usize {
        self.ids.len()
    }

    /// How many slots this store has issued (live and free): a despawn frees a slot but never
    /// removes it, so a value derived from this (the level-of-detail schedule's phase block)
    /// changes only when spawns outgrow it, or when a restore brings back an earlier store.
    pub fn slots(&self) -> usize {
        self.generation.len()
    }

    /// Dense position of `id`, or `None` if it is stale or was never issued.
    pub fn dense(&self, id: FishId) -> Option<usize> {
        let slot = id.index as usize;
        let dense = *self.dense_of.get(slot)?;
        (dense != FREE && self.generation[slot] == id.generation).then_some(dense as usize)
    }

    pub fn insert(&mut self, fish: NewFish) -> FishId {
        let index = match self.free.pop() {
            Some(slot) => slot,
            None => {
                self.generation.push(0);
                self.dense_of.push(FREE);
                (self.generation.len() - 1) as u32
            }
        };
        let id = FishId {
            index,
            generation: self.generation[index as usize],
        };
        self.dense_of[index as usize] = self.ids.len() as u32;
        self.ids.push(id);
        self.roots.push(fish.root);
        self.species.push(fish.species);
        self.players.push(Box::new(fish.player));
        self.yaw.push([0.0; MAX_DRIVEN_JOINTS]);
        self.lateral.push([0.0; MAX_DRIVEN_JOINTS + 1]);
        let behavior = fish.behavior.map(|name| self.intern(name));
        self.behaviors.push(behavior);
        self.seeds.push(fish.seed);
        self.rngs.push(Pcg32::seed_from_u64(fish.seed));
        self.contact.push(false);
        self.steer.push(SteerMemo::default());
        self.last_decided.push(0);
        self.alerted.push(false);
        self.threat_seen.push(f32::INFINITY);
        id
    }

    /// `name` as a shared behaviour name: the allocation a fish already running it holds, else a
    /// new one. Called when a fish is added or switches behaviour. Scans the fish from the most
    /// recent, comparing text only where the allocation changes (a few distinct names live at a
    /// time), so a batch of fish with one behaviour shares it at once.
    pub fn intern(&self, name: String) -> Arc<str> {
        let mut last: Option<&Arc<str>> = None;
        for b in self.behaviors.iter().rev().flatten() {
            if last.is_some_and(|l| Arc::ptr_eq(l, b)) {
                continue;
            }
            if **b == *name {
                return Arc::clone(b);
            }
            last = Some(b);
        }
        Arc::from(name)
    }

    /// Removes `id`; the last fish moves into its dense position. Returns the dense position
    /// that was vacated, or `None` if `id` was stale.
    pub fn remove(&mut self, id: FishId) -> Option<usize> {
        let dense = self.dense(id)?;
        let slot = id.index as usize;
        self.generation[slot] = self.generation[slot].wrapping_add(1);
        self.dense_of[slot] = FREE;
        self.free.push(id.index);
        self.ids.swap_remove(dense);
        self.roots.swap_remove(dense);
        self.species.swap_remove(dense);
        self.players.swap_remove(dense);
        self.yaw.swap_remove(dense);
        self.lateral.swap_remove(dense);
        self.behaviors.swap_remove(dense);
        self.seeds.swap_remove(dense);
        self.rngs.swap_remove(dense);
        self.contact.swap_remove(dense);
        self.steer.swap_remove(dense);
        self.last_decided.swap_remove(dense);
        self.alerted.swap_remove(dense);
        self.threat_seen.swap_remove(dense);
        if let Some(moved) = self.ids.get(dense) {
            self.dense_of[moved.index as usize] = dense as u32;
        }
        Some(dense)
    }
}
