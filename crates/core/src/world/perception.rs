//! The perception layer's sensors (paper section 3.1): vision (what a fish sees, nearest
//! first, from the spatial grid) and the body sensor.

use glam::Vec3;

use super::sense::{ViewCone, bearing, elevation, forward, tank_distances};
use super::{BodySense, FishId, ObstacleId, Percept, PerceptKind, SpeciesId, VisionBatch, World};
use crate::motion::RootState;

impl World {
    // ---- perception -------------------------------------------------------------------------

    /// Calls `visit(dense index, position, distance²)` for every live fish within `radius` of
    /// `pos`, from the grid plus the fish spawned since its last rebuild. Positions and distances
    /// are current ones.
    pub(super) fn for_each_fish_near(
        &self,
        pos: Vec3,
        radius: f32,
        mut visit: impl FnMut(usize, Vec3, f32),
    ) {
        let r2 = radius * radius;
        if self.index.grid_exact && self.index.grid_positions_current {
            // Nothing moved since the rebuild: the grid's own (cell-ordered) copy of the positions
            // is exact, and reading it avoids a cache miss per candidate on the roots array.
            self.index.grid.for_each_within(pos, radius, |key, p, d2| {
                visit(key as usize, p, d2);
                true
            });
            return;
        }
        let mut check = |d: usize| {
            let p = self.state.fish.roots[d].pos;
            let d2 = p.distance_squared(pos);
            if d2 <= r2 {
                visit(d, p, d2);
            }
        };
        if self.index.grid_exact {
            self.index.grid.for_each_within(pos, radius, |key, _, _| {
                check(key as usize);
                true
            });
            return;
        }
        self.index.grid.for_each_within(pos, radius, |key, _, _| {
            if let Some(d) = self.state.fish.dense(self.index.grid_ids[key as usize]) {
                check(d);
            }
            true
        });
        for &id in &self.index.spawned_since_grid {
            if let Some(d) = self.state.fish.dense(id) {
                check(d);
            }
        }
    }

    /// Fish whose root lies within `radius` of `pos` (inclusive), in grid order. Answered from the
    /// spatial grid as of the last [`World::rebuild_grid`] plus fish spawned since.
    pub fn neighbors(&self, pos: Vec3, radius: f32, out: &mut Vec<FishId>) {
        out.clear();
        if !pos.is_finite() || radius.is_nan() || radius < 0.0 {
            return;
        }
        self.for_each_fish_near(pos, radius, |d, _, _| out.push(self.state.fish.ids[d]));
    }

    /// Everything the fish sees: fish (predators marked), uneaten food and obstacles within its
    /// species' `view_range` and inside its view cone (`view_angle_deg`, the cone's full opening
    /// around its forward direction), nearest first (ties broken by kind, then id, so the order
    /// is deterministic). Clears `out`; a stale id leaves it empty.
    pub fn vision(&self, id: FishId, out: &mut Vec<Percept>) {
        self.vision_nearest(id, usize::MAX, out);
    }

    /// [`World::vision`] keeping only the `max` nearest percepts (exactly the first `max` of the
    /// full list), for scripts that look at a few things: only those are sorted and built.
    pub fn vision_nearest(&self, id: FishId, max: usize, out: &mut Vec<Percept>) {
        out.clear();
        if let Some(d) = self.state.fish.dense(id) {
            self.append_vision(d, max, out);
        }
    }

    /// The `max` nearest percepts of each of `ids` (as [`World::vision_nearest`] gives them),
    /// computed in parallel over rayon's threads into `batch`; `batch.get(i)` is `ids[i]`'s.
    /// For a host that runs the decisions due this tick one after another: the sensing, the
    /// expensive part, then uses both cores. Results do not depend on the thread count, and the
    /// batch's buffers are reused, so a warm batch does not allocate.
    pub fn vision_batch(&self, ids: &[FishId], max: usize, batch: &mut VisionBatch) {
        use rayon::prelude::*;
        let num_chunks = ids.len().div_ceil(VisionBatch::CHUNK);
        if batch.chunks.len() < num_chunks {
            batch.chunks.resize_with(num_chunks, Vec::new);
        }
        batch.spans.clear();
        batch.spans.resize(ids.len(), (0, 0, 0));
        ids.par_chunks(VisionBatch::CHUNK)
            .zip(batch.chunks[..num_chunks].par_iter_mut())
            .zip(batch.spans.par_chunks_mut(VisionBatch::CHUNK))
            .enumerate()
            .for_each(|(c, ((ids, buf), spans))| {
                buf.clear();
                for (&id, span) in ids.iter().zip(spans) {
                    let start = buf.len() as u32;
                    if let Some(d) = self.state.fish.dense(id) {
                        self.append_vision(d, max, buf);
                    }
                    *span = (c as u32, start, buf.len() as u32);
                }
            });
    }

    /// Appends the `max` nearest percepts of dense fish `d` to `out`, nearest first.
    ///
    /// For a few (up to [`NEAREST_FIRST_MAX`]) while the grid is current, the fish are searched
    /// nearest cells first and the search stops once no cell left can hold one nearer than the
    /// `max`-th best so far: a script asking for the 5 nearest things does not pay for the
    /// hundreds in view of a fish in a dense school. The answer is the full list's head.
    pub(super) fn append_vision(&self, d: usize, max: usize, out: &mut Vec<Percept>) {
        if max == 0 {
            return;
        }
        if max <= NEAREST_FIRST_MAX && self.index.grid_exact && self.index.grid_positions_current {
            self.append_vision_nearest_first(d, max, out);
            return;
        }
        SEEN.with_borrow_mut(|seen| {
            seen.clear();
            self.collect_seen(d, seen);
            if seen.len() > max {
                seen.select_nth_unstable_by_key(max - 1, |s| s.key);
                seen.truncate(max);
            }
            seen.sort_unstable_by_key(|s| s.key);
            let me = &self.state.fish.roots[d];
            out.extend(seen.iter().map(|s| self.percept_of(me, *s)));
        });
    }

    /// [`World::append_vision`] for a few, nearest cells first (the grid must be current).
    fn append_vision_nearest_first(&self, d: usize, max: usize, out: &mut Vec<Percept>) {
        SEEN.with_borrow_mut(|seen| {
            seen.clear();
            let view = self.view_of(d);
            // Pellets and obstacles are few: all of them, then the fish into the same max-heap.
            self.food_seen(&view, |s| seen.push(s));
            self.obstacles_seen(&view, |s| seen.push(s));
            let mut heap: std::collections::BinaryHeap<(u64, u32)> =
                seen.iter().map(|s| (s.key, s.index)).collect();
            while heap.len() > max {
                heap.pop();
            }
            let grid = &self.index.grid;
            let (keys, positions) = (grid.keys(), grid.positions());
            let r2 = view.range * view.range;
            let fish = &self.state.fish;
            // How far, squared, a fish can lie and still enter the heap (see below).
            let mut need = r2;
            grid.for_each_run_nearest_first(view.pos, view.range, |run| {
                for slot in run {
                    let (o, pos) = (keys[slot] as usize, positions[slot]);
                    let d2 = pos.distance_squared(view.pos);
                    if d2 > need || o == d || !view.cone.contains(pos) {
                        continue;
                    }
                    let kind = self.fish_kind(view.species, fish.species[o]);
                    let s = Seen::new(d2.sqrt(), kind, fish.ids[o].index, o as u32);
                    if heap.len() < max {
                        heap.push((s.key, s.index));
                    } else if heap.peek().is_some_and(|&(top, _)| s.key < top) {
                        heap.pop();
                        heap.push((s.key, s.index));
                    }
                }
                need = match heap.peek() {
                    // A farther fish can still win a tie at the same rounded distance: reach a
                    // hair past the max-th.
                    Some(&(top, _)) if heap.len() == max => {
                        let dist = f32::from_bits((top >> 32) as u32) * (1.0 + 1e-5);
                        r2.min(dist * dist)
                    }
                    _ => r2,
                };
                need
            });
            seen.clear();
            seen.extend(heap.into_iter().map(|(key, index)| Seen { key, index }));
            seen.sort_unstable_by_key(|s| s.key);
            let me = &self.state.fish.roots[d];
            out.extend(seen.iter().map(|s| self.percept_of(me, *s)));
        });
    }

    /// Everything in view of dense fish `d`, as sort keys (see [`Seen`]).
    pub(super) fn collect_seen(&self, d: usize, seen: &mut Vec<Seen>) {
        let view = self.view_of(d);
        self.fish_seen(d, &view, |_, _| true, |s| seen.push(s));
        self.food_seen(&view, |s| seen.push(s));
        self.obstacles_seen(&view, |s| seen.push(s));
    }

    /// How dense fish `d` sees: from where, how far, how wide.
    pub(super) fn view_of(&self, d: usize) -> View {
        let me = self.state.fish.roots[d];
        let species = self.state.fish.species[d];
        let desc = &self.catalog.species[usize::from(species.0)].desc;
        let fwd = forward(me.heading, me.pitch);
        View {
            pos: me.pos,
            species,
            range: desc.view_range,
            angle: desc.view_angle_deg,
            fwd,
            cone: ViewCone::new(me.pos, fwd, desc.view_angle_deg),
        }
    }

    /// How a fish of species `viewer` perceives a fish of species `other`.
    pub(super) fn fish_kind(&self, viewer: SpeciesId, other: SpeciesId) -> PerceptKind {
        if other != viewer && self.catalog.species[usize::from(other.0)].desc.predator {
            PerceptKind::Predator
        } else {
            PerceptKind::Fish
        }
    }

    /// Calls `found` with every fish in `view` of dense fish `d` (itself excluded) that `want`
    /// (dense index, kind) accepts; `want` is asked before the view-cone test.
    pub(super) fn fish_seen(
        &self,
        d: usize,
        view: &View,
        want: impl Fn(usize, PerceptKind) -> bool,
        mut found: impl FnMut(Seen),
    ) {
        self.for_each_fish_near(view.pos, view.range, |o, pos, d2| {
            if o == d {
                return;
            }
            let kind = self.fish_kind(view.species, self.state.fish.species[o]);
            if !want(o, kind) || !view.cone.contains(pos) {
                return;
            }
            found(Seen::new(
                d2.sqrt(),
                kind,
                self.state.fish.ids[o].index,
                o as u32,
            ));
        });
    }

    /// Calls `found` with every food pellet in `view` (only pellets in the water are listed).
    pub(super) fn food_seen(&self, view: &View, mut found: impl FnMut(Seen)) {
        let foods = &self.state.foods;
        let mut see_food = |i: usize| {
            let (id, f) = &foods[i];
            if f.eaten || !view.cone.contains(f.pos) {
                return;
            }
            let dist = f.pos.distance(view.pos);
            if dist <= view.range {
                found(Seen::new(dist, PerceptKind::Food, id.0, i as u32));
            }
        };
        if self.index.food_in_grid > 0 {
            self.index
                .food_grid
                .for_each_within(view.pos, view.range, |key, _, _| {
                    see_food(key as usize);
                    true
                });
        }
        for i in self.index.food_in_grid..foods.len() {
            see_food(i);
        }
    }

    /// Calls `found` with every obstacle any part of which is in `view`.
    pub(super) fn obstacles_seen(&self, view: &View, mut found: impl FnMut(Seen)) {
        let (range, angle) = (view.range, view.angle);
        for (i, o) in self.state.obstacles.iter().enumerate() {
            let to_centre = o.pos.distance(view.pos);
            let distance = to_centre - o.radius;
            if distance > range {
                continue;
            }
            // Seen if any part of the sphere is inside the cone: widen the cone by the sphere's
            // angular radius.
            let visible = if to_centre <= o.radius || angle >= 360.0 {
                true
            } else {
                let half = (angle.max(0.0) * 0.5).to_radians();
                let angular_radius = (o.radius / to_centre).clamp(0.0, 1.0).asin();
                let off_axis = view
                    .fwd
                    .dot((o.pos - view.pos) / to_centre)
                    .clamp(-1.0, 1.0)
                    .acos();
                off_axis <= half + angular_radius
            };
            if visible {
                found(Seen::new(
                    distance,
                    PerceptKind::Obstacle,
                    i as u32,
                    i as u32,
                ));
            }
        }
    }

    /// Builds the percept of `s` as seen from `me`.
    pub(super) fn percept_of(&self, me: &RootState, s: Seen) -> Percept {
        let (distance, kind) = s.distance_and_kind();
        let i = s.index as usize;
        let mut p = Percept {
            kind,
            fish: None,
            food: None,
            obstacle: None,
            species: None,
            pos: Vec3::ZERO,
            distance,
            bearing: 0.0,
            elevation: 0.0,
            heading: 0.0,
            speed: 0.0,
        };
        match kind {
            PerceptKind::Fish | PerceptKind::Predator => {
                let other = &self.state.fish.roots[i];
                p.fish = Some(self.state.fish.ids[i]);
                p.species = Some(self.state.fish.species[i]);
                p.pos = other.pos;
                p.heading = other.heading;
                p.speed = other.speed;
            }
            PerceptKind::Food => {
                let (id, food) = &self.state.foods[i];
                p.food = Some(*id);
                p.pos = food.pos;
            }
            PerceptKind::Obstacle => {
                p.obstacle = Some(ObstacleId(s.index));
                p.pos = self.state.obstacles[i].pos;
            }
        }
        p.bearing = bearing(me.pos, me.heading, p.pos);
        p.elevation = elevation(me.pos, p.pos);
        p
    }

    /// The fish's body sensor: depth, distances to floor, surface and nearest side wall (with
    /// its inward normal), contact in the last motion step, speed, heading and pitch.
    pub fn body_sense(&self, id: FishId) -> Option<BodySense> {
        let d = self.state.fish.dense(id)?;
        let r = &self.state.fish.roots[d];
        let (to_floor, to_surface, to_wall, wall_normal) = tank_distances(&self.state.tank, r.pos);
        Some(BodySense {
            pos: r.pos,
            depth: self.state.tank.depth_of(r.pos.y),
            to_floor,
            to_surface,
            to_wall,
            wall_normal,
            contact: self.state.fish.contact[d],
            speed: r.speed,
            heading: r.heading,
            pitch: r.pitch,
        })
    }
}

/// Something in view before it becomes a [`Percept`]: a sort key that orders nearest first,
/// then by kind, then by id (a total order on distinct things, so vision is deterministic), and
/// where to find the thing (dense fish index, food or obstacle index).
#[derive(Clone, Copy, Debug)]
pub(super) struct Seen {
    /// distance bits (non-negative floats order like their bits) << 32 | kind << 30 | id.
    pub(super) key: u64,
    pub(super) index: u32,
}

impl Seen {
    pub(super) fn new(distance: f32, kind: PerceptKind, id: u32, index: u32) -> Self {
        // Clamp to +0.0 (never −0.0, whose bits would sort last).
        let distance = if distance > 0.0 { distance } else { 0.0 };
        let kind = kind as u64;
        Self {
            key: (u64::from(distance.to_bits()) << 32) | (kind << 30) | u64::from(id & 0x3FFF_FFFF),
            index,
        }
    }

    pub(super) fn distance_and_kind(&self) -> (f32, PerceptKind) {
        let distance = f32::from_bits((self.key >> 32) as u32);
        let kind = match (self.key >> 30) & 3 {
            0 => PerceptKind::Fish,
            1 => PerceptKind::Food,
            2 => PerceptKind::Obstacle,
            _ => PerceptKind::Predator,
        };
        (distance, kind)
    }
}

/// How a fish sees (see [`World::vision`]): its root position, species, view range and cone.
#[derive(Clone, Copy, Debug)]
pub(super) struct View {
    pub(super) pos: Vec3,
    pub(super) species: SpeciesId,
    pub(super) range: f32,
    pub(super) angle: f32,
    pub(super) fwd: Vec3,
    pub(super) cone: ViewCone,
}

/// Most percepts [`World::vision_nearest`] searches for nearest cells first; more are gathered
/// from the whole view and selected (a max-heap of hundreds gains nothing over the selection).
const NEAREST_FIRST_MAX: usize = 64;

thread_local! {
    /// Vision's scratch list, per thread so `vision` can take `&self` and never allocate once
    /// warm.
    static SEEN: std::cell::RefCell<Vec<Seen>> = const { std::cell::RefCell::new(Vec::new()) };
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn grid_cells_are_a_share_of_the_longest_view_range() {
        let scene = super::super::test_world::random_scene(1, 50);
        let longest = (0..scene.world.num_species())
            .map(|s| scene.world.species(SpeciesId(s as u16)).desc.view_range)
            .fold(0.0f32, f32::max);
        let cell = super::super::index::GRID_CELL_OF_VIEW * longest;
        assert!(longest > 0.0 && cell < 0.5 * longest);
        assert_eq!(scene.world.index.grid.cell_size(), cell);
        assert_eq!(scene.world.index.food_grid.cell_size(), cell);
    }

    /// In a school far denser than the bench's (16 fish per cubic body length, some on top of
    /// each other, pellets and an obstacle among them) the few nearest, searched nearest cells
    /// first, are exactly the head of the full list.
    #[test]
    fn a_few_nearest_are_the_head_of_the_full_list_in_a_dense_school() {
        let mut scene = super::super::test_world::random_scene(23, 4000);
        let w = &mut scene.world;
        let c = (w.tank().min + w.tank().max) * 0.5;
        w.add_obstacle(c, 0.5 * scene.l);
        w.rebuild_grid();
        let (mut all, mut few) = (Vec::new(), Vec::new());
        let mut compared = 0;
        for id in w.fish_ids().step_by(17) {
            w.vision(id, &mut all);
            for max in [1, 2, 7, 20, NEAREST_FIRST_MAX] {
                w.vision_nearest(id, max, &mut few);
                assert_eq!(
                    format!("{few:?}"),
                    format!("{:?}", &all[..max.min(all.len())]),
                    "fish {id:?}, max {max}"
                );
                compared += few.len();
            }
        }
        assert!(compared > 10_000, "percepts compared: {compared}");
    }

    #[test]
    fn seen_keys_round_trip_and_order_nearest_then_kind_then_id() {
        let kinds = [
            PerceptKind::Fish,
            PerceptKind::Food,
            PerceptKind::Obstacle,
            PerceptKind::Predator,
        ];
        for (k, kind) in kinds.into_iter().enumerate() {
            let s = Seen::new(12.5, kind, 7, 3);
            assert_eq!(s.distance_and_kind(), (12.5, kind));
            assert_eq!(s.key & 0x3FFF_FFFF, 7);
            assert_eq!((s.key >> 30) & 3, k as u64);
        }
        let near = Seen::new(1.0, PerceptKind::Predator, 9, 0).key;
        let far = Seen::new(1.5, PerceptKind::Fish, 0, 0).key;
        assert!(near < far);
        assert!(Seen::new(1.0, PerceptKind::Fish, 9, 0).key < near);
        assert!(Seen::new(1.0, PerceptKind::Predator, 8, 0).key < near);
        // Inside an obstacle: distance 0, never −0 (which would sort last).
        assert_eq!(
            Seen::new(-0.0, PerceptKind::Obstacle, 0, 0)
                .distance_and_kind()
                .0
                .to_bits(),
            0
        );
        assert!(Seen::new(-3.0, PerceptKind::Obstacle, 0, 0).key < far);
    }
}
