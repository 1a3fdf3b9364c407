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
//! level-by-level search that stores step counts only, potentials derived afterwards from a
//! table of the same repeated products); [`PotentialField::bfs_reference`] is the literal
//! algorithm, kept so tests can check the two agree bit for bit.

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
    /// Padded cell states: `FREE`, `SEEN` or `BLOCKED` (wall or border).
    state: Vec<u8>,
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

/// Cell state of the search: free and not yet queued.
const FREE: u8 = 0;
/// Cell state of the search: queued (its step count is final).
const SEEN: u8 = 1;
/// Cell state of the search: a wall or the border.
const BLOCKED: u8 = 2;
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
    /// The result is the notes' algorithm's (see [`PotentialField::bfs_reference`]), bit for
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

    /// The reference build: the notes' algorithm literally, each popped cell giving
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
    /// one-byte cell state; a level-by-level search over that state with a small ring FIFO
    /// that writes only the step count of each cell it pops (queueing is branch-free: a
    /// neighbour is always written at the tail, which advances only when the neighbour was
    /// free); and a parallel pass that marks unreached cells and walls and derives every
    /// potential from its step count through a table of repeated products, so each value is
    /// bit for bit the reference's `current * decay` chain.
    fn search(&mut self, grid: &OccupancyGrid, goals: &[(u32, u32)]) {
        let l = self.lattice;
        let Scratch { state, ring, table } = &mut self.scratch;
        fill_state(grid, &l, state);
        // Fresh buffers come zeroed from the allocator, untouched until written (in parallel
        // below), and every cell is written before it is read.
        if self.steps.len() != l.len {
            self.steps = vec![0; l.len];
        }
        if self.potential.len() != l.len {
            self.potential = vec![0.0; l.len];
        }
        if ring.len() < 1024 {
            *ring = vec![0; 1024];
        }
        let mut tail = 0usize;
        for &(x, y) in goals {
            let p = l.index(x, y);
            if state[p] == FREE {
                state[p] = SEEN;
                let mask = ring.len() - 1;
                ring[tail & mask] = p as u32;
                tail += 1;
                if tail + 8 >= ring.len() {
                    grow(ring, 0, tail);
                }
            }
        }
        let levels = match self.neighbourhood {
            Neighbourhood::Four => search4(&l, state, &mut self.steps, ring, tail),
            Neighbourhood::Eight => search8(&l, state, &mut self.steps, ring, tail),
        };
        self.reachable = levels.1;
        table.clear();
        let mut v = 1.0_f32;
        for _ in 0..levels.0 {
            table.push(v);
            v *= self.decay;
        }
        derive(&l, state, table, &mut self.steps, &mut self.potential);
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

/// Fills `state` with the padded cell states of `grid`: `BLOCKED` on walls and the border,
/// `FREE` elsewhere (parallel over rows).
fn fill_state(grid: &OccupancyGrid, l: &Lattice, state: &mut Vec<u8>) {
    use rayon::prelude::*;
    if state.len() != l.len {
        *state = vec![BLOCKED; l.len];
    }
    let w = l.width as usize;
    let h = l.height as usize;
    let cells = grid.cells();
    state
        .par_chunks_mut(l.stride)
        .enumerate()
        .with_min_len(64)
        .for_each(|(row, line)| {
            if row == 0 || row > h {
                line.fill(BLOCKED);
                return;
            }
            line[0] = BLOCKED;
            line[w + 1] = BLOCKED;
            for (o, c) in line[1..=w].iter_mut().zip(&cells[(row - 1) * w..row * w]) {
                *o = if c.is_free() { FREE } else { BLOCKED };
            }
        });
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

/// The level-by-level 4-neighbourhood search from the `tail` queued goals. Returns the number
/// of levels and the number of cells queued.
fn search4(
    l: &Lattice,
    state: &mut [u8],
    steps: &mut [u32],
    ring: &mut Vec<u32>,
    mut tail: usize,
) -> (usize, usize) {
    let o = [l.offsets[0], l.offsets[1], l.offsets[2], l.offsets[3]];
    let mut head = 0usize;
    let mut level = 0u32;
    while head < tail {
        let end = tail;
        while head < end {
            if tail - head + 8 > ring.len() {
                grow(ring, head, tail);
            }
            let r = &mut ring[..];
            let mask = r.len() - 1;
            let p = r[head & mask] as usize;
            head += 1;
            steps[p] = level;
            for off in o {
                let q = p.wrapping_add_signed(off);
                let f = u8::from(state[q] == FREE);
                state[q] |= f;
                r[tail & mask] = q as u32;
                tail += usize::from(f);
            }
        }
        level += 1;
    }
    (level as usize, tail)
}

/// The level-by-level 8-neighbourhood search (no corner cutting); see [`search4`].
fn search8(
    l: &Lattice,
    state: &mut [u8],
    steps: &mut [u32],
    ring: &mut Vec<u32>,
    mut tail: usize,
) -> (usize, usize) {
    let o = l.offsets;
    let mut head = 0usize;
    let mut level = 0u32;
    while head < tail {
        let end = tail;
        while head < end {
            if tail - head + 8 > ring.len() {
                grow(ring, head, tail);
            }
            let r = &mut ring[..];
            let mask = r.len() - 1;
            let p = r[head & mask] as usize;
            head += 1;
            steps[p] = level;
            let mut open = [false; 4];
            for (k, open) in open.iter_mut().enumerate() {
                let q = p.wrapping_add_signed(o[k]);
                let s = state[q];
                *open = s != BLOCKED;
                let f = u8::from(s == FREE);
                state[q] = s | f;
                r[tail & mask] = q as u32;
                tail += usize::from(f);
            }
            for (k, &(a, b)) in DIAGONAL_SIDES.iter().enumerate() {
                let q = p.wrapping_add_signed(o[k + 4]);
                let f = u8::from(state[q] == FREE && open[a] && open[b]);
                state[q] |= f;
                r[tail & mask] = q as u32;
                tail += usize::from(f);
            }
        }
        level += 1;
    }
    (level as usize, tail)
}

/// The last pass: `WALL` / `UNSET` step counts and `UNREACHABLE` potentials where the search
/// did not reach, `table[steps]` where it did (parallel over rows).
fn derive(l: &Lattice, state: &[u8], table: &[f32], steps: &mut [u32], potential: &mut [f32]) {
    use rayon::prelude::*;
    let chunk = l.stride * ROWS_PER_TASK;
    (
        state.par_chunks(chunk),
        steps.par_chunks_mut(chunk),
        potential.par_chunks_mut(chunk),
    )
        .into_par_iter()
        .for_each(|(st, sp, po)| {
            for ((&c, s), v) in st.iter().zip(sp.iter_mut()).zip(po.iter_mut()) {
                match c {
                    SEEN => *v = table[*s as usize],
                    FREE => {
                        *s = UNSET;
                        *v = PotentialField::UNREACHABLE;
                    }
                    _ => {
                        *s = WALL;
                        *v = PotentialField::UNREACHABLE;
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
