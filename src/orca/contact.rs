//! Hard contact resolution: after integration, agents that overlap are pushed apart.
//!
//! ORCA guarantees collision-free velocities only while its linear program is feasible; in a
//! dense crowd it is not, and the 3D program lets pairs overlap. This pass takes the positions
//! after the move, lists the pairs near contact (within 1.5 times their summed radii, searched
//! in parallel through a grid from the agents flagged as near, sorted by their ids), and then
//! sweeps the list in that order, Gauss-Seidel fashion: each overlapping pair is moved apart along the line between its
//! centres to exactly touching, each agent by its share (half when both take part, all of it
//! when the other does not move). Sweeps stop when no pair overlaps by more than `tolerance` of
//! its summed radii, or after `iterations`. The list and the sweep order depend neither on the
//! thread count nor on the agents' order in memory, so neither does the result.
//!
//! Invariants: only agents whose `moves` flag is set change position; a coincident pair
//! separates along a direction fixed by the ids; velocities are left alone.

use glam::Vec2;
use rayon::prelude::*;

use crate::bounds::Bounds;
use crate::spatial::{GridIndex, Neighbour, NeighbourIndex};

/// Agents per parallel task of the pair search.
const CHUNK: usize = 2048;
/// Pairs closer than this many times their summed radii are listed.
const NEAR: f32 = 1.5;

/// Reused buffers of the contact pass.
#[derive(Debug, Default)]
pub(crate) struct ContactScratch {
    grid: GridIndex,
    /// Near pairs per search chunk, then all of them in order.
    chunks: Vec<Vec<(u32, u32)>>,
    pairs: Vec<(u32, u32)>,
}

/// What the contact pass reads besides positions.
pub(crate) struct ContactInput<'a> {
    pub bounds: Bounds,
    pub radius: &'a [f32],
    pub ids: &'a [u32],
    /// Whether each agent takes part (its group has contact on).
    pub moves: &'a [bool],
    /// Whether each agent may be near contact after the move (pairs are searched from these;
    /// every agent that may touch another must have it set).
    pub near: &'a [bool],
    pub iterations: u32,
    /// Overlaps below this fraction of `ri + rj` end the sweeps early.
    pub tolerance: f32,
}

thread_local! {
    static FOUND: std::cell::RefCell<Vec<Neighbour>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Pushes overlapping agents apart in place; returns the sweeps run.
pub(crate) fn resolve(
    input: &ContactInput,
    xs: &mut [f32],
    ys: &mut [f32],
    scratch: &mut ContactScratch,
    parallel: bool,
) -> u32 {
    let n = xs.len();
    if n < 2 || !input.moves.iter().zip(input.near).any(|(&m, &c)| m && c) {
        return 0;
    }
    let max_r = input.radius.iter().copied().fold(0.0_f32, f32::max);
    if max_r <= 0.0 {
        return 0;
    }
    scratch
        .grid
        .rebuild(xs, ys, input.bounds, NEAR * 2.0 * max_r);
    let chunks = n.div_ceil(CHUNK);
    scratch.chunks.resize_with(chunks, Vec::new);
    let grid = &scratch.grid;
    let search = |c: usize, out: &mut Vec<(u32, u32)>| {
        out.clear();
        FOUND.with_borrow_mut(|found| {
            for i in c * CHUNK..((c + 1) * CHUNK).min(n) {
                if !(input.moves[i] && input.near[i]) {
                    continue;
                }
                let ri = input.radius[i];
                grid.neighbours_of(i, NEAR * (ri + max_r), found);
                for nb in found.iter() {
                    let j = nb.index as usize;
                    let near = NEAR * (ri + input.radius[j]);
                    if nb.dist_sq < near * near {
                        out.push((i.min(j) as u32, i.max(j) as u32));
                    }
                }
            }
        });
    };
    if parallel {
        scratch
            .chunks
            .par_iter_mut()
            .enumerate()
            .for_each(|(c, out)| search(c, out));
    } else {
        for (c, out) in scratch.chunks.iter_mut().enumerate() {
            search(c, out);
        }
    }
    scratch.pairs.clear();
    for c in &scratch.chunks {
        scratch.pairs.extend_from_slice(c);
    }
    // Swept in the order of the pairs' ids, so that the result depends neither on the thread
    // count nor on where agents sit in memory; a pair of two searching agents is found from
    // both.
    let ids = input.ids;
    scratch.pairs.sort_unstable_by_key(|&(i, j)| {
        let (a, b) = (ids[i as usize], ids[j as usize]);
        (a.min(b), a.max(b))
    });
    scratch.pairs.dedup();
    if scratch.pairs.is_empty() {
        return 0;
    }
    let share = |k: usize, other: usize| match (input.moves[k], input.moves[other]) {
        (false, _) => 0.0,
        (true, true) => 0.5,
        (true, false) => 1.0,
    };
    for sweep in 0..input.iterations {
        let mut overlapped = false;
        for &(i, j) in &scratch.pairs {
            let (i, j) = (i as usize, j as usize);
            let pi = Vec2::new(xs[i], ys[i]);
            let pj = Vec2::new(xs[j], ys[j]);
            let offset = input.bounds.offset(pi, pj);
            let sum = (input.radius[i] + input.radius[j]) * (1.0 - input.tolerance);
            let dist_sq = offset.length_squared();
            if dist_sq >= sum * sum {
                continue;
            }
            let dist = dist_sq.sqrt();
            let overlap = sum - dist;
            overlapped |= overlap > 1e-3 * sum;
            let dir = if dist > 0.0 {
                offset / dist
            } else if input.ids[i] < input.ids[j] {
                Vec2::X
            } else {
                -Vec2::X
            };
            let (di, dj) = (dir * (overlap * share(i, j)), dir * (overlap * share(j, i)));
            xs[i] = pi.x - di.x;
            ys[i] = pi.y - di.y;
            xs[j] = pj.x + dj.x;
            ys[j] = pj.y + dj.y;
        }
        if !overlapped {
            return sweep + 1;
        }
    }
    input.iterations
}

#[cfg(test)]
mod tests {
    use super::*;

    fn min_gap(xs: &[f32], ys: &[f32], r: f32) -> f32 {
        let mut best = f32::MAX;
        for i in 0..xs.len() {
            for j in i + 1..xs.len() {
                let d = Vec2::new(xs[i] - xs[j], ys[i] - ys[j]).length();
                best = best.min(d / (2.0 * r));
            }
        }
        best
    }

    #[test]
    fn overlapping_agents_end_nearly_apart_and_the_same_on_any_thread_count() {
        let mut rng = crate::rng::AgentRng::new(3, 0, 0, 0);
        let n = 300;
        let xs: Vec<f32> = (0..n).map(|_| rng.unit() * 40.0).collect();
        let ys: Vec<f32> = (0..n).map(|_| rng.unit() * 40.0).collect();
        let radius = vec![0.5; n];
        let ids: Vec<u32> = (0..n as u32).collect();
        let moves = vec![true; n];
        let input = ContactInput {
            bounds: Bounds::Open,
            radius: &radius,
            ids: &ids,
            moves: &moves,
            near: &moves,
            iterations: 64,
            tolerance: 0.01,
        };
        assert!(min_gap(&xs, &ys, 0.5) < 0.5);
        let (mut x1, mut y1) = (xs.clone(), ys.clone());
        let (mut x2, mut y2) = (xs.clone(), ys.clone());
        resolve(
            &input,
            &mut x1,
            &mut y1,
            &mut ContactScratch::default(),
            false,
        );
        resolve(
            &input,
            &mut x2,
            &mut y2,
            &mut ContactScratch::default(),
            true,
        );
        assert_eq!(x1, x2);
        assert_eq!(y1, y2);
        let gap = min_gap(&x1, &y1, 0.5);
        assert!(gap > 0.95, "closest pair at {gap} of the summed radii");
    }

    #[test]
    fn coincident_agents_separate_and_fixed_agents_stay() {
        let (mut xs, mut ys) = (vec![1.0, 1.0, 5.0], vec![2.0, 2.0, 5.0]);
        let input = ContactInput {
            bounds: Bounds::Open,
            radius: &[0.5, 0.5, 0.5],
            ids: &[0, 1, 2],
            moves: &[true, true, false],
            near: &[true, true, true],
            iterations: 4,
            tolerance: 0.0,
        };
        resolve(
            &input,
            &mut xs,
            &mut ys,
            &mut ContactScratch::default(),
            false,
        );
        assert!((xs[1] - xs[0] - 1.0).abs() < 1e-6, "{xs:?}");
        assert_eq!((xs[2], ys[2]), (5.0, 5.0));
    }
}
