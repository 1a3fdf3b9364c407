//! [`WorldBuilder`]: an empty world's bounds, seed, neighbour index and first groups, checked
//! when the world is built.

use super::Profile;
use super::state::World;
use crate::agents::{AgentId, AgentInit};
use crate::bounds::Bounds;
use crate::error::Result;
use crate::field::GoalChannels;
use crate::gravity::GravityPoint;
use crate::group::FormationParams;
use crate::obstacles::{Circle, Wall};
use crate::targets::{TargetPoint, TargetSlot};

/// The seed a builder starts with, the same as a scenario file without a `seed` key.
pub const DEFAULT_SEED: u64 = 1;

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
///     .group(Profile::dynamic(seek))
///     .agent(AgentInit::at(Vec2::new(10.0, 10.0), 0))
///     .build()?;
/// let stats = world.step(0.05)?;
/// assert_eq!(stats.agents, 1);
/// # Ok(())
/// # }
/// ```
#[derive(Clone, Debug)]
pub struct WorldBuilder {
    bounds: Bounds,
    seed: u64,
    groups: Vec<Profile>,
    agents: Vec<AgentInit>,
    paths: Vec<crate::group::Path>,
    targets: Vec<TargetPoint>,
    circles: Vec<Circle>,
    walls: Vec<Wall>,
    polygons: Vec<(Vec<glam::Vec2>, bool)>,
    fields: Vec<GoalChannels>,
    gravity: Vec<GravityPoint>,
    formations: Vec<(AgentId, FormationParams, Vec<AgentId>)>,
}

impl Default for WorldBuilder {
    fn default() -> Self {
        WorldBuilder {
            bounds: Bounds::default(),
            seed: DEFAULT_SEED,
            groups: Vec::new(),
            agents: Vec::new(),
            paths: Vec::new(),
            targets: Vec::new(),
            circles: Vec::new(),
            walls: Vec::new(),
            polygons: Vec::new(),
            fields: Vec::new(),
            gravity: Vec::new(),
            formations: Vec::new(),
        }
    }
}

impl WorldBuilder {
    /// An empty builder: open world, seed [`DEFAULT_SEED`] (as scenario files), no groups.
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
    pub fn group(mut self, params: Profile) -> Self {
        self.groups.push(params);
        self
    }

    /// Adds groups (indices in order, after the groups added before).
    #[must_use]
    pub fn groups(mut self, groups: impl IntoIterator<Item = Profile>) -> Self {
        self.groups.extend(groups);
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

    /// Adds a target slot (its [`TargetSlot`](crate::targets::TargetSlot) is the number of
    /// slots added before it), for behaviours to name with
    /// [`Target::Slot`](crate::steering::Target::Slot).
    #[must_use]
    pub fn target(mut self, target: TargetPoint) -> Self {
        self.targets.push(target);
        self
    }

    /// Adds a target slot as [`WorldBuilder::target`] does and hands back its
    /// [`TargetSlot`], for behaviours to name with
    /// [`Target::Slot`](crate::steering::Target::Slot) and for
    /// [`World::set_target_point`] to move.
    ///
    /// # Examples
    /// ```
    /// use throng::prelude::*;
    ///
    /// # fn main() -> throng::Result<()> {
    /// let (builder, player) = World::builder().target_slot(TargetPoint::at(Vec2::new(5.0, 5.0)));
    /// let chase = SteeringProfile::single(Behaviour::pursue(Target::Slot(player)));
    /// let mut world = builder.group(Profile::dynamic(chase)).build()?;
    /// world.set_target_point(player, Vec2::new(9.0, 1.0))?;
    /// # Ok(())
    /// # }
    /// ```
    #[must_use]
    pub fn target_slot(self, target: TargetPoint) -> (Self, TargetSlot) {
        // Slots are numbered in the order they are added, from 0; u32 holds any count that
        // fits in memory alongside a world.
        let slot = TargetSlot(u32::try_from(self.targets.len()).unwrap_or(u32::MAX));
        (self.target(target), slot)
    }

    /// Adds a circular obstacle (as [`World::add_circle`]: no agent may stand inside it).
    #[must_use]
    pub fn circle(mut self, circle: Circle) -> Self {
        self.circles.push(circle);
        self
    }

    /// Adds circular obstacles.
    #[must_use]
    pub fn circles(mut self, circles: impl IntoIterator<Item = Circle>) -> Self {
        self.circles.extend(circles);
        self
    }

    /// Adds a wall (as [`World::add_wall`]).
    #[must_use]
    pub fn wall(mut self, wall: Wall) -> Self {
        self.walls.push(wall);
        self
    }

    /// Adds the walls of a polyline, closed into a polygon when `closed` (as
    /// [`World::add_polygon`]).
    #[must_use]
    pub fn polygon(mut self, points: impl IntoIterator<Item = glam::Vec2>, closed: bool) -> Self {
        self.polygons.push((points.into_iter().collect(), closed));
        self
    }

    /// Adds a goal field (its index is the number of fields added before it; as
    /// [`World::add_field`]: no agent may stand inside one of its walls).
    #[must_use]
    pub fn field(mut self, channels: GoalChannels) -> Self {
        self.fields.push(channels);
        self
    }

    /// Adds a gravity point (as [`World::add_gravity_point`]; a point riding on an agent names
    /// an agent added to this builder).
    #[must_use]
    pub fn gravity_point(mut self, point: GravityPoint) -> Self {
        self.gravity.push(point);
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
    /// The variant naming the first bad parameter: bounds, a group's limits or behaviours
    /// (including a path or target slot they name that was not added), an agent (unknown
    /// group, NaN, outside the world, inside an obstacle or a field's wall: the error names
    /// the agent), an obstacle, field, gravity point or formation. A field a group names may
    /// also be added after the build ([`World::add_field`]); the first step refuses one that
    /// is still missing, where [`World::add_group`] refuses it at once.
    ///
    /// The world is the same as one built from the groups, paths, target slots and agents alone
    /// with the obstacles, fields, gravity points and formations then added in that order.
    pub fn build(self) -> Result<World> {
        self.bounds.validate()?;
        for g in &self.groups {
            g.validate()?;
        }
        let mut world = World::from_parts(self.groups, self.bounds, self.seed);
        for p in self.paths {
            world.add_path(p)?;
        }
        for t in self.targets {
            world.add_target_point(t)?;
        }
        // Fields named by behaviours are checked when the plans compile (a field may also be
        // added after the build).
        for g in &world.groups {
            world.check_group_refs(g)?;
        }
        for a in self.agents {
            world.add_agent(a)?;
        }
        world.add_circles(&self.circles)?;
        for w in self.walls {
            world.add_wall(w)?;
        }
        for (points, closed) in &self.polygons {
            world.add_polygon(points, *closed)?;
        }
        for f in self.fields {
            world.add_field(f)?;
        }
        for g in self.gravity {
            world.add_gravity_point(g)?;
        }
        for (anchor, params, members) in self.formations {
            world.add_formation(anchor, params, &members)?;
        }
        Ok(world)
    }
}

impl World {
    /// A builder for a world.
    #[must_use]
    pub fn builder() -> WorldBuilder {
        WorldBuilder::new()
    }
}
