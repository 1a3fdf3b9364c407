//! The ORCA filter of the steering layer: after the steering pass, every agent of a group with
//! [`Orca`] parameters has its request replaced by the collision-free velocity closest to its
//! preferred one ([`crate::orca`]).
//!
//! Per agent: the preferred velocity from the pass's output (kinematic: the desired velocity;
//! dynamic: `velocity + acceleration * dt`), truncated to `pref_speed` and perturbed when the
//! group asks (every agent's perturbation of a chunk drawn in lanes first, [`perturbations`]);
//! the candidates from the hashed grid packed eight lanes at a time (`steer::pack`), in a crowd
//! first within a little more than the previous agent's `max_neighbours`-th distance (exact:
//! the search widens to `neighbour_dist` when fewer lie that close); the hard
//! lines of the walls (nearest edge first) and circles within
//! `time_horizon_obst * max_speed + radius`; the lines of the nearest `max_neighbours` agents
//! within `neighbour_dist`, sorted by `(distance, id)` (when fewer lie within reach of the
//! hashed grid, in the order found, and sorted only when one cuts the preferred velocity: only
//! then does the program's answer depend on the order); the linear program. In free flow the
//! agent lines are not built: when the hard lines and every neighbour surely permit the
//! velocity the program starts from (`orca::lines::permits`, decided with a margin far above
//! rounding), that velocity is the program's answer, the same bits. The result is
//! written back as the desired velocity (kinematic) or as the acceleration towards it, clamped
//! to the group's maximum (dynamic).
//!
//! Invariants: reads frame-t positions and velocities and the agent's own request only, writes
//! only the agent's own request, so the result does not depend on the order or the thread in
//! which agents are filtered; per-worker buffers are reused, so a warm step allocates nothing.

use std::cell::RefCell;

use glam::Vec2;
use rayon::prelude::*;

use super::pack::{Block, Packed, pack_lanes};
use super::pass::SteerOut;
use super::view::SteerView;
use crate::agents::AgentId;
use crate::orca::lines::LANES;
use crate::orca::{
    Line, Orca, WallChains, accepted, agent_line, permits, solve, tested, unconstrained,
};
use crate::rng::{self, Stream};
use crate::spatial::{HashGrid, Neighbour, NeighbourIndex, Runs, farthest_move};
use crate::steering::trig;

/// One worker's buffers.
#[derive(Default)]
struct Buffers {
    found: Vec<Neighbour>,
    /// The offsets and indices of the candidates within reach, packed eight lanes at a time
    /// (`steer::pack`): only the first `count` entries of a scan are hits, the rest is room.
    rx: Vec<f32>,
    ry: Vec<f32>,
    js: Vec<u32>,
    /// The nearest candidates as `dist_sq bits << 32 | p`, `p` their place in `rx`, `ry` and
    /// `js`, in order of `(dist_sq, id)` ([`nearest_in_order`]).
    near: Vec<u64>,
    /// Scratch of [`nearest_in_order`] for ties at the `k`-th distance: `(dist_sq bits << 32 |
    /// id, p)`.
    tied: Vec<(u64, u32)>,
    lines: Vec<Line>,
    projected: Vec<Line>,
    walls: Vec<u32>,
    circles: Vec<u32>,
    edges: Vec<(f32, u32)>,
    inside: Vec<(u32, bool)>,
    /// Per agent of the chunk: its perturbation's direction (cosine, sine) and length in
    /// units of the group's `perturbation` ([`perturbations`]).
    turb_cos: Vec<f32>,
    turb_sin: Vec<f32>,
    turb_len: Vec<f32>,
    /// The squared distance of the previous agent's `k`-th nearest neighbour (infinite when it
    /// had fewer, and at the start of every chunk).
    kth_sq: f32,
    /// How many of the next agents go to the programs without the free-flow test (reset for
    /// every chunk): after an agent the test failed for, its neighbours in storage order are
    /// likely in the same conflict, and a failed test is work lost.
    untested: u32,
    /// The block of cells last gathered (reset for every chunk of agents: the grid changes
    /// between steps), and its points gathered from the hashed grid's runs into one contiguous
    /// list (positions and indices, then [`LANES`] of padding), which every agent whose query's
    /// block lies within it scans eight lanes at a time.
    block: Option<[i32; 4]>,
    block_x: Vec<f32>,
    block_y: Vec<f32>,
    block_j: Vec<u32>,
    /// Points in the block (without the padding).
    block_len: usize,
}

thread_local! {
    static BUFFERS: RefCell<Buffers> = RefCell::new(Buffers::default());
}

/// Whether some plan filters its agents through ORCA.
pub(crate) fn any(view: &SteerView) -> bool {
    view.plans.iter().any(|p| p.orca.is_some())
}

/// The ORCA pass's own state, reused across steps.
#[derive(Debug, Default)]
pub(crate) struct OrcaScratch {
    /// Per agent: whether it may touch another agent after this step's move (read by the
    /// contact pass).
    pub near: Vec<bool>,
    /// Cells of the neighbour distance, or of twice it when [`wide`](Self::wide): the
    /// candidates in open and walled worlds.
    hash: HashGrid,
    /// The agents' ids and positions at the last rebuild of `hash`, in storage order: while the
    /// same agents are in the same order, the next frames refresh the positions instead of
    /// rebuilding ([`OrcaScratch::prepare_hash`]).
    built_ids: Vec<AgentId>,
    built_x: Vec<f32>,
    built_y: Vec<f32>,
    /// Whether the cells are twice the neighbour distance: set by the world on the frames it
    /// orders the agents by ORCA's grid ([`wide_cells`]), false otherwise. A query of the
    /// neighbour distance then reads two cells per axis instead of three: more candidates, but
    /// every agent of a cell shares one gathered block, and in a sparse crowd a cell's block is
    /// gathered for few agents. The candidates within reach, and so every result, are the same
    /// either way.
    pub wide: bool,
}

impl OrcaScratch {
    /// Makes `hash` hold the agents' current positions in cells of `side`, and returns how much
    /// farther than their radius its queries must reach. While the same agents are in the same
    /// storage order (no reorder, addition or removal since the last rebuild) and none has moved
    /// farther than [`MAX_SLACK`] cells' sides from where it was at that rebuild, the points
    /// keep their buckets and only their positions are refreshed; the queries then reach as
    /// far beyond their radius as the farthest move (a bound on it), which keeps every agent
    /// within the radius in the block. Otherwise the grid is rebuilt, and the queries reach
    /// their radius. Which of the two happens changes the cost, not the candidates within
    /// reach: the results are the same bits.
    fn prepare_hash(&mut self, ids: &[AgentId], (xs, ys): (&[f32], &[f32]), side: f32) -> f32 {
        if self.hash.side() == side && self.built_ids == ids {
            let moved = farthest_move((xs, ys), (&self.built_x, &self.built_y));
            if moved <= MAX_SLACK * side {
                self.hash.refresh(xs, ys);
                return moved;
            }
        }
        self.hash.rebuild(xs, ys, side);
        self.remember(ids, (xs, ys));
        0.0
    }
}

impl OrcaScratch {
    /// Takes `grid`, built over the agents now stored as `ids` at `(xs, ys)` (the world's order
    /// grid after the agents were reordered by it and it adopted that order), as the pass's
    /// hashed grid, and gives back the previous one in its place: the pass then refreshes
    /// instead of rebuilding in this frame ([`OrcaScratch::prepare_hash`] still checks the
    /// agents, their positions and the side).
    pub(crate) fn adopt(
        &mut self,
        grid: &mut HashGrid,
        ids: &[AgentId],
        (xs, ys): (&[f32], &[f32]),
    ) {
        std::mem::swap(&mut self.hash, grid);
        self.remember(ids, (xs, ys));
    }

    /// The hashed grid with the positions it bucketed the agents at, when it was built over
    /// the agents now stored as `ids` (in that order): a later search of this frame may use it
    /// instead of building its own, reaching farther by how far the agents have moved since.
    pub(crate) fn prebuilt(&self, ids: &[AgentId]) -> Option<crate::orca::contact::Prebuilt<'_>> {
        (self.hash.len() == ids.len() && self.built_ids == ids).then_some(
            crate::orca::contact::Prebuilt {
                hash: &self.hash,
                at: (&self.built_x, &self.built_y),
            },
        )
    }

    /// Records the agents and positions the hashed grid was built over.
    fn remember(&mut self, ids: &[AgentId], (xs, ys): (&[f32], &[f32])) {
        for (built, now) in [(&mut self.built_x, xs), (&mut self.built_y, ys)] {
            built.clear();
            built.extend_from_slice(now);
        }
        self.built_ids.clear();
        self.built_ids.extend_from_slice(ids);
    }
}

/// How far the hashed grid's points may move, in cells' sides, before it is rebuilt: each
/// query reads a block that much wider.
const MAX_SLACK: f32 = 0.25;

/// Whether ORCA's cells should be twice the neighbour distance, given the [`HashGrid::crowding`]
/// of a grid of such cells over the agents: where fewer than [`WIDE_BELOW`] agents share an
/// agent's cell. Measured on `circle` (a ring of agents five units apart, about six per wide
/// cell): 7.5% faster a step at 100,000 agents with wide cells; on `crossing` (hundreds per
/// wide cell) 7% more instructions, so dense crowds keep the narrow cells.
pub(crate) fn wide_cells(crowding: f32) -> bool {
    crowding < WIDE_BELOW
}

/// Agents per wide cell (about four narrow cells in a crowd, two along a line of agents) below
/// which wide cells gather fewer blocks than they cost in extra candidates.
const WIDE_BELOW: f32 = 12.0;

/// The largest `neighbour_dist` of the plans that use ORCA (0 when none does).
pub(crate) fn reach(plans: &[super::plan::Plan]) -> f32 {
    plans
        .iter()
        .filter_map(|p| p.orca.map(|o| o.neighbour_dist))
        .fold(0.0_f32, f32::max)
}

/// Where the filter reads its neighbour candidates from.
#[derive(Clone, Copy)]
enum Source<'a> {
    /// The pass's own hashed grid of cells as wide as the neighbour distance, or twice it where
    /// agents are sparse (open and walled worlds, where the offset to a neighbour is the plain
    /// difference). The world's grid would do at crowd densities, but its cells are capped at
    /// `4 N`, so in a large sparse world they grow far wider than the neighbour distance.
    Hash(&'a HashGrid),
    /// The world's index through its query (a torus, where offsets take the minimum image).
    Index,
}

/// What the filter needs besides the view.
struct Context<'a> {
    walls: &'a WallChains,
    /// Where the candidates come from.
    source: Source<'a>,
    /// How much farther than their radius queries of the hashed grid reach: the farthest any
    /// agent has moved since its rebuild ([`OrcaScratch::prepare_hash`]).
    slack: f32,
    /// The largest radius and speed of any agent: what bounds a pair's approach in one step.
    r_max: f32,
    v_max: f32,
    /// The frame's random key ([`rng::frame_key`]), from which each agent's stream derives.
    frame_key: u64,
    /// Whether the CPU has AVX2 (the candidates are packed in its lanes).
    avx2: bool,
    /// Whether some ORCA group perturbs its preferred velocities.
    perturbs: bool,
}

/// Filters the requests in `out` of every agent whose group uses ORCA.
pub(crate) fn run(
    view: &SteerView,
    walls: &WallChains,
    scratch: &mut OrcaScratch,
    out: &mut SteerOut,
    parallel: bool,
) {
    let a = view.agents;
    let n = a.len();
    let mut slack = 0.0;
    let source = if view.bounds.is_torus() {
        Source::Index
    } else {
        let side = if scratch.wide { 2.0 } else { 1.0 } * reach(view.plans);
        slack = scratch.prepare_hash(&a.ids, (&a.pos_x, &a.pos_y), side);
        Source::Hash(&scratch.hash)
    };
    let ctx = Context {
        walls,
        source,
        slack,
        r_max: crate::agents::largest(&a.radius),
        v_max: crate::agents::largest(&a.max_speed),
        frame_key: rng::frame_key(view.seed, view.frame),
        #[cfg(target_arch = "x86_64")]
        avx2: std::arch::is_x86_feature_detected!("avx2"),
        #[cfg(not(target_arch = "x86_64"))]
        avx2: false,
        perturbs: view
            .plans
            .iter()
            .any(|p| p.orca.is_some_and(|o| o.perturbation > 0.0)),
    };
    scratch.near.clear();
    scratch.near.resize(n, false);
    let chunk = |base: usize, lx: &mut [f32], ly: &mut [f32], near: &mut [bool]| {
        BUFFERS.with_borrow_mut(|b| {
            b.block = None;
            b.kth_sq = f32::INFINITY;
            b.untested = 0;
            if ctx.perturbs {
                let ids = &a.ids[base..base + lx.len()];
                perturbations(ids, ctx.frame_key, b);
            }
            // Room for every agent as a candidate: a warm step allocates nothing however
            // crowded a neighbourhood becomes.
            if b.js.len() < n + LANES {
                for v in [&mut b.rx, &mut b.ry, &mut b.block_x, &mut b.block_y] {
                    v.resize(n + LANES, 0.0);
                }
                b.js.resize(n + LANES, 0);
                b.block_j.resize(n + LANES, 0);
            }
            b.near.reserve(n.saturating_sub(b.near.len()));
            b.tied.reserve(n.saturating_sub(b.tied.len()));
            filter_chunk(view, &ctx, base, (lx, ly, near), b);
        });
    };
    let (lx, ly) = (&mut out.lin_x[..n], &mut out.lin_y[..n]);
    let near = &mut scratch.near[..];
    if parallel {
        lx.par_chunks_mut(FILTER_CHUNK)
            .zip(ly.par_chunks_mut(FILTER_CHUNK))
            .zip(near.par_chunks_mut(FILTER_CHUNK))
            .enumerate()
            .with_max_len(1)
            .for_each(|(c, ((x, y), f))| chunk(c * FILTER_CHUNK, x, y, f));
    } else {
        chunk(0, lx, ly, near);
    }
}

/// Agents per task of the parallel filter, each chunk a task of its own (`with_max_len(1)`):
/// threads that run at different speeds (a core shared with another process) then share the
/// chunks by how fast they go. In chunks of the pass's 1,024, split by rayon's default into
/// runs of two or three, one thread of a 10,000-agent circle waited for the other 84 to 171 µs
/// a step on average (the filter's two threads 0.82 to 0.89 busy); in tasks of 256, 38 to 60
/// µs (0.93 to 0.95). A chunk's first agent regathers its block and searches without the
/// previous agent's distance, a few hundred instructions. Which agents share a task changes
/// only what the buffers carry from one agent to the next (the gathered block, the `k`-th
/// distance, the skipped tests), never a result.
const FILTER_CHUNK: usize = 256;

/// Every agent's perturbation of the chunk whose ids are `ids`, into `b.turb_*`: the first two
/// draws of its ORCA stream from the frame's key, a direction (the polynomial sine and cosine
/// of the first times 2 pi, in their range) and a length (the second, in units of the group's
/// `perturbation`). Eight agents at a time in lanes; the same operations per agent as one at a
/// time, so the same bits.
#[multiversion::multiversion(targets(
    "x86_64+avx2+fma+avx512f+avx512vl+avx512bw+avx512dq",
    "x86_64+avx2+fma"
))]
fn perturbations(ids: &[AgentId], frame_key: u64, b: &mut Buffers) {
    let n = ids.len();
    for v in [&mut b.turb_cos, &mut b.turb_sin, &mut b.turb_len] {
        v.resize(n.next_multiple_of(LANES), 0.0);
    }
    let mut at = 0;
    while at < n {
        let len = LANES.min(n - at);
        let mut lane_ids = [0u32; LANES];
        for (l, id) in ids[at..at + len].iter().enumerate() {
            lane_ids[l] = id.0;
        }
        let (mut c, mut s, mut u) = ([0.0f32; LANES], [0.0f32; LANES], [0.0f32; LANES]);
        for l in 0..LANES {
            let key = rng::agent_key(frame_key, lane_ids[l], Stream::Orca as u32);
            let angle = rng::unit_at(key, 1) * std::f32::consts::TAU;
            (s[l], c[l]) = trig::sin_cos_reduced(angle);
            u[l] = rng::unit_at(key, 2);
        }
        b.turb_cos[at..at + LANES].copy_from_slice(&c);
        b.turb_sin[at..at + LANES].copy_from_slice(&s);
        b.turb_len[at..at + LANES].copy_from_slice(&u);
        at += LANES;
    }
}

/// Gathers the points of the runs `runs` of the hashed grid into `b.block_*`, one contiguous
/// list, then [`LANES`] entries of padding (far away, never kept).
#[inline(always)]
fn gather_block(hash: &HashGrid, runs: &Runs, b: &mut Buffers) {
    let (sx, sy, order) = (hash.sorted_x(), hash.sorted_y(), hash.order());
    let mut len = 0;
    for run in runs.iter() {
        // Eight lanes at a time (the sorted positions are padded); the next copy starts where
        // this one's points end.
        let mut at = run.start;
        while at < run.end {
            let take = (run.end - at).min(LANES);
            let x: &[f32; LANES] = sx[at..at + LANES].try_into().expect("padded positions");
            let y: &[f32; LANES] = sy[at..at + LANES].try_into().expect("padded positions");
            let to: &mut [f32; LANES] =
                (&mut b.block_x[len..len + LANES]).try_into().expect("room");
            *to = *x;
            let to: &mut [f32; LANES] =
                (&mut b.block_y[len..len + LANES]).try_into().expect("room");
            *to = *y;
            match order.get(at..at + LANES) {
                Some(js) => b.block_j[len..len + LANES].copy_from_slice(js),
                None => b.block_j[len..len + take].copy_from_slice(&order[at..at + take]),
            }
            len += take;
            at += take;
        }
    }
    b.block_x[len..len + LANES].fill(f32::MAX);
    b.block_y[len..len + LANES].fill(f32::MAX);
    b.block_j[len..len + LANES].fill(u32::MAX);
    b.block_len = len;
}

/// What [`candidates`] found.
#[derive(Clone, Copy, Debug)]
enum Hits {
    /// The `k` nearest, in order, in `b.near`.
    Ordered,
    /// Fewer than `k` agents within reach of a hashed grid's query: all of them, places
    /// `0..n` of `b.rx`, `b.ry` and `b.js`, in no order (`b.near` unused). The order is made
    /// only when the linear program needs it ([`order_lines`]).
    All(usize),
}

/// The `k` nearest agents within `r` of agent `i` at `pos` (itself left out), sorted by
/// `(dist_sq, id)` in `b.near` ([`Hits::Ordered`]; each entry is `dist_sq bits << 32 | p`, `p`
/// the hit's place in `b.rx`, `b.ry` (its offset from `pos`) and `b.js` (its storage index)),
/// or when fewer than `k` lie within reach of the hashed grid, all of them ([`Hits::All`]).
#[inline(always)]
fn candidates(
    view: &SteerView,
    ctx: &Context,
    i: usize,
    pos: Vec2,
    r: f32,
    k: usize,
    b: &mut Buffers,
) -> Hits {
    let a = view.agents;
    let r_sq = r * r;
    b.near.clear();
    match ctx.source {
        Source::Hash(hash) => {
            // Agents lie in the order of a hashed grid of these cells (the world reorders them
            // every few frames), so the next agents' blocks of cells often lie within this
            // one's: its points are gathered once, for all of them. Where the query reaches no
            // farther than the neighbouring cells (wide cells), the block gathered is the
            // agent's cell and its eight neighbours, which holds the query of every agent of
            // that cell. Any block that holds the query's has the same candidates within
            // reach, so the results are the same bits.
            let cells = hash.cells(pos, r + ctx.slack);
            let holds = |[x0, x1, y0, y1]: [i32; 4]| {
                x0 <= cells[0] && cells[1] <= x1 && y0 <= cells[2] && cells[3] <= y1
            };
            if !b.block.is_some_and(holds) {
                let [cx, cy] = hash.cell_of(pos);
                let around = [
                    cx.saturating_sub(1),
                    cx.saturating_add(1),
                    cy.saturating_sub(1),
                    cy.saturating_add(1),
                ];
                let block = if holds(around) { around } else { cells };
                b.block = Some(block);
                gather_block(hash, &hash.runs_of(block), b);
            }
            // In a crowd, first within a little more than the distance of the previous
            // agent's `k`-th neighbour (its neighbourhood is this one's): when `k` agents lie
            // that close, the `k` nearest within `r` are among them, the same agents in the
            // same order, with fewer hits to choose from. Otherwise within `r`.
            let tight = (b.kth_sq * TIGHT_SQ).min(r_sq);
            let len = b.block_len;
            let blocks = len.div_ceil(LANES);
            let xs = b.block_x[..blocks * LANES].as_chunks::<LANES>().0;
            let ys = b.block_y[..blocks * LANES].as_chunks::<LANES>().0;
            let js = b.block_j[..blocks * LANES].as_chunks::<LANES>().0;
            let mut count = 0;
            for reach_sq in [tight, r_sq] {
                let mut out = Packed {
                    rx: &mut b.rx[..],
                    ry: &mut b.ry[..],
                    js: &mut b.js[..],
                    p: (pos.x, pos.y),
                    r_sq: reach_sq,
                    me: i as u32,
                };
                count = 0;
                let mut left = len;
                for ((xs, ys), js) in xs.iter().zip(ys).zip(js) {
                    let block = Block { xs, ys, js, left };
                    count = pack_lanes(&block, &mut out, count, ctx.avx2);
                    left = left.saturating_sub(LANES);
                }
                if count >= k || reach_sq >= r_sq {
                    break;
                }
            }
            if count < k {
                b.kth_sq = f32::INFINITY;
                return Hits::All(count);
            }
            push_keys(&b.rx[..count], &b.ry[..count], &mut b.near);
        }
        Source::Index => {
            view.index.neighbours_at(pos, r, &mut b.found);
            let found = b.found.iter().filter(|nb| nb.index as usize != i);
            for (p, nb) in found.enumerate() {
                let j = nb.index as usize;
                let rel = view.bounds.offset(pos, a.position(j));
                (b.rx[p], b.ry[p], b.js[p]) = (rel.x, rel.y, nb.index);
                b.near.push(near_key(nb.dist_sq, p));
            }
        }
    }
    nearest_in_order(&mut b.near, k, &b.js, &a.ids, &mut b.tied);
    b.kth_sq = if b.near.len() == k {
        f32::from_bits((b.near[k - 1] >> 32) as u32)
    } else {
        f32::INFINITY
    };
    Hits::Ordered
}

/// Puts the agent lines `lines[hard..]` of [`Hits::All`]'s `n` hits (line `hard + p` for the
/// hit at place `p`) in the order of [`Hits::Ordered`]: nearest first, ties by id.
#[inline(always)]
fn order_lines(b: &mut Buffers, hard: usize, n: usize, k: usize, ids: &[AgentId]) {
    b.near.clear();
    push_keys(&b.rx[..n], &b.ry[..n], &mut b.near);
    nearest_in_order(&mut b.near, k, &b.js, ids, &mut b.tied);
    b.projected.clear();
    b.projected.extend(
        b.near
            .iter()
            .map(|&key| b.lines[hard + key as u32 as usize]),
    );
    b.lines.truncate(hard);
    b.lines.extend_from_slice(&b.projected);
}

/// The sort key of the hit at place `p` at squared distance `d_sq`: `d_sq bits << 32 | p`
/// (the bits of non-negative floats order as their values).
#[inline(always)]
fn near_key(d_sq: f32, p: usize) -> u64 {
    (u64::from(d_sq.to_bits()) << 32) | p as u64
}

/// Pushes the keys of the hits at offsets `(rx[p], ry[p])` onto `near`, in place order.
#[inline(always)]
fn push_keys(rx: &[f32], ry: &[f32], near: &mut Vec<u64>) {
    let hits = rx.iter().zip(ry).enumerate();
    near.extend(hits.map(|(p, (&dx, &dy))| near_key(dx * dx + dy * dy, p)));
}

/// Keeps the `k` smallest of `near` (entries `dist_sq bits << 32 | p`, the hit `p` being agent
/// `ids[js[p]]`) by `(dist_sq, id)`, in that order. The keys carry the hit's place rather than
/// its id (no load per hit): they order by distance as they are; only equal distances, rare,
/// need the ids, and are put in id order afterwards, or, where they straddle the `k`-th place,
/// chosen by id through `tied`.
#[inline(always)]
fn nearest_in_order(
    near: &mut Vec<u64>,
    k: usize,
    js: &[u32],
    ids: &[AgentId],
    tied: &mut Vec<(u64, u32)>,
) {
    const PLACE: u64 = 0xFFFF_FFFF;
    let id = |key: u64| ids[js[(key & PLACE) as usize] as usize].0;
    if near.len() > k {
        near.select_nth_unstable(k - 1);
        let kth = near[k - 1] >> 32;
        if near[k..].iter().any(|&key| key >> 32 == kth) {
            // Agents at the `k`-th distance on both sides of it: which are kept goes by id.
            tied.clear();
            tied.extend(
                near.iter()
                    .map(|&key| ((key & !PLACE) | u64::from(id(key)), key as u32)),
            );
            tied.select_nth_unstable(k - 1);
            tied.truncate(k);
            tied.sort_unstable();
            near.clear();
            near.extend(tied.iter().map(|&(key, p)| (key & !PLACE) | u64::from(p)));
            return;
        }
        near.truncate(k);
    }
    insertion_sort(near, |x, y| x > y);
    // Equal distances in id order.
    if near.windows(2).any(|w| w[0] >> 32 == w[1] >> 32) {
        insertion_sort(near, |x, y| {
            x >> 32 > y >> 32 || (x >> 32 == y >> 32 && id(x) > id(y))
        });
    }
}

/// Whether the filter may take the free-flow way (always, but in this crate's own tests,
/// which turn it off on their thread to compare the two ways).
#[inline(always)]
fn free_flow_on() -> bool {
    #[cfg(test)]
    {
        !tests::NO_FREE_FLOW.get()
    }
    #[cfg(not(test))]
    {
        true
    }
}

/// Agents that skip the free-flow test after one it failed for ([`Buffers::untested`]): in a
/// crowd in conflict the test is then tried for one agent in four (`crossing` at 20,000
/// agents: about 1% of agents are free, and a failed test costs two or three neighbours'
/// tests); a crowd in free flow never fails it, and loses nothing.
const UNTESTED_AFTER_FAILURE: u32 = 3;

/// The first search's squared radius over the previous agent's `k`-th squared distance
/// (1.25 squared).
const TIGHT_SQ: f32 = 1.5625;

/// Sorts a handful of keys in place by `after` (whether the first goes after the second), stable
/// (the library sort's call and set-up cost more than the sorting at ten entries).
#[inline(always)]
fn insertion_sort(v: &mut [u64], after: impl Fn(u64, u64) -> bool) {
    for a in 1..v.len() {
        let x = v[a];
        let mut at = a;
        while at > 0 && after(v[at - 1], x) {
            v[at] = v[at - 1];
            at -= 1;
        }
        v[at] = x;
    }
}

/// The filtered requests of the agents from storage index `base` on, one per slot of `lx`,
/// `ly` and `near`. Compiled for AVX-512 and AVX2 too, where the candidate scan runs in vectors
/// (the same arithmetic, so the same bits); dispatched once per chunk, with [`filter`] inlined,
/// rather than once per agent.
#[multiversion::multiversion(targets(
    "x86_64+avx2+fma+avx512f+avx512vl+avx512bw+avx512dq",
    "x86_64+avx2+fma"
))]
fn filter_chunk(
    view: &SteerView,
    ctx: &Context,
    base: usize,
    (lx, ly, near): (&mut [f32], &mut [f32], &mut [bool]),
    b: &mut Buffers,
) {
    let a = view.agents;
    for k in 0..lx.len() {
        let i = base + k;
        let g = a.group[i] as usize;
        if let Some(orca) = &view.plans[g].orca {
            let turb = if ctx.perturbs {
                let s = orca.perturbation * b.turb_len[k];
                Vec2::new(b.turb_cos[k], b.turb_sin[k]) * s
            } else {
                Vec2::ZERO
            };
            let (x, y, close) = filter(view, ctx, orca, i, (lx[k], ly[k]), turb, b);
            lx[k] = x;
            ly[k] = y;
            near[k] = close;
        }
    }
}

/// One agent's filtered request, and whether it may touch another agent after the move.
#[inline(always)]
fn filter(
    view: &SteerView,
    ctx: &Context,
    orca: &Orca,
    i: usize,
    request: (f32, f32),
    turb: Vec2,
    b: &mut Buffers,
) -> (f32, f32, bool) {
    let walls = ctx.walls;
    let a = view.agents;
    // The columns cut to one length: one bounds check per agent read serves all of them.
    let n = a.len();
    let (px, py, vx, vy) = (&a.pos_x[..n], &a.pos_y[..n], &a.vel_x[..n], &a.vel_y[..n]);
    let (groups, radii, ids) = (&a.group[..n], &a.radius[..n], &a.ids[..n]);
    let g = groups[i] as usize;
    let plan = &view.plans[g];
    let dt = view.dt;
    let pos = Vec2::new(px[i], py[i]);
    let vel = Vec2::new(vx[i], vy[i]);
    let radius = radii[i];
    let max_speed = a.max_speed[..n][i];
    let id = ids[i].0;
    let request = Vec2::new(request.0, request.1);
    let mut pref = if plan.adapter.kinematic {
        request
    } else {
        vel + request * dt
    };
    if let Some(s) = orca.pref_speed {
        pref = crate::steering::truncate(pref, s);
    }
    if orca.perturbation > 0.0 {
        pref += turb;
    }
    b.lines.clear();

    // Hard lines: walls nearest edge first, then circles.
    let inv_tau_obst = 1.0 / orca.time_horizon_obst;
    let range = orca.time_horizon_obst * max_speed + radius;
    if !view.obstacles.is_empty() {
        view.obstacles
            .broadphase()
            .near(pos, range, &mut b.circles, &mut b.walls);
        if !walls.is_empty() {
            b.edges.clear();
            b.inside.clear();
            for &w in &b.walls {
                walls.edges_near(w as usize, pos, range * range, &mut b.inside, &mut b.edges);
            }
            b.edges
                .sort_unstable_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1)));
            walls.lines(&b.edges, pos, vel, radius, inv_tau_obst, &mut b.lines);
        }
        for &c in &b.circles {
            let circle = view.obstacles.circles()[c as usize];
            let rel = view.bounds.offset(pos, circle.center);
            let reach = range + circle.radius;
            if rel.length_squared() < reach * reach {
                b.lines.push(agent_line(
                    vel,
                    rel,
                    vel,
                    circle.radius + radius,
                    inv_tau_obst,
                    1.0 / dt,
                    1.0,
                    1.0,
                ));
            }
        }
    }
    let hard = b.lines.len();
    // Room for every agent line and the 3D program's projections: a warm step allocates
    // nothing however the neighbour counts change.
    b.lines.reserve(orca.max_neighbours as usize);
    b.projected.clear();
    b.projected.reserve(hard + orca.max_neighbours as usize);

    // Agent lines, nearest first (ties by id); or, with fewer than `k` hits, in the order
    // found, put nearest first only when the linear program's answer depends on it.
    let r = orca.neighbour_dist;
    let k = orca.max_neighbours as usize;
    let hits = candidates(view, ctx, i, pos, r, k, b);
    let inv_tau = 1.0 / orca.time_horizon;
    let inv_dt = 1.0 / dt;
    // Whether the agent may touch another after the move: its nearest neighbour is closer than
    // the most both can close in one step, with a margin for the contact pass's pushes (and
    // neighbours out of sight could be that close when the neighbourhood is tiny).
    // Measured against the largest radius: a farther but larger neighbour may be within reach
    // when the nearest is not, and every other candidate is at least as far as the nearest.
    let limit = (max_speed + ctx.v_max) * dt + crate::orca::contact::REACH * (radius + ctx.r_max);
    let limit_sq = limit * limit;
    let mut close = r < limit;
    let own_share = {
        let sum = orca.responsibility + orca.responsibility;
        if sum > 0.0 {
            orca.responsibility / sum
        } else {
            0.5
        }
    };
    let (rx, ry, js) = (&b.rx[..], &b.ry[..], &b.js[..]);
    // With the hits in order, the nearest is the first; otherwise each hit is compared as it
    // is visited (every hit is visited by at least one of the two ways below).
    let count = match hits {
        Hits::Ordered => {
            if let Some(&key) = b.near.first() {
                close |= f32::from_bits((key >> 32) as u32) < limit_sq;
            }
            b.near.len()
        }
        Hits::All(n) => n,
    };
    // The hit that gives the `q`-th line: its place in `rx`, `ry` and `js`.
    let place = |q: usize| match hits {
        Hits::Ordered => b.near[q] as u32 as usize,
        Hits::All(_) => q,
    };
    let me = Pairs {
        view,
        orca,
        g,
        own_share,
        vel,
        radius,
        hits: (rx, ry, js),
    };
    // Free flow: when the velocity the programs would start from violates no hard line and
    // surely none of the agent lines ([`crate::orca::lines::permits`], which builds none), it is
    // their answer, the same bits as theirs. Most agents of a crowd that is not in conflict
    // take this way; the first neighbour it is not sure of sends the agent to the programs.
    let start = tested(pref, max_speed);
    let tests = b.untested == 0 && free_flow_on();
    b.untested = b.untested.saturating_sub(1);
    let mut free = tests && !b.lines.iter().any(|line| line.violation(start) > 0.0);
    if free {
        for q in 0..count {
            let p = place(q);
            if let Hits::All(_) = hits {
                close |= rx[p] * rx[p] + ry[p] * ry[p] < limit_sq;
            }
            let (rel, rel_vel, r, share, _) = me.pair(p);
            if !permits(vel, rel, rel_vel, r, inv_tau, share, start) {
                free = false;
                break;
            }
        }
    }
    if tests && !free {
        b.untested = UNTESTED_AFTER_FAILURE;
    }
    #[cfg(test)]
    tests::FREE_OF.with_borrow_mut(|[taken, all]| {
        *taken += usize::from(free);
        *all += 1;
    });
    let chosen = if free {
        accepted(start, max_speed)
    } else {
        // One line per neighbour, only the case that applies computed (measured faster than
        // blocks of eight in lanes, whose inputs are written a lane at a time and read back as
        // vectors, which the store buffer cannot forward).
        for q in 0..count {
            let p = place(q);
            if let Hits::All(_) = hits {
                close |= rx[p] * rx[p] + ry[p] * ry[p] < limit_sq;
            }
            let (rel, rel_vel, r, share, j) = me.pair(p);
            let tie = if id < ids[j].0 { 1.0 } else { -1.0 };
            b.lines.push(agent_line(
                vel, rel, rel_vel, r, inv_tau, inv_dt, share, tie,
            ));
        }
        match hits {
            Hits::Ordered => solve(&b.lines, hard, max_speed, pref, &mut b.projected),
            // When the preferred velocity violates no line, the lines' order does not matter;
            // otherwise the program gets them nearest first, as for `Hits::Ordered`.
            Hits::All(n) => unconstrained(&b.lines, max_speed, pref).unwrap_or_else(|| {
                order_lines(b, hard, n, k, ids);
                solve(&b.lines, hard, max_speed, pref, &mut b.projected)
            }),
        }
    };
    let chosen = if chosen.is_finite() {
        chosen
    } else {
        Vec2::ZERO
    };
    let out = if plan.adapter.kinematic {
        chosen
    } else {
        crate::steering::truncate((chosen - vel) / dt, plan.adapter.max_acceleration)
    };
    (out.x, out.y, close)
}

/// An agent's pairs with its hits.
struct Pairs<'a> {
    view: &'a SteerView<'a>,
    orca: &'a Orca,
    /// The agent's group.
    g: usize,
    /// Its share of the avoidance against an agent of its own group.
    own_share: f32,
    vel: Vec2,
    radius: f32,
    /// The hits' offsets and storage indices.
    hits: (&'a [f32], &'a [f32], &'a [u32]),
}

impl Pairs<'_> {
    /// The pair with the hit at place `p`: the neighbour's offset, the relative velocity, the
    /// summed radii, the agent's share of the avoidance, the neighbour's storage index.
    #[inline(always)]
    fn pair(&self, p: usize) -> (Vec2, Vec2, f32, f32, usize) {
        let a = self.view.agents;
        let (rx, ry, js) = self.hits;
        let (rel, j) = (Vec2::new(rx[p], ry[p]), js[p] as usize);
        let gj = a.group[j] as usize;
        let share = if gj == self.g {
            self.own_share
        } else {
            match self.view.plans[gj].orca {
                Some(o) => {
                    let sum = self.orca.responsibility + o.responsibility;
                    if sum > 0.0 {
                        self.orca.responsibility / sum
                    } else {
                        0.5
                    }
                }
                None => 1.0,
            }
        };
        let other = Vec2::new(a.vel_x[j], a.vel_y[j]);
        (rel, self.vel - other, self.radius + a.radius[j], share, j)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::AgentRng;

    thread_local! {
        /// Set by a test to send every agent of the filters run on its thread to the programs.
        pub(super) static NO_FREE_FLOW: std::cell::Cell<bool> = const {
            std::cell::Cell::new(false)
        };
        /// The agents filtered on this thread that took the free-flow way, and all of them.
        pub(super) static FREE_OF: RefCell<[usize; 2]> = const { RefCell::new([0; 2]) };
    }

    /// The free-flow way gives the bits of building every line and solving: the ORCA
    /// scenarios (open, walled, with obstacles, on a torus, dynamic agents) stepped with it and
    /// without it, on this thread (the sequential step), agree after every step; and it is
    /// taken by many agents and not by all of them.
    #[test]
    fn free_flow_equals_building_every_line() {
        use crate::scenario;
        let torus = {
            let mut s = scenario::builtin("circle")
                .unwrap()
                .with_agents(400)
                .unwrap();
            s.world = toml::from_str("kind = \"torus\"\nsize = [460, 460]").unwrap();
            for g in &mut s.groups {
                g.spawn = toml::from_str(
                    "kind = \"circle\"\ncenter = [230, 230]\nradius = 200\nper = 400",
                )
                .unwrap();
            }
            s
        };
        let dynamic = {
            let mut s = scenario::builtin("circle")
                .unwrap()
                .with_agents(300)
                .unwrap();
            for g in &mut s.groups {
                g.params.model = crate::movement::MovementModel::Dynamic;
            }
            s
        };
        let cases = [
            (
                scenario::builtin("circle")
                    .unwrap()
                    .with_agents(600)
                    .unwrap(),
                900,
            ),
            (
                scenario::builtin("crossing")
                    .unwrap()
                    .with_agents(1500)
                    .unwrap(),
                150,
            ),
            (scenario::builtin("blocks").unwrap(), 400),
            (
                scenario::builtin("evacuation")
                    .unwrap()
                    .with_agents(600)
                    .unwrap(),
                150,
            ),
            (torus, 600),
            (dynamic, 600),
        ];
        for (s, steps) in cases {
            FREE_OF.set([0; 2]);
            let mut with = s.build().unwrap();
            let mut without = s.build().unwrap();
            for step in 0..steps {
                NO_FREE_FLOW.set(false);
                with.step_here(s.dt).unwrap();
                NO_FREE_FLOW.set(true);
                without.step_here(s.dt).unwrap();
                NO_FREE_FLOW.set(false);
                let bits = |w: &crate::World| {
                    let a = w.agents();
                    let columns = [a.pos_x(), a.pos_y(), a.vel_x(), a.vel_y()];
                    columns.map(|c| c.iter().map(|x| x.to_bits()).collect::<Vec<_>>())
                };
                assert_eq!(bits(&with), bits(&without), "{}: step {step}", s.name);
            }
            // Counted over both runs: the second never takes the free way.
            let [taken, all] = FREE_OF.with_borrow(|c| *c);
            assert!(
                taken * 50 > all && taken < all / 2,
                "{}: {taken} of {all}",
                s.name
            );
        }
    }

    /// The `k` nearest by `(distance, id)` in that order, against a full sort, with many equal
    /// distances (on both sides of the `k`-th place too) and hits in any order.
    #[test]
    fn nearest_in_order_sorts_by_distance_then_id() {
        let mut rng = AgentRng::new(21, 0, 0, 0);
        let (mut near, mut tied) = (Vec::new(), Vec::new());
        let mut straddled = 0;
        for case in 0..3000 {
            let m = 1 + (rng.unit() * 24.0) as usize;
            let k = 1 + (rng.unit() * 12.0) as usize;
            // Storage indices of the hits, and the ids stored there (a permutation).
            let js: Vec<u32> = (0..m as u32).map(|p| (p * 7 + case) % m as u32).collect();
            let ids: Vec<AgentId> = (0..m as u32)
                .map(|j| AgentId((j * 13 + 5) % m as u32 + 100))
                .collect();
            let levels = 1 + (rng.unit() * 6.0) as u32;
            let dist: Vec<f32> = (0..m)
                .map(|_| (rng.unit() * levels as f32).floor())
                .collect();
            near.clear();
            near.extend((0..m).map(|p| (u64::from(dist[p].to_bits()) << 32) | p as u64));
            let mut want: Vec<(u32, u32, usize)> = (0..m)
                .map(|p| (dist[p].to_bits(), ids[js[p] as usize].0, p))
                .collect();
            want.sort_unstable();
            straddled += usize::from(m > k && want[k].0 == want[k - 1].0);
            want.truncate(k);
            nearest_in_order(&mut near, k, &js, &ids, &mut tied);
            let got: Vec<usize> = near.iter().map(|&key| key as u32 as usize).collect();
            let want: Vec<usize> = want.iter().map(|w| w.2).collect();
            assert_eq!(got, want, "case {case}");
            for &key in &near {
                assert_eq!((key >> 32) as u32, dist[key as u32 as usize].to_bits());
            }
        }
        assert!(straddled > 100, "{straddled}");
    }

    /// Refreshed positions with the returned slack find every agent within reach, as a rebuild
    /// would; the slack bounds every move; a reorder, a long move or a non-finite position
    /// rebuilds. The queries without the slack miss some agents, so the slack is needed.
    #[test]
    fn refreshed_grids_with_their_slack_find_every_agent_within_reach() {
        let mut rng = AgentRng::new(5, 0, 0, 0);
        let (side, r) = (15.0_f32, 15.0_f32);
        let mut s = OrcaScratch::default();
        let mut missed_without_slack = 0;
        for n in [3_000_usize, 40_000] {
            let extent = (n as f32).sqrt() * 6.0;
            let mut ids: Vec<AgentId> = (0..n as u32).map(AgentId).collect();
            let mut xs: Vec<f32> = (0..n).map(|_| rng.unit() * extent).collect();
            let mut ys: Vec<f32> = (0..n).map(|_| rng.unit() * extent).collect();
            assert_eq!(s.prepare_hash(&ids, (&xs, &ys), side), 0.0, "a first build");
            for round in 0..4 {
                let (x0, y0) = (xs.clone(), ys.clone());
                for k in 0..n {
                    xs[k] += (rng.unit() - 0.5) * 0.8;
                    ys[k] += (rng.unit() - 0.5) * 0.8;
                }
                let slack = s.prepare_hash(&ids, (&xs, &ys), side);
                assert!(slack > 0.0, "refreshed in round {round}");
                let farthest = (0..n)
                    .map(|k| f64::from(xs[k] - x0[k]).hypot(f64::from(ys[k] - y0[k])))
                    .fold(0.0, f64::max);
                assert!(f64::from(slack) >= farthest, "{slack} < {farthest}");
                let (x0, y0) = (&s.built_x, &s.built_y);
                assert!((0..n).all(|k| (x0[k] - xs[k]).abs() + (y0[k] - ys[k]).abs() <= slack));
                for _ in 0..1000 {
                    let p = Vec2::new(rng.unit() * extent, rng.unit() * extent);
                    let within = |k: usize| (Vec2::new(xs[k], ys[k]) - p).length_squared() <= r * r;
                    let found = |reach: f32| {
                        let mut v: Vec<usize> = Vec::new();
                        for run in s.hash.runs_of(s.hash.cells(p, reach)).iter() {
                            for at in run {
                                assert_eq!(s.hash.sorted_x()[at], xs[s.hash.order()[at] as usize]);
                                v.push(s.hash.order()[at] as usize);
                            }
                        }
                        v.retain(|&k| within(k));
                        v.sort_unstable();
                        v
                    };
                    let brute: Vec<usize> = (0..n).filter(|&k| within(k)).collect();
                    assert_eq!(found(r + slack), brute, "round {round}");
                    missed_without_slack += usize::from(found(r) != brute);
                }
            }
            // Two agents swap places in storage: rebuilt.
            ids.swap(0, 1);
            xs.swap(0, 1);
            ys.swap(0, 1);
            assert_eq!(s.prepare_hash(&ids, (&xs, &ys), side), 0.0);
            // One agent moves farther than the slack allows: rebuilt.
            xs[7] += MAX_SLACK * side * 1.01;
            assert_eq!(s.prepare_hash(&ids, (&xs, &ys), side), 0.0);
            // Another side: rebuilt.
            assert_eq!(s.prepare_hash(&ids, (&xs, &ys), 2.0 * side), 0.0);
            // A position that is not finite: rebuilt.
            xs[0] = f32::NAN;
            assert_eq!(s.prepare_hash(&ids, (&xs, &ys), 2.0 * side), 0.0);
            assert_eq!(s.prepare_hash(&ids, (&xs, &ys), 2.0 * side), 0.0);
        }
        assert!(missed_without_slack > 0, "the slack was never needed");
    }

    /// The lanes give every agent of a chunk (a partial block included) the same bits as its
    /// own stream drawn one number at a time.
    #[test]
    fn perturbations_in_lanes_equal_each_agents_own_draws() {
        let (seed, frame) = (0x5eed_u64, 77_u64);
        let ids: Vec<AgentId> = (0..29).map(|k| AgentId(k * 7919 + 3)).collect();
        let mut b = Buffers::default();
        perturbations(&ids, rng::frame_key(seed, frame), &mut b);
        for (k, id) in ids.iter().enumerate() {
            let mut rng = AgentRng::new(seed, id.0, frame, Stream::Orca as u32);
            let angle = rng.unit() * std::f32::consts::TAU;
            let (sin, cos) = trig::sin_cos(angle);
            let len = rng.unit();
            let got = (b.turb_cos[k], b.turb_sin[k], b.turb_len[k]);
            assert_eq!(got, (cos, sin, len), "agent {k}");
            assert!((cos.hypot(sin) - 1.0).abs() < 1e-6);
        }
    }
}
