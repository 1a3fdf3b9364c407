//! Obstacle non-penetration over the moved agents: each agent's move from its frame-start
//! position resolved against the obstacles (no centre inside a circle, no move across a wall).
//!
//! Invariant: each agent's result depends on its own move alone, so the parallel chunks give
//! the bits of the sequential pass.

use rayon::prelude::*;

use crate::bounds::Bounds;
use crate::obstacles::Obstacles;
use crate::plans::STEER_CHUNK;

/// Resolves every agent's move from `(px, py)` (the frame-start positions) to its position in
/// `pos_x`, `pos_y` against `obstacles`, in parallel chunks when `parallel`; on a torus the move
/// is resolved as the short hop it was, then wrapped.
pub(crate) fn resolve_obstacles(
    obstacles: &Obstacles,
    bounds: Bounds,
    (px, py): (&[f32], &[f32]),
    (pos_x, pos_y, vel_x, vel_y): (&mut [f32], &mut [f32], &mut [f32], &mut [f32]),
    parallel: bool,
) {
    let fix = |base: usize, x: &mut [f32], y: &mut [f32], vx: &mut [f32], vy: &mut [f32]| {
        for k in 0..x.len() {
            let from = glam::Vec2::new(px[base + k], py[base + k]);
            let to = glam::Vec2::new(x[k], y[k]);
            // On a torus, resolve the move as the short hop it was, then wrap.
            let to_image = from + bounds.offset(from, to);
            let (p, v) = obstacles.resolve(from, to_image, glam::Vec2::new(vx[k], vy[k]));
            let p = if p == to_image { to } else { bounds.wrap(p) };
            x[k] = p.x;
            y[k] = p.y;
            vx[k] = v.x;
            vy[k] = v.y;
        }
    };
    if parallel {
        (
            pos_x.par_chunks_mut(STEER_CHUNK),
            pos_y.par_chunks_mut(STEER_CHUNK),
            vel_x.par_chunks_mut(STEER_CHUNK),
            vel_y.par_chunks_mut(STEER_CHUNK),
        )
            .into_par_iter()
            .enumerate()
            .for_each(|(c, (x, y, vx, vy))| fix(c * STEER_CHUNK, x, y, vx, vy));
    } else {
        fix(0, pos_x, pos_y, vel_x, vel_y);
    }
}
