//! The world's API over pedestrian model parameters of single agents: an agent may walk by
//! parameters of its own (another time gap, another repulsion) within its group's model. The
//! table itself is [`crate::ped::own::AgentModelParams`].

use super::state::World;
use crate::error::{Error, Result};
use crate::id::AgentId;
use crate::ped::{ModelParams, Pedestrian};

impl World {
    /// Gives agent `id` pedestrian model parameters of its own (`None`: its group's again).
    /// They must be of its group's model; the desired speed stays per agent as it was
    /// ([`World::set_desired_speed`]). Takes effect at the next step; a checkpoint keeps them.
    ///
    /// # Examples
    /// ```
    /// use throng::prelude::*;
    /// use throng::ped::{Cfsm, ModelParams};
    ///
    /// # fn main() -> throng::Result<()> {
    /// let s = throng::scenario::builtin("corridor")?.with_agents(20)?;
    /// let mut world = s.build()?;
    /// let id = world.agents().id(0);
    /// let patient = ModelParams::Cfsm(Cfsm { time_gap: 1.2, ..Cfsm::default() });
    /// world.set_agent_model_params(id, Some(patient))?;
    /// assert_eq!(world.agent_model_params(id)?, Some(patient));
    /// # Ok(()) }
    /// ```
    ///
    /// # Errors
    /// [`Error::UnknownAgent`] for an id that names no live agent; [`Error::Invalid`] when the
    /// agent's group has no pedestrian model or another model than `params`; the variant
    /// naming the key for a bad value. Nothing changes on an error.
    pub fn set_agent_model_params(
        &mut self,
        id: AgentId,
        params: Option<ModelParams>,
    ) -> Result<()> {
        let group = self.pedestrian_of(id)?;
        if let Some(p) = &params {
            if p.model() != group.model() {
                return Err(Error::Invalid {
                    name: "model_params".into(),
                    reason: format!(
                        "agent {id} walks by the {} model, not by {}",
                        group.model().name(),
                        p.model().name()
                    ),
                });
            }
            p.validate()?;
        }
        self.model_params.set(id, params);
        Ok(())
    }

    /// The pedestrian model parameters agent `id` walks by: its own, else its group's;
    /// `None` when its group has no pedestrian model.
    ///
    /// # Errors
    /// [`Error::UnknownAgent`] for an id that names no live agent.
    pub fn agent_model_params(&self, id: AgentId) -> Result<Option<ModelParams>> {
        Ok(self
            .group_pedestrian(id)?
            .map(|group| match self.model_params.get(id) {
                Some(own) if own.model() == group.model() => *own,
                _ => group.params,
            }))
    }

    /// The pedestrian model of agent `id`'s group, an error when it has none.
    fn pedestrian_of(&self, id: AgentId) -> Result<Pedestrian> {
        self.group_pedestrian(id)?.ok_or_else(|| Error::Invalid {
            name: "model_params".into(),
            reason: format!("agent {id} walks by no pedestrian model"),
        })
    }

    /// The pedestrian model of agent `id`'s group, if it has one.
    fn group_pedestrian(&self, id: AgentId) -> Result<Option<Pedestrian>> {
        let i = self.agents.index_of(id).ok_or(Error::UnknownAgent { id })?;
        Ok(self.groups[self.agents.group[i] as usize].pedestrian)
    }
}
