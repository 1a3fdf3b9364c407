//! Dijkstra integration fields: the cost of the cheapest path from every cell to its nearest goal.
//!
//! Steps cost their length (1 orthogonal, `sqrt(2)` diagonal, never cutting a wall's corner)
//! times the optional cost of the cell entered, so paths follow straight lines and open ground
//! more smoothly than the BFS field's step counts. Costs are at least 1, so every step strictly
//! raises the cost and each reachable non-goal cell has a strictly cheaper neighbour.
//!
//! Invariants: goals cost 0; walls and unreachable cells hold [`IntegrationField::UNREACHABLE`]
//! (`+inf`); the build is sequential and deterministic (heap ties are broken by cell index).

use std::cmp::Reverse;
use std::collections::BinaryHeap;

use super::lattice::{DIAGONAL_SIDES, Lattice, Neighbourhood, check_goals, padded_map};
use super::occupancy::OccupancyGrid;
use crate::error::{Error, Result, in_range};

/// Cheapest path cost from every cell to the nearest goal.
#[derive(Clone, Debug, PartialEq)]
pub struct IntegrationField {
    pub(crate) lattice: Lattice,
    pub(crate) neighbourhood: Neighbourhood,
    /// Padded costs; `+inf` on walls, the border and unreachable cells.
    pub(crate) cost: Vec<f32>,
    /// Padded: 1 for free cells, 0 for walls and the border.
    pub(crate) open: Vec<u32>,
    reachable: usize,
}

impl IntegrationField {
    /// Cost of walls and of cells no goal can reach.
    pub const UNREACHABLE: f32 = f32::INFINITY;

    /// Builds the field of `goals` on `grid`. `costs`, when given, holds one multiplier per cell
    /// (row by row, at least 1, walls' entries ignored) applied to steps *into* that cell.
    ///
    /// # Examples
    /// ```
    /// # fn main() -> throng::Result<()> {
    /// use throng::field::{IntegrationField, Neighbourhood, OccupancyGrid};
    /// let grid = OccupancyGrid::new(3, 3)?;
    /// let field = IntegrationField::dijkstra(&grid, &[(0, 0)], Neighbourhood::Eight, None)?;
    /// assert_eq!(field.cost(2, 2), Some(2.0 * std::f32::consts::SQRT_2));
    /// # Ok(()) }
    /// ```
    ///
    /// # Errors
    /// [`Error::Invalid`] for bad goals (as [`PotentialField::bfs`](super::PotentialField::bfs))
    /// or a cost slice of the wrong length; [`Error::NonFinite`] or [`Error::OutOfRange`] for a
    /// cost that is not a finite number of at least 1.
    pub fn dijkstra(
        grid: &OccupancyGrid,
        goals: &[(u32, u32)],
        neighbourhood: Neighbourhood,
        costs: Option<&[f32]>,
    ) -> Result<Self> {
        check_goals(grid, goals)?;
        let lattice = Lattice::of(grid);
        let mut multiplier = vec![1.0_f32; lattice.len];
        if let Some(costs) = costs {
            if costs.len() != grid.len() {
                return Err(Error::Invalid {
                    name: "costs".into(),
                    reason: format!("{} costs given for {} cells", costs.len(), grid.len()),
                });
            }
            for (y, row) in costs.chunks_exact(lattice.width as usize).enumerate() {
                for (m, &c) in multiplier[lattice.row_range(y as u32)].iter_mut().zip(row) {
                    *m = in_range("cell cost", c, 1.0, f32::MAX, "[1, inf)")?;
                }
            }
        }
        let open = padded_map(grid, &lattice, 1, 0);
        let mut cost = vec![Self::UNREACHABLE; lattice.len];
        let mut done = vec![false; lattice.len];
        let mut heap = BinaryHeap::with_capacity(goals.len() * 4);
        for &(x, y) in goals {
            let p = lattice.index(x, y);
            cost[p] = 0.0;
            heap.push(Reverse((0u32, p as u32)));
        }
        let n = neighbourhood.count();
        let mut reachable = 0;
        while let Some(Reverse((key, p))) = heap.pop() {
            let p = p as usize;
            // Non-negative f32s order like their bit patterns.
            if done[p] || key != cost[p].to_bits() {
                continue;
            }
            done[p] = true;
            reachable += 1;
            let c = cost[p];
            for k in 0..n {
                let q = lattice.step(p, k);
                if open[q] == 0 || done[q] {
                    continue;
                }
                let length = if k >= 4 {
                    let (a, b) = DIAGONAL_SIDES[k - 4];
                    if open[lattice.step(p, a)] == 0 || open[lattice.step(p, b)] == 0 {
                        continue;
                    }
                    std::f32::consts::SQRT_2
                } else {
                    1.0
                };
                let candidate = c + length * multiplier[q];
                if candidate < cost[q] {
                    cost[q] = candidate;
                    heap.push(Reverse((candidate.to_bits(), q as u32)));
                }
            }
        }
        Ok(IntegrationField {
            lattice,
            neighbourhood,
            cost,
            open,
            reachable,
        })
    }

    /// Number of columns.
    #[must_use]
    pub fn width(&self) -> u32 {
        self.lattice.width
    }

    /// Number of rows.
    #[must_use]
    pub fn height(&self) -> u32 {
        self.lattice.height
    }

    /// The neighbourhood the field was built with.
    #[must_use]
    pub fn neighbourhood(&self) -> Neighbourhood {
        self.neighbourhood
    }

    /// Number of cells some goal reaches (goals included).
    #[must_use]
    pub fn reachable_count(&self) -> usize {
        self.reachable
    }

    /// Path cost from `(x, y)` to the nearest goal: `None` outside the grid, on walls and where
    /// no goal reaches.
    #[must_use]
    pub fn cost(&self, x: u32, y: u32) -> Option<f32> {
        let c = self.cost[self.lattice.checked_index(x, y)?];
        c.is_finite().then_some(c)
    }

    /// Row `y`'s costs, [`IntegrationField::UNREACHABLE`] where no goal reaches.
    ///
    /// # Panics
    /// When `y >= height`.
    #[must_use]
    pub fn row(&self, y: u32) -> &[f32] {
        assert!(
            y < self.lattice.height,
            "row {y} outside a grid of height {}",
            self.lattice.height
        );
        &self.cost[self.lattice.row_range(y)]
    }

    /// The allowed neighbour of padded cell `p` with the lowest cost below `p`'s (first in
    /// neighbour order on ties).
    #[inline]
    pub(crate) fn best_from(&self, p: usize) -> Option<usize> {
        let mut best = self.cost[p];
        if !best.is_finite() {
            return None;
        }
        let mut out = None;
        for k in 0..self.neighbourhood.count() {
            let q = self.lattice.step(p, k);
            let c = self.cost[q];
            if c >= best {
                continue;
            }
            if k >= 4 {
                let (a, b) = DIAGONAL_SIDES[k - 4];
                if self.open[self.lattice.step(p, a)] == 0
                    || self.open[self.lattice.step(p, b)] == 0
                {
                    continue;
                }
            }
            best = c;
            out = Some(q);
        }
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn costs_are_validated() {
        let g = OccupancyGrid::new(2, 2).unwrap();
        let r = IntegrationField::dijkstra(
            &g,
            &[(0, 0)],
            Neighbourhood::Four,
            Some(&[1.0, 0.5, 1.0, 1.0]),
        );
        assert!(matches!(r, Err(Error::OutOfRange { .. })));
        let r = IntegrationField::dijkstra(
            &g,
            &[(0, 0)],
            Neighbourhood::Four,
            Some(&[1.0, f32::NAN, 1.0, 1.0]),
        );
        assert!(matches!(r, Err(Error::NonFinite { .. })));
        let r = IntegrationField::dijkstra(&g, &[(0, 0)], Neighbourhood::Four, Some(&[1.0]));
        assert!(matches!(r, Err(Error::Invalid { .. })));
    }

    #[test]
    fn per_cell_costs_route_around_mud() {
        let g = OccupancyGrid::new(3, 2).unwrap();
        // Goal at (0, 0); (1, 0) is mud costing 10: the way from (2, 0) goes through row 1.
        let costs = [1.0, 10.0, 1.0, 1.0, 1.0, 1.0];
        let f =
            IntegrationField::dijkstra(&g, &[(0, 0)], Neighbourhood::Four, Some(&costs)).unwrap();
        assert_eq!(f.cost(1, 0), Some(10.0));
        assert_eq!(f.cost(2, 0), Some(4.0));
    }
}
