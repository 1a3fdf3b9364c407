use super::GroupParams;
use super::state::World;
use crate::agents::{AgentId, AgentInit};
use crate::bounds::Bounds;
use crate::error::Result;
use crate::group::FormationParams;

/// Builds a [`World`], validating everything before the first step.
///
/// # Examples
/// ```
/// use throng::prelude::*;
///
/// # fn main() -> throng::Result<()> {
/// let seek = SteeringProfile::single(Behaviour::Seek { target: Target::Point(Vec2::new(50.0, 50.0)), threshold: 0.0 });
/// let mut world = World::builder()
///     .bounds(Bounds::bounded(100.0, 100.0)?)
///     .seed(7)
///     .group(GroupParams::dynamic(seek))
///     .agent(AgentInit::at(Vec2::new(10.0, 10.0), 0))
///     .build()?;
/// let stats = world.step(0.05)?;
/// assert_eq!(stats.agents, 1);
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug, Default)]
pub struct WorldBuilder {
    bounds: Bounds,
    seed: u64,
    groups: Vec<GroupParams>,
    agents: Vec<AgentInit>,
    paths: Vec<crate::group::Path>,
    formations: Vec<(AgentId, FormationParams, Vec<AgentId>)>,
}

impl WorldBuilder {
    /// An empty builder: open world, seed 0, no groups.
    #[must_use]
    pub fn new() -> Self {
        Self::default()
    }

    /// Sets the world's bounds.
    #[must_use]
    pub fn bounds(mut self, bounds: Bounds) -> Self {
        self.bounds = bounds;
        self
    }

    /// Sets the seed all randomness derives from.
    #[must_use]
    pub fn seed(mut self, seed: u64) -> Self {
        self.seed = seed;
        self
    }

    /// Adds a group (its index is the number of groups added before it).
    #[must_use]
    pub fn group(mut self, params: GroupParams) -> Self {
        self.groups.push(params);
        self
    }

    /// Adds an agent.
    #[must_use]
    pub fn agent(mut self, init: AgentInit) -> Self {
        self.agents.push(init);
        self
    }

    /// Adds agents.
    #[must_use]
    pub fn agents(mut self, inits: impl IntoIterator<Item = AgentInit>) -> Self {
        self.agents.extend(inits);
        self
    }

    /// Adds a path (its [`crate::group::PathId`] is the number of paths added before it).
    #[must_use]
    pub fn path(mut self, path: crate::group::Path) -> Self {
        self.paths.push(path);
        self
    }

    /// Adds a formation of agents added to this builder (ids count from 0 in the order added),
    /// as [`World::add_formation`] does after the agents.
    #[must_use]
    pub fn formation(
        mut self,
        anchor: AgentId,
        params: FormationParams,
        members: impl IntoIterator<Item = AgentId>,
    ) -> Self {
        self.formations
            .push((anchor, params, members.into_iter().collect()));
        self
    }

    /// Validates everything and builds the world.
    ///
    /// # Errors
    /// The variant naming the first bad parameter: bounds, a group's limits or behaviours, or an
    /// agent (unknown group, NaN, outside the world).
    pub fn build(self) -> Result<World> {
        self.bounds.validate()?;
        for g in &self.groups {
            g.validate()?;
        }
        let mut world = World::from_parts(self.groups, self.bounds, self.seed);
        for p in self.paths {
            world.add_path(p)?;
        }
        for g in &world.groups {
            world.check_group_refs(g)?;
        }
        for a in self.agents {
            world.add_agent(a)?;
        }
        for (anchor, params, members) in self.formations {
            world.add_formation(anchor, params, &members)?;
        }
        Ok(world)
    }
}
