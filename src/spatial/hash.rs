//! A hashed grid: cells of one fixed side, hashed by row into a table of about `2 N` buckets,
//! for queries much shorter than the world is wide.
//!
//! The dense [`super::GridIndex`] caps its cells at `4 N`, so in a world that is large and
//! sparse (RVO2's Circle at 100,000 agents spans 160,000 units while ORCA looks 15 units
//! around) its cells grow far beyond the query radius and a query reads hundreds of candidates.
//! Here the cells stay as small as the query radius however large the world is; only the
//! occupied ones cost memory, through the hash.
//!
//! # Layout
//!
//! Cell `(cx, cy)` (`floor(x / side)`, `floor(y / side)`, saturating) goes to bucket
//! `(cy * ROW + cx) mod T`, `T` a power of two: the cells `x0..=x1` of one row are a run of
//! consecutive buckets (two runs when it wraps around the end of the table). `order` is the
//! stable sort of the point indices by bucket, `start` its prefix sums (`T + 1` long), and
//! `sorted_x` / `sorted_y` the positions in that order (then [`PAD`] more, so that eight lanes
//! can be read from any point), so every run of buckets is one contiguous run of points.
//!
//! # Invariants
//!
//! * A query visits every bucket that can hold a point within reach, each at most once (the
//!   runs of its rows are sorted and merged), so each point is offered once; other cells that
//!   share a bucket only add candidates, which the caller's distance filter drops.
//! * The rebuild is a stable counting sort by bucket, the same sort as [`super::GridIndex`]'s: in
//!   one level up to 1,048,576 points and 262,144 buckets (on the calling thread up to 65,536
//!   points), beyond in two levels
//!   (per-chunk histograms of at most 1024 runs of buckets, a scatter into chunk-owned slots,
//!   then a counting sort within each run) on the current rayon pool; the result does not
//!   depend on the thread count or the way.
//! * Offsets are plain differences: open and walled worlds only (on a torus the world's own
//!   index serves).
//! * Buffers are reused: once warm, a rebuild of the same size allocates nothing.

use std::ops::Range;

use glam::Vec2;
use rayon::prelude::*;

use super::sort::CountingSort;
use super::{gather_radius, to_u32};

/// The row multiplier of the hash: odd, and far from every small multiple of a table size.
const ROW: u32 = 0x9E37_79B1;
/// Queries spanning more rows than this scan every point instead.
const MAX_ROWS: usize = 8;
/// From this many points on, the rebuild's bucket pass runs on the current rayon pool (and the
/// sort too, beyond the sizes it sorts in one level).
const PARALLEL_MIN_POINTS: usize = 8 * 1024;
/// Points per work item of the bucket pass.
const CHUNK: usize = 8 * 1024;
/// Positions past the last point, so that a scan may read eight lanes from any point.
pub const PAD: usize = 8;

/// A hashed grid of query-sized cells: cell `(cx, cy)` (`floor(x / side)`, `floor(y / side)`)
/// goes to bucket `(cy * ROW + cx) mod T`, `T` a power of two near `2 N`, so the cells of one
/// row within reach are one run of consecutive buckets (two where the run wraps around the
/// table). [`HashGrid::for_each_run`] hands out those runs as ranges of points, each point at
/// most once; callers filter by distance. Offsets are plain differences: for open and walled
/// worlds (on a torus the world's own index serves).
#[derive(Clone, Debug, Default)]
pub struct HashGrid {
    side: f32,
    inv_side: f32,
    /// Table size minus one (`T - 1`).
    mask: u32,
    /// Scratch: each point's bucket.
    bucket: Vec<u32>,
    /// The points sorted by bucket: `start` (prefix sums, `T + 1` long), `order` and the
    /// sorted positions (then [`PAD`] of `f32::MAX`), with the sort's scratch.
    sort: CountingSort,
}

/// The cell coordinate of `x`: `floor(x * inv)`, saturating at the ends of `i32` (monotone, so a
/// query's cell range still holds every point within reach). Written out rather than
/// `f32::floor`, which the portable build calls as a library function.
#[inline]
fn cell(x: f32, inv: f32) -> i32 {
    let v = x * inv;
    let t = v as i32;
    // Truncation rounds negative fractions up; saturated values are already the ends.
    if (t as f32) > v {
        t.saturating_sub(1)
    } else {
        t
    }
}

/// An upper bound on the distance between `now[i]` and `then[i]` over every `i` (`|dx| + |dy|`,
/// widened for the rounding of the differences); infinite when a coordinate is not finite. On
/// the current rayon pool for large N.
pub(crate) fn farthest_move((x, y): (&[f32], &[f32]), (x0, y0): (&[f32], &[f32])) -> f32 {
    const CHUNK: usize = 2048;
    // A NaN counts as infinitely far, which then stays the largest; selects rather than
    // `f32::max`. The largest is kept per lane of eight and the lanes' taken at the end (a
    // single running maximum is a chain LLVM does not vectorise): the largest of a set is the
    // same in any order.
    const LANES: usize = 8;
    let part = |x: &[f32], y: &[f32], x0: &[f32], y0: &[f32]| {
        let keep = |most: f32, (((&x, &y), &x0), &y0): (((&f32, &f32), &f32), &f32)| {
            let d = (x - x0).abs() + (y - y0).abs();
            let d = if d.is_nan() { f32::INFINITY } else { d };
            if d <= most { most } else { d }
        };
        let n = x.len().min(y.len()).min(x0.len()).min(y0.len());
        let whole = n / LANES * LANES;
        let mut lanes = [0.0f32; LANES];
        for k in (0..whole).step_by(LANES) {
            let block =
                |v: &[f32]| -> [f32; LANES] { v[k..k + LANES].try_into().expect("a whole block") };
            let (bx, by, bx0, by0) = (block(x), block(y), block(x0), block(y0));
            for l in 0..LANES {
                lanes[l] = keep(lanes[l], (((&bx[l], &by[l]), &bx0[l]), &by0[l]));
            }
        }
        let rest = x[whole..n].iter().zip(&y[whole..n]);
        let rest = rest.zip(&x0[whole..n]).zip(&y0[whole..n]);
        let most = rest.fold(0.0f32, keep);
        lanes.iter().fold(most, |m, &l| if l <= m { m } else { l })
    };
    let most = if x.len() >= 4 * CHUNK {
        x.par_chunks(CHUNK)
            .zip(y.par_chunks(CHUNK))
            .zip(x0.par_chunks(CHUNK).zip(y0.par_chunks(CHUNK)))
            .map(|((x, y), (x0, y0))| part(x, y, x0, y0))
            .reduce(|| 0.0, f32::max)
    } else {
        part(x, y, x0, y0)
    };
    if most.is_finite() {
        most * (1.0 + 1e-5)
    } else {
        f32::INFINITY
    }
}

impl HashGrid {
    /// Rebuilds the grid from the positions `(xs[i], ys[i])` with cells of side `side` (> 0;
    /// the radius most queries will use): a stable counting sort by bucket, on the current rayon
    /// pool for large N, whose result does not depend on the thread count.
    ///
    /// # Panics
    /// If `xs` and `ys` differ in length or hold more than `u32::MAX` points, or if `side` is
    /// not positive and finite.
    pub fn rebuild(&mut self, xs: &[f32], ys: &[f32], side: f32) {
        let parts = if xs.len() >= PARALLEL_MIN_POINTS {
            rayon::current_num_threads()
        } else {
            1
        };
        self.rebuild_with(xs, ys, side, parts);
    }

    /// Rebuild using `parts` workers (1 = sequential); the result does not depend on `parts`.
    fn rebuild_with(&mut self, xs: &[f32], ys: &[f32], side: f32, parts: usize) {
        assert_eq!(xs.len(), ys.len(), "xs and ys must have the same length");
        assert!(
            side > 0.0 && side.is_finite(),
            "cell side must be positive, got {side}"
        );
        let n = xs.len();
        to_u32(n);
        let table = (2 * n).next_power_of_two().clamp(64, 1 << 31);
        self.mask = (table - 1) as u32;
        self.side = side;
        self.inv_side = side.recip();
        let (inv, mask) = (self.inv_side, self.mask);
        let fill = |out: &mut [u32], xs: &[f32], ys: &[f32]| {
            for ((b, &x), &y) in out.iter_mut().zip(xs).zip(ys) {
                *b = ((cell(y, inv) as u32).wrapping_mul(ROW)).wrapping_add(cell(x, inv) as u32)
                    & mask;
            }
        };
        self.bucket.resize(n, 0);
        if parts > 1 {
            self.bucket
                .par_chunks_mut(CHUNK)
                .zip(xs.par_chunks(CHUNK).zip(ys.par_chunks(CHUNK)))
                .for_each(|(out, (xs, ys))| fill(out, xs, ys));
        } else {
            fill(&mut self.bucket, xs, ys);
        }
        let pos = |i: usize| (xs[i], ys[i]);
        self.sort
            .sort(&self.bucket, table, pos, parts, (PAD, f32::MAX));
    }

    /// Replaces the sorted positions by `(xs[i], ys[i])` (the points' new positions, indexed as
    /// at the last rebuild) while every point keeps the bucket of its position at that rebuild:
    /// much cheaper than a rebuild when points have moved a little. A query must then widen its
    /// radius by the farthest any point has moved since the rebuild: a point within `r` of the
    /// query now was within `r + d` of it where it was bucketed. On the current rayon pool for
    /// large N, like the rebuild.
    ///
    /// # Panics
    /// If `xs` or `ys` does not hold one position per point.
    pub(crate) fn refresh(&mut self, xs: &[f32], ys: &[f32]) {
        let n = self.len();
        assert!(
            xs.len() == n && ys.len() == n,
            "one position per point: {n} points, {} and {} positions",
            xs.len(),
            ys.len()
        );
        let sort = &mut self.sort;
        let (order, sx, sy) = (
            &sort.order,
            &mut sort.sorted_x[..n],
            &mut sort.sorted_y[..n],
        );
        let copy = |order: &[u32], sx: &mut [f32], sy: &mut [f32]| {
            for ((&i, x), y) in order.iter().zip(sx).zip(sy) {
                (*x, *y) = (xs[i as usize], ys[i as usize]);
            }
        };
        if n >= PARALLEL_MIN_POINTS {
            // About four pieces per thread: chunks of the rebuild's size would load the threads
            // unevenly at a few chunks' worth of points (8,192 and 1,808 at 10,000).
            let piece = n
                .div_ceil(4 * rayon::current_num_threads())
                .clamp(1024, CHUNK);
            order
                .par_chunks(piece)
                .zip(sx.par_chunks_mut(piece).zip(sy.par_chunks_mut(piece)))
                .for_each(|(order, (sx, sy))| copy(order, sx, sy));
        } else {
            copy(order, sx, sy);
        }
    }

    /// Makes the grid the one a rebuild would give after the points were permuted into its
    /// [`order`](Self::order) (point `k` becomes the old point `order()[k]`), without sorting:
    /// the same points give the same buckets and sorted positions, and a stable sort of points
    /// already in bucket order is the identity.
    pub(crate) fn adopt_order(&mut self) {
        for (k, (o, r)) in self
            .sort
            .order
            .iter_mut()
            .zip(&self.sort.rank.0)
            .enumerate()
        {
            *o = k as u32;
            r.store(k as u32, std::sync::atomic::Ordering::Relaxed);
        }
    }

    /// The side of the cells, as given to the last rebuild (0 before the first).
    #[must_use]
    pub fn side(&self) -> f32 {
        self.side
    }

    /// How many points the grid holds.
    #[must_use]
    pub fn len(&self) -> usize {
        self.sort.order.len()
    }

    /// Whether the grid holds no points.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.sort.order.is_empty()
    }

    /// The mean, over the points, of how many points share a point's bucket (itself included):
    /// `sum(count^2) / N` over the buckets, 0 for an empty grid. About how many points a cell
    /// holds where the points are, however many empty cells lie between them; a caller choosing
    /// the cell side for its queries compares it between sides.
    #[must_use]
    pub fn crowding(&self) -> f32 {
        let n = self.len();
        if n == 0 {
            return 0.0;
        }
        let squares: u64 = self
            .sort
            .start
            .windows(2)
            .map(|w| u64::from(w[1] - w[0]).pow(2))
            .sum();
        squares as f32 / n as f32
    }

    /// Point indices sorted by bucket.
    #[must_use]
    pub fn order(&self) -> &[u32] {
        &self.sort.order
    }

    /// x coordinates in [`order`](Self::order), followed by eight entries of `f32::MAX`.
    #[must_use]
    pub fn sorted_x(&self) -> &[f32] {
        &self.sort.sorted_x
    }

    /// y coordinates in [`order`](Self::order), followed by eight entries of `f32::MAX`.
    #[must_use]
    pub fn sorted_y(&self) -> &[f32] {
        &self.sort.sorted_y
    }

    /// Calls `visit` with ranges into [`order`](Self::order), [`sorted_x`](Self::sorted_x) and
    /// [`sorted_y`](Self::sorted_y) that together hold every point within `r` of `p` (and
    /// others), each point in at most one range. Callers filter by distance.
    #[inline(always)]
    pub fn for_each_run(&self, p: Vec2, r: f32, mut visit: impl FnMut(Range<usize>)) {
        for run in self.runs(p, r).iter() {
            visit(run);
        }
    }

    /// The ranges [`for_each_run`](Self::for_each_run) visits, as a value: a caller compiled for
    /// other target features can loop over them in its own code instead of a closure.
    #[inline(always)]
    #[must_use]
    pub fn runs(&self, p: Vec2, r: f32) -> Runs {
        self.runs_of(self.cells(p, r))
    }

    /// The block of cells a query of radius `r` around `p` reads, inclusive:
    /// `[x0, x1, y0, y1]`. Queries with the same block get the same [`runs`](Self::runs), so a
    /// caller may keep them for the next query whose block is equal.
    #[inline(always)]
    #[must_use]
    pub fn cells(&self, p: Vec2, r: f32) -> [i32; 4] {
        let inv = self.inv_side;
        let r = gather_radius(r, p.x.abs().max(p.y.abs()));
        // `floor` then the saturating conversion: the same value as [`cell`] for every input
        // (NaN included), and four lanes of a vector where the caller is compiled for SSE4.1
        // or better (the ORCA filter's AVX2 clone; elsewhere `floor` is a library call).
        let v = [p.x - r, p.x + r, p.y - r, p.y + r];
        let mut out = [0i32; 4];
        for k in 0..4 {
            out[k] = (v[k] * inv).floor() as i32;
        }
        out
    }

    /// The cell holding `p`, `[x, y]`: the cell points at `p` are bucketed in.
    #[inline(always)]
    #[must_use]
    pub fn cell_of(&self, p: Vec2) -> [i32; 2] {
        [cell(p.x, self.inv_side), cell(p.y, self.inv_side)]
    }

    /// The runs of points of a block of cells from [`cells`](Self::cells).
    #[inline(always)]
    #[must_use]
    pub fn runs_of(&self, [x0, x1, y0, y1]: [i32; 4]) -> Runs {
        let mut out = Runs::default();
        let n = self.sort.order.len();
        if n == 0 {
            return out;
        }
        let table = i64::from(self.mask) + 1;
        let cols = i64::from(x1) - i64::from(x0) + 1;
        let rows = i64::from(y1) - i64::from(y0) + 1;
        if cols <= 0 || rows <= 0 {
            return out;
        }
        if rows > MAX_ROWS as i64 || cols * rows >= table {
            out.push(0, n);
            return out;
        }
        let mut runs = [(0u32, 0u32); 2 * MAX_ROWS];
        let mut len = 0;
        for cy in y0..=y1 {
            let b0 = (cy as u32).wrapping_mul(ROW).wrapping_add(x0 as u32) & self.mask;
            let b1 = i64::from(b0) + cols - 1;
            if b1 < table {
                runs[len] = (b0, b1 as u32);
                len += 1;
            } else {
                runs[len] = (b0, self.mask);
                runs[len + 1] = (0, (b1 - table) as u32);
                len += 2;
            }
        }
        let runs = &mut runs[..len];
        let disjoint = (1..len).all(|a| {
            runs[..a]
                .iter()
                .all(|&(lo, hi)| runs[a].1 < lo || runs[a].0 > hi)
        });
        if disjoint {
            for &(lo, hi) in runs.iter() {
                out.push(
                    self.sort.start[lo as usize] as usize,
                    self.sort.start[hi as usize + 1] as usize,
                );
            }
            return out;
        }
        runs.sort_unstable();
        let mut at = 0;
        while at < runs.len() {
            let (lo, mut hi) = runs[at];
            at += 1;
            while at < runs.len() && runs[at].0 <= hi + 1 {
                hi = hi.max(runs[at].1);
                at += 1;
            }
            out.push(
                self.sort.start[lo as usize] as usize,
                self.sort.start[hi as usize + 1] as usize,
            );
        }
        out
    }
}

/// The ranges of points of one query of a [`HashGrid`] (at most two per row of cells), empty
/// ones left out.
#[derive(Clone, Copy, Debug, Default)]
pub struct Runs {
    ranges: [(u32, u32); 2 * MAX_ROWS],
    len: usize,
}

impl Runs {
    #[inline(always)]
    fn push(&mut self, a: usize, b: usize) {
        if a < b {
            self.ranges[self.len] = (a as u32, b as u32);
            self.len += 1;
        }
    }

    /// The ranges in order of the query.
    #[inline(always)]
    pub fn iter(&self) -> impl Iterator<Item = Range<usize>> + '_ {
        self.ranges[..self.len]
            .iter()
            .map(|&(a, b)| a as usize..b as usize)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::AgentRng;

    /// Every point within `r`, by the runs, against every point by brute force.
    fn check(xs: &[f32], ys: &[f32], side: f32, queries: &[(Vec2, f32)]) {
        let mut g = HashGrid::default();
        g.rebuild(xs, ys, side);
        for &(p, r) in queries {
            let mut seen = vec![0u32; xs.len()];
            let mut found = Vec::new();
            g.for_each_run(p, r, |run| {
                for k in run {
                    let j = g.order()[k] as usize;
                    seen[j] += 1;
                    assert_eq!((g.sorted_x()[k], g.sorted_y()[k]), (xs[j], ys[j]));
                    let d = Vec2::new(xs[j], ys[j]) - p;
                    if d.length_squared() <= r * r {
                        found.push(j);
                    }
                }
            });
            assert!(seen.iter().all(|&s| s <= 1), "a point offered twice");
            found.sort_unstable();
            let brute: Vec<usize> = (0..xs.len())
                .filter(|&j| (Vec2::new(xs[j], ys[j]) - p).length_squared() <= r * r)
                .collect();
            assert_eq!(found, brute, "query {p} radius {r}");
        }
    }

    /// A coordinate that is not finite, anywhere (first, inside, last; in one chunk and among
    /// many), makes the bound infinite; otherwise it bounds every move.
    #[test]
    fn farthest_move_is_infinite_for_any_coordinate_that_is_not_finite() {
        for n in [3usize, 10, 40_000] {
            let then: Vec<f32> = (0..n).map(|k| k as f32 * 0.5).collect();
            let now: Vec<f32> = then.iter().map(|&x| x + 0.25).collect();
            let bound = farthest_move((&now, &then), (&then, &then));
            assert!((0.25..0.2501).contains(&bound), "{n} points: {bound}");
            for at in [0, n / 2, n - 1] {
                for bad in [f32::NAN, f32::INFINITY, f32::NEG_INFINITY] {
                    let mut xs = now.clone();
                    xs[at] = bad;
                    let bound = farthest_move((&xs, &then), (&then, &then));
                    assert_eq!(bound, f32::INFINITY, "{bad} at {at} of {n}");
                }
            }
        }
    }

    /// The bound is the largest move (widened by its factor) wherever it lies: in a whole block
    /// of lanes, in the tail, in any chunk.
    #[test]
    fn farthest_move_is_the_largest_move_wherever_it_lies() {
        let mut rng = AgentRng::new(12, 0, 0, 0);
        for n in [1usize, 7, 8, 9, 17, 100, 9000, 40_000] {
            let then: Vec<f32> = (0..n).map(|_| rng.unit() * 100.0).collect();
            let (mut xs, mut ys) = (then.clone(), then.clone());
            for k in 0..n {
                xs[k] += rng.unit() - 0.5;
                ys[k] -= rng.unit() - 0.5;
            }
            let at = (rng.unit() * n as f32) as usize % n;
            xs[at] += 3.0;
            let largest = (0..n)
                .map(|k| (xs[k] - then[k]).abs() + (ys[k] - then[k]).abs())
                .fold(0.0f32, f32::max);
            let bound = farthest_move((&xs, &ys), (&then, &then));
            assert_eq!(
                bound,
                largest * (1.0 + 1e-5),
                "{n} points, the largest at {at}"
            );
        }
    }

    /// `crowding` against each point's bucket-mates counted one pair at a time, on clusters and
    /// scattered points; empty grids give 0.
    #[test]
    fn crowding_is_the_mean_number_of_points_in_a_points_bucket() {
        let mut rng = AgentRng::new(11, 0, 0, 0);
        let mut g = HashGrid::default();
        g.rebuild(&[], &[], 1.0);
        assert_eq!(g.crowding(), 0.0);
        for (n, extent) in [(1, 1.0), (40, 3.0), (300, 50.0), (2000, 4000.0)] {
            let xs: Vec<f32> = (0..n).map(|_| rng.unit() * extent - 5.0).collect();
            let ys: Vec<f32> = (0..n).map(|_| rng.unit() * extent).collect();
            g.rebuild(&xs, &ys, 2.0);
            let bucket = |i: usize| {
                let (cx, cy) = (cell(xs[i], g.inv_side), cell(ys[i], g.inv_side));
                ((cy as u32).wrapping_mul(ROW)).wrapping_add(cx as u32) & g.mask
            };
            let pairs: usize = (0..n)
                .map(|i| (0..n).filter(|&j| bucket(j) == bucket(i)).count())
                .sum();
            assert_eq!(g.crowding(), pairs as f32 / n as f32, "{n} points");
        }
        // Ten points in one cell and ten alone: (10 * 10 + 10 * 1) / 20.
        let xs: Vec<f32> = (0..20)
            .map(|i| if i < 10 { 0.5 } else { i as f32 * 10.0 })
            .collect();
        g.rebuild(&xs, &[0.5; 20], 1.0);
        assert_eq!(g.crowding(), 5.5);
    }

    /// A grid that adopts its order equals a rebuild over the points permuted into it.
    #[test]
    fn adopting_the_order_equals_a_rebuild_of_the_permuted_points() {
        let mut rng = AgentRng::new(13, 0, 0, 0);
        for n in [0_usize, 1, 50, 3000] {
            let xs: Vec<f32> = (0..n).map(|_| rng.unit() * 80.0 - 40.0).collect();
            let ys: Vec<f32> = (0..n).map(|_| rng.unit() * 80.0).collect();
            let mut g = HashGrid::default();
            g.rebuild(&xs, &ys, 3.0);
            let px: Vec<f32> = g.order().iter().map(|&i| xs[i as usize]).collect();
            let py: Vec<f32> = g.order().iter().map(|&i| ys[i as usize]).collect();
            g.adopt_order();
            let mut fresh = HashGrid::default();
            fresh.rebuild(&px, &py, 3.0);
            assert_eq!(g.order(), fresh.order(), "{n}");
            assert_eq!(g.sort.start, fresh.sort.start, "{n}");
            assert_eq!(g.sorted_x(), fresh.sorted_x(), "{n}");
            assert_eq!(g.sorted_y(), fresh.sorted_y(), "{n}");
        }
    }

    #[test]
    fn every_query_finds_exactly_the_points_brute_force_finds() {
        let mut rng = AgentRng::new(9, 0, 0, 0);
        for (n, extent, side) in [
            (0, 10.0, 1.0),
            (1, 10.0, 1.0),
            (300, 50.0, 2.0),
            (2000, 160_000.0, 15.0),
            (500, 3.0, 15.0),
        ] {
            let (mut xs, mut ys) = (Vec::new(), Vec::new());
            for k in 0..n {
                // Half on a ring (the Circle's layout), half scattered, some negative.
                let t = rng.unit() * std::f32::consts::TAU;
                let p = if k % 2 == 0 {
                    Vec2::from_angle(t) * extent * 0.5
                } else {
                    Vec2::new(rng.signed(), rng.signed()) * extent * 0.5
                };
                xs.push(p.x);
                ys.push(p.y);
            }
            let mut queries = Vec::new();
            for k in 0..200 {
                let p = if n > 0 && k % 2 == 0 {
                    Vec2::new(xs[k % n], ys[k % n])
                } else {
                    Vec2::new(rng.signed(), rng.signed()) * extent * 0.5
                };
                let r = side * [0.0, 0.5, 1.0, 1.5, 4.0, 9.0][k % 6];
                queries.push((p, r));
            }
            queries.push((Vec2::ZERO, extent * 4.0));
            queries.push((Vec2::ZERO, f32::NAN));
            check(&xs, &ys, side, &queries);
        }
    }

    #[test]
    fn far_points_saturate_into_edge_cells_and_are_still_found() {
        let xs = [1e30, -1e30, 3e9, 0.0];
        let ys = [0.0, 1e30, -3e9, 0.0];
        let queries = [
            (Vec2::new(1e30, 0.0), 1.0),
            (Vec2::new(-1e30, 1e30), 1e10),
            (Vec2::new(3e9, -3e9), 100.0),
            (Vec2::ZERO, 1e31),
        ];
        check(&xs, &ys, 15.0, &queries);
    }

    #[test]
    fn rounding_at_a_cell_edge_loses_no_point_the_filter_accepts() {
        // `p.x - r` rounds to -15 (cell -1) while `q` lies in cell -2, yet `q - p` rounds to -15.
        let p = Vec2::new(-(2.0_f32.powi(-21)), 0.0);
        let q = -15.000_001_f32;
        assert!((q - p.x) * (q - p.x) <= 15.0 * 15.0);
        check(&[q, 40.0], &[0.0, 0.0], 15.0, &[(p, 15.0), (p, -15.0)]);
    }

    #[test]
    fn parallel_rebuild_equals_sequential_and_a_plain_counting_sort() {
        // 100,000 points: a quarter in one cell, a quarter in a few dense clusters, the rest on
        // a wide ring.
        let n = 100_000;
        assert!(n >= PARALLEL_MIN_POINTS);
        let mut rng = AgentRng::new(5, 0, 0, 0);
        let (mut xs, mut ys) = (Vec::with_capacity(n), Vec::with_capacity(n));
        for k in 0..n {
            let p = match k % 4 {
                0 => Vec2::new(3.0, -4.0),
                1 => {
                    let centre = Vec2::new((k % 7) as f32 * 100.0, -((k % 5) as f32) * 60.0);
                    centre + Vec2::new(rng.signed(), rng.signed()) * 20.0
                }
                _ => Vec2::from_angle(rng.unit() * std::f32::consts::TAU) * 50_000.0,
            };
            xs.push(p.x);
            ys.push(p.y);
        }
        let side = 15.0;
        let mut seq = HashGrid::default();
        seq.rebuild_with(&xs, &ys, side, 1);

        // The sequential counting sort the grid once used: a histogram over the whole table,
        // prefix sums, then a scatter in index order.
        let (inv, mask) = (seq.inv_side, seq.mask);
        let table = mask as usize + 1;
        let bucket: Vec<usize> = xs
            .iter()
            .zip(&ys)
            .map(|(&x, &y)| {
                ((cell(y, inv) as u32)
                    .wrapping_mul(ROW)
                    .wrapping_add(cell(x, inv) as u32)
                    & mask) as usize
            })
            .collect();
        let mut start = vec![0u32; table + 1];
        for &b in &bucket {
            start[b + 1] += 1;
        }
        for b in 0..table {
            start[b + 1] += start[b];
        }
        let mut cursor = start.clone();
        let mut order = vec![0u32; n];
        for (i, &b) in bucket.iter().enumerate() {
            order[cursor[b] as usize] = i as u32;
            cursor[b] += 1;
        }
        assert!(
            start.windows(2).any(|w| w[1] - w[0] >= 25_000),
            "one crowded bucket"
        );
        assert_eq!(seq.sort.start, start);
        assert_eq!(seq.order(), order);
        let pad = [f32::MAX; PAD];
        let sx: Vec<f32> = order.iter().map(|&i| xs[i as usize]).chain(pad).collect();
        let sy: Vec<f32> = order.iter().map(|&i| ys[i as usize]).chain(pad).collect();
        assert_eq!(seq.sorted_x(), sx);
        assert_eq!(seq.sorted_y(), sy);

        let same = |g: &HashGrid, what: &str| {
            assert_eq!(g.sort.start, seq.sort.start, "{what}");
            assert_eq!(g.order(), seq.order(), "{what}");
            assert_eq!(g.sorted_x(), seq.sorted_x(), "{what}");
            assert_eq!(g.sorted_y(), seq.sorted_y(), "{what}");
        };
        for parts in [2, 3, 4, 7] {
            let mut par = HashGrid::default();
            par.rebuild_with(&xs, &ys, side, parts);
            same(&par, &format!("{parts} parts"));
        }
        // Through the public entry point on a pool of 4 threads, into a grid last built larger.
        let pool = rayon::ThreadPoolBuilder::new()
            .num_threads(4)
            .build()
            .unwrap();
        let mut par = HashGrid::default();
        let wide: Vec<f32> = (0..2 * n).map(|i| i as f32).collect();
        pool.install(|| par.rebuild(&wide, &wide, side));
        pool.install(|| par.rebuild(&xs, &ys, side));
        same(&par, "a pool of 4 threads");
    }

    #[test]
    fn the_padding_is_there_after_a_smaller_rebuild() {
        let xs: Vec<f32> = (0..100).map(|i| i as f32).collect();
        let mut g = HashGrid::default();
        g.rebuild(&xs, &xs, 2.0);
        g.rebuild(&xs[..10], &xs[..10], 2.0);
        assert_eq!(g.sorted_x().len(), 10 + PAD);
        assert!(g.sorted_x()[10..].iter().all(|&x| x == f32::MAX));
        assert!(g.sorted_y()[10..].iter().all(|&y| y == f32::MAX));
    }

    #[test]
    fn a_rebuild_of_the_same_size_keeps_its_buffers() {
        let xs: Vec<f32> = (0..100).map(|i| i as f32).collect();
        let ys = vec![0.0; 100];
        let mut g = HashGrid::default();
        g.rebuild(&xs, &ys, 2.0);
        let cap = (g.sort.start.capacity(), g.sort.order.capacity());
        g.rebuild(&ys, &xs, 2.0);
        assert_eq!(cap, (g.sort.start.capacity(), g.sort.order.capacity()));
    }
}
