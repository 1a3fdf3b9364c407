//! The world's walkable area: a [`Walkable`] whose rings become walls.
//!
//! A world has at most one walkable area. Setting it adds every ring's edges to the obstacle
//! set as closed wall chains (so the hard non-penetration step keeps agents inside it and ORCA
//! sees each ring as a closed loop) and keeps the area for queries and output (its WKT is the
//! geometry of a trajectory file). It does not change the world's bounds and does not add a
//! field: a scenario's `[geometry]` does both (docs/SCENARIOS.md). The area is part of a
//! checkpoint.

use crate::error::{Error, Result};
use crate::geometry::Walkable;

use super::state::World;

impl World {
    /// Sets the walkable area: its walls are added to the obstacles (every ring a closed chain;
    /// the broad phase is rebuilt once) and agents that start a step inside the area stay in it.
    ///
    /// # Examples
    /// ```
    /// # fn main() -> throng::Result<()> {
    /// use throng::prelude::*;
    /// let mut world = World::builder().build()?;
    /// world.set_walkable(Walkable::from_wkt("POLYGON ((0 0, 10 0, 10 4, 0 4, 0 0))")?)?;
    /// assert_eq!(world.obstacles().walls().len(), 4);
    /// assert!(world.walkable().is_some_and(|a| a.contains(Vec2::new(5.0, 2.0))));
    /// # Ok(()) }
    /// ```
    ///
    /// # Errors
    /// [`Error::Invalid`] when the world has a walkable area already, or when an agent stands
    /// outside the new one.
    pub fn set_walkable(&mut self, area: Walkable) -> Result<()> {
        if self.walkable.is_some() {
            return Err(Error::Invalid {
                name: "walkable area".into(),
                reason: "the world has one already".into(),
            });
        }
        if let Some(i) = (0..self.agents.len()).find(|&i| !area.contains(self.agents.position(i))) {
            let p = self.agents.position(i);
            return Err(Error::Invalid {
                name: "walkable area".into(),
                reason: format!(
                    "agent {} stands outside it at ({}, {})",
                    self.agents.id(i),
                    p.x,
                    p.y
                ),
            });
        }
        self.obstacles.add_walls(&area.walls())?;
        self.walkable = Some(area);
        self.journeys.geometry_changed();
        Ok(())
    }

    /// The walkable area, if one was set.
    #[must_use]
    pub fn walkable(&self) -> Option<&Walkable> {
        self.walkable.as_ref()
    }
}
