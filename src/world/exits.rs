//! Exits: rectangles through which agents leave the world (an evacuation's doors).
//!
//! After every step, agents whose centre lies inside an exit are removed, in descending storage
//! order so that the removals do not depend on anything but the positions; `StepStats::left`
//! counts them, and [`World::departures`] lists them with the position at which they left until
//! the next step (so that measurements can still see the last move of an agent that is gone).
//! Exits are part of a checkpoint; departures are not (a loaded world has none).

use glam::Vec2;
use serde::{Deserialize, Serialize};

use super::state::World;
use crate::agents::AgentId;
use crate::error::{Error, Result, finite_vec};

/// An agent that left the world through an exit, and where it stood when it left.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Departure {
    /// The agent's id (no longer live).
    pub id: AgentId,
    /// Its position at the end of the step in which it left (inside an exit).
    pub position: Vec2,
}

/// An axis-aligned rectangle through which agents leave the world.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Exit {
    /// The lower corner.
    pub min: Vec2,
    /// The upper corner (each coordinate at least `min`'s).
    pub max: Vec2,
}

impl Exit {
    /// Whether `p` lies inside (edges included).
    #[must_use]
    pub fn contains(&self, p: Vec2) -> bool {
        p.x >= self.min.x && p.x <= self.max.x && p.y >= self.min.y && p.y <= self.max.y
    }

    /// Checks the corners.
    ///
    /// # Errors
    /// [`Error::NonFinite`] for a corner that is not finite, [`Error::Invalid`] when `min`
    /// exceeds `max`.
    pub fn validate(&self) -> Result<()> {
        finite_vec("exit.min", self.min)?;
        finite_vec("exit.max", self.max)?;
        if self.min.x > self.max.x || self.min.y > self.max.y {
            return Err(Error::Invalid {
                name: "exit".into(),
                reason: "min must not exceed max".into(),
            });
        }
        Ok(())
    }
}

impl World {
    /// Adds an exit: from the next step on, agents that end a step inside it leave the world.
    ///
    /// # Errors
    /// As [`Exit::validate`].
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
        if self.exits.is_empty() {
            return 0;
        }
        // At most every agent leaves: one reservation for the run, none per frame after it.
        self.departures.reserve(self.agents.len());
        for i in (0..self.agents.len()).rev() {
            let p = self.agents.position(i);
            if self.exits.iter().any(|e| e.contains(p)) {
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
