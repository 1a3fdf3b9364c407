//! Reynolds' path following: the direction an agent travels a path in, the parameters, and the
//! desired velocity towards and along the path.
//!
//! Invariant: the desired velocity depends on the agent's position and velocity, the path and
//! the parameters alone; on an open path it comes to rest on the last point of its direction.

use glam::Vec2;
use serde::{Deserialize, Serialize};

use super::Path;
use crate::error::{Result, non_negative, positive};

/// Which way along a path an agent travels.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum PathDirection {
    /// Towards increasing arc length (default).
    #[default]
    Forward,
    /// Towards decreasing arc length.
    Backward,
    /// Per agent: even agent ids forward, odd ones backward.
    Alternate,
}

impl PathDirection {
    /// `+1` or `-1` for the agent with id number `id`.
    #[must_use]
    pub fn sign(self, id: u32) -> f32 {
        match self {
            PathDirection::Forward => 1.0,
            PathDirection::Backward => -1.0,
            PathDirection::Alternate => {
                if id.is_multiple_of(2) {
                    1.0
                } else {
                    -1.0
                }
            }
        }
    }
}

/// Parameters of path following.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct PathFollowParams {
    /// Seconds ahead the future position is predicted (>= 0). Default: 0.5.
    pub predict_time: f32,
    /// Arc length ahead of the agent's projection that it seeks when outside the radius (> 0).
    /// Default: 3.
    pub lead_distance: f32,
    /// Direction of travel. Default: forward.
    pub direction: PathDirection,
    /// Seconds over which the wanted velocity is reached, dynamic model (> 0). Default: 0.25.
    pub time_to_target: f32,
}

impl Default for PathFollowParams {
    fn default() -> Self {
        PathFollowParams {
            predict_time: 0.5,
            lead_distance: 3.0,
            direction: PathDirection::Forward,
            time_to_target: 0.25,
        }
    }
}

impl PathFollowParams {
    /// Checks the numbers.
    ///
    /// # Errors
    /// [`Error::Negative`](crate::Error::Negative),
    /// [`Error::NotPositive`](crate::Error::NotPositive) or
    /// [`Error::NonFinite`](crate::Error::NonFinite).
    pub fn validate(&self) -> Result<()> {
        non_negative("follow_path.predict_time", self.predict_time)?;
        positive("follow_path.lead_distance", self.lead_distance)?;
        positive("follow_path.time_to_target", self.time_to_target)?;
        Ok(())
    }
}

/// Reynolds' path following, as a desired velocity (both movement models use it: the dynamic
/// model turns it into a force, the kinematic model sets it).
///
/// The agent predicts its position `predict_time` seconds ahead and projects it onto the path.
/// When that prediction lies outside the radius, it seeks the point `lead_distance` further along
/// the path than its own projection (in direction `sign`, +1 or -1); inside the radius it only
/// keeps travelling along the path's tangent at full speed. On an open path the agent arrives at
/// and stops on the last point in its direction of travel.
#[must_use]
pub fn follow_path(
    position: Vec2,
    velocity: Vec2,
    path: &Path,
    sign: f32,
    max_speed: f32,
    p: &PathFollowParams,
) -> Vec2 {
    let future = path.project(position + velocity * p.predict_time);
    let here = path.project(position);
    let ahead = here.arc + sign * p.lead_distance;
    if !path.is_looped() && (ahead <= 0.0 || ahead >= path.length()) {
        // Arrive at the end point (slowing over the lead distance).
        let end = path.point_at(ahead);
        let to = end - position;
        let dist = to.length();
        if dist <= 1e-3 {
            return Vec2::ZERO;
        }
        let speed = max_speed * (dist / p.lead_distance).min(1.0);
        return to * (speed / dist);
    }
    if future.distance > path.radius() {
        let target = path.point_at(ahead);
        (target - position).normalize_or_zero() * max_speed
    } else {
        path.tangent_at(future.arc) * (sign * max_speed)
    }
}

#[cfg(test)]
mod tests {
    use super::super::tests::square;
    use super::*;

    #[test]
    fn inside_the_radius_the_agent_travels_along() {
        let s = square();
        let v = follow_path(
            Vec2::new(5.0, 0.5),
            Vec2::ZERO,
            &s,
            1.0,
            2.0,
            &PathFollowParams::default(),
        );
        assert_eq!(v, Vec2::new(2.0, 0.0));
        let back = follow_path(
            Vec2::new(5.0, 0.5),
            Vec2::ZERO,
            &s,
            -1.0,
            2.0,
            &PathFollowParams::default(),
        );
        assert_eq!(back, Vec2::new(-2.0, 0.0));
        // Outside: seek a point ahead on the path.
        let out = follow_path(
            Vec2::new(5.0, -5.0),
            Vec2::ZERO,
            &s,
            1.0,
            2.0,
            &PathFollowParams::default(),
        );
        assert!(out.y > 0.0 && out.x > 0.0, "{out}");
    }
}
