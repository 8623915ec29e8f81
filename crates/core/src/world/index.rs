//! [`SpatialIndex`]: what the grid stage derives from the [`WorldState`] so that the next tick's
//! sensors answer fast — the fish and food grids, the crowding columns, the predators packed for
//! their scan — and how far it is still valid.
//!
//! The world keeps it beside the state and the pose buffers (`pose_buffers.rs`), as Rapier's
//! pipeline keeps its broad phase beside the body set: the grid stage ([`SpatialIndex::rebuild`])
//! takes the state explicitly, and the state's edits (spawning, despawning, eating, moving) mark
//! what they invalidate here. The sensors (`perception.rs`, `crowd.rs`, `nearest.rs`) read both.

use std::sync::atomic::{AtomicBool, Ordering};

use super::grid::Grid;
use super::{FishId, Species, SpeciesId, Tank, WorldState, crowd, nearest};

/// The grid's cell size as a share of the longest view range (see [`SpatialIndex::rebuild`]).
pub(super) const GRID_CELL_OF_VIEW: f32 = 0.45;

/// The spatial index of a world (see the module docs).
pub(super) struct SpatialIndex {
    /// Live fish of species whose description marks them predators (see `nearest.rs`).
    pub(super) predators: Vec<FishId>,
    /// The predator fish as of the last grid rebuild, packed for the scan in `nearest.rs`
    /// (position, species, id, dense index side by side: one cache line per few predators
    /// instead of four scattered reads each). Valid while the grid is exact and current.
    pub(super) predator_spots: Vec<nearest::PredatorSpot>,
    /// The predator spots on a grid of their own (keys: indices into `predator_spots`), so a
    /// fish looking for the nearest predator visits the cells near it, not every predator.
    pub(super) predator_grid: Grid,
    pub(super) grid: Grid,
    /// Fish in the grid, by grid key (the dense index at rebuild time).
    pub(super) grid_ids: Vec<FishId>,
    /// No fish was spawned or despawned since the rebuild: grid keys are dense indices.
    pub(super) grid_exact: bool,
    /// Additionally no fish moved since the rebuild: the grid's positions are the roots'.
    pub(super) grid_positions_current: bool,
    /// Fish spawned since the last rebuild (searched linearly until the next one).
    pub(super) spawned_since_grid: Vec<FishId>,
    /// Per grid slot (the grid's cell order): the fish's species at the rebuild.
    pub(super) grid_species: Vec<SpeciesId>,
    /// Per grid slot: what the crowding rules read of each candidate (position, heading cosine
    /// and sine, species, dense index), one column per field; filled only while crowd queries
    /// are being made (`crowd_wanted`), else empty.
    pub(super) crowd_columns: crowd::CrowdColumns,
    /// A crowd query ran since the last rebuild: the next rebuild fills `crowd_columns`. Worlds
    /// whose behaviours never ask do not pay for the cosines.
    pub(super) crowd_wanted: AtomicBool,
    pub(super) food_grid: Grid,
    /// Live pellets `0..food_in_grid` (positions in `state.foods`) are in `food_grid`; later
    /// ones are searched linearly. Eating a pellet empties the grid until the next rebuild.
    pub(super) food_in_grid: usize,
}

impl SpatialIndex {
    /// An empty index over `tank`.
    pub(super) fn new(tank: &Tank) -> Self {
        let grid = Grid::new(tank.min, tank.max, tank.extent().max_element() / 16.0);
        Self {
            predators: Vec::new(),
            predator_spots: Vec::new(),
            predator_grid: grid.clone(),
            food_grid: grid.clone(),
            grid,
            grid_ids: Vec::new(),
            grid_exact: true,
            grid_positions_current: true,
            spawned_since_grid: Vec::new(),
            grid_species: Vec::new(),
            crowd_columns: crowd::CrowdColumns::default(),
            crowd_wanted: AtomicBool::new(false),
            food_in_grid: 0,
        }
    }

    /// The fish moved (a motion stage): the grid's positions are no longer the roots'.
    pub(super) fn fish_moved(&mut self) {
        self.grid_positions_current = false;
    }

    /// The pellets changed other than by being added (one was eaten, the grids were
    /// reconfigured): the food grid is searched linearly until the next rebuild.
    pub(super) fn food_changed(&mut self) {
        self.food_in_grid = 0;
    }

    /// The grid stage: rebuilds the spatial grid from the fish's current positions (and the
    /// food grid), with cells of [`GRID_CELL_OF_VIEW`] of the longest view range among
    /// `species`, and packs what the crowding and predator scans read.
    ///
    /// `headings_written`: the pass that moved the fish also wrote their heading vectors into
    /// the crowd columns' scratch ([`crowd::CrowdColumns::headings_to_fill`]; `World::advance`),
    /// so the columns, if wanted, do not take them again.
    pub(super) fn rebuild(
        &mut self,
        state: &WorldState,
        species: &[Species],
        headings_written: bool,
    ) {
        let extent = state.tank.extent().max_element();
        let view = species
            .iter()
            .map(|s| s.desc.view_range)
            .filter(|r| r.is_finite() && *r > 0.0)
            .fold(0.0f32, f32::max);
        // Cells of 0.45 of the longest view: queries cull the cells they visit row by row to
        // their sphere, so smaller cells fit it closer, but each row of cells a query visits
        // costs its own setup and two lookups in the cell table. With the barracuda's 500-unit
        // view, 150-unit cells (0.3) scanned 23 % fewer instructions than 250-unit ones at
        // 2,000 fish (callgrind), yet 225-unit cells (0.45) took the 100,000-fish tick (level
        // of detail on) from 30.4 to 29.1 ms, the 10,000-fish tick (off) from 4.52 to 4.31 ms
        // and sensing 9–15 % a decision (docs/performance.md, 2026-12-07); 100-unit cells
        // (0.2) were slower, 0.38, 0.52 and 0.6 within noise of 0.45. Full-range cells visit
        // ~5x the sphere's volume. No smaller than 1/64 of the tank, so a tiny view range
        // cannot explode the count.
        let cell = if view > 0.0 {
            (GRID_CELL_OF_VIEW * view).max(extent / 64.0)
        } else {
            extent / 16.0
        };
        if (cell - self.grid.cell_size()).abs() > 1e-6 * cell {
            self.grid.configure(state.tank.min, state.tank.max, cell);
            self.food_grid
                .configure(state.tank.min, state.tank.max, cell);
            self.food_changed();
        }
        use rayon::prelude::*;
        let (roots, fish_species) = (&state.fish.roots, &state.fish.species);
        // Over both cores: at 100,000 fish the serial rebuild took ~9 ms a tick, ~6 ms now.
        self.grid.rebuild_indexed(roots.len(), |i| roots[i].pos);
        self.grid_ids.clone_from(&state.fish.ids);
        // What the crowding rules read per neighbour, copied into the grid's cell order so
        // their scans read contiguous memory (see `crowd.rs`); the headings' cosines and sines
        // (over both cores) only if crowd queries were made since the last rebuild.
        let keys = self.grid.keys();
        self.grid_species.clear();
        self.grid_species.par_extend(
            keys.par_iter()
                .with_min_len(4096)
                .map(|&k| fish_species[k as usize]),
        );
        let wanted = self.crowd_wanted.swap(false, Ordering::Relaxed);
        if wanted {
            self.crowd_columns.fill(
                keys,
                self.grid.positions(),
                &self.grid_species,
                roots.len(),
                (!headings_written).then_some(|k: usize| roots[k].heading),
                |k| state.fish.ids[k].index,
            );
        } else {
            self.crowd_columns.clear();
        }
        self.refresh_predator_spots(state);
        self.grid_exact = true;
        self.grid_positions_current = true;
        self.spawned_since_grid.clear();
        if self.food_in_grid != state.foods.len() {
            self.food_grid.rebuild(
                state
                    .foods
                    .iter()
                    .enumerate()
                    .map(|(i, (_, f))| (i as u32, f.pos)),
            );
            self.food_in_grid = state.foods.len();
        }
    }

    /// Packs the predators' positions, species and ids for the scan in `nearest.rs`.
    pub(super) fn refresh_predator_spots(&mut self, state: &WorldState) {
        let fish = &state.fish;
        self.predator_spots.clear();
        self.predator_spots
            .extend(self.predators.iter().filter_map(|&p| {
                let d = fish.dense(p)?;
                Some(nearest::PredatorSpot::new(
                    fish.roots[d].pos,
                    fish.species[d],
                    p.index,
                    d as u32,
                ))
            }));
        let cell = self.grid.cell_size();
        if (cell - self.predator_grid.cell_size()).abs() > 1e-6 * cell {
            self.predator_grid
                .configure(state.tank.min, state.tank.max, cell);
        }
        self.predator_grid.rebuild(
            self.predator_spots
                .iter()
                .enumerate()
                .map(|(i, s)| (i as u32, s.pos())),
        );
    }
}
