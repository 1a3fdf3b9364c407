//! Scenario keys for group movement: `[[paths]]` and `[[formations]]`.
//!
//! Paths are [`crate::group::Path`]s (`points`, `radius`, `looped`), added to the world before
//! the groups so that `follow_path` behaviours can name them by index. Formations are added after
//! all agents have spawned; agents are named by id (`{ agent = N }`, ids count from 0 in spawn
//! order: group by group, in file order), members by group or by id.

use glam::Vec2;
use serde::{Deserialize, Serialize};

use crate::agents::AgentId;
use crate::error::{Error, Result};
use crate::group::{FormationId, FormationParams, FormationShape};
use crate::world::World;

/// An agent named in a scenario file: `{ agent = N }`.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct AgentRef {
    /// The agent's id (spawn order, from 0).
    pub agent: AgentId,
}

/// A formation's members: `{ group = G }` (every agent of group G) or `{ agents = [1, 2, 3] }`.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", deny_unknown_fields)]
pub enum Members {
    /// Every agent of this group (index in `[[groups]]`).
    Group(usize),
    /// These agents.
    Agents(Vec<AgentId>),
}

/// One `[[formations]]` entry.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct FormationSpec {
    /// The agent that carries the formation; it moves by its own group's behaviours.
    pub anchor: AgentRef,
    /// The members; their group should use the `keep_formation` behaviour.
    pub members: Members,
    /// `"line"`, `"column"`, `"wedge"`, `"circle"`, `"box"` or `{ custom = [[x, y], ...] }`.
    /// Default: line.
    #[serde(default)]
    pub shape: FormationShape,
    /// Distance between neighbouring slots (> 0). Default: 2.
    #[serde(default = "two")]
    pub spacing: f32,
    /// The shape's reference point in the anchor's frame (x forward, y left). Default: `[0, 0]`.
    #[serde(default)]
    pub offset: Vec2,
    /// Reassign slots every this many frames (0: only when members change). Default: 0.
    #[serde(default)]
    pub reassign_every: u64,
}

fn two() -> f32 {
    2.0
}

impl FormationSpec {
    /// The layout parameters.
    #[must_use]
    pub fn params(&self) -> FormationParams {
        FormationParams {
            shape: self.shape.clone(),
            spacing: self.spacing,
            offset: self.offset,
            reassign_every: self.reassign_every,
        }
    }

    /// Checks the layout and the member group index.
    ///
    /// # Errors
    /// The variant naming a bad parameter; [`Error::UnknownGroup`] for a member group that does
    /// not exist.
    pub fn validate(&self, groups: usize) -> Result<()> {
        self.params().validate()?;
        if let Members::Group(g) = self.members
            && g >= groups
        {
            return Err(Error::UnknownGroup {
                group: g,
                count: groups,
            });
        }
        Ok(())
    }

    /// Adds the formation to a world whose agents have spawned.
    ///
    /// # Errors
    /// As [`World::add_formation`].
    pub fn add_to(&self, world: &mut World) -> Result<FormationId> {
        let by_group = members_by_group(world);
        self.add_with(world, &by_group)
    }

    /// As [`FormationSpec::add_to`] with the agents of each group listed in `by_group` (from
    /// [`members_by_group`]), so that many formations cost one pass over the agents.
    pub(crate) fn add_with(
        &self,
        world: &mut World,
        by_group: &[Vec<AgentId>],
    ) -> Result<FormationId> {
        let members: &[AgentId] = match &self.members {
            Members::Agents(ids) => ids,
            Members::Group(g) => by_group.get(*g).map_or(&[], Vec::as_slice),
        };
        world.add_formation(self.anchor.agent, self.params(), members)
    }
}

/// The ids of each group's agents, ascending.
pub(crate) fn members_by_group(world: &World) -> Vec<Vec<AgentId>> {
    let a = world.agents();
    let mut by_group: Vec<Vec<AgentId>> = vec![Vec::new(); world.groups().len()];
    for i in 0..a.len() {
        if let Some(list) = by_group.get_mut(a.groups()[i] as usize) {
            list.push(a.id(i));
        }
    }
    for list in &mut by_group {
        list.sort_unstable();
    }
    by_group
}
