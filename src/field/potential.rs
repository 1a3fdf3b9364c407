//! BFS potential fields with decay: the field of the "many agents, many goals" notes.
//!
//! The build is exactly that algorithm: a FIFO queue; every goal cell gets potential 1 and is
//! queued; each popped cell gives every unset free neighbour `current * decay` and queues it. All
//! goals go in one pass, so a cell's potential is `decay` multiplied by itself once per step to its
//! *nearest* goal (repeated multiplication, not `powi`), and a multi-goal field is the maximum of
//! the single-goal fields. The queue never holds more entries than the grid has free cells.
//!
//! Besides the potential, the field keeps each cell's step count to the nearest goal. The two
//! orders agree (fewer steps never means less energy), and steps stay exact where `f32`
//! potentials underflow far from the goals, so climbing ("move to the neighbour with the most
//! energy, higher than your own") compares step counts, with ties broken by the fixed neighbour
//! order of [`DIRECTIONS`](super::DIRECTIONS).
//!
//! Cells no goal can reach, and walls, hold [`PotentialField::UNREACHABLE`] (`-1.0`), never a
//! potential a reachable cell could have.
//!
//! [`PotentialField::bfs`] and [`PotentialField::rebuild`] compute exactly that field faster (a
//! search over two-byte step counts in a strip layout, widened to `u32` when the levels outgrow
//! them, potentials derived afterwards from a table of the same repeated products);
//! [`PotentialField::bfs_reference`] is the literal algorithm, kept so tests can check the two
//! agree bit for bit. Results do not depend on the number of threads: only the fill and the
//! derive passes run in parallel, each cell written from its own inputs.

use super::lattice::{DIAGONAL_SIDES, Lattice, Neighbourhood, check_goals, padded_map};
use super::occupancy::OccupancyGrid;
use crate::error::{Error, Result, finite};

/// Step count of a wall (and of the padding border).
pub(crate) const WALL: u32 = u32::MAX;
/// Step count of a free cell no goal reaches.
pub(crate) const UNSET: u32 = u32::MAX - 1;

/// A grid potential field built by breadth-first search from a set of goal cells.
#[derive(Clone, Debug, PartialEq)]
pub struct PotentialField {
    pub(crate) lattice: Lattice,
    pub(crate) neighbourhood: Neighbourhood,
    decay: f32,
    /// Padded potentials.
    potential: Vec<f32>,
    /// Padded step counts, or `WALL` / `UNSET`.
    pub(crate) steps: Vec<u32>,
    reachable: usize,
    /// Buffers of the search, kept for [`PotentialField::rebuild`].
    scratch: Scratch,
}

/// The search's reusable buffers. Not part of a field's value: every two compare equal.
#[derive(Clone, Debug, Default)]
struct Scratch {
    /// Padded search cells (see [`StepCell`]), while the step counts fit in a `u16`.
    state: Vec<u16>,
    /// The FIFO, a ring of power-of-two length.
    ring: Vec<u32>,
    /// `decay` multiplied by itself once per step: `table[s]` is the potential at `s` steps.
    table: Vec<f32>,
}

impl PartialEq for Scratch {
    fn eq(&self, _: &Self) -> bool {
        true
    }
}

/// Padded rows per parallel task of the derived passes.
const ROWS_PER_TASK: usize = 16;

/// Checks a decay factor: finite and strictly between 0 and 1.
pub(crate) fn check_decay(decay: f32) -> Result<f32> {
    finite("decay", decay)?;
    if decay <= 0.0 || decay >= 1.0 {
        return Err(Error::OutOfRange {
            name: "decay",
            value: f64::from(decay),
            range: "(0, 1)",
        });
    }
    Ok(decay)
}

impl PotentialField {
    /// Potential of walls and of cells no goal can reach.
    pub const UNREACHABLE: f32 = -1.0;

    /// Builds the field of `goals` on `grid`: potential 1 at every goal, times `decay` per step.
    /// Duplicate goals are harmless.
    ///
    /// The result is the classic multi-goal BFS's (see [`PotentialField::bfs_reference`]), bit for
    /// bit; see the module docs for how it is computed.
    ///
    /// # Examples
    /// ```
    /// # fn main() -> throng::Result<()> {
    /// use throng::field::{Neighbourhood, OccupancyGrid, PotentialField};
    /// let map = OccupancyGrid::parse_ascii("G..\n.#.\n...\n", "<map>")?;
    /// let field = PotentialField::bfs(&map.grid, &map.goals, 0.5, Neighbourhood::Four)?;
    /// assert_eq!(field.potential(2, 0), Some(0.25));
    /// assert_eq!(field.potential(2, 2), Some(0.0625));
    /// assert_eq!(field.potential(1, 1), None); // a wall
    /// # Ok(()) }
    /// ```
    ///
    /// # Errors
    /// [`Error::NonFinite`] or [`Error::OutOfRange`] unless `decay` lies in `(0, 1)`;
    /// [`Error::Invalid`] when `goals` is empty or a goal is outside the grid or on a wall.
    pub fn bfs(
        grid: &OccupancyGrid,
        goals: &[(u32, u32)],
        decay: f32,
        neighbourhood: Neighbourhood,
    ) -> Result<Self> {
        let decay = check_decay(decay)?;
        check_goals(grid, goals)?;
        let mut field = PotentialField {
            lattice: Lattice::of(grid),
            neighbourhood,
            decay,
            potential: Vec::new(),
            steps: Vec::new(),
            reachable: 0,
            scratch: Scratch::default(),
        };
        field.search(grid, goals);
        Ok(field)
    }

    /// Rebuilds the field in place for `goals` on `grid` (which may differ from the grid it was
    /// built on, in walls or in size), with the same decay and neighbourhood, reusing its
    /// buffers. The result equals a fresh [`PotentialField::bfs`].
    ///
    /// # Examples
    /// ```
    /// # fn main() -> throng::Result<()> {
    /// use throng::field::{Neighbourhood, OccupancyGrid, PotentialField};
    /// let map = OccupancyGrid::parse_ascii("G..\n...\n", "<map>")?;
    /// let mut field = PotentialField::bfs(&map.grid, &map.goals, 0.5, Neighbourhood::Four)?;
    /// field.rebuild(&map.grid, &[(2, 1)])?;
    /// assert_eq!(field.steps(0, 0), Some(3));
    /// # Ok(()) }
    /// ```
    ///
    /// # Errors
    /// [`Error::Invalid`] as [`PotentialField::bfs`] for bad goals; the field is then unchanged.
    pub fn rebuild(&mut self, grid: &OccupancyGrid, goals: &[(u32, u32)]) -> Result<()> {
        check_goals(grid, goals)?;
        self.lattice = Lattice::of(grid);
        self.search(grid, goals);
        Ok(())
    }

    /// The reference build: the classic multi-goal BFS literally, each popped cell giving
    /// `current * decay` to every unset free neighbour, with fresh buffers. Slower than
    /// [`PotentialField::bfs`], which must return the same field; kept for tests to compare
    /// against.
    ///
    /// # Errors
    /// As [`PotentialField::bfs`].
    pub fn bfs_reference(
        grid: &OccupancyGrid,
        goals: &[(u32, u32)],
        decay: f32,
        neighbourhood: Neighbourhood,
    ) -> Result<Self> {
        let decay = check_decay(decay)?;
        check_goals(grid, goals)?;
        let lattice = Lattice::of(grid);
        let mut steps = padded_map(grid, &lattice, UNSET, WALL);
        let mut potential = vec![Self::UNREACHABLE; lattice.len];
        // Every cell is queued at most once, so the free-cell count bounds the queue.
        let mut queue: Vec<u32> = Vec::with_capacity(grid.free_count());
        for &(x, y) in goals {
            let p = lattice.index(x, y);
            if steps[p] == UNSET {
                steps[p] = 0;
                potential[p] = 1.0;
                queue.push(p as u32);
            }
        }
        match neighbourhood {
            Neighbourhood::Four => bfs4(&lattice, decay, &mut steps, &mut potential, &mut queue),
            Neighbourhood::Eight => bfs8(&lattice, decay, &mut steps, &mut potential, &mut queue),
        }
        let reachable = queue.len();
        Ok(PotentialField {
            lattice,
            neighbourhood,
            decay,
            potential,
            steps,
            reachable,
            scratch: Scratch::default(),
        })
    }

    /// The build behind [`PotentialField::bfs`] and [`PotentialField::rebuild`] (goals checked,
    /// `self.lattice` set to `grid`'s).
    ///
    /// It finds the same step counts as the reference in three passes: a parallel fill of a
    /// two-byte search cell per cell (`FREE`, `BLOCKED`, or a step count), laid out in
    /// 64-column strips (see [`Strips`]); a level-by-level FIFO search over those cells with a
    /// small ring that sets a neighbour's step count as it queues it (branch-free: a neighbour
    /// is always written at the tail, which advances only when the neighbour was free),
    /// touching no other array; and a parallel pass that widens the cells to the row-major
    /// `u32` step counts (`UNSET`, `WALL`) and derives every potential through a table of
    /// repeated products, so each value is bit for bit the reference's `current * decay`
    /// chain. When the levels outgrow a `u16`, the search starts again on `u32` cells.
    fn search(&mut self, grid: &OccupancyGrid, goals: &[(u32, u32)]) {
        let l = self.lattice;
        let strips = Strips::of(&l);
        let Scratch { state, ring, table } = &mut self.scratch;
        if ring.len() < 1024 {
            *ring = vec![0; 1024];
        }
        let eight = self.neighbourhood == Neighbourhood::Eight;
        fill_state(grid, &strips, state);
        let found = run_search(&strips, eight, state, ring, goals);
        let mut wide = Vec::new();
        let (levels, reached) = match found {
            Some(found) => found,
            None => {
                // More levels than a `u16` holds: search again on `u32` cells.
                fill_state(grid, &strips, &mut wide);
                run_search(&strips, eight, &mut wide, ring, goals)
                    .expect("a u32 step count holds every level")
            }
        };
        self.reachable = reached;
        table.clear();
        let mut v = 1.0_f32;
        for _ in 0..levels {
            table.push(v);
            v *= self.decay;
        }
        // Fresh buffers come zeroed from the allocator; every cell is written below.
        if self.potential.len() != l.len {
            self.potential = vec![0.0; l.len];
        }
        if self.steps.len() != l.len {
            self.steps = vec![0; l.len];
        }
        if found.is_some() {
            table.resize(1 << 16, Self::UNREACHABLE);
            let table: &[f32; 1 << 16] = table[..].try_into().expect("a table of every u16");
            derive(&strips, state, &mut self.steps, &mut self.potential, |c| {
                // `FREE` and `BLOCKED` widen to `UNSET` and `WALL`.
                let c32 = u32::from(c);
                let s = if c >= <u16 as StepCell>::FREE {
                    c32 | 0xFFFF_0000
                } else {
                    c32
                };
                (s, table[usize::from(c)])
            });
        } else {
            derive(&strips, &wide, &mut self.steps, &mut self.potential, |c| {
                let v = if c >= UNSET {
                    Self::UNREACHABLE
                } else {
                    table[c as usize]
                };
                (c, v)
            });
        }
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

    /// The decay factor per step.
    #[must_use]
    pub fn decay(&self) -> f32 {
        self.decay
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

    /// The potential of `(x, y)`: `None` outside the grid, on walls and where no goal reaches.
    /// Far from the goals it may underflow to zero; [`PotentialField::steps`] stays exact.
    #[must_use]
    pub fn potential(&self, x: u32, y: u32) -> Option<f32> {
        let p = self.lattice.checked_index(x, y)?;
        (self.steps[p] < UNSET).then_some(self.potential[p])
    }

    /// Steps from `(x, y)` to its nearest goal (0 on a goal): `None` outside the grid, on walls
    /// and where no goal reaches.
    #[must_use]
    pub fn steps(&self, x: u32, y: u32) -> Option<u32> {
        let p = self.lattice.checked_index(x, y)?;
        let s = self.steps[p];
        (s < UNSET).then_some(s)
    }

    /// Whether a goal can be reached from `(x, y)`.
    #[must_use]
    pub fn is_reachable(&self, x: u32, y: u32) -> bool {
        self.steps(x, y).is_some()
    }

    /// Whether `(x, y)` is a goal.
    #[must_use]
    pub fn is_goal(&self, x: u32, y: u32) -> bool {
        self.steps(x, y) == Some(0)
    }

    /// Row `y`'s potentials, [`PotentialField::UNREACHABLE`] where no goal reaches.
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
        &self.potential[self.lattice.row_range(y)]
    }

    /// All potentials, row by row (`index = y * width + x`).
    #[must_use]
    pub fn to_vec(&self) -> Vec<f32> {
        (0..self.lattice.height)
            .flat_map(|y| self.row(y).iter().copied())
            .collect()
    }

    /// The neighbour an agent on `(x, y)` climbs to: among the neighbours it may step to (no
    /// corner cutting), the one with the most energy, which must be more than its own; ties go to
    /// the first in neighbour order. `None` on goals, walls, unreachable cells and outside.
    #[must_use]
    pub fn best_neighbour(&self, x: u32, y: u32) -> Option<(u32, u32)> {
        let p = self.lattice.checked_index(x, y)?;
        if self.steps[p] >= UNSET {
            return None;
        }
        self.best_from(p, |_| true).map(|q| self.lattice.coords(q))
    }

    /// The best allowed neighbour of padded cell `p` with fewer steps than `p` for which
    /// `accept` holds (see [`PotentialField::best_neighbour`]).
    #[inline]
    pub(crate) fn best_from(&self, p: usize, accept: impl Fn(usize) -> bool) -> Option<usize> {
        let own = self.steps[p];
        let mut best: Option<(u32, usize)> = None;
        for k in 0..self.neighbourhood.count() {
            let q = self.lattice.step(p, k);
            let s = self.steps[q];
            if s >= own || s >= UNSET || best.is_some_and(|(b, _)| s >= b) {
                continue;
            }
            if k >= 4 {
                let (a, b) = DIAGONAL_SIDES[k - 4];
                if self.steps[self.lattice.step(p, a)] == WALL
                    || self.steps[self.lattice.step(p, b)] == WALL
                {
                    continue;
                }
            }
            if accept(q) {
                best = Some((s, q));
            }
        }
        best.map(|(_, q)| q)
    }
}

/// A search cell: a step count, or [`StepCell::FREE`] (not reached yet) or
/// [`StepCell::BLOCKED`] (a wall, the border, or a column past the border).
trait StepCell: Copy + Eq + Send + Sync {
    /// Not reached yet; also the first step count the type cannot hold.
    const FREE: Self;
    /// A wall or the border.
    const BLOCKED: Self;
    /// Step count 0.
    const ZERO: Self;
    /// The next step count (at most `FREE`).
    fn succ(self) -> Self;
    /// As a `u32`.
    fn get(self) -> u32;
}

impl StepCell for u16 {
    const FREE: Self = u16::MAX - 1;
    const BLOCKED: Self = u16::MAX;
    const ZERO: Self = 0;
    #[inline]
    fn succ(self) -> Self {
        self + 1
    }
    #[inline]
    fn get(self) -> u32 {
        u32::from(self)
    }
}

impl StepCell for u32 {
    const FREE: Self = UNSET;
    const BLOCKED: Self = WALL;
    const ZERO: Self = 0;
    #[inline]
    fn succ(self) -> Self {
        self + 1
    }
    #[inline]
    fn get(self) -> u32 {
        self
    }
}

/// Columns per strip of the search layout (a power of two).
const STRIP: usize = 64;

/// The search's cell layout: the padded grid cut into vertical strips of [`STRIP`] columns
/// (the last one filled up with blocked columns), each stored row after row. A 4 KiB page of
/// two-byte cells then holds a 64 x 32 block instead of two rows, so a BFS frontier, which
/// crosses many rows, touches far fewer pages per level than in the row-major layout.
#[derive(Clone, Copy, Debug)]
struct Strips {
    /// Padded columns (`width + 2`).
    stride: usize,
    /// Padded rows (`height + 2`).
    rows: usize,
    /// Number of strips.
    count: usize,
    /// Cells per strip (`rows * STRIP`).
    len: usize,
}

impl Strips {
    fn of(l: &Lattice) -> Self {
        let rows = l.len / l.stride;
        Strips {
            stride: l.stride,
            rows,
            count: l.stride.div_ceil(STRIP),
            len: rows * STRIP,
        }
    }

    /// Index of padded column `px`, row `py`.
    #[inline]
    fn at(&self, px: usize, py: usize) -> usize {
        (px / STRIP) * self.len + py * STRIP + px % STRIP
    }

    /// The cell right of `p`.
    #[inline]
    fn right(&self, p: usize) -> usize {
        if p % STRIP == STRIP - 1 {
            p + self.len - (STRIP - 1)
        } else {
            p + 1
        }
    }

    /// The cell left of `p`.
    #[inline]
    fn left(&self, p: usize) -> usize {
        if p.is_multiple_of(STRIP) {
            p - self.len + (STRIP - 1)
        } else {
            p - 1
        }
    }
}

/// Fills `state` with the cells of `grid` in the strip layout: `BLOCKED` on walls, the border
/// and past it, `FREE` elsewhere (parallel over strips).
fn fill_state<T: StepCell>(grid: &OccupancyGrid, s: &Strips, state: &mut Vec<T>) {
    use rayon::prelude::*;
    let total = s.count * s.len;
    if state.len() != total {
        // Zeroed pages from the allocator, first touched by the parallel fill below, which
        // writes every cell.
        *state = vec![T::ZERO; total];
    }
    let w = s.stride - 2;
    let cells = grid.cells();
    state
        .par_chunks_mut(s.len)
        .enumerate()
        .for_each(|(strip, lines)| {
            // Padded columns `x0..x1` of this strip hold grid columns `x0 - 1..x1 - 1`.
            let x0 = (strip * STRIP).max(1);
            let x1 = ((strip + 1) * STRIP).min(w + 1);
            let first = x0 - strip * STRIP;
            for (py, line) in lines.chunks_mut(STRIP).enumerate() {
                if py == 0 || py + 1 == s.rows || x0 >= x1 {
                    line.fill(T::BLOCKED);
                    continue;
                }
                line[..first].fill(T::BLOCKED);
                let row = &cells[(py - 1) * w + x0 - 1..(py - 1) * w + x1 - 1];
                for (o, c) in line[first..first + row.len()].iter_mut().zip(row) {
                    *o = if c.is_free() { T::FREE } else { T::BLOCKED };
                }
                line[first + row.len()..].fill(T::BLOCKED);
            }
        });
}

/// Queues the goals (step count 0) and runs the search. Returns the number of levels and of
/// cells reached, or `None` when the levels outgrow `T`.
fn run_search<T: StepCell>(
    s: &Strips,
    eight: bool,
    state: &mut [T],
    ring: &mut Vec<u32>,
    goals: &[(u32, u32)],
) -> Option<(usize, usize)> {
    let mut tail = 0usize;
    for &(x, y) in goals {
        let p = s.at(x as usize + 1, y as usize + 1);
        if state[p] == T::FREE {
            state[p] = T::ZERO;
            let mask = ring.len() - 1;
            ring[tail & mask] = p as u32;
            tail += 1;
            if tail + 8 >= ring.len() {
                grow(ring, 0, tail);
            }
        }
    }
    if eight {
        search::<T, true>(s, state, ring, tail)
    } else {
        search::<T, false>(s, state, ring, tail)
    }
}

/// Doubles the ring, keeping the entries `head..tail` (counted from the start of the search)
/// at their positions modulo the new length.
#[cold]
fn grow(ring: &mut Vec<u32>, head: usize, tail: usize) {
    let old_mask = ring.len() - 1;
    let mut bigger = vec![0u32; ring.len() * 2];
    let mask = bigger.len() - 1;
    for i in head..tail {
        bigger[i & mask] = ring[i & old_mask];
    }
    *ring = bigger;
}

/// The search from the `tail` queued goals, level by level: a FIFO of cells whose step count
/// is set when queued (branch-free: a neighbour is always written at the tail, which advances
/// only when the neighbour was free), diagonals (when `EIGHT`) only between two open sides.
/// Returns the number of levels and of cells queued, or `None` when the levels outgrow `T`.
fn search<T: StepCell, const EIGHT: bool>(
    s: &Strips,
    state: &mut [T],
    ring: &mut Vec<u32>,
    mut tail: usize,
) -> Option<(usize, usize)> {
    let per = if EIGHT { 8 } else { 4 };
    let mut head = 0usize;
    let mut last = T::ZERO;
    while head < tail {
        // A level of `n` cells queues at most `per * n` more while it is popped.
        let end = tail;
        while (per + 1) * (end - head) + 8 > ring.len() {
            grow(ring, head, tail);
        }
        let r = &mut ring[..];
        let mask = r.len() - 1;
        last = state[r[head & mask] as usize];
        let step = last.succ();
        if step == T::FREE {
            return None;
        }
        for i in head..end {
            let p = r[i & mask] as usize;
            let mut visit = |q: usize, allowed: bool| {
                let c = state[q];
                let f = c == T::FREE && allowed;
                state[q] = if f { step } else { c };
                r[tail & mask] = q as u32;
                tail += usize::from(f);
                c != T::BLOCKED
            };
            let (right, left) = (s.right(p), s.left(p));
            let open_r = visit(right, true);
            let open_l = visit(left, true);
            let open_d = visit(p + STRIP, true);
            let open_u = visit(p - STRIP, true);
            if EIGHT {
                visit(right + STRIP, open_r && open_d);
                visit(left + STRIP, open_l && open_d);
                visit(right - STRIP, open_r && open_u);
                visit(left - STRIP, open_l && open_u);
            }
        }
        head = end;
    }
    Some((last.get() as usize + 1, tail))
}

/// The last pass (parallel over rows): every padded cell's step count and potential from its
/// search cell, through `widen`.
fn derive<T: StepCell>(
    s: &Strips,
    state: &[T],
    steps: &mut [u32],
    potential: &mut [f32],
    widen: impl Fn(T) -> (u32, f32) + Sync,
) {
    use rayon::prelude::*;
    let chunk = s.stride * ROWS_PER_TASK;
    (steps.par_chunks_mut(chunk), potential.par_chunks_mut(chunk))
        .into_par_iter()
        .enumerate()
        .for_each(|(task, (sp, po))| {
            let rows = sp.chunks_mut(s.stride).zip(po.chunks_mut(s.stride));
            for (i, (sp, po)) in rows.enumerate() {
                let py = task * ROWS_PER_TASK + i;
                let pieces = sp.chunks_mut(STRIP).zip(po.chunks_mut(STRIP));
                for (strip, (sp, po)) in pieces.enumerate() {
                    let at = strip * s.len + py * STRIP;
                    let st = &state[at..at + sp.len()];
                    for ((&c, o), v) in st.iter().zip(sp.iter_mut()).zip(po.iter_mut()) {
                        (*o, *v) = widen(c);
                    }
                }
            }
        });
}

fn bfs4(
    lattice: &Lattice,
    decay: f32,
    steps: &mut [u32],
    potential: &mut [f32],
    queue: &mut Vec<u32>,
) {
    let offsets = [
        lattice.offsets[0],
        lattice.offsets[1],
        lattice.offsets[2],
        lattice.offsets[3],
    ];
    let mut head = 0;
    while let Some(&p) = queue.get(head) {
        head += 1;
        let p = p as usize;
        let s = steps[p] + 1;
        let v = potential[p] * decay;
        for off in offsets {
            let q = p.wrapping_add_signed(off);
            if steps[q] == UNSET {
                steps[q] = s;
                potential[q] = v;
                queue.push(q as u32);
            }
        }
    }
}

fn bfs8(
    lattice: &Lattice,
    decay: f32,
    steps: &mut [u32],
    potential: &mut [f32],
    queue: &mut Vec<u32>,
) {
    let o = lattice.offsets;
    let mut head = 0;
    while let Some(&p) = queue.get(head) {
        head += 1;
        let p = p as usize;
        let s = steps[p] + 1;
        let v = potential[p] * decay;
        let mut open = [false; 4];
        for (k, open) in open.iter_mut().enumerate() {
            let q = p.wrapping_add_signed(o[k]);
            let t = steps[q];
            *open = t != WALL;
            if t == UNSET {
                steps[q] = s;
                potential[q] = v;
                queue.push(q as u32);
            }
        }
        for (k, &(a, b)) in DIAGONAL_SIDES.iter().enumerate() {
            if open[a] && open[b] {
                let q = p.wrapping_add_signed(o[k + 4]);
                if steps[q] == UNSET {
                    steps[q] = s;
                    potential[q] = v;
                    queue.push(q as u32);
                }
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_decay_is_rejected() {
        let g = OccupancyGrid::new(3, 3).unwrap();
        for d in [0.0, 1.0, -0.5, 1.5] {
            assert!(
                matches!(
                    PotentialField::bfs(&g, &[(0, 0)], d, Neighbourhood::Four),
                    Err(Error::OutOfRange { .. })
                ),
                "{d}"
            );
        }
        assert!(matches!(
            PotentialField::bfs(&g, &[(0, 0)], f32::NAN, Neighbourhood::Four),
            Err(Error::NonFinite { .. })
        ));
    }

    #[test]
    fn diagonals_do_not_cut_corners() {
        let map = OccupancyGrid::parse_ascii("G#\n#.\n", "<map>").unwrap();
        let f = PotentialField::bfs(&map.grid, &map.goals, 0.5, Neighbourhood::Eight).unwrap();
        assert!(!f.is_reachable(1, 1));
        assert_eq!(f.reachable_count(), 1);
    }
}
