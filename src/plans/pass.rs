//! The steering pass: every agent's request for this frame, written into SoA outputs.
//!
//! [`run`] evaluates each agent by its group's [`Plan`]: flocking-only plans in cell batches
//! through the grid kernel when the uniform grid is ready ([`super::cells`]); a lone seek,
//! arrive or wander, leader following and field following, a block of agents at a time in
//! lanes; everything else per agent ([`super::agent`]: the flocking, path and formation plans without
//! dispatch, the general plan over the profile's behaviours and their combination, over
//! neighbour sums the cell batch computed for it when the plan has flocking terms the batch
//! serves).
//!
//! Invariants: the pass reads only frame-t state and writes only the outputs of the agent it
//! evaluates, so results are independent of the thread count; the sequential pass runs the same
//! code on one thread and gives the same bits.

use rayon::prelude::*;

use super::agent::steer_agent_with;
use super::cells;
use super::lanes::lane_run;
use super::out::{STEER_CHUNK, SteerOut};
use super::plan::PlanKind;
use super::view::SteerView;

/// Per-frame scratch of the pass.
#[derive(Debug, Default)]
pub(crate) struct PassScratch {
    /// The cell-batched outputs, in the grid's order.
    pub cells: cells::CellOut,
    /// Per group, whether the latest pass took the group's neighbour sums from the cell batch
    /// for its per-agent or lane evaluation (a summed group).
    pub summed: Vec<bool>,
}

/// Runs the steering pass over all agents (in parallel, or on this thread when `parallel` is
/// false). With `defer`, when the cell batch serves every agent, the linear requests stay in
/// its outputs ([`SteerOut::deferred`]).
pub(crate) fn run(
    view: &SteerView,
    out: &mut SteerOut,
    scratch: &mut PassScratch,
    (parallel, defer): (bool, bool),
) {
    let batched = cells::run(view, &mut scratch.cells, parallel);
    let all = batched && (0..view.plans.len()).all(|g| cells::is_batched_group(view, g));
    scratch.summed.clear();
    scratch
        .summed
        .extend((0..view.plans.len()).map(|g| batched && cells::is_summed_group(view, g)));
    // The batch's total of the neighbours found (when it served every agent).
    out.found = scratch.cells.found();
    // The batch, the seek and arrive lanes and the leader lanes turn nobody and leave wander
    // angles as they are: with every agent served by them, neither output is written (the step
    // reads neither then).
    let still = (0..view.plans.len()).all(|g| {
        matches!(
            view.plans[g].kind,
            PlanKind::Seek { .. } | PlanKind::Arrive { .. } | PlanKind::FollowLeader { .. }
        ) || (batched && cells::is_batched_group(view, g))
    });
    (out.angular, out.wandered) = (!still, !still);
    // The pedestrian models and the ORCA filter read the requests in storage order and replace
    // them: with either, the requests are written.
    out.deferred = all && defer && !super::ped::any(view) && !super::orca::any(view);
    if out.deferred {
        return;
    }
    let kernel = |base: usize,
                  lx: &mut [f32],
                  ly: &mut [f32],
                  an: &mut [f32],
                  wa: &mut [f32],
                  nb: &mut [f32]| {
        if all {
            scratch.cells.take_all(view.index, base, (lx, ly));
            return;
        }
        let groups = &view.agents.group[base..base + lx.len()];
        let mut k = 0;
        while k < lx.len() {
            let i = base + k;
            let g = groups[k] as usize;
            // Each arm evaluates the agents from `k` on that it serves and says how many.
            let done = match view.plans[g].kind {
                PlanKind::Seek { .. } | PlanKind::Arrive { .. } | PlanKind::Wander { .. } => {
                    // The run of this group's agents, a block of lanes at a time.
                    let run = groups[k..].iter().take_while(|&&h| h as usize == g).count();
                    let outs = (&mut *lx, &mut *ly, &mut *an, &mut *wa, &mut *nb);
                    lane_run(view, g, (base + k, base + k + run), base, outs, !still);
                    run
                }
                // Leader following in lanes, with its separation sums from the batch (or from
                // each agent's own query when the batch does not run).
                PlanKind::FollowLeader { .. } => {
                    let run = groups[k..].iter().take_while(|&&h| h as usize == g).count();
                    let outs = (&mut *lx, &mut *ly, &mut *an, &mut *wa, &mut *nb);
                    let sums =
                        (batched && cells::is_summed_group(view, g)).then_some(&scratch.cells);
                    let turns = !still;
                    super::leader::run(view, g, (i, i + run), base, outs, turns, sums);
                    run
                }
                // Field following in lanes, the same way.
                PlanKind::FollowField { .. } => {
                    let run = groups[k..].iter().take_while(|&&h| h as usize == g).count();
                    let outs = (&mut *lx, &mut *ly, &mut *an, &mut *wa, &mut *nb);
                    let sums =
                        (batched && cells::is_summed_group(view, g)).then_some(&scratch.cells);
                    super::follow::run(view, g, (i, i + run), base, outs, sums);
                    run
                }
                _ if batched && cells::is_batched(view, i) => {
                    scratch.cells.take(i, view, (lx, ly, an, wa, nb), k);
                    1
                }
                _ => {
                    // A summed group's neighbour sums come from the batch.
                    let sums = (batched && cells::is_summed_group(view, g))
                        .then(|| scratch.cells.sums_of(view, i));
                    let (st, w, count) = steer_agent_with(view, i, sums);
                    (lx[k], ly[k], an[k], wa[k], nb[k]) =
                        (st.linear.x, st.linear.y, st.angular, w, count);
                    1
                }
            };
            k += done;
        }
    };
    if parallel {
        (
            out.lin_x.par_chunks_mut(STEER_CHUNK),
            out.lin_y.par_chunks_mut(STEER_CHUNK),
            out.ang.par_chunks_mut(STEER_CHUNK),
            out.wander.par_chunks_mut(STEER_CHUNK),
            out.neighbours.par_chunks_mut(STEER_CHUNK),
        )
            .into_par_iter()
            .enumerate()
            .for_each(|(c, (lx, ly, an, wa, nb))| kernel(c * STEER_CHUNK, lx, ly, an, wa, nb));
    } else {
        kernel(
            0,
            &mut out.lin_x,
            &mut out.lin_y,
            &mut out.ang,
            &mut out.wander,
            &mut out.neighbours,
        );
    }
}
