//! The ORCA filter of the steering layer: after the steering pass, every agent of a group with
//! [`Orca`] parameters has its request replaced by the collision-free velocity closest to its
//! preferred one ([`crate::orca`]).
//!
//! Per agent: the preferred velocity from the pass's output (kinematic: the desired velocity;
//! dynamic: `velocity + acceleration * dt`), truncated to `pref_speed` and perturbed when the
//! group asks (every agent's perturbation of a chunk drawn in lanes first, [`perturbations`]);
//! the candidates from the hashed grid packed eight lanes at a time (`plans::pack`), in a crowd
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
//!
//! The neighbour search ([`search`]) is a file of its own: the hashed grid the pass keeps across
//! frames, the block of cells gathered for a run of agents, and the `k` nearest in order.

use std::cell::RefCell;

use glam::Vec2;
use rayon::prelude::*;

use super::out::SteerOut;
use super::view::SteerView;
use crate::agents::AgentId;
use crate::orca::lines::LANES;
use crate::orca::{
    Line, Orca, WallChains, accepted, agent_line, permits, solve, tested, unconstrained,
};
use crate::rng::{self, Stream};
use crate::simd::{apply, integer_kernel};
use crate::spatial::{HashGrid, Neighbour};
use crate::steering::trig;

mod search;

use search::{Hits, candidates, order_lines};
pub(crate) use search::{reach, wide_cells};

/// One worker's buffers.
#[derive(Default)]
struct Buffers {
    found: Vec<Neighbour>,
    /// The offsets and indices of the candidates within reach, packed eight lanes at a time
    /// (`plans::pack`): only the first `count` entries of a scan are hits, the rest is room.
    rx: Vec<f32>,
    ry: Vec<f32>,
    js: Vec<u32>,
    /// The nearest candidates as `dist_sq bits << 32 | p`, `p` their place in `rx`, `ry` and
    /// `js`, in order of `(dist_sq, id)` (`search::nearest_in_order`).
    near: Vec<u64>,
    /// Scratch of `search::nearest_in_order` for ties at the `k`-th
    /// distance: `(dist_sq bits << 32 | id, p)`.
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
/// chunks by how fast they go, rather than one thread finishing a run of several chunks alone.
/// Smaller than the pass's chunks for that sharing, but not much smaller: a chunk's first agent
/// regathers its block and searches without the previous agent's distance, a few hundred
/// instructions (the measurement: docs/PERFORMANCE.md, "Tuning constants"). Which agents share a task changes only what the
/// buffers carry from one agent to the next (the gathered block, the `k`-th distance, the
/// skipped tests), never a result.
const FILTER_CHUNK: usize = 256;

/// Every agent's perturbation of the chunk whose ids are `ids`, into `b.turb_*`: the first two
/// draws of its ORCA stream from the frame's key, a direction (the polynomial sine and cosine
/// of the first times 2 pi, in their range) and a length (the second, in units of the group's
/// `perturbation`). Eight agents at a time in lanes; the same operations per agent as one at a
/// time, so the same bits.
#[apply(integer_kernel!)]
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
/// crowd in conflict the test is then tried for one agent in four (few agents of such a crowd
/// are free, and a failed test costs two or three neighbours' tests; docs/PERFORMANCE.md, "Tuning constants"); a crowd in free
/// flow never fails it, and loses nothing.
const UNTESTED_AFTER_FAILURE: u32 = 3;

/// The filtered requests of the agents from storage index `base` on, one per slot of `lx`,
/// `ly` and `near`. Compiled for AVX-512 and AVX2 too, where the candidate scan runs in vectors
/// (the same arithmetic, so the same bits); dispatched once per chunk, with [`filter`] inlined,
/// rather than once per agent.
#[apply(integer_kernel!)]
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
    #[cfg(feature = "oracle")]
    crate::oracle::record(crate::oracle::Seen {
        model: "orca",
        agent: id,
        position: pos,
        radius: r,
        nearest: Some(k),
        neighbours: (0..count).map(|q| ids[js[place(q)] as usize].0).collect(),
    });
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
