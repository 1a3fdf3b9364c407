//! The indices a path's projection searches: every segment in blocks of [`LANES`] lanes, and,
//! for a path of many segments, a grid of square cells listing the segments that can be nearest
//! in each, built while the world's [`GridBudget`] lasts.
//!
//! Invariant: a projection through the grid's candidates equals the projection over every
//! segment, bit for bit, ties to the earlier segment included (see [`SegmentGrid`]); the lanes
//! compute the scalar projection's operations.

use glam::{Vec2, Vec4};

/// Lanes per block of segments in [`Path::project`](super::Path::project).
pub(super) const LANES: usize = 8;

/// Every segment's start `a`, its direction `b - a` and that direction's squared length, as
/// the scalar projection computes them, padded to whole blocks of [`LANES`] with segments at
/// infinity (never the nearest).
#[derive(Clone, Debug, Default, PartialEq)]
pub(super) struct SegmentLanes {
    pub(super) blocks: Vec<SegmentBlock>,
}

impl SegmentBlock {
    /// Per lane: the squared distance from `p` to the nearest point of the segment, and that
    /// point's parameter along it, by the scalar projection's operations four lanes at a time
    /// (the clamp as its two comparisons, so a NaN stays a NaN as there).
    #[inline]
    pub(super) fn distances(&self, p: Vec2) -> ([f32; LANES], [f32; LANES]) {
        let (px, py) = (Vec4::splat(p.x), Vec4::splat(p.y));
        let (mut d, mut t) = ([0.0_f32; LANES], [0.0_f32; LANES]);
        for h in 0..LANES / 4 {
            let (ax, ay, abx, aby) = (self.ax[h], self.ay[h], self.abx[h], self.aby[h]);
            let len_sq = self.len_sq[h];
            let q = ((px - ax) * abx + (py - ay) * aby) / len_sq;
            let q = Vec4::select(q.cmplt(Vec4::ZERO), Vec4::ZERO, q);
            let q = Vec4::select(q.cmpgt(Vec4::ONE), Vec4::ONE, q);
            let th = Vec4::select(len_sq.cmpgt(Vec4::ZERO), q, Vec4::ZERO);
            let (dx, dy) = ((ax + abx * th) - px, (ay + aby * th) - py);
            d[4 * h..4 * h + 4].copy_from_slice(&(dx * dx + dy * dy).to_array());
            t[4 * h..4 * h + 4].copy_from_slice(&th.to_array());
        }
        (d, t)
    }
}

/// [`LANES`] segments, field by field.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub(super) struct SegmentBlock {
    pub(super) ax: [Vec4; LANES / 4],
    pub(super) ay: [Vec4; LANES / 4],
    pub(super) abx: [Vec4; LANES / 4],
    pub(super) aby: [Vec4; LANES / 4],
    pub(super) len_sq: [Vec4; LANES / 4],
}

/// The squared distance from `p` to the segment from `a` along `ab` (`len_sq` its squared
/// length) and the nearest point's parameter: [`SegmentBlock::distances`] for one lane, the
/// same operations in the same order.
#[inline]
pub(super) fn segment_distance(a: Vec2, ab: Vec2, len_sq: f32, p: Vec2) -> (f32, f32) {
    let q = ((p.x - a.x) * ab.x + (p.y - a.y) * ab.y) / len_sq;
    let q = if q < 0.0 { 0.0 } else { q };
    let q = if q > 1.0 { 1.0 } else { q };
    let t = if len_sq > 0.0 { q } else { 0.0 };
    let (dx, dy) = ((a.x + ab.x * t) - p.x, (a.y + ab.y * t) - p.y);
    (dx * dx + dy * dy, t)
}

/// Segments to try first in [`Path::project`](super::Path::project): a grid of square cells
/// over the path's bounding box widened by half its larger side, each cell listing (in segment
/// order) every segment that can be the nearest one, or tie with it, for some point of the cell.
///
/// Invariant: for any query point `p` whose cell is found by [`SegmentGrid::candidates`], a
/// segment left out of that cell's list is farther from `p`, as `project` computes distances in
/// `f32`, than some listed one. A segment `s` is listed when `d(c, s) <= min_s' d(c, s') + 2h +
/// margin`, with `c` the centre of the cell widened by a rounding allowance and `h` its half
/// diagonal: a left-out segment is then more than `margin` farther from every point of the cell
/// than the segment nearest the centre (triangle inequality), and `margin` (1e-5 of the largest
/// coordinate in the grid plus the distances, and 1e-21 for distances whose squares are
/// subnormal) is well above the rounding of an `f32` distance. So the projection from the
/// candidates is the one over all segments, bit for bit, ties to the earlier segment included.
#[derive(Clone, Debug, Default, PartialEq)]
pub(super) struct SegmentGrid {
    /// The lower corner of the grid.
    origin: Vec2,
    /// One over a cell's side.
    inv_side: f32,
    /// Cells along x and y (0: no grid, every query searches all segments).
    pub(super) nx: u32,
    ny: u32,
    /// Cell `c` lists `segments[starts[c]..starts[c + 1]]`.
    starts: Vec<u32>,
    segments: Vec<Listed>,
}

/// A segment in a [`SegmentGrid`] cell's list: its number, start, direction and squared
/// length, read in one place.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(super) struct Listed {
    pub(super) a: Vec2,
    pub(super) ab: Vec2,
    pub(super) len_sq: f32,
    pub(super) k: u32,
}

/// What building grids of candidate segments may still cost: cell-segment distances computed
/// and segments listed (24 bytes each). A world's paths share one budget
/// ([`GridBudget::default`]: 2^26 distances, a fraction of a second, and 2^21 entries, 48 MiB),
/// so that a scenario of very many paths cannot make their grids hang the build or exhaust
/// memory: paths beyond it are searched in lanes, with the same results.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GridBudget {
    /// Cell-segment distances left.
    pub distances: u64,
    /// Listed segments left.
    pub entries: u64,
}

impl Default for GridBudget {
    fn default() -> Self {
        GridBudget {
            distances: 1 << 26,
            entries: 1 << 21,
        }
    }
}

/// Paths of at most this many segments search them all (one or two blocks of lanes).
const GRID_MIN_SEGMENTS: usize = 2 * LANES;
/// At most this many cells.
const GRID_MAX_CELLS: usize = 4096;
/// At most this many segments listed per cell on average (beyond that, no grid).
const GRID_MAX_LISTED: usize = 32;
/// At most this many cell-segment distances to build a grid, a few milliseconds (a longer path
/// gets fewer, larger cells, which list more segments each; beyond 65,536 segments, none).
const GRID_BUILD_BUDGET: usize = 1 << 22;

impl SegmentGrid {
    /// The grid of the segments `a + t ab` (`t` in [0, 1]) given as `(a, ab)`, or no grid (a
    /// short path, one too long to index within the build budget or `budget`, or coordinates
    /// whose grid would not be finite in `f32`); what it cost is taken out of `budget`.
    pub(super) fn build(segments: &[(Vec2, Vec2)], budget: &mut GridBudget) -> SegmentGrid {
        let n = segments.len();
        let cells = (GRID_BUILD_BUDGET / n.max(1)).min(GRID_MAX_CELLS);
        if n <= GRID_MIN_SEGMENTS || cells < 64 {
            return SegmentGrid::default();
        }
        let (mut lo, mut hi) = ([f64::INFINITY; 2], [f64::NEG_INFINITY; 2]);
        for &(a, ab) in segments {
            for q in [a, a + ab] {
                for (d, v) in [f64::from(q.x), f64::from(q.y)].into_iter().enumerate() {
                    lo[d] = lo[d].min(v);
                    hi[d] = hi[d].max(v);
                }
            }
        }
        let pad = 0.5 * (hi[0] - lo[0]).max(hi[1] - lo[1]);
        let (w, h) = (hi[0] - lo[0] + 2.0 * pad, hi[1] - lo[1] + 2.0 * pad);
        let side = (w * h / cells as f64).sqrt().max(w.max(h) / 64.0);
        let origin = [lo[0] - pad, lo[1] - pad];
        let (nx, ny) = ((w / side).ceil().max(1.0), (h / side).ceil().max(1.0));
        // The largest coordinate of any point in the grid, of a query or of a segment.
        let scale = [origin[0], origin[1], origin[0] + w, origin[1] + h]
            .into_iter()
            .fold(0.0_f64, |m, v| m.max(v.abs()));
        let origin32 = Vec2::new(origin[0] as f32, origin[1] as f32);
        let inv_side = (1.0 / side) as f32;
        let far = Vec2::new((origin[0] + w) as f32, (origin[1] + h) as f32);
        let finite = origin32.is_finite() && far.is_finite() && scale.is_finite();
        if !(finite && inv_side.is_finite() && inv_side > 0.0) {
            return SegmentGrid::default();
        }
        // The cell a point falls in is computed in f32: widen each cell for that rounding.
        let slack = 1e-3 * side + 1e-6 * scale;
        let half_diagonal = std::f64::consts::SQRT_2 * (0.5 * side + slack);
        let (nx, ny) = (nx as usize, ny as usize);
        let Some(left) = budget.distances.checked_sub((nx * ny * n) as u64) else {
            return SegmentGrid::default();
        };
        budget.distances = left;
        let max_listed = (GRID_MAX_LISTED * nx * ny).min(budget.entries as usize);
        let mut starts = Vec::with_capacity(nx * ny + 1);
        let mut listed = Vec::new();
        let mut dist = vec![0.0_f64; n];
        starts.push(0);
        for cy in 0..ny {
            for cx in 0..nx {
                let c = [
                    origin[0] + (cx as f64 + 0.5) * side,
                    origin[1] + (cy as f64 + 0.5) * side,
                ];
                let mut nearest = f64::INFINITY;
                for (d, &(a, ab)) in dist.iter_mut().zip(segments) {
                    *d = distance_f64(c, a, ab);
                    nearest = nearest.min(*d);
                }
                // An f32 distance from `project` is within a few ulps of the largest coordinate
                // and of itself (about 1e-6 of them), and where its square is subnormal within
                // about 4e-23 (the square root of the least subnormal): the margin is ten times
                // and 25 times those, for both distances compared.
                let margin = 1e-5 * (scale + nearest + 2.0 * half_diagonal) + 1e-21;
                let reach = nearest + 2.0 * half_diagonal + margin;
                listed.extend((0..n).filter(|&k| dist[k] <= reach).map(|k| {
                    let (a, ab) = segments[k];
                    Listed {
                        a,
                        ab,
                        len_sq: ab.length_squared(),
                        k: k as u32,
                    }
                }));
                starts.push(listed.len() as u32);
                if listed.len() > max_listed {
                    // Segments so dense that a cell would list many (no gain over lanes), or
                    // the budget is spent.
                    return SegmentGrid::default();
                }
            }
        }
        budget.entries -= listed.len() as u64;
        SegmentGrid {
            origin: origin32,
            inv_side,
            nx: nx as u32,
            ny: ny as u32,
            starts,
            segments: listed,
        }
    }

    /// The segments that can be nearest to `p`, or `None` outside the grid (or without one).
    #[inline]
    pub(super) fn candidates(&self, p: Vec2) -> Option<&[Listed]> {
        let fx = (p.x - self.origin.x) * self.inv_side;
        let fy = (p.y - self.origin.y) * self.inv_side;
        // Also false for a NaN.
        if !(fx >= 0.0 && fy >= 0.0 && fx < self.nx as f32 && fy < self.ny as f32) {
            return None;
        }
        let cx = (fx as u32).min(self.nx - 1);
        let cy = (fy as u32).min(self.ny - 1);
        let c = (cy * self.nx + cx) as usize;
        Some(&self.segments[self.starts[c] as usize..self.starts[c + 1] as usize])
    }
}

/// The distance from `c` to the segment `a + t ab`, `t` in [0, 1], in `f64` (whose range holds
/// the square of any `f32`).
fn distance_f64(c: [f64; 2], a: Vec2, ab: Vec2) -> f64 {
    let (ax, ay) = (f64::from(a.x), f64::from(a.y));
    let (bx, by) = (f64::from(a.x + ab.x), f64::from(a.y + ab.y));
    let (ux, uy) = (bx - ax, by - ay);
    let len_sq = ux * ux + uy * uy;
    let t = if len_sq > 0.0 {
        (((c[0] - ax) * ux + (c[1] - ay) * uy) / len_sq).clamp(0.0, 1.0)
    } else {
        0.0
    };
    let (dx, dy) = (ax + ux * t - c[0], ay + uy * t - c[1]);
    (dx * dx + dy * dy).sqrt()
}

#[cfg(test)]
mod tests {
    use super::super::tests::{bits, project_scalar};
    use super::super::{Path, Projection};
    use super::*;

    /// The projection over every segment in lanes, without the grid.
    fn project_all(path: &Path, p: Vec2) -> Projection {
        let without = Path {
            grid: SegmentGrid::default(),
            ..path.clone()
        };
        without.project(p)
    }

    #[test]
    fn the_grid_s_candidates_give_the_projection_over_all_segments_bit_for_bit() {
        let mut rng = crate::rng::AgentRng::new(11, 0, 0, 0);
        let (mut listed, mut queries, mut segments) = (0_usize, 0_usize, 0_usize);
        for (n, looped, scale, offset) in [
            (18, false, 50.0, 0.0),
            (24, true, 150.0, 0.0),
            (60, false, 1.0, 0.0),
            (200, true, 1000.0, 0.0),
            (40, false, 1e6, 0.0),
            (33, true, 1e-3, 0.0),
            // Far from the origin, where an f32 ulp is a large part of a segment.
            (50, false, 3.0, 1e7),
            (50, true, 0.5, -3e6),
        ] {
            // A random walk (segments of similar length, some crossing), with repeated points
            // (zero-length segments, and exact ties between segments).
            let mut at = Vec2::splat(offset);
            let mut points: Vec<Vec2> = (0..n)
                .map(|_| {
                    at += Vec2::new(rng.signed(), rng.signed()) * scale;
                    at
                })
                .collect();
            points[n / 2] = points[0];
            points[n / 3] = points[n / 3 - 1];
            let path = Path::new(points, 2.0, looped).unwrap().indexed();
            // (Far from the origin, the margin lists every segment, and no grid pays.)
            assert!(
                path.grid.nx > 0 || offset != 0.0,
                "a path of {n} segments has a grid"
            );
            let (lo, hi) = path
                .points()
                .iter()
                .fold((Vec2::INFINITY, Vec2::NEG_INFINITY), |(lo, hi), &p| {
                    (lo.min(p), hi.max(p))
                });
            let size = hi - lo;
            for q in 0..2000 {
                let u = Vec2::new(rng.unit(), rng.unit());
                let p = match q % 5 {
                    // On and near the path, on cell edges' scale.
                    0 => {
                        path.points()[q % n] + Vec2::new(rng.signed(), rng.signed()) * 1e-3 * scale
                    }
                    1 => path.point_at(rng.unit() * path.length()),
                    // Anywhere in the grid, and beyond it.
                    2 | 3 => lo - size + u * 3.0 * size,
                    _ => lo + u * size,
                };
                let got = path.project(p);
                assert_eq!(
                    bits(got),
                    bits(project_all(&path, p)),
                    "path of {n} points, looped {looped}, query {p}"
                );
                assert_eq!(bits(got), bits(project_scalar(&path, p)));
                if let Some(c) = path.grid.candidates(p)
                    && offset == 0.0
                {
                    listed += c.len();
                    queries += 1;
                    segments += path.segments();
                }
            }
        }
        // The grid is what answers most queries, with a small part of the segments each.
        assert!(queries > 6000, "{queries} queries in the grid");
        let mean = listed as f64 / queries as f64;
        assert!(
            mean < 0.25 * segments as f64 / queries as f64,
            "{mean} candidates per query"
        );
    }

    #[test]
    fn a_path_of_tiny_coordinates_projects_as_the_search_over_every_segment() {
        // Distances whose squares are subnormal or underflow to zero: the f32 distances are then
        // off by an absolute amount, not a relative one.
        for scale in [1e-23_f32, 1e-22, 1e-21, 1e-19] {
            let points = (0..18).map(|k| Vec2::new((k % 5) as f32, (k / 5) as f32) * scale);
            let path = Path::new(points.collect(), 1.0, false).unwrap().indexed();
            let mut rng = crate::rng::AgentRng::new(9, 0, 0, 0);
            let mut queries: Vec<Vec2> = (0..3000)
                .map(|_| Vec2::new(rng.unit() * 6.0 - 0.5, rng.unit() * 5.0 - 0.5) * scale)
                .collect();
            queries.push(Vec2::new(
                f32::from_bits(0x1a04_fb5a),
                f32::from_bits(0x199d_290e),
            ));
            for p in queries {
                assert_eq!(
                    bits(path.project(p)),
                    bits(project_all(&path, p)),
                    "scale {scale}, query {p}"
                );
            }
        }
    }

    #[test]
    fn grids_are_built_while_the_budget_lasts() {
        let path = |k: usize| {
            let points = (0..30).map(|j| Vec2::new(j as f32, ((j + k) % 3) as f32) * 10.0);
            Path::new(points.collect(), 1.0, false).unwrap()
        };
        assert!(!path(0).is_indexed(), "Path::new builds no grid");
        assert!(path(0).indexed().is_indexed());
        // Room for two grids' distances: the third path gets none, and projects the same.
        let mut first = path(0);
        first.index(&mut GridBudget::default());
        let per_grid = GridBudget::default().distances - {
            let mut b = GridBudget::default();
            path(0).index(&mut b);
            b.distances
        };
        let mut budget = GridBudget {
            distances: 2 * per_grid + per_grid / 2,
            entries: u64::MAX,
        };
        let paths: Vec<Path> = (0..3)
            .map(|k| {
                let mut p = path(k);
                p.index(&mut budget);
                p
            })
            .collect();
        assert_eq!(
            paths.iter().map(Path::is_indexed).collect::<Vec<_>>(),
            [true, true, false]
        );
        // Room for the entries of one grid and a half: the second stops, the third is not tried.
        let entries = first.grid.segments.len() as u64;
        let mut budget = GridBudget {
            distances: u64::MAX,
            entries: entries + entries / 2,
        };
        let indexed: Vec<bool> = (0..3)
            .map(|k| {
                let mut p = path(k);
                p.index(&mut budget);
                p.is_indexed()
            })
            .collect();
        assert_eq!(indexed, [true, false, false]);
        let p = Vec2::new(55.0, 7.0);
        for q in &paths {
            assert_eq!(bits(q.project(p)), bits(project_scalar(q, p)));
        }
    }

    #[test]
    fn short_paths_very_long_ones_and_dense_ones_search_every_segment() {
        let line = |n: usize, scale: f32| {
            let points = (0..n).map(|k| Vec2::new(k as f32, (k % 2) as f32) * scale);
            Path::new(points.collect(), 1.0, false).unwrap().indexed()
        };
        assert_eq!(line(17, 1.0).grid.nx, 0, "16 segments: no grid");
        assert!(line(18, 1.0).grid.nx > 0);
        // Too long to index within the build budget.
        let long = line(GRID_BUILD_BUDGET / 63, 1.0);
        assert_eq!(long.grid.nx, 0);
        let p = Vec2::new(1e5, 3.0);
        assert_eq!(bits(long.project(p)), bits(project_scalar(&long, p)));
        // So dense that cells would list many segments each: a scribble in a unit square.
        let mut rng = crate::rng::AgentRng::new(3, 0, 0, 0);
        let points = (0..2000).map(|_| Vec2::new(rng.unit(), rng.unit()));
        let scribble = Path::new(points.collect(), 0.1, true).unwrap().indexed();
        assert_eq!(scribble.grid.nx, 0);
        let p = Vec2::new(0.3, 0.6);
        assert_eq!(
            bits(scribble.project(p)),
            bits(project_scalar(&scribble, p))
        );
    }
}
