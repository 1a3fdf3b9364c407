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
use crate::agents::Agents;
use crate::bounds::Bounds;
use crate::field::FieldSet;
use crate::gravity::GravityField;
use crate::group::GroupMovement;
use crate::obstacles::Obstacles;
use crate::profile::Profile;
use crate::spatial::{GridIndex, Neighbour, NeighbourIndex, SpatialIndex};
use crate::steering::{NeighbourSums, Target};
use crate::targets::TargetPoint;

thread_local! {
    /// Per-worker neighbour list of the scalar traversal, reused across agents and frames.
    pub(crate) static NEIGHBOURS: std::cell::RefCell<Vec<Neighbour>> =
        const { std::cell::RefCell::new(Vec::new()) };
}

/// A neighbour index over the agents of one group, for [`Target::Nearest`].
#[derive(Debug, Default)]
pub(crate) struct NearestIndex {
    index: GridIndex,
    /// Agent storage index of each indexed point.
    agents: Vec<u32>,
    xs: Vec<f32>,
    ys: Vec<f32>,
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
    for (g, &r) in within.iter().enumerate() {
        if r <= 0.0 {
            nearest[g] = None;
            continue;
        }
        let ni = nearest[g].get_or_insert_with(NearestIndex::default);
        ni.agents.clear();
        ni.xs.clear();
        ni.ys.clear();
        for i in 0..agents.len() {
            if agents.group[i] as usize == g {
                ni.agents.push(i as u32);
                ni.xs.push(agents.pos_x[i]);
                ni.ys.push(agents.pos_y[i]);
            }
        }
        ni.index.rebuild(&ni.xs, &ni.ys, bounds, r);
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
                let j = NEIGHBOURS.with_borrow_mut(|buf| {
                    ni.index.k_nearest_at(position, 2, within, None, buf);
                    buf.iter()
                        .map(|nb| ni.agents[nb.index as usize] as usize)
                        .find(|&j| j != i)
                })?;
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
        match (self.index, self.sorted) {
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
        }
    }
}
