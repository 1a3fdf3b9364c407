//! The world's bounds on the moved agents: positions wrapped on a torus, clamped to a walled
//! rectangle with the velocity's outward part dropped, in lanes.
//!
//! Invariants: each agent's result depends on its own position and velocity alone; the lanes
//! give the bits of [`crate::bounds::wrap_coord`] and of the clamp's branches.

use rayon::prelude::*;

use super::BOUNDS_CHUNK;
use crate::agents::Agents;
use crate::bounds::Bounds;
use crate::simd::{apply, float_kernel};

/// Wraps positions on a torus; on a walled rectangle clamps them and removes the velocity
/// component that points into the wall.
pub(crate) fn apply_bounds(a: &mut Agents, bounds: Bounds, parallel: bool) {
    if matches!(bounds, Bounds::Open) {
        return;
    }
    let columns = (
        &mut a.pos_x[..],
        &mut a.pos_y[..],
        &mut a.vel_x[..],
        &mut a.vel_y[..],
    );
    if parallel {
        (
            columns.0.par_chunks_mut(BOUNDS_CHUNK),
            columns.1.par_chunks_mut(BOUNDS_CHUNK),
            columns.2.par_chunks_mut(BOUNDS_CHUNK),
            columns.3.par_chunks_mut(BOUNDS_CHUNK),
        )
            .into_par_iter()
            .for_each(|piece| bound_piece(piece, bounds));
    } else {
        bound_piece(columns, bounds);
    }
}

/// The world's bounds on one piece of the agents (positions x and y, velocities x and y): each
/// agent's result depends on its own values alone, so pieces of any size give the same bits.
pub(crate) fn bound_piece(
    (pos_x, pos_y, vel_x, vel_y): (&mut [f32], &mut [f32], &mut [f32], &mut [f32]),
    bounds: Bounds,
) {
    match bounds {
        Bounds::Open => {}
        Bounds::Torus { size } => {
            wrap_lined(pos_x, size.x);
            wrap_lined(pos_y, size.y);
        }
        Bounds::Bounded { size } => {
            clamp_axis(pos_x, vel_x, size.x);
            clamp_axis(pos_y, vel_y, size.y);
        }
    }
}

/// [`wrap_all`] in two pieces, split at the first cache line (`crate::cache_lines`).
fn wrap_lined(v: &mut [f32], side: f32) {
    let (head, rest) = v.split_at_mut(crate::cache_lines::lead(v));
    wrap_all(head, side);
    wrap_all(rest, side);
}

/// [`crate::bounds::wrap_coord`] over a slice, bit for bit: one side added or taken away in
/// lanes (exact, and what `rem_euclid` gives for a coordinate less than one side out), the
/// general function for the rare values farther out (kept unchanged by the lanes).
// `&` rather than a range test: no short circuit, so no branch in the lanes.
#[allow(clippy::manual_range_contains)]
#[apply(float_kernel!)]
fn wrap_all(v: &mut [f32], side: f32) {
    let mut outside = false;
    for x in v.iter_mut() {
        // `-side` itself is left to the general function (`rem_euclid` gives -0 there).
        let w = if (*x < 0.0) & (*x > -side) {
            *x + side
        } else if *x >= side {
            *x - side
        } else {
            *x
        };
        let inside = (w >= 0.0) & (w < side);
        outside |= !inside;
        // A value still outside keeps its original bits for the general function.
        *x = if inside { w } else { *x };
    }
    if outside {
        for x in v.iter_mut() {
            *x = crate::bounds::wrap_coord(*x, side);
        }
    }
}

/// A bounded world's walls on one axis: a coordinate below 0 or above `side` is put on the wall
/// and its velocity's outward part dropped. Every value is written, as selects in lanes (a NaN
/// coordinate is neither below nor above and stays as it is, with its velocity).
#[apply(float_kernel!)]
fn clamp_axis(pos: &mut [f32], vel: &mut [f32], side: f32) {
    let n = pos.len().min(vel.len());
    let (pos, vel) = (&mut pos[..n], &mut vel[..n]);
    for k in 0..n {
        let (p, v) = (pos[k], vel[k]);
        let (below, above) = (p < 0.0, p > side);
        pos[k] = if below {
            0.0
        } else if above {
            side
        } else {
            p
        };
        vel[k] = if below {
            v.max(0.0)
        } else if above {
            v.min(0.0)
        } else {
            v
        };
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wall_clamp_in_lanes_equals_the_branches_bit_for_bit() {
        let side = 12.5_f32;
        let coords = [
            -1.0,
            -0.0,
            0.0,
            1e-30,
            -1e-30,
            6.0,
            side,
            side + 1e-6,
            1e9,
            -1e9,
            f32::NAN,
            f32::INFINITY,
            f32::NEG_INFINITY,
        ];
        let speeds = [-3.0, -0.0, 0.0, 2.0, f32::NAN];
        let (mut pos, mut vel) = (Vec::new(), Vec::new());
        for &p in &coords {
            for &v in &speeds {
                pos.push(p);
                vel.push(v);
            }
        }
        let (mut want_p, mut want_v) = (pos.clone(), vel.clone());
        for (p, v) in want_p.iter_mut().zip(want_v.iter_mut()) {
            if *p < 0.0 {
                *p = 0.0;
                *v = v.max(0.0);
            } else if *p > side {
                *p = side;
                *v = v.min(0.0);
            }
        }
        clamp_axis(&mut pos, &mut vel, side);
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&pos), bits(&want_p));
        assert_eq!(bits(&vel), bits(&want_v));
    }

    #[test]
    fn lane_wrapping_equals_wrap_coord_bit_for_bit() {
        let side = 37.25_f32;
        let mut values = vec![
            0.0,
            -0.0,
            side,
            -side,
            2.0 * side,
            -1e-9,
            -1e-30,
            side - 1e-6,
            side + 1e-6,
            1e10,
            -1e10,
            3.5 * side,
            -3.5 * side,
            f32::MAX,
            -f32::MAX,
        ];
        let mut rng = crate::rng::AgentRng::new(5, 0, 0, 0);
        values.extend((0..10_000).map(|_| rng.signed() * 3.0 * side));
        let expected: Vec<u32> = values
            .iter()
            .map(|&x| crate::bounds::wrap_coord(x, side).to_bits())
            .collect();
        wrap_all(&mut values, side);
        for (k, (x, e)) in values.iter().zip(&expected).enumerate() {
            assert_eq!(
                x.to_bits(),
                *e,
                "value {k}: {x} against {}",
                f32::from_bits(*e)
            );
        }
    }
}
