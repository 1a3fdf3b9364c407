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
//! Each agent counts towards the four cells whose centres surround it, with bilinear weights
//! (cloud in cell), so that the density is continuous in the agents' positions: an agent on a
//! cell edge counts half on either side, and a scene turned or mirrored onto the raster gets
//! the turned or mirrored costs. (Counting each agent in the one cell that holds it would move
//! a whole row of a lattice that lies on cell edges into the cells on one side, and the costs
//! with it, whenever the scene is mirrored.)
//!
//! Invariants: the weights are fixed point ([`WEIGHT_ONE`] per axis) and summed in integers, so
//! the costs are the same for any order of the agents and any number of threads; an agent on
//! the grid counts exactly once in total (weights past the grid's border fold into the border
//! cells); every cost lies in `[1, MAX_CELL_COST]`, and walls cost 1 (they are never entered).

use glam::Vec2;
use rayon::prelude::*;

use super::distance::MAX_CELL_COST;
use super::occupancy::{OccupancyGrid, cell_coords};

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

/// One agent's weight along one axis, in fixed point: an agent counts `WEIGHT_ONE^2` in total.
pub(crate) const WEIGHT_ONE: u64 = 1 << 16;

/// Scratch of [`Congestion::costs`], grown only.
#[derive(Clone, Debug, Default)]
pub(crate) struct Congestion {
    /// Agents per cell, row-major, in units of `1 / WEIGHT_ONE^2` of an agent.
    counts: Vec<u64>,
    /// Summed-area tables of `counts` and of the free cells, `(width + 1) x (height + 1)`.
    agents: Vec<u64>,
    free: Vec<u32>,
}

/// The two cells along one axis whose centres bracket cell coordinate `u` (in cells from the
/// grid's origin, inside `[0, n)`), each with its fixed-point weight; cells past the border
/// are the border cell.
fn bracket(u: f32, n: usize) -> [(usize, u64); 2] {
    let g = u - 0.5;
    let lo = g.floor();
    let high = ((g - lo) * WEIGHT_ONE as f32).round() as u64;
    let high = high.min(WEIGHT_ONE);
    let last = n as i64 - 1;
    let cell = |i: i64| i.clamp(0, last) as usize;
    [
        (cell(lo as i64), WEIGHT_ONE - high),
        (cell(lo as i64 + 1), high),
    ]
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
            let u = (p - grid.origin()) / grid.cell_size();
            if cell_coords(u, w, h).is_none() {
                continue;
            }
            for (y, wy) in bracket(u.y, h) {
                for (x, wx) in bracket(u.x, w) {
                    self.counts[y * w + x] += wx * wy;
                }
            }
        }
        let sw = w + 1;
        summed_area(&mut self.agents, w, h, |i| self.counts[i]);
        summed_area(&mut self.free, w, h, |i| {
            u32::from(grid.cells()[i].is_free())
        });
        let r = ((radius / grid.cell_size()).round() as usize).max(1);
        let cell_area = grid.cell_size() * grid.cell_size();
        let (agents, free, cells) = (&self.agents, &self.free, grid.cells());
        fn rect<T: Copy + std::ops::Add<Output = T> + std::ops::Sub<Output = T>>(
            t: &[T],
            sw: usize,
            (x0, y0, x1, y1): (usize, usize, usize, usize),
        ) -> T {
            t[y1 * sw + x1] + t[y0 * sw + x0] - t[y0 * sw + x1] - t[y1 * sw + x0]
        }
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
                    let n = rect(agents, sw, (x0, y0, x1, y1));
                    if n == 0 {
                        continue;
                    }
                    let n = (n as f64 / (WEIGHT_ONE * WEIGHT_ONE) as f64) as f32;
                    // The cell itself is free, so the area is positive.
                    let area = rect(free, sw, (x0, y0, x1, y1)) as f32 * cell_area;
                    let ratio = weidmann_ratio(n / area);
                    *c = (1.0 / ratio.max(1.0 / MAX_CELL_COST)).clamp(1.0, MAX_CELL_COST);
                }
            });
    }
}

/// Fills `table` with the summed-area table, `(w + 1) x (h + 1)`, of the `w x h` row-major
/// values `value(i)`.
fn summed_area<T>(table: &mut Vec<T>, w: usize, h: usize, value: impl Fn(usize) -> T)
where
    T: Copy + Default + std::ops::Add<Output = T>,
{
    let sw = w + 1;
    table.clear();
    table.resize(sw * (h + 1), T::default());
    for y in 0..h {
        let mut row = T::default();
        for x in 0..w {
            row = row + value(y * w + x);
            table[(y + 1) * sw + x + 1] = table[y * sw + x + 1] + row;
        }
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

    #[test]
    fn agents_count_by_their_share_of_the_cells_so_that_mirrored_crowds_cost_alike() {
        // 0.25 m cells, 12 x 8; a lattice 0.5 m apart, every agent on a cell edge.
        let grid = OccupancyGrid::new(12, 8)
            .unwrap()
            .with_geometry(0.25, Vec2::ZERO)
            .unwrap();
        let crowd: Vec<Vec2> = (0..5)
            .flat_map(|i| {
                (0..3).map(move |j| Vec2::new(0.5 + 0.5 * i as f32, 0.5 + 0.25 * j as f32))
            })
            .collect();
        let mirrored: Vec<Vec2> = crowd.iter().map(|p| Vec2::new(3.0 - p.x, p.y)).collect();
        let mut c = Congestion::default();
        let (mut a, mut b) = (Vec::new(), Vec::new());
        c.costs(&grid, crowd.iter().copied(), 0.25, &mut a);
        c.costs(&grid, mirrored.iter().copied(), 0.25, &mut b);
        for y in 0..8 {
            for x in 0..12 {
                assert_eq!(a[y * 12 + x], b[y * 12 + 11 - x], "({x}, {y})");
            }
        }
        // Every agent counts once in all: the cells' weights sum to the crowd.
        let total: u64 = c.counts.iter().sum();
        assert_eq!(total, crowd.len() as u64 * WEIGHT_ONE * WEIGHT_ONE);
        // An agent on the edge between two cells' centres counts half in each.
        c.costs(&grid, [Vec2::new(0.5, 0.125)].into_iter(), 0.25, &mut a);
        assert_eq!(c.counts[1], WEIGHT_ONE * WEIGHT_ONE / 2);
        assert_eq!(c.counts[2], WEIGHT_ONE * WEIGHT_ONE / 2);
        // Past the border, the weight folds into the border cell.
        c.costs(&grid, [Vec2::new(0.05, 0.05)].into_iter(), 0.25, &mut a);
        assert_eq!(c.counts[0], WEIGHT_ONE * WEIGHT_ONE);
    }
}
