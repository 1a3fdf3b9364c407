//! The fields subsystem: goal channels that agents follow, walls they cannot enter, grid
//! walkers, and their per-step state.
//!
//! A world owns any number of fields (`World::add_field`), each a [`GoalChannels`]: one
//! occupancy grid with one potential and flow field per goal channel. [`FieldSet`] owns them and
//! exposes two hooks that the world calls, none of them inside the parallel steering pass:
//!
//! 1. **prepare** (the `fields` phase, before steering): goals due for re-randomisation get new
//!    cells, dirty channels (moved goals, changed walls) are rebuilt, and the frame-start
//!    positions are kept;
//!    then agents of `choose_exit` groups choose a channel, or revise their choice where the
//!    travel times changed (a reroute or a rebuild), keeping it unless another channel is
//!    cheaper by the group's switching gain;
//! 2. during **steering**, `follow_field` samples its channel's flow at the agent's position
//!    (read only, [`FieldSet::follow`]), `choose_exit` its chosen channel's;
//! 3. **after_move** (the `fields` phase, after integration and the world's bounds): every agent
//!    whose move would end inside a wall cell of any field slides along the free axis (at a
//!    wall cell's corner, along the axis whose cell face the move reaches first) or stays
//!    where it was, and loses the velocity component into the wall (on a torus the move is the
//!    short hop across the seam, and wall lookups wrap); grid walkers take their discrete step;
//!    agents on a goal of the channel they follow are marked arrived.
//!
//! Invariants: after a step no agent that started it on free ground stands inside a wall (moves
//! are checked in sub-steps of at most half a cell, and a diagonal cell change needs one of the
//! two orthogonal cells free, so walls meeting at a corner are not crossed); channels are never
//! dirty while agents steer; arrival flags are reset when the channel an agent follows is
//! rebuilt; a chosen channel changes only in the prepare hook;
//! everything is independent of the number of threads; frames without a goal change allocate
//! nothing.

use glam::Vec2;
use rayon::prelude::*;

use super::channels::ChannelSet;
use super::congestion::Congestion;
use super::occupancy::cell_of;
use crate::agents::{AgentId, Agents};
use crate::bounds::Bounds;
use crate::error::{Error, Result};
use crate::field::{FlowField, GoalChannels, GridWalkers, OccupancyGrid, WalkPolicy};

/// Agents per parallel task of the wall check.
const WALL_CHUNK: usize = 4096;

/// Moves checked together by the field walls' first test ([`Walls::same_open_cell`]).
const WALL_LANES: usize = 8;

/// Grid walkers made of the agents of one group.
#[derive(Debug)]
pub(crate) struct WalkerGroup {
    pub(crate) walkers: GridWalkers,
    /// The agent each walker moves.
    pub(crate) ids: Vec<AgentId>,
    pub(crate) policy: WalkPolicy,
}

/// One field of the world.
#[derive(Debug)]
pub(crate) struct WorldField {
    pub(crate) channels: GoalChannels,
    /// Re-randomise every channel's goals every this many frames (0: never) ...
    pub(crate) shuffle_every: u64,
    /// ... to this many goals each.
    pub(crate) shuffle_count: usize,
    /// With [`FlowMetric::Quickest`](super::FlowMetric): set the costs from the crowd every this
    /// many frames (0: never) ...
    pub(crate) reroute_every: u64,
    /// ... over density windows of this half-side (world units).
    pub(crate) density_radius: f32,
    pub(crate) congestion: Congestion,
    pub(crate) walkers: Vec<WalkerGroup>,
    /// One bit per cell of the grid (row-major), set on walls: the wall check's compact copy
    /// of the grid, kept in step with it by `World::set_field_blocked`.
    pub(crate) wall_bits: Vec<u64>,
}

/// Which channel of a field a group's agents follow.
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) enum FollowChannel {
    /// This channel (`follow_field`).
    Fixed(usize),
    /// Each agent's own choice among these channels (`choose_exit`), kept until another's
    /// travel time falls below `1 - switch_gain` times its own.
    Chosen {
        channels: ChannelSet,
        switch_gain: f32,
    },
}

/// No channel chosen yet (a fresh agent, before its first prepare hook).
const UNCHOSEN: u8 = u8::MAX;

/// The wall bits of `grid` (see `WorldField::wall_bits`).
pub(crate) fn wall_bits(grid: &OccupancyGrid) -> Vec<u64> {
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
    pub(crate) fields: Vec<WorldField>,
    /// Per agent id: reached a goal of its channel since the channel was last rebuilt.
    pub(crate) arrived: Vec<bool>,
    /// Per group: the field and channel its first `follow_field` or `choose_exit` behaviour
    /// names.
    follow: Vec<Option<(usize, FollowChannel)>>,
    /// Per agent id: the channel it chose (`choose_exit`), or `UNCHOSEN`.
    pub(crate) chosen: Vec<u8>,
    /// Channel rebuilds so far.
    pub(crate) rebuilds: u64,
    /// Scratch of the reordering sort, and its permutation.
    sort_keys: Vec<u64>,
    perm: Vec<u32>,
    /// Scratch: the `(field, channel)`s rebuilt this frame.
    rebuilt: Vec<(usize, usize)>,
    /// Scratch: per agent, whether it stands on a goal of the channel it follows.
    on_goal: Vec<bool>,
    /// Scratch: the cell costs of a reroute.
    costs: Vec<f32>,
    /// Scratch: per field, whether its travel times changed this frame.
    due: Vec<bool>,
}

/// Reorders agents by the row-major cell of `grid` they stand in (agents outside last), so that
/// field lookups walk memory in order. Stable for agents sharing a cell.
fn reorder_by_cell(
    agents: &mut Agents,
    grid: &OccupancyGrid,
    keys: &mut Vec<u64>,
    perm: &mut Vec<u32>,
) {
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
    perm.clear();
    perm.extend(keys.iter().map(|&k| k as u32));
    agents.reorder(perm);
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
pub(crate) fn in_wall(grid: &OccupancyGrid, p: Vec2) -> bool {
    cell_of(grid, p).is_some_and(|(x, y)| !grid.cells()[y * grid.width() as usize + x].is_free())
}

/// A grid's walls as the per-agent wall check reads them, with the cell lookup of
/// [`cell_of`] made cheap: when the cell size is a power of two, multiplying by its reciprocal
/// is exact, so it gives the same cells as the division.
#[derive(Clone, Copy)]
struct Walls<'a> {
    /// The grid's wall bits.
    bits: &'a [u64],
    origin: Vec2,
    cell_size: f32,
    /// `1 / cell_size` when that is exact.
    inverse: Option<f32>,
    half: f32,
    width: usize,
    height: usize,
    /// The world's bounds: on a torus, lookups wrap positions into the world first.
    bounds: Bounds,
}

impl<'a> Walls<'a> {
    fn of(grid: &'a OccupancyGrid, bits: &'a [u64], bounds: Bounds) -> Self {
        // `bits` is `wall_bits(grid)` (compared cell by cell: a warm step allocates nothing).
        debug_assert!(
            bits.len() == grid.len().div_ceil(64)
                && grid
                    .cells()
                    .iter()
                    .enumerate()
                    .all(|(i, c)| (bits[i / 64] >> (i % 64)) & 1 == u64::from(!c.is_free()))
        );
        let cell_size = grid.cell_size();
        let inverse = 1.0 / cell_size;
        let exact = cell_size.is_normal()
            && inverse.is_normal()
            && cell_size.to_bits() & 0x007f_ffff == 0
            && inverse * cell_size == 1.0;
        Walls {
            bits,
            origin: grid.origin(),
            cell_size,
            inverse: exact.then_some(inverse),
            half: 0.5 * cell_size,
            width: grid.width() as usize,
            height: grid.height() as usize,
            bounds,
        }
    }

    /// The end of the move from `prev` to `p` as the short hop it was: on a torus the nearest
    /// image of `p`, which may lie outside the world; elsewhere `p` itself.
    #[inline]
    fn hop(&self, prev: Vec2, p: Vec2) -> Vec2 {
        if self.bounds.is_torus() {
            prev + self.bounds.offset(prev, p)
        } else {
            p
        }
    }

    /// Whether world point `p` (any image on a torus) lies in a wall cell.
    #[inline]
    fn in_wall(&self, p: Vec2) -> bool {
        self.is_wall(self.cell(p))
    }

    /// Whether moving from `a` to `b` (at most one cell apart on each axis) is allowed: `b` is
    /// not in a wall, and a diagonal cell change has one of its two orthogonal cells free.
    #[inline]
    fn can_move(&self, a: Vec2, b: Vec2) -> bool {
        let cb = self.cell(b);
        if self.is_wall(cb) {
            return false;
        }
        self.corner_free(self.cell(a), cb)
    }

    /// The axis to slide along when a move by `step` from `from` ends in a wall cell diagonal
    /// to `from`'s with both orthogonal cells open: the move leaves `from`'s cell across the
    /// face it reaches first, so it meets the wall cell's face across the other axis and
    /// keeps its motion along the first. At the corner itself the larger component is kept,
    /// and a move exactly along the diagonal stops (`None`): no axis is preferred to the
    /// other, so that the rule is the same in a turned or mirrored scene.
    fn first_face(&self, from: Vec2, step: Vec2) -> Option<Axis> {
        let (u, du) = (self.raster(from), self.cells(step));
        let within = u - u.floor();
        let left = |f: f32, d: f32| if d > 0.0 { 1.0 - f } else { f };
        // Crossing times along each axis, compared without dividing: `left.x / |du.x|` against
        // `left.y / |du.y|`.
        let tx = left(within.x, du.x) * du.y.abs();
        let ty = left(within.y, du.y) * du.x.abs();
        let (ax, ay) = (du.x.abs(), du.y.abs());
        if tx < ty || tx == ty && ax > ay {
            Some(Axis::X)
        } else if ty < tx || ay > ax {
            Some(Axis::Y)
        } else {
            None
        }
    }

    /// Whether a step from cell `a` to cell `b` is allowed at corners: a diagonal change needs
    /// one of the two orthogonal cells free (anything else passes).
    #[inline]
    fn corner_free(&self, a: Option<usize>, b: Option<usize>) -> bool {
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

    /// [`cell_of`] as a row-major cell index.
    #[inline]
    fn cell(&self, p: Vec2) -> Option<usize> {
        super::occupancy::cell_coords(self.raster(p), self.width, self.height)
            .map(|(x, y)| y * self.width + x)
    }

    /// World point `p` (wrapped into the world on a torus) in cell units from the origin.
    #[inline]
    fn raster(&self, p: Vec2) -> Vec2 {
        let p = if self.bounds.is_torus() {
            self.bounds.wrap(p)
        } else {
            p
        };
        self.cells(p - self.origin)
    }

    /// World vector `d` in cell units.
    #[inline]
    fn cells(&self, d: Vec2) -> Vec2 {
        match self.inverse {
            Some(inv) => d * inv,
            None => d / self.cell_size,
        }
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

    /// For up to [`WALL_LANES`] moves from `(ax, ay)` to `(bx, by)` (the first of each slice;
    /// missing lanes are `false`), whether each starts and ends in the same open cell of a
    /// world that does not wrap: a move [`Walls::unchanged`] leaves as it is. The cells are
    /// [`Walls::cell`]'s, computed in lanes.
    #[inline]
    fn same_open_cell(&self, ax: &[f32], ay: &[f32], bx: &[f32], by: &[f32]) -> [bool; WALL_LANES] {
        let mut out = [false; WALL_LANES];
        let n = WALL_LANES.min(ax.len());
        if self.bounds.is_torus() || n < WALL_LANES {
            return out;
        }
        let (w, h) = (self.width as f32, self.height as f32);
        let cell = |x: f32, y: f32| {
            let (dx, dy) = (x - self.origin.x, y - self.origin.y);
            let (ux, uy) = match self.inverse {
                Some(inv) => (dx * inv, dy * inv),
                None => (dx / self.cell_size, dy / self.cell_size),
            };
            let inside = ux >= 0.0 && uy >= 0.0 && ux <= w && uy <= h;
            let c =
                (uy as usize).min(self.height - 1) * self.width + (ux as usize).min(self.width - 1);
            (inside, c)
        };
        let mut cells = [0_usize; WALL_LANES];
        for k in 0..WALL_LANES {
            let ((ia, ca), (ib, cb)) = (cell(ax[k], ay[k]), cell(bx[k], by[k]));
            out[k] = ia & ib & (ca == cb);
            cells[k] = cb;
        }
        for k in 0..WALL_LANES {
            out[k] = out[k] && !self.wall(cells[k]);
        }
        out
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
        self.corner_free(a, b)
    }
}

/// An axis of the field's raster.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Axis {
    X,
    Y,
}

/// The non-penetration rule for one agent: the position and velocity after moving from `prev`
/// towards `p` without entering a wall.
fn resolve(walls: &Walls, prev: Vec2, p: Vec2, mut v: Vec2) -> (Vec2, Vec2) {
    if p == prev || !walls.in_wall(p) && walls.cell(prev) == walls.cell(p) {
        return (p, v);
    }
    if walls.in_wall(prev) {
        // Placed inside a wall from outside the step: let it leave.
        return (p, v);
    }
    let mut d = p - prev;
    let half = walls.half;
    let n = ((d.x.abs().max(d.y.abs()) / half).ceil() as u32).clamp(1, 1 << 16);
    let mut step = d / n as f32;
    let mut cur = prev;
    for k in 0..n {
        let last = k + 1 == n;
        let to = if last { prev + d } else { cur + step };
        if walls.can_move(cur, to) {
            cur = to;
            continue;
        }
        let slide_x = Vec2::new(to.x, cur.y);
        let slide_y = Vec2::new(cur.x, to.y);
        let along_x = step.x != 0.0 && walls.can_move(cur, slide_x);
        let along_y = step.y != 0.0 && walls.can_move(cur, slide_y);
        // Either slide is open only where the move meets a wall cell's corner: the face it
        // reaches first decides, which a turned or mirrored scene reaches first too.
        let along = match (along_x, along_y) {
            (true, true) => walls.first_face(cur, step),
            (x, y) => x.then_some(Axis::X).or(y.then_some(Axis::Y)),
        };
        if along == Some(Axis::X) {
            cur = slide_x;
            v.y = 0.0;
            step.y = 0.0;
            d.y = cur.y - prev.y;
        } else if along == Some(Axis::Y) {
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

/// Sets or clears the arrival flag of agent `id`.
fn set_arrived(arrived: &mut Vec<bool>, id: AgentId, on: bool) {
    let k = id.0 as usize;
    if k >= arrived.len() {
        if !on {
            return;
        }
        arrived.resize(k + 1, false);
    }
    arrived[k] = on;
}

impl FieldSet {
    /// Whether the world has any field (the hooks have work to do).
    pub(crate) fn is_active(&self) -> bool {
        !self.fields.is_empty()
    }

    /// Whether agent `id` has arrived (see [`FieldSet::after_move`]).
    pub(crate) fn arrived_of(&self, id: AgentId) -> bool {
        self.arrived.get(id.0 as usize).copied().unwrap_or(false)
    }

    /// Sets, per group, the field and channel its agents follow (from the compiled plans).
    pub(crate) fn set_follow(
        &mut self,
        follow: impl Iterator<Item = Option<(usize, FollowChannel)>>,
    ) {
        self.follow.clear();
        self.follow.extend(follow);
    }

    /// The channel agent `id` follows under `channel`: the fixed one, or its choice (the
    /// lowest channel of the set until it has chosen).
    #[inline]
    pub(crate) fn channel_of(&self, channel: FollowChannel, id: AgentId) -> usize {
        match channel {
            FollowChannel::Fixed(c) => c,
            FollowChannel::Chosen { channels, .. } => {
                match self.chosen.get(id.0 as usize).copied() {
                    Some(c) if c != UNCHOSEN && channels.contains(usize::from(c)) => usize::from(c),
                    _ => channels.iter(64).next().unwrap_or(0),
                }
            }
        }
    }

    /// Records that agent `id` (of `issued` ids) has chosen `channel` (a restored checkpoint).
    pub(crate) fn choose_for(&mut self, id: AgentId, channel: usize, issued: usize) {
        if self.chosen.len() < issued {
            self.chosen.resize(issued, UNCHOSEN);
        }
        self.chosen[id.0 as usize] = channel as u8;
    }

    /// The channel agent `id` has chosen (`choose_exit`), if it has.
    pub(crate) fn chosen_of(&self, id: AgentId) -> Option<usize> {
        self.chosen
            .get(id.0 as usize)
            .copied()
            .filter(|&c| c != UNCHOSEN)
            .map(usize::from)
    }

    /// Exit choice: every agent of a `choose_exit` group that has not chosen yet, or whose
    /// field was rerouted this frame (`due[field]`), compares the travel costs of its cell to
    /// the channels of its set; it takes the cheapest when it has no choice (or its choice is
    /// out of reach), and otherwise switches only to a channel cheaper than `1 - switch_gain`
    /// times its own. Ties go to the lower channel. Sequential: a handful of lookups per agent,
    /// in index order, the same for any thread count.
    fn choose(&mut self, agents: &Agents, due: &[bool]) {
        if !self
            .follow
            .iter()
            .any(|f| matches!(f, Some((_, FollowChannel::Chosen { .. }))))
        {
            return;
        }
        for i in 0..agents.len() {
            let Some(&Some((
                fi,
                FollowChannel::Chosen {
                    channels,
                    switch_gain,
                },
            ))) = self.follow.get(agents.group[i] as usize)
            else {
                continue;
            };
            let Some(f) = self.fields.get(fi) else {
                continue;
            };
            let k = agents.ids[i].0 as usize;
            // A choice outside the set or the field (the group's set has changed, or a
            // checkpoint says so) counts as none.
            let current = match self.chosen[k] {
                c if c != UNCHOSEN
                    && !(channels.contains(usize::from(c))
                        && usize::from(c) < f.channels.len()) =>
                {
                    UNCHOSEN
                }
                c => c,
            };
            if current != UNCHOSEN && !due.get(fi).copied().unwrap_or(false) {
                continue;
            }
            let p = agents.position(i);
            // The cheapest channel of the set, and the cost of the current one (which lies in
            // the set) from the same lookups.
            let (mut best, mut own): (Option<(usize, f32)>, Option<f32>) = (None, None);
            for c in channels.iter(f.channels.len()) {
                let Some(t) = f.channels.travel_cost(c, p) else {
                    continue;
                };
                if c == usize::from(current) {
                    own = Some(t);
                }
                if best.is_none_or(|(_, b)| t < b) {
                    best = Some((c, t));
                }
            }
            let Some((c, t)) = best else {
                continue;
            };
            match own {
                Some(o) if t >= (1.0 - switch_gain) * o => {}
                _ => {
                    // A new channel: whatever was reached before is not its goal.
                    if current != UNCHOSEN
                        && usize::from(current) != c
                        && let Some(a) = self.arrived.get_mut(k)
                    {
                        *a = false;
                    }
                    self.chosen[k] = c as u8;
                }
            }
        }
    }

    /// Orders the agents by the row-major cell of the first field they stand in (agents outside
    /// last; stable within a cell), so that field lookups walk memory in order. Called by the
    /// world's owner of the agent order ([`crate::world::World`]'s prepare phase) on the frames
    /// it chooses this order; never by the fields themselves.
    pub(crate) fn order_by_cell(&mut self, agents: &mut Agents) {
        if let Some(f) = self.fields.first() {
            reorder_by_cell(
                agents,
                f.channels.grid(),
                &mut self.sort_keys,
                &mut self.perm,
            );
        }
    }

    /// The prepare hook, before steering: due goal shuffles and rebuilds of dirty channels
    /// (resetting the arrival flags of their followers). It reads the agents and never reorders
    /// them: the world decides their order before any index is built.
    pub(crate) fn prepare(&mut self, agents: &Agents, seed: u64, frame: u64) {
        if self.fields.is_empty() {
            return;
        }
        // One arrival flag per id ever issued, so that arrivals never grow the table mid-run.
        let issued = agents.ids_issued();
        if self.arrived.len() < issued {
            self.arrived.resize(issued, false);
        }
        if self.chosen.len() < issued {
            self.chosen.resize(issued, UNCHOSEN);
        }
        self.rebuilt.clear();
        for (fi, f) in self.fields.iter_mut().enumerate() {
            if f.shuffle_every > 0 && frame > 0 && frame.is_multiple_of(f.shuffle_every) {
                for c in 0..f.channels.len() {
                    let s = mix(seed ^ mix(frame ^ mix(((fi as u64) << 32) | c as u64)));
                    let r = f.channels.randomize_goals(c, f.shuffle_count, s);
                    debug_assert!(r.is_ok(), "shuffle counts are checked when set: {r:?}");
                }
            }
            let before = self.rebuilt.len();
            self.rebuilt.extend(
                (0..f.channels.len())
                    .filter(|&c| f.channels.is_dirty(c))
                    .map(|c| (fi, c)),
            );
            if self.rebuilt.len() > before {
                let r = f.channels.rebuild_dirty();
                debug_assert!(
                    r.is_ok(),
                    "goals and decay are checked on the way in: {r:?}"
                );
                self.rebuilds += r.unwrap_or(0) as u64;
            }
        }
        if !self.rebuilt.is_empty() {
            for i in 0..agents.len() {
                let g = agents.group[i] as usize;
                if let Some(&Some((field, channel))) = self.follow.get(g)
                    && self
                        .rebuilt
                        .contains(&(field, self.channel_of(channel, agents.ids[i])))
                {
                    set_arrived(&mut self.arrived, agents.ids[i], false);
                }
            }
        }
        // Quickest-path reroutes: new costs, the same goals, so arrivals stand. Exit choices are
        // revised where the travel times changed.
        let mut due = std::mem::take(&mut self.due);
        due.clear();
        due.resize(self.fields.len(), false);
        for &(fi, _) in &self.rebuilt {
            due[fi] = true;
        }
        for (fi, f) in self.fields.iter_mut().enumerate() {
            if f.reroute_every > 0 && frame.is_multiple_of(f.reroute_every) {
                due[fi] = true;
                let positions = (0..agents.len()).map(|i| agents.position(i));
                f.congestion.costs(
                    f.channels.grid(),
                    positions,
                    f.density_radius,
                    &mut self.costs,
                );
                let r = f.channels.set_costs(&self.costs);
                debug_assert!(r.is_ok(), "congestion costs lie in [1, 20]: {r:?}");
                let r = f.channels.rebuild_dirty();
                debug_assert!(r.is_ok(), "the goals are unchanged: {r:?}");
                self.rebuilds += r.unwrap_or(0) as u64;
            }
        }
        self.choose(agents, &due);
        self.due = due;
    }

    /// The flow of `channel` of field `field`, or `None` where there is none (as
    /// [`FieldSet::follow`] reads it).
    #[inline]
    pub(crate) fn flow_of(&self, field: usize, channel: usize) -> Option<&FlowField> {
        self.fields
            .get(field)
            .and_then(|f| f.channels.flow(channel))
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
        let Some(flow) = self.flow_of(field, channel) else {
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

    /// The constrain hook, after integration and the world's bounds: wall non-penetration (on a
    /// torus, a move is checked as the short hop it was, across the seam, then wrapped), the
    /// walkers' step, arrivals.
    /// `prev` holds the frame-start positions.
    pub(crate) fn after_move(
        &mut self,
        agents: &mut Agents,
        (prev_x, prev_y): (&[f32], &[f32]),
        bounds: Bounds,
        dt: f32,
        exec_parallel: bool,
    ) {
        if self.fields.is_empty() {
            return;
        }
        let n = agents.len();
        debug_assert_eq!(prev_x.len(), n);
        for f in &self.fields {
            let walls = Walls::of(f.channels.grid(), &f.wall_bits, bounds);
            let kernel = |px: &mut [f32],
                          py: &mut [f32],
                          vx: &mut [f32],
                          vy: &mut [f32],
                          ox: &[f32],
                          oy: &[f32]| {
                // Blocks of moves that stay inside one open cell, found in lanes, stay as
                // they are; the others are checked one by one.
                let mut still = [false; WALL_LANES];
                for k in 0..px.len() {
                    if k % WALL_LANES == 0 {
                        still = walls.same_open_cell(&ox[k..], &oy[k..], &px[k..], &py[k..]);
                        if still == [true; WALL_LANES] {
                            continue;
                        }
                    }
                    if still[k % WALL_LANES] {
                        continue;
                    }
                    let prev = Vec2::new(ox[k], oy[k]);
                    let p = Vec2::new(px[k], py[k]);
                    // On a torus the wrapped position may lie across the world from the start:
                    // resolve the move as the short hop it was.
                    let hop = walls.hop(prev, p);
                    if walls.unchanged(prev, hop) {
                        continue;
                    }
                    let (q, v) = resolve(&walls, prev, hop, Vec2::new(vx[k], vy[k]));
                    let q = if q == hop { p } else { bounds.wrap(q) };
                    (px[k], py[k], vx[k], vy[k]) = (q.x, q.y, v.x, v.y);
                }
            };
            if exec_parallel {
                (
                    agents.pos_x.par_chunks_mut(WALL_CHUNK),
                    agents.pos_y.par_chunks_mut(WALL_CHUNK),
                    agents.vel_x.par_chunks_mut(WALL_CHUNK),
                    agents.vel_y.par_chunks_mut(WALL_CHUNK),
                    prev_x.par_chunks(WALL_CHUNK),
                    prev_y.par_chunks(WALL_CHUNK),
                )
                    .into_par_iter()
                    .for_each(|(px, py, vx, vy, ox, oy)| kernel(px, py, vx, vy, ox, oy));
            } else {
                kernel(
                    &mut agents.pos_x,
                    &mut agents.pos_y,
                    &mut agents.vel_x,
                    &mut agents.vel_y,
                    prev_x,
                    prev_y,
                );
            }
        }
        // Walkers: one discrete step, then their agents stand on their cells' centres.
        for f in &mut self.fields {
            for wg in &mut f.walkers {
                let r = wg.walkers.step_channels(&f.channels, wg.policy);
                debug_assert!(r.is_ok(), "channels are rebuilt in the prepare hook: {r:?}");
                let grid = f.channels.grid();
                for (w, &id) in wg.ids.iter().enumerate() {
                    let Some(i) = agents.index_of(id) else {
                        continue;
                    };
                    let (x, y) = wg.walkers.position(w);
                    let c = grid.cell_center(x, y);
                    let old = Vec2::new(prev_x[i], prev_y[i]);
                    let v = (c - old) / dt;
                    (agents.pos_x[i], agents.pos_y[i]) = (c.x, c.y);
                    (agents.vel_x[i], agents.vel_y[i]) = (v.x, v.y);
                    if wg.walkers.is_arrived(w) {
                        set_arrived(&mut self.arrived, id, true);
                    }
                }
            }
        }
        // Followers standing on a goal of their channel arrive (found in parallel, then flagged
        // in index order).
        if self.follow.iter().all(Option::is_none) {
            return;
        }
        let mut flags_buf = std::mem::take(&mut self.on_goal);
        let this = &*self;
        let fields = &self.fields;
        let follow = &self.follow;
        let agents = &*agents;
        // The flow and goals agent `i` arrives at, and whether they serve its whole group (a
        // fixed channel).
        let target = |i: usize| {
            let Some(&Some((field, channel))) = follow.get(agents.group[i] as usize) else {
                return (None, true);
            };
            let fixed = matches!(channel, FollowChannel::Fixed(_));
            let channel = this.channel_of(channel, agents.ids[i]);
            let Some(channels) = fields.get(field).map(|f| &f.channels) else {
                return (None, fixed);
            };
            let (Some(flow), Ok(goals)) = (channels.flow(channel), channels.goals(channel)) else {
                return (None, fixed);
            };
            (Some((flow, goals)), fixed)
        };
        // The agents from `from` on, one flag each; the target resolved once per run of a group
        // with a fixed channel.
        let on_goal = |from: usize, flags: &mut [bool]| {
            let mut last = None;
            for (k, f) in flags.iter_mut().enumerate() {
                let i = from + k;
                let g = agents.group[i];
                let t = match last {
                    Some((h, t)) if h == g => t,
                    _ => {
                        let (t, fixed) = target(i);
                        last = fixed.then_some((g, t));
                        t
                    }
                };
                let p = Vec2::new(agents.pos_x[i], agents.pos_y[i]);
                // A short goal list is searched instead of the flow's cells (no memory
                // traffic).
                *f = t.is_some_and(|(flow, goals)| {
                    if goals.len() <= 16 {
                        flow.world_to_cell(p).is_some_and(|c| goals.contains(&c))
                    } else {
                        flow.is_goal_at(p)
                    }
                });
            }
        };
        flags_buf.resize(n, false);
        if exec_parallel {
            flags_buf
                .par_chunks_mut(WALL_CHUNK)
                .enumerate()
                .for_each(|(c, flags)| on_goal(c * WALL_CHUNK, flags));
        } else {
            on_goal(0, &mut flags_buf);
        }
        self.on_goal = flags_buf;
        for i in 0..n {
            if self.on_goal[i] {
                set_arrived(&mut self.arrived, agents.ids[i], true);
            }
        }
    }
}

impl FieldSet {
    pub(crate) fn get_mut(&mut self, field: usize) -> Result<&mut WorldField> {
        let count = self.fields.len();
        self.fields.get_mut(field).ok_or_else(|| Error::Invalid {
            name: "field".into(),
            reason: format!("no field {field} (there are {count})"),
        })
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
            &Walls::of(&g, &wall_bits(&g), Bounds::Open),
            Vec2::new(0.5, 0.9),
            Vec2::new(0.5, 1.2),
            Vec2::new(0.0, 3.0),
        );
        assert_eq!((p, v), (Vec2::new(0.5, 0.9), Vec2::ZERO));
        // Diagonal into the wall: slides along x.
        let (p, v) = resolve(
            &Walls::of(&g, &wall_bits(&g), Bounds::Open),
            Vec2::new(0.5, 0.9),
            Vec2::new(0.7, 1.2),
            Vec2::new(2.0, 3.0),
        );
        assert_eq!((p, v), (Vec2::new(0.7, 0.9), Vec2::new(2.0, 0.0)));
    }

    #[test]
    fn a_move_onto_a_wall_corner_slides_along_the_face_it_reaches_first() {
        let g = grid("..\n.#\n");
        let bits = wall_bits(&g);
        let walls = Walls::of(&g, &bits, Bounds::Open);
        let v = Vec2::new(3.0, 3.0);
        // Across x first (a third of the way), then into the wall cell's upper face: keeps x.
        let (p, w) = resolve(&walls, Vec2::new(0.9, 0.8), Vec2::new(1.2, 1.1), v);
        assert_eq!((p, w), (Vec2::new(1.2, 0.8), Vec2::new(3.0, 0.0)));
        // The same move mirrored across the diagonal: keeps y.
        let (p, w) = resolve(&walls, Vec2::new(0.8, 0.9), Vec2::new(1.1, 1.2), v);
        assert_eq!((p, w), (Vec2::new(0.8, 1.2), Vec2::new(0.0, 3.0)));
        // Through the corner point itself: the larger component is kept; along the diagonal
        // neither is.
        let (p, _) = resolve(&walls, Vec2::new(0.9, 0.9), Vec2::new(1.3, 1.2), v);
        assert_eq!(p, Vec2::new(1.3, 0.9));
        let (p, w) = resolve(&walls, Vec2::new(0.875, 0.875), Vec2::new(1.125, 1.125), v);
        assert_eq!((p, w), (Vec2::new(0.875, 0.875), Vec2::ZERO));
    }

    /// The wall rule has no preferred axis: on the transposed map, the transposed move ends
    /// at the transposed position with the transposed velocity, bit for bit.
    #[test]
    fn the_wall_rule_commutes_with_transposing_the_map() {
        use rand::{RngExt, SeedableRng};
        let g = OccupancyGrid::caves(24, 24, 0.5, 5).unwrap();
        let text = |transpose: bool| {
            let mut t = String::new();
            for y in 0..24 {
                for x in 0..24 {
                    let (cx, cy) = if transpose { (y, x) } else { (x, y) };
                    t.push(if g.cells()[cy * 24 + cx].is_free() {
                        '.'
                    } else {
                        '#'
                    });
                }
                t.push('\n');
            }
            t
        };
        let (a, b) = (grid(&text(false)), grid(&text(true)));
        let (wa, wb) = (wall_bits(&a), wall_bits(&b));
        let (walls, turned) = (
            Walls::of(&a, &wa, Bounds::Open),
            Walls::of(&b, &wb, Bounds::Open),
        );
        let t = |p: Vec2| Vec2::new(p.y, p.x);
        let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(3);
        let mut slid = 0;
        for _ in 0..50_000 {
            let prev = Vec2::new(rng.random_range(0.0..24.0), rng.random_range(0.0..24.0));
            if walls.in_wall(prev) {
                continue;
            }
            let p = prev + Vec2::new(rng.random_range(-0.6..0.6), rng.random_range(-0.6..0.6));
            let v = Vec2::new(rng.random_range(-2.0..2.0), rng.random_range(-2.0..2.0));
            let (q, w) = resolve(&walls, prev, p, v);
            assert_eq!(
                (t(q), t(w)),
                resolve(&turned, t(prev), t(p), t(v)),
                "{prev} -> {p}"
            );
            slid += usize::from(q != p && q != prev);
        }
        assert!(slid > 500, "{slid}");
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
            let walls = Walls::of(&g, &bits, Bounds::Open);
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
                    assert_eq!(
                        resolve(&Walls::of(&g, &wall_bits(&g), Bounds::Open), prev, p, v),
                        (p, v),
                        "{prev} -> {p}"
                    );
                }
            }
            assert!(kept > 5_000, "{kept}");
        }
    }

    #[test]
    fn corners_are_not_cut_and_long_moves_do_not_tunnel() {
        let g = grid(".#\n#.\n");
        let (p, _) = resolve(
            &Walls::of(&g, &wall_bits(&g), Bounds::Open),
            Vec2::new(0.9, 0.9),
            Vec2::new(1.1, 1.1),
            Vec2::ONE,
        );
        assert_eq!(p, Vec2::new(0.9, 0.9));
        let g = grid(".#.\n");
        let (p, _) = resolve(
            &Walls::of(&g, &wall_bits(&g), Bounds::Open),
            Vec2::new(0.5, 0.5),
            Vec2::new(2.5, 0.5),
            Vec2::X,
        );
        assert!(p.x < 1.0, "{p}");
    }
}
