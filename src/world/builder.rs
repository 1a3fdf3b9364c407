use super::group::GroupParams;
use super::state::World;
use crate::agents::AgentInit;
use crate::bounds::Bounds;
use crate::error::Result;

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
        for a in self.agents {
            world.add_agent(a)?;
        }
        Ok(world)
    }
}
