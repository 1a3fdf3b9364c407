//! The integrator of both movement models: it turns each agent's steering request (a force in
//! the dynamic model, a desired velocity in the kinematic one) into its new velocity, position
//! and orientation over one time step, clamped to its group's limits.
//!
//! Invariants: every agent's update reads its own values and its group's constants only, so
//! pieces of any size on any number of threads give the same bits; speeds never exceed the
//! agent's maximum, and orientations stay in `[0, 2pi)`.

use std::f32::consts::TAU;

use crate::simd::{apply, float_kernel};
use rayon::iter::Either;
use rayon::prelude::*;

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
    /// The group's maximum speed: every one of its agents' when
    /// [`SteeringBuffers::max_speed`] is empty (no agent has a speed of its own).
    pub max_speed: f32,
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
    /// Rotation, radians per second; empty when every agent's is `+0.0` and no angular output
    /// is given ([`SteeringBuffers::ang`] empty): it then stays `+0.0`, and is neither read nor
    /// written.
    pub rotation: &'a mut [f32],
}

impl MotionState<'_> {
    /// The same buffers, borrowed again for a shorter time.
    pub(crate) fn reborrow(&mut self) -> MotionState<'_> {
        MotionState {
            pos_x: self.pos_x,
            pos_y: self.pos_y,
            vel_x: self.vel_x,
            vel_y: self.vel_y,
            orientation: self.orientation,
            rotation: self.rotation,
        }
    }
}

/// The steering pass's outputs and the per-agent inputs of the integrator.
#[derive(Clone, Copy, Debug)]
pub struct SteeringBuffers<'a> {
    /// Linear x: clamped acceleration (dynamic) or desired velocity (kinematic).
    pub lin_x: &'a [f32],
    /// Linear y.
    pub lin_y: &'a [f32],
    /// Angular: clamped angular acceleration (dynamic) or rotation (kinematic); empty when it
    /// is zero for every agent (nothing is read then).
    pub ang: &'a [f32],
    /// Per-agent maximum speed; empty when every agent's is its group's
    /// ([`IntegrationParams::max_speed`]), which then is not read per agent.
    pub max_speed: &'a [f32],
    /// Per-agent group index into the parameter table.
    pub group: &'a [u32],
}

/// Speeds below this (units per second) snap to rest. A braking agent's speed otherwise decays
/// geometrically into subnormal numbers, which cost a hundred times more in every operation.
pub const REST_SPEED: f32 = 1e-6;
/// Rotations below this (radians per second) snap to zero, for the same reason.
pub const REST_ROTATION: f32 = 1e-6;

/// The most agents per parallel task; a multiple of the SIMD width so lanes never straddle
/// tasks.
const CHUNK: usize = 4096;
/// The fewest agents per parallel task (a multiple of the SIMD width too).
const MIN_CHUNK: usize = 1024;

/// Agents per task for `n` agents: [`CHUNK`], or fewer where whole chunks would load the
/// threads unevenly (10,000 agents in chunks of 4,096 are one thread's 4,096 and another's
/// 5,904): about four tasks per thread, never fewer agents than [`MIN_CHUNK`].
fn chunk_len(n: usize) -> usize {
    let even = n.div_ceil(4 * rayon::current_num_threads());
    even.next_multiple_of(LANES).clamp(MIN_CHUNK, CHUNK)
}
const LANES: usize = 16;

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
/// When the slices' lengths differ (an empty `ang`, `max_speed` or, with an empty `ang`,
/// `rotation` aside) or a group index is outside `params` (with one entry, the indices are not
/// read).
pub fn integrate(
    state: MotionState<'_>,
    steer: SteeringBuffers<'_>,
    params: &[IntegrationParams],
    dt: f32,
) {
    integrate_then(state, steer, params, dt, &|_| {}, None);
}

/// Fills the linear requests of the agents `base..base + x.len()` into `(x, y)`.
pub(crate) type LinearSource<'s> = &'s (dyn Fn(usize, &mut [f32], &mut [f32]) + Sync);

thread_local! {
    /// A task's linear requests from a [`LinearSource`], reused across tasks and steps.
    static LINEAR: std::cell::RefCell<(Vec<f32>, Vec<f32>)> =
        const { std::cell::RefCell::new((Vec::new(), Vec::new())) };
}

/// [`integrate`], then `then` on each task's agents (positions and velocities) while they are
/// still in cache: the same values as `then` over all agents after [`integrate`], without a
/// second pass through memory (the step's world bounds, for one).
///
/// With `linear`, each task takes its agents' linear requests from it, into a buffer of the
/// task's that stays in cache (`steer.lin_x` and `steer.lin_y` are not read and may be empty):
/// where the requests are a gather from another order, the gather and the integration then cost
/// one pass through memory instead of a stored copy and a second pass.
///
/// Returns whether some rotation it wrote is other than `+0.0`.
///
/// # Panics
/// As [`integrate`].
pub(crate) fn integrate_then(
    state: MotionState<'_>,
    steer: SteeringBuffers<'_>,
    params: &[IntegrationParams],
    dt: f32,
    then: &(dyn Fn(&mut MotionState<'_>) + Sync),
    linear: Option<LinearSource<'_>>,
) -> bool {
    let n = state.pos_x.len();
    check_lengths(&state, &steer, n, linear.is_some());
    let chunk = chunk_len(n);
    // Without rotations, each task gets an empty buffer.
    let rotations = if state.rotation.is_empty() {
        Either::Right(rayon::iter::repeat_n((), n.div_ceil(chunk)).map(|()| None))
    } else {
        Either::Left(state.rotation.par_chunks_mut(chunk).map(Some))
    };
    (
        state.pos_x.par_chunks_mut(chunk),
        state.pos_y.par_chunks_mut(chunk),
        state.vel_x.par_chunks_mut(chunk),
        state.vel_y.par_chunks_mut(chunk),
        state.orientation.par_chunks_mut(chunk),
        rotations,
        steer.group.par_chunks(chunk),
    )
        .into_par_iter()
        .enumerate()
        .map(|(c, (px, py, vx, vy, or, rot, grp))| {
            let range = c * chunk..c * chunk + px.len();
            let (ang, ms) = (part(steer.ang, &range), part(steer.max_speed, &range));
            let mut chunk_state = MotionState {
                pos_x: px,
                pos_y: py,
                vel_x: vx,
                vel_y: vy,
                orientation: or,
                rotation: rot.unwrap_or_default(),
            };
            let task = |lin_x: &[f32], lin_y: &[f32], state: MotionState<'_>| {
                let steer = SteeringBuffers {
                    lin_x,
                    lin_y,
                    ang,
                    max_speed: ms,
                    group: grp,
                };
                integrate_chunk(state, steer, params, dt)
            };
            let turning = match linear {
                Some(fill) => LINEAR.with_borrow_mut(|(x, y)| {
                    x.resize(chunk, 0.0);
                    y.resize(chunk, 0.0);
                    let (x, y) = (&mut x[..range.len()], &mut y[..range.len()]);
                    fill(range.start, x, y);
                    task(x, y, chunk_state.reborrow())
                }),
                None => task(
                    &steer.lin_x[range.clone()],
                    &steer.lin_y[range],
                    chunk_state.reborrow(),
                ),
            };
            then(&mut chunk_state);
            turning
        })
        .reduce(|| false, |a, b| a | b)
}

/// A task's `range` of an optional buffer: an empty one stays empty (nothing is read per agent).
fn part<'s>(v: &'s [f32], range: &std::ops::Range<usize>) -> &'s [f32] {
    if v.is_empty() { v } else { &v[range.clone()] }
}

/// [`part`] of a mutable buffer.
fn part_mut(v: &mut [f32], range: std::ops::Range<usize>) -> &mut [f32] {
    if v.is_empty() { v } else { &mut v[range] }
}

/// The scalar reference integrator: one agent at a time, same operations as [`integrate`].
///
/// # Panics
/// When the slices' lengths differ (an empty `ang` aside) or a group index is outside `params`
/// (with one entry, the indices are not read).
pub fn integrate_scalar(
    state: MotionState<'_>,
    steer: SteeringBuffers<'_>,
    params: &[IntegrationParams],
    dt: f32,
) {
    let mut state = state;
    let n = state.pos_x.len();
    check_lengths(&state, &steer, n, false);
    for i in 0..n {
        integrate_one(&mut state, &steer, params, dt, i);
    }
}

/// Panics unless every buffer has `n` values (the linear requests' unless they are
/// `gathered`, from elsewhere).
fn check_lengths(state: &MotionState<'_>, steer: &SteeringBuffers<'_>, n: usize, gathered: bool) {
    let lin = |v: &[f32]| if gathered { n } else { v.len() };
    for len in [
        state.pos_y.len(),
        state.vel_x.len(),
        state.vel_y.len(),
        state.orientation.len(),
        if state.rotation.is_empty() && steer.ang.is_empty() {
            n
        } else {
            state.rotation.len()
        },
        lin(steer.lin_x),
        lin(steer.lin_y),
        if steer.ang.is_empty() {
            n
        } else {
            steer.ang.len()
        },
        if steer.max_speed.is_empty() {
            n
        } else {
            steer.max_speed.len()
        },
        steer.group.len(),
    ] {
        assert_eq!(len, n, "integrator buffers must have one length");
    }
}

/// One agent's inputs to the integrator.
#[derive(Clone, Copy, Debug, Default)]
struct Lane {
    kinematic: bool,
    face_velocity: bool,
    damp: f32,
    max_rotation: f32,
    px: f32,
    py: f32,
    vx: f32,
    vy: f32,
    lx: f32,
    ly: f32,
    ang: f32,
    max_speed: f32,
    orientation: f32,
    rotation: f32,
}

/// One agent's state after the step: position, velocity, orientation, rotation.
type Out = [f32; 6];

/// The step of one agent, branch-free (every `if` is a select), so that the chunk's loop over
/// [`LANES`] agents compiles to vector instructions and the scalar reference, which calls the
/// same function, equals it bit for bit.
#[inline(always)]
fn step_lane(l: &Lane, dt: f32) -> Out {
    // Angular part (reads the pre-update velocity in the dynamic model).
    let (hx, hy) = if l.kinematic {
        (l.lx, l.ly)
    } else {
        (l.vx, l.vy)
    };
    let moving = hx * hx + hy * hy > 0.0;
    let heading = heading_turn(atan2(hy, hx));
    let clamp = |x: f32| {
        let x = if x < -l.max_rotation {
            -l.max_rotation
        } else {
            x
        };
        if x > l.max_rotation {
            l.max_rotation
        } else {
            x
        }
    };
    let rot_kin = clamp(l.ang);
    let rot_dyn = clamp(l.rotation + l.ang * dt);
    let turning = if l.kinematic { rot_kin } else { l.rotation };
    let integrated = wrap_turn(l.orientation + turning * dt);
    let orientation = if l.face_velocity {
        if moving { heading } else { l.orientation }
    } else {
        integrated
    };
    let rotation = if l.kinematic { rot_kin } else { rot_dyn };
    let rotation = if rotation.abs() < REST_ROTATION {
        0.0
    } else {
        rotation
    };

    // Linear part.
    let (dvx, dvy) = ((l.vx + l.lx * dt) * l.damp, (l.vy + l.ly * dt) * l.damp);
    let (nvx, nvy) = if l.kinematic {
        (l.lx, l.ly)
    } else {
        (dvx, dvy)
    };
    let sp_sq = nvx * nvx + nvy * nvy;
    let over = sp_sq > l.max_speed * l.max_speed;
    let scale = l.max_speed / sp_sq.sqrt();
    let (nvx, nvy) = if over {
        (nvx * scale, nvy * scale)
    } else {
        (nvx, nvy)
    };
    let still = sp_sq < REST_SPEED * REST_SPEED;
    let (nvx, nvy) = if still { (0.0, 0.0) } else { (nvx, nvy) };
    let (mx, my) = if l.kinematic {
        (nvx, nvy)
    } else {
        (l.vx, l.vy)
    };
    [
        l.px + mx * dt,
        l.py + my * dt,
        nvx,
        nvy,
        orientation,
        rotation,
    ]
}

/// `atan2(y, x)` in `(-pi, pi]` to a few units in the last place, branch-free: the octant
/// reduction to `a = min / max` in `[0, 1]`, Cephes' reduction of `a > tan(pi / 8)` to
/// `(a - 1) / (a + 1)` around `pi / 4`, and its degree-9 odd polynomial. `(0, 0)` gives 0.
///
/// One division: the reduced argument is `(min - max) / (min + max)` beyond `tan(pi / 8)`
/// (the same value as `(a - 1) / (a + 1)`, one rounding fewer) and `min / max` below it.
/// Divisions are most of the integrator's time on processors with slow vector division.
#[inline(always)]
fn atan2(y: f32, x: f32) -> f32 {
    use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};
    let (ax, ay) = (x.abs(), y.abs());
    let (hi, lo) = if ay > ax { (ay, ax) } else { (ax, ay) };
    let far = lo > 0.414_213_57 * hi;
    let (base, num, den) = if far {
        (FRAC_PI_4, lo - hi, lo + hi)
    } else {
        (0.0, lo, hi)
    };
    let t = if hi > 0.0 { num / den } else { 0.0 };
    let z = t * t;
    let p = 8.053_744_5e-2_f32;
    let p = p * z - 1.387_768_6e-1;
    let p = p * z + 1.997_771_1e-1;
    let p = p * z - 3.333_295e-1;
    let r = base + (p * z * t + t);
    let r = if ay > ax { FRAC_PI_2 - r } else { r };
    let r = if x < 0.0 { PI - r } else { r };
    if y < 0.0 { -r } else { r }
}

/// An [`atan2`] angle (in `[-pi, pi]`) into `[0, 2pi)`, with the bits of `wrap_turn` of it
/// plus a turn where negative: that sum lies in `[0, 2pi]` (or is -0, kept), so at most one turn
/// comes off, and `wrap_turn`'s general path is never needed; NaN (from infinite components)
/// gives 0, as there.
#[inline(always)]
fn heading_turn(h: f32) -> f32 {
    let a = if h < 0.0 { h + TAU } else { h };
    let a = if a >= TAU { a - TAU } else { a };
    if a.is_nan() { 0.0 } else { a }
}

/// An angle into `[0, 2pi)`: one turn added or taken away covers every step the limits allow;
/// anything farther is reduced with `floor` (computed in every lane, selected where needed).
// `&` rather than a range test: no short circuit, so no branch in the lanes.
#[allow(clippy::manual_range_contains)]
#[inline(always)]
fn wrap_turn(a: f32) -> f32 {
    let a = if a >= TAU { a - TAU } else { a };
    let a = if a < 0.0 { a + TAU } else { a };
    let inside = (a >= 0.0) & (a < TAU);
    // A product, not a quotient: the lanes that take this path are rare, and a division in
    // every lane costs more than the rest of the function.
    let r = a - TAU * (a * (1.0 / TAU)).floor();
    let r = if (r >= 0.0) & (r < TAU) { r } else { 0.0 };
    if inside { a } else { r }
}

/// One task's agents, [`LANES`] at a time after a first block up to the positions' first cache
/// line (runtime dispatch: clones for AVX-512, AVX2 + FMA and AVX, the first the processor has,
/// else the baseline x86-64 build; the same operations in every clone).
#[apply(float_kernel!)]
fn integrate_chunk(
    s: MotionState<'_>,
    st: SteeringBuffers<'_>,
    params: &[IntegrationParams],
    dt: f32,
) -> bool {
    let n = s.pos_x.len();
    // Whether some rotation written is other than +0.
    let mut turning = false;
    // A short first block up to the first cache line of the positions, so that the whole blocks
    // after it load and store whole lines (`crate::cache_lines`).
    const _: () = assert!(LANES == crate::cache_lines::F32_PER_LINE);
    let lead = crate::cache_lines::lead(s.pos_x);
    let mut i = 0;
    while i < n {
        let lanes = if i == 0 && lead > 0 {
            lead.min(n)
        } else {
            (n - i).min(LANES)
        };
        // Structure of arrays, so that the loop over lanes compiles to vector instructions; a
        // short block (the first, up to a cache line, or the last) is padded with agents at
        // rest, whose results are not stored.
        let mut kinematic = [false; LANES];
        let mut face = [false; LANES];
        let mut damp = [1.0_f32; LANES];
        let mut max_rot = [0.0_f32; LANES];
        // One group, or a block of one group (groups mostly sit in runs): its parameters in
        // every lane; with one group no group index is read.
        let one = match params {
            [p] => Some(p),
            _ => {
                let groups = &st.group[i..i + lanes];
                let g = groups[0];
                groups.iter().all(|&h| h == g).then(|| &params[g as usize])
            }
        };
        if let Some(p) = one {
            (kinematic, face) = ([p.kinematic; LANES], [p.face_velocity; LANES]);
            (damp, max_rot) = ([p.damp; LANES], [p.max_rotation; LANES]);
        } else {
            for k in 0..lanes {
                let p = &params[st.group[i + k] as usize];
                kinematic[k] = p.kinematic;
                face[k] = p.face_velocity;
                damp[k] = p.damp;
                max_rot[k] = p.max_rotation;
            }
        }
        // A whole block is one vector move; a copy of a length known only at run time would
        // be a library call per buffer and block.
        let load = |v: &[f32]| {
            if lanes == LANES {
                <[f32; LANES]>::try_from(&v[i..i + LANES]).expect("a whole block")
            } else {
                let mut a = [0.0_f32; LANES];
                a[..lanes].copy_from_slice(&v[i..i + lanes]);
                a
            }
        };
        let (px, py, vx, vy) = (load(s.pos_x), load(s.pos_y), load(s.vel_x), load(s.vel_y));
        let ang = if st.ang.is_empty() {
            [0.0; LANES]
        } else {
            load(st.ang)
        };
        let (lx, ly) = (load(st.lin_x), load(st.lin_y));
        let ms = match (st.max_speed.is_empty(), one) {
            (false, _) => load(st.max_speed),
            (true, Some(p)) => [p.max_speed; LANES],
            (true, None) => {
                std::array::from_fn(|k| params[st.group[i + k.min(lanes - 1)] as usize].max_speed)
            }
        };
        let orient = load(s.orientation);
        let rot = if s.rotation.is_empty() {
            [0.0; LANES]
        } else {
            load(s.rotation)
        };
        let mut out = [[0.0_f32; LANES]; 6];
        for k in 0..LANES {
            let l = Lane {
                kinematic: kinematic[k],
                face_velocity: face[k],
                damp: damp[k],
                max_rotation: max_rot[k],
                px: px[k],
                py: py[k],
                vx: vx[k],
                vy: vy[k],
                lx: lx[k],
                ly: ly[k],
                ang: ang[k],
                max_speed: ms[k],
                orientation: orient[k],
                rotation: rot[k],
            };
            let o = step_lane(&l, dt);
            for (v, &x) in out.iter_mut().zip(&o) {
                v[k] = x;
            }
        }
        let range = i..i + lanes;
        if !s.rotation.is_empty() {
            turning |= out[5][..lanes].iter().any(|r| r.to_bits() != 0);
        }
        let dst = [
            &mut s.pos_x[range.clone()],
            &mut s.pos_y[range.clone()],
            &mut s.vel_x[range.clone()],
            &mut s.vel_y[range.clone()],
            &mut s.orientation[range.clone()],
            part_mut(s.rotation, range),
        ];
        for (d, v) in dst.into_iter().zip(&out) {
            if d.is_empty() {
                continue;
            }
            if lanes == LANES {
                d.copy_from_slice(v);
            } else {
                d.copy_from_slice(&v[..lanes]);
            }
        }
        i += lanes;
    }
    turning
}

/// Agent `i`'s inputs.
#[inline(always)]
fn lane(
    s: &MotionState<'_>,
    st: &SteeringBuffers<'_>,
    params: &[IntegrationParams],
    i: usize,
) -> Lane {
    // With one entry the group indices are not read, as in the lanes.
    let p = match params {
        [p] => p,
        _ => &params[st.group[i] as usize],
    };
    Lane {
        kinematic: p.kinematic,
        face_velocity: p.face_velocity,
        damp: p.damp,
        max_rotation: p.max_rotation,
        px: s.pos_x[i],
        py: s.pos_y[i],
        vx: s.vel_x[i],
        vy: s.vel_y[i],
        lx: st.lin_x[i],
        ly: st.lin_y[i],
        ang: st.ang.get(i).copied().unwrap_or(0.0),
        max_speed: st.max_speed.get(i).copied().unwrap_or(p.max_speed),
        orientation: s.orientation[i],
        rotation: s.rotation.get(i).copied().unwrap_or(0.0),
    }
}

/// One agent, in plain scalar code: the reference the lanes are tested against bit for bit.
fn integrate_one(
    s: &mut MotionState<'_>,
    st: &SteeringBuffers<'_>,
    params: &[IntegrationParams],
    dt: f32,
    i: usize,
) {
    let [px, py, vx, vy, orientation, rotation] = step_lane(&lane(s, st, params, i), dt);
    s.pos_x[i] = px;
    s.pos_y[i] = py;
    s.vel_x[i] = vx;
    s.vel_y[i] = vy;
    s.orientation[i] = orientation;
    if let Some(r) = s.rotation.get_mut(i) {
        *r = rotation;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atan2_is_within_a_few_ulps_of_the_standard_library() {
        let mut worst = 0.0_f32;
        for k in 0..20_000 {
            let angle = -std::f32::consts::PI + k as f32 * (std::f32::consts::TAU / 20_000.0);
            for r in [1e-3_f32, 1.0, 7.5, 1e4] {
                let (y, x) = (r * angle.sin(), r * angle.cos());
                worst = worst.max((atan2(y, x) - y.atan2(x)).abs());
            }
        }
        assert!(worst < 1e-6, "largest error {worst}");
        assert_eq!(atan2(0.0, 0.0), 0.0);
        assert_eq!(atan2(0.0, -1.0), std::f32::consts::PI);
    }

    #[test]
    fn heading_turn_gives_wrap_turn_bits_for_every_atan2_angle() {
        // A sweep of directions at several lengths, and the edges: tiny components (an angle
        // just below zero rounds up to a whole turn), both signs of zero, the axes.
        let mut cases = vec![
            (0.0_f32, 0.0_f32),
            (-0.0, 1.0),
            (0.0, -1.0),
            (-0.0, -1.0),
            (-1e-30, 1.0),
            (-1e-7, 1.0),
            (1e-30, -1.0),
            (-1e-30, -1.0),
            (-1.0, 0.0),
            (1.0, -0.0),
            // -0 from a ratio that underflows below a negative component.
            (-1e-45, 1e30),
            // NaN from infinite components.
            (f32::INFINITY, f32::INFINITY),
            (f32::NEG_INFINITY, f32::INFINITY),
            (1.0, f32::NEG_INFINITY),
        ];
        for k in 0..200_000 {
            let angle = -std::f32::consts::PI + k as f32 * (std::f32::consts::TAU / 200_000.0);
            for r in [1e-20_f32, 1.0, 3e4] {
                cases.push((r * angle.sin(), r * angle.cos()));
            }
        }
        for (y, x) in cases {
            let h = atan2(y, x);
            let want = wrap_turn(if h < 0.0 { h + TAU } else { h });
            let got = heading_turn(h);
            assert_eq!(
                got.to_bits(),
                want.to_bits(),
                "atan2({y}, {x}) = {h}: {got} vs {want}"
            );
        }
    }

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
                        max_speed: 1.5 + damp,
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
        let buffers = |ang, group| SteeringBuffers {
            lin_x: &lx,
            lin_y: &ly,
            ang,
            max_speed: &ms,
            group,
        };
        let run = |simd: bool| run_with(&cols, buffers(&ang, &grp), &p, dt, simd);
        let (a, b) = (run(true), run(false));
        assert_same_bits(&a, &b);
        for &o in &a[4] {
            assert!((0.0..TAU).contains(&o), "orientation {o}");
        }
        for i in 0..n {
            let speed = a[2][i].hypot(a[3][i]);
            assert!(speed <= ms[i] * (1.0 + 1e-6), "speed {speed} > {}", ms[i]);
        }
        // No per-agent speeds: each group's, in the lanes and the reference, give the bits of a
        // column that holds them (groups in runs of blocks and mixed within blocks).
        for runs in [false, true] {
            let grp: Vec<u32> = (0..n as u32)
                .map(|i| if runs { i / 40 % 8 } else { i % 8 })
                .collect();
            let own: Vec<f32> = grp.iter().map(|&g| p[g as usize].max_speed).collect();
            let column = SteeringBuffers {
                lin_x: &lx,
                lin_y: &ly,
                ang: &ang,
                max_speed: &own,
                group: &grp,
            };
            let want = run_with(&cols, column, &p, dt, false);
            for simd in [true, false] {
                let none = SteeringBuffers {
                    max_speed: &[],
                    ..column
                };
                assert_same_bits(&run_with(&cols, none, &p, dt, simd), &want);
            }
        }
        // One group (its parameters splat across the lanes, no group index read), and an empty
        // angular buffer (no agent turns): the scalar reference with zeros gives the same bits.
        let zeros = vec![0.0; n];
        let group0 = vec![0; n];
        for one in &p {
            let single = std::slice::from_ref(one);
            for (a_simd, a_ref) in [(&ang[..], &ang[..]), (&[][..], &zeros[..])] {
                let a = run_with(&cols, buffers(a_simd, &group0), single, dt, true);
                let b = run_with(&cols, buffers(a_ref, &group0), single, dt, false);
                assert_same_bits(&a, &b);
            }
        }
    }

    /// With no angular output and every rotation `+0`, an empty rotation buffer (not read, not
    /// written) gives the other columns' bits of a buffer of zeros, which stays zeros; a rotation
    /// other than `+0` is reported.
    #[test]
    fn rotations_at_rest_need_no_buffer() {
        let n = 1037;
        let mut r = AgentRng::new(9, 0, 0, 0);
        let mut f = |scale: f32| r.signed() * scale;
        let cols: Vec<Vec<f32>> = (0..6)
            .map(|c| match c {
                4 => (0..n).map(|_| (f(1.0) + 1.0) * TAU * 0.5).collect(),
                5 => vec![0.0; n],
                _ => (0..n).map(|_| f(50.0)).collect(),
            })
            .collect();
        let (lx, ly): (Vec<f32>, Vec<f32>) = (0..n).map(|_| (f(30.0), f(30.0))).unzip();
        let grp: Vec<u32> = (0..n as u32).map(|i| i % 8).collect();
        let steer = SteeringBuffers {
            lin_x: &lx,
            lin_y: &ly,
            ang: &[],
            max_speed: &[],
            group: &grp,
        };
        let p = params();
        let want = run_with(&cols, steer, &p, 0.05, false);
        assert!(want[5].iter().all(|r| r.to_bits() == 0));
        // One step of the lanes over `cols`, their rotations left out when `rotations` is false;
        // whether a rotation written is other than +0.
        let step = |cols: &mut [Vec<f32>], rotations: bool| {
            integrate_then(motion(cols, rotations), steer, &p, 0.05, &|_| {}, None)
        };
        let mut got = cols.clone();
        assert!(!step(&mut got, false));
        assert_same_bits(&got, &want);
        // One rotation other than +0 (a negative zero): agent 500 is of group 4, kinematic, and
        // its rotation becomes the angular output, +0.
        let mut spun = cols.clone();
        spun[5][500] = -0.0;
        assert!(!step(&mut spun, true));
        // Agent 498 is of group 2, dynamic: its rotation stays (within the clamp, above the
        // rest floor), and the lanes say so.
        spun[5][498] = 0.25;
        assert!(step(&mut spun, true));
    }

    /// The motion state over six columns, without the rotations unless `rotations`.
    fn motion(cols: &mut [Vec<f32>], rotations: bool) -> MotionState<'_> {
        let [px, py, vx, vy, or, rot] = cols else {
            unreachable!()
        };
        MotionState {
            pos_x: px,
            pos_y: py,
            vel_x: vx,
            vel_y: vy,
            orientation: or,
            rotation: if rotations { rot } else { &mut [] },
        }
    }

    /// The six state columns after one step of either integrator.
    fn run_with(
        cols: &[Vec<f32>],
        steer: SteeringBuffers<'_>,
        p: &[IntegrationParams],
        dt: f32,
        simd: bool,
    ) -> Vec<Vec<f32>> {
        let mut c = cols.to_vec();
        let state = motion(&mut c, true);
        if simd {
            integrate(state, steer, p, dt)
        } else {
            integrate_scalar(state, steer, p, dt)
        }
        c
    }

    fn assert_same_bits(a: &[Vec<f32>], b: &[Vec<f32>]) {
        for (ca, cb) in a.iter().zip(b) {
            for (x, y) in ca.iter().zip(cb) {
                assert_eq!(x.to_bits(), y.to_bits());
            }
        }
    }
}
