//! Fields in the world: goal channels that agents follow, walls they cannot enter, grid walkers.
//!
//! A world owns any number of fields ([`World::add_field`]), each a [`GoalChannels`]: one
//! occupancy grid with one potential and flow field per goal channel. Three things happen to them
//! in a step, none of them inside the parallel steering pass:
//!
//! 1. **index phase** (timed with it): goals due for re-randomisation get new cells, dirty
//!    channels (moved goals, changed walls) are rebuilt, and the frame-start positions are kept;
//! 2. **steer**: [`Behaviour::FollowField`](crate::steering::Behaviour::FollowField) samples its
//!    channel's flow at the agent's position (read only);
//! 3. **bounds phase**: every agent whose move would end inside a wall cell of any field slides
//!    along the free axis or stays where it was, and loses the velocity component into the wall;
//!    grid walkers take their discrete step; agents on a goal of the channel they follow are
//!    marked arrived.
//!
//! Invariants: after a step no agent that started it on free ground stands inside a wall (moves
//! are checked in sub-steps of at most half a cell, and a diagonal cell change needs one of the
//! two orthogonal cells free, so walls meeting at a corner are not crossed); channels are never
//! dirty while agents steer; arrival flags are reset when the channel an agent follows is
//! rebuilt; everything is independent of the number of threads.

use glam::Vec2;
use rayon::prelude::*;

use super::state::World;
use crate::agents::{AgentId, Agents};
use crate::error::{Error, Result};
use crate::field::{FlowField, GoalChannels, GridWalkers, OccupancyGrid, WalkPolicy};
use crate::steering::Behaviour;

/// Agents per parallel task of the wall check.
const WALL_CHUNK: usize = 4096;

/// Grid walkers made of the agents of one group.
#[derive(Debug)]
struct WalkerGroup {
    walkers: GridWalkers,
    /// The agent each walker moves.
    ids: Vec<AgentId>,
    policy: WalkPolicy,
}

/// One field of the world.
#[derive(Debug)]
struct WorldField {
    channels: GoalChannels,
    /// Re-randomise every channel's goals every this many frames (0: never) ...
    shuffle_every: u64,
    /// ... to this many goals each.
    shuffle_count: usize,
    walkers: Vec<WalkerGroup>,
    /// One bit per cell of the grid (row-major), set on walls: the wall check's compact copy
    /// of the grid, kept in step with it by [`World::set_field_blocked`].
    wall_bits: Vec<u64>,
}

/// The wall bits of `grid` (see `WorldField::wall_bits`).
fn wall_bits(grid: &OccupancyGrid) -> Vec<u64> {
    let mut bits = vec![0u64; grid.len().div_ceil(64)];
    for (i, c) in grid.cells().iter().enumerate() {
        if !c.is_free() {
            bits[i / 64] |= 1 << (i % 64);
        }
    }
    bits
}

/// The world's fields and their per-step state (see the module docs).
#[derive(Debug, Default)]
pub(crate) struct FieldSet {
    fields: Vec<WorldField>,
    /// Per agent id: reached a goal of its channel since the channel was last rebuilt.
    arrived: Vec<bool>,
    /// Per group: the `(field, channel)` its first `follow_field` behaviour names.
    follow: Vec<Option<(usize, usize)>>,
    /// Positions at the start of the step.
    prev_x: Vec<f32>,
    prev_y: Vec<f32>,
    /// Channel rebuilds so far.
    rebuilds: u64,
    /// Scratch of the reordering sort.
    sort_keys: Vec<u64>,
}

/// Reorders agents by the row-major cell of `grid` they stand in (agents outside last), so that
/// field lookups walk memory in order. Stable for agents sharing a cell.
fn reorder_by_cell(agents: &mut Agents, grid: &OccupancyGrid, keys: &mut Vec<u64>) {
    let w = grid.width() as u64;
    keys.clear();
    keys.par_extend(
        (agents.pos_x.par_iter(), agents.pos_y.par_iter())
            .into_par_iter()
            .enumerate()
            .map(|(i, (&x, &y))| {
                let cell = cell_of(grid, Vec2::new(x, y))
                    .map_or(u64::from(u32::MAX), |(cx, cy)| cy as u64 * w + cx as u64);
                (cell << 32) | i as u64
            }),
    );
    keys.par_sort_unstable();
    let perm: Vec<u32> = keys.iter().map(|&k| k as u32).collect();
    agents.reorder(&perm);
}

/// A 64-bit mix (splitmix64's finaliser) for derived seeds.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9e37_79b9_7f4a_7c15);
    z = (z ^ (z >> 30)).wrapping_mul(0xbf58_476d_1ce4_e5b9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94d0_49bb_1331_11eb);
    z ^ (z >> 31)
}

/// Whether world point `p` lies in a wall cell of `grid` (points outside the grid do not).
#[inline]
fn in_wall(grid: &OccupancyGrid, p: Vec2) -> bool {
    cell_of(grid, p).is_some_and(|(x, y)| !grid.cells()[y * grid.width() as usize + x].is_free())
}

#[inline]
fn cell_of(grid: &OccupancyGrid, p: Vec2) -> Option<(usize, usize)> {
    let u = (p - grid.origin()) / grid.cell_size();
    if !(u.x >= 0.0 && u.y >= 0.0) {
        return None;
    }
    let (x, y) = (u.x as usize, u.y as usize);
    (x < grid.width() as usize && y < grid.height() as usize).then_some((x, y))
}

/// Whether moving from `a` to `b` (at most one cell apart on each axis) is allowed: `b` is not
/// in a wall, and a diagonal cell change has one of its two orthogonal cells free.
#[inline]
fn can_move(grid: &OccupancyGrid, a: Vec2, b: Vec2) -> bool {
    if in_wall(grid, b) {
        return false;
    }
    match (cell_of(grid, a), cell_of(grid, b)) {
        (Some((ax, ay)), Some((bx, by))) if ax != bx && ay != by => {
            let w = grid.width() as usize;
            let c = grid.cells();
            c[ay * w + bx].is_free() || c[by * w + ax].is_free()
        }
        _ => true,
    }
}

/// The flow a group follows and its channel's goal cells.
type GoalCheck<'a> = (&'a FlowField, &'a [(u32, u32)]);

/// A grid's walls as the per-agent wall check reads them, with the cell lookup of
/// [`cell_of`] made cheap: when the cell size is a power of two, multiplying by its reciprocal
/// is exact, so it gives the same cells as the division.
#[derive(Clone, Copy)]
struct Walls<'a> {
    grid: &'a OccupancyGrid,
    /// The grid's wall bits.
    bits: &'a [u64],
    origin: Vec2,
    cell_size: f32,
    /// `1 / cell_size` when that is exact.
    inverse: Option<f32>,
    half: f32,
    width: usize,
    height: usize,
}

impl<'a> Walls<'a> {
    fn of(grid: &'a OccupancyGrid, bits: &'a [u64]) -> Self {
        debug_assert_eq!(bits, &wall_bits(grid)[..]);
        let cell_size = grid.cell_size();
        let inverse = 1.0 / cell_size;
        let exact = cell_size.is_normal()
            && inverse.is_normal()
            && cell_size.to_bits() & 0x007f_ffff == 0
            && inverse * cell_size == 1.0;
        Walls {
            grid,
            bits,
            origin: grid.origin(),
            cell_size,
            inverse: exact.then_some(inverse),
            half: 0.5 * cell_size,
            width: grid.width() as usize,
            height: grid.height() as usize,
        }
    }

    /// [`cell_of`] as a row-major cell index.
    #[inline]
    fn cell(&self, p: Vec2) -> Option<usize> {
        let d = p - self.origin;
        let u = match self.inverse {
            Some(inv) => d * inv,
            None => d / self.cell_size,
        };
        if !(u.x >= 0.0 && u.y >= 0.0) {
            return None;
        }
        let (x, y) = (u.x as usize, u.y as usize);
        (x < self.width && y < self.height).then_some(y * self.width + x)
    }

    #[inline]
    fn is_wall(&self, cell: Option<usize>) -> bool {
        cell.is_some_and(|c| self.wall(c))
    }

    /// Whether row-major cell `c` is a wall.
    #[inline]
    fn wall(&self, c: usize) -> bool {
        self.bits[c / 64] >> (c % 64) & 1 != 0
    }

    /// Whether [`resolve`] leaves a move from `prev` to `p` as it is (velocity included): no
    /// move; or `p` not in a wall and in `prev`'s cell; or a start inside a wall; or a move of
    /// one sub-step (at most half a cell per axis) that [`can_move`] allows and that lands
    /// exactly on `p`. Everything else goes through [`resolve`].
    #[inline]
    fn unchanged(&self, prev: Vec2, p: Vec2) -> bool {
        if p == prev {
            return true;
        }
        let (a, b) = (self.cell(prev), self.cell(p));
        let wall_b = self.is_wall(b);
        if !wall_b && a == b {
            return true;
        }
        if self.is_wall(a) {
            return true;
        }
        if wall_b {
            return false;
        }
        let d = p - prev;
        let n = ((d.x.abs().max(d.y.abs()) / self.half).ceil() as u32).clamp(1, 1 << 16);
        if n != 1 || prev + d != p {
            return false;
        }
        // One sub-step to `p`, which is not in a wall: allowed unless it changes cell
        // diagonally past two walls.
        match (a, b) {
            (Some(a), Some(b))
                if a % self.width != b % self.width && a / self.width != b / self.width =>
            {
                let (ax, ay) = (a % self.width, a / self.width);
                let (bx, by) = (b % self.width, b / self.width);
                !self.wall(ay * self.width + bx) || !self.wall(by * self.width + ax)
            }
            _ => true,
        }
    }
}

/// The non-penetration rule for one agent: the position and velocity after moving from `prev`
/// towards `p` without entering a wall of `grid`.
fn resolve(grid: &OccupancyGrid, prev: Vec2, p: Vec2, mut v: Vec2) -> (Vec2, Vec2) {
    if p == prev || !in_wall(grid, p) && cell_of(grid, prev) == cell_of(grid, p) {
        return (p, v);
    }
    if in_wall(grid, prev) {
        // Placed inside a wall from outside the step: let it leave.
        return (p, v);
    }
    let mut d = p - prev;
    let half = 0.5 * grid.cell_size();
    let n = ((d.x.abs().max(d.y.abs()) / half).ceil() as u32).clamp(1, 1 << 16);
    let mut step = d / n as f32;
    let mut cur = prev;
    for k in 0..n {
        let last = k + 1 == n;
        let to = if last { prev + d } else { cur + step };
        if can_move(grid, cur, to) {
            cur = to;
            continue;
        }
        let slide_x = Vec2::new(to.x, cur.y);
        let slide_y = Vec2::new(cur.x, to.y);
        if step.x != 0.0 && can_move(grid, cur, slide_x) {
            cur = slide_x;
            v.y = 0.0;
            step.y = 0.0;
            d.y = cur.y - prev.y;
        } else if step.y != 0.0 && can_move(grid, cur, slide_y) {
            cur = slide_y;
            v.x = 0.0;
            step.x = 0.0;
            d.x = cur.x - prev.x;
        } else {
            v = Vec2::ZERO;
            break;
        }
    }
    (cur, v)
}

impl FieldSet {
    fn arrived_of(&self, id: AgentId) -> bool {
        self.arrived.get(id.0 as usize).copied().unwrap_or(false)
    }

    fn set_arrived(&mut self, id: AgentId, on: bool) {
        let k = id.0 as usize;
        if k >= self.arrived.len() {
            if !on {
                return;
            }
            self.arrived.resize(k + 1, false);
        }
        self.arrived[k] = on;
    }

    /// The index-phase work: due goal shuffles, rebuilds of dirty channels (resetting the
    /// arrival flags of their followers), the groups' follow specs, reordering agents by field
    /// cell when due (every `reorder_every` frames, only when no group queries neighbours: the
    /// neighbour index reorders them otherwise), and frame-start positions.
    pub(crate) fn prepare(
        &mut self,
        agents: &mut Agents,
        groups: &[super::GroupParams],
        seed: u64,
        frame: u64,
        reorder_every: u32,
    ) {
        if self.fields.is_empty() {
            return;
        }
        let flocking = groups
            .iter()
            .any(|g| super::neighbours::FlockSpec::of(g).active);
        if !flocking
            && !agents.is_empty()
            && reorder_every > 0
            && frame.is_multiple_of(u64::from(reorder_every))
        {
            reorder_by_cell(agents, self.fields[0].channels.grid(), &mut self.sort_keys);
        }
        self.follow.clear();
        self.follow.extend(groups.iter().map(|g| {
            g.steering
                .behaviours
                .iter()
                .find_map(|w| match w.behaviour {
                    Behaviour::FollowField { field, channel } => Some((field, channel)),
                    _ => None,
                })
        }));
        let agents = &*agents;
        let mut rebuilt: Vec<(usize, usize)> = Vec::new();
        for (fi, f) in self.fields.iter_mut().enumerate() {
            if f.shuffle_every > 0 && frame > 0 && frame.is_multiple_of(f.shuffle_every) {
                for c in 0..f.channels.len() {
                    let s = mix(seed ^ mix(frame ^ mix(((fi as u64) << 32) | c as u64)));
                    // Cannot fail: the count was checked against the grid when it was set.
                    let _ = f.channels.randomize_goals(c, f.shuffle_count, s);
                }
            }
            let dirty: Vec<usize> = (0..f.channels.len())
                .filter(|&c| f.channels.is_dirty(c))
                .collect();
            if !dirty.is_empty() {
                // Cannot fail: goals and decay were checked on the way in.
                let n = f.channels.rebuild_dirty().unwrap_or(0);
                self.rebuilds += n as u64;
                rebuilt.extend(dirty.into_iter().map(|c| (fi, c)));
            }
        }
        if !rebuilt.is_empty() {
            for i in 0..agents.len() {
                let g = agents.group[i] as usize;
                if let Some(Some(fc)) = self.follow.get(g)
                    && rebuilt.contains(fc)
                {
                    self.set_arrived(agents.ids[i], false);
                }
            }
        }
        self.prev_x.clear();
        self.prev_x.extend_from_slice(&agents.pos_x);
        self.prev_y.clear();
        self.prev_y.extend_from_slice(&agents.pos_y);
    }

    /// The linear steering of `follow_field` for one agent: a desired velocity (kinematic) or
    /// the force towards it (dynamic); braking on a goal cell or once arrived.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn follow(
        &self,
        field: usize,
        channel: usize,
        id: AgentId,
        position: Vec2,
        velocity: Vec2,
        max_speed: f32,
        kinematic: bool,
    ) -> Vec2 {
        let Some(flow) = self
            .fields
            .get(field)
            .and_then(|f| f.channels.flow(channel))
        else {
            return Vec2::ZERO;
        };
        let dir = if self.arrived_of(id) {
            Vec2::ZERO
        } else {
            flow.sample(position)
        };
        if kinematic {
            dir * max_speed
        } else if dir == Vec2::ZERO {
            // Brake to rest over a tenth of a second (as arrive does inside its target radius).
            -velocity * 10.0
        } else {
            dir * max_speed - velocity
        }
    }

    /// The bounds-phase work: wall non-penetration, the walkers' step, arrivals.
    pub(crate) fn after_move(&mut self, agents: &mut Agents, dt: f32, exec_parallel: bool) {
        if self.fields.is_empty() {
            return;
        }
        let n = agents.len();
        debug_assert_eq!(self.prev_x.len(), n);
        for f in &self.fields {
            let walls = Walls::of(f.channels.grid(), &f.wall_bits);
            let kernel = |px: &mut [f32],
                          py: &mut [f32],
                          vx: &mut [f32],
                          vy: &mut [f32],
                          ox: &[f32],
                          oy: &[f32]| {
                for k in 0..px.len() {
                    let prev = Vec2::new(ox[k], oy[k]);
                    let p = Vec2::new(px[k], py[k]);
                    if walls.unchanged(prev, p) {
                        continue;
                    }
                    let (p, v) = resolve(walls.grid, prev, p, Vec2::new(vx[k], vy[k]));
                    (px[k], py[k], vx[k], vy[k]) = (p.x, p.y, v.x, v.y);
                }
            };
            if exec_parallel {
                (
                    agents.pos_x.par_chunks_mut(WALL_CHUNK),
                    agents.pos_y.par_chunks_mut(WALL_CHUNK),
                    agents.vel_x.par_chunks_mut(WALL_CHUNK),
                    agents.vel_y.par_chunks_mut(WALL_CHUNK),
                    self.prev_x.par_chunks(WALL_CHUNK),
                    self.prev_y.par_chunks(WALL_CHUNK),
                )
                    .into_par_iter()
                    .for_each(|(px, py, vx, vy, ox, oy)| kernel(px, py, vx, vy, ox, oy));
            } else {
                kernel(
                    &mut agents.pos_x,
                    &mut agents.pos_y,
                    &mut agents.vel_x,
                    &mut agents.vel_y,
                    &self.prev_x,
                    &self.prev_y,
                );
            }
        }
        // Walkers: one discrete step, then their agents stand on their cells' centres.
        let mut arrivals: Vec<AgentId> = Vec::new();
        for f in &mut self.fields {
            for wg in &mut f.walkers {
                // Cannot fail: the channels were rebuilt in the index phase.
                let _ = wg.walkers.step_channels(&f.channels, wg.policy);
                let grid = f.channels.grid();
                for (w, &id) in wg.ids.iter().enumerate() {
                    let Some(i) = agents.index_of(id) else {
                        continue;
                    };
                    let (x, y) = wg.walkers.position(w);
                    let c = grid.cell_center(x, y);
                    let old = Vec2::new(self.prev_x[i], self.prev_y[i]);
                    let v = (c - old) / dt;
                    (agents.pos_x[i], agents.pos_y[i]) = (c.x, c.y);
                    (agents.vel_x[i], agents.vel_y[i]) = (v.x, v.y);
                    if wg.walkers.is_arrived(w) {
                        arrivals.push(id);
                    }
                }
            }
        }
        for id in arrivals {
            self.set_arrived(id, true);
        }
        // Followers standing on a goal of their channel arrive (found in parallel, in index
        // order, then flagged).
        let fields = &self.fields;
        // Per group: the flow its agents follow and that channel's goals, looked up once. A
        // short goal list is searched instead of the flow's cells (no memory traffic).
        let flows: Vec<Option<GoalCheck>> = self
            .follow
            .iter()
            .map(|fc| {
                let (field, channel) = (*fc)?;
                let channels = &fields.get(field)?.channels;
                Some((channels.flow(channel)?, channels.goals(channel).ok()?))
            })
            .collect();
        if flows.iter().all(Option::is_none) {
            return;
        }
        let agents = &*agents;
        let on_goal = |i: usize| {
            let Some(&Some((flow, goals))) = flows.get(agents.group[i] as usize) else {
                return false;
            };
            let p = Vec2::new(agents.pos_x[i], agents.pos_y[i]);
            if goals.len() <= 16 {
                flow.world_to_cell(p).is_some_and(|c| goals.contains(&c))
            } else {
                flow.is_goal_at(p)
            }
        };
        let found: Vec<AgentId> = if exec_parallel {
            (0..n)
                .into_par_iter()
                .with_min_len(WALL_CHUNK)
                .filter(|&i| on_goal(i))
                .map(|i| agents.ids[i])
                .collect()
        } else {
            (0..n)
                .filter(|&i| on_goal(i))
                .map(|i| agents.ids[i])
                .collect()
        };
        for id in found {
            self.set_arrived(id, true);
        }
    }
}

impl FieldSet {
    fn get_mut(&mut self, field: usize) -> Result<&mut WorldField> {
        let count = self.fields.len();
        self.fields.get_mut(field).ok_or_else(|| Error::Invalid {
            name: "field".into(),
            reason: format!("no field {field} (there are {count})"),
        })
    }
}

impl World {
    /// Adds a field (an occupancy grid with its goal channels) and returns its number, which
    /// `follow_field` behaviours name. Dirty channels are built at the start of the next step.
    ///
    /// # Examples
    /// ```
    /// # fn main() -> throng::Result<()> {
    /// use throng::field::{GoalChannels, Neighbourhood, OccupancyGrid};
    /// use throng::prelude::*;
    /// let grid = OccupancyGrid::parse_ascii("......\n.####.\n......\n", "<map>")?.grid;
    /// let mut channels = GoalChannels::new(grid, 0.9, Neighbourhood::Eight)?;
    /// channels.add_channel(&[(5, 2)])?;
    /// let follow = SteeringProfile::single(Behaviour::FollowField { field: 0, channel: 0 });
    /// let mut world = World::builder()
    ///     .bounds(Bounds::bounded(6.0, 3.0)?)
    ///     .group(GroupParams { max_speed: 3.0, ..GroupParams::kinematic(follow) })
    ///     .agent(AgentInit::at(Vec2::new(0.5, 0.5), 0))
    ///     .build()?;
    /// world.add_field(channels)?;
    /// for _ in 0..200 {
    ///     world.step(1.0 / 30.0)?;
    /// }
    /// assert!(world.has_arrived(AgentId(0)));
    /// # Ok(()) }
    /// ```
    ///
    /// # Errors
    /// [`Error::Invalid`] when an agent already stands inside one of the grid's walls.
    pub fn add_field(&mut self, channels: GoalChannels) -> Result<usize> {
        let grid = channels.grid();
        if let Some(i) = (0..self.agents.len()).find(|&i| in_wall(grid, self.agents.position(i))) {
            return Err(Error::Invalid {
                name: "field".into(),
                reason: format!(
                    "agent {} stands inside a wall of the field's grid",
                    self.agents.ids[i]
                ),
            });
        }
        let bits = wall_bits(grid);
        self.fields.fields.push(WorldField {
            channels,
            shuffle_every: 0,
            shuffle_count: 0,
            walkers: Vec::new(),
            wall_bits: bits,
        });
        Ok(self.fields.fields.len() - 1)
    }

    /// Number of fields.
    #[must_use]
    pub fn field_count(&self) -> usize {
        self.fields.fields.len()
    }

    /// The goal channels of `field` (with their potential and flow fields once built).
    #[must_use]
    pub fn field(&self, field: usize) -> Option<&GoalChannels> {
        self.fields.fields.get(field).map(|f| &f.channels)
    }

    /// Moves the goals of one channel; the channel is rebuilt at the start of the next step and
    /// its followers' arrival flags are reset then.
    ///
    /// # Errors
    /// [`Error::Invalid`] for an unknown field or channel, or bad goals (see
    /// [`GoalChannels::set_goals`]).
    pub fn set_field_goals(
        &mut self,
        field: usize,
        channel: usize,
        goals: &[(u32, u32)],
    ) -> Result<()> {
        self.fields
            .get_mut(field)?
            .channels
            .set_goals(channel, goals)
    }

    /// Re-randomises the goals of one channel: `n` distinct free cells drawn with `seed`.
    ///
    /// # Errors
    /// As [`GoalChannels::randomize_goals`], and for an unknown field.
    pub fn randomize_field_goals(
        &mut self,
        field: usize,
        channel: usize,
        n: usize,
        seed: u64,
    ) -> Result<()> {
        self.fields
            .get_mut(field)?
            .channels
            .randomize_goals(channel, n, seed)
    }

    /// Re-randomises every channel's goals of `field` to `count` free cells each, every `every`
    /// frames (the notes' click; 0 turns it off). The draws derive from the world seed, the
    /// frame and the channel.
    ///
    /// # Errors
    /// [`Error::Invalid`] for an unknown field, `count == 0` with `every > 0`, or a `count`
    /// larger than the grid's free cells.
    pub fn shuffle_field_goals_every(
        &mut self,
        field: usize,
        every: u64,
        count: usize,
    ) -> Result<()> {
        let f = self.fields.get_mut(field)?;
        if every > 0 && (count == 0 || count > f.channels.grid().free_count()) {
            return Err(Error::Invalid {
                name: "goal count".into(),
                reason: format!(
                    "{count} goals requested; the grid has {} free cells",
                    f.channels.grid().free_count()
                ),
            });
        }
        f.shuffle_every = every;
        f.shuffle_count = count;
        Ok(())
    }

    /// Makes cell `(x, y)` of `field` a wall or free ground; the field's channels are rebuilt
    /// at the start of the next step.
    ///
    /// # Errors
    /// [`Error::Invalid`] for an unknown field, a cell outside the grid, a goal cell becoming a
    /// wall, or a cell that an agent or walker stands on becoming a wall.
    pub fn set_field_blocked(&mut self, field: usize, x: u32, y: u32, blocked: bool) -> Result<()> {
        let f = self.fields.get_mut(field)?;
        f.channels.grid().check_cell("cell", x, y)?;
        if blocked {
            let grid = f.channels.grid();
            let taken = (0..self.agents.len())
                .find(|&i| cell_of(grid, self.agents.position(i)) == Some((x as usize, y as usize)))
                .map(|i| self.agents.ids[i]);
            let walker = f.walkers.iter().any(|w| w.walkers.occupant(x, y).is_some());
            if let Some(id) = taken {
                return Err(Error::Invalid {
                    name: "cell".into(),
                    reason: format!("agent {id} stands on ({x}, {y})"),
                });
            }
            if walker {
                return Err(Error::Invalid {
                    name: "cell".into(),
                    reason: format!("a walker stands on ({x}, {y})"),
                });
            }
        }
        let f = self.fields.get_mut(field)?;
        f.channels.set_blocked(x, y, blocked)?;
        let i = y as usize * f.channels.grid().width() as usize + x as usize;
        if blocked {
            f.wall_bits[i / 64] |= 1 << (i % 64);
        } else {
            f.wall_bits[i / 64] &= !(1 << (i % 64));
        }
        Ok(())
    }

    /// Turns the agents of `group` into grid walkers on `field` following `channel` (the notes'
    /// discrete movement): each is moved to the centre of its cell (or, when another walker has
    /// that cell, of the next free cell in row-major order), and from then on every step moves it
    /// at most one cell, by [`GridWalkers`] with `policy`, overriding its own steering. Returns
    /// the number of walkers. Agents added to the group later are not walkers.
    ///
    /// # Errors
    /// [`Error::Invalid`] for an unknown field or channel, an agent outside the grid or on a
    /// wall, or more walkers than free cells; [`Error::UnknownGroup`].
    pub fn add_walkers(
        &mut self,
        field: usize,
        group: usize,
        channel: usize,
        policy: WalkPolicy,
    ) -> Result<usize> {
        if group >= self.groups.len() {
            return Err(Error::UnknownGroup {
                group,
                count: self.groups.len(),
            });
        }
        let f = self.fields.get_mut(field)?;
        f.channels.goals(channel)?;
        let mut ids: Vec<AgentId> = (0..self.agents.len())
            .filter(|&i| self.agents.group[i] as usize == group)
            .map(|i| self.agents.ids[i])
            .collect();
        ids.sort_unstable();
        let grid = f.channels.grid();
        let (w, len) = (grid.width() as usize, grid.len());
        let mut taken = vec![false; len];
        for wg in &f.walkers {
            for k in 0..wg.walkers.len() {
                if !wg.walkers.is_arrived(k) {
                    let (x, y) = wg.walkers.position(k);
                    taken[y as usize * w + x as usize] = true;
                }
            }
        }
        let mut starts = Vec::with_capacity(ids.len());
        for &id in &ids {
            let i = self.agents.index_of(id).expect("live agent");
            let p = self.agents.position(i);
            let Some((x, y)) = cell_of(grid, p) else {
                return Err(Error::Invalid {
                    name: "walker".into(),
                    reason: format!("agent {id} at {p} lies outside the field's grid"),
                });
            };
            if !grid.cells()[y * w + x].is_free() {
                return Err(Error::Invalid {
                    name: "walker".into(),
                    reason: format!("agent {id} stands inside a wall"),
                });
            }
            let start = y * w + x;
            let Some(k) = (0..len)
                .map(|k| (start + k) % len)
                .find(|&k| grid.cells()[k].is_free() && !taken[k])
            else {
                return Err(Error::Invalid {
                    name: "walker".into(),
                    reason: "more walkers than free cells".into(),
                });
            };
            taken[k] = true;
            starts.push(((k % w) as u32, (k / w) as u32));
        }
        let walkers = GridWalkers::with_channels(grid, &starts, &vec![channel as u32; ids.len()])?;
        for (&id, &(x, y)) in ids.iter().zip(&starts) {
            let i = self.agents.index_of(id).expect("live agent");
            let c = grid.cell_center(x, y);
            (self.agents.pos_x[i], self.agents.pos_y[i]) = (c.x, c.y);
            (self.agents.vel_x[i], self.agents.vel_y[i]) = (0.0, 0.0);
        }
        let n = ids.len();
        f.walkers.push(WalkerGroup {
            walkers,
            ids,
            policy,
        });
        Ok(n)
    }

    /// The `k`-th walker group of `field` (in [`World::add_walkers`] order).
    #[must_use]
    pub fn walkers(&self, field: usize, k: usize) -> Option<&GridWalkers> {
        self.fields
            .fields
            .get(field)?
            .walkers
            .get(k)
            .map(|w| &w.walkers)
    }

    /// Whether agent `id` has reached a goal of the channel it follows (`follow_field` or a
    /// walker) since that channel was last rebuilt.
    #[must_use]
    pub fn has_arrived(&self, id: AgentId) -> bool {
        self.fields.arrived_of(id)
    }

    /// Number of live agents that have arrived (see [`World::has_arrived`]).
    #[must_use]
    pub fn arrived_count(&self) -> usize {
        self.agents
            .ids
            .iter()
            .filter(|&&id| self.fields.arrived_of(id))
            .count()
    }

    /// Channel rebuilds done so far, over all fields.
    #[must_use]
    pub fn field_rebuilds(&self) -> u64 {
        self.fields.rebuilds
    }

    /// Whether world point `p` lies inside a wall cell of some field.
    #[must_use]
    pub fn in_field_wall(&self, p: Vec2) -> bool {
        self.fields
            .fields
            .iter()
            .any(|f| in_wall(f.channels.grid(), p))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn grid(text: &str) -> OccupancyGrid {
        OccupancyGrid::parse_ascii(text, "<map>").unwrap().grid
    }

    #[test]
    fn moves_into_walls_slide_or_stop() {
        let g = grid("..\n#.\n");
        // Straight down into the wall: stays, vertical velocity removed.
        let (p, v) = resolve(
            &g,
            Vec2::new(0.5, 0.9),
            Vec2::new(0.5, 1.2),
            Vec2::new(0.0, 3.0),
        );
        assert_eq!((p, v), (Vec2::new(0.5, 0.9), Vec2::ZERO));
        // Diagonal into the wall: slides along x.
        let (p, v) = resolve(
            &g,
            Vec2::new(0.5, 0.9),
            Vec2::new(0.7, 1.2),
            Vec2::new(2.0, 3.0),
        );
        assert_eq!((p, v), (Vec2::new(0.7, 0.9), Vec2::new(2.0, 0.0)));
    }

    /// The fast path changes nothing: where it keeps a move, [`resolve`] keeps it too.
    #[test]
    fn the_unchanged_shortcut_agrees_with_resolve() {
        use rand::{RngExt, SeedableRng};
        for (cell_size, origin) in [
            (1.0, Vec2::ZERO),
            (0.5, Vec2::new(-3.0, 2.0)),
            (0.7, Vec2::ONE),
        ] {
            let g = OccupancyGrid::caves(24, 24, 0.5, 3)
                .unwrap()
                .with_geometry(cell_size, origin)
                .unwrap();
            let bits = wall_bits(&g);
            let walls = Walls::of(&g, &bits);
            let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(9);
            let mut kept = 0;
            for _ in 0..20_000 {
                let prev = origin
                    + Vec2::new(rng.random_range(-1.0..25.0), rng.random_range(-1.0..25.0))
                        * cell_size;
                let step = if rng.random_bool(0.8) { 0.6 } else { 3.0 };
                let p = prev
                    + Vec2::new(rng.random_range(-step..step), rng.random_range(-step..step))
                        * cell_size;
                let v = Vec2::new(1.0, -2.0);
                if walls.unchanged(prev, p) {
                    kept += 1;
                    assert_eq!(resolve(&g, prev, p, v), (p, v), "{prev} -> {p}");
                }
            }
            assert!(kept > 5_000, "{kept}");
        }
    }

    #[test]
    fn corners_are_not_cut_and_long_moves_do_not_tunnel() {
        let g = grid(".#\n#.\n");
        let (p, _) = resolve(&g, Vec2::new(0.9, 0.9), Vec2::new(1.1, 1.1), Vec2::ONE);
        assert_eq!(p, Vec2::new(0.9, 0.9));
        let g = grid(".#.\n");
        let (p, _) = resolve(&g, Vec2::new(0.5, 0.5), Vec2::new(2.5, 0.5), Vec2::X);
        assert!(p.x < 1.0, "{p}");
    }
}
