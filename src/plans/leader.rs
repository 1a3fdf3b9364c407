//! Leader following in lanes: the [`PlanKind::FollowLeader`] plan.
//!
//! A follower's profile is `follow_leader`, alone or followed by `separation`, in a weighted sum
//! (the shape of a squad behind its leader). The plan resolves the leader once per run of the
//! group's agents (its index, position, velocity and frame, one `sin_cos` of its orientation
//! instead of one per follower) and evaluates [`LANES`] followers at a time: the leader's
//! nearest image, the follower's spread slot (its draws from the agent's fixed stream, the
//! polynomial [`crate::steering::trig`] sine and cosine), the keep-out area in front of the
//! leader, the predicted slot and its approach, the model adapter, the separation term (from
//! the neighbour sums the cell batch computed, or each agent's own query when the batch does not
//! run), and the adapter's finish.
//!
//! Invariants: every lane performs the operations of the per-agent evaluation
//! ([`super::eval`]'s `follow_leader`, `group::follow_leader`, the separation term and the
//! general plan's weighted sum) in the same order, so the result is the same bits; a lane the
//! vector form does not serve exactly (the leader itself, a speed or request that overflowed)
//! takes the per-agent path with the same neighbour sums, and so does a whole run whose leader
//! is gone.

use std::f32::consts::TAU;

use super::agent::steer_agent_with;
use super::cells::CellOut;
use super::lanes::{put, take};
use super::neighbours::LANES;
use super::out::OutChunks;
use super::plan::PlanKind;
use super::view::SteerView;
use crate::bounds::{Bounds, wrap_delta};
use crate::group::FollowParams;
use crate::rng::{Stream, agent_key, frame_key, unit_at};
use crate::simd::{apply, float_kernel};
use crate::steering::trig::sin_cos_reduced;

/// The leader of a run, resolved once: its storage index, position, velocity and frame.
#[derive(Clone, Copy, Debug)]
struct Leader {
    index: usize,
    x: f32,
    y: f32,
    vx: f32,
    vy: f32,
    /// The unit heading `(cos, sin)` of its orientation; the side is its quarter turn left.
    hx: f32,
    hy: f32,
}

/// Up to [`LANES`] consecutive followers of one plan (of a leader or of a field).
#[derive(Debug, Default)]
pub(super) struct Lanes {
    pub id: [u32; LANES],
    pub px: [f32; LANES],
    pub py: [f32; LANES],
    pub vx: [f32; LANES],
    pub vy: [f32; LANES],
    pub max_speed: [f32; LANES],
    /// The separation sums and the neighbour counts (zero without separation).
    pub sep_x: [f32; LANES],
    pub sep_y: [f32; LANES],
    pub count: [f32; LANES],
}

/// The plan's constants for one step.
#[derive(Clone, Copy, Debug)]
struct Consts {
    params: FollowParams,
    weight: f32,
    /// The separation term's weight, when the profile has one.
    separation: Option<f32>,
    kinematic: bool,
    /// `mass / time_to_target`: the dynamic model's gain towards the desired velocity.
    gain: f32,
    /// The torus's side per axis, when the world wraps.
    torus: Option<(f32, f32)>,
    /// The key of the spread's stream before the agent's id (frame 0).
    spread_key: u64,
}

/// Evaluates group `g`'s followers at storage indices `from..to` (one [`PlanKind::FollowLeader`]
/// plan) into the chunks starting at `base`; the angular outputs and wander angles are written
/// when `turns` (and for the lanes that take the per-agent path). `cells` holds the batch's
/// neighbour sums when it computed them; without it, each agent's separation sums come from its
/// own query ([`SteerView::sums`]), as in the general plan.
#[apply(float_kernel!)]
pub(super) fn run(
    view: &SteerView,
    g: usize,
    (from, to): (usize, usize),
    base: usize,
    (lx, ly, an, wa, nb): OutChunks,
    turns: bool,
    cells: Option<&CellOut>,
) {
    let plan = &view.plans[g];
    let PlanKind::FollowLeader {
        leader,
        params,
        weight,
        separation,
    } = plan.kind
    else {
        unreachable!("only follow_leader plans run here")
    };
    let a = view.agents;
    // Without its leader (removed) the per-agent path gives every follower the separation
    // term alone: rare, and left to it.
    let Some(j) = a.index_of(leader) else {
        per_agent(view, (from, to), base, (lx, ly, an, wa, nb), cells);
        return;
    };
    // `Basis::from_orientation` of the leader, once.
    let (s, c) = a.orientation[j].sin_cos();
    let lead = Leader {
        index: j,
        x: a.pos_x[j],
        y: a.pos_y[j],
        vx: a.vel_x[j],
        vy: a.vel_y[j],
        hx: c,
        hy: s,
    };
    let consts = Consts {
        params,
        weight,
        separation,
        kinematic: plan.adapter.kinematic,
        gain: plan.adapter.mass / params.time_to_target,
        torus: match view.bounds {
            Bounds::Torus { size } => Some((size.x, size.y)),
            _ => None,
        },
        spread_key: frame_key(view.seed, 0),
    };
    let mut l = Lanes::default();
    for s in (from..to).step_by(LANES) {
        let len = LANES.min(to - s);
        l.fill(view, s, len, cells, separation.is_some());
        let (tx, ty, exact) = lanes(&l, &lead, &consts);
        let (ox, oy) = plan.adapter.finish_lanes(tx, ty);
        let k0 = s - base;
        take(&mut lx[k0..], &ox, len);
        take(&mut ly[k0..], &oy, len);
        take(&mut nb[k0..], &l.count, len);
        if turns {
            take(&mut an[k0..], &[0.0; LANES], len);
            wa[k0..k0 + len].copy_from_slice(&a.wander[s..s + len]);
        }
        for q in (0..len).filter(|&q| !exact[q] || s + q == lead.index) {
            let outs = (&mut *lx, &mut *ly, &mut *an, &mut *wa, &mut *nb);
            per_agent(view, (s + q, s + q + 1), base, outs, cells);
        }
    }
}

/// The outputs of the agents at storage indices `from..to` by the per-agent path, into the
/// chunks starting at `base`, with their neighbour sums from `cells` when the batch computed
/// them.
#[inline]
pub(super) fn per_agent(
    view: &SteerView,
    (from, to): (usize, usize),
    base: usize,
    (lx, ly, an, wa, nb): OutChunks,
    cells: Option<&CellOut>,
) {
    for i in from..to {
        let (st, w, count) = steer_agent_with(view, i, cells.map(|c| c.sums_of(view, i)));
        let k = i - base;
        (lx[k], ly[k], an[k], wa[k], nb[k]) = (st.linear.x, st.linear.y, st.angular, w, count);
    }
}

impl Lanes {
    /// Takes the `len` (at most [`LANES`]) agents from storage index `i` on, with their
    /// separation sums from `cells` when `separation`.
    #[inline(always)]
    pub(super) fn fill(
        &mut self,
        view: &SteerView,
        i: usize,
        len: usize,
        cells: Option<&CellOut>,
        separation: bool,
    ) {
        let a = view.agents;
        for (l, id) in a.ids[i..i + len].iter().enumerate() {
            self.id[l] = id.0;
        }
        put(&mut self.px, &a.pos_x[i..], len);
        put(&mut self.py, &a.pos_y[i..], len);
        put(&mut self.vx, &a.vel_x[i..], len);
        put(&mut self.vy, &a.vel_y[i..], len);
        put(&mut self.max_speed, &a.max_speed[i..], len);
        (self.sep_x, self.sep_y, self.count) = ([0.0; LANES], [0.0; LANES], [0.0; LANES]);
        if !separation {
            return;
        }
        for q in 0..len {
            let j = i + q;
            let own;
            let s = match cells {
                Some(c) => c.sums_of(view, j),
                None => {
                    own = view.sums(j, a.velocity(j), a.orientation[j]);
                    &own
                }
            };
            (self.sep_x[q], self.sep_y[q], self.count[q]) =
                (s.separation.x, s.separation.y, s.count);
        }
    }
}

/// Every lane's weighted request before the adapter's finish, and whether it is the per-agent
/// path's: `eval`'s `follow_leader` (the leader's nearest image as the frame's origin, the
/// spread slot, `group::follow_leader`, the adapter's `towards`), then the separation term, in
/// the general plan's order `(0 + lead w) + separation w'`.
#[inline(always)]
fn lanes(l: &Lanes, lead: &Leader, k: &Consts) -> ([f32; LANES], [f32; LANES], [bool; LANES]) {
    let p = &k.params;
    let (mut tx, mut ty, mut exact) = ([0.0_f32; LANES], [0.0_f32; LANES], [false; LANES]);
    let (hx, hy) = (lead.hx, lead.hy);
    // `heading.perp()`.
    let (sx, sy) = (-hy, hx);
    // One lane per index across the lane arrays: the loop the vector units run.
    #[allow(clippy::needless_range_loop)]
    for q in 0..LANES {
        let (px, py, ms) = (l.px[q], l.py[q], l.max_speed[q]);
        // The leader's frame at its nearest image: `position + bounds.offset(position, leader)`.
        let (mut dx, mut dy) = (lead.x - px, lead.y - py);
        if let Some((w, h)) = k.torus {
            dx = wrap_delta(dx, w);
            dy = wrap_delta(dy, h);
        }
        let (ox, oy) = (px + dx, py + dy);
        // The slot: the offset, plus the agent's fixed place on the spread disc.
        let (mut slot_x, mut slot_y) = (p.offset.x, p.offset.y);
        if p.spread > 0.0 {
            let key = agent_key(k.spread_key, l.id[q], Stream::Spread as u32);
            let r = p.spread * unit_at(key, 1).sqrt();
            let (s, c) = sin_cos_reduced(TAU * unit_at(key, 2));
            slot_x += c * r;
            slot_y += s * r;
        }
        // `group::follow_leader`: the follower in the leader's frame, the keep-out area.
        let (ldx, ldy) = (px - ox, py - oy);
        let (local_x, local_y) = (ldx * hx + ldy * hy, ldx * sx + ldy * sy);
        let ahead = (local_x > 0.0) & (local_x < p.clear_ahead) & (local_y.abs() < p.clear_width);
        let sign = if local_y >= 0.0 { 1.0 } else { -1.0 };
        let (ax, ay) = (sx * (sign * ms), sy * (sign * ms));
        // `slot_velocity`: the slot in the world, predicted, approached, truncated.
        let (wx, wy) = (
            (ox + hx * slot_x) + sx * slot_y,
            (oy + hy * slot_x) + sy * slot_y,
        );
        let (pred_x, pred_y) = if p.max_prediction > 0.0 {
            let (ddx, ddy) = (wx - px, wy - py);
            let distance = (ddx * ddx + ddy * ddy).sqrt();
            let t = if ms <= distance / p.max_prediction {
                p.max_prediction
            } else {
                distance / ms
            };
            (wx + lead.vx * t, wy + lead.vy * t)
        } else {
            (wx, wy)
        };
        let (to_x, to_y) = (pred_x - px, pred_y - py);
        let dist = (to_x * to_x + to_y * to_y).sqrt();
        let ratio = dist / p.slow_radius;
        // `f32::min(ratio, 1)`, 1 for a NaN ratio as there.
        let ratio = if ratio < 1.0 { ratio } else { 1.0 };
        let f = ms * ratio / dist;
        let (apx, apy) = if dist <= p.target_radius {
            (0.0, 0.0)
        } else {
            (to_x * f, to_y * f)
        };
        let (vx, vy) = (lead.vx + apx, lead.vy + apy);
        let len_sq = vx * vx + vy * vy;
        let scale = ms / len_sq.sqrt();
        let (vx, vy) = if len_sq > ms * ms {
            (vx * scale, vy * scale)
        } else {
            (vx, vy)
        };
        let (dx, dy) = if ahead { (ax, ay) } else { (vx, vy) };
        // The adapter's `towards`.
        let (fx, fy) = if k.kinematic {
            (dx, dy)
        } else {
            ((dx - l.vx[q]) * k.gain, (dy - l.vy[q]) * k.gain)
        };
        let (mut x, mut y) = (0.0 + fx * k.weight, 0.0 + fy * k.weight);
        if let Some(w) = k.separation {
            let (fx, fy) = separation_lane(l, q, k.kinematic);
            x += fx * w;
            y += fy * w;
        }
        (tx[q], ty[q]) = (x, y);
        // A truncation of an infinite speed takes the robust path there.
        exact[q] = (ahead | len_sq.is_finite()) & (x * x + y * y).is_finite();
    }
    (tx, ty, exact)
}

/// Lane `q`'s separation request, `flock_force` of separation: the sums' direction at full
/// speed (kinematic), or that less the velocity, zero without a direction (dynamic).
#[inline(always)]
pub(super) fn separation_lane(l: &Lanes, q: usize, kinematic: bool) -> (f32, f32) {
    let (dx, dy, ms) = (l.sep_x[q], l.sep_y[q], l.max_speed[q]);
    let rcp = 1.0 / (dx * dx + dy * dy).sqrt();
    let unit = rcp.is_finite() & (rcp > 0.0);
    let (nx, ny) = if unit {
        ((dx * rcp) * ms, (dy * rcp) * ms)
    } else {
        (0.0, 0.0)
    };
    let none = (dx == 0.0) & (dy == 0.0);
    if kinematic {
        (nx, ny)
    } else if none {
        (0.0, 0.0)
    } else {
        (nx - l.vx[q], ny - l.vy[q])
    }
}
