//! Exits: rectangles through which agents leave the world (an evacuation's doors).
//!
//! After every step, agents whose centre lies inside an exit are removed, in descending storage
//! order so that the removals do not depend on anything but the positions; `StepStats::left`
//! counts them. Exits are part of a checkpoint.

use glam::Vec2;
use serde::{Deserialize, Serialize};

use super::state::World;
use crate::error::{Error, Result, finite_vec};

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

    /// Removes the agents inside an exit; returns how many left.
    pub(crate) fn leave_through_exits(&mut self) -> usize {
        if self.exits.is_empty() {
            return 0;
        }
        let mut left = 0;
        for i in (0..self.agents.len()).rev() {
            let p = self.agents.position(i);
            if self.exits.iter().any(|e| e.contains(p)) {
                self.agents.swap_remove(i);
                left += 1;
            }
        }
        left
    }
}
