//! The crowd query's scan over the grid's cell-ordered columns, four candidates at a time.
//!
//! [`CrowdColumns`] holds, per grid slot, what the three rules read of a candidate — position,
//! heading cosine and sine, species, dense index — one column per field, so a run of candidates
//! loads as whole SIMD vectors (`wide::f32x4`, SSE2 on every x86-64). Slot s always goes to lane
//! s mod 4 (a run is read in the aligned groups of four it overlaps, the slots outside it masked
//! off), and each lane adds its candidates in slot order; the lanes are added together once, at
//! the end of the query ([`LaneSums::total`]). So a lane's sum depends only on which candidates
//! lie within the radius, not on how the grid cut them into runs: a single rule, whose scan
//! visits fewer runs at its smaller radius, gets bitwise the combined query's answer. The sums
//! are the same terms as a one-by-one scan (the squared distance is computed the same way, so
//! the same candidates fall within each radius) added in another order: they differ from it by
//! rounding only.

use std::ops::Range;

use glam::{Vec2, Vec3};
use wide::{f32x4, u32x4};

use super::CrowdSums;
use crate::world::SpeciesId;

/// Per grid slot (the grid's cell order): the candidate fields a crowd query reads, in groups
/// of four slots (group g holds slots 4g to 4g + 3, one SIMD vector per field), the last group
/// padded with slots no rule counts. Filled by the grid rebuild while crowd queries are being
/// made, else empty.
#[derive(Debug, Default)]
pub(in crate::world) struct CrowdColumns {
    groups: Vec<Candidates>,
    /// Slots filled (without the padding).
    slots: usize,
    /// Scratch of [`CrowdColumns::fill`]: each fish's heading vector and id index, in fish
    /// order.
    headings: Vec<Vec2>,
}

/// The key of a padding slot: never a fish's dense index.
const PAD_KEY: u32 = u32::MAX;

/// Lanes at or after the first slot of a run that starts `k` slots into its group.
const FROM: [[u32; 4]; 4] = [
    [!0, !0, !0, !0],
    [0, !0, !0, !0],
    [0, 0, !0, !0],
    [0, 0, 0, !0],
];

/// Lanes before the end of a run that ends `k` slots into its group (k = 0: the whole group).
const BEFORE: [[u32; 4]; 4] = [
    [!0, !0, !0, !0],
    [!0, 0, 0, 0],
    [!0, !0, 0, 0],
    [!0, !0, !0, 0],
];

impl CrowdColumns {
    /// Slots filled (0 when the columns are off).
    pub(in crate::world) fn len(&self) -> usize {
        self.slots
    }

    /// Empties the columns (keeping their memory).
    pub(in crate::world) fn clear(&mut self) {
        self.groups.clear();
        self.slots = 0;
    }

    /// The heading vectors' scratch, `num_fish` long, for a pass that has every fish's heading
    /// at hand to write (`crowd::heading_vector` of each fish's heading, in fish order) before
    /// [`CrowdColumns::fill`] is called with no `heading`: the motion pass of `World::advance`.
    pub(in crate::world) fn headings_to_fill(&mut self, num_fish: usize) -> &mut [Vec2] {
        self.headings.resize(num_fish, Vec2::ZERO);
        &mut self.headings
    }

    /// Fills the columns from the grid's cell-ordered `keys`, `positions` and `species`, with
    /// the heading of fish `k` (a key, `0..num_fish`) read by `heading(k)` (`None`: as written
    /// into [`CrowdColumns::headings_to_fill`]) and its id's index by `id(k)`, over both cores.
    /// The headings' cosines and sines are taken first in fish order, where `heading` reads
    /// memory in order, then gathered in slot order.
    pub(in crate::world) fn fill(
        &mut self,
        keys: &[u32],
        positions: &[Vec3],
        species: &[SpeciesId],
        num_fish: usize,
        heading: Option<impl Fn(usize) -> f32 + Sync>,
        id: impl Fn(usize) -> u32 + Sync,
    ) {
        use rayon::prelude::*;
        self.slots = keys.len();
        match heading {
            Some(heading) => {
                self.headings.resize(num_fish, Vec2::ZERO);
                self.headings
                    .par_iter_mut()
                    .enumerate()
                    .with_min_len(1024)
                    .for_each(|(k, h)| *h = super::heading_vector(heading(k)));
            }
            None => assert_eq!(
                self.headings.len(),
                num_fish,
                "the heading vectors were written for every fish (CrowdColumns::headings_to_fill)"
            ),
        }
        let headings = &self.headings;
        self.groups.resize(keys.len().div_ceil(4), Candidates::PAD);
        self.groups
            .par_iter_mut()
            .zip(keys.par_chunks(4))
            .zip(positions.par_chunks(4))
            .zip(species.par_chunks(4))
            .with_min_len(256)
            .for_each(|(((group, keys), positions), species)| {
                // Padding: NaN positions are within no radius, and the key is no fish's.
                let mut f = [
                    [f32::NAN; 4],
                    [f32::NAN; 4],
                    [f32::NAN; 4],
                    [0.0; 4],
                    [0.0; 4],
                ];
                let (mut sp, mut key, mut ids) = ([0; 4], [PAD_KEY; 4], [0; 4]);
                for (lane, ((&k, p), s)) in keys.iter().zip(positions).zip(species).enumerate() {
                    let h = headings[k as usize];
                    (f[0][lane], f[1][lane], f[2][lane]) = (p.x, p.y, p.z);
                    (f[3][lane], f[4][lane]) = (h.x, h.y);
                    (sp[lane], key[lane], ids[lane]) = (u32::from(s.0), k, id(k as usize));
                }
                *group = Candidates {
                    x: f32x4::new(f[0]),
                    y: f32x4::new(f[1]),
                    z: f32x4::new(f[2]),
                    cos: f32x4::new(f[3]),
                    sin: f32x4::new(f[4]),
                    species: u32x4::new(sp),
                    key: u32x4::new(key),
                    id: u32x4::new(ids),
                };
            });
    }

    /// Adds the candidates of grid slots `run` to `sums` for `query`.
    #[inline]
    pub(super) fn add_run(&self, run: Range<usize>, query: &LaneQuery, sums: &mut LaneSums) {
        for (g, valid) in groups_of(run) {
            sums.add(query, valid, &self.groups[g]);
        }
    }

    /// Adds every `stride`-th lane group of grid slots `run` to `sums` for `query`, counting
    /// groups across calls in `next` (groups still to skip before the next one taken; start at
    /// 0 to take the first). Returns the slots taken.
    #[inline]
    pub(super) fn add_run_sampled(
        &self,
        run: Range<usize>,
        query: &LaneQuery,
        sums: &mut LaneSums,
        stride: usize,
        next: &mut usize,
    ) -> usize {
        let mut taken = 0;
        for (g, valid) in groups_of(run) {
            if *next == 0 {
                sums.add(query, valid, &self.groups[g]);
                taken += valid.to_bitmask().count_ones() as usize;
                *next = stride;
            }
            *next -= 1;
        }
        taken
    }

    /// Pushes `(squared distance bits << 32) | slot` onto `out` for each candidate of grid
    /// slots `run` within `reach2` of `query`'s centre, but the querying fish, in slot order.
    /// The squared distance is the one [`LaneSums`] tests (so `Vec3::distance_squared`'s,
    /// bitwise).
    #[inline]
    pub(super) fn gather_run(
        &self,
        run: Range<usize>,
        query: &LaneQuery,
        reach2: f32x4,
        out: &mut Vec<u64>,
    ) {
        for (g, valid) in groups_of(run) {
            let c = &self.groups[g];
            let d2 = query.distance_squared(c);
            let take = valid & !c.key.simd_eq(query.me) & d2.simd_le(reach2).to_bits();
            let mut lanes = take.to_bitmask();
            if lanes == 0 {
                continue;
            }
            let d2 = d2.to_array();
            while lanes != 0 {
                let lane = lanes.trailing_zeros() as usize;
                out.push((u64::from(d2[lane].to_bits()) << 32) | (4 * g + lane) as u64);
                lanes &= lanes - 1;
            }
        }
    }

    /// The candidate in grid slot `slot`: its heading vector (cosine, sine), species and id's
    /// index.
    #[inline]
    pub(super) fn candidate(&self, slot: usize) -> (Vec2, u32, u32) {
        let c = &self.groups[slot / 4];
        let lane = slot % 4;
        (
            Vec2::new(c.cos.to_array()[lane], c.sin.to_array()[lane]),
            c.species.to_array()[lane],
            c.id.to_array()[lane],
        )
    }

    /// The id's index of the candidate in grid slot `slot`.
    #[inline]
    pub(super) fn id(&self, slot: usize) -> u32 {
        self.groups[slot / 4].id.to_array()[slot % 4]
    }
}

/// How many lane groups hold grid slots `run` (as [`groups_of`] yields them).
#[inline]
pub(super) fn groups_in(run: Range<usize>) -> usize {
    if run.start < run.end {
        (run.end - 1) / 4 - run.start / 4 + 1
    } else {
        0
    }
}

/// The lane groups holding grid slots `run`, each with the mask of its lanes inside `run`
/// (nothing for an empty run).
#[inline]
fn groups_of(run: Range<usize>) -> impl Iterator<Item = (usize, u32x4)> {
    let Range { start, end } = run;
    let (first, last) = (start / 4, end.saturating_sub(1) / 4);
    let groups = (start < end).then_some(first..=last).into_iter().flatten();
    groups.map(move |g| {
        let mut valid = u32x4::splat(!0);
        if g == first {
            valid &= u32x4::new(FROM[start % 4]);
        }
        if g == last {
            valid &= u32x4::new(BEFORE[end % 4]);
        }
        (g, valid)
    })
}

/// Four candidates' fields.
#[derive(Clone, Copy, Debug)]
struct Candidates {
    x: f32x4,
    y: f32x4,
    z: f32x4,
    cos: f32x4,
    sin: f32x4,
    species: u32x4,
    key: u32x4,
    /// The fish's id's index (the tie-break of the nearest-k query's order).
    id: u32x4,
}

/// One crowd query, splatted across the lanes.
pub(super) struct LaneQuery {
    centre: [f32x4; 3],
    me: u32x4,
    species: u32x4,
    /// Squared radii of separation, alignment and cohesion (−1 for a rule that is off).
    r2: [f32x4; 3],
}

impl Candidates {
    /// Four padding slots.
    const PAD: Self = Self {
        x: f32x4::splat(f32::NAN),
        y: f32x4::splat(f32::NAN),
        z: f32x4::splat(f32::NAN),
        cos: f32x4::ZERO,
        sin: f32x4::ZERO,
        species: u32x4::ZERO,
        key: u32x4::splat(PAD_KEY),
        id: u32x4::ZERO,
    };
}

impl LaneQuery {
    /// The query of the fish with dense index `me` and `species` at `centre`, for the rules'
    /// squared radii `r2`.
    pub(super) fn new(centre: Vec3, me: usize, species: SpeciesId, r2: [f32; 3]) -> Self {
        Self {
            centre: [
                f32x4::splat(centre.x),
                f32x4::splat(centre.y),
                f32x4::splat(centre.z),
            ],
            me: u32x4::splat(me as u32),
            species: u32x4::splat(u32::from(species.0)),
            r2: r2.map(f32x4::splat),
        }
    }

    /// Squared distances from the centre to four candidates, summed as
    /// `Vec3::distance_squared` sums them.
    #[inline(always)]
    fn distance_squared(&self, c: &Candidates) -> f32x4 {
        let dx = self.centre[0] - c.x;
        let dy = self.centre[1] - c.y;
        let dz = self.centre[2] - c.z;
        dx * dx + dy * dy + dz * dz
    }
}

/// The rules' sums, one per lane (see the module documentation).
#[derive(Default)]
pub(super) struct LaneSums {
    push: [f32x4; 3],
    heading: [f32x4; 2],
    centre: [f32x4; 3],
    count: u32x4,
}

impl LaneSums {
    /// Adds the `valid` ones of four candidates to the rules whose radius they lie within
    /// (never the querying fish itself). Masked-out lanes add +0, which leaves a sum unchanged.
    #[inline(always)]
    fn add(&mut self, q: &LaneQuery, valid: u32x4, c: &Candidates) {
        // centre − pos, and its squared length summed as `Vec3::distance_squared` sums it.
        let dx = q.centre[0] - c.x;
        let dy = q.centre[1] - c.y;
        let dz = q.centre[2] - c.z;
        let d2 = dx * dx + dy * dy + dz * dz;
        let other = valid & !c.key.simd_eq(q.me);
        let same = other & c.species.simd_eq(q.species);
        let within = |r2: f32x4| d2.simd_le(r2).to_bits();
        // Few candidates are this close: most groups skip the division.
        let close = other & within(q.r2[0]) & d2.simd_gt(f32x4::ZERO).to_bits();
        if close.any() {
            let m = f32x4::from_bits(close);
            self.push[0] += (dx / d2) & m;
            self.push[1] += (dy / d2) & m;
            self.push[2] += (dz / d2) & m;
        }
        let aligned = f32x4::from_bits(same & within(q.r2[1]));
        self.heading[0] += c.cos & aligned;
        self.heading[1] += c.sin & aligned;
        let cohesive = same & within(q.r2[2]);
        let m = f32x4::from_bits(cohesive);
        self.centre[0] += c.x & m;
        self.centre[1] += c.y & m;
        self.centre[2] += c.z & m;
        self.count += cohesive & u32x4::ONE;
    }

    /// The lanes added together: (lane 0 + lane 1) + (lane 2 + lane 3), field by field.
    pub(super) fn total(&self) -> CrowdSums {
        let add = |v: f32x4| {
            let a = v.to_array();
            (a[0] + a[1]) + (a[2] + a[3])
        };
        CrowdSums {
            push: Vec3::new(add(self.push[0]), add(self.push[1]), add(self.push[2])),
            heading: Vec2::new(add(self.heading[0]), add(self.heading[1])),
            centre: Vec3::new(
                add(self.centre[0]),
                add(self.centre[1]),
                add(self.centre[2]),
            ),
            count: self.count.to_array().iter().sum(),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// 37 fish on a line, two species, the querying fish (dense index 5) among them.
    fn columns() -> (CrowdColumns, LaneQuery) {
        let n = 37u32;
        let keys: Vec<u32> = (0..n).rev().collect();
        let positions: Vec<Vec3> = (0..n)
            .map(|i| Vec3::new(i as f32 * 0.7 - 9.0, (i % 5) as f32 * 0.3, 0.1 * i as f32))
            .collect();
        let species: Vec<SpeciesId> = (0..n).map(|i| SpeciesId((i % 3 == 0) as u16)).collect();
        let mut c = CrowdColumns::default();
        c.fill(
            &keys,
            &positions,
            &species,
            n as usize,
            Some(|k: usize| 0.37 * k as f32),
            |k| 1000 + k as u32,
        );
        let me = 5usize;
        let slot = keys.iter().position(|&k| k as usize == me).unwrap();
        let q = LaneQuery::new(positions[slot], me, species[slot], [4.0, 36.0, 100.0]);
        (c, q)
    }

    fn sums_bits(s: &CrowdSums) -> [u32; 9] {
        [
            s.push.x,
            s.push.y,
            s.push.z,
            s.heading.x,
            s.heading.y,
            s.centre.x,
            s.centre.y,
            s.centre.z,
            s.count as f32,
        ]
        .map(f32::to_bits)
    }

    #[test]
    fn a_run_cut_anywhere_sums_bitwise_the_same() {
        let (c, q) = columns();
        assert_eq!(c.len(), 37);
        let whole = {
            let mut s = LaneSums::default();
            c.add_run(0..37, &q, &mut s);
            s.total()
        };
        // Every candidate but the fish itself that is within the cohesion radius counts once.
        assert!(whole.count > 5, "{}", whole.count);
        for cut in 0..=37 {
            for cut2 in cut..=37 {
                let mut s = LaneSums::default();
                c.add_run(0..cut, &q, &mut s);
                c.add_run(cut..cut2, &q, &mut s);
                c.add_run(cut2..37, &q, &mut s);
                assert_eq!(
                    sums_bits(&s.total()),
                    sums_bits(&whole),
                    "cuts {cut}, {cut2}"
                );
            }
        }
    }

    #[test]
    fn lanes_sum_what_a_one_by_one_scan_sums() {
        let (c, q) = columns();
        let mut s = LaneSums::default();
        c.add_run(3..31, &q, &mut s);
        let lanes = s.total();
        let [cx, cy, cz] = q.centre.map(|v| v.to_array()[0]);
        let centre = Vec3::new(cx, cy, cz);
        let r2 = q.r2.map(|v| v.to_array()[0]);
        let me = q.me.to_array()[0];
        let sp = q.species.to_array()[0];
        let mut one = CrowdSums::default();
        let at = |col: fn(&Candidates) -> f32x4, i: usize| col(&c.groups[i / 4]).to_array()[i % 4];
        let at_u =
            |col: fn(&Candidates) -> u32x4, i: usize| col(&c.groups[i / 4]).to_array()[i % 4];
        for i in 3..31 {
            let pos = Vec3::new(at(|g| g.x, i), at(|g| g.y, i), at(|g| g.z, i));
            let d2 = pos.distance_squared(centre);
            let other = at_u(|g| g.key, i) != me;
            let same = other && at_u(|g| g.species, i) == sp;
            if other && d2 <= r2[0] && d2 > 0.0 {
                one.push += (centre - pos) / d2;
            }
            if same && d2 <= r2[1] {
                one.heading += Vec2::new(at(|g| g.cos, i), at(|g| g.sin, i));
            }
            if same && d2 <= r2[2] {
                one.centre += pos;
                one.count += 1;
            }
        }
        assert_eq!(lanes.count, one.count);
        assert!(one.count > 3 && one.push != Vec3::ZERO && one.heading != Vec2::ZERO);
        assert!(lanes.push.abs_diff_eq(one.push, 1e-5), "{lanes:?} {one:?}");
        assert!(
            lanes.heading.abs_diff_eq(one.heading, 1e-5),
            "{lanes:?} {one:?}"
        );
        assert!(
            lanes.centre.abs_diff_eq(one.centre, 1e-3),
            "{lanes:?} {one:?}"
        );
    }
}
