//! The world's group-movement API: paths, formations and their members, jump plans. The
//! per-step work lives in the group-movement subsystem (`crate::group::GroupMovement`).

use glam::Vec2;

use super::Profile;
use super::state::World;
use crate::agents::AgentId;
use crate::error::{Error, Result};
use crate::group::{
    self, Formation, FormationId, FormationParams, JumpParams, JumpPlan, NO_FORMATION, Path, PathId,
};
use crate::steering::{Basis, Behaviour, Target};

impl World {
    /// Adds a path that `FollowPath` behaviours can refer to, with its grid of candidate
    /// segments built while the world's budget for them lasts (see
    /// [`GridBudget`](crate::group::GridBudget); the projections are the same either way).
    ///
    /// # Errors
    /// None today beyond the path's own validation (done by [`Path::new`]); kept fallible for
    /// bounds checks.
    pub fn add_path(&mut self, mut path: Path) -> Result<PathId> {
        let id = PathId(self.group_movement.paths.len() as u32);
        if !path.is_indexed() {
            path.index(&mut self.group_movement.path_grids);
        }
        self.group_movement.paths.push(path);
        self.plans_stale = true;
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
    ///     .group(Profile::default())
    ///     .group(Profile::dynamic(keep))
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
        // Only the new formation: the others are as they were (and checking them all would
        // make adding many formations quadratic).
        group::update_formations_in(
            &mut self.group_movement,
            &self.agents,
            self.bounds,
            self.frame,
            f..f + 1,
        );
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
            Err(Error::UnknownFormation {
                formation: f.0,
                count: self.group_movement.formations.len(),
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
    pub(crate) fn check_group_refs(&self, g: &Profile) -> Result<()> {
        for w in &g.steering.behaviours {
            if let Some(Target::Slot(slot)) = w.behaviour.target()
                && self.target_slot(slot).is_none()
            {
                return Err(Error::UnknownTarget {
                    slot: slot.0,
                    count: self.target_slots(),
                });
            }
            match &w.behaviour {
                Behaviour::FollowPath { path, .. } if self.path(*path).is_none() => {
                    return Err(Error::UnknownPath {
                        path: path.0,
                        count: self.group_movement.paths.len(),
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
}
