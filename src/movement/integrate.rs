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
            integrate_chunk(chunk_state, chunk_steer, params, dt, true);
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
    let n = state.pos_x.len();
    check_lengths(&state, &steer, n);
    integrate_chunk(state, steer, params, dt, false);
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
    simd: bool,
) {
    let n = s.pos_x.len();
    // Angular part first: it reads the pre-update velocity (dynamic model, face velocity). The
    // headings of eight agents at a time come from one vector atan2; the scalar reference takes
    // lane 0 of the same function, so both paths give the same bits.
    let mut k = 0;
    while k < n {
        let lanes = if simd { (n - k).min(LANES) } else { 1 };
        let mut hx = [0.0_f32; LANES];
        let mut hy = [0.0_f32; LANES];
        for l in 0..lanes {
            let i = k + l;
            let p = &params[st.group[i] as usize];
            (hx[l], hy[l]) = if p.kinematic {
                (st.lin_x[i], st.lin_y[i])
            } else {
                (s.vel_x[i], s.vel_y[i])
            };
        }
        let heading = f32x8::from(hy).atan2(f32x8::from(hx)).to_array();
        for l in 0..lanes {
            let i = k + l;
            let p = &params[st.group[i] as usize];
            let moving = hx[l] * hx[l] + hy[l] * hy[l] > 0.0;
            if p.face_velocity && moving {
                s.orientation[i] = wrap_orientation(heading[l]);
            }
            if p.kinematic {
                let rot = st.ang[i].clamp(-p.max_rotation, p.max_rotation);
                if !p.face_velocity {
                    s.orientation[i] = wrap_orientation(s.orientation[i] + rot * dt);
                }
                s.rotation[i] = rot;
            } else {
                if !p.face_velocity {
                    s.orientation[i] = wrap_orientation(s.orientation[i] + s.rotation[i] * dt);
                }
                s.rotation[i] =
                    (s.rotation[i] + st.ang[i] * dt).clamp(-p.max_rotation, p.max_rotation);
            }
        }
        k += lanes;
    }
    // Linear part.
    let simd_end = if simd { n - n % LANES } else { 0 };
    let dt8 = f32x8::splat(dt);
    let one = f32x8::splat(1.0);
    let zero = f32x8::splat(0.0);
    let mut i = 0;
    while i < simd_end {
        let mut kin = [0.0_f32; LANES];
        let mut damp = [0.0_f32; LANES];
        for l in 0..LANES {
            let p = &params[st.group[i + l] as usize];
            kin[l] = if p.kinematic { 1.0 } else { 0.0 };
            damp[l] = p.damp;
        }
        let kin = f32x8::from(kin).simd_gt(zero);
        let damp = f32x8::from(damp);
        let vx = load(s.vel_x, i);
        let vy = load(s.vel_y, i);
        let lx = load(st.lin_x, i);
        let ly = load(st.lin_y, i);
        let ms = load(st.max_speed, i);
        let dvx = (vx + lx * dt8) * damp;
        let dvy = (vy + ly * dt8) * damp;
        let mut nvx = kin.bitselect(lx, dvx);
        let mut nvy = kin.bitselect(ly, dvy);
        let sp_sq = nvx * nvx + nvy * nvy;
        let over = sp_sq.simd_gt(ms * ms);
        let scale = over.bitselect(ms / sp_sq.sqrt(), one);
        nvx = over.bitselect(nvx * scale, nvx);
        nvy = over.bitselect(nvy * scale, nvy);
        let mx = kin.bitselect(nvx, vx);
        let my = kin.bitselect(nvy, vy);
        store(s.pos_x, i, load(s.pos_x, i) + mx * dt8);
        store(s.pos_y, i, load(s.pos_y, i) + my * dt8);
        store(s.vel_x, i, nvx);
        store(s.vel_y, i, nvy);
        i += LANES;
    }
    for i in simd_end..n {
        let p = &params[st.group[i] as usize];
        let (vx, vy) = (s.vel_x[i], s.vel_y[i]);
        let (lx, ly) = (st.lin_x[i], st.lin_y[i]);
        let ms = st.max_speed[i];
        let (mut nvx, mut nvy) = if p.kinematic {
            (lx, ly)
        } else {
            ((vx + lx * dt) * p.damp, (vy + ly * dt) * p.damp)
        };
        let sp_sq = nvx * nvx + nvy * nvy;
        if sp_sq > ms * ms {
            let scale = ms / sp_sq.sqrt();
            nvx *= scale;
            nvy *= scale;
        }
        let (mx, my) = if p.kinematic { (nvx, nvy) } else { (vx, vy) };
        s.pos_x[i] += mx * dt;
        s.pos_y[i] += my * dt;
        s.vel_x[i] = nvx;
        s.vel_y[i] = nvy;
    }
}

#[inline(always)]
fn load(s: &[f32], i: usize) -> f32x8 {
    let a: [f32; LANES] = s[i..i + LANES].try_into().expect("8 lanes");
    f32x8::from(a)
}

#[inline(always)]
fn store(s: &mut [f32], i: usize, v: f32x8) {
    s[i..i + LANES].copy_from_slice(&v.to_array());
}
