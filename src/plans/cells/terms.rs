//! The flocking terms and the Vicsek turns over runs: for each run of one group's agents in a
//! task's [`Runs`], the weighted terms (or the turned headings) and the model adapter, one
//! operation at a time over the whole run, in long loops of vector instructions.
//!
//! Invariant: each agent's request equals its scalar evaluation bit for bit (the same operations
//! in the same order, exact square roots and divisions).

use super::runs::{Column, Runs};
use crate::plans::adapter::Adapter;
use crate::plans::neighbours::positive_finite;
use crate::plans::spec::{ALI, SEP};
use crate::rng::Stream;
use crate::simd::{apply, float_kernel};

/// The flocking terms and the model adapter for the agents at `range` of `r`, one term at a
/// time over the whole run (long loops of vector instructions): the same operations in the same
/// order as [`flock_total`](crate::plans::agent::flock_total) and [`Adapter::finish`] per agent
/// (exact square roots and divisions), so each agent's result equals the scalar evaluation bit
/// for bit.
#[apply(float_kernel!)]
pub(super) fn evaluate_run(
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
/// (`rng::unit_at` on the frame's `key`, as [`AgentRng`](crate::rng::AgentRng) draws it), its
/// summed heading normalised and turned ([`crate::steering::vicsek_heading`]'s operations),
/// times its speed and the weight, then the model adapter, in long loops over the run: each
/// agent equals the scalar evaluation bit for bit.
#[apply(float_kernel!)]
pub(super) fn vicsek_run(
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
