use std::f32::consts::TAU;

use rayon::prelude::*;
use wide::f32x8;

/// Per-group constants the integrator needs, resolved for one time step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct IntegrationParams {
    /// Whether the group moves kinematically.
    pub kinematic: bool,
    /// Velocity factor from drag for this step, `max(0, 1 - drag * dt)` (1 without drag).
    pub damp: f32,
    /// Largest rotation magnitude, radians per second.
    pub max_rotation: f32,
    /// Whether orientation follows the velocity.
    pub face_velocity: bool,
}

/// Mutable views of the agents' motion buffers (all of one length).
#[derive(Debug)]
pub struct MotionState<'a> {
    /// Position x.
    pub pos_x: &'a mut [f32],
    /// Position y.
    pub pos_y: &'a mut [f32],
    /// Velocity x.
    pub vel_x: &'a mut [f32],
    /// Velocity y.
    pub vel_y: &'a mut [f32],
    /// Orientation, radians in `[0, 2pi)`.
    pub orientation: &'a mut [f32],
    /// Rotation, radians per second.
    pub rotation: &'a mut [f32],
}

/// The steering pass's outputs and the per-agent inputs of the integrator.
#[derive(Clone, Copy, Debug)]
pub struct SteeringBuffers<'a> {
    /// Linear x: clamped acceleration (dynamic) or desired velocity (kinematic).
    pub lin_x: &'a [f32],
    /// Linear y.
    pub lin_y: &'a [f32],
    /// Angular: clamped angular acceleration (dynamic) or rotation (kinematic).
    pub ang: &'a [f32],
    /// Per-agent maximum speed.
    pub max_speed: &'a [f32],
    /// Per-agent group index into the parameter table.
    pub group: &'a [u32],
}

/// Speeds below this (units per second) snap to rest. A braking agent's speed otherwise decays
/// geometrically into subnormal numbers, which cost a hundred times more in every operation.
pub const REST_SPEED: f32 = 1e-6;
/// Rotations below this (radians per second) snap to zero, for the same reason.
pub const REST_ROTATION: f32 = 1e-6;

/// Agents per parallel task; a multiple of the SIMD width so lanes never straddle tasks.
const CHUNK: usize = 4096;
const LANES: usize = 8;

/// Maps an orientation into `[0, 2pi)`.
#[inline]
#[must_use]
pub fn wrap_orientation(a: f32) -> f32 {
    if (0.0..TAU).contains(&a) {
        return a;
    }
    if (-TAU..0.0).contains(&a) {
        let w = a + TAU;
        return if w >= TAU { 0.0 } else { w };
    }
    let w = a.rem_euclid(TAU);
    if w >= TAU { 0.0 } else { w }
}

/// Integrates one step in parallel chunks with SIMD lanes. Bit-identical to
/// [`integrate_scalar`] for any thread count.
///
/// # Panics
/// When the slices' lengths differ or a group index is outside `params`.
pub fn integrate(
    state: MotionState<'_>,
    steer: SteeringBuffers<'_>,
    params: &[IntegrationParams],
    dt: f32,
) {
    let n = state.pos_x.len();
    check_lengths(&state, &steer, n);
    (
        state.pos_x.par_chunks_mut(CHUNK),
        state.pos_y.par_chunks_mut(CHUNK),
        state.vel_x.par_chunks_mut(CHUNK),
        state.vel_y.par_chunks_mut(CHUNK),
        state.orientation.par_chunks_mut(CHUNK),
        state.rotation.par_chunks_mut(CHUNK),
        steer.lin_x.par_chunks(CHUNK),
        steer.lin_y.par_chunks(CHUNK),
        steer.ang.par_chunks(CHUNK),
        steer.max_speed.par_chunks(CHUNK),
        steer.group.par_chunks(CHUNK),
    )
        .into_par_iter()
        .for_each(|(px, py, vx, vy, or, rot, lx, ly, ang, ms, grp)| {
            let chunk_state = MotionState {
                pos_x: px,
                pos_y: py,
                vel_x: vx,
                vel_y: vy,
                orientation: or,
                rotation: rot,
            };
            let chunk_steer = SteeringBuffers {
                lin_x: lx,
                lin_y: ly,
                ang,
                max_speed: ms,
                group: grp,
            };
            integrate_chunk(chunk_state, chunk_steer, params, dt);
        });
}

/// The scalar reference integrator: one agent at a time, same operations as [`integrate`].
///
/// # Panics
/// When the slices' lengths differ or a group index is outside `params`.
pub fn integrate_scalar(
    state: MotionState<'_>,
    steer: SteeringBuffers<'_>,
    params: &[IntegrationParams],
    dt: f32,
) {
    let mut state = state;
    let n = state.pos_x.len();
    check_lengths(&state, &steer, n);
    for i in 0..n {
        integrate_one(&mut state, &steer, params, dt, i);
    }
}

fn check_lengths(state: &MotionState<'_>, steer: &SteeringBuffers<'_>, n: usize) {
    for len in [
        state.pos_y.len(),
        state.vel_x.len(),
        state.vel_y.len(),
        state.orientation.len(),
        state.rotation.len(),
        steer.lin_x.len(),
        steer.lin_y.len(),
        steer.ang.len(),
        steer.max_speed.len(),
        steer.group.len(),
    ] {
        assert_eq!(len, n, "integrator buffers must have one length");
    }
}

fn integrate_chunk(
    s: MotionState<'_>,
    st: SteeringBuffers<'_>,
    params: &[IntegrationParams],
    dt: f32,
) {
    let n = s.pos_x.len();
    let dt8 = f32x8::splat(dt);
    let zero = f32x8::ZERO;
    let one = f32x8::ONE;
    let tau = f32x8::splat(TAU);
    let mut i = 0;
    while i < n {
        let lanes = (n - i).min(LANES);
        // Gather the lanes (a short last block is padded with inert zeros).
        let mut kin = [0.0_f32; LANES];
        let mut face = [0.0_f32; LANES];
        let mut damp = [1.0_f32; LANES];
        let mut max_rot = [0.0_f32; LANES];
        for l in 0..lanes {
            let p = &params[st.group[i + l] as usize];
            kin[l] = if p.kinematic { 1.0 } else { 0.0 };
            face[l] = if p.face_velocity { 1.0 } else { 0.0 };
            damp[l] = p.damp;
            max_rot[l] = p.max_rotation;
        }
        let kin = f32x8::from(kin).simd_gt(zero);
        let face = f32x8::from(face).simd_gt(zero);
        let damp = f32x8::from(damp);
        let max_rot = f32x8::from(max_rot);
        let vx = load(s.vel_x, i, lanes);
        let vy = load(s.vel_y, i, lanes);
        let lx = load(st.lin_x, i, lanes);
        let ly = load(st.lin_y, i, lanes);
        let ang = load(st.ang, i, lanes);
        let ms = load(st.max_speed, i, lanes);
        let orient = load(s.orientation, i, lanes);
        let rot = load(s.rotation, i, lanes);

        // Angular part (reads the pre-update velocity in the dynamic model).
        let hx = kin.bitselect(lx, vx);
        let hy = kin.bitselect(ly, vy);
        let moving = (hx * hx + hy * hy).simd_gt(zero);
        let heading = hy.atan2(hx);
        let heading = wrap8(heading.simd_lt(zero).bitselect(heading + tau, heading));
        let rot_kin = clamp8(ang, max_rot);
        let rot_dyn = clamp8(rot + ang * dt8, max_rot);
        let turning = kin.bitselect(rot_kin, rot);
        let integrated = wrap8(orient + turning * dt8);
        let new_orient = face.bitselect(moving.bitselect(heading, orient), integrated);
        let new_rot = kin.bitselect(rot_kin, rot_dyn);
        let new_rot = new_rot
            .abs()
            .simd_lt(f32x8::splat(REST_ROTATION))
            .bitselect(zero, new_rot);

        // Linear part.
        let dvx = (vx + lx * dt8) * damp;
        let dvy = (vy + ly * dt8) * damp;
        let mut nvx = kin.bitselect(lx, dvx);
        let mut nvy = kin.bitselect(ly, dvy);
        let sp_sq = nvx * nvx + nvy * nvy;
        let over = sp_sq.simd_gt(ms * ms);
        let scale = over.bitselect(ms / sp_sq.sqrt(), one);
        nvx = over.bitselect(nvx * scale, nvx);
        nvy = over.bitselect(nvy * scale, nvy);
        let still = sp_sq.simd_lt(f32x8::splat(REST_SPEED * REST_SPEED));
        nvx = still.bitselect(zero, nvx);
        nvy = still.bitselect(zero, nvy);
        let mx = kin.bitselect(nvx, vx);
        let my = kin.bitselect(nvy, vy);
        let px = load(s.pos_x, i, lanes) + mx * dt8;
        let py = load(s.pos_y, i, lanes) + my * dt8;

        store(s.pos_x, i, lanes, px);
        store(s.pos_y, i, lanes, py);
        store(s.vel_x, i, lanes, nvx);
        store(s.vel_y, i, lanes, nvy);
        store(s.orientation, i, lanes, new_orient);
        store(s.rotation, i, lanes, new_rot);
        i += LANES;
    }
}

/// `x` clamped to `[-limit, limit]` (NaN-free inputs).
#[inline(always)]
fn clamp8(x: f32x8, limit: f32x8) -> f32x8 {
    let lo = -limit;
    let x = x.simd_lt(lo).bitselect(lo, x);
    x.simd_gt(limit).bitselect(limit, x)
}

/// Angles into `[0, 2pi)`: one turn added or taken away covers every step the limits allow;
/// anything farther is reduced with `floor`, lane by lane, exactly as [`wrap_one`] does.
#[inline(always)]
fn wrap8(a: f32x8) -> f32x8 {
    let tau = f32x8::splat(TAU);
    let zero = f32x8::ZERO;
    let a = a.simd_ge(tau).bitselect(a - tau, a);
    let a = a.simd_lt(zero).bitselect(a + tau, a);
    let outside = a.simd_lt(zero) | a.simd_ge(tau);
    if outside.any() {
        f32x8::from(a.to_array().map(reduce_turns))
    } else {
        a
    }
}

/// The scalar form of [`wrap8`], operation for operation.
#[inline]
fn wrap_one(a: f32) -> f32 {
    let a = if a >= TAU { a - TAU } else { a };
    let a = if a < 0.0 { a + TAU } else { a };
    reduce_turns(a)
}

/// Whole turns taken away from an angle more than one turn outside `[0, 2pi)`.
#[inline]
fn reduce_turns(a: f32) -> f32 {
    if (0.0..TAU).contains(&a) {
        return a;
    }
    let r = a - TAU * (a / TAU).floor();
    if (0.0..TAU).contains(&r) { r } else { 0.0 }
}

/// One agent, in plain scalar code: the reference the SIMD path is tested against bit for bit.
/// The heading's `atan2` is the same polynomial as the lanes' (lane 0 of it).
fn integrate_one(
    s: &mut MotionState<'_>,
    st: &SteeringBuffers<'_>,
    params: &[IntegrationParams],
    dt: f32,
    i: usize,
) {
    let p = &params[st.group[i] as usize];
    let (vx, vy) = (s.vel_x[i], s.vel_y[i]);
    let (lx, ly) = (st.lin_x[i], st.lin_y[i]);
    let (hx, hy) = if p.kinematic { (lx, ly) } else { (vx, vy) };
    let moving = hx * hx + hy * hy > 0.0;
    let heading = f32x8::splat(hy).atan2(f32x8::splat(hx)).to_array()[0];
    let heading = wrap_one(if heading < 0.0 {
        heading + TAU
    } else {
        heading
    });
    let clamp = |x: f32| {
        let x = if x < -p.max_rotation {
            -p.max_rotation
        } else {
            x
        };
        if x > p.max_rotation {
            p.max_rotation
        } else {
            x
        }
    };
    let rot_kin = clamp(st.ang[i]);
    let rot_dyn = clamp(s.rotation[i] + st.ang[i] * dt);
    let turning = if p.kinematic { rot_kin } else { s.rotation[i] };
    let integrated = wrap_one(s.orientation[i] + turning * dt);
    let orientation = if p.face_velocity {
        if moving { heading } else { s.orientation[i] }
    } else {
        integrated
    };
    let rotation = if p.kinematic { rot_kin } else { rot_dyn };
    let rotation = if rotation.abs() < REST_ROTATION {
        0.0
    } else {
        rotation
    };

    let (mut nvx, mut nvy) = if p.kinematic {
        (lx, ly)
    } else {
        ((vx + lx * dt) * p.damp, (vy + ly * dt) * p.damp)
    };
    let ms = st.max_speed[i];
    let sp_sq = nvx * nvx + nvy * nvy;
    if sp_sq > ms * ms {
        let scale = ms / sp_sq.sqrt();
        nvx *= scale;
        nvy *= scale;
    }
    if sp_sq < REST_SPEED * REST_SPEED {
        (nvx, nvy) = (0.0, 0.0);
    }
    let (mx, my) = if p.kinematic { (nvx, nvy) } else { (vx, vy) };
    let (px, py) = (s.pos_x[i] + mx * dt, s.pos_y[i] + my * dt);
    s.pos_x[i] = px;
    s.pos_y[i] = py;
    s.vel_x[i] = nvx;
    s.vel_y[i] = nvy;
    s.orientation[i] = orientation;
    s.rotation[i] = rotation;
}

#[inline(always)]
fn load(s: &[f32], i: usize, lanes: usize) -> f32x8 {
    let mut a = [0.0_f32; LANES];
    a[..lanes].copy_from_slice(&s[i..i + lanes]);
    f32x8::from(a)
}

#[inline(always)]
fn store(s: &mut [f32], i: usize, lanes: usize, v: f32x8) {
    s[i..i + lanes].copy_from_slice(&v.to_array()[..lanes]);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::AgentRng;

    fn params() -> Vec<IntegrationParams> {
        let mut v = Vec::new();
        for kinematic in [false, true] {
            for face_velocity in [false, true] {
                for (damp, max_rotation) in [(1.0, 3.0), (0.9, 500.0)] {
                    v.push(IntegrationParams {
                        kinematic,
                        damp,
                        max_rotation,
                        face_velocity,
                    });
                }
            }
        }
        v
    }

    #[test]
    fn simd_lanes_equal_the_scalar_reference_bit_for_bit() {
        let n = 1037; // not a multiple of the lane count
        let mut r = AgentRng::new(5, 0, 0, 0);
        let mut f = |scale: f32| r.signed() * scale;
        let mut cols: Vec<Vec<f32>> = (0..6).map(|_| Vec::new()).collect();
        let (mut lx, mut ly, mut ang, mut ms, mut grp) = (vec![], vec![], vec![], vec![], vec![]);
        for i in 0..n {
            cols[0].push(f(100.0));
            cols[1].push(f(100.0));
            // Some agents at rest, some fast.
            let v = if i % 7 == 0 { 0.0 } else { 10.0 };
            cols[2].push(f(v));
            cols[3].push(f(v));
            cols[4].push((f(1.0) + 1.0) * TAU * 0.5);
            cols[5].push(f(600.0));
            lx.push(if i % 11 == 0 { 0.0 } else { f(30.0) });
            ly.push(f(30.0));
            ang.push(f(1000.0));
            ms.push(1.0 + (f(1.0) + 1.0) * 4.0);
            grp.push((i % 8) as u32);
        }
        let p = params();
        let dt = 0.05;
        let run = |simd: bool| {
            let mut c = cols.clone();
            let [px, py, vx, vy, or, rot] = &mut c[..] else {
                unreachable!()
            };
            let state = MotionState {
                pos_x: px,
                pos_y: py,
                vel_x: vx,
                vel_y: vy,
                orientation: or,
                rotation: rot,
            };
            let steer = SteeringBuffers {
                lin_x: &lx,
                lin_y: &ly,
                ang: &ang,
                max_speed: &ms,
                group: &grp,
            };
            if simd {
                integrate(state, steer, &p, dt)
            } else {
                integrate_scalar(state, steer, &p, dt)
            }
            c
        };
        let (a, b) = (run(true), run(false));
        for (ca, cb) in a.iter().zip(&b) {
            for (x, y) in ca.iter().zip(cb) {
                assert_eq!(x.to_bits(), y.to_bits());
            }
        }
        for &o in &a[4] {
            assert!((0.0..TAU).contains(&o), "orientation {o}");
        }
        for i in 0..n {
            let speed = a[2][i].hypot(a[3][i]);
            assert!(speed <= ms[i] * (1.0 + 1e-6), "speed {speed} > {}", ms[i]);
        }
    }
}
