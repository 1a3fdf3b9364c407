//! Field following in lanes: the [`PlanKind::FollowField`] plan.
//!
//! A follower's profile is `follow_field` of one channel, alone, followed by `separation`, or
//! by `separation` then `avoid_walls`, in a weighted sum (the shape of a crowd crossing a cave or
//! a town). The plan resolves the field's flow once per run of the group's agents and evaluates
//! [`LANES`] followers at a time: the flow sample ([`crate::field::FlowField`]'s lane form, with
//! its wall rules), braking once arrived, the separation term from the neighbour sums the cell
//! batch computed (or each agent's own query when the batch does not run), the walls' feelers
//! per lane, and the model adapter's finish.
//!
//! Invariants: every lane performs the operations of the per-agent evaluation
//! (`FieldSet::follow`, the separation term, `avoid_walls` and the general plan's weighted sum
//! `((0 + follow w) + separation w') + walls w''`) in the same order, so the result is the same
//! bits; a lane the vector form does not serve exactly (a request that overflowed) takes the
//! per-agent path with the same neighbour sums, and so do a run whose agents each choose their
//! channel (`choose_exit`) and a run shorter than half a block.

use super::cells::CellOut;
use super::eval::wall_request;
use super::lanes::take;
use super::leader::{Lanes, per_agent, separation_lane};
use super::neighbours::LANES;
use super::out::OutChunks;
use super::plan::PlanKind;
use super::view::SteerView;
use crate::agents::AgentId;
use crate::field::FollowChannel;
use crate::simd::{apply, float_kernel};

/// Evaluates group `g`'s followers at storage indices `from..to` (one [`PlanKind::FollowField`]
/// plan) into the chunks starting at `base`. `cells` holds the batch's neighbour sums when it
/// computed them; without it, each agent's separation sums come from its own query, as in the
/// general plan.
#[apply(float_kernel!)]
pub(super) fn run(
    view: &SteerView,
    g: usize,
    (from, to): (usize, usize),
    base: usize,
    (lx, ly, an, wa, nb): OutChunks,
    cells: Option<&CellOut>,
) {
    let plan = &view.plans[g];
    let PlanKind::FollowField {
        field,
        channel,
        weight,
        separation,
        walls,
    } = plan.kind
    else {
        unreachable!("only follow_field plans run here")
    };
    let a = view.agents;
    // Each agent's own choice of channel, or a run too short to fill half a block (groups
    // mixed in the cells' order, as in a town): per agent.
    let (FollowChannel::Fixed(channel), false) = (channel, to - from < LANES / 2) else {
        per_agent(view, (from, to), base, (lx, ly, an, wa, nb), cells);
        return;
    };
    let flow = view.fields.flow_of(field, channel);
    let kinematic = plan.adapter.kinematic;
    let mut l = Lanes::default();
    for s in (from..to).step_by(LANES) {
        let len = LANES.min(to - s);
        l.fill(view, s, len, cells, separation.is_some());
        // `FieldSet::follow`: no flow, no request; an arrived agent's direction is zero.
        let (mut dx, mut dy) = match flow {
            Some(f) => f.sample_lanes(&l.px, &l.py, len),
            None => ([0.0; LANES], [0.0; LANES]),
        };
        for q in 0..len {
            if view.fields.arrived_of(AgentId(l.id[q])) {
                (dx[q], dy[q]) = (0.0, 0.0);
            }
        }
        let (mut tx, mut ty) = ([0.0_f32; LANES], [0.0_f32; LANES]);
        // One lane per index across the lane arrays: the loop the vector units run.
        #[allow(clippy::needless_range_loop)]
        for q in 0..LANES {
            let (ms, vx, vy) = (l.max_speed[q], l.vx[q], l.vy[q]);
            let (fx, fy) = if flow.is_none() {
                (0.0, 0.0)
            } else if kinematic {
                (dx[q] * ms, dy[q] * ms)
            } else if (dx[q] == 0.0) & (dy[q] == 0.0) {
                // Brake to rest over a tenth of a second.
                (-vx * 10.0, -vy * 10.0)
            } else {
                (dx[q] * ms - vx, dy[q] * ms - vy)
            };
            let (mut x, mut y) = (0.0 + fx * weight, 0.0 + fy * weight);
            if let Some(w) = separation {
                let (sx, sy) = separation_lane(&l, q, kinematic);
                x += sx * w;
                y += sy * w;
            }
            (tx[q], ty[q]) = (x, y);
        }
        if let Some((feeler_length, w)) = walls {
            for q in 0..len {
                let i = s + q;
                let agent = (
                    a.position(i),
                    a.velocity(i),
                    a.orientation[i],
                    a.max_speed[i],
                );
                let f = wall_request(view, agent, &plan.adapter, feeler_length);
                tx[q] += f.x * w;
                ty[q] += f.y * w;
            }
        }
        let (ox, oy) = plan.adapter.finish_lanes(tx, ty);
        let k0 = s - base;
        take(&mut lx[k0..], &ox, len);
        take(&mut ly[k0..], &oy, len);
        take(&mut nb[k0..], &l.count, len);
        take(&mut an[k0..], &[0.0; LANES], len);
        wa[k0..k0 + len].copy_from_slice(&a.wander[s..s + len]);
        for q in (0..len).filter(|&q| !(tx[q] * tx[q] + ty[q] * ty[q]).is_finite()) {
            let outs = (&mut *lx, &mut *ly, &mut *an, &mut *wa, &mut *nb);
            per_agent(view, (s + q, s + q + 1), base, outs, cells);
        }
    }
}
