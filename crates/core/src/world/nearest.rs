//! The nearest thing of a kind a fish sees, without building its whole view.
//!
//! Behaviours mostly ask for one thing — the nearest predator, the nearest food — and in a dense
//! school the view holds hundreds of fish. [`World::nearest_in_view`] keeps only the best
//! candidate of the kind asked for (the least [`Seen`] key: nearest, then lowest id, vision's
//! own order), so it answers exactly what [`World::vision`] lists first of that kind. Predators
//! are few (one fish in a hundred in the bench scene), so while the grid is current they are
//! found from the world's list of predator fish instead of scanning every fish in range.

use glam::Vec3;

use super::perception::Seen;
use super::{FishId, Percept, PerceptKind, SpeciesId, World};

/// Where [`World::nearest_seen`] looks for predators.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(not(test), allow(dead_code))] // the tests force each route
pub(super) enum Route {
    /// The predator list when it is the cheaper way, else the grid.
    Auto,
    /// Every fish in range, from the grid.
    Grid,
    /// The world's list of predator fish (only valid while the grid is current).
    #[cfg(test)]
    List,
}

impl World {
    /// The first percept of `kind` (and, if given, of `species`) that [`World::vision`] would
    /// list for the fish: the nearest such thing in view, ties broken by id, with the same
    /// fields. Food and obstacles have no species, so asking for them with a species finds
    /// nothing. `None` for a stale id or when nothing of the kind is in view.
    ///
    /// Only the winner is kept (no list is built or sorted). Predators are taken from the
    /// world's list of fish of predator species when that is shorter than the fish the grid
    /// would scan, and the grid is current (nothing moved since [`World::rebuild_grid`]).
    pub fn nearest_in_view(
        &self,
        id: FishId,
        kind: PerceptKind,
        species: Option<SpeciesId>,
    ) -> Option<Percept> {
        let d = self.state.fish.dense(id)?;
        let seen = self.nearest_seen(d, kind, species, Route::Auto)?;
        Some(self.percept_of(&self.state.fish.roots[d], seen))
    }

    /// Fish of predator species now alive, in no particular order.
    pub fn predator_fish(&self) -> &[FishId] {
        &self.index.predators
    }

    /// [`World::nearest_in_view`]'s winner for dense fish `d`, as a sort key.
    pub(super) fn nearest_seen(
        &self,
        d: usize,
        kind: PerceptKind,
        species: Option<SpeciesId>,
        route: Route,
    ) -> Option<Seen> {
        let view = self.view_of(d);
        let mut best: Option<Seen> = None;
        let mut keep = |s: Seen| {
            if best.is_none_or(|b| s.key < b.key) {
                best = Some(s);
            }
        };
        match kind {
            PerceptKind::Fish | PerceptKind::Predator => {
                let of_species = |s: SpeciesId| species.is_none_or(|want| s == want);
                let use_list = match route {
                    Route::Auto => {
                        kind == PerceptKind::Predator && self.predator_list_pays(view.range)
                    }
                    Route::Grid => false,
                    #[cfg(test)]
                    Route::List => kind == PerceptKind::Predator,
                };
                if use_list {
                    // The grid's set, without the grid: every predator within range now (the
                    // grid is current, so the spots' positions are the roots').
                    let r2 = view.range * view.range;
                    for spot in &self.index.predator_spots {
                        let d2 = spot.pos.distance_squared(view.pos);
                        if d2 > r2 || spot.dense as usize == d {
                            continue;
                        }
                        if self.fish_kind(view.species, spot.species) != kind
                            || !of_species(spot.species)
                        {
                            continue;
                        }
                        if view.cone.contains(spot.pos) {
                            keep(Seen::new(d2.sqrt(), kind, spot.index, spot.dense));
                        }
                    }
                } else {
                    self.fish_seen(
                        d,
                        &view,
                        |o, k| k == kind && of_species(self.state.fish.species[o]),
                        &mut keep,
                    );
                }
            }
            PerceptKind::Food if species.is_none() => self.food_seen(&view, &mut keep),
            PerceptKind::Obstacle if species.is_none() => self.obstacles_seen(&view, &mut keep),
            PerceptKind::Food | PerceptKind::Obstacle => {}
        }
        best
    }

    /// Whether walking the predator list beats scanning the grid for a view of `range`: the
    /// grid must be current (the list gives current positions, the grid's set is as of its
    /// rebuild), and the list shorter than half the fish in the cells the grid would visit
    /// (a cube of 2·range plus a cell a side, capped by the tank).
    fn predator_list_pays(&self, range: f32) -> bool {
        let valid_range = range >= 0.0; // false for NaN, as the grid's own test
        if !(self.index.grid_exact && self.index.grid_positions_current && valid_range) {
            return false;
        }
        let extent = self.state.tank.extent().max(Vec3::splat(1e-6));
        let side = 2.0 * range + self.index.grid.cell_size();
        let scanned = (Vec3::splat(side).min(extent) / extent).element_product()
            * self.state.fish.len() as f32;
        2.0 * self.index.predators.len() as f32 <= scanned
    }

    /// Rebuilds the list of predator fish from the species' `predator` flags.
    pub(super) fn refresh_predators(&mut self) {
        self.index.predators.clear();
        for (&id, &s) in self.state.fish.ids.iter().zip(&self.state.fish.species) {
            if self.catalog.species[usize::from(s.0)].desc.predator {
                self.index.predators.push(id);
            }
        }
        self.index.refresh_predator_spots(&self.state);
    }
}

/// A predator fish as [`World::nearest_seen`] scans them: 24 bytes, side by side.
#[derive(Clone, Copy, Debug)]
pub(super) struct PredatorSpot {
    pos: Vec3,
    species: SpeciesId,
    /// Its id's index (the percept's id).
    index: u32,
    /// Its dense index when the spots were packed.
    dense: u32,
}

impl PredatorSpot {
    pub(super) fn new(pos: Vec3, species: SpeciesId, index: u32, dense: u32) -> Self {
        Self {
            pos,
            species,
            index,
            dense,
        }
    }

    /// Its position when the spots were packed.
    pub(super) fn pos(&self) -> Vec3 {
        self.pos
    }

    /// Its species.
    pub(super) fn species(&self) -> SpeciesId {
        self.species
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_world::{Scene, random_scene};
    use super::super::{SpawnParams, SpeciesId};
    use super::*;

    const KINDS: [PerceptKind; 4] = [
        PerceptKind::Fish,
        PerceptKind::Predator,
        PerceptKind::Food,
        PerceptKind::Obstacle,
    ];

    /// Compares every fish's nearest of each kind and species (by every route in `routes`)
    /// with the first such entry of its full vision list, bit for bit (`Debug` prints each
    /// float's shortest round-trip form, so equal text is equal bits). Returns how many of the
    /// answers were something.
    fn check(w: &World, species: &[SpeciesId], routes: &[Route], what: &str) -> usize {
        let mut vision = Vec::new();
        let mut found = 0;
        let filters: Vec<Option<SpeciesId>> = std::iter::once(None)
            .chain(species.iter().copied().map(Some))
            .collect();
        for id in w.fish_ids() {
            w.vision(id, &mut vision);
            let d = w.state.fish.dense(id).unwrap();
            for kind in KINDS {
                for &want in &filters {
                    let expected = vision
                        .iter()
                        .find(|p| p.kind == kind && (want.is_none() || p.species == want));
                    let got = w.nearest_in_view(id, kind, want);
                    assert_eq!(
                        format!("{got:?}"),
                        format!("{expected:?}"),
                        "{what}: fish {id:?}, {kind:?} of {want:?}"
                    );
                    for &route in routes {
                        let got = w
                            .nearest_seen(d, kind, want, route)
                            .map(|s| w.percept_of(&w.state.fish.roots[d], s));
                        assert_eq!(
                            format!("{got:?}"),
                            format!("{expected:?}"),
                            "{what}: fish {id:?}, {kind:?} of {want:?} by {route:?}"
                        );
                    }
                    found += usize::from(got.is_some());
                }
            }
        }
        found
    }

    #[test]
    fn nearest_in_view_is_what_vision_lists_first_of_the_kind() {
        let Scene {
            mut world, species, ..
        } = random_scene(5, 500);
        let all = [Route::Auto, Route::Grid, Route::List];
        let found = check(&world, &species, &all, "fresh grid");
        assert!(found > 1500, "answers found: {found}");
        // Predators were seen by many fish (not a vacuous comparison).
        let with_predator = world
            .fish_ids()
            .filter(|&id| {
                world
                    .nearest_in_view(id, PerceptKind::Predator, None)
                    .is_some()
            })
            .count();
        assert!(
            with_predator > 100,
            "fish seeing a predator: {with_predator}"
        );

        // Fish moved since the rebuild: the list would see fish the grid does not; Auto must
        // take the grid.
        for _ in 0..15 {
            world.step_motion(1.0 / 60.0);
        }
        check(&world, &species, &[Route::Auto, Route::Grid], "moved");

        // Predators despawned and spawned, including on top of others.
        let ids: Vec<_> = world.fish_ids().collect();
        for &id in ids.iter().step_by(9) {
            world.despawn(id);
        }
        for k in 0..12 {
            let pos = world.roots()[3 * k].pos;
            world
                .spawn(SpawnParams {
                    species: species[2],
                    pos,
                    heading: k as f32,
                    pitch: 0.0,
                    speed: 0.0,
                    behavior: None,
                    seed: k as u64,
                })
                .unwrap();
        }
        check(&world, &species, &[Route::Auto, Route::Grid], "spawned");
        world.rebuild_grid();
        check(&world, &species, &all, "rebuilt");

        // The list follows the species' predator flags.
        let expected: Vec<FishId> = world
            .fish_ids()
            .filter(|&id| world.species_of(id) == Some(species[2]))
            .collect();
        let mut listed = world.predator_fish().to_vec();
        listed.sort();
        let mut sorted = expected.clone();
        sorted.sort();
        assert_eq!(listed, sorted);
        for (s, predator) in [(1, true), (2, false)] {
            let mut changed = world.species(species[s]).clone();
            changed.desc.predator = predator;
            world.replace_species(species[s], changed).unwrap();
        }
        let found = check(&world, &species, &all, "other species now the predators");
        assert!(found > 1500, "answers found: {found}");
        assert!(
            world
                .predator_fish()
                .iter()
                .all(|&id| world.species_of(id) == Some(species[1]))
        );
    }

    #[test]
    fn the_predator_list_is_taken_only_when_it_pays() {
        let Scene {
            mut world,
            l,
            species,
        } = random_scene(9, 400);
        // The view reaches across this small tank: the grid would scan every fish, 20 times
        // as many as there are predators.
        assert!(world.predator_list_pays(5.0 * l));
        // Most fish predators: the grid is the cheaper way.
        let mut changed = world.species(species[0]).clone();
        changed.desc.predator = true;
        world.replace_species(species[0], changed).unwrap();
        assert!(!world.predator_list_pays(5.0 * l));
        let mut changed = world.species(species[0]).clone();
        changed.desc.predator = false;
        world.replace_species(species[0], changed).unwrap();
        assert!(world.predator_list_pays(5.0 * l));
        // Fish moved since the rebuild: the list would see fish the grid does not.
        world.step_motion(1.0 / 60.0);
        assert!(!world.predator_list_pays(5.0 * l), "the grid is stale");
    }
}
