//! The arrival count: agents of groups with an arrival radius, and those of them within it of
//! their own target (the minimum image on a torus).
//!
//! Invariant: the counts are sums of whole numbers, the same over pieces of any size and on any
//! number of threads.

use rayon::prelude::*;

use super::BOUNDS_CHUNK;
use crate::agents::Agents;
use crate::bounds::{Bounds, wrap_delta};

/// `(arrived, with_goal)` over the agents of `a`, given each group's squared arrival radius in
/// `r_sq` (-1 for none: a branch-free count per agent), counted in parallel chunks when
/// `parallel`.
pub(crate) fn arrivals(a: &Agents, bounds: Bounds, r_sq: &[f32], parallel: bool) -> (usize, usize) {
    let count = |range: std::ops::Range<usize>| {
        let (px, py) = (&a.pos_x[range.clone()], &a.pos_y[range.clone()]);
        let (tx, ty) = (&a.target_x[range.clone()], &a.target_y[range.clone()]);
        let group = &a.group[range];
        let (mut arrived, mut with_goal) = (0, 0);
        let mut tally = |dx: f32, dy: f32, g: u32| {
            let r_sq = r_sq[g as usize];
            with_goal += usize::from(r_sq >= 0.0);
            arrived += usize::from(dx * dx + dy * dy <= r_sq);
        };
        if let ([r_sq], Bounds::Open | Bounds::Bounded { .. }) = (r_sq, bounds) {
            // One group (the group numbers are not read): counts in vector lanes.
            let within = px
                .iter()
                .zip(py)
                .zip(tx)
                .zip(ty)
                .fold(0u32, |n, (((px, py), tx), ty)| {
                    let (dx, dy) = (tx - px, ty - py);
                    n + u32::from(dx * dx + dy * dy <= *r_sq)
                });
            let goals = if *r_sq >= 0.0 { px.len() } else { 0 };
            return (within as usize, goals);
        }
        let each = px.iter().zip(py).zip(tx).zip(ty).zip(group);
        match bounds {
            Bounds::Torus { size } => {
                for ((((&px, &py), &tx), &ty), &g) in each {
                    let (dx, dy) = (wrap_delta(tx - px, size.x), wrap_delta(ty - py, size.y));
                    tally(dx, dy, g);
                }
            }
            _ => {
                for ((((&px, &py), &tx), &ty), &g) in each {
                    tally(tx - px, ty - py, g);
                }
            }
        }
        (arrived, with_goal)
    };
    let n = a.len();
    if parallel && n > BOUNDS_CHUNK {
        (0..n.div_ceil(BOUNDS_CHUNK))
            .into_par_iter()
            .map(|c| count(c * BOUNDS_CHUNK..n.min((c + 1) * BOUNDS_CHUNK)))
            .reduce(|| (0, 0), |x, y| (x.0 + y.0, x.1 + y.1))
    } else {
        count(0..n)
    }
}
