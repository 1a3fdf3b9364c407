//! Grid walkers: the discrete cell-to-cell movement of the potential-field notes.
//!
//! Each step, every walker looks at its neighbours (no corner cutting) and picks the one with
//! the most energy that is higher than its own ([`PotentialField::best_neighbour`]). Under
//! [`WalkPolicy::Queue`] it moves there if no walker stands there, else it waits, so walkers
//! queue in corridors. Under [`WalkPolicy::NextBest`] it takes the best *free* higher neighbour.
//! A walker that reaches a goal cell is marked arrived and leaves the grid, freeing its cell.
//!
//! The step is parallel and deterministic: every walker decides from the state at the start of
//! the step (a cell counts as free when nobody stood on it then); when several walkers want the
//! same cell, the one nearest its goal (fewest steps; this differs only between channels) wins,
//! then the lowest walker index. Walkers of different channels can block each other in a ring
//! (two walkers meeting head-on in a corridor); a ring in which every walker wants the next one's
//! cell rotates as a whole. Moves are applied after all decisions, so the result is the same on
//! any number of threads.
//!
//! Invariants: no two walkers that have not arrived share a cell; a walker only ever moves to a
//! cell with fewer steps to its goal, so walls are never entered; and some walker moves in every
//! step while any walker can still climb (the one nearest a goal can always move, and a set of
//! blocked walkers always contains a ring), so every walker that can reach a goal does.

use rayon::prelude::*;

use super::channels::GoalChannels;
use super::lattice::Lattice;
use super::occupancy::OccupancyGrid;
use super::potential::{PotentialField, UNSET};
use crate::error::{Error, Result};

/// Occupant entry of an empty cell.
const EMPTY: u32 = u32::MAX;

/// What a walker does when the neighbour it wants is taken.
#[derive(
    Clone, Copy, Debug, Default, PartialEq, Eq, Hash, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "snake_case")]
pub enum WalkPolicy {
    /// Wait for the best neighbour to be free (walkers queue).
    #[default]
    Queue,
    /// Take the best free neighbour with more energy than the own cell, if any.
    NextBest,
}

/// What one [`GridWalkers::step`] did.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct WalkStats {
    /// Walkers that moved to another cell.
    pub moved: usize,
    /// Walkers that stayed although they had a better cell to go to (blocked or outbid).
    pub waited: usize,
    /// Walkers that arrived at a goal this step.
    pub arrived: usize,
    /// Walkers still on the grid after the step.
    pub active: usize,
}

/// Walkers on an occupancy grid, each following a potential field (or its group's channel).
#[derive(Clone, Debug)]
pub struct GridWalkers {
    lattice: Lattice,
    /// Padded cell of each walker.
    cells: Vec<u32>,
    channels: Vec<u32>,
    arrived: Vec<bool>,
    /// Walkers that have not arrived, in index order.
    active: Vec<u32>,
    /// Padded map: the walker standing on each cell, or `EMPTY`.
    occupant: Vec<u32>,
    /// Scratch: `(target cell, priority key, wanted cell)` per walker with a better cell.
    proposals: Vec<(u32, u64, u32)>,
    /// Scratch for cycle detection: per walker 0 = unseen, 1 = on the current path, 2 = done.
    mark: Vec<u8>,
    /// Scratch: the walkers of the cycles found, one cycle after another.
    cycle_members: Vec<u32>,
    /// Scratch: `(start, length)` pairs into `cycle_members`, flattened.
    cycles: Vec<u32>,
    /// Scratch of the cycle search: `(walker, walker on the cell it wants)` and the walk.
    next: Vec<(u32, u32)>,
    path: Vec<u32>,
    /// Scratch of the cycle rotation: the members' cells before it.
    old_cells: Vec<u32>,
}

impl GridWalkers {
    /// Walkers at `starts` on `grid`, all on channel 0.
    ///
    /// # Examples
    /// ```
    /// # fn main() -> throng::Result<()> {
    /// use throng::field::{GridWalkers, Neighbourhood, OccupancyGrid, PotentialField, WalkPolicy};
    /// let map = OccupancyGrid::parse_ascii("S.S.G\n", "<map>")?;
    /// let field = PotentialField::bfs(&map.grid, &map.goals, 0.9, Neighbourhood::Four)?;
    /// let mut walkers = GridWalkers::new(&map.grid, &map.spawns)?;
    /// while walkers.active_count() > 0 {
    ///     walkers.step(&field, WalkPolicy::Queue)?;
    /// }
    /// assert!(walkers.is_arrived(0) && walkers.is_arrived(1));
    /// # Ok(()) }
    /// ```
    ///
    /// # Errors
    /// As [`GridWalkers::with_channels`].
    pub fn new(grid: &OccupancyGrid, starts: &[(u32, u32)]) -> Result<Self> {
        Self::with_channels(grid, starts, &vec![0; starts.len()])
    }

    /// Walkers at `starts`, walker `i` following goal channel `channels[i]`.
    ///
    /// # Errors
    /// [`Error::Invalid`] when the lengths differ, a start lies outside the grid or on a wall,
    /// two walkers share a start, or there are `u32::MAX` or more walkers.
    pub fn with_channels(
        grid: &OccupancyGrid,
        starts: &[(u32, u32)],
        channels: &[u32],
    ) -> Result<Self> {
        if starts.len() != channels.len() {
            return Err(Error::Invalid {
                name: "channels".into(),
                reason: format!(
                    "{} channels given for {} walkers",
                    channels.len(),
                    starts.len()
                ),
            });
        }
        if starts.len() >= EMPTY as usize {
            return Err(Error::Invalid {
                name: "starts".into(),
                reason: "too many walkers".into(),
            });
        }
        let lattice = Lattice::of(grid);
        let mut occupant = vec![EMPTY; lattice.len];
        let mut cells = Vec::with_capacity(starts.len());
        for (i, &(x, y)) in starts.iter().enumerate() {
            grid.check_cell("walker start", x, y)?;
            if !grid.is_free(x, y) {
                return Err(Error::Invalid {
                    name: "walker start".into(),
                    reason: format!("walker {i} starts on the wall cell ({x}, {y})"),
                });
            }
            let p = lattice.index(x, y);
            if occupant[p] != EMPTY {
                return Err(Error::Invalid {
                    name: "walker start".into(),
                    reason: format!("walkers {} and {i} both start on ({x}, {y})", occupant[p]),
                });
            }
            occupant[p] = i as u32;
            cells.push(p as u32);
        }
        Ok(GridWalkers {
            lattice,
            cells,
            channels: channels.to_vec(),
            arrived: vec![false; starts.len()],
            active: (0..starts.len() as u32).collect(),
            occupant,
            // Scratch sized for every walker up front, so that steps never grow it.
            proposals: Vec::with_capacity(starts.len()),
            mark: vec![0; starts.len()],
            cycle_members: Vec::with_capacity(starts.len()),
            cycles: Vec::with_capacity(2 * starts.len()),
            next: Vec::with_capacity(starts.len()),
            path: Vec::with_capacity(starts.len()),
            old_cells: Vec::with_capacity(starts.len()),
        })
    }

    /// Walkers as a checkpoint holds them: walker `i` on `cells[i]` following `channels[i]`,
    /// arrived (off the grid, on the goal it reached) when `arrived[i]`. The checks of
    /// [`GridWalkers::with_channels`] apply to the walkers that have not arrived; an arrived
    /// walker's cell must lie in the grid.
    pub(crate) fn restore(
        grid: &OccupancyGrid,
        cells: &[(u32, u32)],
        channels: &[u32],
        arrived: &[bool],
    ) -> Result<Self> {
        if arrived.len() != cells.len() {
            return Err(Error::Invalid {
                name: "arrived".into(),
                reason: format!(
                    "{} arrival flags given for {} walkers",
                    arrived.len(),
                    cells.len()
                ),
            });
        }
        let active: Vec<(u32, u32)> = cells
            .iter()
            .zip(arrived)
            .filter(|(_, a)| !**a)
            .map(|(c, _)| *c)
            .collect();
        let active_channels: Vec<u32> = channels
            .iter()
            .zip(arrived)
            .filter(|(_, a)| !**a)
            .map(|(c, _)| *c)
            .collect();
        // The checks (and the lattice) of the constructor, on the walkers still on the grid.
        let mut w = Self::with_channels(grid, &active, &active_channels)?;
        for &(x, y) in cells {
            grid.check_cell("walker cell", x, y)?;
        }
        let lattice = w.lattice;
        w.cells = cells
            .iter()
            .map(|&(x, y)| lattice.index(x, y) as u32)
            .collect();
        w.channels = channels.to_vec();
        w.arrived = arrived.to_vec();
        w.active.clear();
        w.occupant.fill(EMPTY);
        for (i, (&p, &a)) in w.cells.iter().zip(arrived).enumerate() {
            if !a {
                w.active.push(i as u32);
                w.occupant[p as usize] = i as u32;
            }
        }
        w.mark = vec![0; cells.len()];
        Ok(w)
    }

    /// Number of walkers, arrived or not.
    #[must_use]
    pub fn len(&self) -> usize {
        self.cells.len()
    }

    /// Whether there are no walkers.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.cells.is_empty()
    }

    /// Number of walkers that have not arrived.
    #[must_use]
    pub fn active_count(&self) -> usize {
        self.active.len()
    }

    /// Cell of walker `i` (for an arrived walker, the goal it reached).
    ///
    /// # Panics
    /// When `i >= len()`.
    #[must_use]
    pub fn position(&self, i: usize) -> (u32, u32) {
        self.lattice.coords(self.cells[i] as usize)
    }

    /// Cells of all walkers, by index.
    #[must_use]
    pub fn positions(&self) -> Vec<(u32, u32)> {
        self.cells
            .iter()
            .map(|&p| self.lattice.coords(p as usize))
            .collect()
    }

    /// Whether walker `i` has reached a goal and left the grid.
    ///
    /// # Panics
    /// When `i >= len()`.
    #[must_use]
    pub fn is_arrived(&self, i: usize) -> bool {
        self.arrived[i]
    }

    /// The channel walker `i` follows.
    ///
    /// # Panics
    /// When `i >= len()`.
    #[must_use]
    pub fn channel(&self, i: usize) -> u32 {
        self.channels[i]
    }

    /// The walker standing on `(x, y)`, if any (arrived walkers stand nowhere).
    #[must_use]
    pub fn occupant(&self, x: u32, y: u32) -> Option<usize> {
        let p = self.lattice.checked_index(x, y)?;
        let o = self.occupant[p];
        (o != EMPTY).then_some(o as usize)
    }

    /// One step of every walker on `field` (channels are ignored).
    ///
    /// # Errors
    /// [`Error::Invalid`] when the field's grid has another size than the walkers'.
    pub fn step(&mut self, field: &PotentialField, policy: WalkPolicy) -> Result<WalkStats> {
        self.check_field(field)?;
        Ok(self.step_with(|_| field, policy))
    }

    /// One step of every walker on its channel's field in `channels`.
    ///
    /// # Errors
    /// [`Error::Invalid`] when a walker's channel does not exist or has no up-to-date field (call
    /// [`GoalChannels::rebuild_dirty`] first), or the grid sizes differ.
    pub fn step_channels(
        &mut self,
        channels: &GoalChannels,
        policy: WalkPolicy,
    ) -> Result<WalkStats> {
        for &i in &self.active {
            let ch = self.channels[i as usize] as usize;
            if ch >= channels.len() {
                return Err(Error::Invalid {
                    name: "channel".into(),
                    reason: format!("walker {i} follows channel {ch}, which does not exist"),
                });
            }
            match channels.field(ch) {
                None => {
                    return Err(Error::Invalid {
                        name: "channel".into(),
                        reason: format!("channel {ch} has no up-to-date field"),
                    });
                }
                Some(f) => self.check_field(f)?,
            }
        }
        Ok(self.step_with(
            |ch| channels.field(ch as usize).expect("checked above"),
            policy,
        ))
    }

    fn check_field(&self, field: &PotentialField) -> Result<()> {
        if self.lattice.same_shape(&field.lattice) {
            Ok(())
        } else {
            Err(Error::Invalid {
                name: "field".into(),
                reason: format!(
                    "field is {}x{} but the walkers' grid is {}x{}",
                    field.width(),
                    field.height(),
                    self.lattice.width,
                    self.lattice.height
                ),
            })
        }
    }

    /// Puts walker `i` (already removed from its cell) on `target`, or marks it arrived there.
    fn move_into<'f>(
        &mut self,
        i: usize,
        target: u32,
        field_of: &impl Fn(u32) -> &'f PotentialField,
        stats: &mut WalkStats,
    ) {
        self.cells[i] = target;
        stats.moved += 1;
        if field_of(self.channels[i]).steps[target as usize] == 0 {
            self.arrived[i] = true;
            stats.arrived += 1;
        } else {
            self.occupant[target as usize] = i as u32;
        }
    }

    /// Finds the cycles among blocked walkers (each wants the cell of the next), from the
    /// start-of-step state in `proposals`; fills `cycles` and `cycle_members`.
    /// Walkers are visited in index order, so the result is deterministic.
    fn find_cycles(&mut self) {
        self.cycles.clear();
        self.cycle_members.clear();
        let blocked = self.proposals.iter().filter(|p| p.0 == EMPTY).count();
        if blocked < 2 {
            return;
        }
        self.mark.clear();
        self.mark.resize(self.cells.len(), 0);
        // Blocked walkers sort last; `next[i]` is the walker on the cell `i` wants.
        let mut next = std::mem::take(&mut self.next);
        next.clear();
        next.extend(
            self.proposals[self.proposals.len() - blocked..]
                .iter()
                .map(|&(_, key, want)| ((key & 0xffff_ffff) as u32, self.occupant[want as usize])),
        );
        next.sort_unstable();
        let next_of = |i: u32| {
            next.binary_search_by_key(&i, |e| e.0)
                .ok()
                .map(|k| next[k].1)
        };
        let mut path = std::mem::take(&mut self.path);
        for &(start, _) in &next {
            if self.mark[start as usize] != 0 {
                continue;
            }
            path.clear();
            let mut i = start;
            loop {
                self.mark[i as usize] = 1;
                path.push(i);
                match next_of(i) {
                    Some(j) if self.mark[j as usize] == 0 => i = j,
                    Some(j) if self.mark[j as usize] == 1 => {
                        let k = path.iter().position(|&m| m == j).expect("on the path");
                        self.cycles.push(self.cycle_members.len() as u32);
                        self.cycles.push((path.len() - k) as u32);
                        self.cycle_members.extend_from_slice(&path[k..]);
                        break;
                    }
                    _ => break,
                }
            }
            for &m in &path {
                self.mark[m as usize] = 2;
            }
        }
        (self.next, self.path) = (next, path);
    }

    /// The step: arrivals, parallel proposals, deterministic conflict resolution, moves.
    fn step_with<'f>(
        &mut self,
        field_of: impl Fn(u32) -> &'f PotentialField + Sync,
        policy: WalkPolicy,
    ) -> WalkStats {
        let mut stats = WalkStats::default();
        // Walkers standing on a goal (placed there, or a goal that moved under them) arrive.
        for &i in &self.active {
            let i = i as usize;
            let p = self.cells[i] as usize;
            if field_of(self.channels[i]).steps[p] == 0 {
                self.arrived[i] = true;
                self.occupant[p] = EMPTY;
                stats.arrived += 1;
            }
        }
        if stats.arrived > 0 {
            let arrived = &self.arrived;
            self.active.retain(|&i| !arrived[i as usize]);
        }
        // Proposals, from the state at the start of the step: (target, key, wanted cell). A
        // walker whose wanted cell is taken proposes target `EMPTY` (sorted last).
        let (cells, channels, occupant) = (&self.cells, &self.channels, &self.occupant);
        let mut proposals = std::mem::take(&mut self.proposals);
        proposals.clear();
        // One slot per active walker, filled in parallel (no allocation once warm), then the
        // walkers without a move (no better cell) dropped.
        const NONE: (u32, u64, u32) = (u32::MAX, u64::MAX, u32::MAX);
        proposals.resize(self.active.len(), NONE);
        let propose = |i: u32| -> Option<(u32, u64, u32)> {
            let field = field_of(channels[i as usize]);
            let p = cells[i as usize] as usize;
            let best = field.best_from(p, |_| true)?;
            let target = match policy {
                WalkPolicy::Queue => Some(best).filter(|&q| occupant[q] == EMPTY),
                WalkPolicy::NextBest => field.best_from(p, |q| occupant[q] == EMPTY),
            };
            let own = u64::from(field.steps[p].min(UNSET));
            Some((
                target.map_or(EMPTY, |q| q as u32),
                (own << 32) | u64::from(i),
                best as u32,
            ))
        };
        proposals
            .par_chunks_mut(512)
            .zip(self.active.par_chunks(512))
            .for_each(|(out, ids)| {
                for (o, &i) in out.iter_mut().zip(ids) {
                    *o = propose(i).unwrap_or(NONE);
                }
            });
        proposals.retain(|&p| p != NONE);
        // Keys are unique, so the sorted order (and the winners) do not depend on threads.
        proposals.par_sort_unstable();
        self.proposals = proposals;
        self.find_cycles();
        let proposals = std::mem::take(&mut self.proposals);
        let mut last = EMPTY;
        for &(target, key, _) in proposals.iter() {
            if target == EMPTY || target == last {
                stats.waited += 1;
                continue;
            }
            last = target;
            let i = (key & 0xffff_ffff) as usize;
            let from = self.cells[i] as usize;
            debug_assert_eq!(self.occupant[target as usize], EMPTY);
            self.occupant[from] = EMPTY;
            self.move_into(i, target, &field_of, &mut stats);
        }
        // Cycles of walkers that each want the next one's cell (possible only between channels)
        // rotate together, so walkers never deadlock.
        let (cycles, members) = (
            std::mem::take(&mut self.cycles),
            std::mem::take(&mut self.cycle_members),
        );
        let mut old = std::mem::take(&mut self.old_cells);
        for cycle in cycles.chunks_exact(2) {
            let members = &members[cycle[0] as usize..(cycle[0] + cycle[1]) as usize];
            old.clear();
            old.extend(members.iter().map(|&m| self.cells[m as usize]));
            for &cell in &old {
                self.occupant[cell as usize] = EMPTY;
            }
            for (j, &m) in members.iter().enumerate() {
                self.move_into(m as usize, old[(j + 1) % old.len()], &field_of, &mut stats);
            }
            stats.waited -= members.len();
        }
        (self.cycles, self.cycle_members, self.proposals) = (cycles, members, proposals);
        self.old_cells = old;
        let arrived = &self.arrived;
        self.active.retain(|&i| !arrived[i as usize]);
        stats.active = self.active.len();
        stats
    }
}
