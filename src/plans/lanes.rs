//! A lone seek, arrive or wander in lanes: the [`PlanKind::Seek`], [`PlanKind::Arrive`] and
//! [`PlanKind::Wander`] plans, a block of [`LANES`] consecutive agents of one group at a time.
//! Each block gathers its agents' columns ([`put`]), evaluates every lane with the operations of
//! the per-agent path in its order (each case computed in every lane and the lane's own case
//! selected, so that the loops run in vector lanes), and writes the outputs back ([`take`]).
//!
//! Invariants: each lane gives the bits of [`super::agent`]'s evaluation of its agent; a lane the
//! vector form does not serve exactly (an angle beyond the polynomial's range, an agent at rest,
//! a request that overflowed) takes the per-agent path.

use super::agent::steer_agent;
use super::neighbours::LANES;
use super::out::OutChunks;
use super::plan::PlanKind;
use super::view::SteerView;
use crate::rng::Stream;
use crate::simd::{apply, float_kernel};
use crate::steering::{self, Target};

/// The agents at storage indices `from..to`, all of lane group `g` (seek, arrive or wander), a
/// block of [`LANES`] at a time into the chunks starting at `base` (a seek or arrive run writes
/// the angular outputs and wander angles too only when `turns`). Compiled for each dispatch
/// target with the lane evaluations, the model adapter and the copies inlined: the whole run is
/// vector code of the processor's width (a baseline build of the glue around a dispatched
/// kernel cost more than the kernel).
#[apply(float_kernel!)]
pub(super) fn lane_run(
    view: &SteerView,
    g: usize,
    (from, to): (usize, usize),
    base: usize,
    (lx, ly, an, wa, nb): OutChunks,
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

/// What every block of lanes holds: which agents fill it, and the velocities and speed limits
/// each lane evaluation reads.
#[derive(Debug, Default)]
struct LaneAgents {
    len: usize,
    group: usize,
    /// The storage index of the first lane's agent.
    first: usize,
    vx: [f32; LANES],
    vy: [f32; LANES],
    max_speed: [f32; LANES],
}

impl LaneAgents {
    /// Takes the `len` (at most [`LANES`]) agents from storage index `i` on, all of `group`.
    #[inline(always)]
    fn fill(&mut self, view: &SteerView, group: usize, i: usize, len: usize) {
        let a = view.agents;
        (self.group, self.first, self.len) = (group, i, len);
        put(&mut self.vx, &a.vel_x[i..], len);
        put(&mut self.vy, &a.vel_y[i..], len);
        put(&mut self.max_speed, &a.max_speed[i..], len);
    }

    /// Writes the weighted requests `(tx, ty)`, finished by the plan's model adapter, and zero
    /// neighbours found into the chunks starting at `base`; returns how many lanes are filled
    /// and the first one's offset in the chunks.
    #[inline(always)]
    fn write_linear(
        &self,
        view: &SteerView,
        (tx, ty): ([f32; LANES], [f32; LANES]),
        (lx, ly, nb): (&mut [f32], &mut [f32], &mut [f32]),
        base: usize,
    ) -> (usize, usize) {
        let (ox, oy) = view.plans[self.group].adapter.finish_lanes(tx, ty);
        let (n, k0) = (self.len, self.first - base);
        take(&mut lx[k0..], &ox, n);
        take(&mut ly[k0..], &oy, n);
        take(&mut nb[k0..], &[0.0; LANES], n);
        (n, k0)
    }
}

/// Up to [`LANES`] consecutive agents of one seek or arrive plan, evaluated together.
#[derive(Debug, Default)]
struct SeekLanes {
    agents: LaneAgents,
    px: [f32; LANES],
    py: [f32; LANES],
    /// The point each lane seeks: the plan's point or slot, or the agent's own target.
    tx: [f32; LANES],
    ty: [f32; LANES],
}

impl SeekLanes {
    /// Takes the `len` (at most [`LANES`]) agents from storage index `i` on, all of `group`.
    #[inline(always)]
    fn fill(&mut self, view: &SteerView, group: usize, i: usize, len: usize) {
        let a = view.agents;
        self.agents.fill(view, group, i, len);
        put(&mut self.px, &a.pos_x[i..], len);
        put(&mut self.py, &a.pos_y[i..], len);
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
        (lx, ly, an, wa, nb): OutChunks,
        base: usize,
        turns: bool,
    ) {
        let plan = &view.plans[self.agents.group];
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
        let (n, k0) = self.agents.write_linear(view, (tx, ty), (lx, ly, nb), base);
        if turns {
            let first = self.agents.first;
            take(&mut an[k0..], &[0.0; LANES], n);
            wa[k0..k0 + n].copy_from_slice(&view.agents.wander[first..first + n]);
        }
        self.agents.len = 0;
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
        let s = l.agents.max_speed[k] / d_sq.sqrt();
        let (fx, fy) = if kinematic {
            (to_x * s, to_y * s)
        } else {
            (to_x * s - l.agents.vx[k], to_y * s - l.agents.vy[k])
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
        let m = l.agents.max_speed[k];
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
            let (vx, vy) = (l.agents.vx[k], l.agents.vy[k]);
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
            let f = crate::steering::kinematic_arrive(p, resolved, l.agents.max_speed[k], params);
            tx[k] = 0.0 + f.x * weight;
            ty[k] = 0.0 + f.y * weight;
        }
    }
    (tx, ty)
}

/// Up to [`LANES`] consecutive agents of one wander plan, evaluated together.
#[derive(Debug, Default)]
struct WanderLanes {
    agents: LaneAgents,
    id: [u32; LANES],
    orientation: [f32; LANES],
    wander: [f32; LANES],
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
        self.agents.fill(view, group, i, len);
        for (l, id) in a.ids[i..i + len].iter().enumerate() {
            self.id[l] = id.0;
        }
        put(&mut self.orientation, &a.orientation[i..], len);
        put(&mut self.wander, &a.wander[i..], len);
    }

    /// Evaluates the filled lanes and writes their outputs into the chunks starting at `base`;
    /// lanes the vector form does not serve exactly take [`steer_agent`].
    #[inline(always)]
    fn flush(&mut self, view: &SteerView, (lx, ly, an, wa, nb): OutChunks, base: usize) {
        let group = self.agents.group;
        let plan = &view.plans[group];
        let PlanKind::Wander { params, weight } = plan.kind else {
            unreachable!("only wander plans are gathered")
        };
        let key = crate::rng::frame_key(view.seed, view.frame);
        let o = if plan.adapter.kinematic {
            let max_rotation = view.profiles[group].max_rotation;
            kinematic_wander_lanes(self, key, max_rotation, weight)
        } else {
            wander_lanes(self, key, &params, view.dt, weight)
        };
        let (n, k0) = self
            .agents
            .write_linear(view, (o.tx, o.ty), (lx, ly, nb), base);
        take(&mut an[k0..], &o.ang, n);
        take(&mut wa[k0..], &o.angle, n);
        for l in (0..n).filter(|&l| !o.exact[l]) {
            let (st, w, count) = steer_agent(view, self.agents.first + l);
            let k = k0 + l;
            (lx[k], ly[k], an[k], wa[k], nb[k]) = (st.linear.x, st.linear.y, st.angular, w, count);
        }
        self.agents.len = 0;
    }
}

/// Copies the first `len` of `from` into `lanes`: a whole block as one vector move (a copy of a
/// length known only at run time is a library call).
#[inline(always)]
pub(crate) fn put(lanes: &mut [f32; LANES], from: &[f32], len: usize) {
    if len == LANES {
        *lanes = from[..LANES].try_into().expect("a whole block");
    } else {
        lanes[..len].copy_from_slice(&from[..len]);
    }
}

/// Copies the first `len` lanes into `to`, as [`put`] does the other way.
#[inline(always)]
pub(crate) fn take(to: &mut [f32], lanes: &[f32; LANES], len: usize) {
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
        let (vx, vy) = (c * l.agents.max_speed[k], s * l.agents.max_speed[k]);
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
        let (vx, vy) = (l.agents.vx[k], l.agents.vy[k]);
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
        let (fx, fy) = (
            nx * l.agents.max_speed[k] - vx,
            ny * l.agents.max_speed[k] - vy,
        );
        o.tx[k] = 0.0 + fx * weight;
        o.ty[k] = 0.0 + fy * weight;
        o.angle[k] = a;
        o.exact[k] = moving & within & (o.tx[k] * o.tx[k] + o.ty[k] * o.ty[k]).is_finite();
    }
    o
}
