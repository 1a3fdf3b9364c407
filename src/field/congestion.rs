//! Cell costs from the local density of a crowd, for quickest-path flows.
//!
//! A cell's cost is how much longer crossing it takes than walking freely: the inverse of
//! Weidmann's fundamental diagram at the density of agents in a square window around the cell,
//! `v(rho) / v0 = 1 - exp(-1.913 (1 / rho - 1 / 5.4))` (persons per square metre, so the grid's
//! units must be metres), capped at [`MAX_CELL_COST`]. A [`DistanceField`](super::DistanceField)
//! built with these costs is the travel time through the crowd as it stands; its gradient leads
//! round a jam where going round is quicker (Kretz 2009, "Pedestrian traffic: on the quickest
//! path"; JuPedSim's quickest router and Vadere's dynamic floor fields work the same way).
//!
//! Invariants: the costs depend only on how many agents stand in each cell, counted in
//! integers, so they are the same for any order of the agents and any number of threads; every
//! cost lies in `[1, MAX_CELL_COST]`, and walls cost 1 (they are never entered).

use glam::Vec2;
use rayon::prelude::*;

use super::distance::MAX_CELL_COST;
use super::occupancy::{OccupancyGrid, cell_of};

/// Frames between reroutes of a new quickest-path field.
pub const DEFAULT_REROUTE_EVERY: u64 = 50;
/// The half-side of the density window of a new quickest-path field, world units (metres).
pub const DEFAULT_DENSITY_RADIUS: f32 = 0.5;

/// Weidmann's speed at density `rho` over the free speed, in `[0, 1]`.
#[must_use]
pub(crate) fn weidmann_ratio(rho: f32) -> f32 {
    if rho <= 0.0 {
        return 1.0;
    }
    (1.0 - (-1.913 * (1.0 / rho - 1.0 / 5.4)).exp()).clamp(0.0, 1.0)
}

/// Scratch of [`Congestion::costs`], grown only.
#[derive(Clone, Debug, Default)]
pub(crate) struct Congestion {
    /// Agents per cell, row-major.
    counts: Vec<u32>,
    /// Summed-area tables of `counts` and of the free cells, `(width + 1) x (height + 1)`.
    agents: Vec<u32>,
    free: Vec<u32>,
}

impl Congestion {
    /// Writes into `out` (one cost per cell of `grid`, row-major) the costs of the crowd at
    /// `positions`, densities taken over a square of `2 r + 1` cells a side around each cell,
    /// `r` the window's half-side `radius` in cells (at least 1); only free cells of the window
    /// count towards its area.
    pub(crate) fn costs(
        &mut self,
        grid: &OccupancyGrid,
        positions: impl Iterator<Item = Vec2>,
        radius: f32,
        out: &mut Vec<f32>,
    ) {
        let (w, h) = (grid.width() as usize, grid.height() as usize);
        self.counts.clear();
        self.counts.resize(w * h, 0);
        for p in positions {
            if let Some((x, y)) = cell_of(grid, p) {
                self.counts[y * w + x] += 1;
            }
        }
        let sw = w + 1;
        for (table, value) in [(&mut self.agents, 0), (&mut self.free, 1)] {
            table.clear();
            table.resize(sw * (h + 1), 0);
            for y in 0..h {
                let mut row = 0u32;
                for x in 0..w {
                    row += if value == 0 {
                        self.counts[y * w + x]
                    } else {
                        u32::from(grid.cells()[y * w + x].is_free())
                    };
                    table[(y + 1) * sw + x + 1] = table[y * sw + x + 1] + row;
                }
            }
        }
        let r = ((radius / grid.cell_size()).round() as usize).max(1);
        let cell_area = grid.cell_size() * grid.cell_size();
        let (agents, free, cells) = (&self.agents, &self.free, grid.cells());
        let rect = |t: &[u32], x0: usize, y0: usize, x1: usize, y1: usize| {
            t[y1 * sw + x1] + t[y0 * sw + x0] - t[y0 * sw + x1] - t[y1 * sw + x0]
        };
        out.clear();
        out.resize(w * h, 1.0);
        out.par_chunks_mut(w)
            .enumerate()
            .with_min_len(16)
            .for_each(|(y, row)| {
                let (y0, y1) = (y.saturating_sub(r), (y + r + 1).min(h));
                for (x, c) in row.iter_mut().enumerate() {
                    if !cells[y * w + x].is_free() {
                        continue;
                    }
                    let (x0, x1) = (x.saturating_sub(r), (x + r + 1).min(w));
                    let n = rect(agents, x0, y0, x1, y1);
                    if n == 0 {
                        continue;
                    }
                    // The cell itself is free, so the area is positive.
                    let area = rect(free, x0, y0, x1, y1) as f32 * cell_area;
                    let ratio = weidmann_ratio(n as f32 / area);
                    *c = (1.0 / ratio.max(1.0 / MAX_CELL_COST)).clamp(1.0, MAX_CELL_COST);
                }
            });
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn costs_follow_weidmann_and_ignore_order() {
        // 1 m cells, a 9 x 9 room; four agents in the middle cell, window 3 x 3 cells.
        let grid = OccupancyGrid::new(9, 9).unwrap();
        let mut c = Congestion::default();
        let mut out = Vec::new();
        let at = [Vec2::new(4.5, 4.5); 4];
        c.costs(&grid, at.iter().copied(), 1.0, &mut out);
        // Density 4 / 9 m^2 wherever the window holds the middle cell.
        let expect = 1.0 / weidmann_ratio(4.0 / 9.0);
        assert!((out[4 * 9 + 4] - expect).abs() < 1e-6);
        assert!((out[3 * 9 + 5] - expect).abs() < 1e-6);
        assert_eq!(out[2 * 9 + 4], 1.0);
        // At 4 persons/m^2 and more the cost is large, capped at 20.
        let crowd: Vec<Vec2> = (0..200)
            .map(|i| Vec2::new(4.5, 4.5 + (i % 3) as f32 * 0.01))
            .collect();
        c.costs(&grid, crowd.iter().copied(), 1.0, &mut out);
        assert_eq!(out[4 * 9 + 4], MAX_CELL_COST);
        let mut rev = crowd.clone();
        rev.reverse();
        let mut back = Vec::new();
        c.costs(&grid, rev.iter().copied(), 1.0, &mut back);
        assert_eq!(out, back);
        assert!(out.iter().all(|&k| (1.0..=MAX_CELL_COST).contains(&k)));
        // Walls cost 1, and agents outside the grid are not counted.
        let map = OccupancyGrid::parse_ascii("...\n.#.\n...\n", "<map>").unwrap();
        c.costs(
            &map.grid,
            [Vec2::new(1.5, 1.5), Vec2::new(-5.0, 0.0)].into_iter(),
            1.0,
            &mut out,
        );
        assert_eq!(out[4], 1.0);
        assert!(out[0] > 1.0);
        assert!(weidmann_ratio(5.4) == 0.0 && weidmann_ratio(0.0) == 1.0);
    }
}
