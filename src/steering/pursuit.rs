//! Pursue and evade: seek or flee the target's predicted position.

use glam::Vec2;

use crate::vector::predict_position;

/// Dynamic pursue: seek the target's predicted position at full speed.
#[inline]
#[must_use]
pub fn pursue(
    position: Vec2,
    velocity: Vec2,
    target: Vec2,
    target_velocity: Vec2,
    max_speed: f32,
    max_prediction: f32,
) -> Vec2 {
    let predicted = predict_position(
        position,
        velocity.length(),
        target,
        target_velocity,
        max_prediction,
    );
    super::seek(position, velocity, predicted, max_speed, 0.0)
}

/// Dynamic evade: flee the pursuer's predicted position while the pursuer is within
/// `panic_distance` (use `f32::INFINITY` for always).
#[inline]
#[must_use]
pub fn evade(
    position: Vec2,
    velocity: Vec2,
    pursuer: Vec2,
    pursuer_velocity: Vec2,
    max_speed: f32,
    max_prediction: f32,
    panic_distance: f32,
) -> Vec2 {
    if (pursuer - position).length_squared() >= panic_distance * panic_distance {
        return Vec2::ZERO;
    }
    // Predict from the pursuer's point of view: how soon could it reach us?
    let predicted = predict_position(
        position,
        pursuer_velocity.length(),
        pursuer,
        pursuer_velocity,
        max_prediction,
    );
    let away = position - predicted;
    if away.length_squared() == 0.0 {
        // Predicted to land on us: flee the pursuer's present position instead.
        return super::flee(position, velocity, pursuer, max_speed, f32::INFINITY);
    }
    away.normalize() * max_speed - velocity
}
