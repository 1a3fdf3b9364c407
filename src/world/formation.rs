//! The world's group-movement state: shared paths, formations and their slot assignment, and the
//! evaluation of the group behaviours for one agent.
//!
//! Invariants: every member of a formation is a live agent other than the anchor and belongs to
//! exactly one formation; `slot_of[id]` names the formation and local slot of agent `id` (or
//! none). Membership changes mark a formation dirty; before the steering pass of the next step
//! [`World::step`] drops removed agents and re-runs the assignment of dirty formations,
//! sequentially and in formation order, so the result does not depend on the thread count. The
//! steering itself reads only frame-t state.

use std::f32::consts::TAU;

use glam::Vec2;

use super::group::GroupParams;
use super::state::World;
use super::step::SteerCtx;
use crate::agents::AgentId;
use crate::error::{Error, Result};
use crate::group::{
    self, FormationId, FormationParams, JumpParams, JumpPhase, JumpPlan, Path, PathId,
};
use crate::movement::MovementModel;
use crate::rng::AgentRng;
use crate::steering::{Basis, Behaviour, Steering, Target};

/// Stream tag for a follower's fixed spread around its slot.
const STREAM_SPREAD: u32 = 0x6772_0001;
/// `slot_of` entry of an agent in no formation.
const NO_FORMATION: u32 = u32::MAX;

/// Paths and formations shared by many agents.
#[derive(Clone, Debug, Default)]
pub(crate) struct GroupMovement {
    pub(crate) paths: Vec<Path>,
    pub(crate) formations: Vec<Formation>,
    /// Indexed by agent id: (formation index or `NO_FORMATION`, local slot offset).
    pub(crate) slot_of: Vec<(u32, Vec2)>,
}

impl GroupMovement {
    fn slot(&self, id: AgentId) -> Option<(usize, Vec2)> {
        match self.slot_of.get(id.0 as usize) {
            Some(&(f, s)) if f != NO_FORMATION => Some((f as usize, s)),
            _ => None,
        }
    }

    fn set_slot(&mut self, id: AgentId, entry: (u32, Vec2)) {
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
    anchor: AgentId,
    params: FormationParams,
    members: Vec<AgentId>,
    /// `slots[k]`: member k's slot in the anchor's frame.
    slots: Vec<Vec2>,
    dirty: bool,
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

    /// Member `id`'s slot in the anchor's local frame, as last assigned.
    #[must_use]
    pub fn slot(&self, id: AgentId) -> Option<Vec2> {
        let k = self.members.iter().position(|&m| m == id)?;
        self.slots.get(k).copied()
    }
}

impl World {
    /// Adds a path that `FollowPath` behaviours can refer to.
    ///
    /// # Errors
    /// None today beyond the path's own validation (done by [`Path::new`]); kept fallible for
    /// bounds checks.
    pub fn add_path(&mut self, path: Path) -> Result<PathId> {
        let id = PathId(self.group_movement.paths.len() as u32);
        self.group_movement.paths.push(path);
        Ok(id)
    }

    /// The path `id`.
    #[must_use]
    pub fn path(&self, id: PathId) -> Option<&Path> {
        self.group_movement.paths.get(id.0 as usize)
    }

    /// All paths, in the order added.
    #[must_use]
    pub fn paths(&self) -> &[Path] {
        &self.group_movement.paths
    }

    /// Adds a formation carried by `anchor` with the given members; their slots are assigned at
    /// once (least total distance).
    ///
    /// # Examples
    /// ```
    /// use throng::prelude::*;
    /// use throng::group::{FormationParams, FormationShape, SlotParams};
    /// # fn main() -> throng::Result<()> {
    /// let keep = SteeringProfile::single(Behaviour::KeepFormation { params: SlotParams::default() });
    /// let mut world = World::builder()
    ///     .group(GroupParams::default())
    ///     .group(GroupParams::dynamic(keep))
    ///     .agent(AgentInit::at(Vec2::ZERO, 0))
    ///     .agents((1..4).map(|k| AgentInit::at(Vec2::new(-5.0, k as f32), 1)))
    ///     .build()?;
    /// let shape = FormationParams { shape: FormationShape::Line, ..FormationParams::default() };
    /// let f = world.add_formation(AgentId(0), shape, &[AgentId(1), AgentId(2), AgentId(3)])?;
    /// assert_eq!(world.formation(f).unwrap().members().len(), 3);
    /// # Ok(())
    /// # }
    /// ```
    ///
    /// # Errors
    /// The variant naming a bad parameter (a custom shape without slots, a spacing <= 0);
    /// [`Error::UnknownAgent`] for a dead anchor or member; [`Error::Invalid`] for a member that
    /// is the anchor, is listed twice, already belongs to a formation, or does not fit a custom
    /// shape.
    pub fn add_formation(
        &mut self,
        anchor: AgentId,
        params: FormationParams,
        members: &[AgentId],
    ) -> Result<FormationId> {
        params.validate()?;
        if !self.agents.contains(anchor) {
            return Err(Error::UnknownAgent { id: anchor });
        }
        if members.len() > params.capacity() {
            params.slots(members.len())?;
        }
        let f = self.group_movement.formations.len();
        self.group_movement.formations.push(Formation {
            anchor,
            params,
            members: Vec::with_capacity(members.len()),
            slots: Vec::new(),
            dirty: true,
        });
        for &m in members {
            if let Err(e) = self.join(f, m) {
                // Leave the world as it was.
                for &done in &self.group_movement.formations[f].members.clone() {
                    self.group_movement
                        .set_slot(done, (NO_FORMATION, Vec2::ZERO));
                }
                self.group_movement.formations.pop();
                return Err(e);
            }
        }
        self.update_formations();
        Ok(FormationId(f as u32))
    }

    fn join(&mut self, f: usize, id: AgentId) -> Result<()> {
        if !self.agents.contains(id) {
            return Err(Error::UnknownAgent { id });
        }
        let form = &self.group_movement.formations[f];
        if id == form.anchor {
            return Err(Error::Invalid {
                name: "formation.members".into(),
                reason: format!("agent {id} is the formation's anchor"),
            });
        }
        if form.members.len() >= form.params.capacity() {
            return Err(Error::Invalid {
                name: "formation.members".into(),
                reason: format!("the custom shape has only {} slots", form.params.capacity()),
            });
        }
        if self.group_movement.slot(id).is_some() {
            return Err(Error::Invalid {
                name: "formation.members".into(),
                reason: format!("agent {id} already belongs to a formation"),
            });
        }
        let form = &mut self.group_movement.formations[f];
        form.members.push(id);
        form.slots.push(Vec2::ZERO);
        form.dirty = true;
        self.group_movement.set_slot(id, (f as u32, Vec2::ZERO));
        Ok(())
    }

    fn formation_index(&self, f: FormationId) -> Result<usize> {
        let k = f.0 as usize;
        if k < self.group_movement.formations.len() {
            Ok(k)
        } else {
            Err(Error::Invalid {
                name: "formation".into(),
                reason: format!(
                    "no formation {} (the world has {})",
                    f.0,
                    self.group_movement.formations.len()
                ),
            })
        }
    }

    /// Adds a member to a formation; the formation re-forms (slots laid out for the new count and
    /// reassigned) before the next step's steering.
    ///
    /// # Errors
    /// As for [`World::add_formation`]'s members, and [`Error::Invalid`] for an unknown formation.
    pub fn add_formation_member(&mut self, f: FormationId, id: AgentId) -> Result<()> {
        let k = self.formation_index(f)?;
        self.join(k, id)
    }

    /// Removes a member from a formation (the agent stays in the world); the others re-form
    /// without a gap. Removing an agent from the world removes it from its formation too.
    ///
    /// # Errors
    /// [`Error::Invalid`] for an unknown formation or an agent that is not a member.
    pub fn remove_formation_member(&mut self, f: FormationId, id: AgentId) -> Result<()> {
        let k = self.formation_index(f)?;
        let form = &mut self.group_movement.formations[k];
        let Some(pos) = form.members.iter().position(|&m| m == id) else {
            return Err(Error::Invalid {
                name: "formation.members".into(),
                reason: format!("agent {id} is not a member of formation {}", f.0),
            });
        };
        form.members.remove(pos);
        form.slots.remove(pos);
        form.dirty = true;
        self.group_movement.set_slot(id, (NO_FORMATION, Vec2::ZERO));
        Ok(())
    }

    /// The formation `f`.
    #[must_use]
    pub fn formation(&self, f: FormationId) -> Option<&Formation> {
        self.group_movement.formations.get(f.0 as usize)
    }

    /// All formations, in the order added.
    #[must_use]
    pub fn formations(&self) -> &[Formation] {
        &self.group_movement.formations
    }

    /// Where agent `id`'s formation slot is now, in world coordinates (from the anchor's current
    /// position and orientation); `None` when it has no slot or the anchor is gone.
    #[must_use]
    pub fn slot_position(&self, id: AgentId) -> Option<Vec2> {
        let (f, local) = self.group_movement.slot(id)?;
        let j = self
            .agents
            .index_of(self.group_movement.formations[f].anchor)?;
        Some(
            Basis::from_orientation(self.agents.position(j), self.agents.orientation[j])
                .to_world(local),
        )
    }

    /// The take-off velocity agent `id` needs to jump from `launch` to `landing`, with its own
    /// maximum speed.
    ///
    /// # Errors
    /// [`Error::UnknownAgent`]; [`Error::Impossible`] when the jump is out of reach (as
    /// [`group::jump_plan`]).
    pub fn jump_plan(
        &self,
        id: AgentId,
        launch: Vec2,
        landing: Vec2,
        params: &JumpParams,
    ) -> Result<JumpPlan> {
        let i = self.agents.index_of(id).ok_or(Error::UnknownAgent { id })?;
        group::jump_plan(launch, landing, params, self.agents.max_speed[i])
    }

    /// Checks a group profile's references into the world: its paths exist and its jumps are
    /// possible at the group's maximum speed.
    pub(crate) fn check_group_refs(&self, g: &GroupParams) -> Result<()> {
        for w in &g.steering.behaviours {
            match &w.behaviour {
                Behaviour::FollowPath { path, .. } if self.path(*path).is_none() => {
                    return Err(Error::Invalid {
                        name: "follow_path.path".into(),
                        reason: format!(
                            "no path {} (the world has {})",
                            path.0,
                            self.group_movement.paths.len()
                        ),
                    });
                }
                Behaviour::Jump {
                    launch,
                    landing,
                    params,
                } => {
                    group::jump_plan(*launch, *landing, params, g.max_speed)?;
                }
                _ => {}
            }
        }
        Ok(())
    }

    /// Drops removed agents from formations and reassigns the slots of formations whose
    /// membership changed (or whose reassignment period has come). Sequential and in formation
    /// order: deterministic.
    pub(crate) fn update_formations(&mut self) {
        let frame = self.frame;
        let bounds = self.bounds;
        let gm = &mut self.group_movement;
        let agents = &self.agents;
        for f in 0..gm.formations.len() {
            let form = &mut gm.formations[f];
            let before = form.members.len();
            let mut k = 0;
            while k < form.members.len() {
                if agents.contains(form.members[k]) {
                    k += 1;
                } else {
                    form.members.remove(k);
                    form.slots.remove(k);
                }
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
            let cost = group::distance_matrix(&at, &world, |a, b| bounds.offset(a, b));
            let Ok(assignment) = group::assign_min_cost(&cost, n, local.len()) else {
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
}

impl SteerCtx<'_> {
    /// Turns a desired velocity into the model's request: itself (kinematic) or the force that
    /// reaches it in `time_to_target` seconds (dynamic).
    fn towards(
        kinematic: bool,
        g: &GroupParams,
        desired: Vec2,
        velocity: Vec2,
        time_to_target: f32,
    ) -> Steering {
        if kinematic {
            Steering::linear(desired)
        } else {
            Steering::linear((desired - velocity) * (g.mass / time_to_target))
        }
    }

    /// The frame of agent `j` as seen from `position` (nearest image on a torus), and its
    /// velocity.
    fn frame_of(&self, j: usize, position: Vec2) -> (Basis, Vec2) {
        let a = self.agents;
        let p = position + self.bounds.offset(position, a.position(j));
        (Basis::from_orientation(p, a.orientation[j]), a.velocity(j))
    }

    /// Evaluates a group-movement behaviour (`FollowPath`, `FollowLeader`, `KeepFormation`,
    /// `Jump`) for agent `i`; zero for any other behaviour.
    #[allow(clippy::too_many_arguments)]
    pub(crate) fn group_behaviour(
        &self,
        i: usize,
        b: &Behaviour,
        g: &GroupParams,
        kinematic: bool,
        position: Vec2,
        velocity: Vec2,
        max_speed: f32,
    ) -> Steering {
        let a = self.agents;
        let gm = self.group_movement;
        let id = a.ids[i];
        match b {
            Behaviour::FollowPath { path, params } => {
                let Some(path) = gm.paths.get(path.0 as usize) else {
                    return Steering::ZERO;
                };
                let desired = group::follow_path(
                    position,
                    velocity,
                    path,
                    params.direction.sign(id.0),
                    max_speed,
                    params,
                );
                Self::towards(kinematic, g, desired, velocity, params.time_to_target)
            }
            Behaviour::FollowLeader { leader, params } => {
                let Target::Agent(leader) = *leader else {
                    return Steering::ZERO;
                };
                let Some(j) = a.index_of(leader).filter(|&j| j != i) else {
                    return Steering::ZERO;
                };
                let (basis, leader_velocity) = self.frame_of(j, position);
                let mut slot = params.offset;
                if params.spread > 0.0 {
                    let mut rng = AgentRng::new(self.seed, id.0, 0, STREAM_SPREAD);
                    let r = params.spread * rng.unit().sqrt();
                    slot += Vec2::from_angle(TAU * rng.unit()) * r;
                }
                let desired = group::follow_leader(
                    position,
                    &basis,
                    leader_velocity,
                    slot,
                    max_speed,
                    params,
                );
                Self::towards(kinematic, g, desired, velocity, params.time_to_target)
            }
            Behaviour::KeepFormation { params } => {
                let anchor = gm
                    .slot(id)
                    .and_then(|(f, s)| Some((a.index_of(gm.formations[f].anchor)?, s)));
                let desired = match anchor {
                    Some((j, local)) => {
                        let (basis, anchor_velocity) = self.frame_of(j, position);
                        group::slot_velocity(
                            position,
                            basis.to_world(local),
                            anchor_velocity,
                            max_speed,
                            params,
                        )
                    }
                    // No formation or no anchor: stop.
                    None => Vec2::ZERO,
                };
                Self::towards(kinematic, g, desired, velocity, params.time_to_target)
            }
            Behaviour::Jump {
                launch,
                landing,
                params,
            } => {
                // An impossible jump (this agent's own maximum speed may be lower than the
                // group's) is not attempted.
                let Ok(plan) = group::jump_plan(*launch, *landing, params, max_speed) else {
                    return Steering::ZERO;
                };
                let acc = if g.model == MovementModel::Kinematic {
                    f32::INFINITY
                } else {
                    g.max_acceleration
                };
                match group::jump_phase(
                    position, velocity, *launch, *landing, &plan, max_speed, acc, params,
                ) {
                    JumpPhase::Approach(v) | JumpPhase::RunUp(v) => {
                        Self::towards(kinematic, g, v, velocity, params.time_to_target)
                    }
                    JumpPhase::Flight if kinematic => Steering::linear(plan.velocity),
                    JumpPhase::Flight => Steering::ZERO,
                }
            }
            _ => Steering::ZERO,
        }
    }
}
