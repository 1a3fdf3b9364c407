//! The walkable area as an occupancy grid, for the flow fields that agents navigate by.
//!
//! A cell is free when its centre lies in the walkable area and no wall (ring edge) passes
//! through its open interior; every other cell is a wall. An edge that runs along a cell
//! boundary blocks neither neighbour, so an area whose corners lie on the grid's lines keeps
//! every cell it covers. The grid's lines are those of the lattice `anchor + k * cell_size`,
//! and the grid covers the area's bounding box.
//!
//! Invariants: the work is linear in the cells plus the rows and columns the edges span, and
//! the span total is refused above [`MAX_RASTER_SPANS`] before anything is allocated; the
//! centre test uses the same crossing rule as [`Walkable::contains`].

use glam::Vec2;

use super::Walkable;
use crate::error::{Error, Result, finite_vec, positive};
use crate::field::{Cell, OccupancyGrid};

/// The most rows and columns the edges of a walkable area may span in all at the raster's cell
/// size (2^22): the raster's work beyond its cells, and at most 64 MiB of row crossings.
pub const MAX_RASTER_SPANS: u64 = 1 << 22;

impl Walkable {
    /// The occupancy grid of the area at `cell_size`: the smallest grid of the lattice through
    /// `anchor` that covers the bounding box, a cell free when its centre lies in the area and
    /// no wall passes through its interior (see the module docs of `geometry::raster`).
    ///
    /// # Errors
    /// [`Error::NotPositive`] or [`Error::NonFinite`] for a bad `cell_size` or `anchor`;
    /// [`Error::Invalid`] when the grid would have more than
    /// [`MAX_CELLS`](crate::limits::MAX_CELLS) cells or the edges span more than
    /// [`MAX_RASTER_SPANS`] rows and columns.
    pub fn rasterize(&self, cell_size: f32, anchor: Vec2) -> Result<OccupancyGrid> {
        positive("field.cell_size", cell_size)?;
        finite_vec("field.origin", anchor)?;
        let cs = f64::from(cell_size);
        // Coordinates within a millionth of a grid line are on it (1.2 / 0.1 is not 12 in
        // floating point), so walls along grid lines block neither side.
        let snap = |v: f64| {
            let r = v.round();
            if (v - r).abs() <= 1e-6 * r.abs().max(1.0) {
                r
            } else {
                v
            }
        };
        let (ax, ay) = (f64::from(anchor.x), f64::from(anchor.y));
        let lo_x = snap((f64::from(self.min.x) - ax) / cs).floor();
        let lo_y = snap((f64::from(self.min.y) - ay) / cs).floor();
        let hi_x = snap((f64::from(self.max.x) - ax) / cs)
            .ceil()
            .max(lo_x + 1.0);
        let hi_y = snap((f64::from(self.max.y) - ay) / cs)
            .ceil()
            .max(lo_y + 1.0);
        let (w, h) = (hi_x - lo_x, hi_y - lo_y);
        let too_big = || Error::Invalid {
            name: "walkable raster".into(),
            reason: format!(
                "{w} x {h} cells of side {cell_size}, more than the {} a grid may have",
                crate::limits::MAX_CELLS
            ),
        };
        if !at_most(w * h, crate::limits::MAX_CELLS as f64) {
            return Err(too_big());
        }
        let (w, h) = (w as u32, h as u32);
        let origin = Vec2::new((ax + lo_x * cs) as f32, (ay + lo_y * cs) as f32);
        // Grid coordinates of every ring, in f64 (cell units from the grid's origin).
        let to_grid = |p: Vec2| {
            (
                snap((f64::from(p.x) - f64::from(origin.x)) / cs),
                snap((f64::from(p.y) - f64::from(origin.y)) / cs),
            )
        };
        let rings: Vec<Vec<(f64, f64)>> = self
            .rings()
            .map(|r| r.iter().map(|&p| to_grid(p)).collect())
            .collect();
        let spans: f64 = rings
            .iter()
            .flat_map(|r| edges(r))
            .map(|(a, b)| (a.0 - b.0).abs() + (a.1 - b.1).abs() + 2.0)
            .sum();
        if !at_most(spans, MAX_RASTER_SPANS as f64) {
            return Err(Error::Invalid {
                name: "walkable raster".into(),
                reason: format!(
                    "the walls span {spans:.0} rows and columns at cell size {cell_size}, more than the {MAX_RASTER_SPANS} allowed (use larger cells)"
                ),
            });
        }
        let mut grid = OccupancyGrid::new(w, h)?.with_geometry(cell_size, origin)?;
        let mut cells = vec![Cell::Wall; grid.len()];
        // Centres inside: per row, the x of every edge crossing the row's centre line, sorted;
        // the centres between the 1st and 2nd, 3rd and 4th, ... crossings are inside.
        let mut crossings: Vec<(u32, f64)> = Vec::new();
        for ring in &rings {
            for (a, b) in edges(ring) {
                let (y0, y1) = (a.1.min(b.1), a.1.max(b.1));
                // Rows whose centre c + 0.5 satisfies y0 <= c < y1 (the half-open crossing rule).
                let first = (y0 - 0.5).ceil().max(0.0);
                let last = ((y1 - 0.5).ceil() - 1.0).min(f64::from(h) - 1.0);
                let mut row = first;
                while row <= last {
                    let yc = row + 0.5;
                    if (a.1 > yc) != (b.1 > yc) {
                        let x = a.0 + (yc - a.1) * (b.0 - a.0) / (b.1 - a.1);
                        crossings.push((row as u32, x));
                    }
                    row += 1.0;
                }
            }
        }
        crossings.sort_by(|p, q| p.0.cmp(&q.0).then(p.1.total_cmp(&q.1)));
        for pair in crossings.chunk_by(|p, q| p.0 == q.0) {
            let row = pair[0].0 as usize * w as usize;
            for span in pair.chunks_exact(2) {
                // Columns whose centre c + 0.5 lies in [x0, x1).
                let c0 = (span[0].1 - 0.5).ceil().max(0.0);
                let c1 = (span[1].1 - 0.5).ceil().min(f64::from(w));
                if c1 > c0 {
                    cells[row + c0 as usize..row + c1 as usize].fill(Cell::Free);
                }
            }
        }
        // Walls through a cell's open interior block it.
        for ring in &rings {
            for (a, b) in edges(ring) {
                block_crossed(&mut cells, w, h, a, b);
            }
        }
        grid = OccupancyGrid::from_cells(w, h, cells)?.with_geometry(cell_size, origin)?;
        Ok(grid)
    }
}

/// Whether `x <= max` (false for NaN).
fn at_most(x: f64, max: f64) -> bool {
    matches!(
        x.partial_cmp(&max),
        Some(std::cmp::Ordering::Less | std::cmp::Ordering::Equal)
    )
}

/// The edges of a ring in grid coordinates.
fn edges(ring: &[(f64, f64)]) -> impl Iterator<Item = ((f64, f64), (f64, f64))> + '_ {
    let n = ring.len();
    (0..n).map(move |k| (ring[k], ring[(k + 1) % n]))
}

/// Marks as walls the cells whose open interior the segment `a -> b` passes through.
fn block_crossed(cells: &mut [Cell], w: u32, h: u32, a: (f64, f64), b: (f64, f64)) {
    let (wf, hf) = (f64::from(w), f64::from(h));
    let mut block_rows = |col: f64, y0: f64, y1: f64| {
        // Rows r with y0 < r + 1 and y1 > r, or the row holding y0 when the part is a point
        // strictly inside a row.
        let (lo, hi) = (y0.min(y1), y0.max(y1));
        let (first, last) = if lo == hi {
            if lo == lo.floor() {
                return; // along a row boundary
            }
            (lo.floor(), lo.floor())
        } else {
            (lo.floor(), hi.ceil() - 1.0)
        };
        let (first, last) = (first.max(0.0), last.min(hf - 1.0));
        let mut r = first;
        while r <= last {
            cells[r as usize * w as usize + col as usize] = Cell::Wall;
            r += 1.0;
        }
    };
    if a.0 == b.0 {
        let x = a.0;
        if x == x.floor() || x < 0.0 || x >= wf {
            return; // along a column boundary, or outside
        }
        block_rows(x.floor(), a.1, b.1);
        return;
    }
    let (l, r) = if a.0 < b.0 { (a, b) } else { (b, a) };
    let slope = (r.1 - l.1) / (r.0 - l.0);
    let first = l.0.floor().max(0.0);
    let last = (r.0.ceil() - 1.0).min(wf - 1.0);
    let mut col = first;
    while col <= last {
        let x0 = l.0.max(col);
        let x1 = r.0.min(col + 1.0);
        if x1 > x0 {
            let y0 = l.1 + (x0 - l.0) * slope;
            let y1 = l.1 + (x1 - l.0) * slope;
            block_rows(col, y0, y1);
        }
        col += 1.0;
    }
}
