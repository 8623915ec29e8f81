//! The crowding rules (paper section 3.1: separation, alignment, cohesion) answered from one scan
//! of the spatial grid.
//!
//! The shipped `school` behaviour asks for all three every decision, at radii of 1, 4 and 6 body
//! lengths. [`World::steer_crowd`] visits the neighbourhood once, at the largest radius, and
//! sorts each candidate into the rules whose radius it lies within. Candidates are visited in the
//! grid's order whatever the radius (a smaller sphere's items are a subsequence of a larger
//! one's), and each rule sums exactly the terms, in exactly the order, its own scan would: the
//! results are bitwise those of [`World::steer_separation`], [`World::steer_alignment`] and
//! [`World::steer_cohesion`], which are this same scan with the other rules off.
//!
//! While nothing moved since the grid's rebuild (the behaviour stage of a tick) the scan reads
//! only the grid's cell-ordered columns — positions, species, heading cosine/sine and dense
//! index, packed in groups of four by [`World::rebuild_grid`] — four candidates at a time
//! (`crowd/simd.rs`). Otherwise it falls back to the fish arrays with the same rules as
//! the world's other neighbour queries (the grid as of its rebuild, current positions, plus the
//! fish spawned since).
//!
//! `shoal.crowd`'s default is [`World::steer_crowd_bounded`]: this scan wherever the cells
//! within reach hold at most [`CROWD_DENSE`] fish, and in denser neighbourhoods an even sample
//! of them for alignment and cohesion, so a decision's cost stays bounded in a packed school.
//! [`World::steer_crowd_nearest`] takes the nearest k instead (a script passing a number).

use std::sync::atomic::Ordering;

use glam::{Vec2, Vec3};

use super::steer::{self, Agent, Steer};
use super::{FishId, SpeciesId, World};

mod simd;

pub(super) use simd::CrowdColumns;
use simd::{LaneQuery, LaneSums};

/// Most fish the cells within a crowd query's widest radius may hold for
/// [`World::steer_crowd_bounded`] (`shoal.crowd`'s default) to sum every one of them; in denser
/// neighbourhoods alignment and cohesion take an even sample (see [`CROWD_SAMPLE`]).
///
/// Why a sample and not the nearest few: real schools interact *topologically* (Ballerini et
/// al. 2008, PNAS 105:1232: starlings follow six to seven neighbours), and the first bounded
/// query took the nearest 24 — but the shipped school was tuned with metric radii, and on the
/// 10,000-fish `big_school` the nearest 24 made a looser school than every fish within the
/// radii (polarization 0.087 → 0.055, wall contacts +28 %, 16 seeds, significant; 128 nearest
/// still +6 % wall contacts): at that density a fish's cohesion radius holds about 200 fish and
/// the centroid of the nearest 24 lies next to it. It was also dearer per decision than the
/// four-lane scan of every fish (docs/performance.md). Most queries hold far fewer than this
/// in their cells (at 100,000 fish in `shoal bench sim`, none of 400,000 queries held more
/// than 1,024; in 12 s of `big_school`, none of 800,000 held more than 2,048 and 9 % held
/// more than 1,024), so they are exactly the unbounded rules; the sample bounds the dense tail
/// (a ball of fish round a pellet, a school pressed into a corner, a designer's packed test
/// scene). It was 1,024 while the grid's cells were 150 units; the 225-unit cells a query
/// visits hold more fish, and with 1,024 the big school's sampled share would have risen from
/// 2 % to 9 % of its queries, so the limit rose with them.
pub const CROWD_DENSE: usize = 2048;

/// At most this many grid slots (in aligned groups of four) a dense crowd query samples for
/// alignment and cohesion: every m-th group of four in the grid's order of the cells within
/// reach, m the smallest that keeps the sample within this. The grid orders slots by cell, so
/// the sample is spread evenly over the neighbourhood. In a school of two fish per cubic body
/// length (7,000 fish; the radii of the shipped school), the sampled answers' mean heading lay
/// within 0.017 rad of the full sum's (median; 0.18 at worst) and their centroid within 0.08
/// body lengths (median; 0.96 at worst, a fish with few of its own species near). Separation
/// (the smallest radius, the nearest fish) always sums every one.
pub const CROWD_SAMPLE: usize = 1024;

/// [`CROWD_DENSE`] and [`CROWD_SAMPLE`].
const SHIPPED: [usize; 2] = [CROWD_DENSE, CROWD_SAMPLE];

/// How many neighbours `shoal.crowd` takes when given a number: the old default, kept as the
/// documented example of a topological rule (`shoal.crowd(..., nil, 24)`).
pub const CROWD_NEAREST: usize = 24;

/// What the three crowding rules ask of a fish (see [`World::steer_crowd`]); each is `None` when
/// its rule has nothing to say (no neighbour in its radius, or their pulls cancel out).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Crowd {
    /// [`World::steer_separation`]'s answer: away from every fish within the separation radius.
    pub separation: Option<Steer>,
    /// [`World::steer_alignment`]'s answer: the mean heading of its own species within the
    /// alignment radius.
    pub alignment: Option<Steer>,
    /// [`World::steer_cohesion`]'s answer: towards the centroid of its own species within the
    /// cohesion radius.
    pub cohesion: Option<Steer>,
}

/// The sums the three rules are built from.
#[derive(Clone, Copy, Debug, Default)]
struct CrowdSums {
    /// Σ (me − other) / d² over fish within the separation radius (d > 0).
    push: Vec3,
    /// Σ (cos h, sin h) over own-species fish within the alignment radius.
    heading: Vec2,
    /// Σ position and count of own-species fish within the cohesion radius.
    centre: Vec3,
    count: u32,
}

impl CrowdSums {
    /// Adds one neighbour at `pos`, `d2` from the centre `me`, to the rules it is `within`
    /// (separation, alignment, cohesion). `heading` is only called when alignment takes it.
    #[inline(always)]
    fn add(
        &mut self,
        me: Vec3,
        pos: Vec3,
        d2: f32,
        within: [bool; 3],
        heading: impl FnOnce() -> Vec2,
    ) {
        if within[0] && d2 > 0.0 {
            self.push += (me - pos) / d2;
        }
        if within[1] {
            self.heading += heading();
        }
        if within[2] {
            self.centre += pos;
            self.count += 1;
        }
    }

    fn separation(&self, agent: &Agent, speed: f32) -> Option<Steer> {
        // Same weighting as steer::separation (1/d along the unit direction).
        (self.push.length_squared() > 1e-12).then(|| agent.toward(self.push, speed))
    }

    fn alignment(&self, agent: &Agent, speed: f32) -> Option<Steer> {
        (self.heading.length_squared() > 1e-8).then(|| Steer {
            heading: self.heading.y.atan2(self.heading.x),
            depth: agent.depth(),
            speed,
        })
    }

    fn cohesion(&self, agent: &Agent, speed: f32) -> Option<Steer> {
        (self.count > 0).then(|| steer::seek(agent, self.centre / self.count as f32, speed))
    }
}

/// (cos h, sin h) of a heading, as alignment sums it.
#[inline(always)]
pub(super) fn heading_vector(h: f32) -> Vec2 {
    Vec2::new(h.cos(), h.sin())
}

/// The widest valid radius of the rules (f32::max skips NaN; negative radii are off), NaN when
/// none is valid.
fn widest(radii: [f32; 3]) -> f32 {
    radii
        .into_iter()
        .filter(|r| *r >= 0.0)
        .fold(f32::NAN, f32::max)
}

/// Squared radius of a rule, or −1 (nothing is within it) for a NaN or negative radius.
fn squared(radius: f32) -> f32 {
    if radius.is_nan() || radius < 0.0 {
        -1.0
    } else {
        radius * radius
    }
}

impl World {
    /// The dense index of the fish a grid key stands for: the key itself while the grid is
    /// exact (nothing spawned or despawned since its rebuild), else its id's current slot
    /// (`None` for a fish despawned since).
    pub(super) fn grid_key_dense(&self, key: u32) -> Option<usize> {
        if self.index.grid_exact {
            Some(key as usize)
        } else {
            self.state.fish.dense(self.index.grid_ids[key as usize])
        }
    }

    /// [`World::steer_separation`], [`World::steer_alignment`] and [`World::steer_cohesion`] of
    /// a fish at once, from one scan of the grid at the largest of the three radii (world units;
    /// any order; a NaN or negative radius finds nothing): bitwise the same answers as the three
    /// calls, at about the cost of the widest one. All three steer at `speed`. `None` for a
    /// stale id.
    pub fn steer_crowd(
        &self,
        id: FishId,
        separation_radius: f32,
        alignment_radius: f32,
        cohesion_radius: f32,
        speed: f32,
    ) -> Option<Crowd> {
        let agent = self.fish(id)?.agent();
        let sums = self.crowd_sums(
            id,
            agent.pos,
            [separation_radius, alignment_radius, cohesion_radius],
        )?;
        Some(Crowd {
            separation: sums.separation(&agent, speed),
            alignment: sums.alignment(&agent, speed),
            cohesion: sums.cohesion(&agent, speed),
        })
    }

    /// [`World::steer_crowd`] from at most the `nearest` fish (of any species, nearest first,
    /// ties by id) within the widest of the three radii: each rule then takes those of them
    /// within its own radius (alignment and cohesion only its own species). `None` takes every
    /// fish, as [`World::steer_crowd`] does. [`World::steer_crowd_bounded`] is `shoal.crowd`'s
    /// default; this is what it does when a script passes a number (a topological rule).
    ///
    /// With a bound, cells holding few fish (at most 16 per neighbour asked for) are read in
    /// one pass and the nearest selected; in a denser school the grid is searched nearest cells
    /// first and the search stops once no cell left can hold a nearer fish, so the cost follows
    /// `nearest`, not the school's density. The chosen neighbours are summed in order of distance: the answer depends only on the world, not
    /// on the grid's cells or the thread (so lanes and replays stay bit-exact).
    pub fn steer_crowd_nearest(
        &self,
        id: FishId,
        radii: [f32; 3],
        speed: f32,
        nearest: Option<usize>,
    ) -> Option<Crowd> {
        let Some(k) = nearest else {
            return self.steer_crowd(id, radii[0], radii[1], radii[2], speed);
        };
        let agent = self.fish(id)?.agent();
        let sums = self.crowd_sums_nearest(id, agent.pos, radii, k)?;
        Some(Crowd {
            separation: sums.separation(&agent, speed),
            alignment: sums.alignment(&agent, speed),
            cohesion: sums.cohesion(&agent, speed),
        })
    }

    /// [`World::steer_crowd`] with its cost bounded in dense schools (`shoal.crowd`'s
    /// default): when the cells within the widest radius hold at most [`CROWD_DENSE`] fish it is
    /// [`World::steer_crowd`], bit for bit; in a denser neighbourhood separation still sums
    /// every fish within its radius (bitwise [`World::steer_separation`]), while alignment and
    /// cohesion sum an even sample of at most [`CROWD_SAMPLE`] of the fish in those cells (every
    /// m-th group of four in the grid's cell order). The answer is a function of the world
    /// alone (the grid is rebuilt from it), so lanes and replays stay bit-exact. While fish
    /// have moved since the grid's rebuild (outside the behaviour stage) it is the unbounded
    /// query. `None` for a stale id.
    pub fn steer_crowd_bounded(&self, id: FishId, radii: [f32; 3], speed: f32) -> Option<Crowd> {
        let agent = self.fish(id)?.agent();
        let sums = self.crowd_sums_bounded(id, agent.pos, radii, SHIPPED, &mut 0)?;
        Some(Crowd {
            separation: sums.separation(&agent, speed),
            alignment: sums.alignment(&agent, speed),
            cohesion: sums.cohesion(&agent, speed),
        })
    }

    /// [`steer::separation`] from every fish (any species) within `radius`, found on the grid.
    pub fn steer_separation(&self, id: FishId, radius: f32, speed: f32) -> Option<Steer> {
        let agent = self.fish(id)?.agent();
        let off = f32::NAN;
        self.crowd_sums(id, agent.pos, [radius, off, off])?
            .separation(&agent, speed)
    }

    /// [`steer::alignment`] with the fish's own species within `radius`, found on the grid.
    pub fn steer_alignment(&self, id: FishId, radius: f32, speed: f32) -> Option<Steer> {
        let agent = self.fish(id)?.agent();
        let off = f32::NAN;
        self.crowd_sums(id, agent.pos, [off, radius, off])?
            .alignment(&agent, speed)
    }

    /// [`steer::cohesion`] with the fish's own species within `radius`, found on the grid.
    pub fn steer_cohesion(&self, id: FishId, radius: f32, speed: f32) -> Option<Steer> {
        let agent = self.fish(id)?.agent();
        let off = f32::NAN;
        self.crowd_sums(id, agent.pos, [off, off, radius])?
            .cohesion(&agent, speed)
    }

    /// The crowding sums of the `k` fish nearest to fish `id` (at `centre`, its root) within the
    /// widest of `radii`, summed nearest first (see [`World::steer_crowd_nearest`]).
    fn crowd_sums_nearest(
        &self,
        id: FishId,
        centre: Vec3,
        radii: [f32; 3],
        k: usize,
    ) -> Option<CrowdSums> {
        let me = self.state.fish.dense(id)?;
        let species = self.state.fish.species[me];
        let r2 = radii.map(squared);
        let mut sums = CrowdSums::default();
        let reach = widest(radii);
        if reach.is_nan() || k == 0 {
            return Some(sums);
        }
        let reach2 = reach * reach;
        let fish = &self.state.fish;
        // Neighbour order: squared distance (non-negative floats order like their bits), then id.
        let order =
            |d2: f32, o: usize| (u64::from(d2.to_bits()) << 32) | u64::from(fish.ids[o].index);
        NEAREST.with_borrow_mut(|chosen| {
            chosen.clear();
            let current = self.index.grid_exact && self.index.grid_positions_current;
            if current {
                // Nothing moved since the rebuild: the k nearest by the grid's positions (the
                // roots').
                self.nearest_on_grid(me, centre, reach, k, gather_limit(k), chosen);
            } else {
                // Fish moved (or were spawned or despawned): the candidates the unbounded query
                // would take (within reach by the grid and by their current positions), the
                // k nearest by current position.
                let mut add = |o: usize, grid_d2: f32| {
                    if o == me || grid_d2 > reach2 {
                        return;
                    }
                    let pos = fish.roots[o].pos;
                    let d2 = pos.distance_squared(centre);
                    if d2 <= reach2 {
                        chosen.push(Neighbour {
                            order: order(d2, o),
                            dense: o as u32,
                            slot: NO_SLOT,
                            within: f32::max(d2, grid_d2),
                            pos,
                        });
                    }
                };
                self.index
                    .grid
                    .for_each_within(centre, reach, |key, _, grid_d2| {
                        if let Some(o) = self.grid_key_dense(key) {
                            add(o, grid_d2);
                        }
                        true
                    });
                if !self.index.grid_exact {
                    for &spawned in &self.index.spawned_since_grid {
                        if let Some(o) = fish.dense(spawned) {
                            add(o, f32::NEG_INFINITY);
                        }
                    }
                }
                if chosen.len() > k {
                    chosen.select_nth_unstable_by_key(k - 1, |c| c.order);
                    chosen.truncate(k);
                }
            }
            chosen.sort_unstable_by_key(|c| c.order);
            // The crowding columns, when filled, hold each grid slot's species and heading
            // vector next to its position (the same values as the fish arrays while the grid is
            // current).
            let columns = &self.index.crowd_columns;
            let columns = (current && columns.len() == self.index.grid.len()).then_some(columns);
            let species_id = u32::from(species.0);
            // `within`: the larger of the current and the grid's squared distance (a candidate
            // counts for a rule when both put it within the radius, as the unbounded query).
            for n in chosen.iter() {
                let o = n.dense as usize;
                let d2 = n.pos.distance_squared(centre);
                let (same, heading) = match columns {
                    Some(c) if n.slot != NO_SLOT => {
                        let (heading, s, _) = c.candidate(n.slot as usize);
                        (s == species_id, Some(heading))
                    }
                    _ => (fish.species[o] == species, None),
                };
                sums.add(
                    centre,
                    n.pos,
                    d2,
                    [
                        n.within <= r2[0],
                        same && n.within <= r2[1],
                        same && n.within <= r2[2],
                    ],
                    || heading.unwrap_or_else(|| heading_vector(fish.roots[o].heading)),
                );
            }
        });
        Some(sums)
    }

    /// The `k` fish nearest to dense fish `me` at `centre` within `reach` by the grid's
    /// positions (the grid must be exact and current), pushed onto `chosen` in no particular
    /// order.
    ///
    /// Two ways to the same set: when the cells within `reach` hold at most `gather_max` fish
    /// (a sparse neighbourhood, or one a few cells wide), every one within reach is gathered in
    /// one pass over the cells' slots (four at a time on the crowding columns) and the `k`
    /// least selected; otherwise the cells are walked nearest first
    /// ([`Grid::for_each_run_nearest_first`](super::grid::Grid::for_each_run_nearest_first))
    /// and the walk stops once no cell left can hold a nearer fish. Either way the set is the
    /// `k` least by (squared distance, id) of the fish within reach, so which way was taken
    /// never shows.
    fn nearest_on_grid(
        &self,
        me: usize,
        centre: Vec3,
        reach: f32,
        k: usize,
        gather_max: usize,
        chosen: &mut Vec<Neighbour>,
    ) {
        let grid = &self.index.grid;
        let (keys, positions) = (grid.keys(), grid.positions());
        let fish = &self.state.fish;
        let reach2 = reach * reach;
        let columns = &self.index.crowd_columns;
        let have_columns = columns.len() == keys.len();
        self.want_crowd_columns();
        // Neighbour order: squared distance (non-negative floats order like their bits), then
        // id (from the columns, next to the position, when they are filled).
        let order = |d2: f32, slot: usize, o: usize| {
            let id = if have_columns {
                columns.id(slot)
            } else {
                fish.ids[o].index
            };
            (u64::from(d2.to_bits()) << 32) | u64::from(id)
        };
        // How many fish the cells within reach hold (stopping once past `gather_max`).
        let mut in_cells = 0usize;
        grid.for_each_run_within(centre, reach, |run| {
            in_cells += run.len();
            in_cells <= gather_max
        });
        GATHERED.with_borrow_mut(|cands| {
            // Candidates as (squared distance bits << 32) | slot: eight bytes each, ordered by
            // distance; their ids are read only for the few left at the end.
            cands.clear();
            let cand = |d2: f32, slot: usize| (u64::from(d2.to_bits()) << 32) | slot as u64;
            if in_cells <= gather_max {
                // Every other fish within reach, in one pass over the cells.
                if have_columns {
                    let query = LaneQuery::new(centre, me, SpeciesId(0), [-1.0; 3]);
                    let reach2 = wide::f32x4::splat(reach2);
                    grid.for_each_run_within(centre, reach, |run| {
                        columns.gather_run(run, &query, reach2, cands);
                        true
                    });
                } else {
                    grid.for_each_run_within(centre, reach, |run| {
                        for slot in run {
                            let d2 = positions[slot].distance_squared(centre);
                            if d2 <= reach2 && keys[slot] as usize != me {
                                cands.push(cand(d2, slot));
                            }
                        }
                        true
                    });
                }
            } else {
                // Cells nearest first, gathering every fish no farther than the k-th so far:
                // once k are held the list is cut to the k nearest (and any tied with the
                // k-th), once on reaching k and then each time it doubles, which tightens the
                // reach the walk skips cells by.
                let mut need = reach2;
                grid.for_each_run_nearest_first(centre, reach, |run| {
                    for slot in run {
                        let d2 = positions[slot].distance_squared(centre);
                        if d2 <= need && keys[slot] as usize != me {
                            cands.push(cand(d2, slot));
                        }
                    }
                    if cands.len() >= 2 * k || (cands.len() >= k && need == reach2) {
                        need = keep_nearest(cands, k);
                    }
                    need
                });
            }
            if cands.len() > k {
                keep_nearest(cands, k);
            }
            // The k nearest and any tied with the k-th: ties go by id.
            chosen.extend(cands.iter().map(|&c| {
                let slot = (c & u64::from(u32::MAX)) as usize;
                let o = keys[slot] as usize;
                let d2 = f32::from_bits((c >> 32) as u32);
                Neighbour {
                    order: order(d2, slot, o),
                    dense: o as u32,
                    slot: slot as u32,
                    within: d2,
                    pos: positions[slot],
                }
            }));
        });
        if chosen.len() > k {
            chosen.select_nth_unstable_by_key(k - 1, |c| c.order);
            chosen.truncate(k);
        }
    }

    /// Asks the next grid rebuild for the crowding columns (a crowd query is being made). A
    /// plain load first: a store per query would bounce the flag's cache line between the
    /// lanes.
    fn want_crowd_columns(&self) {
        if !self.index.crowd_wanted.load(Ordering::Relaxed) {
            self.index.crowd_wanted.store(true, Ordering::Relaxed);
        }
    }

    /// [`World::steer_crowd_bounded`]'s sums, with `dense` and `sample` in place of
    /// [`CROWD_DENSE`] and [`CROWD_SAMPLE`] (tests lower them); adds the grid slots sampled for
    /// alignment and cohesion to `sampled` (0 when every fish was summed).
    fn crowd_sums_bounded(
        &self,
        id: FishId,
        centre: Vec3,
        radii: [f32; 3],
        [dense, sample]: [usize; 2],
        sampled: &mut usize,
    ) -> Option<CrowdSums> {
        let me = self.state.fish.dense(id)?;
        let reach = widest(radii);
        let grid = &self.index.grid;
        let columns = &self.index.crowd_columns;
        let current = self.index.grid_exact && self.index.grid_positions_current;
        if reach.is_nan() || !current || columns.len() != grid.len() {
            // Nothing to scan, or no columns to sample from: the unbounded query (which also
            // asks the next rebuild for the columns).
            return self.crowd_sums(id, centre, radii);
        }
        self.want_crowd_columns();
        let species = self.state.fish.species[me];
        let r2 = radii.map(squared);
        // The unbounded scan (the same runs and lane sums as `crowd_sums`, so bitwise its
        // answer) until the cells hold more than `dense` fish.
        let query = LaneQuery::new(centre, me, species, r2);
        let mut lanes = LaneSums::default();
        let mut in_cells = 0usize;
        let mut crowded = false;
        grid.for_each_run_within(centre, reach, |run| {
            in_cells += run.len();
            crowded = in_cells > dense;
            if !crowded {
                columns.add_run(run, &query, &mut lanes);
            }
            !crowded
        });
        if !crowded {
            return Some(lanes.total());
        }
        // Dense: alignment and cohesion from every m-th group of four, m the smallest that
        // keeps the groups taken within the sample.
        let mut groups = 0usize;
        grid.for_each_run_within(centre, reach, |run| {
            groups += simd::groups_in(run);
            true
        });
        let limit = (sample / 4).max(1);
        let stride = groups.div_ceil(limit).max(1);
        let far = LaneQuery::new(centre, me, species, [-1.0, r2[1], r2[2]]);
        let mut far_sums = LaneSums::default();
        let mut next = 0usize;
        grid.for_each_run_within(centre, reach, |run| {
            *sampled += columns.add_run_sampled(run, &far, &mut far_sums, stride, &mut next);
            true
        });
        let mut sums = far_sums.total();
        // Separation: every fish within its radius, as `steer_separation` scans them.
        let near = LaneQuery::new(centre, me, species, [r2[0], -1.0, -1.0]);
        let mut near_sums = LaneSums::default();
        if r2[0] >= 0.0 {
            grid.for_each_run_within(centre, radii[0], |run| {
                columns.add_run(run, &near, &mut near_sums);
                true
            });
        }
        sums.push = near_sums.total().push;
        Some(sums)
    }

    /// The crowding sums of fish `id` at `centre` (its root) for the rules' `radii`
    /// (separation, alignment, cohesion), from one grid scan at the largest valid radius.
    fn crowd_sums(&self, id: FishId, centre: Vec3, radii: [f32; 3]) -> Option<CrowdSums> {
        let me = self.state.fish.dense(id)?;
        let species = self.state.fish.species[me];
        let r2 = radii.map(squared);
        let mut sums = CrowdSums::default();
        let reach = widest(radii);
        if reach.is_nan() {
            return Some(sums);
        }
        let reach2 = reach * reach;

        if self.index.grid_exact && self.index.grid_positions_current {
            // Nothing moved since the rebuild: everything the rules need lies in the grid's
            // cell-ordered arrays, read front to back.
            let keys = self.index.grid.keys();
            let positions = self.index.grid.positions();
            let species_of = &self.index.grid_species;
            // The columns are filled only for worlds whose behaviours make crowd queries: the
            // first query after a rebuild without them asks the next rebuild for them and
            // meanwhile scans the grid's positions and the roots' headings (the same values).
            if self.index.crowd_columns.len() == keys.len() {
                // Ask the next rebuild for them again. Without this, every other tick's queries
                // took the fallback below.
                self.want_crowd_columns();
                let query = LaneQuery::new(centre, me, species, r2);
                let mut lanes = LaneSums::default();
                let columns = &self.index.crowd_columns;
                self.index.grid.for_each_run_within(centre, reach, |run| {
                    columns.add_run(run, &query, &mut lanes);
                    true
                });
                return Some(lanes.total());
            }
            // No columns yet: ask the next rebuild for them.
            self.want_crowd_columns();
            self.index.grid.for_each_run_within(centre, reach, |run| {
                for slot in run {
                    let pos = positions[slot];
                    let d2 = pos.distance_squared(centre);
                    if d2 > reach2 || keys[slot] as usize == me {
                        continue;
                    }
                    let same = species_of[slot] == species;
                    sums.add(
                        centre,
                        pos,
                        d2,
                        [d2 <= r2[0], same && d2 <= r2[1], same && d2 <= r2[2]],
                        || heading_vector(self.state.fish.roots[keys[slot] as usize].heading),
                    );
                }
                true
            });
            return Some(sums);
        }

        // Fish moved (or were spawned or despawned) since the rebuild: a candidate counts for a
        // rule when the grid (its position at the rebuild) and its current position both put it
        // within the rule's radius, as the world's other neighbour queries do.
        let mut visit = |o: usize, grid_d2: f32| {
            if o == me {
                return;
            }
            let pos = self.state.fish.roots[o].pos;
            let d2 = pos.distance_squared(centre);
            let within = |r2: f32| grid_d2 <= r2 && d2 <= r2;
            let same = self.state.fish.species[o] == species;
            sums.add(
                centre,
                pos,
                d2,
                [within(r2[0]), same && within(r2[1]), same && within(r2[2])],
                || heading_vector(self.state.fish.roots[o].heading),
            );
        };
        self.index
            .grid
            .for_each_within(centre, reach, |key, _, grid_d2| {
                if let Some(o) = self.grid_key_dense(key) {
                    visit(o, grid_d2);
                }
                true
            });
        if !self.index.grid_exact {
            for &spawned in &self.index.spawned_since_grid {
                if let Some(o) = self.state.fish.dense(spawned) {
                    // Not in the grid: only the current position counts.
                    visit(o, f32::NEG_INFINITY);
                }
            }
        }
        Some(sums)
    }
}

/// Cuts `cands` ((squared distance bits << 32) | slot, more than `k` of them) to the `k` least
/// by distance and every one tied with the k-th in distance (so that ties can still go by id);
/// returns the k-th distance.
fn keep_nearest(cands: &mut Vec<u64>, k: usize) -> f32 {
    cands.select_nth_unstable(k - 1);
    let kth = cands[k - 1] >> 32;
    let mut end = k;
    for i in k..cands.len() {
        if cands[i] >> 32 == kth {
            cands.swap(end, i);
            end += 1;
        }
    }
    cands.truncate(end);
    f32::from_bits(kth as u32)
}

/// One neighbour a bounded crowd query chose.
#[derive(Clone, Copy, Debug)]
struct Neighbour {
    /// (squared distance, id) as one sortable key.
    order: u64,
    /// Dense index.
    dense: u32,
    /// Grid slot, or [`NO_SLOT`] when found off the grid's current positions.
    slot: u32,
    /// The squared distance each rule tests.
    within: f32,
    pos: Vec3,
}

/// [`Neighbour::slot`] of a neighbour not found on a current grid.
const NO_SLOT: u32 = u32::MAX;

/// [`gather_limit`] per neighbour asked for (see docs/performance.md, "Bounded perception at
/// 10,000 fish").
const GATHER_PER_NEIGHBOUR: usize = 16;

/// Most fish in the cells within reach for which a bounded crowd query of `k` gathers every one
/// within reach in one pass instead of walking the cells nearest first (see
/// [`World::nearest_on_grid`]).
fn gather_limit(k: usize) -> usize {
    k.saturating_mul(GATHER_PER_NEIGHBOUR)
}

thread_local! {
    /// Scratch of [`World::nearest_on_grid`]: its candidates.
    static GATHERED: std::cell::RefCell<Vec<u64>> =
        const { std::cell::RefCell::new(Vec::new()) };
    /// The chosen neighbours of a bounded crowd query (order key, dense index, squared distance
    /// each rule tests, position), per thread so queries take `&self` and never allocate once
    /// warm.
    static NEAREST: std::cell::RefCell<Vec<Neighbour>> =
        const { std::cell::RefCell::new(Vec::new()) };
}

#[cfg(test)]
mod tests {
    use super::super::SpawnParams;
    use super::super::test_world::{Scene, bits, random_scene, random_scene_sized};
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_pcg::Pcg32;

    /// The three rules as they were written before the one-pass scan: one neighbour query each.
    fn reference(w: &World, id: FishId, radii: [f32; 3], speed: f32) -> Crowd {
        let agent = w.fish(id).unwrap().agent();
        let me = w.state.fish.dense(id).unwrap();
        let species = w.state.fish.species[me];
        let mut push = Vec3::ZERO;
        w.for_each_fish_near(agent.pos, radii[0], |o, pos, d2| {
            if o != me && d2 > 0.0 {
                push += (agent.pos - pos) / d2;
            }
        });
        let mut sum = Vec2::ZERO;
        w.for_each_fish_near(agent.pos, radii[1], |o, _, _| {
            if o != me && w.state.fish.species[o] == species {
                let h = w.state.fish.roots[o].heading;
                sum += Vec2::new(h.cos(), h.sin());
            }
        });
        let (mut centre, mut n) = (Vec3::ZERO, 0u32);
        w.for_each_fish_near(agent.pos, radii[2], |o, pos, _| {
            if o != me && w.state.fish.species[o] == species {
                centre += pos;
                n += 1;
            }
        });
        Crowd {
            separation: (push.length_squared() > 1e-12).then(|| agent.toward(push, speed)),
            alignment: (sum.length_squared() > 1e-8).then(|| Steer {
                heading: sum.y.atan2(sum.x),
                depth: agent.depth(),
                speed,
            }),
            cohesion: (n > 0).then(|| steer::seek(&agent, centre / n as f32, speed)),
        }
    }

    fn crowd_bits(c: &Crowd) -> [Option<[u32; 3]>; 3] {
        [c.separation, c.alignment, c.cohesion].map(|s| s.map(|s| bits(&s)))
    }

    /// Whether two answers of a rule agree to rounding: both or neither, headings within
    /// 1e-4 rad, depths within 1e-3 world units (a fish is 50 long here: a depth is a point a
    /// few lengths away, built from sums whose terms partly cancel), speeds within 1e-5
    /// relative.
    fn agree(a: Option<Steer>, b: Option<Steer>) -> bool {
        match (a, b) {
            (None, None) => true,
            (Some(a), Some(b)) => {
                let turn = (a.heading - b.heading).rem_euclid(std::f32::consts::TAU);
                turn.min(std::f32::consts::TAU - turn) <= 1e-4
                    && (a.depth - b.depth).abs() <= 1e-3
                    && (a.speed - b.speed).abs() <= 1e-5 * a.speed.abs().max(1.0)
            }
            _ => false,
        }
    }

    /// How the one-pass answers must compare with the three-scan code's.
    #[derive(Clone, Copy, PartialEq)]
    enum Against {
        /// Bitwise: the one-by-one scans (the grid's positions, or the fish's own).
        Bitwise,
        /// To rounding: the four-lane scan of the grid's columns sums the same terms in
        /// another order.
        Rounding,
    }

    /// Checks every fish of `w` with each radius triple: one pass = three calls (bitwise) = the
    /// old code (as `against` says).
    fn check(w: &World, what: &str, radii: &[[f32; 3]], against: Against) -> [usize; 3] {
        let mut found = [0; 3];
        for id in w.fish_ids() {
            for &r in radii {
                let speed = 42.0;
                let crowd = w.steer_crowd(id, r[0], r[1], r[2], speed).unwrap();
                let separate = Crowd {
                    separation: w.steer_separation(id, r[0], speed),
                    alignment: w.steer_alignment(id, r[1], speed),
                    cohesion: w.steer_cohesion(id, r[2], speed),
                };
                assert_eq!(
                    crowd_bits(&crowd),
                    crowd_bits(&separate),
                    "{what}: fish {id:?}, radii {r:?}"
                );
                if r.iter().all(|r| *r >= 0.0) {
                    let old = reference(w, id, r, speed);
                    match against {
                        Against::Bitwise => assert_eq!(
                            crowd_bits(&crowd),
                            crowd_bits(&old),
                            "{what}: fish {id:?}, radii {r:?} against the three-scan code"
                        ),
                        Against::Rounding => {
                            for (rule, (new, old)) in [
                                (crowd.separation, old.separation),
                                (crowd.alignment, old.alignment),
                                (crowd.cohesion, old.cohesion),
                            ]
                            .into_iter()
                            .enumerate()
                            {
                                assert!(
                                    agree(new, old),
                                    "{what}: fish {id:?}, radii {r:?}, rule {rule}: {new:?} \
                                     against the three-scan code's {old:?}"
                                );
                            }
                        }
                    }
                }
                for (k, s) in [crowd.separation, crowd.alignment, crowd.cohesion]
                    .iter()
                    .enumerate()
                {
                    found[k] += usize::from(s.is_some());
                }
            }
        }
        found
    }

    #[test]
    fn one_pass_equals_the_three_rules_in_every_grid_state() {
        let Scene { mut world, l, .. } = random_scene(11, 400);
        let radii = [
            [1.0 * l, 4.0 * l, 6.0 * l],
            [6.0 * l, 1.0 * l, 4.0 * l],
            [4.0 * l, 6.0 * l, 1.0 * l],
            [2.5 * l, 2.5 * l, 2.5 * l],
            [0.0, 3.0 * l, f32::NAN],
            [-1.0, f32::INFINITY, 0.5 * l],
        ];
        // Grid current (the behaviour stage).
        let found = check(&world, "fresh grid", &radii, Against::Bitwise);
        // Every rule found neighbours for most fish: the comparison is not vacuous.
        assert!(
            found.iter().all(|&n| n > 400),
            "rules with an answer: {found:?}"
        );
        // Fish moved since the rebuild.
        for _ in 0..20 {
            world.step_motion(1.0 / 60.0);
        }
        check(&world, "moved", &radii, Against::Bitwise);
        // Fish spawned and despawned since the rebuild.
        let ids: Vec<_> = world.fish_ids().collect();
        for id in ids.iter().step_by(7) {
            world.despawn(*id);
        }
        let centre = (world.tank().min + world.tank().max) * 0.5;
        for k in 0..30 {
            let mut p = world.roots()[k];
            p.pos = (p.pos + centre) * 0.5;
            world
                .spawn(super::super::SpawnParams {
                    species: world.fish_species()[k],
                    pos: p.pos,
                    heading: 0.3 * k as f32,
                    pitch: 0.0,
                    speed: 10.0,
                    behavior: None,
                    seed: k as u64,
                })
                .unwrap();
        }
        check(&world, "spawned and despawned", &radii, Against::Bitwise);
        // The queries asked for the columns; the rebuild fills them.
        assert_eq!(world.index.crowd_columns.len(), 0);
        world.rebuild_grid();
        assert_eq!(world.index.crowd_columns.len(), world.num_fish());
        let found = check(&world, "rebuilt, columns filled", &radii, Against::Rounding);
        assert!(
            found.iter().all(|&n| n > 400),
            "rules with an answer on the columns: {found:?}"
        );
    }

    /// The bounded query by brute force: every other fish within the widest radius (by current
    /// position and, while the grid is not current, by the grid's), the `k` least by (squared
    /// distance, id), summed nearest first.
    fn brute_nearest(w: &World, id: FishId, radii: [f32; 3], speed: f32, k: usize) -> Crowd {
        let agent = w.fish(id).unwrap().agent();
        let me = w.state.fish.dense(id).unwrap();
        let species = w.state.fish.species[me];
        let r2 = radii.map(squared);
        let reach2 = r2.into_iter().fold(-1.0f32, f32::max);
        let mut grid_d2 = vec![f32::NEG_INFINITY; w.state.fish.len()];
        if !(w.index.grid_exact && w.index.grid_positions_current) {
            for (slot, &key) in w.index.grid.keys().iter().enumerate() {
                let o = w.grid_key_dense(key);
                if let Some(o) = o {
                    grid_d2[o] = w.index.grid.positions()[slot].distance_squared(agent.pos);
                }
            }
        }
        let mut all: Vec<(u64, usize, f32)> = (0..w.state.fish.len())
            .filter(|&o| o != me)
            .filter_map(|o| {
                let d2 = w.state.fish.roots[o].pos.distance_squared(agent.pos);
                let within = d2.max(grid_d2[o]);
                (within <= reach2).then(|| {
                    let key =
                        (u64::from(d2.to_bits()) << 32) | u64::from(w.state.fish.ids[o].index);
                    (key, o, within)
                })
            })
            .collect();
        all.sort_unstable_by_key(|c| c.0);
        all.truncate(k);
        let mut sums = CrowdSums::default();
        for (_, o, within) in all {
            let pos = w.state.fish.roots[o].pos;
            let same = w.state.fish.species[o] == species;
            sums.add(
                agent.pos,
                pos,
                pos.distance_squared(agent.pos),
                [
                    within <= r2[0],
                    same && within <= r2[1],
                    same && within <= r2[2],
                ],
                || heading_vector(w.state.fish.roots[o].heading),
            );
        }
        Crowd {
            separation: sums.separation(&agent, speed),
            alignment: sums.alignment(&agent, speed),
            cohesion: sums.cohesion(&agent, speed),
        }
    }

    /// The nearest-k query is bitwise the brute-force one in a dense school (16 fish per cubic
    /// body length, some on top of each other), with the grid current, moved and rebuilt; with
    /// no bound it is the unbounded query; and a bound changes the answer (a wrong neighbour
    /// set or sum would show).
    #[test]
    fn the_nearest_k_crowd_is_the_brute_force_one() {
        let Scene { mut world, l, .. } = random_scene(29, 4000);
        let radii = [[1.0 * l, 4.0 * l, 6.0 * l], [3.0 * l, 0.5 * l, f32::NAN]];
        let mut differs = 0;
        for what in ["fresh grid", "moved", "rebuilt"] {
            let mut compared = 0;
            for id in world.fish_ids().step_by(23) {
                for r in radii {
                    for k in [1, 7, 30] {
                        let got = world.steer_crowd_nearest(id, r, 42.0, Some(k)).unwrap();
                        let want = brute_nearest(&world, id, r, 42.0, k);
                        assert_eq!(
                            crowd_bits(&got),
                            crowd_bits(&want),
                            "{what}: fish {id:?}, radii {r:?}, k {k}"
                        );
                        compared += usize::from(got.cohesion.is_some());
                    }
                    let all = world.steer_crowd_nearest(id, r, 42.0, None).unwrap();
                    let unbounded = world.steer_crowd(id, r[0], r[1], r[2], 42.0).unwrap();
                    assert_eq!(crowd_bits(&all), crowd_bits(&unbounded), "{what}");
                    let seven = world.steer_crowd_nearest(id, r, 42.0, Some(7)).unwrap();
                    differs += usize::from(crowd_bits(&seven) != crowd_bits(&all));
                }
            }
            assert!(compared > 200, "{what}: answers compared: {compared}");
            if what == "fresh grid" {
                for _ in 0..10 {
                    world.step_motion(1.0 / 60.0);
                }
            } else {
                world.rebuild_grid();
            }
        }
        assert!(differs > 100, "the bound changed {differs} answers");
    }

    /// Both ways of the bounded query on a current grid — gathering every fish in the cells
    /// within reach, or walking the cells nearest first — choose the brute-force set (the k
    /// least by squared distance, then id, of the other fish within reach), with the crowding
    /// columns off and on, in a dense school and a sparse one, and so each other's.
    #[test]
    fn gathering_and_walking_choose_the_brute_force_nearest() {
        for (seed, n) in [(31, 4000), (37, 300)] {
            let Scene { mut world, l, .. } = random_scene(seed, n);
            for columns in [false, true] {
                if columns {
                    // A query asks the next rebuild for the columns.
                    world.index.crowd_wanted.store(true, Ordering::Relaxed);
                    world.rebuild_grid();
                }
                assert_eq!(world.index.crowd_columns.len() == n, columns);
                assert!(world.index.grid_exact && world.index.grid_positions_current);
                let mut compared = 0;
                for id in world.fish_ids().step_by(13) {
                    let me = world.state.fish.dense(id).unwrap();
                    let centre = world.state.fish.roots[me].pos;
                    for reach in [1.5 * l, 6.0 * l] {
                        let mut all: Vec<u64> = (0..n)
                            .filter(|&o| o != me)
                            .filter_map(|o| {
                                let d2 = world.state.fish.roots[o].pos.distance_squared(centre);
                                (d2 <= reach * reach).then(|| {
                                    (u64::from(d2.to_bits()) << 32)
                                        | u64::from(world.state.fish.ids[o].index)
                                })
                            })
                            .collect();
                        all.sort_unstable();
                        for k in [1, 7, 24, 30] {
                            let want = &all[..k.min(all.len())];
                            for gather_max in [0, usize::MAX] {
                                let mut got = Vec::new();
                                world.nearest_on_grid(me, centre, reach, k, gather_max, &mut got);
                                let mut got: Vec<u64> = got.iter().map(|c| c.order).collect();
                                got.sort_unstable();
                                assert_eq!(
                                    got, want,
                                    "{n} fish, columns {columns}, fish {id:?}, reach {reach}, \
                                     k {k}, gather up to {gather_max}"
                                );
                                compared += usize::from(want.len() == k && k > 1);
                            }
                        }
                    }
                }
                assert!(compared > 100, "full answers compared: {compared}");
            }
        }
    }

    /// A packed school: two fish per cubic body length, about five times the density of the
    /// 100,000-fish bench's schools (whose nearest neighbour of 0.76 lengths means ~0.4), so
    /// many crowd queries pass the dense limit; swimming roughly one way (headings spread ±0.6
    /// rad about a direction that turns along x); the grid rebuilt with the crowding columns.
    fn dense_school(seed: u64, fish: usize) -> Scene {
        let mut scene = random_scene_sized(seed, 0, Vec3::new(24.0, 12.0, 12.0));
        let (w, l) = (&mut scene.world, scene.l);
        let tank = *w.tank();
        let mut rng = Pcg32::seed_from_u64(seed);
        for i in 0..fish {
            let pos = Vec3::new(
                rng.random_range(tank.min.x..tank.max.x),
                rng.random_range(tank.min.y..tank.max.y),
                rng.random_range(tank.min.z..tank.max.z),
            );
            w.spawn(SpawnParams {
                species: scene.species[usize::from(i % 10 == 9)],
                pos,
                heading: 0.1 * pos.x / l + rng.random_range(-0.6..0.6),
                pitch: 0.0,
                speed: 40.0,
                behavior: None,
                seed: i as u64,
            })
            .unwrap();
        }
        w.index.crowd_wanted.store(true, Ordering::Relaxed);
        w.rebuild_grid();
        assert_eq!(w.index.crowd_columns.len(), fish);
        scene
    }

    /// The bounded crowd query (`shoal.crowd`'s default). With the shipped limit, in a packed
    /// school, it is the unbounded query bit for bit wherever the
    /// cells hold at most [`CROWD_DENSE`] fish and samples where they hold more. Forced to
    /// sample everywhere (a limit of 0): separation is still bitwise `steer_separation`,
    /// alignment and cohesion sum at most [`CROWD_SAMPLE`] slots — a part of the fish — and
    /// stay close to the full sums. A sample of the wrong fish, a wrong stride or separation
    /// taken from the sample would show.
    #[test]
    fn the_bounded_crowd_is_the_full_one_until_dense_then_a_close_sample() {
        let Scene { world, l, .. } = dense_school(41, 7000);
        let radii = [1.0 * l, 4.0 * l, 6.0 * l];
        let speed = 42.0;
        let (mut full_answers, mut sampled_answers) = (0, 0);
        let (mut turns, mut offsets) = (Vec::new(), Vec::new());
        for id in world.fish_ids().step_by(7) {
            let agent = world.fish(id).unwrap().agent();
            let as_crowd = |s: &CrowdSums| Crowd {
                separation: s.separation(&agent, speed),
                alignment: s.alignment(&agent, speed),
                cohesion: s.cohesion(&agent, speed),
            };
            let full = world
                .steer_crowd(id, radii[0], radii[1], radii[2], speed)
                .unwrap();
            let full_sums = world.crowd_sums(id, agent.pos, radii).unwrap();
            // The shipped limit.
            let shipped = world.steer_crowd_bounded(id, radii, speed).unwrap();
            let mut sampled = 0;
            let sums = world
                .crowd_sums_bounded(id, agent.pos, radii, SHIPPED, &mut sampled)
                .unwrap();
            assert_eq!(crowd_bits(&shipped), crowd_bits(&as_crowd(&sums)));
            assert!(sampled <= CROWD_SAMPLE, "{id:?}: {sampled} slots sampled");
            if sampled == 0 {
                full_answers += 1;
                assert_eq!(crowd_bits(&shipped), crowd_bits(&full), "{id:?}");
            } else {
                sampled_answers += 1;
                assert!(
                    sums.count < full_sums.count * 3 / 4,
                    "{id:?}: {} of {} in the sample",
                    sums.count,
                    full_sums.count
                );
                let (a, b) = (shipped.alignment.unwrap(), full.alignment.unwrap());
                let turn = (a.heading - b.heading).rem_euclid(std::f32::consts::TAU);
                turns.push(turn.min(std::f32::consts::TAU - turn));
                let centroid = |s: &CrowdSums| s.centre / s.count as f32;
                offsets.push(centroid(&sums).distance(centroid(&full_sums)) / l);
            }
            // Separation is never sampled: forced to sample everywhere, and from few slots.
            let forced = world
                .crowd_sums_bounded(id, agent.pos, radii, [0, 64], &mut 0)
                .unwrap();
            assert!(forced.count < full_sums.count / 2, "{id:?}: forced sample");
            let separate = world.steer_separation(id, radii[0], speed);
            for answer in [shipped.separation, as_crowd(&forced).separation] {
                assert_eq!(
                    answer.map(|s| bits(&s)),
                    separate.map(|s| bits(&s)),
                    "{id:?}: separation from every fish within its radius"
                );
            }
        }
        assert!(
            full_answers > 100 && sampled_answers > 100,
            "{full_answers} full, {sampled_answers} sampled"
        );
        let median = |v: &mut Vec<f32>| {
            v.sort_by(f32::total_cmp);
            (v[v.len() / 2], v[v.len() - 1])
        };
        let ((turn, worst_turn), (offset, worst_offset)) =
            (median(&mut turns), median(&mut offsets));
        eprintln!(
            "{full_answers} full, {sampled_answers} sampled: alignment off by {turn} rad \
             (median), {worst_turn} (worst); centroid by {offset} L, {worst_offset} L"
        );
        assert!(
            turn < 0.05 && worst_turn < 0.3,
            "alignment off by {turn} / {worst_turn} rad"
        );
        assert!(
            offset < 0.2 && worst_offset < 1.5,
            "centroid off by {offset} / {worst_offset} L"
        );
    }

    #[test]
    fn a_stale_fish_has_no_crowd() {
        let Scene { mut world, l, .. } = random_scene(3, 20);
        let id = world.fish_ids().next().unwrap();
        world.despawn(id);
        assert_eq!(world.steer_crowd(id, l, l, l, 1.0), None);
    }
}
