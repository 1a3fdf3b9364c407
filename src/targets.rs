//! Shared, movable targets: the points a game or a script moves every frame.
//!
//! A world keeps a table of target slots. A behaviour names a slot with
//! [`Target::Slot`](crate::steering::Target::Slot); moving the slot
//! ([`World::set_target_point`](crate::World::set_target_point)) is one write, whatever the number
//! of agents that refer to it, and changes what every one of them steers towards in the next
//! step. A slot may carry a velocity, which pursuit and evasion use to predict where it will be.
//!
//! Invariants: every slot's position is finite with coordinates within
//! [`MAX_COORDINATE`](crate::error::MAX_COORDINATE), and its velocity finite with a magnitude of
//! at most [`MAX_SPEED`]; slots are never removed, so a
//! [`TargetSlot`] handed out stays valid for the world's life.

use glam::Vec2;
use serde::{Deserialize, Serialize};

use crate::error::{Error, MAX_SPEED, Result, finite_vec, in_range};

/// A handle to one of a world's target slots (its index in the order slots were added).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize, Deserialize)]
#[serde(transparent)]
pub struct TargetSlot(pub u32);

/// The state of one target slot: where it is and how it moves.
#[derive(Clone, Copy, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TargetPoint {
    /// Position in world coordinates.
    pub position: Vec2,
    /// Velocity, for the prediction of pursuit and evasion. Default: at rest.
    #[serde(default)]
    pub velocity: Vec2,
}

impl TargetPoint {
    /// A target at rest at `position`.
    #[must_use]
    pub fn at(position: Vec2) -> Self {
        TargetPoint {
            position,
            velocity: Vec2::ZERO,
        }
    }

    /// The same target moving with `velocity`.
    #[must_use]
    pub fn moving(self, velocity: Vec2) -> Self {
        TargetPoint { velocity, ..self }
    }

    /// Checks the numbers.
    ///
    /// # Errors
    /// [`Error::NonFinite`] or [`Error::OutOfRange`] for a position beyond
    /// [`MAX_COORDINATE`](crate::error::MAX_COORDINATE) or a velocity faster than [`MAX_SPEED`].
    pub fn validate(&self) -> Result<()> {
        crate::error::coordinate("target.position", self.position)?;
        let v = finite_vec("target.velocity", self.velocity)?;
        in_range(
            "target.velocity",
            v.length(),
            0.0,
            MAX_SPEED,
            "a speed of at most 1e12",
        )?;
        Ok(())
    }
}

/// A world's target slots.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct TargetSlots {
    slots: Vec<TargetPoint>,
}

impl TargetSlots {
    /// Adds a validated slot and returns its handle.
    ///
    /// # Errors
    /// As [`TargetPoint::validate`], or [`Error::Invalid`] past `u32::MAX` slots.
    pub fn add(&mut self, target: TargetPoint) -> Result<TargetSlot> {
        target.validate()?;
        let id = u32::try_from(self.slots.len()).map_err(|_| Error::Invalid {
            name: "targets".into(),
            reason: "a world holds at most 2^32 - 1 target slots".into(),
        })?;
        self.slots.push(target);
        Ok(TargetSlot(id))
    }

    /// Replaces a slot's state (validated first; on error the slot keeps its old state).
    ///
    /// # Errors
    /// [`Error::UnknownTarget`], or as [`TargetPoint::validate`].
    pub fn set(&mut self, slot: TargetSlot, target: TargetPoint) -> Result<()> {
        let count = self.slots.len();
        let s = self
            .slots
            .get_mut(slot.0 as usize)
            .ok_or(Error::UnknownTarget {
                slot: slot.0,
                count,
            })?;
        target.validate()?;
        *s = target;
        Ok(())
    }

    /// A slot's state, `None` when the world has no such slot.
    #[must_use]
    pub fn get(&self, slot: TargetSlot) -> Option<TargetPoint> {
        self.slots.get(slot.0 as usize).copied()
    }

    /// How many slots there are.
    #[must_use]
    pub fn len(&self) -> usize {
        self.slots.len()
    }

    /// Whether there are no slots.
    #[must_use]
    pub fn is_empty(&self) -> bool {
        self.slots.is_empty()
    }

    /// Every slot, by handle order.
    #[must_use]
    pub fn as_slice(&self) -> &[TargetPoint] {
        &self.slots
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bad_numbers_are_refused_and_keep_the_old_state() {
        let mut t = TargetSlots::default();
        let s = t.add(TargetPoint::at(Vec2::new(1.0, 2.0))).unwrap();
        for bad in [
            TargetPoint::at(Vec2::new(f32::NAN, 0.0)),
            TargetPoint::at(Vec2::new(0.0, f32::INFINITY)),
            TargetPoint::at(Vec2::new(1e20, 0.0)),
            TargetPoint::at(Vec2::ZERO).moving(Vec2::new(1e13, 0.0)),
            TargetPoint::at(Vec2::ZERO).moving(Vec2::new(0.0, f32::NAN)),
        ] {
            assert!(t.set(s, bad).is_err(), "{bad:?} accepted");
            assert!(t.add(bad).is_err(), "{bad:?} added");
        }
        assert_eq!(t.get(s), Some(TargetPoint::at(Vec2::new(1.0, 2.0))));
        assert_eq!(t.len(), 1);
        assert!(matches!(
            t.set(TargetSlot(1), TargetPoint::default()),
            Err(Error::UnknownTarget { slot: 1, count: 1 })
        ));
    }
}
