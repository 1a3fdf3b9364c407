//! The gather: a cell's 3 x 3 block of cells copied from the grid's cell-ordered columns into
//! one contiguous buffer, shifted across torus seams, padded to whole blocks of [`KLANES`] with
//! far-away points.
//!
//! Invariants: the buffer holds the block's points cell by cell, each cell's in the grid's order,
//! so an agent's sums over it are fixed by the grid alone; an interior cell's fast path gathers
//! the same bits as the general path ([`Gather::edge_cell`]); padding points lie at [`FAR`],
//! where no mask admits them.

use super::KLANES;
use crate::bounds::Bounds;
use crate::plans::neighbours::{LANES, SortedCopies};
use crate::spatial::GridIndex;

/// The smallest size of a cell buffer's vectors.
const MIN_CELL_BUF: usize = 4096;
/// A padding coordinate: far from every point, with a finite square.
pub(super) const FAR: f32 = 1e18;

/// The padded neighbourhood of one cell.
#[derive(Debug, Default)]
pub(super) struct CellBuf {
    /// Values in use (a multiple of `LANES` once gathered); the vectors may be longer.
    pub(super) len: usize,
    pub(super) x: Vec<f32>,
    pub(super) y: Vec<f32>,
    pub(super) vx: Vec<f32>,
    pub(super) vy: Vec<f32>,
    pub(super) g: Vec<f32>,
    /// Unit headings, gathered only for Vicsek batches.
    pub(super) hx: Vec<f32>,
    pub(super) hy: Vec<f32>,
}

/// One block of the cell buffer: positions, velocities and groups of `KLANES` candidates.
pub(super) type Block<'b> = (
    &'b [f32; KLANES],
    &'b [f32; KLANES],
    &'b [f32; KLANES],
    &'b [f32; KLANES],
    &'b [f32; KLANES],
);

impl CellBuf {
    /// The gathered candidates in blocks of `KLANES`. The five columns are cut to one length
    /// first, so the loop over blocks runs on one counter without bounds checks.
    #[inline(always)]
    pub(super) fn blocks(&self) -> impl Iterator<Item = Block<'_>> {
        self.blocks_of((&self.vx, &self.vy))
    }

    /// [`CellBuf::blocks`] with `motion` read in the velocities' place (the unit headings, for
    /// Vicsek sums).
    #[inline(always)]
    pub(super) fn blocks_of<'b>(
        &'b self,
        (mx, my): (&'b [f32], &'b [f32]),
    ) -> impl Iterator<Item = Block<'b>> {
        let n = self.len;
        fn col(v: &[f32], n: usize) -> &[[f32; KLANES]] {
            v[..n].as_chunks::<KLANES>().0
        }
        let (x, y) = (col(&self.x, n), col(&self.y, n));
        let (vx, vy, g) = (col(mx, n), col(my, n), col(&self.g, n));
        let m = x.len();
        let (y, vx, vy, g) = (&y[..m], &vx[..m], &vy[..m], &g[..m]);
        (0..m).map(move |k| (&x[k], &y[k], &vx[k], &vy[k], &g[k]))
    }
}

/// What a task's gathers read: the grid and the copies in its order, the world's bounds, and
/// whether the kernels read the groups and the unit headings.
#[derive(Clone, Copy)]
pub(super) struct Gather<'a> {
    pub(super) grid: &'a GridIndex,
    pub(super) s: &'a SortedCopies,
    pub(super) bounds: Bounds,
    pub(super) groups: bool,
    pub(super) headings: bool,
}

impl Gather<'_> {
    /// Gathers the 3 x 3 block of cells around `cell` into `buf`, shifted across torus seams,
    /// and pads it to whole blocks of lanes with far-away points. The groups are gathered only
    /// when some kernel tells groups apart (`groups`), the unit headings only for Vicsek sums
    /// (`headings`); otherwise `buf.g` (or `buf.hx` and `buf.hy`) keep stale values nobody
    /// reads.
    ///
    /// A cell away from the grid's edges (nearly all of them) takes a path of its own: its
    /// three rows are one run each, unshifted, so their bounds are six loads of the cells'
    /// starts, and the buffer's room is checked once. Its values are the general path's, bit
    /// for bit (`+ 0.0` included); [`Gather::edge_cell`] serves the edges.
    #[inline(always)]
    pub(super) fn cell(&self, cell: usize, buf: &mut CellBuf) {
        let (grid, s) = (self.grid, self.s);
        let (groups, headings) = (self.groups, self.headings);
        let (nx, ny) = (grid.cells_x() as usize, grid.cells_y() as usize);
        let (cx, cy) = (cell % nx, cell / nx);
        if cx > 0 && cx + 1 < nx && cy > 0 && cy + 1 < ny {
            let starts = grid.cell_start();
            let run = |c: usize| (starts[c - 1] as usize, starts[c + 2] as usize);
            let runs = [run(cell - nx), run(cell), run(cell + nx)];
            let total: usize = runs.iter().map(|&(a, b)| b - a).sum();
            buf.reserve(total + KLANES);
            let mut len = 0;
            for (a, b) in runs {
                append_motion(buf, len, (grid.sorted_padded(), s), a, b, (0.0, 0.0));
                append_columns(buf, len, s, (a, b), (groups, headings));
                len += b - a;
            }
            buf.len = len;
            pad(buf, groups, headings);
            return;
        }
        self.edge_cell(cell, buf);
    }

    /// [`Gather::cell`] for any cell, at the grid's edges too: a row across a torus seam is two
    /// runs, one of them shifted; outside a walled world a row or column is left out.
    fn edge_cell(&self, cell: usize, buf: &mut CellBuf) {
        let (grid, s, bounds) = (self.grid, self.s, self.bounds);
        let (groups, headings) = (self.groups, self.headings);
        buf.len = 0;
        let (nx, ny) = (grid.cells_x() as i64, grid.cells_y() as i64);
        let (cx, cy) = (cell as i64 % nx, cell as i64 / nx);
        let side = match bounds {
            Bounds::Torus { size } => Some(size),
            _ => None,
        };
        let starts = grid.cell_start();
        for dy in -1..=1 {
            let Some((row, shift_y)) = axis(cy + dy, ny, side.map(|s| s.y)) else {
                continue;
            };
            // The row's columns cx - 1 ..= cx + 1 as contiguous runs of cells: one run, or on a
            // torus at a seam the far column (shifted) apart from the others.
            let mut runs = [(0i64, 0i64, 0.0f32); 2];
            let nr = match side.map(|s| s.x) {
                Some(w) if cx == 0 => {
                    runs[0] = (nx - 1, nx - 1, -w);
                    runs[1] = (0, 1, 0.0);
                    2
                }
                Some(w) if cx == nx - 1 => {
                    runs[0] = (cx - 1, cx, 0.0);
                    runs[1] = (0, 0, w);
                    2
                }
                _ => {
                    runs[0] = ((cx - 1).max(0), (cx + 1).min(nx - 1), 0.0);
                    1
                }
            };
            let runs = runs.map(|(c0, c1, shift)| {
                (
                    starts[(row * nx + c0) as usize] as usize,
                    starts[(row * nx + c1) as usize + 1] as usize,
                    shift,
                )
            });
            for &(a, b, shift_x) in &runs[..nr] {
                let len = buf.len;
                buf.reserve(len + (b - a) + KLANES);
                append_motion(
                    buf,
                    len,
                    (grid.sorted_padded(), s),
                    a,
                    b,
                    (shift_x, shift_y),
                );
                append_columns(buf, len, s, (a, b), (groups, headings));
                buf.len += b - a;
            }
        }
        pad(buf, groups, headings);
    }
}

impl CellBuf {
    /// Makes every column at least `need` values long.
    #[inline(always)]
    fn reserve(&mut self, need: usize) {
        if self.x.len() < need {
            for v in [
                &mut self.x,
                &mut self.y,
                &mut self.vx,
                &mut self.vy,
                &mut self.g,
                &mut self.hx,
                &mut self.hy,
            ] {
                // Room for dense cells from the start, so that a flock clumping after warm-up
                // rarely grows the buffers again.
                v.resize(need.max(MIN_CELL_BUF), 0.0);
            }
        }
    }
}

/// The groups (with `groups`) and the unit headings (with `headings`) of `s[a..b]` into the
/// buffer at `len`, as [`append`] writes them.
#[inline(always)]
fn append_columns(
    buf: &mut CellBuf,
    len: usize,
    s: &SortedCopies,
    (a, b): (usize, usize),
    (groups, headings): (bool, bool),
) {
    if groups {
        append(&mut buf.g, len, &s.g, a, b);
    }
    if headings {
        append(&mut buf.hx, len, &s.hx, a, b);
        append(&mut buf.hy, len, &s.hy, a, b);
    }
}

/// Pads the gathered `buf.len` values to whole blocks with far-away points that no mask admits:
/// one whole block written past the last run (the gather made room for it), of which the used
/// part is kept. The groups and headings are padded where they were gathered.
#[inline(always)]
fn pad(buf: &mut CellBuf, groups: bool, headings: bool) {
    let len = buf.len;
    let pad = |v: &mut Vec<f32>, value: f32| v[len..len + KLANES].copy_from_slice(&[value; KLANES]);
    pad(&mut buf.x, FAR);
    pad(&mut buf.y, FAR);
    pad(&mut buf.vx, 0.0);
    pad(&mut buf.vy, 0.0);
    if groups {
        pad(&mut buf.g, -1.0);
    }
    if headings {
        pad(&mut buf.hx, 0.0);
        pad(&mut buf.hy, 0.0);
    }
    buf.len = len.div_ceil(KLANES) * KLANES;
}

/// Writes `src[a..b]` at `dst[len..]` in whole blocks of lanes: up to `LANES - 1` values past
/// `b` are read (the grid's positions and the sorted copies are padded for it) and written past
/// the run (the next run or the padding overwrites them). The slices are cut once, so the block
/// loop carries no bounds checks.
#[inline(always)]
fn append(dst: &mut [f32], len: usize, src: &[f32], a: usize, b: usize) {
    let blocks = (b - a).div_ceil(LANES) * LANES;
    let (from, _) = src[a..a + blocks].as_chunks::<LANES>();
    let (to, _) = dst[len..len + blocks].as_chunks_mut::<LANES>();
    for (t, f) in to.iter_mut().zip(from) {
        *t = *f;
    }
}

/// [`append`] of the positions (plus `shift`) and velocities of `s[a..b]` into the buffer at
/// `len`, the four in one loop over blocks.
#[inline(always)]
fn append_motion(
    buf: &mut CellBuf,
    len: usize,
    ((sx, sy), s): ((&[f32], &[f32]), &SortedCopies),
    a: usize,
    b: usize,
    (shift_x, shift_y): (f32, f32),
) {
    fn src(v: &[f32], a: usize, blocks: usize) -> &[[f32; LANES]] {
        v[a..a + blocks].as_chunks::<LANES>().0
    }
    fn dst(v: &mut [f32], len: usize, blocks: usize) -> &mut [[f32; LANES]] {
        v[len..len + blocks].as_chunks_mut::<LANES>().0
    }
    let blocks = (b - a).div_ceil(LANES) * LANES;
    let (x, y) = (src(sx, a, blocks), src(sy, a, blocks));
    let (vx, vy) = (src(&s.vx, a, blocks), src(&s.vy, a, blocks));
    let n = x.len();
    let (x, y, vx, vy) = (&x[..n], &y[..n], &vx[..n], &vy[..n]);
    let (tx, ty, tvx, tvy) = (
        dst(&mut buf.x, len, blocks),
        dst(&mut buf.y, len, blocks),
        dst(&mut buf.vx, len, blocks),
        dst(&mut buf.vy, len, blocks),
    );
    let (tx, ty, tvx, tvy) = (&mut tx[..n], &mut ty[..n], &mut tvx[..n], &mut tvy[..n]);
    for k in 0..n {
        tx[k] = x[k].map(|v| v + shift_x);
        ty[k] = y[k].map(|v| v + shift_y);
        tvx[k] = vx[k];
        tvy[k] = vy[k];
    }
}

/// Cell coordinate `c` of an axis of `n` cells: its index and the shift that brings its points
/// next to the centre cell (`None` outside a world that does not wrap).
#[inline]
fn axis(c: i64, n: i64, side: Option<f32>) -> Option<(i64, f32)> {
    match side {
        Some(side) if c < 0 => Some((c + n, -side)),
        Some(side) if c >= n => Some((c - n, side)),
        _ if (0..n).contains(&c) => Some((c, 0.0)),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use glam::Vec2;
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::*;

    /// A cell away from the grid's edges gathers what the general path gathers for it, bit for
    /// bit, over the padded length: torus, walled and open worlds, tiny and large grids, empty
    /// and crowded cells, each combination of the optional columns, and points at `-0.0` (which
    /// both paths turn into `+0.0`). Every cell is gathered both ways into buffers that are
    /// reused, as a task reuses its own.
    #[test]
    fn the_interior_gather_equals_the_general_one() {
        use crate::spatial::NeighbourIndex;
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut interior = 0;
        for case in 0..120 {
            let n = [0usize, 1, 3, 10, 50, 300, 2000, 20_000][case % 8];
            let (w, h) = (
                rng.random_range(0.5f32..60.0),
                rng.random_range(0.5f32..60.0),
            );
            let r = rng.random_range(0.2f32..8.0);
            let bounds = match case % 3 {
                0 => Bounds::Torus {
                    size: Vec2::new(w, h),
                },
                1 => Bounds::Bounded {
                    size: Vec2::new(w, h),
                },
                _ => Bounds::Open,
            };
            let mut at = |side: f32, k: usize| {
                if k % 97 == 5 {
                    -0.0
                } else {
                    rng.random_range(0.0..side)
                }
            };
            let xs: Vec<f32> = (0..n).map(|k| at(w, k)).collect();
            let ys: Vec<f32> = (0..n).map(|k| at(h, k + 11)).collect();
            let mut grid = GridIndex::default();
            grid.rebuild(&xs, &ys, bounds, r);
            let (nx, ny) = (grid.cells_x() as usize, grid.cells_y() as usize);
            if bounds.is_torus() && (nx < 3 || ny < 3) {
                // The batch does not serve such a torus (a cell would be its own neighbour).
                continue;
            }
            let mut column = |lo: f32, hi: f32| {
                let mut v: Vec<f32> = (0..n).map(|_| rng.random_range(lo..hi)).collect();
                v.extend([0.0; LANES]);
                v
            };
            let mut s = SortedCopies::default();
            s.vx = column(-2.0, 2.0);
            s.vy = column(-2.0, 2.0);
            s.g = column(0.0, 4.0).iter().map(|g| g.floor()).collect();
            s.hx = column(-1.0, 1.0);
            s.hy = column(-1.0, 1.0);
            let (mut a, mut b) = (CellBuf::default(), CellBuf::default());
            for (groups, headings) in [(false, false), (true, false), (false, true), (true, true)] {
                let gathers = Gather {
                    grid: &grid,
                    s: &s,
                    bounds,
                    groups,
                    headings,
                };
                for cell in 0..nx * ny {
                    gathers.cell(cell, &mut a);
                    gathers.edge_cell(cell, &mut b);
                    let m = b.len;
                    assert_eq!(a.len, m, "case {case}, cell {cell} of {nx} x {ny}");
                    let bits = |v: &[f32]| v[..m].iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    let mut columns =
                        vec![(&a.x, &b.x), (&a.y, &b.y), (&a.vx, &b.vx), (&a.vy, &b.vy)];
                    if groups {
                        columns.push((&a.g, &b.g));
                    }
                    if headings {
                        columns.extend([(&a.hx, &b.hx), (&a.hy, &b.hy)]);
                    }
                    for (k, (got, want)) in columns.into_iter().enumerate() {
                        assert_eq!(
                            bits(got),
                            bits(want),
                            "case {case}, cell {cell}, column {k}"
                        );
                    }
                    let (cx, cy) = (cell % nx, cell / nx);
                    interior += usize::from(cx > 0 && cx + 1 < nx && cy > 0 && cy + 1 < ny);
                }
            }
        }
        // The fast path ran (on many cells), not only the general one.
        assert!(interior > 10_000, "{interior} interior cells");
    }
}
