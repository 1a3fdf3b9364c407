//! Cell-batched flocking: the agents of one grid cell evaluated against one gathered
//! neighbourhood.
//!
//! With cells at least as wide as every flocking radius, the candidates of all agents in a cell are
//! the points of its 3 x 3 block of cells. The batch gathers that block once per cell into a
//! contiguous, padded buffer, with the torus image already applied (a neighbour cell across a seam
//! is shifted by the world's side), so the lane kernel needs neither run boundaries nor
//! minimum-image arithmetic. Every agent of the cell then sums over the buffer in SIMD lanes
//! (runtime dispatch: two agents per 16-lane vector on AVX-512, clones for AVX2 + FMA and AVX, the
//! baseline build otherwise; the same bits on each). The kernel reads the agents from columns (a
//! cell's run of the grid's own positions and copies when all its agents are of one batched
//! group; otherwise batches of one group's agents of the cell) and writes their sums straight
//! into the task's waiting columns,
//! where they stay until the task's cells are done; then the flocking terms and the model adapter
//! run over each run of agents of one group, one term at a time in long vector loops, writing the
//! outputs in the grid's order. Vicsek sums wait the same way; their turns (each agent's draw,
//! computed from the frame's key without a per-agent generator), headings and the adapter then run
//! over each run in lanes too; the Vicsek sums themselves are the flock's kernel summing the unit
//! headings as alignment sums. For a general plan with flocking terms (a "summed" group) the batch
//! stores the sums alone, which the per-agent evaluation then reads instead of querying the
//! neighbourhood.
//!
//! View cones are tested without a square root: for a cosine `c < 0` a neighbour at offset `d`
//! is seen when `h . d >= 0` or `(h . d)^2 <= c^2 |d|^2`, for `c >= 0` when both `h . d >= 0`
//! and `(h . d)^2 >= c^2 |d|^2`: the same test as `h . d >= c |d|` up to rounding at the cone's
//! edge.
//!
//! Invariants: an agent's sums depend only on its cell's buffer, whose order is fixed by the
//! grid (cell by cell, and by index within a cell), so the result is the same for any number of
//! threads and for the sequential pass; the sums equal the scalar reference traversal to
//! rounding (`tests/flocking.rs` checks it against brute force).

use std::cell::RefCell;
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};

use glam::Vec2;
use multiversion::multiversion;
use multiversion::target::target_cfg;
use rayon::prelude::*;

use super::adapter::Adapter;
use super::neighbours::{LANES, SortedCopies, positive_finite, unit_headings_at, without_self};
use super::plan::{ALI, COH, NeighbourSpec, PlanKind, SEP};
use super::view::SteerView;
use crate::bounds::Bounds;
use crate::rng::Stream;
use crate::spatial::{GridIndex, SpatialIndex};
use crate::steering::NeighbourSums;

#[cfg(target_arch = "x86_64")]
mod avx512;

/// Agents (in grid order) per parallel task; each chunk is a task of its own
/// (`with_max_len(1)`), so that two threads running at different speeds (a core shared with
/// another process) share the tasks by speed rather than in rayon's default runs of several
/// chunks, which one thread then finishes alone. The flock at 100,000 agents on 2 threads: the
/// idle time of the batch's loop, median per step, 135 µs in runs of 2,048-agent chunks, 35 µs
/// in single tasks of 1,024 (docs/notes/performance-history.md).
const CELL_CHUNK: usize = 1024;
/// Lanes of the neighbour kernel: two vectors per operation, for instruction-level parallelism
/// over the short candidate lists of a cell.
const KLANES: usize = 8;
/// The smallest size of a cell buffer's vectors.
const MIN_CELL_BUF: usize = 4096;
/// A padding coordinate: far from every point, with a finite square.
const FAR: f32 = 1e18;

/// The batch's outputs in the grid's order (the grid's ranks map storage indices to it).
#[derive(Debug, Default)]
pub(crate) struct CellOut {
    lin_x: Vec<f32>,
    lin_y: Vec<f32>,
    count: Vec<f32>,
    /// Per group: the kernel's query template, when the group is batched or summed.
    specs: Vec<Option<Query>>,
    /// Per grid position: the neighbour sums of an agent of a summed group (empty when no
    /// group is summed).
    sums: Vec<NeighbourSums>,
    /// The neighbours all agents found, when the batch evaluated every agent (a sum of whole
    /// numbers, exact in any order).
    found: Option<f64>,
}

/// One task's chunks of the pass outputs: linear x and y, angular, wander angle, neighbours.
pub(crate) type OutChunks<'c> = (
    &'c mut [f32],
    &'c mut [f32],
    &'c mut [f32],
    &'c mut [f32],
    &'c mut [f32],
);

/// The padded neighbourhood of one cell.
#[derive(Debug, Default)]
struct CellBuf {
    /// Values in use (a multiple of `LANES` once gathered); the vectors may be longer.
    len: usize,
    x: Vec<f32>,
    y: Vec<f32>,
    vx: Vec<f32>,
    vy: Vec<f32>,
    g: Vec<f32>,
    /// Unit headings, gathered only for Vicsek batches.
    hx: Vec<f32>,
    hy: Vec<f32>,
}

thread_local! {
    static BUF: RefCell<(CellBuf, Runs, TaskHeadings)> =
        RefCell::new((CellBuf::default(), Runs::default(), TaskHeadings::default()));
}

/// A task's unit headings, when the copies hold none (no Vicsek plan) and a view cone needs its
/// agents' own: computed for the task's grid positions alone, in cache, instead of a pass over
/// every agent that stores them.
#[derive(Debug, Default)]
struct TaskHeadings {
    x: Vec<f32>,
    y: Vec<f32>,
}

/// Whether agent `i` is evaluated by the batch (its plan is flocking-only and the kernel serves
/// its neighbourhood).
#[inline]
pub(crate) fn is_batched(view: &SteerView, i: usize) -> bool {
    is_batched_group(view, view.agents.group[i] as usize)
}

/// Whether the agents of group `g` are evaluated by the batch.
#[inline]
pub(crate) fn is_batched_group(view: &SteerView, g: usize) -> bool {
    batched(&view.plans[g])
}

/// Whether the batch computes the neighbour sums of group `g`'s agents for their per-agent
/// evaluation (a plan that mixes flocking terms with other behaviours).
#[inline]
pub(crate) fn is_summed_group(view: &SteerView, g: usize) -> bool {
    summed(&view.plans[g])
}

/// Whether a plan's neighbour sums come from the batch while the rest of it is evaluated per
/// agent or in the leader's lanes: the general plan, and leader and field following with
/// separation, with sums the lane kernel serves.
fn summed(plan: &super::plan::Plan) -> bool {
    matches!(
        plan.kind,
        PlanKind::General | PlanKind::FollowLeader { .. } | PlanKind::FollowField { .. }
    ) && plan.spec.active
        && plan.spec.kernel_ok()
}

/// Whether a plan is evaluated by the batch: flocking the lane kernel serves, or Vicsek.
fn batched(plan: &super::plan::Plan) -> bool {
    match plan.kind {
        PlanKind::Flock { .. } => plan.spec.kernel_ok(),
        PlanKind::Vicsek { .. } => plan.spec.batch_ok(),
        _ => false,
    }
}

/// One block of the cell buffer: positions, velocities and groups of `KLANES` candidates.
type Block<'b> = (
    &'b [f32; KLANES],
    &'b [f32; KLANES],
    &'b [f32; KLANES],
    &'b [f32; KLANES],
    &'b [f32; KLANES],
);

impl CellBuf {
    /// The gathered candidates in blocks of `KLANES`. The five columns are cut to one length
    /// first, so the loop over blocks runs on one counter without bounds checks.
    #[inline(always)]
    fn blocks(&self) -> impl Iterator<Item = Block<'_>> {
        self.blocks_of((&self.vx, &self.vy))
    }

    /// [`CellBuf::blocks`] with `motion` read in the velocities' place (the unit headings, for
    /// Vicsek sums).
    #[inline(always)]
    fn blocks_of<'b>(
        &'b self,
        (mx, my): (&'b [f32], &'b [f32]),
    ) -> impl Iterator<Item = Block<'b>> {
        let n = self.len;
        fn col(v: &[f32], n: usize) -> &[[f32; KLANES]] {
            v[..n].as_chunks::<KLANES>().0
        }
        let (x, y) = (col(&self.x, n), col(&self.y, n));
        let (vx, vy, g) = (col(mx, n), col(my, n), col(&self.g, n));
        let m = x.len();
        let (y, vx, vy, g) = (&y[..m], &vx[..m], &vy[..m], &g[..m]);
        (0..m).map(move |k| (&x[k], &y[k], &vx[k], &vy[k], &g[k]))
    }
}

/// Lane accumulators of the neighbour kernels, gathered once the loop is done (inside the loop
/// they are separate locals, which stay in registers).
#[derive(Clone, Copy)]
struct Acc {
    sx: [f32; KLANES],
    sy: [f32; KLANES],
    ax: [f32; KLANES],
    ay: [f32; KLANES],
    an: [f32; KLANES],
    cx: [f32; KLANES],
    cy: [f32; KLANES],
    cn: [f32; KLANES],
    n: [f32; KLANES],
}

impl Acc {
    /// The lanes summed (as trees); `shared`: cohesion counts the alignment neighbours.
    #[inline(always)]
    fn reduced(&self, shared: bool) -> Reduced {
        let an = tree_sum(&self.an);
        [
            tree_sum(&self.sx),
            tree_sum(&self.sy),
            tree_sum(&self.ax),
            tree_sum(&self.ay),
            an,
            tree_sum(&self.cx),
            tree_sum(&self.cy),
            if shared { an } else { tree_sum(&self.cn) },
            tree_sum(&self.n),
        ]
    }
}

/// One agent's kernel sums, reduced: separation x and y, alignment x and y, alignment's count,
/// cohesion x and y, cohesion's count, neighbours within the query radius. A Vicsek sum holds
/// the summed unit headings in alignment's place and their number in the last.
type Reduced = [f32; 9];

/// The [`NeighbourSums`] of a flocking query's reduced sums.
#[inline(always)]
fn flock_sums(r: &Reduced) -> NeighbourSums {
    let [sx, sy, ax, ay, an, cx, cy, cn, n] = *r;
    NeighbourSums {
        separation: Vec2::new(sx, sy),
        alignment: Vec2::new(ax, ay),
        alignment_count: an,
        cohesion: Vec2::new(cx, cy),
        cohesion_count: cn,
        repulsion: Vec2::ZERO,
        count: n,
        heading: Vec2::ZERO,
    }
}

impl CellOut {
    /// Copies the batched linear requests of storage indices `base..base + lx.len()` (every
    /// agent batched) into the per-agent output chunks (the neighbour counts are summed in the
    /// batch, the angular outputs, all zero, and the wander angles, unchanged, are not written).
    pub(crate) fn take_all(
        &self,
        index: &SpatialIndex,
        base: usize,
        (lx, ly): (&mut [f32], &mut [f32]),
    ) {
        let n = lx.len();
        let rank = &ranks(index)[base..base + n];
        let ly = &mut ly[..n];
        // The columns cut to one length, and each rank clamped below it: a select instead of a
        // bounds-check branch per load (ranks are grid positions, so the clamp changes none).
        let m = self.lin_x.len().min(self.lin_y.len());
        let Some(last) = m.checked_sub(1) else {
            return;
        };
        let (px, py) = (&self.lin_x[..m], &self.lin_y[..m]);
        for k in 0..n {
            let r = rank[k].load(Ordering::Relaxed) as usize;
            // A rank past the columns means outputs of another frame's batch (a stale grid).
            debug_assert!(r < m, "rank {r} of agent {} past the batch's {m}", base + k);
            let r = r.min(last);
            lx[k] = px[r];
            ly[k] = py[r];
        }
    }

    /// The neighbours all agents found, when the batch evaluated every agent.
    pub(crate) fn found(&self) -> Option<f64> {
        self.found
    }

    /// The neighbour sums the batch computed for agent `i` (storage index) of a summed group.
    #[inline]
    pub(crate) fn sums_of(&self, view: &SteerView, i: usize) -> &NeighbourSums {
        &self.sums[ranks(view.index)[i].load(Ordering::Relaxed) as usize]
    }

    /// Copies agent `i`'s batched outputs into slot `k` of the per-agent output chunks.
    #[inline]
    pub(crate) fn take(
        &self,
        i: usize,
        view: &SteerView,
        (lx, ly, an, wa, nb): OutChunks,
        k: usize,
    ) {
        let r = ranks(view.index)[i].load(Ordering::Relaxed) as usize;
        lx[k] = self.lin_x[r];
        ly[k] = self.lin_y[r];
        an[k] = 0.0;
        wa[k] = view.agents.wander[i];
        nb[k] = self.count[r];
    }
}

/// The grid's position of each storage index (the grid's ranks, written by its rebuild), for
/// the outputs the batch wrote in the grid's order; empty without a grid (the batch then did
/// not run).
fn ranks(index: &SpatialIndex) -> &[AtomicU32] {
    match index {
        SpatialIndex::Grid(grid) => grid.ranks(),
        _ => &[],
    }
}

/// The maximum speed of agent `i` (storage index) of `group`: its group's while no agent has
/// one of its own, without a read of the agents' column (the batch visits agents in the grid's
/// order, which scatters reads of storage-ordered columns as the order goes stale).
#[inline(always)]
fn max_speed_of(view: &SteerView, group: usize, i: usize) -> f32 {
    if view.agents.speeds_of_groups() {
        view.profiles[group].max_speed
    } else {
        view.agents.max_speed[i]
    }
}

/// The grid and its copies when the batch can run: the grid kernel is ready and, on a torus,
/// the grid has at least three cells per axis (so a 3 x 3 block never holds a cell twice).
fn ready<'a>(view: &SteerView<'a>) -> Option<(&'a GridIndex, &'a SortedCopies)> {
    let (SpatialIndex::Grid(grid), Some(sorted)) = (view.index, view.sorted) else {
        return None;
    };
    if view.bounds.is_torus() && (grid.cells_x() < 3 || grid.cells_y() < 3) {
        return None;
    }
    Some((grid, sorted))
}

/// Evaluates every batched agent into `out` (in the grid's order), and stores the neighbour sums
/// of every agent of a summed group. Returns whether the batch ran; when it did not, every agent
/// goes through the per-agent path.
pub(crate) fn run(view: &SteerView, out: &mut CellOut, parallel: bool) -> bool {
    out.found = None;
    let Some((grid, sorted)) = ready(view) else {
        return false;
    };
    let a = view.agents;
    let one_group = view.plans.len() == 1;
    out.specs.clear();
    out.specs.extend(
        view.plans
            .iter()
            .map(|p| (batched(p) || summed(p)).then(|| Query::of(&p.spec, one_group))),
    );
    if out.specs.iter().all(Option::is_none) {
        return false;
    }
    let n = a.len();
    for v in [&mut out.lin_x, &mut out.lin_y, &mut out.count] {
        v.resize(n, 0.0);
    }
    let any_summed = view.plans.iter().any(summed);
    out.sums
        .resize(if any_summed { n } else { 0 }, NeighbourSums::default());
    // With every agent batched, each task adds up its agents' neighbour counts while they are
    // in cache (whole numbers: the total is exact in any order).
    let all = view.plans.iter().all(batched);
    let found = AtomicU64::new(0);
    let specs = &out.specs;
    let work = |base: usize, (lx, ly, nb): Columns, sums: &mut [NeighbourSums]| {
        BUF.with_borrow_mut(|(buf, runs, heads)| {
            chunk(
                view,
                grid,
                sorted,
                specs,
                base,
                (lx, ly, nb, sums),
                (buf, runs, heads),
            );
        });
        if all {
            // Whole numbers below 2^24 each: the double-precision sum is exact.
            found.fetch_add(sum_lanes(nb) as u64, Ordering::Relaxed);
        }
    };
    if parallel {
        let columns = (
            out.lin_x.par_chunks_mut(CELL_CHUNK),
            out.lin_y.par_chunks_mut(CELL_CHUNK),
            out.count.par_chunks_mut(CELL_CHUNK),
        );
        if any_summed {
            (
                columns.0,
                columns.1,
                columns.2,
                out.sums.par_chunks_mut(CELL_CHUNK),
            )
                .into_par_iter()
                .enumerate()
                .with_max_len(1)
                .for_each(|(c, (lx, ly, nb, s))| work(c * CELL_CHUNK, (lx, ly, nb), s));
        } else {
            columns
                .into_par_iter()
                .enumerate()
                .with_max_len(1)
                .for_each(|(c, (lx, ly, nb))| work(c * CELL_CHUNK, (lx, ly, nb), &mut []));
        }
    } else {
        // The same tasks, one after another (a task's columns hold `CELL_CHUNK` agents).
        let tasks = out
            .lin_x
            .chunks_mut(CELL_CHUNK)
            .zip(out.lin_y.chunks_mut(CELL_CHUNK))
            .zip(out.count.chunks_mut(CELL_CHUNK));
        let mut sums = out.sums.chunks_mut(CELL_CHUNK);
        for (c, ((lx, ly), nb)) in tasks.enumerate() {
            let s = if any_summed {
                sums.next().expect("a chunk of sums per task")
            } else {
                &mut []
            };
            work(c * CELL_CHUNK, (lx, ly, nb), s);
        }
    }
    out.found = all.then(|| found.into_inner() as f64);
    true
}

/// The sum of `v` in double precision, in eight interleaved accumulators (vector lanes rather
/// than one chain of dependent additions), then those in order: the same order on any number of
/// threads and in every dispatch target (the baseline build converts and adds two lanes at a
/// time).
#[multiversion::multiversion(targets(
    "x86_64+avx2+fma+avx512f+avx512vl+avx512bw+avx512dq",
    "x86_64+avx2+fma",
    "x86_64+avx"
))]
pub(crate) fn sum_lanes(v: &[f32]) -> f64 {
    let (blocks, rest) = v.as_chunks::<8>();
    let mut acc = [0.0_f64; 8];
    for b in blocks {
        for (a, &x) in acc.iter_mut().zip(b) {
            *a += f64::from(x);
        }
    }
    acc.iter().sum::<f64>() + rest.iter().map(|&x| f64::from(x)).sum::<f64>()
}

/// One task's chunks of the batch's columns: linear x and y, neighbours found.
type Columns<'c> = (&'c mut [f32], &'c mut [f32], &'c mut [f32]);

/// Agents whose sums one kernel call computes in a batch (one cell, one group, when a task's
/// groups are mixed).
const CELL_BATCH: usize = 32;

/// One agent's numbers for the lane kernel.
#[derive(Clone, Copy, Debug, Default)]
struct Agent {
    x: f32,
    y: f32,
    hx: f32,
    hy: f32,
    g: f32,
}

/// The agents of one kernel call, as columns of one length: a run of the grid's cell-ordered
/// positions and copies, or a batch's arrays.
#[derive(Clone, Copy)]
struct AgentCols<'a> {
    x: &'a [f32],
    y: &'a [f32],
    /// Unit headings; `None` when no query reads them (no view cone), which the kernel then
    /// takes as zeros.
    h: Option<(&'a [f32], &'a [f32])>,
    g: &'a [f32],
}

impl AgentCols<'_> {
    /// The number of agents.
    fn len(&self) -> usize {
        self.x.len()
    }

    /// Agent `k`.
    #[inline(always)]
    fn at(&self, k: usize) -> Agent {
        let (hx, hy) = self.h.map_or((0.0, 0.0), |(hx, hy)| (hx[k], hy[k]));
        Agent {
            x: self.x[k],
            y: self.y[k],
            hx,
            hy,
            g: self.g[k],
        }
    }
}

/// Where a kernel call writes its agents' sums in the task's [`Runs`]: at consecutive slots from
/// `start`, or at the slots listed.
#[derive(Clone, Copy)]
struct Slots<'a> {
    start: usize,
    list: Option<&'a [usize]>,
}

impl Slots<'_> {
    /// The slot of agent `k`.
    #[inline(always)]
    fn at(&self, k: usize) -> usize {
        self.list.map_or(self.start + k, |l| l[k])
    }
}

/// The outputs of one parallel task, indexed from its first grid position.
struct Outputs<'o> {
    base: usize,
    lx: &'o mut [f32],
    ly: &'o mut [f32],
    nb: &'o mut [f32],
    /// The sums of summed groups' agents, for their per-agent evaluation (empty when no group
    /// is summed).
    sums: &'o mut [NeighbourSums],
    /// The agents' sums, waiting for [`Outputs::finish`].
    runs: &'o mut Runs,
    /// The copies in the grid's order (the flocking agents' velocities).
    sorted: &'o SortedCopies,
}

impl Outputs<'_> {
    /// Files the sums the kernel wrote at slot `j` (grid position `base + j`) for the agent of
    /// storage index `i` of `group`: a flocking or Vicsek agent waits in the runs for
    /// [`Outputs::finish`]; a summed group's agent gets its sums without itself.
    #[inline(always)]
    fn settle(&mut self, view: &SteerView, group: usize, (j, i): (usize, usize)) {
        let plan = &view.plans[group];
        let runs = &mut *self.runs;
        assert!(j < CELL_CHUNK, "a slot of the task");
        match plan.kind {
            PlanKind::Flock { .. } => {
                // The sums still hold the agent itself: `finish` takes it out in lanes.
                runs.mark[j] = group as u32 + 1;
                runs.max_speed[j] = max_speed_of(view, group, i);
            }
            PlanKind::Vicsek { .. } => {
                // The summed headings wait too: the turns, the headings and the adapter then run
                // over each run of the group in lanes (`vicsek_run`).
                runs.mark[j] = group as u32 + 1;
                runs.id[j] = view.agents.ids[i].0;
                runs.max_speed[j] = max_speed_of(view, group, i);
            }
            _ => self.summed(&plan.spec, j),
        }
    }

    /// A summed plan's agent at slot `j`: its sums without itself, for its evaluation in the
    /// pass.
    #[inline(always)]
    fn summed(&mut self, spec: &NeighbourSpec, j: usize) {
        let p = self.base + j;
        let velocity = Vec2::new(self.sorted.vx[p], self.sorted.vy[p]);
        self.sums[j] = without_self(self.runs.sums_at(j), velocity, spec);
    }

    /// [`Outputs::settle`] for every agent of the task, all of group 0, whose storage indices
    /// are `order`: the plan's kind chosen once, then one loop per column.
    fn settle_all(&mut self, view: &SteerView, order: &[u32]) {
        let plan = &view.plans[0];
        let n = order.len();
        assert!(n <= CELL_CHUNK, "a task's agents");
        let waits = matches!(plan.kind, PlanKind::Flock { .. } | PlanKind::Vicsek { .. });
        if !waits {
            for j in 0..n {
                self.summed(&plan.spec, j);
            }
            return;
        }
        let runs = &mut *self.runs;
        runs.mark[..n].fill(1);
        if view.agents.speeds_of_groups() {
            // Every agent's is the group's: no read through the order.
            runs.max_speed[..n].fill(view.profiles[0].max_speed);
        } else {
            let max_speed = &view.agents.max_speed;
            for (m, &i) in runs.max_speed[..n].iter_mut().zip(order) {
                *m = max_speed[i as usize];
            }
        }
        if let PlanKind::Vicsek { .. } = plan.kind {
            let ids = &view.agents.ids;
            for (id, &i) in runs.id[..n].iter_mut().zip(order) {
                *id = ids[i as usize].0;
            }
        }
    }

    /// Runs the flocking terms and the model adapter over every run of agents of one flocking
    /// group (in the task's grid order) and writes their results.
    fn finish(&mut self, view: &SteerView) {
        let n = self.lx.len();
        let mut j = 0;
        while j < n {
            let mark = self.runs.mark[j];
            if mark == 0 {
                j += 1;
                continue;
            }
            let end = j + self.runs.mark[j..n]
                .iter()
                .take_while(|&&m| m == mark)
                .count();
            let plan = &view.plans[mark as usize - 1];
            let outs = (&mut self.lx[j..end], &mut self.ly[j..end]);
            match plan.kind {
                PlanKind::Flock { terms, len } => {
                    let (a, b) = (self.base + j, self.base + end);
                    let vel = (&self.sorted.vx[a..b], &self.sorted.vy[a..b]);
                    self.runs.without_self_run(j..end, vel, plan.spec.on);
                    evaluate_run(
                        self.runs,
                        j..end,
                        &terms[..len as usize],
                        &plan.adapter,
                        outs,
                    );
                    self.nb[j..end].copy_from_slice(&self.runs.count[j..end]);
                }
                PlanKind::Vicsek { noise, weight } => {
                    let key = crate::rng::frame_key(view.seed, view.frame);
                    vicsek_run(self.runs, j..end, (noise, weight), key, &plan.adapter, outs);
                    // The count held the agent itself.
                    for (nb, &c) in self.nb[j..end].iter_mut().zip(&self.runs.count[j..end]) {
                        *nb = c - 1.0;
                    }
                }
                _ => unreachable!("only flocking and Vicsek plans wait in runs"),
            }
            j = end;
        }
    }
}

/// The agents of one cell and group waiting for their kernel call, when a task's groups are
/// mixed.
struct Batch {
    x: [f32; CELL_BATCH],
    y: [f32; CELL_BATCH],
    hx: [f32; CELL_BATCH],
    hy: [f32; CELL_BATCH],
    g: [f32; CELL_BATCH],
    /// Per agent: its slot in the task's runs (its grid position less the task's first), its
    /// storage index.
    slot: [usize; CELL_BATCH],
    i: [usize; CELL_BATCH],
    len: usize,
    group: usize,
}

impl Batch {
    /// Computes the batch's sums over `buf` into the task's runs and files them.
    fn run(&mut self, view: &SteerView, q: &Query, buf: &CellBuf, out: &mut Outputs) {
        let m = self.len;
        if m == 0 {
            return;
        }
        let agents = AgentCols {
            x: &self.x[..m],
            y: &self.y[..m],
            h: Some((&self.hx[..m], &self.hy[..m])),
            g: &self.g[..m],
        };
        let slots = Slots {
            start: 0,
            list: Some(&self.slot[..m]),
        };
        kernel_cell(buf, q, &agents, slots, out.runs);
        for k in 0..m {
            out.settle(view, self.group, (self.slot[k], self.i[k]));
        }
        self.len = 0;
    }
}

/// The batch over grid positions `base..base + lx.len()`: per cell, the neighbourhood is
/// gathered once and the sums of its agents computed over it in one kernel call (the cell's
/// agents straight from the grid's columns when they are all of one batched group; otherwise in
/// batches of one group); once every cell is done, the sums of each run of agents of one group
/// go through the flocking terms and the model adapter together ([`Outputs::finish`]).
#[allow(clippy::too_many_arguments)]
#[multiversion(targets(
    "x86_64+avx2+fma+avx512f+avx512vl+avx512bw+avx512dq",
    "x86_64+avx2+fma",
    "x86_64+avx"
))]
fn chunk(
    view: &SteerView,
    grid: &GridIndex,
    sorted: &SortedCopies,
    specs: &[Option<Query>],
    base: usize,
    (lx, ly, nb, sums): (&mut [f32], &mut [f32], &mut [f32], &mut [NeighbourSums]),
    (buf, runs, heads): (&mut CellBuf, &mut Runs, &mut TaskHeadings),
) {
    let order = grid.order();
    let starts = grid.cell_start();
    let end = base + lx.len();
    let groups = specs.iter().flatten().any(Query::needs_groups);
    let headings = specs.iter().flatten().any(|q| q.mode == VICSEK);
    let gathers = Gather {
        grid,
        s: sorted,
        bounds: view.bounds,
        groups,
        headings,
    };
    runs.clear(lx.len());
    let mut out = Outputs {
        base,
        lx,
        ly,
        nb,
        sums,
        runs,
        sorted,
    };
    let (xs, ys) = grid.sorted_padded();
    let cones = specs.iter().flatten().any(Query::needs_headings);
    let h = if sorted.headings {
        Some((&sorted.hx[..], &sorted.hy[..], 0))
    } else if cones {
        let positions = base..end;
        let (hx, hy) = (&mut heads.x, &mut heads.y);
        hx.resize(CELL_CHUNK, 0.0);
        hy.resize(CELL_CHUNK, 0.0);
        let (hx, hy) = (&mut hx[..positions.len()], &mut hy[..positions.len()]);
        unit_headings_at(
            (&sorted.vx, &sorted.vy),
            positions,
            (hx, hy),
            order,
            &view.agents.orientation,
        );
        Some((&hx[..], &hy[..], base))
    } else {
        None
    };
    let cols = (xs, ys, h, &sorted.g[..]);
    if let [Some(q)] = specs {
        // One batched group: every agent of a cell is its, in one kernel call that reads the
        // agents from the grid's columns and writes their sums in place.
        for (cell, range) in cell_pieces(starts, base..end) {
            gathers.cell(cell, buf);
            whole_cell(buf, q, cols, (range, base), out.runs);
        }
        out.settle_all(view, &order[base..end]);
        out.finish(view);
        return;
    }
    let mut batch = Batch {
        x: [0.0; CELL_BATCH],
        y: [0.0; CELL_BATCH],
        hx: [0.0; CELL_BATCH],
        hy: [0.0; CELL_BATCH],
        g: [0.0; CELL_BATCH],
        slot: [0; CELL_BATCH],
        i: [0; CELL_BATCH],
        len: 0,
        group: 0,
    };
    for (cell, range) in cell_pieces(starts, base..end) {
        let (k, cell_end) = (range.start, range.end);
        // A cell of one group's agents alone (the common case where groups keep apart, or where
        // the other groups are few): as with one batched group, one kernel call straight from
        // the grid's columns. The kernel sums each agent on its own, so the bits are a batch's.
        let first = sorted.g[k];
        if sorted.g[range.clone()].iter().all(|&g| g == first) {
            if let Some(q) = &specs[first as usize] {
                gathers.cell(cell, buf);
                whole_cell(buf, q, cols, (range.clone(), base), out.runs);
                for (p, &i) in range.clone().zip(&order[range]) {
                    out.settle(view, first as usize, (p - base, i as usize));
                }
            }
            continue;
        }
        let mut gathered = false;
        for p in k..cell_end {
            let g = sorted.g[p] as usize;
            if specs[g].is_none() {
                continue;
            }
            if !gathered {
                gathers.cell(cell, buf);
                gathered = true;
            }
            if batch.len == CELL_BATCH || (batch.len > 0 && batch.group != g) {
                let q = specs[batch.group].as_ref().expect("batched");
                batch.run(view, q, buf, &mut out);
            }
            let m = batch.len;
            // The unit heading from the copies; they have none when no batched query has a
            // view cone, and then no kernel reads it.
            (batch.hx[m], batch.hy[m]) = h.map_or((0.0, 0.0), |(hx, hy, f)| (hx[p - f], hy[p - f]));
            (batch.x[m], batch.y[m], batch.g[m]) = (xs[p], ys[p], sorted.g[p]);
            (batch.slot[m], batch.i[m]) = (p - base, order[p] as usize);
            batch.group = g;
            batch.len += 1;
        }
        // The buffer belongs to this cell: its batch runs before the next cell gathers.
        if batch.len > 0 {
            let q = specs[batch.group].as_ref().expect("batched");
            batch.run(view, q, buf, &mut out);
        }
    }
    out.finish(view);
}

/// The grid positions `range` cut at cell boundaries: `(cell, positions)` for each cell they
/// reach, in order (`starts` the cells' prefix sums; the first cell may begin before the range
/// and the last end after it). Every piece holds at least one position.
fn cell_pieces(
    starts: &[u32],
    range: std::ops::Range<usize>,
) -> impl Iterator<Item = (usize, std::ops::Range<usize>)> + '_ {
    let end = range.end;
    // The first cell holding position `range.start`.
    let mut cell = starts.partition_point(|&s| s as usize <= range.start) - 1;
    let mut k = range.start;
    std::iter::from_fn(move || {
        if k >= end {
            return None;
        }
        while starts[cell + 1] as usize <= k {
            cell += 1;
        }
        let piece = k..(starts[cell + 1] as usize).min(end);
        k = piece.end;
        Some((cell, piece))
    })
}

/// The grid's columns: positions, unit headings (when some query reads them: the copies', or
/// the task's, with the grid position of their first value), groups.
type GridCols<'a> = (
    &'a [f32],
    &'a [f32],
    Option<(&'a [f32], &'a [f32], usize)>,
    &'a [f32],
);

/// The sums of the agents at grid positions `range` (of one cell, whose neighbourhood `buf`
/// holds) in one kernel call that reads them from the grid's columns and writes them at their
/// slots (position minus `base`).
#[inline(always)]
fn whole_cell(
    buf: &CellBuf,
    q: &Query,
    (xs, ys, h, g): GridCols,
    (range, base): (std::ops::Range<usize>, usize),
    runs: &mut Runs,
) {
    let agents = AgentCols {
        x: &xs[range.clone()],
        y: &ys[range.clone()],
        h: h.map(|(hx, hy, f)| {
            let at = range.start - f..range.end - f;
            (&hx[at.clone()], &hy[at])
        }),
        g: &g[range.clone()],
    };
    let slots = Slots {
        start: range.start - base,
        list: None,
    };
    kernel_cell(buf, q, &agents, slots, runs);
}

/// One column of [`Runs`]: a task's agents at most, so that an index checked once against
/// [`CELL_CHUNK`] needs no further bounds checks, on whole cache lines (`crate::lines`: the
/// flocking terms read and write the columns in 64-byte vectors).
type Column = Box<Lines>;

/// [`CELL_CHUNK`] values starting on a cache line.
#[derive(Debug)]
#[repr(C, align(64))]
struct Lines([f32; CELL_CHUNK]);

impl std::ops::Deref for Lines {
    type Target = [f32; CELL_CHUNK];
    fn deref(&self) -> &[f32; CELL_CHUNK] {
        &self.0
    }
}

impl std::ops::DerefMut for Lines {
    fn deref_mut(&mut self) -> &mut [f32; CELL_CHUNK] {
        &mut self.0
    }
}

/// A zeroed [`Column`] (8 KiB on the heap).
fn column() -> Column {
    Box::new(Lines([0.0; CELL_CHUNK]))
}

/// The sums and state of a task's agents, in columns indexed from the task's first grid
/// position: the kernel writes every batched or summed agent's sums here; `mark` is the agent's
/// group plus one where they wait for the flocking terms or Vicsek turns, 0 elsewhere (a summed
/// agent's sums are read back at once, by [`Outputs::settle`]).
#[derive(Debug)]
struct Runs {
    mark: Box<[u32; CELL_CHUNK]>,
    sep: [Column; 2],
    ali: [Column; 2],
    ali_n: Column,
    coh: [Column; 2],
    coh_n: Column,
    vel: [Column; 2],
    max_speed: Column,
    count: Column,
    /// Agent ids (Vicsek runs: each agent's random stream).
    id: Box<[u32; CELL_CHUNK]>,
    /// The weighted sum of the terms, per agent.
    total: [Column; 2],
}

impl Default for Runs {
    fn default() -> Self {
        Runs {
            mark: vec![0; CELL_CHUNK]
                .into_boxed_slice()
                .try_into()
                .expect("CELL_CHUNK marks"),
            sep: [column(), column()],
            ali: [column(), column()],
            ali_n: column(),
            coh: [column(), column()],
            coh_n: column(),
            vel: [column(), column()],
            max_speed: column(),
            count: column(),
            id: vec![0; CELL_CHUNK]
                .into_boxed_slice()
                .try_into()
                .expect("CELL_CHUNK ids"),
            total: [column(), column()],
        }
    }
}

impl Runs {
    /// No agent of the first `n` waiting.
    fn clear(&mut self, n: usize) {
        self.mark[..n].fill(0);
    }

    /// Writes the kernel's sums of the agent at slot `j`, the agent itself still in them (as
    /// the kernel summed its buffer).
    #[inline(always)]
    fn set(&mut self, j: usize, r: &Reduced) {
        assert!(j < CELL_CHUNK, "a slot of the task");
        let [sx, sy, ax, ay, an, cx, cy, cn, n] = *r;
        (self.sep[0][j], self.sep[1][j]) = (sx, sy);
        (self.ali[0][j], self.ali[1][j]) = (ax, ay);
        self.ali_n[j] = an;
        (self.coh[0][j], self.coh[1][j]) = (cx, cy);
        self.coh_n[j] = cn;
        self.count[j] = n;
    }

    /// The flocking sums held at slot `j`.
    #[inline(always)]
    fn sums_at(&self, j: usize) -> NeighbourSums {
        flock_sums(&[
            self.sep[0][j],
            self.sep[1][j],
            self.ali[0][j],
            self.ali[1][j],
            self.ali_n[j],
            self.coh[0][j],
            self.coh[1][j],
            self.coh_n[j],
            self.count[j],
        ])
    }

    /// [`without_self`] over the agents at `range`, whose velocities are `(vx, vy)`: the same
    /// subtractions in lanes, so the same bits; the velocities go to `vel`.
    fn without_self_run(
        &mut self,
        range: std::ops::Range<usize>,
        (vx, vy): (&[f32], &[f32]),
        on: [bool; 3],
    ) {
        let n = range.len();
        let (vx, vy) = (&vx[..n], &vy[..n]);
        self.vel[0][range.clone()].copy_from_slice(vx);
        self.vel[1][range.clone()].copy_from_slice(vy);
        for c in &mut self.count[range.clone()] {
            *c -= 1.0;
        }
        if on[ALI] {
            let [ax, ay] = &mut self.ali;
            let (ax, ay) = (&mut ax[range.clone()], &mut ay[range.clone()]);
            let ay = &mut ay[..ax.len()];
            for k in 0..n.min(ax.len()) {
                ax[k] -= vx[k];
                ay[k] -= vy[k];
            }
            for c in &mut self.ali_n[range.clone()] {
                *c -= 1.0;
            }
        }
        if on[COH] {
            for c in &mut self.coh_n[range] {
                *c -= 1.0;
            }
        }
    }
}

/// The flocking terms and the model adapter for the agents at `range` of `r`, one term at a
/// time over the whole run (long loops of vector instructions): the same operations in the same
/// order as [`flock_total`] and [`Adapter::finish`] per agent (exact square roots and
/// divisions), so each agent's result equals the scalar evaluation bit for bit.
#[multiversion(targets(
    "x86_64+avx2+fma+avx512f+avx512vl+avx512bw+avx512dq",
    "x86_64+avx2+fma",
    "x86_64+avx"
))]
fn evaluate_run(
    r: &mut Runs,
    range: std::ops::Range<usize>,
    terms: &[(u8, f32)],
    adapter: &Adapter,
    (ox, oy): (&mut [f32], &mut [f32]),
) {
    let [tx, ty] = &mut r.total;
    let (tx, ty) = (&mut tx[range.clone()], &mut ty[range.clone()]);
    tx.fill(0.0);
    ty.fill(0.0);
    fn cut(v: &Column, range: std::ops::Range<usize>) -> &[f32] {
        &v[range]
    }
    let col = |v| cut(v, range.clone());
    let vel = (col(&r.vel[0]), col(&r.vel[1]));
    let ms = col(&r.max_speed);
    for &(slot, w) in terms {
        // Kinematic terms steer along the raw sums; dynamic alignment and cohesion along the
        // means, and nothing without neighbours.
        let (x, y, n) = match slot as usize {
            SEP => (col(&r.sep[0]), col(&r.sep[1]), None),
            ALI => (col(&r.ali[0]), col(&r.ali[1]), Some(col(&r.ali_n))),
            _ => (col(&r.coh[0]), col(&r.coh[1]), Some(col(&r.coh_n))),
        };
        match (n, adapter.kinematic) {
            (Some(n), false) => term_run::<false, true>((x, y), n, vel, ms, w, (tx, ty)),
            (_, true) => term_run::<true, false>((x, y), x, vel, ms, w, (tx, ty)),
            (None, false) => term_run::<false, false>((x, y), x, vel, ms, w, (tx, ty)),
        }
    }
    adapter.finish_run((tx, ty), (ox, oy));
}

/// The Vicsek step for the agents at `range` of `r`: each agent's turn drawn from its stream
/// (`rng::unit_at` on the frame's `key`, as [`AgentRng`] draws it), its summed heading
/// normalised and turned ([`crate::steering::vicsek_heading`]'s operations), times its speed
/// and the weight, then the model adapter, in long loops over the run: each agent equals the
/// scalar evaluation bit for bit.
#[multiversion(targets(
    "x86_64+avx2+fma+avx512f+avx512vl+avx512bw+avx512dq",
    "x86_64+avx2+fma",
    "x86_64+avx"
))]
fn vicsek_run(
    r: &mut Runs,
    range: std::ops::Range<usize>,
    (noise, weight): (f32, f32),
    key: u64,
    adapter: &Adapter,
    (ox, oy): (&mut [f32], &mut [f32]),
) {
    let n = range.len();
    let [tx, ty] = &mut r.total;
    let (tx, ty) = (&mut tx[range.clone()], &mut ty[range.clone()]);
    let (sx, sy) = (&r.ali[0][range.clone()], &r.ali[1][range.clone()]);
    let (ids, ms) = (&r.id[range.clone()], &r.max_speed[range]);
    let (ty, sx, sy, ids, ms) = (&mut ty[..n], &sx[..n], &sy[..n], &ids[..n], &ms[..n]);
    for k in 0..n {
        let stream = crate::rng::agent_key(key, ids[k], Stream::Steer as u32);
        let turn = noise * 0.5 * (crate::rng::unit_at(stream, 1) * 2.0 - 1.0);
        let (sin, cos) = crate::steering::trig::sin_cos(turn);
        // `try_normalize().unwrap_or(Vec2::X)`, as glam computes it.
        let (x, y) = (sx[k], sy[k]);
        let rcp = 1.0 / (x * x + y * y).sqrt();
        let unit = positive_finite(rcp);
        let (ux, uy) = if unit { (x * rcp, y * rcp) } else { (1.0, 0.0) };
        let (hx, hy) = (ux * cos - uy * sin, ux * sin + uy * cos);
        tx[k] = 0.0 + hx * ms[k] * weight;
        ty[k] = 0.0 + hy * ms[k] * weight;
    }
    adapter.finish_run((tx, ty), (ox, oy));
}

/// One flocking term, weighted by `w`, added to `(tx, ty)` for every agent of a run, from its
/// sums `(x, y)` (divided by `n` when `MEAN`): the desired velocity of full speed along them
/// (kinematic), or the force towards it (dynamic), exactly as [`crate::steering::desired`],
/// `separation`, `alignment` and `cohesion` compute them.
#[inline(always)]
fn term_run<const KINEMATIC: bool, const MEAN: bool>(
    (x, y): (&[f32], &[f32]),
    n: &[f32],
    (vx, vy): (&[f32], &[f32]),
    max_speed: &[f32],
    w: f32,
    (tx, ty): (&mut [f32], &mut [f32]),
) {
    let len = tx.len();
    let (x, y, n, vx, vy, ms, ty) = (
        &x[..len],
        &y[..len],
        &n[..len],
        &vx[..len],
        &vy[..len],
        &max_speed[..len],
        &mut ty[..len],
    );
    for k in 0..len {
        let (dx, dy) = if MEAN {
            (x[k] / n[k], y[k] / n[k])
        } else {
            (x[k], y[k])
        };
        // `normalize_or_zero(d) * max_speed`, as glam computes it.
        let rcp = 1.0 / (dx * dx + dy * dy).sqrt();
        let unit = positive_finite(rcp);
        let ux = if unit { dx * rcp } else { 0.0 };
        let uy = if unit { dy * rcp } else { 0.0 };
        let (desired_x, desired_y) = (ux * ms[k], uy * ms[k]);
        let (ax, ay) = if KINEMATIC {
            (desired_x, desired_y)
        } else {
            let zero = (dx == 0.0) & (dy == 0.0);
            (
                if zero { 0.0 } else { desired_x - vx[k] },
                if zero { 0.0 } else { desired_y - vy[k] },
            )
        };
        let present = !MEAN || n[k] != 0.0;
        let (fx, fy) = if present { (ax, ay) } else { (0.0, 0.0) };
        tx[k] += fx * w;
        ty[k] += fy * w;
    }
}

/// What a task's gathers read: the grid and the copies in its order, the world's bounds, and
/// whether the kernels read the groups and the unit headings.
#[derive(Clone, Copy)]
struct Gather<'a> {
    grid: &'a GridIndex,
    s: &'a SortedCopies,
    bounds: Bounds,
    groups: bool,
    headings: bool,
}

impl Gather<'_> {
    /// Gathers the 3 x 3 block of cells around `cell` into `buf`, shifted across torus seams,
    /// and pads it to whole blocks of lanes with far-away points. The groups are gathered only
    /// when some kernel tells groups apart (`groups`), the unit headings only for Vicsek sums
    /// (`headings`); otherwise `buf.g` (or `buf.hx` and `buf.hy`) keep stale values nobody
    /// reads.
    ///
    /// A cell away from the grid's edges (nearly all of them) takes a path of its own: its
    /// three rows are one run each, unshifted, so their bounds are six loads of the cells'
    /// starts, and the buffer's room is checked once. Its values are the general path's, bit
    /// for bit (`+ 0.0` included); [`Gather::edge_cell`] serves the edges.
    #[inline(always)]
    fn cell(&self, cell: usize, buf: &mut CellBuf) {
        let (grid, s) = (self.grid, self.s);
        let (groups, headings) = (self.groups, self.headings);
        let (nx, ny) = (grid.cells_x() as usize, grid.cells_y() as usize);
        let (cx, cy) = (cell % nx, cell / nx);
        if cx > 0 && cx + 1 < nx && cy > 0 && cy + 1 < ny {
            let starts = grid.cell_start();
            let run = |c: usize| (starts[c - 1] as usize, starts[c + 2] as usize);
            let runs = [run(cell - nx), run(cell), run(cell + nx)];
            let total: usize = runs.iter().map(|&(a, b)| b - a).sum();
            buf.reserve(total + KLANES);
            let mut len = 0;
            for (a, b) in runs {
                append_motion(buf, len, (grid.sorted_padded(), s), a, b, (0.0, 0.0));
                append_columns(buf, len, s, (a, b), (groups, headings));
                len += b - a;
            }
            buf.len = len;
            pad(buf, groups, headings);
            return;
        }
        self.edge_cell(cell, buf);
    }

    /// [`Gather::cell`] for any cell, at the grid's edges too: a row across a torus seam is two
    /// runs, one of them shifted; outside a walled world a row or column is left out.
    fn edge_cell(&self, cell: usize, buf: &mut CellBuf) {
        let (grid, s, bounds) = (self.grid, self.s, self.bounds);
        let (groups, headings) = (self.groups, self.headings);
        buf.len = 0;
        let (nx, ny) = (grid.cells_x() as i64, grid.cells_y() as i64);
        let (cx, cy) = (cell as i64 % nx, cell as i64 / nx);
        let side = match bounds {
            Bounds::Torus { size } => Some(size),
            _ => None,
        };
        let starts = grid.cell_start();
        for dy in -1..=1 {
            let Some((row, shift_y)) = axis(cy + dy, ny, side.map(|s| s.y)) else {
                continue;
            };
            // The row's columns cx - 1 ..= cx + 1 as contiguous runs of cells: one run, or on a
            // torus at a seam the far column (shifted) apart from the others.
            let mut runs = [(0i64, 0i64, 0.0f32); 2];
            let nr = match side.map(|s| s.x) {
                Some(w) if cx == 0 => {
                    runs[0] = (nx - 1, nx - 1, -w);
                    runs[1] = (0, 1, 0.0);
                    2
                }
                Some(w) if cx == nx - 1 => {
                    runs[0] = (cx - 1, cx, 0.0);
                    runs[1] = (0, 0, w);
                    2
                }
                _ => {
                    runs[0] = ((cx - 1).max(0), (cx + 1).min(nx - 1), 0.0);
                    1
                }
            };
            let runs = runs.map(|(c0, c1, shift)| {
                (
                    starts[(row * nx + c0) as usize] as usize,
                    starts[(row * nx + c1) as usize + 1] as usize,
                    shift,
                )
            });
            for &(a, b, shift_x) in &runs[..nr] {
                let len = buf.len;
                buf.reserve(len + (b - a) + KLANES);
                append_motion(
                    buf,
                    len,
                    (grid.sorted_padded(), s),
                    a,
                    b,
                    (shift_x, shift_y),
                );
                append_columns(buf, len, s, (a, b), (groups, headings));
                buf.len += b - a;
            }
        }
        pad(buf, groups, headings);
    }
}

impl CellBuf {
    /// Makes every column at least `need` values long.
    #[inline(always)]
    fn reserve(&mut self, need: usize) {
        if self.x.len() < need {
            for v in [
                &mut self.x,
                &mut self.y,
                &mut self.vx,
                &mut self.vy,
                &mut self.g,
                &mut self.hx,
                &mut self.hy,
            ] {
                // Room for dense cells from the start, so that a flock clumping after warm-up
                // rarely grows the buffers again.
                v.resize(need.max(MIN_CELL_BUF), 0.0);
            }
        }
    }
}

/// The groups (with `groups`) and the unit headings (with `headings`) of `s[a..b]` into the
/// buffer at `len`, as [`append`] writes them.
#[inline(always)]
fn append_columns(
    buf: &mut CellBuf,
    len: usize,
    s: &SortedCopies,
    (a, b): (usize, usize),
    (groups, headings): (bool, bool),
) {
    if groups {
        append(&mut buf.g, len, &s.g, a, b);
    }
    if headings {
        append(&mut buf.hx, len, &s.hx, a, b);
        append(&mut buf.hy, len, &s.hy, a, b);
    }
}

/// Pads the gathered `buf.len` values to whole blocks with far-away points that no mask admits:
/// one whole block written past the last run (the gather made room for it), of which the used
/// part is kept. The groups and headings are padded where they were gathered.
#[inline(always)]
fn pad(buf: &mut CellBuf, groups: bool, headings: bool) {
    let len = buf.len;
    let pad = |v: &mut Vec<f32>, value: f32| v[len..len + KLANES].copy_from_slice(&[value; KLANES]);
    pad(&mut buf.x, FAR);
    pad(&mut buf.y, FAR);
    pad(&mut buf.vx, 0.0);
    pad(&mut buf.vy, 0.0);
    if groups {
        pad(&mut buf.g, -1.0);
    }
    if headings {
        pad(&mut buf.hx, 0.0);
        pad(&mut buf.hy, 0.0);
    }
    buf.len = len.div_ceil(KLANES) * KLANES;
}

/// Writes `src[a..b]` at `dst[len..]` in whole blocks of lanes: up to `LANES - 1` values past
/// `b` are read (the grid's positions and the sorted copies are padded for it) and written past
/// the run (the next run or the padding overwrites them). The slices are cut once, so the block
/// loop carries no bounds checks.
#[inline(always)]
fn append(dst: &mut [f32], len: usize, src: &[f32], a: usize, b: usize) {
    let blocks = (b - a).div_ceil(LANES) * LANES;
    let (from, _) = src[a..a + blocks].as_chunks::<LANES>();
    let (to, _) = dst[len..len + blocks].as_chunks_mut::<LANES>();
    for (t, f) in to.iter_mut().zip(from) {
        *t = *f;
    }
}

/// [`append`] of the positions (plus `shift`) and velocities of `s[a..b]` into the buffer at
/// `len`, the four in one loop over blocks.
#[inline(always)]
fn append_motion(
    buf: &mut CellBuf,
    len: usize,
    ((sx, sy), s): ((&[f32], &[f32]), &SortedCopies),
    a: usize,
    b: usize,
    (shift_x, shift_y): (f32, f32),
) {
    fn src(v: &[f32], a: usize, blocks: usize) -> &[[f32; LANES]] {
        v[a..a + blocks].as_chunks::<LANES>().0
    }
    fn dst(v: &mut [f32], len: usize, blocks: usize) -> &mut [[f32; LANES]] {
        v[len..len + blocks].as_chunks_mut::<LANES>().0
    }
    let blocks = (b - a).div_ceil(LANES) * LANES;
    let (x, y) = (src(sx, a, blocks), src(sy, a, blocks));
    let (vx, vy) = (src(&s.vx, a, blocks), src(&s.vy, a, blocks));
    let n = x.len();
    let (x, y, vx, vy) = (&x[..n], &y[..n], &vx[..n], &vy[..n]);
    let (tx, ty, tvx, tvy) = (
        dst(&mut buf.x, len, blocks),
        dst(&mut buf.y, len, blocks),
        dst(&mut buf.vx, len, blocks),
        dst(&mut buf.vy, len, blocks),
    );
    let (tx, ty, tvx, tvy) = (&mut tx[..n], &mut ty[..n], &mut tvx[..n], &mut tvy[..n]);
    for k in 0..n {
        tx[k] = x[k].map(|v| v + shift_x);
        ty[k] = y[k].map(|v| v + shift_y);
        tvx[k] = vx[k];
        tvy[k] = vy[k];
    }
}

/// Cell coordinate `c` of an axis of `n` cells: its index and the shift that brings its points
/// next to the centre cell (`None` outside a world that does not wrap).
#[inline]
fn axis(c: i64, n: i64, side: Option<f32>) -> Option<(i64, f32)> {
    match side {
        Some(side) if c < 0 => Some((c + n, -side)),
        Some(side) if c >= n => Some((c - n, side)),
        _ if (0..n).contains(&c) => Some((c, 0.0)),
        _ => None,
    }
}

/// The lane kernel's view of the query: plain numbers.
#[derive(Clone, Copy, Debug)]
struct Query {
    x: f32,
    y: f32,
    hx: f32,
    hy: f32,
    g: f32,
    q_sq: f32,
    /// Squared radius per slot (-1 when the slot is off).
    r_sq: [f32; 3],
    /// Squared view cosine per slot.
    c2: [f32; 3],
    /// Per slot: 0 all round, 1 a cone wider than a half plane (cos < 0), 2 narrower.
    cone: [u8; 3],
    /// Per slot: any group counts.
    any_group: [bool; 3],
    /// The Vicsek neighbourhood's squared radius (`VICSEK` mode).
    vicsek_r_sq: f32,
    /// The kernel body that serves this shape.
    mode: u8,
}

/// The kernel mode of the Vicsek sum.
const VICSEK: u8 = 32;

impl Query {
    /// The query of agent `a`: this template with the agent's own numbers.
    #[inline(always)]
    fn at(&self, a: &Agent) -> Query {
        Query {
            x: a.x,
            y: a.y,
            hx: a.hx,
            hy: a.hy,
            g: a.g,
            ..*self
        }
    }

    /// Whether some slot in use has a view cone (the kernel reads the agent's unit heading).
    fn needs_headings(&self) -> bool {
        (0..3).any(|b| self.r_sq[b] >= 0.0 && self.cone[b] != 0)
    }

    /// Whether some slot counts only the agent's own group (the kernel reads groups).
    fn needs_groups(&self) -> bool {
        !self.any_group.iter().all(|&a| a)
    }

    /// The query template of a neighbour spec (the agent's own numbers are filled in later).
    fn of(spec: &NeighbourSpec, one_group: bool) -> Query {
        let cone = spec.cos.map(|c| {
            if c <= -1.0 {
                0
            } else if c < 0.0 {
                1
            } else {
                2
            }
        });
        let r_sq = [0, 1, 2].map(|b| if spec.on[b] { spec.r_sq[b] } else { -1.0 });
        let c2 = spec.cos.map(|c| c * c);
        let any_group = spec.same.map(|s| !s || one_group);
        let groups = !any_group.iter().all(|&a| a);
        // The common shape (a flock): separation all round, alignment and cohesion sharing one
        // neighbourhood. Everything else takes the general body.
        let shared = cone[SEP] == 0
            && r_sq[ALI] == r_sq[COH]
            && cone[ALI] == cone[COH]
            && c2[ALI] == c2[COH]
            && any_group[ALI] == any_group[COH];
        let q_sq = spec.query_r * spec.query_r;
        let mode = if spec.vicsek_r_sq.is_some() {
            VICSEK
        } else if shared {
            cone[ALI] | (u8::from(groups) << 2) | (u8::from(q_sq == r_sq[ALI]) << 4)
        } else {
            8 | u8::from(groups)
        };
        Query {
            x: 0.0,
            y: 0.0,
            hx: 0.0,
            hy: 0.0,
            g: 0.0,
            q_sq,
            r_sq,
            c2,
            cone,
            any_group,
            vicsek_r_sq: spec.vicsek_r_sq.unwrap_or(-1.0),
            mode,
        }
    }
}

/// The sums of every agent of `agents` over one cell buffer, written into `runs` at `slots`.
///
/// Where the processor has AVX-512, the flock's shape runs two agents at a time, one per half of
/// a 16-lane vector ([`avx512::pairs`]); each half gives the bits of the 8-lane kernel, so the
/// sums are the same on every dispatch target. The AVX-512 target string names AVX-512 F, VL, BW
/// and DQ, but multiversion 0.9 adds the Ice Lake extensions to every AVX-512 target (BITALG,
/// IFMA, VBMI, VBMI2, VNNI, VPOPCNTDQ, GFNI, VAES, VPCLMULQDQ; unless the build sets `--cfg
/// multiversion_allow_slow_avx512`): the clone runs on Ice Lake and the later Intel parts with
/// AVX-512, and on Zen 4, whose 512-bit units do not slow the clock much; Skylake-SP and Cascade
/// Lake take the AVX2 clone.
#[multiversion(targets(
    "x86_64+avx2+fma+avx512f+avx512vl+avx512bw+avx512dq",
    "x86_64+avx2+fma",
    "x86_64+avx"
))]
fn kernel_cell(buf: &CellBuf, q: &Query, agents: &AgentCols, slots: Slots, runs: &mut Runs) {
    // Also true in every version when the build itself targets a CPU with AVX-512 (`-C
    // target-cpu=native` on such a machine): the binary then runs only where it is present.
    #[target_cfg(all(
        target_arch = "x86_64",
        target_feature = "avx512f",
        target_feature = "avx512dq",
        target_feature = "avx512vl",
        target_feature = "avx2",
        target_feature = "fma"
    ))]
    #[expect(
        unsafe_code,
        reason = "a call to a `#[target_feature]` function from a function that does not list \
                  the features; it has them, from its target or from the build's (without the \
                  block, a build with `-C target-cpu=native` on an AVX-512 machine fails)"
    )]
    fn pairs(buf: &CellBuf, q: &Query, agents: &AgentCols, slots: Slots, runs: &mut Runs) -> usize {
        // SAFETY: this function is compiled only where AVX-512F, DQ and VL, AVX2 and FMA are
        // enabled (in the version for multiversion's AVX-512 target, chosen at run time only
        // where the processor has them, or in every version of a build whose own target has
        // them): the features `avx512::pairs` needs.
        unsafe { avx512::pairs(buf, q, agents, slots, runs) }
    }
    #[target_cfg(not(all(
        target_arch = "x86_64",
        target_feature = "avx512f",
        target_feature = "avx512dq",
        target_feature = "avx512vl",
        target_feature = "avx2",
        target_feature = "fma"
    )))]
    fn pairs(_: &CellBuf, _: &Query, _: &AgentCols, _: Slots, _: &mut Runs) -> usize {
        0
    }
    let paired = pairs(buf, q, agents, slots, runs);
    // The body is chosen once per call, then runs for every agent: each arm its own loop, with
    // the body called directly, so that it is inlined and compiled for this target (called
    // through a pointer, a body is the baseline build).
    macro_rules! each {
        ($body:expr) => {
            for k in paired..agents.len() {
                runs.set(slots.at(k), &$body(buf, &q.at(&agents.at(k))));
            }
        };
    }
    match q.mode {
        0 => each!(shared::<0, false, false>),
        1 => each!(shared::<1, false, false>),
        2 => each!(shared::<2, false, false>),
        4 => each!(shared::<0, true, false>),
        5 => each!(shared::<1, true, false>),
        6 => each!(shared::<2, true, false>),
        16 => each!(shared::<0, false, true>),
        17 => each!(shared::<1, false, true>),
        18 => each!(shared::<2, false, true>),
        20 => each!(shared::<0, true, true>),
        21 => each!(shared::<1, true, true>),
        22 => each!(shared::<2, true, true>),
        8 => each!(general::<false>),
        VICSEK => each!(vicsek),
        _ => each!(general::<true>),
    }
}

/// 1.0 when `b`, else 0.0: masks as floats, "and" as a product.
#[inline(always)]
fn one_if(b: bool) -> f32 {
    if b { 1.0 } else { 0.0 }
}

/// `x` when `m`, else `+0`, as a bitwise and with the mask (one vector instruction: a branch or
/// a select here can compile to masked stores of the accumulators).
#[inline(always)]
fn keep(m: bool, x: f32) -> f32 {
    f32::from_bits(x.to_bits() & 0u32.wrapping_sub(u32::from(m)))
}

/// Whether the view cone of kind `CONE` (0 all round, 1 wider than a half plane, 2 narrower)
/// admits an offset with `dot = h . d`, squared length `d2`, squared cosine `c2`.
#[inline(always)]
fn in_cone<const CONE: u8>(c2: f32, dot: f32, d2: f32) -> bool {
    match CONE {
        0 => true,
        1 => (dot >= 0.0) | (dot * dot <= c2 * d2),
        _ => (dot >= 0.0) & (dot * dot >= c2 * d2),
    }
}

/// The sum of the lanes of `a`, as a tree (halves, then quarters, then the pair).
#[inline(always)]
fn tree_sum(a: &[f32; KLANES]) -> f32 {
    let h: [f32; 4] = std::array::from_fn(|i| a[i] + a[i + 4]);
    let q: [f32; 2] = std::array::from_fn(|i| h[i] + h[i + 2]);
    q[0] + q[1]
}

/// The flock's shape: separation all round; alignment and cohesion share radius, cone and
/// group rule, so they share one mask and one count (and, when `Q_AC`, the query radius is
/// theirs, so the neighbour count shares their radius test). Masks are booleans and terms are
/// kept by them ([`keep`], one vector instruction each). Adding a selected
/// `+0` leaves an accumulator as it is, and so does subtracting `dx * 0 = ±0` from separation:
/// the accumulators start at `+0` and so are never `-0`. The sums are the masked products of the
/// scalar reference, bit for bit.
#[inline(always)]
fn shared<const CONE: u8, const GROUPS: bool, const Q_AC: bool>(
    buf: &CellBuf,
    q: &Query,
) -> Reduced {
    shared_over::<CONE, GROUPS, Q_AC>(buf, q, (&buf.vx, &buf.vy))
}

/// [`shared`] with `motion` summed as alignment's values in the velocities' place.
#[inline(always)]
fn shared_over<const CONE: u8, const GROUPS: bool, const Q_AC: bool>(
    buf: &CellBuf,
    q: &Query,
    motion: (&[f32], &[f32]),
) -> Reduced {
    let z = [0.0_f32; KLANES];
    let (mut sx, mut sy, mut ax, mut ay, mut an, mut cx, mut cy, mut n) = (z, z, z, z, z, z, z, z);
    let (r_sep, r_ac, c2) = (q.r_sq[SEP], q.r_sq[ALI], q.c2[ALI]);
    let (sep_any, ac_any) = (q.any_group[SEP], q.any_group[ALI]);
    for (xs, ys, vxs, vys, gs) in buf.blocks_of(motion) {
        for l in 0..KLANES {
            let dx = xs[l] - q.x;
            let dy = ys[l] - q.y;
            let d2 = dx * dx + dy * dy;
            let (g_sep, g_ac) = if GROUPS {
                let same = gs[l] == q.g;
                (sep_any | same, ac_any | same)
            } else {
                (true, true)
            };
            let ms = (d2 <= r_sep) & (d2 > 0.0) & g_sep;
            let inv = 1.0 / d2.max(f32::MIN_POSITIVE);
            let inv = keep(ms, inv);
            sx[l] -= dx * inv;
            sy[l] -= dy * inv;
            let dot = q.hx * dx + q.hy * dy;
            let in_r = d2 <= r_ac;
            let view = match CONE {
                0 => true,
                1 => (dot >= 0.0) | (dot * dot <= c2 * d2),
                _ => (dot >= 0.0) & (dot * dot >= c2 * d2),
            };
            let ma = in_r & view & g_ac;
            ax[l] += keep(ma, vxs[l]);
            ay[l] += keep(ma, vys[l]);
            an[l] += keep(ma, 1.0);
            cx[l] += keep(ma, dx);
            cy[l] += keep(ma, dy);
            n[l] += keep(if Q_AC { in_r } else { d2 <= q.q_sq }, 1.0);
        }
    }
    Acc {
        sx,
        sy,
        ax,
        ay,
        an,
        cx,
        cy,
        cn: z,
        n,
    }
    .reduced(true)
}

/// The Vicsek sum: the unit headings of every agent within the radius, the agent itself included
/// (in alignment's place), and their number (in the last). The flock's kernel with the headings in
/// the velocities' place, alignment's radius the Vicsek radius, all round, any group, and
/// separation off: its alignment sum and count are the masked sums of the headings and of ones over
/// the neighbourhood in eight lanes (a kernel of its own, with three accumulators, came out of the
/// compiler as pairs of lanes and took twice the instructions).
#[inline(always)]
fn vicsek(buf: &CellBuf, q: &Query) -> Reduced {
    let r = q.vicsek_r_sq;
    let flock = Query {
        r_sq: [-1.0, r, r],
        q_sq: r,
        c2: [1.0; 3],
        cone: [0; 3],
        any_group: [true; 3],
        ..*q
    };
    shared_over::<0, false, true>(buf, &flock, (&buf.hx, &buf.hy))
}

/// Any shape: a mask per slot, view cones by their kind per slot.
#[inline(always)]
fn general<const GROUPS: bool>(buf: &CellBuf, q: &Query) -> Reduced {
    let z = [0.0_f32; KLANES];
    let (mut sx, mut sy, mut ax, mut ay, mut an, mut cx, mut cy, mut cn, mut n) =
        (z, z, z, z, z, z, z, z, z);
    for (xs, ys, vxs, vys, gs) in buf.blocks() {
        for l in 0..KLANES {
            let dx = xs[l] - q.x;
            let dy = ys[l] - q.y;
            let d2 = dx * dx + dy * dy;
            let same = if GROUPS { one_if(gs[l] == q.g) } else { 1.0 };
            let dot = q.hx * dx + q.hy * dy;
            let sees = |b: usize| {
                let group = if !GROUPS || q.any_group[b] { 1.0 } else { same };
                let view = match q.cone[b] {
                    0 => 1.0,
                    1 => one_if(in_cone::<1>(q.c2[b], dot, d2)),
                    _ => one_if(in_cone::<2>(q.c2[b], dot, d2)),
                };
                one_if(d2 <= q.r_sq[b]) * group * view
            };
            let ms = sees(SEP) * one_if(d2 > 0.0);
            let ma = sees(ALI);
            let mc = sees(COH);
            let inv = 1.0 / d2.max(f32::MIN_POSITIVE);
            sx[l] -= ms * (dx * inv);
            sy[l] -= ms * (dy * inv);
            ax[l] += ma * vxs[l];
            ay[l] += ma * vys[l];
            an[l] += ma;
            cx[l] += mc * dx;
            cy[l] += mc * dy;
            cn[l] += mc;
            n[l] += one_if(d2 <= q.q_sq);
        }
    }
    Acc {
        sx,
        sy,
        ax,
        ay,
        an,
        cx,
        cy,
        cn,
        n,
    }
    .reduced(false)
}

#[cfg(test)]
mod tests {
    use rand::{RngExt, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    use super::*;

    /// The bits of every sum.
    fn bits(s: &NeighbourSums) -> [u32; 9] {
        reduced_of(s).map(f32::to_bits)
    }

    /// The sums of `agents` through the dispatched kernel, read back from the runs; with
    /// `listed`, written at slots given as a list (in reverse order) rather than from slot 0;
    /// without `headings`, the agents' columns hold none (as with no view cone in a frame).
    fn kernel_sums(
        buf: &CellBuf,
        q: &Query,
        agents: &[Agent],
        (listed, headings): (bool, bool),
    ) -> Vec<Reduced> {
        let col = |f: fn(&Agent) -> f32| agents.iter().map(f).collect::<Vec<f32>>();
        let (x, y, hx, hy, g) = (
            col(|a| a.x),
            col(|a| a.y),
            col(|a| a.hx),
            col(|a| a.hy),
            col(|a| a.g),
        );
        let cols = AgentCols {
            x: &x,
            y: &y,
            h: headings.then_some((&hx[..], &hy[..])),
            g: &g,
        };
        let n = agents.len();
        let list: Vec<usize> = (0..n).rev().collect();
        let slots = Slots {
            start: 0,
            list: listed.then_some(&list[..]),
        };
        let mut runs = Runs::default();
        kernel_cell(buf, q, &cols, slots, &mut runs);
        (0..n)
            .map(|k| {
                let j = slots.at(k);
                let c = |v: &Column| v[j];
                [
                    c(&runs.sep[0]),
                    c(&runs.sep[1]),
                    c(&runs.ali[0]),
                    c(&runs.ali[1]),
                    c(&runs.ali_n),
                    c(&runs.coh[0]),
                    c(&runs.coh[1]),
                    c(&runs.coh_n),
                    c(&runs.count),
                ]
            })
            .collect()
    }

    /// The reduced form of `s`, as the kernel writes it.
    fn reduced_of(s: &NeighbourSums) -> Reduced {
        [
            s.separation.x,
            s.separation.y,
            s.alignment.x,
            s.alignment.y,
            s.alignment_count,
            s.cohesion.x,
            s.cohesion.y,
            s.cohesion_count,
            s.count,
        ]
    }

    /// A gathered buffer of `m` random candidates (some exactly on the agents, some on the radii)
    /// padded as `gather` pads it.
    fn buffer(rng: &mut ChaCha8Rng, m: usize, agents: &[Agent]) -> CellBuf {
        let padded = m.div_ceil(KLANES) * KLANES;
        let mut b = CellBuf {
            len: padded,
            ..CellBuf::default()
        };
        for k in 0..padded {
            let (x, y, g) = if k >= m {
                (FAR, FAR, -1.0)
            } else if k % 7 == 0 {
                let a = agents[k % agents.len()];
                (a.x, a.y, a.g)
            } else if k % 11 == 0 {
                let a = agents[k % agents.len()];
                (a.x + 2.0, a.y, a.g)
            } else {
                (
                    rng.random_range(-6.0..6.0),
                    rng.random_range(-6.0..6.0),
                    f32::from(rng.random_range(0u8..2)),
                )
            };
            let live = k < m;
            b.x.push(x);
            b.y.push(y);
            b.vx.push(if live {
                rng.random_range(-4.0..4.0)
            } else {
                0.0
            });
            b.vy.push(if live {
                rng.random_range(-4.0..4.0)
            } else {
                0.0
            });
            b.g.push(g);
        }
        b
    }

    /// The Vicsek sums as eight lanes of plain scalar additions, each lane's in buffer order,
    /// the lanes then summed as the kernels sum them.
    fn vicsek_lanes(buf: &CellBuf, a: &Agent, r_sq: f32) -> NeighbourSums {
        let (mut hx, mut hy, mut n) = ([0.0f32; KLANES], [0.0f32; KLANES], [0.0f32; KLANES]);
        for k in 0..buf.len {
            let (dx, dy) = (buf.x[k] - a.x, buf.y[k] - a.y);
            if dx * dx + dy * dy <= r_sq {
                hx[k % KLANES] += buf.hx[k];
                hy[k % KLANES] += buf.hy[k];
                n[k % KLANES] += 1.0;
            }
        }
        NeighbourSums {
            heading: Vec2::new(tree_sum(&hx), tree_sum(&hy)),
            count: tree_sum(&n),
            ..NeighbourSums::default()
        }
    }

    #[test]
    fn vicsek_sums_through_the_flock_kernel_equal_the_scalar_lanes_bit_for_bit() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let mut seen = 0;
        for case in 0..300 {
            let agents: Vec<Agent> = (0..3)
                .map(|_| Agent {
                    x: rng.random_range(-2.0..2.0),
                    y: rng.random_range(-2.0..2.0),
                    ..Agent::default()
                })
                .collect();
            let m = rng.random_range(1..60);
            let mut buf = buffer(&mut rng, m, &agents);
            // Unit headings; the velocities differ, and no sum may read them.
            let n = buf.x.len();
            (buf.hx, buf.hy) = (vec![0.0; n], vec![0.0; n]);
            for k in 0..n.min(m) {
                let angle: f32 = rng.random_range(0.0..std::f32::consts::TAU);
                (buf.hx[k], buf.hy[k]) = (angle.cos(), angle.sin());
            }
            let r_sq: f32 = [1.0, 4.0, 9.0][case % 3];
            let mut q = Query::of(&NeighbourSpec::default(), true);
            (q.vicsek_r_sq, q.mode) = (r_sq, VICSEK);
            let out = kernel_sums(&buf, &q, &agents, (case % 2 == 0, false));
            for (a, got) in agents.iter().zip(&out) {
                let want = vicsek_lanes(&buf, a, r_sq);
                // The summed headings in alignment's place, the count in the last.
                let got = [got[2], got[3], got[8]].map(f32::to_bits);
                let want_bits = [want.heading.x, want.heading.y, want.count].map(f32::to_bits);
                assert_eq!(got, want_bits, "case {case}: {got:?} vs {want:?}");
                seen += usize::from(want.count > 1.0);
            }
        }
        assert!(seen > 100, "{seen}");
    }

    /// Neighbour sums with every field [`Runs`] holds random (counts whole, as the kernel counts),
    /// the others zero.
    fn random_sums(rng: &mut ChaCha8Rng) -> NeighbourSums {
        let mut v = || Vec2::new(rng.random_range(-50.0..50.0), rng.random_range(-50.0..50.0));
        let (separation, alignment, cohesion) = (v(), v(), v());
        NeighbourSums {
            separation,
            alignment,
            alignment_count: f32::from(rng.random_range(1u8..40)),
            cohesion,
            cohesion_count: f32::from(rng.random_range(1u8..40)),
            count: f32::from(rng.random_range(1u8..80)),
            ..NeighbourSums::default()
        }
    }

    #[test]
    fn without_self_over_a_run_equals_without_self_per_agent_bit_for_bit() {
        // Every pattern of the separation, alignment and cohesion flags; a run that starts inside
        // the columns and whose length is a multiple of no vector width, with slots on both
        // sides of it that must keep their sums.
        let mut rng = ChaCha8Rng::seed_from_u64(12);
        let range = 3..3 + 4 * LANES + 5;
        let slots = range.end + 4;
        for pattern in 0..8u8 {
            let on = [SEP, ALI, COH].map(|b| pattern & (1 << b) != 0);
            let spec = NeighbourSpec {
                on,
                ..NeighbourSpec::default()
            };
            let sums: Vec<NeighbourSums> = (0..slots).map(|_| random_sums(&mut rng)).collect();
            let mut runs = Runs::default();
            for (j, s) in sums.iter().enumerate() {
                runs.set(j, &reduced_of(s));
            }
            let vel: Vec<Vec2> = range
                .clone()
                .map(|_| Vec2::new(rng.random_range(-4.0..4.0), rng.random_range(-4.0..4.0)))
                .collect();
            let (vx, vy): (Vec<f32>, Vec<f32>) = vel.iter().map(|v| (v.x, v.y)).unzip();
            runs.without_self_run(range.clone(), (&vx, &vy), on);
            for (j, s) in sums.iter().enumerate() {
                let want = match j.checked_sub(range.start) {
                    Some(k) if range.contains(&j) => {
                        let got_vel = [runs.vel[0][j], runs.vel[1][j]].map(f32::to_bits);
                        assert_eq!(got_vel, [vel[k].x, vel[k].y].map(f32::to_bits), "slot {j}");
                        without_self(*s, vel[k], &spec)
                    }
                    _ => *s,
                };
                let got = runs.sums_at(j);
                assert_eq!(
                    bits(&got),
                    bits(&want),
                    "on {on:?}, slot {j}: {got:?} vs {want:?}"
                );
            }
        }
    }

    #[test]
    fn every_dispatch_target_gives_the_scalar_lanes_bits_for_every_flock_shape() {
        // `kernel_cell` runs the best target this processor has (on AVX-512, two agents per
        // vector); `shared` called here is the baseline build of the 8-lane kernel. Every shape
        // of the flock's query: cones of each kind, groups told apart or not, the count on its
        // own radius or on alignment's; odd and even numbers of agents.
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        // Agents with some separation, with some alignment neighbours.
        let mut seen = [0usize; 2];
        for case in 0..200 {
            let (cone, groups, q_ac) = ((case % 3) as u8, case % 6 >= 3, case % 12 >= 6);
            let cos: f32 = [-1.0, -0.5, 0.3][cone as usize];
            let r_ac = 25.0;
            let query = Query {
                x: 0.0,
                y: 0.0,
                hx: 0.0,
                hy: 0.0,
                g: 0.0,
                q_sq: if q_ac { r_ac } else { 16.0 },
                r_sq: [4.0, r_ac, r_ac],
                c2: [1.0, cos * cos, cos * cos],
                cone: [0, cone, cone],
                any_group: [!groups, !groups, !groups],
                vicsek_r_sq: -1.0,
                mode: cone | (u8::from(groups) << 2) | (u8::from(q_ac) << 4),
            };
            // Cells of more agents than a batch holds, as the one-group path passes whole cells.
            let n = rng.random_range(1..2 * CELL_BATCH);
            let mut agents: Vec<Agent> = (0..n)
                .map(|_| {
                    let angle: f32 = rng.random_range(0.0..std::f32::consts::TAU);
                    Agent {
                        x: rng.random_range(-2.0..2.0),
                        y: rng.random_range(-2.0..2.0),
                        hx: angle.cos(),
                        hy: angle.sin(),
                        g: f32::from(rng.random_range(0u8..2)),
                    }
                })
                .collect();
            if case % 5 == 0 {
                // Two agents on one spot.
                agents[n - 1] = agents[0];
            }
            let m = rng.random_range(1..120);
            let buf = buffer(&mut rng, m, &agents);
            // Without a cone no kernel reads the headings: they may be absent.
            let headings = cone != 0 || case % 4 == 0;
            let out = kernel_sums(&buf, &query, &agents, (case % 2 == 1, headings));
            for (a, got) in agents.iter().zip(&out) {
                let q = query.at(a);
                let want = match (cone, groups, q_ac) {
                    (0, false, false) => shared::<0, false, false>(&buf, &q),
                    (1, false, false) => shared::<1, false, false>(&buf, &q),
                    (2, false, false) => shared::<2, false, false>(&buf, &q),
                    (0, true, false) => shared::<0, true, false>(&buf, &q),
                    (1, true, false) => shared::<1, true, false>(&buf, &q),
                    (2, true, false) => shared::<2, true, false>(&buf, &q),
                    (0, false, true) => shared::<0, false, true>(&buf, &q),
                    (1, false, true) => shared::<1, false, true>(&buf, &q),
                    (2, false, true) => shared::<2, false, true>(&buf, &q),
                    (0, true, true) => shared::<0, true, true>(&buf, &q),
                    (1, true, true) => shared::<1, true, true>(&buf, &q),
                    _ => shared::<2, true, true>(&buf, &q),
                };
                let (got, want) = (flock_sums(got), flock_sums(&want));
                assert_eq!(bits(&got), bits(&want), "case {case}: {got:?} vs {want:?}");
                seen[0] += usize::from(want.separation != Vec2::ZERO);
                seen[1] += usize::from(want.alignment_count > 0.0);
            }
        }
        assert!(seen.iter().all(|&k| k > 500), "{seen:?}");
    }

    /// A cell away from the grid's edges gathers what the general path gathers for it, bit for
    /// bit, over the padded length: torus, walled and open worlds, tiny and large grids, empty
    /// and crowded cells, each combination of the optional columns, and points at `-0.0` (which
    /// both paths turn into `+0.0`). Every cell is gathered both ways into buffers that are
    /// reused, as a task reuses its own.
    #[test]
    fn the_interior_gather_equals_the_general_one() {
        use crate::spatial::NeighbourIndex;
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        let mut interior = 0;
        for case in 0..120 {
            let n = [0usize, 1, 3, 10, 50, 300, 2000, 20_000][case % 8];
            let (w, h) = (
                rng.random_range(0.5f32..60.0),
                rng.random_range(0.5f32..60.0),
            );
            let r = rng.random_range(0.2f32..8.0);
            let bounds = match case % 3 {
                0 => Bounds::Torus {
                    size: Vec2::new(w, h),
                },
                1 => Bounds::Bounded {
                    size: Vec2::new(w, h),
                },
                _ => Bounds::Open,
            };
            let mut at = |side: f32, k: usize| {
                if k % 97 == 5 {
                    -0.0
                } else {
                    rng.random_range(0.0..side)
                }
            };
            let xs: Vec<f32> = (0..n).map(|k| at(w, k)).collect();
            let ys: Vec<f32> = (0..n).map(|k| at(h, k + 11)).collect();
            let mut grid = GridIndex::default();
            grid.rebuild(&xs, &ys, bounds, r);
            let (nx, ny) = (grid.cells_x() as usize, grid.cells_y() as usize);
            if bounds.is_torus() && (nx < 3 || ny < 3) {
                // The batch does not serve such a torus (a cell would be its own neighbour).
                continue;
            }
            let mut column = |lo: f32, hi: f32| {
                let mut v: Vec<f32> = (0..n).map(|_| rng.random_range(lo..hi)).collect();
                v.extend([0.0; LANES]);
                v
            };
            let mut s = SortedCopies::default();
            s.vx = column(-2.0, 2.0);
            s.vy = column(-2.0, 2.0);
            s.g = column(0.0, 4.0).iter().map(|g| g.floor()).collect();
            s.hx = column(-1.0, 1.0);
            s.hy = column(-1.0, 1.0);
            let (mut a, mut b) = (CellBuf::default(), CellBuf::default());
            for (groups, headings) in [(false, false), (true, false), (false, true), (true, true)] {
                let gathers = Gather {
                    grid: &grid,
                    s: &s,
                    bounds,
                    groups,
                    headings,
                };
                for cell in 0..nx * ny {
                    gathers.cell(cell, &mut a);
                    gathers.edge_cell(cell, &mut b);
                    let m = b.len;
                    assert_eq!(a.len, m, "case {case}, cell {cell} of {nx} x {ny}");
                    let bits = |v: &[f32]| v[..m].iter().map(|x| x.to_bits()).collect::<Vec<_>>();
                    let mut columns =
                        vec![(&a.x, &b.x), (&a.y, &b.y), (&a.vx, &b.vx), (&a.vy, &b.vy)];
                    if groups {
                        columns.push((&a.g, &b.g));
                    }
                    if headings {
                        columns.extend([(&a.hx, &b.hx), (&a.hy, &b.hy)]);
                    }
                    for (k, (got, want)) in columns.into_iter().enumerate() {
                        assert_eq!(
                            bits(got),
                            bits(want),
                            "case {case}, cell {cell}, column {k}"
                        );
                    }
                    let (cx, cy) = (cell % nx, cell / nx);
                    interior += usize::from(cx > 0 && cx + 1 < nx && cy > 0 && cy + 1 < ny);
                }
            }
        }
        // The fast path ran (on many cells), not only the general one.
        assert!(interior > 10_000, "{interior} interior cells");
    }
}
