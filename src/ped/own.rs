//! Pedestrian model parameters of single agents: the side table, by agent id, of the
//! parameters an agent walks by instead of its group's ([`crate::World::set_agent_model_params`]).
//!
//! Keyed by id, so that no change of the agents' order touches it (ids are never reused).
//! Invariants: every entry passed [`ModelParams::validate`]; `max_cutoff` is at least the
//! cut-off of every entry, so that the neighbour index is built wide enough for every agent's
//! own model. An entry of another model than its agent's group's (the group's model was
//! changed after it was set) is not applied: the agent then walks by its group's parameters.

use super::{ModelParams, Pedestrian};
use crate::error::{Error, Result};
use crate::id::AgentId;

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

    pub(crate) fn set(&mut self, id: AgentId, params: Option<ModelParams>) {
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
