//! Wander: the kinematic random-binomial form and Reynolds' wander circle.

use glam::Vec2;

use super::behaviour::WanderParams;
use crate::rng::AgentRng;

/// Kinematic wander (reference notes): move at full speed along the orientation and turn by a
/// random binomial times `max_rotation`. Returns `(velocity, rotation)`.
#[inline]
#[must_use]
pub fn kinematic_wander(
    orientation: f32,
    max_speed: f32,
    max_rotation: f32,
    rng: &mut AgentRng,
) -> (Vec2, f32) {
    let (s, c) = super::trig::sin_cos(orientation);
    (Vec2::new(c, s) * max_speed, rng.binomial() * max_rotation)
}

/// Reynolds' wander circle for the dynamic model.
///
/// A circle of `params.radius` sits `params.distance` ahead of the agent along `heading` (a unit
/// vector); the wander target sits on it at `wander_angle` (relative to the heading), which takes
/// a random step of at most `params.jitter * dt` radians each call. The force is a seek towards
/// that target at full speed. Returns `(force, new_wander_angle)`.
#[inline]
#[must_use]
pub fn wander(
    velocity: Vec2,
    heading: Vec2,
    wander_angle: f32,
    max_speed: f32,
    params: &WanderParams,
    dt: f32,
    rng: &mut AgentRng,
) -> (Vec2, f32) {
    let angle = super::wrap_angle(wander_angle + rng.binomial() * params.jitter * dt);
    let (s, c) = super::trig::sin_cos(angle);
    // The circle point in the heading frame: forward = heading, left = perp(heading).
    let side = heading.perp();
    let local = heading * (params.distance + params.radius * c) + side * (params.radius * s);
    let desired = local.normalize_or_zero() * max_speed;
    (desired - velocity, angle)
}
