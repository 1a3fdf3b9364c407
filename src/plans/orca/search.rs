//! The ORCA filter's neighbour search: the hashed grid the pass keeps across frames (refreshed
//! in place while the agents stay in order and move little, rebuilt otherwise), the block of
//! cells gathered once for a run of agents whose queries it holds, and the `k` nearest
//! candidates by `(distance, id)`.
//!
//! Invariants: which grid (refreshed or rebuilt), which block and which first radius serve a
//! query change the cost, never what the search returns (the `k` nearest in order, or all the
//! agents within reach when fewer lie there): the results are the same bits.

use glam::Vec2;

use super::{Buffers, Context, OrcaScratch, Source};
use crate::agents::AgentId;
use crate::orca::lines::LANES;
use crate::plans::pack::{Block, Packed, pack_lanes};
use crate::plans::plan::Plan;
use crate::plans::view::SteerView;
use crate::spatial::{HashGrid, NeighbourIndex, Runs, farthest_move};

impl OrcaScratch {
    /// Makes `hash` hold the agents' current positions in cells of `side`, and returns how much
    /// farther than their radius its queries must reach. While the same agents are in the same
    /// storage order (no reorder, addition or removal since the last rebuild) and none has moved
    /// farther than [`MAX_SLACK`] cells' sides from where it was at that rebuild, the points
    /// keep their buckets and only their positions are refreshed; the queries then reach as
    /// far beyond their radius as the farthest move (a bound on it), which keeps every agent
    /// within the radius in the block. Otherwise the grid is rebuilt, and the queries reach
    /// their radius. Which of the two happens changes the cost, not the candidates within
    /// reach: the results are the same bits.
    pub(super) fn prepare_hash(
        &mut self,
        ids: &[AgentId],
        (xs, ys): (&[f32], &[f32]),
        side: f32,
    ) -> f32 {
        if self.hash.side() == side && self.built_ids == ids {
            let moved = farthest_move((xs, ys), (&self.built_x, &self.built_y));
            if moved <= MAX_SLACK * side {
                self.hash.refresh(xs, ys);
                return moved;
            }
        }
        self.hash.rebuild(xs, ys, side);
        self.remember(ids, (xs, ys));
        0.0
    }
}

impl OrcaScratch {
    /// Takes `grid`, built over the agents now stored as `ids` at `(xs, ys)` (the world's order
    /// grid after the agents were reordered by it and it adopted that order), as the pass's
    /// hashed grid, and gives back the previous one in its place: the pass then refreshes
    /// instead of rebuilding in this frame ([`OrcaScratch::prepare_hash`] still checks the
    /// agents, their positions and the side).
    pub(crate) fn adopt(
        &mut self,
        grid: &mut HashGrid,
        ids: &[AgentId],
        (xs, ys): (&[f32], &[f32]),
    ) {
        std::mem::swap(&mut self.hash, grid);
        self.remember(ids, (xs, ys));
    }

    /// The hashed grid with the positions it bucketed the agents at, when it was built over
    /// the agents now stored as `ids` (in that order): a later search of this frame may use it
    /// instead of building its own, reaching farther by how far the agents have moved since.
    pub(crate) fn prebuilt(&self, ids: &[AgentId]) -> Option<crate::orca::contact::Prebuilt<'_>> {
        (self.hash.len() == ids.len() && self.built_ids == ids).then_some(
            crate::orca::contact::Prebuilt {
                hash: &self.hash,
                at: (&self.built_x, &self.built_y),
            },
        )
    }

    /// Records the agents and positions the hashed grid was built over.
    fn remember(&mut self, ids: &[AgentId], (xs, ys): (&[f32], &[f32])) {
        for (built, now) in [(&mut self.built_x, xs), (&mut self.built_y, ys)] {
            built.clear();
            built.extend_from_slice(now);
        }
        self.built_ids.clear();
        self.built_ids.extend_from_slice(ids);
    }
}

/// How far the hashed grid's points may move, in cells' sides, before it is rebuilt: each
/// query reads a block that much wider.
const MAX_SLACK: f32 = 0.25;

/// Whether ORCA's cells should be twice the neighbour distance, given the [`HashGrid::crowding`]
/// of a grid of such cells over the agents: where fewer than [`WIDE_BELOW`] agents share an
/// agent's cell. Wide cells save rows per gather in a sparse crowd and cost candidates in a
/// dense one, so dense crowds keep the narrow cells (the measurement: docs/PERFORMANCE.md, "Tuning constants").
pub(crate) fn wide_cells(crowding: f32) -> bool {
    crowding < WIDE_BELOW
}

/// Agents per wide cell (about four narrow cells in a crowd, two along a line of agents) below
/// which wide cells gather fewer blocks than they cost in extra candidates.
const WIDE_BELOW: f32 = 12.0;

/// The largest `neighbour_dist` of the plans that use ORCA (0 when none does).
pub(crate) fn reach(plans: &[Plan]) -> f32 {
    plans
        .iter()
        .filter_map(|p| p.orca.map(|o| o.neighbour_dist))
        .fold(0.0_f32, f32::max)
}

/// Gathers the points of the runs `runs` of the hashed grid into `b.block_*`, one contiguous
/// list, then [`LANES`] entries of padding (far away, never kept).
#[inline(always)]
fn gather_block(hash: &HashGrid, runs: &Runs, b: &mut Buffers) {
    let (sx, sy, order) = (hash.sorted_x(), hash.sorted_y(), hash.order());
    let mut len = 0;
    for run in runs.iter() {
        // Eight lanes at a time (the sorted positions are padded); the next copy starts where
        // this one's points end.
        let mut at = run.start;
        while at < run.end {
            let take = (run.end - at).min(LANES);
            let x: &[f32; LANES] = sx[at..at + LANES].try_into().expect("padded positions");
            let y: &[f32; LANES] = sy[at..at + LANES].try_into().expect("padded positions");
            let to: &mut [f32; LANES] =
                (&mut b.block_x[len..len + LANES]).try_into().expect("room");
            *to = *x;
            let to: &mut [f32; LANES] =
                (&mut b.block_y[len..len + LANES]).try_into().expect("room");
            *to = *y;
            match order.get(at..at + LANES) {
                Some(js) => b.block_j[len..len + LANES].copy_from_slice(js),
                None => b.block_j[len..len + take].copy_from_slice(&order[at..at + take]),
            }
            len += take;
            at += take;
        }
    }
    b.block_x[len..len + LANES].fill(f32::MAX);
    b.block_y[len..len + LANES].fill(f32::MAX);
    b.block_j[len..len + LANES].fill(u32::MAX);
    b.block_len = len;
}

/// What [`candidates`] found.
#[derive(Clone, Copy, Debug)]
pub(super) enum Hits {
    /// The `k` nearest, in order, in `b.near`.
    Ordered,
    /// Fewer than `k` agents within reach of a hashed grid's query: all of them, places
    /// `0..n` of `b.rx`, `b.ry` and `b.js`, in no order (`b.near` unused). The order is made
    /// only when the linear program needs it ([`order_lines`]).
    All(usize),
}

/// The `k` nearest agents within `r` of agent `i` at `pos` (itself left out), sorted by
/// `(dist_sq, id)` in `b.near` ([`Hits::Ordered`]; each entry is `dist_sq bits << 32 | p`, `p`
/// the hit's place in `b.rx`, `b.ry` (its offset from `pos`) and `b.js` (its storage index)),
/// or when fewer than `k` lie within reach of the hashed grid, all of them ([`Hits::All`]).
#[inline(always)]
pub(super) fn candidates(
    view: &SteerView,
    ctx: &Context,
    i: usize,
    pos: Vec2,
    r: f32,
    k: usize,
    b: &mut Buffers,
) -> Hits {
    let a = view.agents;
    let r_sq = r * r;
    b.near.clear();
    match ctx.source {
        Source::Hash(hash) => {
            // Agents lie in the order of a hashed grid of these cells (the world reorders them
            // every few frames), so the next agents' blocks of cells often lie within this
            // one's: its points are gathered once, for all of them. Where the query reaches no
            // farther than the neighbouring cells (wide cells), the block gathered is the
            // agent's cell and its eight neighbours, which holds the query of every agent of
            // that cell. Any block that holds the query's has the same candidates within
            // reach, so the results are the same bits.
            let cells = hash.cells(pos, r + ctx.slack);
            let holds = |[x0, x1, y0, y1]: [i32; 4]| {
                x0 <= cells[0] && cells[1] <= x1 && y0 <= cells[2] && cells[3] <= y1
            };
            if !b.block.is_some_and(holds) {
                let [cx, cy] = hash.cell_of(pos);
                let around = [
                    cx.saturating_sub(1),
                    cx.saturating_add(1),
                    cy.saturating_sub(1),
                    cy.saturating_add(1),
                ];
                let block = if holds(around) { around } else { cells };
                b.block = Some(block);
                gather_block(hash, &hash.runs_of(block), b);
            }
            // In a crowd, first within a little more than the distance of the previous
            // agent's `k`-th neighbour (its neighbourhood is this one's): when `k` agents lie
            // that close, the `k` nearest within `r` are among them, the same agents in the
            // same order, with fewer hits to choose from. Otherwise within `r`.
            let tight = (b.kth_sq * TIGHT_SQ).min(r_sq);
            let len = b.block_len;
            let blocks = len.div_ceil(LANES);
            let xs = b.block_x[..blocks * LANES].as_chunks::<LANES>().0;
            let ys = b.block_y[..blocks * LANES].as_chunks::<LANES>().0;
            let js = b.block_j[..blocks * LANES].as_chunks::<LANES>().0;
            let mut count = 0;
            for reach_sq in [tight, r_sq] {
                let mut out = Packed {
                    rx: &mut b.rx[..],
                    ry: &mut b.ry[..],
                    js: &mut b.js[..],
                    p: (pos.x, pos.y),
                    r_sq: reach_sq,
                    me: i as u32,
                };
                count = 0;
                let mut left = len;
                for ((xs, ys), js) in xs.iter().zip(ys).zip(js) {
                    let block = Block { xs, ys, js, left };
                    count = pack_lanes(&block, &mut out, count, ctx.avx2);
                    left = left.saturating_sub(LANES);
                }
                if count >= k || reach_sq >= r_sq {
                    break;
                }
            }
            if count < k {
                b.kth_sq = f32::INFINITY;
                return Hits::All(count);
            }
            push_keys(&b.rx[..count], &b.ry[..count], &mut b.near);
        }
        Source::Index => {
            view.index.neighbours_at(pos, r, &mut b.found);
            let found = b.found.iter().filter(|nb| nb.index as usize != i);
            for (p, nb) in found.enumerate() {
                let j = nb.index as usize;
                let rel = view.bounds.offset(pos, a.position(j));
                (b.rx[p], b.ry[p], b.js[p]) = (rel.x, rel.y, nb.index);
                b.near.push(near_key(nb.dist_sq, p));
            }
        }
    }
    nearest_in_order(&mut b.near, k, &b.js, &a.ids, &mut b.tied);
    b.kth_sq = if b.near.len() == k {
        f32::from_bits((b.near[k - 1] >> 32) as u32)
    } else {
        f32::INFINITY
    };
    Hits::Ordered
}

/// Puts the agent lines `lines[hard..]` of [`Hits::All`]'s `n` hits (line `hard + p` for the
/// hit at place `p`) in the order of [`Hits::Ordered`]: nearest first, ties by id.
#[inline(always)]
pub(super) fn order_lines(b: &mut Buffers, hard: usize, n: usize, k: usize, ids: &[AgentId]) {
    b.near.clear();
    push_keys(&b.rx[..n], &b.ry[..n], &mut b.near);
    nearest_in_order(&mut b.near, k, &b.js, ids, &mut b.tied);
    b.projected.clear();
    b.projected.extend(
        b.near
            .iter()
            .map(|&key| b.lines[hard + key as u32 as usize]),
    );
    b.lines.truncate(hard);
    b.lines.extend_from_slice(&b.projected);
}

/// The sort key of the hit at place `p` at squared distance `d_sq`: `d_sq bits << 32 | p`
/// (the bits of non-negative floats order as their values).
#[inline(always)]
fn near_key(d_sq: f32, p: usize) -> u64 {
    (u64::from(d_sq.to_bits()) << 32) | p as u64
}

/// Pushes the keys of the hits at offsets `(rx[p], ry[p])` onto `near`, in place order.
#[inline(always)]
fn push_keys(rx: &[f32], ry: &[f32], near: &mut Vec<u64>) {
    let hits = rx.iter().zip(ry).enumerate();
    near.extend(hits.map(|(p, (&dx, &dy))| near_key(dx * dx + dy * dy, p)));
}

/// Keeps the `k` smallest of `near` (entries `dist_sq bits << 32 | p`, the hit `p` being agent
/// `ids[js[p]]`) by `(dist_sq, id)`, in that order. The keys carry the hit's place rather than
/// its id (no load per hit): they order by distance as they are; only equal distances, rare,
/// need the ids, and are put in id order afterwards, or, where they straddle the `k`-th place,
/// chosen by id through `tied`.
#[inline(always)]
fn nearest_in_order(
    near: &mut Vec<u64>,
    k: usize,
    js: &[u32],
    ids: &[AgentId],
    tied: &mut Vec<(u64, u32)>,
) {
    const PLACE: u64 = 0xFFFF_FFFF;
    let id = |key: u64| ids[js[(key & PLACE) as usize] as usize].0;
    if near.len() > k {
        near.select_nth_unstable(k - 1);
        let kth = near[k - 1] >> 32;
        if near[k..].iter().any(|&key| key >> 32 == kth) {
            // Agents at the `k`-th distance on both sides of it: which are kept goes by id.
            tied.clear();
            tied.extend(
                near.iter()
                    .map(|&key| ((key & !PLACE) | u64::from(id(key)), key as u32)),
            );
            tied.select_nth_unstable(k - 1);
            tied.truncate(k);
            tied.sort_unstable();
            near.clear();
            near.extend(tied.iter().map(|&(key, p)| (key & !PLACE) | u64::from(p)));
            return;
        }
        near.truncate(k);
    }
    insertion_sort(near, |x, y| x > y);
    // Equal distances in id order.
    if near.windows(2).any(|w| w[0] >> 32 == w[1] >> 32) {
        insertion_sort(near, |x, y| {
            x >> 32 > y >> 32 || (x >> 32 == y >> 32 && id(x) > id(y))
        });
    }
}

/// The first search's squared radius over the previous agent's `k`-th squared distance
/// (1.25 squared).
const TIGHT_SQ: f32 = 1.5625;

/// Sorts a handful of keys in place by `after` (whether the first goes after the second), stable
/// (the library sort's call and set-up cost more than the sorting at ten entries).
#[inline(always)]
fn insertion_sort(v: &mut [u64], after: impl Fn(u64, u64) -> bool) {
    for a in 1..v.len() {
        let x = v[a];
        let mut at = a;
        while at > 0 && after(v[at - 1], x) {
            v[at] = v[at - 1];
            at -= 1;
        }
        v[at] = x;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::AgentRng;

    /// The `k` nearest by `(distance, id)` in that order, against a full sort, with many equal
    /// distances (on both sides of the `k`-th place too) and hits in any order.
    #[test]
    fn nearest_in_order_sorts_by_distance_then_id() {
        let mut rng = AgentRng::new(21, 0, 0, 0);
        let (mut near, mut tied) = (Vec::new(), Vec::new());
        let mut straddled = 0;
        for case in 0..3000 {
            let m = 1 + (rng.unit() * 24.0) as usize;
            let k = 1 + (rng.unit() * 12.0) as usize;
            // Storage indices of the hits, and the ids stored there (a permutation).
            let js: Vec<u32> = (0..m as u32).map(|p| (p * 7 + case) % m as u32).collect();
            let ids: Vec<AgentId> = (0..m as u32)
                .map(|j| AgentId((j * 13 + 5) % m as u32 + 100))
                .collect();
            let levels = 1 + (rng.unit() * 6.0) as u32;
            let dist: Vec<f32> = (0..m)
                .map(|_| (rng.unit() * levels as f32).floor())
                .collect();
            near.clear();
            near.extend((0..m).map(|p| (u64::from(dist[p].to_bits()) << 32) | p as u64));
            let mut want: Vec<(u32, u32, usize)> = (0..m)
                .map(|p| (dist[p].to_bits(), ids[js[p] as usize].0, p))
                .collect();
            want.sort_unstable();
            straddled += usize::from(m > k && want[k].0 == want[k - 1].0);
            want.truncate(k);
            nearest_in_order(&mut near, k, &js, &ids, &mut tied);
            let got: Vec<usize> = near.iter().map(|&key| key as u32 as usize).collect();
            let want: Vec<usize> = want.iter().map(|w| w.2).collect();
            assert_eq!(got, want, "case {case}");
            for &key in &near {
                assert_eq!((key >> 32) as u32, dist[key as u32 as usize].to_bits());
            }
        }
        assert!(straddled > 100, "{straddled}");
    }

    /// Refreshed positions with the returned slack find every agent within reach, as a rebuild
    /// would; the slack bounds every move; a reorder, a long move or a non-finite position
    /// rebuilds. The queries without the slack miss some agents, so the slack is needed.
    #[test]
    fn refreshed_grids_with_their_slack_find_every_agent_within_reach() {
        let mut rng = AgentRng::new(5, 0, 0, 0);
        let (side, r) = (15.0_f32, 15.0_f32);
        let mut s = OrcaScratch::default();
        let mut missed_without_slack = 0;
        for n in [3_000_usize, 40_000] {
            let extent = (n as f32).sqrt() * 6.0;
            let mut ids: Vec<AgentId> = (0..n as u32).map(AgentId).collect();
            let mut xs: Vec<f32> = (0..n).map(|_| rng.unit() * extent).collect();
            let mut ys: Vec<f32> = (0..n).map(|_| rng.unit() * extent).collect();
            assert_eq!(s.prepare_hash(&ids, (&xs, &ys), side), 0.0, "a first build");
            for round in 0..4 {
                let (x0, y0) = (xs.clone(), ys.clone());
                for k in 0..n {
                    xs[k] += (rng.unit() - 0.5) * 0.8;
                    ys[k] += (rng.unit() - 0.5) * 0.8;
                }
                let slack = s.prepare_hash(&ids, (&xs, &ys), side);
                assert!(slack > 0.0, "refreshed in round {round}");
                let farthest = (0..n)
                    .map(|k| f64::from(xs[k] - x0[k]).hypot(f64::from(ys[k] - y0[k])))
                    .fold(0.0, f64::max);
                assert!(f64::from(slack) >= farthest, "{slack} < {farthest}");
                let (x0, y0) = (&s.built_x, &s.built_y);
                assert!((0..n).all(|k| (x0[k] - xs[k]).abs() + (y0[k] - ys[k]).abs() <= slack));
                for _ in 0..1000 {
                    let p = Vec2::new(rng.unit() * extent, rng.unit() * extent);
                    let within = |k: usize| (Vec2::new(xs[k], ys[k]) - p).length_squared() <= r * r;
                    let found = |reach: f32| {
                        let mut v: Vec<usize> = Vec::new();
                        for run in s.hash.runs_of(s.hash.cells(p, reach)).iter() {
                            for at in run {
                                assert_eq!(s.hash.sorted_x()[at], xs[s.hash.order()[at] as usize]);
                                v.push(s.hash.order()[at] as usize);
                            }
                        }
                        v.retain(|&k| within(k));
                        v.sort_unstable();
                        v
                    };
                    let brute: Vec<usize> = (0..n).filter(|&k| within(k)).collect();
                    assert_eq!(found(r + slack), brute, "round {round}");
                    missed_without_slack += usize::from(found(r) != brute);
                }
            }
            // Two agents swap places in storage: rebuilt.
            ids.swap(0, 1);
            xs.swap(0, 1);
            ys.swap(0, 1);
            assert_eq!(s.prepare_hash(&ids, (&xs, &ys), side), 0.0);
            // One agent moves farther than the slack allows: rebuilt.
            xs[7] += MAX_SLACK * side * 1.01;
            assert_eq!(s.prepare_hash(&ids, (&xs, &ys), side), 0.0);
            // Another side: rebuilt.
            assert_eq!(s.prepare_hash(&ids, (&xs, &ys), 2.0 * side), 0.0);
            // A position that is not finite: rebuilt.
            xs[0] = f32::NAN;
            assert_eq!(s.prepare_hash(&ids, (&xs, &ys), 2.0 * side), 0.0);
            assert_eq!(s.prepare_hash(&ids, (&xs, &ys), 2.0 * side), 0.0);
        }
        assert!(missed_without_slack > 0, "the slack was never needed");
    }
}
