//! Angular behaviours (align, face, look where you are going) and velocity matching.

use std::f32::consts::{PI, TAU};

use glam::Vec2;
use serde::{Deserialize, Serialize};

/// Parameters of [`align`] and the behaviours built on it.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct AlignParams {
    /// Angle (radians) within which the orientation counts as reached. Default: 0.01.
    pub target_radius: f32,
    /// Angle (radians) within which the rotation slows down. Default: 0.5.
    pub slow_radius: f32,
    /// Time (seconds) over which to reach the wanted rotation. Default: 0.1.
    pub time_to_target: f32,
}

impl Default for AlignParams {
    fn default() -> Self {
        AlignParams {
            target_radius: 0.01,
            slow_radius: 0.5,
            time_to_target: 0.1,
        }
    }
}

/// Maps an angle to `(-pi, pi]`.
#[inline]
#[must_use]
pub fn wrap_angle(a: f32) -> f32 {
    let mut a = a % TAU;
    if a > PI {
        a -= TAU;
    } else if a <= -PI {
        a += TAU;
    }
    a
}

/// Dynamic align (Millington): the angular acceleration that turns `orientation` towards
/// `target_orientation`, at up to `max_rotation` and slowing inside the slow radius.
#[inline]
#[must_use]
pub fn align(
    orientation: f32,
    rotation: f32,
    target_orientation: f32,
    max_rotation: f32,
    p: &AlignParams,
) -> f32 {
    let diff = wrap_angle(target_orientation - orientation);
    let size = diff.abs();
    if size < p.target_radius {
        return -rotation / p.time_to_target;
    }
    let wanted = if size > p.slow_radius {
        max_rotation
    } else {
        max_rotation * size / p.slow_radius
    };
    (wanted * diff.signum() - rotation) / p.time_to_target
}

/// Dynamic face: align with the direction from `position` to `target`.
#[inline]
#[must_use]
pub fn face(
    position: Vec2,
    orientation: f32,
    rotation: f32,
    target: Vec2,
    max_rotation: f32,
    p: &AlignParams,
) -> f32 {
    let to = target - position;
    if to.length_squared() == 0.0 {
        return -rotation / p.time_to_target;
    }
    align(orientation, rotation, to.y.atan2(to.x), max_rotation, p)
}

/// Kinematic face: the rotation (angular velocity) that turns towards `target` within
/// `time_to_target`, clamped to `max_rotation`.
#[inline]
#[must_use]
pub fn kinematic_face(
    position: Vec2,
    orientation: f32,
    target: Vec2,
    max_rotation: f32,
    p: &AlignParams,
) -> f32 {
    let to = target - position;
    if to.length_squared() == 0.0 {
        return 0.0;
    }
    let diff = wrap_angle(to.y.atan2(to.x) - orientation);
    if diff.abs() < p.target_radius {
        return 0.0;
    }
    (diff / p.time_to_target).clamp(-max_rotation, max_rotation)
}

/// Dynamic look-where-you-are-going: align with the velocity (no request when at rest).
#[inline]
#[must_use]
pub fn look_where_you_are_going(
    velocity: Vec2,
    orientation: f32,
    rotation: f32,
    max_rotation: f32,
    p: &AlignParams,
) -> f32 {
    if velocity.length_squared() == 0.0 {
        return -rotation / p.time_to_target;
    }
    align(
        orientation,
        rotation,
        velocity.y.atan2(velocity.x),
        max_rotation,
        p,
    )
}

/// Velocity matching: the acceleration that reaches `target_velocity` in `time_to_target` seconds.
#[inline]
#[must_use]
pub fn velocity_match(velocity: Vec2, target_velocity: Vec2, time_to_target: f32) -> Vec2 {
    (target_velocity - velocity) / time_to_target
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn wrap_angle_range() {
        for a in [-10.0_f32, -PI, 0.0, PI, 3.5, 100.0] {
            let w = wrap_angle(a);
            assert!(w > -PI - 1e-6 && w <= PI + 1e-6, "{a} -> {w}");
            assert!(((a - w) / TAU - ((a - w) / TAU).round()).abs() < 1e-4);
        }
    }

    #[test]
    fn align_turns_the_short_way() {
        let p = AlignParams::default();
        assert!(
            align(0.1, 0.0, 6.0, 1.0, &p) < 0.0,
            "6.0 rad is reached clockwise from 0.1"
        );
        assert!(align(6.0, 0.0, 0.1, 1.0, &p) > 0.0);
    }
}
