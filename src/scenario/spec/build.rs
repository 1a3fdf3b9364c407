//! The build of a [`World`] from a scenario ([`Scenario::build`] and its variants with a
//! memory bound): validation and the memory check first, then the world's parts in a fixed
//! order (index, targets, paths, obstacles, walkable area, exits, stages and journeys, field,
//! groups), the agents (each on its group's journey),
//! gravity, formations and the field's last pass.
//!
//! Invariant: nothing is built from a scenario that does not validate or whose estimate
//! exceeds the bound, and the same scenario builds the same world, bit for bit.

use crate::error::Result;
use crate::world::World;

use super::validate::at_path;
use super::{GroupSpec, Scenario};

impl Scenario {
    /// Builds the world: groups, then agents spawned group by group from the seed. The memory
    /// estimate is checked first against the tightest bound this process runs under (the
    /// machine's available memory, `ulimit -v`, the control group's limit:
    /// [`crate::limits::memory_ceiling`]), where known.
    ///
    /// # Errors
    /// The variant naming the first bad value (a spawn region outside the world, say);
    /// [`Error::OutOfMemory`](crate::Error::OutOfMemory) when the estimate exceeds that bound, naming it.
    pub fn build(&self) -> Result<World> {
        self.build_under(crate::limits::memory_ceiling())
    }

    /// [`Scenario::build`] with the memory estimate checked against `memory` bytes (`None`:
    /// not checked).
    ///
    /// # Errors
    /// As [`Scenario::build`].
    pub fn build_within(&self, memory: Option<u64>) -> Result<World> {
        self.build_under(memory.map(crate::limits::MemoryCeiling::given))
    }

    /// [`Scenario::build`] with the memory estimate checked against `ceiling` (`None`: not
    /// checked).
    ///
    /// # Errors
    /// As [`Scenario::build`].
    pub fn build_under(&self, ceiling: Option<crate::limits::MemoryCeiling>) -> Result<World> {
        if self.layout.is_some() {
            return self.expanded()?.build_under(ceiling);
        }
        self.validate()?;
        if let Some(ceiling) = ceiling {
            crate::limits::check_memory_under(
                &format!("scenario {}", self.name),
                self.memory_estimate(),
                ceiling,
            )?;
        }
        let bounds = self.bounds()?;
        let mut world = World::builder().bounds(bounds).seed(self.seed).build()?;
        world.set_index(self.world.index);
        if let Some(k) = self.world.reorder_every {
            world.set_reorder_every(k);
        }
        for (k, t) in self.targets.iter().enumerate() {
            world
                .add_target_point(*t)
                .map_err(|e| at_path(format!("targets[{k}]"), e))?;
        }
        for p in &self.paths {
            world.add_path(p.clone())?;
        }
        self.obstacles.apply(&mut world, self.seed)?;
        if let Some(g) = &self.geometry {
            world.set_walkable(g.walkable.clone())?;
        }
        for e in &self.exits {
            world.add_exit(e.clone())?;
        }
        self.add_journeys(&mut world)?;
        // The field before the groups: a group that follows it names it when it is added.
        let field = match &self.field {
            Some(f) => Some(f.add_to(&mut world, self.seed)?),
            None => None,
        };
        for (i, g) in self.groups.iter().enumerate() {
            world
                .add_group(g.params.clone())
                .map_err(|e| at_path(format!("groups[{i}]"), e))?;
        }
        if let (Some(f), Some(id)) = (&self.field, field) {
            let counts: Vec<usize> = self.groups.iter().map(GroupSpec::count_of).collect();
            f.check_walkers(&world, id, &counts)?;
        }
        world.try_reserve_agents(self.agent_count())?;
        self.spawn_agents(&mut world, bounds)?;
        self.gravity.apply(&mut world, self.seed)?;
        if !self.formations.is_empty() {
            let by_group = crate::scenario::group::members_by_group(&world);
            for f in &self.formations {
                f.add_with(&mut world, &by_group)?;
            }
        }
        if let (Some(f), Some(id)) = (&self.field, field) {
            f.finish(&mut world, id)?;
        }
        Ok(world)
    }
}
