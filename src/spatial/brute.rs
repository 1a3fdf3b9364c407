//! The brute-force reference: every query checks every point, in index order.
//!
//! O(N) per query and O(N^2) for all agents. It defines what the other backends must return.

use glam::Vec2;

use super::{Neighbour, NeighbourIndex, exact, to_u32};
use crate::bounds::Bounds;

/// Brute-force neighbour search over a copy of the positions.
#[derive(Clone, Debug, Default)]
pub struct BruteIndex {
    bounds: Bounds,
    xs: Vec<f32>,
    ys: Vec<f32>,
}

impl BruteIndex {
    fn scan(&self, p: Vec2, r: f32, skip: usize, out: &mut Vec<Neighbour>) {
        out.clear();
        let r_sq = r * r;
        for (j, (&x, &y)) in self.xs.iter().zip(&self.ys).enumerate() {
            if j != skip
                && let Some(n) = exact(&self.bounds, p, Vec2::new(x, y), j as u32, r_sq)
            {
                out.push(n);
            }
        }
    }
}

impl NeighbourIndex for BruteIndex {
    fn rebuild(&mut self, xs: &[f32], ys: &[f32], bounds: Bounds, _max_radius: f32) {
        assert_eq!(xs.len(), ys.len(), "xs and ys must have the same length");
        to_u32(xs.len());
        self.bounds = bounds;
        self.xs.clear();
        self.xs.extend_from_slice(xs);
        self.ys.clear();
        self.ys.extend_from_slice(ys);
    }

    fn neighbours_of(&self, i: usize, r: f32, out: &mut Vec<Neighbour>) {
        self.scan(Vec2::new(self.xs[i], self.ys[i]), r, i, out);
    }

    fn neighbours_at(&self, p: Vec2, r: f32, out: &mut Vec<Neighbour>) {
        self.scan(p, r, usize::MAX, out);
    }

    fn len(&self) -> usize {
        self.xs.len()
    }
}
