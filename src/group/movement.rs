//! The group-movement subsystem: shared paths, formations and their slot assignment.
//!
//! Invariants: every member of a formation is a live agent other than the anchor and belongs to
//! exactly one formation; `slot_of[id]` names the formation and local slot of agent `id` (or
//! none). Membership changes mark a formation dirty; the prepare hook [`update_formations`],
//! run by the world before the steering pass (its `formations` phase), drops removed agents and
//! re-runs the assignment of dirty formations, sequentially and in formation order, so the
//! result does not depend on the thread count. The steering itself reads only frame-t state.

use glam::Vec2;

use crate::agents::{AgentId, Agents};
use crate::bounds::Bounds;
use crate::group::{self, FormationParams, Path};
use crate::vector::Basis;

/// `slot_of` entry of an agent in no formation.
pub(crate) const NO_FORMATION: u32 = u32::MAX;

/// Paths and formations shared by many agents.
#[derive(Clone, Debug, Default)]
pub(crate) struct GroupMovement {
    pub(crate) paths: Vec<Path>,
    /// What the paths' grids of candidate segments may still cost.
    pub(crate) path_grids: crate::group::GridBudget,
    pub(crate) formations: Vec<Formation>,
    /// Indexed by agent id: (formation index or `NO_FORMATION`, local slot offset).
    pub(crate) slot_of: Vec<(u32, Vec2)>,
}

impl GroupMovement {
    /// The formation index and local slot of agent `id`, if it belongs to a formation.
    pub(crate) fn slot(&self, id: AgentId) -> Option<(usize, Vec2)> {
        match self.slot_of.get(id.0 as usize) {
            Some(&(f, s)) if f != NO_FORMATION => Some((f as usize, s)),
            _ => None,
        }
    }

    /// Records agent `id`'s formation and slot.
    pub(crate) fn set_slot(&mut self, id: AgentId, entry: (u32, Vec2)) {
        let k = id.0 as usize;
        if self.slot_of.len() <= k {
            self.slot_of.resize(k + 1, (NO_FORMATION, Vec2::ZERO));
        }
        self.slot_of[k] = entry;
    }
}

/// A formation: an anchor agent, a layout and members, each assigned one slot.
#[derive(Clone, Debug)]
pub struct Formation {
    pub(crate) anchor: AgentId,
    pub(crate) params: FormationParams,
    pub(crate) members: Vec<AgentId>,
    /// `slots[k]`: member k's slot in the anchor's frame.
    pub(crate) slots: Vec<Vec2>,
    pub(crate) dirty: bool,
}

impl Formation {
    /// The agent whose position and heading carry the formation.
    #[must_use]
    pub fn anchor(&self) -> AgentId {
        self.anchor
    }

    /// The layout.
    #[must_use]
    pub fn params(&self) -> &FormationParams {
        &self.params
    }

    /// The members, in the order they joined.
    #[must_use]
    pub fn members(&self) -> &[AgentId] {
        &self.members
    }

    /// The members' slots in the anchor's local frame, as last assigned, in the order of
    /// [`Formation::members`].
    #[must_use]
    pub fn slots(&self) -> &[Vec2] {
        &self.slots
    }

    /// Member `id`'s slot in the anchor's local frame, as last assigned.
    #[must_use]
    pub fn slot(&self, id: AgentId) -> Option<Vec2> {
        let k = self.members.iter().position(|&m| m == id)?;
        self.slots.get(k).copied()
    }
}

/// Drops removed agents from formations and reassigns the slots of formations whose
/// membership changed (or whose reassignment period has come). Sequential and in formation
/// order: deterministic.
pub(crate) fn update_formations(
    gm: &mut GroupMovement,
    agents: &Agents,
    bounds: Bounds,
    frame: u64,
) {
    update_formations_in(gm, agents, bounds, frame, 0..gm.formations.len());
}

/// [`update_formations`] for the formations of `range` only.
pub(crate) fn update_formations_in(
    gm: &mut GroupMovement,
    agents: &Agents,
    bounds: Bounds,
    frame: u64,
    range: std::ops::Range<usize>,
) {
    for f in range {
        let form = &mut gm.formations[f];
        let before = form.members.len();
        if form.members.iter().any(|&m| !agents.contains(m)) {
            let mut keep = form.members.iter().map(|&m| agents.contains(m));
            form.slots.retain(|_| keep.next().unwrap_or(false));
            form.members.retain(|&m| agents.contains(m));
        }
        let periodic =
            form.params.reassign_every > 0 && frame.is_multiple_of(form.params.reassign_every);
        if !(form.dirty || periodic || form.members.len() != before) {
            continue;
        }
        let Some(j) = agents.index_of(form.anchor) else {
            continue;
        };
        let basis = Basis::from_orientation(agents.position(j), agents.orientation[j]);
        let n = form.members.len();
        // Capacity was checked when members joined.
        let local = form.params.slots(n).unwrap_or_default();
        let world: Vec<Vec2> = local.iter().map(|&s| basis.to_world(s)).collect();
        let at: Vec<Vec2> = form
            .members
            .iter()
            .map(|&m| agents.position(agents.index_of(m).unwrap_or(j)))
            .collect();
        let assignment = if n <= group::EXACT_MAX {
            let cost = group::distance_matrix(&at, &world, |a, b| bounds.offset(a, b));
            group::assign_min_cost(&cost, n, local.len())
        } else {
            // Members as seen from the anchor (their torus images nearest to it), so that plain
            // differences are the offsets the exact method uses.
            let anchor = agents.position(j);
            let seen: Vec<Vec2> = at
                .iter()
                .map(|&p| anchor + bounds.offset(anchor, p))
                .collect();
            group::assign_slots_local(&seen, &world)
        };
        let Ok(assignment) = assignment else {
            continue;
        };
        for (k, &s) in assignment.iter().enumerate() {
            form.slots[k] = local[s];
        }
        form.dirty = false;
        let entries: Vec<(AgentId, Vec2)> = form
            .members
            .iter()
            .copied()
            .zip(form.slots.iter().copied())
            .collect();
        for (id, s) in entries {
            gm.set_slot(id, (f as u32, s));
        }
    }
}
