//! The world's shared target slots: the API over [`crate::targets::TargetSlots`].

use glam::Vec2;

use super::state::World;
use crate::error::Result;
use crate::targets::{TargetPoint, TargetSlot};

impl World {
    /// Adds a target slot at rest at `position` and returns its handle, for behaviours to name
    /// with [`Target::Slot`](crate::steering::Target::Slot).
    ///
    /// # Examples
    /// A crowd seeks a point that a script moves every frame:
    /// ```
    /// use throng::prelude::*;
    ///
    /// # fn main() -> throng::Result<()> {
    /// let mut world = World::builder().bounds(Bounds::bounded(100.0, 100.0)?).build()?;
    /// let player = world.add_target(Vec2::new(50.0, 50.0))?;
    /// let seek = SteeringProfile::single(Behaviour::seek(Target::Slot(player)));
    /// let crowd = world.add_group(Profile::dynamic(seek))?;
    /// world.add_agent(AgentInit::at(Vec2::new(10.0, 10.0), crowd))?;
    /// for frame in 0..100 {
    ///     let t = frame as f32 * 0.05;
    ///     world.set_target_point(player, Vec2::new(50.0 + 20.0 * t.cos(), 50.0 + 20.0 * t.sin()))?;
    ///     world.step(1.0 / 30.0)?;
    /// }
    /// # Ok(())
    /// # }
    /// ```
    ///
    /// # Errors
    /// [`Error::NonFinite`](crate::Error::NonFinite) or
    /// [`Error::OutOfRange`](crate::Error::OutOfRange) for a bad position.
    pub fn add_target(&mut self, position: Vec2) -> Result<TargetSlot> {
        self.targets.add(TargetPoint::at(position))
    }

    /// Adds a target slot with its full state (position and velocity).
    ///
    /// # Errors
    /// As [`TargetPoint::validate`].
    pub fn add_target_point(&mut self, target: TargetPoint) -> Result<TargetSlot> {
        self.targets.add(target)
    }

    /// Moves a target slot (its velocity unchanged): one write, whatever the number of agents
    /// that refer to it; every behaviour naming the slot steers towards the new point from the
    /// next step on.
    ///
    /// # Errors
    /// [`Error::UnknownTarget`](crate::Error::UnknownTarget), or as [`TargetPoint::validate`];
    /// on error the slot is unchanged.
    pub fn set_target_point(&mut self, slot: TargetSlot, position: Vec2) -> Result<()> {
        let velocity = self.target_slot(slot).map_or(Vec2::ZERO, |t| t.velocity);
        self.targets.set(slot, TargetPoint { position, velocity })
    }

    /// Sets a target slot's position and velocity (the velocity feeds the prediction of
    /// pursuit and evasion).
    ///
    /// # Errors
    /// As [`World::set_target_point`].
    pub fn set_target_motion(&mut self, slot: TargetSlot, target: TargetPoint) -> Result<()> {
        self.targets.set(slot, target)
    }

    /// A target slot's state, `None` when the world has no such slot.
    #[must_use]
    pub fn target_slot(&self, slot: TargetSlot) -> Option<TargetPoint> {
        self.targets.get(slot)
    }

    /// How many target slots the world has.
    #[must_use]
    pub fn target_slots(&self) -> usize {
        self.targets.len()
    }
}
