//! Candidates shared by the queries of one grid cell.
//!
//! Agents stored in the grid's order come cell by cell, so a run of queries asks about points of
//! one cell. [`CellCandidates`] gathers, once for the run, every indexed point within the query
//! radius of any point of the cell's box; each query then filters that list with the grid's own
//! exact test ([`super::exact`]), so it finds the same neighbours with bit-identical offsets, in
//! ascending index when the list is sorted (as [`NeighbourIndex::neighbours_at`] lists them).
//!
//! Invariant: the list is reused only for the same grid build (its generation), cell and radius.

use glam::Vec2;

use super::{GridIndex, Neighbour, exact};

/// One worker's candidates for the queries of one cell of a grid.
#[derive(Debug, Default)]
pub(crate) struct CellCandidates {
    /// `(grid generation, column, row, radius bits, sorted)` the list was gathered for.
    key: Option<(u64, u32, u32, u32, bool)>,
    /// Per candidate: its index, its position and its offset from `centre`.
    points: Vec<(u32, Vec2, Vec2)>,
    /// The cell box's centre.
    centre: Vec2,
    /// A query's bound on `(offset from the centre - query's offset from the centre)²` beyond
    /// which a candidate is farther than the radius whatever the rounding (infinite where the
    /// bound would not hold: a torus narrower than the block).
    prefilter_sq: f32,
}

impl CellCandidates {
    /// Makes the list that of `p`'s cell of `grid` for queries of radius `r` (sorted by index
    /// when `sorted`), gathering it unless it already is. `false` when the list cannot serve
    /// `p`: `p` lies outside its cell's box (a point the grid clamps into an edge cell) or `r`
    /// is not a positive number; the caller then queries the grid itself.
    pub(crate) fn of_cell(&mut self, grid: &GridIndex, p: Vec2, r: f32, sorted: bool) -> bool {
        let size = grid.cell_size();
        if !(r > 0.0 && r.is_finite() && size.x > 0.0 && size.y > 0.0) {
            return false;
        }
        let (cx, cy) = grid.cell_of(p);
        let lo = grid.origin() + Vec2::new(cx as f32, cy as f32) * size;
        // A margin for the rounding of the cell's corners.
        let slack = size * (1.0 / 64.0);
        let (min, max) = (lo - slack, lo + size + slack);
        if !(p.cmpge(min).all() && p.cmple(max).all()) {
            return false;
        }
        let key = Some((grid.generation(), cx, cy, r.to_bits(), sorted));
        if self.key != key {
            self.points.clear();
            let (order, xs, ys) = (grid.order(), grid.sorted_x(), grid.sorted_y());
            let bounds = grid.bounds();
            let centre = (min + max) * 0.5;
            // Every point within `r` of a point of the box is within `r` plus the half-diagonal
            // of its centre.
            let half_diagonal = 0.5 * (max - min).length();
            let reach = r + half_diagonal;
            grid.for_each_run(centre, reach, |run| {
                for k in run {
                    let q = Vec2::new(xs[k], ys[k]);
                    self.points.push((order[k], q, bounds.offset(centre, q)));
                }
            });
            if sorted {
                self.points.sort_unstable_by_key(|&(j, _, _)| j);
            }
            // The offsets differ from exact ones by a few units in the last place of the
            // coordinates' magnitude; a margin of 1e-5 of it covers them many times over.
            let side = bounds.size().unwrap_or(Vec2::ZERO);
            let magnitude = centre.abs().max_element().max(side.max_element()) + reach;
            let bound = r + 1e-5 * magnitude;
            let narrow = bounds.is_torus() && 2.0 * (reach + bound) >= side.min_element();
            self.prefilter_sq = if narrow { f32::INFINITY } else { bound * bound };
            self.centre = centre;
            self.key = key;
        }
        true
    }

    /// Calls `visit` for every candidate within `r` of `p` under `grid`'s world, other than
    /// point `skip`, in the list's order: the grid's exact test, so the records equal its
    /// queries'. `grid`, `p` and `r` are those [`CellCandidates::of_cell`] last served.
    #[inline]
    pub(crate) fn within(
        &self,
        grid: &GridIndex,
        p: Vec2,
        r: f32,
        skip: usize,
        mut visit: impl FnMut(Neighbour),
    ) {
        let (bounds, r_sq) = (grid.bounds(), r * r);
        let pc = bounds.offset(self.centre, p);
        for &(j, q, o) in &self.points {
            // A cheap test first: most candidates of the block are beyond the radius.
            if (o - pc).length_squared() > self.prefilter_sq {
                continue;
            }
            if let Some(n) = exact(&bounds, p, q, j, r_sq)
                && j as usize != skip
            {
                visit(n);
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::bounds::Bounds;
    use crate::rng::AgentRng;
    use crate::spatial::NeighbourIndex;

    #[test]
    fn a_cells_candidates_give_the_grids_own_neighbours() {
        // Queries in runs through cells (the candidates reused), jumps, points of the index
        // (left out of their own answers) and rebuilds that move every point.
        let mut rng = AgentRng::new(5, 0, 0, 0);
        let (mut want, mut got) = (Vec::new(), Vec::new());
        let mut c = CellCandidates::default();
        for bounds in [
            Bounds::torus(120.0, 80.0).unwrap(),
            // Narrower than a cell's block: every candidate tested exactly.
            Bounds::torus(30.0, 20.0).unwrap(),
            Bounds::bounded(120.0, 80.0).unwrap(),
            Bounds::Open,
        ] {
            let mut grid = GridIndex::default();
            for (n, r) in [(1, 4.0_f32), (50, 10.0), (3_000, 2.0), (3_000, 7.5)] {
                let points: Vec<Vec2> = (0..n)
                    .map(|_| bounds.wrap(Vec2::new(rng.unit() * 120.0, rng.unit() * 80.0)))
                    .collect();
                let xs: Vec<f32> = points.iter().map(|p| p.x).collect();
                let ys: Vec<f32> = points.iter().map(|p| p.y).collect();
                grid.rebuild(&xs, &ys, bounds, r);
                let mut p = Vec2::new(60.0, 40.0);
                let mut served = 0;
                for q in 0..600 {
                    let skip = if q % 4 == 0 { q % n } else { usize::MAX };
                    p = if skip < n {
                        Vec2::new(xs[skip], ys[skip])
                    } else if q % 7 == 0 {
                        bounds.wrap(Vec2::new(rng.unit() * 120.0, rng.unit() * 80.0))
                    } else {
                        bounds.wrap(p + Vec2::new(rng.unit() - 0.5, rng.unit() - 0.5))
                    };
                    for sorted in [true, false] {
                        if !c.of_cell(&grid, p, r, sorted) {
                            continue;
                        }
                        served += 1;
                        got.clear();
                        c.within(&grid, p, r, skip, |nb| got.push(nb));
                        grid.neighbours_at(p, r, &mut want);
                        want.retain(|nb| nb.index as usize != skip);
                        if !sorted {
                            got.sort_unstable_by_key(|nb| nb.index);
                        }
                        assert_eq!(got, want, "{bounds:?}, {n} points, r {r}, at {p}");
                    }
                }
                assert!(
                    served > 300,
                    "{bounds:?}, {n} points: the candidates served {served} queries"
                );
            }
        }
    }
}
