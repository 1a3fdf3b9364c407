//! Leaving the world: [`World`]'s exits and departures, and the removal after each step of the
//! agents inside an exit or at the end of their journey (what an exit is: [`super::exits`]).
//!
//! Invariant: removals run in descending storage order, so that they depend on nothing but the
//! positions.

use super::exits::{Departure, Exit};
use super::state::World;
use crate::error::Result;

impl World {
    /// Adds an exit: from the next step on, agents that end a step inside it leave the world.
    ///
    /// # Errors
    /// As [`Exit::validate`].
    ///
    /// # Examples
    /// ```
    /// # fn main() -> throng::Result<()> {
    /// use throng::prelude::*;
    /// use throng::world::Exit;
    /// let mut world = World::builder().build()?;
    /// world.add_exit(Exit::rect(Vec2::new(9.0, 0.0), Vec2::new(10.0, 2.0)))?;
    /// world.add_exit(Exit::polygon(Walkable::from_wkt("POLYGON ((0 0, 1 0, 0 1, 0 0))")?))?;
    /// assert!(world.exits()[1].contains(Vec2::new(0.2, 0.2)));
    /// assert!(!world.exits()[1].contains(Vec2::new(0.8, 0.8)));
    /// # Ok(()) }
    /// ```
    pub fn add_exit(&mut self, exit: Exit) -> Result<()> {
        exit.validate()?;
        self.exits.push(exit);
        Ok(())
    }

    /// The exits.
    #[must_use]
    pub fn exits(&self) -> &[Exit] {
        &self.exits
    }

    /// The agents that left through an exit in the step that produced the current frame, in
    /// descending storage order, with their positions when they left (empty before the first
    /// step, after a step in which nobody left, and in a world loaded from a checkpoint).
    #[must_use]
    pub fn departures(&self) -> &[Departure] {
        &self.departures
    }

    /// Removes the agents inside an exit and lists them in the departures; returns how many
    /// left.
    pub(crate) fn leave_through_exits(&mut self) -> usize {
        self.departures.clear();
        if self.exits.is_empty() && self.journeys.is_empty() {
            return 0;
        }
        // At most every agent leaves: one reservation for the run, none per frame after it.
        self.departures.reserve(self.agents.len());
        for i in (0..self.agents.len()).rev() {
            let p = self.agents.position(i);
            let id = self.agents.id(i);
            if self.journeys.leaves(id, p) || self.exits.iter().any(|e| e.contains(p)) {
                self.departures.push(Departure {
                    id: self.agents.id(i),
                    position: p,
                });
                self.agents.swap_remove(i);
            }
        }
        self.departures.len()
    }
}
