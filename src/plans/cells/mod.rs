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
//! headings as alignment sums. For a general plan with flocking terms, or with repulsion alone (a
//! "summed" group), the batch stores the sums alone, which the per-agent evaluation then reads
//! instead of querying the neighbourhood; the repulsion kernel sums `strength / d^n` for whole
//! exponents `n` from 0 to 4 in the buffer's order.
//!
//! Invariants: an agent's sums depend only on its cell's buffer, whose order is fixed by the
//! grid (cell by cell, and by index within a cell), so the result is the same for any number of
//! threads and for the sequential pass; the sums equal the scalar reference traversal to
//! rounding (`tests/flocking.rs` checks it against brute force).
//!
//! The batch in files: [`gather`] fills a cell's buffer, [`kernels`] sums every agent of the cell
//! over it, [`runs`] keeps a task's sums until its cells are done, [`terms`] turns them into
//! requests, and [`task`] drives one parallel task through its cells; this file decides which
//! groups the batch serves, runs the tasks, and holds their outputs for the pass.

use std::cell::RefCell;
use std::sync::atomic::{AtomicU32, AtomicU64, Ordering};

use rayon::prelude::*;

use super::neighbours::SortedCopies;
use super::out::OutChunks;
use super::plan::PlanKind;
use super::view::SteerView;
use crate::simd::{apply, float_kernel};
use crate::spatial::{GridIndex, SpatialIndex};
use crate::steering::NeighbourSums;

use gather::CellBuf;
use kernels::Query;
use runs::Runs;
use task::{TaskHeadings, chunk};

mod gather;
mod kernels;
mod runs;
mod task;
mod terms;

/// Agents (in grid order) per parallel task; each chunk is a task of its own
/// (`with_max_len(1)`), so that two threads running at different speeds (a core shared with
/// another process) share the tasks by speed rather than in rayon's default runs of several
/// chunks, which one thread then finishes alone. Small enough for that sharing, large enough
/// that a task's start-up stays small against its work; the measurement it was chosen by is in
/// docs/PERFORMANCE.md, "Tuning constants".
const CELL_CHUNK: usize = 1024;
/// Lanes of the neighbour kernel: two vectors per operation, for instruction-level parallelism
/// over the short candidate lists of a cell.
const KLANES: usize = 8;

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

thread_local! {
    static BUF: RefCell<(CellBuf, Runs, TaskHeadings)> =
        RefCell::new((CellBuf::default(), Runs::default(), TaskHeadings::default()));
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
/// separation, with sums the lane kernels serve (flocking sums, or repulsion alone:
/// [`NeighbourSpec::summed_ok`](super::spec::NeighbourSpec::summed_ok)).
fn summed(plan: &super::plan::Plan) -> bool {
    matches!(
        plan.kind,
        PlanKind::General
            | PlanKind::FollowLeader { .. }
            | PlanKind::FollowField { .. }
            | PlanKind::AntiGravitySeek { .. }
    ) && plan.spec.active
        && plan.spec.summed_ok()
}

/// Whether a plan is evaluated by the batch: flocking the lane kernel serves, or Vicsek.
fn batched(plan: &super::plan::Plan) -> bool {
    match plan.kind {
        PlanKind::Flock { .. } => plan.spec.kernel_ok(),
        PlanKind::Vicsek { .. } => plan.spec.batch_ok(),
        _ => false,
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
        let sums = &self.sums[ranks(view.index)[i].load(Ordering::Relaxed) as usize];
        #[cfg(feature = "oracle")]
        {
            let a = view.agents;
            let spec = &view.plans[a.group[i] as usize].spec;
            crate::oracle::record_sums(spec.summed("summed", (a.ids[i].0, a.position(i)), *sums));
        }
        sums
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
#[apply(float_kernel!)]
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
