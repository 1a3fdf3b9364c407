//! Occupancy grids: which cells of a rectangular grid are walls.
//!
//! A grid has `width x height` cells of side `cell_size` world units; cell `(x, y)` covers
//! `origin + [x, x + 1) * cell_size` by `origin + [y, y + 1) * cell_size`. Cells are stored row by
//! row (`index = y * width + x`). Grids are built in code, parsed from ASCII maps (line 1 of the
//! file is row `y = 0`, column 1 is `x = 0`), or generated from a seed. Generation uses
//! `ChaCha8Rng`, so a seed gives the same grid on every platform.
//!
//! Invariants: `width, height >= 1`; `(width + 2) * (height + 2)` fits in a `u32` (fields index
//! cells with `u32` queues); `cell_size` is finite and positive; `origin` is finite.

use glam::Vec2;
use rand::{Rng, RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

use crate::error::{Error, Result, finite_vec, in_range, positive};

/// One cell of an [`OccupancyGrid`].
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
#[repr(u8)]
pub enum Cell {
    /// Open ground.
    #[default]
    Free = 0,
    /// An obstacle: nothing stands in or passes through it.
    Wall = 1,
}

impl Cell {
    /// Whether the cell is open ground.
    #[inline]
    #[must_use]
    pub fn is_free(self) -> bool {
        self == Cell::Free
    }
}

/// A rectangular grid of free and wall cells placed in the world.
#[derive(Clone, Debug, PartialEq)]
pub struct OccupancyGrid {
    width: u32,
    height: u32,
    cell_size: f32,
    origin: Vec2,
    cells: Vec<Cell>,
}

/// An ASCII map as parsed: the grid, its goal cells (`G`) and spawn cells (`S`), in reading order.
#[derive(Clone, Debug, PartialEq)]
pub struct MapFile {
    /// The name used in error messages (a path, or `<map>`).
    pub source_name: String,
    /// The cells; goals and spawns are free.
    pub grid: OccupancyGrid,
    /// Cells marked `G`, row by row.
    pub goals: Vec<(u32, u32)>,
    /// Cells marked `S`, row by row.
    pub spawns: Vec<(u32, u32)>,
}

impl MapFile {
    /// The goals, for callers that need at least one.
    ///
    /// # Errors
    /// [`Error::Invalid`] naming the map when it has no `G` cell.
    pub fn require_goals(&self) -> Result<&[(u32, u32)]> {
        if self.goals.is_empty() {
            Err(Error::Invalid {
                name: format!("map {}", self.source_name),
                reason: "it has no goal cell ('G')".into(),
            })
        } else {
            Ok(&self.goals)
        }
    }

    /// The spawn cells, for callers that need at least one.
    ///
    /// # Errors
    /// [`Error::Invalid`] naming the map when it has no `S` cell.
    pub fn require_spawns(&self) -> Result<&[(u32, u32)]> {
        if self.spawns.is_empty() {
            Err(Error::Invalid {
                name: format!("map {}", self.source_name),
                reason: "it has no spawn cell ('S')".into(),
            })
        } else {
            Ok(&self.spawns)
        }
    }
}

fn check_size(width: u32, height: u32) -> Result<()> {
    if width == 0 || height == 0 {
        return Err(Error::Invalid {
            name: "grid size".into(),
            reason: format!("{width}x{height} has no cells"),
        });
    }
    if u64::from(width) * u64::from(height) > crate::limits::MAX_CELLS {
        return Err(Error::Invalid {
            name: "grid size".into(),
            reason: format!(
                "{width}x{height} has too many cells (at most {})",
                crate::limits::MAX_CELLS
            ),
        });
    }
    Ok(())
}

impl OccupancyGrid {
    /// An all-free grid of `width x height` unit cells with its origin at `(0, 0)`.
    ///
    /// # Examples
    /// ```
    /// # fn main() -> throng::Result<()> {
    /// use throng::field::{Cell, OccupancyGrid};
    /// let mut grid = OccupancyGrid::new(4, 3)?;
    /// grid.set(1, 1, Cell::Wall)?;
    /// assert_eq!(grid.free_count(), 11);
    /// # Ok(()) }
    /// ```
    ///
    /// # Errors
    /// [`Error::Invalid`] when a side is zero or the grid is too large.
    pub fn new(width: u32, height: u32) -> Result<Self> {
        check_size(width, height)?;
        let n = width as usize * height as usize;
        let mut cells = Vec::new();
        crate::error::try_reserve(&mut cells, n, "field cells")?;
        cells.resize(n, Cell::Free);
        Ok(OccupancyGrid {
            width,
            height,
            cell_size: 1.0,
            origin: Vec2::ZERO,
            cells,
        })
    }

    /// A grid from row-major cells.
    ///
    /// # Errors
    /// [`Error::Invalid`] when the size is bad or `cells.len() != width * height`.
    pub fn from_cells(width: u32, height: u32, cells: Vec<Cell>) -> Result<Self> {
        check_size(width, height)?;
        if cells.len() != width as usize * height as usize {
            return Err(Error::Invalid {
                name: "cells".into(),
                reason: format!("{} cells given for a {width}x{height} grid", cells.len()),
            });
        }
        Ok(OccupancyGrid {
            width,
            height,
            cell_size: 1.0,
            origin: Vec2::ZERO,
            cells,
        })
    }

    /// The same cells with side `cell_size` and the lower corner of cell `(0, 0)` at `origin`.
    ///
    /// # Errors
    /// [`Error::NotPositive`] or [`Error::NonFinite`] for a bad size or origin.
    pub fn with_geometry(mut self, cell_size: f32, origin: Vec2) -> Result<Self> {
        self.cell_size = positive("cell size", cell_size)?;
        self.origin = finite_vec("grid origin", origin)?;
        Ok(self)
    }

    /// Number of columns.
    #[must_use]
    pub fn width(&self) -> u32 {
        self.width
    }

    /// Number of rows.
    #[must_use]
    pub fn height(&self) -> u32 {
        self.height
    }

    /// Side of a cell in world units.
    #[must_use]
    pub fn cell_size(&self) -> f32 {
        self.cell_size
    }

    /// World position of the lower corner of cell `(0, 0)`.
    #[must_use]
    pub fn origin(&self) -> Vec2 {
        self.origin
    }

    /// Number of cells, `width * height`.
    #[must_use]
    pub fn len(&self) -> usize {
        self.cells.len()
    }

    /// Always false: a grid has at least one cell.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    /// The cells, row by row.
    #[must_use]
    pub fn cells(&self) -> &[Cell] {
        &self.cells
    }

    /// Number of free cells.
    #[must_use]
    pub fn free_count(&self) -> usize {
        self.cells.iter().filter(|c| c.is_free()).count()
    }

    /// The cell at `(x, y)`, or `None` outside the grid.
    #[must_use]
    pub fn cell(&self, x: u32, y: u32) -> Option<Cell> {
        (x < self.width && y < self.height)
            .then(|| self.cells[y as usize * self.width as usize + x as usize])
    }

    /// Whether `(x, y)` lies in the grid and is free.
    #[must_use]
    pub fn is_free(&self, x: u32, y: u32) -> bool {
        self.cell(x, y).is_some_and(Cell::is_free)
    }

    /// Sets the cell at `(x, y)`.
    ///
    /// # Errors
    /// [`Error::Invalid`] when `(x, y)` lies outside the grid.
    pub fn set(&mut self, x: u32, y: u32, cell: Cell) -> Result<()> {
        self.check_cell("cell", x, y)?;
        self.cells[y as usize * self.width as usize + x as usize] = cell;
        Ok(())
    }

    /// Sets every cell of the rectangle `[x0, x1) x [y0, y1)` (clipped to the grid).
    pub fn fill_rect(&mut self, x0: u32, y0: u32, x1: u32, y1: u32, cell: Cell) {
        let w = self.width as usize;
        for y in y0.min(self.height)..y1.min(self.height) {
            let row = y as usize * w;
            self.cells[row + x0.min(self.width) as usize..row + x1.min(self.width) as usize]
                .fill(cell);
        }
    }

    /// Checks that `(x, y)` lies in the grid.
    ///
    /// # Errors
    /// [`Error::Invalid`] naming `name` when it does not.
    pub fn check_cell(&self, name: &str, x: u32, y: u32) -> Result<()> {
        if x < self.width && y < self.height {
            Ok(())
        } else {
            Err(Error::Invalid {
                name: name.into(),
                reason: format!(
                    "({x}, {y}) lies outside the {}x{} grid",
                    self.width, self.height
                ),
            })
        }
    }

    /// The cell containing world point `p`, or `None` when `p` lies outside the grid or is not
    /// finite. Cell edges belong to the cell above and to the right.
    #[must_use]
    pub fn world_to_cell(&self, p: Vec2) -> Option<(u32, u32)> {
        cell_of(self, p).map(|(x, y)| (x as u32, y as u32))
    }

    /// The grid with every free cell whose centre lies within `clearance` (world units) of a
    /// wall cell or of the grid's border turned into a wall: a navigation grid whose paths keep
    /// that far from walls (a disc of that radius fits along them). Linear in the cells times
    /// `(clearance / cell_size)^2`.
    ///
    /// # Examples
    /// ```
    /// # fn main() -> throng::Result<()> {
    /// use throng::field::OccupancyGrid;
    /// let map = OccupancyGrid::parse_ascii(".....\n.....\n..#..\n", "<map>")?;
    /// let wide = map.grid.dilated(0.5)?;
    /// // Cells next to the wall and to the border (their centres 0.5 away) are blocked; the
    /// // wall's diagonal neighbours (0.71 away) stay free.
    /// assert!(!wide.is_free(2, 1) && !wide.is_free(0, 0) && !wide.is_free(3, 2));
    /// assert!(wide.is_free(1, 1) && wide.is_free(3, 1));
    /// assert_eq!(wide.free_count(), 2);
    /// # Ok(()) }
    /// ```
    ///
    /// # Errors
    /// [`Error::OutOfRange`] for a clearance that is negative, not finite or more than 64
    /// cells.
    pub fn dilated(&self, clearance: f32) -> Result<OccupancyGrid> {
        let near = self.near_walls(clearance)?;
        let mut out = self.clone();
        for (cell, near) in out.cells.iter_mut().zip(near) {
            if near {
                *cell = Cell::Wall;
            }
        }
        Ok(out)
    }

    /// Per cell (row-major), whether it is a free cell whose centre lies within `clearance`
    /// (world units) of a wall cell or of the grid's border: the cells that
    /// [`OccupancyGrid::dilated`] turns into walls.
    ///
    /// # Errors
    /// As [`OccupancyGrid::dilated`].
    pub fn near_walls(&self, clearance: f32) -> Result<Vec<bool>> {
        in_range(
            "field.clearance / field.cell_size",
            clearance / self.cell_size,
            0.0,
            64.0,
            "[0, 64] cells",
        )?;
        let mut out = vec![false; self.cells.len()];
        if clearance <= 0.0 {
            return Ok(out);
        }
        let cs = self.cell_size;
        let k = (clearance / cs).ceil() as i64;
        let (w, h) = (i64::from(self.width), i64::from(self.height));
        // Distance from a cell centre to a cell `d` cells away along one axis (0 for itself).
        let gap = |d: i64| ((d.abs() as f32) * cs - 0.5 * cs).max(0.0);
        let near = |dx: i64, dy: i64| gap(dx).hypot(gap(dy)) <= clearance;
        for y in 0..h {
            for x in 0..w {
                if !self.cells[(y * w + x) as usize].is_free() {
                    continue;
                }
                // The border counts as wall beyond the grid.
                let to_border = (x.min(w - 1 - x).min(y).min(h - 1 - y)) as f32 * cs + 0.5 * cs;
                let mut blocked = to_border <= clearance;
                'search: for dy in -k..=k {
                    for dx in -k..=k {
                        if blocked {
                            break 'search;
                        }
                        let (nx, ny) = (x + dx, y + dy);
                        if (0..w).contains(&nx)
                            && (0..h).contains(&ny)
                            && !self.cells[(ny * w + nx) as usize].is_free()
                            && near(dx, dy)
                        {
                            blocked = true;
                        }
                    }
                }
                out[(y * w + x) as usize] = blocked;
            }
        }
        Ok(out)
    }

    /// World position of the centre of cell `(x, y)` (not checked against the grid).
    #[must_use]
    pub fn cell_center(&self, x: u32, y: u32) -> Vec2 {
        self.origin + (Vec2::new(x as f32, y as f32) + 0.5) * self.cell_size
    }

    /// Parses an ASCII map: `#` wall, `.` free, `G` goal, `S` spawn, one text line per row, all
    /// rows equally long. Line 1 is row `y = 0`. Trailing empty lines and `\r\n` endings are
    /// accepted. Unit cells, origin `(0, 0)`.
    ///
    /// # Examples
    /// ```
    /// # fn main() -> throng::Result<()> {
    /// use throng::field::OccupancyGrid;
    /// let map = OccupancyGrid::parse_ascii("S.#\n..G\n", "<map>")?;
    /// assert_eq!((map.grid.width(), map.grid.height()), (3, 2));
    /// assert_eq!(map.goals, vec![(2, 1)]);
    /// assert_eq!(map.spawns, vec![(0, 0)]);
    /// # Ok(()) }
    /// ```
    ///
    /// # Errors
    /// [`Error::MapParse`] with the 1-based line and column of an unknown character, of a row
    /// whose length differs from the first row's, or line 1 column 1 for an empty map.
    pub fn parse_ascii(text: &str, source_name: &str) -> Result<MapFile> {
        let err = |line: usize, column: usize, message: String| Error::MapParse {
            source_name: source_name.to_string(),
            line,
            column,
            message,
        };
        let mut lines: Vec<&str> = text
            .split('\n')
            .map(|l| l.strip_suffix('\r').unwrap_or(l))
            .collect();
        while lines.last().is_some_and(|l| l.is_empty()) {
            lines.pop();
        }
        if lines.is_empty() {
            return Err(err(1, 1, "the map is empty".into()));
        }
        let width = lines[0].chars().count();
        let height = lines.len();
        if width > u32::MAX as usize || height > u32::MAX as usize {
            return Err(err(
                1,
                1,
                format!("the map is too large ({width}x{height})"),
            ));
        }
        let mut cells = Vec::with_capacity(width * height);
        let (mut goals, mut spawns) = (Vec::new(), Vec::new());
        for (y, line) in lines.iter().enumerate() {
            let mut count = 0;
            for (x, ch) in line.chars().enumerate() {
                if x >= width {
                    return Err(err(
                        y + 1,
                        x + 1,
                        format!("row {} is longer than the first row ({width} cells)", y + 1),
                    ));
                }
                let cell = match ch {
                    '#' => Cell::Wall,
                    '.' => Cell::Free,
                    'G' => {
                        goals.push((x as u32, y as u32));
                        Cell::Free
                    }
                    'S' => {
                        spawns.push((x as u32, y as u32));
                        Cell::Free
                    }
                    other => {
                        return Err(err(
                            y + 1,
                            x + 1,
                            format!(
                                "unexpected character {other:?} (expected '#', '.', 'G' or 'S')"
                            ),
                        ));
                    }
                };
                cells.push(cell);
                count += 1;
            }
            if count < width {
                return Err(err(
                    y + 1,
                    count + 1,
                    format!(
                        "row {} has {count} cells but the first row has {width}",
                        y + 1
                    ),
                ));
            }
        }
        let grid = OccupancyGrid::from_cells(width as u32, height as u32, cells)
            .map_err(|e| err(1, 1, e.to_string()))?;
        Ok(MapFile {
            source_name: source_name.to_string(),
            grid,
            goals,
            spawns,
        })
    }

    /// Reads and parses an ASCII map file (see [`OccupancyGrid::parse_ascii`]) of at most
    /// [`MAX_MAP_BYTES`](crate::limits::MAX_MAP_BYTES); larger files are refused before they
    /// are read, endless ones (`/dev/zero`) after that many bytes.
    ///
    /// # Errors
    /// [`Error::Io`] when the file cannot be read, else as [`OccupancyGrid::parse_ascii`].
    pub fn load_ascii(path: impl AsRef<std::path::Path>) -> Result<MapFile> {
        let path = path.as_ref();
        let text = crate::limits::read_text(path, crate::limits::MAX_MAP_BYTES, "map files")?;
        Self::parse_ascii(&text, &path.display().to_string())
    }

    /// The grid as an ASCII map (the inverse of [`OccupancyGrid::parse_ascii`]); `goals` are
    /// drawn as `G`, `spawns` as `S`. Cells outside the grid are ignored.
    #[must_use]
    pub fn to_ascii(&self, goals: &[(u32, u32)], spawns: &[(u32, u32)]) -> String {
        let w = self.width as usize;
        let mut chars: Vec<u8> = self
            .cells
            .iter()
            .map(|c| if c.is_free() { b'.' } else { b'#' })
            .collect();
        for (list, mark) in [(spawns, b'S'), (goals, b'G')] {
            for &(x, y) in list {
                if x < self.width && y < self.height {
                    chars[y as usize * w + x as usize] = mark;
                }
            }
        }
        let mut out = String::with_capacity(chars.len() + self.height as usize);
        for row in chars.chunks_exact(w) {
            out.extend(row.iter().map(|&b| b as char));
            out.push('\n');
        }
        out
    }

    /// An all-wall grid to carve from, how many cells to free for `obstacle_fraction`, and the
    /// seeded generator.
    fn solid(
        width: u32,
        height: u32,
        obstacle_fraction: f32,
        seed: u64,
    ) -> Result<(Self, usize, ChaCha8Rng)> {
        let fraction = check_fraction(obstacle_fraction)?;
        let mut grid = OccupancyGrid::new(width, height)?;
        grid.cells.fill(Cell::Wall);
        let n = grid.cells.len();
        let target = ((1.0 - f64::from(fraction)) * n as f64)
            .round()
            .clamp(1.0, n as f64) as usize;
        Ok((grid, target, ChaCha8Rng::seed_from_u64(seed)))
    }

    /// A cave: all walls, then a seeded drunkard's walk from the centre carves free cells (one
    /// 4-connected region, so every free cell reaches every other) until
    /// `round((1 - obstacle_fraction) * cells)` cells (at least one) are free. When the walk has
    /// gone 64 steps without carving it jumps to a carved cell next to a wall, so the cost stays
    /// linear in the cells carved (a plain walk needs about `n log^2 n` steps to cover `n` cells).
    ///
    /// # Errors
    /// [`Error::Invalid`] for a bad size; [`Error::NonFinite`] or [`Error::OutOfRange`] unless
    /// `obstacle_fraction` lies in `[0, 1)`.
    pub fn caves(width: u32, height: u32, obstacle_fraction: f32, seed: u64) -> Result<Self> {
        let (mut grid, target, mut rng) = Self::solid(width, height, obstacle_fraction, seed)?;
        let (w, h) = (width as usize, height as usize);
        let (mut x, mut y) = (w / 2, h / 2);
        grid.cells[y * w + x] = Cell::Free;
        let mut frontier = Frontier::new(y * w + x, target)?;
        let mut carved = 1;
        let mut bits = 0u64;
        let mut left = 0;
        let mut idle = 0;
        while carved < target {
            if idle == 64 {
                let c = frontier.pick(&grid, &mut rng);
                (x, y) = (c % w, c / w);
                idle = 0;
            }
            if left == 0 {
                bits = rng.next_u64();
                left = 32;
            }
            (x, y) = step(bits, x, y, w, h);
            bits >>= 2;
            left -= 1;
            idle += 1;
            let c = &mut grid.cells[y * w + x];
            if *c == Cell::Wall {
                *c = Cell::Free;
                carved += 1;
                frontier.cells.push((y * w + x) as u32);
                idle = 0;
            }
        }
        Ok(grid)
    }

    /// Branching tunnels: all walls, then short seeded drunkard's walks (32 steps each,
    /// 4-connected), each starting from a random carved cell next to a wall, until
    /// `round((1 - obstacle_fraction) * cells)` cells (at least one) are free. Every walk starts
    /// on carved ground, so the free cells form one 4-connected region, as with
    /// [`OccupancyGrid::caves`], and the cost is linear in the cells carved (a 8192 x 8192 grid
    /// in about a second).
    ///
    /// # Examples
    /// ```
    /// # fn main() -> throng::Result<()> {
    /// use throng::field::OccupancyGrid;
    /// let grid = OccupancyGrid::tunnels(100, 80, 0.85, 3)?;
    /// assert_eq!(grid.free_count(), 1200);
    /// # Ok(()) }
    /// ```
    ///
    /// # Errors
    /// As [`OccupancyGrid::caves`].
    pub fn tunnels(width: u32, height: u32, obstacle_fraction: f32, seed: u64) -> Result<Self> {
        let (mut grid, target, mut rng) = Self::solid(width, height, obstacle_fraction, seed)?;
        let (w, h) = (width as usize, height as usize);
        let centre = (h / 2) * w + w / 2;
        grid.cells[centre] = Cell::Free;
        let mut frontier = Frontier::new(centre, target)?;
        let mut carved = 1;
        while carved < target {
            let start = frontier.pick(&grid, &mut rng);
            let (mut x, mut y) = (start % w, start / w);
            let mut bits = rng.next_u64();
            for _ in 0..32 {
                (x, y) = step(bits, x, y, w, h);
                bits >>= 2;
                let c = &mut grid.cells[y * w + x];
                if *c == Cell::Wall {
                    *c = Cell::Free;
                    frontier.cells.push((y * w + x) as u32);
                    carved += 1;
                    if carved == target {
                        break;
                    }
                }
            }
        }
        Ok(grid)
    }

    /// Open ground with scattered obstacles: each cell is a wall with probability
    /// `obstacle_fraction`, independently. Fast at any size, but the free space need not be
    /// connected (it mostly is below a fraction of about 0.4).
    ///
    /// # Errors
    /// As [`OccupancyGrid::caves`].
    pub fn scattered(width: u32, height: u32, obstacle_fraction: f32, seed: u64) -> Result<Self> {
        let fraction = check_fraction(obstacle_fraction)?;
        let mut grid = OccupancyGrid::new(width, height)?;
        let threshold = (f64::from(fraction) * 4_294_967_296.0) as u64;
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        for c in &mut grid.cells {
            if u64::from(rng.next_u32()) < threshold {
                *c = Cell::Wall;
            }
        }
        Ok(grid)
    }
}

/// One step of a 4-connected walk by the low two bits of `bits`, clamped to the grid.
fn step(bits: u64, x: usize, y: usize, w: usize, h: usize) -> (usize, usize) {
    match bits & 3 {
        0 => ((x + 1).min(w - 1), y),
        1 => (x.saturating_sub(1), y),
        2 => (x, (y + 1).min(h - 1)),
        _ => (x, y.saturating_sub(1)),
    }
}

/// Carved cells that may still touch a wall: where walks start. Cells found with no wall left
/// among their 4 neighbours are dropped when drawn (walls only ever become free, so they never
/// qualify again), which keeps the whole carving linear in the cells carved.
struct Frontier {
    cells: Vec<u32>,
}

impl Frontier {
    fn new(first: usize, target: usize) -> Result<Self> {
        let mut cells = Vec::new();
        crate::error::try_reserve(&mut cells, target, "carved cells")?;
        cells.push(first as u32);
        Ok(Frontier { cells })
    }

    /// A random carved cell with a wall among its 4 neighbours. One exists while fewer cells
    /// are carved than the grid has, since the carved region is connected.
    fn pick(&mut self, grid: &OccupancyGrid, rng: &mut ChaCha8Rng) -> usize {
        let (w, h) = (grid.width as usize, grid.height as usize);
        loop {
            let k = rng.random_range(0..self.cells.len());
            let c = self.cells[k] as usize;
            let (x, y) = (c % w, c / w);
            let wall = |xx: usize, yy: usize| grid.cells[yy * w + xx] == Cell::Wall;
            if (x + 1 < w && wall(x + 1, y))
                || (x > 0 && wall(x - 1, y))
                || (y + 1 < h && wall(x, y + 1))
                || (y > 0 && wall(x, y - 1))
            {
                return c;
            }
            self.cells.swap_remove(k);
        }
    }
}

fn check_fraction(f: f32) -> Result<f32> {
    in_range("obstacle fraction", f, 0.0, 1.0, "[0, 1)")?;
    if f >= 1.0 {
        return Err(Error::OutOfRange {
            name: "obstacle fraction",
            value: f64::from(f),
            range: "[0, 1)",
        });
    }
    Ok(f)
}

/// `n` distinct free cells of `grid`, drawn uniformly with a `ChaCha8Rng` seeded by `seed` (for
/// goals and spawn points; the same seed gives the same cells on every platform).
///
/// # Examples
/// ```
/// # fn main() -> throng::Result<()> {
/// use throng::field::{OccupancyGrid, random_free_cells};
/// let grid = OccupancyGrid::caves(64, 64, 0.5, 7)?;
/// let goals = random_free_cells(&grid, 4, 1)?;
/// assert!(goals.iter().all(|&(x, y)| grid.is_free(x, y)));
/// # Ok(()) }
/// ```
///
/// # Errors
/// [`Error::Invalid`] when the grid has fewer than `n` free cells.
pub fn random_free_cells(grid: &OccupancyGrid, n: usize, seed: u64) -> Result<Vec<(u32, u32)>> {
    let mut free: Vec<u32> = grid
        .cells
        .iter()
        .enumerate()
        .filter(|(_, c)| c.is_free())
        .map(|(i, _)| i as u32)
        .collect();
    if n > free.len() {
        return Err(Error::Invalid {
            name: "n".into(),
            reason: format!(
                "{n} free cells requested but the grid has only {}",
                free.len()
            ),
        });
    }
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    for i in 0..n {
        let j = rng.random_range(i..free.len());
        free.swap(i, j);
    }
    let w = grid.width;
    Ok(free[..n].iter().map(|&i| (i % w, i / w)).collect())
}

/// The cell of continuous cell coordinates `u` in a `width x height` grid: cell `(x, y)` spans
/// `[x, x + 1)`, except that the far edges (`u.x == width`, `u.y == height`) belong to the last
/// column and row, so that an agent clamped onto a walled world's far edge stays on the grid.
/// `None` outside the grid or for a non-finite `u`.
#[inline]
pub(crate) fn cell_coords(u: Vec2, width: usize, height: usize) -> Option<(usize, usize)> {
    if !(u.x >= 0.0 && u.y >= 0.0 && u.x <= width as f32 && u.y <= height as f32) {
        return None;
    }
    // Truncation is the floor for non-negative values; the far edge maps to the last cell.
    Some((
        (u.x as usize).min(width - 1),
        (u.y as usize).min(height - 1),
    ))
}

/// The cell of world point `p` on `grid` as `(column, row)`, as [`cell_coords`] places it.
#[inline]
pub(crate) fn cell_of(grid: &OccupancyGrid, p: Vec2) -> Option<(usize, usize)> {
    let u = (p - grid.origin()) / grid.cell_size();
    cell_coords(u, grid.width() as usize, grid.height() as usize)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parse_reports_unknown_characters_with_position() {
        let e = OccupancyGrid::parse_ascii("..#\n.x.\n", "m.txt").unwrap_err();
        match e {
            Error::MapParse {
                source_name,
                line,
                column,
                ..
            } => assert_eq!((source_name.as_str(), line, column), ("m.txt", 2, 2)),
            other => panic!("{other:?}"),
        }
    }

    #[test]
    fn ascii_round_trips() {
        let text = "S.#\n#.G\n...\n";
        let map = OccupancyGrid::parse_ascii(text, "<map>").unwrap();
        assert_eq!(map.grid.to_ascii(&map.goals, &map.spawns), text);
    }

    #[test]
    fn caves_hit_the_free_share_and_are_connected() {
        let g = OccupancyGrid::caves(50, 40, 0.7, 3).unwrap();
        assert_eq!(g.free_count(), 600);
        assert_eq!(g, OccupancyGrid::caves(50, 40, 0.7, 3).unwrap());
    }
}
