//! Uniform spatial grid: the index the perception layer's sensor queries run on (issue 7: cost grows
//! with neighbours, not with the square of the fish count).
//!
//! The grid is rebuilt from scratch every tick by a counting sort into flat arrays: count items per
//! cell, prefix-sum the counts into `cell_start`, scatter the items. Within a cell items keep their
//! input order, so queries visit items in a deterministic order. After the first rebuild at a given
//! size no rebuild allocates. [`Grid::rebuild_indexed`] (the fish grid's) does the same over every
//! core, slot for slot.
//!
//! Items outside the grid's bounds are clamped into the border cells, so a query still finds them:
//! clamping is monotonic, so an item within `radius` of the query point always lies in the (clamped)
//! block of cells the query visits.

use std::ops::Range;

use glam::Vec3;

/// Upper bound on the number of cells; a cell size that would give more is enlarged.
pub const MAX_CELLS: usize = 1 << 18;

/// Fewest items [`Grid::rebuild_indexed`] hands a thread; below it one thread does the scatter.
const PAR_MIN_ITEMS: usize = 2048;

/// Most blocks [`Grid::rebuild_indexed`] scatters in parallel.
const MAX_SCATTER_BLOCKS: usize = 16;

/// A uniform grid over an axis-aligned box, holding items (by `u32` key) with positions.
#[derive(Debug, Clone)]
pub struct Grid {
    origin: Vec3,
    cell_size: f32,
    inv_cell_size: f32,
    dims: [u32; 3],
    /// `cell_start[c]..cell_start[c + 1]` are the entries of cell `c`; length = cells + 1.
    cell_start: Vec<u32>,
    /// Item keys sorted by cell.
    keys: Vec<u32>,
    /// Item positions in the same order as `keys`.
    positions: Vec<Vec3>,
    /// Scratch: the cell of each input item, in input order.
    cell_of: Vec<u32>,
    /// Scratch of [`Grid::rebuild_indexed`]: each cell's next free slot while scattering.
    cursor: Vec<u32>,
}

impl Default for Grid {
    fn default() -> Self {
        Self::new(Vec3::ZERO, Vec3::ONE, 1.0)
    }
}

impl Grid {
    /// A grid over the box `min..max` with cubic cells of `cell_size` world units (enlarged if the
    /// box would need more than [`MAX_CELLS`] cells; a non-finite or non-positive size means one
    /// cell spanning the box).
    pub fn new(min: Vec3, max: Vec3, cell_size: f32) -> Self {
        let mut grid = Self {
            origin: Vec3::ZERO,
            cell_size: 1.0,
            inv_cell_size: 1.0,
            dims: [1, 1, 1],
            cell_start: Vec::new(),
            keys: Vec::new(),
            positions: Vec::new(),
            cell_of: Vec::new(),
            cursor: Vec::new(),
        };
        grid.configure(min, max, cell_size);
        grid
    }

    /// Re-derives the cell layout for the box `min..max` and `cell_size`; clears the contents.
    pub fn configure(&mut self, min: Vec3, max: Vec3, cell_size: f32) {
        let extent = (max - min).max(Vec3::splat(1e-6));
        let mut size = if cell_size.is_finite() && cell_size > 0.0 {
            cell_size
        } else {
            extent.max_element()
        };
        let dims_for = |size: f32| {
            let d = (extent / size).ceil().max(Vec3::ONE);
            [d.x as u64, d.y as u64, d.z as u64]
        };
        let mut dims = dims_for(size);
        while dims[0] * dims[1] * dims[2] > MAX_CELLS as u64 {
            size *= 1.25;
            dims = dims_for(size);
        }
        self.origin = min;
        self.cell_size = size;
        self.inv_cell_size = 1.0 / size;
        self.dims = [dims[0] as u32, dims[1] as u32, dims[2] as u32];
        let cells = self.num_cells();
        self.cell_start.clear();
        self.cell_start.resize(cells + 1, 0);
        self.keys.clear();
        self.positions.clear();
    }

    /// Edge length of a cell, world units.
    pub fn cell_size(&self) -> f32 {
        self.cell_size
    }

    /// Cells along x, y and z.
    pub fn dims(&self) -> [u32; 3] {
        self.dims
    }

    /// Total number of cells.
    pub fn num_cells(&self) -> usize {
        self.dims.iter().map(|&d| d as usize).product()
    }

    /// Number of items stored by the last rebuild.
    pub fn len(&self) -> usize {
        self.keys.len()
    }

    /// Whether the last rebuild stored no item.
    pub fn is_empty(&self) -> bool {
        self.keys.is_empty()
    }

    /// Cell coordinate of `p` along each axis, clamped into the grid.
    fn coord(&self, p: Vec3) -> [u32; 3] {
        let c = (p - self.origin) * self.inv_cell_size;
        [
            clamp_cell(c.x, self.dims[0]),
            clamp_cell(c.y, self.dims[1]),
            clamp_cell(c.z, self.dims[2]),
        ]
    }

    /// [`Grid::coord`]'s x coordinate alone.
    fn coord_x(&self, x: f32) -> u32 {
        clamp_cell((x - self.origin.x) * self.inv_cell_size, self.dims[0])
    }

    fn cell_index(&self, c: [u32; 3]) -> usize {
        (c[2] as usize * self.dims[1] as usize + c[1] as usize) * self.dims[0] as usize
            + c[0] as usize
    }

    /// Rebuilds from `items` (key, position) by a counting sort. Never allocates once the arrays
    /// have grown to the item count.
    pub fn rebuild(&mut self, items: impl ExactSizeIterator<Item = (u32, Vec3)> + Clone) {
        let n = items.len();
        self.cell_start.fill(0);
        self.cell_of.clear();
        for (_, p) in items.clone() {
            let cell = self.cell_index(self.coord(p));
            self.cell_of.push(cell as u32);
            self.cell_start[cell + 1] += 1;
        }
        for c in 0..self.num_cells() {
            self.cell_start[c + 1] += self.cell_start[c];
        }
        self.keys.clear();
        self.keys.resize(n, 0);
        self.positions.clear();
        self.positions.resize(n, Vec3::ZERO);
        // Scatter using cell_start as a running cursor, then shift it back: cursor of cell c ends
        // at the start of cell c + 1.
        for ((key, p), &cell) in items.zip(self.cell_of.iter()) {
            let slot = &mut self.cell_start[cell as usize];
            self.keys[*slot as usize] = key;
            self.positions[*slot as usize] = p;
            *slot += 1;
        }
        for c in (1..=self.num_cells()).rev() {
            self.cell_start[c] = self.cell_start[c - 1];
        }
        self.cell_start[0] = 0;
    }

    /// [`Grid::rebuild`] of items keyed by their index, `0..n` at `pos_of(i)`, over every core:
    /// the same keys, positions and cells, slot for slot.
    ///
    /// The cells are worked out in parallel, counted and prefix-summed on one thread (a few
    /// instructions an item), then scattered in parallel by blocks of consecutive cells: each
    /// block's slots are one contiguous run of the arrays, so each thread owns its run, and it
    /// scans the items in input order, so items keep that order within a cell. Once the arrays
    /// have grown to the item count it allocates only the list of blocks (one per thread).
    pub fn rebuild_indexed(&mut self, n: usize, pos_of: impl Fn(usize) -> Vec3 + Sync) {
        use rayon::prelude::*;
        let cells = self.num_cells();
        self.cell_of.resize(n, 0);
        let mut cell_of = std::mem::take(&mut self.cell_of);
        let grid = &*self;
        cell_of
            .par_iter_mut()
            .enumerate()
            .with_min_len(PAR_MIN_ITEMS)
            .for_each(|(i, c)| *c = grid.cell_index(grid.coord(pos_of(i))) as u32);
        self.cell_of = cell_of;
        // Counts, then the start of each cell (cell_start[c + 1] is the end of cell c).
        self.cell_start.fill(0);
        for &c in &self.cell_of {
            self.cell_start[c as usize + 1] += 1;
        }
        for c in 0..cells {
            self.cell_start[c + 1] += self.cell_start[c];
        }
        self.keys.resize(n, 0);
        self.positions.resize(n, Vec3::ZERO);
        // Blocks of consecutive cells holding about n / blocks items each, and their slot runs.
        let blocks = rayon::current_num_threads().clamp(1, MAX_SCATTER_BLOCKS);
        let blocks = if n < PAR_MIN_ITEMS { 1 } else { blocks };
        let mut ends = [0usize; MAX_SCATTER_BLOCKS];
        let mut c = 0;
        for (b, end) in ends.iter_mut().enumerate().take(blocks) {
            let want = (n * (b + 1)).div_ceil(blocks) as u32;
            while c < cells && self.cell_start[c + 1] <= want && b + 1 < blocks {
                c += 1;
            }
            *end = if b + 1 == blocks { cells } else { c };
        }
        // Running slot of each cell (from its start), split with the arrays by block.
        self.cursor.clear();
        self.cursor.extend_from_slice(&self.cell_start[..cells]);
        let mut work = Vec::with_capacity(blocks);
        let (mut keys, mut positions) = (&mut self.keys[..], &mut self.positions[..]);
        let mut cursor = &mut self.cursor[..];
        let mut first_cell = 0;
        for &end_cell in &ends[..blocks] {
            let len = (self.cell_start[end_cell] - self.cell_start[first_cell]) as usize;
            let (k, rest_k) = keys.split_at_mut(len);
            let (p, rest_p) = positions.split_at_mut(len);
            let (c, rest_c) = cursor.split_at_mut(end_cell - first_cell);
            work.push((first_cell as u32, self.cell_start[first_cell], c, k, p));
            (keys, positions, cursor) = (rest_k, rest_p, rest_c);
            first_cell = end_cell;
        }
        let cell_of = &self.cell_of;
        work.into_par_iter()
            .for_each(|(lo, base, cursor, keys, positions)| {
                let hi = lo + cursor.len() as u32;
                if lo == hi {
                    return;
                }
                for (i, &c) in cell_of.iter().enumerate() {
                    if c >= lo && c < hi {
                        let slot = &mut cursor[(c - lo) as usize];
                        let at = (*slot - base) as usize;
                        keys[at] = i as u32;
                        positions[at] = pos_of(i);
                        *slot += 1;
                    }
                }
            });
    }

    /// Item keys in the grid's cell order (slot order): entry `s` is the item in slot `s`.
    /// Callers that keep per-item data in this order (see [`Grid::for_each_run_within`]) scan
    /// contiguous memory.
    pub fn keys(&self) -> &[u32] {
        &self.keys
    }

    /// Item positions as of the last rebuild, in slot order (parallel to [`Grid::keys`]).
    pub fn positions(&self) -> &[Vec3] {
        &self.positions
    }

    /// Calls `visit(slots)` for each run of contiguous slots (indices into [`Grid::keys`] and
    /// [`Grid::positions`]) whose cells the sphere of `radius` around `center` reaches, in the
    /// same deterministic order [`Grid::for_each_within`] visits items. The runs hold every item
    /// within `radius` but also others nearby: the caller tests distances. Returns early if
    /// `visit` returns `false`; visits nothing for a NaN or negative radius or a non-finite
    /// centre.
    pub fn for_each_run_within(
        &self,
        center: Vec3,
        radius: f32,
        mut visit: impl FnMut(Range<usize>) -> bool,
    ) {
        if self.keys.is_empty() || radius.is_nan() || radius < 0.0 || !center.is_finite() {
            return;
        }
        let r2 = radius * radius;
        let lo = self.coord(center - Vec3::splat(radius));
        let hi = self.coord(center + Vec3::splat(radius));
        let local = center - self.origin;
        // Squared distance from `v` to the cell slab [i·size, (i+1)·size) on one axis; border
        // cells extend to infinity (items outside the box are clamped into them).
        let gap = |v: f32, i: u32, dim: u32| {
            let below = i as f32 * self.cell_size;
            let above = below + self.cell_size;
            let d = if v < below && i > 0 {
                below - v
            } else if v > above && i + 1 < dim {
                v - above
            } else {
                0.0
            };
            d * d
        };
        for z in lo[2]..=hi[2] {
            let gz = gap(local.z, z, self.dims[2]);
            if gz > r2 {
                continue;
            }
            for y in lo[1]..=hi[1] {
                let gyz = gz + gap(local.y, y, self.dims[1]);
                if gyz > r2 {
                    continue;
                }
                // Only the cells of this row the sphere reaches: |dx| ≤ √(r² − dy² − dz²).
                let half = (r2 - gyz).sqrt();
                let x0 = self.coord_x(center.x - half).max(lo[0]);
                let x1 = self.coord_x(center.x + half).min(hi[0]);
                let row = self.cell_index([0, y, z]);
                let start = self.cell_start[row + x0 as usize] as usize;
                let end = self.cell_start[row + x1 as usize + 1] as usize;
                // Cells along x are contiguous, so a row of cells is one run of entries.
                if start < end && !visit(start..end) {
                    return;
                }
            }
        }
    }

    /// Visits runs of contiguous slots (as [`Grid::for_each_run_within`]) nearest cells first,
    /// for queries that want only the nearest few items: shell k holds the cells k cells from
    /// `center`'s cell (along the farthest axis). `visit(run)` returns how far, squared, an item
    /// can still lie and matter (at first `radius²`; a k-nearest query then the k-th distance it
    /// holds; a negative value stops the walk). Cells whose nearest point lies farther than
    /// that are skipped, and the walk ends once every unvisited cell does. Every item within
    /// the returned reach of `center` is visited (with a small safety margin for rounding), so
    /// a nearest or k-nearest answer is the one a full scan gives, at a cost that follows the
    /// items near the answer instead of all within `radius`. The order of runs is
    /// deterministic. Nothing for a NaN or negative radius or a non-finite centre.
    pub fn for_each_run_nearest_first(
        &self,
        center: Vec3,
        radius: f32,
        mut visit: impl FnMut(Range<usize>) -> f32,
    ) {
        if self.keys.is_empty() || radius.is_nan() || radius < 0.0 || !center.is_finite() {
            return;
        }
        let mut need = radius * radius;
        let lo = self.coord(center - Vec3::splat(radius));
        let hi = self.coord(center + Vec3::splat(radius));
        let c = self.coord(center);
        let local = center - self.origin;
        let (l, cs) = (local.to_array(), self.cell_size);
        // Gaps are shrunk by this much before being compared, so that rounding in them (or in the
        // caller's squared distances) never skips a cell holding an item that matters.
        let slack = 1e-4 * (cs + local.abs().max_element());
        let shrink = |g: f32| (g - slack).max(0.0);
        // Squared gap from the centre to cell slab i on an axis (border cells extend to infinity).
        let gap = |axis: usize, i: u32| {
            let below = i as f32 * cs;
            let above = below + cs;
            let v = l[axis];
            let d = if v < below && i > 0 {
                below - v
            } else if v > above && i + 1 < self.dims[axis] {
                v - above
            } else {
                0.0
            };
            let d = shrink(d);
            d * d
        };
        let shells = (0..3)
            .map(|a| (c[a] - lo[a]).max(hi[a] - c[a]))
            .max()
            .unwrap_or(0);
        for k in 0..=shells {
            if k > 0 {
                // Every unvisited cell lies beyond a face of the block of shells 0..k: the
                // nearest such face (on a side where cells remain) bounds their distance.
                let mut bound = f32::INFINITY;
                for a in 0..3 {
                    if c[a] >= k && c[a] - k >= lo[a] {
                        bound = bound.min(l[a] - (c[a] - k + 1) as f32 * cs);
                    }
                    if c[a] + k <= hi[a] {
                        bound = bound.min((c[a] + k) as f32 * cs - l[a]);
                    }
                }
                if bound == f32::INFINITY {
                    return;
                }
                let b = shrink(bound);
                if b * b > need {
                    return;
                }
            }
            let span = |a: usize| (c[a].saturating_sub(k).max(lo[a]), (c[a] + k).min(hi[a]));
            let ((z0, z1), (y0, y1), (x0, x1)) = (span(2), span(1), span(0));
            for z in z0..=z1 {
                let gz = gap(2, z);
                if gz > need {
                    continue;
                }
                for y in y0..=y1 {
                    let gyz = gz + gap(1, y);
                    if gyz > need {
                        continue;
                    }
                    let row = self.cell_index([0, y, z]);
                    let on_face = z.abs_diff(c[2]) == k || y.abs_diff(c[1]) == k;
                    // A row on the shell's z or y face is all in the shell: one run of the
                    // cells the reach allows. Else only its two ends are.
                    let ends = if on_face {
                        [Some((x0, x1)), None]
                    } else {
                        let left = (c[0] >= k && c[0] - k >= lo[0]).then(|| (c[0] - k, c[0] - k));
                        let right = (c[0] + k <= hi[0]).then_some((c[0] + k, c[0] + k));
                        [left, right]
                    };
                    for (a, b) in ends.into_iter().flatten() {
                        let (mut a, mut b) = (a, b);
                        while a <= b && gyz + gap(0, a) > need {
                            a += 1;
                        }
                        while b > a && gyz + gap(0, b) > need {
                            b -= 1;
                        }
                        if a > b {
                            continue;
                        }
                        let start = self.cell_start[row + a as usize] as usize;
                        let end = self.cell_start[row + b as usize + 1] as usize;
                        if start < end {
                            need = visit(start..end);
                            if need < 0.0 {
                                return;
                            }
                        }
                    }
                }
            }
        }
    }

    /// Calls `visit(key, position, distance²)` for every item within `radius` of `center`
    /// (inclusive), cell by cell in a deterministic order. Returns early if `visit` returns
    /// `false`.
    pub fn for_each_within(
        &self,
        center: Vec3,
        radius: f32,
        mut visit: impl FnMut(u32, Vec3, f32) -> bool,
    ) {
        let r2 = radius * radius;
        self.for_each_run_within(center, radius, |run| {
            for (key, &p) in self.keys[run.clone()].iter().zip(&self.positions[run]) {
                let d2 = p.distance_squared(center);
                if d2 <= r2 && !visit(*key, p, d2) {
                    return false;
                }
            }
            true
        });
    }
}

/// The cell holding grid coordinate `v` (in cells) on an axis of `cells` cells, clamped into it:
/// ⌊v⌋ for 0 ≤ v < cells. The saturating cast truncates, which is ⌊v⌋ for v ≥ 0, gives 0 for
/// every v < 0 and for NaN, and saturates above, so no `floor` is needed (without SSE4.1 it is
/// a libm call, one per axis per item and query).
fn clamp_cell(v: f32, cells: u32) -> u32 {
    (v as u32).min(cells - 1)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rebuild_sorts_items_into_cells_and_queries_find_them() {
        // 2×1×1 cells of size 1 over [0,2]×[0,1]×[0,1].
        let mut g = Grid::new(Vec3::ZERO, Vec3::new(2.0, 1.0, 1.0), 1.0);
        assert_eq!(g.dims(), [2, 1, 1]);
        let pts = [
            Vec3::new(1.5, 0.5, 0.5),
            Vec3::new(0.5, 0.5, 0.5),
            Vec3::new(1.9, 0.5, 0.5),
        ];
        g.rebuild(pts.iter().enumerate().map(|(i, &p)| (i as u32, p)));
        assert_eq!(g.cell_start, vec![0, 1, 3]);
        assert_eq!(g.keys, vec![1, 0, 2]);
        let mut found = Vec::new();
        g.for_each_within(Vec3::new(1.6, 0.5, 0.5), 0.35, |k, _, _| {
            found.push(k);
            true
        });
        assert_eq!(found, vec![0, 2]);
    }

    /// The parallel rebuild gives the serial one's grid, slot for slot, whatever the thread
    /// count: clustered and empty cells, items outside the box, NaN positions.
    #[test]
    fn parallel_rebuild_equals_the_serial_one() {
        let mut state = 0x9e37_79b9_u32;
        let mut next = move || {
            state ^= state << 13;
            state ^= state >> 17;
            state ^= state << 5;
            (state >> 8) as f32 / (1 << 24) as f32
        };
        for (n, threads) in [(0, 2), (5, 2), (3000, 1), (9000, 2), (9000, 3), (20000, 7)] {
            let pts: Vec<Vec3> = (0..n)
                .map(|i| match i % 97 {
                    0 => Vec3::new(-50.0, next() * 10.0, 200.0),
                    1 => Vec3::NAN,
                    // A dense school in a few cells, the rest spread over the box.
                    k if k < 60 => Vec3::new(30.0 + next(), 40.0 + next(), 50.0 + next()),
                    _ => Vec3::new(next() * 100.0, next() * 60.0, next() * 80.0),
                })
                .collect();
            let mut serial = Grid::new(Vec3::ZERO, Vec3::new(100.0, 60.0, 80.0), 7.0);
            serial.rebuild(pts.iter().enumerate().map(|(i, &p)| (i as u32, p)));
            let mut parallel = Grid::new(Vec3::ZERO, Vec3::new(100.0, 60.0, 80.0), 7.0);
            let pool = rayon::ThreadPoolBuilder::new()
                .num_threads(threads)
                .build()
                .unwrap();
            // Twice: the second rebuild reuses the arrays of the first.
            for _ in 0..2 {
                pool.install(|| parallel.rebuild_indexed(n, |i| pts[i]));
                assert_eq!(
                    parallel.cell_start, serial.cell_start,
                    "{n} items, {threads} threads"
                );
                assert_eq!(parallel.keys, serial.keys, "{n} items, {threads} threads");
                let bits = |g: &Grid| -> Vec<[u32; 3]> {
                    g.positions
                        .iter()
                        .map(|p| p.to_array().map(f32::to_bits))
                        .collect()
                };
                assert_eq!(
                    bits(&parallel),
                    bits(&serial),
                    "{n} items, {threads} threads"
                );
            }
        }
    }

    #[test]
    fn items_outside_the_box_are_still_found() {
        let mut g = Grid::new(Vec3::ZERO, Vec3::splat(4.0), 1.0);
        let far = Vec3::new(-10.0, 2.0, 2.0);
        g.rebuild([(7u32, far)].into_iter());
        let mut found = Vec::new();
        g.for_each_within(Vec3::new(-9.5, 2.0, 2.0), 1.0, |k, _, _| {
            found.push(k);
            true
        });
        assert_eq!(found, vec![7]);
    }

    #[test]
    fn huge_boxes_are_capped_in_cells() {
        let g = Grid::new(Vec3::ZERO, Vec3::splat(1e6), 1.0);
        assert!(g.num_cells() <= MAX_CELLS);
        assert!(g.cell_size() > 1.0);
    }

    #[test]
    fn clamping_without_floor_is_floor_then_clamp() {
        let old = |v: f32, d: u32| (v.floor().max(0.0) as u32).min(d - 1);
        let mut values = vec![
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
            -0.0,
            0.0,
            -1e-30,
            1e-30,
            4e9,
            -4e9,
            f32::MAX,
            f32::MIN,
        ];
        for k in -4000..4000 {
            let v = k as f32 * 0.0123;
            values.extend([v, v.next_up(), v.next_down(), (k / 3) as f32]);
        }
        for v in values {
            for d in [1, 2, 7, 64] {
                assert_eq!(clamp_cell(v, d), old(v, d), "v = {v}, {d} cells");
            }
        }
    }
}
