//! Hard contact resolution: after integration, agents that overlap are pushed apart.
//!
//! ORCA guarantees collision-free velocities only while its linear program is feasible; in a
//! dense crowd it is not, and the 3D program lets pairs overlap. This pass takes the positions
//! after the move, lists the pairs near contact (within 1.5 times their summed radii, searched
//! in parallel through a grid (hashed cells as wide as the search, except on a torus; when few
//! agents search, the ORCA pass's grid of the frame, its reach widened by how far the agents
//! have moved since it bucketed them) from the agents flagged as near, sorted by their ids),
//! and then sweeps the list in that order, Gauss-Seidel fashion: each overlapping pair is moved
//! apart along the line between its centres to exactly touching, each agent by its share (half
//! when both take part, all of it when the other does not move). Sweeps stop when no pair
//! overlaps by more than `tolerance` of its summed radii, or after `iterations`. The list and
//! the sweep order depend neither on the thread count nor on the agents' order in memory, so
//! neither does the result.
//!
//! The sweeps need not converge in a crowd pressed together from all sides, so [`guard`] runs
//! last in the step: agents of pairs that still end closer than [`FLOOR`] of their summed radii
//! (and closer than they started) go back to where they stood at the frame's start, which kept
//! the bound. By induction no step brings two agents that take part closer than `FLOOR` of
//! their summed radii, unless they started closer.
//!
//! Invariants: only agents whose `moves` flag is set change position; a coincident pair
//! separates along a direction fixed by the ids; the sweeps leave velocities alone, and an
//! agent the guard sends back has zero velocity.

use glam::Vec2;
use rayon::prelude::*;

use crate::agents::{AgentId, any_both, largest};
use crate::bounds::Bounds;
use crate::spatial::{GridIndex, HashGrid, Neighbour, NeighbourIndex, farthest_move};

/// Agents per parallel task of the pair search.
const CHUNK: usize = 2048;
/// Agents per parallel task of the guard's check whether the listed pairs still suffice.
const CHECK_CHUNK: usize = 2048;
/// Pairs closer than this many times their summed radii are listed.
const NEAR: f32 = 1.5;

/// Reused buffers of the contact pass.
#[derive(Debug, Default)]
pub(crate) struct ContactScratch {
    /// The pair search's grid on a torus (minimum-image offsets).
    grid: GridIndex,
    /// The pair search's grid in open and walled worlds: cells as wide as the search however
    /// large and sparse the world (the dense grid caps its cells at `4 N`).
    hash: HashGrid,
    /// Near pairs per search chunk, then all of them in order.
    chunks: Vec<Vec<(u32, u32)>>,
    pairs: Vec<(u32, u32)>,
    /// The pairs with their sort keys (the smaller id, then the larger).
    keyed: Vec<(u64, (u32, u32))>,
    /// The positions [`resolve`] started from (after integration).
    after_x: Vec<f32>,
    after_y: Vec<f32>,
    /// Per agent: sent back to its frame-start position by the guard.
    back: Vec<bool>,
    /// The agents the guard's current round sends back.
    fresh: Vec<u32>,
}

/// The fraction of `ri + rj` below which [`guard`] takes a pair's moves back.
pub(crate) const FLOOR: f32 = 0.96;
/// Agents not flagged `near` stay farther than this many times their summed radii from every
/// other agent after the move.
pub(crate) const REACH: f32 = 1.25;
/// Rounds of [`guard`] after which every agent still moved goes back at once.
const MAX_ROUNDS: u32 = 64;

/// What the contact pass reads besides positions.
pub(crate) struct ContactInput<'a> {
    pub bounds: Bounds,
    pub radius: &'a [f32],
    pub ids: &'a [AgentId],
    /// Whether each agent takes part (its group has contact on).
    pub moves: &'a [bool],
    /// Whether each agent may be near contact after the move (pairs are searched from these;
    /// every agent that may come closer to another than [`REACH`] times their summed radii
    /// must have it set).
    pub near: &'a [bool],
    pub iterations: u32,
    /// Overlaps below this fraction of `ri + rj` end the sweeps early.
    pub tolerance: f32,
    /// A hashed grid over the agents built earlier in the frame (ORCA's), searched instead of
    /// a grid of the pass's own when few agents search (open and walled worlds).
    pub prebuilt: Option<Prebuilt<'a>>,
    /// Nothing moves the agents between [`resolve`] and [`guard`] (an open world without
    /// obstacles or fields): `resolve` keeps no copy of the positions it leaves, and `guard`
    /// takes the positions it is given as those.
    pub unmoved: bool,
}

/// A hashed grid over the agents in their current storage order, with the positions it
/// bucketed them at (`at`): a point within `r` of a query now was within `r + d` of it there,
/// `d` a bound on how far any agent has moved since ([`farthest_move`]).
#[derive(Clone, Copy)]
pub(crate) struct Prebuilt<'a> {
    pub hash: &'a HashGrid,
    pub at: (&'a [f32], &'a [f32]),
}

/// A [`Prebuilt`] grid is searched when fewer than one agent in this many searches: its cells
/// are the neighbour distance (or twice it), a search of the contact distance reads several
/// times the candidates of the pass's own cells, while the own grid costs a rebuild per agent
/// (docs/PERFORMANCE.md, "Tuning constants").
const PREBUILT_BELOW: usize = 16;

thread_local! {
    static FOUND: std::cell::RefCell<Vec<Neighbour>> = const { std::cell::RefCell::new(Vec::new()) };
}

/// Whether `a` and `b` hold the same bits: a fold of XORs over blocks (which compiles to
/// vector instructions), stopping at the first block that differs.
fn same_bits(a: &[f32], b: &[f32]) -> bool {
    const BLOCK: usize = 256;
    a.len() == b.len()
        && a.chunks(BLOCK).zip(b.chunks(BLOCK)).all(|(p, q)| {
            p.iter()
                .zip(q)
                .fold(0u32, |acc, (x, y)| acc | (x.to_bits() ^ y.to_bits()))
                == 0
        })
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
    // The positions the guard compares with. When nothing but the sweeps can move the agents
    // before the guard, they are needed only if the sweeps run.
    let keep = |scratch: &mut ContactScratch| {
        scratch.after_x.clear();
        scratch.after_x.extend_from_slice(xs);
        scratch.after_y.clear();
        scratch.after_y.extend_from_slice(ys);
    };
    if input.unmoved {
        scratch.after_x.clear();
        scratch.after_y.clear();
    } else {
        keep(scratch);
    }
    scratch.pairs.clear();
    if n < 2 || !any_both(input.moves, input.near) {
        return 0;
    }
    let max_r = largest(input.radius);
    if max_r <= 0.0 {
        return 0;
    }
    if input.unmoved {
        keep(scratch);
    }
    list_pairs(input, xs, ys, scratch, parallel, (NEAR, max_r), |i| {
        input.moves[i] && input.near[i]
    });
    // Swept in the order of the pairs' ids, so that the result depends neither on the thread
    // count nor on where agents sit in memory; the key of the two ids travels with its pair,
    // so that comparisons load nothing.
    let ids = input.ids;
    let keyed = &mut scratch.keyed;
    keyed.clear();
    keyed.extend(scratch.pairs.iter().map(|&(i, j)| {
        let (a, b) = (ids[i as usize].0, ids[j as usize].0);
        ((u64::from(a.min(b)) << 32) | u64::from(a.max(b)), (i, j))
    }));
    keyed.sort_unstable_by_key(|&(key, _)| key);
    scratch.pairs.clear();
    scratch.pairs.extend(keyed.iter().map(|&(_, pair)| pair));
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

/// The guard after every other position change of the step. A pair of agents that ends closer
/// than [`FLOOR`] of its summed radii and closer than it was at the frame's start is not
/// allowed (unless one of them does not take part and moved this step, which sending the other
/// back cannot undo): of its agents that take part, the one that moved farther this step goes
/// back to its frame-start position with zero velocity, and the search repeats with it in place (a
/// pushed crowd goes back agent by agent, each round one rank further) until no such pair is
/// left; after [`MAX_ROUNDS`] rounds every agent that takes part and still moved goes back at
/// once. Two agents sent back stand as they stood at the frame's start, so a step never brings
/// two taking-part agents closer than `FLOOR` unless they started closer. Each round decides
/// from the positions the round began with, so the result depends neither on the thread count
/// nor on the order of the pairs. Returns the agents sent back.
///
/// On a torus the positions must lie in the world (wrapped, as the step's bounds phase leaves
/// them): the grid that finds the pairs places a point outside it in an edge cell, where a
/// neighbour across the seam can be missed.
#[allow(clippy::too_many_arguments)]
pub(crate) fn guard(
    input: &ContactInput,
    start: (&[f32], &[f32]),
    xs: &mut [f32],
    ys: &mut [f32],
    vx: &mut [f32],
    vy: &mut [f32],
    scratch: &mut ContactScratch,
    parallel: bool,
) -> usize {
    let n = xs.len();
    // No pair listed, so no sweep moved anyone, and nothing else moves the agents: every pair is
    // as far apart as after integration, where none was near contact.
    if n < 2 || !input.moves.iter().any(|&m| m) || (input.unmoved && scratch.pairs.is_empty()) {
        return 0;
    }
    let max_r = largest(input.radius);
    if max_r <= 0.0 {
        return 0;
    }
    let mut back = std::mem::take(&mut scratch.back);
    back.clear();
    back.resize(n, false);
    // The first round's candidates. A pair [`resolve`] did not list was at least `REACH` times
    // its summed radii apart after integration (farther than `NEAR` when both searched), so it
    // cannot have come within `FLOOR` when no agent `k` has moved by `(REACH - FLOOR) * r_k` or
    // more since; then the listed pairs are all there is to check.
    let still = |k: usize| {
        let after = Vec2::new(scratch.after_x[k], scratch.after_y[k]);
        let slack = (REACH - FLOOR) * input.radius[k];
        let moved = input.bounds.offset(after, Vec2::new(xs[k], ys[k]));
        moved == Vec2::ZERO || moved.length_squared() < slack * slack
    };
    // Where nothing moved the agents since `resolve` copied them (no sweep ran, and an open
    // world without obstacles or fields), every agent is still: one comparison of the bits.
    let unmoved = same_bits(&scratch.after_x, xs) && same_bits(&scratch.after_y, ys);
    let listed = scratch.after_x.len() == n
        && (unmoved
            || if parallel {
                (0..n.div_ceil(CHECK_CHUNK))
                    .into_par_iter()
                    .all(|c| (c * CHECK_CHUNK..n.min((c + 1) * CHECK_CHUNK)).all(still))
            } else {
                (0..n).all(still)
            });
    scratch.fresh.reserve(n);
    if !listed {
        list_pairs(input, xs, ys, scratch, parallel, (FLOOR, max_r), |i| {
            input.moves[i]
        });
    }
    let mut sent = 0;
    for round in 0.. {
        scratch.fresh.clear();
        for &(i, j) in &scratch.pairs {
            let (i, j) = (i as usize, j as usize);
            let now = input
                .bounds
                .offset(Vec2::new(xs[i], ys[i]), Vec2::new(xs[j], ys[j]))
                .length_squared();
            let floor = FLOOR * (input.radius[i] + input.radius[j]);
            if now >= floor * floor {
                continue;
            }
            let then = input
                .bounds
                .offset(
                    Vec2::new(start.0[i], start.1[i]),
                    Vec2::new(start.0[j], start.1[j]),
                )
                .length_squared();
            if now >= then {
                continue;
            }
            // An agent that does not take part and moved in cannot be undone by sending the
            // other back: such a pair is not the guard's to keep.
            let stays = |k: usize| input.moves[k] || (xs[k], ys[k]) == (start.0[k], start.1[k]);
            if !(stays(i) && stays(j)) {
                continue;
            }
            // The agent that moved farther goes back first (ties by the larger id); the other
            // only when that is not enough, which the next round finds.
            let moved = |k: usize| {
                let from = Vec2::new(start.0[k], start.1[k]);
                let d = input.bounds.offset(from, Vec2::new(xs[k], ys[k]));
                (d.length_squared(), input.ids[k])
            };
            let (first, second) = if moved(i) > moved(j) { (i, j) } else { (j, i) };
            let free = |k: usize| input.moves[k] && !back[k];
            if free(first) {
                scratch.fresh.push(first as u32);
            } else if free(second) {
                scratch.fresh.push(second as u32);
            }
        }
        if scratch.fresh.is_empty() {
            break;
        }
        if round + 1 >= MAX_ROUNDS {
            scratch.fresh.clear();
            scratch
                .fresh
                .extend((0..n as u32).filter(|&k| input.moves[k as usize] && !back[k as usize]));
        }
        for &k in &scratch.fresh {
            let k = k as usize;
            if !back[k] {
                back[k] = true;
                sent += 1;
                xs[k] = start.0[k];
                ys[k] = start.1[k];
                vx[k] = 0.0;
                vy[k] = 0.0;
            }
        }
        // Pairs of two agents that stayed were decided this round; a new one has an agent sent
        // back in it.
        let back = &back;
        list_pairs(input, xs, ys, scratch, parallel, (FLOOR, max_r), |i| {
            back[i]
        });
    }
    scratch.back = back;
    sent
}

/// Lists in `scratch.pairs` (unordered, each once) the pairs of agents closer than `factor`
/// times their summed radii at `xs`, `ys`, searched from the agents where `from` holds (a pair
/// of two of them from the one first in storage); `max_r` is the largest radius.
fn list_pairs(
    input: &ContactInput,
    xs: &[f32],
    ys: &[f32],
    scratch: &mut ContactScratch,
    parallel: bool,
    (factor, max_r): (f32, f32),
    from: impl Fn(usize) -> bool + Sync,
) {
    let n = xs.len();
    let side = factor * 2.0 * max_r;
    let torus = input.bounds.is_torus();
    // Few searching agents: the grid built earlier in the frame, its reach widened by how far
    // the agents have moved since it bucketed them (none when a position is not finite).
    let prebuilt = input
        .prebuilt
        .filter(|p| !torus && p.hash.len() == n)
        .filter(|_| {
            let few = n.div_ceil(PREBUILT_BELOW);
            (0..n).filter(|&i| from(i)).take(few).count() < few
        })
        .map(|p| (p.hash, farthest_move((xs, ys), p.at)))
        .filter(|&(grid, slack)| slack <= grid.side());
    if torus {
        scratch.grid.rebuild(xs, ys, input.bounds, side);
    } else if prebuilt.is_none() {
        scratch.hash.rebuild(xs, ys, side);
    }
    let chunks = n.div_ceil(CHUNK);
    scratch.chunks.resize_with(chunks, Vec::new);
    let (grid, hash) = (&scratch.grid, &scratch.hash);
    let search = |c: usize, out: &mut Vec<(u32, u32)>| {
        out.clear();
        FOUND.with_borrow_mut(|found| {
            for i in c * CHUNK..((c + 1) * CHUNK).min(n) {
                if !from(i) {
                    continue;
                }
                let ri = input.radius[i];
                let mut offer = |j: usize, dist_sq: f32| {
                    // A pair of two searching agents is listed from the first of them only
                    // (the other finds it: its reach covers the pair's distance, the same bits
                    // from either side).
                    if j < i && from(j) {
                        return;
                    }
                    let near = factor * (ri + input.radius[j]);
                    if dist_sq < near * near {
                        out.push((i.min(j) as u32, i.max(j) as u32));
                    }
                };
                if torus {
                    grid.neighbours_of(i, factor * (ri + max_r), found);
                    for nb in found.iter() {
                        offer(nb.index as usize, nb.dist_sq);
                    }
                } else if let Some((grid, slack)) = prebuilt {
                    // Its positions are old: the current ones, by index.
                    let p = Vec2::new(xs[i], ys[i]);
                    let order = grid.order();
                    grid.for_each_run(p, factor * (ri + max_r) + slack, |run| {
                        for k in run {
                            let j = order[k] as usize;
                            if j != i {
                                offer(j, (Vec2::new(xs[j], ys[j]) - p).length_squared());
                            }
                        }
                    });
                } else {
                    // The plain offset, as the dense grid's exact test computes it.
                    let p = Vec2::new(xs[i], ys[i]);
                    let (sx, sy, order) = (hash.sorted_x(), hash.sorted_y(), hash.order());
                    hash.for_each_run(p, factor * (ri + max_r), |run| {
                        for k in run {
                            let j = order[k] as usize;
                            if j != i {
                                offer(j, (Vec2::new(sx[k], sy[k]) - p).length_squared());
                            }
                        }
                    });
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
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    /// The input of a test in an open world where every agent of `moves` searches and no grid
    /// is prebuilt; tests that differ set their fields over it.
    fn open_input<'a>(
        radius: &'a [f32],
        ids: &'a [AgentId],
        moves: &'a [bool],
        (iterations, tolerance): (u32, f32),
    ) -> ContactInput<'a> {
        ContactInput {
            bounds: Bounds::Open,
            radius,
            ids,
            moves,
            near: moves,
            iterations,
            tolerance,
            prebuilt: None,
            unmoved: false,
        }
    }

    /// The pairs found through a grid built at older positions (its reach widened by the
    /// farthest move since) are those of the pass's own grid at the current ones; the old grid
    /// is used only when few agents search and none has moved farther than a cell.
    #[test]
    fn a_prebuilt_grid_finds_the_pairs_of_a_fresh_one() {
        let mut rng = crate::rng::AgentRng::new(21, 0, 0, 0);
        let n = 2000;
        let at_x: Vec<f32> = (0..n).map(|_| rng.unit() * 150.0 - 40.0).collect();
        let at_y: Vec<f32> = (0..n).map(|_| rng.unit() * 150.0).collect();
        let mut grid = HashGrid::default();
        grid.rebuild(&at_x, &at_y, 2.5);
        let radius: Vec<f32> = (0..n).map(|_| 0.3 + rng.unit() * 0.4).collect();
        let ids: Vec<AgentId> = (0..n as u32).map(AgentId).collect();
        let moves = vec![true; n];
        let cases = [
            (2.0, 100, true),
            (2.0, 200, false),
            (12.0, 100, false),
            (2.0, n, false),
        ];
        for (reach, searching, used) in cases {
            let xs: Vec<f32> = at_x
                .iter()
                .map(|&x| x + (rng.unit() - 0.5) * reach)
                .collect();
            let ys: Vec<f32> = at_y
                .iter()
                .map(|&y| y + (rng.unit() - 0.5) * reach)
                .collect();
            let near: Vec<bool> = (0..n).map(|i| i % (n / searching) == 0).collect();
            let pairs = |prebuilt: Option<Prebuilt>| {
                let input = ContactInput {
                    near: &near,
                    prebuilt,
                    ..open_input(&radius, &ids, &moves, (1, 0.0))
                };
                let mut scratch = ContactScratch::default();
                let max_r = largest(&radius);
                list_pairs(&input, &xs, &ys, &mut scratch, false, (NEAR, max_r), |i| {
                    near[i]
                });
                let mut pairs = scratch.pairs.clone();
                pairs.sort_unstable();
                pairs.dedup();
                assert_eq!(pairs.len(), scratch.pairs.len(), "a pair listed twice");
                (pairs, scratch.hash.is_empty())
            };
            let prebuilt = Prebuilt {
                hash: &grid,
                at: (&at_x, &at_y),
            };
            let (own, _) = pairs(None);
            let (old, skipped_rebuild) = pairs(Some(prebuilt));
            assert!(own.len() > 10, "{} pairs", own.len());
            assert_eq!(old, own, "moves of up to {reach}, {searching} searching");
            assert_eq!(
                skipped_rebuild, used,
                "moves of up to {reach}, {searching} searching"
            );
        }
    }

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
        let ids: Vec<AgentId> = (0..n as u32).map(AgentId).collect();
        let moves = vec![true; n];
        let input = open_input(&radius, &ids, &moves, (64, 0.01));
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

    /// The sweeps go by the pairs' ids: the same agents stored in another order end at the
    /// same positions, bit for bit (with few sweeps, so that the order of the pushes shows).
    #[test]
    fn the_sweeps_do_not_depend_on_the_storage_order() {
        let mut rng = crate::rng::AgentRng::new(8, 0, 0, 0);
        let n = 400;
        let xs: Vec<f32> = (0..n).map(|_| rng.unit() * 30.0).collect();
        let ys: Vec<f32> = (0..n).map(|_| rng.unit() * 30.0).collect();
        let radius: Vec<f32> = (0..n).map(|_| 0.4 + rng.unit() * 0.3).collect();
        let ids: Vec<AgentId> = (0..n as u32).map(|k| AgentId(k * 5 + 1)).collect();
        let moves: Vec<bool> = (0..n).map(|k| k % 7 != 0).collect();
        // Storage place `k` of the second store holds agent `perm[k]` of the first.
        let perm: Vec<usize> = (0..n).map(|k| (k * 263 + 17) % n).collect();
        let run = |order: &dyn Fn(usize) -> usize| {
            let take = |v: &[f32]| (0..n).map(|k| v[order(k)]).collect::<Vec<f32>>();
            let (mut x, mut y, r) = (take(&xs), take(&ys), take(&radius));
            let ids: Vec<AgentId> = (0..n).map(|k| ids[order(k)]).collect();
            let moves: Vec<bool> = (0..n).map(|k| moves[order(k)]).collect();
            let input = open_input(&r, &ids, &moves, (2, 0.0));
            resolve(
                &input,
                &mut x,
                &mut y,
                &mut ContactScratch::default(),
                false,
            );
            let mut by_id: Vec<(AgentId, u32, u32)> = (0..n)
                .map(|k| (ids[k], x[k].to_bits(), y[k].to_bits()))
                .collect();
            by_id.sort_unstable();
            by_id
        };
        let plain = run(&|k| k);
        assert_eq!(plain, run(&|k| perm[k]));
        assert_eq!(plain, run(&|k| n - 1 - k));
        // Some agent was pushed, so the order could have shown.
        let moved = plain
            .iter()
            .zip(&ids)
            .any(|(&(_, x, _), id)| x != xs[(id.0 as usize - 1) / 5].to_bits());
        assert!(moved);
    }

    /// Every pair of agents, as `(distance / (ri + rj), i, j)`, on `bounds`.
    fn gaps(bounds: Bounds, xs: &[f32], ys: &[f32], r: &[f32]) -> Vec<(f32, usize, usize)> {
        let mut out = Vec::new();
        for i in 0..xs.len() {
            for j in i + 1..xs.len() {
                let d = bounds.offset(Vec2::new(xs[i], ys[i]), Vec2::new(xs[j], ys[j]));
                out.push((d.length() / (r[i] + r[j]), i, j));
            }
        }
        out
    }

    /// A step's moves on a start that keeps the floor, the sweeps, then the guard: returns the
    /// positions and velocities after both.
    #[allow(clippy::type_complexity)]
    fn guarded_step(
        input: &ContactInput,
        start: (&[f32], &[f32]),
        moves: &[(f32, f32)],
        parallel: bool,
    ) -> (Vec<f32>, Vec<f32>, Vec<f32>, Vec<f32>) {
        let out = guarded_step_as_given(input, start, moves, parallel);
        // In an open world nothing moves the agents between the two: told so, the pass keeps
        // no copy of the positions and the guard may stop early, with the same result.
        if matches!(input.bounds, Bounds::Open) {
            let told = ContactInput {
                unmoved: true,
                ..*input
            };
            let same = guarded_step_as_given(&told, start, moves, parallel);
            assert!(
                bits_of(&same) == bits_of(&out),
                "the unmoved shortcut changed the result"
            );
        }
        out
    }

    /// The bits of a [`guarded_step`] result.
    fn bits_of(v: &(Vec<f32>, Vec<f32>, Vec<f32>, Vec<f32>)) -> Vec<u32> {
        [&v.0, &v.1, &v.2, &v.3]
            .iter()
            .flat_map(|c| c.iter().map(|x| x.to_bits()))
            .collect()
    }

    /// [`guarded_step`] with `input` as it is.
    fn guarded_step_as_given(
        input: &ContactInput,
        start: (&[f32], &[f32]),
        moves: &[(f32, f32)],
        parallel: bool,
    ) -> (Vec<f32>, Vec<f32>, Vec<f32>, Vec<f32>) {
        let mut xs: Vec<f32> = start.0.iter().zip(moves).map(|(x, m)| x + m.0).collect();
        let mut ys: Vec<f32> = start.1.iter().zip(moves).map(|(y, m)| y + m.1).collect();
        let (mut vx, mut vy): (Vec<f32>, Vec<f32>) = moves.iter().copied().unzip();
        let mut scratch = ContactScratch::default();
        resolve(input, &mut xs, &mut ys, &mut scratch, parallel);
        // As the step does: the world's bounds wrap the positions between the two.
        if let Bounds::Torus { size } = input.bounds {
            for (x, y) in xs.iter_mut().zip(ys.iter_mut()) {
                (*x, *y) = (x.rem_euclid(size.x), y.rem_euclid(size.y));
            }
        }
        guard(
            input,
            start,
            &mut xs,
            &mut ys,
            &mut vx,
            &mut vy,
            &mut scratch,
            parallel,
        );
        (xs, ys, vx, vy)
    }

    #[test]
    fn a_crowd_pressed_together_from_all_sides_keeps_the_floor_where_the_sweeps_alone_do_not() {
        // A packed square of 15 x 15 agents touching at the start, each moving a third of a
        // diameter towards the centre (one sweep cannot spread the press), and a lone agent
        // walking in open space.
        let side = 15;
        let n = side * side + 1;
        let (mut sx, mut sy, mut mv) = (Vec::new(), Vec::new(), Vec::new());
        for k in 0..side * side {
            let p = Vec2::new((k % side) as f32, (k / side) as f32) * 1.02;
            let to = (Vec2::splat(7.0 * 1.02) - p).normalize_or_zero() * 0.33;
            sx.push(p.x);
            sy.push(p.y);
            mv.push((to.x, to.y));
        }
        sx.push(100.0);
        sy.push(100.0);
        mv.push((0.3, 0.0));
        let radius = vec![0.5; n];
        let ids: Vec<AgentId> = (0..n as u32).rev().map(AgentId).collect();
        let all = vec![true; n];
        let input = open_input(&radius, &ids, &all, (1, 0.03));
        let (mut xs, mut ys) = (sx.clone(), sy.clone());
        for k in 0..n {
            xs[k] += mv[k].0;
            ys[k] += mv[k].1;
        }
        resolve(
            &input,
            &mut xs,
            &mut ys,
            &mut ContactScratch::default(),
            false,
        );
        let swept = gaps(Bounds::Open, &xs, &ys, &radius);
        assert!(
            swept.iter().any(|g| g.0 < FLOOR),
            "the sweeps alone kept the floor"
        );

        let (xs, ys, vx, vy) = guarded_step(&input, (&sx, &sy), &mv, false);
        let worst = gaps(Bounds::Open, &xs, &ys, &radius)
            .into_iter()
            .fold(f32::MAX, |m, g| m.min(g.0));
        assert!(worst >= FLOOR * (1.0 - 1e-5), "closest pair at {worst}");
        let sent: Vec<usize> = (0..n)
            .filter(|&k| (xs[k], ys[k]) == (sx[k], sy[k]))
            .collect();
        assert!(!sent.is_empty(), "none sent back");
        assert_eq!((xs[n - 1], ys[n - 1], vx[n - 1]), (100.3, 100.0, 0.3));
        for &k in &sent {
            assert_eq!((vx[k], vy[k]), (0.0, 0.0));
        }
        assert_eq!(
            guarded_step(&input, (&sx, &sy), &mv, true),
            (xs, ys, vx, vy)
        );
    }

    /// An agent's start `(x, y)`, radius and whether it takes part.
    type Start = (f32, f32, f32, bool);

    fn start_strategy() -> impl Strategy<Value = (Vec<Start>, u32, bool)> {
        (
            prop::collection::vec(
                (
                    0.0f32..12.0,
                    0.0f32..12.0,
                    0.3f32..0.8,
                    prop::bool::weighted(0.8),
                ),
                2..60,
            ),
            0u32..4,
            any::<bool>(),
        )
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(300))]

        /// After any moves from any start (agents of random sizes, some that do not take part
        /// and stand still, an open plane or a torus), no pair ends closer than `FLOOR` of its
        /// summed radii unless it started closer, and then no closer than it started.
        #[test]
        fn no_pair_ends_closer_than_the_floor_or_its_start(
            (agents, iterations, torus) in start_strategy(),
            seed in 0u64..1000,
        ) {
            let n = agents.len();
            let bounds = if torus {
                Bounds::Torus { size: Vec2::splat(12.0) }
            } else {
                Bounds::Open
            };
            let sx: Vec<f32> = agents.iter().map(|a| a.0).collect();
            let sy: Vec<f32> = agents.iter().map(|a| a.1).collect();
            let radius: Vec<f32> = agents.iter().map(|a| a.2).collect();
            let takes_part: Vec<bool> = agents.iter().map(|a| a.3).collect();
            let ids: Vec<AgentId> = (0..n as u32).map(AgentId).collect();
            let mut rng = crate::rng::AgentRng::new(seed, 0, 0, 0);
            let mv: Vec<(f32, f32)> = (0..n)
                .map(|k| {
                    let step = 0.4 * radius[k];
                    let (dx, dy) = ((rng.unit() - 0.5) * 2.0 * step, (rng.unit() - 0.5) * 2.0 * step);
                    if takes_part[k] { (dx, dy) } else { (0.0, 0.0) }
                })
                .collect();
            let input = ContactInput {
                bounds,
                radius: &radius,
                ids: &ids,
                moves: &takes_part,
                near: &takes_part,
                iterations,
                tolerance: 0.03,
                prebuilt: None,
            unmoved: false,
            };
            let (mut xs, mut ys, _, _) = guarded_step(&input, (&sx, &sy), &mv, false);
            if torus {
                for k in 0..n {
                    xs[k] = xs[k].rem_euclid(12.0);
                    ys[k] = ys[k].rem_euclid(12.0);
                }
            }
            let before = gaps(bounds, &sx, &sy, &radius);
            for (after, then) in gaps(bounds, &xs, &ys, &radius).into_iter().zip(before) {
                let bound = FLOOR.min(then.0) * (1.0 - 1e-4);
                prop_assert!(
                    after.0 >= bound,
                    "pair {:?} at {} (started at {})", (after.1, after.2), after.0, then.0
                );
            }
            for k in 0..n {
                if !takes_part[k] {
                    prop_assert_eq!((xs[k], ys[k]), (sx[k], sy[k]));
                }
            }
        }
    }

    #[test]
    fn coincident_agents_separate_and_fixed_agents_stay() {
        let (mut xs, mut ys) = (vec![1.0, 1.0, 5.0], vec![2.0, 2.0, 5.0]);
        let input = ContactInput {
            bounds: Bounds::Open,
            radius: &[0.5, 0.5, 0.5],
            ids: &[AgentId(0), AgentId(1), AgentId(2)],
            moves: &[true, true, false],
            near: &[true, true, true],
            iterations: 4,
            tolerance: 0.0,
            prebuilt: None,
            unmoved: false,
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
