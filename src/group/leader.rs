//! Leader following (Reynolds): offset pursuit of a slot behind the leader, and keeping out of
//! the area just in front of it.
//!
//! Separation between followers is not done here: it needs the neighbour index. Add the
//! separation behaviour to the followers' profile beside `follow_leader` (the world also calls
//! the `follower_separation` hook, which returns nothing until that exists).

use glam::Vec2;
use serde::{Deserialize, Serialize};

use super::formation::{SlotParams, slot_velocity};
use crate::error::{Result, finite_vec, non_negative, positive};
use crate::vector::Basis;

/// Parameters of leader following.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct FollowParams {
    /// The slot in the leader's local frame (x forward, y left). Default: `[-3, 0]` (behind).
    pub offset: Vec2,
    /// Followers spread over a disc of this radius around the slot, each at its own fixed place
    /// derived from its id and the seed (>= 0). Default: 0.
    pub spread: f32,
    /// Length of the keep-out area in front of the leader (>= 0). Default: 4.
    pub clear_ahead: f32,
    /// Half-width of the keep-out area (>= 0). Default: 1.5.
    pub clear_width: f32,
    /// Within this distance of the slot only its velocity is matched (>= 0). Default: 0.
    pub target_radius: f32,
    /// Within this distance the approach slows down (> 0). Default: 3.
    pub slow_radius: f32,
    /// Seconds over which the wanted velocity is reached, dynamic model (> 0). Default: 0.2.
    pub time_to_target: f32,
    /// Longest look-ahead when predicting the slot, seconds (>= 0). Default: 0.5.
    pub max_prediction: f32,
}

impl Default for FollowParams {
    fn default() -> Self {
        let s = SlotParams::default();
        FollowParams {
            offset: Vec2::new(-3.0, 0.0),
            spread: 0.0,
            clear_ahead: 4.0,
            clear_width: 1.5,
            target_radius: s.target_radius,
            slow_radius: s.slow_radius,
            time_to_target: s.time_to_target,
            max_prediction: s.max_prediction,
        }
    }
}

impl FollowParams {
    /// The slot-steering part.
    #[must_use]
    pub fn slot(&self) -> SlotParams {
        SlotParams {
            target_radius: self.target_radius,
            slow_radius: self.slow_radius,
            time_to_target: self.time_to_target,
            max_prediction: self.max_prediction,
        }
    }

    /// Checks the numbers.
    ///
    /// # Errors
    /// [`crate::Error::Negative`], [`crate::Error::NotPositive`] or [`crate::Error::NonFinite`].
    pub fn validate(&self) -> Result<()> {
        finite_vec("follow_leader.offset", self.offset)?;
        non_negative("follow_leader.spread", self.spread)?;
        non_negative("follow_leader.clear_ahead", self.clear_ahead)?;
        non_negative("follow_leader.clear_width", self.clear_width)?;
        positive("follow_leader.slow_radius", self.slow_radius)?;
        self.slot().validate()
    }
}

/// Leader following as a desired velocity.
///
/// `leader` is the leader's frame (position and heading), `leader_velocity` its velocity and
/// `slot` the follower's slot in that frame (the offset plus its spread). A follower inside the
/// keep-out rectangle in front of the leader (`0 < x < clear_ahead`, `|y| < clear_width` in the
/// leader's frame) steers sideways out of the leader's way at full speed (to the leader's left
/// when exactly on its path); otherwise it pursues its slot ([`slot_velocity`]).
#[must_use]
pub fn follow_leader(
    position: Vec2,
    leader: &Basis,
    leader_velocity: Vec2,
    slot: Vec2,
    max_speed: f32,
    p: &FollowParams,
) -> Vec2 {
    let local = leader.to_local(position);
    if local.x > 0.0 && local.x < p.clear_ahead && local.y.abs() < p.clear_width {
        let sign = if local.y >= 0.0 { 1.0 } else { -1.0 };
        return leader.side * (sign * max_speed);
    }
    slot_velocity(
        position,
        leader.to_world(slot),
        leader_velocity,
        max_speed,
        &p.slot(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_follower_in_front_gets_out_of_the_way() {
        let leader = Basis::from_orientation(Vec2::ZERO, 0.0);
        let p = FollowParams::default();
        let v = follow_leader(Vec2::new(2.0, -0.5), &leader, Vec2::X, p.offset, 3.0, &p);
        assert_eq!(v, Vec2::new(0.0, -3.0));
        // Behind the leader: head for the slot.
        let v = follow_leader(Vec2::new(-10.0, 0.0), &leader, Vec2::X, p.offset, 3.0, &p);
        assert!(v.x > 0.0 && v.y.abs() < 1e-6);
    }
}
