//! Pedestrian model parameters of single agents: an agent may walk by parameters of its own
//! (another time gap, another repulsion) within its group's model.
//!
//! Owns [`AgentModelParams`], a side table by agent id, so that no change of the agents'
//! order touches it (ids are never reused). Invariants: every entry passed
//! [`ModelParams::validate`]; `max_cutoff` is at least the cut-off of every entry, so that
//! the neighbour index is built wide enough for every agent's own model. An entry of another
//! model than its agent's group's (the group's model was changed after it was set) is not
//! applied: the agent then walks by its group's parameters.

use super::state::World;
use crate::error::{Error, Result};
use crate::id::AgentId;
use crate::ped::{ModelParams, Pedestrian};

/// Per agent id, the agent's own pedestrian model parameters, if it has any.
#[derive(Clone, Debug, Default)]
pub(crate) struct AgentModelParams {
    by_id: Vec<Option<ModelParams>>,
    /// The largest cut-off of any entry (0 with none).
    pub(crate) max_cutoff: f32,
}

impl AgentModelParams {
    /// Agent `id`'s own parameters, if it has any.
    #[inline]
    pub(crate) fn get(&self, id: AgentId) -> Option<&ModelParams> {
        self.by_id.get(id.0 as usize).and_then(Option::as_ref)
    }

    fn set(&mut self, id: AgentId, params: Option<ModelParams>) {
        let k = id.0 as usize;
        if params.is_none() && k >= self.by_id.len() {
            return;
        }
        if k >= self.by_id.len() {
            self.by_id.resize(k + 1, None);
        }
        if let Some(p) = &params {
            self.max_cutoff = self.max_cutoff.max(p.cutoff());
        }
        self.by_id[k] = params;
    }

    /// The entries as `(id, parameters)` in ascending id order (a checkpoint's form).
    pub(crate) fn entries(&self) -> Vec<(u32, Pedestrian)> {
        self.by_id
            .iter()
            .enumerate()
            .filter_map(|(k, p)| {
                p.map(|params| {
                    (
                        k as u32,
                        Pedestrian {
                            params,
                            ..Pedestrian::default()
                        },
                    )
                })
            })
            .collect()
    }

    /// The table of `entries`, each checked, for agents with ids below `issued`.
    ///
    /// # Errors
    /// [`Error::Invalid`] naming the entry for an id never issued or bad parameters.
    pub(crate) fn from_entries(entries: Vec<(u32, Pedestrian)>, issued: usize) -> Result<Self> {
        let mut t = AgentModelParams::default();
        for (id, p) in entries {
            if id as usize >= issued {
                return Err(Error::Invalid {
                    name: "model_params".into(),
                    reason: format!("agent #{id} was never added"),
                });
            }
            p.params.validate()?;
            t.set(AgentId(id), Some(p.params));
        }
        Ok(t)
    }
}

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
        let i = self.agents.index_of(id).ok_or(Error::UnknownAgent { id })?;
        let Some(group) = self.groups[self.agents.group[i] as usize].pedestrian else {
            return Ok(None);
        };
        Ok(Some(match self.model_params.get(id) {
            Some(own) if own.model() == group.model() => *own,
            _ => group.params,
        }))
    }

    /// The pedestrian model of agent `id`'s group.
    fn pedestrian_of(&self, id: AgentId) -> Result<Pedestrian> {
        let i = self.agents.index_of(id).ok_or(Error::UnknownAgent { id })?;
        self.groups[self.agents.group[i] as usize]
            .pedestrian
            .ok_or_else(|| Error::Invalid {
                name: "model_params".into(),
                reason: format!("agent {id} walks by no pedestrian model"),
            })
    }
}

/// The model agent `id` of a group walking by `group` moves by when its own parameters
/// apply (they are of the group's model), `None` when it moves by the group's.
#[inline]
pub(crate) fn own(table: &AgentModelParams, id: AgentId, group: &Pedestrian) -> Option<Pedestrian> {
    match table.get(id) {
        Some(own) if own.model() == group.model() => Some(Pedestrian {
            params: *own,
            ..*group
        }),
        _ => None,
    }
}
