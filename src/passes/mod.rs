//! The step's per-agent passes that belong to no subsystem: the world's bounds on the moved
//! agents ([`bounds`]), the arrival count ([`arrivals`](mod@arrivals)), obstacle
//! non-penetration over the agents ([`obstacles`]), and the copies of columns the later phases
//! compare against.
//! `World::step` (`world/step.rs`) decides when each runs; these passes read and write the
//! columns they are given and nothing else.
//!
//! Invariant: each agent's result depends on its own values alone, and a count is a sum of whole
//! numbers, so pieces of any size, on any number of threads, give the same bits as one
//! sequential pass.

use rayon::prelude::*;

mod arrivals;
mod bounds;
mod obstacles;

pub(crate) use arrivals::arrivals;
pub(crate) use bounds::{apply_bounds, bound_piece};
pub(crate) use obstacles::resolve_obstacles;

/// Makes `to` a copy of `from`, in parallel chunks when `parallel` and `from` is long.
pub(crate) fn copy_column(to: &mut Vec<f32>, from: &[f32], parallel: bool) {
    if parallel && from.len() > BOUNDS_CHUNK {
        to.resize(from.len(), 0.0);
        to.par_chunks_mut(BOUNDS_CHUNK)
            .zip(from.par_chunks(BOUNDS_CHUNK))
            .for_each(|(t, f)| t.copy_from_slice(f));
    } else {
        to.clear();
        to.extend_from_slice(from);
    }
}

/// Agents per parallel task of the bounds, the arrival count and the copies.
const BOUNDS_CHUNK: usize = 16 * 1024;
