//! The steering pass: every agent's request for this frame, written into SoA outputs.
//!
//! [`run`] evaluates each agent by its group's [`Plan`]: flocking-only plans in cell batches
//! through the grid kernel when the uniform grid is ready ([`super::cells`]); a lone seek,
//! arrive or wander, and leader following, a block of agents at a time in lanes; everything
//! else per agent ([`steer_agent`]: the flocking, flow-field, path and formation plans without
//! dispatch, the general plan by [`evaluate`] over the profile's behaviours and their
//! combination, over neighbour sums the cell batch computed for it when the plan has flocking
//! terms the batch serves).
//!
//! Invariants: the pass reads only frame-t state and writes only the outputs of the agent it
//! evaluates, so results are independent of the thread count; the sequential pass runs the same
//! code on one thread and gives the same bits.

use rayon::prelude::*;

use super::adapter::Adapter;
use super::cells;
use super::eval::{self, Draws, Me, evaluate};
use super::neighbours::LANES;
use super::plan::{PlanKind, SEP};
use super::view::SteerView;
use crate::rng::{AgentRng, Stream};
use crate::simd::{apply, float_kernel};
use crate::steering::{self, Combine, Steering, Target};

/// Agents per parallel steering task.
pub(crate) const STEER_CHUNK: usize = 1024;

/// The steering pass's per-agent outputs, in storage order.
#[derive(Debug, Default)]
pub(crate) struct SteerOut {
    pub lin_x: Vec<f32>,
    pub lin_y: Vec<f32>,
    pub ang: Vec<f32>,
    pub wander: Vec<f32>,
    /// Neighbours found per agent this step (not written when `found` holds their total).
    pub neighbours: Vec<f32>,
    /// The neighbours all agents found this step, when the pass summed them itself.
    pub found: Option<f64>,
    /// Whether `ang` was written this step; when not, every agent's angular output is zero.
    pub angular: bool,
    /// Whether `wander` was written this step; when not, every wander angle is unchanged.
    pub wandered: bool,
    /// Whether `lin_x` and `lin_y` were left unwritten because every agent's request waits in
    /// the cell batch's outputs, in the grid's order ([`cells::CellOut::take_all`] copies them
    /// out, as the integrator does task by task); never when a pedestrian model or the ORCA
    /// filter reads and replaces the requests after the pass.
    pub deferred: bool,
}

impl SteerOut {
    /// Sizes every output for `n` agents.
    pub(crate) fn resize(&mut self, n: usize) {
        for v in [
            &mut self.lin_x,
            &mut self.lin_y,
            &mut self.ang,
            &mut self.wander,
            &mut self.neighbours,
        ] {
            v.resize(n, 0.0);
        }
    }
}

/// Per-frame scratch of the pass.
#[derive(Debug, Default)]
pub(crate) struct PassScratch {
    /// The cell-batched outputs, in the grid's order.
    pub cells: cells::CellOut,
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

/// The agents at storage indices `from..to`, all of lane group `g` (seek, arrive or wander), a
/// block of [`LANES`] at a time into the chunks starting at `base` (a seek or arrive run writes
/// the angular outputs and wander angles too only when `turns`). Compiled for each dispatch
/// target with the lane evaluations, the model adapter and the copies inlined: the whole run is
/// vector code of the processor's width (a baseline build of the glue around a dispatched
/// kernel cost more than the kernel).
#[apply(float_kernel!)]
fn lane_run(
    view: &SteerView,
    g: usize,
    (from, to): (usize, usize),
    base: usize,
    (lx, ly, an, wa, nb): cells::OutChunks,
    turns: bool,
) {
    let wander = matches!(view.plans[g].kind, PlanKind::Wander { .. });
    let (mut seekers, mut wanderers) = (SeekLanes::default(), WanderLanes::default());
    for s in (from..to).step_by(LANES) {
        let (len, outs) = (
            LANES.min(to - s),
            (&mut *lx, &mut *ly, &mut *an, &mut *wa, &mut *nb),
        );
        if wander {
            wanderers.fill(view, g, s, len);
            wanderers.flush(view, outs, base);
        } else {
            seekers.fill(view, g, s, len);
            seekers.flush(view, outs, base, turns);
        }
    }
}

/// Up to [`LANES`] consecutive agents of one seek or arrive plan, evaluated together.
#[derive(Debug, Default)]
struct SeekLanes {
    len: usize,
    group: usize,
    /// The storage index of the first lane's agent.
    first: usize,
    px: [f32; LANES],
    py: [f32; LANES],
    vx: [f32; LANES],
    vy: [f32; LANES],
    max_speed: [f32; LANES],
    /// The point each lane seeks: the plan's point or slot, or the agent's own target.
    tx: [f32; LANES],
    ty: [f32; LANES],
}

impl SeekLanes {
    /// Takes the `len` (at most [`LANES`]) agents from storage index `i` on, all of `group`.
    #[inline(always)]
    fn fill(&mut self, view: &SteerView, group: usize, i: usize, len: usize) {
        let a = view.agents;
        (self.group, self.first, self.len) = (group, i, len);
        put(&mut self.px, &a.pos_x[i..], len);
        put(&mut self.py, &a.pos_y[i..], len);
        put(&mut self.vx, &a.vel_x[i..], len);
        put(&mut self.vy, &a.vel_y[i..], len);
        put(&mut self.max_speed, &a.max_speed[i..], len);
        let target = match view.plans[group].kind {
            PlanKind::Seek { target, .. } | PlanKind::Arrive { target, .. } => target,
            _ => unreachable!("only seek and arrive plans are gathered"),
        };
        let point = match target {
            Target::Point(p) => p,
            Target::Slot(s) => view.targets[s.0 as usize].position,
            Target::Own => {
                put(&mut self.tx, &a.target_x[i..], len);
                put(&mut self.ty, &a.target_y[i..], len);
                return;
            }
            _ => unreachable!("lane plans name a point, a slot or the own target"),
        };
        (self.tx, self.ty) = ([point.x; LANES], [point.y; LANES]);
    }

    /// Lane `k`'s offset to its target: the target resolved to its nearest image on a torus of
    /// `torus` (its size), then the offset to it, as the scalar path computes them.
    #[inline(always)]
    fn to_target(&self, k: usize, torus: Option<glam::Vec2>) -> (f32, f32) {
        let (px, py) = (self.px[k], self.py[k]);
        let (mut dx, mut dy) = (self.tx[k] - px, self.ty[k] - py);
        if let Some(size) = torus {
            dx = crate::bounds::wrap_delta(dx, size.x);
            dy = crate::bounds::wrap_delta(dy, size.y);
        }
        ((px + dx) - px, (py + dy) - py)
    }

    /// Evaluates the filled lanes and writes their outputs into the chunks starting at `base`
    /// (the angular outputs and wander angles only when `turns`: some agent of the frame may
    /// turn or wander, so the step reads them).
    #[inline(always)]
    fn flush(
        &mut self,
        view: &SteerView,
        (lx, ly, an, wa, nb): cells::OutChunks,
        base: usize,
        turns: bool,
    ) {
        let plan = &view.plans[self.group];
        let kinematic = plan.adapter.kinematic;
        let (tx, ty) = match plan.kind {
            PlanKind::Seek {
                threshold, weight, ..
            } => seek_lanes(self, view.bounds, threshold, weight, kinematic),
            PlanKind::Arrive { params, weight, .. } => {
                arrive_lanes(self, view.bounds, &params, weight, kinematic)
            }
            _ => unreachable!("only seek and arrive plans are gathered"),
        };
        let (ox, oy) = plan.adapter.finish_lanes(tx, ty);
        let (n, k0) = (self.len, self.first - base);
        take(&mut lx[k0..], &ox, n);
        take(&mut ly[k0..], &oy, n);
        take(&mut nb[k0..], &[0.0; LANES], n);
        if turns {
            take(&mut an[k0..], &[0.0; LANES], n);
            wa[k0..k0 + n].copy_from_slice(&view.agents.wander[self.first..self.first + n]);
        }
        self.len = 0;
    }
}

/// The size of a torus world, `None` for the others.
#[inline(always)]
fn torus_size(bounds: crate::bounds::Bounds) -> Option<glam::Vec2> {
    match bounds {
        crate::bounds::Bounds::Torus { size } => Some(size),
        _ => None,
    }
}

/// The weighted seek request of every lane: the same operations in the same order as
/// resolving the point target (its nearest image) and `steering::seek` / `kinematic_seek`.
#[inline(always)]
fn seek_lanes(
    l: &SeekLanes,
    bounds: crate::bounds::Bounds,
    threshold: f32,
    weight: f32,
    kinematic: bool,
) -> ([f32; LANES], [f32; LANES]) {
    let (mut tx, mut ty) = ([0.0_f32; LANES], [0.0_f32; LANES]);
    let torus = torus_size(bounds);
    let thr_sq = threshold * threshold;
    for k in 0..LANES {
        let (to_x, to_y) = l.to_target(k, torus);
        let d_sq = to_x * to_x + to_y * to_y;
        let stop = (d_sq <= thr_sq) | (d_sq == 0.0);
        let s = l.max_speed[k] / d_sq.sqrt();
        let (fx, fy) = if kinematic {
            (to_x * s, to_y * s)
        } else {
            (to_x * s - l.vx[k], to_y * s - l.vy[k])
        };
        let (fx, fy) = if stop { (0.0, 0.0) } else { (fx, fy) };
        // `Steering::ZERO + request * weight`, as the general plan sums it.
        tx[k] = 0.0 + fx * weight;
        ty[k] = 0.0 + fy * weight;
    }
    (tx, ty)
}

/// The weighted arrive request of every lane: the same operations in the same order as
/// resolving the point target (its nearest image) and `steering::arrive` /
/// `kinematic_arrive`, each case computed in every lane and the lane's own case selected, so
/// that the loop runs in vector lanes. A kinematic lane whose slowed velocity's squared length
/// overflows (where `truncate` takes its robust way) is computed by `kinematic_arrive` itself.
#[inline(always)]
fn arrive_lanes(
    l: &SeekLanes,
    bounds: crate::bounds::Bounds,
    params: &crate::steering::ArriveParams,
    weight: f32,
    kinematic: bool,
) -> ([f32; LANES], [f32; LANES]) {
    let (mut tx, mut ty) = ([0.0_f32; LANES], [0.0_f32; LANES]);
    let torus = torus_size(bounds);
    let ttt = params.time_to_target;
    let mut robust = [false; LANES];
    for k in 0..LANES {
        let (to_x, to_y) = l.to_target(k, torus);
        let dist = (to_x * to_x + to_y * to_y).sqrt();
        let rest = dist <= params.target_radius;
        let m = l.max_speed[k];
        let (fx, fy);
        if kinematic {
            // Inside the slow radius: the offset over the time to target, truncated.
            let (vx, vy) = (to_x / ttt, to_y / ttt);
            let len_sq = vx * vx + vy * vy;
            let over = len_sq > m * m;
            robust[k] = over & !len_sq.is_finite();
            let t = if over { m / len_sq.sqrt() } else { 1.0 };
            let s = m / dist;
            let slow = dist < params.slow_radius;
            let (kx, ky) = if slow {
                (vx * t, vy * t)
            } else {
                (to_x * s, to_y * s)
            };
            // `v * 1.0` is `v`: the untruncated velocity's bits.
            fx = if rest { 0.0 } else { kx };
            fy = if rest { 0.0 } else { ky };
        } else {
            let speed = if dist > params.slow_radius {
                m
            } else {
                m * dist / params.slow_radius
            };
            let s = speed / dist;
            let (vx, vy) = (l.vx[k], l.vy[k]);
            fx = if rest { -vx } else { to_x * s - vx } / ttt;
            fy = if rest { -vy } else { to_y * s - vy } / ttt;
        }
        // `Steering::ZERO + request * weight`, as the general plan sums it.
        tx[k] = 0.0 + fx * weight;
        ty[k] = 0.0 + fy * weight;
    }
    if robust.contains(&true) {
        for k in (0..LANES).filter(|&k| robust[k]) {
            let p = glam::Vec2::new(l.px[k], l.py[k]);
            let resolved = p + bounds.offset(p, glam::Vec2::new(l.tx[k], l.ty[k]));
            let f = crate::steering::kinematic_arrive(p, resolved, l.max_speed[k], params);
            tx[k] = 0.0 + f.x * weight;
            ty[k] = 0.0 + f.y * weight;
        }
    }
    (tx, ty)
}

/// Up to [`LANES`] consecutive agents of one wander plan, evaluated together.
#[derive(Debug, Default)]
struct WanderLanes {
    len: usize,
    group: usize,
    /// The storage index of the first lane's agent.
    first: usize,
    id: [u32; LANES],
    orientation: [f32; LANES],
    vx: [f32; LANES],
    vy: [f32; LANES],
    wander: [f32; LANES],
    max_speed: [f32; LANES],
}

/// What the wander lanes give: the weighted request, the angular request, the new wander angle,
/// and whether the lane's result is the scalar one (false where the scalar path takes a branch
/// the lanes do not: an angle beyond the polynomial's range or to be wrapped by more than a
/// turn, an agent at rest, a request that overflowed).
struct WanderOut {
    tx: [f32; LANES],
    ty: [f32; LANES],
    ang: [f32; LANES],
    angle: [f32; LANES],
    exact: [bool; LANES],
}

impl WanderLanes {
    /// Takes the `len` (at most [`LANES`]) agents from storage index `i` on, all of `group`.
    #[inline(always)]
    fn fill(&mut self, view: &SteerView, group: usize, i: usize, len: usize) {
        let a = view.agents;
        (self.group, self.first, self.len) = (group, i, len);
        for (l, id) in a.ids[i..i + len].iter().enumerate() {
            self.id[l] = id.0;
        }
        put(&mut self.orientation, &a.orientation[i..], len);
        put(&mut self.vx, &a.vel_x[i..], len);
        put(&mut self.vy, &a.vel_y[i..], len);
        put(&mut self.wander, &a.wander[i..], len);
        put(&mut self.max_speed, &a.max_speed[i..], len);
    }

    /// Evaluates the filled lanes and writes their outputs into the chunks starting at `base`;
    /// lanes the vector form does not serve exactly take [`steer_agent`].
    #[inline(always)]
    fn flush(&mut self, view: &SteerView, (lx, ly, an, wa, nb): cells::OutChunks, base: usize) {
        let plan = &view.plans[self.group];
        let PlanKind::Wander { params, weight } = plan.kind else {
            unreachable!("only wander plans are gathered")
        };
        let key = crate::rng::frame_key(view.seed, view.frame);
        let o = if plan.adapter.kinematic {
            let max_rotation = view.profiles[self.group].max_rotation;
            kinematic_wander_lanes(self, key, max_rotation, weight)
        } else {
            wander_lanes(self, key, &params, view.dt, weight)
        };
        let (ox, oy) = plan.adapter.finish_lanes(o.tx, o.ty);
        let (n, k0) = (self.len, self.first - base);
        take(&mut lx[k0..], &ox, n);
        take(&mut ly[k0..], &oy, n);
        take(&mut an[k0..], &o.ang, n);
        take(&mut wa[k0..], &o.angle, n);
        take(&mut nb[k0..], &[0.0; LANES], n);
        for l in (0..n).filter(|&l| !o.exact[l]) {
            let (st, w, count) = steer_agent(view, self.first + l);
            let k = k0 + l;
            (lx[k], ly[k], an[k], wa[k], nb[k]) = (st.linear.x, st.linear.y, st.angular, w, count);
        }
        self.len = 0;
    }
}

/// Copies the first `len` of `from` into `lanes`: a whole block as one vector move (a copy of a
/// length known only at run time is a library call).
#[inline(always)]
pub(super) fn put(lanes: &mut [f32; LANES], from: &[f32], len: usize) {
    if len == LANES {
        *lanes = from[..LANES].try_into().expect("a whole block");
    } else {
        lanes[..len].copy_from_slice(&from[..len]);
    }
}

/// Copies the first `len` lanes into `to`, as [`put`] does the other way.
#[inline(always)]
pub(super) fn take(to: &mut [f32], lanes: &[f32; LANES], len: usize) {
    if len == LANES {
        to[..LANES].copy_from_slice(lanes);
    } else {
        to[..len].copy_from_slice(&lanes[..len]);
    }
}

/// The two uniform draws of `steering::wander` / `kinematic_wander` for every lane: the
/// agent's stream from the frame's key, its first and second numbers, their difference.
#[inline(always)]
fn binomial_lanes(l: &WanderLanes, frame_key: u64) -> [f32; LANES] {
    let mut b = [0.0_f32; LANES];
    for (b, &id) in b.iter_mut().zip(&l.id) {
        let key = crate::rng::agent_key(frame_key, id, Stream::Steer as u32);
        *b = crate::rng::unit_at(key, 1) - crate::rng::unit_at(key, 2);
    }
    b
}

/// The weighted kinematic wander of every lane: `kinematic_wander`'s operations in its order,
/// then `Steering::ZERO + s * weight` as the plan sums it.
#[inline(always)]
fn kinematic_wander_lanes(
    l: &WanderLanes,
    frame_key: u64,
    max_rotation: f32,
    weight: f32,
) -> WanderOut {
    let b = binomial_lanes(l, frame_key);
    let mut o = WanderOut {
        tx: [0.0; LANES],
        ty: [0.0; LANES],
        ang: [0.0; LANES],
        angle: l.wander,
        exact: [false; LANES],
    };
    // One lane per index across the lane arrays: the loop the vector units run.
    #[allow(clippy::needless_range_loop)]
    for k in 0..LANES {
        let (s, c) = steering::trig::sin_cos_reduced(l.orientation[k]);
        let (vx, vy) = (c * l.max_speed[k], s * l.max_speed[k]);
        let rotation = b[k] * max_rotation;
        o.tx[k] = 0.0 + vx * weight;
        o.ty[k] = 0.0 + vy * weight;
        o.ang[k] = 0.0 + rotation * weight;
        o.exact[k] = steering::trig::in_range(l.orientation[k])
            & (o.tx[k] * o.tx[k] + o.ty[k] * o.ty[k]).is_finite()
            & o.ang[k].is_finite();
    }
    o
}

/// The weighted wander circle of every lane: `steering::wander`'s operations in its order (the
/// heading from the velocity, the angle's step and wrap, the circle point, the seek of it), then
/// `Steering::ZERO + s * weight` as the plan sums it.
#[inline(always)]
fn wander_lanes(
    l: &WanderLanes,
    frame_key: u64,
    params: &crate::steering::WanderParams,
    dt: f32,
    weight: f32,
) -> WanderOut {
    use std::f32::consts::{PI, TAU};
    let b = binomial_lanes(l, frame_key);
    let mut o = WanderOut {
        tx: [0.0; LANES],
        ty: [0.0; LANES],
        ang: [0.0; LANES],
        angle: [0.0; LANES],
        exact: [false; LANES],
    };
    // One lane per index across the lane arrays: the loop the vector units run.
    #[allow(clippy::needless_range_loop)]
    for k in 0..LANES {
        let (vx, vy) = (l.vx[k], l.vy[k]);
        // `velocity.try_normalize()`; the lane is left to the scalar path when it fails.
        let rcp = 1.0 / (vx * vx + vy * vy).sqrt();
        let moving = rcp.is_finite() & (rcp > 0.0);
        let (hx, hy) = (vx * rcp, vy * rcp);
        // `wrap_angle`: `a % TAU` is `a` itself below a turn; beyond, the scalar path.
        let a = l.wander[k] + b[k] * params.jitter * dt;
        let within = a.abs() < TAU;
        let a = if a > PI {
            a - TAU
        } else if a <= -PI {
            a + TAU
        } else {
            a
        };
        let (s, c) = steering::trig::sin_cos_reduced(a);
        // `heading * (distance + radius c) + perp(heading) * (radius s)`.
        let (along, across) = (params.distance + params.radius * c, params.radius * s);
        let (px, py) = (hx * along + -hy * across, hy * along + hx * across);
        // `normalize_or_zero() * max_speed - velocity`.
        let r = 1.0 / (px * px + py * py).sqrt();
        let unit = r.is_finite() & (r > 0.0);
        let (nx, ny) = if unit { (px * r, py * r) } else { (0.0, 0.0) };
        let (fx, fy) = (nx * l.max_speed[k] - vx, ny * l.max_speed[k] - vy);
        o.tx[k] = 0.0 + fx * weight;
        o.ty[k] = 0.0 + fy * weight;
        o.angle[k] = a;
        o.exact[k] = moving & within & (o.tx[k] * o.tx[k] + o.ty[k] * o.ty[k]).is_finite();
    }
    o
}

/// The steering of agent `i`, per agent: `(request, new wander angle, neighbours found)`, the
/// request being a clamped acceleration (dynamic) or a desired velocity (kinematic).
pub(crate) fn steer_agent(v: &SteerView, i: usize) -> (Steering, f32, f32) {
    steer_agent_with(v, i, None)
}

/// [`steer_agent`] with the agent's neighbour sums when the cell batch computed them (the
/// general plan then does not query its neighbourhood itself).
pub(super) fn steer_agent_with(
    v: &SteerView,
    i: usize,
    sums: Option<&crate::steering::NeighbourSums>,
) -> (Steering, f32, f32) {
    let a = v.agents;
    let g = a.group[i] as usize;
    let plan = &v.plans[g];
    let adapter = plan.adapter;
    let velocity = a.velocity(i);
    // A lone behaviour's request as the general loop sums and finishes it (0 + s w, as there),
    // without its dispatch.
    let lone = |s: Steering, weight: f32| adapter.finish(Steering::ZERO + s.scaled(weight));
    match plan.kind {
        PlanKind::FollowField {
            field,
            channel,
            weight,
            separation,
        } => {
            let f = v.fields.follow(
                field,
                v.fields.channel_of(channel, a.ids[i]),
                a.ids[i],
                a.position(i),
                velocity,
                a.max_speed[i],
                adapter.kinematic,
            );
            // The general loop's sum without its dispatch (0 + f w, then the separation term,
            // as there).
            let mut total = glam::Vec2::ZERO + f * weight;
            let mut found = 0.0;
            if let Some(w) = separation {
                let sums = sums
                    .copied()
                    .unwrap_or_else(|| v.sums(i, velocity, a.orientation[i]));
                let max_speed = a.max_speed[i];
                total += eval::flock_force(&sums, SEP, velocity, max_speed, adapter.kinematic) * w;
                found = sums.count;
            }
            (adapter.finish(Steering::linear(total)), a.wander[i], found)
        }
        PlanKind::FollowPath {
            path,
            params,
            weight,
        } => {
            let me = (a.position(i), velocity, a.max_speed[i]);
            let s = eval::follow_path(v, i, me, &adapter, path, &params);
            (lone(s, weight), a.wander[i], 0.0)
        }
        PlanKind::KeepFormation { params, weight } => {
            let me = (a.position(i), velocity, a.max_speed[i]);
            let s = eval::keep_formation(v, i, me, &adapter, &params);
            (lone(s, weight), a.wander[i], 0.0)
        }
        PlanKind::Wander { params, weight } => {
            // The general loop's draws and sum without its dispatch (0 + s w, as there).
            let mut rng = AgentRng::new(v.seed, a.ids[i].0, v.frame, Stream::Steer as u32);
            let orientation = a.orientation[i];
            let (s, angle) = if adapter.kinematic {
                let profile = &v.profiles[g];
                let (linear, angular) = steering::kinematic_wander(
                    orientation,
                    a.max_speed[i],
                    profile.max_rotation,
                    &mut rng,
                );
                (Steering { linear, angular }, a.wander[i])
            } else {
                let heading = velocity
                    .try_normalize()
                    .unwrap_or_else(|| glam::Vec2::from_angle(orientation));
                let (f, angle) = steering::wander(
                    velocity,
                    heading,
                    a.wander[i],
                    a.max_speed[i],
                    &params,
                    v.dt,
                    &mut rng,
                );
                (Steering::linear(f), angle)
            };
            (lone(s, weight), angle, 0.0)
        }
        PlanKind::Flock { terms, len } => {
            let sums = v.sums(i, velocity, a.orientation[i]);
            let total = flock_total(
                &terms[..len as usize],
                &sums,
                velocity,
                a.max_speed[i],
                &adapter,
            );
            (
                adapter.finish(Steering::linear(total)),
                a.wander[i],
                sums.count,
            )
        }
        PlanKind::General
        | PlanKind::Vicsek { .. }
        | PlanKind::Seek { .. }
        | PlanKind::Arrive { .. }
        | PlanKind::FollowLeader { .. } => general(v, i, &adapter, sums),
    }
}

/// The weighted sum of flocking terms, in the profile's order (as the general loop sums them).
#[inline(always)]
pub(crate) fn flock_total(
    terms: &[(u8, f32)],
    sums: &crate::steering::NeighbourSums,
    velocity: glam::Vec2,
    max_speed: f32,
    adapter: &Adapter,
) -> glam::Vec2 {
    let mut total = glam::Vec2::ZERO;
    for &(slot, weight) in terms {
        total +=
            eval::flock_force(sums, slot as usize, velocity, max_speed, adapter.kinematic) * weight;
    }
    total
}

/// The general plan: every behaviour of the profile evaluated and combined.
fn general(
    v: &SteerView,
    i: usize,
    adapter: &Adapter,
    sums: Option<&crate::steering::NeighbourSums>,
) -> (Steering, f32, f32) {
    let a = v.agents;
    let profile = &v.profiles[a.group[i] as usize];
    let velocity = a.velocity(i);
    let orientation = a.orientation[i];
    let me = Me {
        i,
        position: a.position(i),
        velocity,
        orientation,
        rotation: a.rotation[i],
        max_speed: a.max_speed[i],
        profile,
        adapter: *adapter,
        sums: sums.map_or_else(|| v.sums(i, velocity, orientation), |s| *s),
    };
    let mut draws = Draws {
        wander: a.wander[i],
        rng: AgentRng::new(v.seed, a.ids[i].0, v.frame, Stream::Steer as u32),
    };
    let total = match profile.steering.combine {
        Combine::WeightedSum => {
            let mut total = Steering::ZERO;
            for w in &profile.steering.behaviours {
                total += evaluate(v, &me, &w.behaviour, &mut draws).scaled(w.weight);
            }
            total
        }
        Combine::Priority => {
            let mut running = adapter.budget(me.max_speed);
            for w in &profile.steering.behaviours {
                let s = evaluate(v, &me, &w.behaviour, &mut draws).scaled(w.weight);
                if !running.push(s) {
                    break;
                }
            }
            running.total()
        }
    };
    (adapter.finish(total), draws.wander, me.sums.count)
}
