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
    /// While the grid is current: predators from their own grid, other fish from the fish
    /// grid nearest cells first; else every fish in range from the grid.
    Auto,
    /// Every fish in range, from the grid.
    Grid,
    /// Predators from their own grid (only valid while the grid is current).
    Predators,
    /// The fish grid, nearest cells first (only valid while the grid is current).
    NearestFirst,
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
    /// Only the winner is kept (no list is built or sorted). While the grid is current (nothing
    /// moved since [`World::rebuild_grid`]), predators come from their own grid and other fish
    /// from the fish grid nearest cells first (see the module docs).
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
                let current = self.predator_spots_current(view.range);
                let route = match route {
                    Route::Auto if current && kind == PerceptKind::Predator => Route::Predators,
                    Route::Auto if current => Route::NearestFirst,
                    Route::Auto => Route::Grid,
                    other => other,
                };
                // The predators' own grid or list: every predator within range now (the grid
                // is current, so the spots' positions are the roots').
                let mut spot_seen = |spot: &PredatorSpot| {
                    let d2 = spot.pos.distance_squared(view.pos);
                    if d2 > view.range * view.range || spot.dense as usize == d {
                        return;
                    }
                    if self.fish_kind(view.species, spot.species) != kind
                        || !of_species(spot.species)
                    {
                        return;
                    }
                    if view.cone.contains(spot.pos) {
                        keep(Seen::new(d2.sqrt(), kind, spot.index, spot.dense));
                    }
                };
                match route {
                    Route::Predators if kind == PerceptKind::Predator => {
                        self.index.predator_grid.for_each_within(
                            view.pos,
                            view.range,
                            |key, _, _| {
                                spot_seen(&self.index.predator_spots[key as usize]);
                                true
                            },
                        );
                    }
                    #[cfg(test)]
                    Route::List if kind == PerceptKind::Predator => {
                        self.index.predator_spots.iter().for_each(spot_seen);
                    }
                    Route::NearestFirst => {
                        // Cells nearest first, skipping those farther than the best so far:
                        // the answer is the full scan's, at the cost of the fish near it.
                        let grid = &self.index.grid;
                        let (keys, positions) = (grid.keys(), grid.positions());
                        let r2 = view.range * view.range;
                        let mut best: Option<Seen> = None;
                        let mut need = r2;
                        grid.for_each_run_nearest_first(view.pos, view.range, |run| {
                            for slot in run {
                                let (o, pos) = (keys[slot] as usize, positions[slot]);
                                let d2 = pos.distance_squared(view.pos);
                                if d2 > need || o == d {
                                    continue;
                                }
                                let k = self.fish_kind(view.species, self.state.fish.species[o]);
                                if k != kind
                                    || !of_species(self.state.fish.species[o])
                                    || !view.cone.contains(pos)
                                {
                                    continue;
                                }
                                let s =
                                    Seen::new(d2.sqrt(), k, self.state.fish.ids[o].index, o as u32);
                                if best.is_none_or(|b| s.key < b.key) {
                                    best = Some(s);
                                }
                            }
                            // A farther fish can still win a tie (lower id) at the same rounded
                            // distance: reach a hair past the best.
                            need = best.map_or(r2, |b| {
                                let dist = b.distance_and_kind().0 * (1.0 + 1e-5);
                                r2.min(dist * dist)
                            });
                            need
                        });
                        if let Some(s) = best {
                            keep(s);
                        }
                    }
                    _ => {
                        self.fish_seen(
                            d,
                            &view,
                            |o, k| k == kind && of_species(self.state.fish.species[o]),
                            &mut keep,
                        );
                    }
                }
            }
            PerceptKind::Food if species.is_none() => self.food_seen(&view, &mut keep),
            PerceptKind::Obstacle if species.is_none() => self.obstacles_seen(&view, &mut keep),
            PerceptKind::Food | PerceptKind::Obstacle => {}
        }
        best
    }

    /// Whether the grid (and so the predator spots and their grid) is current for a view of
    /// `range`: nothing was spawned, despawned or moved since [`World::rebuild_grid`].
    fn predator_spots_current(&self, range: f32) -> bool {
        let valid_range = range >= 0.0; // false for NaN, as the grid's own test
        self.index.grid_exact && self.index.grid_positions_current && valid_range
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
        let all = [
            Route::Auto,
            Route::Grid,
            Route::List,
            Route::Predators,
            Route::NearestFirst,
        ];
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
    fn the_fast_routes_are_taken_only_while_the_grid_is_current() {
        let Scene { mut world, l, .. } = random_scene(9, 400);
        assert!(world.predator_spots_current(5.0 * l));
        assert!(!world.predator_spots_current(f32::NAN));
        // Fish moved since the rebuild: the spots and the grid's positions are stale.
        world.step_motion(1.0 / 60.0);
        assert!(!world.predator_spots_current(5.0 * l), "the grid is stale");
        world.rebuild_grid();
        assert!(world.predator_spots_current(5.0 * l));
    }

    /// A school ten times as dense as the 100,000-fish bench's thickest (16 fish per cubic body
    /// length, many on top of each other): the nearest fish of each kind and species, found
    /// nearest cells first, is the brute-force answer (every fish compared with every other).
    #[test]
    fn nearest_first_matches_brute_force_in_a_dense_school() {
        let Scene { world, species, .. } = random_scene(17, 4000);
        let filters = [None, Some(species[0]), Some(species[1]), Some(species[2])];
        let mut found = 0;
        for (n, id) in world.fish_ids().enumerate() {
            if n % 13 != 0 {
                continue;
            }
            let d = world.state.fish.dense(id).unwrap();
            let view = world.view_of(d);
            for kind in [PerceptKind::Fish, PerceptKind::Predator] {
                for want in filters {
                    // Brute force: every other fish, the least (distance, kind, id) key.
                    let mut best: Option<Seen> = None;
                    for o in 0..world.state.fish.len() {
                        let pos = world.state.fish.roots[o].pos;
                        let d2 = pos.distance_squared(view.pos);
                        let sp = world.state.fish.species[o];
                        let k = world.fish_kind(view.species, sp);
                        if o == d
                            || d2 > view.range * view.range
                            || k != kind
                            || want.is_some_and(|w| w != sp)
                            || !view.cone.contains(pos)
                        {
                            continue;
                        }
                        let s = Seen::new(d2.sqrt(), k, world.state.fish.ids[o].index, o as u32);
                        if best.is_none_or(|b| s.key < b.key) {
                            best = Some(s);
                        }
                    }
                    let expected = best.map(|s| world.percept_of(&world.state.fish.roots[d], s));
                    for route in [Route::Auto, Route::NearestFirst, Route::Predators] {
                        let got = world
                            .nearest_seen(d, kind, want, route)
                            .map(|s| world.percept_of(&world.state.fish.roots[d], s));
                        assert_eq!(
                            format!("{got:?}"),
                            format!("{expected:?}"),
                            "fish {id:?}, {kind:?} of {want:?} by {route:?}"
                        );
                    }
                    found += usize::from(expected.is_some());
                }
            }
        }
        assert!(found > 600, "answers found: {found}");
    }
}
