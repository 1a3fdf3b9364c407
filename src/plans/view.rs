//! The steering view: a read-only window on frame-t state, and what it resolves for one agent.
//!
//! [`SteerView`] borrows everything the steering pass may read (agents, profiles and their
//! plans, bounds, the neighbour index and its cell-ordered copies, nearest-agent indices,
//! obstacles, gravity points, group movement, fields) and nothing it may write. It resolves
//! targets to their nearest image and velocity and hands out an agent's fused neighbour sums.
//!
//! Invariant: everything it returns depends only on frame-t state and the agent, never on the
//! order in which agents are evaluated or on the thread that evaluates them.

use glam::Vec2;

use super::neighbours::{self, Querier, SortedCopies};
use super::plan::Plan;
use crate::agents::{AgentOrder, Agents};
use crate::bounds::Bounds;
use crate::field::FieldSet;
use crate::gravity::GravityField;
use crate::group::GroupMovement;
use crate::obstacles::Obstacles;
use crate::profile::Profile;
use crate::spatial::{CellCandidates, GridIndex, Neighbour, NeighbourIndex, SpatialIndex};
use crate::steering::{NeighbourSums, Target};
use crate::targets::TargetPoint;

thread_local! {
    /// Per-worker neighbour list of the scalar traversal, reused across agents and frames.
    pub(crate) static NEIGHBOURS: std::cell::RefCell<Vec<Neighbour>> =
        const { std::cell::RefCell::new(Vec::new()) };
}

/// A neighbour index over the agents of one group, for [`Target::Nearest`].
///
/// Its cells are about two mean spacings of the group's agents wide (never wider than the
/// largest search radius), and a search starts within one cell width and widens fourfold until
/// it finds an agent or reaches its radius: the nearest agent within a short radius is the
/// nearest within any longer one, so the answer is the one search over the whole radius would
/// give, from a few cells instead of every cell the radius covers.
#[derive(Debug, Default)]
pub(crate) struct NearestIndex {
    index: GridIndex,
    /// Agent storage index of each indexed point.
    agents: Vec<u32>,
    xs: Vec<f32>,
    ys: Vec<f32>,
    /// The first search radius (the cell width asked of the grid).
    start: f32,
    /// The agents' order `agents` indexes into.
    order: AgentOrder,
}

thread_local! {
    /// Per-worker candidates of the last cell a nearest-agent target searched.
    static CANDIDATES: std::cell::RefCell<CellCandidates> =
        std::cell::RefCell::new(CellCandidates::default());
}

/// Rebuilds, per group, the index some plan's nearest-agent target looks into (reusing the
/// buffers of the previous frame); groups nobody looks for get none.
pub(crate) fn prepare_nearest(
    plans: &[Plan],
    agents: &Agents,
    bounds: Bounds,
    within: &mut Vec<f32>,
    nearest: &mut Vec<Option<NearestIndex>>,
) {
    let groups = plans.len();
    nearest.resize_with(groups, || None);
    within.clear();
    within.resize(groups, 0.0);
    for p in plans {
        for &(g, r) in &p.nearest {
            within[g] = within[g].max(r);
        }
    }
    let mut looked_for = 0;
    for (g, &r) in within.iter().enumerate() {
        if r <= 0.0 {
            nearest[g] = None;
            continue;
        }
        looked_for += 1;
        let ni = nearest[g].get_or_insert_with(NearestIndex::default);
        ni.agents.clear();
        ni.xs.clear();
        ni.ys.clear();
    }
    if looked_for == 0 {
        return;
    }
    // One pass over the agents for every group looked for (a tiled scenario has one such group
    // per copy), each index gathering its agents in storage order.
    for i in 0..agents.len() {
        if let Some(ni) = nearest
            .get_mut(agents.group[i] as usize)
            .and_then(Option::as_mut)
        {
            ni.agents.push(i as u32);
            ni.xs.push(agents.pos_x[i]);
            ni.ys.push(agents.pos_y[i]);
        }
    }
    for (g, &r) in within.iter().enumerate() {
        if let Some(ni) = nearest[g].as_mut() {
            ni.rebuild(bounds, r);
            ni.order = agents.order();
        }
    }
}

impl NearestIndex {
    /// The agents' order the index was built for.
    pub(crate) fn order(&self) -> AgentOrder {
        self.order
    }

    /// Rebuilds the grid over the gathered points for searches up to `r`: cells of about two
    /// mean spacings of the points (in a world with a size), never wider than `r`.
    fn rebuild(&mut self, bounds: Bounds, r: f32) {
        let spacing = bounds
            .size()
            .map(|s| 2.0 * (s.x * s.y / self.xs.len().max(1) as f32).sqrt())
            .filter(|w| w.is_finite() && *w > 0.0);
        self.start = spacing.map_or(r, |w| w.min(r));
        self.index.rebuild(&self.xs, &self.ys, bounds, self.start);
    }

    /// [`NearestIndex::nearest`] answered from the candidates of `position`'s cell, which the
    /// queries of the same cell and radius that follow on this worker share: the same agent
    /// (the nearest other than `i` within `within` by `(distance², index)`, as the one search
    /// over the radius finds it), from one gathering per cell. Searches that would widen (a
    /// radius beyond the first search's) and positions the candidates cannot serve take the
    /// reference.
    fn nearest_by_cell(
        &self,
        position: Vec2,
        within: f32,
        i: usize,
        buf: &mut Vec<Neighbour>,
    ) -> Option<usize> {
        // A search no wider than the first is one search over the radius, which the cell's
        // candidates answer; a wider one widens from a few cells, cheaper per agent.
        if within > self.start {
            return self.nearest(position, within, i, buf);
        }
        CANDIDATES.with_borrow_mut(|c| {
            if !c.of_cell(&self.index, position, within, false) {
                return self.nearest(position, within, i, buf);
            }
            let mut best: Option<(f32, u32)> = None;
            c.within(&self.index, position, within, usize::MAX, |nb| {
                let (d, k) = (nb.dist_sq, nb.index);
                let closer = best.is_none_or(|(b, m)| d < b || (d == b && k < m));
                if closer && self.agents[k as usize] as usize != i {
                    best = Some((d, k));
                }
            });
            best.map(|(_, k)| self.agents[k as usize] as usize)
        })
    }

    /// The storage index of the indexed agent other than `i` nearest to `position` within
    /// `within` (ties by their order in the index), by widening searches: the first that finds
    /// such an agent has found the nearest within `within`.
    fn nearest(
        &self,
        position: Vec2,
        within: f32,
        i: usize,
        buf: &mut Vec<Neighbour>,
    ) -> Option<usize> {
        let mut r = self.start.min(within);
        loop {
            self.index.k_nearest_at(position, 2, r, None, buf);
            let found = buf
                .iter()
                .map(|nb| self.agents[nb.index as usize] as usize)
                .find(|&j| j != i);
            // Also the end when `within` is not a number.
            let wider = r < within;
            if found.is_some() || !wider {
                return found;
            }
            r = (r * 4.0).min(within);
        }
    }
}

/// Everything the steering of one agent reads: frame-t state only.
#[derive(Clone, Copy)]
pub(crate) struct SteerView<'a> {
    pub agents: &'a Agents,
    pub profiles: &'a [Profile],
    pub plans: &'a [Plan],
    pub bounds: Bounds,
    pub seed: u64,
    pub frame: u64,
    pub dt: f32,
    /// The world's time at frame t, s.
    pub time: f64,
    pub index: &'a SpatialIndex,
    /// Cell-ordered copies for the grid kernels (`None`: use the scalar traversal).
    pub sorted: Option<&'a SortedCopies>,
    pub nearest: &'a [Option<NearestIndex>],
    pub obstacles: &'a Obstacles,
    pub gravity: &'a GravityField,
    pub group_movement: &'a GroupMovement,
    pub fields: &'a FieldSet,
    /// The world's target slots.
    pub targets: &'a [TargetPoint],
    /// Pedestrian model parameters of single agents.
    pub model_params: &'a crate::ped::own::AgentModelParams,
}

/// A resolved target: its position (nearest image) and velocity.
#[derive(Clone, Copy, Debug)]
pub(crate) struct Resolved {
    pub position: Vec2,
    pub velocity: Vec2,
}

impl SteerView<'_> {
    /// Agent `i`'s target: `None` when it names no live agent other than `i`.
    pub(crate) fn resolve(&self, i: usize, target: Target, position: Vec2) -> Option<Resolved> {
        let a = self.agents;
        let (p, v) = match target {
            Target::Point(p) => (p, Vec2::ZERO),
            Target::Own => (Vec2::new(a.target_x[i], a.target_y[i]), Vec2::ZERO),
            Target::Slot(s) => {
                let t = self.targets.get(s.0 as usize)?;
                (t.position, t.velocity)
            }
            Target::Agent(id) => {
                let j = a.index_of(id)?;
                if j == i {
                    return None;
                }
                (a.position(j), a.velocity(j))
            }
            Target::Nearest { group, within } => {
                let ni = self.nearest.get(group)?.as_ref()?;
                let j = NEIGHBOURS
                    .with_borrow_mut(|buf| ni.nearest_by_cell(position, within, i, buf))?;
                (a.position(j), a.velocity(j))
            }
        };
        Some(Resolved {
            position: position + self.bounds.offset(position, p),
            velocity: v,
        })
    }

    /// The fused neighbour sums of agent `i` (all zero when its group needs no neighbours),
    /// by the per-agent grid kernel when it is ready, else by the scalar reference traversal.
    pub(crate) fn sums(&self, i: usize, velocity: Vec2, orientation: f32) -> NeighbourSums {
        let a = self.agents;
        let spec = &self.plans[a.group[i] as usize].spec;
        if !spec.active {
            return NeighbourSums::default();
        }
        let me = Querier {
            position: a.position(i),
            velocity,
            heading: velocity
                .try_normalize()
                .unwrap_or_else(|| Vec2::from_angle(orientation)),
            group: a.group[i],
        };
        let sums = match (self.index, self.sorted) {
            (SpatialIndex::Grid(grid), Some(sorted)) if spec.kernel_ok() => neighbours::sums_grid(
                grid,
                sorted,
                self.bounds,
                &me,
                spec,
                self.profiles.len() == 1,
            ),
            _ => NEIGHBOURS
                .with_borrow_mut(|buf| neighbours::sums_scalar(self.index, i, &me, spec, a, buf)),
        };
        #[cfg(feature = "oracle")]
        crate::oracle::record_sums(spec.summed("summed", (a.ids[i].0, me.position), sums));
        sums
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::rng::AgentRng;

    /// The nearest agent other than `i` within `within` by a scan of every indexed point.
    fn brute(ni: &NearestIndex, bounds: Bounds, p: Vec2, within: f32, i: usize) -> Option<usize> {
        (0..ni.xs.len())
            .filter(|&k| ni.agents[k] as usize != i)
            .map(|k| {
                let d = bounds
                    .offset(p, Vec2::new(ni.xs[k], ni.ys[k]))
                    .length_squared();
                (d, k)
            })
            .filter(|&(d, _)| d <= within * within)
            .min_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)))
            .map(|(_, k)| ni.agents[k] as usize)
    }

    #[test]
    fn the_cell_candidates_answer_what_the_searches_answer() {
        // Queries in runs along cells (as agents in the grid's order ask), at random, from
        // indexed agents and from outside the index; every rebuild moves the points, so that
        // candidates of a previous rebuild would answer wrongly.
        let mut rng = AgentRng::new(11, 0, 0, 0);
        let (mut b1, mut b2) = (Vec::new(), Vec::new());
        let mut served = 0;
        for bounds in [
            Bounds::torus(300.0, 200.0).unwrap(),
            Bounds::bounded(300.0, 200.0).unwrap(),
        ] {
            for count in [1, 2, 40, 600] {
                let mut ni = NearestIndex::default();
                for round in 0..3 {
                    ni.agents.clear();
                    ni.xs.clear();
                    ni.ys.clear();
                    for k in 0..count {
                        ni.agents.push(2 * k as u32 + round);
                        ni.xs.push(rng.unit() * 300.0);
                        ni.ys.push(rng.unit() * 200.0);
                    }
                    for within in [3.0_f32, 15.0, 60.0] {
                        ni.rebuild(bounds, within);
                        let mut p = Vec2::new(rng.unit() * 300.0, rng.unit() * 200.0);
                        for q in 0..400 {
                            p = if q % 3 == 0 {
                                Vec2::new(rng.unit() * 300.0, rng.unit() * 200.0)
                            } else {
                                bounds.wrap(p + Vec2::new(rng.unit() - 0.5, rng.unit() - 0.5))
                            };
                            let i = if q % 2 == 0 && count > 0 {
                                let k = q % count;
                                p = Vec2::new(ni.xs[k], ni.ys[k]);
                                ni.agents[k] as usize
                            } else {
                                usize::MAX
                            };
                            assert_eq!(
                                ni.nearest_by_cell(p, within, i, &mut b1),
                                ni.nearest(p, within, i, &mut b2),
                                "{bounds:?} {count} points, within {within}, at {p}"
                            );
                            // Whether the candidates, not the searches, answered.
                            let mut c = CellCandidates::default();
                            if within <= ni.start && c.of_cell(&ni.index, p, within, false) {
                                served += 1;
                            }
                        }
                    }
                }
            }
        }
        // Two of the three radii are no wider than the first search at every count.
        assert!(
            served > 8_000,
            "the candidates answered {served} of 28,800 queries"
        );
    }

    #[test]
    fn widening_searches_find_what_one_search_over_the_radius_finds() {
        let mut rng = AgentRng::new(9, 0, 0, 0);
        let mut buf = Vec::new();
        for bounds in [
            Bounds::torus(300.0, 200.0).unwrap(),
            Bounds::bounded(300.0, 200.0).unwrap(),
        ] {
            for count in [1, 2, 7, 300, 5_000] {
                let mut ni = NearestIndex::default();
                for k in 0..count {
                    // Storage indices spaced out, as a group's agents among others; some points
                    // repeated, for ties; most in one corner, so that queries elsewhere find
                    // the mean spacing too short and widen their search.
                    ni.agents.push(3 * k as u32 + 1);
                    let (x, y) = if k % 17 == 5 {
                        (ni.xs[0], ni.ys[0])
                    } else if k % 5 == 0 {
                        (rng.unit() * 300.0, rng.unit() * 200.0)
                    } else {
                        (rng.unit() * 30.0, rng.unit() * 20.0)
                    };
                    ni.xs.push(x);
                    ni.ys.push(y);
                }
                for within in [0.5_f32, 3.0, 40.0, 1_000.0] {
                    ni.rebuild(bounds, within);
                    for q in 0..200 {
                        let p = Vec2::new(rng.unit() * 300.0, rng.unit() * 200.0);
                        // Half the queries by an indexed agent, which must not find itself.
                        let i = if q % 2 == 0 {
                            ni.agents[q % count] as usize
                        } else {
                            usize::MAX
                        };
                        let p = if q % 2 == 0 {
                            Vec2::new(ni.xs[q % count], ni.ys[q % count])
                        } else {
                            p
                        };
                        assert_eq!(
                            ni.nearest(p, within, i, &mut buf),
                            brute(&ni, bounds, p, within, i),
                            "{bounds:?} {count} points, within {within}, at {p}"
                        );
                    }
                }
            }
        }
    }
}
