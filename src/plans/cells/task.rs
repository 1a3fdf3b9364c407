//! One parallel task of the batch: its grid positions cut at cell boundaries, each cell's
//! neighbourhood gathered once and its agents summed over it (straight from the grid's columns
//! when they are of one batched group, otherwise in batches of one group), the sums filed, and
//! once every cell is done, each run of one group's agents turned into requests.
//!
//! Invariant: a task writes only its own grid positions' outputs, and what it computes for an
//! agent depends on the agent's cell alone, never on the task's other cells or its size.

use glam::Vec2;

use super::CELL_CHUNK;
use super::gather::{CellBuf, Gather};
use super::kernels::{AgentCols, Query, Slots, VICSEK, kernel_cell};
use super::runs::Runs;
use super::terms::{evaluate_run, vicsek_run};
use crate::plans::neighbours::{SortedCopies, unit_headings_at, without_self};
use crate::plans::plan::PlanKind;
use crate::plans::spec::NeighbourSpec;
use crate::plans::view::SteerView;
use crate::simd::{apply, float_kernel};
use crate::spatial::GridIndex;
use crate::steering::NeighbourSums;

/// A task's unit headings, when the copies hold none (no Vicsek plan) and a view cone needs its
/// agents' own: computed for the task's grid positions alone, in cache, instead of a pass over
/// every agent that stores them.
#[derive(Debug, Default)]
pub(super) struct TaskHeadings {
    x: Vec<f32>,
    y: Vec<f32>,
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

/// Agents whose sums one kernel call computes in a batch (one cell, one group, when a task's
/// groups are mixed).
pub(super) const CELL_BATCH: usize = 32;

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
    /// pass (a repulsion query's sum, which the kernel leaves in separation's place, as
    /// repulsion).
    #[inline(always)]
    fn summed(&mut self, spec: &NeighbourSpec, j: usize) {
        let p = self.base + j;
        let velocity = Vec2::new(self.sorted.vx[p], self.sorted.vy[p]);
        let mut sums = self.runs.sums_at(j);
        if spec.repel.is_some() {
            (sums.repulsion, sums.separation) = (sums.separation, Vec2::ZERO);
        }
        self.sums[j] = without_self(sums, velocity, spec);
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
#[apply(float_kernel!)]
pub(super) fn chunk(
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
        #[cfg(feature = "oracle")]
        record(view, order, (xs, ys), base..end, out.runs);
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
    #[cfg(feature = "oracle")]
    record(view, order, (xs, ys), base..end, out.runs);
}

/// Records the sums every flocking and Vicsek agent of the task at grid positions `range` used
/// (the `oracle` feature): the flocking sums without the agent itself, as the terms read them;
/// the Vicsek headings and count with it.
#[cfg(feature = "oracle")]
fn record(
    view: &SteerView,
    order: &[u32],
    (xs, ys): (&[f32], &[f32]),
    range: std::ops::Range<usize>,
    runs: &Runs,
) {
    for p in range.clone() {
        let j = p - range.start;
        let mark = runs.mark[j];
        if mark == 0 {
            continue;
        }
        let plan = &view.plans[mark as usize - 1];
        let agent = (
            view.agents.ids[order[p] as usize].0,
            Vec2::new(xs[p], ys[p]),
        );
        let (model, sums) = match plan.kind {
            PlanKind::Vicsek { .. } => (
                "vicsek",
                NeighbourSums {
                    heading: Vec2::new(runs.ali[0][j], runs.ali[1][j]),
                    count: runs.count[j],
                    ..NeighbourSums::default()
                },
            ),
            _ => ("flocking", runs.sums_at(j)),
        };
        crate::oracle::record_sums(plan.spec.summed(model, agent, sums));
    }
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
