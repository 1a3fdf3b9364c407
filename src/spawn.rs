//! Spawn helpers: seeded, deterministic placements of agents in common shapes.
//!
//! A [`Spawner`] draws from its own seed (the same seed gives the same points on every machine
//! and thread count) and, when asked with [`Spawner::avoiding`], never places a point inside a
//! circle obstacle (nor within the clearance of one). Its results are positions; [`agents`]
//! turns them into [`AgentInit`]s of one group with headings drawn from the same seed.
//!
//! ```
//! use throng::prelude::*;
//! use throng::spawn::Spawner;
//!
//! # fn main() -> throng::Result<()> {
//! let crowd = Spawner::new(7).disc(500, Vec2::new(50.0, 50.0), 20.0)?;
//! let lanes = Spawner::new(7).poisson_disc(Vec2::ZERO, Vec2::new(30.0, 10.0), 1.0, 1000)?;
//! assert_eq!(crowd.len(), 500);
//! assert!(lanes.len() > 100);
//! # Ok(())
//! # }
//! ```
//!
//! Invariants: every point returned is finite and inside its shape (closed rectangle, disc or
//! annulus); Poisson-disc points are at least `spacing` apart; with obstacles to avoid, no point
//! lies within `clearance` of a circle's edge or inside it. Counts are capped at
//! [`MAX_AGENTS`], and a shape too crowded to fill is an error, not a
//! hang.

use std::f32::consts::TAU;

use glam::Vec2;
use rand::{Rng, RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::agents::AgentInit;
use crate::error::{Error, MAX_AGENTS, MAX_COORDINATE, Result, non_negative, positive};
use crate::field::OccupancyGrid;
use crate::obstacles::Obstacles;

/// How many draws a random placement may spend per point before it gives up.
const TRIES_PER_POINT: usize = 1000;
/// Candidates tried around each active point of the Poisson-disc sampler (Bridson's k).
const POISSON_CANDIDATES: usize = 30;

/// A uniform point of the rectangle `[min, max]`: the loader's and the spawner's one formula.
#[inline]
pub(crate) fn sample_rect(rng: &mut impl Rng, min: Vec2, max: Vec2) -> Vec2 {
    Vec2::new(
        min.x + rng.random::<f32>() * (max.x - min.x),
        min.y + rng.random::<f32>() * (max.y - min.y),
    )
}

/// A uniform point of the annulus `inner <= |p - center| <= outer` (a disc when `inner` is 0).
#[inline]
pub(crate) fn sample_ring(rng: &mut impl Rng, center: Vec2, inner: f32, outer: f32) -> Vec2 {
    let r = if inner == 0.0 {
        outer * rng.random::<f32>().sqrt()
    } else {
        let (a, b) = (inner * inner, outer * outer);
        (a + rng.random::<f32>() * (b - a)).sqrt()
    };
    let angle = rng.random::<f32>() * 2.0 * std::f32::consts::PI;
    center + Vec2::from_angle(angle) * r
}

/// Seeded placements in a shape, optionally clear of circle obstacles.
#[derive(Clone, Copy, Debug)]
pub struct Spawner<'a> {
    seed: u64,
    avoid: Option<(&'a Obstacles, f32)>,
}

impl<'a> Spawner<'a> {
    /// A spawner drawing from `seed`.
    #[must_use]
    pub fn new(seed: u64) -> Self {
        Spawner { seed, avoid: None }
    }

    /// The same spawner, placing no point inside a circle of `obstacles` or within `clearance`
    /// of its edge (for agents of radius `clearance`).
    #[must_use]
    pub fn avoiding(self, obstacles: &'a Obstacles, clearance: f32) -> Self {
        Spawner {
            avoid: Some((obstacles, clearance.max(0.0))),
            ..self
        }
    }

    fn rng(&self, shape: u64) -> ChaCha8Rng {
        ChaCha8Rng::seed_from_u64(self.seed ^ shape.wrapping_mul(0x9e37_79b9_7f4a_7c15))
    }

    /// Whether `p` is clear of the obstacles to avoid.
    fn free(&self, p: Vec2) -> bool {
        match self.avoid {
            None => true,
            Some((o, clearance)) => !o.near_circle(p, clearance),
        }
    }

    /// `n` points drawn by `draw`, each redrawn while it is not free.
    fn draw(
        &self,
        n: usize,
        shape: u64,
        mut draw: impl FnMut(&mut ChaCha8Rng) -> Vec2,
    ) -> Result<Vec<Vec2>> {
        count(n)?;
        let mut rng = self.rng(shape);
        let mut out = Vec::new();
        out.try_reserve_exact(n).map_err(|_| too_many(n))?;
        for k in 0..n {
            let mut tries = 0;
            let p = loop {
                let p = draw(&mut rng);
                if self.free(p) {
                    break p;
                }
                tries += 1;
                if tries == TRIES_PER_POINT {
                    return Err(crowded(k));
                }
            };
            out.push(p);
        }
        Ok(out)
    }

    /// `n` points uniform in the rectangle `[min, max]`.
    ///
    /// # Errors
    /// [`Error::NonFinite`] / [`Error::Invalid`] for a bad rectangle or count; [`Error::Invalid`]
    /// when obstacles leave no room.
    pub fn rect(&self, n: usize, min: Vec2, max: Vec2) -> Result<Vec<Vec2>> {
        rect_ok(min, max)?;
        self.draw(n, 1, |r| sample_rect(r, min, max))
    }

    /// `n` points uniform in the disc of `radius` around `center`.
    ///
    /// # Errors
    /// As [`Spawner::rect`].
    pub fn disc(&self, n: usize, center: Vec2, radius: f32) -> Result<Vec<Vec2>> {
        self.ring(n, center, 0.0, radius)
    }

    /// `n` points uniform in the annulus between radii `inner` and `outer` around `center`.
    ///
    /// # Errors
    /// As [`Spawner::rect`], and for `inner > outer`.
    pub fn ring(&self, n: usize, center: Vec2, inner: f32, outer: f32) -> Result<Vec<Vec2>> {
        point_ok("spawn.center", center)?;
        non_negative("spawn.inner", inner)?;
        coordinate("spawn.outer", non_negative("spawn.outer", outer)?)?;
        if inner > outer {
            return Err(invalid(
                "spawn.inner",
                "the inner radius exceeds the outer one",
            ));
        }
        self.draw(n, 2, |r| sample_ring(r, center, inner, outer))
    }

    /// `n` points on a regular grid over the rectangle `[min, max]` (cells as square as the
    /// rectangle allows, points at cell centres, row by row from `min`); with obstacles to
    /// avoid, the grid is refined until `n` of its points are free and the first `n` are kept.
    ///
    /// # Errors
    /// As [`Spawner::rect`].
    pub fn grid(&self, n: usize, min: Vec2, max: Vec2) -> Result<Vec<Vec2>> {
        self.jittered_grid(n, min, max, 0.0)
    }

    /// [`Spawner::grid`] with each point moved uniformly within `jitter` (a fraction of the
    /// cell, in `[0, 1]`) of its cell centre: no two points share a cell.
    ///
    /// # Errors
    /// As [`Spawner::rect`], and for a jitter outside `[0, 1]`.
    pub fn jittered_grid(&self, n: usize, min: Vec2, max: Vec2, jitter: f32) -> Result<Vec<Vec2>> {
        rect_ok(min, max)?;
        count(n)?;
        crate::error::in_range("spawn.jitter", jitter, 0.0, 1.0, "[0, 1]")?;
        if n == 0 {
            return Ok(Vec::new());
        }
        let size = max - min;
        let aspect = if size.y > 0.0 {
            f64::from((size.x / size.y).clamp(1e-6, 1e6))
        } else {
            1e6
        };
        // Lattices of `cells >= n` points, finer each round while obstacles take too many:
        // beyond 64 n cells the free part is too small a share of the rectangle to try on.
        let mut cells = n;
        while cells <= n.saturating_mul(64) {
            let cols = ((cells as f64 * aspect).sqrt().ceil() as usize).clamp(1, cells);
            let rows = cells.div_ceil(cols);
            let cell = Vec2::new(size.x / cols as f32, size.y / rows as f32);
            let mut rng = self.rng(3);
            let mut out = Vec::new();
            out.try_reserve_exact(n).map_err(|_| too_many(n))?;
            'cells: for row in 0..rows {
                for col in 0..cols {
                    let centre = min + (Vec2::new(col as f32, row as f32) + 0.5) * cell;
                    let offset = Vec2::new(rng.random::<f32>() - 0.5, rng.random::<f32>() - 0.5);
                    let p = (centre + offset * jitter * cell).clamp(min, max);
                    if self.free(p) {
                        out.push(p);
                        if out.len() == n {
                            break 'cells;
                        }
                    }
                }
            }
            if out.len() == n {
                return Ok(out);
            }
            cells = cells + cells / 2 + 1;
        }
        Err(crowded(0))
    }

    /// Points at least `spacing` apart over the rectangle `[min, max]` (Bridson's Poisson-disc
    /// sampling: a blue-noise layout, maximal in that no further point fits), at most
    /// `max_count` of them.
    ///
    /// # Errors
    /// As [`Spawner::rect`], [`Error::NotPositive`] for the spacing, and [`Error::Invalid`]
    /// when the rectangle holds more than [`MAX_AGENTS`] cells of that spacing.
    pub fn poisson_disc(
        &self,
        min: Vec2,
        max: Vec2,
        spacing: f32,
        max_count: usize,
    ) -> Result<Vec<Vec2>> {
        rect_ok(min, max)?;
        positive("spawn.spacing", spacing)?;
        count(max_count)?;
        let cell = spacing / std::f32::consts::SQRT_2;
        let size = max - min;
        let (gw, gh) = (
            (f64::from(size.x / cell)).floor() + 1.0,
            (f64::from(size.y / cell)).floor() + 1.0,
        );
        if gw * gh > MAX_AGENTS as f64 {
            return Err(invalid(
                "spawn.spacing",
                "the rectangle holds too many points of that spacing (more than 100,000,000 cells)",
            ));
        }
        let (gw, gh) = (gw as usize, gh as usize);
        let mut grid: Vec<u32> = vec![u32::MAX; gw * gh];
        let at = |p: Vec2| -> usize {
            let c = ((p - min) / cell).floor();
            (c.y as usize).min(gh - 1) * gw + (c.x as usize).min(gw - 1)
        };
        let mut rng = self.rng(4);
        let mut points: Vec<Vec2> = Vec::new();
        let mut active: Vec<u32> = Vec::new();
        // The first point: a free one, drawn uniformly.
        let first = (0..TRIES_PER_POINT)
            .map(|_| sample_rect(&mut rng, min, max))
            .find(|&p| self.free(p));
        let Some(first) = first else {
            return Err(crowded(0));
        };
        if max_count == 0 {
            return Ok(points);
        }
        grid[at(first)] = 0;
        points.push(first);
        active.push(0);
        let sq = spacing * spacing;
        while !active.is_empty() && points.len() < max_count {
            let k = rng.random_range(0..active.len());
            let base = points[active[k] as usize];
            let mut placed = false;
            for _ in 0..POISSON_CANDIDATES {
                let p = sample_ring(&mut rng, base, spacing, 2.0 * spacing);
                if p.x < min.x || p.y < min.y || p.x > max.x || p.y > max.y || !self.free(p) {
                    continue;
                }
                let c = ((p - min) / cell).floor();
                let (cx, cy) = ((c.x as usize).min(gw - 1), (c.y as usize).min(gh - 1));
                let near = (cy.saturating_sub(2)..(cy + 3).min(gh)).any(|y| {
                    (cx.saturating_sub(2)..(cx + 3).min(gw)).any(|x| {
                        let q = grid[y * gw + x];
                        q != u32::MAX && points[q as usize].distance_squared(p) < sq
                    })
                });
                if near {
                    continue;
                }
                grid[cy * gw + cx] = points.len() as u32;
                active.push(points.len() as u32);
                points.push(p);
                placed = true;
                break;
            }
            if !placed {
                active.swap_remove(k);
            }
        }
        Ok(points)
    }

    /// `n` points uniform over the free cells of an occupancy grid (each inside its cell, off
    /// the cell's edges).
    ///
    /// # Errors
    /// [`Error::Invalid`] when the grid has no free cell (or the obstacles cover them all).
    pub fn free_cells(&self, n: usize, grid: &OccupancyGrid) -> Result<Vec<Vec2>> {
        count(n)?;
        let free = FreeCells::new(grid);
        if free.is_empty() {
            return Err(invalid("spawn.free_cells", "the grid has no free cell"));
        }
        self.draw(n, 5, |rng| {
            let (x, y) = free.nth(grid, rng.random_range(0..free.len()));
            let inner = Vec2::new(rng.random::<f32>(), rng.random::<f32>())
                .clamp(Vec2::splat(0.01), Vec2::splat(0.99));
            grid.origin() + (Vec2::new(x as f32, y as f32) + inner) * grid.cell_size()
        })
    }
}

/// Cells counted per entry of [`FreeCells`]' running count.
const FREE_CHUNK: usize = 64;

/// The free cells of an occupancy grid, numbered in row-major order, for uniform draws in
/// O(log cells) each: a running count of free cells every [`FREE_CHUNK`] cells (an eighth of
/// a byte per cell), so that a sparse grid costs no more per draw than a dense one.
#[derive(Clone, Debug, Default)]
pub(crate) struct FreeCells {
    /// `before[c]`: free cells in chunks `0..c`; one entry per chunk and the total last.
    before: Vec<usize>,
}

impl FreeCells {
    /// The index of `grid`'s free cells.
    pub(crate) fn new(grid: &OccupancyGrid) -> Self {
        let cells = grid.cells();
        let mut before = Vec::with_capacity(cells.len() / FREE_CHUNK + 2);
        let mut total = 0;
        for chunk in cells.chunks(FREE_CHUNK) {
            before.push(total);
            total += chunk.iter().filter(|c| c.is_free()).count();
        }
        before.push(total);
        FreeCells { before }
    }

    /// Number of free cells.
    pub(crate) fn len(&self) -> usize {
        self.before.last().copied().unwrap_or(0)
    }

    /// Whether the grid has no free cell.
    pub(crate) fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The `k`-th free cell (`k < len()`) of `grid` (the grid the index was made of), in
    /// row-major order.
    pub(crate) fn nth(&self, grid: &OccupancyGrid, k: usize) -> (u32, u32) {
        // The last chunk whose free cells before it are at most k holds the k-th.
        let chunk = self.before.partition_point(|&b| b <= k) - 1;
        let mut left = k - self.before[chunk];
        let start = chunk * FREE_CHUNK;
        let cells = grid.cells();
        let end = (start + FREE_CHUNK).min(cells.len());
        let mut at = start;
        for (i, c) in cells[start..end].iter().enumerate() {
            if c.is_free() {
                if left == 0 {
                    at = start + i;
                    break;
                }
                left -= 1;
            }
        }
        let w = grid.width() as usize;
        ((at % w) as u32, (at / w) as u32)
    }
}

/// The most agents a `spread` spawn can place `distance` apart in the rectangle `[min, max]`
/// by dart throwing: about 0.547 of the plane is covered by the discs of diameter `distance`
/// around the points when random sequential placement jams (Feder's jamming coverage), here
/// over the rectangle grown by `distance`, with a tenth and two more for small and thin
/// rectangles; never more than Oler's bound `2 A / (sqrt 3 d^2) + P / (2 d) + 1`, which no
/// arrangement exceeds. `None` when any count fits (`distance` is 0).
pub(crate) fn spread_capacity(min: Vec2, max: Vec2, distance: f32) -> Option<f64> {
    if distance <= 0.0 {
        return None;
    }
    let (d, size) = (f64::from(distance), (max - min).as_dvec2());
    let jammed = 0.547 * (size.x + d) * (size.y + d) / (std::f64::consts::PI * d * d / 4.0);
    let oler = 2.0 / 3f64.sqrt() * size.x * size.y / (d * d) + (size.x + size.y) / d + 1.0;
    Some((1.1 * jammed + 2.0).min(oler).floor())
}

/// Checks before any work that `n` agents of a `spread` spawn can be `distance` apart in
/// `[min, max]` ([`spread_capacity`]).
///
/// # Errors
/// [`Error::Invalid`] naming `spawn` with the capacity when they cannot.
pub(crate) fn spread_fits(n: usize, min: Vec2, max: Vec2, distance: f32) -> Result<()> {
    match spread_capacity(min, max, distance) {
        Some(cap) if n as f64 > cap => Err(invalid(
            "spawn",
            &format!(
                "no room for {n} agents at least {distance} apart in [{}, {}] x [{}, {}]: random \
                 placement fits about {cap} there (lower the count or the distance, or widen \
                 the rectangle)",
                min.x, max.x, min.y, max.y
            ),
        )),
        _ => Ok(()),
    }
}

/// Dart throwing for `spread` spawns: the points placed so far (by every `spread` group of a
/// scenario), hashed by cells of the largest distance asked, so that a draw is checked against
/// the points of 3 x 3 cells only. A distance of 0 checks nothing: every point fits.
#[derive(Debug, Default)]
pub(crate) struct Spread {
    cell: f32,
    points: Vec<Vec2>,
    cells: std::collections::HashMap<(i64, i64), Vec<u32>>,
}

impl Spread {
    /// Draws from `[min, max]` until a point lies at least `distance` from every point placed
    /// before and is accepted by `accept` (clear of the obstacles, inside the walkable area);
    /// `None` after 10,000 draws.
    pub(crate) fn place(
        &mut self,
        rng: &mut ChaCha8Rng,
        (min, max): (Vec2, Vec2),
        distance: f32,
        accept: impl Fn(Vec2) -> bool,
    ) -> Option<Vec2> {
        if distance > self.cell {
            // Re-hash at the larger cell so that the 3 x 3 block stays enough.
            self.cell = distance;
            self.cells.clear();
            for (k, &p) in self.points.iter().enumerate() {
                let key = self.key(p);
                self.cells.entry(key).or_default().push(k as u32);
            }
        }
        let d_sq = distance * distance;
        for _ in 0..10_000 {
            let p = sample_rect(rng, min, max);
            if !accept(p) {
                continue;
            }
            let (kx, ky) = self.key(p);
            let free = distance <= 0.0
                || (-1..=1).all(|dx| {
                    (-1..=1).all(|dy| {
                        self.cells.get(&(kx + dx, ky + dy)).is_none_or(|v| {
                            v.iter()
                                .all(|&q| self.points[q as usize].distance_squared(p) >= d_sq)
                        })
                    })
                });
            if free {
                if self.cell > 0.0 {
                    self.cells
                        .entry((kx, ky))
                        .or_default()
                        .push(self.points.len() as u32);
                }
                self.points.push(p);
                return Some(p);
            }
        }
        None
    }

    fn key(&self, p: Vec2) -> (i64, i64) {
        if self.cell <= 0.0 {
            return (0, 0);
        }
        (
            (p.x / self.cell).floor() as i64,
            (p.y / self.cell).floor() as i64,
        )
    }
}

/// Agents of `group` at `positions`, each with a heading drawn uniformly from `seed` and an
/// initial velocity of `speed` along it.
pub fn agents(
    positions: &[Vec2],
    group: usize,
    speed: f32,
    seed: u64,
) -> impl Iterator<Item = AgentInit> + '_ {
    let mut rng = ChaCha8Rng::seed_from_u64(seed ^ 0x6865_6164);
    positions.iter().map(move |&position| {
        let heading = rng.random::<f32>() * TAU;
        AgentInit {
            position,
            velocity: Vec2::from_angle(heading) * speed,
            orientation: heading,
            group,
            ..AgentInit::default()
        }
    })
}

fn count(n: usize) -> Result<()> {
    if n > MAX_AGENTS {
        Err(too_many(n))
    } else {
        Ok(())
    }
}

fn too_many(n: usize) -> Error {
    invalid(
        "spawn.count",
        &format!("{n} points asked, more than the ceiling of 100,000,000 agents"),
    )
}

fn crowded(placed: usize) -> Error {
    invalid(
        "spawn",
        &format!("no free spot found for point {placed}: the obstacles leave no room in the shape"),
    )
}

fn invalid(name: &str, reason: &str) -> Error {
    Error::Invalid {
        name: name.into(),
        reason: reason.into(),
    }
}

fn coordinate(name: &'static str, v: f32) -> Result<f32> {
    crate::error::in_range(name, v, -MAX_COORDINATE, MAX_COORDINATE, "[-1e18, 1e18]")
}

fn point_ok(name: &'static str, p: Vec2) -> Result<()> {
    crate::error::coordinate(name, p).map(|_| ())
}

fn rect_ok(min: Vec2, max: Vec2) -> Result<()> {
    point_ok("spawn.min", min)?;
    point_ok("spawn.max", max)?;
    if min.x > max.x || min.y > max.y {
        return Err(invalid(
            "spawn.max",
            "the upper corner lies below the lower one",
        ));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::field::Cell;

    #[test]
    fn the_nth_free_cell_is_the_nth_in_row_major_order() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        for (w, h, free_share) in [(1, 1, 1.0), (7, 5, 0.5), (130, 3, 0.02), (64, 64, 0.001)] {
            let cells: Vec<Cell> = (0..w * h)
                .map(|_| {
                    if rng.random::<f64>() < free_share {
                        Cell::Free
                    } else {
                        Cell::Wall
                    }
                })
                .collect();
            let grid = OccupancyGrid::from_cells(w, h, cells).unwrap();
            let brute: Vec<(u32, u32)> = (0..h)
                .flat_map(|y| (0..w).map(move |x| (x, y)))
                .filter(|&(x, y)| grid.is_free(x, y))
                .collect();
            let index = FreeCells::new(&grid);
            assert_eq!(index.len(), brute.len());
            for (k, &cell) in brute.iter().enumerate() {
                assert_eq!(index.nth(&grid, k), cell, "{w} x {h}, k = {k}");
            }
        }
    }

    #[test]
    fn spread_capacity_admits_what_dart_throwing_reaches_and_nothing_impossible() {
        // Dart throwing until 10,000 draws fail: the count it reaches fits the capacity, and
        // the capacity stays under Oler's bound.
        for (size, d) in [
            (Vec2::new(20.0, 20.0), 1.0),
            (Vec2::new(10.0, 3.0), 1.0),
            (Vec2::new(1.0, 1.0), 1.0),
            (Vec2::new(0.0, 5.0), 1.0),
            (Vec2::new(5.0, 0.2), 1.0),
        ] {
            let cap = spread_capacity(Vec2::ZERO, size, d).unwrap();
            for seed in 0..3 {
                let mut rng = ChaCha8Rng::seed_from_u64(seed);
                let mut spread = Spread::default();
                let mut n = 0;
                while spread
                    .place(&mut rng, (Vec2::ZERO, size), d, |_| true)
                    .is_some()
                {
                    n += 1;
                }
                assert!(n as f64 <= cap, "{size} at {d}: {n} placed, capacity {cap}");
            }
            let oler =
                2.0 / 3f64.sqrt() * f64::from(size.x * size.y) + f64::from(size.x + size.y) + 1.0;
            assert!(cap <= oler, "{size}: {cap} over Oler's {oler}");
        }
        assert_eq!(spread_capacity(Vec2::ZERO, Vec2::ONE, 0.0), None);
    }
}
