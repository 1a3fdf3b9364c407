//! A k-d tree backend on [kiddo](https://docs.rs/kiddo) 6.
//!
//! The tree gathers candidates with a slightly widened radius (kiddo's `within` takes the
//! *squared* radius under `SquaredEuclidean`); the exact filter of the module then keeps those
//! within `r` under the world's metric, and the result is sorted by index.
//!
//! On a torus the tree holds the points once and the query is repeated from the images of the
//! query point shifted by `(kx * W, ky * H)`, `kx, ky` in `{-1, 0, 1}`, skipping images that cannot
//! reach the world; a point found from several images is kept once. Three images per axis are
//! enough for any radius, because for points inside `[0, W)` the minimum-image difference is the
//! plain difference shifted by `-W`, `0` or `W`.

use std::fmt;

use glam::Vec2;
use kiddo::{ImmutableKdTree, SquaredEuclidean};

use super::{Neighbour, NeighbourIndex, coordinate_scale, exact, gather_radius, to_u32};
use crate::bounds::Bounds;

/// A k-d tree neighbour index.
///
/// Cloning rebuilds the tree from the stored points (kiddo's immutable tree is not `Clone`).
#[derive(Default)]
pub struct KdTreeIndex {
    bounds: Bounds,
    xs: Vec<f32>,
    ys: Vec<f32>,
    points: Vec<[f32; 2]>,
    tree: Option<ImmutableKdTree<f32, 2>>,
    scale: f32,
}

impl Clone for KdTreeIndex {
    fn clone(&self) -> Self {
        KdTreeIndex {
            bounds: self.bounds,
            xs: self.xs.clone(),
            ys: self.ys.clone(),
            points: self.points.clone(),
            tree: build(&self.points),
            scale: self.scale,
        }
    }
}

/// The tree over `points`, or `None` when there are none.
fn build(points: &[[f32; 2]]) -> Option<ImmutableKdTree<f32, 2>> {
    (!points.is_empty())
        .then(|| ImmutableKdTree::new_from_slice(points).expect("u32 items hold every index"))
}

impl fmt::Debug for KdTreeIndex {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("KdTreeIndex")
            .field("bounds", &self.bounds)
            .field("len", &self.xs.len())
            .finish_non_exhaustive()
    }
}

impl KdTreeIndex {
    fn gather(&self, p: Vec2, r: f32, skip: usize, out: &mut Vec<Neighbour>) {
        out.clear();
        let Some(tree) = &self.tree else { return };
        let r_sq = r * r;
        let rg = gather_radius(r, self.scale);
        let rg_sq = rg * rg;
        let query = |q: [f32; 2], out: &mut Vec<Neighbour>| {
            tree.query(&q)
                .within::<SquaredEuclidean<f32>>(rg_sq)
                .unsorted()
                .visit(|found| {
                    let j = found.item as usize;
                    if j != skip
                        && let Some(n) = exact(
                            &self.bounds,
                            p,
                            Vec2::new(self.xs[j], self.ys[j]),
                            found.item,
                            r_sq,
                        )
                    {
                        out.push(n);
                    }
                });
        };
        match self.bounds {
            Bounds::Torus { size } => {
                // Shifts whose image of p can reach points in [0, side].
                let shifts = |c: f32, side: f32| {
                    [(0.0, true), (side, c - rg <= 0.0), (-side, c + rg >= side)]
                };
                for (sx, use_x) in shifts(p.x, size.x) {
                    for (sy, use_y) in shifts(p.y, size.y) {
                        if use_x && use_y {
                            query([p.x + sx, p.y + sy], out);
                        }
                    }
                }
                out.sort_unstable_by_key(|n| n.index);
                out.dedup_by_key(|n| n.index);
            }
            _ => {
                query([p.x, p.y], out);
                out.sort_unstable_by_key(|n| n.index);
            }
        }
    }
}

impl NeighbourIndex for KdTreeIndex {
    fn rebuild(&mut self, xs: &[f32], ys: &[f32], bounds: Bounds, _max_radius: f32) {
        assert_eq!(xs.len(), ys.len(), "xs and ys must have the same length");
        to_u32(xs.len());
        self.bounds = bounds;
        self.xs.clear();
        self.xs.extend_from_slice(xs);
        self.ys.clear();
        self.ys.extend_from_slice(ys);
        self.points.clear();
        self.points.extend(xs.iter().zip(ys).map(|(&x, &y)| [x, y]));
        self.scale = coordinate_scale(xs, ys, &bounds);
        self.tree = build(&self.points);
    }

    fn neighbours_of(&self, i: usize, r: f32, out: &mut Vec<Neighbour>) {
        self.gather(Vec2::new(self.xs[i], self.ys[i]), r, i, out);
    }

    fn neighbours_at(&self, p: Vec2, r: f32, out: &mut Vec<Neighbour>) {
        self.gather(p, r, usize::MAX, out);
    }

    fn len(&self) -> usize {
        self.xs.len()
    }
}
