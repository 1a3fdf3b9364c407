//! A static uniform grid over obstacles, so that an agent only looks at the obstacles near it,
//! and a finer grid of clearances, so that an agent in open space does not look at all.
//!
//! Invariants: a query returns every obstacle within its radius (possibly more, never fewer);
//! a clearance is a lower bound on the distance from any point of its cell (or, for the edge
//! cells, of the region that clamps to it) to the nearest obstacle.

use std::sync::OnceLock;

use glam::Vec2;

use super::{Circle, Wall};

/// Cell lists of circle and wall ids over the obstacles' bounding box. Queries outside the box
/// clamp to its edge cells, which is exact because every obstacle lies inside the box.
#[derive(Clone, Debug, Default)]
pub struct ObstacleGrid {
    origin: Vec2,
    cell: f32,
    /// `1 / cell`: cells are found by a product rather than a division.
    inv: f32,
    cols: usize,
    rows: usize,
    /// `starts[c]..starts[c + 1]` indexes `items` for cell `c`.
    starts: Vec<u32>,
    /// Ids, circles as `id`, walls as `id | WALL`.
    items: Vec<u32>,
    /// Built on the first query after a rebuild (obstacles are often added one at a time).
    clearance: OnceLock<Clearance>,
    /// What the clearance is built from.
    shapes: Shapes,
    /// The size of the obstacles' bounding box.
    extent: Vec2,
}

/// The obstacles' outlines as the clearance rasterises them.
#[derive(Clone, Debug, Default)]
struct Shapes {
    /// Bounding boxes of the circles, `(lo, hi)`.
    boxes: Vec<(Vec2, Vec2)>,
    /// The walls' end points.
    segments: Vec<(Vec2, Vec2)>,
}

const WALL: u32 = 1 << 31;

impl ObstacleGrid {
    /// Rebuilds the grid for these obstacles.
    pub fn rebuild(&mut self, circles: &[Circle], walls: &[Wall]) {
        let mut lo = Vec2::splat(f32::INFINITY);
        let mut hi = Vec2::splat(f32::NEG_INFINITY);
        let mut size_sum = 0.0_f32;
        for c in circles {
            lo = lo.min(c.center - c.radius);
            hi = hi.max(c.center + c.radius);
            size_sum += 2.0 * c.radius;
        }
        for w in walls {
            lo = lo.min(w.a.min(w.b));
            hi = hi.max(w.a.max(w.b));
            size_sum += (w.b - w.a).length().min(10.0);
        }
        let count = circles.len() + walls.len();
        if count == 0 {
            *self = Self::default();
            return;
        }
        let extent = (hi - lo).max(Vec2::splat(1e-3));
        // Cells about twice the mean obstacle size, at most ~4 cells per obstacle overall.
        let mean = (size_sum / count as f32).max(1e-3);
        let min_cell = (extent.x * extent.y / (4.0 * count as f32).max(1.0)).sqrt();
        let cell = (2.0 * mean).max(min_cell).max(1e-3);
        self.origin = lo;
        self.extent = extent;
        self.cell = cell;
        self.inv = 1.0 / cell;
        self.cols = ((extent.x / cell).ceil() as usize).clamp(1, 4096);
        self.rows = ((extent.y / cell).ceil() as usize).clamp(1, 4096);
        let n = self.cols * self.rows;
        let mut lists: Vec<Vec<u32>> = vec![Vec::new(); n];
        for (i, c) in circles.iter().enumerate() {
            self.for_cells(c.center - c.radius, c.center + c.radius, |k| {
                lists[k].push(i as u32)
            });
        }
        for (i, w) in walls.iter().enumerate() {
            // Cells of the segment's bounding box that the segment's swept box can touch.
            self.for_cells(w.a.min(w.b), w.a.max(w.b), |k| {
                lists[k].push(i as u32 | WALL)
            });
        }
        self.starts.clear();
        self.items.clear();
        self.starts.push(0);
        for l in &lists {
            self.items.extend_from_slice(l);
            self.starts.push(self.items.len() as u32);
        }
        self.shapes.boxes.clear();
        self.shapes.boxes.extend(
            circles
                .iter()
                .map(|c| (c.center - c.radius, c.center + c.radius)),
        );
        self.shapes.segments.clear();
        self.shapes
            .segments
            .extend(walls.iter().map(|w| (w.a, w.b)));
        self.clearance = OnceLock::new();
    }

    /// Whether no obstacle lies within `r` of `p`, by the clearance grid alone (`false` when it
    /// cannot tell).
    #[inline]
    #[must_use]
    pub fn clear(&self, p: Vec2, r: f32) -> bool {
        !self.items.is_empty()
            && self
                .clearance
                .get_or_init(|| Clearance::build(self.origin, self.extent, &self.shapes))
                .at(p)
                > r
    }

    #[inline]
    fn cell_of(&self, p: Vec2) -> (usize, usize) {
        clamped_cell(p, self.origin, self.inv, self.cols, self.rows)
    }

    fn for_cells(&self, lo: Vec2, hi: Vec2, mut f: impl FnMut(usize)) {
        let (c0, r0) = self.cell_of(lo);
        let (c1, r1) = self.cell_of(hi);
        for r in r0..r1 + 1 {
            for c in c0..c1 + 1 {
                f(r * self.cols + c);
            }
        }
    }

    /// The ids of the circles and walls that may lie within `r` of `p`, each once, ascending
    /// (the buffers are cleared first).
    pub fn near(&self, p: Vec2, r: f32, circles: &mut Vec<u32>, walls: &mut Vec<u32>) {
        circles.clear();
        walls.clear();
        // Nothing lies within a negative (or NaN) radius.
        if self.items.is_empty() || r.is_nan() || r < 0.0 || self.clear(p, r) {
            return;
        }
        let (lo, hi) = (self.cell_of(p - r), self.cell_of(p + r));
        self.visit_cells(lo, hi, |c| circles.push(c), |w| walls.push(w));
        // A cell lists each obstacle once, circles and walls each ascending (`rebuild` adds
        // them in id order), so only a query over several cells needs sorting.
        if lo != hi {
            for v in [circles, walls] {
                v.sort_unstable();
                v.dedup();
            }
        }
    }

    /// Calls `circle(id)` / `wall(id)` for every obstacle that may lie within `r` of `p` (an id
    /// may come more than once).
    pub fn visit(&self, p: Vec2, r: f32, circle: impl FnMut(u32), wall: impl FnMut(u32)) {
        if self.items.is_empty() || self.clear(p, r) {
            return;
        }
        self.visit_cells(self.cell_of(p - r), self.cell_of(p + r), circle, wall);
    }

    /// Calls `circle(id)` / `wall(id)` for every obstacle the cells `lo..=hi` (column, row)
    /// list, row by row (a row's cells hold one run of `items`); nothing for an empty range.
    fn visit_cells(
        &self,
        lo: (usize, usize),
        hi: (usize, usize),
        mut circle: impl FnMut(u32),
        mut wall: impl FnMut(u32),
    ) {
        if lo.0 > hi.0 {
            return;
        }
        for row in lo.1..=hi.1 {
            let first = row * self.cols;
            let run = self.starts[first + lo.0] as usize..self.starts[first + hi.0 + 1] as usize;
            for &id in &self.items[run] {
                if id & WALL == 0 {
                    circle(id);
                } else {
                    wall(id & !WALL);
                }
            }
        }
    }
}

/// Lower bounds on the distance to the nearest obstacle, per cell of a grid finer than the
/// broad phase's over the same box: the Chebyshev distance `k` in cells from a cell to the
/// nearest cell an obstacle touches bounds the distance from below by `(k - 1)` cells.
#[derive(Clone, Debug, Default)]
struct Clearance {
    origin: Vec2,
    cell: f32,
    /// `1 / cell`.
    inv: f32,
    cols: usize,
    rows: usize,
    /// Chebyshev distances in cells, saturating.
    steps: Vec<u16>,
}

impl Clearance {
    /// About this many cells (at least), and this many per obstacle.
    const MIN_CELLS: f32 = 65_536.0;
    const CELLS_PER_OBSTACLE: f32 = 256.0;
    const MAX_CELLS: f32 = 1_048_576.0;
    /// At most this many cells along each side.
    const MAX_SIDE: f32 = 4_096.0;

    fn build(origin: Vec2, extent: Vec2, shapes: &Shapes) -> Self {
        let count = (shapes.boxes.len() + shapes.segments.len()) as f32;
        let budget = (count * Self::CELLS_PER_OBSTACLE).clamp(Self::MIN_CELLS, Self::MAX_CELLS);
        // Far from the origin a cell must stay wide against the coordinates' spacing (2^-23 of
        // their size), so that the hundredth of a cell the marks and the bound keep in hand
        // covers the rounding of cell indices and row edges there.
        let far = origin.abs().max((origin + extent).abs()).max_element();
        let cell = (extent.x * extent.y / budget)
            .sqrt()
            .max(extent.x / Self::MAX_SIDE)
            .max(extent.y / Self::MAX_SIDE)
            .max(far * 512.0 * f32::EPSILON)
            .max(1e-6);
        // `cols * cell` covers the extent, so no cell but the edges' is stretched by clamping.
        let cols = ((extent.x / cell).ceil() as usize + 1).max(1);
        let rows = ((extent.y / cell).ceil() as usize + 1).max(1);
        let mut c = Self {
            origin,
            cell,
            inv: 1.0 / cell,
            cols,
            rows,
            steps: vec![u16::MAX; cols * rows],
        };
        // Touched cells, widened by a hundredth of a cell against rounding.
        let pad = Vec2::splat(0.01 * cell);
        for &(lo, hi) in &shapes.boxes {
            c.mark(lo - pad, hi + pad);
        }
        for &(a, b) in &shapes.segments {
            c.mark_segment(a, b, pad.x);
        }
        c.chebyshev();
        c
    }

    #[inline]
    fn cell_of(&self, p: Vec2) -> (usize, usize) {
        clamped_cell(p, self.origin, self.inv, self.cols, self.rows)
    }

    /// Marks every cell of the box `lo..hi` as touched.
    fn mark(&mut self, lo: Vec2, hi: Vec2) {
        let (c0, r0) = self.cell_of(lo);
        let (c1, r1) = self.cell_of(hi);
        for r in r0..=r1 {
            self.steps[r * self.cols + c0..=r * self.cols + c1].fill(0);
        }
    }

    /// Marks the cells the segment `a..b` passes through: per row of cells, the box of the part
    /// of the segment inside the row, widened by `pad`.
    fn mark_segment(&mut self, a: Vec2, b: Vec2, pad: f32) {
        let (lo, hi) = (a.min(b), a.max(b));
        let (_, r0) = self.cell_of(lo - pad);
        let (_, r1) = self.cell_of(hi + pad);
        let d = b - a;
        for r in r0..=r1 {
            let y0 = (self.origin.y + r as f32 * self.cell - pad).max(lo.y);
            let y1 = (self.origin.y + (r + 1) as f32 * self.cell + pad).min(hi.y);
            let (x0, x1) = if d.y.abs() <= 1e-6 * d.x.abs() || y0 > y1 {
                (lo.x, hi.x)
            } else {
                let at = |y: f32| a.x + (y - a.y) * (d.x / d.y);
                let (u, v) = (at(y0), at(y1));
                (u.min(v).max(lo.x), u.max(v).min(hi.x))
            };
            let (c0, _) = self.cell_of(Vec2::new(x0 - pad, 0.0));
            let (c1, _) = self.cell_of(Vec2::new(x1 + pad, 0.0));
            self.steps[r * self.cols + c0..=r * self.cols + c1].fill(0);
        }
    }

    /// Turns the marks into Chebyshev distances: a forward and a backward pass over the
    /// 8-neighbourhood.
    fn chebyshev(&mut self) {
        let (cols, rows) = (self.cols, self.rows);
        let s = &mut self.steps;
        for r in 0..rows {
            for c in 0..cols {
                let mut best = s[r * cols + c];
                if c > 0 {
                    best = best.min(s[r * cols + c - 1].saturating_add(1));
                }
                if r > 0 {
                    for cc in c.saturating_sub(1)..(c + 2).min(cols) {
                        best = best.min(s[(r - 1) * cols + cc].saturating_add(1));
                    }
                }
                s[r * cols + c] = best;
            }
        }
        for r in (0..rows).rev() {
            for c in (0..cols).rev() {
                let mut best = s[r * cols + c];
                if c + 1 < cols {
                    best = best.min(s[r * cols + c + 1].saturating_add(1));
                }
                if r + 1 < rows {
                    for cc in c.saturating_sub(1)..(c + 2).min(cols) {
                        best = best.min(s[(r + 1) * cols + cc].saturating_add(1));
                    }
                }
                s[r * cols + c] = best;
            }
        }
    }

    /// A lower bound on the distance from `p` to the nearest obstacle (a hundredth of a cell
    /// less, against rounding; negative next to an obstacle).
    #[inline]
    fn at(&self, p: Vec2) -> f32 {
        let (c, r) = self.cell_of(p);
        (f32::from(self.steps[r * self.cols + c]) - 1.01) * self.cell
    }
}

/// The cell of `p` in a grid of `cols` x `rows` square cells of side `1 / inv` from `origin`,
/// clamped to the grid (a point outside it, or NaN, belongs to the nearest edge cell).
#[inline]
fn clamped_cell(p: Vec2, origin: Vec2, inv: f32, cols: usize, rows: usize) -> (usize, usize) {
    let f = (p - origin) * inv;
    let cx = if f.x > 0.0 {
        (f.x as usize).min(cols - 1)
    } else {
        0
    };
    let cy = if f.y > 0.0 {
        (f.y as usize).min(rows - 1)
    } else {
        0
    };
    (cx, cy)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::AgentRng;

    /// The distance from `p` to the segment `a..b`, in f64.
    fn segment_distance(p: Vec2, a: Vec2, b: Vec2) -> f64 {
        let (p, a, b) = (p.as_dvec2(), a.as_dvec2(), b.as_dvec2());
        let ab = b - a;
        let t = if ab.length_squared() > 0.0 {
            ((p - a).dot(ab) / ab.length_squared()).clamp(0.0, 1.0)
        } else {
            0.0
        };
        p.distance(a + ab * t)
    }

    #[test]
    fn clearance_stays_a_lower_bound_far_from_the_origin() {
        // A few short, shallow walls, some far out: there the clearance cells would be finer
        // than the coordinates' spacing (cells of 5 mm at 1e5, where floats are 8 mm apart).
        let mut rng = AgentRng::new(5, 0, 0, 0);
        let mut misses = std::collections::BTreeMap::new();
        for case in 0..200 {
            let offset = Vec2::splat([3e4, 1e5, 5e3, 0.0][case % 4]);
            let size = [2.0_f32, 8.0, 20.0][case % 3];
            let walls: Vec<Wall> = (0..3)
                .map(|_| {
                    let a = offset + Vec2::new(size * rng.unit(), size * rng.unit());
                    let b = a + Vec2::new(size * (0.5 + rng.unit()), 0.05 * size * rng.signed());
                    Wall { a, b }
                })
                .collect();
            let mut grid = ObstacleGrid::default();
            grid.rebuild(&[], &walls);
            for _ in 0..20_000 {
                let w = walls[(rng.unit() * 3.0) as usize % 3];
                let q = w.a.lerp(w.b, rng.unit()) + Vec2::new(0.0, 0.05 * rng.signed());
                let truth = walls
                    .iter()
                    .map(|w| segment_distance(q, w.a, w.b))
                    .fold(f64::INFINITY, f64::min);
                if truth < 0.05 && grid.clear(q, 0.05) {
                    *misses.entry(case).or_insert(0) += 1;
                }
            }
        }
        assert!(
            misses.is_empty(),
            "clear within 0.05 m of a wall, per case: {misses:?}"
        );
    }

    #[test]
    fn a_negative_or_nan_radius_finds_nothing() {
        // Many short walls along a thin line: clearance cells wider than the grid's.
        let walls: Vec<Wall> = (0..2000)
            .map(|k| {
                let x = 5.0 * k as f32;
                Wall {
                    a: Vec2::new(x, 0.0),
                    b: Vec2::new(x + 0.01, 0.0),
                }
            })
            .collect();
        let mut grid = ObstacleGrid::default();
        grid.rebuild(&[], &walls);
        let (mut c, mut w) = (vec![7], vec![7]);
        for r in [-2.0, -1e-3, f32::NAN] {
            grid.near(Vec2::new(50.0, 0.0), r, &mut c, &mut w);
            assert!(c.is_empty() && w.is_empty());
        }
        grid.near(Vec2::new(50.0, 0.0), 0.5, &mut c, &mut w);
        assert_eq!(w, [10]);
    }

    #[test]
    fn near_lists_each_candidate_once_ascending_in_one_cell_or_many() {
        let mut rng = AgentRng::new(3, 0, 0, 0);
        let mut p = || Vec2::new(50.0 * rng.unit(), 20.0 * rng.unit());
        let circles: Vec<Circle> = (0..30).map(|_| Circle::new(p(), 0.5)).collect();
        let walls: Vec<Wall> = (0..40).map(|_| Wall { a: p(), b: p() }).collect();
        let mut grid = ObstacleGrid::default();
        grid.rebuild(&circles, &walls);
        let (mut c, mut w) = (Vec::new(), Vec::new());
        for k in 0..400 {
            let q = p() * 1.2 - Vec2::splat(2.0);
            let r = [0.0, 0.5, 2.0, 30.0][k % 4];
            grid.near(q, r, &mut c, &mut w);
            let (mut want_c, mut want_w) = (Vec::new(), Vec::new());
            grid.visit(q, r, |i| want_c.push(i), |i| want_w.push(i));
            for v in [&mut want_c, &mut want_w] {
                v.sort_unstable();
                v.dedup();
            }
            assert_eq!((&c, &w), (&want_c, &want_w), "at {q} within {r}");
        }
    }

    /// The clearance never claims open space where an obstacle lies within the radius (walls at
    /// every slope, long thin worlds, points outside the box), and does find open space.
    #[test]
    fn clearance_is_a_lower_bound_and_finds_open_space() {
        let mut rng = AgentRng::new(5, 0, 0, 0);
        for (case, size) in [Vec2::new(60.0, 40.0), Vec2::new(1000.0, 10.0)]
            .into_iter()
            .enumerate()
        {
            let mut p = || Vec2::new(size.x * rng.unit(), size.y * rng.unit());
            let circles: Vec<Circle> = (0..6).map(|_| Circle::new(p(), 0.7)).collect();
            let mut walls: Vec<Wall> = (0..10)
                .map(|k| {
                    let a = p();
                    let b = match k % 3 {
                        0 => Vec2::new(a.x + 5.0, a.y),
                        1 => Vec2::new(a.x, a.y - 3.0),
                        _ => p(),
                    };
                    Wall { a, b }
                })
                .collect();
            walls.push(Wall {
                a: Vec2::ZERO,
                b: Vec2::new(size.x, 0.0),
            });
            let mut grid = ObstacleGrid::default();
            grid.rebuild(&circles, &walls);
            let (mut open, mut queries) = (0, 0);
            for k in 0..20_000 {
                let q = p() * 1.1 - size * 0.05;
                let r = [0.0, 0.01, 0.5, 2.0][k % 4];
                let nearest = walls
                    .iter()
                    .map(|w| w.closest_point(q).distance(q))
                    .chain(circles.iter().map(|c| c.center.distance(q) - c.radius))
                    .fold(f32::INFINITY, f32::min);
                queries += 1;
                if grid.clear(q, r) {
                    open += 1;
                    assert!(
                        nearest > r,
                        "case {case}: {q} within {r}: nearest at {nearest}"
                    );
                }
            }
            assert!(
                open > queries / 3,
                "case {case}: only {open} of {queries} open"
            );
        }
    }
}
