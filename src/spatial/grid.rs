//! A uniform grid of cell lists, rebuilt by a counting sort in O(N).
//!
//! Invariants: `order` is the stable sort of the point indices by row-major cell id, the same
//! for any number of threads; `cell_start` holds its prefix sums; the sorted positions follow
//! `order`. The layout, geometry and rebuild are documented on [`GridIndex`].

use std::ops::Range;
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};

use glam::Vec2;
use rayon::prelude::*;

use super::sort::CountingSort;
use super::{Neighbour, NeighbourIndex, exact, gather_radius, to_u32};
use crate::bounds::Bounds;
use crate::simd::{apply, rounding_kernel};

/// Below this many points the rebuild runs on the calling thread.
const PARALLEL_MIN_POINTS: usize = 8 * 1024;
/// Points per work item in the parallel cell-id pass.
const CHUNK: usize = 8 * 1024;
/// The largest number of cells a grid ever has.
const MAX_CELLS: usize = 1 << 22;
/// Zeros after the sorted positions ([`GridIndex::sorted_padded`]): one block of lanes (the
/// kernels that read past a run's end assert at compile time that it covers their blocks).
pub(crate) const SORTED_PAD: usize = 8;

/// A uniform-grid neighbour index: cell lists rebuilt by counting sort.
///
/// # Layout
///
/// Cells are numbered row-major: cell `(cx, cy)` is `cy * cells_x + cx`. After a rebuild,
/// [`GridIndex::order`] lists the point indices sorted by cell, and ascending by index within a
/// cell (the sort is stable); [`GridIndex::cell_start`] holds the prefix sums, so cell `c` owns
/// `order[cell_start[c]..cell_start[c + 1]]`; [`GridIndex::sorted_x`] and
/// [`GridIndex::sorted_y`] hold the positions in that same order. The cells `x0..=x1` of one row
/// are therefore one contiguous run of points, which is what a SIMD kernel wants to read.
///
/// # Geometry
///
/// * Torus `W x H`: origin `(0, 0)`, `cells_x = max(1, floor(W / max_radius))`, cell width
///   `W / cells_x` (so cells tile the world exactly and every cell is at least `max_radius` wide).
/// * Walled world: the rectangle `[0, W] x [0, H]`, square cells of side `max_radius`.
/// * Open world: the bounding box of the points, square cells of side `max_radius`.
///
/// Points outside the grid's rectangle are clamped into its edge cells ([`GridIndex::cell_of`]).
/// The total number of cells is capped at `clamp(4 N, 64, 2^22)`: when `max_radius` is tiny
/// compared to the world the cells grow instead, so memory stays bounded. Cells are never smaller
/// than `max_radius`; a query of any radius stays exact (it visits more rings of cells).
///
/// # Rebuild
///
/// A counting sort, O(N + cells) (`super::sort`): in one level on the calling thread up to
/// 65,536 points; above that, on the current rayon pool, in one level per range of cells when
/// the points come nearly in cell order (agents reordered by this grid a few frames before), or
/// else in one level (up to 1,048,576 points and 262,144 cells) or in the two levels below:
///
/// 1. Per chunk of points: compute each point's cell id.
/// 2. Per chunk: a histogram of *buckets*, runs of `2^k` consecutive cells chosen so that there
///    are at most 1024 of them; prefix sums over (bucket, chunk) give every chunk its own slots in
///    every bucket.
/// 3. Per chunk: scatter `(cell, index)` into those slots. Few buckets means few write streams,
///    which stay in cache even when the points come in random order. Slots of different chunks
///    interleave, so this buffer holds relaxed atomics (plain stores on x86) rather than `unsafe`.
/// 4. Per bucket: a counting sort by cell inside the bucket (its cells' counters fit in L1),
///    writing `cell_start`, `order` and the sorted positions. Buckets own disjoint output ranges.
///
/// Every step keeps index order within a cell, so the result is the stable sort by cell, the
/// same for any number of threads. Steps 2 to 4 are the same sort as the one that orders a
/// [`HashGrid`](super::HashGrid) by bucket. Buffers are reused: once warm, a rebuild of the same
/// size allocates nothing.
#[derive(Clone, Debug)]
pub struct GridIndex {
    bounds: Bounds,
    origin: Vec2,
    cell_size: Vec2,
    inv_cell: Vec2,
    cells_x: u32,
    cells_y: u32,
    scale: f32,
    /// Cell id of each point.
    cell: Vec<u32>,
    /// The points sorted by cell: `start` (`cells + 1` prefix sums), `order` and the sorted
    /// positions, with the sort's scratch.
    sort: CountingSort,
    /// Changed by every rebuild and reorder ([`GridIndex::generation`]).
    generation: u64,
}

impl Default for GridIndex {
    fn default() -> Self {
        GridIndex {
            bounds: Bounds::Open,
            origin: Vec2::ZERO,
            cell_size: Vec2::ONE,
            inv_cell: Vec2::ONE,
            cells_x: 1,
            cells_y: 1,
            scale: 0.0,
            cell: Vec::new(),
            sort: CountingSort::with_keys(1),
            generation: 0,
        }
    }
}

/// Up to two column (or row) intervals, ascending and disjoint.
#[derive(Clone, Copy)]
struct Spans {
    spans: [(u32, u32); 2],
    len: usize,
}

impl Spans {
    fn one(lo: u32, hi: u32) -> Self {
        Spans {
            spans: [(lo, hi), (0, 0)],
            len: 1,
        }
    }

    fn as_slice(&self) -> &[(u32, u32)] {
        &self.spans[..self.len]
    }
}

/// Cell index of coordinate `x` on an axis of `n` cells, clamped to `0..n`.
#[inline]
fn axis_cell(x: f32, origin: f32, inv: f32, n: u32) -> u32 {
    let f = (x - origin) * inv;
    // Truncation is floor for f >= 0 and avoids a libm call on baseline x86-64; `as` saturates.
    if f >= 0.0 { (f as u32).min(n - 1) } else { 0 }
}

/// Pass 1 of a rebuild: each point's cell (row-major, as
/// [`axis_cell`] computes it on each axis) into `cell`, and the largest magnitude of a
/// coordinate. In vector lanes: the clamp is done in floating point before the conversion
/// (`max(f, 0)` is 0 for a negative or NaN `f`, and truncating `min(f, n - 1)` equals clamping
/// the truncation, `n - 1` being an integer that `f32` holds exactly), so the cells are
/// [`axis_cell`]'s for every input. The SSE4.1 clone truncates with `roundps`, where the
/// baseline x86-64 build calls libm's `truncf` per value (the same result: truncation is exact).
#[apply(rounding_kernel!)]
fn cell_keys(
    (xs, ys): (&[f32], &[f32]),
    cell: &mut [u32],
    (origin, inv): (Vec2, Vec2),
    (cx, cy): (u32, u32),
) -> f32 {
    // Cells per axis are below 2^22 (`MAX_CELLS`), so `n - 1` is exact in `f32`, and the
    // truncated clamp, a whole number in `[0, 2^23)`, is the low bits of its sum with 2^23 (a
    // conversion in vector lanes, where `as` would test each lane for saturation).
    let (top_x, top_y) = ((cx - 1) as f32, (cy - 1) as f32);
    let axis = |v: f32, o: f32, inv: f32, top: f32| {
        let whole = ((v - o) * inv).max(0.0).min(top).trunc();
        (whole + 8_388_608.0).to_bits() - 0x4B00_0000
    };
    let n = cell.len();
    let (xs, ys) = (&xs[..n], &ys[..n]);
    for k in 0..n {
        let (x, y) = (xs[k], ys[k]);
        cell[k] = axis(y, origin.y, inv.y, top_y) * cx + axis(x, origin.x, inv.x, top_x);
    }
    // The largest magnitude in lanes, as selects (a NaN is never greater, so it is passed
    // over as `f32::max` passes it over).
    let mut lanes = [0.0_f32; 8];
    for v in [xs, ys] {
        let (blocks, tail) = v.as_chunks::<8>();
        for b in blocks {
            for l in 0..8 {
                let a = b[l].abs();
                lanes[l] = if a > lanes[l] { a } else { lanes[l] };
            }
        }
        for &t in tail {
            lanes[0] = lanes[0].max(t.abs());
        }
    }
    lanes.iter().fold(0.0_f32, |m, &v| m.max(v))
}

impl GridIndex {
    /// Number of cell columns.
    #[must_use]
    pub fn cells_x(&self) -> u32 {
        self.cells_x
    }

    /// Number of cell rows.
    #[must_use]
    pub fn cells_y(&self) -> u32 {
        self.cells_y
    }

    /// Width and height of one cell; at least the `max_radius` of the last rebuild.
    #[must_use]
    pub fn cell_size(&self) -> Vec2 {
        self.cell_size
    }

    /// World position of the lower corner of cell `(0, 0)`.
    #[must_use]
    pub fn origin(&self) -> Vec2 {
        self.origin
    }

    /// The cell `(column, row)` holding `p`, clamped into the grid.
    #[must_use]
    pub fn cell_of(&self, p: Vec2) -> (u32, u32) {
        (
            axis_cell(p.x, self.origin.x, self.inv_cell.x, self.cells_x),
            axis_cell(p.y, self.origin.y, self.inv_cell.y, self.cells_y),
        )
    }

    /// Prefix sums over the row-major cells, `cells_x * cells_y + 1` long: cell `c` holds the
    /// points `order()[cell_start()[c]..cell_start()[c + 1]]`.
    #[must_use]
    pub fn cell_start(&self) -> &[u32] {
        &self.sort.start
    }

    /// Point indices sorted by cell, ascending by index within a cell.
    ///
    /// A permutation of `0..len()`: reordering agent storage by it puts agents of one cell next
    /// to each other in memory.
    #[must_use]
    pub fn order(&self) -> &[u32] {
        &self.sort.order
    }

    /// x coordinates in [`order`](Self::order).
    #[must_use]
    pub fn sorted_x(&self) -> &[f32] {
        &self.sort.sorted_x[..self.sort.order.len()]
    }

    /// y coordinates in [`order`](Self::order).
    #[must_use]
    pub fn sorted_y(&self) -> &[f32] {
        &self.sort.sorted_y[..self.sort.order.len()]
    }

    /// [`sorted_x`](Self::sorted_x) and [`sorted_y`](Self::sorted_y) followed by
    /// [`SORTED_PAD`] zeros (`order().len() + SORTED_PAD` values each), so that a kernel can read
    /// whole blocks of lanes from any point. This holds after every rebuild, whatever the number
    /// of points before it, and after [`adopt_order`](Self::adopt_order), which leaves the
    /// sorted positions and their padding as they are; a grid never rebuilt has no points and
    /// gives two empty slices.
    #[must_use]
    pub(crate) fn sorted_padded(&self) -> (&[f32], &[f32]) {
        (&self.sort.sorted_x, &self.sort.sorted_y)
    }

    /// `ranks()[i]`: the position of point `i` in [`order`](Self::order), the inverse
    /// permutation, written by the rebuild where it places each point (relaxed atomics: plain
    /// loads on x86).
    pub(crate) fn ranks(&self) -> &[AtomicU32] {
        &self.sort.rank.0
    }

    /// Makes the grid the one a rebuild would give after the points were permuted into its
    /// [`order`](Self::order) (point `k` becomes the old point `order()[k]`), without sorting:
    /// the same set of points gives the same cells and sorted positions, and a stable sort of
    /// points already in cell order is the identity. Every agent-storage reorder by `order()`
    /// is followed by this or by a rebuild.
    ///
    /// In parallel chunks from 8,192 points on (every value is a function of its position
    /// alone, so the result is the same).
    pub fn adopt_order(&mut self) {
        self.generation = next_generation();
        let sort = &mut self.sort;
        let n = sort.order.len();
        let start = &sort.start;
        // Positions `base..base + len` of the new order: their cells (the cell holding `base`
        // found by a search of the prefix sums, then walked), the identity.
        let rank = &sort.rank.0[..n];
        let adopt = |base: usize, cell: &mut [u32], order: &mut [u32]| {
            let mut c = start.partition_point(|&s| s as usize <= base) - 1;
            let rank = &rank[base..base + order.len()];
            for (j, (ce, (o, r))) in cell.iter_mut().zip(order.iter_mut().zip(rank)).enumerate() {
                let k = base + j;
                while start[c + 1] as usize <= k {
                    c += 1;
                }
                *ce = c as u32;
                *o = k as u32;
                r.store(k as u32, Ordering::Relaxed);
            }
        };
        let (cell, order) = (&mut self.cell[..n], &mut sort.order[..]);
        if n >= PARALLEL_MIN_POINTS {
            cell.par_chunks_mut(CHUNK)
                .zip(order.par_chunks_mut(CHUNK))
                .enumerate()
                .for_each(|(c, (ce, o))| adopt(c * CHUNK, ce, o));
        } else if n > 0 {
            adopt(0, cell, order);
        }
    }

    /// Point `i`'s position at the last rebuild: its sorted copy, at its rank.
    fn position(&self, i: usize) -> Vec2 {
        let k = self.sort.rank.0[i].load(Ordering::Relaxed) as usize;
        Vec2::new(self.sort.sorted_x[k], self.sort.sorted_y[k])
    }

    /// The world the grid was built for.
    #[must_use]
    pub fn bounds(&self) -> Bounds {
        self.bounds
    }

    /// A number no other rebuild or reorder of any grid took (its clones share it until they
    /// change): what [`super::CellCandidates`] were gathered from.
    pub(crate) fn generation(&self) -> u64 {
        self.generation
    }

    /// Calls `visit` with ranges into [`order`](Self::order), [`sorted_x`](Self::sorted_x) and
    /// [`sorted_y`](Self::sorted_y) that together hold every point within `r` of `p` (and some
    /// farther ones), each point in at most one range.
    ///
    /// A range is a run of cells of one row (on a torus, cells left and right of the seam come as
    /// separate ranges). Callers filter the candidates by
    /// `bounds.offset(p, q).length_squared() <= r * r`; this is how the grid's own queries work,
    /// and how a vectorised kernel can read neighbour cells as contiguous slices.
    #[inline]
    pub fn for_each_run(&self, p: Vec2, r: f32, mut visit: impl FnMut(Range<usize>)) {
        if self.sort.order.is_empty() {
            return;
        }
        let rg = gather_radius(r, self.scale);
        let cx = self.cells_x as usize;
        if !self.bounds.is_torus() {
            // One span per axis, as `spans` finds it off a torus: the same runs without the
            // span loops.
            let col = |x: f32| axis_cell(x, self.origin.x, self.inv_cell.x, self.cells_x) as usize;
            let row = |y: f32| axis_cell(y, self.origin.y, self.inv_cell.y, self.cells_y) as usize;
            let (c0, c1) = (col(p.x - rg), col(p.x + rg) + 1);
            for row in row(p.y - rg)..row(p.y + rg) + 1 {
                let (a, b) = (
                    self.sort.start[row * cx + c0],
                    self.sort.start[row * cx + c1],
                );
                if a < b {
                    visit(a as usize..b as usize);
                }
            }
            return;
        }
        self.runs_by_spans(p, rg, visit);
    }

    /// [`GridIndex::for_each_run`] for the gather radius `rg`, through the cell intervals of
    /// each axis ([`GridIndex::spans`]): the path of a torus, and the reference of the others'.
    fn runs_by_spans(&self, p: Vec2, rg: f32, mut visit: impl FnMut(Range<usize>)) {
        let cx = self.cells_x as usize;
        let side = self.bounds.size().filter(|_| self.bounds.is_torus());
        let cols = self.spans(
            p.x,
            rg,
            self.origin.x,
            self.inv_cell.x,
            self.cells_x,
            side.map(|s| s.x),
        );
        let rows = self.spans(
            p.y,
            rg,
            self.origin.y,
            self.inv_cell.y,
            self.cells_y,
            side.map(|s| s.y),
        );
        for &(r0, r1) in rows.as_slice() {
            for row in r0 as usize..=r1 as usize {
                for &(c0, c1) in cols.as_slice() {
                    let a = self.sort.start[row * cx + c0 as usize] as usize;
                    let b = self.sort.start[row * cx + c1 as usize + 1] as usize;
                    if a < b {
                        visit(a..b);
                    }
                }
            }
        }
    }

    /// The cell intervals along one axis that hold every point within `rg` of `c`.
    fn spans(
        &self,
        c: f32,
        rg: f32,
        origin: f32,
        inv: f32,
        n: u32,
        torus_side: Option<f32>,
    ) -> Spans {
        let cell = |x: f32| axis_cell(x, origin, inv, n);
        let Some(side) = torus_side else {
            return Spans::one(cell(c - rg), cell(c + rg));
        };
        if rg.is_nan() || 2.0 * rg >= side {
            return Spans::one(0, n - 1);
        }
        let (lo, hi) = (cell(c - rg), cell(c + rg));
        if c - rg < 0.0 {
            // The window also covers [c - rg + side, side): the high end of the axis.
            let wrap_lo = cell(c - rg + side).max(hi + 1);
            if wrap_lo < n {
                return Spans {
                    spans: [(lo, hi), (wrap_lo, n - 1)],
                    len: 2,
                };
            }
        } else if c + rg >= side {
            // The window also covers [0, c + rg - side]: the low end of the axis.
            let wrap_hi = cell(c + rg - side);
            if wrap_hi < lo {
                return Spans {
                    spans: [(0, wrap_hi), (lo, hi)],
                    len: 2,
                };
            }
            return Spans::one(0, hi);
        }
        Spans::one(lo, hi)
    }

    /// Every point within `r` of `p` but `skip`, in ascending index order when `SORT` (in the
    /// grid's order otherwise).
    fn gather<const SORT: bool>(&self, p: Vec2, r: f32, skip: usize, out: &mut Vec<Neighbour>) {
        // One match on the world's shape, so the candidate loop is specialised for it; the
        // filter is still `exact` with the same `Bounds`, so results stay bit-identical.
        match self.bounds {
            Bounds::Torus { size } => {
                self.gather_in::<SORT>(Bounds::Torus { size }, p, r, skip, out);
            }
            Bounds::Bounded { size } => {
                self.gather_in::<SORT>(Bounds::Bounded { size }, p, r, skip, out);
            }
            Bounds::Open => self.gather_in::<SORT>(Bounds::Open, p, r, skip, out),
        }
    }

    #[inline(always)]
    fn gather_in<const SORT: bool>(
        &self,
        bounds: Bounds,
        p: Vec2,
        r: f32,
        skip: usize,
        out: &mut Vec<Neighbour>,
    ) {
        out.clear();
        let r_sq = r * r;
        self.for_each_run(p, r, |run| {
            let (order, xs, ys) = (
                &self.sort.order[run.clone()],
                &self.sort.sorted_x[run.clone()],
                &self.sort.sorted_y[run],
            );
            for ((&j, &x), &y) in order.iter().zip(xs).zip(ys) {
                if let Some(n) = exact(&bounds, p, Vec2::new(x, y), j, r_sq)
                    && j as usize != skip
                {
                    out.push(n);
                }
            }
        });
        if SORT {
            out.sort_unstable_by_key(|n| n.index);
        }
    }

    /// Chooses origin, cell size and cell counts for `n` points.
    fn plan(&mut self, bounds: Bounds, max_radius: f32, n: usize, bbox: (Vec2, Vec2)) {
        let (origin, extent) = match bounds {
            Bounds::Bounded { size } | Bounds::Torus { size } => (Vec2::ZERO, size),
            Bounds::Open => (bbox.0, bbox.1 - bbox.0),
        };
        let max_cells = (4 * n).clamp(64, MAX_CELLS);
        // Smallest cell side s with (ex / s + 1) * (ey / s + 1) <= max_cells.
        let (ex, ey) = (f64::from(extent.x), f64::from(extent.y));
        let m = max_cells as f64 - 1.0;
        let b = ex + ey;
        let cap_side = (b + (b * b + 4.0 * m * ex * ey).sqrt()) / (2.0 * m);
        let mut side = f64::from(max_radius.max(0.0)).max(cap_side);
        if side <= 0.0 || side.is_nan() {
            side = 1.0;
        }
        let (nx, ny, cell_size) = if bounds.is_torus() {
            let count = |len: f32| {
                let mut c = ((f64::from(len) / side).floor() as u32).clamp(1, MAX_CELLS as u32);
                // Rounding must not make a cell narrower than max_radius.
                while c > 1 && len / (c as f32) < max_radius {
                    c -= 1;
                }
                c
            };
            let (nx, ny) = (count(extent.x), count(extent.y));
            (
                nx,
                ny,
                Vec2::new(extent.x / nx as f32, extent.y / ny as f32),
            )
        } else {
            let s = side as f32;
            let count = |len: f32| {
                ((f64::from(len) / side).floor() as u32)
                    .saturating_add(1)
                    .clamp(1, MAX_CELLS as u32)
            };
            (count(extent.x), count(extent.y), Vec2::splat(s))
        };
        self.bounds = bounds;
        self.origin = origin;
        self.cells_x = nx;
        self.cells_y = ny;
        debug_assert!(
            nx as usize * ny as usize <= max_cells,
            "{nx} x {ny} cells exceed the cap {max_cells}"
        );
        self.cell_size = cell_size;
        self.inv_cell = cell_size.recip();
    }

    /// Rebuild using `parts` workers (1 = sequential); the result does not depend on `parts`.
    fn rebuild_with(
        &mut self,
        xs: &[f32],
        ys: &[f32],
        bounds: Bounds,
        max_radius: f32,
        parts: usize,
    ) {
        assert_eq!(xs.len(), ys.len(), "xs and ys must have the same length");
        self.generation = next_generation();
        let n = xs.len();
        to_u32(n);
        let parts = parts.clamp(1, 64);

        let parallel = parts > 1;
        let bbox = if bounds == Bounds::Open {
            bounding_box(xs, ys, parallel)
        } else {
            (Vec2::ZERO, Vec2::ZERO)
        };
        self.plan(bounds, max_radius, n, bbox);
        let cells = self.cells_x as usize * self.cells_y as usize;

        // Pass 1: find each point's cell and the coordinates' magnitude.
        self.cell.resize(n, 0);
        let (origin, inv, cx, cy) = (self.origin, self.inv_cell, self.cells_x, self.cells_y);
        let fill = |cell: &mut [u32], xs: &[f32], ys: &[f32]| {
            cell_keys((xs, ys), cell, (origin, inv), (cx, cy))
        };
        let max_abs = if parallel {
            self.cell
                .par_chunks_mut(CHUNK)
                .zip(xs.par_chunks(CHUNK).zip(ys.par_chunks(CHUNK)))
                .map(|(c, (x, y))| fill(c, x, y))
                .reduce(|| 0.0, f32::max)
        } else {
            fill(&mut self.cell, xs, ys)
        };
        self.scale = bounds.size().map_or(max_abs, |s| max_abs.max(s.x).max(s.y));

        // Passes 2-4: the counting sort by cell.
        self.sort.sort(
            &self.cell,
            cells,
            |i| (xs[i], ys[i]),
            parts,
            (SORTED_PAD, 0.0),
        );
    }
}

/// The next [`GridIndex::generation`].
fn next_generation() -> u64 {
    static NEXT: AtomicU64 = AtomicU64::new(1);
    NEXT.fetch_add(1, Ordering::Relaxed)
}

/// Lower and upper corners of the points' bounding box (zero when there are none).
fn bounding_box(xs: &[f32], ys: &[f32], parallel: bool) -> (Vec2, Vec2) {
    if xs.is_empty() {
        return (Vec2::ZERO, Vec2::ZERO);
    }
    let fold = |(lo, hi): (f32, f32), &v: &f32| (lo.min(v), hi.max(v));
    let init = (f32::INFINITY, f32::NEG_INFINITY);
    let ((x0, x1), (y0, y1)) = if parallel {
        let axis = |v: &[f32]| {
            v.par_chunks(CHUNK)
                .map(|c| c.iter().fold(init, fold))
                .reduce(|| init, |a, b| (a.0.min(b.0), a.1.max(b.1)))
        };
        rayon::join(|| axis(xs), || axis(ys))
    } else {
        (xs.iter().fold(init, fold), ys.iter().fold(init, fold))
    };
    (Vec2::new(x0, y0), Vec2::new(x1, y1))
}

impl NeighbourIndex for GridIndex {
    /// Rebuilds the grid by counting sort; the cell ids in parallel on the current rayon pool
    /// for large N, the sort as `super::sort` decides.
    fn rebuild(&mut self, xs: &[f32], ys: &[f32], bounds: Bounds, max_radius: f32) {
        let parts = if xs.len() >= PARALLEL_MIN_POINTS {
            rayon::current_num_threads()
        } else {
            1
        };
        self.rebuild_with(xs, ys, bounds, max_radius, parts);
    }

    fn neighbours_of(&self, i: usize, r: f32, out: &mut Vec<Neighbour>) {
        self.gather::<true>(self.position(i), r, i, out);
    }

    fn neighbours_at(&self, p: Vec2, r: f32, out: &mut Vec<Neighbour>) {
        self.gather::<true>(p, r, usize::MAX, out);
    }

    /// The candidates unsorted: the selection orders them by `(dist_sq, index)` alone, so the
    /// index order `neighbours_at` sorts into is work thrown away here.
    fn k_nearest_at(
        &self,
        p: Vec2,
        k: usize,
        r: f32,
        exclude: Option<usize>,
        out: &mut Vec<Neighbour>,
    ) {
        self.gather::<false>(p, r, usize::MAX, out);
        super::keep_k_nearest(out, k, exclude);
    }

    fn len(&self) -> usize {
        self.sort.order.len()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cell_keys_in_lanes_equal_axis_cell_for_every_kind_of_coordinate() {
        // Inside, on cell edges, on the last cell's edge and past it, negative, tiny, huge,
        // infinite and NaN coordinates, in whole blocks of lanes and in the tail.
        let special = [
            0.0,
            -0.0,
            1e-30,
            -1e-30,
            2.5,
            3.0,
            9.999_999,
            10.0,
            10.5,
            -3.0,
            1e30,
            -1e30,
            f32::INFINITY,
            f32::NEG_INFINITY,
            f32::NAN,
            f32::MAX,
            f32::MIN_POSITIVE,
        ];
        let (rx, ry) = points(61, 12.0, 9);
        let xs: Vec<f32> = special.iter().chain(&rx).copied().collect();
        let ys: Vec<f32> = rx
            .iter()
            .chain(&special)
            .chain(&ry)
            .copied()
            .take(xs.len())
            .collect();
        for (origin, inv, cells) in [
            (Vec2::ZERO, Vec2::splat(0.4), (4, 4)),
            (Vec2::new(-1.5, 2.0), Vec2::new(0.7, 1.3), (17, 3)),
            (Vec2::ZERO, Vec2::splat(1.0), (1, 1)),
        ] {
            let n = xs.len();
            let mut cell = vec![0; n];
            let max_abs = cell_keys((&xs, &ys), &mut cell, (origin, inv), cells);
            let mut want_max = 0.0_f32;
            for k in 0..n {
                let (x, y) = (xs[k], ys[k]);
                let want = axis_cell(y, origin.y, inv.y, cells.1) * cells.0
                    + axis_cell(x, origin.x, inv.x, cells.0);
                assert_eq!(cell[k], want, "({x}, {y}) with {origin} {inv} {cells:?}");
                want_max = want_max.max(x.abs()).max(y.abs());
            }
            assert_eq!(max_abs.to_bits(), want_max.to_bits());
        }
    }

    fn points(n: usize, w: f32, seed: u64) -> (Vec<f32>, Vec<f32>) {
        // A small xorshift: deterministic and dependency-free.
        let mut s = seed | 1;
        let mut next = || {
            s ^= s << 13;
            s ^= s >> 7;
            s ^= s << 17;
            (s >> 40) as f32 / (1u64 << 24) as f32 * w
        };
        (0..n).map(|_| (next(), next())).unzip()
    }

    fn check_layout(g: &GridIndex, xs: &[f32], ys: &[f32]) {
        let n = xs.len();
        let cells = (g.cells_x() * g.cells_y()) as usize;
        assert_eq!(g.cell_start().len(), cells + 1);
        assert_eq!(g.cell_start()[0], 0);
        assert_eq!(g.cell_start()[cells] as usize, n);
        assert!(g.cell_start().windows(2).all(|w| w[0] <= w[1]));
        let mut seen = vec![false; n];
        for &i in g.order() {
            assert!(!seen[i as usize], "index {i} twice");
            seen[i as usize] = true;
        }
        assert!(seen.iter().all(|&s| s), "order is not a permutation");
        for c in 0..cells {
            let run = g.cell_start()[c] as usize..g.cell_start()[c + 1] as usize;
            let ids = &g.order()[run.clone()];
            assert!(
                ids.windows(2).all(|w| w[0] < w[1]),
                "cell {c} not ascending"
            );
            for k in run {
                let i = g.order()[k] as usize;
                let (x, y) = g.cell_of(Vec2::new(xs[i], ys[i]));
                assert_eq!((y * g.cells_x() + x) as usize, c);
                assert_eq!(g.sorted_x()[k].to_bits(), xs[i].to_bits());
                assert_eq!(g.sorted_y()[k].to_bits(), ys[i].to_bits());
            }
        }
    }

    #[test]
    fn sorted_padded_is_the_sorted_positions_then_zeros_after_every_rebuild_and_adoption() {
        // One grid through a growing, shrinking and emptied point set (a shrink leaves old
        // positions where the new padding goes), each rebuild then followed by an adoption of
        // its order. The positions are all nonzero, so a stale one in the tail shows.
        let mut g = GridIndex::default();
        let check = |g: &GridIndex, what: &str| {
            let n = g.order().len();
            let (xs, ys) = g.sorted_padded();
            assert_eq!(
                (xs.len(), ys.len()),
                (n + SORTED_PAD, n + SORTED_PAD),
                "{what}"
            );
            assert_eq!((&xs[..n], &ys[..n]), (g.sorted_x(), g.sorted_y()), "{what}");
            let (tx, ty) = (&xs[n..], &ys[n..]);
            assert!(
                tx.iter().chain(ty).all(|v| v.to_bits() == 0),
                "{what}: tail {tx:?} {ty:?}"
            );
        };
        for (n, bounds) in [
            (20, Bounds::torus(40.0, 40.0).unwrap()),
            (5, Bounds::Open),
            (13, Bounds::bounded(40.0, 40.0).unwrap()),
            (0, Bounds::Open),
        ] {
            let (xs, ys) = points(n, 30.0, n as u64 + 1);
            let (xs, ys): (Vec<f32>, Vec<f32>) =
                xs.iter().zip(&ys).map(|(x, y)| (x + 1.0, y + 1.0)).unzip();
            g.rebuild(&xs, &ys, bounds, 4.0);
            assert_eq!(g.order().len(), n);
            check(&g, &format!("rebuild of {n} points"));
            g.adopt_order();
            check(&g, &format!("adoption after the rebuild of {n} points"));
        }
    }

    #[test]
    fn counting_sort_is_a_stable_permutation() {
        for (n, bounds) in [
            (0, Bounds::Open),
            (1, Bounds::Open),
            (1000, Bounds::torus(100.0, 50.0).unwrap()),
            (5000, Bounds::bounded(100.0, 100.0).unwrap()),
            (777, Bounds::Open),
        ] {
            let (xs, ys) = points(n, 50.0, n as u64 + 7);
            let mut g = GridIndex::default();
            g.rebuild(&xs, &ys, bounds, 3.0);
            check_layout(&g, &xs, &ys);
        }
    }

    /// After the points are permuted into the grid's order, adopting it gives the grid a
    /// rebuild from the permuted points gives, field for field, and the same neighbours.
    #[test]
    fn adopting_the_order_equals_rebuilding_the_reordered_points() {
        for (n, bounds) in [
            (0, Bounds::Open),
            (1, Bounds::Open),
            (3000, Bounds::Open),
            (2000, Bounds::torus(60.0, 40.0).unwrap()),
            (5000, Bounds::bounded(100.0, 100.0).unwrap()),
            (40_000, Bounds::torus(200.0, 200.0).unwrap()),
        ] {
            let (mut xs, mut ys) = points(n, 50.0, n as u64 + 3);
            // Clusters and duplicates: many points of one cell, equal positions.
            for k in (0..n).step_by(7) {
                (xs[k], ys[k]) = (xs[k / 2], ys[k / 2]);
            }
            let mut adopted = GridIndex::default();
            adopted.rebuild(&xs, &ys, bounds, 2.5);
            let perm = adopted.order().to_vec();
            let px: Vec<f32> = perm.iter().map(|&i| xs[i as usize]).collect();
            let py: Vec<f32> = perm.iter().map(|&i| ys[i as usize]).collect();
            adopted.adopt_order();
            let mut rebuilt = GridIndex::default();
            rebuilt.rebuild(&px, &py, bounds, 2.5);
            check_layout(&adopted, &px, &py);
            for i in 0..n {
                assert_eq!(adopted.position(i), rebuilt.position(i), "point {i} of {n}");
            }
            assert_eq!(adopted.cell, rebuilt.cell, "{n} points");
            assert_eq!(adopted.sort.start, rebuilt.sort.start);
            assert_eq!(adopted.sort.order, rebuilt.sort.order);
            let ranks = |g: &GridIndex| {
                let r = g.ranks().iter().map(|r| r.load(Ordering::Relaxed));
                r.collect::<Vec<u32>>()
            };
            assert_eq!(ranks(&adopted), ranks(&rebuilt));
            assert_eq!(adopted.sort.sorted_x, rebuilt.sort.sorted_x);
            assert_eq!(adopted.sort.sorted_y, rebuilt.sort.sorted_y);
            assert_eq!(adopted.scale.to_bits(), rebuilt.scale.to_bits());
            let (mut a, mut b) = (Vec::new(), Vec::new());
            for k in (0..n).step_by(97) {
                adopted.neighbours_of(k, 2.5, &mut a);
                rebuilt.neighbours_of(k, 2.5, &mut b);
                assert_eq!(a, b, "point {k} of {n}");
            }
        }
    }

    /// Asserts that two grids sorted their points alike: cells, order, sorted positions, ranks.
    fn assert_same_sort(par: &GridIndex, seq: &GridIndex, parts: usize) {
        assert_eq!(par.sort.start, seq.sort.start, "{parts} parts");
        assert_eq!(par.sort.order, seq.sort.order, "{parts} parts");
        assert_eq!(par.sort.sorted_x, seq.sort.sorted_x, "{parts} parts");
        assert_eq!(par.sort.sorted_y, seq.sort.sorted_y, "{parts} parts");
        let ranks = |g: &GridIndex| {
            let r = g.ranks().iter().map(|r| r.load(Ordering::Relaxed));
            r.collect::<Vec<u32>>()
        };
        assert_eq!(ranks(par), ranks(seq), "{parts} parts");
    }

    /// The grid of the points rebuilt on one part and checked, each rebuild on 2, 3, 4 and 7
    /// parts held to it; returns it and whether each of those sorted in ranges of cells.
    fn rebuilt_every_way(xs: &[f32], ys: &[f32], bounds: Bounds) -> (GridIndex, Vec<bool>) {
        let mut seq = GridIndex::default();
        seq.rebuild_with(xs, ys, bounds, 2.0, 1);
        check_layout(&seq, xs, ys);
        let ranged = [2, 3, 4, 7].map(|parts| {
            let mut par = GridIndex::default();
            par.rebuild_with(xs, ys, bounds, 2.0, parts);
            assert_same_sort(&par, &seq, parts);
            par.sort.took_ranges()
        });
        (seq, ranged.to_vec())
    }

    #[test]
    fn parallel_rebuild_equals_sequential() {
        let (xs, ys) = points(100_000, 300.0, 42);
        let bounds = Bounds::torus(300.0, 300.0).unwrap();
        let (seq, _) = rebuilt_every_way(&xs, &ys, bounds);
        // Through the public entry point on a pool of 4 threads.
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(4)
            .build()
            .unwrap();
        let mut par = GridIndex::default();
        pool.install(|| par.rebuild(&xs, &ys, bounds, 2.0));
        assert_eq!(par.sort.order, seq.sort.order);

        // Points nearly in cell order (put in it, then moved by up to a third of a cell, some
        // across the torus's seams): the parallel rebuild sorts them per range of cells, or
        // declines to and sorts them in rows.
        let (xs, ys) = points(600_000, 700.0, 43);
        let bounds = Bounds::torus(700.0, 700.0).unwrap();
        let mut seq = GridIndex::default();
        seq.rebuild_with(&xs, &ys, bounds, 2.0, 1);
        let (mut nx, mut ny): (Vec<f32>, Vec<f32>) = seq
            .order()
            .iter()
            .map(|&i| (xs[i as usize], ys[i as usize]))
            .unzip();
        let (jx, jy) = points(nx.len(), 1.4, 7);
        for k in 0..nx.len() {
            let p = bounds.wrap(Vec2::new(nx[k] + jx[k] - 0.7, ny[k] + jy[k] - 0.7));
            (nx[k], ny[k]) = (p.x, p.y);
        }
        let (_, ranged) = rebuilt_every_way(&nx, &ny, bounds);
        assert_eq!(ranged[..3], [true; 3], "on 2, 3 and 4 parts");
    }

    #[test]
    fn all_points_in_one_cell_still_split_between_workers() {
        let xs = vec![5.0; 50_000];
        let ys = vec![5.0; 50_000];
        let mut g = GridIndex::default();
        g.rebuild_with(&xs, &ys, Bounds::Open, 1.0, 4);
        check_layout(&g, &xs, &ys);
        assert_eq!(g.order().to_vec(), (0..50_000).collect::<Vec<u32>>());
    }

    #[test]
    fn runs_off_a_torus_are_the_runs_by_the_axes_spans() {
        let (xs, ys) = points(3_000, 50.0, 7);
        let mut g = GridIndex::default();
        for bounds in [Bounds::Open, Bounds::bounded(50.0, 50.0).unwrap()] {
            g.rebuild(&xs, &ys, bounds, 0.8);
            assert!(!g.bounds().is_torus(), "the single-span path runs");
            let (mut fast, mut spans) = (Vec::new(), Vec::new());
            let mut probes: Vec<Vec2> = (0..400).map(|k| Vec2::new(xs[k], ys[k])).collect();
            probes.extend([
                Vec2::new(-3.0, 25.0),
                Vec2::new(49.9, 60.0),
                Vec2::splat(0.0),
            ]);
            for (k, &p) in probes.iter().enumerate() {
                let r = [0.0, 0.3, 1.1, 2.0, 7.5, 80.0][k % 6];
                fast.clear();
                spans.clear();
                g.for_each_run(p, r, |run| fast.push(run));
                g.runs_by_spans(p, gather_radius(r, g.scale), |run| spans.push(run));
                assert_eq!(fast, spans, "{p} within {r}");
            }
        }
    }

    #[test]
    fn cell_geometry() {
        let (xs, ys) = points(10_000, 100.0, 3);
        let mut g = GridIndex::default();
        g.rebuild(&xs, &ys, Bounds::torus(100.0, 60.0).unwrap(), 3.0);
        assert_eq!((g.cells_x(), g.cells_y()), (33, 20));
        assert!(g.cell_size().x >= 3.0 && g.cell_size().y >= 3.0);
        assert_eq!(g.cell_of(Vec2::new(99.99, 59.99)), (32, 19));
        assert_eq!(g.cell_of(Vec2::new(-1.0, 1000.0)), (0, 19));
        // A tiny radius is capped: at most 4 N cells.
        g.rebuild(
            &xs[..100],
            &ys[..100],
            Bounds::torus(100.0, 60.0).unwrap(),
            1e-6,
        );
        assert!(g.cells_x() * g.cells_y() <= 400);
        g.rebuild(&xs[..100], &ys[..100], Bounds::Open, 0.0);
        assert!(g.cells_x() * g.cells_y() <= 400);
        check_layout(&g, &xs[..100], &ys[..100]);
        // An infinite radius: one cell, and every point found.
        for bounds in [Bounds::Open, Bounds::torus(100.0, 100.0).unwrap()] {
            g.rebuild(&xs[..100], &ys[..100], bounds, f32::INFINITY);
            assert_eq!((g.cells_x(), g.cells_y()), (1, 1));
            check_layout(&g, &xs[..100], &ys[..100]);
            let mut out = Vec::new();
            g.neighbours_of(3, f32::INFINITY, &mut out);
            assert_eq!(out.len(), 99);
        }
    }

    #[test]
    fn warm_rebuild_keeps_its_buffers() {
        let (xs, ys) = points(50_000, 200.0, 9);
        let bounds = Bounds::torus(200.0, 200.0).unwrap();
        let mut g = GridIndex::default();
        g.rebuild(&xs, &ys, bounds, 2.0);
        let ptrs = (
            g.sort.order.as_ptr(),
            g.sort.start.as_ptr(),
            g.sort.sorted_x.as_ptr(),
            g.cell.as_ptr(),
        );
        g.rebuild(&xs, &ys, bounds, 2.0);
        assert_eq!(
            ptrs,
            (
                g.sort.order.as_ptr(),
                g.sort.start.as_ptr(),
                g.sort.sorted_x.as_ptr(),
                g.cell.as_ptr()
            )
        );
    }
}
