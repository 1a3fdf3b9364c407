//! The padded cell layout every field shares, and the neighbourhoods.
//!
//! Fields store one value per cell in a row-major array that has a one-cell border of walls
//! around the grid (`stride = width + 2`). Every interior cell therefore has all eight neighbours
//! inside the array, so the inner loops need no per-neighbour bounds tests on coordinates: a
//! neighbour is `index + offset`. The border is never reachable and never free.
//!
//! Neighbours are visited in one fixed order, [`DIRECTIONS`]: the four orthogonal steps first,
//! then the four diagonals. Every tie in the crate (which neighbour is "best" when two are equally
//! good) is broken by that order, so results never depend on threads or storage.

use glam::Vec2;

use super::occupancy::{OccupancyGrid, cell_coords};

/// Which cells count as a cell's neighbours.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "snake_case")]
pub enum Neighbourhood {
    /// The four orthogonal neighbours (von Neumann); every step has length 1.
    #[default]
    Four,
    /// All eight neighbours (Moore). A diagonal step has length `sqrt(2)` and is allowed only
    /// when both orthogonal cells it passes are free, so paths never cut a wall's corner.
    Eight,
}

impl Neighbourhood {
    /// How many neighbours a cell has: 4 or 8.
    #[must_use]
    pub fn count(self) -> usize {
        match self {
            Neighbourhood::Four => 4,
            Neighbourhood::Eight => 8,
        }
    }
}

/// The eight steps `(dx, dy)` in the order fields visit them: orthogonal first, then diagonal.
pub const DIRECTIONS: [(i32, i32); 8] = [
    (1, 0),
    (-1, 0),
    (0, 1),
    (0, -1),
    (1, 1),
    (-1, 1),
    (1, -1),
    (-1, -1),
];

/// For diagonal direction `k` (4..8): the indices (into [`DIRECTIONS`]) of the two orthogonal
/// steps it passes, x first.
pub(crate) const DIAGONAL_SIDES: [(usize, usize); 4] = [(0, 2), (1, 2), (0, 3), (1, 3)];

/// Unit vectors of [`DIRECTIONS`].
pub(crate) const UNIT: [Vec2; 8] = {
    const D: f32 = std::f32::consts::FRAC_1_SQRT_2;
    [
        Vec2::new(1.0, 0.0),
        Vec2::new(-1.0, 0.0),
        Vec2::new(0.0, 1.0),
        Vec2::new(0.0, -1.0),
        Vec2::new(D, D),
        Vec2::new(-D, D),
        Vec2::new(D, -D),
        Vec2::new(-D, -D),
    ]
};

/// The size and world placement of a grid, and its padded index arithmetic.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Lattice {
    pub width: u32,
    pub height: u32,
    /// `width + 2`.
    pub stride: usize,
    /// `(width + 2) * (height + 2)`.
    pub len: usize,
    pub cell_size: f32,
    pub origin: Vec2,
    /// Signed index offsets of [`DIRECTIONS`].
    pub offsets: [isize; 8],
}

impl Lattice {
    /// The padded layout of `grid`.
    pub fn of(grid: &OccupancyGrid) -> Self {
        let stride = grid.width() as usize + 2;
        let len = stride * (grid.height() as usize + 2);
        let s = stride as isize;
        let offsets = DIRECTIONS.map(|(dx, dy)| dx as isize + dy as isize * s);
        Lattice {
            width: grid.width(),
            height: grid.height(),
            stride,
            len,
            cell_size: grid.cell_size(),
            origin: grid.origin(),
            offsets,
        }
    }

    /// Padded index of cell `(x, y)`, which must lie in the grid.
    #[inline]
    pub fn index(&self, x: u32, y: u32) -> usize {
        debug_assert!(x < self.width && y < self.height);
        (y as usize + 1) * self.stride + x as usize + 1
    }

    /// Padded index of `(x, y)`, or `None` outside the grid.
    #[inline]
    pub fn checked_index(&self, x: u32, y: u32) -> Option<usize> {
        (x < self.width && y < self.height).then(|| self.index(x, y))
    }

    /// Cell coordinates of an interior padded index.
    #[inline]
    pub fn coords(&self, p: usize) -> (u32, u32) {
        ((p % self.stride - 1) as u32, (p / self.stride - 1) as u32)
    }

    /// The padded index `p` moved by direction `k`.
    #[inline]
    pub fn step(&self, p: usize, k: usize) -> usize {
        p.wrapping_add_signed(self.offsets[k])
    }

    /// The padded range of row `y`'s interior cells.
    #[inline]
    pub fn row_range(&self, y: u32) -> std::ops::Range<usize> {
        let start = self.index(0, y);
        start..start + self.width as usize
    }

    /// Whether two lattices describe the same cells (size only).
    #[inline]
    pub fn same_shape(&self, other: &Lattice) -> bool {
        self.width == other.width && self.height == other.height
    }

    /// Continuous cell coordinates of a world point (cell `(x, y)` spans `[x, x + 1)`).
    #[inline]
    pub fn cell_space(&self, p: Vec2) -> Vec2 {
        (p - self.origin) / self.cell_size
    }

    /// The cell containing world point `p`, or `None` outside the grid or for a non-finite point
    /// (the grid's far edges belong to its last column and row, see [`cell_coords`]).
    #[inline]
    pub fn world_to_cell(&self, p: Vec2) -> Option<(u32, u32)> {
        cell_coords(
            self.cell_space(p),
            self.width as usize,
            self.height as usize,
        )
        .map(|(x, y)| (x as u32, y as u32))
    }

    /// The world position of cell `(x, y)`'s centre.
    #[inline]
    pub fn cell_center(&self, x: u32, y: u32) -> Vec2 {
        self.origin + (Vec2::new(x as f32, y as f32) + 0.5) * self.cell_size
    }
}

/// A padded map of the grid: `wall` for walls and the border, `free` for free cells. Rows are
/// filled in parallel (the values do not depend on the order).
pub(crate) fn padded_map<T: Copy + Send + Sync>(
    grid: &OccupancyGrid,
    lattice: &Lattice,
    free: T,
    wall: T,
) -> Vec<T> {
    use rayon::prelude::*;
    let mut out = vec![wall; lattice.len];
    let w = lattice.width as usize;
    out.par_chunks_mut(lattice.stride)
        .enumerate()
        .with_min_len(64)
        .for_each(|(row, line)| {
            if row == 0 || row > lattice.height as usize {
                return;
            }
            let cells = &grid.cells()[(row - 1) * w..row * w];
            for (o, c) in line[1..=w].iter_mut().zip(cells) {
                *o = if c.is_free() { free } else { wall };
            }
        });
    out
}

/// Checks a goal list against `grid`: at least one goal, each inside and on a free cell.
pub(crate) fn check_goals(grid: &OccupancyGrid, goals: &[(u32, u32)]) -> crate::error::Result<()> {
    use crate::error::Error;
    if goals.is_empty() {
        return Err(Error::Invalid {
            name: "goals".into(),
            reason: "at least one goal cell is required".into(),
        });
    }
    for &(x, y) in goals {
        match grid.cell(x, y) {
            None => {
                return Err(Error::Invalid {
                    name: "goals".into(),
                    reason: format!(
                        "goal ({x}, {y}) lies outside the {}x{} grid",
                        grid.width(),
                        grid.height()
                    ),
                });
            }
            Some(c) if !c.is_free() => {
                return Err(Error::Invalid {
                    name: "goals".into(),
                    reason: format!("goal ({x}, {y}) is a wall cell"),
                });
            }
            Some(_) => {}
        }
    }
    Ok(())
}
